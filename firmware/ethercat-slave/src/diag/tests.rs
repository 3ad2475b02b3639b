//! 10F3h against the standard profile's declaration (8 messages of 28 bytes).

use super::*;
use crate::mailbox::emcy::{code, Emergency};
use crate::test_profiles::standard;

const SLOTS: u8 = 8;

fn with_od(f: impl FnOnce(&mut Dictionary<'_>)) {
    let mut ram = [0u8; standard::RAM_SIZE];
    let mut od = Dictionary::new(&standard::PROFILE, &mut ram);
    od.load_defaults();
    f(&mut od);
}

fn sub_u8(od: &Dictionary<'_>, s: u8) -> u8 {
    read_u8(od, s).expect("entry")
}

fn message(od: &Dictionary<'_>, n: u8) -> [u8; 28] {
    let e = od
        .entry(DIAG_HISTORY, sub::FIRST_MESSAGE + n)
        .expect("message entry");
    od.value(e).expect("value").try_into().expect("28 bytes")
}

fn set_flags(od: &mut Dictionary<'_>, v: u16) {
    let e = od.entry(DIAG_HISTORY, sub::FLAGS).expect("flags");
    od.set_value(e, &v.to_le_bytes()).expect("set");
}

/// What an SDO download of `v` to 10F3h:03 leaves in the OD.
fn master_writes_ack(od: &mut Dictionary<'_>, v: u8) {
    let e = od
        .entry(DIAG_HISTORY, sub::NEWEST_ACKNOWLEDGED)
        .expect(":03");
    od.set_value(e, &[v]).expect("set");
}

fn msg(i: u16) -> DiagMessage {
    DiagMessage::new(diag_code_for_emcy(0x1000 + i), DiagType::Error, 0x0100 + i)
}

#[test]
fn the_standard_profile_has_8_slots() {
    with_od(|od| assert_eq!(Diagnosis::slots(od), SLOTS));
}

#[test]
fn message_bytes_are_code_flags_text_time_params() {
    let m = DiagMessage::new(
        diag_code_for_emcy(code::ESM_TRANSITION),
        DiagType::Error,
        0x0011,
    )
    .with(DiagParam::U16(0x001D))
    .with(DiagParam::U8(0x24));
    let mut out = [0xAAu8; 28];
    m.encode(0x0102_0304_0506_0708, &mut out);
    assert_eq!(
        out,
        [
            0x00, 0xE8, 0x00, 0xA0, // diag code 0xA000_E800 (emergency code 0xA000)
            0x12, 0x02, // flags 0x0212: error, local time stamp, 2 parameters
            0x11, 0x00, // text ID
            0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01, // time stamp
            0x06, 0x00, 0x1D, 0x00, // UNSIGNED16 0x001D
            0x05, 0x00, 0x24, // UNSIGNED8 0x24
            0, 0, 0, 0, 0,
        ]
    );
}

#[test]
fn parameters_that_do_not_fit_are_left_out() {
    let m = DiagMessage::new(1, DiagType::Info, 0)
        .with(DiagParam::U32(0xAABBCCDD))
        .with(DiagParam::U32(1));
    let mut out = [0u8; MESSAGE_HEADER_LEN + 6 + 3];
    m.encode(0, &mut out);
    assert_eq!(
        u16::from_le_bytes([out[4], out[5]]),
        0x0110,
        "info, local time, 1 parameter"
    );
    assert_eq!(&out[16..22], &[0x07, 0x00, 0xDD, 0xCC, 0xBB, 0xAA]);
    assert_eq!(&out[22..], &[0, 0, 0]);
}

#[test]
fn overwrite_mode_rings_and_flags_the_overwrite() {
    with_od(|od| {
        let mut d = Diagnosis::new();
        assert_eq!(sub_u8(od, sub::NEWEST), 0);
        for i in 0..SLOTS as u16 {
            assert_eq!(d.report(od, &msg(i), u64::from(i), 0), Ok(None));
        }
        assert_eq!(sub_u8(od, sub::NEWEST), 6 + SLOTS - 1);
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 1);
        assert_eq!(Diagnosis::flags(od), 0, "nothing overwritten yet");
        // The ninth message replaces the oldest (subindex 6).
        d.report(od, &msg(8), 8, 0).expect("stored");
        assert_eq!(sub_u8(od, sub::NEWEST), 6);
        assert_eq!(
            &message(od, 0)[..4],
            &diag_code_for_emcy(0x1008).to_le_bytes()
        );
        assert_eq!(
            &message(od, 1)[..4],
            &diag_code_for_emcy(0x1001).to_le_bytes()
        );
        assert_eq!(Diagnosis::flags(od), flags::OVERWRITTEN_OR_DISCARDED);
        // Acknowledging the newest clears "new messages" and the overwrite flag.
        master_writes_ack(od, 6);
        d.poll(od).expect("poll");
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 0);
        assert_eq!(Diagnosis::flags(od), 0);
    });
}

