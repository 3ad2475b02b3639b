//! Judging a stop reaction from what the motor did (CiA402 §6.3.4–6.3.8): the samples of the
//! cycles from the stop command on, the deceleration the motor had, the power stage during and
//! after the stop, and the state the drive ends in. Shared by the scenarios that stop a drive.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;

use crate::cia402::{self, OPERATION_ENABLED, QUICK_STOP_ACTIVE};

/// A measured deceleration within this fraction of its ramp.
pub const RAMP_TOLERANCE: f64 = 0.15;
/// The drive's standstill level, rev/s (20 rpm).
pub const STANDSTILL_REV_S: f64 = 20.0 / 60.0;

/// What brings the motor to rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stop {
    /// The power stage off at once.
    Coast,
    /// Along a ramp, rev/s².
    Ramp(f64),
    /// At the current or the voltage limit: at least this deceleration, rev/s².
    Limit(f64),
    /// No stop (the command is ignored).
    None,
}

/// What one cycle brought back, and the motor and power stage of the axis.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// 6041h.
    pub statusword: u16,
    /// The motor's speed (signed).
    pub rev_s: f64,
    /// The power stage switches.
    pub gates: bool,
}

impl Sample {
    /// The sample of the first drive's axis `axis` with `statusword` from the inputs.
    pub fn of(m: &InProcess, axis: usize, statusword: u16) -> Self {
        let segment = m.shared.segment();
        let servo = &segment.drives()[0].servos[axis];
        Self {
            statusword,
            rev_s: servo.plant.mech_speed_rad_s() / TAU,
            gates: servo.latched().gates,
        }
    }

    /// Whether the drive is in `state`.
    pub fn is(&self, state: cia402::State) -> bool {
        cia402::is(self.statusword, state)
    }
}

/// The deceleration from 80 % to 20 % of `speed_rev_s` (cycles of `cycle_s`), rev/s², or how
/// far it got.
pub fn deceleration(samples: &[Sample], speed_rev_s: f64, cycle_s: f64) -> Result<f64, String> {
    let at = |fraction: f64| {
        samples
            .iter()
            .position(|s| s.rev_s.abs() <= fraction * speed_rev_s)
            .ok_or_else(|| {
                format!(
                    "never below {:.0} % of the speed (ends at {:.2} rev/s)",
                    fraction * 100.0,
                    samples.last().map_or(0.0, |s| s.rev_s)
                )
            })
    };
    let (high, low) = (at(0.8)?, at(0.2)?);
    let seconds = ((low - high).max(1)) as f64 * cycle_s;
    Ok(0.6 * speed_rev_s / seconds)
}

/// What is wrong with a stop from `speed_rev_s` (cycles of `cycle_s`), if anything: `stop` the
/// way the motor must come to rest, `end` the state the drive ends in, `via` a state it must
/// pass.
pub fn check(
    samples: &[Sample],
    (stop, end, via): (Stop, cia402::State, Option<cia402::State>),
    (speed_rev_s, cycle_s): (f64, f64),
) -> Result<(), String> {
    let last = samples.last().ok_or("no samples")?;
    if let Some(state) = via {
        if !samples.iter().any(|s| s.is(state)) {
            return Err(format!("never in {:#06x} under {:#06x}", state.1, state.0));
        }
    }
    match stop {
        Stop::None => {
            if (last.rev_s.abs() - speed_rev_s).abs() > 0.3 || !last.gates {
                return Err(format!("stopped: {:.2} rev/s", last.rev_s));
            }
        }
        Stop::Coast => {
            // The power stage off in the cycle the drive leaves Operation Enabled (a command at
            // once, a fault when it trips), and from then on; friction only.
            let left = samples
                .iter()
                .position(|s| !s.is(OPERATION_ENABLED))
                .ok_or("never left Operation Enabled")?;
            if samples.iter().skip(left + 1).any(|s| s.gates) {
                return Err("the power stage stays on".into());
            }
            let later = samples[(left + 100).min(samples.len() - 1)].rev_s.abs();
            if later < 0.3 * speed_rev_s {
                return Err(format!("braked to {later:.2} rev/s in 0.1 s: not coasting"));
            }
        }
        Stop::Ramp(ramp) => {
            let d = deceleration(samples, speed_rev_s, cycle_s)?;
            if (d - ramp).abs() > RAMP_TOLERANCE * ramp {
                return Err(format!("decelerated at {d:.1} rev/s², the ramp is {ramp}"));
            }
        }
        Stop::Limit(at_least) => {
            let d = deceleration(samples, speed_rev_s, cycle_s)?;
            if d < at_least {
                return Err(format!("decelerated at only {d:.1} rev/s² at the limit"));
            }
        }
    }
    if stop != Stop::Coast && stop != Stop::None {
        // Under power until at rest.
        if let Some(s) = samples
            .iter()
            .find(|s| !s.gates && s.rev_s.abs() > STANDSTILL_REV_S * 2.0)
        {
            return Err(format!("power stage off at {:.2} rev/s", s.rev_s));
        }
        if last.rev_s.abs() > STANDSTILL_REV_S {
            return Err(format!("not at rest: {:.2} rev/s", last.rev_s));
        }
        // Held (quick stop 5-8, halt) or disabled.
        let held = end == QUICK_STOP_ACTIVE || end == OPERATION_ENABLED;
        if last.gates != held {
            return Err(format!(
                "power stage {} at rest",
                if last.gates { "on" } else { "off" }
            ));
        }
    }
    if !last.is(end) {
        return Err(format!(
            "ends in statusword {:#06x}, expected {:#06x} under {:#06x}",
            last.statusword, end.1, end.0
        ));
    }
    Ok(())
}
