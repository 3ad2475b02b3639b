//! Measurements of the control quality on the simulated 400 W servo ([`PlantConfig::servo_400w`]
//! with [`Tuning::default`]: 40 kHz PWM and current loop, 20 kHz position/speed loops, 1 ms bus
//! cycle), shared by the tests (`boards/sim/tests/motor_*.rs`, which assert the bounds) and
//! `sim-drive plots` (which draws them for the docs).
//!
//! Every measurement starts from a fresh, seeded plant, so it is repeatable to the bit.

use std::f64::consts::TAU;
use std::io;
use std::path::{Path, PathBuf};

use firmware::motor::axis::{AxisCommand, AxisState, ControlMode};

use crate::plant::PlantConfig;
use crate::plot::Plot;
use crate::servo::{axis_config, counts_per_rev, SimServo, Tuning};

/// PWM periods per 1 ms bus cycle at 40 kHz.
pub const PERIODS_PER_CYCLE: u64 = 40;

/// The servo enabled in `mode` and running (offsets calibrated), holding its position.
pub fn running_servo(plant: PlantConfig, tuning: &Tuning, mode: ControlMode) -> SimServo {
    let cfg = axis_config(&plant, tuning);
    let mut servo = match SimServo::new(plant, cfg) {
        Ok(servo) => servo,
        Err(e) => panic!("the servo configuration is invalid: {e:?}"),
    };
    for _ in 0..50 {
        let command = AxisCommand {
            enable: true,
            mode,
            position: servo.feedback().position,
            ..Default::default()
        };
        servo.publish(command);
        servo.run_periods(PERIODS_PER_CYCLE);
        if servo.axis.state() == AxisState::Running {
            return servo;
        }
    }
    panic!("the axis did not start: {:?}", servo.feedback());
}

/// Increments per revolution of the servo's encoder.
fn cpr(servo: &SimServo) -> f64 {
    f64::from(counts_per_rev(&servo.plant.config().encoder))
}

// ---- current loop ------------------------------------------------------------------------

/// One point of a closed-loop frequency response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrequencyPoint {
    /// Frequency, Hz.
    pub hz: f64,
    /// Real part of the closed loop T(jω).
    pub re: f64,
    /// Imaginary part of T(jω).
    pub im: f64,
}

impl FrequencyPoint {
    /// |T|.
    pub fn gain(&self) -> f64 {
        self.re.hypot(self.im)
    }

    /// ∠T in degrees.
    pub fn phase_deg(&self) -> f64 {
        self.im.atan2(self.re).to_degrees()
    }

    /// The open loop L = T / (1 − T) as (re, im).
    pub fn open_loop(&self) -> (f64, f64) {
        let (dr, di) = (1.0 - self.re, -self.im);
        let den = dr * dr + di * di;
        (
            (self.re * dr + self.im * di) / den,
            (self.im * dr - self.re * di) / den,
        )
    }
}

/// Amplitude of the injected q current, A: well above the current noise (0.03 A rms) and the
/// dead-time compensation band, well below the voltage limit at the highest frequency.
pub const INJECTION_A: f64 = 3.0;

/// The closed-loop response of the q current at `hz` on a locked rotor: a sine of
/// [`INJECTION_A`] injected into the q-current reference (as a drive's frequency-response tool
/// does), the true q current of the plant at each sampling instant correlated with it over a
/// whole number of periods after settling.
pub fn current_loop_point(hz: f64) -> FrequencyPoint {
    let mut plant = PlantConfig::servo_400w();
    plant.seed ^= hz.to_bits();
    let mut servo = running_servo(plant, &Tuning::default(), ControlMode::Torque);
    servo.plant.set_driven_speed(Some(0.0));
    let ts = servo.plant.period_s();
    let periods_per_sine = 1.0 / (hz * ts);
    let sines = (0.02 * hz).ceil().max(4.0);
    let settle = ((0.005 / ts) as u64).max(2 * periods_per_sine as u64);
    let total = settle + (sines * periods_per_sine).round() as u64;
    let (mut sr, mut si, mut rr, mut ri) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..total {
        let t = k as f64 * ts;
        let reference = INJECTION_A * (TAU * hz * t).sin();
        servo.axis.set_current_injection(0.0, reference as f32);
        let (_, iq) = servo.plant.currents_dq();
        servo.period();
        if k >= settle {
            let (s, c) = (TAU * hz * t).sin_cos();
            sr += iq * s;
            si += iq * c;
            rr += reference * s;
            ri += reference * c;
        }
    }
    let den = rr * rr + ri * ri;
    FrequencyPoint {
        hz,
        re: (sr * rr + si * ri) / den,
        im: (si * rr - sr * ri) / den,
    }
}

