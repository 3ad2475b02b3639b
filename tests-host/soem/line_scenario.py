"""SOEM (pysoem 1.1.13) against a line of simulated drives of different profiles: discovery
(the SII identity and name of each), the identity 1018h of each by SDO, DC SYNC0 at 1 ms (inside
every profile's range), config_map with each drive's default PDO mapping, OP for all, cyclic
process data with the expected working counter, back to INIT. Prints one JSON object;
tests-host/tests/line_soem.rs asserts on it against the profile files."""

import json
import struct
import sys
import time

import pysoem

RECEIVE_TIMEOUT_US = 20_000
RETURN_TIMEOUT_US = 20_000
CYCLE_NS = 1_000_000
CYCLES = 200


def main():
    ifname = sys.argv[1]
    out = {}
    # The simulated line answers from an ordinary process: on a loaded machine a frame through
    # seven drives can take longer than SOEM's 2 ms default return timeout, and discovery would
    # miss the line. 20 ms only matters when a frame is late.
    pysoem.settings.timeouts.ret = RETURN_TIMEOUT_US
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    out["slaves"] = []
    for s in m.slaves:
        ident = [struct.unpack("<I", s.sdo_read(0x1018, sub)[:4])[0] for sub in (1, 2, 3)]
        out["slaves"].append(
            {"name": s.name, "man": s.man, "id": s.id, "rev": s.rev, "sdo_identity": ident}
        )
    # A Python master is not real time: SYNC0 events without new outputs are routine here, so the
    # sync error supervision of the drives that count them (the Sigma-V-SD, 10F1h:02 = 0
    # disables it, ETG.1020) is switched off, as a master without real-time cycles must.
    for s in m.slaves:
        try:
            s.sdo_write(0x10F1, 2, struct.pack("<I", 0))
        except pysoem.SdoError:
            pass
    # DC before config_map: SOEM's config_map requests SAFE-OP at its end, and the GHA-E runs in
    # DC SYNC0 only (it refuses free run with AL status code 0x0027).
    out["dc"] = m.config_dc()
    for s in m.slaves:
        s.dc_sync(True, CYCLE_NS)
    out["iomap_size"] = m.config_map()
    out["io"] = [[len(bytes(s.output)), len(bytes(s.input))] for s in m.slaves]
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    m.read_state()
    out["safeop_states"] = [[s.state, s.al_status] for s in m.slaves]
    out["expected_wkc"] = m.expected_wkc
    m.state = pysoem.OP_STATE
    m.write_state()
    for _ in range(3000):
        m.send_processdata()
        m.receive_processdata(RECEIVE_TIMEOUT_US)
        if m.state_check(pysoem.OP_STATE, 1000) == pysoem.OP_STATE:
            break
        time.sleep(CYCLE_NS / 1e9)
    out["op"] = m.read_state()
    out["op_states"] = [s.state for s in m.slaves]
    wkcs = []
    for _ in range(CYCLES):
        m.send_processdata()
        wkcs.append(m.receive_processdata(RECEIVE_TIMEOUT_US))
        time.sleep(CYCLE_NS / 1e9)
    out["wkcs"] = wkcs
    m.read_state()
    out["states_after"] = [s.state for s in m.slaves]
    out["al_codes"] = [s.al_status for s in m.slaves]
    m.state = pysoem.INIT_STATE
    m.write_state()
    out["init"] = m.state_check(pysoem.INIT_STATE, 2_000_000)
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
