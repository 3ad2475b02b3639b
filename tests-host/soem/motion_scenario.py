"""SOEM (pysoem 1.1.13) homes a simulated drive and then runs a profile-position move over the
profile's default PDOs with DC SYNC0 at 1 ms (a cycle every profile accepts):

1. homing (6060h = 6) with the profile's method from DRIVES below and home offset
   607Ch = HOME_OFFSET, started by controlword bit 4, until the statusword shows homing attained
   + target reached;
2. profile position (6060h = 1, in the PDO where the default RxPDO maps 6060h, else by SDO in
   OP): an absolute set-point (bit 4) two revolutions past the home, acknowledged (bit 12),
   until target reached (bit 10).

Usage: motion_scenario.py IFNAME DRIVES [PROFILE] (PROFILE defaults to `standard`; the
drive is the first slave, axis 1). The switches a method needs are placed by the caller with
`sim-drive attach --home-switch-rev / --limit-switches-rev` (tests-host/tests/motion_soem.rs).
Speeds and ramps are the same motion in every profile's units: homing searches at 1 rev/s and
0.5 rev/s, profile moves at 10 rev/s, 100 rev/s² (the standard profile runs on its defaults).

Prints one JSON object; tests-host/tests/motion_soem.rs asserts on it."""

import json
import struct
import sys
import time
from dataclasses import dataclass

import pysoem

RECEIVE_TIMEOUT_US = 20_000
CYCLE_S = 0.001
HOME_OFFSET = 1000
HM, PP = 6, 1
# SOEM's dc_sync starts SYNC0 about 100 ms after the call: each command is held longer.
HOLD = 300
# Increments per motor revolution of the simulated servo's encoder.
REV = 1 << 20
# The motion, in revolutions of the motor.
SEARCH, CREEP, SPEED, ACCEL = 1.0, 0.5, 10.0, 100.0
PP_REVOLUTIONS = 2
# Cycles of PP commanded before 6061h is read, and at most before the mode counts as not taken.
MODE_SETTLE_CYCLES, MODE_WAIT_CYCLES = 20, 1000


@dataclass(frozen=True)
class Drive:
    """How one profile is commanded: its homing method, position units, default PDO layout
    (byte offsets; None = not mapped) and the SDO settings written in PREOP."""

    method: int
    # 607Ah/6064h/607Ch units per motor revolution.
    units_per_rev: float
    # RxPDO: controlword, target position 607Ah, modes of operation 6060h.
    rx: tuple
    # TxPDO: statusword, position actual 6064h, modes of operation display 6061h.
    tx: tuple
    # Controlword bit 6 of an absolute PP move (0 in CiA402, 1 on the SDV3-E/OSD-G-E).
    absolute_bit6: int = 0
    setup: tuple = ()


def u32(index, sub, value):
    return (index, sub, "<I", round(value))


def motion(vel, acc, homing_acc=True):
    """The SDO writes of the common motion; `vel`/`acc` convert rev/s and rev/s² to the
    profile's objects."""
    writes = [
        u32(0x6099, 1, vel(SEARCH)),
        u32(0x6099, 2, vel(CREEP)),
        u32(0x6081, 0, vel(SPEED)),
        u32(0x6083, 0, acc(ACCEL)),
        u32(0x6084, 0, acc(ACCEL)),
    ]
    if homing_acc:
        writes.append(u32(0x609A, 0, acc(ACCEL)))
    return tuple(writes)


def sdv3_e(method):
    # §7.11: 6093h = 16/1 increments per position unit; 6081h/6099h in 0.1 rpm; §7.4 6083h/6084h
    # the time in ms from 0 to 2000 rpm (no 609Ah); §7.4 bit 6 = 1 is ABSOLUTE.
    return Drive(
        method=method,
        units_per_rev=REV / 16,
        rx=(0, 2, 12),
        tx=(0, 2, 12),
        absolute_bit6=1,
        setup=motion(lambda v: v * 600, lambda a: 2000 / 60 / a * 1000, homing_acc=False),
    )


