//! 1010h/1011h end to end with ethercrab in process: a parameter changed by SDO and stored with
//! "save" survives a power cycle of the simulated drive (which keeps its `SimStorage`),
//! "load" brings the defaults back after the next power cycle, a wrong signature is refused with
//! 0x08000020, and a power cut in the middle of a save leaves the old or the new value.

use std::time::Duration;

use board_sim::inproc::{InMemoryTxRx, InProcess};
use board_sim::Segment;
use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::{MainDeviceConfig, Timeouts};
use tests_host::block_on;
use tests_host::session::{power_cycle, take_segment};

/// The tunable parameter of the standard profile used here (manufacturer range, UDINT).
const USER_PARAMETER: u16 = 0x2F00;
const STORE: u16 = 0x1010;
const RESTORE: u16 = 0x1011;
/// 1010h:01 "save all parameters", 1011h:01 "restore all default parameters".
const ALL: u8 = 1;
/// CiA 301 §7.5.2.13: "save" = 's' 73h (LSB), 'a' 61h, 'v' 76h, 'e' 65h (MSB).
const SIGNATURE_SAVE: u32 = 0x6576_6173;
/// CiA 301 §7.5.2.14: "load" = 'l' 6Ch (LSB), 'o' 6Fh, 'a' 61h, 'd' 64h (MSB).
const SIGNATURE_LOAD: u32 = 0x6461_6F6C;
/// Header length of a parameter record and offset of its payload length
/// (`firmware::params::record`), to find the length of the record in a slot.
const RECORD_HEADER_LEN: usize = 28;
const PAYLOAD_LEN_OFFSET: usize = 24;
const RECORD_CRC_LEN: usize = 4;

fn connect(segment: Segment) -> (InProcess, InMemoryTxRx) {
    InProcess::connect(
        segment,
        Timeouts {
            // Wall-clock timeouts: generous, so a loaded CI machine does not time out.
            pdu: Duration::from_millis(500),
            eeprom: Duration::from_millis(2000),
            mailbox_response: Duration::from_millis(2000),
            ..Timeouts::default()
        },
        MainDeviceConfig::default(),
    )
}

/// What one master session does with drive 0 in PRE-OP.
enum Step {
    Write(u16, u8, u32),
    Read(u16, u8),
}

/// Connects a fresh master to `segment`, brings the drive to PRE-OP, runs `steps` and returns
/// the segment with each step's outcome (a read's value, or a write's result).
fn session(segment: Segment, steps: &[Step]) -> (Segment, Vec<Result<u32, Error>>) {
    block_on(async {
        let (m, transport) = connect(segment);
        let transport = tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init to PRE-OP");
        let sd = group.iter(md).next().expect("one drive");
        let mut out = Vec::new();
        for step in steps {
            out.push(match *step {
                Step::Write(index, sub, value) => sd.sdo_write(index, sub, value).await.map(|()| 0),
                Step::Read(index, sub) => sd.sdo_read::<u32>(index, sub).await,
            });
        }
        let segment = take_segment(&m);
        drop(group);
        transport.abort();
        (segment, out)
    })
}

fn abort_code(r: &Result<u32, Error>) -> Option<CoeAbortCode> {
    match r {
        Err(Error::Mailbox(MailboxError::Aborted { code, .. })) => Some(*code),
        _ => None,
    }
}

fn read_user_parameter(segment: Segment) -> (Segment, u32) {
    let (segment, out) = session(segment, &[Step::Read(USER_PARAMETER, 0)]);
    (segment, *out[0].as_ref().expect("2F00h readable"))
}

