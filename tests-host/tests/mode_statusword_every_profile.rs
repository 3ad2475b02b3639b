//! Statusword bits 10–13 ("operation mode specific") in every mode of every profile, end to
//! end (ethercrab, DC SYNC0 at 1 ms; 6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch mapped). The
//! drive goes through CSP, CST, CSV, PV and homing (method 35) at rest and at speed, and each
//! bit must show what the manual's statusword table says for the mode:
//!
//! | profile | CSP | CSV | CST | PV | HM | manual |
//! |---|---|---|---|---|---|---|
//! | standard, gha-e, sigma-v-sd | –, limit, follows, following error | –, limit, follows, – | –, limit, follows, – | reached, limit, speed zero, – | reached, limit, attained, error | CiA402; GHA-E §5.4; Σ-V-SD §4.7 |
//! | rse | reached, software limit, follows, following error | reached, software limit, follows, – | –, software limit, follows, – | reached, software limit, speed zero, – | reached, software limit, attained, error | 7.2 |
//! | sdv3-e, osd-g-e | reached, limit, synchronisation, following error | reached, speed zero, synchronisation, – | –, –, synchronisation, – | reached, speed zero, –, – | reached, –, attained, error | §7.5–§7.10 |
//!
//! (bits 10, 11, 12, 13; "follows": the drive follows the command value; "synchronisation":
//! SYNC0 and the master's data of the cycle normal; "software limit": the RSE's bit 11, the
//! position command or feedback beyond 607Dh and nothing else.) A CSP target beyond the
//! software limits sets bit 11 in every profile (internal limit, the SDV3-E's limiter, the
//! RSE's software limit); a torque at its limit does not on the RSE. The RSE also shows "home
//! found" on bit 15 from the first completed homing run on, in every mode (7.2).
//!
//! The tables here are the manuals', not the profile files': a profile that moved a bit the
//! wrong way fails.

use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{self, OPERATION_ENABLED, SWITCHED_ON};
use tests_host::vendor::{self, DcDrive, Sdo};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSP: i8 = 8;
const CSV: i8 = 9;
const CST: i8 = 10;
const PV: i8 = 3;
const HM: i8 = cia402::HOMING;
/// Homing method 35 (CiA402: the current position is the home), which every profile runs.
const HOME_HERE: i8 = 35;
const SPEED_REV_S: f64 = 5.0;
/// The profile ramps 6083h/6084h: 5 rev/s in 0.1 s.
const RAMP_REV_S2: f64 = 50.0;
/// Statusword bit 11.
const INTERNAL_LIMIT: u16 = 1 << 11;
/// Statusword bit 15 (manufacturer-specific).
const BIT_15: u16 = 1 << 15;

/// What a mode-specific bit shows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shows {
    Nothing,
    Reached,
    Limit,
    SoftwareLimit,
    SpeedZero,
    Follows,
    Synchronised,
    FollowingError,
    Attained,
    HomingError,
    /// The RSE's PT/CST "target torque reached" (2008h:0Ah-0Ch; `rse_torque_reached.rs`).
    TorqueReached,
}
use Shows::*;

/// The manual's bits 10–13 for `mode`.
fn manual(profile: &str, mode: i8) -> [Shows; 4] {
    let sdv3 = matches!(profile, "sdv3-e" | "osd-g-e");
    let rse = profile == "rse";
    match mode {
        CSP if sdv3 => [Reached, Limit, Synchronised, FollowingError],
        CSP if rse => [Reached, SoftwareLimit, Follows, FollowingError],
        CSP => [Nothing, Limit, Follows, FollowingError],
        CSV if sdv3 => [Reached, SpeedZero, Synchronised, Nothing],
        CSV if rse => [Reached, SoftwareLimit, Follows, Nothing],
        CSV => [Nothing, Limit, Follows, Nothing],
        CST if sdv3 => [Nothing, Nothing, Synchronised, Nothing],
        CST if rse => [TorqueReached, SoftwareLimit, Follows, Nothing],
        CST => [Nothing, Limit, Follows, Nothing],
        PV if sdv3 => [Reached, SpeedZero, Nothing, Nothing],
        PV if rse => [Reached, SoftwareLimit, SpeedZero, Nothing],
        PV => [Reached, Limit, SpeedZero, Nothing],
        HM if sdv3 => [Reached, Nothing, Attained, HomingError],
        HM if rse => [Reached, SoftwareLimit, Attained, HomingError],
        HM => [Reached, Limit, Attained, HomingError],
        _ => unreachable!("mode {mode}"),
    }
}

