//! The set-point generators of the CiA402 profile modes, run in every process-data cycle:
//!
//! | mode | the master writes | the drive generates | statusword |
//! |---|---|---|---|
//! | profile position (1) | 607Ah, 6081h, 6083h, 6084h, bits 4/5/6/9 | a trapezoidal move per set-point ([`crate::motor::trajectory`]) | 10 target reached (6067h/6068h), 12 set-point acknowledge |
//! | profile velocity (3) | 60FFh, 6083h, 6084h | a velocity ramp | 10 target reached (606Dh/606Eh), 12 speed zero (606Fh/6070h) |
//! | profile torque (4) | 6071h, 6087h | a torque ramp at the torque slope | 10 target reached (the ramp has arrived) |
//! | homing (6) | 6098h, 6099h, 609Ah, bit 4 | the search of [`cia402::homing`]: velocity ramps on 609Ah, the move to the home found | 10, 12 homing attained, 13 homing error |
//!
//! 607Fh limits the profile velocity and 60FFh. The set-point handshake is
//! [`cia402::profile_position`]; the axis interpolates the generated positions between cycles
//! as it does cyclic synchronous targets. While the axis stops (halt, quick stop, disable) or is
//! off, the generator follows the actual values, so a move resumes from where the motor is;
//! halt keeps the profile-position set-points, everything else drops them.

use cia402::homing::{self, Demand, Homing};
use cia402::limits::SoftwareLimits;
use cia402::modes::{Loop, Mode, SetPoint};
use cia402::pds::statusword;
use cia402::profile_position::{self, ProfilePosition};
use cia402::units::Ratio;
use cia402::window::{self, WindowTimer};

use crate::motor::math;
use crate::motor::trajectory::{self, Limits, SaneLimits, Trajectory};

/// Statusword bit 10 "target reached".
pub const TARGET_REACHED: u16 = 1 << 10;
/// Statusword bit 12 in profile velocity: "speed" (1 = the speed is zero).
pub const SPEED_ZERO: u16 = 1 << 12;
/// The statusword bits the profile modes own (10, 12, 11 for a limited target and, in homing,
/// 13).
pub const MODE_BITS: u16 =
    TARGET_REACHED | SPEED_ZERO | statusword::INTERNAL_LIMIT_ACTIVE | homing::HOMING_ERROR;

/// What the drive read from the objects this cycle, in axis units (increments, increments/s,
/// N·m) except where noted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs {
    /// 6040h.
    pub controlword: u16,
    /// The axis runs the mode's set-point (Operation Enabled, no stop).
    pub running: bool,
    /// The stop under way is a halt (the set-points stay).
    pub halted: bool,
    /// 607Ah as written (user position units).
    pub target_position: i32,
    /// 60FFh.
    pub target_velocity: f32,
    /// 6071h.
    pub target_torque: f32,
    /// 6081h profile velocity, 6083h profile acceleration, 6084h profile deceleration (6081h
    /// limited by 607Fh).
    pub move_limits: SaneLimits,
    /// 607Fh max profile velocity with 6083h/6084h: the ramp of profile velocity.
    pub velocity_limits: SaneLimits,
    /// 6087h torque slope, N·m/s (0 = no ramp).
    pub torque_slope: f32,
    /// The position factor (user units ↔ increments).
    pub position_ratio: Ratio,
    /// 6067h (user units) and 6068h (ms).
    pub position_window: (u32, u16),
    /// 606Dh and 606Eh (increments/s, ms).
    pub velocity_window: (f32, u16),
    /// 606Fh and 6070h (increments/s, ms).
    pub velocity_threshold: (f32, u16),
    /// The axis' actual position and velocity.
    pub actual_position: i64,
    /// Increments/s.
    pub actual_velocity: f32,
    /// What homing takes (`None` in the other modes: the switches' latches are a large
    /// record, made only where it is used).
    pub homing: Option<HomingInputs>,
    /// The software position limits: profile-position targets are limited to them.
    pub position_range: Option<SoftwareLimits>,
}

