//! Every homing method of every profile, end to end: ethercrab takes the simulated drive to OP
//! (DC, SYNC0 every 1 ms: the GHA-E runs in DC only) with 6040h, 6060h, 607Ah / 6041h, 6061h, 6064h mapped, sets the method
//! 6098h, the home offset 607Ch, the speeds 6099h and the acceleration 609Ah in the profile's
//! units, enables in homing mode and starts homing with controlword bit 4. The simulated servo
//! has limit switches, a home switch or cam, and its encoder's single-turn zero as the index
//! pulse (one per revolution, at whole revolutions).
//!
//! The expected home comes from the CiA402 figure of each method (IEC 61800-7-201, homing
//! mode), written here as geometry independent of the firmware's tables: which switch edge,
//! and whether the home is that edge or the index pulse to its left or right. Each method runs
//! from every start its figure draws a path from: outside and inside the home switch, and
//! beyond a home cam so that the search reverses at the limit switch. The home must be found,
//! the motor must stop on it, 6064h must read 607Ch there, and the statusword must show
//! 13/12/10 = 0/0/1 before the start, 0/0/0 while searching and 0/1/1 at the end. The path
//! follows the figure: the first motion in the figure's initial direction (by the switch's
//! state at the start), never faster than 6099h:01, a search for a switch at 6099h:01, and
//! the approach onto the home at the zero-search speed 6099h:02.
//!
//! Each profile runs the methods its manual lists, as the manual defines them:
//!
//! | profile | methods | manual |
//! |---|---|---|
//! | standard | 1–14, 17–30, 33, 34, 35, 37 | CiA402 (our own drive) |
//! | gha-e | 1–14, 17–30, 33, 34, 35 | §5.4.3 |
//! | rse | 17–30, 35 | 7.11 |
//! | sdv3-e, osd-g-e | 1–14, 17–30, 35; 7, 8, 11, 12, 23, 24, 27, 28 "the same to way" 3, 4, 5, 6, 19, 20, 21, 22 | §7.6 (OSD-G-E §4.4) |
//! | sigma-v-sd | 1, 2, 7–14, 24, 28, 33, 34, 35 | §6.9 |
//! | sigma-v-sd-2axis (axis 2, objects + 800h) | as sigma-v-sd | §2.4, §6.9 |
//!
//! Every other method in 6098h's range starts a run that ends at once in a homing error
//! (13/12/10 = 1/0/1) without motion.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use board_sim::plant::SwitchParams;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{
    self, HOMING_ATTAINED, HOMING_BITS, HOMING_ERROR, HOMING_START, OPERATION_ENABLED,
    TARGET_REACHED,
};
use tests_host::vendor::{self, DcGroup, MappedEntry, Sdo};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const HM: i8 = cia402::HOMING;
/// The home offset every run sets: the home reads as this (in every profile's 607Ch range).
const HOME_OFFSET: i32 = 1_000;
/// The rotor stops on the home within this many encoder increments, or within the drive's
/// position window 6067h where that is wider (target reached ends the settling).
const HOME_TOLERANCE_INC: f64 = 40.0;
/// 6064h at the home within this many increments of 607Ch plus the rotor's offset.
const POSITION_TOLERANCE_INC: f64 = 60.0;
/// Search and zero-search speeds, homing acceleration.
const SEARCH_REV_S: f64 = 5.0;
const ZERO_SEARCH_REV_S: f64 = 1.0;
const ACCELERATION_REV_S2: f64 = 200.0;
/// The path checks: a motion counts from this far (rev); speeds within this factor of
/// 6099h; the approach onto the home is the last this many cycles before the rotor stays
/// there (at the search speed a quarter of a revolution).
const PATH_RESOLUTION_REV: f64 = 0.01;
const SPEED_TOLERANCE: f64 = 1.1;
const APPROACH_CYCLES: usize = 50;
/// The longest run: a cam search reversing at a limit, then up to a revolution at the
/// zero-search speed for the index.
const MAX_CYCLES: usize = 10_000;

