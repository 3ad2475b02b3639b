//! The drive application: what the slave stack runs in every process-data cycle. It binds the
//! objects of the profile (OD RAM, laid out by od-gen) to the CiA402 device of each axis and to
//! the axis' motor.
//!
//! | module | what |
//! |---|---|
//! | [`axis`] | [`DriveAxis`]: one axis' CiA402 device on its objects, and the exchange with its motor's control interrupt |
//! | `ram` | the reads and writes of the variables in the OD RAM |
//! | `settings` | the parameters the cycle uses (limits, ramps, windows...) in drive units, read again only when their objects may have changed |
//!
//! A profile has one axis or, like the Σ-V-SD for two axes, several in one slave
//! ([`DriveProfile::axes`]): each runs its own state machine, mode, homing, touch probes and
//! faults on its own objects; the errors of the unit (an AL error the stack raises) fault every
//! axis.
//!
//! A profile's adjusting services ([`crate::adjust`], e.g. the Σ-V-SD's 2310h) take their
//! requests from SDO downloads ([`Application::downloaded`]) and are timed in the background
//! ([`Application::background`]), in every EtherCAT state; the adjustments act on the axis
//! the service names.

pub mod axis;
mod ram;
mod settings;

pub use axis::DriveAxis;

use cia402::faults::FaultReport;
use cia402::pds::PdsState;
use ethercat_slave::od::index::STORE_PARAMETERS;
use ethercat_slave::od::{ErrorReport, Object};
use ethercat_slave::pdo::PdoPlan;
use ethercat_slave::slave::{AppEvent, AppEvents, Application};

use crate::adjust::service::{Progress, Refusal};
use crate::adjust::{Action, AdjustingService};
use crate::alarm_log::{AlarmLog, AlarmTable};
use crate::motor::axis::{AxisFeedback, AxisLink, AxisState};
use crate::motor::servo::EncoderSpec;
use crate::profile::Operand;
use crate::profile::{DriveProfile, SplitValue, MAX_AXES};

/// Adjusting-service objects a drive serves (one per axis of the two-axis profiles).
pub const MAX_ADJUSTING_SERVICES: usize = 2;

const NS_PER_MS: u64 = 1_000_000;
const NS_PER_HOUR: u64 = 3_600_000_000_000;

/// An adjustment running on an axis: which service started it and the axis counters then.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RunningAdjustment {
    service: usize,
    /// The axis it runs on (index into the drive's axes).
    axis: usize,
    action: Action,
    offset_calibrations: u32,
    trips: u32,
}

/// The profile has no axis with this index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoSuchAxis(pub usize);

/// The drive application: its axes and the profile's adjusting services.
#[derive(Clone)]
pub struct Drive {
    /// The profile's axes (`None` past its count).
    axes: [Option<DriveAxis>; MAX_AXES],
    /// The profile's adjusting services (`None` past its list).
    adjusting: [Option<AdjustingService>; MAX_ADJUSTING_SERVICES],
    /// The adjustment running on an axis, if any.
    adjustment: Option<RunningAdjustment>,
    /// The profile's alarms and the objects that show them.
    alarm_table: &'static AlarmTable,
    /// The alarm records.
    alarm_log: AlarmLog,
    /// Board time of the last ESC-event round, ns since power-on (the records' power-on time).
    now_ns: u64,
    /// The object dictionary (to find the variable an SDO download wrote).
    od: &'static ethercat_slave::od::Profile,
    /// The profile's split settings and their values `[whole, high, low]` as last seen.
    split_values: &'static [SplitValue],
    split_seen: [[u32; 3]; MAX_SPLIT_VALUES],
    /// Which split settings the master's outputs write (one of their forms is RxPDO-mapped):
    /// only those can change between two SDO downloads, so only those are reconciled every
    /// cycle (`Application::outputs_mapped`).
    split_mapped: [bool; MAX_SPLIT_VALUES],
    /// Any of `split_mapped` (one test per cycle).
    any_split_mapped: bool,
    /// The slave runs the cycle in sync (`Application::synchronisation`).
    in_sync: bool,
    /// Whether an axis needs to know the cycles without new outputs
    /// ([`Self::watching_missed_outputs`]; kept, not worked out in every cycle).
    watches_missed_outputs: bool,
}

/// The most `[[split_value]]` settings a profile has (od-gen checks it).
pub const MAX_SPLIT_VALUES: usize = 4;

