//! Homing mode (6060h = 6; CiA402 / IEC 61800-7-201 "Homing mode"): the search sequences of
//! the homing methods 6098h as a decision function, one call per bus cycle.
//!
//! Every switch method has the same shape: the reference is one edge of a switch (a limit
//! switch, a home switch that is active on one side, or one edge of a home cam), approached in
//! a given direction; the home is that edge, or the first index pulse past it in the approach
//! direction. The sequence: find the switch's active region at the search speed 6099h:01
//! (reversing once at a limit switch in the way), leave it against the approach direction if
//! the approach must enter it, approach the edge at the zero-search speed 6099h:02, then the
//! index pulse; stop, and go to the home position found. Edges and index pulses come with the
//! positions the axis latched (`firmware::motor::capture`), so the home does not depend on when
//! the bus cycle saw them.
//!
//! | methods | switch | edge (active side) | approach | index | first search |
//! |---|---|---|---|---|---|
//! | 1, 17 | negative limit | its edge (−) | + | 1 | − |
//! | 2, 18 | positive limit | its edge (+) | − | 2 | + |
//! | 3, 19 / 4, 20 | home switch active on the + side | its edge (+) | − / + | 3, 4 | by the switch state |
//! | 5, 21 / 6, 22 | home switch active on the − side | its edge (−) | + / − | 5, 6 | by the switch state |
//! | 7–10, 23–26 | home cam | left (+) / left / right (−) / right | − / + / − / + | 7–10 | + (reverse at the positive limit) |
//! | 11–14, 27–30 | home cam | right (−) / right / left (+) / left | + / − / + / − | 11–14 | − (reverse at the negative limit) |
//! | 33 / 34 | – | – | − / + | index | − / + |
//! | 35, 37 | – | the current position is the home | – | – | – |
//!
//! Statusword (CiA402 homing): bit 13 homing error, bit 12 homing attained, bit 10 target
//! reached: 0/0/0 in progress, 0/0/1 interrupted or not started, 0/1/0 attained but moving,
//! 0/1/1 completed, 1/0/0 error while moving, 1/0/1 error at rest.

/// 6060h value of homing mode.
pub const HOMING: i8 = 6;
/// Controlword bit 4: homing operation start (rising edge starts, 0 interrupts).
pub const HOMING_START: u16 = 1 << 4;
/// Statusword bit 10 "target reached".
pub const TARGET_REACHED: u16 = 1 << 10;
/// Statusword bit 12 "homing attained".
pub const HOMING_ATTAINED: u16 = 1 << 12;
/// Statusword bit 13 "homing error".
pub const HOMING_ERROR: u16 = 1 << 13;

/// A direction of motion: +1 positive, −1 negative.
pub type Direction = i8;

/// The opposite of `direction` (saturating only so that no value can overflow; directions are
/// ±1).
const fn reverse(direction: Direction) -> Direction {
    direction.saturating_neg()
}

/// The switch a method refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Switch {
    /// Negative limit switch.
    NegativeLimit,
    /// Positive limit switch.
    PositiveLimit,
    /// Home switch.
    Home,
}

/// The reference a homing method looks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// An edge of `switch` between its active side `active` and the other side, crossed in
    /// direction `approach`; the home is the edge or (`index`) the first index pulse past it.
    /// `first` is the direction of the first search while the switch is inactive (a home cam
    /// can be on either side); `None`: toward the active side.
    Edge {
        /// The switch.
        switch: Switch,
        /// The side of the edge on which the switch is active.
        active: Direction,
        /// The direction of the final approach.
        approach: Direction,
        /// The home is the first index pulse past the edge.
        index: bool,
        /// First search direction while the switch is inactive.
        first: Option<Direction>,
    },
    /// The first index pulse in `direction`.
    Index(Direction),
    /// The current position.
    Here,
}