/// A sweep from 100 Hz to 8 kHz in steps of ×1.15.
pub fn current_loop_sweep() -> Vec<FrequencyPoint> {
    let mut points = Vec::new();
    let mut hz = 100.0;
    while hz <= 8_000.0 {
        points.push(current_loop_point(hz));
        hz *= 1.15;
    }
    points
}

/// Bandwidth figures of a sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopFigures {
    /// Closed-loop −3 dB frequency, Hz.
    pub bandwidth_hz: f64,
    /// Open-loop unity-gain frequency, Hz.
    pub crossover_hz: f64,
    /// Phase margin at the crossover, degrees.
    pub phase_margin_deg: f64,
}

/// Log-frequency interpolation of where `y` crosses `level` between two points.
fn crossing((x0, y0): (f64, f64), (x1, y1): (f64, f64), level: f64) -> f64 {
    let u = (level - y0) / (y1 - y0);
    (x0.ln() + u * (x1.ln() - x0.ln())).exp()
}

/// −3 dB bandwidth, crossover and phase margin of a sweep; `None` if the sweep does not reach
/// them.
pub fn loop_figures(points: &[FrequencyPoint]) -> Option<LoopFigures> {
    let level = 0.5f64.sqrt();
    let i = points.iter().position(|p| p.gain() < level)?;
    let before = points.get(i.checked_sub(1)?)?;
    let bandwidth_hz = crossing(
        (before.hz, before.gain()),
        (points[i].hz, points[i].gain()),
        level,
    );
    let open: Vec<(f64, f64, f64)> = points
        .iter()
        .map(|p| {
            let (re, im) = p.open_loop();
            (p.hz, re.hypot(im), im.atan2(re))
        })
        .collect();
    let j = open.iter().position(|&(_, gain, _)| gain < 1.0)?;
    let (f0, g0, p0) = *open.get(j.checked_sub(1)?)?;
    let (f1, g1, p1) = open[j];
    let crossover_hz = crossing((f0, g0), (f1, g1), 1.0);
    let u = (crossover_hz.ln() - f0.ln()) / (f1.ln() - f0.ln());
    let mut phase_margin_deg = 180.0 + (p0 + u * (p1 - p0)).to_degrees();
    if phase_margin_deg > 180.0 {
        phase_margin_deg -= 360.0;
    }
    Some(LoopFigures {
        bandwidth_hz,
        crossover_hz,
        phase_margin_deg,
    })
}

// ---- speed loop --------------------------------------------------------------------------

/// A time response: (s, value) every PWM period.
pub type Trace = Vec<(f64, f64)>;

fn csv(velocity: f32) -> AxisCommand {
    AxisCommand {
        enable: true,
        mode: ControlMode::Velocity,
        velocity,
        ..Default::default()
    }
}

/// Runs `cycles` bus cycles of `command`, recording the plant's speed (rpm) every period.
fn record_speed(servo: &mut SimServo, command: AxisCommand, cycles: u32, t0: f64) -> Trace {
    let mut out = Vec::new();
    for _ in 0..cycles {
        servo.publish(command);
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            out.push((
                servo.plant.time_s() - t0,
                servo.plant.mech_speed_rad_s() * 60.0 / TAU,
            ));
        }
    }
    out
}

