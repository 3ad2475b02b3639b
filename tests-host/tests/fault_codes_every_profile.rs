//! Every profile reports the drive's faults as its manual's alarms, end to end: ethercrab runs
//! the simulated drive in cyclic synchronous velocity (DC SYNC0 at 1 ms), the simulated board
//! injects a fault (the power stage over its temperature, the motor's thermal switch, the DC
//! link over or under its limits, a load driving the rotor over the speed limit, a serial encoder
//! whose frames fail their CRC, an encoder reading that jumps), and the drive must go to
//! Fault with 603Fh, the emergency's code and manufacturer field and 1001h as the profile's
//! `[motor_faults]` table maps that fault (each entry a row of the manual's alarm table, e.g.
//! the SDV3-E's AH: 4210h, error No. 26h, auxiliary code 8003h, Table 5-1; the GHA-E's AH
//! 4210h, §6.2; the RSE's AL.248; the Σ-V-SD's 4210h with the axis number in byte 7, §2.7).

use board_sim::inproc::InProcess;
use board_sim::plant::EncoderFaultInjection;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcGroup};

use tests_host::{block_on, cia402, emcy, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
/// Statusword bit 4.
const VOLTAGE_ENABLED: u16 = 1 << 4;
/// 1001h bit 0: generic error.
const GENERIC_ERROR: u8 = 0x01;
/// The longest a fault takes to trip (the confirmation times are at most a few hundred ms).
const TRIP_CYCLES: usize = 2_000;

/// A fault the simulated board injects, by its `[motor_faults]` key.
#[derive(Clone, Copy, Debug)]
enum Injection {
    DriveOverTemperature,
    MotorOverTemperature,
    BusOverVoltage,
    BusUnderVoltage,
    EncoderCrc,
    EncoderJump,
}

impl Injection {
    // Over-speed cannot be injected here: a load driving the rotor over the trip level makes
    // the back-EMF exceed the 48 V bus, the inverter loses current control and over-current
    // trips first (as on a real drive), and the drive's own speed stays below it on 48 V.
    const ALL: [Injection; 6] = [
        Injection::DriveOverTemperature,
        Injection::MotorOverTemperature,
        Injection::BusOverVoltage,
        Injection::BusUnderVoltage,
        Injection::EncoderCrc,
        Injection::EncoderJump,
    ];

    /// The `[motor_faults]` key of the fault it raises.
    fn key(self) -> &'static str {
        match self {
            Injection::DriveOverTemperature => "drive_over_temperature",
            Injection::MotorOverTemperature => "motor_over_temperature",
            Injection::BusOverVoltage => "bus_over_voltage",
            Injection::BusUnderVoltage => "bus_under_voltage",
            Injection::EncoderCrc => "encoder_crc",
            Injection::EncoderJump => "encoder_jump",
        }
    }

    fn inject(self, m: &InProcess) {
        let mut segment = m.shared.segment();
        let servo = &mut segment.drives_mut()[0].servos[0];
        let protection = servo.axis.config().protection;
        let plant = &mut servo.plant;
        match self {
            Injection::DriveOverTemperature => {
                plant.set_drive_temperature(f64::from(protection.drive_over_temperature_c) + 10.0)
            }
            Injection::MotorOverTemperature => plant.set_motor_overtemp_input(true),
            Injection::BusOverVoltage => {
                plant.set_bus_voltage(f64::from(protection.bus_over_voltage_v) + 5.0)
            }
            Injection::BusUnderVoltage => {
                plant.set_bus_voltage(f64::from(protection.bus_under_voltage_v) - 5.0)
            }
            Injection::EncoderCrc => {
                plant.set_encoder_fault(Some(EncoderFaultInjection::CrcErrors))
            }
            Injection::EncoderJump => {
                // Half a turn in one sample: far beyond what the motor can move.
                let counts = (units::COUNTS_PER_REV / 2.0) as i64;
                plant.set_encoder_fault(Some(EncoderFaultInjection::Jump { counts }))
            }
        }
    }
}

async fn cycle(m: &InProcess, md: &MainDevice<'_>, group: &DcGroup, cw: u16) -> u16 {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, CSV, 0), CYCLE_NS).await;
    vendor::u16_at(&inputs, 0)
}

