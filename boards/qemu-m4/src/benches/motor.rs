//! The motor-control hot paths: the sin/cos kernel, one current-loop (FOC) step, the whole
//! control interrupt of an axis in its worst period, and the SYNC0 side of the set-point and
//! feedback handoff.
//!
//! The axis is the 48 V / 400 W reference servo of the simulation, configured by the same code:
//! [`servo::axis_config`] of [`SERVO_400W`] with the default [`Tuning`] (the loop divider and
//! bus cycle set per measurement): 40 kHz PWM, 2 kHz current-loop bandwidth with decoupling and
//! dead-time compensation, 150 Hz speed loop, 20-bit absolute encoder with a known commutation
//! offset (no alignment at enable).
//!
//! Every measured operation runs the same code on every call (the harness fails otherwise): the
//! inputs are constant and the state is a steady state in which the errors are zero, so that no
//! integrator, filter or counter moves.

use core::hint::black_box;

use firmware::motor::axis::{Axis, AxisCommand, AxisLink, AxisState, ControlMode, Output, Sample};
use firmware::motor::capture::Switches;
use firmware::motor::foc::{CurrentLoop, CurrentLoopConfig, CurrentLoopInput};
use firmware::motor::math::{self, sin_cos, TAU};
use firmware::motor::servo::{self, Tuning, SERVO_400W};
use firmware::motor::{Duties, ElectricalAngle};
use hal::io::ProbeCapture;
use hal::power::PhaseCurrents;

use crate::harness::Harness;

/// DESIGN.md §6: FOC current-loop step (Clarke, Park, 2 PI with decoupling and anti-windup,
/// inverse Park, SVPWM).
const FOC_STEP_BUDGET: u32 = 250;
/// DESIGN.md §6: whole control interrupt (sensing, FOC, speed and position loops, protections).
const CONTROL_INTERRUPT_BUDGET: u32 = 1_500;

/// PWM frequency of the servo, Hz.
const PWM_HZ: f32 = SERVO_400W.inverter.pwm_hz as f32;
/// The loop divider of the servo's default tuning (20 kHz position and speed loops).
const LOOP_DIVIDER: u32 = Tuning::DEFAULT.loop_divider;
/// DC-bus voltage of the measurement, V.
const BUS_VOLTAGE: f32 = 48.0;
/// Power-stage temperature of the measurement, °C.
const TEMPERATURE: f32 = 25.0;
/// The (constant) encoder position of the measurement, increments: any value away from zero.
pub(super) const POSITION: i64 = 0x0012_3456;
/// Margin of the duty checks (the duties of a steady state are 0.5 up to rounding).
const DUTY_TOLERANCE: f32 = 1e-3;

/// The default tuning with the position and speed loops every `loop_divider`-th PWM period and
/// set-points every `bus_cycle_s`.
pub(super) fn tuning(loop_divider: u32, bus_cycle_s: f32) -> Tuning {
    Tuning {
        loop_divider,
        bus_cycle_s,
        ..Tuning::DEFAULT
    }
}

/// The current-loop configuration of the servo (that of its default tuning).
fn current_loop_config() -> CurrentLoopConfig {
    servo::axis_config(&SERVO_400W, &Tuning::DEFAULT).current_loop
}

/// Whether `d` are valid duties (0..=1) centred on 0.5 (the min-max centring of SVPWM).
fn centred(d: &Duties) -> bool {
    let valid = |x: f32| (0.0..=1.0).contains(&x);
    let hi = d.a.max(d.b).max(d.c);
    let lo = d.a.min(d.b).min(d.c);
    valid(d.a) && valid(d.b) && valid(d.c) && ((hi + lo) * 0.5 - 0.5).abs() < DUTY_TOLERANCE
}

/// Whether `d` are all 0.5 (zero voltage).
fn zero_voltage(d: &Duties) -> bool {
    [d.a, d.b, d.c]
        .iter()
        .all(|x| (x - 0.5).abs() < DUTY_TOLERANCE)
}

/// Measures the motor-control hot paths.
pub fn run(h: &mut Harness) {
    sin_cos_bench(h);
    sqrt_bench(h);
    foc_step(h);
    control_interrupt(h);
    control_cycle_average(h);
}

