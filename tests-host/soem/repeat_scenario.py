"""SOEM (pysoem 1.1.13) recovers a lost mailbox response with the repeat request: the
simulator (started with --drop-mailbox-read 1) drops the reply to the first successful read of
the slave -> master mailbox; SOEM's ecx_mbxreceive sees no working counter, toggles SM1 repeat
request (0x080E bit 1), waits for the repeat acknowledge (0x080F bit 1) and reads the response
again. Prints what SOEM got."""

import json
import struct
import sys

import pysoem


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s0 = m.slaves[0]
    out["identity"] = [struct.unpack("<I", s0.sdo_read(0x1018, sub)[:4])[0] for sub in (1, 2, 3, 4)]
    out["device_name"] = s0.sdo_read(0x1008, 0).decode("ascii", "replace")
    # The repeat-ack bit the slave shows now must equal the request bit SOEM left set.
    sm1 = s0._fprd(0x0808, 8)
    out["sm1_repeat_request"] = (sm1[6] >> 1) & 1
    out["sm1_repeat_ack"] = (sm1[7] >> 1) & 1
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
