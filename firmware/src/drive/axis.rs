//! One axis of the drive: its CiA402 device on the axis' objects (OD RAM offsets of
//! [`AppVars`]), and the exchange with its motor's control interrupt.
//!
//! - with a motor attached ([`Drive::attach_axis`](super::Drive::attach_axis)): the set-point
//!   of the mode (CSP 607Ah, CSV 60FFh, CST 6071h, the profile modes, identification) goes to
//!   the control interrupt through its [`AxisLink`], the actual values (6064h, 606Ch, 6077h)
//!   come back from it, and a motor fault becomes a CiA402 fault with the profile's 603Fh code
//!   for it;
//! - without one (a board with no power stage, the benchmarks): an ideal axis whose position
//!   actual value follows the target position while operation is enabled.
//!
//! Units at this boundary come from [`cia402::units`]: positions in increments (the 32-bit
//! objects wrap; the axis works on 64-bit positions), velocities in increments/s, torques in ‰
//! of the motor rated torque 6076h (mN·m).

use cia402::device::{Device, DeviceRules, Motion};
use cia402::faults::FaultReport;
use cia402::homing;
use cia402::interpolated_position;
use cia402::limits::{self, Blocked};
use cia402::mode_status::{self, ModeStatus, Shows};
use cia402::modes::{self, Mode, Targets};
use cia402::outputs;
use cia402::pds::{controlword, statusword, PdsState};
use cia402::stop::Deceleration;
use cia402::touch_probe::{self, Bit7, TouchProbes};
use cia402::units::{self, Polarity};
use cia402::window::{self, WindowTimer};

use ethercat_slave::od::index::{sm_parameter::SUB_SYNC_TYPE, SM_OUTPUT_PARAMETER};
use ethercat_slave::slave::SyncMode;

use super::ram::{ram_offset, read_bytes, read_i32, read_u16, read_u32, write_bytes, write_u16};
use super::settings::{self, live_groups, Groups, GroupsByOffset, Settings, FOLLOWING_ERROR_OFF};
use crate::adjust::service::Refusal;
use crate::adjust::Action;
use crate::alarm_log::{self, next_in_ring, AlarmTable, Conditions, Warning, WarningInputs};
use crate::motion::{self, HomingInputs, ProfileModes};
use crate::motor::axis::{
    AxisCommand, AxisFeedback, AxisLink, AxisState, ControlMode, MotorModel, Withheld,
};
use crate::motor::capture::{Captures, Latch, SwitchCapture, Switches};
use crate::motor::math;
use crate::motor::servo::EncoderSpec;
use crate::motor::trajectory::SaneLimits;
use crate::profile::{
    self, AccelerationUnit, AppVars, Cia402Rules, DriveProfile, Factor, Operand,
    ProbeInputAssignment, RatioRange, UnitRatios, MOTOR_FAULT_COUNT,
};
use ethercat_slave::od::{Object, Value};
use ethercat_slave::pdo::PdoPlan;

/// The motor counts as running above this speed and at rest at or below it, rpm: the Σ-V
/// rotation detection level (Pn502, /TGON) default. Neither the adjusting service's "while the
/// servomotor is running" nor CiA402's "standstill" after a stop gives a figure.
const STANDSTILL_RPM: f32 = 20.0;
const SECONDS_PER_MINUTE: f32 = 60.0;
const NS_TO_S: f32 = 1e-9;
/// Statusword bit 13 in the position modes: following error.
const FOLLOWING_ERROR: u16 = 1 << 13;
/// Statusword bit 12 in the cyclic synchronous modes: the drive follows the command value.
const FOLLOWS_COMMAND: u16 = 1 << 12;
/// The EMCY byte of the first byte of the manufacturer-specific field (CiA 301: bytes 3–7).
const EMCY_DATA_FIRST_BYTE: usize = 3;

/// The connection to a motor's control interrupt.
#[derive(Clone)]
pub(super) struct AxisPort {
    pub(super) link: &'static AxisLink,
    /// The motor encoder's increments per revolution (unit factors in rpm).
    pub(super) counts_per_rev: u32,
    /// The encoder gives the position from power-on (absolute): a referenced position.
    absolute: bool,
    /// The axis' trip counter at the last fault raised here.
    trips_seen: u32,
    /// The motor data objects (R, Ld, Lq, J as the objects hold them) last handed to the axis
    /// as a model.
    model_sent: Option<[u32; 4]>,
    /// The results of the finished identification are in the OD.
    results_written: bool,
}

/// No captures seen yet: not a sequence number (they have 31 bits), so the first read copies.
const NO_CAPTURES_SEEN: u32 = u32::MAX;

/// The CiA402 side of one axis.
#[derive(Clone)]
pub struct DriveAxis {
    /// The axis number the profile's EMCY carries (1 = the first axis), at `emcy_axis_byte`.
    number: u8,
    /// Where the axis' CiA402 variables live (the profile's; a reference, so that reading it in
    /// the cycle copies a pointer, not the table).
    vars: &'static AppVars,
    /// 603Fh code and EMCY per motor fault (the profile's `[motor_faults]`).
    fault_codes: &'static [FaultReport; MOTOR_FAULT_COUNT],
    /// The profile's CiA402 rules.
    rules: &'static Cia402Rules,
    /// The EMCY byte (index into the manufacturer field, bytes 3–7) that carries the axis
    /// number, when the profile has one (`[emcy] axis_number_byte`).
    emcy_axis_byte: Option<u8>,
    /// The EMCY code and manufacturer field of the fault the device holds (a motor fault's come
    /// from the profile's alarm; an error the stack raises has its code and no data).
    fault_emcy: (u16, [u8; 5]),
    device: Device,
    pub(super) port: Option<AxisPort>,
    /// The drive runs an adjustment that measures this axis' current offsets.
    pub(super) calibrating_offsets: bool,
    /// The set-point generators of the profile modes.
    profile_modes: ProfileModes,
    /// The touch probes (60B8h–60BDh, 60D5h–60D8h).
    touch_probes: TouchProbes,
    /// The mode of operation the axis runs (6061h): the last supported 6060h value.
    running_mode: u8,
    /// `running_mode` as the drive runs it (decoded once per change, not every cycle).
    mode: Mode,
    /// What statusword bits 10–13 show in `running_mode` where the profile's layout differs
    /// from CiA402's (resolved once per change).
    mode_status: Option<ModeStatus>,
    /// The cyclic position or velocity target inside its window (6067h/6068h, 606Dh/606Eh),
    /// where the profile shows it (statusword bit 10 in the RSE's and SDV3-E's CSP and CSV).
    cyclic_target_timer: WindowTimer,
    /// |606Ch| within 606Fh for 6070h outside profile velocity, where the profile shows it
    /// (the SDV3-E's CSV bit 11).
    speed_zero_timer: WindowTimer,
    /// The slave runs the cycle in sync (OP on SYNC0 without sync errors).
    pub(super) in_sync: bool,
    /// The profile shows the synchronisation in a statusword bit (the SDV3-E's "successful
    /// synchronization": the master's outputs of each cycle count).
    shows_synchronisation: bool,
    /// A homing run has completed since power-on (`Cia402Rules::home_found_statusword`).
    homed: bool,
    /// How long the following error has been outside 6065h (statusword bit 13).
    following_error_timer: WindowTimer,
    /// Drive position − axis position, increments: 0 at power-on, set by homing so that the
    /// home position reads as the home offset 607Ch (and moved with 607Ch where the profile
    /// adds it to every position). Every position of the objects and of the
    /// profile modes is a drive position; the axis works on encoder positions.
    position_shift: i64,
    /// The part of `position_shift` that is the home offset 607Ch (increments) where the
    /// profile adds it to every position (`Cia402Rules::home_offset_added`, or
    /// `home_offset_added_absolute` with an absolute encoder); 0 otherwise.
    home_offset_shift: i64,
    /// 607Ch as it was at power-on (`Cia402Rules::home_offset_added_absolute`).
    home_offset_at_power_on: i32,
    /// Where the slave shows its synchronisation (1C32h:01 sync type), to tell a SYNC0 cycle
    /// from a free-run one.
    sync_type_at: Option<u16>,
    /// The position set-point handed to the axis in the last cycle (increments, drive frame;
    /// the actual position while the axis does not run the mode's set-point): the reference of
    /// the interpolation speed guard (`Cia402Rules::max_interpolation_speed`).
    position_demand: i64,
    /// The failed homing run has raised the profile's alarm (`Cia402Rules::homing_error_alarm`).
    homing_failure_raised: bool,
    /// 60B8h as last seen (a write that enables a probe on an unassigned input is an error,
    /// `Cia402Rules::touch_probe_inputs`).
    probe_function_seen: u16,
    /// The sequence number of the axis' captures the touch probes last stepped with
    /// ([`NO_CAPTURES_SEEN`] before the first, and after an axis is attached).
    captures_seen: u32,
    /// 60BAh–60BDh hold positions converted with unit factors or a polarity no longer in force.
    probe_positions_stale: bool,
    /// Interpolated position: how long the axis has been inside the position window of the
    /// unchanged set-point (statusword bit 10).
    ip_target_timer: WindowTimer,
    /// Interpolated position: the set-point of the previous cycle.
    ip_last_set_point: Option<i64>,
    /// The polarity 607Eh in force (taken while the power stage is off).
    polarity: Polarity,
    /// The digital output levels of this cycle (60FEh layout, [`outputs`]).
    output_levels: u32,
    /// The profile's alarms (numbers, resettable).
    alarm_table: &'static AlarmTable,
    /// The alarm number of the fault the device holds, if the profile lists it.
    fault_number: Option<u16>,
    /// What the axis did in the last cycles, for an alarm record.
    recent: Recent,
    /// The unit factors in force where the profile makes them take effect on a command (the
    /// Σ-V-SD's 2300h, `AppVars::units_apply`): read at power-on and on the command.
    latched_units: Option<UnitRatios>,
    /// The unit conversions in force (rebuilt only when [`Groups::UNITS`] is due: a factor's
    /// object may have changed).
    units_cache: Option<UnitRatios>,
    /// The values of [`Shown`] a TxPDO carries: the cycle writes these, an upload the others
    /// ([`Self::before_upload`]).
    carried: Shown,
    /// The OD RAM offsets of the values of [`Shown`] ([`Shown::places`]).
    shown_places: [u16; Shown::COUNT],
    /// The settings (option codes, limits, ramps, windows...) in drive units.
    settings: Settings,
    /// The setting groups to read again in the next cycle (their objects were written).
    settings_due: Groups,
    /// Which setting groups read an OD RAM offset (of `vars`).
    setting_offsets: GroupsByOffset,
    /// The setting groups the RxPDO mapping writes: read again in a cycle whose outputs
    /// changed one ([`Self::mapped_settings_changed`]).
    settings_live: Groups,
    /// Safe torque off holds (the axis' last feedback).
    safe_torque_off: bool,
    /// The torque demand is at its limit (the axis' last feedback).
    torque_limited: bool,
    /// CSP extrapolates over a cycle without new outputs (`Cia402Rules::csp_extrapolation`,
    /// as set at power-on).
    csp_extrapolation: bool,
    /// The software position limits are switched off (`Cia402Rules::software_limits_off`, read
    /// at power-on).
    software_limits_off: bool,
    /// The controlword of the previous cycle (edges of bit 4 across a mode change).
    previous_controlword: u16,
    /// The torque-reached condition (`Cia402Rules::torque_reached`), kept between its levels.
    torque_reached: bool,
    /// The drive announced the active fault (its EMCY and alarm record): a fault raised
    /// anywhere (the cycle, a download's check, power-on) is announced at the next cycle.
    pub(super) fault_announced: bool,
    /// The SYNC0 of this cycle brought no new outputs (`Drive::outputs_missed`).
    outputs_missed: bool,
    /// CSP with extrapolation: the last target taken (increments) and its step from the one
    /// before.
    csp_last: Option<(i64, i64)>,
    /// The profile's warnings.
    warnings: &'static [Warning],
    /// The warning that holds (its place in `warnings`).
    warning: Option<usize>,
}