impl Drive {
    /// The application of `profile` at power-on, without motors.
    // Build-time only (the board's statics): both loops are bounded by the array lengths they
    // index, so nothing here can go out of range or overflow.
    #[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
    pub const fn new(profile: &'static DriveProfile) -> Self {
        let mut adjusting = [None; MAX_ADJUSTING_SERVICES];
        let mut i = 0;
        // od-gen allows at most MAX_ADJUSTING_SERVICES.
        while i < profile.adjusting.len() && i < MAX_ADJUSTING_SERVICES {
            adjusting[i] = Some(AdjustingService::new(&profile.adjusting[i]));
            i += 1;
        }
        let mut axes = [const { None }; MAX_AXES];
        let mut a = 0;
        // od-gen allows at most MAX_AXES (a generated assertion checks the two agree).
        while a < profile.axes.len() && a < MAX_AXES {
            axes[a] = Some(DriveAxis::new(profile, a as u8, &profile.axes[a]));
            a += 1;
        }
        let watches_missed_outputs = Self::watching_missed_outputs(&axes);
        Self {
            axes,
            adjusting,
            adjustment: None,
            alarm_table: &profile.alarms,
            alarm_log: AlarmLog::new(),
            now_ns: 0,
            od: &profile.od,
            split_values: profile.split_values,
            split_seen: [[0; 3]; MAX_SPLIT_VALUES],
            split_mapped: [false; MAX_SPLIT_VALUES],
            any_split_mapped: false,
            in_sync: false,
            watches_missed_outputs,
        }
    }

    /// Whether any of `axes` shows the synchronisation or extrapolates CSP over cycles without
    /// new outputs: a profile constant, but for the SDV3-E's P4.04 taken at power-on.
    // Bounded by the array's length (a const fn cannot use the iterators).
    #[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
    const fn watching_missed_outputs(axes: &[Option<DriveAxis>; MAX_AXES]) -> bool {
        let mut a = 0;
        while a < MAX_AXES {
            if let Some(axis) = &axes[a] {
                if axis.extrapolates_lost_cycles() || axis.shows_synchronisation() {
                    return true;
                }
            }
            a += 1;
        }
        false
    }

    /// Connects the control interrupt of axis `axis`'s motor (0 = the first axis): from now on
    /// its set-points go to it and its actual values come from it; the commissioned motor data
    /// in `ram` go to it at once (the parameters were loaded at power-on). The board calls
    /// [`crate::motor::axis::Axis::control_step`] with the same `link`; `encoder` is its
    /// encoder (its resolution for profiles whose velocity unit is in rpm; whether it is
    /// absolute for the rules that need a referenced position).
    pub fn attach_axis(
        &mut self,
        axis: usize,
        link: &'static AxisLink,
        encoder: EncoderSpec,
        ram: &[u8],
    ) -> Result<(), NoSuchAxis> {
        let drive_axis = self.axis_mut(axis).ok_or(NoSuchAxis(axis))?;
        drive_axis.attach(link, encoder, ram);
        Ok(())
    }

    /// The number of axes.
    pub fn axis_count(&self) -> usize {
        self.axes.iter().flatten().count()
    }

    /// Axis `axis` (0 = the first).
    pub fn axis(&self, axis: usize) -> Option<&DriveAxis> {
        self.axes.get(axis).and_then(Option::as_ref)
    }

    /// Axis `axis` (0 = the first), to change.
    pub fn axis_mut(&mut self, axis: usize) -> Option<&mut DriveAxis> {
        self.axes.get_mut(axis).and_then(Option::as_mut)
    }

    /// The PDS state of the first axis.
    pub fn pds_state(&self) -> PdsState {
        self.axis(0)
            .map_or(PdsState::NotReadyToSwitchOn, DriveAxis::pds_state)
    }

    /// The CiA402 error code (603Fh) of the first axis' active fault.
    pub fn fault_code(&self) -> Option<u16> {
        self.axis(0).and_then(DriveAxis::fault_code)
    }

    /// One cycle of every axis: the CiA402 device on its controlword and option codes, the mode
    /// display, the axis exchange.
    pub fn step(&mut self, ram: &mut [u8], cycle_ns: u32) {
        for axis in self.axes.iter_mut().flatten() {
            axis.in_sync = self.in_sync;
            axis.step(ram, cycle_ns);
        }
    }