def command_units(units_per_rev, *extra):
    # RSE 7.6 / GHA-E §5: 6091h gear ratio; velocities in command units/s, accelerations in
    # command units/s²; 607Fh (default below 10 rev/s) raised to 20 rev/s.
    return motion(lambda v: v * units_per_rev, lambda a: a * units_per_rev) + (
        u32(0x607F, 0, 2 * SPEED * units_per_rev),
    ) + extra


def sigma_v_sd(method):
    # §6.7: 2301h/2302h 1/1 (1 inc per unit, 1 inc/s), 2303h 1/1 × 10^4 inc/s². A Python master
    # is not real time: SYNC0 events without new outputs are routine here, so the sync error
    # supervision that counts them is switched off (10F1h:02 = 0, ETG.1020).
    return Drive(
        method=method,
        units_per_rev=REV,
        rx=(0, 2, None),
        tx=(0, 2, None),
        setup=(u32(0x10F1, 2, 0),) + motion(lambda v: v * REV, lambda a: a * REV / 1e4),
    )


# GHA-E 6091h default 131072/10000: 10000 command units per 131072 increments.
GHA_E_UNITS_PER_REV = REV * 10_000 / 131_072

DRIVES = {
    # Method 34: the first index pulse in the positive direction; the defaults' speeds.
    "standard": Drive(method=34, units_per_rev=REV, rx=(0, 2, 6), tx=(0, 2, 6)),
    # Method 20: the home switch's rising edge approached moving positive; no 609Ah: the drive
    # homes on its profile acceleration 6083h.
    "sdv3-e": sdv3_e(20),
    "osd-g-e": sdv3_e(20),
    # Method 20: the home switch's rising edge approached moving positive (no index methods).
    # RxPDO 6040h, 607Ah, 60B8h; TxPDO 603Fh, 6041h, 6061h, 6064h, ...
    "rse": Drive(
        method=20,
        units_per_rev=REV,
        rx=(0, 2, None),
        tx=(2, 5, 4),
        setup=command_units(REV),
    ),
    # Method 3: the home switch, then the first index pulse left of its edge. 6067h defaults to
    # 0 (exact): a window of 100 command units (about 1300 increments).
    "gha-e": Drive(
        method=3,
        units_per_rev=GHA_E_UNITS_PER_REV,
        rx=(0, 2, 6),
        tx=(0, 2, None),
        setup=command_units(GHA_E_UNITS_PER_REV, u32(0x6067, 0, 100)),
    ),
    # Method 1: the negative limit switch, then the first index pulse right of it.
    "sigma-v-sd": sigma_v_sd(1),
    # Axis 1 (the first 16/20 bytes of the process image), method 34; axis 2 stays off.
    "sigma-v-sd-2axis": sigma_v_sd(34),
}