/// What an alarm record shows of the axis: the last cycle's values, the speed a few ms back,
/// the time the power stage has been on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Recent {
    /// Increments/s (converted to rpm only for a record: the cycle just stores).
    velocity: f32,
    /// What the axis was asked for (also what the demand values show).
    demands: Demands,
    /// The input levels (what 60FDh shows).
    inputs: InputsSeen,
    /// N·m, and the rated torque it is a share of (the demand torque's too).
    torque: f32,
    rated_nm: f32,
    bus_voltage: f32,
    /// Velocities (increments/s) sampled every [`SPEED_SAMPLE_NS`], the newest at
    /// `speeds[newest]`.
    speeds: [f32; SPEED_SAMPLES],
    newest: usize,
    since_sample_ns: u32,
    running_ns: u64,
}

/// What the axis was asked for in a cycle, in drive units: the demand values 6062h, 606Bh and
/// 6074h show it in their objects' units ([`DriveAxis::show`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Demands {
    /// The position set-point (increments, drive positions).
    position: i64,
    /// The velocity set-point (increments/s).
    velocity: f32,
    /// The torque demand (N·m).
    torque: f32,
}

/// An OD RAM offset no entry has (the OD RAM is far smaller than 64 KiB).
const NO_PLACE: u16 = u16::MAX;

/// The input levels of a cycle that 60FDh digital inputs shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct InputsSeen {
    switches: Switches,
    withheld: Withheld,
    safe_torque_off_channels: [bool; 2],
}

/// The process values of a cycle that the OD RAM shows only where a TxPDO carries them, or an
/// upload reads them ([`DriveAxis::show`]): converting them to the objects' units in every
/// cycle would be work nobody reads (the position's conversion is one of the costliest steps
/// of a cycle). The actual position 6064h is not among them: the cycle converts it anyway.
/// A set of them: element `i` for the value at index `i` of [`Shown::places`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Shown([bool; Shown::COUNT]);

impl Shown {
    /// 6062h position demand value.
    const POSITION_DEMAND: usize = 0;
    /// 606Bh velocity demand value.
    const VELOCITY_DEMAND: usize = 1;
    /// 6074h torque demand.
    const TORQUE_DEMAND: usize = 2;
    /// 606Ch velocity actual value.
    const VELOCITY_ACTUAL: usize = 3;
    /// 6077h torque actual value.
    const TORQUE_ACTUAL: usize = 4;
    /// 60FDh digital inputs.
    const DIGITAL_INPUTS: usize = 5;
    /// How many values there are.
    const COUNT: usize = 6;
    const NONE: Self = Self([false; Self::COUNT]);
    const ALL: Self = Self([true; Self::COUNT]);

    /// The OD RAM offsets of the values in `vars`, in the order of their indices ([`NO_PLACE`]
    /// for those the profile does not have).
    const fn places(vars: &AppVars) -> [u16; Self::COUNT] {
        const fn or_none(at: Option<u16>) -> u16 {
            match at {
                Some(at) => at,
                None => NO_PLACE,
            }
        }
        [
            or_none(vars.position_demand_value),
            or_none(vars.velocity_demand_value),
            or_none(vars.torque_demand),
            or_none(vars.velocity_actual_value),
            or_none(vars.torque_actual_value),
            or_none(vars.digital_inputs),
        ]
    }

    /// The values whose OD RAM offsets (of [`Self::places`]) satisfy `at`.
    fn where_placed(places: &[u16; Self::COUNT], at: impl Fn(u16) -> bool) -> Self {
        Self(places.map(|place| place != NO_PLACE && at(place)))
    }

    /// Whether the set has the value of index `value` (one of the constants: in range).
    fn has(self, value: usize) -> bool {
        self.0.get(value).copied().unwrap_or(false)
    }
}

/// The record's "speed 5 ms before": samples 1 ms apart, the oldest of them 5 ms back.
const SPEED_SAMPLES: usize = 6;
const SPEED_SAMPLE_NS: u32 = 1_000_000;
const PERCENT: f32 = 100.0;
const NS_PER_S: u64 = 1_000_000_000;

impl DriveAxis {
    /// Axis `index` (0 = the first) of `profile` at power-on, without a motor; `vars` are its
    /// variables (`profile.axes[index]`).
    pub(super) const fn new(
        profile: &'static DriveProfile,
        index: u8,
        vars: &'static AppVars,
    ) -> Self {
        Self {
            number: index.saturating_add(1),
            vars,
            fault_codes: profile.motor_faults,
            rules: &profile.cia402,
            emcy_axis_byte: profile.emcy_axis_number_byte,
            fault_emcy: (0, [0; 5]),
            device: Device::with_rules(DeviceRules {
                stops_end_switched_off: profile.cia402.stops_end_switched_off,
                switch_on_requires_main_power: profile.cia402.switch_on_requires_main_power,
            }),
            port: None,
            calibrating_offsets: false,
            profile_modes: ProfileModes::new(),
            touch_probes: TouchProbes::new(),
            running_mode: 0,
            mode: Mode::from_object(0),
            mode_status: None,
            cyclic_target_timer: WindowTimer::new(),
            speed_zero_timer: WindowTimer::new(),
            in_sync: false,
            shows_synchronisation: mode_status::shown_in(
                profile.cia402.mode_statusword,
                Shows::Synchronised,
            ),
            homed: false,
            following_error_timer: WindowTimer::new(),
            position_shift: 0,
            home_offset_shift: 0,
            home_offset_at_power_on: 0,
            position_demand: 0,
            sync_type_at: ram_offset(&profile.od, SM_OUTPUT_PARAMETER, SUB_SYNC_TYPE),
            probe_function_seen: 0,
            captures_seen: NO_CAPTURES_SEEN,
            probe_positions_stale: true,
            homing_failure_raised: false,
            ip_target_timer: WindowTimer::new(),
            ip_last_set_point: None,
            polarity: Polarity::NONE,
            output_levels: outputs::BRAKE,
            alarm_table: &profile.alarms,
            safe_torque_off: false,
            torque_limited: false,
            csp_extrapolation: false,
            software_limits_off: false,
            previous_controlword: 0,
            torque_reached: false,
            fault_announced: false,
            outputs_missed: false,
            csp_last: None,
            warnings: profile.warnings,
            warning: None,
            latched_units: None,
            units_cache: None,
            carried: Shown::NONE,
            shown_places: Shown::places(vars),
            settings: Settings::UNREAD,
            settings_due: Groups::ALL,
            setting_offsets: GroupsByOffset::of(vars),
            settings_live: Groups::NONE,
            fault_number: None,
            recent: Recent {
                velocity: 0.0,
                demands: Demands {
                    position: 0,
                    velocity: 0.0,
                    torque: 0.0,
                },
                inputs: InputsSeen {
                    switches: Switches {
                        positive_limit: false,
                        negative_limit: false,
                        home: false,
                    },
                    withheld: Withheld::NONE,
                    safe_torque_off_channels: [false; 2],
                },
                torque: 0.0,
                rated_nm: 1.0,
                bus_voltage: 0.0,
                speeds: [0.0; SPEED_SAMPLES],
                newest: 0,
                since_sample_ns: 0,
                running_ns: 0,
            },
        }
    }

    /// Connects the motor's control interrupt: from now on the set-points go to it and the
    /// actual values come from it; the commissioned motor data in `ram` go to it at once (the
    /// parameters were loaded at power-on). The board calls
    /// [`crate::motor::axis::Axis::control_step`] with the same `link`; `encoder` is its
    /// encoder (the resolution for profiles whose velocity unit is in rpm, and whether the
    /// position is referenced from power-on).
    pub(super) fn attach(&mut self, link: &'static AxisLink, encoder: EncoderSpec, ram: &[u8]) {
        let counts_per_rev = encoder.counts_per_rev();
        let mut port = AxisPort {
            link,
            counts_per_rev,
            absolute: encoder.is_absolute(),
            trips_seen: link.feedback().trips,
            model_sent: None,
            results_written: false,
        };
        sync_motor_model(&mut port, self.vars, ram);
        if self.vars.units_apply.is_some() {
            // The factors stored at power-on take effect now (the parameters were loaded).
            self.latched_units = Some(self.vars.unit_ratios(ram, counts_per_rev));
        }
        self.port = Some(port);
        // Another link numbers its captures afresh.
        self.captures_seen = NO_CAPTURES_SEEN;
        // The conversions depend on the motor's encoder: everything is read again.
        self.units_cache = None;
        self.settings_due = Groups::ALL;
        self.refresh_settings(ram);
    }

    /// Reads the settings that are due (their objects were written) and converts them, here
    /// rather than in the next cycle: after a download, at power-on, when a motor is attached
    /// (the ESC-event context; the SYNC0 handler pays only for the settings its outputs map).
    /// Without a motor only the option codes are read; the rest waits for one.
    pub(super) fn refresh_settings(&mut self, ram: &[u8]) {
        let mut due = self.settings_due;
        if due.has(Groups::OPTIONS) {
            let torque_mode = self.runs_torque_mode();
            self.settings
                .refresh_options(ram, self.vars, self.rules, torque_mode);
        }
        let Some(counts_per_rev) = self.port.as_ref().map(|p| p.counts_per_rev) else {
            return;
        };
        let units = self.unit_ratios(ram, counts_per_rev, &mut due);
        self.settings
            .refresh(ram, self.vars, (&units, self.polarity), self.rules, due);
        if due.has(Groups::POSITION_LIMITS) {
            self.position_settings_refreshed(ram, units.position);
        }
        self.settings_due = Groups::NONE;
    }

    /// The position limits' group was read again (the unit factors, the polarity, 607Ch or
    /// 607Dh may have changed): the home offset's shift follows ([`Self::refresh_home_offset`],
    /// whose result this returns), and the touch probes' stored positions are converted again
    /// at their next step.
    fn position_settings_refreshed(&mut self, ram: &[u8], ratio: units::Ratio) -> i64 {
        self.probe_positions_stale = true;
        self.refresh_home_offset(ram, ratio)
    }

