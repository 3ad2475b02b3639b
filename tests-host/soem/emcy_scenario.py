"""SOEM (pysoem 1.1.13) receives the drive's emergencies: a SAFE-OP request with a wrong SM2
length is refused (AL status code 0x001D); the drive sends an emergency 0xA000 with error
register 1001h = 0x11, stores a 10F3h diagnosis message that SOEM reads by SDO and
acknowledges, and sends the "error reset" emergency (0x0000) when the AL error is acknowledged.
Prints one JSON object with what SOEM saw; tests-host/tests/emcy_soem.rs asserts on it."""

import json
import struct
import sys
import time

import pysoem


def al_status(slave):
    return struct.unpack("<H", slave._fprd(0x0130, 2))[0]


def main():
    ifname = sys.argv[1]
    out = {}
    m = pysoem.Master()
    m.open(ifname)
    out["slave_count"] = m.config_init()
    s0 = m.slaves[0]
    emergencies = []

    def on_emergency(e):
        emergencies.append(
            {
                "code": e.error_code,
                "register": e.error_reg,
                "b1": e.b1,
                "w1": e.w1,
                "w2": e.w2,
            }
        )

    s0.add_emergency_callback(on_emergency)

    def poll_mailbox():
        # SOEM reads SM1 with timeout 0 before every SDO request as well; mbx_receive does the
        # same on its own and hands an emergency to the callback.
        for _ in range(5):
            try:
                s0.mbx_receive()
            except pysoem.Emergency as e:  # only without a callback
                on_emergency(e)
            time.sleep(0.01)

    # config_map sets up SM2/SM3 and requests SAFE-OP; come back to PRE-OP.
    m.config_map()
    m.state_check(pysoem.SAFEOP_STATE, 2_000_000)
    m.state = pysoem.PREOP_STATE
    m.write_state()
    out["preop"] = m.state_check(pysoem.PREOP_STATE, 2_000_000)
    poll_mailbox()
    out["register_before"] = s0.sdo_read(0x1001, 0)[0]
    out["emergencies_before"] = len(emergencies)

    # Wrong SM2 length (as scenario.py does), then request SAFE-OP: refused with 0x001D.
    sm2_len = struct.unpack("<H", s0._fprd(0x0812, 2))[0]
    s0._fpwr(0x0816, b"\x00")
    s0._fpwr(0x0812, struct.pack("<H", sm2_len + 1))
    s0._fpwr(0x0816, b"\x01")
    s0._fpwr(0x0120, struct.pack("<H", pysoem.SAFEOP_STATE))
    time.sleep(0.05)
    out["al_status"] = al_status(s0)
    out["al_status_code"] = struct.unpack("<H", s0._fprd(0x0134, 2))[0]
    poll_mailbox()
    out["emergencies_after_refusal"] = list(emergencies)

    out["register"] = s0.sdo_read(0x1001, 0)[0]
    newest = s0.sdo_read(0x10F3, 2)[0]
    out["newest"] = newest
    out["new_messages"] = s0.sdo_read(0x10F3, 4)[0]
    out["message"] = list(s0.sdo_read(0x10F3, newest)) if newest else []
    s0.sdo_write(0x10F3, 3, bytes([newest]))
    out["newest_acknowledged"] = s0.sdo_read(0x10F3, 3)[0]
    out["new_messages_after_ack"] = s0.sdo_read(0x10F3, 4)[0]

    # Acknowledge the AL error (PRE-OP + ack): the error clears, "error reset" follows.
    s0._fpwr(0x0120, struct.pack("<H", pysoem.PREOP_STATE | 0x10))
    time.sleep(0.05)
    out["al_status_after_ack"] = al_status(s0)
    poll_mailbox()
    out["register_after_ack"] = s0.sdo_read(0x1001, 0)[0]
    out["emergencies"] = emergencies
    m.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
