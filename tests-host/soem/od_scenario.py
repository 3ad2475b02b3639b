"""SOEM (pysoem 1.1.13) reads a simulated drive's whole object dictionary through SDO
information: the object list (ETG.1000.6 Get OD List, fragmented for large dictionaries), every
object description and every entry description up to each object's highest subindex. Prints one
JSON object; tests-host/tests/sdo_info_soem.rs compares it with the profile file."""

import json
import sys
import time

import pysoem

from od_common import describe, drain_info_errors


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s = m.slaves[0]
    t = time.monotonic()
    od = s.od
    out["od"] = [describe(o) for o in od]
    out["od_seconds"] = time.monotonic() - t
    out["stale_info_errors"] = drain_info_errors(s)
    # Complete access (ETG.1000.6 §5.6.2.1.1) to every object of the list: the upload stream,
    # or the abort code.
    ca = {}
    for index in (o.index for o in od):
        try:
            ca[f"{index:04x}"] = s.sdo_read(index, 0, size=4096, ca=True).hex()
        except pysoem.SdoError as e:
            ca[f"{index:04x}"] = {"abort": e.abort_code}
    out["ca"] = ca
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