/// The reference of CiA402 homing method `method`, `None` for a method CiA402 does not define
/// (0, 15, 16, 31, 32, 36, negative: manufacturer-specific).
pub const fn method(method: i8) -> Option<Reference> {
    const fn edge(
        switch: Switch,
        active: Direction,
        approach: Direction,
        first: Option<Direction>,
    ) -> Reference {
        Reference::Edge {
            switch,
            active,
            approach,
            index: true,
            first,
        }
    }
    use Switch::*;
    let with_index = match method {
        1 | 17 => edge(NegativeLimit, -1, 1, None),
        2 | 18 => edge(PositiveLimit, 1, -1, None),
        3 | 19 => edge(Home, 1, -1, None),
        4 | 20 => edge(Home, 1, 1, None),
        5 | 21 => edge(Home, -1, 1, None),
        6 | 22 => edge(Home, -1, -1, None),
        7 | 23 => edge(Home, 1, -1, Some(1)),
        8 | 24 => edge(Home, 1, 1, Some(1)),
        9 | 25 => edge(Home, -1, -1, Some(1)),
        10 | 26 => edge(Home, -1, 1, Some(1)),
        11 | 27 => edge(Home, -1, 1, Some(-1)),
        12 | 28 => edge(Home, -1, -1, Some(-1)),
        13 | 29 => edge(Home, 1, 1, Some(-1)),
        14 | 30 => edge(Home, 1, -1, Some(-1)),
        33 => return Some(Reference::Index(-1)),
        34 => return Some(Reference::Index(1)),
        35 | 37 => return Some(Reference::Here),
        _ => return None,
    };
    match with_index {
        Reference::Edge {
            switch,
            active,
            approach,
            first,
            ..
        } if method >= 17 => Some(Reference::Edge {
            switch,
            active,
            approach,
            index: false,
            first,
        }),
        r => Some(r),
    }
}

/// Edges of a signal as the axis latched them: how many (wrapping) and where the last was.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Edges {
    /// Edges so far (wrapping).
    pub count: u16,
    /// Position of the last one.
    pub position: i64,
}

/// A switch: its level and the latches of its edges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SwitchSignal {
    /// Actuated now.
    pub level: bool,
    /// Edges to actuated.
    pub rising: Edges,
    /// Edges to inactive.
    pub falling: Edges,
}

impl SwitchSignal {
    fn edges_to(&self, level: bool) -> Edges {
        if level {
            self.rising
        } else {
            self.falling
        }
    }
}

/// The signals homing looks at, in drive positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Signals {
    /// Negative limit switch.
    pub negative_limit: SwitchSignal,
    /// Positive limit switch.
    pub positive_limit: SwitchSignal,
    /// Home switch.
    pub home: SwitchSignal,
    /// Encoder index pulses.
    pub index: Edges,
}

impl Signals {
    fn switch(&self, s: Switch) -> SwitchSignal {
        match s {
            Switch::NegativeLimit => self.negative_limit,
            Switch::PositiveLimit => self.positive_limit,
            Switch::Home => self.home,
        }
    }

    /// The limit switch ahead in `direction`.
    fn limit_ahead(&self, direction: Direction) -> (Switch, SwitchSignal) {
        if direction > 0 {
            (Switch::PositiveLimit, self.positive_limit)
        } else {
            (Switch::NegativeLimit, self.negative_limit)
        }
    }
}

/// What the motion generator does this cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Demand {
    /// Stay where the demand is (not homing).
    Hold,
    /// Run in `direction` at the search speed 6099h:01.
    Search(Direction),
    /// Run in `direction` at the zero-search speed 6099h:02.
    Creep(Direction),
    /// Decelerate to rest on the homing acceleration.
    Stop,
    /// Go to this position at the zero-search speed and stop on it.
    MoveTo(i64),
}

/// One homing cycle's result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output {
    /// What the motion generator does.
    pub demand: Demand,
    /// Statusword bits 10, 12, 13.
    pub statusword: u16,
    /// The home position found (drive position), in the cycle homing completes: the drive
    /// makes it read as the home offset.
    pub home_found: Option<i64>,
}

