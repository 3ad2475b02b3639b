//! The vendor profiles' parameter storage rules (`[storage]`, executed by the slave stack's
//! `params`) end to end with ethercrab in process; a power cycle is a new firmware on the same
//! simulated storage (`SimDrive::power_cycle`):
//!
//! - Σ-V-SD: 1010h:04 in Switch On Disabled stores the SERVOPACK parameters (2000h–22FFh), not
//!   the 6xxxh ones; 1010h:01 and 1011h:01 outside Switch On Disabled (Ready to Switch On after
//!   "shutdown") are refused with 0x08000022; 2300h is not kept by 1010h:01, 2301h is;
//! - RSE: a PDO-mappable parameter (2009h:01, 6067h) survives "save" and a power cycle, 6065h
//!   and the command 607Ah do not;
//! - GHA-E: an SDO download to 607Dh or to a Pn entry survives a power cycle without any 1010h
//!   write; with Pn-046 = 1 a Pn download does not; a PDO write to 607Dh is never stored.

use board_sim::Segment;
use ethercrab::error::{Error, MailboxError};
use tests_host::session::{power_cycle, take_segment};
use tests_host::{al_status, block_on, master_for};

const STORE: u16 = 0x1010;
const RESTORE: u16 = 0x1011;
/// 1010h/1011h sub 1 "all parameters"; sub 4 on the Σ-V-SD: SERVOPACK parameters.
const ALL: u8 = 1;
const MANUFACTURER: u8 = 4;
/// CiA 301 §7.5.2.13/14 signatures "save" and "load".
const SIGNATURE_SAVE: u32 = 0x6576_6173;
const SIGNATURE_LOAD: u32 = 0x6461_6F6C;
/// SDO abort "data cannot be transferred or stored because of the present device state".
const ABORT_DEVICE_STATE: u32 = 0x0800_0022;
/// CiA402 statusword (6041h) state bits and values (IEC 61800-7-201 Table 30).
const STATE_MASK: u16 = 0x006F;
const SWITCH_ON_DISABLED: u16 = 0x0040;
const READY_TO_SWITCH_ON: u16 = 0x0021;
/// Controlword "disable voltage" (stay in Switch On Disabled) and "shutdown" (→ Ready to Switch
/// On).
const CW_DISABLE_VOLTAGE: u16 = 0x0000;
const CW_SHUTDOWN: u16 = 0x0006;
/// Free-run cycle the master runs in OP.
const CYCLE_NS: u64 = 1_000_000;
/// Cycles a controlword is held before the statusword is read.
const SETTLE_CYCLES: usize = 10;
/// Largest process image of these tests' mappings (bytes) and ethercrab's table size.
const MAX_PDI: usize = 128;
const MAX_SUBDEVICES: usize = 4;

/// A value of the width of its entry.
#[derive(Clone, Copy, Debug)]
enum V {
    U16(u16),
    U32(u32),
    I32(i32),
}

/// What a master session does with the drive, in order.
#[derive(Clone, Copy, Debug)]
enum Step {
    /// SDO download.
    Write(u16, u8, V),
    /// SDO upload (up to 4 bytes, little-endian, zero-extended).
    Read(u16, u8),
    /// OP sessions: hold this controlword for [`SETTLE_CYCLES`] cycles; the outcome is the
    /// statusword.
    Controlword(u16),
}

/// Outcome of a step: a value (read, statusword), `Ok(0)` for a write, or the SDO abort code.
type Outcome = Result<u32, u32>;