    /// Puts the outputs the master drives into their safe state (on leaving OP, on a watchdog):
    /// every axis is disabled at once. `cycle_ns` is the bus cycle that was running.
    pub fn safe_outputs(&mut self, ram: &mut [u8], cycle_ns: u32) {
        for axis in self.axes.iter_mut().flatten() {
            axis.safe_outputs(ram, cycle_ns);
        }
    }

    /// An alarm of axis `axis` was raised: a record of it (with the axis' state) and the active
    /// alarms shown.
    fn alarm_raised(&mut self, axis: usize, ram: &mut [u8]) {
        let hours = u32::try_from(self.now_ns / NS_PER_HOUR).unwrap_or(u32::MAX);
        if let Some((number, conditions)) = self
            .axis(axis)
            .and_then(|a| Some((a.alarm_number()?, a.alarm_conditions(hours))))
        {
            self.alarm_log
                .raised(self.alarm_table, ram, number, &conditions);
        }
        self.show_active_alarms(ram);
    }

    /// Shows the numbers of the alarms the axes hold (each once).
    fn show_active_alarms(&self, ram: &mut [u8]) {
        if self.alarm_table.active.is_empty() {
            return;
        }
        let mut numbers = [0u16; MAX_AXES];
        let mut n = 0;
        for number in self
            .axes
            .iter()
            .flatten()
            .filter_map(DriveAxis::alarm_number)
        {
            if !numbers.get(..n).is_some_and(|seen| seen.contains(&number)) {
                if let Some(slot) = numbers.get_mut(n) {
                    *slot = number;
                    // Below the array's length: `get_mut` found the slot.
                    n = n.saturating_add(1);
                }
            }
        }
        AlarmLog::show_active(self.alarm_table, ram, numbers.get(..n).unwrap_or(&[]));
    }

    /// Whether another axis than `except` holds a fault announced with EMCY code `code` (its
    /// error stays active in 1001h until that one is reset too).
    fn emcy_code_held(&self, code: u16, except: usize) -> bool {
        self.axes.iter().enumerate().any(|(i, a)| {
            i != except
                && a.as_ref()
                    .is_some_and(|a| a.fault_code().is_some() && a.fault_emcy().0 == code)
        })
    }

    /// Starts `action` of service `service` on axis `axis` (its conditions were checked).
    fn start_adjustment(
        &mut self,
        service: usize,
        axis: usize,
        action: Action,
        feedback: AxisFeedback,
    ) {
        self.adjustment = Some(RunningAdjustment {
            service,
            axis,
            action,
            offset_calibrations: feedback.offset_calibrations,
            trips: feedback.trips,
        });
        if let Some(a) = self.axis_mut(axis) {
            a.set_calibrating_offsets(action == Action::CurrentOffsetCalibration);
        }
    }

    /// How the adjustment of service `service` stands.
    fn adjustment_progress(&self, service: usize) -> Progress {
        let Some(a) = self.adjustment.filter(|a| a.service == service) else {
            return Progress::Failed;
        };
        let Some(feedback) = self.axis(a.axis).and_then(DriveAxis::motor_feedback) else {
            return Progress::Failed;
        };
        match a.action {
            Action::CurrentOffsetCalibration => {
                if feedback.trips != a.trips || feedback.state == AxisState::Faulted {
                    Progress::Failed
                } else if feedback.offset_calibrations != a.offset_calibrations {
                    Progress::Done
                } else {
                    Progress::Running
                }
            }
            Action::MultiTurnReset | Action::MultiTurnLimitSetting => Progress::Failed,
        }
    }
}

impl Drive {
    /// What a download to `index:subindex` does beyond setting a value: a store, the alarm
    /// log's commands, the unit factors taking effect, an adjusting service's request.
    /// `at`: the entry's OD RAM offset, if it is a RAM variable.
    fn act_on_download(&mut self, ram: &mut [u8], (index, subindex): (u16, u8), at: Option<u16>) {
        if index == STORE_PARAMETERS {
            // A store that succeeded (a refused one is not committed).
            for axis in self.axes.iter_mut().flatten() {
                axis.parameters_stored(subindex);
            }
            return;
        }
        if self
            .alarm_log
            .downloaded(self.alarm_table, ram, index, subindex)
        {
            return;
        }
        if let Some(at) = at {
            if let Some(axis) = self
                .axes
                .iter_mut()
                .flatten()
                .find(|a| a.is_units_apply(at))
            {
                axis.apply_units(ram);
                return;
            }
        }
        let now_ms = self.now_ns / NS_PER_MS;
        for i in 0..MAX_ADJUSTING_SERVICES {
            let Some(mut service) = self
                .adjusting
                .get(i)
                .copied()
                .flatten()
                .filter(|s| s.is_request(index, subindex))
            else {
                continue;
            };
            // The service names its axis from 1.
            let axis = usize::from(service.spec().axis).wrapping_sub(1);
            let busy = self.adjustment.is_some();
            let target = self.axis(axis);
            let mut allowed = None;
            let start = service.on_request(ram, now_ms, |action| {
                if busy {
                    return Err(Refusal::Busy);
                }
                let feedback = target.ok_or(Refusal::NoAxis)?.adjustment_allowed(action)?;
                allowed = Some(feedback);
                Ok(())
            });
            if let Some(slot) = self.adjusting.get_mut(i) {
                *slot = Some(service);
            }
            if let (Some(action), Some(feedback)) = (start, allowed) {
                self.start_adjustment(i, axis, action, feedback);
            }
        }
    }