/// What the homing mode takes in a cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HomingInputs {
    /// What 6098h looks for (`None`: a method the profile does not run).
    pub method: Option<homing::Reference>,
    /// 6099h:01 (search for switch), 6099h:02 (search for zero), 609Ah.
    pub speeds: (f32, f32, f32),
    /// The switches and index pulses (drive positions).
    pub signals: homing::Signals,
    /// The profile's time limit of a run, ms (`None` or 0: none).
    pub timeout_ms: Option<u32>,
    /// The drive function is disabled (a start there follows the profile's rules).
    pub disabled: bool,
    /// The motor is at speed zero.
    pub speed_zero: bool,
    /// The profile's start rules.
    pub rules: homing::Rules,
}

/// The set-point of a profile mode and the statusword bits it sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// What the axis runs.
    pub set_point: SetPoint,
    /// Statusword bits 10 and 12 (within [`MODE_BITS`]).
    pub statusword: u16,
    /// Homing found this home position (drive position) in this cycle.
    pub home_found: Option<i64>,
}

/// The generator state of the profile modes.
#[derive(Clone, Copy, Debug, Default)]
pub struct ProfileModes {
    set_points: ProfilePosition<SaneLimits>,
    trajectory: Trajectory,
    torque: f32,
    /// The mode the generator ran in the last cycle (`None`: it followed the actual values).
    active: Option<Mode>,
    target_window: WindowTimer,
    speed_zero: WindowTimer,
    homing: Homing,
}

/// Whether `mode` is one of the profile modes generated here.
pub fn is_profile_mode(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::ProfilePosition | Mode::ProfileVelocity | Mode::ProfileTorque | Mode::Homing
    )
}

impl ProfileModes {
    /// No set-point, nothing generated.
    pub const fn new() -> Self {
        Self {
            set_points: ProfilePosition::new(),
            trajectory: Trajectory::at(0, 0.0),
            torque: 0.0,
            active: None,
            target_window: WindowTimer::new(),
            speed_zero: WindowTimer::new(),
            homing: Homing::new(),
        }
    }

    /// The motor is being stopped outside the generators (a limit): they follow it, so a move
    /// resumes from where the motor is.
    pub fn follow(&mut self, position: i64, velocity: f32) {
        self.trajectory = Trajectory::at(position, velocity);
    }

    /// The drive positions moved by `delta` (homing made the home read as the home offset):
    /// the generator moves along, so the axis sees no step.
    pub fn rebase(&mut self, delta: i64) {
        let t = self.trajectory;
        self.trajectory = Trajectory::at(t.position().saturating_add(delta), t.velocity());
    }

    /// `mode` was selected; `previous_cw` is the controlword of the cycle before: whether bit
    /// 4 carried into the mode starts a profile-position set-point or a homing run at once
    /// (`start`, a profile's rule) or waits for its next rising edge (CiA402).
    pub fn enter(&mut self, mode: Mode, previous_cw: u16, start: bool) {
        match mode {
            Mode::ProfilePosition => self.set_points.enter(previous_cw, start),
            Mode::Homing => self.homing.enter(previous_cw, start),
            _ => {}
        }
    }

    /// Whether a homing run is under way.
    pub fn homing_running(&self) -> bool {
        self.homing.running()
    }

    /// Whether the last homing run failed (statusword bit 13).
    pub fn homing_failed(&self) -> bool {
        self.homing.failed()
    }

    /// The demand position and velocity (6062h, 606Bh) and torque (6074h in profile torque).
    pub fn demand(&self) -> (i64, f32, f32) {
        (
            self.trajectory.position(),
            self.trajectory.velocity(),
            self.torque,
        )
    }

