//! Protections of one axis: each turns measurements into a [`MotorFault`].
//!
//! | protection | trips when | confirmation | fault |
//! |---|---|---|---|
//! | over-current | any \|phase current\| > `over_current_a` | none: that very sample | [`MotorFault::OverCurrent`] |
//! | motor / drive I²t | ∫(i² − I_c²)dt (floored at 0) ≥ (I_p² − I_c²)·t_p | the integral is the time | [`MotorFault::MotorOverload`], [`MotorFault::DriveOverload`] |
//! | bus over-voltage | U_bus > `bus_over_voltage_v` (always armed) | `bus_confirm_s` | [`MotorFault::BusOverVoltage`] |
//! | bus under-voltage | U_bus < `bus_under_voltage_v`, only while enabled | `bus_confirm_s` | [`MotorFault::BusUnderVoltage`] |
//! | over-speed | \|velocity\| > `over_speed` | `over_speed_confirm_s` | [`MotorFault::OverSpeed`] |
//! | encoder signal loss | [`EncoderFault::SignalLoss`] | none | [`MotorFault::EncoderSignalLoss`] |
//! | encoder CRC | error counter (+`encoder_crc_weight` per bad frame, −1 per good one) ≥ `encoder_crc_trip` | the counter | [`MotorFault::EncoderCrc`] |
//! | encoder jump | \|Δposition\| > `over_speed`·T_s·`encoder_jump_margin` per sample, or [`EncoderFault::ImplausibleJump`] | none | [`MotorFault::EncoderJump`] |
//! | drive over-temperature | T > `drive_over_temperature_c` | `drive_temperature_confirm_s` | [`MotorFault::DriveOverTemperature`] |
//! | motor over-temperature | thermal-switch input active | `motor_over_temperature_confirm_s` | [`MotorFault::MotorOverTemperature`] |
//! | following error | \|error\| > window (6065h) for longer than the timeout (6066h), while enabled | the timeout | [`MotorFault::FollowingError`] |
//!
//! All comparisons are strict: a value exactly at its level does not trip. A NaN measurement
//! counts as out of range (fail-safe): a broken measurement chain must stop the motor.
//!
//! # Use
//! [`Protections::check_over_current`] runs first thing every PWM period (the control interrupt
//! turns the gates off in that same period and latches the fault itself; the check is a pure
//! function of the three currents). [`Protections::check`] runs once per loop sample (the
//! `sample_time_s` given to [`Protections::new`]) with everything else ([`ProtectionInputs`]).
//!
//! # Priority
//! All protections are evaluated on every [`Protections::check`] (so that every counter and
//! integral advances), and when several trip in the same sample the first of this list is
//! returned, causes before their consequences: a collapsed or overshooting supply and a broken
//! position measurement make the speed, current and following-error readings meaningless;
//! over-speed comes before the overloads, the overloads (the drive's first: its thermal time
//! constant is the shorter) before the temperatures they lead to, and the following error last,
//! because almost every other fault also produces one.
//!
//! 1. [`MotorFault::BusOverVoltage`]
//! 2. [`MotorFault::BusUnderVoltage`]
//! 3. [`MotorFault::EncoderSignalLoss`]
//! 4. [`MotorFault::EncoderJump`]
//! 5. [`MotorFault::EncoderCrc`]
//! 6. [`MotorFault::OverSpeed`]
//! 7. [`MotorFault::DriveOverload`]
//! 8. [`MotorFault::MotorOverload`]
//! 9. [`MotorFault::DriveOverTemperature`]
//! 10. [`MotorFault::MotorOverTemperature`]
//! 11. [`MotorFault::FollowingError`]
//!
//! # Latching and reset
//! The first fault [`Protections::check`] reports is latched and returned by every later call
//! until [`Protections::reset`], with one exception: a fault that allows a controlled stop
//! (7–11 above: [`MotorFault::allows_controlled_stop`]; the motor runs on for the drive's
//! fault reaction) is replaced by a later one that does not (1–6: the encoder lost during the
//! reaction's ramp must cut the gates). The reset clears the latch, the confirmation counters, the CRC
//! counter, the following-error timer and the encoder-jump reference, but **not** the I²t
//! integrals: they model heat, which a fault reset does not remove (a reset right after an
//! overload trip leaves little margin, and [`Protections::current_limit`] shows it).
//!
//! # Encoder CRC errors
//! A frame that failed its CRC carries no usable position: the caller holds the previous good
//! position for that sample (and does not feed a velocity estimator a jump). The jump check then
//! compares the next good position with the last good one and allows one sample's worth of
//! movement per sample elapsed.

use hal::encoder::EncoderFault;

use super::math::{max, min};
use super::MotorFault;

/// 6065h value that switches the following-error check off (CiA402).
pub const FOLLOWING_ERROR_WINDOW_OFF: u32 = u32::MAX;

/// The smallest I_p² − I_c² an I²t model uses, A²: a configuration with I_p ≤ I_c (no overload
/// allowed) trips almost at once above I_c instead of dividing by zero.
const MIN_PEAK_MARGIN_A2: f32 = 1.0e-6;

/// The load at which the I²t foldback limit reaches I_c. Below 1 on purpose: at I_c the load
/// stops rising, so a drive that follows the limit settles here; were it 1, the load would creep
/// towards the trip level and the last rounding would trip it.
pub const FOLDBACK_FULL_LOAD: f32 = 0.95;

/// Milliseconds per second (6066h is in ms).
const MS_PER_S: f32 = 1_000.0;

/// Rounding offset for the float → integer conversions of the constructor (`as` truncates).
const ROUND_HALF: f32 = 0.5;

/// One I²t (thermal overload) model: continuous current I_c, peak current I_p, and the time t_p
/// the peak may be held from cold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct I2tConfig {
    /// Continuous (rated) current I_c, A (current-vector magnitude = phase amplitude).
    pub continuous_a: f32,
    /// Peak current I_p, A (> I_c).
    pub peak_a: f32,
    /// How long I_p may flow from cold before the model trips, s.
    pub peak_time_s: f32,
    /// Load (fraction of the trip level, 0..=1) above which [`I2t::current_limit`] ramps down
    /// linearly from I_p (at this load) to I_c (at [`FOLDBACK_FULL_LOAD`]), so that a drive which
    /// respects the limit derates to its continuous current instead of tripping. At or above
    /// [`FOLDBACK_FULL_LOAD`] (e.g. 1.0): no foldback, the limit stays at I_p.
    pub foldback_start: f32,
}

/// Trip levels of the protections of one axis, in physical units.
///
/// [`Default`]: a 400 W servo on a 230 V AC mains (325 V DC bus): motor 2.7 A rms rated /
/// 8.1 A rms peak, drive 3 A rms continuous / 9 A rms peak, a 17-bit (131 072 increments per
/// revolution) encoder and 5000 rpm maximum speed. Currents are amplitudes (rms × √2), because
/// the current-vector magnitude of the amplitude-invariant Park transform is the phase amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProtectionConfig {
    /// Instantaneous phase-current trip level, A (magnitude of any one phase).
    pub over_current_a: f32,
    /// The motor's thermal model.
    pub motor_i2t: I2tConfig,
    /// The drive's (power stage) thermal model.
    pub drive_i2t: I2tConfig,
    /// DC-bus over-voltage trip level, V (always armed).
    pub bus_over_voltage_v: f32,
    /// DC-bus under-voltage trip level, V (armed only while the drive is enabled: a drive
    /// waiting for its bus must not fault).
    pub bus_under_voltage_v: f32,
    /// How long a bus voltage must stay beyond a level before it trips, s (rounded to whole
    /// samples, at least one).
    pub bus_confirm_s: f32,
    /// Over-speed trip level, increments/s (magnitude).
    pub over_speed: f32,
    /// How long the speed must stay above the level before it trips, s.
    pub over_speed_confirm_s: f32,
    /// Added to the encoder error counter per frame that failed its CRC (one is subtracted per
    /// good frame): a steady fraction of bad frames above 1/(weight + 1) trips.
    pub encoder_crc_weight: u16,
    /// Encoder error counter level that trips [`MotorFault::EncoderCrc`].
    pub encoder_crc_trip: u16,
    /// Factor on the largest distance the motor can move in one sample at the over-speed level;
    /// a larger position step is an encoder fault (≥ 1).
    pub encoder_jump_margin: f32,
    /// Power-stage over-temperature trip level, °C.
    pub drive_over_temperature_c: f32,
    /// How long the power-stage temperature must stay above the level before it trips, s.
    pub drive_temperature_confirm_s: f32,
    /// How long the motor's thermal-switch input must stay active before it trips, s.
    pub motor_over_temperature_confirm_s: f32,
    /// Following-error window, increments (6065h); [`FOLLOWING_ERROR_WINDOW_OFF`] switches the
    /// check off.
    pub following_error_window: u32,
    /// Following-error timeout, ms (6066h).
    pub following_error_timeout_ms: u16,
}

