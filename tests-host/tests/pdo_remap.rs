//! Dynamic PDO mapping under a real master (ethercrab, in process): the ETG sequence "SI0 = 0,
//! edit, SI0 = n" in PRE-OP for several mappings the standard profile allows (subsets, other
//! orders, padding, every mappable object), checked through the process data that flows in OP;
//! and the mappings and edits the profile refuses, with their SDO abort codes.

use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::{MainDevice, SubDeviceRef};
use tests_host::{block_on, master};

const RX_ASSIGN: u16 = 0x1C12;
const TX_ASSIGN: u16 = 0x1C13;
const RXPDO: u16 = 0x1600;
const TXPDO: u16 = 0x1A00;
const CYCLE_NS: u64 = 1_000_000;
/// Cycles of each remapping run: enabling (cycles 20..) takes the offset calibration (6.4 ms)
/// and the motor's catch-up to the target, the rest shows it following.
const CYCLES: u32 = 80;
/// Following error allowed at the end of the run, increments (2^20 per revolution): the ramp
/// crawls at 1 increment per ms, where the Coulomb friction makes the cascade stick and slip
/// (bound of boards/sim/tests/motor_speed_position.rs at standstill).
const FOLLOWING_TOLERANCE: i32 = 150;
/// Modes of operation 6060h: cyclic synchronous position.
const MODE_CSP: u8 = 8;

/// One mapping entry (CiA 301 §7.4.7.1): index, subindex, bit length.
#[derive(Clone, Copy)]
struct Map(u16, u8, u8);

impl Map {
    fn value(self) -> u32 {
        (u32::from(self.0) << 16) | (u32::from(self.1) << 8) | u32::from(self.2)
    }
}

const CONTROLWORD: Map = Map(0x6040, 0, 16);
const TARGET: Map = Map(0x607A, 0, 32);
const MODE: Map = Map(0x6060, 0, 8);
const STATUSWORD: Map = Map(0x6041, 0, 16);
const ACTUAL: Map = Map(0x6064, 0, 32);
const MODE_DISPLAY: Map = Map(0x6061, 0, 8);
const ERROR_REGISTER: Map = Map(0x1001, 0, 8);
const ERROR_CODE: Map = Map(0x603F, 0, 16);
const fn pad(bits: u8) -> Map {
    Map(0x0000, 0, bits)
}

/// Writes a mapping with the ETG sequence: assignment SI0 = 0, mapping SI0 = 0, entries,
/// mapping SI0 = n, assignment entry, assignment SI0 = 1.
async fn remap<S>(
    sd: &SubDeviceRef<'_, S>,
    assign: u16,
    pdo: u16,
    entries: &[Map],
) -> Result<(), Error>
where
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    sd.sdo_write(assign, 0, 0u8).await?;
    sd.sdo_write(pdo, 0, 0u8).await?;
    for (i, e) in entries.iter().enumerate() {
        sd.sdo_write(pdo, i as u8 + 1, e.value()).await?;
    }
    sd.sdo_write(pdo, 0, entries.len() as u8).await?;
    sd.sdo_write(assign, 1, pdo).await?;
    sd.sdo_write(assign, 0, 1u8).await?;
    Ok(())
}