/// Edges of the switches, revolutions: a home switch or cam from `LOW` up (to `HIGH`); limit
/// switches beyond.
const LOW: f64 = 0.4;
const HIGH: f64 = 1.6;
const NEGATIVE_LIMIT: f64 = -1.3;
const POSITIVE_LIMIT: f64 = 2.6;
/// A limit switch far away (only there to reverse a wrong search).
const FAR: f64 = 4.0;

/// A machine: switch positions, revolutions.
#[derive(Clone, Copy, Debug)]
struct Machine {
    negative_limit: f64,
    positive_limit: f64,
    /// The home switch's active range.
    home: Option<(f64, f64)>,
}

impl Machine {
    /// Whether the home switch or cam is active at `position` (rev).
    fn on_home_switch(&self, position: f64) -> bool {
        self.home
            .is_some_and(|(low, high)| (low..=high).contains(&position))
    }

    fn switches(&self) -> SwitchParams {
        SwitchParams {
            limit_neg_rad: Some(self.negative_limit * TAU),
            limit_pos_rad: Some(self.positive_limit * TAU),
            home_rad: self.home.map(|(a, _)| a * TAU),
            home_end_rad: self.home.map(|(_, b)| b * TAU),
            probes: [None; 2],
        }
    }
}

/// Where the home is relative to the reference edge.
#[derive(Clone, Copy, Debug)]
enum Home {
    /// The edge itself (methods 17–30).
    Edge,
    /// The first index pulse on the negative side of the edge.
    IndexBelow,
    /// The first index pulse on the positive side of the edge.
    IndexAbove,
}

impl Home {
    fn from(self, edge: f64) -> f64 {
        match self {
            Self::Edge => edge,
            Self::IndexBelow => edge.floor(),
            Self::IndexAbove => edge.ceil(),
        }
    }
}

/// A method's figure: the machine it runs on, where its runs start and where the home is.
#[derive(Clone, Debug)]
struct Figure {
    machine: Machine,
    starts: Vec<f64>,
    home: f64,
    /// The run moves (not the current-position methods).
    searches: bool,
    /// The run looks for a switch first, at the search speed 6099h:01, where it does not start
    /// on its home switch (methods 1–30).
    switch_search: bool,
    /// The direction of the first motion from each start (+1 positive, -1 negative).
    first_directions: Vec<f64>,
}

/// The direction a run of base method `base` (1–14, 33, 34) first moves in from `start` on
/// `machine` (IEC 61800-7-201, homing mode): limit-switch methods towards their switch; the
/// home-switch methods 3–6 by the switch's state; the cam methods 7–14 positive (7–10) or
/// negative (11–14) off the cam, towards the edge they look for when they start on it.
fn first_direction(base: i8, machine: &Machine, start: f64) -> f64 {
    let on_switch = machine.on_home_switch(start);
    let (on, off) = match base {
        1 | 33 => (-1.0, -1.0),
        2 | 34 => (1.0, 1.0),
        3 | 4 => (-1.0, 1.0),
        5 | 6 => (1.0, -1.0),
        7 | 8 => (-1.0, 1.0),
        9 | 10 => (1.0, 1.0),
        11 | 12 => (1.0, -1.0),
        _ => (-1.0, -1.0),
    };
    if on_switch {
        on
    } else {
        off
    }
}