    /// Keeps each split setting's forms equal (`SplitValue::reconcile`): after an SDO download
    /// (`only_mapped` false) and every cycle (`only_mapped`: those the master's outputs write);
    /// at power-on (`power_on`) the parts set the whole.
    fn sync_split_values(&mut self, ram: &mut [u8], power_on: bool, only_mapped: bool) {
        for ((value, seen), mapped) in self
            .split_values
            .iter()
            .zip(self.split_seen.iter_mut())
            .zip(self.split_mapped)
        {
            if only_mapped && !mapped {
                continue;
            }
            let now = [value.whole, value.high, value.low].map(|o| o.value(ram, 0));
            let next = value.reconcile(now, (!power_on).then_some(*seen));
            for ((object, old), new) in [value.whole, value.high, value.low]
                .into_iter()
                .zip(now)
                .zip(next)
            {
                if new != old {
                    object.write(ram, new);
                    if let Some((at, _)) = object.object() {
                        // A setting the axes keep (e.g. the gear ratio 6091h of the units).
                        for axis in self.axes.iter_mut().flatten() {
                            axis.written(at);
                        }
                    }
                }
            }
            // As the objects hold them now (a write may have saturated).
            *seen = [value.whole, value.high, value.low].map(|o| o.value(ram, 0));
        }
    }
}

/// The slave stack's view of the drive.
impl Application for Drive {
    fn cycle(&mut self, ram: &mut [u8], cycle_ns: u32, events: &mut AppEvents) {
        // A split setting the master wrote by PDO (both forms may be mapped).
        if self.any_split_mapped {
            self.sync_split_values(ram, false, true);
        }
        let in_sync = self.in_sync;
        for i in 0..MAX_AXES {
            let Some(axis) = self.axis_mut(i) else {
                continue;
            };
            axis.in_sync = in_sync;
            let announced = axis.fault_announced;
            let warning_before = axis.warning();
            axis.step(ram, cycle_ns);
            let warning_after = axis.warning();
            if warning_after != warning_before {
                // A warning ends or begins: its EMCY (1001h holds it while it lasts).
                if let Some((code, _)) = warning_before.and_then(|w| axis.warning_emcy(w)) {
                    let _ = events.push(AppEvent::ErrorCleared(code));
                }
                if let Some((code, data)) = warning_after.and_then(|w| axis.warning_emcy(w)) {
                    let _ = events.push(AppEvent::ErrorRaised { code, data });
                }
            }
            let Some(axis) = self.axis_mut(i) else {
                continue;
            };
            let fault = axis.fault_code();
            axis.fault_announced = fault.is_some();
            let event = match (announced, fault) {
                (true, None) => {
                    let (emcy_code, _) = axis.fault_emcy();
                    self.show_active_alarms(ram);
                    // The unit's error stays while another axis still holds it.
                    if self.emcy_code_held(emcy_code, i) {
                        continue;
                    }
                    AppEvent::ErrorCleared(emcy_code)
                }
                (false, Some(_)) => {
                    let (emcy_code, data) = axis.fault_emcy();
                    self.alarm_raised(i, ram);
                    AppEvent::ErrorRaised {
                        code: emcy_code,
                        data,
                    }
                }
                _ => continue,
            };
            // MAX_APP_EVENTS holds a raise and a clear of every axis; one cycle gives at most one
            // event per axis.
            let _ = events.push(event);
        }
    }

