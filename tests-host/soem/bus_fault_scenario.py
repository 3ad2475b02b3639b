"""SOEM (pysoem 1.1.13) against `sim-drive attach --lose-every 10 --pull-cable-at-ms T
--pull-cable-for-ms D --halt-mcu-at-ms H --halt-mcu-for-ms E`: the drive in OP (free run, 1 ms)
while every 10th cyclic frame is lost on the cable, then the cable pulled for D ms and plugged
again, then the master's recovery; then the drive's MCU stopped for E ms and restarted, and the
master's start-up run again; then the master's interface taken down for 0.5 s. Prints what SOEM saw as one JSON object; the Rust test asserts on
it."""

import json
import struct
import subprocess
import sys
import time

import pysoem

CYCLE_S = 0.001
# A lost frame must show as lost within the cycle.
RECEIVE_TIMEOUT_US = 2_000
# Consecutive cycles without a reply that mean the cable is out (lost frames come one in ten).
PULLED_AFTER = 20
MAX_CYCLES = 20_000
AL_CONTROL, AL_STATUS, AL_STATUS_CODE = 0x0120, 0x0130, 0x0134
DL_STATUS, WATCHDOG_COUNTER_PDI = 0x0110, 0x0443
PDI_WATCHDOG_OK = 0x0002
ACK = 0x10
STATE_MASK = 0x0F
# How long to wait for the MCU halt and its restart after the recovery.
HALT_WATCH_S = 15.0
# How long the master's interface is down (longer than the process-data watchdog, 100 ms).
INTERFACE_DOWN_S = 0.5


# Register reads wait this long for their frame (pysoem's default is 2 ms): the simulated drive
# runs in wall-clock time, and on a loaded machine a reply can take longer than a cycle.
REGISTER_TIMEOUT_US = 50_000


def fprd(s, address, size):
    return s._fprd(address, size, REGISTER_TIMEOUT_US)


def fpwr(s, address, data):
    return s._fpwr(address, data, REGISTER_TIMEOUT_US)


def al(s):
    return (
        struct.unpack("<H", fprd(s, AL_STATUS, 2))[0],
        struct.unpack("<H", fprd(s, AL_STATUS_CODE, 2))[0],
    )


def al_once_answering(s, timeout_s=2.0):
    """`al(s)` as soon as the slave answers register reads (None if it does not in time)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            return al(s)
        except Exception:  # pysoem raises on a read without a reply
            time.sleep(0.01)
    return None


def to_op(m):
    m.state = pysoem.OP_STATE
    m.write_state()
    for _ in range(3000):
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        if m.state_check(pysoem.OP_STATE, 1000) == pysoem.OP_STATE:
            return True
        time.sleep(CYCLE_S)
    return False


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s0 = m.slaves[0]
    out["iomap_size"] = m.config_map()
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    out["op"] = to_op(m)
    expected = m.expected_wkc
    out["expected_wkc"] = expected

    cycles = errors = misses = 0
    states_while_losing = set()
    pulled_at = None
    while cycles < MAX_CYCLES:
        for s in m.slaves:
            s.output = bytes(len(s.output))
        m.send_processdata()
        wkc = m.receive_processdata(RECEIVE_TIMEOUT_US)
        cycles += 1
        if wkc == expected:
            if pulled_at is not None:
                break
            misses = 0
        else:
            misses += 1
            if pulled_at is None:
                errors += 1
            if misses == PULLED_AFTER and pulled_at is None:
                pulled_at = cycles
        if pulled_at is None and cycles % 500 == 0:
            # The cable may be out already, before PULLED_AFTER missed cycles tell: no reply.
            try:
                states_while_losing.add(al(s0))
            except pysoem.WkcError:
                pass
        time.sleep(CYCLE_S)
    out["cycles_before_pull"] = (pulled_at or cycles) - PULLED_AFTER
    out["wkc_errors_before_pull"] = errors - PULLED_AFTER + 1 if pulled_at else errors
    out["states_while_losing"] = sorted(states_while_losing)
    out["cable_pulled_seen"] = pulled_at is not None
    # Replies came back: the cable is in again. The mailbox and register frames pass.
    out["after_pull"] = al(s0)
    fpwr(s0, AL_CONTROL, struct.pack("<H", pysoem.SAFEOP_STATE | ACK))
    time.sleep(0.05)
    out["after_ack"] = al(s0)
    out["recovered"] = to_op(m)
    out["final"] = al(s0)

    # The MCU stops (attach's --halt-mcu-at-ms) and restarts: the master cycles on and watches
    # the PDI watchdog in DL status, then the AL status.
    pdi_expired_seen = False
    deadline = time.monotonic() + HALT_WATCH_S
    while time.monotonic() < deadline:
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        dl = struct.unpack("<H", fprd(s0, DL_STATUS, 2))[0]
        if not dl & PDI_WATCHDOG_OK and not pdi_expired_seen:
            pdi_expired_seen = True
            out["al_while_halted"] = al(s0)
            out["pdi_expiries"] = fprd(s0, WATCHDOG_COUNTER_PDI, 1)[0]
        if pdi_expired_seen and al(s0)[0] & STATE_MASK == pysoem.INIT_STATE:
            out["after_restart"] = al(s0)
            break
        time.sleep(CYCLE_S)
    out["pdi_expired_seen"] = pdi_expired_seen
    # The master's start-up again (SOEM's init acknowledges the error).
    out["slave_count_again"] = m.config_init()
    m.config_map()
    m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    out["op_again"] = to_op(m)
    out["final_again"] = al(s0)

    # The master's interface goes down for half a second (its cable pulled at the master's
    # end): the simulator's end loses its carrier, which `attach` takes for a pulled cable.
    subprocess.run(["ip", "link", "set", ifname, "down"], check=True)
    time.sleep(INTERFACE_DOWN_S)
    subprocess.run(["ip", "link", "set", ifname, "up"], check=True)
    # (/sys shows the parent namespace's interfaces: ask `ip` for the carrier, LOWER_UP.)
    for _ in range(200):
        link = subprocess.run(
            ["ip", "-o", "link", "show", ifname], capture_output=True, text=True
        ).stdout
        if "LOWER_UP" in link:
            break
        time.sleep(0.01)
    # `attach` polls the interface's flags: the drive answers again once it saw the link back.
    out["after_interface_down"] = al_once_answering(s0)
    fpwr(s0, AL_CONTROL, struct.pack("<H", pysoem.SAFEOP_STATE | ACK))
    time.sleep(0.05)
    out["op_after_interface_down"] = to_op(m)
    out["final_after_interface_down"] = al(s0)
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
