//! Bus faults under ethercrab (in process, DC SYNC0, standard profile).
//!
//! **Link loss.** The cable between the master and the drive is pulled while the motor turns in
//! OP (1 ms, cyclic synchronous velocity), then plugged again:
//!
//! - without frames the process-data watchdog expires (ET1100 default 100 ms, ETG.1000.6
//!   Table 11): SAFE-OP with the error indication and AL status code 0x001B, raised as an
//!   emergency with the ESM's code A000h and kept in 10F3h;
//! - outputs go to their safe state (ETG.1000.6 §6.4.1: SAFE-OP does not apply outputs): the
//!   drive leaves Operation Enabled and the motor stops;
//! - the DL status shows the lost link of port 0 while the cable is out;
//! - with the cable back the master acknowledges the error, requests OP, and the drive turns
//!   the motor again after the enable sequence.
//!
//! **A motor fault while the bus is faulted.** The DC link rises over its limit while the cable
//! is out: with the cable back the master finds both, the ESM's 0x001B and the drive's Fault with
//! the over-voltage's 603Fh, each with its emergency in 1001h; with the voltage back and both
//! acknowledged (AL error acknowledge, fault reset) the drive runs again.
//!
//! **Clock drift.** Three Σ-V-SD drives (the profile that counts a SYNC0 without new outputs,
//! §4.4 (4): +3 per miss, −1 per good cycle, SAFE-OP with A.A12 at 10F1h:02) whose local clocks
//! run 50 ppm apart from power-on times seconds apart, the master's frames at the DC-aligned
//! time ethercrab computes, SYNC0 half a cycle later (ethercrab's SYNC0 shift): for 20 000
//! cycles of 250 µs no cycle misses its outputs (1C32h:0C "SM2 event miss count" stays 0),
//! every drive stays in OP and follows its CSV set-point, and the drift compensation holds the
//! drives' system times (so their SYNC0s) within 1 µs of the reference's. The clocks are 25 ppm
//! either side, the ET1100's crystal tolerance.
//!
//! **Jitter.** The same line with each frame leaving up to a fifth of the cycle (50 µs) before
//! or after its DC-aligned time, as a master on a loaded non-real-time PC does, and each drive
//! serving SYNC0 up to 8 % of the cycle (20 µs) late, as interrupt latency does: SYNC0 comes
//! from the drives' clocks, not from the frames, so the outputs still arrive once per SYNC0
//! interval, the control loop's PLL follows the latency, and nothing is missed.

use ethercrab::{Command, MainDevice};
use tests_host::vendor::{self, DcGroup};
use tests_host::{al_status, block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const STATION: u16 = 0x1000;
const AL_CONTROL: u16 = hal::esc::regs::AL_CONTROL.addr;
const AL_STATUS: u16 = hal::esc::regs::AL_STATUS.addr;
const AL_STATUS_CODE: u16 = hal::esc::regs::AL_STATUS_CODE.addr;
/// AL status (ETG.1000.6 Table 9): SAFE-OP, OP, error indication; AL control acknowledge.
const SAFEOP: u16 = 0x04;
const OP: u16 = 0x08;
const ERROR: u16 = 0x10;
const ACK: u16 = 0x10;
/// ETG.1000.6 Table 11: sync manager watchdog.
const SM_WATCHDOG: u16 = 0x001B;
/// The speed the motor turns at, rev/s.
const SPEED_REV_S: f64 = 10.0;

/// The motor turns at [`SPEED_REV_S`] (within 0.5 rev/s).
fn assert_at_speed(m: &board_sim::inproc::InProcess, what: &str) {
    let (rpm, _) = vendor::motor(m);
    assert!((rpm / 60.0 - SPEED_REV_S).abs() < 0.5, "{what}: {rpm} rpm");
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

/// The drive in OP (DC, CSV) enabled and commanded to `target`: the master's group.
async fn turning(m: &board_sim::inproc::InProcess, target: i32) -> DcGroup {
    let md: &MainDevice<'_> = &m.maindevice;
    let group = vendor::into_op_dc_velocity(m, md, (0, &[]), CSV, CYCLE_NS).await;
    let sw = cycles(m, md, &group, vendor::enable_sequence(1_000), target).await;
    assert!(
        cia402::is(sw, cia402::OPERATION_ENABLED),
        "enabled: {sw:#06x}"
    );
    group
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
        let group = turning(&m, target).await;
        assert_at_speed(&m, "at speed");

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
        assert_eq!(al_status(md).await, (SAFEOP | ERROR, SM_WATCHDOG));
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
        assert_eq!(al_status(md).await, (SAFEOP, 0), "acknowledged");
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, OP)
            .await
            .expect("request OP");
        let sw = cycles(&m, md, &group, std::iter::repeat_n(0, 20), 0).await;
        assert_eq!(
            al_status(md).await,
            (OP, 0),
            "OP again (statusword {sw:#06x})"
        );
        let sw = cycles(&m, md, &group, vendor::enable_sequence(1_000), target).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "enabled again: {sw:#06x}"
        );
        assert_at_speed(&m, "at speed again");
        assert!(drive(&m).1, "bridge on");
    });
}