    /// One cycle of `mode` (a profile mode, [`is_profile_mode`]) with `inputs` and
    /// profile-position `rules`; `dt_s` is the bus cycle.
    pub fn step(
        &mut self,
        mode: Mode,
        inputs: &Inputs,
        rules: profile_position::Rules,
        actual_torque: f32,
        dt_s: f32,
    ) -> Output {
        let ratio = inputs.position_ratio;
        let held_user = ratio.position_from_internal(inputs.actual_position);
        if self.active != Some(mode) || !inputs.running {
            // Take over from the actual values (a mode change, the end of a stop).
            self.trajectory = Trajectory::at(inputs.actual_position, inputs.actual_velocity);
            self.torque = actual_torque;
            if !matches!(mode, Mode::ProfilePosition) || !(inputs.running || inputs.halted) {
                self.set_points.clear(held_user);
            }
            if !matches!(mode, Mode::Homing) {
                self.homing.leave();
            }
        }
        self.active = inputs.running.then_some(mode);
        let acknowledge =
            if matches!(mode, Mode::ProfilePosition) && (inputs.running || inputs.halted) {
                self.set_points.step(
                    inputs.controlword,
                    rules,
                    inputs.target_position,
                    held_user,
                    inputs.move_limits,
                )
            } else {
                self.set_points.observe(inputs.controlword);
                0
            };
        let mut home_found = None;
        let (set_point, statusword) = match mode {
            Mode::ProfileVelocity => self.velocity(inputs, dt_s),
            Mode::ProfileTorque => self.torque_ramp(inputs, dt_s),
            Mode::Homing => {
                let (set_point, statusword, found) = self.home(inputs, dt_s);
                home_found = found;
                // Homing reports "interrupted" and "error" also while halted.
                return Output {
                    set_point,
                    statusword,
                    home_found,
                };
            }
            _ => self.position(inputs, held_user, dt_s, acknowledge),
        };
        Output {
            set_point,
            statusword: if inputs.running { statusword } else { 0 },
            home_found,
        }
    }

    /// Homing: the demand of the search.
    fn home(&mut self, inputs: &Inputs, dt_s: f32) -> (SetPoint, u16, Option<i64>) {
        // Target reached (bit 10) needs the demand at rest and the motor inside the position
        // window 6067h around it (the Σ-V-SD's 0/1/0 "attained, target not reached" until then).
        // The deviation is converted as one difference: the difference of two converted
        // positions would be a whole unit off whenever they straddle a unit boundary, so that a
        // window of 0 (the GHA-E's default) would never be met from one side.
        let lag = inputs.position_ratio.position_from_internal(
            self.trajectory
                .position()
                .saturating_sub(inputs.actual_position),
        );
        let settled = window::inside(lag, inputs.position_window.0);
        // Without its inputs homing runs no method (and says so).
        let h = inputs.homing.unwrap_or_default();
        let out = self.homing.step(&homing::Inputs {
            controlword: inputs.controlword,
            running: inputs.running,
            disabled: h.disabled,
            speed_zero: h.speed_zero,
            rules: h.rules,
            method: h.method,
            signals: h.signals,
            demand_position: self.trajectory.position(),
            demand_at_rest: self.trajectory.velocity() == 0.0,
            at_target: self.trajectory.velocity() == 0.0 && settled,
            timeout_ms: h.timeout_ms,
            cycle_ns: seconds_to_ns(dt_s),
        });
        let (switch_speed, zero_speed, acceleration) = h.speeds;
        let ramp = |velocity| {
            Limits {
                velocity,
                acceleration,
                deceleration: acceleration,
            }
            .sane()
        };
        if inputs.running {
            let t = &mut self.trajectory;
            match out.demand {
                Demand::Hold => {}
                Demand::Search(d) => {
                    t.run_at(f32::from(d) * switch_speed, ramp(switch_speed), dt_s)
                }
                Demand::Creep(d) => t.run_at(f32::from(d) * zero_speed, ramp(zero_speed), dt_s),
                Demand::Stop => t.run_at(0.0, ramp(switch_speed), dt_s),
                Demand::MoveTo(p) => {
                    t.move_to(p, 0.0, ramp(zero_speed), dt_s);
                }
            }
        }
        let set_point = SetPoint {
            control: Loop::Position,
            position: self.trajectory.position(),
            velocity: self.trajectory.velocity(),
            torque: 0.0,
        };
        (set_point, out.statusword, out.home_found)
    }