/// The CiA402 figure of `method` (IEC 61800-7-201, homing mode).
fn cia402_figure(method: i8) -> Option<Figure> {
    let limits = |negative_limit, positive_limit| Machine {
        negative_limit,
        positive_limit,
        home: None,
    };
    // Outside the home switch / cam below it, inside it, beyond a cam above it.
    let below = LOW - 1.1;
    let inside = (LOW + HIGH) / 2.0;
    let beyond = HIGH + 0.5;
    // 1–14 find an index pulse next to the edge, 17–30 the edge itself.
    let (base, edge_home) = match method {
        1..=14 => (method, None),
        17..=30 => (method - 16, Some(Home::Edge)),
        33 | 34 => {
            // The first index pulse in the negative (33) or positive (34) direction.
            let start = 0.3;
            let home = if method == 33 { 0.0 } else { 1.0 };
            let machine = limits(-FAR, FAR);
            return Some(Figure {
                machine,
                starts: vec![start],
                home,
                searches: true,
                switch_search: false,
                first_directions: vec![first_direction(method, &machine, start)],
            });
        }
        35 | 37 => {
            // The current position is the home.
            return Some(Figure {
                machine: limits(-FAR, FAR),
                starts: vec![0.3],
                home: 0.3,
                searches: false,
                switch_search: false,
                first_directions: vec![0.0],
            });
        }
        _ => return None,
    };
    let home = |index: Home| edge_home.unwrap_or(index);
    let figure = |machine: Machine, starts: &[f64], edge: f64, index: Home| Figure {
        machine,
        starts: starts.to_vec(),
        home: home(index).from(edge),
        searches: true,
        switch_search: true,
        first_directions: starts
            .iter()
            .map(|&start| first_direction(base, &machine, start))
            .collect(),
    };
    let positive_home_switch = Machine {
        home: Some((LOW, FAR * 10.0)),
        ..limits(-FAR, FAR * 20.0)
    };
    let negative_home_switch = Machine {
        home: Some((-FAR * 10.0, LOW)),
        ..limits(-FAR * 20.0, FAR)
    };
    let cam = Machine {
        home: Some((LOW, HIGH)),
        ..limits(NEGATIVE_LIMIT, POSITIVE_LIMIT)
    };
    Some(match base {
        // 1: the negative limit switch, the first index pulse to the right of where it
        // becomes inactive; 2: the positive limit switch, the index to its left.
        1 => figure(
            limits(NEGATIVE_LIMIT, FAR),
            &[0.2],
            NEGATIVE_LIMIT,
            Home::IndexAbove,
        ),
        2 => figure(
            limits(-FAR, POSITIVE_LIMIT),
            &[0.2],
            POSITIVE_LIMIT,
            Home::IndexBelow,
        ),
        // 3, 4: a positive home switch (active above its edge), the initial direction by its
        // state; the index to the left (3) or right (4) of the edge.
        3 => figure(
            positive_home_switch,
            &[below, inside],
            LOW,
            Home::IndexBelow,
        ),
        4 => figure(
            positive_home_switch,
            &[below, inside],
            LOW,
            Home::IndexAbove,
        ),
        // 5, 6: a negative home switch (active below its edge); right (5), left (6).
        5 => figure(
            negative_home_switch,
            &[below, inside],
            LOW,
            Home::IndexAbove,
        ),
        6 => figure(
            negative_home_switch,
            &[below, inside],
            LOW,
            Home::IndexBelow,
        ),
        // 7–10: a home cam, initial motion positive (reversing at the positive limit switch);
        // 7/8 the index left/right of its lower edge, 9/10 of its upper edge.
        7 => figure(cam, &[below, inside, beyond], LOW, Home::IndexBelow),
        8 => figure(cam, &[below, inside, beyond], LOW, Home::IndexAbove),
        9 => figure(cam, &[below, inside, beyond], HIGH, Home::IndexBelow),
        10 => figure(cam, &[below, inside, beyond], HIGH, Home::IndexAbove),
        // 11–14: mirrored, initial motion negative (reversing at the negative limit switch);
        // 11/12 the index right/left of the upper edge, 13/14 of the lower edge.
        11 => figure(cam, &[below, inside, beyond], HIGH, Home::IndexAbove),
        12 => figure(cam, &[below, inside, beyond], HIGH, Home::IndexBelow),
        13 => figure(cam, &[below, inside, beyond], LOW, Home::IndexAbove),
        14 => figure(cam, &[below, inside, beyond], LOW, Home::IndexBelow),
        _ => return None,
    })
}

