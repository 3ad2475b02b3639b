//! Homing mode (CiA402 / IEC 61800-7-201, 6060h = 6) on the simulated servo with simulated
//! limit and home switches, commanded by ethercrab over the standard profile's default PDOs
//! (6040h, 607Ah, 6060h / 6041h, 6064h, 6061h) in free run, 6098h and 607Ch set by SDO.
//!
//! The servo's absolute encoder gives its single-turn zero as the index pulse (one per
//! revolution, at whole revolutions). Each method must find the home its CiA402 figure defines,
//! stop on it, and make 6064h read the home offset 607Ch there; statusword bits 13/12/10 follow
//! the homing status table.

use std::f64::consts::TAU;

use board_sim::plant::SwitchParams;
use ethercrab::MainDevice;
use tests_host::cia402::{
    self, HOMING_ATTAINED, HOMING_BITS, HOMING_ERROR, HOMING_START, TARGET_REACHED,
};
use tests_host::csp::{self, Sample};
use tests_host::{block_on, master};

const CPR: f64 = (1u32 << 20) as f64;
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const HM: i8 = cia402::HOMING;
/// The home offset the tests set: the home position reads as this.
const HOME_OFFSET: i32 = 1_000;

/// A machine: switch positions in revolutions.
struct Machine {
    negative_limit: Option<f64>,
    positive_limit: Option<f64>,
    home: Option<(f64, Option<f64>)>,
}

impl Machine {
    fn switches(&self) -> SwitchParams {
        SwitchParams {
            limit_neg_rad: self.negative_limit.map(|r| r * TAU),
            limit_pos_rad: self.positive_limit.map(|r| r * TAU),
            home_rad: self.home.map(|(a, _)| a * TAU),
            home_end_rad: self.home.and_then(|(_, b)| b.map(|b| b * TAU)),
            probes: [None; 2],
        }
    }
}

/// Limits at ±3 revolutions.
const LIMITS: Machine = Machine {
    negative_limit: Some(-3.0),
    positive_limit: Some(3.0),
    home: None,
};

/// The result of a homing run: the samples, and the rotor's position at the end (rev).
struct Run {
    samples: Vec<Sample>,
}

impl Run {
    fn last(&self) -> &Sample {
        self.samples.last().expect("samples")
    }
}

/// Homes with `method` on `machine`, the rotor starting at `start` revolutions: enabled in
/// homing mode, bit 4 raised and held for up to `cycles` cycles (stopping early once the
/// statusword shows completion or an error at rest).
macro_rules! home {
    ($machine:expr, $start:expr, $method:expr, $cycles:expr) => {{
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        {
            let mut segment = m.shared.segment();
            let servo = &mut segment.drives_mut()[0].servos[0];
            servo.plant.set_switches($machine.switches());
            servo.plant.set_rotor_position($start * TAU);
        }
        let group = csp::into_op_with_mode(&m, md, HM).await;
        {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(0x6098, 0, $method as i8).await.expect("6098h");
            sd.sdo_write(0x607C, 0, HOME_OFFSET).await.expect("607Ch");
        }
        let mut s = csp::phase_locked(&m, md, &group, 0, 0, HM).await;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 20])
        {
            s = csp::phase_locked(&m, md, &group, cw, 0, HM).await;
        }
        assert_eq!(s.statusword & STATE_MASK, OPERATION_ENABLED, "enabled");
        assert_eq!(
            s.statusword & HOMING_BITS,
            TARGET_REACHED,
            "homing not started"
        );
        let mut samples = Vec::new();
        for k in 0..$cycles {
            let s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION | HOMING_START, 0, HM).await;
            samples.push(s);
            let done = s.statusword & HOMING_BITS;
            if k > 5 && (done == HOMING_ATTAINED | TARGET_REACHED || done & HOMING_ERROR != 0) {
                // A few more cycles to see it stays.
                for _ in 0..20 {
                    samples.push(
                        csp::phase_locked(&m, md, &group, ENABLE_OPERATION | HOMING_START, 0, HM)
                            .await,
                    );
                }
                break;
            }
        }
        Run { samples }
    }};
}

