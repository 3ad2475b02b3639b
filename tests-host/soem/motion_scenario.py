"""SOEM (pysoem 1.1.13) homes the simulated standard drive and then runs a profile-position move
over the default PDOs (6040h, 607Ah, 6060h / 6041h, 6064h, 6061h) with DC SYNC0 at 1 ms:

1. homing (6060h = 6) with method 34 (the first index pulse in the positive direction: the
   absolute encoder's single-turn zero) and home offset 607Ch = HOME_OFFSET, started by
   controlword bit 4, until the statusword shows homing attained + target reached;
2. profile position (6060h = 1 written in the PDO): an absolute set-point (bit 4) two
   revolutions past the home, acknowledged (bit 12), until target reached (bit 10).

Prints one JSON object; tests-host/tests/motion_soem.rs asserts on it."""

import json
import struct
import sys
import time

import pysoem

RECEIVE_TIMEOUT_US = 20_000
CYCLE_S = 0.001
HOMING_METHOD = 34
HOME_OFFSET = 1000
PP_TARGET = HOME_OFFSET + 2 * (1 << 20)
HM, PP = 6, 1
# SOEM's dc_sync starts SYNC0 about 100 ms after the call: each command is held longer.
HOLD = 300


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s = m.slaves[0]
    s.sdo_write(0x6060, 0, struct.pack("<b", HM))
    s.sdo_write(0x6098, 0, struct.pack("<b", HOMING_METHOD))
    s.sdo_write(0x607C, 0, struct.pack("<i", HOME_OFFSET))
    m.config_map()
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    m.config_dc()
    s.dc_sync(True, int(CYCLE_S * 1e9))
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

    def cycle(cw, target, mode):
        nonlocal next_t
        s.output = struct.pack("<HiB", cw, target, mode & 0xFF)
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        next_t += CYCLE_S
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        sw, actual, display = struct.unpack("<HiB", bytes(s.input)[:7])
        return sw, actual, display - 256 if display > 127 else display

    for cw in [0x06] * HOLD + [0x07] * HOLD + [0x0F] * HOLD:
        sw, actual, display = cycle(cw, 0, HM)
    out["enabled_statusword"] = sw
    out["homing_display"] = display
    out["homing_not_started"] = sw

    # Homing: bit 4 held until completed (or 10 s).
    homing = []
    for _ in range(10_000):
        sw, actual, _ = cycle(0x1F, 0, HM)
        homing.append([sw, actual])
        if sw & 0x3400 == 0x1400 and len(homing) > 10:
            break
    for _ in range(50):
        sw, actual, _ = cycle(0x1F, 0, HM)
    out["homing_in_progress_seen"] = any(h[0] & 0x3400 == 0 for h in homing)
    out["homing_statusword"] = sw
    out["homed_actual"] = actual
    out["homing_cycles"] = len(homing)

    # Profile position: mode 1 in the PDO, an absolute set-point.
    for _ in range(20):
        sw, actual, display = cycle(0x0F, PP_TARGET, PP)
    out["pp_display"] = display
    acknowledged = False
    for _ in range(100):
        sw, actual, _ = cycle(0x1F, PP_TARGET, PP)
        if sw & 0x1000:
            acknowledged = True
            break
    out["pp_acknowledged"] = acknowledged
    reached = []
    for _ in range(5_000):
        sw, actual, _ = cycle(0x0F, PP_TARGET, PP)
        reached.append(sw & 0x0400 != 0)
        if sw & 0x0400 and sw & 0x1000 == 0 and len(reached) > 20:
            break
    out["pp_cycles"] = len(reached)
    out["pp_moving_not_reached_seen"] = not all(reached)
    out["pp_statusword"] = sw
    out["pp_actual"] = actual
    out["pp_target"] = PP_TARGET
    out["home_offset"] = HOME_OFFSET

    m.state = pysoem.INIT_STATE
    m.write_state()
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
