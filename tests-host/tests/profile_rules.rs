//! Profile rules (DESIGN.md §4: behaviour that differs between profiles is data in the profile
//! file) under a real master (ethercrab, in process):
//!
//! - `[pdo] sdo_write_to_rx_mapped = "blocked"` (standard): an SDO download to an entry of the
//!   active RxPDO mapping is aborted with 0x06010006 in OP and served in PREOP;
//! - `[sync] cycle_step_ns` (standard: 31.25 µs): a SYNC0 cycle in range but not a multiple is
//!   refused with AL status code 0x0036;
//! - `[esm] op_exit_while_enabled_error`: absent in the standard profile (leaving OP while
//!   Operation Enabled only disables the drive); set in a variant of it, the drive raises the
//!   error (603Fh, 1001h, EMCY) and goes to the PDS Fault state.

use std::time::Duration;

use board_sim::drive::SimDrive;
use board_sim::Segment;
use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{DcSync, MainDevice};
use tests_host::{al_status, block_on, master, master_for};

const CYCLE_NS: u64 = 1_000_000;
const CONTROLWORD: u16 = 0x6040;
const STATUSWORD: u16 = 0x6041;
const ERROR_CODE: u16 = 0x603F;
const ERROR_REGISTER: u16 = 0x1001;
/// AL status SAFEOP, error indication bit (ETG.1000.6 Table 9).
const SAFEOP: u16 = 0x04;
const ERROR: u16 = 0x10;
/// CiA402 statusword masks/values (Table 30): Operation Enabled, Fault, Switch On Disabled.
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const FAULT_MASK: u16 = 0x4F;
const FAULT: u16 = 0x08;
const SWITCH_ON_DISABLED: u16 = 0x40;
/// The error the profile variant raises (CiA402 / CiA 301 0x8700: sync controller).
const OP_EXIT_ERROR: u16 = 0x8700;

fn abort_code(e: Error) -> CoeAbortCode {
    match e {
        Error::Mailbox(MailboxError::Aborted { code, .. }) => code,
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

#[test]
fn sdo_download_to_an_rx_mapped_object_is_blocked_in_op_and_served_in_preop() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(CONTROLWORD, 0, 0x0006u16)
                .await
                .expect("PREOP: no PDO runs, the download is served");
            assert_eq!(sd.sdo_read::<u16>(CONTROLWORD, 0).await.unwrap(), 0x0006);
        }
        let group = into_op(&m, group).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let e = sd
            .sdo_write(CONTROLWORD, 0, 0x000Fu16)
            .await
            .expect_err("6040h is mapped in 1600h, assigned in 1C12h");
        assert_eq!(abort_code(e), CoeAbortCode::DownloadBlocked, "0x06010006");
        // Not mapped (RxPDO-mappable only through remapping): served in OP.
        sd.sdo_write(0x2F00, 0, 0x1234_5678u32)
            .await
            .expect("a parameter that is not process data");
    });
}

#[test]
fn sync0_cycle_not_a_multiple_of_the_cycle_step_is_refused_with_0x36() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let mut group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        for mut sd in group.iter_mut(md) {
            sd.set_dc_sync(DcSync::Sync0);
        }
        let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
        // 1 ms + 1 µs: inside 31.25 µs .. 10 ms, not a multiple of 31.25 µs.
        let group = group
            .configure_dc_sync(
                md,
                DcConfiguration {
                    start_delay: Duration::from_millis(5),
                    sync0_period: Duration::from_nanos(1_001_000),
                    sync0_shift: Duration::ZERO,
                },
            )
            .await
            .expect("DC");
        assert!(group.into_safe_op(md).await.is_err(), "SAFE-OP refused");
        let (status, code) = al_status(md).await;
        assert_eq!((status & ERROR, code), (ERROR, 0x0036), "DcSync0CycleTime");
    });
}

type OpGroup =
    ethercrab::SubDeviceGroup<4, 64, ethercrab::DefaultLock, ethercrab::subdevice_group::Op>;

/// PRE-OP → SAFE-OP → OP in free run, cycling process data until the drive is in OP (it
/// enters OP only after the first outputs).
async fn into_op(
    m: &board_sim::inproc::InProcess,
    group: ethercrab::SubDeviceGroup<
        4,
        64,
        ethercrab::DefaultLock,
        ethercrab::subdevice_group::PreOp,
    >,
) -> OpGroup {
    let md = &*m.maindevice;
    let group = group.into_safe_op(md).await.expect("SAFE-OP");
    let group = group.request_into_op(md).await.expect("request OP");
    for _ in 0..100 {
        let r = group.tx_rx(md).await.expect("tx/rx");
        m.shared.advance(CYCLE_NS);
        if r.all_op() {
            return group;
        }
    }
    panic!("no OP after 100 cycles: {:?}", al_status(md).await);
}

