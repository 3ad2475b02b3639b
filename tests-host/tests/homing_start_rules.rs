//! When a homing run may start, per profile, end to end (ethercrab, DC SYNC0 at 1 ms; 1600h:
//! 6040h, 6060h, 607Ah; 1A00h: 6041h, 6064h; 6060h = 6, 6098h = 35 "the current position"):
//!
//! - CiA402 (the standard profile, the GHA-E, the RSE): homing starts on the rising edge of
//!   controlword bit 4 in Operation Enabled; an edge in Switched On starts nothing
//!   (statusword bits 13/12/10 = 0/0/1 "not started").
//! - The SDV3-E and OSD-G-E (§4.4, statusword bit 13): "3. Perform homing if the servo is not
//!   enabled" and "2. Perform position preset when speed zero is not established (6098h is 35)"
//!   are homing errors; the preset at standstill takes the position.
//! - The Σ-V-SD (§4.9, method 35): "This method does not require the drive device to be in
//!   operational enabled state": the edge in Switched On makes the current position the home
//!   (bit 12 homing attained).

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcDrive, Sdo, POSITION_MAPPING};
use tests_host::{block_on, cia402, master_for};

const CYCLE_NS: u64 = 1_000_000;
const HOMING: i8 = cia402::HOMING;
const HOME_HERE: i8 = 35;
/// Controlword: switch on (Switched On) and enable operation, each with bit 4 "homing start".
const SWITCH_ON_START: u16 = vendor::SWITCH_ON | cia402::HOMING_START;
const ENABLE_START: u16 = vendor::ENABLE_OPERATION | cia402::HOMING_START;
/// A load turning the motor at 1 rev/s: far outside every profile's speed-zero range.
const DRIVEN_RAD_S: f64 = std::f64::consts::TAU;

/// What the homing bits 13/12/10 said and whether the position became the home.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Result {
    /// 0/0/1: not started (or interrupted), at rest.
    NotStarted,
    /// 0/1/x: homing attained (target reached or, the motor still turning, not).
    Attained,
    /// 1/x/x: homing error.
    Error,
    /// Anything else (e.g. still running).
    Other(u16),
}

fn result(statusword: u16) -> Result {
    match statusword & cia402::HOMING_BITS {
        b if b & cia402::HOMING_ERROR != 0 => Result::Error,
        cia402::TARGET_REACHED => Result::NotStarted,
        b if b & cia402::HOMING_ATTAINED != 0 => Result::Attained,
        b => Result::Other(b),
    }
}

struct Drive<'a> {
    bus: DcDrive<'a>,
}

impl Drive<'_> {
    /// `n` cycles of controlword `cw` in homing mode; the last statusword.
    async fn hold(&self, cw: u16, n: usize) -> u16 {
        self.bus.hold_statusword((cw, HOMING, 0), n).await
    }
}

/// Drive 0 from INIT to OP in homing mode with method 35.
async fn into_op<'a>(m: &'a InProcess, md: &'a MainDevice<'a>) -> Drive<'a> {
    let mut sdos = vendor::mapping(&POSITION_MAPPING.0, &POSITION_MAPPING.1);
    sdos.push(Sdo::I8(0x6098, 0, HOME_HERE));
    let group = vendor::into_op_dc(m, md, &sdos, CYCLE_NS).await;
    let drive = Drive {
        bus: DcDrive {
            m,
            md,
            group,
            cycle_ns: CYCLE_NS,
        },
    };
    drive.hold(0, vendor::SYNC0_START_CYCLES).await;
    drive
}

/// The homing result of a bit-4 edge in Switched On.
fn start_while_switched_on(name: &str) -> Result {
    block_on(async {
        let (m, transport) = master_for(Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let d = into_op(&m, &m.maindevice).await;
        d.hold(vendor::SHUTDOWN, 5).await;
        let sw = d.hold(vendor::SWITCH_ON, 5).await;
        assert!(cia402::is(sw, cia402::SWITCHED_ON), "{name}: {sw:#06x}");
        let sw = d.hold(SWITCH_ON_START, 5).await;
        assert!(cia402::is(sw, cia402::SWITCHED_ON), "{name}: {sw:#06x}");
        result(sw)
    })
}

/// The homing result of method 35 started in Operation Enabled, with the motor at rest or
/// turned by a load.
fn preset(name: &str, moving: bool) -> Result {
    block_on(async {
        let (m, transport) = master_for(Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let d = into_op(&m, &m.maindevice).await;
        for cw in vendor::enable_sequence(20) {
            d.hold(cw, 1).await;
        }
        if moving {
            let mut segment = m.shared.segment();
            let plant = &mut segment.drives_mut()[0].servos[0].plant;
            plant.set_driven_speed(Some(DRIVEN_RAD_S));
        }
        let sw = d.hold(vendor::ENABLE_OPERATION, 20).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "{name}: {sw:#06x}"
        );
        result(d.hold(ENABLE_START, 3).await)
    })
}

#[test]
fn cia402_profiles_start_homing_only_in_operation_enabled() {
    for name in ["standard", "gha-e", "rse"] {
        assert_eq!(start_while_switched_on(name), Result::NotStarted, "{name}");
    }
}

#[test]
fn sdv3_e_and_osd_g_e_homing_started_while_not_enabled_is_a_homing_error() {
    for name in ["sdv3-e", "osd-g-e"] {
        assert_eq!(start_while_switched_on(name), Result::Error, "{name}");
    }
}

#[test]
fn sdv3_e_position_preset_needs_speed_zero() {
    assert_eq!(preset("sdv3-e", false), Result::Attained, "at standstill");
    assert_eq!(preset("sdv3-e", true), Result::Error, "turning");
}

#[test]
fn cia402_position_preset_takes_the_position_while_turning() {
    assert_eq!(preset("standard", true), Result::Attained);
}

#[test]
fn sigma_v_sd_homes_on_the_current_position_while_switched_on() {
    assert_eq!(start_while_switched_on("sigma-v-sd"), Result::Attained);
}