/// Asserts a completed homing at `home_rev`: the rotor on it (within `tolerance` increments),
/// 6064h = 607Ch there, bits 12 and 10 set, no error.
fn assert_homed(run: &Run, home_rev: f64, tolerance: f64) {
    let last = run.last();
    assert_eq!(
        last.statusword & HOMING_BITS,
        HOMING_ATTAINED | TARGET_REACHED,
        "homing completed (statusword {:#06x})",
        last.statusword
    );
    let off = (last.revolutions - home_rev) * CPR;
    assert!(
        off.abs() <= tolerance,
        "rotor {off:.0} increments from the home at {home_rev} rev"
    );
    // The actual position reads the home offset at the home (plus the rotor's offset from it).
    let expected = f64::from(HOME_OFFSET) + off;
    assert!(
        (f64::from(last.position) - expected).abs() <= 60.0,
        "6064h = {} at the home, expected {expected:.0} (607Ch = {HOME_OFFSET})",
        last.position
    );
    // In progress while moving: bits 13/12/10 = 0/0/0.
    assert!(
        run.samples
            .iter()
            .any(|s| s.statusword & HOMING_BITS == 0 && s.rpm.abs() > 20.0),
        "in progress shows 0/0/0"
    );
}

#[test]
fn standard_homing_method_37_takes_the_current_position() {
    block_on(async {
        let run = home!(LIMITS, 0.3, 37, 100);
        assert_eq!(
            run.last().statusword & HOMING_BITS,
            HOMING_ATTAINED | TARGET_REACHED
        );
        assert!(
            (run.last().position - HOME_OFFSET).abs() <= 60,
            "{}",
            run.last().position
        );
        assert!((run.last().revolutions - 0.3).abs() < 1e-3, "no motion");
    });
}

#[test]
fn standard_homing_method_19_home_switch_edge_from_either_side() {
    // Home switch active from 1.5 rev up; method 19: home where it turns off moving negative.
    let machine = Machine {
        home: Some((1.5, None)),
        ..LIMITS
    };
    block_on(async {
        for start in [0.0, 2.2] {
            let run = home!(machine, start, 19, 4_000);
            assert_homed(&run, 1.5, 40.0);
        }
    });
}

#[test]
fn standard_homing_method_3_home_switch_then_index() {
    // Method 3: the first index pulse left of the edge at 1.5 rev: the single-turn zero at 1.
    let machine = Machine {
        home: Some((1.5, None)),
        ..LIMITS
    };
    block_on(async {
        let run = home!(machine, 0.2, 3, 5_000);
        assert_homed(&run, 1.0, 40.0);
    });
}

#[test]
fn standard_homing_method_1_negative_limit_then_index() {
    // Negative limit at -2.3 rev: the first index right of it is at -2 rev.
    let machine = Machine {
        negative_limit: Some(-2.3),
        ..LIMITS
    };
    block_on(async {
        let run = home!(machine, 0.4, 1, 6_000);
        assert_homed(&run, -2.0, 40.0);
    });
}

#[test]
fn standard_homing_method_10_home_cam_right_edge_then_index() {
    // Cam 1.2..1.7 rev; method 10: right edge, then the index to its right (2 rev); starting
    // right of the cam the positive search runs into the positive limit and reverses.
    let machine = Machine {
        home: Some((1.2, Some(1.7))),
        positive_limit: Some(2.5),
        ..LIMITS
    };
    block_on(async {
        for start in [0.0, 2.1] {
            let run = home!(machine, start, 10, 8_000);
            assert_homed(&run, 2.0, 40.0);
        }
    });
}

#[test]
fn standard_homing_errors_and_interruption() {
    block_on(async {
        // Method 0 is no method: homing error at rest (13/12/10 = 1/0/1).
        let run = home!(LIMITS, 0.0, 0, 50);
        assert_eq!(
            run.last().statusword & HOMING_BITS,
            HOMING_ERROR | TARGET_REACHED
        );
        // A home switch that is not there: the search reverses at one limit and fails at the
        // other, stopped (13 = 1).
        let machine = Machine {
            negative_limit: Some(-0.5),
            positive_limit: Some(0.5),
            home: None,
        };
        let run = home!(machine, 0.0, 7, 4_000);
        let last = run.last();
        assert_eq!(last.statusword & HOMING_ERROR, HOMING_ERROR);
        assert!(
            last.revolutions.abs() < 0.7,
            "stopped near a limit: {}",
            last.revolutions
        );
    });
}