    fn outputs_safe(&mut self, ram: &mut [u8], cycle_ns: u32) -> bool {
        // Active under the master's control: Operation Enabled, or a quick stop under way or
        // holding (the SDV3-E's ESr names both, §5.2 10), on any axis.
        let was_active = self.axes.iter().flatten().any(DriveAxis::active);
        self.safe_outputs(ram, cycle_ns);
        was_active
    }

    fn power_on(&mut self, ram: &mut [u8]) {
        self.sync_split_values(ram, true, false);
        // CiA402 transition 1: initialisation is done at power-on, in any EtherCAT state, so a
        // master reads Switch On Disabled in PREOP already (and profile rules that test it,
        // e.g. the Σ-V-SD's 1010h write condition, see the real state).
        for axis in self.axes.iter_mut().flatten() {
            axis.power_on(ram);
        }
        self.watches_missed_outputs = Self::watching_missed_outputs(&self.axes);
    }

    fn raise_error(&mut self, report: ErrorReport, ram: &mut [u8]) {
        // An error of the unit (e.g. its EtherCAT communication): every axis faults; one
        // record of it.
        let new = self.axes.iter().flatten().any(|a| a.fault_code().is_none());
        for axis in self.axes.iter_mut().flatten() {
            let report = self.alarm_table.with_alarm(FaultReport {
                error_code: report.error_code,
                emcy_code: report.emcy_code,
                emcy_data: report.emcy_data,
                alarm: None,
            });
            axis.report_fault(report, ram);
            // The slave sends its EMCY; the record follows here.
            axis.fault_announced = true;
        }
        if new {
            self.alarm_raised(0, ram);
        }
    }

    fn downloaded(&mut self, ram: &mut [u8], index: u16, subindex: u8, now_ns: u64) {
        self.now_ns = now_ns;
        // Searched once for all that follows.
        let object = self.od.object(index);
        if let Some(object) = object {
            for axis in self.axes.iter_mut().flatten() {
                axis.downloaded(object);
            }
        }
        self.sync_split_values(ram, false, false);
        let at = object.and_then(|o| ram::ram_offset_in(o, subindex));
        self.act_on_download(ram, (index, subindex), at);
        // The settings the download changed, in drive units before the next cycle uses them.
        for axis in self.axes.iter_mut().flatten() {
            axis.refresh_settings(ram);
        }
    }

    fn watches_missed_outputs(&self) -> bool {
        self.watches_missed_outputs
    }

    fn outputs_missed(&mut self) {
        for axis in self.axes.iter_mut().flatten() {
            axis.outputs_missed();
        }
    }

    fn synchronisation(&mut self, in_sync: bool) {
        // Handed to the axes in the cycle's loop.
        self.in_sync = in_sync;
    }

    fn watches_outputs(&self, at: u16, len: u16) -> bool {
        self.axes
            .iter()
            .flatten()
            .any(|axis| axis.reads_setting_from(at, len))
    }

    fn watched_outputs_changed(&mut self) {
        for axis in self.axes.iter_mut().flatten() {
            axis.mapped_settings_changed();
        }
    }

    fn outputs_mapped(&mut self, outputs: &PdoPlan) {
        for axis in self.axes.iter_mut().flatten() {
            axis.outputs_mapped(outputs);
        }
        for (mapped, value) in self.split_mapped.iter_mut().zip(self.split_values) {
            *mapped = [value.whole, value.high, value.low]
                .iter()
                .any(|form| match *form {
                    Operand::Ram { at, len } => outputs.writes_ram(at, u16::from(len)),
                    _ => false,
                });
        }
        self.any_split_mapped = self.split_mapped.contains(&true);
    }

    fn inputs_mapped(&mut self, inputs: &PdoPlan) {
        for axis in self.axes.iter_mut().flatten() {
            axis.inputs_mapped(inputs);
        }
    }

    fn before_upload(&mut self, ram: &mut [u8], object: &Object) {
        for axis in self.axes.iter().flatten() {
            axis.before_upload(ram, object);
        }
    }