/// `math::sin_cos` of a constant angle in the second quadrant (the quadrant select is part of it).
fn sin_cos_bench(h: &mut Harness) {
    // 5/12 turn = 150°: sin 0.5, cos −√3/2.
    let angle = ElectricalAngle::from_bits((5u64 * (1u64 << 32) / 12) as u32);
    let (s, c) = sin_cos(angle);
    if (s - 0.5).abs() > 1e-5 || (c + 0.866_025_4).abs() > 1e-5 {
        h.fail("sin-cos", format_args!("sin_cos(150°) = ({s}, {c})"));
        return;
    }
    h.bench(
        "sin-cos",
        None,
        format_args!("math::sin_cos of an electrical angle (150°)"),
        &mut || {
            black_box(sin_cos(black_box(angle)));
        },
    );
}

/// `math::sqrt` on the target (the hardware VSQRT there): checked against exact values and
/// its defined results for the inputs outside its domain, then timed.
fn sqrt_bench(h: &mut Harness) {
    const NAME: &str = "sqrt";
    let cases = [
        (4.0f32, 2.0f32),
        (2.25, 1.5),
        (0.25, 0.5),
        (1_048_576.0, 1_024.0),
        (0.0, 0.0),
        (-1.0, 0.0),
        (f32::NAN, 0.0),
        (f32::INFINITY, 0.0),
    ];
    for (x, root) in cases {
        let got = math::sqrt(black_box(x));
        // Correctly rounded on the target: the exact squares come out exact.
        if got != root {
            h.fail(NAME, format_args!("sqrt({x}) = {got}, not {root}"));
            return;
        }
    }
    h.bench(
        NAME,
        None,
        format_args!("math::sqrt (VSQRT with the domain checks)"),
        &mut || {
            black_box(math::sqrt(black_box(2.0)));
        },
    );
}

/// One `CurrentLoop::step` of the servo at 1500 rpm with 5 A of q current.
///
/// Steady state: a probe step measures the id/iq the loop sees for the constant currents and
/// angle; with the references set to exactly those values (and the integrators emptied) the PI
/// errors are zero, the integrators stay where they are and every call is the same. The output
/// is then the decoupling feed-forward alone (vd = −ω·Lq·iq, vq = ω·(Ld·id + ψ)), which is
/// checked, as are the duties (valid and centred) and the linear range (no limiting).
fn foc_step(h: &mut Harness) {
    const NAME: &str = "foc-step";
    let cfg = current_loop_config();
    let Ok(mut cl) = CurrentLoop::new(&cfg) else {
        h.fail(
            NAME,
            format_args!("the current-loop configuration was refused"),
        );
        return;
    };
    // 1500 rpm with 4 pole pairs: 100 Hz electrical.
    let omega_e = TAU * 100.0;
    // A balanced set of 5 A peak with its vector at −30° (α/β), the rotor at 240° electrical:
    // id ≈ 0, iq ≈ 5 A (motoring).
    let currents = PhaseCurrents {
        a: 4.330_127,
        b: -4.330_127,
        c: 0.0,
    };
    let mut input = CurrentLoopInput {
        currents,
        angle: ElectricalAngle::from_bits(0xAAAA_AAAA),
        omega_e,
        vbus: BUS_VOLTAGE,
        inv_vbus: 1.0 / BUS_VOLTAGE,
        id_ref: 0.0,
        iq_ref: 0.0,
    };
    let probe = cl.step(&input);
    input.id_ref = probe.id;
    input.iq_ref = probe.iq;
    cl.reset();
    let out = cl.step(&input);
    let vd_ff = -omega_e * cfg.lq_h * out.iq;
    let vq_ff = omega_e * (cfg.ld_h * out.id + cfg.flux_wb);
    let ok = out.id == input.id_ref
        && out.iq == input.iq_ref
        && cl.integrals() == (0.0, 0.0)
        && (out.vd - vd_ff).abs() < 1e-4
        && (out.vq - vq_ff).abs() < 1e-4
        && out.iq.abs() > 1.0
        && !out.voltage_limited
        && centred(&out.duties)
        && !zero_voltage(&out.duties);
    if !ok {
        h.fail(
            NAME,
            format_args!(
                "not the steady decoupled step: id {} iq {} vd {} (ff {vd_ff}) vq {} (ff {vq_ff}) \
                 duties {:?} limited {}",
                out.id, out.iq, out.vd, out.vq, out.duties, out.voltage_limited
            ),
        );
        return;
    }
    h.bench(
        NAME,
        Some(FOC_STEP_BUDGET),
        format_args!(
            "CurrentLoop::step: Clarke, sin/cos, Park, 2 PI with decoupling and anti-windup, \
             circle limiter, inverse Park with latency compensation, SVPWM, dead-time \
             compensation; steady state (PI errors 0) at 100 Hz electrical, iq {:.1} A",
            out.iq
        ),
        &mut || {
            black_box(cl.step(black_box(&input)));
        },
    );
    if cl.integrals() != (0.0, 0.0) {
        h.fail(
            NAME,
            format_args!("the measured steps moved the integrators"),
        );
    }
}

