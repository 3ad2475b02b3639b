"""SOEM (pysoem 1.1.13) runs the Σ-V-SD's adjusting service 2310h on the simulated drive in PREOP
(§4.5 (8)): the 16-byte requests are normal SDO downloads to 2310h:01, the status is polled at
2310h:02 and the reply read at 2310h:03. Step 1 selects 100EH (offset adjustment), step 3
executes it, the status is polled until it leaves 255; an unknown code, and 1008H executed before
its preparation, are refused. Prints one JSON object; tests-host/tests/adjusting_soem.rs asserts
on it."""

import json
import struct
import sys
import time

import pysoem

ADJUSTING = 0x2310
EXECUTING = 255


def request(address, data):
    # bytes 0-1 reserved, 2 CCMD = 01h write, 3 CSIZE = 2, 4-7 CADDRESS, 8-9 CDATA, 10-15 zero
    return struct.pack("<xxBBIH6x", 0x01, 2, address, data)


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s = m.slaves[0]

    def step(address, data):
        s.sdo_write(ADJUSTING, 1, request(address, data))
        return s.sdo_read(ADJUSTING, 2)[0]

    out["unknown_code"] = step(0x2000, 0x1234)
    out["select_1008"] = step(0x2000, 0x1008)
    out["execute_unprepared"] = step(0x2001, 0x0001)
    out["abort"] = step(0x2000, 0x0000)
    out["select_100e"] = step(0x2000, 0x100E)
    out["select_reply"] = s.sdo_read(ADJUSTING, 3).hex()
    out["execute"] = step(0x2001, 0x0001)
    polled = []
    deadline = time.monotonic() + 6.0
    while time.monotonic() < deadline:
        status = s.sdo_read(ADJUSTING, 2)[0]
        polled.append(status)
        if status != EXECUTING:
            break
        time.sleep(0.005)
    out["polled"] = polled
    out["final_reply"] = s.sdo_read(ADJUSTING, 3).hex()
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
