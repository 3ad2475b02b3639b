//! The whole SYNC0 handler with the motor attached, as the board runs it: `on_sync0` on the
//! slave's core in OP in DC mode (each cycle a SYNC0 one DC cycle after the last, which the
//! sync supervision counts), with the `standard` profile's default mapping, and the drive's
//! axis attached to a motor-control [`Axis`] through an [`AxisLink`], so that the cycle
//! includes the axis handoff (feedback read, set-point publish) and the set-point generators.
//!
//! Two modes:
//! - cyclic synchronous position at rest (the master's target equals the actual position);
//! - profile position through a whole move of [`MOVE_DISTANCE`] on the profile's default 6081h,
//!   6083h and 6084h, measured in each of its kinds of cycle: the new set-point accepted from
//!   rest, accelerating, at constant velocity, a set-point that changes the move at once while
//!   it runs (bit 5), decelerating, and holding the target once the generator has arrived. The
//!   budget applies to the most expensive of them.
//!
//! A cycle of a move is not repeatable by itself (the generator advances), so each kind is
//! measured from a snapshot of the core taken just before it: one call restores the snapshot
//! and runs the handler, and the restore alone is measured and subtracted. The control
//! interrupt (measured on its own in `motor`) does not run between the measured cycles: the
//! feedback the handler reads is that of the axis running at rest on the start position.

use core::hint::black_box;

use firmware::cia402::pds::{controlword, PdsState};
use firmware::cia402::profile_position::{CHANGE_SET_IMMEDIATELY, NEW_SET_POINT};
use firmware::motor::axis::{Axis, AxisLink, AxisState};
use firmware::motor::servo::{self, SERVO_400W};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};
use firmware::slave::Application;
use firmware::sync0::on_sync0;
use firmware::DriveCore;

use super::motor::{tuning, POSITION, SAMPLE};
use super::sync0_handler::{Setup, DC_CYCLE_NS};
use super::{axis_vars, master_outputs_for, read, MODE_CYCLIC_SYNC_POSITION};
use crate::harness::{Cases, Harness};

/// DESIGN.md §6: SYNC0 handler (PDO unpack, CiA402, PDO pack; PDI bus time excluded).
const SYNC0_HANDLER_BUDGET: u32 = 2_000;
/// Modes of operation 6060h: profile position mode (IEC 61800-7-201).
const MODE_PROFILE_POSITION: i8 = 1;
/// CiA402 606Bh velocity demand value: the phases of the move are told by its change.
const VELOCITY_DEMAND_VALUE: u16 = 0x606B;
/// CiA402 device-control commands (IEC 61800-7-201 Table 5).
const SHUTDOWN: u16 = controlword::ENABLE_VOLTAGE | controlword::QUICK_STOP;
const SWITCH_ON: u16 = SHUTDOWN | controlword::SWITCH_ON;
const ENABLE_OPERATION: u16 = SWITCH_ON | controlword::ENABLE_OPERATION;
/// The start position: the encoder position of [`SAMPLE`], as a 607Ah value (the standard
/// profile's position unit is the increment).
const START: i32 = POSITION as i32;
/// The profile-position move, increments (8 revolutions of the 20-bit encoder): long enough on
/// the standard profile's default 6081h/6083h/6084h (1000 rpm, 100 rev/s²) for a phase at
/// constant velocity between the ramps.
const MOVE_DISTANCE: i32 = 8 << 20;
/// The target a set-point with bit 5 sets while the move runs: further on, so the move goes on.
const CHANGED_TARGET: i32 = START + MOVE_DISTANCE + (2 << 20);
/// Bus cycles of the enable sequence before giving up (offset calibration included).
const MAX_ENABLE_CYCLES: u32 = 400;
/// PWM periods of the control interrupt per bus cycle during the enable sequence (how many is
/// not critical: the axis only has to finish its offset calibration and run).
const PERIODS_PER_CYCLE: u32 = 40;
/// Bus cycles a move may take before giving up.
const MAX_MOVE_CYCLES: u32 = 20_000;

/// The link between the drive's SYNC0 side and the axis' control interrupt.
// SAFETY: the benchmark runs in one context (its main), so the publishing side and the control
// interrupt never preempt each other: the single-writer/priority contract holds.
static LINK: AxisLink = unsafe { AxisLink::new() };

/// The slave in OP with the motor attached and the axis it commands.
struct Bench {
    setup: Setup,
    axis: Axis,
}

