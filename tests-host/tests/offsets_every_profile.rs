//! The offsets of the cyclic synchronous modes on every profile that has them, end to end
//! (ethercrab, DC SYNC0 at 1 ms; 1600h: 6040h, 6060h, 607Ah; 1A00h: 6041h, 6064h, 606Ch; the
//! offsets written by SDO in OP, 60FFh and 6071h left at 0):
//!
//! - 60B0h position offset in CSP: the motor goes to 607Ah + 60B0h (CiA402; the RSE 6.3
//!   "target = 607A + 60B0"; the GHA-E §5 "all active"; the SDV3-E lists it);
//! - 60B1h velocity offset in CSV: with 60FFh = 0 the motor turns at 60B1h (CiA402; the RSE;
//!   the Σ-V-SD §6.6 "60B1h added to the velocity reference"; the GHA-E);
//! - 60B2h torque offset in CST: with 6071h = 0 the torque demand is 60B2h and the free motor
//!   accelerates (CiA402; the RSE; the Σ-V-SD "60B2h added to the torque reference"; the
//!   GHA-E, whose 60B2h is an INT32).

use board_sim::Segment;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcDrive};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSP: i8 = 8;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const CST: i8 = 10;
/// 60B0h: a tenth of a turn.
const POSITION_OFFSET_REV: f64 = 0.1;
/// 60B1h: 2 rev/s.
const VELOCITY_OFFSET_REV_S: f64 = 2.0;
/// 60B2h: 5 % of the rated torque (0.1 % units).
const TORQUE_OFFSET_PERMILLE: i32 = 50;
/// How far from the expected position or speed the motor may end (the loops at rest).
const POSITION_TOLERANCE_REV: f64 = 0.002;
const VELOCITY_TOLERANCE_REV_S: f64 = 0.05;

struct Drive<'a> {
    bus: DcDrive<'a>,
    profile: &'a Profile,
}

impl Drive<'_> {
    /// `n` cycles of (cw, mode, 607Ah); the last (statusword, 6064h, 606Ch).
    async fn hold(&self, command: (u16, i8, i32), n: usize) -> (u16, i32, i32) {
        let inputs = self.bus.hold(command, n).await;
        (
            vendor::u16_at(&inputs, 0),
            vendor::i32_at(&inputs, 2),
            vendor::i32_at(&inputs, 6),
        )
    }

    /// Writes `value` into `index`:00 at the entry's size.
    async fn write(&self, index: u16, value: i32) {
        let sd = self.bus.group.subdevice(self.bus.md, 0).expect("drive");
        let len = self
            .profile
            .entry(index, 0)
            .map(|e| e.initial_bytes().len())
            .expect("the object");
        let written = match len {
            2 => sd.sdo_write(index, 0, value as i16).await,
            _ => sd.sdo_write(index, 0, value).await,
        };
        written.unwrap_or_else(|e| panic!("{index:04X}h: {e:?}"));
    }
}

/// What the offsets did: where CSP ended (rev from the start), the CSV speed (rev/s), the CST
/// torque demand 6074h and speed after 100 ms; `None` where the profile lacks the object or
/// the mode.
#[derive(Clone, Copy, Debug, Default)]
struct Outcome {
    csp_rev: Option<f64>,
    csv_rev_s: Option<f64>,
    cst: Option<(i16, f64)>,
}

