//! Whether the interrupt contexts are alive: the decision behind every refresh of the
//! independent watchdog.
//!
//! The watchdog is refreshed from thread mode, the lowest priority: a refresh at all proves that
//! no interrupt context has taken the CPU for good. It must also prove that the contexts still
//! *run*: the control interrupt (its timer or ADC trigger could stop, leaving the last duties on
//! the bridge) and, where the bus expects it, the process-data cycle. Each context counts its
//! runs; between two checks every expected context must have advanced, or the refresh is
//! withheld and the watchdog resets the MCU (gates off, the ESC's outputs to their safe state
//! through the SM watchdog).

/// The run counters seen at the last check.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Liveness {
    control: Option<u32>,
    cycle: Option<u32>,
}

impl Liveness {
    /// Nothing seen yet.
    pub const fn new() -> Self {
        Self {
            control: None,
            cycle: None,
        }
    }

    /// Whether to refresh the watchdog: `control` and `cycle` are the contexts' run counters,
    /// `None` where the context is not expected to run now (no motor; no synchronous cycle in
    /// the present EtherCAT state). A context that has just become expected gets one check
    /// period to show its first run.
    pub fn check(&mut self, control: Option<u32>, cycle: Option<u32>) -> bool {
        let alive = advanced(self.control, control) && advanced(self.cycle, cycle);
        self.control = control;
        self.cycle = cycle;
        alive
    }
}

/// Whether a counter expected to run has moved since the last check.
fn advanced(before: Option<u32>, now: Option<u32>) -> bool {
    match (before, now) {
        (Some(before), Some(now)) => now != before,
        // Not expected now, or only from now on.
        (_, None) | (None, Some(_)) => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_context_that_stops_withholds_the_refresh() {
        let mut l = Liveness::new();
        assert!(l.check(Some(10), None), "first sight: one period of grace");
        assert!(l.check(Some(50), None));
        assert!(!l.check(Some(50), None), "control stopped");
        assert!(l.check(Some(51), None));
        // The cycle becomes expected (SAFEOP in a DC mode), then stops.
        assert!(l.check(Some(90), Some(0)));
        assert!(l.check(Some(130), Some(3)));
        assert!(!l.check(Some(170), Some(3)), "cycle stopped");
        // Not expected any more (back to PREOP): no check.
        assert!(l.check(Some(210), None));
        // A counter that wrapped has moved too.
        let mut l = Liveness::new();
        l.check(Some(u32::MAX), None);
        assert!(l.check(Some(0), None));
    }

    #[test]
    fn without_a_motor_only_the_cycle_counts() {
        let mut l = Liveness::new();
        assert!(l.check(None, None));
        assert!(l.check(None, None));
        assert!(l.check(None, Some(7)));
        assert!(!l.check(None, Some(7)));
    }
}