    fn background(&mut self, ram: &mut [u8], now_ns: u64) {
        self.now_ns = now_ns;
        // Every ESC-event round calls this: with every service idle (no time limit running)
        // and no adjustment on an axis there is nothing to do, and the round spares the
        // 64-bit division below (a library call on the Cortex-M4).
        let timing = self.adjusting.iter().flatten().any(|s| !s.idle());
        if !timing && self.adjustment.is_none() {
            return;
        }
        let now_ms = now_ns / NS_PER_MS;
        for i in 0..MAX_ADJUSTING_SERVICES {
            let Some(mut service) = self.adjusting.get(i).copied().flatten() else {
                continue;
            };
            let progress = self.adjustment_progress(i);
            service.on_time(ram, now_ms, progress);
            if let Some(slot) = self.adjusting.get_mut(i) {
                *slot = Some(service);
            }
            let ours = self.adjustment.filter(|a| a.service == i);
            if let Some(a) = ours.filter(|_| service.running().is_none()) {
                // Ended, timed out or aborted: the axis request falls.
                self.adjustment = None;
                if let Some(axis) = self.axis_mut(a.axis) {
                    axis.set_calibrating_offsets(false);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::AppVars;
    use crate::profiles::standard;

    const VARS: AppVars = AppVars {
        controlword: Some(0),
        statusword: Some(2),
        modes_of_operation: Some(4),
        modes_of_operation_display: Some(5),
        target_position: Some(6),
        position_actual_value: Some(10),
        error_code: Some(14),
        ..AppVars::NONE
    };
    /// The standard profile with the variables of this test's small RAM.
    static PROFILE: DriveProfile = DriveProfile {
        axes: &[VARS],
        ..standard::PROFILE
    };

    #[test]
    fn actual_position_follows_target_only_when_operation_enabled() {
        let mut ram = [0u8; 16];
        let mut app = Drive::new(&PROFILE);
        ram[6..10].copy_from_slice(&1234i32.to_le_bytes());
        for cw in [0x00u16, 0x06, 0x07] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&mut ram, 0);
        }
        assert_eq!(&ram[10..14], &[0; 4], "not enabled yet");
        ram[0..2].copy_from_slice(&0x0Fu16.to_le_bytes());
        app.step(&mut ram, 0);
        assert_eq!(u16::from_le_bytes([ram[2], ram[3]]) & 0x6F, 0x27);
        assert_eq!(i32::from_le_bytes(ram[10..14].try_into().unwrap()), 1234);
    }

    /// An RxPDO mapping (1600h, assigned alone in 1C12h) of `entries` (index, subindex, bits)
    /// in `ram` of `profile`, and its plan.
    fn rx_plan(
        profile: &'static DriveProfile,
        ram: &mut [u8],
        entries: &[(u16, u8, u8)],
    ) -> ethercat_slave::pdo::PdoPlan {
        use ethercat_slave::od::Dictionary;
        use ethercat_slave::pdo::Direction;
        let mut od = Dictionary::new(&profile.od, ram);
        let mut set = |index: u16, sub: u8, value: u32| {
            let entry = od.object(index).and_then(|o| o.entry(sub)).unwrap();
            let bytes = value.to_le_bytes();
            od.set_value(entry, &bytes[..entry.byte_len()]).unwrap();
        };
        set(0x1C12, 0, 0);
        set(0x1C12, 1, 0x1600);
        set(0x1C12, 0, 1);
        set(0x1600, 0, 0);
        for (i, &(index, sub, bits)) in entries.iter().enumerate() {
            let value = u32::from(index) << 16 | u32::from(sub) << 8 | u32::from(bits);
            set(0x1600, i as u8 + 1, value);
        }
        set(0x1600, 0, entries.len() as u32);
        PdoPlan::build(&Dictionary::new(&profile.od, ram), Direction::Rx).unwrap()
    }

    /// The RxPDO plan compares the entries the drive keeps converted settings of (limits,
    /// ramps, windows, option codes, unit factors), not the process values it reads in every
    /// cycle anyway; a change it tells makes the mapped settings be read in the next cycle: a
    /// 6081h the master streams is the next profile-position move's speed.
    #[test]
    fn the_rxpdo_watches_the_settings_and_a_change_applies_in_the_next_cycle() {
        let od = &standard::PROFILE.od;
        let app = Drive::new(&standard::PROFILE);
        let watched = |index, sub| {
            let entry = od.object(index).and_then(|o| o.entry(sub)).unwrap();
            let ethercat_slave::od::Value::Ram(at) = entry.value else {
                panic!("{index:#06x} in the OD RAM")
            };
            app.watches_outputs(at, entry.byte_len() as u16)
        };
        for (index, sub) in [
            (0x605A, 0),
            (0x6065, 0),
            (0x6067, 0),
            (0x6072, 0),
            (0x607D, 1),
            (0x607D, 2),
            (0x607F, 0),
            (0x6081, 0),
            (0x6083, 0),
            (0x6084, 0),
            (0x6085, 0),
        ] {
            assert!(watched(index, sub), "{index:#06x}:{sub} is a setting");
        }
        for (index, sub) in [
            (0x6040, 0),
            (0x6060, 0),
            (0x607A, 0),
            (0x60FF, 0),
            (0x6071, 0),
        ] {
            assert!(
                !watched(index, sub),
                "{index:#06x}:{sub} is a process value"
            );
        }

        // SAFETY: the test is the one context that publishes, reads and steps.
        static LINK: AxisLink = unsafe { AxisLink::new() };
        let mut ram = standard::DEFAULTS.to_vec();
        let mut app = Drive::new(&standard::PROFILE);
        app.power_on(&mut ram);
        let encoder = crate::motor::servo::EncoderSpec::Incremental {
            counts_per_rev: 1 << 20,
        };
        app.attach_axis(0, &LINK, encoder, &ram).expect("axis 1");
        app.cycle(&mut ram, 1_000_000, &mut AppEvents::new());
        let plan = rx_plan(
            &standard::PROFILE,
            &mut ram,
            &[(0x6040, 0, 16), (0x6081, 0, 32)],
        );
        app.outputs_mapped(&plan);
        // The standard profile's velocity unit is the increment/s.
        let speed = |app: &Drive| {
            app.axis(0)
                .expect("axis 1")
                .settings()
                .move_limits
                .get()
                .velocity
        };
        let at = usize::from(ram::ram_offset(od, 0x6081, 0).expect("6081h in the OD RAM"));
        for (velocity, told) in [(12_345u32, true), (23_456, false)] {
            let before = speed(&app);
            ram[at..at + 4].copy_from_slice(&velocity.to_le_bytes());
            if told {
                app.watched_outputs_changed();
            }
            app.cycle(&mut ram, 1_000_000, &mut AppEvents::new());
            let expected = if told { velocity as f32 } else { before };
            assert_eq!(speed(&app), expected, "6081h = {velocity}, told: {told}");
        }
    }

    /// The GHA-E's gear ratio in two forms (6091h:01 = Pn-006 × 10000 + Pn-007): at power-on
    /// the parts set the whole; a form the master writes by PDO (straight into the OD RAM) sets
    /// the other in the next cycle, when the RxPDO mapping has it; an SDO download always does.
    #[test]
    fn a_split_setting_follows_a_pdo_write_and_the_parts_at_power_on() {
        use crate::profiles::gha_e;
        let mut ram = gha_e::DEFAULTS.to_vec();
        let [gear, _] = gha_e::PROFILE.split_values else {
            panic!("the GHA-E's two gear-ratio settings")
        };
        // Parts that disagree with the whole at power-on: the parts win.
        gear.high.write(&mut ram, 2);
        gear.low.write(&mut ram, 5);
        let mut app = Drive::new(&gha_e::PROFILE);
        app.power_on(&mut ram);
        assert_eq!(gear.whole.value(&ram, 0), 20_005);
        // Pn-007 (2000h:08) and 6091h:01 in the RxPDO.
        let plan = rx_plan(
            &gha_e::PROFILE,
            &mut ram,
            &[(0x2000, 8, 16), (0x6091, 1, 32)],
        );
        app.outputs_mapped(&plan);
        // A PDO write of the low part: the whole follows in the cycle.
        gear.low.write(&mut ram, 7);
        app.cycle(&mut ram, 1_000_000, &mut AppEvents::new());
        assert_eq!(gear.whole.value(&ram, 0), 20_007);
        // A PDO write of the whole: the parts follow.
        gear.whole.write(&mut ram, 131_072);
        app.cycle(&mut ram, 1_000_000, &mut AppEvents::new());
        assert_eq!(
            (gear.high.value(&ram, 0), gear.low.value(&ram, 0)),
            (13, 1_072)
        );
        // Not in the mapping: the master cannot write it by PDO, the cycle leaves it (it costs
        // the SYNC0 handler nothing), and an SDO download of it sets the other form.
        let plan = rx_plan(&gha_e::PROFILE, &mut ram, &[(0x6040, 0, 16)]);
        app.outputs_mapped(&plan);
        gear.low.write(&mut ram, 9);
        app.cycle(&mut ram, 1_000_000, &mut AppEvents::new());
        assert_eq!(
            gear.whole.value(&ram, 0),
            131_072,
            "not reconciled in the cycle"
        );
        app.downloaded(&mut ram, 0x2000, 8, 0);
        assert_eq!(gear.whole.value(&ram, 0), 130_009);
    }

    /// The drive reads the SM2 event in a cycle (to tell one without new outputs) exactly where
    /// an axis needs it: the SDV3-E and OSD-G-E show the synchronisation in the CSP statusword
    /// (bit 12), the SDV3-E extrapolates with P4.04 = 1 (taken at power-on); CiA402 alone
    /// (the standard profile) needs neither. The kept flag agrees with its axes before and
    /// after power-on, with P4.04 either way.
    #[test]
    fn missed_outputs_are_watched_where_an_axis_needs_them() {
        use crate::profiles::{sdv3_e, standard};
        let by_axes = |app: &Drive| {
            app.axes
                .iter()
                .flatten()
                .any(|a| a.extrapolates_lost_cycles() || a.shows_synchronisation())
        };
        for profile in crate::profiles::ALL {
            let mut ram = profile.od.defaults.to_vec();
            let mut app = Drive::new(profile);
            assert_eq!(app.watches_missed_outputs(), by_axes(&app));
            app.power_on(&mut ram);
            assert_eq!(app.watches_missed_outputs(), by_axes(&app));
        }
        assert!(!Drive::new(&standard::PROFILE).watches_missed_outputs());
        let extrapolation = sdv3_e::PROFILE
            .cia402
            .csp_extrapolation
            .expect("the SDV3-E's P4.04");
        for p404 in [0, 1] {
            let mut ram = sdv3_e::DEFAULTS.to_vec();
            extrapolation.write(&mut ram, p404);
            let mut app = Drive::new(&sdv3_e::PROFILE);
            app.power_on(&mut ram);
            let axis = app.axis(0).expect("axis 1");
            assert_eq!(axis.extrapolates_lost_cycles(), p404 == 1);
            assert!(
                app.watches_missed_outputs(),
                "bit 12 shows the synchronisation"
            );
        }
    }

    #[test]
    fn power_on_ends_initialisation_in_switch_on_disabled() {
        // CiA402 transition 1 (automatic): the statusword reads Switch On Disabled
        // (xxxx xxxx x1xx 0000) before any process-data cycle ran.
        let mut ram = [0u8; 16];
        let mut app = Drive::new(&PROFILE);
        assert_eq!(app.pds_state(), PdsState::NotReadyToSwitchOn);
        app.power_on(&mut ram);
        assert_eq!(app.pds_state(), PdsState::SwitchOnDisabled);
        assert_eq!(u16::from_le_bytes([ram[2], ram[3]]) & 0x004F, 0x0040);
    }

    #[test]
    fn safe_outputs_disable_the_drive() {
        let mut ram = [0u8; 16];
        let mut app = Drive::new(&PROFILE);
        for cw in [0x00u16, 0x06, 0x07, 0x0F] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&mut ram, 0);
        }
        app.safe_outputs(&mut ram, 0);
        assert_eq!(app.pds_state(), PdsState::SwitchOnDisabled);
        assert_eq!(&ram[0..2], &[0, 0]);
    }