/// Where a homing run stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Not started or interrupted.
    Idle,
    /// Looking for the switch's active region in `direction` (reversed once already?).
    Search {
        direction: Direction,
        reversed: bool,
    },
    /// Inside the active region, moving against the approach until the switch is inactive.
    Leave { direction: Direction, falling: u16 },
    /// The final approach in `direction` until the edge to `level` (its latch count at the
    /// start is `count`).
    Approach {
        direction: Direction,
        level: bool,
        count: u16,
    },
    /// Past the edge at `edge`, until the next index pulse past it.
    Index {
        direction: Direction,
        edge: i64,
        count: u16,
    },
    /// Found `home`: decelerating, then going to it.
    Settle { home: i64 },
    /// Completed at `home` (the drive already applied it).
    Done { home: i64 },
    /// Failed.
    Error,
}

/// The homing state of a drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Homing {
    phase: Phase,
    reference: Option<Reference>,
    previous_start: bool,
    /// How long the run has been under way, ns.
    elapsed_ns: u64,
}

const NS_PER_MS: u64 = 1_000_000;

impl Default for Homing {
    fn default() -> Self {
        Self::new()
    }
}

/// A profile's rules for the start of a run, where its manual adds to CiA402.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rules {
    /// The current-position methods (35, 37) also run while the drive function is disabled
    /// (the Σ-V-SD, §4.9: "does not require the drive device to be in operation enabled
    /// state").
    pub here_while_disabled: bool,
    /// A start while the drive function is disabled ends in a homing error (the SDV3-E,
    /// §4.4: "perform homing if the servo is not enabled").
    pub start_while_disabled_error: bool,
    /// The current-position methods run only while the motor is at speed zero; started
    /// while it moves they end in a homing error (the SDV3-E, §4.4: "perform position preset
    /// when speed zero is not established").
    pub here_needs_speed_zero: bool,
}

/// The inputs of one homing cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs {
    /// 6040h.
    pub controlword: u16,
    /// The axis runs the mode's demand (Operation Enabled, no halt or stop).
    pub running: bool,
    /// The drive function is disabled (neither Operation Enabled nor a stop under way).
    pub disabled: bool,
    /// The motor is at speed zero (its actual speed inside the profile's zero-speed range).
    pub speed_zero: bool,
    /// The profile's start rules.
    pub rules: Rules,
    /// 6098h, filtered by the profile (`None`: a method the profile does not support).
    pub method: Option<Reference>,
    /// The switches and index pulses.
    pub signals: Signals,
    /// The demand position and whether the demand is at rest.
    pub demand_position: i64,
    /// The demand velocity is 0.
    pub demand_at_rest: bool,
    /// The motor is at the demand (at rest and inside the position window): statusword bit 10
    /// "target reached".
    pub at_target: bool,
    /// The longest a run may take, ms (a profile's homing time limit; `None` or 0: no limit):
    /// past it the run ends in a homing error.
    pub timeout_ms: Option<u32>,
    /// The cycle time, ns (the run's clock).
    pub cycle_ns: u32,
}

impl Homing {
    /// Not started.
    pub const fn new() -> Self {
        Self {
            phase: Phase::Idle,
            reference: None,
            previous_start: false,
            elapsed_ns: 0,
        }
    }

    /// Whether the last run failed (homing error).
    pub fn failed(&self) -> bool {
        self.phase == Phase::Error
    }

    /// Whether a homing run is under way (the mode and the method may not change, some
    /// profiles say).
    pub fn running(&self) -> bool {
        !matches!(self.phase, Phase::Idle | Phase::Done { .. } | Phase::Error)
    }

    /// The mode was selected; `previous_cw` is the controlword of the cycle before. Bit 4 set
    /// there and carried into the mode starts a run only where `start` (a profile's rule: the
    /// Σ-V-SD's dynamic mode change, §3.2 "Homing will be started immediately"); CiA402 starts
    /// on a rising edge. Bit 4 rising in the selecting cycle itself is an edge either way.
    pub fn enter(&mut self, previous_cw: u16, start: bool) {
        self.previous_start = !start && previous_cw & HOMING_START != 0;
    }