/// The conditions that hold at a point of the run.
#[derive(Clone, Copy, Debug, Default)]
struct Now {
    reached: bool,
    speed_zero: bool,
    follows: bool,
    synchronised: bool,
    attained: bool,
}

/// Bits 10–13 the manual's table gives for `now`.
fn expected(profile: &str, mode: i8, now: Now) -> u16 {
    let mut bits = 0;
    for (n, shows) in manual(profile, mode).iter().enumerate() {
        let on = match shows {
            Reached => now.reached,
            SpeedZero => now.speed_zero,
            Follows => now.follows,
            Synchronised => now.synchronised,
            Attained => now.attained,
            // Nothing is limited, lagging or failing in these runs; no torque is commanded
            // (the RSE's torque-reached reference is set above the standstill noise).
            Nothing | Limit | SoftwareLimit | FollowingError | HomingError | TorqueReached => false,
        };
        if on {
            bits |= 1 << (10 + n);
        }
    }
    bits
}

struct Run<'a> {
    bus: DcDrive<'a>,
    name: &'a str,
}

impl Run<'_> {
    /// `cycles` cycles of (cw, mode, 60FFh); the last statusword.
    async fn hold(&self, (cw, mode, velocity): (u16, i8, i32), cycles: usize) -> u16 {
        self.bus.hold_statusword((cw, mode, velocity), cycles).await
    }

    fn check(&self, what: &str, sw: u16, mode: i8, now: Now) {
        assert_eq!(
            sw & 0x3C00,
            expected(self.name, mode, now),
            "{}: {what}: statusword {sw:#06x} (mode {mode}, {now:?})",
            self.name
        );
    }
}