#[test]
fn acknowledge_mode_discards_when_every_slot_is_unacknowledged() {
    with_od(|od| {
        set_flags(od, flags::ACKNOWLEDGE_MODE);
        let mut d = Diagnosis::new();
        for i in 0..SLOTS as u16 {
            d.report(od, &msg(i), 0, 0).expect("stored");
        }
        assert_eq!(d.report(od, &msg(99), 0, 0), Err(DiagError::Discarded));
        assert_eq!(
            Diagnosis::flags(od),
            flags::ACKNOWLEDGE_MODE | flags::OVERWRITTEN_OR_DISCARDED
        );
        assert_eq!(sub_u8(od, sub::NEWEST), 6 + SLOTS - 1, "newest unchanged");
        // The master acknowledges up to the third message (subindex 8): three slots free up.
        master_writes_ack(od, 8);
        d.poll(od).expect("poll");
        assert_eq!(sub_u8(od, sub::NEWEST_ACKNOWLEDGED), 8);
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 1, "5 still unacknowledged");
        assert_eq!(Diagnosis::flags(od), flags::ACKNOWLEDGE_MODE);
        for i in 0..3 {
            d.report(od, &msg(20 + i), 0, 0)
                .expect("replaces an acknowledged one");
        }
        assert_eq!(sub_u8(od, sub::NEWEST), 8);
        assert_eq!(d.report(od, &msg(30), 0, 0), Err(DiagError::Discarded));
        // Acknowledge everything.
        master_writes_ack(od, 8);
        d.acknowledge(od, 8).expect("ack");
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 0);
    });
}

#[test]
fn invalid_acknowledge_is_undone_and_zero_clears() {
    with_od(|od| {
        let mut d = Diagnosis::new();
        d.report(od, &msg(0), 0, 0).expect("stored");
        d.report(od, &msg(1), 0, 0).expect("stored");
        master_writes_ack(od, 9); // no message at subindex 9
        d.poll(od).expect("poll");
        assert_eq!(sub_u8(od, sub::NEWEST_ACKNOWLEDGED), 0, "restored");
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 1);
        master_writes_ack(od, 6);
        d.poll(od).expect("poll");
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 1, "message at 7 still new");
        master_writes_ack(od, 0);
        d.poll(od).expect("poll");
        assert_eq!(d.stored(), 0);
        assert_eq!(sub_u8(od, sub::NEWEST), 0);
        assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 0);
        assert_eq!(message(od, 0), [0; 28]);
    });
}

#[test]
fn disabled_types_are_suppressed() {
    with_od(|od| {
        set_flags(od, flags::DISABLE_INFO | flags::DISABLE_ERROR);
        let mut d = Diagnosis::new();
        let info = DiagMessage::new(0xE000, DiagType::Info, 1);
        assert_eq!(d.report(od, &info, 0, 0), Err(DiagError::Suppressed));
        assert_eq!(d.report(od, &msg(0), 0, 0), Err(DiagError::Suppressed));
        let warning = DiagMessage::new(0xE000, DiagType::Warning, 1);
        assert_eq!(d.report(od, &warning, 0, 0), Ok(None));
    });
}

#[test]
fn flag_bit0_sends_the_message_as_emergency() {
    with_od(|od| {
        set_flags(od, flags::SEND_AS_EMERGENCY);
        let mut d = Diagnosis::new();
        let m = DiagMessage::new(diag_code_for_emcy(0x8130), DiagType::Error, 0)
            .with(DiagParam::U16(0x001B));
        assert_eq!(
            d.report(od, &m, 0, 0x11),
            Ok(Some(Emergency::new(0x8130, 0x11, [0x1B, 0, 0, 0, 0])))
        );
        let m = DiagMessage::new(0xE000, DiagType::Error, 0);
        assert_eq!(
            d.report(od, &m, 0, 0x01).map(|e| e.map(|e| e.code)),
            Ok(Some(code::GENERIC))
        );
        let m = DiagMessage::new(0xE000, DiagType::Warning, 0);
        assert_eq!(d.report(od, &m, 0, 0x01), Ok(None));
    });
}

/// A dictionary whose 10F3h has the most slots the ring handles ([`MAX_MESSAGES`] = 250
/// messages of 16 bytes), the rest of the profile as the standard one.
mod full_ring {
    use super::*;
    use crate::od::{Access, Entry, Object, ObjectCode, PdoMappable, Profile, Value};