    /// Forgets an attained or failed homing (the mode was left): the statusword starts as
    /// "not started".
    pub fn leave(&mut self) {
        self.phase = Phase::Idle;
    }

    /// One cycle.
    pub fn step(&mut self, i: &Inputs) -> Output {
        let start = i.controlword & HOMING_START != 0;
        let rising = start && !self.previous_start;
        self.previous_start = start;
        let mut home_found = None;
        let here = i.method == Some(Reference::Here);
        if rising && i.disabled && here && i.rules.here_while_disabled {
            // The current position is the home without the drive function (the demand is the
            // actual position while disabled).
            self.reference = i.method;
            home_found = Some(i.demand_position);
            self.phase = Phase::Done {
                home: i.demand_position,
            };
        } else if rising && i.disabled && i.rules.start_while_disabled_error {
            self.reference = i.method;
            self.phase = Phase::Error;
        } else if rising && i.running {
            self.reference = i.method;
            self.elapsed_ns = 0;
            self.phase = match i.method {
                None => Phase::Error,
                Some(Reference::Here) if i.rules.here_needs_speed_zero && !i.speed_zero => {
                    Phase::Error
                }
                Some(Reference::Here) => {
                    home_found = Some(i.demand_position);
                    Phase::Done {
                        home: i.demand_position,
                    }
                }
                Some(Reference::Index(direction)) => Phase::Index {
                    direction,
                    edge: i.demand_position,
                    count: i.signals.index.count,
                },
                Some(Reference::Edge {
                    switch,
                    active,
                    first,
                    ..
                }) => {
                    let direction = first.unwrap_or(active);
                    let found = i.signals.switch(switch).level;
                    self.after_search(found, direction, i)
                }
            };
        } else if (!start || !i.running) && self.running() {
            // Bit 4 cleared or a halt / stop: homing interrupted.
            self.phase = Phase::Idle;
        } else {
            home_found = self.advance(i);
            if self.running() {
                self.elapsed_ns = self.elapsed_ns.saturating_add(u64::from(i.cycle_ns));
                let limit_ns = i
                    .timeout_ms
                    .filter(|ms| *ms > 0)
                    .map(|ms| u64::from(ms) * NS_PER_MS);
                if limit_ns.is_some_and(|limit| self.elapsed_ns >= limit) {
                    // The profile's homing time limit: the run ends in an error.
                    self.phase = Phase::Error;
                }
            }
        }
        Output {
            demand: self.demand(),
            statusword: self.statusword(i),
            home_found,
        }
    }

    /// The phase after the search: inside the active region (`found`), or still searching.
    fn after_search(&self, found: bool, direction: Direction, i: &Inputs) -> Phase {
        let Some(Reference::Edge {
            switch,
            active,
            approach,
            ..
        }) = self.reference
        else {
            return Phase::Error;
        };
        let signal = i.signals.switch(switch);
        if !found {
            return Phase::Search {
                direction,
                reversed: false,
            };
        }
        if active == reverse(approach) {
            // The approach leaves the active region through the edge.
            Phase::Approach {
                direction: approach,
                level: false,
                count: signal.falling.count,
            }
        } else {
            Phase::Leave {
                direction: reverse(approach),
                falling: signal.falling.count,
            }
        }
    }