    #[test]
    fn fault_sets_error_code_and_statusword_until_fault_reset() {
        let mut ram = [0u8; 16];
        let mut app = Drive::new(&PROFILE);
        for cw in [0x00u16, 0x06, 0x07, 0x0F] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&mut ram, 0);
        }
        app.axis_mut(0).expect("axis 1").fault(0x8700, &mut ram);
        assert_eq!(app.pds_state(), PdsState::Fault);
        assert_eq!(app.fault_code(), Some(0x8700));
        assert_eq!(u16::from_le_bytes([ram[14], ram[15]]), 0x8700);
        assert_ne!(
            u16::from_le_bytes([ram[2], ram[3]]) & 0x08,
            0,
            "statusword bit 3"
        );
        // Controlword ignored while in Fault; a rising edge of bit 7 resets.
        ram[0..2].copy_from_slice(&0x0Fu16.to_le_bytes());
        app.step(&mut ram, 0);
        assert_eq!(app.pds_state(), PdsState::Fault);
        ram[0..2].copy_from_slice(&0x80u16.to_le_bytes());
        app.step(&mut ram, 0);
        assert_eq!(app.pds_state(), PdsState::SwitchOnDisabled);
        assert_eq!(app.fault_code(), None);
        assert_eq!(&ram[14..16], &[0, 0]);
    }
}
