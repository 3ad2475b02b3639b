"""SOEM (pysoem 1.1.13) against the simulated drive: the CoE services beyond plain SDO.

SDO information (`slave.od`: object list, object and entry descriptions), complete-access
uploads of 1C12h/1A00h, a complete-access download of a new 1A00h mapping in PREOP and a refused
one, a 64 KiB segmented download + upload round trip to the test domain 2FF0h, then config_map
(SOEM reads the PDO configuration with complete access because the SII advertises it) and
SAFEOP. Prints one JSON object; tests-host/tests/coe_soem.rs asserts on it."""

import json
import struct
import sys
import time

import pysoem

from od_common import describe, drain_info_errors

DOMAIN = 0x2FF0
DOMAIN_LEN = 64 * 1024


def abort_of(f):
    try:
        f()
        return None
    except pysoem.SdoError as e:
        return e.abort_code


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s = m.slaves[0]

    t = time.monotonic()
    out["od"] = [describe(o) for o in s.od]
    out["od_seconds"] = time.monotonic() - t
    out["stale_info_errors"] = drain_info_errors(s, 256)

    out["ca_1c12"] = s.sdo_read(0x1C12, 0, ca=True).hex()
    out["ca_1a00"] = s.sdo_read(0x1A00, 0, ca=True).hex()
    out["ca_1a00_si1"] = s.sdo_read(0x1A00, 1, ca=True).hex()

    new_map = struct.pack("<BxII", 2, 0x6041_0010, 0x6064_0020)
    s.sdo_write(0x1A00, 0, new_map, ca=True)
    out["ca_1a00_after_write"] = s.sdo_read(0x1A00, 0, ca=True).hex()
    out["1a00_si0_after_write"] = s.sdo_read(0x1A00, 0)[0]
    # 6040h (controlword) is RxPDO-only: refused in a TxPDO, mapping unchanged.
    bad_map = struct.pack("<BxII", 2, 0x6041_0010, 0x6040_0010)
    out["ca_bad_map_abort"] = abort_of(lambda: s.sdo_write(0x1A00, 0, bad_map, ca=True))
    out["ca_1a00_after_bad"] = s.sdo_read(0x1A00, 0, ca=True).hex()
    # Restore the default mapping for config_map.
    s.sdo_write(0x1A00, 0, bytes.fromhex(out["ca_1a00"]), ca=True)

    data = bytes((i * 31 + (i >> 8)) & 0xFF for i in range(DOMAIN_LEN))
    t = time.monotonic()
    s.sdo_write(DOMAIN, 0, data)
    back = s.sdo_read(DOMAIN, 0, size=DOMAIN_LEN + 16)
    out["domain_seconds"] = time.monotonic() - t
    out["domain_len"] = len(back)
    out["domain_equal"] = back == data

    out["iomap_size"] = m.config_map()
    out["safeop"] = m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    m.state = pysoem.INIT_STATE
    m.write_state()
    out["init"] = m.state_check(pysoem.INIT_STATE, 2_000_000)
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