    /// Moves the run on by what the signals show; the home position when it is found.
    fn advance(&mut self, i: &Inputs) -> Option<i64> {
        let reference = self.reference?;
        let signals = &i.signals;
        let switch = match reference {
            Reference::Edge { switch, .. } => Some(switch),
            _ => None,
        };
        // A limit switch in the way that is not the method's own: reverse once while
        // searching, else an error.
        let blocked = |direction: Direction| {
            let (limit, signal) = signals.limit_ahead(direction);
            signal.level && switch != Some(limit)
        };
        match self.phase {
            Phase::Search {
                direction,
                reversed,
            } => {
                let signal = signals.switch(switch?);
                if signal.level {
                    self.phase = self.after_search(true, direction, i);
                } else if blocked(direction) {
                    self.phase = if reversed {
                        Phase::Error
                    } else {
                        Phase::Search {
                            direction: reverse(direction),
                            reversed: true,
                        }
                    };
                }
            }
            Phase::Leave { direction, falling } => {
                let signal = signals.switch(switch?);
                if blocked(direction) {
                    self.phase = Phase::Error;
                } else if signal.falling.count != falling || !signal.level {
                    self.phase = Phase::Approach {
                        direction: reverse(direction),
                        level: true,
                        count: signal.rising.count,
                    };
                }
            }
            Phase::Approach {
                direction,
                level,
                count,
            } => {
                let signal = signals.switch(switch?);
                let edges = signal.edges_to(level);
                if edges.count != count {
                    let index = matches!(reference, Reference::Edge { index: true, .. });
                    self.phase = if index {
                        Phase::Index {
                            direction,
                            edge: edges.position,
                            count: signals.index.count,
                        }
                    } else {
                        Phase::Settle {
                            home: edges.position,
                        }
                    };
                } else if blocked(direction) {
                    self.phase = Phase::Error;
                }
            }
            Phase::Index {
                direction,
                edge,
                count,
            } => {
                let index = signals.index;
                let past =
                    index.position.saturating_sub(edge).signum() != i64::from(reverse(direction));
                if index.count != count && past {
                    self.phase = Phase::Settle {
                        home: index.position,
                    };
                } else if blocked(direction) {
                    self.phase = Phase::Error;
                } else {
                    self.phase = Phase::Index {
                        direction,
                        edge,
                        count: index.count,
                    };
                }
            }
            Phase::Settle { home } => {
                if i.demand_at_rest && i.demand_position == home {
                    self.phase = Phase::Done { home };
                    return Some(home);
                }
            }
            Phase::Idle | Phase::Done { .. } | Phase::Error => {}
        }
        None
    }

    fn demand(&self) -> Demand {
        match self.phase {
            Phase::Idle | Phase::Done { .. } | Phase::Error => Demand::Stop,
            Phase::Search { direction, .. } => Demand::Search(direction),
            Phase::Leave { direction, .. } => Demand::Creep(direction),
            Phase::Approach { direction, .. } | Phase::Index { direction, .. } => {
                Demand::Creep(direction)
            }
            Phase::Settle { home } => Demand::MoveTo(home),
        }
    }

