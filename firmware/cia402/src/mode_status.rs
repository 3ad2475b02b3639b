//! Statusword bits 10–13 ("operation mode specific", CiA402 §6.4 Table 7 and each mode's
//! statusword table): what each bit shows in each mode of operation.
//!
//! The drive works out the conditions ([`Conditions`]) and the mode's [`Layout`] puts them on
//! the bits. CiA402's layouts ([`cia402`]):
//!
//! | mode | bit 10 | bit 11 | bit 12 | bit 13 |
//! |---|---|---|---|---|
//! | profile position | target reached | internal limit active | set-point acknowledge | following error |
//! | profile velocity | target reached | internal limit active | speed (1 = zero) | max slippage (not modelled) |
//! | profile torque | target reached | internal limit active | – | – |
//! | homing | target reached | internal limit active | homing attained | homing error |
//! | interpolated position | target reached | internal limit active | ip mode active | following error |
//! | cyclic synchronous position | – | internal limit active | drive follows the command value | following error |
//! | cyclic synchronous velocity / torque | – | internal limit active | drive follows the command value | – |
//!
//! A profile whose manual moves a condition to another bit, or drops it, gives its own layout
//! for that mode ([`Override`]: the SDV3-E's "speed zero" on bit 11 and "successful
//! synchronization" on bit 12, the RSE's target reached in the cyclic modes). Modes without a
//! layout (identification, manufacturer modes) keep the bits as the mode set them.

use crate::modes::{CSP, CST, CSV, HM, IP, PP, PT, PV};

/// A condition a mode-specific statusword bit can show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Shows {
    /// The bit is not used in the mode (always 0).
    Nothing,
    /// Target reached: the mode's target inside its window (6067h/6068h for a position,
    /// 606Dh/606Eh for a velocity), the torque ramp arrived, the homing move ended.
    TargetReached,
    /// Internal limit active: a target or demand limited (software limits, 6080h, torque
    /// limits, a limit switch, the current limit).
    InternalLimit,
    /// Profile position: set-point acknowledge.
    SetPointAcknowledge,
    /// Speed zero: |606Ch| within the velocity threshold 606Fh for 6070h.
    SpeedZero,
    /// Following error: beyond 6065h for longer than 6066h.
    FollowingError,
    /// The drive follows the command value: operation enabled and the master's target is the
    /// input of the loop (no stop, no limit holding it).
    FollowsCommand,
    /// Synchronisation is good: the cycle runs on SYNC0 in OP with no sync error counted.
    Synchronised,
    /// Homing attained.
    HomingAttained,
    /// Homing error.
    HomingError,
    /// Interpolated position: ip mode active.
    InterpolationActive,
    /// The position command or the actual position beyond a software limit 607Dh (the RSE's
    /// bit 11, which shows nothing else).
    SoftwareLimit,
    /// The actual torque has reached the profile's torque-reached level, with hysteresis: set
    /// above the "on" level, cleared below the "off" level (the RSE's "target torque reached"
    /// from 2008h:0Ah-0Ch in PT and CST).
    TorqueReached,
}

impl Shows {
    /// The condition's bit in [`Conditions`] (0 for [`Shows::Nothing`]).
    const fn flag(self) -> u16 {
        match self {
            Shows::Nothing => 0,
            other => 1 << (other as u16),
        }
    }
}

/// The conditions that hold in a cycle (one bit per [`Shows`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Conditions(u16);

impl Conditions {
    /// None holds.
    pub const NONE: Self = Self(0);

    /// `c` holds (or not).
    pub fn set(&mut self, c: Shows, holds: bool) {
        if holds {
            self.0 |= c.flag();
        }
    }

    /// Whether `c` holds.
    pub const fn has(self, c: Shows) -> bool {
        self.0 & c.flag() != 0
    }

    /// The conditions CiA402's layout of `mode` (a 6060h value) shows in statusword bits
    /// 10–13 of `statusword` (the bits as the mode's code sets them).
    pub fn from_cia402(mode: i8, statusword: u16) -> Self {
        cia402(mode).map_or(Self::NONE, |l| Self::shown(&l, statusword))
    }

