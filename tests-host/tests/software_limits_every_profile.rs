//! The software position limits 607Dh on every profile, end to end: ethercrab runs the
//! simulated drive in cyclic synchronous position (DC SYNC0 at 1 ms; 1600h: 6040h, 6060h,
//! 607Ah; 1A00h: 6041h, 6064h) and ramps the target from the motor's position to a turn
//! beyond it, with 607Dh set to half a turn either side of the start.
//!
//! - Limits on: the motor stops at 607Dh:02 and never passes it; statusword bit 11 is set
//!   (CiA402 "internal limit active", in CSP on every profile's table: the Σ-V-SD §4.7, the
//!   RSE 6.2.2 "position command or feedback beyond the software limit", the SDV3-E §7.8).
//! - min ≥ max switches them off (CiA402; the 0/0 default of the Σ-V-SD and the RSE).
//! - The SDV3-E and OSD-G-E with P2.25 "position command format" = 1 (infinite length,
//!   §2.4) have none, from the next power-on (a * parameter): written without a power cycle
//!   it changes nothing yet.
//! - The Σ-V-SD (§6.8 (2)) limits "when homing is completed" or "an absolute encoder is
//!   connected": with an incremental encoder the target passes the limit until a homing run
//!   (method 35, the current position); the standard profile (CiA402 states no such
//!   condition) limits with an incremental encoder from the start. Its limits are "relative to
//!   the machine home position", compared as 607Dh - 607Ch (§4.8 (2)).

use board_sim::plant::{EncoderParams, PlantConfig};
use board_sim::servo::{axis_config, SimServo, Tuning};
use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::session::{power_cycle, session, Step};
use tests_host::vendor::{self, DcGroup, Sdo, POSITION_MAPPING};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSP: i8 = 8;
/// Statusword bit 11.
const INTERNAL_LIMIT: u16 = 1 << 11;
/// Statusword bit 12 in CSP: the drive follows the command value (CiA402, every profile).
const FOLLOWS_COMMAND: u16 = 1 << 12;
/// The longest the drive takes from enable to following (the alignment of an incremental
/// encoder), cycles.
const ALIGNMENT_CYCLES: usize = 2_000;
/// Modes of operation 6060h: homing; 6098h method 35: the current position is the home.
const HOMING: i8 = cia402::HOMING;
const HOME_HERE: i8 = 35;
/// 607Dh either side of the start, rev.
const LIMIT_REV: f64 = 0.5;
/// How far the target ramps, rev, and how fast, rev/s.
const TARGET_REV: f64 = 1.0;
const RAMP_REV_S: f64 = 2.0;
/// The position error a stop at the limit may show (the position loop at rest), rev.
const AT_REST_REV: f64 = 0.002;
/// SDV3-E P2.25 "position command format" (P2.25 = 3001h:25, §6.3); 1 = infinite length.
const P2_25: (u16, u8) = (0x3001, 25);
/// 1010h:01 "save all parameters" with its signature "save".
const STORE_ALL: (u16, u8, u32) = (0x1010, 1, 0x6576_6173);

/// What a run found.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    /// The furthest the motor went beyond the start, rev.
    furthest_rev: f64,
    /// Where it ended, rev from the start.
    end_rev: f64,
    /// The last statusword.
    statusword: u16,
}

impl Outcome {
    /// The motor stopped at 607Dh:02 and showed bit 11.
    fn limited(&self) -> Result<(), String> {
        self.limited_at(LIMIT_REV)
    }

    /// The motor stopped at `limit_rev` from the start, never went beyond it, and showed bit 11.
    fn limited_at(&self, limit_rev: f64) -> Result<(), String> {
        if (self.end_rev - limit_rev).abs() > AT_REST_REV
            || self.furthest_rev > limit_rev + AT_REST_REV
            || self.statusword & INTERNAL_LIMIT == 0
        {
            return Err(format!("not limited at {limit_rev} rev: {self:?}"));
        }
        Ok(())
    }

    /// The motor followed the target past 607Dh:02, bit 11 clear.
    fn free(&self) -> Result<(), String> {
        if (self.end_rev - TARGET_REV).abs() > AT_REST_REV || self.statusword & INTERNAL_LIMIT != 0
        {
            return Err(format!("limited: {self:?}"));
        }
        Ok(())
    }
}

