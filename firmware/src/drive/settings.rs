//! The settings of an axis: the parameters the cycle uses that a master sets rather than
//! streams (option codes, torque and position limits, ramps, windows, homing speeds, the
//! following-error window), read from the OD RAM and converted to drive units only when they
//! may have changed, not in every cycle (each read and conversion costs instructions in the
//! SYNC0 handler).
//!
//! A setting may change when
//! - an SDO download writes one of its objects ([`GroupsByOffset::of_object`]; the application learns
//!   of every committed download): its groups are read again at once, in the context that
//!   commits the download, so the next cycle has them and pays nothing for it;
//! - the drive writes one itself (a split value's other form, also in the cycle);
//! - the master's RxPDO maps one of its objects: such a group is [`live`](live_groups); the
//!   RxPDO plan compares the bytes of the mapped settings as it copies them (a watched entry,
//!   `PdoPlan::build_watching`) and the live groups are read in a cycle whose outputs changed
//!   one;
//! - what its conversion depends on changes: the unit factors ([`Groups::UNIT_DEPENDENT`]), the
//!   polarity 607Eh (the software limits; taken in the cycle while the power stage is off), the
//!   motor (attached: everything);
//! - the parameters are loaded at power-on (everything).
//!
//! The groups split the settings along the PDOs a master maps (e.g. 6081h–6084h for profile
//! position, the torque limits for a press): a mapped object that changes makes only the
//! mapped groups be read again.

use cia402::limits::SoftwareLimits;
use cia402::stop::{OptionCodes, Reactions};
use cia402::units::{self, Polarity};
use cia402::window;

use ethercat_slave::od::{Object, Value};
use ethercat_slave::pdo::PdoPlan;

use super::ram::{read_i16, read_i32, read_u16, read_u32};
use crate::motor::math;
use crate::motor::trajectory::{Limits, SaneLimits};
use crate::profile::{AppVars, Cia402Rules, UnitRatios};

/// 6065h value that switches the following-error check off (CiA402).
pub(super) const FOLLOWING_ERROR_OFF: u32 = u32::MAX;

/// A set of setting groups (bit per group).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Groups(u8);

impl Groups {
    pub const NONE: Self = Self(0);
    /// 605Ah–605Eh.
    pub const OPTIONS: Self = Self(1 << 0);
    /// 6076h, 6072h, 60E0h, 60E1h, 6087h.
    pub const TORQUE: Self = Self(1 << 1);
    /// 607Fh, 6080h, 6081h, 6083h, 6084h, 6085h.
    pub const RAMPS: Self = Self(1 << 2);
    /// 6067h/6068h, 606Dh/606Eh, 606Fh/6070h.
    pub const WINDOWS: Self = Self(1 << 3);
    /// 6099h, 609Ah (6083h without it), the profile's homing time limit.
    pub const HOMING: Self = Self(1 << 4);
    /// 607Dh.
    pub const POSITION_LIMITS: Self = Self(1 << 5);
    /// 6065h, 6066h.
    pub const FOLLOWING_ERROR: Self = Self(1 << 6);
    /// The objects the unit factors read (e.g. 6091h, 6092h).
    pub const UNITS: Self = Self(1 << 7);
    pub const ALL: Self = Self(u8::MAX);
    /// The groups whose values are converted with the unit factors.
    pub const UNIT_DEPENDENT: Self = Self(
        Self::TORQUE.0
            | Self::RAMPS.0
            | Self::WINDOWS.0
            | Self::HOMING.0
            | Self::POSITION_LIMITS.0
            | Self::FOLLOWING_ERROR.0,
    );

