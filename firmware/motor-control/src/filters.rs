//! Torque-reference filters: first-order low-pass, biquad low-pass and notch.
//!
//! Design happens when a configuration is applied (divisions, `sin`/`cos` through
//! [`math::sin_cos_rad`](super::math::sin_cos_rad)); the per-tick `update` functions are a few
//! multiply-adds with no division.
//!
//! All designs use the bilinear transform with the analog prototype prewarped at the design
//! frequency, so the digital response has exactly the prototype's gain there: −3.01 dB at the
//! cut-off of a first-order or Butterworth (Q = 1/√2) low-pass, exactly `depth` at the centre
//! of a notch. The coefficients are those of the RBJ "Audio EQ cookbook"; the notch of any depth
//! is its peaking-EQ form with the numerator damping `depth` times the denominator's.
//!
//! | filter | prototype H(s), s normalised to the design frequency |
//! |---|---|
//! | [`LowPass1`], [`Biquad::first_order_low_pass`] | 1 / (s + 1) |
//! | [`Biquad::low_pass`] | 1 / (s² + s/Q + 1) |
//! | [`Biquad::notch`] | (s² + s·depth/Q + 1) / (s² + s/Q + 1), Q = f0 / bandwidth |
//!
//! Every filter has unity gain at DC.

use super::math::{sin_cos_rad, TAU};

/// Why a filter could not be designed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FilterError {
    /// A frequency, Q, bandwidth, depth or the sample rate is NaN or infinite.
    NotFinite,
    /// A frequency, Q, bandwidth or the sample rate is zero or negative.
    NotPositive,
    /// A frequency is at or above the Nyquist frequency (half the sample rate).
    AboveNyquist,
    /// A notch depth outside `0.0..=1.0`.
    DepthOutOfRange,
}

/// Checks that `x` is finite and strictly positive.
fn positive(x: f32) -> Result<f32, FilterError> {
    if !x.is_finite() {
        Err(FilterError::NotFinite)
    } else if x <= 0.0 {
        Err(FilterError::NotPositive)
    } else {
        Ok(x)
    }
}

/// The digital angular frequency `2π·f/fs` (radians per sample) of `freq_hz`, checked to be
/// positive and below Nyquist.
fn digital_angle(freq_hz: f32, sample_hz: f32) -> Result<f32, FilterError> {
    let fs = positive(sample_hz)?;
    let f = positive(freq_hz)?;
    if f >= 0.5 * fs {
        return Err(FilterError::AboveNyquist);
    }
    Ok(TAU * f / fs)
}

/// First-order low-pass, bilinear transform prewarped at the cut-off:
/// `y[k] = b·(x[k] + x[k−1]) + a·y[k−1]` with K = tan(π·fc/fs), b = K/(1+K), a = (1−K)/(1+K).
///
/// Compared with the exact pole mapping a = exp(−2π·fc/fs) the pole is the same to first order
/// in fc/fs; the bilinear form adds a zero at Nyquist (more attenuation of the highest
/// frequencies) and puts the −3 dB point exactly at `fc` for every fc < fs/2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowPass1 {
    b: f32,
    a: f32,
    x1: f32,
    y1: f32,
}

/// `(b, a)` of the prewarped first-order low-pass, see [`LowPass1`].
fn first_order_coefficients(cutoff_hz: f32, sample_hz: f32) -> Result<(f32, f32), FilterError> {
    let w0 = digital_angle(cutoff_hz, sample_hz)?;
    // w0/2 < π/2: cos > 0, tan finite.
    let (s, c) = sin_cos_rad(0.5 * w0);
    let k = s / c;
    let a = (1.0 - k) / (1.0 + k);
    // b = K/(1+K) = (1 − a)/2: taken from the rounded pole so the DC gain 2b/(1 − a) is 1.
    Ok((0.5 * (1.0 - a), a))
}