    fn statusword(&self, i: &Inputs) -> u16 {
        let at_rest = if i.at_target { TARGET_REACHED } else { 0 };
        match self.phase {
            Phase::Idle => at_rest,
            Phase::Done { .. } => HOMING_ATTAINED | at_rest,
            Phase::Error => HOMING_ERROR | at_rest,
            _ => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// A one-dimensional axis for the tests: a demand that moves `speed` per cycle, switches
    /// at fixed positions, an index every `pitch`.
    struct Axis {
        position: i64,
        velocity: i64,
        signals: Signals,
        negative_limit_at: i64,
        positive_limit_at: i64,
        /// Home switch active over this range.
        home: (i64, i64),
        pitch: i64,
        index_offset: i64,
    }

    const FAST: i64 = 40;
    const SLOW: i64 = 3;

    impl Axis {
        fn new(position: i64, home: (i64, i64)) -> Self {
            let mut a = Self {
                position,
                velocity: 0,
                signals: Signals::default(),
                negative_limit_at: -10_000,
                positive_limit_at: 10_000,
                home,
                pitch: 1_000,
                index_offset: 250,
            };
            a.sense(position, position);
            a
        }

        fn levels(&self, p: i64) -> (bool, bool, bool) {
            (
                p <= self.negative_limit_at,
                p >= self.positive_limit_at,
                p >= self.home.0 && p <= self.home.1,
            )
        }

        /// The switches and index between `from` and `to`, latched at the exact positions.
        fn sense(&mut self, from: i64, to: i64) {
            let step = (to - from).signum();
            let mut p = from;
            loop {
                let (n, pl, h) = self.levels(p);
                for (sig, level) in [
                    (&mut self.signals.negative_limit, n),
                    (&mut self.signals.positive_limit, pl),
                    (&mut self.signals.home, h),
                ] {
                    if sig.level != level {
                        // The edge at the switch's boundary: its last (or first) active
                        // position.
                        let (e, at) = if level {
                            (&mut sig.rising, p)
                        } else {
                            (&mut sig.falling, p - step)
                        };
                        e.count = e.count.wrapping_add(1);
                        e.position = at;
                        sig.level = level;
                    }
                }
                if p != from && (p - self.index_offset).rem_euclid(self.pitch) == 0 {
                    self.signals.index.count = self.signals.index.count.wrapping_add(1);
                    self.signals.index.position = p;
                }
                if p == to || step == 0 {
                    break;
                }
                p += step;
            }
        }

        fn apply(&mut self, demand: Demand) {
            let target_velocity = match demand {
                Demand::Hold | Demand::Stop => 0,
                Demand::Search(d) => FAST * i64::from(d),
                Demand::Creep(d) => SLOW * i64::from(d),
                Demand::MoveTo(p) => (p - self.position).clamp(-SLOW, SLOW),
            };
            // One unit of acceleration per cycle (a few cycles of overshoot after each edge).
            self.velocity += (target_velocity - self.velocity).clamp(-10, 10);
            let from = self.position;
            self.position += self.velocity;
            self.sense(from, self.position);
        }
    }

    /// Runs method `m` from `start` with the home switch over `home`; the home found.
    fn home(m: i8, start: i64, home: (i64, i64)) -> (Option<i64>, Vec<Phase>) {
        let mut axis = Axis::new(start, home);
        let mut h = Homing::new();
        let mut phases = Vec::new();
        let mut found = None;
        for k in 0..20_000 {
            let cw = if k == 0 { 0x0F } else { 0x1F };
            let out = h.step(&Inputs {
                controlword: cw,
                running: true,
                disabled: false,
                speed_zero: true,
                rules: Rules::default(),
                method: method(m),
                signals: axis.signals,
                demand_position: axis.position,
                demand_at_rest: axis.velocity == 0,
                at_target: axis.velocity == 0,
                timeout_ms: None,
                cycle_ns: 1_000_000,
            });
            if phases.last() != Some(&h.phase) {
                phases.push(h.phase);
            }
            found = found.or(out.home_found);
            if matches!(h.phase, Phase::Done { .. } | Phase::Error) {
                assert_eq!(
                    out.statusword & (HOMING_ATTAINED | HOMING_ERROR | TARGET_REACHED),
                    if found.is_some() {
                        HOMING_ATTAINED | TARGET_REACHED
                    } else {
                        HOMING_ERROR | (out.statusword & TARGET_REACHED)
                    }
                );
                break;
            }
            axis.apply(out.demand);
        }
        (found, phases)
    }

    /// Index pulses at 250 + k·1000.
    const STEP_SWITCH: (i64, i64) = (2_000, i64::MAX); // home switch active from 2000 up
    const NEGATIVE_SWITCH: (i64, i64) = (i64::MIN, 2_000); // active up to 2000
    const CAM: (i64, i64) = (2_000, 2_600);

    #[test]
    fn limit_switch_methods_home_on_the_index_or_the_edge() {
        // Method 1: first index right of the negative limit edge at -10 000 → -9 750.
        assert_eq!(home(1, 0, CAM).0, Some(-9_750));
        assert_eq!(home(17, 0, CAM).0, Some(-10_000), "the edge itself");
        // Method 2: first index left of +10 000 → 9 250.
        assert_eq!(home(2, 0, CAM).0, Some(9_250));
        assert_eq!(home(18, 0, CAM).0, Some(10_000));
        // Starting on the limit switch.
        assert_eq!(home(1, -10_050, CAM).0, Some(-9_750));
    }

    #[test]
    fn home_switch_methods_3_to_6_from_either_side() {
        for start in [0, 5_000] {
            // 3: index left of the edge at 2000 → 1250; 4: right → 2250.
            assert_eq!(home(3, start, STEP_SWITCH).0, Some(1_250), "3 from {start}");
            assert_eq!(home(4, start, STEP_SWITCH).0, Some(2_250), "4 from {start}");
            assert_eq!(
                home(19, start, STEP_SWITCH).0,
                Some(2_000),
                "19 from {start}"
            );
            assert_eq!(
                home(20, start, STEP_SWITCH).0,
                Some(2_000),
                "20 from {start}"
            );
            // 5: negative home switch, index right of the edge; 6: left.
            assert_eq!(
                home(5, start, NEGATIVE_SWITCH).0,
                Some(2_250),
                "5 from {start}"
            );
            assert_eq!(
                home(6, start, NEGATIVE_SWITCH).0,
                Some(1_250),
                "6 from {start}"
            );
        }
    }

    #[test]
    fn home_cam_methods_7_to_14_from_left_inside_and_right() {
        // Cam 2000..2600: left edge 2000 (index left 1250, right 2250); right edge 2600
        // (index left 2250, right 3250).
        let expected = [
            (7, 1_250),
            (8, 2_250),
            (9, 2_250),
            (10, 3_250),
            (11, 3_250),
            (12, 2_250),
            (13, 2_250),
            (14, 1_250),
        ];
        for start in [0, 2_300, 5_000] {
            for (m, home_at) in expected {
                let (found, phases) = home(m, start, CAM);
                assert_eq!(found, Some(home_at), "method {m} from {start}: {phases:?}");
                let edge = if [7, 8, 13, 14].contains(&m) {
                    2_000
                } else {
                    2_600
                };
                assert_eq!(home(m + 16, start, CAM).0, Some(edge), "method {}", m + 16);
            }
        }
    }

    #[test]
    fn a_search_away_from_the_cam_reverses_at_the_limit_switch() {
        // Method 7 searches positive first: from 5000 the cam is behind; the positive limit
        // at 10 000 reverses the search.
        let (found, phases) = home(7, 5_000, CAM);
        assert_eq!(found, Some(1_250));
        assert!(phases.contains(&Phase::Search {
            direction: -1,
            reversed: true
        }));
        // No cam at all: both limits → error.
        let (found, phases) = home(7, 5_000, (50_000, 50_001));
        assert_eq!(found, None);
        assert_eq!(phases.last(), Some(&Phase::Error));
    }

    #[test]
    fn index_and_current_position_methods() {
        assert_eq!(home(33, 0, CAM).0, Some(-750));
        assert_eq!(home(34, 0, CAM).0, Some(250));
        assert_eq!(home(35, 123, CAM).0, Some(123));
        assert_eq!(home(37, -5, CAM).0, Some(-5));
    }

    #[test]
    fn unknown_methods_and_interruptions() {
        for m in [0, 15, 16, 31, 32, 36, -1] {
            assert_eq!(method(m), None);
            let (found, phases) = home(m, 0, CAM);
            assert_eq!((found, phases.last()), (None, Some(&Phase::Error)), "{m}");
        }
        let mut h = Homing::new();
        let mut i = Inputs {
            controlword: 0x0F,
            running: true,
            disabled: false,
            speed_zero: true,
            rules: Rules::default(),
            method: method(34),
            signals: Signals::default(),
            demand_position: 0,
            demand_at_rest: true,
            at_target: true,
            timeout_ms: None,
            cycle_ns: 1_000_000,
        };
        assert_eq!(h.step(&i).statusword, TARGET_REACHED, "not started");
        i.controlword = 0x1F;
        i.demand_at_rest = false;
        i.at_target = false;
        let out = h.step(&i);
        assert_eq!((out.demand, out.statusword), (Demand::Creep(1), 0));
        assert!(h.running());
        i.controlword = 0x0F;
        let out = h.step(&i);
        assert_eq!(out.demand, Demand::Stop, "bit 4 cleared: interrupted");
        assert!(!h.running());
        i.demand_at_rest = true;
        i.at_target = true;
        assert_eq!(h.step(&i).statusword, TARGET_REACHED);
    }

    /// The profiles' start rules: the SDV3-E's homing errors for a start while disabled and a
    /// preset while moving, the Σ-V-SD's current-position method while disabled; CiA402 alone
    /// ignores a start while disabled.
    #[test]
    fn start_rules_of_the_profiles() {
        let inputs = |running: bool, speed_zero: bool, rules: Rules, m: i8| Inputs {
            controlword: 0x1F,
            running,
            disabled: !running,
            speed_zero,
            rules,
            method: method(m),
            signals: Signals::default(),
            demand_position: 77,
            demand_at_rest: true,
            at_target: true,
            timeout_ms: None,
            cycle_ns: 1_000_000,
        };
        let start = |i: Inputs| {
            let mut h = Homing::new();
            let out = h.step(&i);
            (out.statusword, out.home_found)
        };
        let sdv3_e = Rules {
            start_while_disabled_error: true,
            here_needs_speed_zero: true,
            ..Rules::default()
        };
        let sigma_v_sd = Rules {
            here_while_disabled: true,
            ..Rules::default()
        };
        let cia402 = Rules::default();
        // Disabled: CiA402 does not start (not started, at rest).
        assert_eq!(
            start(inputs(false, true, cia402, 35)),
            (TARGET_REACHED, None)
        );
        assert_eq!(
            start(inputs(false, true, cia402, 34)),
            (TARGET_REACHED, None)
        );
        // The SDV3-E: a homing error, whatever the method.
        for m in [35, 34, 19] {
            assert_eq!(
                start(inputs(false, true, sdv3_e, m)),
                (HOMING_ERROR | TARGET_REACHED, None),
                "{m}"
            );
        }
        // The Σ-V-SD: the current position is the home; the other methods wait.
        assert_eq!(
            start(inputs(false, true, sigma_v_sd, 35)),
            (HOMING_ATTAINED | TARGET_REACHED, Some(77))
        );
        assert_eq!(
            start(inputs(false, true, sigma_v_sd, 34)),
            (TARGET_REACHED, None)
        );
        // Enabled, moving: the SDV3-E's preset is an error; CiA402's takes the position.
        assert_eq!(
            start(inputs(true, false, sdv3_e, 35)),
            (HOMING_ERROR | TARGET_REACHED, None)
        );
        assert_eq!(
            start(inputs(true, false, cia402, 35)),
            (HOMING_ATTAINED | TARGET_REACHED, Some(77))
        );
        // At speed zero the SDV3-E presets.
        assert_eq!(
            start(inputs(true, true, sdv3_e, 35)),
            (HOMING_ATTAINED | TARGET_REACHED, Some(77))
        );
    }

    #[test]
    fn a_run_past_the_time_limit_ends_in_a_homing_error() {
        // Method 34 with no index pulse ever: the search goes on until the limit (a profile's
        // homing time limit, e.g. the RSE's P03.45), then bit 13 homing error.
        let mut h = Homing::new();
        let mut i = Inputs {
            controlword: 0x1F,
            running: true,
            disabled: false,
            speed_zero: true,
            rules: Rules::default(),
            method: method(34),
            signals: Signals::default(),
            demand_position: 0,
            demand_at_rest: false,
            at_target: false,
            timeout_ms: Some(100),
            cycle_ns: 1_000_000,
        };
        // The starting cycle, then 99 ms of search.
        for k in 0..100 {
            h.step(&i);
            assert!(h.running(), "running at {k} ms");
        }
        let out = h.step(&i);
        assert!(h.failed(), "the limit");
        assert_eq!(out.demand, Demand::Stop);
        assert_eq!(out.statusword & HOMING_ERROR, HOMING_ERROR);
        // 0 is no limit.
        let mut h = Homing::new();
        i.timeout_ms = Some(0);
        for _ in 0..1_000 {
            h.step(&i);
        }
        assert!(h.running() && !h.failed());
    }
}
