"""What the SOEM scenarios share about SDO information: an object of `slave.od` as JSON, and
draining the SDO Info Errors SOEM keeps for missing subindexes."""


# SOEM gives up on an entry description after its mailbox timeout (EC_TIMEOUTRXM, 700 ms); on a
# loaded machine the simulated drive, which runs in wall-clock time, can answer later than that.
# A late answer is a slow master's problem, not a wrong one: the read is tried again.
ENTRY_READ_ATTEMPTS = 3


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
    for attempt in range(ENTRY_READ_ATTEMPTS):
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
            d.pop("entries_error", None)
            break
        except Exception as e:  # noqa: BLE001 - reported, not hidden
            d["entries_error"] = repr(e)
            d["entry_read_attempts"] = attempt + 1
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