fn abort_code(e: Error) -> CoeAbortCode {
    match e {
        Error::Mailbox(MailboxError::Aborted { code, .. }) => code,
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

fn bytes(entries: &[Map]) -> usize {
    entries
        .iter()
        .map(|e| usize::from(e.2))
        .sum::<usize>()
        .div_ceil(8)
}

/// Byte offset of `m` in a mapping.
fn offset(entries: &[Map], m: Map) -> usize {
    let bits: usize = entries
        .iter()
        .take_while(|e| e.0 != m.0)
        .map(|e| usize::from(e.2))
        .sum();
    bits / 8
}

/// Maps `rx`/`tx`, goes to OP in free run, enables the drive through the controlword at its
/// mapped offset and checks statusword and position actual at theirs.
async fn run_mapping(rx: &[Map], tx: &[Map]) {
    let (m, transport) = master();
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group = md
        .init_single_group::<4, 64>(m.shared.clock().now_fn())
        .await
        .expect("init");
    {
        let sd = group.subdevice(md, 0).expect("drive");
        remap(&sd, RX_ASSIGN, RXPDO, rx)
            .await
            .expect("RxPDO mapping accepted");
        remap(&sd, TX_ASSIGN, TXPDO, tx)
            .await
            .expect("TxPDO mapping accepted");
        let n: u8 = sd.sdo_read(RXPDO, 0).await.expect("1600:00");
        assert_eq!(usize::from(n), rx.len());
        for (i, e) in rx.iter().enumerate() {
            assert_eq!(
                sd.sdo_read::<u32>(RXPDO, i as u8 + 1).await.expect("entry"),
                e.value()
            );
        }
    }
    let group = group
        .into_safe_op(md)
        .await
        .expect("SAFE-OP with the new mapping");
    let group = group.request_into_op(md).await.expect("request OP");
    let sd = group.subdevice(md, 0).expect("drive");
    assert_eq!(
        sd.outputs_raw().len(),
        bytes(rx),
        "SM2 length follows the RxPDO mapping"
    );
    assert_eq!(
        sd.inputs_raw().len(),
        bytes(tx),
        "SM3 length follows the TxPDO mapping"
    );
    let has_cw = rx.iter().any(|e| e.0 == CONTROLWORD.0);
    let has_target = rx.iter().any(|e| e.0 == TARGET.0);
    let mut last_target = 0i32;
    let mut statusword = 0u16;
    let mut actual = 0i32;
    for i in 0..CYCLES {
        let cw: u16 = match i {
            0..=9 => 0x06,
            10..=19 => 0x07,
            _ => 0x0F,
        };
        let target = 1000 + i as i32;
        {
            let mut out = sd.outputs_raw_mut();
            if has_cw {
                let o = offset(rx, CONTROLWORD);
                out[o..o + 2].copy_from_slice(&cw.to_le_bytes());
            }
            if has_target {
                let o = offset(rx, TARGET);
                out[o..o + 4].copy_from_slice(&target.to_le_bytes());
            }
            if rx.iter().any(|e| e.0 == MODE.0) {
                out[offset(rx, MODE)] = MODE_CSP;
            }
        }
        group.tx_rx(md).await.expect("tx/rx");
        m.shared.advance(CYCLE_NS);
        let inp = sd.inputs_raw();
        if tx.iter().any(|e| e.0 == STATUSWORD.0) {
            let o = offset(tx, STATUSWORD);
            statusword = u16::from_le_bytes([inp[o], inp[o + 1]]);
        }
        if tx.iter().any(|e| e.0 == ACTUAL.0) {
            let o = offset(tx, ACTUAL);
            actual = i32::from_le_bytes(inp[o..o + 4].try_into().expect("4 bytes"));
        }
        if i == CYCLES - 1 {
            last_target = target;
        }
    }
    if has_cw && tx.iter().any(|e| e.0 == STATUSWORD.0) {
        assert_eq!(
            statusword & 0x6F,
            0x27,
            "operation enabled through the remapped controlword"
        );
    }
    if has_cw && has_target && tx.iter().any(|e| e.0 == ACTUAL.0) {
        // The motor (CSP, the profile's default mode) follows the 1-increment-per-cycle ramp
        // one to four cycles late (interpolation, input latency), plus a few increments of
        // following error.
        assert!(
            (last_target - 4 - FOLLOWING_TOLERANCE..=last_target + FOLLOWING_TOLERANCE)
                .contains(&actual),
            "position actual {actual} follows the remapped target {last_target}"
        );
    }
}

#[test]
fn default_layout_rewritten_explicitly() {
    block_on(run_mapping(
        &[CONTROLWORD, TARGET, MODE],
        &[STATUSWORD, ACTUAL, MODE_DISPLAY],
    ));
}

#[test]
fn reordered_entries() {
    block_on(run_mapping(
        &[TARGET, MODE, CONTROLWORD],
        &[ACTUAL, MODE_DISPLAY, STATUSWORD],
    ));
}

#[test]
fn minimal_mapping() {
    block_on(run_mapping(&[CONTROLWORD], &[STATUSWORD]));
}

#[test]
fn padding_entries() {
    block_on(run_mapping(
        &[CONTROLWORD, pad(8), TARGET, pad(8)],
        &[STATUSWORD, pad(16), ACTUAL],
    ));
}

#[test]
fn every_mappable_object() {
    block_on(run_mapping(
        &[CONTROLWORD, TARGET, MODE],
        &[STATUSWORD, ACTUAL, MODE_DISPLAY, ERROR_REGISTER, ERROR_CODE],
    ));
}

#[test]
fn refused_edits_get_their_abort_codes() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let sd = group.subdevice(md, 0).expect("drive");
        // Editing an entry while SI0 ≠ 0 (ETG.1000.6: "SI0 must be 0").
        let e = sd
            .sdo_write(RXPDO, 1, TARGET.value())
            .await
            .expect_err("SI0 is 3");
        assert_eq!(abort_code(e), CoeAbortCode::IndexOnly, "0x06010003");
        sd.sdo_write(RXPDO, 0, 0u8).await.expect("SI0 = 0");
        // A TxPDO-only object in an RxPDO, a wrong bit length, a missing object.
        for bad in [STATUSWORD, Map(0x6040, 0, 32), Map(0x2FFF, 0, 16)] {
            let e = sd
                .sdo_write(RXPDO, 1, bad.value())
                .await
                .expect_err("not mappable");
            assert_eq!(
                abort_code(e),
                CoeAbortCode::PdoMappingFailed,
                "{:#010x}",
                bad.value()
            );
        }
        // More entries than the object has (16 per PDO in the standard profile).
        let e = sd.sdo_write(RXPDO, 0, 17u8).await.expect_err("17 entries");
        assert_eq!(abort_code(e), CoeAbortCode::ValueTooLarge);
        // Assigning a TxPDO to the RxPDO assignment.
        sd.sdo_write(RX_ASSIGN, 0, 0u8).await.expect("1C12:0 = 0");
        let e = sd
            .sdo_write(RX_ASSIGN, 1, TXPDO)
            .await
            .expect_err("1A00h is not an RxPDO");
        assert_eq!(abort_code(e), CoeAbortCode::ValueOutOfRange);
        // The refused edits left the device usable: restore and reach SAFE-OP.
        remap(&sd, RX_ASSIGN, RXPDO, &[CONTROLWORD, TARGET, MODE])
            .await
            .expect("restore");
        let group = group.into_safe_op(md).await.expect("SAFE-OP");
        // Mapping objects are writable in PRE-OP only.
        let sd = group.subdevice(md, 0).expect("drive");
        let e = sd.sdo_write(RXPDO, 0, 0u8).await.expect_err("SAFE-OP");
        assert_eq!(abort_code(e), CoeAbortCode::InvalidState, "0x08000022");
    });
}
