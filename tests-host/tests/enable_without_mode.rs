//! Enable operation with no mode of operation selected (6060h = 0), in every profile, end to
//! end (ethercrab, DC SYNC0 at 1 ms; 6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch mapped):
//!
//! | profile | reaction | manual |
//! |---|---|---|
//! | gha-e | Fault, alarm Co01 (603Fh FF05h) | §5.3.2, §6.1 |
//! | sdv3-e, osd-g-e | Fault, alarm oPE (603Fh 8800h) | §5.2 9 (OSD-G-E §5.2) |
//! | standard, rse, sigma-v-sd | Operation Enabled, the motor held (CiA402 names no error) | CiA402; 7.3; §4.7 |
//!
//! Each fault also sends the alarm's emergency.

use ethercrab::MainDevice;
use tests_host::vendor::{self, DcGroup};
use tests_host::{block_on, cia402, emcy, master_for};

const CYCLE_NS: u64 = 1_000_000;
const NO_MODE: i8 = 0;

async fn cycle(
    m: &board_sim::inproc::InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    cw: u16,
) -> u16 {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, NO_MODE, 0), CYCLE_NS).await;
    vendor::u16_at(&inputs, 0)
}

/// Enables a drive of `name` with 6060h = 0; `error`: the 603Fh the manual names, or `None`
/// for a drive that enables.
fn enable_without_mode(name: &str, error: Option<u16>) {
    let profile = od_gen::builtin(name).expect("profile");
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), NO_MODE, CYCLE_NS).await;
        let mut emergency = None;
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            sw = cycle(&m, md, &group, cw).await;
            if let Some(e) = emcy::read(md, profile.sm.mailbox_in.start)
                .await
                .expect("a CoE emergency")
            {
                emergency.get_or_insert(e);
            }
        }
        match error {
            None => {
                assert!(
                    cia402::is(sw, cia402::OPERATION_ENABLED),
                    "{name}: enabled without a mode: {sw:#06x}"
                );
                assert_eq!(emergency, None, "{name}: no emergency");
            }
            Some(code) => {
                assert!(cia402::is(sw, cia402::FAULT), "{name}: Fault: {sw:#06x}");
                let sd = group.subdevice(md, 0).expect("drive");
                let error_code: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
                assert_eq!(error_code, code, "{name}: 603Fh");
                let e = emergency.expect("an emergency");
                assert_eq!(e.code, code, "{name}: EMCY code");
            }
        }
    });
}

#[test]
fn standard_enables_without_a_mode_and_holds() {
    enable_without_mode("standard", None);
}

#[test]
fn gha_e_enable_operation_without_a_mode_is_co01() {
    enable_without_mode("gha-e", Some(0xFF05));
}

#[test]
fn rse_enables_without_a_mode_and_holds() {
    enable_without_mode("rse", None);
}

#[test]
fn sdv3_e_enable_operation_without_a_mode_is_ope() {
    enable_without_mode("sdv3-e", Some(0x8800));
}

#[test]
fn osd_g_e_enable_operation_without_a_mode_is_ope() {
    enable_without_mode("osd-g-e", Some(0x8800));
}

#[test]
fn sigma_v_sd_enables_without_a_mode_and_holds() {
    enable_without_mode("sigma-v-sd", None);
}