/// A profile's homing as its manual lists it.
struct Manual {
    profile: &'static str,
    /// The axis under test (0, or 1 for the second axis of a two-axis drive).
    axis: usize,
    /// The methods the manual lists.
    methods: Vec<i8>,
    /// Methods the manual defines as "the same" as another.
    same_as: &'static [(i8, i8)],
}

impl Manual {
    fn figure(&self, method: i8) -> Figure {
        let as_method = self
            .same_as
            .iter()
            .find(|(m, _)| *m == method)
            .map_or(method, |(_, other)| *other);
        cia402_figure(as_method).unwrap_or_else(|| panic!("no figure for method {as_method}"))
    }

    /// Axis 1's object `index` on the axis under test.
    fn object(&self, index: u16) -> u16 {
        vendor::axis_object(index, self.axis)
    }
}

fn range(r: std::ops::RangeInclusive<i8>) -> Vec<i8> {
    r.collect()
}

/// Methods 1–14 and 17–30.
fn switch_methods() -> Vec<i8> {
    [range(1..=14), range(17..=30)].concat()
}

/// SDV3-E §7.6 / OSD-G-E §4.4: "The same to way 3" etc.
const SDV3_E_SAME_AS: &[(i8, i8)] = &[
    (7, 3),
    (8, 4),
    (11, 5),
    (12, 6),
    (23, 19),
    (24, 20),
    (27, 21),
    (28, 22),
];

fn sigma_v_sd(profile: &'static str, axis: usize) -> Manual {
    Manual {
        profile,
        axis,
        methods: [vec![1, 2], range(7..=14), vec![24, 28, 33, 34, 35]].concat(),
        same_as: &[],
    }
}

/// What one cycle brought back: statusword, mode display, position; and the rotor (rev).
#[derive(Clone, Copy, Debug)]
struct Sample {
    statusword: u16,
    mode: i8,
    position: i32,
    revolutions: f64,
}

/// The PDOs of the axis under test: outputs 6040h, 6060h, 607Ah; inputs 6041h, 6061h, 6064h.
fn mapping(manual: &Manual) -> (u16, u16, [MappedEntry; 3], [MappedEntry; 3]) {
    let o = |index| manual.object(index);
    let offset = 0x10 * manual.axis as u16;
    (
        0x1600 + offset,
        0x1A00 + offset,
        [(o(0x6040), 0, 16), (o(0x6060), 0, 8), (o(0x607A), 0, 32)],
        [(o(0x6041), 0, 16), (o(0x6061), 0, 8), (o(0x6064), 0, 32)],
    )
}

/// The set-up written in PREOP: the mapping, the method, the home offset, the speeds and the
/// acceleration in the profile's units (the SDV3-E has no 609Ah: it homes on 6083h, §7.6).
fn setup(manual: &Manual, profile: &Profile, method: i8) -> Vec<Sdo> {
    let (rx, tx, outputs, inputs) = mapping(manual);
    let o = |index| manual.object(index);
    let mut sdos = vendor::remap(rx, 0x1C12, &outputs);
    sdos.extend(vendor::remap(tx, 0x1C13, &inputs));
    sdos.extend([
        Sdo::I8(o(0x6098), 0, method),
        Sdo::I32(o(0x607C), 0, HOME_OFFSET),
        Sdo::U32(o(0x6099), 1, units::velocity(profile, SEARCH_REV_S)),
        Sdo::U32(o(0x6099), 2, units::velocity(profile, ZERO_SEARCH_REV_S)),
    ]);
    let acceleration = units::acceleration(profile, ACCELERATION_REV_S2);
    if profile.entry(o(0x609A), 0).is_some() {
        sdos.push(Sdo::U32(o(0x609A), 0, acceleration));
    } else {
        sdos.push(Sdo::U32(o(0x6083), 0, acceleration));
    }
    sdos
}