impl Default for ProtectionConfig {
    fn default() -> Self {
        Self {
            // Above the drive's 12.7 A peak with room for PWM ripple and current-loop overshoot,
            // below the pulse rating of a 400 W power module.
            over_current_a: 18.0,
            // 2.7 A rms / 8.1 A rms; 3 s at peak is a typical data-sheet overload figure.
            motor_i2t: I2tConfig {
                continuous_a: 3.8,
                peak_a: 11.5,
                peak_time_s: 3.0,
                foldback_start: 0.8,
            },
            // 3 A rms / 9 A rms; the power stage heats faster than the motor.
            drive_i2t: I2tConfig {
                continuous_a: 4.2,
                peak_a: 12.7,
                peak_time_s: 2.0,
                foldback_start: 0.8,
            },
            // 325 V nominal: above the brake-chopper threshold (~390 V), below the 450 V of the
            // DC-link capacitors.
            bus_over_voltage_v: 410.0,
            // Well below the 325 V nominal and its mains sag under load.
            bus_under_voltage_v: 200.0,
            bus_confirm_s: 0.001,
            // 6000 rpm = 5000 rpm maximum + 20 %, with 2^17 increments per revolution.
            over_speed: 6_000.0 / 60.0 * 131_072.0,
            over_speed_confirm_s: 0.001,
            // Ten bad frames in a row trip; fewer than one bad frame in eleven never does.
            encoder_crc_weight: 10,
            encoder_crc_trip: 100,
            encoder_jump_margin: 2.0,
            // Heat-sink sensor of the power stage.
            drive_over_temperature_c: 90.0,
            // Temperatures change slowly: a long confirmation filters ADC noise.
            drive_temperature_confirm_s: 0.1,
            // Debounces EMI picked up by the thermal-switch wires in the motor cable.
            motor_over_temperature_confirm_s: 0.01,
            // A quarter revolution for 20 ms.
            following_error_window: 32_768,
            following_error_timeout_ms: 20,
        }
    }
}

/// What [`Protections::check`] looks at, once per loop sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProtectionInputs {
    /// d current, A.
    pub id: f32,
    /// q current, A.
    pub iq: f32,
    /// DC-bus voltage, V.
    pub bus_voltage: f32,
    /// Velocity, increments/s.
    pub velocity: f32,
    /// This sample's encoder reading.
    pub encoder: Result<i64, EncoderFault>,
    /// Power-stage temperature, °C.
    pub temperature: f32,
    /// The motor's over-temperature (thermal-switch) input is active.
    pub motor_overtemp: bool,
    /// Position following error (demand − actual), increments.
    pub following_error: i64,
    /// The power stage is enabled (arms the under-voltage and following-error checks).
    pub enabled: bool,
}

/// Whether any of the three phase currents has a magnitude above `limit` (or is NaN).
///
/// Timing: three absolute values and three compares, combined without branches.
#[inline]
pub fn phase_current_exceeds(ia: f32, ib: f32, ic: f32, limit: f32) -> bool {
    // `<=` is false for NaN, so a NaN current counts as an over-current. `&` instead of `&&`:
    // no branch per phase.
    let within = (ia.abs() <= limit) & (ib.abs() <= limit) & (ic.abs() <= limit);
    !within
}

/// `x > level`, or `x` is NaN (a broken measurement counts as out of range).
#[inline]
fn above(x: f32, level: f32) -> bool {
    (x > level) | x.is_nan()
}

/// `x < level`, or `x` is NaN.
#[inline]
fn below(x: f32, level: f32) -> bool {
    (x < level) | x.is_nan()
}

/// `time_s` in whole samples of `sample_time_s`, rounded, at least one (a non-finite or
/// non-positive quotient gives one sample). Not for the control interrupt (divides).
pub fn confirmation_samples(time_s: f32, sample_time_s: f32) -> u16 {
    // `as` saturates (and maps NaN to 0).
    let n = (time_s / sample_time_s + ROUND_HALF) as u16;
    if n == 0 {
        1
    } else {
        n
    }
}

/// The largest plausible encoder step in one sample, increments: the distance covered in one
/// sample at the over-speed level times `margin`, at least one increment.
pub fn max_increments_per_sample(over_speed: f32, sample_time_s: f32, margin: f32) -> u64 {
    let n = (over_speed.abs() * sample_time_s * margin) as u64;
    if n == 0 {
        1
    } else {
        n
    }
}

/// A condition that must hold for a number of consecutive samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Confirmation {
    count: u16,
    needed: u16,
}

impl Confirmation {
    /// A condition confirmed after `samples` consecutive samples (0 counts as 1).
    pub const fn new(samples: u16) -> Self {
        Self {
            count: 0,
            needed: if samples == 0 { 1 } else { samples },
        }
    }

    /// Feeds one sample; `true` once the condition held for the needed consecutive samples.
    /// A sample without the condition restarts the count.
    #[inline]
    pub fn update(&mut self, condition: bool) -> bool {
        self.count = if condition {
            self.count.saturating_add(1)
        } else {
            0
        };
        self.count >= self.needed
    }

    /// Forgets the samples seen so far.
    pub fn reset(&mut self) {
        self.count = 0;
    }
}

/// One I²t model. The state is the integral x = ∫(i² − I_c²)dt floored at 0, kept normalised to
/// "samples at peak current": y = x / ((I_p² − I_c²)·T_s), so that one sample at I_p adds 1 and
/// the trip level is t_p / T_s samples. The sum is compensated (Kahan): a plain `f32` sum of tens
/// of thousands of steps drifts by several samples (at 2·I_c, 10 samples early after 32 000).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct I2t {
    /// y (see the type docs), 0..=`trip`.
    level: f32,
    /// The rounding error of `level` not yet added (Kahan compensation).
    carry: f32,
    /// 1 / (I_p² − I_c²), 1/A².
    per_a2: f32,
    /// I_c² / (I_p² − I_c²): what one sample removes.
    continuous: f32,
    /// Trip level: t_p / T_s samples (at least one).
    trip: f32,
    /// 1 / `trip`.
    inv_trip: f32,
    /// I_p, A.
    peak_a: f32,
    /// I_c, A.
    continuous_a: f32,
    /// Load at which the foldback starts (0..`FOLDBACK_FULL_LOAD`; 1: none).
    foldback_start: f32,
    /// (I_p − I_c) / (`FOLDBACK_FULL_LOAD` − foldback_start), A per unit of load; 0 without
    /// foldback.
    foldback_slope: f32,
}