impl Bench {
    /// The slave in OP in DC mode ([`Setup::new_dc`]) with its axis attached to a servo axis.
    fn new() -> Result<Self, &'static str> {
        let mut setup =
            <Setup>::new_dc().ok_or("the slave did not reach OP in DC mode on the ESC image")?;
        let cfg = servo::axis_config(&SERVO_400W, &tuning(1, 1e-3));
        let axis = Axis::new(cfg).map_err(|_| "the axis configuration was refused")?;
        let (drive, ram) = setup.core.application();
        drive
            .attach_axis(0, &LINK, SERVO_400W.encoder, ram)
            .map_err(|_| "the profile has no axis 0")?;
        Ok(Self { setup, axis })
    }

    /// The master's outputs: `cw`, 607Ah `target`, 6060h `mode`.
    fn outputs(&mut self, cw: u16, target: i32, mode: i8) -> Result<(), &'static str> {
        let master = master_outputs_for(cw, target, mode).ok_or("a CiA402 variable is missing")?;
        self.setup.set_master(&master);
        Ok(())
    }

    /// One bus cycle: the SYNC0 handler, then `periods` control interrupts.
    fn cycle(&mut self, periods: u32) -> Result<(), &'static str> {
        self.setup.dc_cycle()?;
        for _ in 0..periods {
            self.axis.control_step(&SAMPLE, &LINK);
        }
        Ok(())
    }

    /// Power-up to operation enabled in CSP on the start position, the axis running.
    fn enable(&mut self) -> Result<(), &'static str> {
        for cw in [0, SHUTDOWN, SWITCH_ON] {
            self.outputs(cw, START, MODE_CYCLIC_SYNC_POSITION)?;
            self.cycle(PERIODS_PER_CYCLE)?;
        }
        self.outputs(ENABLE_OPERATION, START, MODE_CYCLIC_SYNC_POSITION)?;
        for _ in 0..MAX_ENABLE_CYCLES {
            self.cycle(PERIODS_PER_CYCLE)?;
            if self.pds() == PdsState::OperationEnabled && self.axis.state() == AxisState::Running {
                // A few more cycles: the drive's windows and the axis settle at rest.
                for _ in 0..16 {
                    self.cycle(PERIODS_PER_CYCLE)?;
                }
                return self.at_rest();
            }
        }
        Err("the drive did not reach operation enabled with the axis running")
    }

    fn pds(&self) -> PdsState {
        self.setup.core.app().pds_state()
    }

    /// The axis runs at rest on the start position and the drive is enabled without a fault.
    fn at_rest(&self) -> Result<(), &'static str> {
        let fb = LINK.feedback();
        let ok = self.pds() == PdsState::OperationEnabled
            && fb.state == AxisState::Running
            && fb.position == POSITION
            && fb.following_error == 0;
        ok.then_some(())
            .ok_or("the enabled axis is not at rest on the start position")
    }

    /// 606Bh velocity demand value, increments/s, as an upload reads it (no TxPDO carries
    /// it: the drive writes it for the upload).
    fn velocity_demand(&mut self) -> Option<i32> {
        let object = PROFILE.od.object(VELOCITY_DEMAND_VALUE)?;
        let (app, ram) = self.setup.core.application();
        app.before_upload(ram, object);
        read::<4>(ram, axis_vars()?.velocity_demand_value).map(i32::from_le_bytes)
    }

    /// The statusword 6041h.
    fn statusword(&mut self) -> Option<u16> {
        let (_, ram) = self.setup.core.application();
        read::<2>(ram, axis_vars()?.statusword).map(u16::from_le_bytes)
    }
}

/// The cost of the SYNC0 handler on the core in `snapshot`'s state with the outputs in the ESC
/// image: (restore + handler) − restore ([`Harness::measure_from`]).
fn cost_from(
    h: &mut Harness,
    name: &str,
    snapshot: &DriveCore<RAM_SIZE>,
    setup: &mut Setup,
) -> Option<u32> {
    // The next SYNC0 (the snapshot's cycle runs again after the measurement).
    let now_ns = setup.now_ns.saturating_add(u64::from(DC_CYCLE_NS));
    let Setup { core, esc, .. } = setup;
    h.measure_from(name, snapshot, core, |core| {
        let _ = on_sync0(core, esc, black_box(now_ns));
    })
}

/// Measures both modes.
pub fn run(h: &mut Harness) {
    let Some(mut bench) = h.ready(
        "sync0-handler-csp",
        Bench::new().and_then(|mut b| b.enable().map(|()| b)),
    ) else {
        return;
    };
    csp_at_rest(h, &mut bench);
    if let Err(reason) = profile_position_move(h, &mut bench) {
        h.fail(PP_NAME, format_args!("{reason}"));
    }
}

/// CSP at rest: every cycle the same (the target equals the actual position).
fn csp_at_rest(h: &mut Harness, bench: &mut Bench) {
    const NAME: &str = "sync0-handler-csp";
    let Setup {
        core, esc, now_ns, ..
    } = &mut bench.setup;
    h.bench(
        NAME,
        Some(SYNC0_HANDLER_BUDGET),
        format_args!(
            "on_sync0 in OP in DC mode (SYNC0 every {} µs) with the axis attached, CSP at rest: \
             SYNC0 supervision, SM2 read + unpack, CiA402 + CSP set-point + axis handoff \
             (feedback read, command publish), pack + SM3 write (default mapping, PDI bus \
             time excluded)",
            DC_CYCLE_NS / 1000
        ),
        &mut || {
            *now_ns += u64::from(DC_CYCLE_NS);
            let _ = on_sync0(core, esc, black_box(*now_ns));
        },
    );
    if bench.at_rest().is_err() {
        h.fail(NAME, format_args!("the measured cycles changed the drive"));
    }
    bench.setup.record_transfers(h, NAME);
}