    pub fn has(self, group: Self) -> bool {
        self.0 & group.0 != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl core::ops::BitOr for Groups {
    type Output = Self;
    fn bitor(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }
}

impl core::ops::BitOrAssign for Groups {
    fn bitor_assign(&mut self, other: Self) {
        self.0 |= other.0;
    }
}

/// One variable a group reads: its OD RAM offset (`None`: the profile has none) and length.
#[derive(Clone, Copy)]
struct Member {
    group: Groups,
    at: Option<u16>,
    len: u16,
}

/// How many variables the setting groups read ([`members`]).
const MEMBERS: usize = 42;

/// Every variable each group reads (a variable may serve several groups): the one list of
/// them.
const fn members(vars: &AppVars) -> [Member; MEMBERS] {
    const fn m(group: Groups, at: Option<u16>, len: u16) -> Member {
        Member { group, at, len }
    }
    const fn unit_factor(object: Option<(u16, u8)>) -> Member {
        match object {
            Some((at, len)) => m(Groups::UNITS, Some(at), len as u16),
            None => m(Groups::UNITS, None, 0),
        }
    }
    use Groups as G;
    let [f0, f1, f2, f3, f4, f5, f6, f7, f8, f9] = vars.unit_factor_objects();
    [
        m(G::OPTIONS, vars.quick_stop_option_code, 2),
        m(G::OPTIONS, vars.shutdown_option_code, 2),
        m(G::OPTIONS, vars.disable_operation_option_code, 2),
        m(G::OPTIONS, vars.halt_option_code, 2),
        m(G::OPTIONS, vars.fault_reaction_option_code, 2),
        m(G::TORQUE, vars.motor_rated_torque, 4),
        m(G::TORQUE, vars.max_torque, 2),
        m(G::TORQUE, vars.positive_torque_limit, 2),
        m(G::TORQUE, vars.negative_torque_limit, 2),
        m(G::TORQUE, vars.torque_slope, 4),
        m(G::RAMPS, vars.max_profile_velocity, 4),
        m(G::RAMPS, vars.max_motor_speed, 4),
        m(G::RAMPS, vars.profile_velocity, 4),
        m(G::RAMPS, vars.profile_acceleration, 4),
        m(G::RAMPS, vars.profile_deceleration, 4),
        m(G::RAMPS, vars.quick_stop_deceleration, 4),
        m(G::WINDOWS, vars.position_window, 4),
        m(G::WINDOWS, vars.position_window_time, 2),
        m(G::WINDOWS, vars.velocity_window, 2),
        m(G::WINDOWS, vars.velocity_window_time, 2),
        m(G::WINDOWS, vars.velocity_threshold, 2),
        m(G::WINDOWS, vars.velocity_threshold_time, 2),
        m(G::HOMING, vars.homing_speed_switch, 4),
        m(G::HOMING, vars.homing_speed_zero, 4),
        m(G::HOMING, vars.homing_acceleration, 4),
        // Without 609Ah homing accelerates on 6083h.
        m(G::HOMING, vars.profile_acceleration, 4),
        m(G::HOMING, vars.homing_timeout, 2),
        m(G::POSITION_LIMITS, vars.software_position_limit_min, 4),
        m(G::POSITION_LIMITS, vars.software_position_limit_max, 4),
        // Where 607Dh is relative to the machine home.
        m(G::POSITION_LIMITS, vars.home_offset, 4),
        m(G::FOLLOWING_ERROR, vars.following_error_window, 4),
        m(G::FOLLOWING_ERROR, vars.following_error_timeout, 2),
        unit_factor(f0),
        unit_factor(f1),
        unit_factor(f2),
        unit_factor(f3),
        unit_factor(f4),
        unit_factor(f5),
        unit_factor(f6),
        unit_factor(f7),
        unit_factor(f8),
        unit_factor(f9),
    ]
}

/// The setting groups of one axis by OD RAM offset: the offsets of its [`members`], sorted,
/// each with the groups of every member there. Built once, so that a download finds its
/// groups by a binary search (some 60 instructions) instead of a comparison with every member
/// (some 450, in the ESC-event round under the lock the SYNC0 interrupt shares).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct GroupsByOffset {
    /// The first `len` hold the offsets, ascending, each once.
    offsets: [u16; MEMBERS],
    /// The groups of `offsets[i]`.
    groups: [Groups; MEMBERS],
    len: usize,
}

impl GroupsByOffset {
    /// The table of the variables `vars` (const: part of the drive's power-on value).
    // The indices stay below MEMBERS: at most one offset is added per member.
    #[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
    pub const fn of(vars: &AppVars) -> Self {
        let members = members(vars);
        let mut table = Self {
            offsets: [0; MEMBERS],
            groups: [Groups::NONE; MEMBERS],
            len: 0,
        };
        let mut i = 0;
        while i < MEMBERS {
            if let Some(at) = members[i].at {
                let group = members[i].group;
                // Insertion sort: the first place whose offset is not below `at`.
                let mut place = 0;
                while place < table.len && table.offsets[place] < at {
                    place += 1;
                }
                if place < table.len && table.offsets[place] == at {
                    table.groups[place] = Groups(table.groups[place].0 | group.0);
                } else {
                    let mut k = table.len;
                    while k > place {
                        table.offsets[k] = table.offsets[k - 1];
                        table.groups[k] = table.groups[k - 1];
                        k -= 1;
                    }
                    table.offsets[place] = at;
                    table.groups[place] = group;
                    table.len += 1;
                }
            }
            i += 1;
        }
        table
    }

