"""SOEM (pysoem 1.1.13) reads a simulated drive's whole object dictionary through SDO
information: the object list (ETG.1000.6 Get OD List, fragmented for large dictionaries), every
object description and every entry description up to each object's highest subindex. Prints one
JSON object; tests-host/tests/sdo_info_soem.rs compares it with the profile file."""

import json
import sys
import time

import pysoem


def text(v):
    return v.decode("ascii", "replace") if isinstance(v, bytes) else v


def describe(obj):
    d = {
        "index": obj.index,
        "name": text(obj.name),
        "object_code": obj.object_code,
        "data_type": obj.data_type,
        # A VAR's own entry: pysoem exposes its length and access on the object.
        "bit_length": getattr(obj, "bit_length", None),
        "obj_access": getattr(obj, "obj_access", None),
    }
    try:
        d["entries"] = [
            {
                "name": text(e.name),
                "data_type": e.data_type,
                "bit_length": e.bit_length,
                "obj_access": e.obj_access,
            }
            for e in obj.entries
        ]
    except Exception as e:  # noqa: BLE001 - reported, not hidden
        d["entries_error"] = repr(e)
    return d


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
    # SOEM keeps an SDO Info Error for each missing subindex of objects with gaps and pysoem
    # raises them on the next SDO calls, one per call: drain them first.
    stale = 0
    while stale < 1024:
        try:
            s.sdo_read(0x1000, 0)
            break
        except Exception:  # noqa: BLE001 - the stale SDO info errors
            stale += 1
    out["stale_info_errors"] = stale
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