impl LowPass1 {
    /// A low-pass with its −3 dB point at `cutoff_hz`, run at `sample_hz`; the state starts at 0.
    pub fn new(cutoff_hz: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (b, a) = first_order_coefficients(cutoff_hz, sample_hz)?;
        Ok(Self {
            b,
            a,
            x1: 0.0,
            y1: 0.0,
        })
    }

    /// One sample.
    ///
    /// Timing: about 8 instructions on a Cortex-M4F (2 multiplies, 2 adds, loads/stores).
    #[inline]
    pub fn update(&mut self, x: f32) -> f32 {
        let y = self.b * (x + self.x1) + self.a * self.y1;
        self.x1 = x;
        self.y1 = y;
        y
    }

    /// Sets the state to the steady state of a constant input `value` (output = `value`).
    pub fn reset(&mut self, value: f32) {
        self.x1 = value;
        self.y1 = value;
    }

    /// The last output.
    pub fn output(&self) -> f32 {
        self.y1
    }
}

/// Second-order section, direct form II transposed:
/// y = b0·x + s1; s1 ← b1·x − a1·y + s2; s2 ← b2·x − a2·y (a0 normalised to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Biquad {
    b0: f32,
    b1: f32,
    b2: f32,
    a1: f32,
    a2: f32,
    s1: f32,
    s2: f32,
}

impl Biquad {
    /// y = x.
    pub const fn passthrough() -> Self {
        Self {
            b0: 1.0,
            b1: 0.0,
            b2: 0.0,
            a1: 0.0,
            a2: 0.0,
            s1: 0.0,
            s2: 0.0,
        }
    }

    /// From un-normalised coefficients `b0 b1 b2 / a0 a1 a2` (a0 > 0 for every design here).
    fn normalised(b: [f32; 3], a: [f32; 3]) -> Self {
        let inv_a0 = 1.0 / a[0];
        Self {
            b0: b[0] * inv_a0,
            b1: b[1] * inv_a0,
            b2: b[2] * inv_a0,
            a1: a[1] * inv_a0,
            a2: a[2] * inv_a0,
            s1: 0.0,
            s2: 0.0,
        }
    }

    /// The first-order low-pass of [`LowPass1`] as a section (b2 = a2 = 0), so that it can take
    /// a biquad's place in [`TorqueFilters`].
    pub fn first_order_low_pass(cutoff_hz: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (b, a) = first_order_coefficients(cutoff_hz, sample_hz)?;
        Ok(Self {
            b0: b,
            b1: b,
            a1: -a,
            ..Self::passthrough()
        })
    }

    /// Second-order low-pass (RBJ cookbook `LPF`): gain `q` at `cutoff_hz`, so Q = 1/√2 is the
    /// Butterworth response with −3.01 dB at the cut-off; Q above 1/√2 peaks.
    pub fn low_pass(cutoff_hz: f32, q: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let w0 = digital_angle(cutoff_hz, sample_hz)?;
        let q = positive(q)?;
        let (sin, cos) = sin_cos_rad(w0);
        let alpha = sin / (2.0 * q);
        let mut section = Self::normalised(
            [0.5 * (1.0 - cos), 1.0 - cos, 0.5 * (1.0 - cos)],
            [1.0 + alpha, -2.0 * cos, 1.0 - alpha],
        );
        // b0 : b1 : b2 = 1 : 2 : 1 and b0 + b1 + b2 = 1 + a1 + a2 analytically; derive the
        // numerator from the rounded denominator so the DC gain is 1 to the last bit even for
        // a cut-off far below the sample rate (where 1 + a1 + a2 is a small difference).
        let b0 = 0.25 * (1.0 + section.a1 + section.a2);
        section.b0 = b0;
        section.b1 = 2.0 * b0;
        section.b2 = b0;
        Ok(section)
    }