    /// The conditions `layout` shows in statusword bits 10–13 of `statusword`.
    fn shown(layout: &Layout, statusword: u16) -> Self {
        let mut c = Self::NONE;
        for (bit, shows) in layout.bits.iter().enumerate() {
            c.set(*shows, statusword & (FIRST_BIT << bit) != 0);
        }
        c
    }
}

/// Statusword bit 10, the first mode-specific bit.
const FIRST_BIT: u16 = 1 << 10;

/// The statusword bits a layout owns (10–13).
pub const MODE_BITS: u16 = 0xF * FIRST_BIT;

/// What statusword bits 10, 11, 12 and 13 show in a mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Bits 10, 11, 12, 13.
    pub bits: [Shows; 4],
}

impl Layout {
    /// Statusword bits 10–13 for the conditions `c`.
    pub fn statusword(&self, c: Conditions) -> u16 {
        let mut sw = 0;
        for (bit, shows) in self.bits.iter().enumerate() {
            if c.has(*shows) {
                sw |= FIRST_BIT << bit;
            }
        }
        sw
    }

    /// Whether a bit shows `c`.
    pub fn shows(&self, c: Shows) -> bool {
        c != Shows::Nothing && self.bits.contains(&c)
    }
}

/// A profile's own layout for a mode (its manual's statusword table for it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Override {
    /// The 6060h value.
    pub mode: i8,
    /// Bits 10–13 in that mode.
    pub layout: Layout,
}

/// CiA402's layout of `mode` (a 6060h value); `None` for a mode CiA402 does not define.
pub const fn cia402(mode: i8) -> Option<Layout> {
    use Shows::*;
    let bits = match mode {
        PP => [
            TargetReached,
            InternalLimit,
            SetPointAcknowledge,
            FollowingError,
        ],
        PV => [TargetReached, InternalLimit, SpeedZero, Nothing],
        PT => [TargetReached, InternalLimit, Nothing, Nothing],
        HM => [TargetReached, InternalLimit, HomingAttained, HomingError],
        IP => [
            TargetReached,
            InternalLimit,
            InterpolationActive,
            FollowingError,
        ],
        CSP => [Nothing, InternalLimit, FollowsCommand, FollowingError],
        CSV | CST => [Nothing, InternalLimit, FollowsCommand, Nothing],
        _ => return None,
    };
    Some(Layout { bits })
}

/// The layout of `mode` in a profile with `overrides`: its own where it has one, else
/// CiA402's.
pub fn layout(mode: i8, overrides: &[Override]) -> Option<Layout> {
    overrides
        .iter()
        .find(|o| o.mode == mode)
        .map(|o| o.layout)
        .or(cia402(mode))
}

/// Statusword bits 10–13 of `statusword` (set as CiA402's layout of `mode` has them) moved to
/// `layout`, with the `extra` conditions only the layout shows; the other bits unchanged.
pub fn relayout(mode: i8, statusword: u16, layout: &Layout, extra: Conditions) -> u16 {
    moved(cia402(mode).as_ref(), statusword, layout, extra)
}

/// [`relayout`] from the `standard` layout the bits are set in.
fn moved(standard: Option<&Layout>, statusword: u16, layout: &Layout, extra: Conditions) -> u16 {
    let mut c = standard.map_or(Conditions::NONE, |l| Conditions::shown(l, statusword));
    c.0 |= extra.0;
    (statusword & !MODE_BITS) | layout.statusword(c)
}

/// The conditions a profile layout may show beyond CiA402's for the mode: the drive works
/// them out in any mode (target reached only in the cyclic position and velocity modes).
pub const EXTRA_CONDITIONS: [Shows; 6] = [
    Shows::SpeedZero,
    Shows::Synchronised,
    Shows::FollowsCommand,
    Shows::TargetReached,
    Shows::SoftwareLimit,
    Shows::TorqueReached,
];