/// A velocity step response.
#[derive(Clone, Debug, PartialEq)]
pub struct StepResponse {
    /// Speed in rpm over time from the bus cycle that carried the step.
    pub trace: Trace,
    /// Step height, rpm.
    pub step_rpm: f64,
    /// Peak above the step, fraction of the step.
    pub overshoot: f64,
    /// Time after which the speed stays within ±2 % of the step, s.
    pub settling_s: f64,
}

/// The CSV set-point steps from standstill to `rpm` in one bus cycle; the trace starts at the
/// start of that cycle.
pub fn velocity_step(rpm: f64) -> StepResponse {
    velocity_step_of(PlantConfig::servo_400w(), rpm)
}

/// [`velocity_step`] on another plant (e.g. the same servo at another [`Fidelity`]), with the
/// default tuning.
///
/// [`Fidelity`]: crate::plant::Fidelity
pub fn velocity_step_of(plant: PlantConfig, rpm: f64) -> StepResponse {
    let mut servo = running_servo(plant, &Tuning::default(), ControlMode::Velocity);
    for _ in 0..20 {
        servo.publish(csv(0.0));
        servo.run_periods(PERIODS_PER_CYCLE);
    }
    let counts = (rpm / 60.0 * cpr(&servo)) as f32;
    let t0 = servo.plant.time_s();
    let trace = record_speed(&mut servo, csv(counts), 40, t0);
    let peak = trace.iter().map(|p| p.1).fold(f64::MIN, f64::max);
    let settling_s = trace
        .iter()
        .rev()
        .find(|p| (p.1 / rpm - 1.0).abs() > 0.02)
        .map_or(0.0, |p| p.0);
    StepResponse {
        trace,
        step_rpm: rpm,
        overshoot: peak / rpm - 1.0,
        settling_s,
    }
}

/// The response to a load-torque step at constant speed.
#[derive(Clone, Debug, PartialEq)]
pub struct DisturbanceResponse {
    /// Speed in rpm from the moment the load is applied.
    pub trace: Trace,
    /// Speed before the step, rpm.
    pub speed_rpm: f64,
    /// Largest speed drop, rpm.
    pub dip_rpm: f64,
    /// When the largest drop occurred, s.
    pub dip_at_s: f64,
    /// Time after which the speed stays within 2 % of the dip from the set speed, s.
    pub recovery_s: f64,
}

/// Runs at `rpm` (CSV), then applies `load_nm` as a step.
pub fn load_step(rpm: f64, load_nm: f64) -> DisturbanceResponse {
    load_step_of(PlantConfig::servo_400w(), rpm, load_nm)
}

/// [`load_step`] on another plant, with the default tuning.
pub fn load_step_of(plant: PlantConfig, rpm: f64, load_nm: f64) -> DisturbanceResponse {
    let mut servo = running_servo(plant, &Tuning::default(), ControlMode::Velocity);
    let counts = (rpm / 60.0 * cpr(&servo)) as f32;
    for _ in 0..200 {
        servo.publish(csv(counts));
        servo.run_periods(PERIODS_PER_CYCLE);
    }
    let speed_rpm = servo.plant.mech_speed_rad_s() * 60.0 / TAU;
    servo.plant.set_load_torque(load_nm);
    let t0 = servo.plant.time_s();
    let trace = record_speed(&mut servo, csv(counts), 60, t0);
    let (dip_at_s, lowest) = trace
        .iter()
        .fold((0.0, f64::MAX), |a, p| if p.1 < a.1 { *p } else { a });
    let dip_rpm = speed_rpm - lowest;
    let recovery_s = trace
        .iter()
        .rev()
        .find(|p| (speed_rpm - p.1).abs() > 0.02 * dip_rpm)
        .map_or(0.0, |p| p.0);
    DisturbanceResponse {
        trace,
        speed_rpm,
        dip_rpm,
        dip_at_s,
        recovery_s,
    }
}

// ---- position loop -----------------------------------------------------------------------

/// A jerk-limited (7-segment S-curve) point-to-point move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SCurve {
    /// Distance, rad (mechanical).
    pub distance: f64,
    /// Top speed, rad/s.
    pub v_max: f64,
    /// Acceleration, rad/s².
    pub a_max: f64,
    /// Jerk, rad/s³.
    pub j_max: f64,
}

