"""SOEM (pysoem 1.1.13) against the simulated drive(s): discovery, SDO, PDO mapping, DC, OP,
cyclic process data, refused requests, back to INIT. Prints one JSON object with what SOEM saw;
the Rust test asserts on it against the profile and the specifications."""

import json
import struct
import sys
import time

import pysoem

# SOEM's receive timeout for process data: generous, so that a busy host (CI) is not mistaken
# for a lost frame; the simulated drive answers within microseconds.
RECEIVE_TIMEOUT_US = 20_000

CYCLE_S = 0.001
CYCLES = 1000
# SOEM's dc_sync starts SYNC0 about 100 ms after the call (SyncDelay in ecx_dcsync0), so each
# controlword command is held for longer than that before the next one.
SHUTDOWN_UNTIL = 300
SWITCH_ON_UNTIL = 600


def sdo_u32(slave, index, sub):
    return struct.unpack("<I", slave.sdo_read(index, sub)[:4])[0]


def main():
    ifname, drives = sys.argv[1], int(sys.argv[2])
    out = {"events": []}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    out["slaves"] = [
        {"name": s.name, "man": s.man, "id": s.id, "rev": s.rev} for s in m.slaves
    ]
    s0 = m.slaves[0]
    out["sdo_identity"] = [sdo_u32(s0, 0x1018, sub) for sub in (1, 2, 3, 4)]
    out["sdo_device_name"] = s0.sdo_read(0x1008, 0).decode("ascii", "replace")
    try:
        s0.sdo_read(0x2FFF, 0)
        out["missing_object_abort"] = None
    except pysoem.SdoError as e:
        out["missing_object_abort"] = e.abort_code

    out["iomap_size"] = m.config_map()
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    out["dc"] = m.config_dc()
    for s in m.slaves:
        s.dc_sync(True, int(CYCLE_S * 1e9))
    out["expected_wkc"] = m.expected_wkc

    m.state = pysoem.OP_STATE
    m.write_state()
    for _ in range(2000):
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        if m.state_check(pysoem.OP_STATE, 1000) == pysoem.OP_STATE:
            break
        time.sleep(CYCLE_S)
    out["op"] = m.read_state()
    out["op_states"] = [s.state for s in m.slaves]

    samples = []
    next_t = time.monotonic()
    for i in range(CYCLES):
        cw = 0x0006 if i < SHUTDOWN_UNTIL else (0x0007 if i < SWITCH_ON_UNTIL else 0x000F)
        target = i * 100
        for s in m.slaves:
            s.output = struct.pack("<HiB", cw, target, 8)
        m.send_processdata()
        wkc = m.receive_processdata(RECEIVE_TIMEOUT_US)
        sw, actual, mode = struct.unpack("<HiB", bytes(s0.input)[:7])
        samples.append([wkc, cw, target, sw, actual, mode])
        next_t += CYCLE_S
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    out["samples"] = samples
    out["phases"] = [SHUTDOWN_UNTIL, SWITCH_ON_UNTIL]

    m.state = pysoem.INIT_STATE
    m.write_state()
    out["init"] = m.state_check(pysoem.INIT_STATE, 2_000_000)

    # A refused request: SAFE-OP with a wrong SM2 length must give AL status code 0x001D and the
    # error flag. Go to PRE-OP (mailbox SMs from the SII), set up SM2 with one byte too many.
    m.state = pysoem.PREOP_STATE
    m.write_state()
    out["preop_again"] = m.state_check(pysoem.PREOP_STATE, 2_000_000)
    sm2 = bytearray(s0._fprd(0x0810, 8))
    sm2_len = struct.unpack_from("<H", sm2, 2)[0]
    out["sm2_len_configured"] = sm2_len
    s0._fpwr(0x0816, b"\x00")  # disable SM2 so that its length becomes writable
    s0._fpwr(0x0812, struct.pack("<H", sm2_len + 1))
    s0._fpwr(0x0816, b"\x01")
    s0._fpwr(0x0120, struct.pack("<H", pysoem.SAFEOP_STATE))
    time.sleep(0.05)
    al_status = struct.unpack("<H", s0._fprd(0x0130, 2))[0]
    al_code = struct.unpack("<H", s0._fprd(0x0134, 2))[0]
    out["bad_sm2"] = {"al_status": al_status, "al_status_code": al_code}
    s0._fpwr(0x0120, struct.pack("<H", pysoem.INIT_STATE | 0x10))  # INIT + error ack
    time.sleep(0.05)
    out["after_ack"] = struct.unpack("<H", s0._fprd(0x0130, 2))[0]
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