/// The kinds of cycle of a profile-position move, in the order a move meets them.
#[derive(Clone, Copy, PartialEq)]
enum Phase {
    Accept,
    Accelerating,
    Cruising,
    ChangeImmediately,
    Decelerating,
    Arrived,
}

impl Phase {
    fn label(self) -> &'static str {
        match self {
            Phase::Accept => "set-point accepted from rest",
            Phase::Accelerating => "accelerating",
            Phase::Cruising => "constant velocity",
            Phase::ChangeImmediately => "set-point with bit 5 while moving",
            Phase::Decelerating => "decelerating",
            Phase::Arrived => "holding the target",
        }
    }
}

/// The phases measured so far, in order, and their costs.
struct PhaseCosts {
    phases: [Phase; PHASES],
    len: usize,
    cases: Cases,
}

/// The number of [`Phase`]s.
const PHASES: usize = 6;

impl PhaseCosts {
    fn has(&self, phase: Phase) -> bool {
        self.phases.iter().take(self.len).any(|p| *p == phase)
    }

    /// Measures the next cycle of `bench` as `phase` ([`cost_from`] a snapshot), then runs it.
    fn measure(
        &mut self,
        h: &mut Harness,
        bench: &mut Bench,
        phase: Phase,
    ) -> Result<(), &'static str> {
        let snapshot = bench.setup.core.clone();
        let cost = cost_from(h, PP_NAME, &snapshot, &mut bench.setup).ok_or("not measurable")?;
        let slot = self
            .phases
            .get_mut(self.len)
            .ok_or("a phase measured twice")?;
        *slot = phase;
        self.len += 1;
        h.case(&mut self.cases, phase.label(), cost);
        // On from the snapshot: the measured cycle once more, as the move would run it.
        bench.setup.core = snapshot;
        bench.cycle(0)
    }
}

const PP_NAME: &str = "sync0-handler-pp";

/// A profile-position move, measured in each [`Phase`]; reports the most expensive.
fn profile_position_move(h: &mut Harness, bench: &mut Bench) -> Result<(), &'static str> {
    // Into profile position at rest, no set-point.
    bench.outputs(ENABLE_OPERATION, START, MODE_PROFILE_POSITION)?;
    for _ in 0..4 {
        bench.cycle(0)?;
    }
    bench.at_rest()?;
    let target = START + MOVE_DISTANCE;
    let mut phases = PhaseCosts {
        phases: [Phase::Accept; PHASES],
        len: 0,
        cases: Cases::new(PP_NAME),
    };
    // The rising edge of bit 4 with the target 8 revolutions on.
    bench.outputs(
        ENABLE_OPERATION | NEW_SET_POINT,
        target,
        MODE_PROFILE_POSITION,
    )?;
    bench.setup.record_transfers(h, PP_NAME);
    phases.measure(h, bench, Phase::Accept)?;
    bench.outputs(ENABLE_OPERATION, target, MODE_PROFILE_POSITION)?;
    // 606Bh of the previous cycle: its change tells the phase.
    let mut last = bench.velocity_demand().ok_or("no 606Bh")?;
    let mut cycles = 0;
    loop {
        cycles += 1;
        if cycles > MAX_MOVE_CYCLES {
            return Err("the move did not end");
        }
        let v = bench.velocity_demand().ok_or("no 606Bh")?;
        let phase = match v.cmp(&last) {
            core::cmp::Ordering::Greater => Some(Phase::Accelerating),
            core::cmp::Ordering::Equal if v > 0 => Some(Phase::Cruising),
            core::cmp::Ordering::Less => Some(Phase::Decelerating),
            core::cmp::Ordering::Equal => None,
        };
        last = v;
        match phase {
            Some(p) if !phases.has(p) => phases.measure(h, bench, p)?,
            Some(Phase::Cruising) if !phases.has(Phase::ChangeImmediately) => {
                bench.outputs(
                    ENABLE_OPERATION | NEW_SET_POINT | CHANGE_SET_IMMEDIATELY,
                    CHANGED_TARGET,
                    MODE_PROFILE_POSITION,
                )?;
                phases.measure(h, bench, Phase::ChangeImmediately)?;
                bench.outputs(ENABLE_OPERATION, CHANGED_TARGET, MODE_PROFILE_POSITION)?;
            }
            None if phases.has(Phase::Decelerating) => break,
            _ => bench.cycle(0)?,
        }
    }
    phases.measure(h, bench, Phase::Arrived)?;
    let sw = bench.statusword().ok_or("no 6041h")?;
    if sw & firmware::cia402::pds::statusword::FAULT != 0
        || bench.pds() != PdsState::OperationEnabled
    {
        return Err("the move ended in a fault");
    }
    if phases.len != PHASES {
        return Err("the move did not go through every phase");
    }
    h.report_cases(
        &phases.cases,
        Some(SYNC0_HANDLER_BUDGET),
        format_args!(
            "on_sync0 in OP in DC mode with the axis attached, profile position: the cycles of an \
             8-revolution move, each kind from a snapshot of the core taken just before it \
             (restore + handler − restore)"
        ),
    );
    Ok(())
}