impl I2t {
    /// A cold model (load 0) for samples `sample_time_s` apart.
    pub fn new(cfg: &I2tConfig, sample_time_s: f32) -> Self {
        let ic_sq = cfg.continuous_a * cfg.continuous_a;
        let margin = cfg.peak_a * cfg.peak_a - ic_sq;
        // `>` is false for NaN: a NaN configuration also takes the floor.
        let margin = if margin > MIN_PEAK_MARGIN_A2 {
            margin
        } else {
            MIN_PEAK_MARGIN_A2
        };
        let per_a2 = 1.0 / margin;
        let trip = cfg.peak_time_s / sample_time_s;
        let trip = if trip >= 1.0 { trip } else { 1.0 };
        let start = cfg.foldback_start;
        let start = if start > 0.0 { start } else { 0.0 };
        let (foldback_start, foldback_slope) = if start < FOLDBACK_FULL_LOAD {
            (
                start,
                (cfg.peak_a - cfg.continuous_a) / (FOLDBACK_FULL_LOAD - start),
            )
        } else {
            // Off (also for NaN, which the `>` above turned into 0: on from no load).
            (1.0, 0.0)
        };
        Self {
            level: 0.0,
            carry: 0.0,
            per_a2,
            // The same product `update` forms for a current of exactly I_c, so that the
            // increment at I_c is exactly zero.
            continuous: ic_sq * per_a2,
            trip,
            inv_trip: 1.0 / trip,
            peak_a: cfg.peak_a,
            continuous_a: cfg.continuous_a,
            foldback_start,
            foldback_slope,
        }
    }

    /// Integrates one sample with the squared current-vector magnitude `current_sq` (A²,
    /// id² + iq²); `true` when the model is at its trip level. A NaN current leaves the state
    /// unchanged (the over-current check trips on it).
    ///
    /// Timing: control interrupt, once per sample; six `f32` additions/multiplications and
    /// three compares.
    #[inline]
    pub fn update(&mut self, current_sq: f32) -> bool {
        let step = current_sq * self.per_a2 - self.continuous;
        // Kahan summation: `carry` is what the previous addition rounded away.
        let compensated = step - self.carry;
        let sum = self.level + compensated;
        let carry = (sum - self.level) - compensated;
        if sum < 0.0 {
            self.level = 0.0;
            self.carry = 0.0;
        } else if sum >= self.trip {
            // Saturate at the trip level so that the cooling time after a trip stays bounded.
            self.level = self.trip;
            self.carry = 0.0;
        } else if sum >= 0.0 {
            self.level = sum;
            self.carry = carry;
        }
        self.level >= self.trip
    }

    /// Fraction of the trip level, 0..=1 (for display).
    #[inline]
    pub fn load(&self) -> f32 {
        min(self.level * self.inv_trip, 1.0)
    }

    /// The current the drive may allow now, A: I_p up to the foldback start, then linearly
    /// down to I_c at [`FOLDBACK_FULL_LOAD`] and above (I_p throughout without foldback).
    #[inline]
    pub fn current_limit(&self) -> f32 {
        let over = max(self.load() - self.foldback_start, 0.0);
        max(self.peak_a - self.foldback_slope * over, self.continuous_a)
    }

    /// Starts from cold (power-up or a test; a fault reset keeps the heat).
    pub fn clear(&mut self) {
        self.level = 0.0;
        self.carry = 0.0;
    }
}

/// The encoder checks: signal loss, CRC error counter, implausible jumps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderMonitor {
    crc_errors: u16,
    crc_weight: u16,
    crc_trip: u16,
    /// Last good position (None: no reference yet).
    last: Option<i64>,
    /// Largest plausible step from `last` to the next good position: `max_step` per sample
    /// since `last` was read.
    allowed: u64,
    /// Largest plausible step per sample, increments.
    max_step: u64,
}

impl EncoderMonitor {
    /// CRC counter weight and trip level (0 counts as 1), largest plausible step per sample.
    pub fn new(crc_weight: u16, crc_trip: u16, max_step: u64) -> Self {
        Self {
            crc_errors: 0,
            crc_weight: if crc_weight == 0 { 1 } else { crc_weight },
            crc_trip: if crc_trip == 0 { 1 } else { crc_trip },
            last: None,
            allowed: max_step,
            max_step,
        }
    }

    /// Checks one sample's reading.
    ///
    /// Timing: control interrupt, once per sample; a few 64-bit integer additions and compares.
    pub fn update(&mut self, reading: Result<i64, EncoderFault>) -> Option<MotorFault> {
        match reading {
            Err(EncoderFault::SignalLoss) => Some(MotorFault::EncoderSignalLoss),
            Err(EncoderFault::ImplausibleJump) => Some(MotorFault::EncoderJump),
            Err(EncoderFault::Crc) => {
                self.crc_errors = self.crc_errors.saturating_add(self.crc_weight);
                self.allowed = self.allowed.saturating_add(self.max_step);
                (self.crc_errors >= self.crc_trip).then_some(MotorFault::EncoderCrc)
            }
            Ok(position) => {
                self.crc_errors = self.crc_errors.saturating_sub(1);
                let allowed = self.allowed;
                // Wrapping: a multi-turn counter that wraps at the i64 range moved by the short
                // way round.
                let jumped = self
                    .last
                    .is_some_and(|last| position.wrapping_sub(last).unsigned_abs() > allowed);
                self.last = Some(position);
                self.allowed = self.max_step;
                jumped.then_some(MotorFault::EncoderJump)
            }
        }
    }

    /// The CRC error counter.
    pub fn crc_errors(&self) -> u16 {
        self.crc_errors
    }

    /// Clears the counter and the jump reference (the next good position becomes it).
    pub fn reset(&mut self) {
        self.crc_errors = 0;
        self.last = None;
        self.allowed = self.max_step;
    }
}

/// The following-error check with CiA402 6065h/6066h semantics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FollowingErrorMonitor {
    window: u32,
    /// The timeout in samples: the error may be above the window for this many samples.
    timeout_samples: u32,
    samples_per_ms: f32,
    /// Consecutive samples above the window.
    above: u32,
}

impl FollowingErrorMonitor {
    /// Window (6065h, increments) and timeout (6066h, ms) for samples `sample_time_s` apart.
    pub fn new(window: u32, timeout_ms: u16, sample_time_s: f32) -> Self {
        let mut m = Self {
            window,
            timeout_samples: 0,
            samples_per_ms: 1.0 / (sample_time_s * MS_PER_S),
            above: 0,
        };
        m.set_limits(window, timeout_ms);
        m
    }

    /// New 6065h/6066h values (an SDO or PDO write); no division.
    pub fn set_limits(&mut self, window: u32, timeout_ms: u16) {
        self.window = window;
        self.timeout_samples = (f32::from(timeout_ms) * self.samples_per_ms + ROUND_HALF) as u32;
    }

    /// Checks one sample: `true` when |error| has been above the window for longer than the
    /// timeout, i.e. for more than `timeout / T_s` consecutive samples (timeout 0: the first
    /// sample above). Only armed while `enabled`; disabled, the timer restarts.
    ///
    /// Timing: control interrupt, once per sample; integer compares.
    pub fn update(&mut self, error: i64, enabled: bool) -> bool {
        let armed = enabled && self.window != FOLLOWING_ERROR_WINDOW_OFF;
        if armed && error.unsigned_abs() > u64::from(self.window) {
            self.above = self.above.saturating_add(1);
        } else {
            self.above = 0;
        }
        self.above > self.timeout_samples
    }

    /// Restarts the timer.
    pub fn reset(&mut self) {
        self.above = 0;
    }
}

/// The protections of one axis, with every limit precomputed for its sample time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Protections {
    over_current_a: f32,
    motor_i2t: I2t,
    drive_i2t: I2t,
    bus_over_voltage_v: f32,
    bus_under_voltage_v: f32,
    bus_over: Confirmation,
    bus_under: Confirmation,
    over_speed: f32,
    over_speed_confirm: Confirmation,
    encoder: EncoderMonitor,
    drive_over_temperature_c: f32,
    drive_temperature: Confirmation,
    motor_temperature: Confirmation,
    following_error: FollowingErrorMonitor,
    latched: Option<MotorFault>,
}