    /// The groups that read the variable at OD RAM offset `at`.
    pub fn of_offset(&self, at: u16) -> Groups {
        let offsets = self.offsets.get(..self.len).unwrap_or(&[]);
        offsets
            .binary_search(&at)
            .ok()
            .and_then(|i| self.groups.get(i).copied())
            .unwrap_or(Groups::NONE)
    }

    /// The groups with an entry of `object` (any subindex: a complete-access download names
    /// only its first).
    pub fn of_object(&self, object: &Object) -> Groups {
        object
            .entries
            .iter()
            .filter_map(|e| match e.value {
                Value::Ram(at) => Some(self.of_offset(at)),
                _ => None,
            })
            .fold(Groups::NONE, |a, b| a | b)
    }
}

/// Whether a setting group reads any of the `len` OD RAM bytes from `at`.
pub(super) fn reads_from(vars: &AppVars, at: u16, len: u16) -> bool {
    members(vars).iter().any(|m| {
        m.at.is_some_and(|from| ethercat_slave::pdo::overlaps(&[(from, m.len)], at, len))
    })
}

/// The groups with a variable the RxPDO `plan` writes: read again in a cycle whose outputs
/// changed one.
pub(super) fn live_groups(vars: &AppVars, plan: &PdoPlan) -> Groups {
    members(vars)
        .iter()
        .filter(|m| m.at.is_some_and(|at| plan.writes_ram(at, m.len)))
        .fold(Groups::NONE, |a, m| a | m.group)
}

/// The settings in drive units (increments, increments/s, N·m), as of the last refresh of
/// each group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The reactions of 605Ah–605Eh (resolved when the codes change, not in every cycle).
    pub reactions: Reactions,
    /// 6076h, N·m.
    pub rated_nm: f32,
    /// The rated torque in the torque objects' unit: a torque object counts ‰ of this
    /// (6076h × the torque unit's ‰ per unit; 6076h with CiA402's 0.1 %).
    pub object_rated_nm: f32,
    /// 6072h with 60E0h/60E1h (positive, negative magnitudes in the objects' sense, N·m):
    /// the lower of the general and the direction's limit; `None` without any of them.
    pub torque_limits: Option<(f32, f32)>,
    /// 6087h, N·m/s (0: no ramp).
    pub torque_slope: f32,
    /// 6080h, increments/s.
    pub max_motor_speed: Option<f32>,
    /// Profile position: 6081h limited by 607Fh and 6080h, 6083h, 6084h (6083h without it).
    pub move_limits: SaneLimits,
    /// Profile velocity: 607Fh limited by 6080h, 6083h, 6084h (6083h without it).
    pub velocity_limits: SaneLimits,
    /// The stop ramps 6084h and 6085h, increments/s² (0 without the object).
    pub profile_deceleration: f32,
    pub quick_stop_deceleration: f32,
    /// 6067h (position units) and 6068h (ms).
    pub position_window: (u32, u16),
    /// 6067h as the largest distance in increments inside it (`u64::MAX`: the window is off),
    /// for a comparison without a conversion per cycle; `None` where the position ratio does
    /// not give it ([`units::Ratio::increments_within`]: compare in position units).
    pub position_window_increments: Option<u64>,
    /// 606Dh (increments/s) and 606Eh (ms).
    pub velocity_window: (f32, u16),
    /// 606Fh (increments/s) and 6070h (ms); `None` without 606Fh (the drive's standstill
    /// level counts).
    pub velocity_threshold: Option<(f32, u16)>,
    /// 6099h:01, 6099h:02 (increments/s) and 609Ah (increments/s²).
    pub homing_speeds: (f32, f32, f32),
    /// The profile's homing time limit, ms.
    pub homing_timeout_ms: Option<u32>,
    /// 607Dh in drive increments with the polarity applied; `None` when disabled or absent.
    pub software_limits: Option<SoftwareLimits>,
    /// 6065h in increments ([`FOLLOWING_ERROR_OFF`]: no check), `None` without the object.
    pub following_error_window: Option<u32>,
    /// 6066h, ms.
    pub following_error_timeout_ms: u16,
}