def main():
    ifname = sys.argv[1]
    profile = sys.argv[3] if len(sys.argv) > 3 and sys.argv[3] else "standard"
    if profile not in DRIVES:
        known = ", ".join(DRIVES)
        sys.exit(f"motion_scenario.py: no scenario for profile {profile!r} (known: {known})")
    drive = DRIVES[profile]
    pp_target = HOME_OFFSET + round(PP_REVOLUTIONS * drive.units_per_rev)
    out = {"profile": profile, "method": drive.method}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s = m.slaves[0]
    s.sdo_write(0x6060, 0, struct.pack("<b", HM))
    s.sdo_write(0x6098, 0, struct.pack("<b", drive.method))
    s.sdo_write(0x607C, 0, struct.pack("<i", HOME_OFFSET))
    for index, sub, fmt, value in drive.setup:
        s.sdo_write(index, sub, struct.pack(fmt, value))
    # DC before config_map: SOEM's config_map requests SAFE-OP at its end, and the GHA-E runs in
    # DC SYNC0 only.
    m.config_dc()
    s.dc_sync(True, int(CYCLE_S * 1e9))
    m.config_map()
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    m.state = pysoem.OP_STATE
    m.write_state()
    for _ in range(2000):
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        if m.state_check(pysoem.OP_STATE, 1000) == pysoem.OP_STATE:
            break
        time.sleep(CYCLE_S)
    out["op"] = m.read_state()

    next_t = time.monotonic()
    outputs = bytearray(len(bytes(s.output)))
    rx_cw, rx_target, rx_mode = drive.rx
    tx_sw, tx_actual, tx_display = drive.tx

    def cycle(cw, target, mode):
        nonlocal next_t
        struct.pack_into("<Hi", outputs, rx_cw, cw, target)
        if rx_mode is not None:
            struct.pack_into("<b", outputs, rx_mode, mode)
        s.output = bytes(outputs)
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        next_t += CYCLE_S
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        inputs = bytes(s.input)
        (sw,) = struct.unpack_from("<H", inputs, tx_sw)
        (actual,) = struct.unpack_from("<i", inputs, tx_actual)
        return sw, actual

    def display():
        """6061h: from the TxPDO where mapped, else by SDO."""
        if tx_display is not None:
            return struct.unpack_from("<b", bytes(s.input), tx_display)[0]
        return struct.unpack("<b", s.sdo_read(0x6061, 0)[:1])[0]

    for cw in [0x06] * HOLD + [0x07] * HOLD + [0x0F] * HOLD:
        sw, actual = cycle(cw, 0, HM)
    out["enabled_statusword"] = sw
    out["homing_display"] = display()
    out["homing_not_started"] = sw

    # Homing: bit 4 held until completed (or 10 s).
    homing = []
    for _ in range(10_000):
        sw, actual = cycle(0x1F, 0, HM)
        homing.append([sw, actual])
        if sw & 0x3400 == 0x1400 and len(homing) > 10:
            break
    for _ in range(50):
        sw, actual = cycle(0x1F, 0, HM)
    out["homing_in_progress_seen"] = any(h[0] & 0x3400 == 0 for h in homing)
    out["homing_statusword"] = sw
    out["homed_actual"] = actual
    out["homing_cycles"] = len(homing)
    out["homing_trace"] = changes(homing)

    # Profile position: mode 1 (in the PDO, or by SDO), an absolute set-point.
    if rx_mode is None:
        s.sdo_write(0x6060, 0, struct.pack("<b", PP))
    pp_cw = 0x0F | drive.absolute_bit6 << 6
    # The drive takes the mode in the cycle it sees it; a master that is not real time (this one,
    # on a loaded machine) may need more cycles for the round trip: wait for 6061h, up to 1 s.
    for k in range(MODE_WAIT_CYCLES):
        sw, actual = cycle(pp_cw, pp_target, PP)
        if k >= MODE_SETTLE_CYCLES and display() == PP:
            break
    out["pp_display"] = display()
    out["pp_controlword"] = pp_cw | 0x10
    acknowledged = False
    for _ in range(100):
        sw, actual = cycle(pp_cw | 0x10, pp_target, PP)
        if sw & 0x1000:
            acknowledged = True
            break
    out["pp_acknowledged"] = acknowledged
    reached = []
    moving = []
    for _ in range(5_000):
        sw, actual = cycle(pp_cw, pp_target, PP)
        reached.append(sw & 0x0400 != 0)
        moving.append([sw, actual])
        if sw & 0x0400 and sw & 0x1000 == 0 and len(reached) > 20:
            break
    out["pp_cycles"] = len(reached)
    out["pp_moving_not_reached_seen"] = not all(reached)
    out["pp_statusword"] = sw
    out["pp_actual"] = actual
    out["pp_target"] = pp_target
    out["pp_trace"] = changes(moving)
    out["home_offset"] = HOME_OFFSET
    out["position_window"] = struct.unpack("<I", s.sdo_read(0x6067, 0)[:4])[0]

    m.state = pysoem.INIT_STATE
    m.write_state()
    m.close()
    print(json.dumps(out))


def changes(samples):
    """[cycle, statusword, 6064h] at every statusword change (for the failure messages)."""
    return [
        [k, sw, actual]
        for k, (sw, actual) in enumerate(samples)
        if k == 0 or sw != samples[k - 1][0]
    ]


if __name__ == "__main__":
    main()