impl Protections {
    /// The protections for `check` calls `sample_time_s` apart (> 0): times become sample
    /// counts, the I²t levels are normalised, the encoder step limit is derived from the
    /// over-speed level. Both thermal models start cold.
    pub fn new(cfg: &ProtectionConfig, sample_time_s: f32) -> Self {
        let dt = sample_time_s;
        let bus = confirmation_samples(cfg.bus_confirm_s, dt);
        Self {
            over_current_a: cfg.over_current_a,
            motor_i2t: I2t::new(&cfg.motor_i2t, dt),
            drive_i2t: I2t::new(&cfg.drive_i2t, dt),
            bus_over_voltage_v: cfg.bus_over_voltage_v,
            bus_under_voltage_v: cfg.bus_under_voltage_v,
            bus_over: Confirmation::new(bus),
            bus_under: Confirmation::new(bus),
            over_speed: cfg.over_speed,
            over_speed_confirm: Confirmation::new(confirmation_samples(
                cfg.over_speed_confirm_s,
                dt,
            )),
            encoder: EncoderMonitor::new(
                cfg.encoder_crc_weight,
                cfg.encoder_crc_trip,
                max_increments_per_sample(cfg.over_speed, dt, cfg.encoder_jump_margin),
            ),
            drive_over_temperature_c: cfg.drive_over_temperature_c,
            drive_temperature: Confirmation::new(confirmation_samples(
                cfg.drive_temperature_confirm_s,
                dt,
            )),
            motor_temperature: Confirmation::new(confirmation_samples(
                cfg.motor_over_temperature_confirm_s,
                dt,
            )),
            following_error: FollowingErrorMonitor::new(
                cfg.following_error_window,
                cfg.following_error_timeout_ms,
                dt,
            ),
            latched: None,
        }
    }

    /// `Some(OverCurrent)` when any phase current's magnitude is above the trip level (or NaN).
    /// Pure: the caller turns the gates off and latches the fault.
    ///
    /// Timing: first thing in the control interrupt, every PWM period; three absolute values,
    /// three compares, one branch.
    #[inline]
    pub fn check_over_current(&self, ia: f32, ib: f32, ic: f32) -> Option<MotorFault> {
        phase_current_exceeds(ia, ib, ic, self.over_current_a).then_some(MotorFault::OverCurrent)
    }

    /// Runs every other protection on one sample and returns the latched fault, if any (see the
    /// module docs for the priority when several trip together).
    ///
    /// Timing: control interrupt, once per loop sample; about 300 instructions of code on a
    /// Cortex-M4F (release build, fewer of them executed per call), no division and no library
    /// call.
    pub fn check(&mut self, inputs: &ProtectionInputs) -> Option<MotorFault> {
        let i_sq = inputs.id * inputs.id + inputs.iq * inputs.iq;
        let drive_overload = self.drive_i2t.update(i_sq);
        let motor_overload = self.motor_i2t.update(i_sq);

        let v = inputs.bus_voltage;
        let over_voltage = self.bus_over.update(above(v, self.bus_over_voltage_v));
        let under_voltage = self
            .bus_under
            .update(inputs.enabled & below(v, self.bus_under_voltage_v));
        let over_speed = self
            .over_speed_confirm
            .update(above(inputs.velocity.abs(), self.over_speed));
        let encoder = self.encoder.update(inputs.encoder);
        let drive_hot = self
            .drive_temperature
            .update(above(inputs.temperature, self.drive_over_temperature_c));
        let motor_hot = self.motor_temperature.update(inputs.motor_overtemp);
        let following = self
            .following_error
            .update(inputs.following_error, inputs.enabled);

        // The first fault latches; a fault that cuts the gates replaces one that allowed a
        // controlled stop (an encoder lost during the fault reaction's ramp must stop it).
        let escalating = self.latched.is_some_and(MotorFault::allows_controlled_stop);
        if self.latched.is_none() || escalating {
            let fault = if over_voltage {
                Some(MotorFault::BusOverVoltage)
            } else if under_voltage {
                Some(MotorFault::BusUnderVoltage)
            } else if encoder.is_some() {
                encoder
            } else if over_speed {
                Some(MotorFault::OverSpeed)
            } else if drive_overload {
                Some(MotorFault::DriveOverload)
            } else if motor_overload {
                Some(MotorFault::MotorOverload)
            } else if drive_hot {
                Some(MotorFault::DriveOverTemperature)
            } else if motor_hot {
                Some(MotorFault::MotorOverTemperature)
            } else if following {
                Some(MotorFault::FollowingError)
            } else {
                None
            };
            if !escalating {
                self.latched = fault;
            } else if let Some(hard) = fault.filter(|f| !f.allows_controlled_stop()) {
                self.latched = Some(hard);
            }
        }
        self.latched
    }

    /// The latched fault.
    pub fn latched(&self) -> Option<MotorFault> {
        self.latched
    }

    /// Clears the latched fault and every confirmation, the CRC counter, the following-error
    /// timer and the encoder-jump reference; keeps the I²t state (the heat is still there).
    pub fn reset(&mut self) {
        self.latched = None;
        self.bus_over.reset();
        self.bus_under.reset();
        self.over_speed_confirm.reset();
        self.encoder.reset();
        self.drive_temperature.reset();
        self.motor_temperature.reset();
        self.following_error.reset();
    }

    /// Whether the cause of `fault` is still there in the sample `inputs` (the raw condition,
    /// before any confirmation time): a fault reset is refused meanwhile. Faults that are
    /// events (over-current, an encoder jump, a following error, the commissioning faults)
    /// have no lasting cause.
    ///
    /// Timing: control interrupt, only while the axis is faulted; a few compares.
    pub fn cause_present(&self, fault: MotorFault, inputs: &ProtectionInputs) -> bool {
        match fault {
            MotorFault::BusOverVoltage => above(inputs.bus_voltage, self.bus_over_voltage_v),
            MotorFault::BusUnderVoltage => below(inputs.bus_voltage, self.bus_under_voltage_v),
            MotorFault::OverSpeed => above(inputs.velocity.abs(), self.over_speed),
            MotorFault::EncoderSignalLoss | MotorFault::EncoderCrc => inputs.encoder.is_err(),
            MotorFault::DriveOverTemperature => {
                above(inputs.temperature, self.drive_over_temperature_c)
            }
            MotorFault::MotorOverTemperature => inputs.motor_overtemp,
            MotorFault::MotorOverload => self.motor_i2t.load() >= 1.0,
            MotorFault::DriveOverload => self.drive_i2t.load() >= 1.0,
            MotorFault::OverCurrent
            | MotorFault::EncoderJump
            | MotorFault::FollowingError
            | MotorFault::CurrentOffset
            | MotorFault::Alignment
            | MotorFault::Identification => false,
        }
    }

    /// New following-error window (6065h, increments; [`FOLLOWING_ERROR_WINDOW_OFF`]: off) and
    /// timeout (6066h, ms).
    pub fn set_following_error(&mut self, window: u32, timeout_ms: u16) {
        self.following_error.set_limits(window, timeout_ms);
    }

    /// The motor's I²t load, 0..=1 of its trip level.
    pub fn motor_load(&self) -> f32 {
        self.motor_i2t.load()
    }

    /// The drive's I²t load, 0..=1 of its trip level.
    pub fn drive_load(&self) -> f32 {
        self.drive_i2t.load()
    }