impl Settings {
    /// Before the first refresh (every group is refreshed before the first cycle uses it).
    pub const UNREAD: Self = Self {
        reactions: Reactions::NONE,
        rated_nm: 1.0,
        object_rated_nm: 1.0,
        torque_limits: None,
        torque_slope: 0.0,
        max_motor_speed: None,
        move_limits: SaneLimits::REST,
        velocity_limits: SaneLimits::REST,
        profile_deceleration: 0.0,
        quick_stop_deceleration: 0.0,
        position_window: (0, 0),
        position_window_increments: Some(0),
        velocity_window: (0.0, 0),
        velocity_threshold: None,
        homing_speeds: (0.0, 0.0, 0.0),
        homing_timeout_ms: None,
        software_limits: None,
        following_error_window: None,
        following_error_timeout_ms: 0,
    };

    /// Reads the option codes (needed before the units are known), with the profile's own
    /// codes, the codes it implies without an object and a 605Eh it ignores (`rules`);
    /// `torque_mode`: the axis runs a torque mode (where a profile may stop at once).
    pub fn refresh_options(
        &mut self,
        ram: &[u8],
        vars: &AppVars,
        rules: &Cia402Rules,
        torque_mode: bool,
    ) {
        let implied = rules.implied_option_codes;
        let codes = OptionCodes {
            quick_stop: read_i16(ram, vars.quick_stop_option_code).or(implied.quick_stop),
            shutdown: read_i16(ram, vars.shutdown_option_code).or(implied.shutdown),
            disable_operation: read_i16(ram, vars.disable_operation_option_code)
                .or(implied.disable_operation),
            halt: read_i16(ram, vars.halt_option_code).or(implied.halt),
            fault_reaction: read_i16(ram, vars.fault_reaction_option_code)
                .or(implied.fault_reaction)
                .filter(|_| !rules.fault_reaction_ignored),
            vendor: rules.stop_codes,
        };
        let reactions = Reactions::from(codes);
        self.reactions = if torque_mode && rules.torque_modes_stop_at_once {
            reactions.commands_at_once()
        } else {
            reactions
        };
    }