/// The command of the measurement: enabled, CSP, target = the actual position.
pub(super) const COMMAND: AxisCommand = AxisCommand {
    enable: true,
    fault_reset: false,
    identify: false,
    calibrate_offsets: false,
    mode: ControlMode::Position,
    position: POSITION,
    velocity: 0.0,
    torque: 0.0,
    deceleration: 0.0,
    // Unchanged: the interpolator keeps the bus cycle of the configuration.
    bus_cycle_ns: 0,
    // As the drive sends them every cycle (6065h/6066h): compared, applied once.
    following_error_limits: Some((262_144, 20)),
    torque_limits: None,
};

/// The sample of the measurement: no current, 48 V, 25 °C, the encoder at rest.
pub(super) const SAMPLE: Sample = Sample {
    currents: PhaseCurrents {
        a: 0.0,
        b: 0.0,
        c: 0.0,
    },
    bus_voltage: BUS_VOLTAGE,
    temperature: TEMPERATURE,
    motor_overtemp: false,
    position: Ok(POSITION),
    switches: Switches {
        positive_limit: false,
        negative_limit: false,
        home: false,
    },
    index: None,
    probes: [ProbeCapture {
        active: false,
        edge_ns_before_position: None,
    }; 2],
    safe_torque_off_channels: [true; 2],
    enable_input: true,
    power_stage_trip: false,
};

/// An axis of the servo at `tuning`, brought to Running in CSP through its link, at rest on
/// [`POSITION`]: offset calibration, then the cascade with the target equal to the actual
/// position. Runs whole loop cycles (`loop_divider` periods, a command published before each),
/// so that the next period is a loop period. The reason if it did not get there.
fn running_axis(tuning: &Tuning, link: &AxisLink) -> Result<Axis, &'static str> {
    let cfg = servo::axis_config(&SERVO_400W, tuning);
    let loop_divider = tuning.loop_divider;
    let mut axis = Axis::new(cfg).map_err(|_| "the axis configuration was refused")?;
    let mut output = Output {
        gates: false,
        duties: Duties::CENTRED,
    };
    // Calibration (offset_samples periods) and then enough loop cycles for the interpolator to
    // be in its continuous stream path and the velocity estimator to settle at zero.
    let cycles = cfg.offset_samples + 16;
    for _ in 0..cycles {
        link.publish(COMMAND);
        for _ in 0..loop_divider {
            output = axis.control_step(&SAMPLE, link);
        }
    }
    let fb = link.feedback();
    if axis.state() != AxisState::Running || axis.fault().is_some() {
        return Err("the axis did not reach Running");
    }
    if fb.state != AxisState::Running || fb.position != POSITION || fb.following_error != 0 {
        return Err("the feedback is not that of the running axis at rest");
    }
    if !output.gates || !zero_voltage(&output.duties) {
        return Err("the running axis does not drive zero voltage");
    }
    Ok(axis)
}

/// Checks that `axis` is still running at rest after a measurement.
fn still_running(h: &mut Harness, name: &str, axis: &Axis, link: &AxisLink) {
    let fb = link.feedback();
    if axis.state() != AxisState::Running
        || axis.fault().is_some()
        || fb.state != AxisState::Running
        || fb.position != POSITION
        || fb.following_error != 0
        || fb.velocity != 0.0
        || fb.torque != 0.0
    {
        h.fail(name, format_args!("the measured periods changed the axis"));
    }
}