    pub const SLOTS: u8 = MAX_MESSAGES as u8;
    const MESSAGE_BYTES: u16 = MESSAGE_HEADER_LEN as u16;
    /// RAM: 10F3h:02, :03, :04 at 0..3, :05 at 4..6, the messages from 6 on.
    const FIRST_MESSAGE_RAM: u16 = 6;
    pub const RAM_SIZE: usize = FIRST_MESSAGE_RAM as usize + MAX_MESSAGES * MESSAGE_HEADER_LEN;

    const fn entry(subindex: u8, data_type: DataType, bit_len: u16, value: Value) -> Entry {
        Entry {
            subindex,
            name: "",
            data_type,
            bit_len,
            access: Access::RO,
            pdo: PdoMappable::No,
            value,
            default: &[],
            min: &[],
            max: &[],
        }
    }

    const fn entries() -> [Entry; 256] {
        let mut e = [entry(0, DataType::Unsigned8, 8, Value::Const(&[255])); 256];
        e[1] = entry(1, DataType::Unsigned8, 8, Value::Const(&[SLOTS]));
        e[2] = entry(2, DataType::Unsigned8, 8, Value::Ram(0));
        e[3] = entry(3, DataType::Unsigned8, 8, Value::Ram(1));
        e[3].access = Access::RW;
        e[4] = entry(4, DataType::Boolean, 1, Value::Ram(2));
        e[5] = entry(5, DataType::Unsigned16, 16, Value::Ram(4));
        e[5].access = Access::RW;
        let mut i = 0;
        while i < MAX_MESSAGES {
            let ram = FIRST_MESSAGE_RAM + i as u16 * MESSAGE_BYTES;
            let s = sub::FIRST_MESSAGE + i as u8;
            e[s as usize] = entry(s, DataType::OctetString, MESSAGE_BYTES * 8, Value::Ram(ram));
            i += 1;
        }
        e
    }

    static ENTRIES: [Entry; 256] = entries();
    static OBJECTS: [Object; 1] = [Object {
        index: DIAG_HISTORY,
        code: ObjectCode::Record,
        name: "Diagnosis history",
        entries: &ENTRIES,
    }];
    static DEFAULTS: [u8; RAM_SIZE] = [0; RAM_SIZE];
    pub static PROFILE: Profile = Profile {
        objects: &OBJECTS,
        defaults: &DEFAULTS,
        value_lists: &[],
        ..standard::PROFILE
    };
}

#[test]
fn ring_arithmetic_holds_for_250_slots() {
    let slots = MAX_MESSAGES as u8;
    assert_eq!(newer_than(200, 100, slots), 100);
    assert_eq!(newer_than(249, 0, slots), 249);
    assert_eq!(
        newer_than(0, 249, slots),
        1,
        "wrapped: only slot 0 is newer"
    );
    assert_eq!(newer_than(100, 200, slots), 150);
    assert_eq!(newer_than(7, 7, slots), 0);
    assert_eq!(newer_than(3, 5, 8), 6);
    assert_eq!(next_slot(248, slots), 249);
    assert_eq!(next_slot(249, slots), 0);
    assert_eq!(next_slot(7, 8), 0);
    assert_eq!(message_subindex(slots - 1), Some(255));
    assert_eq!(message_subindex(slots), None);
}

#[test]
fn a_full_ring_of_250_messages_wraps_and_acknowledges() {
    let mut ram = [0u8; full_ring::RAM_SIZE];
    let mut od = Dictionary::new(&full_ring::PROFILE, &mut ram);
    od.load_defaults();
    let od = &mut od;
    assert_eq!(Diagnosis::slots(od), full_ring::SLOTS);
    let mut d = Diagnosis::new();
    for i in 0..u16::from(full_ring::SLOTS) {
        d.report(od, &msg(i), 0, 0).expect("stored");
    }
    assert_eq!(d.stored(), full_ring::SLOTS);
    assert_eq!(sub_u8(od, sub::NEWEST), 255, "the last slot");
    // Acknowledging the first message leaves the 249 after it new.
    d.acknowledge(od, sub::FIRST_MESSAGE).expect("ack");
    assert_eq!(d.unacknowledged, 249);
    assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 1);
    // Two more wrap to slots 0 and 1 (subindexes 6 and 7).
    d.report(od, &msg(300), 0, 0).expect("stored");
    d.report(od, &msg(301), 0, 0).expect("stored");
    assert_eq!(sub_u8(od, sub::NEWEST), 7);
    assert_eq!(d.stored(), full_ring::SLOTS, "never more than the slots");
    // Acknowledging slot 200 (subindex 206) across the wrap: slots 201..=249, 0, 1 are newer.
    d.acknowledge(od, 206).expect("ack");
    assert_eq!(d.unacknowledged, 51);
    d.acknowledge(od, 7).expect("ack the newest");
    assert_eq!(d.unacknowledged, 0);
    assert_eq!(sub_u8(od, sub::NEW_MESSAGES), 0);
}
