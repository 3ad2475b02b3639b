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
//! Timing: three compare-and-latch steps and an optional index latch per period; no arithmetic.

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

/// Everything the axis captured: the three switches and the index.
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