/// One DC cycle: controlword `cw`, 6060h = 6.
async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    axis: usize,
    cw: u16,
) -> Sample {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, HM, 0), CYCLE_NS).await;
    Sample {
        statusword: vendor::u16_at(&inputs, 0),
        mode: inputs[2] as i8,
        position: vendor::i32_at(&inputs, 3),
        revolutions: m.shared.segment().drives()[0].servos[axis]
            .plant
            .mech_angle_rad()
            / TAU,
    }
}

/// One homing run of `method` on `machine` from `start` (rev): the samples from the start of
/// homing, or what went wrong before it.
async fn home(
    manual: &Manual,
    profile: &Profile,
    method: i8,
    machine: Machine,
    start: f64,
    cycles: usize,
) -> Result<Vec<Sample>, String> {
    let segment = board_sim::Segment::new(manual.profile, 1).expect("profile");
    let (m, transport) = master_for(segment);
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    {
        let mut segment = m.shared.segment();
        let plant = &mut segment.drives_mut()[0].servos[manual.axis].plant;
        plant.set_switches(machine.switches());
        plant.set_rotor_position(start * TAU);
    }
    let group = vendor::into_op_dc(&m, md, &setup(manual, profile, method), CYCLE_NS).await;
    // Past the SYNC0 start delay.
    let mut s = cycle(&m, md, &group, manual.axis, 0).await;
    for _ in 0..vendor::SYNC0_START_CYCLES {
        s = cycle(&m, md, &group, manual.axis, 0).await;
    }
    for cw in vendor::enable_sequence(20) {
        s = cycle(&m, md, &group, manual.axis, cw).await;
    }
    if !cia402::is(s.statusword, OPERATION_ENABLED) {
        return Err(format!("not enabled: statusword {:#06x}", s.statusword));
    }
    if s.mode != HM {
        return Err(format!("6061h = {} in homing mode", s.mode));
    }
    if s.statusword & HOMING_BITS != TARGET_REACHED {
        return Err(format!("not started is 0/0/1: {:#06x}", s.statusword));
    }
    let start_cw = vendor::ENABLE_OPERATION | HOMING_START;
    let mut samples = Vec::new();
    for _ in 0..cycles {
        let s = cycle(&m, md, &group, manual.axis, start_cw).await;
        samples.push(s);
        let bits = s.statusword & HOMING_BITS;
        if samples.len() > 5
            && (bits == HOMING_ATTAINED | TARGET_REACHED || bits & HOMING_ERROR != 0)
        {
            // It must stay so.
            for _ in 0..30 {
                samples.push(cycle(&m, md, &group, manual.axis, start_cw).await);
            }
            break;
        }
    }
    Ok(samples)
}

/// What is wrong with a run that should have homed at `figure.home`, if anything.
fn check_homed(
    samples: &[Sample],
    figure: &Figure,
    (increments_per_unit, home_tolerance_inc): (f64, f64),
) -> Result<(), String> {
    let last = samples.last().ok_or("no samples")?;
    let bits = last.statusword & HOMING_BITS;
    if bits != HOMING_ATTAINED | TARGET_REACHED {
        return Err(format!(
            "not completed: statusword {:#06x} after {} cycles, rotor at {:.4} rev",
            last.statusword,
            samples.len(),
            last.revolutions
        ));
    }
    let off_inc = (last.revolutions - figure.home) * units::COUNTS_PER_REV;
    if off_inc.abs() > home_tolerance_inc {
        return Err(format!(
            "stopped at {:.4} rev, {off_inc:.0} increments from the home at {} rev",
            last.revolutions, figure.home
        ));
    }
    let expected = f64::from(HOME_OFFSET) + off_inc / increments_per_unit;
    let tolerance = POSITION_TOLERANCE_INC / increments_per_unit + 1.0;
    if (f64::from(last.position) - expected).abs() > tolerance {
        return Err(format!(
            "6064h = {} at the home, expected {expected:.0} (607Ch = {HOME_OFFSET})",
            last.position
        ));
    }
    if figure.searches
        && !samples
            .iter()
            .any(|s| s.statusword & HOMING_BITS == 0 && s.revolutions != last.revolutions)
    {
        return Err("never showed 0/0/0 (in progress) while moving".into());
    }
    if let Some(s) = samples.iter().find(|s| s.mode != HM) {
        return Err(format!("6061h = {} while homing", s.mode));
    }
    Ok(())
}

