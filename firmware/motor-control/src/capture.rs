//! Position capture on the axis' digital inputs and the encoder index, in the control
//! interrupt: the limit switches and the home switch are sampled every PWM period, and the
//! position at each edge is latched with a counter, so the SYNC0 side (homing, limits) sees
//! every edge and where it happened even when several fall between two bus cycles. The index
//! position comes latched from the encoder driver (a timer capture of the counter on Z, or the
//! single-turn zero of an absolute encoder).
//!
//! Resolution: an edge is placed at the position of the first sample that shows the new level
//! (one PWM period late at most: 0.9° at 3000 rpm and 20 kHz; homing searches run slowly).
//!
//! The touch-probe inputs come with the time of their edge within the period (a timer input
//! capture or the ET1100 latch unit): their edges are latched at the position of that instant,
//! interpolated between this period's and the previous period's encoder positions.
//!
//! Timing: five compare-and-latch steps and an optional index latch per period; a multiply
//! and an add per probe edge.

use hal::io::ProbeCapture;

/// The level of the axis' switches in one sample (`true` = actuated).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Switches {
    /// Positive limit switch.
    pub positive_limit: bool,
    /// Negative limit switch.
    pub negative_limit: bool,
    /// Home switch.
    pub home: bool,
}

/// The edges of one signal: how many (wrapping) and where the last one was.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Latch {
    /// Edges latched so far (wrapping): a change tells the reader that a new one happened.
    pub count: u16,
    /// Position at the last edge, increments.
    pub position: i64,
}

impl Latch {
    fn take(&mut self, position: i64) {
        self.count = self.count.wrapping_add(1);
        self.position = position;
    }
}

/// Rising and falling edges of one switch, and its level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SwitchCapture {
    /// The level in the last sample.
    pub level: bool,
    /// Inactive → actuated.
    pub rising: Latch,
    /// Actuated → inactive.
    pub falling: Latch,
}

impl SwitchCapture {
    /// At `level`, no edge yet.
    const fn at(level: bool) -> Self {
        let none = Latch {
            count: 0,
            position: 0,
        };
        Self {
            level,
            rising: none,
            falling: none,
        }
    }

    fn update(&mut self, level: bool, position: i64) -> bool {
        let changed = level != self.level;
        if changed {
            if level {
                self.rising.take(position);
            } else {
                self.falling.take(position);
            }
            self.level = level;
        }
        changed
    }

    /// The latch of the edge that goes to `level`.
    pub fn edge_to(&self, level: bool) -> Latch {
        if level {
            self.rising
        } else {
            self.falling
        }
    }
}

/// Everything the axis captured: the three switches, the index and the touch-probe inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Captures {
    /// Positive limit switch.
    pub positive_limit: SwitchCapture,
    /// Negative limit switch.
    pub negative_limit: SwitchCapture,
    /// Home switch.
    pub home: SwitchCapture,
    /// Encoder index pulses.
    pub index: Latch,
    /// Touch-probe inputs 1 and 2, each edge at the position of its edge time.
    pub probes: [SwitchCapture; 2],
}

/// The position at an edge `edge_ns_before` the instant of `position` (negative: after it),
/// the motor having moved from `previous` one PWM period earlier (`inv_period_ns` = 1 / the
/// period in ns): linear interpolation, exact at a constant speed.
pub fn position_at_edge(
    position: i64,
    previous: i64,
    edge_ns_before: i32,
    inv_period_ns: f32,
) -> i64 {
    let moved = position.wrapping_sub(previous) as f32;
    let back = moved * edge_ns_before as f32 * inv_period_ns;
    // Rounded to the nearest increment (`as` saturates; a non-finite value gives 0).
    let back = if back >= 0.0 { back + 0.5 } else { back - 0.5 } as i64;
    position.saturating_sub(back)
}

impl Captures {
    /// One sample: the switch levels at `position`, and the index position if one was seen.
    /// Returns whether anything was latched. (The first sample after power-on sets the levels
    /// with [`Self::initial`], counting no edge.)
    pub fn update(&mut self, switches: Switches, index: Option<i64>, position: i64) -> bool {
        let mut changed = self
            .positive_limit
            .update(switches.positive_limit, position);
        changed |= self
            .negative_limit
            .update(switches.negative_limit, position);
        changed |= self.home.update(switches.home, position);
        if let Some(at) = index {
            self.index.take(at);
            changed = true;
        }
        changed
    }

