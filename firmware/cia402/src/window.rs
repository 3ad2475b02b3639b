//! "Inside a window for a time" monitors of CiA402: target reached in position modes (6067h
//! position window for 6068h position window time), in velocity modes (606Dh velocity window
//! for 606Eh), and speed zero (606Fh velocity threshold for 6070h).

/// A window value that switches the monitor off (CiA402 6067h: FFFF FFFFh).
pub const WINDOW_OFF: u32 = u32::MAX;

/// A monitor that reports true once its condition has held for the window time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WindowTimer {
    /// How long the condition has held, ns (saturating).
    held_ns: u64,
    inside: bool,
}

impl WindowTimer {
    /// Not inside.
    pub const fn new() -> Self {
        Self {
            held_ns: 0,
            inside: false,
        }
    }

    /// One cycle of `cycle_ns`: whether the condition holds now; returns whether it has held
    /// for `time_ms` (the cycle it starts holding counts as 0 ms, so a window time of 0 reports
    /// at once).
    pub fn step(&mut self, inside: bool, time_ms: u16, cycle_ns: u32) -> bool {
        if !inside {
            *self = Self::new();
            return false;
        }
        if self.inside {
            self.held_ns = self.held_ns.saturating_add(u64::from(cycle_ns));
        }
        self.inside = true;
        self.held_ns >= u64::from(time_ms) * 1_000_000
    }

    /// Forgets the history (a new target).
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// Whether `deviation` is inside a symmetric window of `window` (both in the same unit);
/// [`WINDOW_OFF`] accepts every deviation.
pub fn inside(deviation: i64, window: u32) -> bool {
    window == WINDOW_OFF || deviation.unsigned_abs() <= u64::from(window)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_after_the_window_time_and_restarts_when_left() {
        let mut w = WindowTimer::new();
        // 1 ms cycles, 3 ms window time: inside at cycles 0, 1, 2, 3 → reported at the 4th.
        let seen: [bool; 5] = core::array::from_fn(|_| w.step(true, 3, 1_000_000));
        assert_eq!(seen, [false, false, false, true, true]);
        assert!(!w.step(false, 3, 1_000_000));
        assert!(!w.step(true, 3, 1_000_000), "starts over");
        assert!(WindowTimer::new().step(true, 0, 1_000_000), "0 ms: at once");
    }

    #[test]
    fn window_bounds_are_inclusive_and_ffffffff_is_off() {
        assert!(inside(-10, 10));
        assert!(inside(10, 10));
        assert!(!inside(11, 10));
        assert!(inside(i64::MIN, WINDOW_OFF));
        assert!(!inside(i64::MIN, u32::MAX - 1));
    }
}