fn abort_of(e: Error) -> u32 {
    match e {
        Error::Mailbox(MailboxError::Aborted { code, .. }) => u32::from(code),
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

fn segment(profile: &str) -> Segment {
    Segment::new(profile, 1).expect("built-in profile")
}

/// Writes of the parameter storage so far.
fn storage_writes(segment: &Segment) -> u32 {
    segment.drives()[0].params.storage().writes()
}

/// One SDO step on `sd`.
async fn sdo_step<S: std::ops::Deref<Target = ethercrab::SubDevice>>(
    sd: &ethercrab::SubDeviceRef<'_, S>,
    step: Step,
) -> Outcome {
    match step {
        Step::Write(index, sub, value) => match value {
            V::U16(v) => sd.sdo_write(index, sub, v).await,
            V::U32(v) => sd.sdo_write(index, sub, v).await,
            V::I32(v) => sd.sdo_write(index, sub, v).await,
        }
        .map(|()| 0)
        .map_err(abort_of),
        Step::Read(index, sub) => sd
            .sdo_read::<heapless08::Vec<u8, 8>>(index, sub)
            .await
            .map(|b| {
                let mut v = [0u8; 4];
                v.iter_mut().zip(b.iter()).for_each(|(d, s)| *d = *s);
                u32::from_le_bytes(v)
            })
            .map_err(abort_of),
        Step::Controlword(_) => panic!("a controlword needs an OP session"),
    }
}

/// A fresh master brings the drive to PRE-OP and runs `steps` (SDO only).
fn preop_session(segment: Segment, steps: &[Step]) -> (Segment, Vec<Outcome>) {
    block_on(async {
        let (m, transport) = master_for(segment);
        let transport = tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
            .await
            .expect("init to PRE-OP");
        let sd = group.subdevice(md, 0).expect("drive");
        let mut out = Vec::new();
        for step in steps {
            out.push(sdo_step(&sd, *step).await);
        }
        let segment = take_segment(&m);
        drop(group);
        transport.abort();
        (segment, out)
    })
}

/// A fresh master brings the drive to OP in free run (controlword 0: the drive goes to Switch
/// On Disabled) and runs `steps`; the controlword is the first word of the outputs and the
/// statusword the first of the inputs (the profile's default mapping).
fn op_session(segment: Segment, steps: &[Step]) -> (Segment, Vec<Outcome>) {
    block_on(async {
        let (m, transport) = master_for(segment);
        let transport = tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
            .await
            .expect("init to PRE-OP");
        let group = group.into_safe_op(md).await.expect("SAFE-OP");
        let group = group.request_into_op(md).await.expect("request OP");
        let mut in_op = false;
        for _ in 0..100 {
            let r = group.tx_rx(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
            if r.all_op() {
                in_op = true;
                break;
            }
        }
        assert!(in_op, "no OP: {:?}", al_status(md).await);
        let mut out = Vec::new();
        for step in steps {
            let sd = group.subdevice(md, 0).expect("drive");
            out.push(match *step {
                Step::Controlword(cw) => {
                    for _ in 0..SETTLE_CYCLES {
                        sd.outputs_raw_mut()[0..2].copy_from_slice(&cw.to_le_bytes());
                        group.tx_rx(md).await.expect("tx/rx");
                        m.shared.advance(CYCLE_NS);
                    }
                    let inputs = sd.inputs_raw();
                    Ok(u32::from(u16::from_le_bytes([inputs[0], inputs[1]])))
                }
                sdo => sdo_step(&sd, sdo).await,
            });
        }
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let segment = take_segment(&m);
        drop(group);
        transport.abort();
        (segment, out)
    })
}

fn state(outcome: &Outcome) -> u16 {
    (*outcome.as_ref().expect("statusword") as u16) & STATE_MASK
}

// ---------------------------------------------------------------------------------------------
// Σ-V-SD
// ---------------------------------------------------------------------------------------------

/// 2000h Pn000 "Basic Function Select Switch 0": a SERVOPACK parameter (1010h sub 4).
const PN000: (u16, u8) = (0x2000, 0);
/// 6065h "Following Error Window": an application parameter (sub 3), default 5242880.
const FOLLOWING_ERROR_WINDOW: (u16, u8) = (0x6065, 0);
const FOLLOWING_ERROR_WINDOW_DEFAULT: u32 = 5_242_880;
/// 2300h "User Parameter Configuration": writable, never stored (§5.1 EEPROM No), default 0.
const USER_PARAMETER_CONFIGURATION: (u16, u8) = (0x2300, 0);
/// 2301h:01 position user unit numerator: stored (sub 3, 23xxh), default 1.
const POSITION_UNIT_NUMERATOR: (u16, u8) = (0x2301, 1);

#[test]
fn sigma_v_sd_sub_4_stores_servopack_parameters_only_in_switch_on_disabled() {
    let (mut s, out) = op_session(
        segment("sigma-v-sd"),
        &[
            Step::Controlword(CW_DISABLE_VOLTAGE),
            Step::Write(PN000.0, PN000.1, V::U16(0x0123)),
            Step::Write(
                FOLLOWING_ERROR_WINDOW.0,
                FOLLOWING_ERROR_WINDOW.1,
                V::U32(1000),
            ),
            Step::Write(STORE, MANUFACTURER, V::U32(SIGNATURE_SAVE)),
            // "Shutdown": Ready to Switch On, sub 1 and sub 4 are refused.
            Step::Controlword(CW_SHUTDOWN),
            Step::Write(STORE, ALL, V::U32(SIGNATURE_SAVE)),
            Step::Write(STORE, MANUFACTURER, V::U32(SIGNATURE_SAVE)),
            Step::Write(RESTORE, ALL, V::U32(SIGNATURE_LOAD)),
            Step::Read(STORE, ALL),
        ],
    );
    assert_eq!(state(&out[0]), SWITCH_ON_DISABLED, "{out:?}");
    assert_eq!(out[3], Ok(0), "sub 4 in Switch On Disabled");
    assert_eq!(state(&out[4]), READY_TO_SWITCH_ON, "{out:?}");
    for refused in &out[5..8] {
        assert_eq!(*refused, Err(ABORT_DEVICE_STATE), "{out:?}");
    }
    assert_eq!(out[8], Ok(1), "1010h:01 reads its capabilities again");
    assert_eq!(storage_writes(&s), 1, "only the sub 4 store was written");

    power_cycle(&mut s);
    let (_, out) = preop_session(
        s,
        &[
            Step::Read(PN000.0, PN000.1),
            Step::Read(FOLLOWING_ERROR_WINDOW.0, FOLLOWING_ERROR_WINDOW.1),
        ],
    );
    assert_eq!(out[0], Ok(0x0123), "2000h stored by sub 4");
    assert_eq!(
        out[1],
        Ok(FOLLOWING_ERROR_WINDOW_DEFAULT),
        "6065h is not in sub 4"
    );
}

#[test]
fn sigma_v_sd_2300h_is_not_kept_by_store_all() {
    let (mut s, out) = op_session(
        segment("sigma-v-sd"),
        &[
            Step::Controlword(CW_DISABLE_VOLTAGE),
            Step::Write(
                USER_PARAMETER_CONFIGURATION.0,
                USER_PARAMETER_CONFIGURATION.1,
                V::U32(1),
            ),
            Step::Write(
                POSITION_UNIT_NUMERATOR.0,
                POSITION_UNIT_NUMERATOR.1,
                V::U32(3),
            ),
            Step::Write(STORE, ALL, V::U32(SIGNATURE_SAVE)),
        ],
    );
    assert_eq!(state(&out[0]), SWITCH_ON_DISABLED, "{out:?}");
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    power_cycle(&mut s);
    let (_, out) = preop_session(
        s,
        &[
            Step::Read(
                USER_PARAMETER_CONFIGURATION.0,
                USER_PARAMETER_CONFIGURATION.1,
            ),
            Step::Read(POSITION_UNIT_NUMERATOR.0, POSITION_UNIT_NUMERATOR.1),
        ],
    );
    assert_eq!(out[0], Ok(0), "2300h not stored (§5.1 EEPROM No)");
    assert_eq!(out[1], Ok(3), "2301h:01 stored beside it");
}

// ---------------------------------------------------------------------------------------------
// RSE
// ---------------------------------------------------------------------------------------------

/// 2009h:01 "1st speed proportional gain" (UINT, RxPDO- and TxPDO-mappable), default 4000.
const SPEED_GAIN: (u16, u8) = (0x2009, 1);
/// 6067h "Position reaches threshold" (UDINT, RxPDO-mappable), default 92.
const POSITION_WINDOW: (u16, u8) = (0x6067, 0);
/// 6065h (UDINT, RxPDO-mappable): saved only by P12.20, not by 1010h; default 393216.
const RSE_FOLLOWING_ERROR_WINDOW: (u16, u8) = (0x6065, 0);
const RSE_FOLLOWING_ERROR_WINDOW_DEFAULT: u32 = 393_216;
/// 607Ah target position (process data), default 0.
const TARGET_POSITION: (u16, u8) = (0x607A, 0);

#[test]
fn rse_store_keeps_pdo_mappable_parameters_but_not_6065h_nor_commands() {
    let (mut s, out) = preop_session(
        segment("rse"),
        &[
            Step::Write(SPEED_GAIN.0, SPEED_GAIN.1, V::U16(4321)),
            Step::Write(POSITION_WINDOW.0, POSITION_WINDOW.1, V::U32(77)),
            Step::Write(
                RSE_FOLLOWING_ERROR_WINDOW.0,
                RSE_FOLLOWING_ERROR_WINDOW.1,
                V::U32(1000),
            ),
            Step::Write(TARGET_POSITION.0, TARGET_POSITION.1, V::I32(5000)),
            Step::Write(STORE, ALL, V::U32(SIGNATURE_SAVE)),
        ],
    );
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    power_cycle(&mut s);
    let (_, out) = preop_session(
        s,
        &[
            Step::Read(SPEED_GAIN.0, SPEED_GAIN.1),
            Step::Read(POSITION_WINDOW.0, POSITION_WINDOW.1),
            Step::Read(RSE_FOLLOWING_ERROR_WINDOW.0, RSE_FOLLOWING_ERROR_WINDOW.1),
            Step::Read(TARGET_POSITION.0, TARGET_POSITION.1),
        ],
    );
    assert_eq!(out[0], Ok(4321), "2009h:01 (PDO-mappable parameter) stored");
    assert_eq!(out[1], Ok(77), "6067h (PDO-mappable parameter) stored");
    assert_eq!(
        out[2],
        Ok(RSE_FOLLOWING_ERROR_WINDOW_DEFAULT),
        "6065h not stored by 1010h"
    );
    assert_eq!(out[3], Ok(0), "607Ah (command) not stored");
}

// ---------------------------------------------------------------------------------------------
// GHA-E
// ---------------------------------------------------------------------------------------------

/// 607Dh:01 minimum position limit (DINT, PDO-mappable), saved on SDO download; default
/// -2000000000.
const MIN_POSITION_LIMIT: (u16, u8) = (0x607D, 1);
const MIN_POSITION_LIMIT_DEFAULT: i32 = -2_000_000_000;
/// 2001h:01 Pn100, 2001h:02 Pn101 (UINT, PDO-mappable), default 0.
const PN100: (u16, u8) = (0x2001, 1);
const PN101: (u16, u8) = (0x2001, 2);
/// 2000h:2Fh Pn-046 "SDO parameter store selection": 1 = do not save SDO writes of 2000h-2005h.
const PN046: (u16, u8) = (0x2000, 0x2F);
const DO_NOT_SAVE: u16 = 1;

#[test]
fn gha_e_sdo_downloads_are_saved_without_1010h_unless_pn046_is_1() {
    let (mut s, out) = preop_session(
        segment("gha-e"),
        &[
            Step::Read(STORE, ALL),
            Step::Write(MIN_POSITION_LIMIT.0, MIN_POSITION_LIMIT.1, V::I32(-1000)),
            Step::Write(PN100.0, PN100.1, V::U16(77)),
        ],
    );
    assert_eq!(out[0], Ok(3), "1010h:01: saves on command and autonomously");
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    assert_eq!(storage_writes(&s), 2, "one record per download, no 1010h");
    power_cycle(&mut s);
    let (mut s, out) = preop_session(
        s,
        &[
            Step::Read(MIN_POSITION_LIMIT.0, MIN_POSITION_LIMIT.1),
            Step::Read(PN100.0, PN100.1),
            // Pn-046 = 1: the next Pn download is not saved (nor is Pn-046 itself).
            Step::Write(PN046.0, PN046.1, V::U16(DO_NOT_SAVE)),
            Step::Write(PN101.0, PN101.1, V::U16(55)),
            Step::Read(PN101.0, PN101.1),
        ],
    );
    assert_eq!(out[0], Ok(-1000i32 as u32), "607Dh:01 kept");
    assert_eq!(out[1], Ok(77), "Pn100 kept");
    assert!(out[2..4].iter().all(Result::is_ok), "{out:?}");
    assert_eq!(out[4], Ok(55), "written, only not saved");
    power_cycle(&mut s);
    let (_, out) = preop_session(
        s,
        &[
            Step::Read(PN101.0, PN101.1),
            Step::Read(PN046.0, PN046.1),
            Step::Read(PN100.0, PN100.1),
        ],
    );
    assert_eq!(out[0], Ok(0), "Pn101 not saved while Pn-046 = 1");
    assert_eq!(out[1], Ok(0), "Pn-046 = 1 is not saved either");
    assert_eq!(out[2], Ok(77), "earlier saves stay");
}

/// GHA-E: a PDO write to an auto-saved entry is never stored. 1600h is remapped in PRE-OP to
/// carry 607Dh:01 after the controlword, the drive runs in OP with DC SYNC0 (its only mode) and
/// the outputs write 607Dh:01.
#[test]
fn gha_e_a_pdo_write_to_607dh_is_never_stored() {
    const RX_MAPPING: u16 = 0x1600;
    const RX_ASSIGN: u16 = 0x1C12;
    const CONTROLWORD_ENTRY: u32 = 0x6040_0010;
    const MIN_LIMIT_ENTRY: u32 = 0x607D_0120;
    const PDO_VALUE: i32 = -4242;
    let (mut s, writes) = block_on(async {
        let (m, transport) = master_for(segment("gha-e"));
        let transport = tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
            .await
            .expect("init to PRE-OP");
        {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(RX_ASSIGN, 0, 0u8).await.expect("1C12h:00 = 0");
            sd.sdo_write(RX_MAPPING, 0, 0u8)
                .await
                .expect("1600h:00 = 0");
            sd.sdo_write(RX_MAPPING, 1, CONTROLWORD_ENTRY)
                .await
                .expect("1600h:01");
            sd.sdo_write(RX_MAPPING, 2, MIN_LIMIT_ENTRY)
                .await
                .expect("1600h:02");
            sd.sdo_write(RX_MAPPING, 0, 2u8)
                .await
                .expect("1600h:00 = 2");
            sd.sdo_write(RX_ASSIGN, 1, RX_MAPPING)
                .await
                .expect("1C12h:01");
            sd.sdo_write(RX_ASSIGN, 0, 1u8).await.expect("1C12h:00 = 1");
        }
        let writes_after_mapping = storage_writes(&m.shared.segment());
        let group = tests_host::dc_safe_op(&m, md, group, CYCLE_NS)
            .await
            .expect("SAFE-OP");
        let group = group.request_into_op(md).await.expect("request OP");
        let mut in_op = false;
        for _ in 0..1000 {
            {
                let sd = group.subdevice(md, 0).expect("drive");
                let mut out = sd.outputs_raw_mut();
                out[0..2].copy_from_slice(&0u16.to_le_bytes());
                out[2..6].copy_from_slice(&PDO_VALUE.to_le_bytes());
            }
            let r = group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
            if r.all_op() {
                in_op = true;
                break;
            }
        }
        assert!(in_op, "no OP: {:?}", al_status(md).await);
        for _ in 0..SETTLE_CYCLES {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
        }
        let sd = group.subdevice(md, 0).expect("drive");
        let value: i32 = sd
            .sdo_read(MIN_POSITION_LIMIT.0, MIN_POSITION_LIMIT.1)
            .await
            .expect("607Dh:01");
        assert_eq!(value, PDO_VALUE, "the PDO wrote 607Dh:01");
        let writes = storage_writes(&m.shared.segment()) - writes_after_mapping;
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let s = take_segment(&m);
        drop(group);
        transport.abort();
        (s, writes)
    });
    assert_eq!(writes, 0, "a PDO write stores nothing");
    power_cycle(&mut s);
    let (_, out) = preop_session(s, &[Step::Read(MIN_POSITION_LIMIT.0, MIN_POSITION_LIMIT.1)]);
    assert_eq!(
        out[0],
        Ok(MIN_POSITION_LIMIT_DEFAULT as u32),
        "607Dh:01 default again"
    );
}