fn mode_bits(name: &str) {
    let profile: Profile = od_gen::builtin(name).expect("profile");
    let supported = cia402::supported_modes(&profile);
    let ramp = units::acceleration(&profile, RAMP_REV_S2);
    // 607Fh limits profile velocity (the RSE's default is 10,000 units/s): twice the speed.
    let setup = [
        Sdo::U32(0x607F, 0, units::velocity(&profile, 2.0 * SPEED_REV_S)),
        Sdo::U32(0x6083, 0, ramp),
        Sdo::U32(0x6084, 0, ramp),
        Sdo::I8(0x6098, 0, HOME_HERE),
    ];
    let mut setup = setup.to_vec();
    if name == "rse" {
        // Torque reached from 5 % of the rated torque (2008h:0Ah A; B = C = 0).
        setup.push(Sdo::U16(0x2008, 0x0A, 50));
    }
    if name == "gha-e" {
        // 606Dh counts instruction units/s (its velocity unit); the default 100 is below the
        // speed ripple of the simulated motor at 5 rev/s: 0.05 rev/s.
        let window = u16::try_from(units::velocity(&profile, 0.05)).expect("a UINT16");
        setup.push(Sdo::U16(0x606D, 0, window));
    }
    let speed = units::target_velocity(&profile, SPEED_REV_S);
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &setup), CSP, CYCLE_NS).await;
        let run = Run {
            bus: DcDrive {
                m: &m,
                md,
                group,
                cycle_ns: CYCLE_NS,
            },
            name,
        };
        let in_sync = Now {
            synchronised: true,
            ..Now::default()
        };
        let at_rest = Now {
            reached: true,
            speed_zero: true,
            follows: true,
            synchronised: true,
            attained: false,
        };

        // Switched On: the mode does not run; only the synchronisation shows.
        run.hold((vendor::SHUTDOWN, CSP, 0), 5).await;
        let sw = run.hold((vendor::SWITCH_ON, CSP, 0), 5).await;
        assert!(cia402::is(sw, SWITCHED_ON), "{name}: {sw:#06x}");
        run.check("switched on", sw, CSP, in_sync);

        // CSP at rest on its target (607Ah = 0, where the motor is).
        let sw = run.hold((vendor::ENABLE_OPERATION, CSP, 0), 50).await;
        assert!(cia402::is(sw, OPERATION_ENABLED), "{name}: {sw:#06x}");
        run.check("CSP at rest", sw, CSP, at_rest);

        // A CSP target (607Ah by SDO) beyond 607Dh: limited to it, bit 11 in every profile;
        // back inside, bit 11 clears; the limits off again (min = max).
        let w = (0.01 * units::COUNTS_PER_REV / units::increments_per_unit(&profile)) as i32;
        let sd = run.bus.group.subdevice(md, 0).expect("drive");
        for (sub, value) in [(1u8, -w), (2, w)] {
            sd.sdo_write(0x607D, sub, value).await.expect("607Dh");
        }
        sd.sdo_write(0x607A, 0, 2 * w).await.expect("607Ah");
        let sw = run.hold((vendor::ENABLE_OPERATION, CSP, 0), 20).await;
        assert_ne!(
            sw & INTERNAL_LIMIT,
            0,
            "{name}: CSP target beyond 607Dh: {sw:#06x}"
        );
        sd.sdo_write(0x607A, 0, 0i32).await.expect("607Ah");
        let sw = run.hold((vendor::ENABLE_OPERATION, CSP, 0), 50).await;
        assert_eq!(
            sw & INTERNAL_LIMIT,
            0,
            "{name}: back inside 607Dh: {sw:#06x}"
        );
        for sub in [1u8, 2] {
            sd.sdo_write(0x607D, sub, 0i32).await.expect("607Dh");
        }

        let sw = run.hold((vendor::ENABLE_OPERATION, CST, 0), 50).await;
        run.check("CST, no torque", sw, CST, at_rest);

        let sw = run.hold((vendor::ENABLE_OPERATION, CSV, 0), 50).await;
        run.check("CSV at rest", sw, CSV, at_rest);
        let sw = run.hold((vendor::ENABLE_OPERATION, CSV, speed), 600).await;
        let at_speed = Now {
            speed_zero: false,
            ..at_rest
        };
        run.check("CSV at speed", sw, CSV, at_speed);

        // A cycle without the master's frame: its SYNC0 came without new outputs. Where a bit
        // shows the synchronisation it drops for that cycle; "follows" does not.
        m.shared.advance(CYCLE_NS);
        let sw = run.hold((vendor::ENABLE_OPERATION, CSV, speed), 1).await;
        run.check(
            "CSV, the cycle without outputs",
            sw,
            CSV,
            Now {
                synchronised: false,
                ..at_speed
            },
        );
        let sw = run.hold((vendor::ENABLE_OPERATION, CSV, speed), 1).await;
        run.check("CSV, the next cycle", sw, CSV, at_speed);
        let sw = run.hold((vendor::ENABLE_OPERATION, CSV, 0), 600).await;
        run.check("CSV back at rest", sw, CSV, at_rest);

        if cia402::supports(supported, PV) {
            // Longer than the longest window time (the GHA-E's 606Eh: 100 ms).
            let sw = run.hold((vendor::ENABLE_OPERATION, PV, 0), 200).await;
            run.check("PV at rest", sw, PV, at_rest);
            let sw = run.hold((vendor::ENABLE_OPERATION, PV, speed), 600).await;
            run.check("PV at speed", sw, PV, at_speed);
            run.hold((vendor::ENABLE_OPERATION, PV, 0), 600).await;
        }

        // Homing method 35 at rest: attained and reached; bit 15 shows "home found" only in
        // the RSE, from then on in every mode.
        let before = run.hold((vendor::ENABLE_OPERATION, CSV, 0), 50).await;
        let sw = run
            .hold((vendor::ENABLE_OPERATION | cia402::HOMING_START, HM, 0), 50)
            .await;
        run.check(
            "homed",
            sw,
            HM,
            Now {
                attained: true,
                ..at_rest
            },
        );
        let after = run.hold((vendor::ENABLE_OPERATION, CSV, 0), 50).await;
        run.check("CSV after homing", after, CSV, at_rest);
        let home_found = name == "rse";
        assert_eq!(
            after & BIT_15 != before & BIT_15,
            home_found,
            "{name}: bit 15 before {before:#06x} / after homing {after:#06x}"
        );
        if home_found {
            assert_eq!(after & BIT_15, BIT_15, "{name}: home found");
        }
    });
}

#[test]
fn standard_mode_bits_are_cia402s() {
    mode_bits("standard");
}

#[test]
fn gha_e_mode_bits() {
    mode_bits("gha-e");
}

#[test]
fn sigma_v_sd_mode_bits() {
    mode_bits("sigma-v-sd");
}

#[test]
fn rse_mode_bits_with_target_reached_in_csp_csv_and_home_found_on_bit_15() {
    mode_bits("rse");
}

#[test]
fn sdv3_e_mode_bits_with_speed_zero_on_bit_11_and_synchronisation_on_bit_12() {
    mode_bits("sdv3-e");
}

#[test]
fn osd_g_e_mode_bits_as_the_sdv3_e() {
    mode_bits("osd-g-e");
}