impl SCurve {
    /// The position every `dt` from the start until the end (rad), integrated finely.
    pub fn sample(&self, dt: f64) -> Vec<f64> {
        let tj = self.a_max / self.j_max;
        let ta = (self.v_max / self.a_max - tj).max(0.0);
        let accel_distance = self.v_max * (2.0 * tj + ta) / 2.0;
        let tc = ((self.distance - 2.0 * accel_distance) / self.v_max).max(0.0);
        let j = self.j_max;
        let phases = [
            (tj, j),
            (ta, 0.0),
            (tj, -j),
            (tc, 0.0),
            (tj, -j),
            (ta, 0.0),
            (tj, j),
        ];
        let h = dt / 100.0;
        let (mut p, mut v, mut a) = (0.0f64, 0.0f64, 0.0f64);
        let mut out = vec![0.0];
        let mut steps = 0u64;
        for (duration, jerk) in phases {
            for _ in 0..(duration / h).round() as u64 {
                a += jerk * h;
                v += a * h;
                p += v * h;
                steps += 1;
                if steps % 100 == 0 {
                    out.push(p);
                }
            }
        }
        out.push(p);
        out
    }
}

/// The move of the position test: 10 revolutions, 3000 rpm, 20,000 rad/s² (1.04 N·m on the
/// 5.2e-5 kg·m² of rotor and load, 43 % of the peak torque), 4e6 rad/s³ (5 ms jerk phases).
pub const S_CURVE: SCurve = SCurve {
    distance: 10.0 * TAU,
    v_max: 3000.0 / 60.0 * TAU,
    a_max: 20_000.0,
    j_max: 4.0e6,
};

/// Following of a CSP move.
#[derive(Clone, Debug, PartialEq)]
pub struct FollowingResponse {
    /// (s, demand rad, following error in increments) every PWM period.
    pub trace: Vec<(f64, f64, f64)>,
    /// Largest |following error| during the move, increments.
    pub max_error: f64,
    /// |following error| 50 ms after the end of the move, increments.
    pub final_error: f64,
    /// Whether a fault occurred.
    pub fault: bool,
}

/// The master sends `curve` as CSP targets every 1 ms; the demand the drive follows is the
/// master's trajectory one bus cycle late (the interpolation), i.e. at the end of bus cycle k
/// it is the target of cycle k. The following error is demand − true rotor position, at every
/// PWM period (the demand between cycle ends from the fine trajectory).
pub fn follow(curve: &SCurve) -> FollowingResponse {
    let mut servo = running_servo(
        PlantConfig::servo_400w(),
        &Tuning::default(),
        ControlMode::Position,
    );
    let counts_per_rad = cpr(&servo) / TAU;
    let start = servo.feedback().position;
    let start_rad = servo.plant.mech_angle_rad();
    let per_cycle = PERIODS_PER_CYCLE as usize;
    let ts = servo.plant.period_s();
    // Fine trajectory, one point per PWM period.
    let fine = curve.sample(ts);
    let cycles = fine.len() / per_cycle + 1;
    let hold = 50;
    let last = *fine.last().unwrap_or(&0.0);
    let at = |i: usize| *fine.get(i).unwrap_or(&last);
    let t0 = servo.plant.time_s();
    let mut trace = Vec::new();
    let mut max_error: f64 = 0.0;
    let mut fault = false;
    for k in 0..cycles + hold {
        let target = start + (at(k * per_cycle) * counts_per_rad).round() as i64;
        servo.publish(AxisCommand {
            enable: true,
            mode: ControlMode::Position,
            position: target,
            ..Default::default()
        });
        for i in 0..per_cycle {
            servo.period();
            // One cycle late: at period i of cycle k the demand is the trajectory at
            // (k − 1)·T + (i + 1)·Ts.
            let demand = if k == 0 {
                0.0
            } else {
                at((k - 1) * per_cycle + i + 1)
            };
            let actual = servo.plant.mech_angle_rad() - start_rad;
            let error = (demand - actual) * counts_per_rad;
            if k <= cycles {
                max_error = max_error.max(error.abs());
            }
            trace.push((servo.plant.time_s() - t0, demand, error));
        }
        fault |= servo.feedback().fault.is_some();
    }
    let final_error = trace.last().map_or(f64::NAN, |p| p.2.abs());
    FollowingResponse {
        trace,
        max_error,
        final_error,
        fault,
    }
}