    /// Notch at `center_hz` whose gain at the centre is `depth` (0 = full notch, 1 = no
    /// attenuation). `bandwidth_hz` is the −3 dB width of the full notch's analog prototype
    /// (Q = center/bandwidth); the digital width is that, slightly narrowed by the frequency
    /// warping near Nyquist.
    pub fn notch(
        center_hz: f32,
        bandwidth_hz: f32,
        depth: f32,
        sample_hz: f32,
    ) -> Result<Self, FilterError> {
        let w0 = digital_angle(center_hz, sample_hz)?;
        let bandwidth = positive(bandwidth_hz)?;
        if !depth.is_finite() {
            return Err(FilterError::NotFinite);
        }
        if !(0.0..=1.0).contains(&depth) {
            return Err(FilterError::DepthOutOfRange);
        }
        let q = center_hz / bandwidth;
        let (sin, cos) = sin_cos_rad(w0);
        let alpha = sin / (2.0 * q);
        let inv_a0 = 1.0 / (1.0 + alpha);
        let mut section = Self::normalised(
            [1.0 + alpha * depth, -2.0 * cos, 1.0 - alpha * depth],
            [1.0 + alpha, -2.0 * cos, 1.0 - alpha],
        );
        // b1 = a1 and b0 + b2 = 1 + a2 (= 2/a0) analytically: taken from the rounded
        // denominator so the DC gain is exactly 1.
        let half_sum = 0.5 * (1.0 + section.a2);
        let half_difference = alpha * depth * inv_a0;
        section.b0 = half_sum + half_difference;
        section.b1 = section.a1;
        section.b2 = half_sum - half_difference;
        Ok(section)
    }

    /// The gain at DC, (b0 + b1 + b2) / (1 + a1 + a2) (1 for every design here, up to rounding).
    pub fn dc_gain(&self) -> f32 {
        let den = 1.0 + self.a1 + self.a2;
        if den == 0.0 {
            return 0.0;
        }
        (self.b0 + self.b1 + self.b2) / den
    }

    /// One sample.
    ///
    /// Timing: about 15 instructions on a Cortex-M4F (5 multiply(-accumulate)s, loads/stores).
    #[inline]
    pub fn update(&mut self, x: f32) -> f32 {
        let y = self.b0 * x + self.s1;
        self.s1 = self.b1 * x - self.a1 * y + self.s2;
        self.s2 = self.b2 * x - self.a2 * y;
        y
    }

    /// Sets the state to the steady state of a constant input `value` (output = DC gain ×
    /// `value`), so that switching a filter in does not kick the torque reference.
    pub fn reset(&mut self, value: f32) {
        let y = self.dc_gain() * value;
        self.s2 = self.b2 * value - self.a2 * y;
        self.s1 = self.b1 * value - self.a1 * y + self.s2;
    }
}

/// The low-pass stage of [`TorqueFilters`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LowPassConfig {
    /// No low-pass.
    #[default]
    Off,
    /// First order, −3 dB at `cutoff_hz`.
    FirstOrder {
        /// Cut-off (−3 dB), Hz.
        cutoff_hz: f32,
    },
    /// Second order with quality factor `q` (1/√2: Butterworth, −3 dB at `cutoff_hz`).
    SecondOrder {
        /// Cut-off, Hz.
        cutoff_hz: f32,
        /// Quality factor (gain at the cut-off).
        q: f32,
    },
}

/// One notch of [`TorqueFilters`], see [`Biquad::notch`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotchConfig {
    /// Centre frequency, Hz.
    pub center_hz: f32,
    /// −3 dB bandwidth of the full notch, Hz.
    pub bandwidth_hz: f32,
    /// Linear gain at the centre, `0.0..=1.0` (0 = full notch).
    pub depth: f32,
}

/// The torque-reference filter chain: an optional low-pass, then up to two optional notches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TorqueFilterConfig {
    /// The low-pass stage.
    pub low_pass: LowPassConfig,
    /// The notches (`None` = off).
    pub notches: [Option<NotchConfig>; MAX_NOTCHES],
}

impl TorqueFilterConfig {
    /// Every stage off: the chain passes the torque reference through unchanged.
    pub const OFF: Self = Self {
        low_pass: LowPassConfig::Off,
        notches: [None; MAX_NOTCHES],
    };
}

