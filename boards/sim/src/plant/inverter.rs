//! Two-level voltage-source inverter with centre-aligned PWM, dead time and device drops.
//!
//! Sign convention: a positive phase current flows *out of* the leg into the motor.
//!
//! Carrier: a triangle counting 0 → peak → 0 over one PWM period `Ts`; the high-side gate of a
//! leg with duty `d` is commanded on for `d·Ts`, centred at `Ts/2`, i.e. over
//! `[t_on, t_off] = [(1−d)·Ts/2, (1+d)·Ts/2]`. At the period boundaries every low side is on
//! (that is where the firmware samples the shunt currents).
//!
//! Dead time `td`: each switch turns on `td` after its complementary switch turned off, so the
//! leg has two dead intervals per period, `[t_on, t_on+td]` and `[t_off, t_off+td]`, in which
//! the current commutates through a diode chosen by its sign: `i > 0` → lower diode → 0 V,
//! `i < 0` → upper diode → `Vbus`. Hence the average leg voltage over a period is
//! `Vbus·(d − sign(i)·td/Ts)`: the error that dead-time compensation in the firmware corrects.
//! A conducting device (switch or diode) drops `device_drop_v` in the direction of the
//! current: the leg voltage is lowered by `device_drop_v·sign(i)`.
//!
//! Limitations (documented, not modelled): when `i` is exactly 0 during a dead interval the leg
//! is taken at `Vbus/2`; a low-side pulse shorter than the dead time at the end of the period
//! is simply cut at the period boundary (the next period starts with the low side on).

/// Parameters of the power stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InverterParams {
    /// DC-link voltage in V (the nominal value; [`super::Plant::set_bus_voltage`] changes it).
    pub bus_voltage_v: f64,
    /// PWM (switching) frequency in Hz; one control period `Ts = 1/pwm_hz`.
    pub pwm_hz: f64,
    /// Dead time inserted on every switching edge, in s (must be below `Ts/2`).
    pub dead_time_s: f64,
    /// Forward drop of a conducting switch or diode, in V (constant-voltage model).
    pub device_drop_v: f64,
}

/// Sign of a phase current as used by the dead-time and drop model (0 for exactly 0 A).
fn current_sign(current_a: f64) -> f64 {
    if current_a > 0.0 {
        1.0
    } else if current_a < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Length of the overlap of `[a0, a1]` with `[b0, b1]` (0 if disjoint or empty).
fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (a1.min(b1) - a0.max(b0)).max(0.0)
}

/// Clamps a commanded duty into [0, 1]; NaN counts as 0 (the leg stays low).
pub fn clamp_duty(duty: f64) -> f64 {
    if duty.is_nan() {
        0.0
    } else {
        duty.clamp(0.0, 1.0)
    }
}

/// The operating point of the power stage during one PWM period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LegTiming {
    /// PWM period `Ts` in s.
    pub period_s: f64,
    /// Dead time in s.
    pub dead_time_s: f64,
    /// Actual DC-link voltage in V.
    pub bus_v: f64,
    /// Device forward drop in V.
    pub drop_v: f64,
}

impl LegTiming {
    /// Exact average leg voltage (leg to negative DC rail) over `[t0, t1]` (times relative to
    /// the start of the PWM period, `0 <= t0 < t1 <= Ts`), for a leg switching with `duty` and
    /// carrying `current_a` (taken as constant over the interval).
    pub fn average_voltage(&self, duty: f64, t0: f64, t1: f64, current_a: f64) -> f64 {
        let span = t1 - t0;
        if span <= 0.0 {
            return 0.0;
        }
        self.average_voltage_over(duty, (t0, t1, 1.0 / span), current_a)
    }

    /// [`Self::average_voltage`] of the three legs over the same interval (one division).
    pub fn average_voltages(
        &self,
        duties: [f64; 3],
        t0: f64,
        t1: f64,
        currents_a: [f64; 3],
    ) -> [f64; 3] {
        let span = t1 - t0;
        if span <= 0.0 {
            return [0.0; 3];
        }
        self.average_voltages_over(duties, (t0, t1, 1.0 / span), currents_a)
    }

    /// [`Self::average_voltages`] over `[t0, t1]` (t1 > t0) with `inverse_span` = 1 / (t1 − t0)
    /// (a plant whose substeps repeat divides once).
    pub fn average_voltages_over(
        &self,
        duties: [f64; 3],
        (t0, t1, inverse_span): (f64, f64, f64),
        currents_a: [f64; 3],
    ) -> [f64; 3] {
        [0, 1, 2]
            .map(|k| self.average_voltage_over(duties[k], (t0, t1, inverse_span), currents_a[k]))
    }

    /// The average over `[t0, t1]` (t1 > t0) with `inverse_span` = 1 / (t1 − t0).
    fn average_voltage_over(
        &self,
        duty: f64,
        (t0, t1, inverse_span): (f64, f64, f64),
        current_a: f64,
    ) -> f64 {
        let LegTiming {
            period_s,
            dead_time_s,
            bus_v,
            drop_v,
        } = *self;
        let span = t1 - t0;
        let d = clamp_duty(duty);
        let sign = current_sign(current_a);
        // Time of [t0, t1] with the high switch conducting and with the low switch conducting;
        // the rest is dead time.
        let (high, low) = if d <= 0.0 {
            (0.0, span)
        } else if d >= 1.0 {
            (span, 0.0)
        } else {
            let t_on = 0.5 * (1.0 - d) * period_s;
            let t_off = 0.5 * (1.0 + d) * period_s;
            let high = overlap(t0, t1, t_on + dead_time_s, t_off);
            let low = overlap(t0, t1, 0.0, t_on)
                + overlap(t0, t1, (t_off + dead_time_s).min(period_s), period_s);
            (high, low)
        };
        let dead = (span - high - low).max(0.0);
        // Leg voltage while both switches are off: set by the freewheeling diode.
        let dead_level = match sign {
            s if s > 0.0 => 0.0,
            s if s < 0.0 => bus_v,
            _ => 0.5 * bus_v,
        };
        (bus_v * high + dead_level * dead) * inverse_span - drop_v * sign
    }
}