    /// Profile position: the move of the current set-point; the drive holds `actual_user`
    /// (the actual position in user units).
    fn position(
        &mut self,
        inputs: &Inputs,
        actual_user: i64,
        dt_s: f32,
        acknowledge: u16,
    ) -> (SetPoint, u16) {
        let ratio = inputs.position_ratio;
        // The target (the current move's, else the last one) in increments, limited to the
        // software limits; converted once per cycle (an i128 division with user units).
        let target = self.set_points.target().map(|t| {
            let t = ratio.position_to_internal(t);
            inputs.position_range.map_or((t, false), |l| l.clamp(t))
        });
        // A target beyond a software limit: bit 11 while it stands.
        let limited = target.is_some_and(|(_, limited)| limited);
        if inputs.running {
            // With a move under way, `target` is its target; the move ends at the limit.
            if let (Some(current), Some((target, _))) = (self.set_points.current(), target) {
                let end_speed = self.end_speed(current, ratio);
                if self
                    .trajectory
                    .move_to(target, end_speed, current.profile, dt_s)
                {
                    self.set_points.reached();
                    self.target_window.reset();
                }
            }
        }
        let target_user = self.set_points.target().unwrap_or(actual_user);
        let (window, time) = inputs.position_window;
        let inside = !self.set_points.busy()
            && window::inside(target_user.saturating_sub(actual_user), window);
        let cycle_ns = seconds_to_ns(dt_s);
        let reached = self.target_window.step(inside, time, cycle_ns);
        let set_point = SetPoint {
            control: Loop::Position,
            position: self.trajectory.position(),
            velocity: self.trajectory.velocity(),
            torque: 0.0,
        };
        let limit = if limited {
            statusword::INTERNAL_LIMIT_ACTIVE
        } else {
            0
        };
        (
            set_point,
            acknowledge | limit | if reached { TARGET_REACHED } else { 0 },
        )
    }

    /// The speed at which the current move passes its target into the buffered one: with
    /// change on set-point, the lower of the two profile velocities when the next move goes on
    /// in the same direction; else 0 (stop on the target).
    fn end_speed(&self, current: profile_position::SetPoint<SaneLimits>, ratio: Ratio) -> f32 {
        let Some(next) = self.set_points.buffered().filter(|_| current.pass_through) else {
            return 0.0;
        };
        let here = self.trajectory.position();
        let to = ratio.position_to_internal(current.target);
        let beyond = ratio.position_to_internal(next.target);
        let same_direction = (to.saturating_sub(here) > 0) == (beyond.saturating_sub(to) > 0);
        if same_direction && beyond != to {
            math::min(current.profile.get().velocity, next.profile.get().velocity)
        } else {
            0.0
        }
    }

    /// Profile velocity: the ramp to 60FFh.
    fn velocity(&mut self, inputs: &Inputs, dt_s: f32) -> (SetPoint, u16) {
        if inputs.running {
            self.trajectory
                .run_at(inputs.target_velocity, inputs.velocity_limits, dt_s);
        }
        let cycle_ns = seconds_to_ns(dt_s);
        let (window, window_ms) = inputs.velocity_window;
        let on_target = (inputs.target_velocity - inputs.actual_velocity).abs() <= window;
        let (threshold, threshold_ms) = inputs.velocity_threshold;
        let still = inputs.actual_velocity.abs() <= threshold;
        let mut statusword = 0;
        if self.target_window.step(on_target, window_ms, cycle_ns) {
            statusword |= TARGET_REACHED;
        }
        if self.speed_zero.step(still, threshold_ms, cycle_ns) {
            statusword |= SPEED_ZERO;
        }
        let set_point = SetPoint {
            control: Loop::Velocity,
            position: inputs.actual_position,
            velocity: self.trajectory.velocity(),
            torque: 0.0,
        };
        (set_point, statusword)
    }