/// Into OP in free run, then Operation Enabled through the controlword.
async fn enable_in_op(m: &board_sim::inproc::InProcess) -> OpGroup {
    let md = &*m.maindevice;
    let group = md
        .init_single_group::<4, 64>(m.shared.clock().now_fn())
        .await
        .expect("init");
    let group = into_op(m, group).await;
    let sd = group.subdevice(md, 0).expect("drive");
    let mut statusword = 0;
    for i in 0..30u32 {
        let cw: u16 = match i {
            0..=9 => 0x06,
            10..=19 => 0x07,
            _ => 0x0F,
        };
        sd.outputs_raw_mut()[0..2].copy_from_slice(&cw.to_le_bytes());
        group.tx_rx(md).await.expect("tx/rx");
        m.shared.advance(CYCLE_NS);
        let inp = sd.inputs_raw();
        statusword = u16::from_le_bytes([inp[0], inp[1]]);
    }
    assert_eq!(statusword & STATE_MASK, OPERATION_ENABLED);
    group
}

#[test]
fn standard_profile_leaving_op_while_enabled_only_disables() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = enable_in_op(&m).await;
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let sd = group.subdevice(md, 0).expect("drive");
        let sw: u16 = sd.sdo_read(STATUSWORD, 0).await.expect("6041h");
        assert_eq!(sw & FAULT_MASK, SWITCH_ON_DISABLED, "disabled, no fault");
        assert_eq!(sd.sdo_read::<u16>(ERROR_CODE, 0).await.unwrap(), 0);
        assert_eq!(sd.sdo_read::<u8>(ERROR_REGISTER, 0).await.unwrap(), 0);
        assert_eq!(al_status(md).await, (SAFEOP, 0));
    });
}

#[test]
fn profile_error_on_leaving_op_while_enabled_faults_the_drive() {
    block_on(async {
        // The standard profile with `[esm] op_exit_while_enabled_error = 0x8700`.
        let mut segment = Segment::new("standard", 1).expect("segment");
        let mut profile = firmware::profiles::standard::PROFILE;
        profile.od.device.esm.op_exit_while_enabled_error =
            Some(ethercat_slave::od::ErrorReport::code(OP_EXIT_ERROR));
        let profile = Box::leak(Box::new(profile));
        let sii = od_gen::builtin("standard").expect("standard").sii_image();
        let mut drive = SimDrive::new(profile, &sii).expect("drive");
        drive.esc.set_port_connected(1, false);
        segment.drives_mut()[0] = drive;

        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = enable_in_op(&m).await;
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let sd = group.subdevice(md, 0).expect("drive");
        let sw: u16 = sd.sdo_read(STATUSWORD, 0).await.expect("6041h");
        assert_eq!(sw & FAULT_MASK, FAULT, "PDS Fault, statusword bit 3");
        assert_eq!(
            sd.sdo_read::<u16>(ERROR_CODE, 0).await.unwrap(),
            OP_EXIT_ERROR
        );
        let register: u8 = sd.sdo_read(ERROR_REGISTER, 0).await.unwrap();
        assert_ne!(register & 0x01, 0, "1001h generic error");
        assert_ne!(register & 0x20, 0, "1001h device profile error");
        // The ESM itself is fine: the fault is the drive's, not the communication's.
        assert_eq!(al_status(md).await, (SAFEOP, 0));

        // Back in OP, a fault reset (controlword bit 7 rising edge, CiA402) clears the fault,
        // 603Fh and 1001h (CiA 301: the error-reset EMCY follows when the last error clears).
        let group = group.request_into_op(md).await.expect("request OP");
        for cw in [0x0000u16, 0x0000, 0x0080, 0x0080, 0x0000] {
            group.subdevice(md, 0).expect("drive").outputs_raw_mut()[0..2]
                .copy_from_slice(&cw.to_le_bytes());
            group.tx_rx(md).await.expect("tx/rx");
            m.shared.advance(1_000_000);
        }
        let sd = group.subdevice(md, 0).expect("drive");
        let sw: u16 = sd.sdo_read(STATUSWORD, 0).await.expect("6041h");
        assert_eq!(
            sw & FAULT_MASK,
            SWITCH_ON_DISABLED,
            "fault reset → switch on disabled"
        );
        assert_eq!(
            sd.sdo_read::<u16>(ERROR_CODE, 0).await.unwrap(),
            0,
            "603Fh cleared"
        );
        assert_eq!(
            sd.sdo_read::<u8>(ERROR_REGISTER, 0).await.unwrap(),
            0,
            "1001h cleared"
        );
    });
}