    /// Reads the `groups` but the option codes from `ram`, converted with `units` and the
    /// position `polarity` and the profile's `rules` (6065h = 0 switching the following-error
    /// check off, 607Dh relative to the machine home).
    pub fn refresh(
        &mut self,
        ram: &[u8],
        vars: &AppVars,
        (units, polarity): (&UnitRatios, Polarity),
        rules: &Cia402Rules,
        groups: Groups,
    ) {
        if groups.has(Groups::TORQUE) {
            self.refresh_torque(ram, vars, units);
        }
        if groups.has(Groups::RAMPS) {
            self.refresh_ramps(ram, vars, units);
        }
        if groups.has(Groups::WINDOWS) {
            self.refresh_windows(ram, vars, units);
        }
        if groups.has(Groups::HOMING) {
            self.refresh_homing(ram, vars, units);
        }
        if groups.has(Groups::POSITION_LIMITS) {
            let less_home_offset = rules.software_limits_less_home_offset;
            self.software_limits =
                software_limits(ram, vars, units.position, polarity, less_home_offset);
        }
        if groups.has(Groups::FOLLOWING_ERROR) {
            self.following_error_window = read_u32(ram, vars.following_error_window).map(|w| {
                let zero_window_off = rules.following_error_zero_window_off;
                if w == FOLLOWING_ERROR_OFF || (w == 0 && zero_window_off) {
                    FOLLOWING_ERROR_OFF
                } else {
                    let increments = units.position.position_to_internal(i64::from(w));
                    u32::try_from(increments).unwrap_or(FOLLOWING_ERROR_OFF - 1)
                }
            });
            self.following_error_timeout_ms =
                read_u16(ram, vars.following_error_timeout).unwrap_or(0);
        }
    }

    fn refresh_torque(&mut self, ram: &[u8], vars: &AppVars, units: &UnitRatios) {
        let rated_nm = units::rated_torque_nm(read_u32(ram, vars.motor_rated_torque));
        self.rated_nm = rated_nm;
        // The torque objects count ‰ of this (the rated torque in their unit).
        let object_rated_nm = rated_nm * units.torque.factor();
        self.object_rated_nm = object_rated_nm;
        self.torque_limits = torque_limits(ram, vars, object_rated_nm);
        let slope = read_u32(ram, vars.torque_slope).unwrap_or(0);
        self.torque_slope = units::torque_from_permille_f32(slope as f32, object_rated_nm);
    }

    fn refresh_ramps(&mut self, ram: &[u8], vars: &AppVars, units: &UnitRatios) {
        let velocity =
            |at| read_u32(ram, at).map(|v| units.velocity.velocity_to_internal(v as f32));
        let accel = |at| read_u32(ram, at).map(|v| units.acceleration.to_internal(v));
        let max_motor_speed = velocity(vars.max_motor_speed);
        // 607Fh, and the maximum motor speed 6080h above it.
        let max = math::min(
            velocity(vars.max_profile_velocity).unwrap_or(f32::INFINITY),
            max_motor_speed.unwrap_or(f32::INFINITY),
        );
        let acceleration = accel(vars.profile_acceleration).unwrap_or(0.0);
        let deceleration = accel(vars.profile_deceleration);
        let move_velocity = velocity(vars.profile_velocity).unwrap_or(0.0);
        self.max_motor_speed = max_motor_speed;
        self.move_limits = Limits {
            velocity: if move_velocity < max {
                move_velocity
            } else {
                max
            },
            acceleration,
            deceleration: deceleration.unwrap_or(acceleration),
        }
        .sane();
        self.velocity_limits = Limits {
            velocity: max,
            acceleration,
            deceleration: deceleration.unwrap_or(acceleration),
        }
        .sane();
        self.profile_deceleration = deceleration.unwrap_or(0.0);
        self.quick_stop_deceleration = accel(vars.quick_stop_deceleration).unwrap_or(0.0);
    }

    fn refresh_windows(&mut self, ram: &[u8], vars: &AppVars, units: &UnitRatios) {
        let time = |at| read_u16(ram, at).unwrap_or(0);
        // 606Dh/606Fh in their own unit where the profile counts them apart (e.g. whole rpm).
        let window = |at| {
            read_u16(ram, at).map_or(0.0, |v| {
                units.velocity_window.velocity_to_internal(f32::from(v))
            })
        };
        let position_window = read_u32(ram, vars.position_window).unwrap_or(0);
        self.position_window = (position_window, time(vars.position_window_time));
        self.position_window_increments = if position_window == window::WINDOW_OFF {
            Some(u64::MAX)
        } else {
            units.position.increments_within(position_window)
        };
        self.velocity_window = (
            window(vars.velocity_window),
            time(vars.velocity_window_time),
        );
        self.velocity_threshold = vars.velocity_threshold.is_some().then(|| {
            (
                window(vars.velocity_threshold),
                time(vars.velocity_threshold_time),
            )
        });
    }