    /// Takes the home offset where the profile adds it to every position
    /// (`Cia402Rules::home_offset_added`: 607Ch; `home_offset_added_absolute`: 607Ch at
    /// power-on) into the drive positions' shift, in increments with `ratio` and the polarity
    /// in force, so that every position object (targets, limits, probes, demand, actual)
    /// carries it and a change moves them all at once. Returns how far (increments), for the
    /// caller's copies of drive positions.
    ///
    /// A setting of the position limits' group (which the unit factors, the polarity, an SDO
    /// download or its mapping make due): called then, not in every cycle, and kept out of the
    /// cycle's code.
    #[inline(never)]
    fn refresh_home_offset(&mut self, ram: &[u8], ratio: units::Ratio) -> i64 {
        let absolute = self.port.as_ref().is_some_and(|p| p.absolute);
        let offset = if self.rules.home_offset_added {
            read_i32(ram, self.vars.home_offset).unwrap_or(0)
        } else if self.rules.home_offset_added_absolute && absolute {
            self.home_offset_at_power_on
        } else {
            return 0;
        };
        let wanted = ratio.position_to_internal(i64::from(self.polarity.position(offset)));
        let delta = wanted.saturating_sub(self.home_offset_shift);
        if delta != 0 {
            self.home_offset_shift = wanted;
            self.position_shift = self.position_shift.saturating_add(delta);
            self.position_demand = self.position_demand.saturating_add(delta);
            self.profile_modes.rebase(delta);
        }
        delta
    }

    /// The unit conversions this cycle: the factors in force (latched where the profile makes
    /// them take effect on a command), or the factors' objects read now when `due` has
    /// [`Groups::UNITS`]; a change makes the groups converted with them `due`.
    fn unit_ratios(&mut self, ram: &[u8], counts_per_rev: u32, due: &mut Groups) -> UnitRatios {
        if let (Some(ratios), false) = (self.units_cache, due.has(Groups::UNITS)) {
            return ratios;
        }
        let fresh = self
            .latched_units
            .unwrap_or_else(|| self.vars.unit_ratios(ram, counts_per_rev));
        match self.units_cache {
            // Equal as ratios: the cached one carries the position ratio's reciprocals.
            Some(cached) if cached == fresh => cached,
            _ => {
                let ratios = UnitRatios {
                    position: fresh.position.prepared(),
                    ..fresh
                };
                self.units_cache = Some(ratios);
                *due |= Groups::UNIT_DEPENDENT;
                ratios
            }
        }
    }

    /// [`Self::unit_ratios`] of a cycle: the position ratio and the velocity scale, read from
    /// the cache without copying the rest unless the units are due.
    fn cycle_unit_ratios(
        &mut self,
        ram: &[u8],
        counts_per_rev: u32,
        due: &mut Groups,
    ) -> (units::Ratio, units::Scale) {
        if let (Some(cached), false) = (self.units_cache.as_ref(), due.has(Groups::UNITS)) {
            return (cached.position, cached.velocity);
        }
        let units = self.unit_ratios(ram, counts_per_rev, due);
        (units.position, units.velocity)
    }

    /// An SDO download to `object` was committed: the settings it belongs to are due
    /// ([`Self::refresh_settings`]).
    pub(super) fn downloaded(&mut self, object: &Object) {
        self.settings_due |= self.setting_offsets.of_object(object);
    }

    /// The drive wrote the OD RAM entry at `at` (e.g. a split value's other form): the
    /// settings it belongs to are due (read in the next cycle, or by
    /// [`Self::refresh_settings`]).
    pub(super) fn written(&mut self, at: u16) {
        self.settings_due |= self.setting_offsets.of_offset(at);
    }

    /// The RxPDO mapping is now `outputs`: the settings it maps are read again whenever it
    /// changes them ([`Self::mapped_settings_changed`]).
    pub(super) fn outputs_mapped(&mut self, outputs: &PdoPlan) {
        self.settings_live = live_groups(self.vars, outputs);
    }

    /// The TxPDO mapping is now `inputs`: the values of [`Shown`] it carries are written in
    /// every cycle, the others when an upload reads them ([`Self::before_upload`]).
    pub(super) fn inputs_mapped(&mut self, inputs: &PdoPlan) {
        // A mapped entry is mapped whole: its first byte tells.
        self.carried = Shown::where_placed(&self.shown_places, |at| inputs.writes_ram(at, 1));
    }

    /// An upload is about to read `object`: if it shows one of the values of [`Shown`], they
    /// are written as of the last cycle (with the unit factors, the polarity and the torque
    /// unit in force). Nothing before the unit conversions exist (no motor yet: no cycle wrote
    /// them either).
    pub(super) fn before_upload(&self, ram: &mut [u8], object: &Object) {
        let places = &self.shown_places;
        let shows = object
            .entries
            .iter()
            .any(|e| matches!(e.value, Value::Ram(at) if places.contains(&at)));
        if !shows {
            return;
        }
        if let Some(units) = self.units_cache.as_ref() {
            self.show(ram, Shown::ALL, (&units.position, &units.velocity));
        }
    }

    /// The last cycle's position demand as 6062h shows it: in user units through `ratio`, with
    /// the polarity.
    #[inline(always)]
    fn position_demand_object(&self, ratio: &units::Ratio) -> i32 {
        let position = units::actual_position(self.recent.demands.position, *ratio);
        self.polarity.position(position)
    }

    /// Writes the values `which` of the last cycle ([`Recent`]) in their objects' units:
    /// positions and velocities through the unit conversions (`ratios`) and the polarity, the
    /// torques in ‰ of the torque objects' unit, the digital inputs in the profile's layout.
    #[inline(always)]
    fn show(&self, ram: &mut [u8], which: Shown, ratios: (&units::Ratio, &units::Scale)) {
        let (vars, r, pol) = (self.vars, &self.recent, self.polarity);
        let (position_ratio, velocity_ratio) = ratios;
        let velocity = |v: f32| {
            pol.velocity(units::velocity_object(
                velocity_ratio.velocity_from_internal(v),
            ))
        };
        let rated_nm = self.settings.object_rated_nm;
        let torque = |t: f32| pol.torque(units::torque_to_permille(t, rated_nm));
        if which.has(Shown::POSITION_DEMAND) {
            let position = self.position_demand_object(position_ratio);
            write_bytes(ram, vars.position_demand_value, position.to_le_bytes());
        }
        if which.has(Shown::VELOCITY_DEMAND) {
            let v = velocity(r.demands.velocity);
            write_bytes(ram, vars.velocity_demand_value, v.to_le_bytes());
        }
        if which.has(Shown::TORQUE_DEMAND) {
            let t = torque(r.demands.torque);
            write_bytes(ram, vars.torque_demand, t.to_le_bytes());
        }
        if which.has(Shown::VELOCITY_ACTUAL) {
            let v = velocity(r.velocity);
            write_bytes(ram, vars.velocity_actual_value, v.to_le_bytes());
        }
        if which.has(Shown::TORQUE_ACTUAL) {
            let t = torque(r.torque);
            write_bytes(ram, vars.torque_actual_value, t.to_le_bytes());
        }
        if which.has(Shown::DIGITAL_INPUTS) {
            let inputs = &r.inputs;
            let switches = inputs.switches;
            let levels = limits::digital_inputs(
                limits::InputLevels {
                    negative_limit: switches.negative_limit,
                    positive_limit: switches.positive_limit,
                    home: switches.home,
                    interlock: inputs.withheld.interlocked(),
                },
                limits::InputLayout {
                    limits_swapped: self.rules.digital_inputs_limits_swapped,
                    without_interlock: self.rules.digital_inputs_without_interlock,
                },
            ) | self
                .rules
                .safe_torque_off
                .map_or(0, |s| s.digital_inputs(inputs.safe_torque_off_channels));
            write_bytes(ram, vars.digital_inputs, levels.to_le_bytes());
        }
    }