// ---- plots -------------------------------------------------------------------------------

/// At most this many points per series (the SVGs stay small).
const MAX_PLOT_POINTS: usize = 1_500;

fn decimate(points: impl Iterator<Item = (f64, f64)> + Clone) -> Vec<(f64, f64)> {
    let n = points.clone().count();
    let step = n.div_ceil(MAX_PLOT_POINTS).max(1);
    points.step_by(step).collect()
}

/// Runs every measurement and writes its plot into `dir`; returns the files written.
pub fn write_plots(dir: &Path) -> io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut write = |name: &str, plot: Plot| -> io::Result<()> {
        let path = dir.join(name);
        plot.write(&path)?;
        files.push(path);
        Ok(())
    };

    let sweep = current_loop_sweep();
    let gain: Vec<_> = sweep
        .iter()
        .map(|p| (p.hz, 20.0 * p.gain().log10()))
        .collect();
    let phase: Vec<_> = sweep.iter().map(|p| (p.hz, p.phase_deg())).collect();
    let figures = loop_figures(&sweep);
    let title = match figures {
        Some(f) => format!(
            "Current loop, 40 kHz PWM: −3 dB at {:.0} Hz, crossover {:.0} Hz, PM {:.0}°",
            f.bandwidth_hz, f.crossover_hz, f.phase_margin_deg
        ),
        None => "Current loop, 40 kHz PWM".to_string(),
    };
    write(
        "current-loop-gain.svg",
        Plot::new(&title, "frequency (Hz)", "|iq/iq_ref| (dB)")
            .log_x()
            .series("closed loop", &gain)
            .hline(-3.0, "−3 dB"),
    )?;
    write(
        "current-loop-phase.svg",
        Plot::new(&title, "frequency (Hz)", "∠ iq/iq_ref (°)")
            .log_x()
            .series("closed loop", &phase),
    )?;

    let step = velocity_step(200.0);
    write(
        "speed-step.svg",
        Plot::new(
            &format!(
                "CSV step 0 → 200 rpm: overshoot {:.1} %, settled (±2 %) after {:.2} ms",
                step.overshoot * 100.0,
                step.settling_s * 1e3
            ),
            "time (s)",
            "speed (rpm)",
        )
        .series("speed", &decimate(step.trace.iter().copied()))
        .hline(step.step_rpm, "set-point"),
    )?;

    let load = load_step(1000.0, 1.0);
    write(
        "load-step.svg",
        Plot::new(
            &format!(
                "Load step 1 N·m at 1000 rpm: dip {:.1} rpm, recovered (2 %) after {:.1} ms",
                load.dip_rpm,
                load.recovery_s * 1e3
            ),
            "time (s)",
            "speed (rpm)",
        )
        .series("speed", &decimate(load.trace.iter().copied()))
        .hline(load.speed_rpm, "set-point"),
    )?;

    let follow = follow(&S_CURVE);
    write(
        "s-curve-following-error.svg",
        Plot::new(
            &format!(
                "CSP S-curve, 10 rev at 3000 rpm: max following error {:.0} increments (2^20/rev)",
                follow.max_error
            ),
            "time (s)",
            "following error (increments)",
        )
        .series("error", &decimate(follow.trace.iter().map(|p| (p.0, p.2)))),
    )?;
    write(
        "s-curve-position.svg",
        Plot::new("CSP S-curve: demand position", "time (s)", "position (rev)").series(
            "demand",
            &decimate(follow.trace.iter().map(|p| (p.0, p.1 / TAU))),
        ),
    )?;
    Ok(files)
}
