//! Profile position (6060h = 1) of every profile, end to end: ethercrab (DC SYNC0 at 1 ms;
//! 6040h, 6060h, 607Ah / 6041h, 6061h, 6064h mapped) hands the drive two set-points with the
//! CiA402 handshake (controlword bit 4 "new set-point", statusword bit 12 "set-point
//! acknowledge") in the profile's units, and the simulated motor must move as the manual says:
//!
//! - set of set-points (bit 5 = 0): the second set-point, given while the first move runs, waits
//!   in the buffer (bit 12 stays set); the motor stops on the first target, then goes on to the
//!   second. The RSE has no buffer (7.5): bit 12 stays set after the first handshake until the
//!   first move has ended, so the master gives the second set-point only then (a master waits
//!   for bit 12 to fall before raising bit 4 on every profile);
//! - change set immediately (bit 5 = 1 with both set-points): the second set-point replaces the
//!   first at once; the motor runs through the first target without stopping;
//! - relative targets (bit 6 with the profile's polarity: the SDV3-E's and OSD-G-E's bit 6 set
//!   means absolute, §7.5): each target adds to the previous one;
//! - change on set-point (bit 9) where the manual supports it (standard, SDV3-E, OSD-G-E,
//!   Σ-V-SD §6.3 "the move continues at the profile velocity through the set-point"): the
//!   motor passes the first target at speed; the GHA-E (§5.2.1 "not supported") and the RSE
//!   (7.2 "no function") ignore the bit and stop on it.
//!
//! Each run ends on the last target within the position window with bit 10 (target reached).

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcGroup, MappedEntry, Sdo};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const PP: i8 = 1;
const NEW_SET_POINT: u16 = 1 << 4;
const CHANGE_SET_IMMEDIATELY: u16 = 1 << 5;
const BIT6: u16 = 1 << 6;
const CHANGE_ON_SET_POINT: u16 = 1 << 9;
const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;
/// Profile velocity and acceleration of the moves.
const SPEED_REV_S: f64 = 5.0;
const ACCELERATION_REV_S2: f64 = 50.0;
/// The targets, revolutions (absolute), and where a relative second move ends.
const FIRST_REV: f64 = 2.0;
const SECOND_REV: f64 = 4.0;
/// At rest below this speed; passing at speed above it (rev/s).
const AT_REST_REV_S: f64 = 0.5;
const OUTPUTS: [MappedEntry; 3] = [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)];
const INPUTS: [MappedEntry; 3] = [(0x6041, 0, 16), (0x6061, 0, 8), (0x6064, 0, 32)];

/// A profile's profile position, as its manual describes it.
struct Manual {
    profile: &'static str,
    /// Bit 6 set means an absolute target.
    bit6_absolute: bool,
    /// Bit 9 "change on set-point" works.
    change_on_set_point: bool,
    /// A set-point given while a move runs waits in a buffer (the RSE has none).
    set_point_buffer: bool,
}

#[derive(Clone, Copy, Debug)]
struct Sample {
    statusword: u16,
    rev: f64,
    rev_s: f64,
}

struct Drive<'a> {
    m: &'a InProcess,
    md: &'a MainDevice<'a>,
    group: DcGroup,
    samples: Vec<Sample>,
}

impl Drive<'_> {
    async fn cycle(&mut self, cw: u16, target: i32) -> Sample {
        let inputs =
            vendor::exchange_dc_command(self.m, self.md, &self.group, (cw, PP, target), CYCLE_NS)
                .await;
        let (rev, rev_s) = {
            let segment = self.m.shared.segment();
            let plant = &segment.drives()[0].servos[0].plant;
            (plant.mech_angle_rad() / TAU, plant.mech_speed_rad_s() / TAU)
        };
        let s = Sample {
            statusword: vendor::u16_at(&inputs, 0),
            rev,
            rev_s,
        };
        self.samples.push(s);
        s
    }

    /// A set-point: bit 4 low until bit 12 is clear (the drive can take one), bit 4 until the
    /// drive acknowledges it (bit 12), then bit 4 cleared.
    async fn set_point(&mut self, cw: u16, target: i32) -> Result<bool, String> {
        let mut free = false;
        for _ in 0..3_000 {
            if self.cycle(cw, target).await.statusword & SET_POINT_ACKNOWLEDGE == 0 {
                free = true;
                break;
            }
        }
        if !free {
            return Err(format!("bit 12 never fell before set-point {target}"));
        }
        let mut acknowledged = false;
        for _ in 0..50 {
            if self.cycle(cw | NEW_SET_POINT, target).await.statusword & SET_POINT_ACKNOWLEDGE != 0
            {
                acknowledged = true;
                break;
            }
        }
        if !acknowledged {
            return Err(format!("set-point {target} not acknowledged"));
        }
        self.cycle(cw, target).await;
        // Whether bit 12 still holds once bit 4 is down.
        Ok(self.cycle(cw, target).await.statusword & SET_POINT_ACKNOWLEDGE != 0)
    }
}