/// A DC link over the drive's trip level, and back to nominal.
fn set_bus_voltage(m: &board_sim::inproc::InProcess, over: bool) {
    let mut s = m.shared.segment();
    let servo = &mut s.drives_mut()[0].servos[0];
    let trip = f64::from(servo.axis.config().protection.bus_over_voltage_v);
    let nominal = servo.plant.config().inverter.bus_voltage_v;
    servo
        .plant
        .set_bus_voltage(if over { trip + 5.0 } else { nominal });
}

#[test]
fn a_motor_fault_while_the_cable_is_out_is_reported_with_the_bus_fault_and_both_recover() {
    let profile = od_gen::builtin("standard").expect("profile");
    let fault = od_gen::model::MOTOR_FAULT_NAMES
        .iter()
        .position(|k| *k == "bus_over_voltage")
        .map(|i| profile.motor_faults[i].error_code)
        .expect("bus_over_voltage");
    let target = units::target_velocity(&profile, SPEED_REV_S);
    block_on(async {
        let segment = board_sim::Segment::new("standard", 1).expect("profile");
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = turning(&m, target).await;

        m.shared.segment().set_master_cable(false);
        m.shared.advance(300_000_000);
        set_bus_voltage(&m, true);
        m.shared.advance(300_000_000);
        m.shared.segment().set_master_cable(true);

        assert_eq!(
            al_status(md).await,
            (SAFEOP | ERROR, SM_WATCHDOG),
            "the bus fault"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        let shown: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
        assert_eq!(shown, fault, "603Fh: the over-voltage");
        let sw: u16 = sd.sdo_read(0x6041, 0).await.expect("6041h");
        assert!(cia402::is(sw, cia402::FAULT), "Fault: {sw:#06x}");
        let register: u8 = sd.sdo_read(0x1001, 0).await.expect("1001h");
        // Generic (bit 0), voltage (bit 2, CiA 301 for 3xxxh), communication (bit 4).
        assert_eq!(register & 0x15, 0x15, "1001h {register:#04x}: both errors");
        assert!(
            !m.shared.segment().drives()[0].servos[0].latched().gates,
            "bridge off"
        );

        // The voltage comes back; the master acknowledges, requests OP, resets the fault.
        set_bus_voltage(&m, false);
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, SAFEOP | ACK)
            .await
            .expect("acknowledge");
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, OP)
            .await
            .expect("request OP");
        cycles(&m, md, &group, std::iter::repeat_n(0, 20), 0).await;
        assert_eq!(al_status(md).await, (OP, 0), "OP again");
        let reset = [0u16, 0x80, 0x80, 0].into_iter();
        let sw = cycles(
            &m,
            md,
            &group,
            reset.chain(vendor::enable_sequence(1_000)),
            target,
        )
        .await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "enabled again: {sw:#06x}"
        );
        assert_at_speed(&m, "at speed again");
        let register: u8 = sd.sdo_read(0x1001, 0).await.expect("1001h");
        assert_eq!(register, 0, "1001h clear");
    });
}

const DRIVES: usize = 3;
const CYCLE: u64 = 250_000;
const RUN: usize = 20_000;
const PROFILE: &str = "sigma-v-sd";
/// Drift compensation keeps the system times within this of each other (Beckhoff: "< 100 ns";
/// the sim's loop is no better than 1 µs with frames that jitter).
const LOCKED_NS: u64 = 1_000;

/// The PDI watchdog as the master sees it: DL status 0x0110 bit 1 (not expired) and the expiry
/// counter 0x0443.
async fn pdi_watchdog(md: &MainDevice<'_>) -> (bool, u8) {
    let dl: u16 = Command::fprd(STATION, hal::esc::regs::DL_STATUS.addr)
        .receive(md)
        .await
        .expect("DL status");
    let expiries: u8 = Command::fprd(STATION, hal::esc::regs::WATCHDOG_COUNTER_PDI.addr)
        .receive(md)
        .await
        .expect("0x0443");
    (dl & hal::esc::DlStatus::PDI_WATCHDOG_OK != 0, expiries)
}