fn offsets(name: &str) -> Outcome {
    let profile = od_gen::builtin(name).expect("profile");
    let supported = cia402::supported_modes(&profile);
    let has = |index: u16| profile.entry(index, 0).is_some();
    let units_per_rev = units::COUNTS_PER_REV / units::increments_per_unit(&profile);
    let rev_s = |v: i32| f64::from(v) / f64::from(units::velocity(&profile, 1.0));
    block_on(async {
        let (m, transport) = master_for(Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let sdos = vendor::mapping(
            &[(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)],
            &[(0x6041, 0, 16), (0x6064, 0, 32), (0x606C, 0, 32)],
        );
        let group = vendor::into_op_dc(&m, md, &sdos, CYCLE_NS).await;
        let d = Drive {
            bus: DcDrive {
                m: &m,
                md,
                group,
                cycle_ns: CYCLE_NS,
            },
            profile: &profile,
        };
        let (_, start, _) = d.hold((0, CSP, 0), vendor::SYNC0_START_CYCLES).await;
        for cw in vendor::enable_sequence(20) {
            d.hold((cw, CSP, start), 1).await;
        }
        let (sw, start, _) = d.hold((vendor::ENABLE_OPERATION, CSP, start), 20).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "{name}: {sw:#06x}"
        );
        let run = (vendor::ENABLE_OPERATION, CSP, start);
        let mut out = Outcome::default();
        if has(0x60B0) && cia402::supports(supported, CSP) {
            let offset = (POSITION_OFFSET_REV * units_per_rev).round() as i32;
            d.write(0x60B0, offset).await;
            let (_, position, _) = d.hold(run, 500).await;
            out.csp_rev = Some(f64::from(position - start) / units_per_rev);
            d.write(0x60B0, 0).await;
            d.hold(run, 500).await;
        }
        if has(0x60B1) && cia402::supports(supported, CSV) {
            let offset = units::target_velocity(&profile, VELOCITY_OFFSET_REV_S);
            d.write(0x60B1, offset).await;
            let (_, _, velocity) = d.hold((vendor::ENABLE_OPERATION, CSV, 0), 500).await;
            out.csv_rev_s = Some(rev_s(velocity));
            d.write(0x60B1, 0).await;
            d.hold((vendor::ENABLE_OPERATION, CSV, 0), 500).await;
        }
        if has(0x60B2) && cia402::supports(supported, CST) {
            d.write(0x60B2, TORQUE_OFFSET_PERMILLE).await;
            let (_, _, velocity) = d.hold((vendor::ENABLE_OPERATION, CST, 0), 100).await;
            let sd = d.bus.group.subdevice(md, 0).expect("drive");
            let demand: i16 = sd.sdo_read(0x6074, 0).await.expect("6074h");
            out.cst = Some((demand, rev_s(velocity)));
            d.write(0x60B2, 0).await;
        }
        out
    })
}

/// Checks `name`'s outcome; `expected` lists the offsets its manual has ("60B0h", ...).
fn check(name: &str, expected: &[&str]) {
    let o = offsets(name);
    let listed = |object: &str| expected.contains(&object);
    assert_eq!(o.csp_rev.is_some(), listed("60B0h"), "{name}: 60B0h {o:?}");
    assert_eq!(
        o.csv_rev_s.is_some(),
        listed("60B1h"),
        "{name}: 60B1h {o:?}"
    );
    assert_eq!(o.cst.is_some(), listed("60B2h"), "{name}: 60B2h {o:?}");
    if let Some(rev) = o.csp_rev {
        assert!(
            (rev - POSITION_OFFSET_REV).abs() < POSITION_TOLERANCE_REV,
            "{name}: CSP with 60B0h ended {rev} rev from 607Ah"
        );
    }
    if let Some(speed) = o.csv_rev_s {
        assert!(
            (speed - VELOCITY_OFFSET_REV_S).abs() < VELOCITY_TOLERANCE_REV_S,
            "{name}: CSV with 60B1h at {speed} rev/s"
        );
    }
    if let Some((demand, speed)) = o.cst {
        assert_eq!(
            i32::from(demand),
            TORQUE_OFFSET_PERMILLE,
            "{name}: 6074h in CST with 60B2h"
        );
        assert!(
            speed > 0.1,
            "{name}: the torque turns the motor: {speed} rev/s"
        );
    }
}

#[test]
fn standard_offsets_are_cia402s() {
    check("standard", &["60B0h", "60B1h", "60B2h"]);
}

#[test]
fn gha_e_offsets_are_all_active() {
    check("gha-e", &["60B0h", "60B1h", "60B2h"]);
}

#[test]
fn rse_offsets_add_to_the_targets() {
    check("rse", &["60B0h", "60B1h", "60B2h"]);
}

#[test]
fn sdv3_e_and_osd_g_e_have_the_position_offset() {
    check("sdv3-e", &["60B0h"]);
    check("osd-g-e", &["60B0h"]);
}

#[test]
fn sigma_v_sd_velocity_and_torque_offsets() {
    check("sigma-v-sd", &["60B1h", "60B2h"]);
}