/// Runs `moves` (controlword bits 5/6/9, target in revolutions, absolute or relative per
/// `relative`) from rest at 0; the samples, or what went wrong.
async fn run(
    manual: &Manual,
    profile: &Profile,
    moves: [(u16, f64); 2],
    relative: bool,
) -> Result<Vec<Sample>, String> {
    let (m, transport) = master_for(board_sim::Segment::new(manual.profile, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let mut setup = vendor::remap(0x1600, 0x1C12, &OUTPUTS);
    setup.extend(vendor::remap(0x1A00, 0x1C13, &INPUTS));
    let speed = units::velocity(profile, SPEED_REV_S);
    let acceleration = units::acceleration(profile, ACCELERATION_REV_S2);
    for (index, value) in [
        (0x607F, 2 * speed),
        (0x6081, speed),
        (0x6083, acceleration),
        (0x6084, acceleration),
    ] {
        if profile.entry(index, 0).is_some() {
            setup.push(Sdo::U32(index, 0, value));
        }
    }
    let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
    let mut d = Drive {
        m: &m,
        md,
        group,
        samples: Vec::new(),
    };
    for _ in 0..vendor::SYNC0_START_CYCLES {
        d.cycle(0, 0).await;
    }
    let mut sw = 0;
    for cw in vendor::enable_sequence(20) {
        sw = d.cycle(cw, 0).await.statusword;
    }
    if !cia402::is(sw, cia402::OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    d.samples.clear();
    // Bit 6 as the profile reads it.
    let mode_bit = match (relative, manual.bit6_absolute) {
        (true, false) | (false, true) => BIT6,
        _ => 0,
    };
    let per_unit = units::increments_per_unit(profile);
    let units = |rev: f64| (rev * units::COUNTS_PER_REV / per_unit).round() as i32;
    let base = vendor::ENABLE_OPERATION | mode_bit;
    let (first_bits, first) = moves[0];
    let held = d.set_point(base | first_bits, units(first)).await?;
    // Without a buffer, bit 12 holds through a move started without bit 5; else it falls.
    let holds = !manual.set_point_buffer && first_bits & CHANGE_SET_IMMEDIATELY == 0;
    if held != holds {
        return Err(format!(
            "bit 12 after the first handshake: {held}, expected {holds}"
        ));
    }
    // The second set-point a third of the way into the first move.
    for _ in 0..100 {
        d.cycle(base | first_bits, units(first)).await;
    }
    let (second_bits, second) = moves[1];
    d.set_point(base | second_bits, units(second)).await?;
    for _ in 0..2_000 {
        let s = d.cycle(base | second_bits, units(second)).await;
        if s.statusword & cia402::TARGET_REACHED != 0 && s.rev_s.abs() < AT_REST_REV_S {
            break;
        }
    }
    Ok(d.samples)
}

/// The lowest speed while the rotor is near `rev`.
fn speed_at(samples: &[Sample], rev: f64) -> f64 {
    samples
        .iter()
        .filter(|s| (s.rev - rev).abs() < 0.02)
        .map(|s| s.rev_s.abs())
        .fold(f64::MAX, f64::min)
}

/// Ended on `rev` with target reached.
fn ended_on(samples: &[Sample], rev: f64) -> Result<(), String> {
    let last = samples.last().ok_or("no samples")?;
    if (last.rev - rev).abs() > 1e-3 || last.statusword & cia402::TARGET_REACHED == 0 {
        return Err(format!(
            "ended at {:.4} rev (statusword {:#06x}), the target is {rev} rev",
            last.rev, last.statusword
        ));
    }
    Ok(())
}

fn every_handshake(manual: Manual) {
    let profile = od_gen::builtin(manual.profile).expect("profile");
    let mut failures = Vec::new();
    block_on(async {
        // Set of set-points: stop on the first target, then the second.
        let r = run(&manual, &profile, [(0, FIRST_REV), (0, SECOND_REV)], false)
            .await
            .and_then(|s| {
                let at_first = speed_at(&s, FIRST_REV);
                if at_first > AT_REST_REV_S {
                    return Err(format!("passed the first target at {at_first:.2} rev/s"));
                }
                ended_on(&s, SECOND_REV)
            });
        if let Err(e) = r {
            failures.push(format!("set of set-points: {e}"));
        }
        // Change set immediately: straight on to the second target.
        let r = run(
            &manual,
            &profile,
            [
                (CHANGE_SET_IMMEDIATELY, FIRST_REV),
                (CHANGE_SET_IMMEDIATELY, SECOND_REV),
            ],
            false,
        )
        .await
        .and_then(|s| {
            let at_first = speed_at(&s, FIRST_REV);
            if at_first < SPEED_REV_S / 2.0 {
                return Err(format!("slowed to {at_first:.2} rev/s at the first target"));
            }
            ended_on(&s, SECOND_REV)
        });
        if let Err(e) = r {
            failures.push(format!("change set immediately: {e}"));
        }
        // Relative: 2 + 2 revolutions.
        let r = run(&manual, &profile, [(0, FIRST_REV), (0, FIRST_REV)], true)
            .await
            .and_then(|s| ended_on(&s, 2.0 * FIRST_REV));
        if let Err(e) = r {
            failures.push(format!("relative: {e}"));
        }
        // Change on set-point.
        let r = run(
            &manual,
            &profile,
            [
                (CHANGE_ON_SET_POINT, FIRST_REV),
                (CHANGE_ON_SET_POINT, SECOND_REV),
            ],
            false,
        )
        .await
        .and_then(|s| {
            let at_first = speed_at(&s, FIRST_REV);
            match manual.change_on_set_point {
                true if at_first < SPEED_REV_S / 2.0 => Err(format!(
                    "bit 9: slowed to {at_first:.2} rev/s at the first target"
                )),
                false if at_first > AT_REST_REV_S => Err(format!(
                    "bit 9 has no function, yet the first target passed at {at_first:.2} rev/s"
                )),
                _ => ended_on(&s, SECOND_REV),
            }
        });
        if let Err(e) = r {
            failures.push(format!("change on set-point: {e}"));
        }
    });
    assert!(
        failures.is_empty(),
        "{}:\n{}",
        manual.profile,
        failures.join("\n")
    );
}

#[test]
fn standard_profile_position_handshakes() {
    every_handshake(Manual {
        profile: "standard",
        bit6_absolute: false,
        change_on_set_point: true,
        set_point_buffer: true,
    });
}

#[test]
fn gha_e_profile_position_handshakes() {
    every_handshake(Manual {
        profile: "gha-e",
        bit6_absolute: false,
        change_on_set_point: false,
        set_point_buffer: true,
    });
}

#[test]
fn rse_profile_position_handshakes() {
    every_handshake(Manual {
        profile: "rse",
        bit6_absolute: false,
        change_on_set_point: false,
        set_point_buffer: false,
    });
}

#[test]
fn sdv3_e_profile_position_set_of_setpoints_and_handshakes() {
    every_handshake(Manual {
        profile: "sdv3-e",
        bit6_absolute: true,
        change_on_set_point: true,
        set_point_buffer: true,
    });
}

#[test]
fn osd_g_e_profile_position_handshakes() {
    every_handshake(Manual {
        profile: "osd-g-e",
        bit6_absolute: true,
        change_on_set_point: true,
        set_point_buffer: true,
    });
}

#[test]
fn sigma_v_sd_profile_position_handshakes() {
    every_handshake(Manual {
        profile: "sigma-v-sd",
        bit6_absolute: false,
        change_on_set_point: true,
        set_point_buffer: true,
    });
}
