//! The touch probes of every profile, end to end: ethercrab runs the simulated motor at 100 rpm
//! in cyclic synchronous velocity (DC SYNC0 at 1 ms; 6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch
//! mapped) past two probe sensors (marks at known angles in the simulated plant) and its
//! encoder index (the single-turn zero at every whole revolution), with 60B8h set by SDO in
//! PREOP. Two runs per profile use both probes on the external input and on the index pulse
//! where the manual has that source, single and continuous trigger, rising and falling edges
//! where the manual has them. The latched positions 60BAh–60BDh must equal the simulated edges
//! within one encoder count (in the profile's position unit), 60B9h must show each probe
//! enabled and its stored edges, and the counters 60D5h–60D8h count the edges where the
//! profile has them.
//!
//! | profile | index source | falling edge (60BBh/60BDh) | set-up | manual |
//! |---|---|---|---|---|
//! | standard | both probes | yes | — | CiA402 |
//! | gha-e | both probes (bit 2/10: DI7/DI8 or Z) | yes | — | §6.8 |
//! | rse | none (bit 2 "meaningless") | yes | — | 7.9 |
//! | sdv3-e, osd-g-e | both probes (Z) | yes | EXT1/EXT2 on EI3/EI5 (3002h:03/05 = 40/41) | §7.12 |
//! | sigma-v-sd, sigma-v-sd-2axis (axis 2) | probe 1 only (phase C) | no (one sampling enable) | — | §6.10 |
//!
//! 60B9h bits 6/7 (14/15 for probe 2), which CiA402 leaves to the manufacturer, as each manual
//! has them: the SDV3-E's and OSD-G-E's bit 6 shows the trigger source (1 = Z phase) and bit 7
//! toggles on every stored position (§7.12), the Σ-V-SD's bit 7 toggles likewise (§6.10), the
//! RSE's bit 7 is the probe input's level (7.9); elsewhere they stay 0.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{self, OPERATION_ENABLED};
use tests_host::vendor::{self, DcGroup, Sdo};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const SPEED_REV_S: f64 = 100.0 / 60.0;
/// 60B8h bits of probe 1 (probe 2: << 8).
const ENABLE: u16 = 1 << 0;
const CONTINUOUS: u16 = 1 << 1;
const SOURCE_INDEX: u16 = 1 << 2;
const RISING: u16 = 1 << 4;
const FALLING: u16 = 1 << 5;
/// 60B9h bits of probe 1 (probe 2: << 8): enabled, rising edge stored, falling edge stored.
const ENABLED: u16 = 1 << 0;
const RISING_STORED: u16 = 1 << 1;
const FALLING_STORED: u16 = 1 << 2;
/// 60B9h bits 6 and 7 of probe 1 (manufacturer-specific).
const BIT6: u16 = 1 << 6;
const BIT7: u16 = 1 << 7;
/// The motor starts here and runs to `END_REV`; the sensors' active ranges, revolutions.
const START_REV: f64 = -0.5;
const END_REV: f64 = 2.2;
const PROBE1: (f64, f64) = (0.3, 0.6);
const PROBE2: (f64, f64) = (1.45, 1.55);

/// A profile's touch probes, as its manual describes them.
struct Probes {
    profile: &'static str,
    axis: usize,
    /// Each probe can latch the index pulse.
    index: [bool; 2],
    /// The probes latch falling edges (60BBh, 60BDh).
    falling: bool,
    /// SDO writes the probes need first.
    setup: &'static [Sdo],
    /// What 60B9h bit 7 (15) shows.
    bit7: Bit7,
    /// 60B9h bit 6 (14) shows the trigger source (1 = index).
    bit6_source: bool,
}

/// What 60B9h bit 7 (15) shows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Bit7 {
    /// Nothing (0).
    Nothing,
    /// Toggles on every stored position.
    Toggle,
    /// The probe input's level.
    Level,
}

impl Probes {
    /// Axis 1's object `index` on the axis under test.
    fn object(&self, index: u16) -> u16 {
        vendor::axis_object(index, self.axis)
    }
}

/// One probe's configuration in a run and what it must latch (revolutions).
#[derive(Clone, Copy, Debug)]
struct Use {
    function: u16,
    rising_at: f64,
    /// Where the falling edge is latched (when the function asks for it).
    falling_at: Option<f64>,
    /// Edges counted (rising, falling) where the profile has 60D5h–60D8h.
    counts: (u16, u16),
}