    fn refresh_homing(&mut self, ram: &[u8], vars: &AppVars, units: &UnitRatios) {
        let velocity =
            |at| read_u32(ram, at).map_or(0.0, |v| units.velocity.velocity_to_internal(v as f32));
        let accel = |at| read_u32(ram, at).map(|v| units.acceleration.to_internal(v));
        self.homing_speeds = (
            velocity(vars.homing_speed_switch),
            velocity(vars.homing_speed_zero),
            // A profile without 609Ah (the SDV3-E) homes on its profile acceleration 6083h.
            accel(vars.homing_acceleration)
                .or_else(|| accel(vars.profile_acceleration))
                .unwrap_or(0.0),
        );
        self.homing_timeout_ms = read_u16(ram, vars.homing_timeout).map(u32::from);
    }
}

/// The torque limits (positive, negative magnitudes; N·m) of 6072h and 60E0h/60E1h, the lower
/// of the general and the direction's limit; `None` when the profile has none of them.
fn torque_limits(ram: &[u8], vars: &AppVars, rated_nm: f32) -> Option<(f32, f32)> {
    let permille = |at| read_u16(ram, at);
    let max = permille(vars.max_torque);
    let positive = permille(vars.positive_torque_limit);
    let negative = permille(vars.negative_torque_limit);
    if max.is_none() && positive.is_none() && negative.is_none() {
        return None;
    }
    // The lower of the two that exist (u16::MAX: no limit).
    let lower = |a: Option<u16>, b: Option<u16>| a.unwrap_or(u16::MAX).min(b.unwrap_or(u16::MAX));
    let nm = |p: u16| units::torque_from_permille_f32(f32::from(p), rated_nm);
    Some((nm(lower(max, positive)), nm(lower(max, negative))))
}