    /// The current-vector magnitude the axis may command now, A: the lower of the two I²t
    /// foldback limits.
    #[inline]
    pub fn current_limit(&self) -> f32 {
        min(
            self.motor_i2t.current_limit(),
            self.drive_i2t.current_limit(),
        )
    }

    /// The encoder's CRC error counter.
    pub fn encoder_crc_errors(&self) -> u16 {
        self.encoder.crc_errors()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Loop sample time of the tests: 4 kHz.
    const DT: f32 = 250.0e-6;
    /// Samples per second.
    const RATE: u32 = 4_000;

    const I2T: I2tConfig = I2tConfig {
        continuous_a: 4.0,
        peak_a: 12.0,
        peak_time_s: 1.0,
        foldback_start: 1.0,
    };

    /// Samples until `update(current_sq)` first reports a trip (None within `limit`).
    fn samples_to_trip(m: &mut I2t, current_sq: f32, limit: u64) -> Option<u64> {
        (1..=limit).find(|_| m.update(current_sq))
    }

    /// Nominal inputs of an enabled, healthy axis at rest.
    fn healthy(position: i64) -> ProtectionInputs {
        ProtectionInputs {
            id: 0.0,
            iq: 0.0,
            bus_voltage: 325.0,
            velocity: 0.0,
            encoder: Ok(position),
            temperature: 40.0,
            motor_overtemp: false,
            following_error: 0,
            enabled: true,
        }
    }

    fn protections() -> Protections {
        Protections::new(&ProtectionConfig::default(), DT)
    }

    /// Feeds `n` samples of `inputs`, returns the sample number (1-based) of the first fault.
    fn first_trip(
        p: &mut Protections,
        inputs: &ProtectionInputs,
        n: u32,
    ) -> Option<(u32, MotorFault)> {
        (1..=n).find_map(|k| p.check(inputs).map(|f| (k, f)))
    }

    fn next_up(x: f32) -> f32 {
        f32::from_bits(x.to_bits() + 1)
    }

    fn next_down(x: f32) -> f32 {
        f32::from_bits(x.to_bits() - 1)
    }

    // --- over-current -------------------------------------------------------------------------

    #[test]
    fn a_lasting_cause_is_present_until_it_is_gone() {
        let p = protections();
        let cfg = ProtectionConfig::default();
        let ok = healthy(0);
        let hot = ProtectionInputs {
            temperature: cfg.drive_over_temperature_c + 1.0,
            ..ok
        };
        assert!(p.cause_present(MotorFault::DriveOverTemperature, &hot));
        assert!(!p.cause_present(MotorFault::DriveOverTemperature, &ok));
        let high = ProtectionInputs {
            bus_voltage: cfg.bus_over_voltage_v + 1.0,
            ..ok
        };
        assert!(p.cause_present(MotorFault::BusOverVoltage, &high));
        let low = ProtectionInputs {
            bus_voltage: cfg.bus_under_voltage_v - 1.0,
            enabled: false,
            ..ok
        };
        assert!(p.cause_present(MotorFault::BusUnderVoltage, &low));
        let switch = ProtectionInputs {
            motor_overtemp: true,
            ..ok
        };
        assert!(p.cause_present(MotorFault::MotorOverTemperature, &switch));
        let lost = ProtectionInputs {
            encoder: Err(EncoderFault::SignalLoss),
            ..ok
        };
        assert!(p.cause_present(MotorFault::EncoderSignalLoss, &lost));
        assert!(!p.cause_present(MotorFault::EncoderSignalLoss, &ok));
        // Events have no lasting cause.
        for f in [
            MotorFault::OverCurrent,
            MotorFault::EncoderJump,
            MotorFault::FollowingError,
        ] {
            assert!(!p.cause_present(f, &hot), "{f:?}");
        }
    }

    #[test]
    fn over_current_trips_on_the_first_sample_above_the_level_in_any_phase_and_sign() {
        let p = protections();
        let trip = ProtectionConfig::default().over_current_a;
        let above = next_up(trip);
        for (ia, ib, ic) in [
            (above, 0.0, 0.0),
            (0.0, -above, 0.0),
            (0.0, 0.0, above),
            (-above, above / 2.0, above / 2.0),
        ] {
            assert_eq!(
                p.check_over_current(ia, ib, ic),
                Some(MotorFault::OverCurrent),
                "{ia} {ib} {ic}"
            );
        }
        assert_eq!(
            p.check_over_current(f32::NAN, 0.0, 0.0),
            Some(MotorFault::OverCurrent)
        );
    }

    #[test]
    fn over_current_does_not_trip_at_or_below_the_level() {
        let p = protections();
        let trip = ProtectionConfig::default().over_current_a;
        for (ia, ib, ic) in [
            (trip, -trip / 2.0, -trip / 2.0),
            (-trip, trip, 0.0),
            (next_down(trip), -next_down(trip), 0.0),
            (0.0, 0.0, 0.0),
        ] {
            assert_eq!(p.check_over_current(ia, ib, ic), None, "{ia} {ib} {ic}");
        }
    }

    // --- I²t ----------------------------------------------------------------------------------

    #[test]
    fn i2t_at_exactly_the_continuous_current_never_trips() {
        // Two hours at I_c along d, then ten minutes at I_c split over d and q (3-4-5).
        let mut m = I2t::new(&I2T, DT);
        let ic = I2T.continuous_a;
        assert_eq!(
            samples_to_trip(&mut m, ic * ic, 2 * 3_600 * u64::from(RATE)),
            None
        );
        assert_eq!(m.load(), 0.0);
        let (id, iq) = (0.6 * ic, 0.8 * ic);
        assert_eq!(
            samples_to_trip(&mut m, id * id + iq * iq, 600 * u64::from(RATE)),
            None
        );
        assert!(m.load() < 1.0e-3, "{}", m.load());
    }

    #[test]
    fn i2t_at_peak_current_trips_after_the_peak_time() {
        let mut m = I2t::new(&I2T, DT);
        let ip = I2T.peak_a;
        let expected = I2T.peak_time_s / DT;
        let n = samples_to_trip(&mut m, ip * ip, 10 * u64::from(RATE)).unwrap() as f32;
        assert!(
            (n - expected).abs() <= 1.0,
            "tripped after {n} samples, expected {expected}"
        );
        assert_eq!(m.load(), 1.0);
    }

    #[test]
    fn i2t_at_twice_the_continuous_current_trips_after_the_analytic_time() {
        // (i² − I_c²)·t = (I_p² − I_c²)·t_p with i = 2·I_c.
        let c = I2tConfig {
            continuous_a: 3.8,
            peak_a: 11.5,
            peak_time_s: 3.0,
            foldback_start: 1.0,
        };
        let (ic, ip) = (c.continuous_a, c.peak_a);
        let t = (ip * ip - ic * ic) * c.peak_time_s / (4.0 * ic * ic - ic * ic);
        let mut m = I2t::new(&c, DT);
        let n = samples_to_trip(&mut m, 4.0 * ic * ic, 100 * u64::from(RATE)).unwrap() as f32;
        assert!(
            (n - t / DT).abs() <= 1.0,
            "tripped after {n} samples, expected {}",
            t / DT
        );
    }

    #[test]
    fn i2t_cools_at_zero_current_and_floors_at_zero() {
        let mut m = I2t::new(&I2T, DT);
        let (ic, ip) = (I2T.continuous_a, I2T.peak_a);
        // Half the peak time at I_p: half loaded.
        let half = RATE / 2;
        for _ in 0..half {
            assert!(!m.update(ip * ip));
        }
        assert!((m.load() - 0.5).abs() < 1.0e-3, "{}", m.load());
        // At zero current x falls by I_c²·t: back to a quarter after
        // t = 0.25·(I_p² − I_c²)·t_p / I_c² = 2 s.
        let quarter = 0.25 * (ip * ip - ic * ic) * I2T.peak_time_s / (ic * ic);
        for _ in 0..(quarter / DT) as u32 {
            assert!(!m.update(0.0));
        }
        assert!((m.load() - 0.25).abs() < 1.0e-3, "{}", m.load());
        // Long at rest: cold again, and no credit below zero: a full peak time to trip.
        for _ in 0..60 * RATE {
            m.update(0.0);
        }
        assert_eq!(m.load(), 0.0);
        let n = samples_to_trip(&mut m, ip * ip, 10 * u64::from(RATE)).unwrap() as f32;
        assert!((n - I2T.peak_time_s / DT).abs() <= 1.0, "{n}");
    }

    #[test]
    fn i2t_just_below_peak_time_does_not_trip() {
        let mut m = I2t::new(&I2T, DT);
        let ip = I2T.peak_a;
        // One sample short of the peak time, minus the one-sample tolerance.
        for _ in 0..(I2T.peak_time_s / DT) as u32 - 2 {
            assert!(!m.update(ip * ip));
        }
        assert!(m.load() < 1.0);
    }

    #[test]
    fn i2t_foldback_ramps_the_limit_from_peak_to_continuous() {
        // From load 0.55 to 0.95: half way at 0.75.
        let c = I2tConfig {
            foldback_start: 0.55,
            ..I2T
        };
        let (ic, ip) = (c.continuous_a, c.peak_a);
        let mut m = I2t::new(&c, DT);
        assert_eq!(m.current_limit(), ip);
        // Load 0.55 (0.55 · t_p at I_p): still I_p.
        for _ in 0..(0.55 * RATE as f32) as u32 {
            m.update(ip * ip);
        }
        assert!((m.load() - 0.55).abs() < 1.0e-3, "{}", m.load());
        assert!(
            (m.current_limit() - ip).abs() < 0.05,
            "{}",
            m.current_limit()
        );
        // Load 0.75: half way down.
        for _ in 0..RATE / 5 {
            m.update(ip * ip);
        }
        assert!((m.load() - 0.75).abs() < 1.0e-3, "{}", m.load());
        assert!(
            (m.current_limit() - (ip + ic) / 2.0).abs() < 0.05,
            "{}",
            m.current_limit()
        );
        // Load 0.95 and above: I_c.
        for _ in 0..RATE / 5 {
            m.update(ip * ip);
        }
        assert!(m.load() >= FOLDBACK_FULL_LOAD, "{}", m.load());
        assert_eq!(m.current_limit(), ic);
        for _ in 0..RATE {
            m.update(ip * ip);
        }
        assert_eq!(m.current_limit(), ic);

        // Without foldback the limit stays at I_p at any load.
        let mut off = I2t::new(&I2T, DT);
        for _ in 0..RATE - 10 {
            off.update(ip * ip);
        }
        assert!(off.load() > 0.99);
        assert_eq!(off.current_limit(), ip);
    }

    #[test]
    fn i2t_foldback_derates_a_drive_that_respects_it_instead_of_tripping() {
        let c = I2tConfig {
            foldback_start: 0.8,
            ..I2T
        };
        let mut m = I2t::new(&c, DT);
        // The drive asks for 2·I_p all the time but never exceeds the limit.
        let demand = 2.0 * c.peak_a;
        let mut i = 0.0;
        for _ in 0..600 * RATE {
            i = min(demand, m.current_limit());
            assert!(!m.update(i * i), "tripped at load {}", m.load());
        }
        // It settles at the continuous current, at the foldback's full load.
        assert!((i - c.continuous_a) / c.continuous_a < 1.0e-3, "{i}");
        assert!(
            (m.load() - FOLDBACK_FULL_LOAD).abs() < 1.0e-3,
            "{}",
            m.load()
        );
    }

    // --- bus voltage --------------------------------------------------------------------------

    /// Samples of the default 1 ms confirmation at 4 kHz.
    const CONFIRM: u32 = 4;

    #[test]
    fn confirmation_time_is_rounded_to_samples() {
        assert_eq!(confirmation_samples(0.001, DT), CONFIRM as u16);
        assert_eq!(confirmation_samples(0.0, DT), 1);
        assert_eq!(confirmation_samples(f32::NAN, DT), 1);
        assert_eq!(confirmation_samples(0.1, DT), 400);
    }

    #[test]
    fn bus_over_voltage_trips_after_the_confirmation_time_even_when_disabled() {
        let level = ProtectionConfig::default().bus_over_voltage_v;
        for enabled in [true, false] {
            let mut p = protections();
            let high = ProtectionInputs {
                bus_voltage: next_up(level),
                enabled,
                ..healthy(0)
            };
            assert_eq!(
                first_trip(&mut p, &high, 100),
                Some((CONFIRM, MotorFault::BusOverVoltage))
            );
        }
    }

    #[test]
    fn bus_over_voltage_ignores_short_spikes_and_the_level_itself() {
        let level = ProtectionConfig::default().bus_over_voltage_v;
        let mut p = protections();
        let spike = ProtectionInputs {
            bus_voltage: 2.0 * level,
            ..healthy(0)
        };
        for _ in 0..100 {
            for _ in 0..CONFIRM - 1 {
                assert_eq!(p.check(&spike), None);
            }
            assert_eq!(p.check(&healthy(0)), None);
        }
        let at = ProtectionInputs {
            bus_voltage: level,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &at, 1_000), None);
    }