#[test]
fn saved_parameter_survives_power_cycle_and_load_restores_defaults() {
    let segment = Segment::new("standard", 1).expect("standard profile");
    let (mut segment, out) = session(
        segment,
        &[
            Step::Read(STORE, ALL),
            Step::Read(RESTORE, ALL),
            Step::Write(USER_PARAMETER, 0, 0x00C0_FFEE),
            Step::Write(STORE, ALL, 0x1234_5678),
            Step::Write(STORE, ALL, SIGNATURE_LOAD),
            Step::Write(STORE, ALL, SIGNATURE_SAVE),
            Step::Read(STORE, ALL),
        ],
    );
    assert_eq!(
        out[0].as_ref().ok(),
        Some(&1),
        "1010h:01 bit 0: saves on command"
    );
    assert_eq!(
        out[1].as_ref().ok(),
        Some(&1),
        "1011h:01 bit 0: restores defaults"
    );
    assert!(out[2].is_ok());
    assert_eq!(
        abort_code(&out[3]),
        Some(CoeAbortCode::TransferFailed),
        "0x08000020"
    );
    assert_eq!(
        abort_code(&out[4]),
        Some(CoeAbortCode::TransferFailed),
        "0x08000020"
    );
    assert!(out[5].is_ok(), "save: {:?}", out[5]);
    assert_eq!(
        out[6].as_ref().ok(),
        Some(&1),
        "reads the capabilities after a save"
    );
    assert_eq!(
        segment.drives()[0].params.storage().writes(),
        1,
        "one record written"
    );

    power_cycle(&mut segment);
    let (segment, value) = read_user_parameter(segment);
    assert_eq!(value, 0x00C0_FFEE, "stored value loaded at power-on");

    // "load": the current value stays until the next power-on, then the default applies.
    let (mut segment, out) = session(
        segment,
        &[
            Step::Write(RESTORE, ALL, SIGNATURE_SAVE),
            Step::Write(RESTORE, ALL, SIGNATURE_LOAD),
            Step::Read(USER_PARAMETER, 0),
        ],
    );
    assert_eq!(
        abort_code(&out[0]),
        Some(CoeAbortCode::TransferFailed),
        "0x08000020"
    );
    assert!(out[1].is_ok(), "load: {:?}", out[1]);
    assert_eq!(out[2].as_ref().ok(), Some(&0x00C0_FFEE));
    power_cycle(&mut segment);
    let (_, value) = read_user_parameter(segment);
    assert_eq!(value, 0, "default after restore + power cycle");
}

#[test]
fn storage_failure_aborts_with_0x06060000() {
    let mut segment = Segment::new("standard", 1).expect("standard profile");
    segment.drives_mut()[0]
        .params
        .storage_mut()
        .set_failing(true);
    let (_, out) = session(segment, &[Step::Write(STORE, ALL, SIGNATURE_SAVE)]);
    assert_eq!(abort_code(&out[0]), Some(CoeAbortCode::HardwareFailure));
}

#[test]
fn power_cut_during_save_leaves_old_or_new_value() {
    const OLD: u32 = 0x1111_1111;
    const NEW: u32 = 0x2222_2222;
    let segment = Segment::new("standard", 1).expect("standard profile");
    let (mut segment, out) = session(
        segment,
        &[
            Step::Write(USER_PARAMETER, 0, OLD),
            Step::Write(STORE, ALL, SIGNATURE_SAVE),
        ],
    );
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    // The record just written is in slot 0; the next save writes slot 1, and so on.
    let slot = segment.drives()[0]
        .params
        .storage()
        .slot(0)
        .expect("slot 0");
    let payload = u32::from_le_bytes(
        slot[PAYLOAD_LEN_OFFSET..PAYLOAD_LEN_OFFSET + 4]
            .try_into()
            .expect("4 bytes"),
    );
    let full = RECORD_HEADER_LEN + payload as usize + RECORD_CRC_LEN;
    power_cycle(&mut segment);
    // Cuts in the header, in the payload, in the CRC, and none.
    for cut in [0, 1, 27, 28, full / 2, full - 4, full - 1, full] {
        segment.drives_mut()[0]
            .params
            .storage_mut()
            .cut_power_after(cut);
        let (mut s, out) = session(
            segment,
            &[
                Step::Write(USER_PARAMETER, 0, NEW),
                Step::Write(STORE, ALL, SIGNATURE_SAVE),
            ],
        );
        assert!(out[0].is_ok());
        power_cycle(&mut s);
        let (s, value) = read_user_parameter(s);
        if cut < full {
            // The drive lost power during the write (the simulated firmware still answered
            // 0x06060000; a real one would have been off).
            assert_eq!(abort_code(&out[1]), Some(CoeAbortCode::HardwareFailure));
            assert!(value == OLD || value == NEW, "cut {cut}: {value:#x}");
            if cut < full - RECORD_CRC_LEN {
                // Within the CRC, a prefix plus erased 0xFF bytes may already equal the whole
                // record; before it, the record cannot be complete.
                assert_eq!(
                    value, OLD,
                    "an incomplete record is never loaded (cut {cut})"
                );
            }
        } else {
            assert!(out[1].is_ok());
            assert_eq!(value, NEW, "complete write");
        }
        // Back to OLD for the next round.
        let (mut s, out) = session(
            s,
            &[
                Step::Write(USER_PARAMETER, 0, OLD),
                Step::Write(STORE, ALL, SIGNATURE_SAVE),
            ],
        );
        assert!(out.iter().all(Result::is_ok), "{out:?}");
        power_cycle(&mut s);
        segment = s;
    }
}
