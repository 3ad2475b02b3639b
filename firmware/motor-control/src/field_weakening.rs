//! Field weakening: a negative d-axis current that lowers the back-EMF when the voltage the
//! current loop asks for approaches what the bus gives, so that the motor reaches speeds whose
//! back-EMF plus q-axis drop would otherwise saturate the voltage circle (and lose current
//! control of q).
//!
//! An integrator on the voltage margin, run at the loop rate: the squared voltage vector of the
//! current loop, normalised by the bus voltage squared, is compared with the squared level
//! `voltage_fraction` of the limiter's circle (max_modulation/√3 of the bus); above it the d
//! current goes down (more negative), below it back up to 0, at `gain_a` per loop tick and unit
//! of normalised error, never below `-max_d_current_a`. Squares throughout: no square root, no
//! division in the interrupt.
//!
//! Loop gain: around the operating point d(v²/Vbus²)/d(id) ≈ 2·|v|·ω_e·L_d/Vbus², for the 400 W
//! servo at 4500 rpm about 0.016 per A; with `gain_a` = 1 the margin settles with a time constant
//! of ~60 ticks (3 ms at 20 kHz), far slower than the current loop (~4 kHz).

/// √3, for the limiter's circle max_modulation·Vbus/√3.
const SQRT3: f32 = 1.732_050_8;

/// Field-weakening settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldWeakeningConfig {
    /// Fraction of the voltage circle the current loop may use before the d current goes down
    /// (0 < fraction < 1, e.g. 0.95); 1 or more switches field weakening off.
    pub voltage_fraction: f32,
    /// Integrator gain, A of d current per loop tick and unit of normalised squared error.
    pub gain_a: f32,
    /// The most negative d current, A (a magnitude; the demagnetisation and current budget).
    pub max_d_current_a: f32,
}

impl FieldWeakeningConfig {
    /// No field weakening (the d current stays 0).
    pub const OFF: Self = Self {
        voltage_fraction: 1.0,
        gain_a: 0.0,
        max_d_current_a: 0.0,
    };
}

/// The field-weakening integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldWeakening {
    /// (voltage_fraction · max_modulation / √3)²: the level of v²/Vbus².
    level2: f32,
    gain_a: f32,
    min_id: f32,
    id: f32,
}

impl FieldWeakening {
    /// The integrator for a current loop whose circle is `max_modulation`·Vbus/√3; off when the
    /// configuration is not usable (a fraction outside 0..1, a gain or limit not finite or
    /// negative).
    pub fn new(cfg: &FieldWeakeningConfig, max_modulation: f32) -> Self {
        let usable = cfg.voltage_fraction > 0.0
            && cfg.voltage_fraction < 1.0
            && cfg.gain_a.is_finite()
            && cfg.gain_a >= 0.0
            && cfg.max_d_current_a.is_finite()
            && cfg.max_d_current_a >= 0.0;
        if !usable {
            return Self {
                // The largest level: the error never turns negative (and 0 × it stays 0).
                level2: f32::MAX,
                gain_a: 0.0,
                min_id: 0.0,
                id: 0.0,
            };
        }
        let level = cfg.voltage_fraction * max_modulation / SQRT3;
        Self {
            level2: level * level,
            gain_a: cfg.gain_a,
            min_id: -cfg.max_d_current_a,
            id: 0.0,
        }
    }

    /// One loop tick with the current loop's last voltage vector squared, normalised by the bus
    /// voltage squared (`v2_per_vbus2` = (vd² + vq²)/Vbus²): the d-current reference, A (≤ 0).
    #[inline]
    pub fn step(&mut self, v2_per_vbus2: f32) -> f32 {
        let error = self.level2 - v2_per_vbus2;
        let id = self.id + self.gain_a * error;
        // A NaN (a bus reading of 0) gives 0, no weakening.
        self.id = if id.is_nan() || id >= 0.0 {
            0.0
        } else if id < self.min_id {
            self.min_id
        } else {
            id
        };
        self.id
    }

    /// The d-current reference now, A.
    pub fn d_current(&self) -> f32 {
        self.id
    }

    /// Back to no weakening (the axis starts running).
    pub fn reset(&mut self) {
        self.id = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: FieldWeakeningConfig = FieldWeakeningConfig {
        voltage_fraction: 0.95,
        gain_a: 1.0,
        max_d_current_a: 10.0,
    };

    #[test]
    fn below_the_level_the_d_current_stays_zero() {
        let mut fw = FieldWeakening::new(&CFG, 0.95);
        for _ in 0..100 {
            assert_eq!(fw.step(0.1), 0.0);
        }
    }

    #[test]
    fn above_the_level_the_d_current_goes_down_to_its_limit_and_back() {
        let mut fw = FieldWeakening::new(&CFG, 0.95);
        // The circle itself (what a saturated limiter returns): (0.95/√3)² = 0.3008.
        let saturated = (0.95f32 / SQRT3).powi(2);
        let first = fw.step(saturated);
        assert!(first < 0.0, "{first}");
        for _ in 0..10_000 {
            fw.step(saturated);
        }
        assert_eq!(fw.d_current(), -10.0, "limited");
        // Low voltage again: back towards 0, never above.
        for _ in 0..100_000 {
            fw.step(0.0);
        }
        assert_eq!(fw.d_current(), 0.0);
    }

    #[test]
    fn it_settles_where_the_voltage_meets_the_level() {
        // A plant whose v²/Vbus² falls linearly with -id: 0.32 at id = 0, 0.016 per A.
        let mut fw = FieldWeakening::new(&CFG, 0.95);
        let level2 = (0.95f32 * 0.95 / SQRT3).powi(2);
        let mut id = 0.0;
        for _ in 0..2_000 {
            id = fw.step(0.32 + 0.016 * id);
        }
        let expected = (level2 - 0.32) / 0.016;
        assert!((id - expected).abs() < 0.01, "{id} vs {expected}");
    }

    #[test]
    fn an_unusable_configuration_is_off() {
        for cfg in [
            FieldWeakeningConfig::OFF,
            FieldWeakeningConfig {
                gain_a: f32::NAN,
                ..CFG
            },
            FieldWeakeningConfig {
                max_d_current_a: -1.0,
                ..CFG
            },
        ] {
            let mut fw = FieldWeakening::new(&cfg, 0.95);
            assert_eq!(fw.step(10.0), 0.0);
        }
    }

    #[test]
    fn a_nan_voltage_gives_no_weakening() {
        let mut fw = FieldWeakening::new(&CFG, 0.95);
        fw.step(1.0);
        assert!(fw.d_current() < 0.0);
        assert_eq!(fw.step(f32::NAN), 0.0);
    }
}
