"""What the SOEM scenarios share about SDO information: an object of `slave.od` as JSON, and
draining the SDO Info Errors SOEM keeps for missing subindexes."""


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


def drain_info_errors(slave, limit=1024):
    """SOEM asks for the entry description of every subindex up to the highest one; objects
    with gaps get an SDO Info Error for each missing subindex (ETG.1000.6), which SOEM keeps in
    its error list and pysoem raises on the next SDO calls, one per call. Returns how many."""
    stale = 0
    while stale < limit:
        try:
            slave.sdo_read(0x1000, 0)
            break
        except Exception:  # noqa: BLE001 - the stale SDO info errors
            stale += 1
    return stale