#[test]
fn mcu_stopped_expires_the_pdi_watchdog_and_its_restart_is_reported_as_0x0060() {
    const INIT: u16 = 0x01;
    const RESTARTED_LOCALLY: u16 = 0x0060;
    let profile = od_gen::builtin("standard").expect("profile");
    let target = units::target_velocity(&profile, SPEED_REV_S);
    block_on(async {
        let segment = board_sim::Segment::new("standard", 1).expect("profile");
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = turning(&m, target).await;
        assert_at_speed(&m, "at speed");
        assert_eq!(pdi_watchdog(md).await, (true, 0), "PDI watchdog running");

        // The MCU stops for 300 ms while the master goes on cycling.
        m.shared.segment().drives_mut()[0].halt_mcu();
        cycles(&m, md, &group, std::iter::repeat_n(0x0F, 150), target).await;
        // ETG.1000.4 / ESC: without PDI accesses for the PDI watchdog time (0x0410, 100 ms by
        // default) DL status 0x0110 bit 1 clears and 0x0443 counts the expiry; the ESC itself
        // leaves the AL status as the firmware last wrote it.
        assert_eq!(pdi_watchdog(md).await, (false, 1), "PDI watchdog expired");
        assert_eq!(al_status(md).await, (OP, 0), "AL status as last written");
        assert!(
            !m.shared.segment().drives()[0].servos[0].latched().gates,
            "bridge off while the MCU is stopped"
        );
        cycles(&m, md, &group, std::iter::repeat_n(0x0F, 150), target).await;

        // The MCU restarts (the board's watchdog) with the ESC as it was: INIT with the error
        // indication and "slave restarted locally" (ETG.1000.6 Table 11).
        m.shared.segment().drives_mut()[0]
            .restart_mcu()
            .expect("restart");
        cycles(&m, md, &group, std::iter::repeat_n(0, 5), 0).await;
        assert_eq!(al_status(md).await, (INIT | ERROR, RESTARTED_LOCALLY));
        assert!(pdi_watchdog(md).await.0, "PDI served again");

        // The master runs its start-up again (which acknowledges the error): the drive turns.
        drop(group);
        let group = turning(&m, target).await;
        assert_at_speed(&m, "at speed again");
        // The restart is in the diagnosis history: the ESM's error A000h, AL status code 0x0060,
        // from OP (the state the ESC showed) to INIT.
        let sd = group.subdevice(md, 0).expect("drive");
        let newest: u8 = sd.sdo_read(0x10F3, 2).await.expect("10F3h:02");
        let mut found = false;
        for sub in 6..=newest {
            let msg = sd.sdo_read::<[u8; 28]>(0x10F3, sub).await.expect("message");
            found |= msg[..4] == [0x00, 0xE8, 0x00, 0xA0]
                && msg[16..20] == [0x06, 0x00, 0x60, 0x00]
                && msg[20..26] == [0x05, 0x00, OP as u8, 0x05, 0x00, INIT as u8];
        }
        assert!(found, "10F3h: a message of the local restart");
    });
}

#[test]
fn clocks_50_ppm_apart_miss_no_cycle() {
    line_of_sigma_v_sd(0, 0);
}

#[test]
fn frames_and_sync0_service_jittering_miss_no_cycle() {
    line_of_sigma_v_sd(CYCLE / 5, CYCLE * 8 / 100);
}