/// The control interrupt in its worst period, and the SYNC0 side of the handoff.
///
/// `Axis::control_step` with `loop_divider` 1, so that every period is a loop period: command
/// taken from the link with a new CSP set-point pushed into the interpolator, velocity
/// estimator, interpolation, position loop, speed loop, current loop, protections, feedback
/// published. The bus cycle equals the loop period (25 µs at 40 kHz) and the op publishes the
/// same command (target = actual position) before each step, as the SYNC0 handler would once
/// per bus cycle: the interpolator then stays in its continuous-stream path (new segment every
/// tick, evaluated in the segment) and every error is zero, so every call runs the same code.
/// Not publishing would instead leave the interpolator in its missed-set-point hold after three
/// ticks, which skips the set-point push and the in-segment polynomial: not the worst period.
/// The publish belongs to the SYNC0 handler, so its separately measured cost is subtracted.
fn control_interrupt(h: &mut Harness) {
    const NAME: &str = "control-interrupt";
    // SAFETY: everything here runs in one context (the benchmark's main), so the publishing and
    // the reading side never preempt each other: the single-writer/priority contract holds.
    let link = unsafe { AxisLink::new() };
    let Some(mut axis) = h.ready(NAME, running_axis(&tuning(1, 1.0 / PWM_HZ), &link)) else {
        return;
    };

    let publish = h.bench(
        "sync0-publish",
        None,
        format_args!("AxisLink::publish of an AxisCommand (SYNC0 side of the set-point handoff)"),
        &mut || link.publish(black_box(COMMAND)),
    );
    h.bench(
        "sync0-handoff",
        None,
        format_args!(
            "AxisLink::publish + AxisLink::feedback: the SYNC0 handler's side of the axis \
             handoff (part of its 2000 budget)"
        ),
        &mut || {
            link.publish(black_box(COMMAND));
            black_box(link.feedback());
        },
    );
    let with_publish = h.measure(NAME, &mut || {
        link.publish(black_box(COMMAND));
        black_box(axis.control_step(black_box(&SAMPLE), &link));
    });
    still_running(h, NAME, &axis, &link);
    let (Some(publish), Some(with_publish)) = (publish, with_publish) else {
        return;
    };
    let Some(cost) = with_publish.checked_sub(publish) else {
        h.fail(NAME, format_args!("publish costs more than publish + step"));
        return;
    };
    h.report(
        NAME,
        cost,
        Some(CONTROL_INTERRUPT_BUDGET),
        format_args!(
            "Axis::control_step, worst period: running in CSP at rest, a new set-point every \
             period (loop divider 1, bus cycle = loop period): command take + interpolation + \
             position, speed and current loops + protections + feedback publish \
             ({with_publish} with the SYNC0 publish in the same op − {publish} publish)"
        ),
    );
}

/// The control interrupt averaged over one loop cycle with the servo's real loop divider:
/// [`LOOP_DIVIDER`] periods, the first a loop period (command, set-point push, loops, current
/// loop, protections, feedback), the others current loop only. Bus cycle = one loop cycle, the
/// same command published per cycle (subtracted as in [`control_interrupt`]).
fn control_cycle_average(h: &mut Harness) {
    const NAME: &str = "control-interrupt-average";
    // SAFETY: as in `control_interrupt`: one context only.
    let link = unsafe { AxisLink::new() };
    let loop_hz = PWM_HZ / LOOP_DIVIDER as f32;
    let Some(mut axis) = h.ready(
        NAME,
        running_axis(&tuning(LOOP_DIVIDER, 1.0 / loop_hz), &link),
    ) else {
        return;
    };
    let measured = h.measure_net(NAME, &mut || link.publish(black_box(COMMAND)), &mut || {
        link.publish(black_box(COMMAND));
        for _ in 0..LOOP_DIVIDER {
            black_box(axis.control_step(black_box(&SAMPLE), &link));
        }
    });
    still_running(h, NAME, &axis, &link);
    let Some((total, _, _)) = measured else {
        return;
    };
    let average = (total + LOOP_DIVIDER / 2) / LOOP_DIVIDER;
    h.report(
        NAME,
        average,
        None,
        format_args!(
            "Axis::control_step averaged over one loop cycle of the servo's tuning (loop \
             divider {LOOP_DIVIDER}: {total} for {LOOP_DIVIDER} periods, one of them the loop \
             period; bus cycle = loop cycle, publish subtracted as above)"
        ),
    );
}
