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
//! Every measured call runs the same code (the harness fails otherwise). The FOC step and the
//! control interrupt are measured over sets of inputs that cover their branches; each input
//! starts from a state restored before every call (the restore measured alone and subtracted),
//! and its branch is checked on the output before it is measured.

use core::hint::black_box;

use firmware::motor::axis::{
    Axis, AxisCommand, AxisFeedback, AxisLink, AxisState, ControlMode, Output, Sample,
};
use firmware::motor::capture::Switches;
use firmware::motor::foc::{
    CurrentLoop, CurrentLoopConfig, CurrentLoopInput, CurrentLoopOutput, MAX_MODULATION_LIMIT,
};
use firmware::motor::math::{self, sin_cos, INV_SQRT3, TAU};
use firmware::motor::servo::{self, Tuning, SERVO_400W};
use firmware::motor::MotorFault;
use firmware::motor::{Duties, ElectricalAngle};
use hal::io::ProbeCapture;
use hal::power::PhaseCurrents;

use crate::harness::{Cases, Harness};

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

/// One `CurrentLoop::step` of the servo, over inputs that cover its branches.
///
/// The base input is 1500 rpm (100 Hz electrical) with 5 A of q current. A probe step
/// measures the id/iq the loop sees for the constant currents and angle, and the references of
/// the steady case are exactly those values (integrators empty): the PI errors are zero and the
/// output is the decoupling feed-forward alone (vd = −ω·Lq·iq, vq = ω·(Ld·id + ψ)), which is
/// checked. The other inputs change one thing each and their branch is checked from the output:
///
/// | input | branch |
/// |---|---|
/// | steady | linear range, PI errors 0 |
/// | current step | linear range, both integrators move |
/// | q limited | the q output is cut to what the d output leaves of the circle (its square root) |
/// | d limited | the d output is pinned at the circle, q gets nothing |
/// | over-modulation | a loop allowed the hexagon (`max_modulation` 2/√3) asks for its corner: the modulator's division path |
/// | NaN current | a sample that is not a number: the modulator's zero vector |
///
/// A step moves the integrators, so each call empties them first (every input starts from
/// empty integrators) and the emptying alone is measured and subtracted.
fn foc_step(h: &mut Harness) {
    const NAME: &str = "foc-step";
    let cfg = current_loop_config();
    let hexagon = CurrentLoopConfig {
        max_modulation: MAX_MODULATION_LIMIT,
        ..cfg
    };
    let (Ok(mut cl), Ok(hexagon_cl)) = (CurrentLoop::new(&cfg), CurrentLoop::new(&hexagon)) else {
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
    let mut steady = CurrentLoopInput {
        currents,
        angle: ElectricalAngle::from_bits(0xAAAA_AAAA),
        omega_e,
        vbus: BUS_VOLTAGE,
        inv_vbus: 1.0 / BUS_VOLTAGE,
        id_ref: 0.0,
        iq_ref: 0.0,
    };
    let probe = cl.step(&steady);
    steady.id_ref = probe.id;
    steady.iq_ref = probe.iq;
    cl.reset();
    let out = cl.step(&steady);
    let vd_ff = -omega_e * cfg.lq_h * out.iq;
    let vq_ff = omega_e * (cfg.ld_h * out.id + cfg.flux_wb);
    let ok = out.id == steady.id_ref
        && out.iq == steady.iq_ref
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
    // The circle's radius at the bus voltage of the measurement.
    let vmax = cfg.max_modulation * INV_SQRT3 * BUS_VOLTAGE;
    let limited = |x: f32| x.abs() >= vmax * (1.0 - 1e-6);
    let inside = |x: f32| x.abs() < vmax * 0.9;
    let inputs: [FocInput; 6] = [
        FocInput {
            label: "steady",
            cl,
            input: steady,
            branch: |o| !o.voltage_limited && centred(&o.duties),
        },
        FocInput {
            label: "current step",
            cl,
            input: CurrentLoopInput {
                iq_ref: steady.iq_ref + 2.0,
                ..steady
            },
            branch: |o| !o.voltage_limited && centred(&o.duties),
        },
        FocInput {
            label: "q limited",
            cl,
            input: CurrentLoopInput {
                iq_ref: steady.iq_ref + 100.0,
                ..steady
            },
            branch: |o| o.voltage_limited && centred(&o.duties),
        },
        FocInput {
            label: "d limited",
            cl,
            input: CurrentLoopInput {
                id_ref: steady.id_ref - 100.0,
                ..steady
            },
            branch: |o| o.voltage_limited && o.vq == 0.0 && centred(&o.duties),
        },
        FocInput {
            label: "over-modulation",
            cl: hexagon_cl,
            input: CurrentLoopInput {
                iq_ref: steady.iq_ref + 100.0,
                ..steady
            },
            branch: |o| o.voltage_limited && spans_the_bus(&o.duties),
        },
        FocInput {
            label: "NaN current",
            cl,
            input: CurrentLoopInput {
                currents: PhaseCurrents {
                    a: f32::NAN,
                    ..currents
                },
                ..steady
            },
            branch: |o| o.voltage_limited && o.duties == Duties::CENTRED,
        },
    ];
    let mut cases = Cases::new(NAME);
    for case in &inputs {
        let out = case.cl.clone().step(&case.input);
        let checked = (case.branch)(&out)
            && match case.label {
                "q limited" => inside(out.vd) && !limited(out.vd),
                "d limited" => limited(out.vd),
                _ => true,
            };
        if !checked {
            h.fail(
                NAME,
                format_args!(
                    "input \"{}\" did not take its branch: vd {} vq {} duties {:?} limited {}",
                    case.label, out.vd, out.vq, out.duties, out.voltage_limited
                ),
            );
            return;
        }
        // Every input starts from empty integrators (the loop's only state), so the restore is
        // `reset`: two stores instead of a copy of the loop.
        let mut cl = case.cl;
        if cl.integrals() != (0.0, 0.0) {
            h.fail(
                NAME,
                format_args!("input \"{}\" does not start empty", case.label),
            );
            return;
        }
        let mut restored = cl;
        let input = case.input;
        let Some((cost, _, _)) = h.measure_net(
            NAME,
            &mut || {
                restored.reset();
                black_box(&mut restored);
            },
            &mut || {
                cl.reset();
                black_box(cl.step(black_box(&input)));
            },
        ) else {
            return;
        };
        h.case(&mut cases, case.label, cost);
    }
    h.report_cases(
        &cases,
        Some(FOC_STEP_BUDGET),
        format_args!(
            "CurrentLoop::step: Clarke, sin/cos, Park, 2 PI with decoupling and anti-windup, \
             circle limiter, inverse Park with latency compensation, SVPWM, dead-time \
             compensation; at 100 Hz electrical, over its branches (linear, current step, q \
             limited, d limited, over-modulation, NaN current)"
        ),
    );
}

/// One input of the current-loop measurement: the loop's state before the step, the input and
/// the check that the step took the input's branch.
struct FocInput {
    label: &'static str,
    cl: CurrentLoop,
    input: CurrentLoopInput,
    branch: fn(&CurrentLoopOutput) -> bool,
}

/// Whether `d` spans the whole bus (over-modulation: the lowest duty 0, the highest 1).
fn spans_the_bus(d: &Duties) -> bool {
    let hi = d.a.max(d.b).max(d.c);
    let lo = d.a.min(d.b).min(d.c);
    hi == 1.0 && lo == 0.0
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

/// The control interrupt in its loop period over inputs that cover its branches, and the SYNC0
/// side of the handoff.
///
/// `Axis::control_step` with `loop_divider` 1, so that every period is a loop period: command
/// taken from the link with a new set-point pushed into the interpolator, velocity estimator,
/// interpolation, position loop, speed loop, current loop, protections, feedback published.
/// The bus cycle equals the loop period (25 µs at 40 kHz) and each call publishes the input's
/// command before the step, as the SYNC0 handler would once per bus cycle: the interpolator
/// stays in its continuous-stream path (new segment every tick, evaluated in the segment).
///
/// Every input starts from the axis running in CSP at rest on [`POSITION`] and changes one
/// thing ([`CONTROL_INPUTS`]), measured in the period that takes it or, for another mode, after
/// a few periods in it; its branch is checked on the output and feedback of one step. That
/// state is restored from a copy before each call (the restore and the publish are measured
/// alone and subtracted).
fn control_interrupt(h: &mut Harness) {
    const NAME: &str = "control-interrupt";
    // SAFETY: everything here runs in one context (the benchmark's main), so the publishing and
    // the reading side never preempt each other: the single-writer/priority contract holds.
    let link = unsafe { AxisLink::new() };
    let Some(snapshot) = h.ready(NAME, running_axis(&tuning(1, 1.0 / PWM_HZ), &link)) else {
        return;
    };

    h.bench(
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
    let mut cases = Cases::new(NAME);
    for input in CONTROL_INPUTS {
        let (command, sample) = (input.command, input.sample);
        // The state the input is measured in: its command and sample taken for `settle`
        // periods, or until the next period takes the input's branch.
        let mut start = snapshot.clone();
        let mut settled = false;
        for period in 0..MAX_SETTLE_PERIODS {
            settled = match input.settle {
                Settle::Periods(n) => period >= n,
                Settle::UntilBranch => {
                    let mut next = start.clone();
                    link.publish(command);
                    let output = next.control_step(&sample, &link);
                    (input.branch)(&next, &link.feedback(), &output)
                }
            };
            if settled {
                break;
            }
            link.publish(command);
            start.control_step(&sample, &link);
        }
        if !settled {
            h.fail(
                NAME,
                format_args!("input \"{}\" never reached its branch", input.label),
            );
            return;
        }
        let snapshot = &start;
        let mut axis = snapshot.clone();
        link.publish(command);
        let output = axis.control_step(&sample, &link);
        let fb = link.feedback();
        if !(input.branch)(&axis, &fb, &output) {
            h.fail(
                NAME,
                format_args!(
                    "input \"{}\" did not take its branch: state {:?} fault {:?} gates {} \
                     following error {} current limited {} duties {:?}",
                    input.label,
                    axis.state(),
                    axis.fault(),
                    output.gates,
                    fb.following_error,
                    fb.current_limited,
                    output.duties
                ),
            );
            return;
        }
        let mut restored = snapshot.clone();
        let Some((cost, _, _)) = h.measure_net(
            NAME,
            &mut || {
                restored = black_box(snapshot).clone();
                link.publish(black_box(command));
                black_box(&mut restored);
            },
            &mut || {
                axis = black_box(snapshot).clone();
                link.publish(black_box(command));
                black_box(axis.control_step(black_box(&sample), &link));
            },
        ) else {
            return;
        };
        h.case(&mut cases, input.label, cost);
    }
    h.report_cases(
        &cases,
        Some(CONTROL_INTERRUPT_BUDGET),
        format_args!(
            "Axis::control_step in its loop period (loop divider 1, a new set-point every \
             period): command take + interpolation + position, speed and current loops + \
             protections + feedback publish; over its branches (CSP at rest, following, at the \
             torque limit and the voltage circle, CSV, CST, stop ramp, over-current and \
             over-voltage trips)"
        ),
    );
}

/// One input of the control-interrupt measurement: the command published before the step,
/// the sample, and the check that the step took the input's branch.
struct ControlInput {
    label: &'static str,
    /// How long the command and sample run (from the axis at rest) before the measured period.
    settle: Settle,
    command: AxisCommand,
    sample: Sample,
    branch: fn(&Axis, &AxisFeedback, &Output) -> bool,
}

/// How an input of [`CONTROL_INPUTS`] reaches the state it is measured in.
#[derive(Clone, Copy)]
enum Settle {
    /// This many periods: 0 measures the period that takes a new command, more the steady path
    /// of a mode switched to.
    Periods(u32),
    /// Until the next period takes the input's branch (a protection that confirms over time
    /// trips in the measured period).
    UntilBranch,
}

/// Most periods an input may need to reach its state (0.25 s at 40 kHz).
const MAX_SETTLE_PERIODS: u32 = 10_000;

/// Whether the axis runs with the gates on after the step.
fn runs(axis: &Axis, fb: &AxisFeedback, out: &Output) -> bool {
    axis.state() == AxisState::Running && axis.fault().is_none() && fb.fault.is_none() && out.gates
}

/// Whether the step tripped `fault`: gates off, latched.
fn tripped(axis: &Axis, fault: MotorFault, out: &Output) -> bool {
    axis.state() == AxisState::Faulted && axis.fault() == Some(fault) && !out.gates
}

/// The spread of the duties: above 0.8 the voltage vector is at the circle of the servo's
/// `max_modulation` 0.95 (its SVPWM span lies between 0.95·√3/2 = 0.82 and 0.95 there).
fn duty_span(d: &Duties) -> f32 {
    d.a.max(d.b).max(d.c) - d.a.min(d.b).min(d.c)
}

/// The inputs of the control-interrupt measurement.
const CONTROL_INPUTS: [ControlInput; 8] = [
    ControlInput {
        label: "CSP at rest",
        settle: Settle::Periods(0),
        command: COMMAND,
        sample: SAMPLE,
        branch: |a, fb, o| runs(a, fb, o) && fb.following_error == 0 && zero_voltage(&o.duties),
    },
    ControlInput {
        label: "CSP following (1 increment per period)",
        settle: Settle::Periods(0),
        command: AxisCommand {
            position: POSITION + 1,
            ..COMMAND
        },
        sample: SAMPLE,
        branch: |a, fb, o| runs(a, fb, o) && !fb.current_limited && !zero_voltage(&o.duties),
    },
    ControlInput {
        label: "CSP step: torque limit, voltage circle",
        settle: Settle::Periods(0),
        command: AxisCommand {
            position: POSITION + 200_000,
            ..COMMAND
        },
        sample: SAMPLE,
        branch: |a, fb, o| runs(a, fb, o) && fb.current_limited && duty_span(&o.duties) > 0.8,
    },
    ControlInput {
        label: "CSV 1000 rpm",
        settle: Settle::Periods(4),
        command: AxisCommand {
            mode: ControlMode::Velocity,
            velocity: 17_476_267.0,
            ..COMMAND
        },
        sample: SAMPLE,
        branch: |a, fb, o| runs(a, fb, o) && !zero_voltage(&o.duties),
    },
    ControlInput {
        label: "CST 0.5 N·m",
        settle: Settle::Periods(4),
        command: AxisCommand {
            mode: ControlMode::Torque,
            torque: 0.5,
            ..COMMAND
        },
        sample: SAMPLE,
        branch: |a, fb, o| runs(a, fb, o) && !zero_voltage(&o.duties),
    },
    ControlInput {
        label: "stop ramp",
        settle: Settle::Periods(4),
        command: AxisCommand {
            mode: ControlMode::Stop,
            deceleration: 1.0e7,
            ..COMMAND
        },
        sample: SAMPLE,
        branch: runs,
    },
    ControlInput {
        label: "over-current trip",
        settle: Settle::Periods(0),
        command: COMMAND,
        sample: Sample {
            currents: PhaseCurrents {
                a: 100.0,
                b: -50.0,
                c: -50.0,
            },
            ..SAMPLE
        },
        branch: |a, _, o| tripped(a, MotorFault::OverCurrent, o),
    },
    ControlInput {
        label: "bus over-voltage trip",
        settle: Settle::UntilBranch,
        command: COMMAND,
        sample: Sample {
            bus_voltage: 80.0,
            ..SAMPLE
        },
        branch: |a, _, o| tripped(a, MotorFault::BusOverVoltage, o),
    },
];

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