/// Whether a profile layout may show `c` in `mode` (a 6060h value): CiA402's conditions of
/// the mode, and those of [`EXTRA_CONDITIONS`] the drive works out there.
pub fn can_show(mode: i8, c: Shows) -> bool {
    let cyclic_target = matches!(mode, CSP | CSV);
    let torque_mode = matches!(mode, PT | CST);
    let extra = match c {
        Shows::TargetReached => cyclic_target,
        Shows::TorqueReached => torque_mode,
        _ => true,
    };
    c == Shows::Nothing
        || cia402(mode).is_some_and(|l| l.shows(c))
        || (EXTRA_CONDITIONS.contains(&c) && extra)
}

/// Whether any of `overrides` shows `c` (a const fn: a drive decides at build time what it
/// must watch).
pub const fn shown_in(overrides: &[Override], c: Shows) -> bool {
    let mut rest = overrides;
    while let [first, tail @ ..] = rest {
        let mut bits: &[Shows] = &first.layout.bits;
        while let [bit, more @ ..] = bits {
            if *bit as u8 == c as u8 {
                return true;
            }
            bits = more;
        }
        rest = tail;
    }
    false
}

/// The statusword bits 10–13 of the mode the drive runs, resolved once when the mode changes
/// into the masks [`Self::apply`] needs (every cycle), rather than the layouts themselves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeStatus {
    /// Per value of bits 10–13 as CiA402's layout sets them (bit k = statusword bit 10 + k):
    /// the bits of the profile's layout that show the same conditions (one lookup per cycle
    /// instead of a test per bit).
    moved: [u8; 16],
    /// Per bit 10–13 of the profile's layout: the condition it shows ([`Shows::flag`]).
    shows: [u16; 4],
    /// The layout differs from CiA402's for the mode.
    relayout: bool,
    /// The conditions the layout shows that CiA402's does not.
    extra: Conditions,
}

impl ModeStatus {
    /// `mode` (a 6060h value) in a profile with `overrides`; `None` for a mode without a
    /// layout (its code's bits stand).
    pub fn of(mode: i8, overrides: &[Override]) -> Option<Self> {
        let own = layout(mode, overrides)?;
        let standard = cia402(mode);
        let mut extra = Conditions::NONE;
        for c in own.bits {
            extra.set(c, !standard.is_some_and(|l| l.shows(c)));
        }
        let mut moves_to = [0; 4];
        if let Some(standard) = standard {
            for (to, from) in moves_to.iter_mut().zip(standard.bits) {
                for (bit, shows) in own.bits.iter().enumerate() {
                    if from != Shows::Nothing && *shows == from {
                        *to |= 1 << bit;
                    }
                }
            }
        }
        let mut moved = [0; 16];
        for (value, to) in moved.iter_mut().enumerate() {
            for (k, bits) in moves_to.iter().enumerate() {
                if value & (1 << k) != 0 {
                    *to |= bits;
                }
            }
        }
        Some(Self {
            moved,
            shows: own.bits.map(Shows::flag),
            relayout: standard != Some(own),
            extra,
        })
    }

    /// Whether the mode's bits need any work beyond CiA402's: a moved bit or a condition to
    /// work out (the drive skips [`Self::apply`] otherwise, in every cycle).
    pub const fn differs(&self) -> bool {
        self.relayout || self.extra.0 != 0
    }

    /// Whether the layout shows `c` where CiA402's does not (the drive must work it out).
    pub fn needs(&self, c: Shows) -> bool {
        self.extra.has(c)
    }