    /// The settings in drive units, as of their last refresh.
    #[cfg(test)]
    pub(super) fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Whether a setting of this axis reads any of the `len` OD RAM bytes from `at` (the
    /// RxPDO plan watches them).
    pub(super) fn reads_setting_from(&self, at: u16, len: u16) -> bool {
        settings::reads_from(self.vars, at, len)
    }

    /// The RxPDO unpacked for this cycle changed bytes of the mapped settings: they are read
    /// in the cycle (which of them changed is not told: every mapped group).
    pub(super) fn mapped_settings_changed(&mut self) {
        self.settings_due |= self.settings_live;
    }

    /// The parameters were stored with 1010h:`subindex`: where the profile says so, the drive
    /// enters Operation Enabled only after the next power-on.
    pub(super) fn parameters_stored(&mut self, subindex: u8) {
        if self.rules.store_requires_power_cycle.contains(&subindex) {
            self.device.require_power_cycle();
        }
    }

    /// Whether `at` (an OD RAM offset) is this axis' command that makes the unit factors take
    /// effect.
    pub(super) fn is_units_apply(&self, at: u16) -> bool {
        self.vars.units_apply == Some(at)
    }

    /// The unit-factor command was written (the Σ-V-SD's 2300h, §4.5 (2)): 1 in Switch On
    /// Disabled makes the factors' objects as they are now take effect; the command reads 0
    /// again when it is done (anything else, or another state, is not acted on).
    /// Factors outside the profile's ranges (`Cia402Rules::unit_ranges`) do not take effect
    /// and raise its error (the Σ-V-SD's A.A20).
    pub(super) fn apply_units(&mut self, ram: &mut [u8]) {
        let command = read_u32(ram, self.vars.units_apply);
        let ready = self.device.state() == PdsState::SwitchOnDisabled;
        let counts_per_rev = self.port.as_ref().map(|port| port.counts_per_rev);
        if let (Some(1), true, Some(counts_per_rev)) = (command, ready, counts_per_rev) {
            match self.units_out_of_range(ram, counts_per_rev) {
                // The next cycle announces it (EMCY, alarm record).
                Some(error) => self.report_fault(error, ram),
                None => {
                    self.latched_units = Some(self.vars.unit_ratios(ram, counts_per_rev));
                    self.settings_due |= Groups::UNITS;
                }
            }
        }
        write_bytes(ram, self.vars.units_apply, 0u32.to_le_bytes());
    }

    /// The profile's error when a unit factor as its objects hold it now is outside its range
    /// (`Cia402Rules::unit_ranges`), `None` when they are all inside (or have no range).
    fn units_out_of_range(&self, ram: &[u8], counts_per_rev: u32) -> Option<FaultReport> {
        let ranges = self.rules.unit_ranges?;
        let inside = |range: Option<RatioRange>, factor: &Factor| {
            range.is_none_or(|r| {
                r.contains(
                    factor.numerator.value(ram, counts_per_rev),
                    factor.denominator.value(ram, counts_per_rev),
                )
            })
        };
        let acceleration = match &self.vars.acceleration_unit {
            AccelerationUnit::Factor(factor) => inside(ranges.acceleration, factor),
            _ => true,
        };
        let all_inside = inside(ranges.position, &self.vars.position_factor)
            && inside(ranges.velocity, &self.vars.velocity_factor)
            && acceleration
            && inside(ranges.torque, &self.vars.torque_factor);
        (!all_inside).then_some(ranges.error)
    }

    /// The digital output levels the board drives (CiA402 60FEh:01 layout: bit 0 the holding
    /// brake, bits 16–31 the general outputs), from the last cycle: the master's levels where
    /// 60FEh:02 forces them, the brake applied unless the power stage runs.
    pub fn digital_outputs(&self) -> u32 {
        self.output_levels
    }

    /// An EMCY manufacturer field with this axis' number where the profile puts it (e.g. the
    /// Σ-V-SD's byte 7; bytes 3–7 are data 0–4).
    fn with_axis_number(&self, mut data: [u8; 5]) -> [u8; 5] {
        let axis_byte = self
            .emcy_axis_byte
            .and_then(|b| usize::from(b).checked_sub(EMCY_DATA_FIRST_BYTE));
        if let Some(byte) = axis_byte.and_then(|i| data.get_mut(i)) {
            *byte = self.number;
        }
        data
    }

    /// The alarm number of the fault the device holds, if the profile lists the alarm.
    pub(super) fn alarm_number(&self) -> Option<u16> {
        self.fault_number
            .filter(|_| self.device.fault_code().is_some())
    }

    /// The axis' state for an alarm record: the last cycle's values, the speed 5 ms back, the
    /// power stage's on time, with the drive's `power_on_hours`.
    pub(super) fn alarm_conditions(&self, power_on_hours: u32) -> Conditions {
        let r = &self.recent;
        // The sample 5 ms back: the oldest of the ring.
        let oldest = next_in_ring(r.newest, SPEED_SAMPLES);
        let rpm_per_count_s = self
            .port
            .as_ref()
            .map_or(0.0, |p| SECONDS_PER_MINUTE / p.counts_per_rev.max(1) as f32);
        let percent_per_nm = PERCENT / r.rated_nm;
        Conditions {
            power_on_hours,
            running_s: u32::try_from(r.running_ns / NS_PER_S).unwrap_or(u32::MAX),
            speed_rpm: r.velocity * rpm_per_count_s,
            speed_rpm_5ms_before: r.speeds.get(oldest).copied().unwrap_or(0.0) * rpm_per_count_s,
            demand_speed_rpm: r.demands.velocity * rpm_per_count_s,
            demand_torque_percent: r.demands.torque * percent_per_nm,
            torque_percent: r.torque * percent_per_nm,
            bus_voltage: r.bus_voltage,
            // As 6062h shows it (no conversion yet: 0, as the cycle had not run either).
            demand_position: self
                .units_cache
                .as_ref()
                .map_or(0, |u| self.position_demand_object(&u.position)),
            mode: self.running_mode as i8,
        }
    }

    /// The EMCY code and manufacturer field of the fault the device holds (or held last).
    pub(super) fn fault_emcy(&self) -> (u16, [u8; 5]) {
        self.fault_emcy
    }

    /// Whether the axis runs under the master's control: Operation Enabled, or a quick stop
    /// under way or holding.
    pub(super) fn active(&self) -> bool {
        matches!(
            self.device.state(),
            PdsState::OperationEnabled | PdsState::QuickStopActive
        )
    }

    /// CiA402 transition 1 at power-on: Switch On Disabled.
    pub(super) fn power_on(&mut self, ram: &mut [u8]) {
        // The SDV3-E's P4.04 takes effect at power-on.
        self.csp_extrapolation = self
            .rules
            .csp_extrapolation
            .is_some_and(|parameter| parameter.value(ram, 0) == 1);
        // The SDV3-E's P2.25 too.
        self.software_limits_off = self
            .rules
            .software_limits_off
            .is_some_and(|parameter| parameter.value(ram, 0) == 1);
        // The Σ-V-SD's home offset of an absolute encoder, as stored.
        if self.rules.home_offset_added_absolute {
            self.home_offset_at_power_on = read_i32(ram, self.vars.home_offset).unwrap_or(0);
        }
        // The parameters were loaded.
        self.settings_due = Groups::ALL;
        self.refresh_settings(ram);
        let statusword = self.device.initialised();
        self.write_statusword(ram, statusword);
        // Stored unit factors outside the profile's ranges: its error from power-on.
        let counts_per_rev = self.port.as_ref().map(|port| port.counts_per_rev);
        if let Some(error) = counts_per_rev.and_then(|c| self.units_out_of_range(ram, c)) {
            self.report_fault(error, ram);
        }
    }

    /// The PDS state.
    pub fn pds_state(&self) -> PdsState {
        self.device.state()
    }

    /// The CiA402 error code of the active fault (603Fh), `None` when there is none.
    pub fn fault_code(&self) -> Option<u16> {
        self.device.fault_code()
    }

    /// Raises CiA402 error `code`: the drive goes through Fault Reaction Active to Fault
    /// (statusword bit 3), controlword reads 0 (the reaction disables the drive), and 603Fh
    /// holds `code` until a fault reset (controlword bit 7 rising edge) leaves Fault. The next
    /// cycle announces it (EMCY, alarm record).
    pub fn fault(&mut self, code: u16, ram: &mut [u8]) {
        self.report_fault(FaultReport::code(code), ram);
    }

    /// [`Self::fault`] with the profile's report: 603Fh = `report.error_code`, the EMCY the
    /// next cycle announces carries `report.emcy_code` and `report.emcy_data`.
    pub(super) fn report_fault(&mut self, report: FaultReport, ram: &mut [u8]) {
        // The profile's alarm: its number and whether a fault reset clears it.
        let alarm = self.alarm_table.entry(&report);
        self.fault_number = alarm.map(|a| a.number);
        let resettable = alarm.is_none_or(|a| a.resettable);
        self.fault_emcy = (report.emcy_code, self.with_axis_number(report.emcy_data));
        let code = report.error_code;
        write_u16(ram, self.vars.controlword, 0);
        let statusword = self.device.fault_with(code, resettable);
        write_u16(ram, self.vars.error_code, code);
        self.write_statusword(ram, statusword);
    }

    /// Whether CSP extrapolates over cycles without new outputs (the drive then needs to know
    /// which they are).
    pub(super) const fn extrapolates_lost_cycles(&self) -> bool {
        self.csp_extrapolation
    }

    /// Whether the axis runs a torque mode (profile or cyclic synchronous torque).
    fn runs_torque_mode(&self) -> bool {
        matches!(self.mode, Mode::ProfileTorque | Mode::CyclicTorque)
    }

    /// Whether the profile shows the synchronisation in a statusword bit.
    pub(super) const fn shows_synchronisation(&self) -> bool {
        self.shows_synchronisation
    }

    /// The SYNC0 of the next cycle brought no new outputs.
    pub(super) fn outputs_missed(&mut self) {
        self.outputs_missed = true;
    }

    /// The CSP target of this cycle with extrapolation (`active`: CSP runs and extrapolates):
    /// after a cycle without new outputs the last target plus the last step (the SDV3-E's
    /// P4.04 = 1, "update the position command with the last interpolation data increment"),
    /// else `target`.
    fn extrapolated(&mut self, target: Option<i64>, active: bool) -> Option<i64> {
        let missed = core::mem::take(&mut self.outputs_missed);
        let Some(target) = target.filter(|_| active) else {
            self.csp_last = None;
            return target;
        };
        let (next, step) = match self.csp_last {
            Some((last, step)) if missed => (last.saturating_add(step), step),
            Some((last, _)) => (target, target.saturating_sub(last)),
            None => (target, 0),
        };
        self.csp_last = Some((next, step));
        Some(next)
    }

    /// The conditions the mode's statusword layout shows beyond CiA402's (`status.needs`):
    /// synchronisation, speed zero outside profile velocity, target reached in CSP/CSV, the
    /// position command limited by the software limits (`software_limited`) or the actual
    /// position beyond them.
    fn extra_conditions(
        &mut self,
        status: &ModeStatus,
        (mode, motion, software_limited): (Mode, Motion, bool),
        set_point: &modes::SetPoint,
        feedback: &AxisFeedback,
        (cycle_ns, counts_per_rev): (u32, u32),
        (position_ratio, torque_levels): (units::Ratio, Option<TorqueLevels>),
    ) -> mode_status::Conditions {
        let mut extra = mode_status::Conditions::NONE;
        extra.set(
            Shows::Synchronised,
            self.in_sync && status.needs(Shows::Synchronised),
        );
        // Like the profile modes' bits, speed zero and target reached show only while the
        // mode runs (operation enabled).
        let running = matches!(motion, Motion::Run);
        if status.needs(Shows::SpeedZero) {
            let (threshold, time_ms) = self.speed_zero_threshold(counts_per_rev);
            let still = running && feedback.velocity.abs() <= threshold;
            extra.set(
                Shows::SpeedZero,
                self.speed_zero_timer.step(still, time_ms, cycle_ns),
            );
        }
        if let Some(levels) = torque_levels {
            // Hysteresis: on above the "on" level, off below the "off" level, else kept.
            let torque = feedback.torque.abs();
            if !running || torque < levels.off {
                self.torque_reached = false;
            } else if torque > levels.on {
                self.torque_reached = true;
            }
            extra.set(Shows::TorqueReached, self.torque_reached);
        }
        if status.needs(Shows::SoftwareLimit) {
            let beyond = self
                .settings
                .software_limits
                .is_some_and(|l| l.clamp(feedback.position).1);
            extra.set(Shows::SoftwareLimit, software_limited || beyond);
        }
        if status.needs(Shows::TargetReached) {
            let inside = match mode {
                Mode::CyclicPosition => {
                    let deviation = set_point.position.saturating_sub(feedback.position);
                    // In increments where the window converts to them, else the difference
                    // converted (see `motion`'s homing target reached): the same result.
                    let inside = match self.settings.position_window_increments {
                        Some(within) => deviation.unsigned_abs() <= within,
                        None => window::inside(
                            position_ratio.position_from_internal(deviation),
                            self.settings.position_window.0,
                        ),
                    };
                    running && inside
                }
                Mode::CyclicVelocity => {
                    let (window, _) = self.settings.velocity_window;
                    running && (set_point.velocity - feedback.velocity).abs() <= window
                }
                _ => false,
            };
            let time_ms = if matches!(mode, Mode::CyclicVelocity) {
                self.settings.velocity_window.1
            } else {
                self.settings.position_window.1
            };
            extra.set(
                Shows::TargetReached,
                self.cyclic_target_timer.step(inside, time_ms, cycle_ns),
            );
        }
        extra
    }

    /// Speed zero's level (increments/s) and time (ms): 606Fh/6070h, or without 606Fh the
    /// drive's standstill level at once (the Σ-V-SD's PV bit 12 "speed = 0" has no threshold
    /// object; its rotation detection level Pn502 is [`STANDSTILL_RPM`]).
    fn speed_zero_threshold(&self, counts_per_rev: u32) -> (f32, u16) {
        self.settings
            .velocity_threshold
            .unwrap_or((standstill_counts_per_s(counts_per_rev), 0))
    }

    /// Writes the device's `statusword` with the profile's own bits: safe torque off, torque
    /// limit (as of the axis' last feedback).
    fn write_statusword(&self, ram: &mut [u8], statusword: u16) {
        let rules = self.rules;
        let sto = rules
            .safe_torque_off
            .map_or(0, |s| s.statusword.bits(self.safe_torque_off));
        let torque_limit = rules
            .torque_limit_statusword
            .map_or(0, |f| f.bits(self.torque_limited));
        let homed = rules
            .home_found_statusword
            .map_or(0, |f| f.bits(self.homed));
        write_u16(
            ram,
            self.vars.statusword,
            statusword | sto | torque_limit | homed,
        );
    }

    /// One cycle: the CiA402 device on the controlword and the option codes, the mode
    /// display, the axis exchange.
    pub fn step(&mut self, ram: &mut [u8], cycle_ns: u32) {
        let vars = self.vars;
        let mut cw = read_u16(ram, vars.controlword).unwrap_or(0);
        let previous_cw = core::mem::replace(&mut self.previous_controlword, cw);
        // The axis feedback of this cycle, read once (a seqlock read).
        let mut feedback = self.port.as_ref().map(|port| port.link.feedback());
        // The settings the RxPDO changed and any the drive wrote since the last refresh (a
        // split value's other form, written in the cycle).
        let due = self.settings_due;
        self.settings_due = Groups::NONE;
        if due.has(Groups::OPTIONS) {
            let torque_mode = self.runs_torque_mode();
            self.settings
                .refresh_options(ram, vars, self.rules, torque_mode);
        }
        let mut refused_during_homing = false;
        let mode = read_bytes::<1>(ram, vars.modes_of_operation).map(|[requested]| {
            if requested != self.running_mode {
                // A mode 6502h does not list is not taken: the drive keeps the mode it runs
                // (and 6061h shows it).
                let supported = read_u32(ram, vars.supported_drive_modes)
                    .is_none_or(|s| modes::is_supported(requested as i8, s));
                // Profile rule: no mode change while homing runs (the SDV3-E's oPE).
                let locked = self.rules.mode_change_while_homing_error.is_some()
                    && self.profile_modes.homing_running();
                refused_during_homing = locked;
                if supported && !locked {
                    self.running_mode = requested;
                    self.mode = Mode::from_object(requested as i8);
                    // Kept only where the profile's bits differ from CiA402's (the mode's code
                    // sets those).
                    self.mode_status = ModeStatus::of(requested as i8, self.rules.mode_statusword)
                        .filter(ModeStatus::differs);
                    self.cyclic_target_timer.reset();
                    self.speed_zero_timer.reset();
                    self.profile_modes
                        .enter(self.mode, previous_cw, self.rules.mode_entry_starts);
                    if self.rules.torque_modes_stop_at_once {
                        // The stops depend on the mode: resolved again at once.
                        let torque_mode = self.runs_torque_mode();
                        self.settings
                            .refresh_options(ram, vars, self.rules, torque_mode);
                    }
                }
            }
            [self.running_mode]
        });
        if let Some(report) = self
            .rules
            .mode_change_while_homing_error
            .filter(|_| refused_during_homing)
        {
            // The fault counts the controlword as 0 (report_fault writes it so).
            self.report_fault(report, ram);
            cw = 0;
        }
        if let Some(report) = self.rules.enable_without_mode_error {
            // Profile rule: enable operation with no mode selected is refused as an error.
            let no_mode = mode.is_none_or(|[m]| m == 0);
            if no_mode && self.device.requested(cw) == PdsState::OperationEnabled {
                // The fault counts the controlword as 0 (report_fault writes it so).
                self.report_fault(report, ram);
                cw = 0;
            }
        }
        if let Some(f) = &feedback {
            self.device.set_main_power(f.main_power);
            self.device.set_fault_cause_present(f.fault_cause_present);
            // The enable input withholding operation cuts the power stage as safe torque off
            // does (in firmware rather than hardware), so the PDS follows it alike; only the
            // profile's safe-torque-off display (`self.safe_torque_off`) is STO's alone.
            self.device
                .set_safe_torque_off(f.withheld.safe_torque_off() || f.withheld.interlocked());
            self.safe_torque_off = f.withheld.safe_torque_off();
            self.torque_limited = f.current_limited;
        }
        let at_rest = feedback.as_ref().is_none_or(|f| self.at_rest(f));
        let step = self.device.step(cw, self.settings.reactions, at_rest);
        if step.fault_cleared.is_some() {
            write_u16(ram, vars.error_code, 0);
        }
        self.write_statusword(ram, step.statusword);
        if let Some(mode) = mode {
            write_bytes(ram, vars.modes_of_operation_display, mode);
        }
        self.output_levels = outputs::levels(
            read_u32(ram, vars.digital_outputs).unwrap_or(0),
            read_u32(ram, vars.digital_outputs_mask).unwrap_or(0),
            !matches!(step.motion, Motion::Off),
        );
        if let Some(feedback) = feedback.as_mut() {
            // A profile without 6060h runs no mode.
            let mode = if mode.is_some() {
                self.mode
            } else {
                Mode::Other
            };
            self.exchange_with_axis(
                ram,
                (cw, mode, step.motion, step.halted),
                feedback,
                cycle_ns,
                due,
            );
        } else if matches!(step.motion, Motion::Run) {
            if let Some(target) = read_bytes::<4>(ram, vars.target_position) {
                write_bytes(ram, vars.position_actual_value, target);
            }
        }
        if !self.warnings.is_empty() {
            self.update_warning(ram, feedback.as_ref());
        }
    }

    /// The profile's warnings (`[warnings]`): the first whose condition holds sets statusword
    /// bit 7 and, while no fault holds, shows its code in 603Fh (0 again when it ends).
    fn update_warning(&mut self, ram: &mut [u8], feedback: Option<&AxisFeedback>) {
        let vars = self.vars;
        let warning = feedback.and_then(|f| {
            alarm_log::active_warning(
                self.warnings,
                &WarningInputs {
                    motor_load: f.motor_load,
                    drive_load: f.drive_load,
                    positive_limit: f.switches.positive_limit,
                    negative_limit: f.switches.negative_limit,
                    homing_error: self.profile_modes.homing_failed(),
                },
            )
        });
        let report = warning.and_then(|i| self.warnings.get(i)).map(|w| w.report);
        if report.is_some() {
            if let Some(sw) = read_u16(ram, vars.statusword) {
                write_u16(ram, vars.statusword, sw | statusword::WARNING);
            }
        }
        if self.device.fault_code().is_none() {
            let code = report.map_or(0, |r| r.error_code);
            write_u16(ram, vars.error_code, code);
        }
        self.warning = warning;
    }

    /// Which of the profile's warnings holds (its place in `[warnings]`), if any: compared
    /// before and after a cycle to tell a warning beginning or ending.
    pub(super) fn warning(&self) -> Option<usize> {
        self.warning
    }

    /// The EMCY code and manufacturer field of warning `slot` ([`Self::warning`]).
    pub(super) fn warning_emcy(&self, slot: usize) -> Option<(u16, [u8; 5])> {
        self.warnings.get(slot).map(|w| {
            (
                w.report.emcy_code,
                self.with_axis_number(w.report.emcy_data),
            )
        })
    }

    /// Whether the motor is at rest by the axis' `feedback`: no stop ramp under way and the
    /// velocity at or below [`STANDSTILL_RPM`].
    fn at_rest(&self, feedback: &AxisFeedback) -> bool {
        self.port.as_ref().is_none_or(|port| {
            !feedback.stopping
                && feedback.velocity.abs() <= standstill_counts_per_s(port.counts_per_rev)
        })
    }

    /// With the axis' `feedback` of this cycle: raises a new motor fault, hands the set-points
    /// of this cycle (or the stop `motion` asks for) to the axis, and writes its actual values.
    /// The settings of the groups `due` are read first.
    fn exchange_with_axis(
        &mut self,
        ram: &mut [u8],
        (cw, mode, motion, halted): (u16, Mode, Motion, bool),
        feedback: &mut AxisFeedback,
        cycle_ns: u32,
        mut due: Groups,
    ) {
        // The port's constants for the cycle; its bookkeeping is updated in place (short
        // borrows, so that `self.fault` can borrow `self`: not a copy of the port out and back).
        let Some((link, counts_per_rev, absolute, trips_seen)) = self
            .port
            .as_ref()
            .map(|p| (p.link, p.counts_per_rev, p.absolute, p.trips_seen))
        else {
            return;
        };
        let shift = self.position_shift;
        // In drive positions from here on (the caller's later uses take no position).
        feedback.position = feedback.position.saturating_add(shift);
        let vars = self.vars;
        let new_fault = if feedback.trips != trips_seen {
            if let Some(port) = self.port.as_mut() {
                port.trips_seen = feedback.trips;
            }
            feedback
                .fault
                .map(|f| profile::motor_fault_report(self.fault_codes, f))
        } else {
            None
        };
        if let Some(report) = new_fault {
            if !matches!(
                self.device.state(),
                PdsState::Fault | PdsState::FaultReactionActive
            ) {
                self.report_fault(report, ram);
            }
            if feedback.state == AxisState::Faulted {
                // The axis tripped with its gates off (or a fault that cuts them ended a
                // controlled stop): no fault reaction ramp can run. A following error or a
                // thermal fault leaves the motor under control: the reaction decelerates it.
                self.device.power_stage_lost();
            }
        }
        if matches!(motion, Motion::Off) || feedback.state == AxisState::Identified {
            // The axis takes a new model only in these states (not while it runs): checked
            // only then.
            if let Some(port) = self.port.as_mut() {
                sync_motor_model(port, vars, ram);
            }
        }
        let identifying = matches!(mode, Mode::Identification);
        // The results are read only where they are taken (not in every cycle).
        let identified = (feedback.state == AxisState::Identified && identifying)
            .then(|| link.identification())
            .flatten();
        match (feedback.state, identified) {
            (AxisState::Identified, Some(result)) => {
                let written = self
                    .port
                    .as_mut()
                    .map(|p| core::mem::replace(&mut p.results_written, true));
                if written == Some(false) {
                    let object = |x: f32, unit: f32| units::to_object_units(x, unit).to_le_bytes();
                    write_bytes(
                        ram,
                        vars.motor_resistance,
                        object(result.resistance_ohm, units::MICRO),
                    );
                    write_bytes(ram, vars.motor_ld, object(result.ld_h, units::NANO));
                    write_bytes(ram, vars.motor_lq, object(result.lq_h, units::NANO));
                    write_bytes(
                        ram,
                        vars.motor_inertia,
                        object(result.inertia_kgm2, units::NANO),
                    );
                }
                if let Some(sw) = read_u16(ram, vars.statusword) {
                    write_u16(ram, vars.statusword, sw | modes::STATUSWORD_IDENTIFIED);
                }
            }
            (AxisState::Identified, _) => {}
            _ => {
                if let Some(port) = self.port.as_mut() {
                    port.results_written = false;
                }
            }
        }
        // The profile's user units (e.g. 6091h gear ratio): a master's change applies in the
        // next cycle.
        // Only the two ratios every cycle needs are copied out of the cache; the whole set
        // only when settings are due (a copy of `UnitRatios` costs some 20 instructions).
        let (position_ratio, velocity_ratio) =
            self.cycle_unit_ratios(ram, counts_per_rev, &mut due);
        if matches!(motion, Motion::Off) {
            // 607Eh: a new polarity is taken while nothing moves.
            let polarity = read_bytes::<1>(ram, vars.polarity)
                .map_or(Polarity::NONE, |[p]| Polarity::from_object(p));
            if polarity != self.polarity {
                self.polarity = polarity;
                due |= Groups::POSITION_LIMITS;
            }
        }
        let pol = self.polarity;
        if !due.is_empty() {
            let units = self.unit_ratios(ram, counts_per_rev, &mut due);
            self.settings
                .refresh(ram, vars, (&units, pol), self.rules, due);
            if due.has(Groups::POSITION_LIMITS) {
                // In drive positions, as the home offset's shift moved them.
                let delta = self.position_settings_refreshed(ram, units.position);
                feedback.position = feedback.position.saturating_add(delta);
            }
        }
        let rated_nm = self.settings.rated_nm;
        // The torque objects' unit.
        let object_rated_nm = self.settings.object_rated_nm;
        // The GHA-E's 6064h = position from the home + 607Ch, before homing too and at once when
        // 607Ch changes; the Σ-V-SD's with an absolute encoder, 607Ch as it was at power-on.
        // Every object value passes the polarity where it enters or leaves (its own inverse).
        let position_in = |at| read_i32(ram, at).map(|v| pol.position(v));
        let velocity_in = |at| {
            read_i32(ram, at).map_or(0.0, |v| {
                velocity_ratio.velocity_to_internal(pol.velocity(v) as f32)
            })
        };
        let torque_in = |at| {
            let permille = read_bytes::<2>(ram, at).map_or(0, i16::from_le_bytes);
            units::torque_from_permille(pol.torque(permille), object_rated_nm)
        };
        // Only the targets the mode takes are read (each read and conversion costs).
        let used = mode.targets_used();
        // A position target extends to 64 bits around the actual position in user units;
        // converted once, as 6064h shows it too (unless homing moves the reference between).
        let actual = (used.position || used.interpolation).then(|| {
            (
                feedback.position,
                position_ratio.position_from_internal(feedback.position),
            )
        });
        let actual_user = |at: i64| match actual {
            Some((converted, user)) if converted == at => user,
            _ => position_ratio.position_from_internal(at),
        };
        let mut targets = Targets {
            position: used
                .position
                .then(|| position_in(vars.target_position))
                .flatten()
                .map(|t| {
                    // CSP's position offset 60B0h joins the target in user units (one
                    // conversion).
                    let offset = used
                        .position_offset
                        .then(|| position_in(vars.position_offset))
                        .flatten()
                        .map_or(0, i64::from);
                    let actual = actual_user(feedback.position);
                    units::target_position(t, offset, actual, position_ratio)
                }),
            velocity: if used.velocity {
                velocity_in(vars.target_velocity)
            } else {
                0.0
            },
            torque: if used.torque {
                torque_in(vars.target_torque)
            } else {
                0.0
            },
            velocity_offset: if used.velocity_offset {
                velocity_in(vars.velocity_offset)
            } else {
                0.0
            },
            // An INT, or the low half of a DINT (the GHA-E's 60B2h).
            torque_offset: if used.torque_offset {
                torque_in(vars.torque_offset)
            } else {
                0.0
            },
            interpolation: (used.interpolation
                && cw & interpolated_position::ENABLE_INTERPOLATION != 0)
                .then(|| position_in(vars.interpolation_data))
                .flatten()
                .map(|t| {
                    units::target_position(t, 0, actual_user(feedback.position), position_ratio)
                }),
        };
        if self.csp_extrapolation {
            let active = matches!(mode, Mode::CyclicPosition) && matches!(motion, Motion::Run);
            targets.position = self.extrapolated(targets.position, active);
        }
        let mut set_point = modes::set_point(mode, targets, feedback.position);
        let mut mode_statusword = 0;
        let mut target_ignored = false;
        // The position command was limited by 607Dh in this cycle.
        let mut software_limited = false;
        if let Some(limit) = self.rules.max_interpolation_speed {
            let interpolated = matches!(mode, Mode::CyclicPosition | Mode::InterpolatedPosition);
            if interpolated && matches!(motion, Motion::Run) {
                let period_ns = if matches!(mode, Mode::InterpolatedPosition) {
                    self.interpolation_period_ns(ram, cycle_ns)
                } else {
                    cycle_ns
                };
                // Profile rule (the Σ-V-SD §4.7 bit 11): a target further from the last demand
                // than the limit allows in one period is ignored (the demand stays), bit 11.
                let step = set_point.position.abs_diff(self.position_demand);
                if interpolation_too_fast(step, limit, period_ns) {
                    set_point.position = self.position_demand;
                    mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
                    target_ignored = true;
                }
            }
        }
        // Software position limits (607Dh), in drive increments; not while homing looks for
        // its references, not where the profile switched them off or they wait for a
        // referenced position.
        let referenced = self.homed || absolute;
        let limits = self.settings.software_limits.filter(|_| {
            !matches!(mode, Mode::Homing)
                && !self.software_limits_off
                && (referenced || !self.rules.software_limits_need_reference)
        });
        if motion::is_profile_mode(mode) {
            let mut inputs = profile_inputs(
                ram,
                vars,
                (cw, mode, motion),
                &targets,
                feedback,
                &self.settings,
                position_ratio,
            );
            inputs.position_range = limits;
            if matches!(mode, Mode::ProfileVelocity) {
                inputs.velocity_threshold = self.speed_zero_threshold(counts_per_rev);
            }
            inputs.target_position = pol.position(inputs.target_position);
            if matches!(mode, Mode::Homing) {
                // Read only where needed: a seqlock read of the captures.
                let captures = link.captures();
                let (threshold, _) = self.speed_zero_threshold(counts_per_rev);
                if let Some(homing) = inputs.homing.as_mut() {
                    homing.method = read_bytes::<1>(ram, vars.homing_method)
                        .and_then(|[m]| self.rules.homing_reference(m as i8));
                    homing.signals = homing_signals(&captures, self.position_shift);
                    homing.disabled = matches!(motion, Motion::Off);
                    homing.speed_zero = feedback.velocity.abs() <= threshold;
                    homing.rules = self.rules.homing;
                }
            }
            let out = self.profile_modes.step(
                mode,
                &inputs,
                self.rules.profile_position(),
                feedback.torque,
                cycle_ns as f32 * NS_TO_S,
            );
            set_point = out.set_point;
            mode_statusword = out.statusword;
            // Profile position reports a target beyond a software limit on bit 11.
            software_limited = matches!(mode, Mode::ProfilePosition)
                && out.statusword & statusword::INTERNAL_LIMIT_ACTIVE != 0;
            if let Some(home) = out.home_found {
                self.homed = true;
                // The home position reads as the home offset from now on.
                let offset = position_in(vars.home_offset).unwrap_or(0);
                let delta = position_ratio
                    .position_to_internal(i64::from(offset))
                    .saturating_sub(home);
                self.position_shift = self.position_shift.saturating_add(delta);
                self.position_demand = self.position_demand.saturating_add(delta);
                self.profile_modes.rebase(delta);
                set_point.position = set_point.position.saturating_add(delta);
                // This cycle's actual values already read in the new positions.
                feedback.position = feedback.position.saturating_add(delta);
            }
        }
        // The maximum motor speed 6080h limits a velocity set-point (bit 11 while it does).
        if let Some(max) = self
            .settings
            .max_motor_speed
            .filter(|_| set_point.control == modes::Loop::Velocity)
        {
            let limited = math::clamp(set_point.velocity, -max, max);
            if limited != set_point.velocity {
                mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
            }
            set_point.velocity = limited;
        }
        // Torque limits 6072h, 60E0h, 60E1h (‰ of the rated torque): to the speed loop, and a
        // torque set-point limited here.
        // 60E0h limits the positive torque the objects name: with the torque polarity, the
        // drive's negative one.
        let torque_limits = self.settings.torque_limits.map(|(positive, negative)| {
            if pol.torque {
                (negative, positive)
            } else {
                (positive, negative)
            }
        });
        if let Some((positive, negative)) = torque_limits {
            if set_point.control == modes::Loop::Torque {
                let limited = math::clamp(set_point.torque, -negative, positive);
                if limited != set_point.torque {
                    mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
                }
                set_point.torque = limited;
            }
        }
        let mut motion = motion;
        if halted
            && self.rules.torque_modes_halt_zero_torque
            && matches!(mode, Mode::ProfileTorque | Mode::CyclicTorque)
        {
            // Profile rule (the Σ-V-SD §6.4): a halt in the torque modes takes the torque
            // demand to zero, the motor running out under its load, instead of a ramp.
            set_point.torque = 0.0;
            motion = Motion::Run;
        }
        if !matches!(mode, Mode::Homing) {
            if let Some(l) = limits.filter(|_| set_point.control == modes::Loop::Position) {
                // A position target beyond a software limit is limited to it (bit 11).
                let (position, limited) = l.clamp(set_point.position);
                set_point.position = position;
                if limited {
                    mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
                    software_limited = true;
                }
            }
            let switches = feedback.switches;
            let blocked = Blocked::at(
                switches.negative_limit,
                switches.positive_limit,
                limits,
                feedback.position,
            );
            if blocked.any() {
                mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
            }
            let direction = match set_point.control {
                // Only the sign counts.
                modes::Loop::Position => match set_point.position.cmp(&feedback.position) {
                    core::cmp::Ordering::Greater => 1.0,
                    core::cmp::Ordering::Less => -1.0,
                    core::cmp::Ordering::Equal => 0.0,
                },
                modes::Loop::Velocity => set_point.velocity,
                modes::Loop::Torque => set_point.torque,
            };
            if matches!(motion, Motion::Run) && blocked.stops(direction) {
                // Into a limit switch or beyond a software limit: stopped on the quick-stop
                // ramp and held; the profile generators follow the motor.
                motion = Motion::Stop(Deceleration::QuickStopRamp);
                self.profile_modes
                    .follow(feedback.position, feedback.velocity);
            }
        }
        // Following error (6065h/6066h): statusword bit 13 in the position modes; the axis
        // trips its fault on the same limits where the profile makes it one.
        let window = self.settings.following_error_window;
        let timeout_ms = self.settings.following_error_timeout_ms;
        let outside = window.is_some_and(|w| {
            w != FOLLOWING_ERROR_OFF && feedback.following_error.unsigned_abs() > u64::from(w)
        });
        let position_mode = matches!(
            mode,
            Mode::ProfilePosition | Mode::CyclicPosition | Mode::InterpolatedPosition
        );
        let lagging = self.following_error_timer.step(
            outside && matches!(motion, Motion::Run) && position_mode,
            timeout_ms,
            cycle_ns,
        );
        if lagging && position_mode {
            mode_statusword |= FOLLOWING_ERROR;
        }
        let following_error_limits = window.map(|w| {
            if self.rules.following_error_fault {
                (w, timeout_ms)
            } else {
                (FOLLOWING_ERROR_OFF, timeout_ms)
            }
        });
        let loop_mode = match set_point.control {
            modes::Loop::Position => ControlMode::Position,
            modes::Loop::Velocity => ControlMode::Velocity,
            modes::Loop::Torque => ControlMode::Torque,
        };
        // A stop reaction replaces the mode's set-point; the axis runs the ramp.
        let (enable, control_mode, deceleration) = match motion {
            Motion::Run => (true, loop_mode, 0.0),
            Motion::Stop(d) => {
                let deceleration = match d {
                    // CiA402's slow-down ramp is the homing acceleration 609Ah in homing.
                    Deceleration::ProfileRamp
                        if matches!(mode, Mode::Homing) && vars.homing_acceleration.is_some() =>
                    {
                        self.settings.homing_speeds.2
                    }
                    Deceleration::ProfileRamp => self.settings.profile_deceleration,
                    Deceleration::QuickStopRamp => self.settings.quick_stop_deceleration,
                    // At once: the speed loop brakes at the current limit. The DC link is not
                    // regulated by its own (no braking chopper model), so the voltage-limit stop
                    // is the current-limit stop, guarded by the bus over-voltage protection.
                    Deceleration::CurrentLimit
                    | Deceleration::VoltageLimit
                    | Deceleration::Coast => 0.0,
                };
                (true, ControlMode::Stop, deceleration)
            }
            Motion::Off => (false, loop_mode, 0.0),
        };
        link.publish(AxisCommand {
            enable,
            fault_reset: cw & controlword::FAULT_RESET != 0,
            identify: identifying && matches!(motion, Motion::Run),
            calibrate_offsets: self.calibrating_offsets,
            mode: control_mode,
            position: set_point.position.saturating_sub(self.position_shift),
            velocity: set_point.velocity,
            torque: set_point.torque,
            deceleration,
            bus_cycle_ns: if matches!(mode, Mode::InterpolatedPosition) {
                self.interpolation_period(ram, cycle_ns)
            } else {
                cycle_ns
            },
            following_error_limits,
            torque_limits,
        });
        if matches!(mode, Mode::InterpolatedPosition) {
            mode_statusword |=
                self.ip_status(&targets, feedback, motion, (position_ratio, cycle_ns));
        }
        if feedback.current_limited && enable {
            // CiA402 statusword bit 11: the torque demand is at its limit.
            mode_statusword |= statusword::INTERNAL_LIMIT_ACTIVE;
        }
        let cyclic = matches!(
            mode,
            Mode::CyclicPosition | Mode::CyclicVelocity | Mode::CyclicTorque
        );
        // CiA402 bit 12 in the cyclic modes: the master's target is the loop's input (not
        // while a stop or a limit holds the motor, nor when the target was ignored, nor before
        // the loops run: the current-sensor calibration and, with an incremental encoder, the
        // commutation alignment after enable take a while, and a master keeps its target at
        // the actual position until this bit is set).
        let follows = cyclic
            && matches!(motion, Motion::Run)
            && !target_ignored
            && feedback.state == AxisState::Running;
        if follows {
            mode_statusword |= FOLLOWS_COMMAND;
        }
        if let Some(status) = self.mode_status {
            // Read only where a layout shows it (the RSE's PT/CST bit 10).
            let torque_levels = self
                .rules
                .torque_reached
                .filter(|_| status.needs(Shows::TorqueReached))
                .map(|levels| torque_reached_levels(ram, levels, self.settings.rated_nm));
            let extra = self.extra_conditions(
                &status,
                (mode, motion, software_limited),
                &set_point,
                feedback,
                (cycle_ns, counts_per_rev),
                (position_ratio, torque_levels),
            );
            mode_statusword = status.apply(mode_statusword, extra);
        }
        if mode_statusword != 0 {
            if let Some(sw) = read_u16(ram, vars.statusword) {
                write_u16(ram, vars.statusword, sw | mode_statusword);
            }
        }
        if let Some(report) = self.rules.homing_error_alarm {
            // Profile rule: a homing run that fails raises the profile's alarm (the GHA-E's
            // GOH), once per failure.
            let failed = self.profile_modes.homing_failed();
            if failed && !self.homing_failure_raised {
                self.report_fault(report, ram);
            }
            self.homing_failure_raised = failed;
        }
        self.touch_probe(ram, link, position_ratio);
        let actual_object = pol.position(units::position_object(actual_user(feedback.position)));
        write_bytes(ram, vars.position_actual_value, actual_object.to_le_bytes());
        self.position_demand = if matches!(motion, Motion::Run) {
            set_point.position
        } else {
            feedback.position
        };
        // What the axis is asked for this cycle.
        let demands = Demands {
            position: set_point.position,
            velocity: set_point.velocity,
            torque: if set_point.control == modes::Loop::Torque {
                set_point.torque
            } else {
                feedback.torque
            },
        };
        self.remember(feedback, &demands, rated_nm, (enable, cycle_ns));
        // The values a TxPDO carries; an upload shows the others.
        self.show(ram, self.carried, (&position_ratio, &velocity_ratio));
    }

    /// Keeps what an alarm record shows of this cycle (a few stores; the speed ring every ms).
    fn remember(
        &mut self,
        feedback: &AxisFeedback,
        demands: &Demands,
        rated_nm: f32,
        (running, cycle_ns): (bool, u32),
    ) {
        // Stored as they are: converted only when a record is made (`alarm_conditions`) or
        // shown in the OD RAM (`show`).
        let r = &mut self.recent;
        r.velocity = feedback.velocity;
        r.demands = *demands;
        r.inputs = InputsSeen {
            switches: feedback.switches,
            withheld: feedback.withheld,
            safe_torque_off_channels: feedback.safe_torque_off_channels,
        };
        r.torque = feedback.torque;
        r.rated_nm = rated_nm;
        r.bus_voltage = feedback.bus_voltage;
        if running {
            r.running_ns = r.running_ns.saturating_add(u64::from(cycle_ns));
        }
        r.since_sample_ns = r.since_sample_ns.saturating_add(cycle_ns);
        if r.since_sample_ns >= SPEED_SAMPLE_NS {
            r.since_sample_ns = 0;
            r.newest = next_in_ring(r.newest, SPEED_SAMPLES);
            if let Some(s) = r.speeds.get_mut(r.newest) {
                *s = r.velocity;
            }
        }
    }

    /// The period the axis interpolates the set-points of the interpolated position mode over:
    /// the SYNC0 cycle when the slave runs in a DC mode (shown in 60C2h, as the Σ-V-SD does,
    /// §4.11 (2)), else the master's interpolation period 60C2h (the drive's own cycle when
    /// 60C2h holds no valid period).
    fn interpolation_period(&self, ram: &mut [u8], cycle_ns: u32) -> u32 {
        let vars = self.vars;
        if self.synchronised(ram) {
            if let Some((value, index)) = interpolated_position::period_object(cycle_ns) {
                write_bytes(ram, vars.interpolation_time_period, [value]);
                write_bytes(ram, vars.interpolation_time_index, index.to_le_bytes());
            }
        }
        self.interpolation_period_ns(ram, cycle_ns)
    }

    /// Whether the slave runs in a DC mode (1C32h:01).
    fn synchronised(&self, ram: &[u8]) -> bool {
        read_bytes::<1>(ram, self.sync_type_at)
            .is_some_and(|[t]| t == SyncMode::DcSync0 as u8 || t == SyncMode::DcSync1 as u8)
    }

    /// The interpolation period of [`Self::interpolation_period`], without showing it in 60C2h.
    fn interpolation_period_ns(&self, ram: &[u8], cycle_ns: u32) -> u32 {
        let vars = self.vars;
        if self.synchronised(ram) {
            return cycle_ns;
        }
        let value = read_bytes::<1>(ram, vars.interpolation_time_period);
        let index = read_bytes::<1>(ram, vars.interpolation_time_index);
        value
            .zip(index)
            .and_then(|([v], [i])| interpolated_position::period_ns(v, i as i8))
            .unwrap_or(cycle_ns)
    }

    /// Statusword bits 12 (ip mode active: the interpolation is enabled while the axis runs)
    /// and 10 (target reached: the set-point did not change and the motor is inside the
    /// position window 6067h for 6068h, as in profile position) of the interpolated position
    /// mode.
    fn ip_status(
        &mut self,
        targets: &Targets,
        feedback: &AxisFeedback,
        motion: Motion,
        (ratio, cycle_ns): (units::Ratio, u32),
    ) -> u16 {
        let running = matches!(motion, Motion::Run);
        let Some(set_point) = targets.interpolation.filter(|_| running) else {
            self.ip_last_set_point = None;
            self.ip_target_timer.step(false, 0, cycle_ns);
            return 0;
        };
        let (window, time_ms) = self.settings.position_window;
        // In position units, as profile position compares.
        // Two i32 positions: their difference fits an i64.
        let deviation = i64::from(units::actual_position(set_point, ratio))
            .wrapping_sub(i64::from(units::actual_position(feedback.position, ratio)));
        let settled =
            self.ip_last_set_point == Some(set_point) && window::inside(deviation, window);
        self.ip_last_set_point = Some(set_point);
        let reached = self.ip_target_timer.step(settled, time_ms, cycle_ns);
        interpolated_position::IP_MODE_ACTIVE
            | if reached {
                statusword::TARGET_REACHED
            } else {
                0
            }
    }

    /// The touch probes: 60B8h in, 60B9h, the positions 60BAh–60BDh (user units) and the
    /// counters 60D5h–60D8h out. The axis' captures are read only while a probe is in use (or
    /// the profile shows the input level in 60B9h), and copied only when they changed since
    /// the probes last stepped with them.
    fn touch_probe(&mut self, ram: &mut [u8], link: &AxisLink, ratio: units::Ratio) {
        let vars = self.vars;
        let Some(function) = read_u16(ram, vars.touch_probe_function) else {
            return;
        };
        if function != self.probe_function_seen {
            self.probe_function_seen = function;
            if let Some(rule) = self.rules.touch_probe_inputs {
                let defined = function & self.rules.touch_probe.function_bits;
                if unassigned_probe_input(defined, &rule, ram) {
                    self.report_fault(rule.unassigned_error, ram);
                }
            }
        }
        let rules = &self.rules.touch_probe;
        if function == 0 && rules.bit7 != Bit7::InputLevel && !self.touch_probes.enabled() {
            return;
        }
        let homing = self.profile_modes.homing_running();
        let captures = link.captures_if_new(self.captures_seen);
        if let (None, false) = (&captures, self.probe_positions_stale) {
            // No edge and the functions the probes last stepped with: nothing would change.
            if let Some(status) = self.touch_probes.unchanged_status(function, homing, rules) {
                write_u16(ram, vars.touch_probe_status, status);
                return;
            }
        }
        let out = match captures {
            Some((c, sequence)) => {
                self.captures_seen = sequence;
                let shift = self.position_shift;
                let [p1, p2] = &c.probes;
                self.touch_probes.step(
                    &touch_probe::Inputs {
                        function,
                        probes: [
                            shifted_switch_signal(p1, shift),
                            shifted_switch_signal(p2, shift),
                        ],
                        index: shifted_edges(&c.index, shift),
                        homing,
                    },
                    rules,
                )
            }
            // No edge, pulse or level change since the last step: the probes know its inputs.
            None => self.touch_probes.step_unchanged(function, homing, rules),
        };
        write_u16(ram, vars.touch_probe_status, out.status);
        // The stored positions and their counters change only with a store; the positions'
        // objects also with the unit factors or the polarity.
        if !(out.stored || self.probe_positions_stale) {
            return;
        }
        self.probe_positions_stale = false;
        let positions = [
            vars.touch_probe_1_positive,
            vars.touch_probe_1_negative,
            vars.touch_probe_2_positive,
            vars.touch_probe_2_negative,
        ];
        for (at, value) in positions.into_iter().zip(out.values) {
            let object = self.polarity.position(units::actual_position(value, ratio));
            write_bytes(ram, at, object.to_le_bytes());
        }
        let counters = [
            vars.touch_probe_1_positive_count,
            vars.touch_probe_1_negative_count,
            vars.touch_probe_2_positive_count,
            vars.touch_probe_2_negative_count,
        ];
        for (at, count) in counters.into_iter().zip(out.counters) {
            write_u16(ram, at, count);
        }
    }

    /// Puts the outputs the master drives into their safe state (on leaving OP, on a watchdog).
    /// With a motor, the axis is disabled at once (gates off): below SAFEOP no cycle runs that
    /// would tell it. (The slave's entry points never run concurrently with each other, so this
    /// and the cycle never publish at the same time: the link keeps a single writer.)
    /// `cycle_ns` is the bus cycle that was running (the axis keeps its interpolation timing).
    pub fn safe_outputs(&mut self, ram: &mut [u8], cycle_ns: u32) {
        write_u16(ram, self.vars.controlword, 0);
        // 60FEh's safe state: every forced output off, the brake applied.
        write_bytes(ram, self.vars.digital_outputs, outputs::BRAKE.to_le_bytes());
        self.output_levels = outputs::BRAKE;
        let statusword = self.device.outputs_lost();
        self.write_statusword(ram, statusword);
        if let Some(port) = &self.port {
            port.link.publish(AxisCommand {
                enable: false,
                calibrate_offsets: self.calibrating_offsets,
                bus_cycle_ns: cycle_ns,
                ..AxisCommand::default()
            });
        }
    }

    /// Whether adjustment `action` may run on this axis now (the Σ-V-SD's §4.5 (8) "Execution
    /// Conditions"); the axis feedback it was decided on.
    pub(super) fn adjustment_allowed(&self, action: Action) -> Result<AxisFeedback, Refusal> {
        let Some(port) = self.port.as_ref() else {
            return Err(Refusal::NoAxis);
        };
        let feedback = port.link.feedback();
        match action {
            Action::CurrentOffsetCalibration => {
                let gates_off =
                    matches!(feedback.state, AxisState::Disabled | AxisState::Identified);
                let running_counts_per_s = standstill_counts_per_s(port.counts_per_rev);
                if feedback.state == AxisState::Faulted {
                    Err(Refusal::Alarm)
                } else if self.device.operation_enabled() || !gates_off {
                    Err(Refusal::ServoOn)
                } else if !feedback.main_power {
                    Err(Refusal::MainPowerOff)
                } else if feedback.velocity.abs() > running_counts_per_s {
                    Err(Refusal::MotorRunning)
                } else {
                    Ok(feedback)
                }
            }
            // See the Σ-V-SD profile's decision "2310h adjustments": the encoder interface
            // has no multi-turn commands yet.
            Action::MultiTurnReset | Action::MultiTurnLimitSetting => Err(Refusal::NotSupported),
        }
    }

    /// The motor's feedback now (outside the cycle), `None` without a motor.
    pub(super) fn motor_feedback(&self) -> Option<AxisFeedback> {
        self.port.as_ref().map(|port| port.link.feedback())
    }

    /// Asks the motor to measure its current offsets (or stop asking), outside the cycle (in
    /// PREOP no cycle runs; in SAFEOP/OP the cycle repeats it). The slave's entry points never
    /// overlap, so the link keeps a single writer.
    pub(super) fn set_calibrating_offsets(&mut self, calibrate: bool) {
        self.calibrating_offsets = calibrate;
        if let Some(port) = &self.port {
            port.link.publish(AxisCommand {
                enable: false,
                calibrate_offsets: calibrate,
                ..AxisCommand::default()
            });
        }
    }
}

/// What the profile modes take this cycle: for mode `mode` only what it uses (the objects of
/// the other modes are not read: each read costs instructions in the SYNC0 handler), the rest
/// neutral; the limits, ramps and windows from the `settings`.
fn profile_inputs(
    ram: &[u8],
    vars: &AppVars,
    (cw, mode, motion): (u16, Mode, Motion),
    targets: &Targets,
    feedback: &AxisFeedback,
    settings: &Settings,
    position_ratio: units::Ratio,
) -> motion::Inputs {
    let mut inputs = motion::Inputs {
        controlword: cw,
        running: matches!(motion, Motion::Run),
        halted: cw & controlword::HALT != 0 && matches!(motion, Motion::Stop(_)),
        target_position: 0,
        target_velocity: targets.velocity,
        target_torque: targets.torque,
        move_limits: SaneLimits::REST,
        velocity_limits: SaneLimits::REST,
        torque_slope: 0.0,
        position_ratio,
        position_window: (0, 0),
        velocity_window: (0.0, 0),
        velocity_threshold: (0.0, 0),
        actual_position: feedback.position,
        actual_velocity: feedback.velocity,
        homing: None,
        // The drive sets the software limits.
        position_range: None,
    };
    match mode {
        Mode::ProfilePosition => {
            inputs.target_position = read_i32(ram, vars.target_position).unwrap_or(0);
            inputs.move_limits = settings.move_limits;
            inputs.position_window = settings.position_window;
        }
        Mode::ProfileVelocity => {
            inputs.velocity_limits = settings.velocity_limits;
            inputs.velocity_window = settings.velocity_window;
        }
        Mode::ProfileTorque => inputs.torque_slope = settings.torque_slope,
        Mode::Homing => {
            inputs.position_window = settings.position_window;
            // The drive sets the method and the signals in the cycle (it needs the profile's
            // rules and the axis' captures).
            inputs.homing = Some(HomingInputs {
                speeds: settings.homing_speeds,
                timeout_ms: settings.homing_timeout_ms,
                ..HomingInputs::default()
            });
        }
        _ => {}
    }
    inputs
}

/// The levels of the torque-reached condition, N·m (magnitudes).
#[derive(Clone, Copy, Debug, PartialEq)]
struct TorqueLevels {
    /// Set above this.
    on: f32,
    /// Cleared below this.
    off: f32,
}

/// The torque-reached levels from the parameters A, B, C (0.1 % of `rated_nm`): on at A + B,
/// off at A + C.
fn torque_reached_levels(ram: &[u8], [a, b, c]: [Operand; 3], rated_nm: f32) -> TorqueLevels {
    // The parameters are UINTs of at most 32 bits: the sums cannot overflow in f32.
    let permille = |o: Operand| o.value(ram, 0) as f32;
    let nm = |p: f32| units::torque_from_permille_f32(p, rated_nm);
    TorqueLevels {
        on: nm(permille(a) + permille(b)),
        off: nm(permille(a) + permille(c)),
    }
}

/// Whether a set-point step of `step` increments in one interpolation period of `period_ns` is
/// at or above `limit_per_ms` increments per ms (step × 10⁶ ≥ limit × period, saturating: a huge
/// step is too fast); a period of 0 (not known) checks nothing.
fn interpolation_too_fast(step: u64, limit_per_ms: u32, period_ns: u32) -> bool {
    const NS_PER_MS: u64 = 1_000_000;
    period_ns != 0
        && step.saturating_mul(NS_PER_MS)
            >= u64::from(limit_per_ms).saturating_mul(u64::from(period_ns))
}

/// Whether 60B8h `function` enables a probe on its input (source 0 with an edge) while no
/// assignment parameter of `rule` holds that probe's input function.
fn unassigned_probe_input(function: u16, rule: &ProbeInputAssignment, ram: &[u8]) -> bool {
    use touch_probe::function::{ENABLE, FALLING, RISING, SOURCE_MASK};
    let assigned = |f: u32| rule.entries.iter().any(|e| e.value(ram, 0) == f);
    function
        .to_le_bytes()
        .into_iter()
        .zip(rule.functions)
        .any(|(probe, input_function)| {
            let on_input =
                probe & ENABLE != 0 && probe & (RISING | FALLING) != 0 && probe & SOURCE_MASK == 0;
            on_input && !assigned(input_function)
        })
}

/// The axis' switch and index captures as homing sees them, in drive positions (`shift`
/// added to every position).
fn homing_signals(c: &Captures, shift: i64) -> homing::Signals {
    homing::Signals {
        negative_limit: shifted_switch_signal(&c.negative_limit, shift),
        positive_limit: shifted_switch_signal(&c.positive_limit, shift),
        home: shifted_switch_signal(&c.home, shift),
        index: shifted_edges(&c.index, shift),
    }
}

/// A latch of the axis as CiA402 sees it, in drive positions (`shift` added).
fn shifted_edges(l: &Latch, shift: i64) -> homing::Edges {
    homing::Edges {
        count: l.count,
        position: l.position.saturating_add(shift),
    }
}

/// A switch capture of the axis as CiA402 sees it, in drive positions (`shift` added).
fn shifted_switch_signal(s: &SwitchCapture, shift: i64) -> homing::SwitchSignal {
    homing::SwitchSignal {
        level: s.level,
        rising: shifted_edges(&s.rising, shift),
        falling: shifted_edges(&s.falling, shift),
    }
}

/// Hands the commissioned motor data (stored parameters, identification results, SDO writes)
/// to the axis when they changed since the last call; the axis applies them when it is not
/// running.
fn sync_motor_model(port: &mut AxisPort, vars: &AppVars, ram: &[u8]) {
    // Compared as the objects hold them: converted only when they changed.
    let object = |at| read_u32(ram, at).unwrap_or(0);
    let objects = [
        object(vars.motor_resistance),
        object(vars.motor_ld),
        object(vars.motor_lq),
        object(vars.motor_inertia),
    ];
    if matches!(port.model_sent, Some(sent) if profile::words_equal(&sent, &objects)) {
        return;
    }
    let [resistance, ld, lq, inertia] = objects;
    port.link.set_motor_model(MotorModel {
        resistance_ohm: resistance as f32 * units::MICRO,
        ld_h: ld as f32 * units::NANO,
        lq_h: lq as f32 * units::NANO,
        inertia_kgm2: inertia as f32 * units::NANO,
    });
    port.model_sent = Some(objects);
}

/// [`STANDSTILL_RPM`] in increments/s for an encoder of `counts_per_rev`.
fn standstill_counts_per_s(counts_per_rev: u32) -> f32 {
    STANDSTILL_RPM / SECONDS_PER_MINUTE * counts_per_rev as f32
}

#[cfg(test)]
mod tests {
    use super::{interpolation_too_fast, DriveAxis};
    use crate::profiles::standard::PROFILE;