/// The two runs of a profile: probe 1 on its input (single, both edges) and probe 2 on the
/// index (continuous, rising), or on its input where it has no index source; then probe 1 on
/// the index (continuous) and probe 2 on its input (single, both edges).
fn runs(p: &Probes) -> [[Use; 2]; 2] {
    let edges = |falling: bool| RISING | if falling { FALLING } else { 0 };
    let input_single = |(a, b): (f64, f64)| Use {
        function: ENABLE | edges(p.falling),
        rising_at: a,
        falling_at: p.falling.then_some(b),
        counts: (1, u16::from(p.falling)),
    };
    // Index pulses at 0, 1 and 2 revolutions on the way: continuous keeps the last.
    let index_continuous = Use {
        function: ENABLE | CONTINUOUS | SOURCE_INDEX | RISING,
        rising_at: 2.0,
        falling_at: None,
        counts: (3, 0),
    };
    let input_continuous = |(a, _): (f64, f64)| Use {
        function: ENABLE | CONTINUOUS | RISING,
        rising_at: a,
        falling_at: None,
        counts: (1, 0),
    };
    let on_index_or_input = |probe: usize, sensor| {
        if p.index[probe] {
            index_continuous
        } else {
            input_continuous(sensor)
        }
    };
    [
        [input_single(PROBE1), on_index_or_input(1, PROBE2)],
        [on_index_or_input(0, PROBE1), input_single(PROBE2)],
    ]
}

async fn cycle(m: &InProcess, md: &MainDevice<'_>, group: &DcGroup, cw: u16, velocity: i32) -> u16 {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, CSV, velocity), CYCLE_NS).await;
    vendor::u16_at(&inputs, 0)
}