/// What is wrong with the path of a run from `start` that homed, if anything: the first motion
/// in `direction`; never faster than the search speed 6099h:01, which a search for a switch
/// reaches (a run that starts on its home switch has found it and looks for the edge at the
/// zero-search speed); the last stretch onto the home at the zero-search speed 6099h:02 (the
/// figures' slow approach to the edge or index pulse).
fn check_path(
    samples: &[Sample],
    figure: &Figure,
    start: f64,
    direction: f64,
) -> Result<(), String> {
    if !figure.searches {
        return Ok(());
    }
    let moved = samples
        .iter()
        .find(|s| (s.revolutions - start).abs() > PATH_RESOLUTION_REV)
        .ok_or("never moved")?;
    if (moved.revolutions - start).signum() != direction {
        return Err(format!(
            "first moved to {:.3} rev, the figure starts {}",
            moved.revolutions,
            if direction > 0.0 {
                "positive"
            } else {
                "negative"
            }
        ));
    }
    let speeds: Vec<f64> = samples
        .windows(2)
        .map(|w| (w[1].revolutions - w[0].revolutions) * 1e9 / CYCLE_NS as f64)
        .collect();
    let peak = speeds.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if peak > SEARCH_REV_S * SPEED_TOLERANCE {
        return Err(format!(
            "{peak:.2} rev/s, faster than 6099h:01 ({SEARCH_REV_S} rev/s)"
        ));
    }
    let switch_search = figure.switch_search && !figure.machine.on_home_switch(start);
    if switch_search && peak < SEARCH_REV_S / SPEED_TOLERANCE {
        return Err(format!(
            "searched at {peak:.2} rev/s, not 6099h:01 ({SEARCH_REV_S} rev/s)"
        ));
    }
    // The arrival: from here on the rotor stays at the home.
    let arrival = speeds.len()
        - samples[1..]
            .iter()
            .rev()
            .take_while(|s| (s.revolutions - figure.home).abs() <= PATH_RESOLUTION_REV)
            .count();
    let approach = &speeds[arrival.saturating_sub(APPROACH_CYCLES)..arrival];
    if let Some(fast) = approach
        .iter()
        .find(|v| v.abs() > ZERO_SEARCH_REV_S * SPEED_TOLERANCE)
    {
        return Err(format!(
            "approached the home at {fast:.2} rev/s, not 6099h:02 ({ZERO_SEARCH_REV_S} rev/s)"
        ));
    }
    Ok(())
}

/// A method the manual does not list: the run ends at once in a homing error at rest.
fn check_refused(samples: &[Sample], start: f64) -> Result<(), String> {
    let last = samples.last().ok_or("no samples")?;
    if last.statusword & HOMING_BITS != HOMING_ERROR | TARGET_REACHED {
        return Err(format!(
            "not a homing error at rest: statusword {:#06x}",
            last.statusword
        ));
    }
    if (last.revolutions - start).abs() > 1e-3 {
        return Err(format!("moved to {:.4} rev", last.revolutions));
    }
    Ok(())
}