/// Leg voltage with all gates off while the phase conducts through a diode in direction `dir`
/// (`+1`: current out of the leg, lower diode; `-1`: current into the leg, upper diode).
pub fn diode_leg_voltage(dir: i8, bus_v: f64, drop_v: f64) -> f64 {
    if dir > 0 {
        -drop_v
    } else {
        bus_v + drop_v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TS: f64 = 25e-6;
    const VBUS: f64 = 48.0;

    fn leg_average_voltage(d: f64, td: f64, t0: f64, t1: f64, i: f64, drop_v: f64) -> f64 {
        let leg = LegTiming {
            period_s: TS,
            dead_time_s: td,
            bus_v: VBUS,
            drop_v,
        };
        leg.average_voltage(d, t0, t1, i)
    }

    /// Average over a whole period computed from `n` equal sub-intervals.
    fn period_average(duty: f64, td: f64, current: f64, drop: f64, n: usize) -> f64 {
        let h = TS / n as f64;
        (0..n)
            .map(|k| {
                let t0 = k as f64 * h;
                leg_average_voltage(duty, td, t0, t0 + h, current, drop) * h
            })
            .sum::<f64>()
            / TS
    }

    /// The three legs at once give each leg's own average, to the last bit or so (one
    /// reciprocal of the span instead of a division per leg), and nothing over an empty span.
    #[test]
    fn three_legs_at_once_are_each_legs_average() {
        let leg = LegTiming {
            period_s: TS,
            dead_time_s: 0.5e-6,
            bus_v: VBUS,
            drop_v: 0.7,
        };
        let duties = [0.0, 0.37, 1.0];
        let currents = [2.0, -1.5, 0.0];
        for (t0, t1) in [(0.0, TS), (1e-6, 2.25e-6), (5e-6, 15e-6), (24e-6, TS)] {
            let all = leg.average_voltages(duties, t0, t1, currents);
            for k in 0..3 {
                let one = leg.average_voltage(duties[k], t0, t1, currents[k]);
                assert!(
                    (all[k] - one).abs() <= 1e-12 * VBUS,
                    "leg {k} over {t0}..{t1}"
                );
            }
        }
        assert_eq!(leg.average_voltages(duties, 3e-6, 3e-6, currents), [0.0; 3]);
    }

    #[test]
    fn centre_aligned_average_is_duty_times_bus_without_dead_time() {
        for &n in &[1usize, 7, 20, 64] {
            for k in 0..=20 {
                let d = k as f64 / 20.0;
                for &i in &[-3.0, 0.0, 2.0] {
                    let v = period_average(d, 0.0, i, 0.0, n);
                    assert!((v - d * VBUS).abs() < 1e-12, "d={d} n={n} v={v}");
                }
            }
        }
    }

    #[test]
    fn pulse_is_centred_and_all_low_at_the_boundaries() {
        let d = 0.3;
        let h = TS / 20.0;
        // First and last substeps: leg low (t_on = 0.35·Ts > h).
        assert_eq!(leg_average_voltage(d, 0.0, 0.0, h, 1.0, 0.0), 0.0);
        assert_eq!(leg_average_voltage(d, 0.0, TS - h, TS, 1.0, 0.0), 0.0);
        // Centre substeps: leg high.
        let mid = leg_average_voltage(d, 0.0, TS / 2.0 - h, TS / 2.0 + h, 1.0, 0.0);
        assert_eq!(mid, VBUS);
        // Symmetry about Ts/2.
        let a = leg_average_voltage(d, 0.0, 0.3 * TS, 0.4 * TS, 1.0, 0.0);
        let b = leg_average_voltage(d, 0.0, 0.6 * TS, 0.7 * TS, 1.0, 0.0);
        assert!((a - b).abs() < 1e-12);
    }

    #[test]
    fn dead_time_error_is_bus_times_td_over_ts_by_current_sign() {
        let td = 500e-9;
        let d = 0.4;
        let err = VBUS * td / TS;
        let pos = period_average(d, td, 5.0, 0.0, 20);
        let neg = period_average(d, td, -5.0, 0.0, 20);
        assert!((pos - (d * VBUS - err)).abs() < 1e-9, "{pos}");
        assert!((neg - (d * VBUS + err)).abs() < 1e-9, "{neg}");
    }

    #[test]
    fn device_drop_opposes_current() {
        let drop = 0.7;
        let pos = period_average(0.5, 0.0, 1.0, drop, 20);
        let neg = period_average(0.5, 0.0, -1.0, drop, 20);
        assert!((pos - (0.5 * VBUS - drop)).abs() < 1e-12);
        assert!((neg - (0.5 * VBUS + drop)).abs() < 1e-12);
        assert_eq!(diode_leg_voltage(1, VBUS, drop), -drop);
        assert_eq!(diode_leg_voltage(-1, VBUS, drop), VBUS + drop);
    }

    #[test]
    fn duty_is_clamped_and_nan_is_low() {
        assert_eq!(clamp_duty(f64::NAN), 0.0);
        assert_eq!(clamp_duty(-0.5), 0.0);
        assert_eq!(clamp_duty(1.5), 1.0);
        assert!((period_average(2.0, 200e-9, 1.0, 0.0, 20) - VBUS).abs() < 1e-12);
    }
}