    #[test]
    fn csp_extrapolation_goes_on_with_the_last_step_over_missed_cycles() {
        let mut axis = DriveAxis::new(&PROFILE, 0, &PROFILE.axes[0]);
        assert_eq!(axis.extrapolated(Some(0), true), Some(0));
        assert_eq!(axis.extrapolated(Some(10), true), Some(10));
        // No new outputs: the image (and so the target) repeats 10; the command goes on.
        axis.outputs_missed();
        assert_eq!(axis.extrapolated(Some(10), true), Some(20));
        axis.outputs_missed();
        assert_eq!(axis.extrapolated(Some(10), true), Some(30));
        // New outputs again: the master's target, the step from the last command.
        assert_eq!(axis.extrapolated(Some(45), true), Some(45));
        axis.outputs_missed();
        assert_eq!(axis.extrapolated(Some(45), true), Some(60));
        // Not running CSP: the target as it is, and no history to go on from afterwards.
        assert_eq!(axis.extrapolated(Some(7), false), Some(7));
        axis.outputs_missed();
        assert_eq!(axis.extrapolated(Some(7), true), Some(7));
        assert_eq!(axis.extrapolated(None, true), None);
    }

    #[test]
    fn the_interpolation_speed_guard_is_at_or_above_the_limit() {
        // Σ-V-SD §4.7: allowed below 4194304 inc/ms; a 1 ms period allows 4194303 increments.
        const LIMIT: u32 = 4_194_304;
        assert!(!interpolation_too_fast(4_194_303, LIMIT, 1_000_000));
        assert!(interpolation_too_fast(4_194_304, LIMIT, 1_000_000));
        // 125 µs: an eighth of that.
        assert!(!interpolation_too_fast(524_287, LIMIT, 125_000));
        assert!(interpolation_too_fast(524_288, LIMIT, 125_000));
        // Huge steps saturate to "too fast"; an unknown period checks nothing.
        assert!(interpolation_too_fast(u64::MAX, LIMIT, 1));
        assert!(!interpolation_too_fast(u64::MAX, LIMIT, 0));
    }
}