/// Number of notches in the chain.
pub const MAX_NOTCHES: usize = 2;
/// Number of sections in the chain: the low-pass and the notches.
const MAX_STAGES: usize = 1 + MAX_NOTCHES;

/// The designed chain: the enabled sections packed at the front, the rest unused, so a chain
/// with everything off costs a loop test and nothing else.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueFilters {
    stages: [Biquad; MAX_STAGES],
    active: usize,
}

impl Default for TorqueFilters {
    fn default() -> Self {
        Self::passthrough()
    }
}

impl TorqueFilters {
    /// The chain with every stage off.
    pub const fn passthrough() -> Self {
        Self {
            stages: [Biquad::passthrough(); MAX_STAGES],
            active: 0,
        }
    }

    /// Designs the chain of `config` for `sample_hz`.
    pub fn new(config: &TorqueFilterConfig, sample_hz: f32) -> Result<Self, FilterError> {
        let mut chain = Self::passthrough();
        let low_pass = match config.low_pass {
            LowPassConfig::Off => None,
            LowPassConfig::FirstOrder { cutoff_hz } => {
                Some(Biquad::first_order_low_pass(cutoff_hz, sample_hz)?)
            }
            LowPassConfig::SecondOrder { cutoff_hz, q } => {
                Some(Biquad::low_pass(cutoff_hz, q, sample_hz)?)
            }
        };
        let mut sections = [None; MAX_STAGES];
        sections[0] = low_pass;
        for (slot, notch) in sections[1..].iter_mut().zip(config.notches.iter()) {
            if let Some(n) = notch {
                *slot = Some(Biquad::notch(
                    n.center_hz,
                    n.bandwidth_hz,
                    n.depth,
                    sample_hz,
                )?);
            }
        }
        for section in sections.into_iter().flatten() {
            if let Some(stage) = chain.stages.get_mut(chain.active) {
                *stage = section;
                // Below the stage count: `get_mut` found the stage.
                chain.active = chain.active.saturating_add(1);
            }
        }
        Ok(chain)
    }

    /// How many sections are enabled.
    pub fn active_stages(&self) -> usize {
        self.active
    }

    /// One sample through the enabled sections.
    ///
    /// Timing: about 5 instructions plus about 20 per enabled section (≤ 65 with all three on).
    #[inline]
    pub fn update(&mut self, x: f32) -> f32 {
        let mut y = x;
        for stage in self.stages.iter_mut().take(self.active) {
            y = stage.update(y);
        }
        y
    }