/// The clock-drift line; each frame leaves up to `jitter_ns` before or after the DC-aligned
/// time (uniform, a fixed-seed sequence), each drive serves SYNC0 up to `sync0_latency_ns`
/// late.
fn line_of_sigma_v_sd(jitter_ns: u64, sync0_latency_ns: u64) {
    use std::time::Duration;

    use ethercrab::subdevice_group::DcConfiguration;
    use ethercrab::DcSync;

    let profile = od_gen::builtin(PROFILE).expect("profile");
    block_on(async {
        let mut segment = board_sim::Segment::new(PROFILE, DRIVES).expect("profile");
        // Local clocks at +25, -25 and +10 ppm from power-on times far apart.
        for (d, (start, ppm)) in segment.drives_mut().iter_mut().zip([
            (0, 25.0),
            (7_000_000_000, -25.0),
            (123_456_789, 10.0),
        ]) {
            d.esc.set_clock(start, ppm);
            d.sync0_latency_max_ns = sync0_latency_ns;
        }
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (outputs, inputs) = vendor::VELOCITY_MAPPING;
        let setup = vendor::mapping(&outputs, &inputs);
        let mut group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        for sd in group.iter(md) {
            for &sdo in &setup {
                vendor::write_to(&sd, sdo).await;
            }
        }
        for mut sd in group.iter_mut(md) {
            sd.set_dc_sync(DcSync::Sync0);
        }
        let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
        for _ in 0..1000 {
            group.tx_rx_sync_system_time(md).await.expect("time");
            m.shared.advance(CYCLE);
        }
        let group = group
            .configure_dc_sync(
                md,
                DcConfiguration {
                    start_delay: Duration::from_millis(10),
                    sync0_period: Duration::from_nanos(CYCLE),
                    sync0_shift: Duration::from_nanos(CYCLE / 2),
                },
            )
            .await
            .expect("DC")
            .into_safe_op(md)
            .await
            .expect("SAFE-OP")
            .request_into_op(md)
            .await
            .expect("OP");
        let target = units::target_velocity(&profile, 2.0);
        let mut k = 0usize;
        let mut op_since = None;
        let mut jitter = Jitter::new(jitter_ns);
        while k < RUN + 4_000 {
            let cw = match op_since {
                Some(at) => vendor::enable_sequence(usize::MAX)
                    .nth(k - at)
                    .unwrap_or(0x0F),
                None => 0,
            };
            for sd in group.iter(md) {
                let [c0, c1] = cw.to_le_bytes();
                let [v0, v1, v2, v3] = target.to_le_bytes();
                sd.outputs_raw_mut()[..7].copy_from_slice(&[c0, c1, CSV as u8, v0, v1, v2, v3]);
            }
            let r = group.tx_rx_dc(md).await.expect("tx/rx");
            if op_since.is_none() && r.all_op() {
                op_since = Some(k);
            }
            if op_since.is_some() && !r.all_op() {
                let mut states = Vec::new();
                for i in 0..DRIVES as u16 {
                    let st: u16 = Command::fprd(STATION + i, AL_STATUS)
                        .receive(md)
                        .await
                        .expect("AL");
                    let c: u16 = Command::fprd(STATION + i, AL_STATUS_CODE)
                        .receive(md)
                        .await
                        .expect("code");
                    states.push((st, c));
                }
                panic!("cycle {k}: a drive left OP: {states:x?}");
            }
            if op_since.is_some() {
                assert_eq!(r.working_counter, 3 * DRIVES as u16, "cycle {k}");
            }
            // The next frame at the DC-aligned start ethercrab computes (SYNC0 half a cycle
            // after it).
            // `next_cycle_wait` counts from when this frame passed the reference clock, so it
            // takes this frame's own offset out.
            let wait = r.extra.next_cycle_wait.as_nanos() as u64;
            m.shared
                .advance((wait + jitter.next()).saturating_sub(jitter_ns));
            k += 1;
            if op_since.is_some_and(|at| k - at >= RUN) {
                break;
            }
            assert!(k < 4_000 || op_since.is_some(), "no OP after 4000 cycles");
        }
        for (i, sd) in group.iter(md).enumerate() {
            let missed: u32 = sd.sdo_read(0x1C32, 0x0C).await.expect("1C32h:0C");
            assert_eq!(missed, 0, "drive {i}: SM2 events missed");
            let sw = vendor::u16_at(&sd.inputs_raw(), 0);
            assert!(
                cia402::is(sw, cia402::OPERATION_ENABLED),
                "drive {i}: {sw:#06x}"
            );
        }
        let s = m.shared.segment();
        // Locked: every drive's system time (and so its SYNC0) within LOCKED_NS of the
        // reference's.
        let now = s.now_ns();
        let reference = s.drives()[0].esc.system_time_at(now);
        for (i, d) in s.drives().iter().enumerate() {
            let off = d.esc.system_time_at(now).abs_diff(reference);
            assert!(
                off < LOCKED_NS,
                "drive {i}: system time {off} ns off the reference"
            );
        }
        for (i, d) in s.drives().iter().enumerate() {
            let rpm = d.servos[0].plant.mech_speed_rad_s() / std::f64::consts::TAU * 60.0;
            assert!(
                (rpm / 60.0 - 2.0).abs() < 0.1,
                "drive {i} follows: {rpm} rpm"
            );
        }
    });
}

/// Frame jitter: a fixed-seed uniform sequence in 0..=2·`amplitude` ns; the frame leaves that
/// long after a point `amplitude` before the aligned time (so within ± `amplitude` of it).
struct Jitter {
    amplitude: u64,
    state: u64,
}

impl Jitter {
    fn new(amplitude: u64) -> Self {
        Self {
            amplitude,
            state: 0x2545_F491_4F6C_DD1D,
        }
    }

    fn next(&mut self) -> u64 {
        // xorshift64
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        self.state % (2 * self.amplitude + 1)
    }
}