    /// Profile torque: the ramp to 6071h at the torque slope.
    fn torque_ramp(&mut self, inputs: &Inputs, dt_s: f32) -> (SetPoint, u16) {
        if inputs.running {
            self.torque = if inputs.torque_slope > 0.0 {
                trajectory::slew(
                    self.torque,
                    inputs.target_torque,
                    inputs.torque_slope * dt_s,
                )
            } else {
                inputs.target_torque
            };
        }
        let set_point = SetPoint {
            control: Loop::Torque,
            position: inputs.actual_position,
            velocity: 0.0,
            torque: self.torque,
        };
        let reached = self.torque == inputs.target_torque;
        (set_point, if reached { TARGET_REACHED } else { 0 })
    }
}

/// A bus cycle in seconds as ns (saturating; the window timers count ns).
fn seconds_to_ns(dt_s: f32) -> u32 {
    (dt_s * 1e9) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use cia402::profile_position::{ABS_REL, CHANGE_SET_IMMEDIATELY, NEW_SET_POINT};

    const DT: f32 = 1e-3;
    const ENABLED: u16 = 0x0F;
    const MOVE: Limits = Limits {
        velocity: 100_000.0,
        acceleration: 1_000_000.0,
        deceleration: 1_000_000.0,
    };
    const CIA402: profile_position::Rules = profile_position::Rules {
        bit6_set_is_absolute: false,
        no_change_on_set_point: false,
        no_buffer: false,
    };

    fn inputs(cw: u16, target: i32) -> Inputs {
        Inputs {
            controlword: cw,
            running: true,
            halted: false,
            target_position: target,
            target_velocity: 0.0,
            target_torque: 0.0,
            move_limits: MOVE.sane(),
            velocity_limits: MOVE.sane(),
            torque_slope: 0.0,
            position_ratio: Ratio::ONE,
            position_window: (10, 2),
            velocity_window: (100.0, 2),
            velocity_threshold: (50.0, 0),
            actual_position: 0,
            actual_velocity: 0.0,
            homing: None,
            position_range: None,
        }
    }

    /// Runs the drive with an ideal axis (actual = demand) for `cycles`; returns the last output.
    fn run(
        m: &mut ProfileModes,
        mode: Mode,
        mut i: Inputs,
        cycles: usize,
        mut each: impl FnMut(&Output),
    ) -> (Output, Inputs) {
        let mut out = None;
        for _ in 0..cycles {
            let o = m.step(mode, &i, CIA402, 0.0, DT);
            each(&o);
            i.actual_position = o.set_point.position;
            i.actual_velocity = o.set_point.velocity;
            out = Some(o);
        }
        (out.unwrap(), i)
    }

    #[test]
    fn a_profile_position_move_reaches_its_target_then_reports_target_reached() {
        let mut m = ProfileModes::new();
        let mode = Mode::ProfilePosition;
        let (out, i) = run(
            &mut m,
            mode,
            inputs(ENABLED | NEW_SET_POINT, 20_000),
            1,
            |_| {},
        );
        assert_eq!(out.statusword, profile_position::SET_POINT_ACKNOWLEDGE);
        // 20 000 increments at 100 000/s with 0.1 s ramps: 0.3 s.
        let mut first_reached = None;
        let mut cycle = 0;
        let (out, _) = run(
            &mut m,
            mode,
            Inputs {
                controlword: ENABLED,
                ..i
            },
            400,
            |o| {
                cycle += 1;
                if o.statusword & TARGET_REACHED != 0 && first_reached.is_none() {
                    first_reached = Some((cycle, o.set_point.position));
                }
            },
        );
        assert_eq!(out.set_point.position, 20_000);
        let (at, position) = first_reached.expect("target reached");
        assert_eq!(position, 20_000);
        assert!((299..=304).contains(&at), "reached after {at} cycles");
    }

    #[test]
    fn halt_keeps_the_move_and_a_quick_stop_drops_it() {
        let mut m = ProfileModes::new();
        let mode = Mode::ProfilePosition;
        let (_, i) = run(
            &mut m,
            mode,
            inputs(ENABLED | NEW_SET_POINT, 50_000),
            50,
            |_| {},
        );
        let halted = Inputs {
            controlword: ENABLED | 0x100,
            running: false,
            halted: true,
            ..i
        };
        let (out, i) = run(&mut m, mode, halted, 5, |_| {});
        assert_eq!(out.statusword, 0, "the device reports bit 10 under halt");
        let (out, _) = run(
            &mut m,
            mode,
            Inputs {
                controlword: ENABLED,
                running: true,
                halted: false,
                ..i
            },
            1000,
            |_| {},
        );
        assert_eq!(out.set_point.position, 50_000, "resumed after the halt");

        let mut m = ProfileModes::new();
        let (_, i) = run(
            &mut m,
            mode,
            inputs(ENABLED | NEW_SET_POINT, 50_000),
            50,
            |_| {},
        );
        let stopped = Inputs {
            controlword: 0x0B,
            running: false,
            ..i
        };
        let (_, i) = run(&mut m, mode, stopped, 5, |_| {});
        let held = i.actual_position;
        let (out, _) = run(
            &mut m,
            mode,
            Inputs {
                controlword: ENABLED,
                running: true,
                ..i
            },
            1000,
            |_| {},
        );
        assert_eq!(
            out.set_point.position, held,
            "the quick stop dropped the set-point"
        );
    }

    #[test]
    fn a_set_point_on_enable_is_an_edge_against_the_disabled_cycles() {
        let mode = Mode::ProfilePosition;
        let disabled = |cw, i: Inputs| Inputs {
            controlword: cw,
            running: false,
            ..i
        };
        let enabled = |i: Inputs, target| Inputs {
            actual_position: i.actual_position,
            ..inputs(ENABLED | NEW_SET_POINT, target)
        };
        // Bit 4 high when the drive was disabled, low while disabled, high with the enable:
        // a rising edge (CiA402), so the set-point is taken and the move made.
        let mut m = ProfileModes::new();
        let (_, i) = run(&mut m, mode, inputs(ENABLED | NEW_SET_POINT, 0), 5, |_| {});
        let (_, i) = run(&mut m, mode, disabled(0x06, i), 5, |_| {});
        let (out, _) = run(&mut m, mode, enabled(i, 5_000), 400, |_| {});
        assert_eq!(out.set_point.position, 5_000, "taken on the enable");
        // Bit 4 held high through the disabled cycles: no edge, the drive holds.
        let mut m = ProfileModes::new();
        let (_, i) = run(&mut m, mode, inputs(ENABLED | NEW_SET_POINT, 0), 5, |_| {});
        let (_, i) = run(&mut m, mode, disabled(0x07 | NEW_SET_POINT, i), 5, |_| {});
        let (out, _) = run(&mut m, mode, enabled(i, 5_000), 400, |_| {});
        assert_eq!(out.set_point.position, 0, "no edge, nothing taken");
    }

    #[test]
    fn homing_target_reached_compares_the_deviation_in_user_units() {
        // 13 increments per unit, window 0 (the GHA-E's default): the deviation rounds to the
        // nearest unit, as 6064h does, so the motor up to six increments (less than half a
        // unit) off a home on a unit boundary has reached it (6064h reads the home); seven or
        // a whole unit off, it has not.
        let home = 13 * 1000;
        let homing = |actual_position| Inputs {
            controlword: ENABLED | homing::HOMING_START,
            position_ratio: Ratio::new(13, 1),
            position_window: (0, 0),
            actual_position,
            homing: Some(HomingInputs {
                method: homing::method(37),
                speeds: (1000.0, 100.0, 10_000.0),
                signals: homing::Signals::default(),
                timeout_ms: None,
                ..HomingInputs::default()
            }),
            ..inputs(ENABLED, 0)
        };
        let done = homing::HOMING_ATTAINED | TARGET_REACHED;
        for (actual, reached) in [
            (home - 6, true),
            (home + 6, true),
            (home + 7, false),
            (home - 13, false),
        ] {
            let mut m = ProfileModes::new();
            // Take over at the home, then start homing on the current position.
            m.step(Mode::Homing, &homing(home), CIA402, 0.0, DT);
            let i = Inputs {
                actual_position: actual,
                ..homing(home)
            };
            let out = m.step(Mode::Homing, &i, CIA402, 0.0, DT);
            assert_eq!(out.set_point.position, home);
            let expected = if reached {
                done
            } else {
                homing::HOMING_ATTAINED
            };
            assert_eq!(out.statusword & done, expected, "actual {actual}");
        }
    }

    #[test]
    fn relative_set_points_accumulate_in_user_units_without_drift() {
        // 3 increments per user unit; 1000 relative moves of 7 units end at 21 000 increments.
        let mut m = ProfileModes::new();
        let mode = Mode::ProfilePosition;
        let mut i = Inputs {
            position_ratio: Ratio::new(3, 1),
            ..inputs(ENABLED, 7)
        };
        for _ in 0..1000 {
            i.controlword = ENABLED | ABS_REL | CHANGE_SET_IMMEDIATELY | NEW_SET_POINT;
            (_, i) = run(&mut m, mode, i, 1, |_| {});
            i.controlword = ENABLED | ABS_REL | CHANGE_SET_IMMEDIATELY;
            (_, i) = run(&mut m, mode, i, 1, |_| {});
        }
        let (out, _) = run(&mut m, mode, i, 2000, |_| {});
        assert_eq!(out.set_point.position, 21_000);
    }

    #[test]
    fn profile_velocity_ramps_and_reports_target_reached_and_speed_zero() {
        let mut m = ProfileModes::new();
        let mode = Mode::ProfileVelocity;
        let mut i = inputs(ENABLED, 0);
        let (out, _) = run(&mut m, mode, i, 3, |_| {});
        assert_eq!(
            out.statusword,
            TARGET_REACHED | SPEED_ZERO,
            "at rest, target 0"
        );
        i.target_velocity = 50_000.0;
        let mut cycles_to_target = 0;
        let (out, i) = run(&mut m, mode, i, 100, |o| {
            if o.statusword & TARGET_REACHED == 0 {
                cycles_to_target += 1;
            }
        });
        assert_eq!(out.set_point.velocity, 50_000.0);
        assert_eq!(out.set_point.control, Loop::Velocity);
        assert_eq!(out.statusword, TARGET_REACHED);
        // 50 ms ramp, then 2 ms window time (the window of 100 opens 0.1 ms before the end).
        assert!((50..=53).contains(&cycles_to_target), "{cycles_to_target}");
        let limited = Inputs {
            target_velocity: 1e9,
            ..i
        };
        let (out, _) = run(&mut m, mode, limited, 200, |_| {});
        assert_eq!(out.set_point.velocity, MOVE.velocity, "607Fh limits 60FFh");
    }

    #[test]
    fn profile_torque_ramps_at_the_slope() {
        let mut m = ProfileModes::new();
        let i = Inputs {
            target_torque: 1.0,
            torque_slope: 10.0,
            ..inputs(ENABLED, 0)
        };
        let (out, _) = run(&mut m, Mode::ProfileTorque, i, 50, |_| {});
        assert!((out.set_point.torque - 0.5).abs() < 1e-4);
        assert_eq!(out.statusword, 0);
        let (out, _) = run(&mut m, Mode::ProfileTorque, i, 51, |_| {});
        assert_eq!(
            (out.set_point.torque, out.statusword),
            (1.0, TARGET_REACHED)
        );
        let step = Inputs {
            torque_slope: 0.0,
            target_torque: -2.0,
            ..i
        };
        let (out, _) = run(&mut m, Mode::ProfileTorque, step, 1, |_| {});
        assert_eq!(out.set_point.torque, -2.0, "slope 0: no ramp");
    }
}