/// Runs every method of `manual` from every start of its figure, and every other method in
/// 6098h's range; panics with the list of what went wrong.
fn every_method(manual: Manual) {
    let profile = od_gen::builtin(manual.profile).expect("profile");
    let per_unit = units::increments_per_unit(&profile);
    let window = profile
        .entry(manual.object(0x6067), 0)
        .map(|e| e.initial_bytes())
        .and_then(|b| {
            b.get(..4)
                .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
        })
        .expect("6067h");
    let tolerance = HOME_TOLERANCE_INC.max(f64::from(window) * per_unit);
    let method_entry = profile
        .entry(manual.object(0x6098), 0)
        .expect("6098h in the dictionary");
    // 6098h is an INTEGER8: its range as one byte each (none: the whole type).
    let bound = |bytes: &[u8], none: i8| bytes.first().map_or(none, |b| *b as i8);
    let (min, max) = (
        bound(&method_entry.min, i8::MIN),
        bound(&method_entry.max, i8::MAX),
    );
    let writable = |m: i8| {
        (min..=max).contains(&m)
            && (method_entry.allowed.is_empty() || method_entry.allowed.contains(&i64::from(m)))
    };
    let mut failures = Vec::new();
    block_on(async {
        for &method in &manual.methods {
            let figure = manual.figure(method);
            for (&start, &direction) in figure.starts.iter().zip(&figure.first_directions) {
                let result = home(&manual, &profile, method, figure.machine, start, MAX_CYCLES)
                    .await
                    .and_then(|samples| {
                        check_homed(&samples, &figure, (per_unit, tolerance))?;
                        check_path(&samples, &figure, start, direction)
                    });
                if let Err(e) = result {
                    failures.push(format!("method {method} from {start:.1} rev: {e}"));
                }
            }
        }
        let machine = Machine {
            negative_limit: -FAR,
            positive_limit: FAR,
            home: Some((LOW, HIGH)),
        };
        for method in (0..=37).filter(|m| writable(*m)) {
            if manual.methods.contains(&method) {
                continue;
            }
            let result = home(&manual, &profile, method, machine, 0.3, 50)
                .await
                .and_then(|samples| check_refused(&samples, 0.3));
            if let Err(e) = result {
                failures.push(format!("unlisted method {method}: {e}"));
            }
        }
    });
    assert!(
        failures.is_empty(),
        "{}: {} of its homing runs failed:\n{}",
        manual.profile,
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn standard_every_cia402_homing_method_finds_its_home() {
    every_method(Manual {
        profile: "standard",
        axis: 0,
        methods: [switch_methods(), vec![33, 34, 35, 37]].concat(),
        same_as: &[],
    });
}

#[test]
fn gha_e_every_homing_method_finds_its_home() {
    every_method(Manual {
        profile: "gha-e",
        axis: 0,
        methods: [switch_methods(), vec![33, 34, 35]].concat(),
        same_as: &[],
    });
}

#[test]
fn rse_every_homing_method_finds_its_home() {
    every_method(Manual {
        profile: "rse",
        axis: 0,
        methods: [range(17..=30), vec![35]].concat(),
        same_as: &[],
    });
}

#[test]
fn sdv3_e_every_homing_method_finds_its_home() {
    every_method(Manual {
        profile: "sdv3-e",
        axis: 0,
        methods: [switch_methods(), vec![35]].concat(),
        same_as: SDV3_E_SAME_AS,
    });
}

#[test]
fn osd_g_e_every_homing_method_finds_its_home() {
    every_method(Manual {
        profile: "osd-g-e",
        axis: 0,
        methods: [switch_methods(), vec![35]].concat(),
        same_as: SDV3_E_SAME_AS,
    });
}

#[test]
fn sigma_v_sd_every_homing_method_finds_its_home() {
    every_method(sigma_v_sd("sigma-v-sd", 0));
}

#[test]
fn sigma_v_sd_2axis_axis_2_every_homing_method_finds_its_home() {
    every_method(sigma_v_sd("sigma-v-sd-2axis", 1));
}