/// How a run is set up.
#[derive(Clone, Copy, Debug, Default)]
struct Setup {
    /// The drive has an incremental encoder instead of the reference servo's absolute one.
    incremental: bool,
    /// P2.25 = 1 stored (1010h) and the drive power cycled before the run.
    infinite_length_stored: bool,
    /// P2.25 = 1 written in PREOP of the run (no power cycle).
    infinite_length_written: bool,
    /// 607Dh:01 = 607Dh:02 (the CiA402 "off").
    limits_equal: bool,
    /// A homing run (method 35) before the move.
    home_first: bool,
    /// 607Ch written before the move, rev (in the profile's position units).
    home_offset_rev: f64,
}

/// The drive of `name` as `setup` wants it, before a master opens it.
fn segment(name: &str, setup: Setup) -> Segment {
    let mut segment = Segment::new(name, 1).expect("profile");
    if setup.incremental {
        let mut plant = PlantConfig::servo_400w();
        plant.encoder = EncoderParams::Incremental {
            counts_per_rev: units::COUNTS_PER_REV as u32,
            index_at_rad: 0.0,
        };
        let axis = axis_config(&plant, &Tuning::default());
        let servo = SimServo::new(plant, axis).expect("a valid board");
        segment.drives_mut()[0]
            .fit_servo(0, servo)
            .expect("the board fitted");
    }
    if setup.infinite_length_stored {
        let (mut stored, out) = session(
            segment,
            &[
                Step::Write(P2_25.0, P2_25.1, 1),
                Step::Write(STORE_ALL.0, STORE_ALL.1, STORE_ALL.2),
            ],
        );
        assert!(out.iter().all(Result::is_ok), "{name}: {out:?}");
        power_cycle(&mut stored);
        segment = stored;
    }
    segment
}

/// One cycle: (cw, mode, 607Ah) out; (statusword, 6064h) back.
async fn cycle(
    m: &board_sim::inproc::InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    command: (u16, i8, i32),
) -> (u16, i32) {
    let inputs = vendor::exchange_dc_command(m, md, group, command, CYCLE_NS).await;
    (vendor::u16_at(&inputs, 0), vendor::i32_at(&inputs, 2))
}

/// The CSP ramp past 607Dh:02 on a drive of `name` set up as `setup`.
fn run(name: &str, setup: Setup) -> Outcome {
    let profile = od_gen::builtin(name).expect("profile");
    let units_per_rev = units::COUNTS_PER_REV / units::increments_per_unit(&profile);
    let rev = |units: i32, start: i32| f64::from(units - start) / units_per_rev;
    let segment = segment(name, setup);
    block_on(async {
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut sdos = vendor::mapping(&POSITION_MAPPING.0, &POSITION_MAPPING.1);
        sdos.push(Sdo::I8(0x6098, 0, HOME_HERE));
        if setup.infinite_length_written {
            sdos.push(Sdo::I32(P2_25.0, P2_25.1, 1));
        }
        let group = vendor::into_op_dc(&m, md, &sdos, CYCLE_NS).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let mut position: i32 = sd.sdo_read(0x6064, 0).await.expect("6064h");
        let mut sw = 0;
        for _ in 0..vendor::SYNC0_START_CYCLES {
            cycle(&m, md, &group, (0, CSP, position)).await;
        }
        for cw in vendor::enable_sequence(20) {
            (sw, position) = cycle(&m, md, &group, (cw, CSP, position)).await;
        }
        // As a CiA402 master does: the target stays at the actual position until the drive
        // follows it (bit 12; an incremental encoder aligns the commutation first).
        for _ in 0..ALIGNMENT_CYCLES {
            if sw & FOLLOWS_COMMAND != 0 {
                break;
            }
            (sw, position) = cycle(&m, md, &group, (vendor::ENABLE_OPERATION, CSP, position)).await;
        }
        if !cia402::is(sw, cia402::OPERATION_ENABLED) || sw & FOLLOWS_COMMAND == 0 {
            let code: u16 = sd.sdo_read(0x603F, 0).await.unwrap_or(0);
            panic!("{name}: not enabled: {sw:#06x}, 603Fh {code:04X}h");
        }
        if setup.home_first {
            let start = vendor::ENABLE_OPERATION | cia402::HOMING_START;
            for _ in 0..20 {
                (sw, position) = cycle(&m, md, &group, (start, HOMING, position)).await;
            }
            assert_ne!(sw & cia402::HOMING_ATTAINED, 0, "{name}: homed {sw:#06x}");
            for _ in 0..5 {
                (sw, position) =
                    cycle(&m, md, &group, (vendor::ENABLE_OPERATION, CSP, position)).await;
            }
        }
        if setup.home_offset_rev != 0.0 {
            let offset = (setup.home_offset_rev * units_per_rev).round() as i32;
            sd.sdo_write(0x607C, 0, offset).await.expect("607Ch");
            for _ in 0..5 {
                (sw, position) =
                    cycle(&m, md, &group, (vendor::ENABLE_OPERATION, CSP, position)).await;
            }
        }
        // 607Dh half a turn either side of where the motor is.
        let start = position;
        let limit = (LIMIT_REV * units_per_rev).round() as i32;
        let (min, max) = if setup.limits_equal {
            (start, start)
        } else {
            (start - limit, start + limit)
        };
        sd.sdo_write(0x607D, 1, min).await.expect("607Dh:01");
        sd.sdo_write(0x607D, 2, max).await.expect("607Dh:02");
        let step = RAMP_REV_S * units_per_rev * CYCLE_NS as f64 * 1e-9;
        let ramp_cycles = (TARGET_REV * units_per_rev / step).round() as usize;
        let mut furthest = f64::MIN;
        for k in 1..=ramp_cycles + 500 {
            let target = start + (step * k.min(ramp_cycles) as f64).round() as i32;
            (sw, position) = cycle(&m, md, &group, (vendor::ENABLE_OPERATION, CSP, target)).await;
            furthest = furthest.max(rev(position, start));
        }
        if !cia402::is(sw, cia402::OPERATION_ENABLED) {
            let code: u16 = sd.sdo_read(0x603F, 0).await.unwrap_or(0);
            panic!("{name}: not enabled after the move: {sw:#06x}, 603Fh {code:04X}h");
        }
        Outcome {
            furthest_rev: furthest,
            end_rev: rev(position, start),
            statusword: sw,
        }
    })
}