    /// The mode's bits 10–13 (`statusword`, as CiA402's layout has them) in the profile's
    /// layout, with the `extra` conditions the drive worked out: the same as [`relayout`].
    /// Timing: one lookup and a test per bit, no search of the layouts.
    pub fn apply(&self, statusword: u16, extra: Conditions) -> u16 {
        if !self.relayout {
            return statusword;
        }
        let standard = usize::from((statusword & MODE_BITS) >> FIRST_BIT.trailing_zeros());
        let moved = self.moved.get(standard).copied().unwrap_or(0);
        // The four bits tested side by side (no loop: a compare and an OR each).
        let [s0, s1, s2, s3] = self.shows;
        let e = extra.0;
        let shown = u8::from(e & s0 != 0)
            | u8::from(e & s1 != 0) << 1
            | u8::from(e & s2 != 0) << 2
            | u8::from(e & s3 != 0) << 3;
        (statusword & !MODE_BITS) | u16::from(moved | shown) << FIRST_BIT.trailing_zeros()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Shows::*;

    /// Every condition.
    const ALL: [Shows; 13] = [
        Nothing,
        TargetReached,
        InternalLimit,
        SetPointAcknowledge,
        SpeedZero,
        FollowingError,
        FollowsCommand,
        Synchronised,
        HomingAttained,
        HomingError,
        InterpolationActive,
        SoftwareLimit,
        TorqueReached,
    ];

    #[test]
    fn every_condition_has_its_own_flag() {
        let mut seen = 0u16;
        for s in ALL.iter().skip(1) {
            assert_eq!(seen & s.flag(), 0, "{s:?}");
            seen |= s.flag();
        }
        assert_eq!(Nothing.flag(), 0);
    }

    #[test]
    fn cia402_layouts_are_the_standard_tables() {
        // CiA402: bit 12 is set-point acknowledge in PP, speed in PV, homing attained in HM,
        // ip mode active in IP and "drive follows the command value" in CSP/CSV/CST; bit 13
        // following error in the position modes, homing error in HM.
        let bit = |mode, n: usize| cia402(mode).map(|l| l.bits[n - 10]);
        assert_eq!(bit(PP, 12), Some(SetPointAcknowledge));
        assert_eq!(bit(PV, 12), Some(SpeedZero));
        assert_eq!(bit(HM, 12), Some(HomingAttained));
        assert_eq!(bit(IP, 12), Some(InterpolationActive));
        for mode in [CSP, CSV, CST] {
            assert_eq!(bit(mode, 12), Some(FollowsCommand));
            assert_eq!(bit(mode, 10), Some(Nothing), "CSx bit 10 is reserved");
        }
        assert_eq!(bit(CSP, 13), Some(FollowingError));
        assert_eq!(bit(HM, 13), Some(HomingError));
        assert_eq!(bit(PT, 12), Some(Nothing));
        for mode in [PP, PV, PT, HM, IP, CSP, CSV, CST] {
            assert_eq!(bit(mode, 11), Some(InternalLimit));
        }
        assert_eq!(cia402(-1), None);
        assert_eq!(cia402(0), None);
    }

    #[test]
    fn the_cia402_layout_round_trips() {
        for mode in [PP, PV, PT, HM, IP, CSP, CSV, CST] {
            let l = cia402(mode).unwrap();
            for bits in 0..16u16 {
                let sw = 0x0237 | (bits << 10);
                let kept = sw & !MODE_BITS | l.statusword(Conditions::from_cia402(mode, sw));
                // Bits a layout does not use are dropped, the others kept.
                let used: u16 = (0..4)
                    .filter(|&b| l.bits[b] != Nothing)
                    .map(|b| FIRST_BIT << b)
                    .sum();
                assert_eq!(
                    kept,
                    sw & !(MODE_BITS & !used),
                    "mode {mode} bits {bits:#x}"
                );
            }
        }
    }

    #[test]
    fn a_profile_layout_moves_conditions_to_other_bits() {
        // The SDV3-E's CSV (§7.8): bit 10 speed arrival, bit 11 speed zero, bit 12 successful
        // synchronisation, bit 13 none.
        let csv = Layout {
            bits: [TargetReached, SpeedZero, Synchronised, Nothing],
        };
        let overrides = [Override {
            mode: CSV,
            layout: csv,
        }];
        assert_eq!(layout(CSV, &overrides), Some(csv));
        assert!(shown_in(&overrides, Synchronised));
        assert!(!shown_in(&overrides, FollowsCommand));
        assert!(!shown_in(&[], Synchronised));
        assert_eq!(layout(CSP, &overrides), cia402(CSP));
        // The mode's code set bit 11 (a limit) and bit 12 (follows): neither shows here.
        assert_eq!(
            relayout(CSV, 0x0237 | 1 << 11 | 1 << 12, &csv, Conditions::NONE),
            0x0237
        );
        let mut extra = Conditions::NONE;
        extra.set(SpeedZero, true);
        extra.set(Synchronised, true);
        assert_eq!(
            relayout(CSV, 0x0237, &csv, extra),
            0x0237 | 1 << 11 | 1 << 12
        );
        let mut extra = Conditions::NONE;
        extra.set(TargetReached, true);
        assert_eq!(relayout(CSV, 0x0237, &csv, extra), 0x0237 | 1 << 10);
        // Bits outside 10–13 pass.
        assert_eq!(relayout(CSV, 0x8237, &csv, Conditions::NONE), 0x8237);
    }

    #[test]
    fn a_mode_status_works_out_only_what_cia402_does_not_show() {
        let csv = Layout {
            bits: [TargetReached, SpeedZero, Synchronised, Nothing],
        };
        let overrides = [Override {
            mode: CSV,
            layout: csv,
        }];
        let own = ModeStatus::of(CSV, &overrides).unwrap();
        for (c, needed) in [
            (TargetReached, true),
            (SpeedZero, true),
            (Synchronised, true),
            (FollowsCommand, false),
            (InternalLimit, false),
        ] {
            assert_eq!(own.needs(c), needed, "{c:?}");
        }
        // CiA402's CSP: nothing to work out beyond the mode's own bits, and nothing moved.
        assert!(own.differs());
        let standard = ModeStatus::of(CSP, &overrides).unwrap();
        assert!(!standard.differs());
        assert!(!standard.needs(FollowsCommand));
        assert_eq!(
            standard.apply(0x1237 | 1 << 13, Conditions::NONE),
            0x1237 | 1 << 13
        );
        assert_eq!(ModeStatus::of(-1, &overrides), None);
    }

    #[test]
    fn a_profile_may_show_only_what_the_drive_works_out_in_the_mode() {
        assert!(can_show(CSV, SpeedZero));
        assert!(can_show(CSP, TargetReached));
        assert!(can_show(CST, Synchronised));
        assert!(can_show(PT, SoftwareLimit));
        assert!(can_show(PT, TorqueReached) && can_show(CST, TorqueReached));
        assert!(!can_show(CSP, TorqueReached) && !can_show(PV, TorqueReached));
        assert!(can_show(PP, SetPointAcknowledge));
        // Not worked out there: a torque window in CST, a following error in CSV, set-point
        // acknowledge outside profile position.
        assert!(!can_show(CST, TargetReached));
        assert!(!can_show(CSV, FollowingError));
        assert!(!can_show(CSP, SetPointAcknowledge));
    }

    #[test]
    fn apply_moves_the_bits_as_relayout_does_for_any_layout() {
        // Layouts drawn from every condition (each bit a different one, or the same one twice),
        // every mode, every combination of bits 10-13 and of the extra conditions.
        let modes = [0, PP, PV, PT, HM, IP, CSP, CSV, CST, -1];
        let mut layouts = 0;
        for a in 0..ALL.len() {
            for shift in 1..ALL.len() {
                let pick = |k: usize| ALL[(a + k * shift) % ALL.len()];
                let layout = Layout {
                    bits: [pick(0), pick(1), pick(2), pick(2 + shift % 2)],
                };
                for mode in modes {
                    let overrides = [Override { mode, layout }];
                    let Some(status) = ModeStatus::of(mode, &overrides) else {
                        continue;
                    };
                    layouts += 1;
                    for bits in 0..16u16 {
                        let sw = 0x8237 | bits << 10;
                        for extra_bits in [0u16, 0x00FF, 0x1F00, 0xAAAA, 0x5555, u16::MAX] {
                            let extra = Conditions(extra_bits);
                            let expected = if cia402(mode) == Some(layout) {
                                sw
                            } else {
                                relayout(mode, sw, &layout, extra)
                            };
                            assert_eq!(
                                status.apply(sw, extra),
                                expected,
                                "mode {mode}, {layout:?}, sw {sw:#06x}, extra {extra_bits:#06x}"
                            );
                        }
                    }
                }
            }
        }
        assert!(layouts > 500, "{layouts} layouts");
    }
}