/// One run: the probes set to `uses`, the motor from [`START_REV`] to [`END_REV`]; what is
/// wrong, if anything.
async fn run(p: &Probes, profile: &Profile, uses: [Use; 2]) -> Result<(), String> {
    let o = |index| p.object(index);
    let (m, transport) = master_for(board_sim::Segment::new(p.profile, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    vendor::place_probe_sensors(&m, p.axis, [PROBE1, PROBE2]);
    m.shared.segment().drives_mut()[0].servos[p.axis]
        .plant
        .set_rotor_position(START_REV * TAU);
    let mut setup = p.setup.to_vec();
    let function = uses[0].function | uses[1].function << 8;
    setup.push(Sdo::U16(o(0x60B8), 0, function));
    let group = vendor::into_op_dc_velocity(&m, md, (p.axis, &setup), CSV, CYCLE_NS).await;
    let mut sw = 0;
    for cw in vendor::enable_sequence(20) {
        sw = cycle(&m, md, &group, cw, 0).await;
    }
    if !cia402::is(sw, OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    let velocity = units::velocity(profile, SPEED_REV_S) as i32;
    let rotor = |m: &InProcess| {
        m.shared.segment().drives()[0].servos[p.axis]
            .plant
            .mech_angle_rad()
            / TAU
    };
    let mut cycles = 0;
    let sd = group.subdevice(md, 0).expect("drive");
    let mut level_seen = [false; 2];
    while rotor(&m) < END_REV {
        cycles += 1;
        if cycles > 5_000 {
            return Err(format!("the motor did not get there: {:.2} rev", rotor(&m)));
        }
        cycle(&m, md, &group, vendor::ENABLE_OPERATION, velocity).await;
        // Inside a sensor's range (a few cycles in): an input-level bit 7 shows it.
        let here = rotor(&m);
        for (n, (a, b)) in [PROBE1, PROBE2].into_iter().enumerate() {
            if p.bit7 == Bit7::Level && !level_seen[n] && here > a + 0.02 && here < b - 0.02 {
                level_seen[n] = true;
                let status = sd
                    .sdo_read::<u16>(o(0x60B9), 0)
                    .await
                    .map_err(|e| format!("60B9h: {e:?}"))?;
                if status & BIT7 << (8 * n) == 0 {
                    return Err(format!(
                        "probe {} input active, 60B9h {status:#06x}: bit {} clear",
                        n + 1,
                        7 + 8 * n
                    ));
                }
            }
        }
    }
    if p.bit7 == Bit7::Level && level_seen != [true; 2] {
        return Err("never inside a sensor's range".into());
    }
    let read_i32 = |index| {
        let sd = &sd;
        async move {
            sd.sdo_read::<i32>(o(index), 0)
                .await
                .map_err(|e| format!("{index:04X}h: {e:?}"))
        }
    };
    let per_unit = units::increments_per_unit(profile);
    let at = |latched: i32, rev: f64, what: &str| {
        // One encoder count, and the rounding of the position unit.
        let off = f64::from(latched) * per_unit - rev * units::COUNTS_PER_REV;
        if off.abs() > 1.0 + per_unit {
            Err(format!(
                "{what}: latched {latched}, the edge is at {rev} rev ({off:.1} increments off)"
            ))
        } else {
            Ok(())
        }
    };
    let status = sd
        .sdo_read::<u16>(o(0x60B9), 0)
        .await
        .map_err(|e| format!("60B9h: {e:?}"))?;
    let mut expected_status = 0;
    let objects = [
        (0x60BA, 0x60BB, 0x60D5, 0x60D6),
        (0x60BC, 0x60BD, 0x60D7, 0x60D8),
    ];
    for (n, (u, (rising, falling, rising_count, falling_count))) in
        uses.iter().zip(objects).enumerate()
    {
        let shift = 8 * n;
        expected_status |= (ENABLED | RISING_STORED) << shift;
        at(
            read_i32(rising).await?,
            u.rising_at,
            &format!("probe {} rising", n + 1),
        )?;
        if let Some(rev) = u.falling_at {
            expected_status |= FALLING_STORED << shift;
            at(
                read_i32(falling).await?,
                rev,
                &format!("probe {} falling", n + 1),
            )?;
        }
        if profile.entry(o(rising_count), 0).is_some() {
            let counts = (
                sd.sdo_read::<u16>(o(rising_count), 0)
                    .await
                    .map_err(|e| format!("{e:?}"))?,
                sd.sdo_read::<u16>(o(falling_count), 0)
                    .await
                    .map_err(|e| format!("{e:?}"))?,
            );
            if counts != u.counts {
                return Err(format!(
                    "probe {} counters {counts:?}, expected {:?}",
                    n + 1,
                    u.counts
                ));
            }
        }
    }
    // Bits 6/7 and 14/15, the profiles' own (the motor is past both sensors now).
    for (n, u) in uses.iter().enumerate() {
        let shift = 8 * n;
        if p.bit6_source && u.function & SOURCE_INDEX != 0 {
            expected_status |= BIT6 << shift;
        }
        let stores = u.counts.0 + u.counts.1;
        if p.bit7 == Bit7::Toggle && stores % 2 == 1 {
            expected_status |= BIT7 << shift;
        }
    }
    const MASK: u16 = 0xC7C7;
    if status & MASK != expected_status {
        return Err(format!(
            "60B9h {status:#06x}, expected {expected_status:#06x} under {MASK:#06x}"
        ));
    }
    Ok(())
}

fn every_probe_use(p: Probes) {
    let profile = od_gen::builtin(p.profile).expect("profile");
    let mut failures = Vec::new();
    block_on(async {
        for (k, uses) in runs(&p).into_iter().enumerate() {
            if let Err(e) = run(&p, &profile, uses).await {
                failures.push(format!(
                    "run {} (60B8h = {:#06x}): {e}",
                    k + 1,
                    uses[0].function | uses[1].function << 8
                ));
            }
        }
    });
    assert!(
        failures.is_empty(),
        "{}:\n{}",
        p.profile,
        failures.join("\n")
    );
}

#[test]
fn standard_touch_probes_latch_every_edge_and_source() {
    every_probe_use(Probes {
        profile: "standard",
        axis: 0,
        index: [true, true],
        falling: true,
        setup: &[],
        bit7: Bit7::Nothing,
        bit6_source: false,
    });
}

#[test]
fn gha_e_touch_probes_latch_every_edge_and_source() {
    every_probe_use(Probes {
        profile: "gha-e",
        axis: 0,
        index: [true, true],
        falling: true,
        setup: &[],
        bit7: Bit7::Nothing,
        bit6_source: false,
    });
}

#[test]
fn rse_touch_probes_latch_every_edge_on_the_input() {
    every_probe_use(Probes {
        profile: "rse",
        axis: 0,
        index: [false, false],
        falling: true,
        setup: &[],
        bit7: Bit7::Level,
        bit6_source: false,
    });
}

/// §7.12: EXT1 and EXT2 are EI functions 40 and 41, captured on EI3-EI5 (P3.03-P3.05).
const SDV3_E_EXT_INPUTS: &[Sdo] = &[Sdo::I32(0x3002, 3, 40), Sdo::I32(0x3002, 5, 41)];

#[test]
fn sdv3_e_touch_probes_latch_every_edge_and_source() {
    every_probe_use(Probes {
        profile: "sdv3-e",
        axis: 0,
        index: [true, true],
        falling: true,
        setup: SDV3_E_EXT_INPUTS,
        bit7: Bit7::Toggle,
        bit6_source: true,
    });
}

#[test]
fn osd_g_e_touch_probes_latch_every_edge_and_source() {
    every_probe_use(Probes {
        profile: "osd-g-e",
        axis: 0,
        index: [true, true],
        falling: true,
        setup: SDV3_E_EXT_INPUTS,
        bit7: Bit7::Toggle,
        bit6_source: true,
    });
}

#[test]
fn sigma_v_sd_touch_probes_latch_on_input_and_phase_c() {
    every_probe_use(Probes {
        profile: "sigma-v-sd",
        axis: 0,
        index: [true, false],
        falling: false,
        setup: &[],
        bit7: Bit7::Toggle,
        bit6_source: false,
    });
}

#[test]
fn sigma_v_sd_2axis_axis_2_touch_probes_latch_on_input_and_phase_c() {
    every_probe_use(Probes {
        profile: "sigma-v-sd-2axis",
        axis: 1,
        index: [true, false],
        falling: false,
        setup: &[],
        bit7: Bit7::Toggle,
        bit6_source: false,
    });
}

/// GHA-E §5.7.3: positions are in instruction units, increments = units × 6091h:01 / 6091h:02.
/// A stored touch-probe position is an encoder position: a new gear ratio shows it in the new
/// units at once (CiA402 60BAh is a position value in user units), though no edge happened
/// since. Probe 1 latches its sensor's rising edge; 6091h:02 is then doubled by SDO (half as
/// many increments per unit), and 60BAh must read twice its value within the rounding.
#[test]
fn gha_e_stored_probe_positions_follow_a_new_gear_ratio() {
    let profile = od_gen::builtin("gha-e").expect("profile");
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        vendor::place_probe_sensors(&m, 0, [PROBE1, PROBE2]);
        let setup = [Sdo::U16(0x60B8, 0, ENABLE | RISING)];
        let group = vendor::into_op_dc_velocity(&m, md, (0, &setup), CSV, CYCLE_NS).await;
        for cw in vendor::enable_sequence(20) {
            cycle(&m, md, &group, cw, 0).await;
        }
        let velocity = units::velocity(&profile, SPEED_REV_S) as i32;
        let rotor = |m: &InProcess| {
            m.shared.segment().drives()[0].servos[0]
                .plant
                .mech_angle_rad()
                / TAU
        };
        let mut cycles = 0;
        while rotor(&m) < PROBE1.1 {
            cycles += 1;
            assert!(cycles < 5_000, "the motor did not get past the sensor");
            cycle(&m, md, &group, vendor::ENABLE_OPERATION, velocity).await;
        }
        cycle(&m, md, &group, vendor::ENABLE_OPERATION, 0).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let before: i32 = sd.sdo_read(0x60BA, 0).await.expect("60BAh");
        let per_unit = units::increments_per_unit(&profile);
        let off = f64::from(before) * per_unit - PROBE1.0 * units::COUNTS_PER_REV;
        assert!(
            off.abs() <= 1.0 + per_unit,
            "60BAh {before}: {off:.1} increments off the edge"
        );
        let denominator: u32 = sd.sdo_read(0x6091, 2).await.expect("6091h:02");
        sd.sdo_write(0x6091, 2, 2 * denominator)
            .await
            .expect("6091h:02");
        for _ in 0..2 {
            cycle(&m, md, &group, vendor::ENABLE_OPERATION, 0).await;
        }
        let after: i32 = sd.sdo_read(0x60BA, 0).await.expect("60BAh");
        assert!(
            (i64::from(after) - 2 * i64::from(before)).abs() <= 1,
            "60BAh {before} before, {after} with 6091h:02 doubled: expected about {}",
            2 * before
        );
    });
}