const PROFILES: [&str; 6] = [
    "standard",
    "gha-e",
    "rse",
    "sdv3-e",
    "osd-g-e",
    "sigma-v-sd",
];

/// With an absolute encoder (the reference servo) every profile limits the move at 607Dh:02.
#[test]
fn every_profile_stops_a_csp_move_at_607dh() {
    let failures: Vec<String> = PROFILES
        .iter()
        .filter_map(|name| {
            run(name, Setup::default())
                .limited()
                .err()
                .map(|e| format!("{name}: {e}"))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// 607Dh:01 = 607Dh:02 switches the limits off on every profile.
#[test]
fn every_profile_has_no_limits_with_min_equal_to_max() {
    let setup = Setup {
        limits_equal: true,
        ..Setup::default()
    };
    let failures: Vec<String> = PROFILES
        .iter()
        .filter_map(|name| {
            run(name, setup)
                .free()
                .err()
                .map(|e| format!("{name}: {e}"))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn sdv3_e_and_osd_g_e_with_p2_25_infinite_length_have_no_limits() {
    let setup = Setup {
        infinite_length_stored: true,
        ..Setup::default()
    };
    for name in ["sdv3-e", "osd-g-e"] {
        let outcome = run(name, setup);
        if let Err(e) = outcome.free() {
            panic!("{name}: P2.25 = 1 at power-on: {e}");
        }
    }
}

#[test]
fn sdv3_e_p2_25_takes_effect_at_the_next_power_on() {
    let setup = Setup {
        infinite_length_written: true,
        ..Setup::default()
    };
    if let Err(e) = run("sdv3-e", setup).limited() {
        panic!("P2.25 = 1 written, no power cycle yet: {e}");
    }
}

#[test]
fn sigma_v_sd_with_an_incremental_encoder_limits_only_after_homing() {
    let incremental = Setup {
        incremental: true,
        ..Setup::default()
    };
    if let Err(e) = run("sigma-v-sd", incremental).free() {
        panic!("not homed: {e}");
    }
    let homed = Setup {
        home_first: true,
        ..incremental
    };
    if let Err(e) = run("sigma-v-sd", homed).limited() {
        panic!("homed: {e}");
    }
}

/// Σ-V-SD §4.8 (2): 607Dh is relative to the machine home; a target is compared with
/// 607Dh - 607Ch. With 607Ch a quarter turn, the limit half a turn on stops the motor a
/// quarter turn on.
#[test]
fn sigma_v_sd_limits_are_corrected_by_the_home_offset() {
    const OFFSET_REV: f64 = 0.25;
    let setup = Setup {
        home_offset_rev: OFFSET_REV,
        ..Setup::default()
    };
    if let Err(e) = run("sigma-v-sd", setup).limited_at(LIMIT_REV - OFFSET_REV) {
        panic!("607Ch = {OFFSET_REV} rev: {e}");
    }
}

#[test]
fn standard_with_an_incremental_encoder_limits_without_homing() {
    let incremental = Setup {
        incremental: true,
        ..Setup::default()
    };
    if let Err(e) = run("standard", incremental).limited() {
        panic!("{e}");
    }
}