/// One fault on a drive of `name`; what is wrong, if anything.
async fn fault(name: &str, profile: &od_gen::Profile, injection: Injection) -> Result<(), String> {
    let index = od_gen::model::MOTOR_FAULT_NAMES
        .iter()
        .position(|k| *k == injection.key())
        .expect("a motor fault key");
    let mut expected = profile.motor_faults[index];
    // The Σ-V-SD's byte 7 carries the axis number, 1 here (§2.7).
    if let Some(byte) = profile.emcy.axis_number_byte {
        let at = usize::from(byte)
            .checked_sub(3)
            .expect("a manufacturer byte 3-7");
        expected.emcy.data[at] = 1;
    }
    let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CSV, CYCLE_NS).await;
    let mut sw = 0;
    for cw in vendor::enable_sequence(20) {
        sw = cycle(&m, md, &group, cw).await;
    }
    if !cia402::is(sw, cia402::OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    // Nothing queued before the fault.
    while emcy::read(md, profile.sm.mailbox_in.start).await?.is_some() {}
    injection.inject(&m);
    let mut emergency = None;
    for _ in 0..TRIP_CYCLES {
        sw = cycle(&m, md, &group, vendor::ENABLE_OPERATION).await;
        if let Some(e) = emcy::read(md, profile.sm.mailbox_in.start).await? {
            emergency.get_or_insert(e);
        }
        if cia402::is(sw, cia402::FAULT) && emergency.is_some() {
            break;
        }
    }
    if matches!(injection, Injection::BusUnderVoltage)
        && profile.cia402.switch_on_requires_main_power
    {
        // The Σ-V-SD (§3.1 *4): main power off takes Operation Enabled to Switch On Disabled,
        // bit 4 "voltage enabled" clear; the under-voltage protection is armed only while
        // enabled, so no alarm follows.
        return if cia402::is(sw, cia402::SWITCH_ON_DISABLED) && sw & VOLTAGE_ENABLED == 0 {
            Ok(())
        } else {
            Err(format!(
                "main power off: {sw:#06x}, expected Switch On Disabled"
            ))
        };
    }
    if !cia402::is(sw, cia402::FAULT) {
        return Err(format!("no Fault: {sw:#06x}"));
    }
    let e = emergency.ok_or("no emergency")?;
    if (e.code, e.data) != (expected.emcy.code, expected.emcy.data) {
        return Err(format!(
            "EMCY {:04X}h {:02x?}, the profile maps {:04X}h {:02x?}",
            e.code, e.data, expected.emcy.code, expected.emcy.data
        ));
    }
    if e.error_register & GENERIC_ERROR == 0 {
        return Err(format!(
            "1001h {:#04x} without the generic error",
            e.error_register
        ));
    }
    let sd = group.subdevice(md, 0).expect("drive");
    let error_code: u16 = sd
        .sdo_read(0x603F, 0)
        .await
        .map_err(|e| format!("603Fh: {e:?}"))?;
    if error_code != expected.error_code {
        return Err(format!(
            "603Fh {error_code:04X}h, the profile maps {:04X}h",
            expected.error_code
        ));
    }
    Ok(())
}

fn every_fault(name: &str) {
    let profile = od_gen::builtin(name).expect("profile");
    let mut failures = Vec::new();
    block_on(async {
        for injection in Injection::ALL {
            if let Err(e) = fault(name, &profile, injection).await {
                failures.push(format!("{}: {e}", injection.key()));
            }
        }
    });
    assert!(failures.is_empty(), "{name}:\n{}", failures.join("\n"));
}

#[test]
fn standard_faults_as_603fh_and_emcy() {
    every_fault("standard");
}

#[test]
fn gha_e_faults_as_its_alarms() {
    every_fault("gha-e");
}

#[test]
fn rse_faults_as_its_alarms() {
    every_fault("rse");
}

#[test]
fn sdv3_e_faults_as_its_alarms() {
    every_fault("sdv3-e");
}

#[test]
fn osd_g_e_faults_as_its_alarms() {
    every_fault("osd-g-e");
}

#[test]
fn sigma_v_sd_faults_as_its_alarms() {
    every_fault("sigma-v-sd");
}