    #[test]
    fn bus_under_voltage_trips_only_while_enabled() {
        let level = ProtectionConfig::default().bus_under_voltage_v;
        let mut p = protections();
        let low = ProtectionInputs {
            bus_voltage: next_down(level),
            enabled: false,
            ..healthy(0)
        };
        // A drive waiting for its bus (0 V, disabled) for a minute.
        let waiting = ProtectionInputs {
            bus_voltage: 0.0,
            ..low
        };
        assert_eq!(first_trip(&mut p, &waiting, 60 * RATE), None);
        assert_eq!(first_trip(&mut p, &low, 1_000), None);
        let enabled = ProtectionInputs {
            enabled: true,
            ..low
        };
        assert_eq!(
            first_trip(&mut p, &enabled, 100),
            Some((CONFIRM, MotorFault::BusUnderVoltage))
        );
    }

    #[test]
    fn bus_under_voltage_does_not_trip_at_the_level_or_briefly_below() {
        let level = ProtectionConfig::default().bus_under_voltage_v;
        let mut p = protections();
        let at = ProtectionInputs {
            bus_voltage: level,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &at, 1_000), None);
        let dip = ProtectionInputs {
            bus_voltage: 0.0,
            ..healthy(0)
        };
        for _ in 0..CONFIRM - 1 {
            assert_eq!(p.check(&dip), None);
        }
        assert_eq!(p.check(&healthy(0)), None);
    }

    // --- over-speed ---------------------------------------------------------------------------

    #[test]
    fn over_speed_trips_after_confirmation_in_both_directions() {
        let limit = ProtectionConfig::default().over_speed;
        for v in [next_up(limit), -next_up(limit), f32::NAN] {
            let mut p = protections();
            // Stand still so that the encoder step check stays quiet.
            let fast = ProtectionInputs {
                velocity: v,
                ..healthy(0)
            };
            assert_eq!(
                first_trip(&mut p, &fast, 100),
                Some((CONFIRM, MotorFault::OverSpeed)),
                "{v}"
            );
        }
    }

    #[test]
    fn over_speed_does_not_trip_at_the_limit_or_for_fewer_samples() {
        let limit = ProtectionConfig::default().over_speed;
        let mut p = protections();
        let at = ProtectionInputs {
            velocity: -limit,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &at, 1_000), None);
        let fast = ProtectionInputs {
            velocity: 2.0 * limit,
            ..healthy(0)
        };
        for _ in 0..CONFIRM - 1 {
            assert_eq!(p.check(&fast), None);
        }
        assert_eq!(p.check(&healthy(0)), None);
    }

    // --- encoder ------------------------------------------------------------------------------

    #[test]
    fn encoder_signal_loss_and_reported_jump_trip_at_once() {
        let mut p = protections();
        let lost = ProtectionInputs {
            encoder: Err(EncoderFault::SignalLoss),
            ..healthy(0)
        };
        assert_eq!(p.check(&lost), Some(MotorFault::EncoderSignalLoss));
        let mut p = protections();
        let jumped = ProtectionInputs {
            encoder: Err(EncoderFault::ImplausibleJump),
            ..healthy(0)
        };
        assert_eq!(p.check(&jumped), Some(MotorFault::EncoderJump));
    }

    #[test]
    fn encoder_crc_counter_trips_on_a_burst_and_tolerates_a_low_error_rate() {
        // Weight 10, trip 100: the tenth bad frame in a row trips.
        let bad = Err(EncoderFault::Crc);
        let mut m = EncoderMonitor::new(10, 100, 1_000);
        for _ in 0..9 {
            assert_eq!(m.update(bad), None);
        }
        assert_eq!(m.update(bad), Some(MotorFault::EncoderCrc));

        // One bad frame in eleven adds as much as it removes: never trips.
        let mut m = EncoderMonitor::new(10, 100, 1_000);
        for _ in 0..100_000 {
            assert_eq!(m.update(bad), None);
            for _ in 0..10 {
                assert_eq!(m.update(Ok(0)), None);
            }
        }
        assert_eq!(m.crc_errors(), 0);

        // One in ten: +10 −9 per ten frames; trips once the counter reaches 100.
        let mut m = EncoderMonitor::new(10, 100, 1_000);
        let mut tripped = None;
        'outer: for round in 1..=1_000u32 {
            if m.update(bad).is_some() {
                tripped = Some(round);
                break 'outer;
            }
            for _ in 0..9 {
                assert_eq!(m.update(Ok(0)), None);
            }
        }
        // After k rounds the counter is k before the bad frame of round k + 1 adds 10: it
        // reaches 100 in round 91.
        assert_eq!(tripped, Some(91));
    }

    #[test]
    fn encoder_jump_limit_follows_from_the_over_speed_level() {
        let cfg = ProtectionConfig::default();
        let max = max_increments_per_sample(cfg.over_speed, DT, cfg.encoder_jump_margin);
        // 6000 rpm · 2^17 / 60 · 250 µs · 2 = 6553.6 → 6553 increments.
        assert_eq!(max, 6_553);
        let max = max as i64;

        let mut p = protections();
        let start = 1_000_000;
        assert_eq!(p.check(&healthy(start)), None);
        // Exactly the limit forward and back: plausible.
        assert_eq!(p.check(&healthy(start + max)), None);
        assert_eq!(p.check(&healthy(start)), None);
        // One increment more: a jump.
        assert_eq!(
            p.check(&healthy(start - max - 1)),
            Some(MotorFault::EncoderJump)
        );
    }

    #[test]
    fn encoder_jump_allows_the_movement_of_the_samples_lost_to_crc_errors() {
        let mut m = EncoderMonitor::new(10, 100, 100);
        assert_eq!(m.update(Ok(0)), None);
        assert_eq!(m.update(Err(EncoderFault::Crc)), None);
        // Two samples since the last good position: up to 200 increments.
        assert_eq!(m.update(Ok(200)), None);
        assert_eq!(m.update(Err(EncoderFault::Crc)), None);
        assert_eq!(m.update(Ok(401)), Some(MotorFault::EncoderJump));
    }

    #[test]
    fn encoder_first_sample_and_wrap_are_not_jumps() {
        let mut m = EncoderMonitor::new(10, 100, 100);
        assert_eq!(m.update(Ok(i64::MAX - 10)), None);
        // The multi-turn counter wraps: 20 increments forward.
        assert_eq!(m.update(Ok(i64::MIN + 9)), None);
        m.reset();
        // After a reset the next position is the new reference, wherever it is.
        assert_eq!(m.update(Ok(0)), None);
    }

    // --- temperatures -------------------------------------------------------------------------

    #[test]
    fn drive_over_temperature_trips_after_its_confirmation_time() {
        let cfg = ProtectionConfig::default();
        let samples = u32::from(confirmation_samples(cfg.drive_temperature_confirm_s, DT));
        assert_eq!(samples, 400);
        let mut p = protections();
        let hot = ProtectionInputs {
            temperature: next_up(cfg.drive_over_temperature_c),
            enabled: false,
            ..healthy(0)
        };
        assert_eq!(
            first_trip(&mut p, &hot, 10 * samples),
            Some((samples, MotorFault::DriveOverTemperature))
        );
    }

    #[test]
    fn drive_over_temperature_does_not_trip_at_the_level_or_briefly_above() {
        let cfg = ProtectionConfig::default();
        let samples = u32::from(confirmation_samples(cfg.drive_temperature_confirm_s, DT));
        let mut p = protections();
        let at = ProtectionInputs {
            temperature: cfg.drive_over_temperature_c,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &at, 10 * samples), None);
        let hot = ProtectionInputs {
            temperature: 150.0,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &hot, samples - 1), None);
        assert_eq!(p.check(&healthy(0)), None);
        assert_eq!(first_trip(&mut p, &hot, samples - 1), None);
    }

    #[test]
    fn motor_over_temperature_input_trips_after_its_confirmation_samples() {
        let cfg = ProtectionConfig::default();
        let samples = u32::from(confirmation_samples(
            cfg.motor_over_temperature_confirm_s,
            DT,
        ));
        assert_eq!(samples, 40);
        let mut p = protections();
        let hot = ProtectionInputs {
            motor_overtemp: true,
            ..healthy(0)
        };
        // A glitch one sample short of the confirmation: ignored.
        assert_eq!(first_trip(&mut p, &hot, samples - 1), None);
        assert_eq!(p.check(&healthy(0)), None);
        assert_eq!(
            first_trip(&mut p, &hot, 10 * samples),
            Some((samples, MotorFault::MotorOverTemperature))
        );
    }

    // --- following error ----------------------------------------------------------------------

    #[test]
    fn following_error_trips_when_above_the_window_for_longer_than_the_timeout() {
        // 6065h = 1000 increments, 6066h = 10 ms = 40 samples.
        let mut m = FollowingErrorMonitor::new(1_000, 10, DT);
        for error in [1_001, -1_001] {
            m.reset();
            for _ in 0..40 {
                assert!(!m.update(error, true));
            }
            assert!(m.update(error, true), "{error}");
        }
    }

    #[test]
    fn following_error_does_not_trip_at_the_window_or_within_the_timeout() {
        let mut m = FollowingErrorMonitor::new(1_000, 10, DT);
        for _ in 0..10 * RATE {
            assert!(!m.update(1_000, true));
            assert!(!m.update(-1_000, true));
        }
        // 40 samples above, one back inside: the timer restarts.
        for _ in 0..100 {
            for _ in 0..40 {
                assert!(!m.update(5_000, true));
            }
            assert!(!m.update(0, true));
        }
    }

    #[test]
    fn following_error_window_all_ones_switches_the_check_off() {
        let mut m = FollowingErrorMonitor::new(FOLLOWING_ERROR_WINDOW_OFF, 0, DT);
        for error in [i64::MAX, i64::MIN, 1 << 40] {
            for _ in 0..1_000 {
                assert!(!m.update(error, true));
            }
        }
        // Switched back on at run time (6065h written): timeout 0 trips on the first sample.
        m.set_limits(1_000, 0);
        assert!(m.update(1_001, true));
    }

    #[test]
    fn following_error_is_only_checked_while_enabled() {
        let mut p = protections();
        let cfg = ProtectionConfig::default();
        let timeout = u32::from(cfg.following_error_timeout_ms) * RATE / 1_000;
        let lagging = ProtectionInputs {
            following_error: i64::from(cfg.following_error_window) + 1,
            enabled: false,
            ..healthy(0)
        };
        assert_eq!(first_trip(&mut p, &lagging, 10 * timeout), None);
        let enabled = ProtectionInputs {
            enabled: true,
            ..lagging
        };
        assert_eq!(
            first_trip(&mut p, &enabled, 10 * timeout),
            Some((timeout + 1, MotorFault::FollowingError))
        );
    }

    // --- the whole set ------------------------------------------------------------------------

    #[test]
    fn healthy_axis_runs_without_faults() {
        let mut p = protections();
        let mut position = 0i64;
        // 3000 rpm with 1 A rms in q for ten seconds.
        let velocity = 3_000.0 / 60.0 * 131_072.0;
        for _ in 0..10 * RATE {
            position += (velocity * DT) as i64;
            let inputs = ProtectionInputs {
                iq: 1.4,
                velocity,
                following_error: 100,
                ..healthy(position)
            };
            assert_eq!(p.check(&inputs), None);
        }
        assert!(p.motor_load() == 0.0 && p.drive_load() == 0.0);
        assert_eq!(p.current_limit(), 11.5);
    }

    /// A configuration where every protection trips on its first sample; the motor's I²t at
    /// 2 A and above, the drive's at 10 A and above.
    fn hair_trigger() -> Protections {
        Protections::new(
            &ProtectionConfig {
                motor_i2t: I2tConfig {
                    continuous_a: 1.0,
                    peak_a: 2.0,
                    peak_time_s: DT,
                    foldback_start: 1.0,
                },
                drive_i2t: I2tConfig {
                    continuous_a: 5.0,
                    peak_a: 10.0,
                    peak_time_s: DT,
                    foldback_start: 1.0,
                },
                bus_confirm_s: 0.0,
                over_speed_confirm_s: 0.0,
                encoder_crc_trip: 1,
                drive_temperature_confirm_s: 0.0,
                motor_over_temperature_confirm_s: 0.0,
                following_error_timeout_ms: 0,
                ..ProtectionConfig::default()
            },
            DT,
        )
    }

    #[test]
    fn simultaneous_faults_report_in_the_documented_priority() {
        let cfg = ProtectionConfig::default();
        // Every fault condition at once; each is removed after it was reported, and the next
        // one in the priority list must come up (fresh protections every time).
        let mut inputs = ProtectionInputs {
            id: 10.0,
            iq: 10.0,
            bus_voltage: 1_000.0,
            velocity: 2.0 * cfg.over_speed,
            encoder: Err(EncoderFault::SignalLoss),
            temperature: 200.0,
            motor_overtemp: true,
            following_error: i64::MAX,
            enabled: true,
        };
        let calm = healthy(0);
        type Clear = fn(&mut ProtectionInputs, &ProtectionInputs);
        let order: [(MotorFault, Clear); 11] = [
            // 0 V while enabled: under-voltage is next.
            (MotorFault::BusOverVoltage, |i, _| i.bus_voltage = 0.0),
            (MotorFault::BusUnderVoltage, |i, c| {
                i.bus_voltage = c.bus_voltage
            }),
            (MotorFault::EncoderSignalLoss, |i, _| {
                i.encoder = Err(EncoderFault::ImplausibleJump)
            }),
            (MotorFault::EncoderJump, |i, _| {
                i.encoder = Err(EncoderFault::Crc)
            }),
            (MotorFault::EncoderCrc, |i, c| i.encoder = c.encoder),
            (MotorFault::OverSpeed, |i, c| i.velocity = c.velocity),
            // 3 A: above the motor's peak, below the drive's.
            (MotorFault::DriveOverload, |i, _| (i.id, i.iq) = (3.0, 0.0)),
            (MotorFault::MotorOverload, |i, c| {
                (i.id, i.iq) = (c.id, c.iq)
            }),
            (MotorFault::DriveOverTemperature, |i, c| {
                i.temperature = c.temperature
            }),
            (MotorFault::MotorOverTemperature, |i, c| {
                i.motor_overtemp = c.motor_overtemp
            }),
            (MotorFault::FollowingError, |i, c| {
                i.following_error = c.following_error
            }),
        ];
        for (fault, clear) in order {
            let mut p = hair_trigger();
            assert_eq!(p.check(&inputs), Some(fault));
            clear(&mut inputs, &calm);
        }
        assert_eq!(inputs, calm);
        assert_eq!(hair_trigger().check(&inputs), None);
    }

    #[test]
    fn a_fault_stays_latched_until_reset_and_reset_keeps_the_heat() {
        let mut p = hair_trigger();
        let hot = ProtectionInputs {
            motor_overtemp: true,
            ..healthy(0)
        };
        assert_eq!(p.check(&hot), Some(MotorFault::MotorOverTemperature));
        for _ in 0..1_000 {
            assert_eq!(p.check(&healthy(0)), Some(MotorFault::MotorOverTemperature));
        }
        // The motor is still under control (a thermal fault): a later fault that also allows a
        // controlled stop does not replace it, one that cuts the gates does (an encoder lost
        // during the fault reaction's ramp), and nothing replaces that one.
        let lagging = ProtectionInputs {
            following_error: i64::MAX,
            ..healthy(0)
        };
        for _ in 0..1_000 {
            assert_eq!(p.check(&lagging), Some(MotorFault::MotorOverTemperature));
        }
        let lost = ProtectionInputs {
            encoder: Err(EncoderFault::SignalLoss),
            ..healthy(0)
        };
        assert_eq!(p.check(&lost), Some(MotorFault::EncoderSignalLoss));
        assert_eq!(p.check(&hot), Some(MotorFault::EncoderSignalLoss));
        let over_voltage = ProtectionInputs {
            bus_voltage: 1.0e6,
            ..healthy(0)
        };
        for _ in 0..1_000 {
            assert_eq!(p.check(&over_voltage), Some(MotorFault::EncoderSignalLoss));
        }
        p.reset();
        assert_eq!(p.latched(), None);
        assert_eq!(p.check(&healthy(0)), None);

        // Overload, reset: the motor is still hot, the next overload sample trips again.
        let mut p = protections();
        let peak = ProtectionInputs {
            iq: 11.5,
            ..healthy(0)
        };
        let (n, fault) = first_trip(&mut p, &peak, 10 * RATE).unwrap();
        // The drive's model (4.2 A / 12.7 A / 2 s) trips before the motor's (3.8 A / 11.5 A /
        // 3 s: 3 s at its peak), after (I_p² − I_c²)·t_p / (i² − I_c²) ≈ 2.51 s.
        assert_eq!(fault, MotorFault::DriveOverload);
        let d = ProtectionConfig::default().drive_i2t;
        let (ic, ip, i) = (d.continuous_a, d.peak_a, peak.iq);
        let t = (ip * ip - ic * ic) * d.peak_time_s / (i * i - ic * ic);
        assert!((n as f32 - t / DT).abs() <= 1.0, "{n} vs {}", t / DT);
        p.reset();
        assert!(p.drive_load() > 0.99);
        assert_eq!(p.check(&peak), Some(MotorFault::DriveOverload));
    }

    #[test]
    fn following_error_limits_can_be_changed_at_run_time() {
        let mut p = protections();
        let lagging = ProtectionInputs {
            following_error: 50_000,
            ..healthy(0)
        };
        p.set_following_error(FOLLOWING_ERROR_WINDOW_OFF, 0);
        assert_eq!(first_trip(&mut p, &lagging, RATE), None);
        // 100 ms = 400 samples.
        p.set_following_error(10_000, 100);
        assert_eq!(
            first_trip(&mut p, &lagging, RATE),
            Some((401, MotorFault::FollowingError))
        );
    }
}