    /// Sets every section to the steady state of a constant input `value`.
    pub fn reset(&mut self, value: f32) {
        for stage in self.stages.iter_mut() {
            stage.reset(value);
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    const FS: f32 = 10_000.0;

    /// Amplitude gain of `filter` for a unit sine at `freq`: `settle` samples are dropped, then
    /// the output over `measure` samples is least-squares fitted with a·sin + b·cos (exact for a
    /// settled sinusoid, whatever the window length).
    fn gain(mut filter: impl FnMut(f32) -> f32, freq: f64, fs: f64) -> f64 {
        let settle = 40_000;
        let measure = 20_000;
        let w = std::f64::consts::TAU * freq / fs;
        let (mut sss, mut scc, mut ssc, mut sys, mut syc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..settle + measure {
            let phase = w * k as f64;
            let y = filter(phase.sin() as f32) as f64;
            if k >= settle {
                let (s, c) = (phase.sin(), phase.cos());
                sss += s * s;
                scc += c * c;
                ssc += s * c;
                sys += y * s;
                syc += y * c;
            }
        }
        let det = sss * scc - ssc * ssc;
        let a = (sys * scc - syc * ssc) / det;
        let b = (syc * sss - sys * ssc) / det;
        (a * a + b * b).sqrt()
    }

    /// The settled response to a unit step (a long run: the slowest pole here is at 10 Hz).
    fn dc_gain(mut section: Biquad) -> f64 {
        let mut y = 0.0;
        for _ in 0..200_000 {
            y = section.update(1.0);
        }
        y as f64
    }

    fn db(g: f64) -> f64 {
        20.0 * g.log10()
    }

    /// The −3 dB point of a first-order or Butterworth low-pass: 20·log10(1/√2).
    const MINUS_3DB: f64 = -3.010_299_956_639_812;

    #[test]
    fn first_order_low_pass_is_3db_down_at_the_cutoff_and_unity_at_dc() {
        for fc in [10.0f32, 200.0, 1_000.0, 4_000.0] {
            let mut lp = LowPass1::new(fc, FS).unwrap();
            let g = db(gain(|x| lp.update(x), fc as f64, FS as f64));
            assert!((g - MINUS_3DB).abs() < 0.1, "fc {fc}: {g} dB");
            let mut lp = LowPass1::new(fc, FS).unwrap();
            let mut y = 0.0;
            for _ in 0..200_000 {
                y = lp.update(1.0);
            }
            assert!((y - 1.0).abs() < 1e-5, "DC gain {y}");
        }
    }

    #[test]
    fn first_order_section_matches_the_dedicated_filter() {
        let mut lp = LowPass1::new(300.0, FS).unwrap();
        let mut bq = Biquad::first_order_low_pass(300.0, FS).unwrap();
        for k in 0..1_000 {
            let x = ((k * 37) % 101) as f32 - 50.0;
            assert!((lp.update(x) - bq.update(x)).abs() < 1e-4);
        }
    }

    #[test]
    fn butterworth_biquad_is_3db_down_at_the_cutoff_and_rolls_off_at_40db_per_decade() {
        let q = core::f32::consts::FRAC_1_SQRT_2;
        for fc in [50.0f32, 500.0, 2_000.0] {
            let mut lp = Biquad::low_pass(fc, q, FS).unwrap();
            let g = db(gain(|x| lp.update(x), fc as f64, FS as f64));
            assert!((g - MINUS_3DB).abs() < 0.1, "fc {fc}: {g} dB");
            assert!((dc_gain(Biquad::low_pass(fc, q, FS).unwrap()) - 1.0).abs() < 1e-4);
        }
        // One decade above a 100 Hz Butterworth cut-off: the analog prototype gives
        // 1/√(1 + 10⁴) (−40.0 dB); the warping at 1 kHz / 10 kHz adds attenuation, never less.
        let mut lp = Biquad::low_pass(100.0, q, FS).unwrap();
        let g = db(gain(|x| lp.update(x), 1_000.0, FS as f64));
        assert!(g < -40.0 + 0.1, "{g} dB");
    }

    #[test]
    fn notch_depth_at_the_centre_and_unity_far_away() {
        let f0 = 800.0f32;
        for depth in [0.0f32, 0.1, 0.5, 0.9] {
            let mut n = Biquad::notch(f0, 100.0, depth, FS).unwrap();
            let g = gain(|x| n.update(x), f0 as f64, FS as f64);
            // ±1 % of the depth, and at least ±1e-3 absolute for the full notch.
            let tol = (0.01 * depth as f64).max(1e-3);
            assert!((g - depth as f64).abs() < tol, "depth {depth}: {g}");
            for far in [f0 as f64 / 10.0, f0 as f64 * 5.0] {
                let mut n = Biquad::notch(f0, 100.0, depth, FS).unwrap();
                let g = db(gain(|x| n.update(x), far, FS as f64));
                assert!(g.abs() < 0.05, "depth {depth} at {far} Hz: {g} dB");
            }
            assert!((dc_gain(Biquad::notch(f0, 100.0, depth, FS).unwrap()) - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn notch_bandwidth_is_the_3db_width() {
        // Full notch, Q = 2: the analog −3 dB edges are at Ω = √(1 + 1/(4Q²)) ± 1/(2Q) (in units
        // of the centre); mapped through the bilinear prewarp back to Hz they lie at f where
        // tan(πf/fs) = Ω·tan(πf0/fs).
        let (f0, bw) = (1_000.0f64, 500.0f64);
        let q = f0 / bw;
        let fs = FS as f64;
        let k0 = (std::f64::consts::PI * f0 / fs).tan();
        for omega in [
            (1.0 + 1.0 / (4.0 * q * q)).sqrt() + 1.0 / (2.0 * q),
            (1.0 + 1.0 / (4.0 * q * q)).sqrt() - 1.0 / (2.0 * q),
        ] {
            let f = (omega * k0).atan() * fs / std::f64::consts::PI;
            let mut n = Biquad::notch(f0 as f32, bw as f32, 0.0, FS).unwrap();
            let g = db(gain(|x| n.update(x), f, fs));
            assert!((g - MINUS_3DB).abs() < 0.1, "edge {f} Hz: {g} dB");
        }
    }

    #[test]
    fn chain_multiplies_the_stage_gains_and_passthrough_is_identity() {
        let cfg = TorqueFilterConfig {
            low_pass: LowPassConfig::FirstOrder { cutoff_hz: 2_000.0 },
            notches: [
                Some(NotchConfig {
                    center_hz: 500.0,
                    bandwidth_hz: 100.0,
                    depth: 0.2,
                }),
                None,
            ],
        };
        let mut chain = TorqueFilters::new(&cfg, FS).unwrap();
        assert_eq!(chain.active_stages(), 2);
        let g = gain(|x| chain.update(x), 500.0, FS as f64);
        let mut lp = LowPass1::new(2_000.0, FS).unwrap();
        let g_lp = gain(|x| lp.update(x), 500.0, FS as f64);
        assert!(
            (g - 0.2 * g_lp).abs() < 0.01 * 0.2 * g_lp,
            "{g} vs {}",
            0.2 * g_lp
        );

        let mut off = TorqueFilters::new(&TorqueFilterConfig::OFF, FS).unwrap();
        assert_eq!(off.active_stages(), 0);
        for x in [1.0f32, -3.5, 1e6] {
            assert_eq!(off.update(x), x);
        }
    }

    #[test]
    fn reset_starts_in_the_steady_state() {
        let mut n = Biquad::notch(300.0, 50.0, 0.0, FS).unwrap();
        n.reset(2.5);
        for _ in 0..100 {
            assert!((n.update(2.5) - 2.5).abs() < 1e-4);
        }
        let mut lp = Biquad::low_pass(300.0, 0.7, FS).unwrap();
        lp.reset(-1.0);
        assert!((lp.update(-1.0) + 1.0).abs() < 1e-5);
    }

    #[test]
    fn invalid_designs_are_rejected() {
        use FilterError::*;
        assert_eq!(LowPass1::new(5_000.0, FS), Err(AboveNyquist));
        assert_eq!(LowPass1::new(0.0, FS), Err(NotPositive));
        assert_eq!(LowPass1::new(-1.0, FS), Err(NotPositive));
        assert_eq!(LowPass1::new(f32::NAN, FS), Err(NotFinite));
        assert_eq!(LowPass1::new(100.0, f32::INFINITY), Err(NotFinite));
        assert_eq!(Biquad::low_pass(100.0, 0.0, FS), Err(NotPositive));
        assert_eq!(Biquad::notch(100.0, 10.0, 1.5, FS), Err(DepthOutOfRange));
        assert_eq!(Biquad::notch(100.0, 10.0, f32::NAN, FS), Err(NotFinite));
        assert_eq!(Biquad::notch(100.0, -10.0, 0.0, FS), Err(NotPositive));
        let bad = TorqueFilterConfig {
            notches: [
                None,
                Some(NotchConfig {
                    center_hz: 6_000.0,
                    bandwidth_hz: 10.0,
                    depth: 0.0,
                }),
            ],
            ..TorqueFilterConfig::OFF
        };
        assert_eq!(TorqueFilters::new(&bad, FS), Err(AboveNyquist));
    }
}
