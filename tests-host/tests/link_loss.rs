//! The cable between the master and the drive is pulled while the motor turns in OP, then
//! plugged again (ethercrab, DC SYNC0 at 1 ms, cyclic synchronous velocity, standard profile):
//!
//! - without frames the process-data watchdog expires (ET1100 default 100 ms, ETG.1000.6
//!   Table 11): SAFE-OP with the error indication and AL status code 0x001B, raised as an
//!   emergency with the ESM's code A000h and kept in 10F3h;
//! - outputs go to their safe state (ETG.1000.6 §6.4.1: SAFE-OP does not apply outputs): the
//!   drive leaves Operation Enabled and the motor stops;
//! - the DL status shows the lost link of port 0 while the cable is out;
//! - with the cable back the master acknowledges the error, requests OP, and the drive turns
//!   the motor again after the enable sequence.

use ethercrab::{Command, MainDevice};
use tests_host::vendor::{self, DcGroup};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const STATION: u16 = 0x1000;
const AL_CONTROL: u16 = 0x0120;
const AL_STATUS: u16 = 0x0130;
const AL_STATUS_CODE: u16 = 0x0134;
/// AL status (ETG.1000.6 Table 9): SAFE-OP, OP, error indication; AL control acknowledge.
const SAFEOP: u16 = 0x04;
const OP: u16 = 0x08;
const ERROR: u16 = 0x10;
const ACK: u16 = 0x10;
/// ETG.1000.6 Table 11: sync manager watchdog.
const SM_WATCHDOG: u16 = 0x001B;
/// The speed the motor turns at, rev/s.
const SPEED_REV_S: f64 = 10.0;

async fn al(md: &MainDevice<'_>) -> (u16, u16) {
    let status: u16 = Command::fprd(STATION, AL_STATUS)
        .receive(md)
        .await
        .expect("AL status");
    let code: u16 = Command::fprd(STATION, AL_STATUS_CODE)
        .receive(md)
        .await
        .expect("AL status code");
    (status, code)
}

/// `n` cycles at `cw` and the target speed; the last statusword.
async fn cycles(
    m: &board_sim::inproc::InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    cws: impl IntoIterator<Item = u16>,
    target: i32,
) -> u16 {
    let mut sw = 0;
    for cw in cws {
        let inputs = vendor::exchange_dc_command(m, md, group, (cw, CSV, target), CYCLE_NS).await;
        sw = vendor::u16_at(&inputs, 0);
    }
    sw
}

#[test]
fn link_loss_in_op_stops_the_motor_and_the_drive_runs_again_after_recovery() {
    let profile = od_gen::builtin("standard").expect("profile");
    let target = units::target_velocity(&profile, SPEED_REV_S);
    block_on(async {
        let segment = board_sim::Segment::new("standard", 1).expect("profile");
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CSV, CYCLE_NS).await;
        let sw = cycles(&m, md, &group, vendor::enable_sequence(1_000), target).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "enabled: {sw:#06x}"
        );
        let (rpm, _) = vendor::motor(&m);
        assert!(
            (rpm / 60.0 - SPEED_REV_S).abs() < 0.5,
            "at speed: {rpm} rpm"
        );

        // The cable is pulled for 1.5 s.
        m.shared.segment().set_master_cable(false);
        let drive = |m: &board_sim::inproc::InProcess| {
            let s = m.shared.segment();
            let d = &s.drives()[0];
            (d.esc.port0_connected(), d.servos[0].latched().gates)
        };
        assert!(!drive(&m).0, "port 0 without link");
        m.shared.advance(1_500_000_000);
        let (rpm, _) = vendor::motor(&m);
        assert!(
            rpm.abs() < 6.0,
            "the motor stopped without the master: {rpm} rpm"
        );
        assert!(!drive(&m).1, "bridge off");

        // Plugged again: the master finds the drive in SAFE-OP with the watchdog error.
        m.shared.segment().set_master_cable(true);
        assert_eq!(al(md).await, (SAFEOP | ERROR, SM_WATCHDOG));
        let sd = group.subdevice(md, 0).expect("drive");
        let register: u8 = sd.sdo_read(0x1001, 0).await.expect("1001h");
        assert_ne!(register & 0x11, 0, "1001h: generic + communication error");
        let newest: u8 = sd.sdo_read(0x10F3, 2).await.expect("10F3h:02");
        let msg = sd
            .sdo_read::<[u8; 28]>(0x10F3, newest)
            .await
            .expect("message");
        assert_eq!(
            msg[..4],
            [0x00, 0xE8, 0x00, 0xA0],
            "10F3h: the ESM's error A000h"
        );
        assert_eq!(
            msg[16..20],
            [0x06, 0x00, 0x1B, 0x00],
            "10F3h: UNSIGNED16 AL status code 0x001B"
        );

        // Recovery: acknowledge, back to OP, enable, turn.
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, SAFEOP | ACK)
            .await
            .expect("acknowledge");
        assert_eq!(al(md).await, (SAFEOP, 0), "acknowledged");
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, OP)
            .await
            .expect("request OP");
        let sw = cycles(&m, md, &group, std::iter::repeat_n(0, 20), 0).await;
        assert_eq!(al(md).await, (OP, 0), "OP again (statusword {sw:#06x})");
        let sw = cycles(&m, md, &group, vendor::enable_sequence(1_000), target).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "enabled again: {sw:#06x}"
        );
        let (rpm, _) = vendor::motor(&m);
        assert!(
            (rpm / 60.0 - SPEED_REV_S).abs() < 0.5,
            "at speed again: {rpm} rpm"
        );
        assert!(drive(&m).1, "bridge on");
    });
}