/// The software position limits 607Dh in drive increments, `None` when disabled (min ≥ max)
/// or absent. `less_home_offset`: 607Dh is relative to the machine home, the limits are
/// 607Dh - 607Ch (the Σ-V-SD §4.8 (2) "Corrected min. position limit = min. position limit -
/// home offset").
fn software_limits(
    ram: &[u8],
    vars: &AppVars,
    ratio: units::Ratio,
    polarity: Polarity,
    less_home_offset: bool,
) -> Option<SoftwareLimits> {
    let offset = if less_home_offset {
        read_i32(ram, vars.home_offset).unwrap_or(0)
    } else {
        0
    };
    let min = read_i32(ram, vars.software_position_limit_min)?.saturating_sub(offset);
    let max = read_i32(ram, vars.software_position_limit_max)?.saturating_sub(offset);
    // With the position polarity the user's minimum is the drive's maximum.
    let (min, max) = if polarity.position {
        (polarity.position(max), polarity.position(min))
    } else {
        (min, max)
    };
    SoftwareLimits::new(
        ratio.position_to_internal(i64::from(min)),
        ratio.position_to_internal(i64::from(max)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::ram::ram_offset;
    use crate::profiles::standard::{PROFILE, RAM_SIZE};
    use ethercat_slave::od::Dictionary;
    use ethercat_slave::pdo::Direction;

    fn vars() -> &'static AppVars {
        &PROFILE.axes[0]
    }

    #[test]
    fn a_download_makes_the_groups_of_its_object_due() {
        let of = |index| {
            PROFILE
                .od
                .object(index)
                .map_or(Groups::NONE, |o| GroupsByOffset::of(vars()).of_object(o))
        };
        assert_eq!(of(0x605A), Groups::OPTIONS);
        assert_eq!(of(0x6072), Groups::TORQUE);
        assert_eq!(of(0x6081), Groups::RAMPS);
        // 6083h is also homing's acceleration where 609Ah is missing.
        assert_eq!(of(0x6083), Groups::RAMPS | Groups::HOMING);
        // Both entries of an array (a complete access names only the first).
        assert_eq!(of(0x607D), Groups::POSITION_LIMITS);
        // Where 607Dh is relative to the machine home.
        assert_eq!(of(0x607C), Groups::POSITION_LIMITS);
        assert_eq!(of(0x6099), Groups::HOMING);
        assert_eq!(of(0x6065), Groups::FOLLOWING_ERROR);
        // Process values and absent objects are no settings.
        assert_eq!(of(0x6040), Groups::NONE);
        assert_eq!(of(0x607A), Groups::NONE);
        assert_eq!(of(0x5FFF), Groups::NONE);
    }

    /// The table finds, for every OD RAM byte of every axis of every profile, the groups of
    /// the members at that offset (the plain definition: a comparison with each member), and
    /// holds every offset once, ascending.
    #[test]
    fn the_offset_table_agrees_with_the_member_list() {
        for profile in crate::profiles::ALL {
            for vars in profile.axes {
                let table = GroupsByOffset::of(vars);
                let list = members(vars);
                let mut settings = 0;
                for at in 0..=u16::try_from(profile.od.defaults.len()).expect("a u16 size") {
                    let expected = list
                        .iter()
                        .filter(|m| m.at == Some(at))
                        .fold(Groups::NONE, |a, m| a | m.group);
                    assert_eq!(table.of_offset(at), expected, "offset {at}");
                    settings += usize::from(!expected.is_empty());
                }
                assert_eq!(settings, table.len);
                assert!(table.offsets[..table.len].windows(2).all(|w| w[0] < w[1]));
                // Every profile has some settings.
                assert!(settings > 10, "{settings}");
            }
        }
    }

    /// The RxPDO plan of 1600h mapping `entries` (index, subindex, bits) on the standard
    /// profile's defaults.
    fn plan_of(entries: &[(u16, u8, u8)]) -> PdoPlan {
        let od = &PROFILE.od;
        let mut ram = [0u8; RAM_SIZE];
        ram.copy_from_slice(od.defaults);
        let mut put = |index, sub, bytes: &[u8]| {
            let at = usize::from(ram_offset(od, index, sub).expect("a RAM entry"));
            ram[at..at + bytes.len()].copy_from_slice(bytes);
        };
        for (n, &(index, sub, bits)) in (1u8..).zip(entries) {
            let mapping = u32::from(index) << 16 | u32::from(sub) << 8 | u32::from(bits);
            put(0x1600, n, &mapping.to_le_bytes());
        }
        put(0x1600, 0, &[entries.len() as u8]);
        PdoPlan::build(&Dictionary::new(od, &mut ram), Direction::Rx).expect("a valid mapping")
    }

    #[test]
    fn the_groups_the_outputs_map_are_live() {
        let live = |entries: &[(u16, u8, u8)]| live_groups(vars(), &plan_of(entries));
        // The default mapping (controlword, target position, mode): no setting.
        assert_eq!(
            live(&[(0x6040, 0, 16), (0x607A, 0, 32), (0x6060, 0, 8)]),
            Groups::NONE
        );
        assert_eq!(live(&[(0x6040, 0, 16), (0x6081, 0, 32)]), Groups::RAMPS);
        assert_eq!(
            live(&[(0x6040, 0, 16), (0x607D, 2, 32), (0x60E0, 0, 16)]),
            Groups::POSITION_LIMITS | Groups::TORQUE
        );
        assert_eq!(live(&[(0x6083, 0, 32)]), Groups::RAMPS | Groups::HOMING);
        assert_eq!(live_groups(vars(), &PdoPlan::default()), Groups::NONE);
    }
}