    /// Whether `probes` show anything new (a level change or an edge): the control interrupt's
    /// fast path, a few compares per period.
    #[inline]
    pub fn probes_changed(&self, probes: &[ProbeCapture; 2]) -> bool {
        let [a, b] = probes;
        let [ca, cb] = &self.probes;
        a.active != ca.level
            || b.active != cb.level
            || a.edge_ns_before_position.is_some()
            || b.edge_ns_before_position.is_some()
    }

    /// One sample of the touch-probe inputs: an edge is latched at the position of its edge
    /// time ([`position_at_edge`]). Returns whether anything was latched. (Rare: called when
    /// [`Self::probes_changed`].)
    #[inline(never)]
    pub fn update_probes(
        &mut self,
        probes: [ProbeCapture; 2],
        position: i64,
        previous: i64,
        inv_period_ns: f32,
    ) -> bool {
        let mut changed = false;
        for (capture, probe) in self.probes.iter_mut().zip(probes) {
            if probe.active == capture.level && probe.edge_ns_before_position.is_none() {
                continue;
            }
            let at = probe.edge_ns_before_position.map_or(position, |ns| {
                position_at_edge(position, previous, ns, inv_period_ns)
            });
            changed |= capture.update(probe.active, at);
        }
        changed
    }

    /// The captures of a power-on with the switches at `switches`: levels set, no edges.
    pub const fn initial(switches: Switches) -> Self {
        Self {
            positive_limit: SwitchCapture::at(switches.positive_limit),
            negative_limit: SwitchCapture::at(switches.negative_limit),
            home: SwitchCapture::at(switches.home),
            index: Latch {
                count: 0,
                position: 0,
            },
            probes: [SwitchCapture::at(false), SwitchCapture::at(false)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_latch_the_position_of_the_first_sample_at_the_new_level() {
        let mut c = Captures::default();
        let home = |on| Switches {
            home: on,
            ..Switches::default()
        };
        assert!(!c.update(home(false), None, 10));
        assert_eq!(c.home.rising.count, 0);
        assert!(c.update(home(true), None, 20));
        assert!(!c.update(home(true), None, 30));
        assert_eq!(
            c.home.rising,
            Latch {
                count: 1,
                position: 20
            }
        );
        assert!(c.home.level);
        c.update(home(false), Some(35), 40);
        assert_eq!(
            c.home.falling,
            Latch {
                count: 1,
                position: 40
            }
        );
        assert_eq!(c.home.edge_to(false), c.home.falling);
        assert_eq!(
            c.index,
            Latch {
                count: 1,
                position: 35
            }
        );
        assert_eq!(c.positive_limit, SwitchCapture::default());
    }

    #[test]
    fn probe_edges_are_latched_at_their_edge_time() {
        let mut c = Captures::default();
        // 25 µs periods; the motor moved 1000 → 1400 in the last one; the probe rose 10 µs
        // before the sample: 1400 − 400 · 10/25 = 1240.
        let inv = 1.0 / 25_000.0;
        let rising = ProbeCapture {
            active: true,
            edge_ns_before_position: Some(10_000),
        };
        assert!(c.update_probes([rising, ProbeCapture::default()], 1400, 1000, inv));
        assert_eq!(
            c.probes[0].rising,
            Latch {
                count: 1,
                position: 1240
            }
        );
        assert_eq!(c.probes[1], SwitchCapture::default());
        // Held: nothing new.
        let held = ProbeCapture {
            active: true,
            edge_ns_before_position: None,
        };
        assert!(!c.update_probes([held, ProbeCapture::default()], 1800, 1400, inv));
        // Falling 1 µs after the position instant (negative): extrapolated, moving backwards.
        let falling = ProbeCapture {
            active: false,
            edge_ns_before_position: Some(-1_000),
        };
        assert!(c.update_probes([falling, ProbeCapture::default()], 1000, 1500, inv));
        assert_eq!(
            c.probes[0].falling,
            Latch {
                count: 1,
                position: 980
            }
        );
        assert_eq!(
            position_at_edge(i64::MAX, i64::MIN, i32::MAX, inv),
            i64::MAX
        );
    }

    #[test]
    fn counters_wrap_and_the_initial_level_is_no_edge() {
        let on = Switches {
            positive_limit: true,
            negative_limit: false,
            home: true,
        };
        let mut c = Captures::initial(on);
        c.update(on, None, 0);
        assert_eq!((c.home.rising.count, c.positive_limit.rising.count), (0, 0));
        c.index.count = u16::MAX;
        c.update(on, Some(5), 0);
        assert_eq!(c.index.count, 0);
    }
}
