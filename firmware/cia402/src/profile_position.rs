//! The set-point handshake of profile position mode (CiA402 §12, IEC 61800-7-201 "Profile
//! position mode"): controlword bits 4 (new set-point), 5 (change set immediately), 6
//! (absolute/relative) and 9 (change on set-point), statusword bit 12 (set-point acknowledge),
//! the set-point buffer of one entry.
//!
//! | controlword | the set-point latched on the rising edge of bit 4 |
//! |---|---|
//! | bit 5 = 1 | replaces the move under way (and a buffered one) at once |
//! | bit 5 = 0, no move under way | starts at once |
//! | bit 5 = 0, a move under way | waits in the buffer until the move has reached its target; with bit 9 = 1 the move passes its target without stopping |
//! | bit 5 = 0, the buffer full | not accepted (bit 12 stays 1: the master waits for it to fall) |
//!
//! Statusword bit 12 rises when a set-point is accepted; it falls when bit 4 has fallen and the
//! buffer is free. A relative target is relative to the preceding target (the CiA402 default of
//! 60F2h), so relative set-points accumulate exactly, also when one replaces an unfinished
//! move; with no preceding target it is relative to the position the drive holds.
//!
//! Works in user position units (the 607Ah unit, extended to 64 bits) so that relative moves
//! are exact; the drive converts to increments. Generic over what else a set-point latches
//! (`P`: profile velocity and ramps in the drive's units).

use crate::pds::controlword;
use crate::units;

/// Controlword bit 4 "new set-point".
pub const NEW_SET_POINT: u16 = 1 << 4;
/// Controlword bit 5 "change set immediately".
pub const CHANGE_SET_IMMEDIATELY: u16 = 1 << 5;
/// Controlword bit 6 "abs/rel" (CiA402: 1 = relative).
pub const ABS_REL: u16 = 1 << 6;
/// Controlword bit 9 "change on set-point".
pub const CHANGE_ON_SET_POINT: u16 = 1 << 9;
/// Statusword bit 12 "set-point acknowledge".
pub const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;

/// How a profile reads the profile-position controlword bits (its deviations from CiA402).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rules {
    /// Bit 6 set means an absolute target (the SDV3-E's and OSD-G-E's "ABS/INC"), where CiA402
    /// has it mean relative.
    pub bit6_set_is_absolute: bool,
    /// Bit 9 "change on set-point" is not supported and ignored (GHA-E, RSE).
    pub no_change_on_set_point: bool,
    /// No set-point buffer (the RSE, 7.5): after a set-point without bit 5, bit 12 stays set
    /// until the move has reached its target, and a new one is accepted only then; with bit 5
    /// it falls with bit 4 as usual.
    pub no_buffer: bool,
}

/// A set-point: where to go and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SetPoint<P> {
    /// Absolute target, user position units.
    pub target: i64,
    /// Profile velocity and ramps latched with it.
    pub profile: P,
    /// Pass the target at speed into the next set-point (bit 9 with bit 5 = 0).
    pub pass_through: bool,
}

/// The set-points of profile position mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProfilePosition<P> {
    /// The move under way.
    current: Option<SetPoint<P>>,
    /// The next move, waiting for the current one to reach its target.
    buffered: Option<SetPoint<P>>,
    /// The last accepted target (what relative targets add to); `None` before the first.
    last_target: Option<i64>,
    /// Controlword bit 4 of the previous cycle.
    previous_new_set_point: bool,
    /// A set-point was accepted on the rising edge of bit 4, which is still high.
    acknowledged: bool,
    /// Without a buffer: the move under way was accepted without bit 5, so bit 12 holds until
    /// it has reached its target.
    holding: bool,
}

impl<P: Copy> Default for ProfilePosition<P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<P: Copy> ProfilePosition<P> {
    /// No set-point.
    pub const fn new() -> Self {
        Self {
            current: None,
            buffered: None,
            last_target: None,
            previous_new_set_point: false,
            acknowledged: false,
            holding: false,
        }
    }

    /// One cycle with controlword `cw`: on the rising edge of bit 4, the set-point of 607Ah
    /// `target_object` (user units, extended around `held_position`, the position the drive
    /// holds in user units) with `profile` is accepted if it can be. Returns statusword bit 12.
    pub fn step(
        &mut self,
        cw: u16,
        rules: Rules,
        target_object: i32,
        held_position: i64,
        profile: P,
    ) -> u16 {
        let new_set_point = cw & NEW_SET_POINT != 0;
        let rising = new_set_point && !self.previous_new_set_point;
        self.previous_new_set_point = new_set_point;
        if !new_set_point {
            self.acknowledged = false;
        }
        if rising {
            self.acknowledged = self.accept(cw, rules, target_object, held_position, profile);
        }
        if self.acknowledged || self.buffered.is_some() || (self.holding && self.current.is_some())
        {
            SET_POINT_ACKNOWLEDGE
        } else {
            0
        }
    }

    fn accept(
        &mut self,
        cw: u16,
        rules: Rules,
        target_object: i32,
        held_position: i64,
        profile: P,
    ) -> bool {
        let immediately = cw & CHANGE_SET_IMMEDIATELY != 0;
        let full = if rules.no_buffer {
            self.current.is_some()
        } else {
            self.buffered.is_some()
        };
        if !immediately && full {
            return false;
        }
        self.holding = rules.no_buffer && !immediately;
        let bit6 = cw & ABS_REL != 0;
        let relative = bit6 != rules.bit6_set_is_absolute;
        // The preceding target: the buffered move's when one waits behind the current one.
        let base = self
            .buffered
            .or(self.current)
            .map(|s| s.target)
            .or(self.last_target)
            .unwrap_or(held_position);
        let target = if relative {
            base.saturating_add(i64::from(target_object))
        } else {
            units::extend_position(target_object, held_position)
        };
        let pass = !rules.no_change_on_set_point && cw & CHANGE_ON_SET_POINT != 0;
        let set_point = SetPoint {
            target,
            profile,
            pass_through: false,
        };
        self.last_target = Some(target);
        if immediately || self.current.is_none() {
            self.current = Some(set_point);
            self.buffered = None;
        } else {
            if let Some(current) = self.current.as_mut() {
                current.pass_through = pass;
            }
            self.buffered = Some(set_point);
        }
        true
    }

    /// The move under way.
    pub fn current(&self) -> Option<SetPoint<P>> {
        self.current
    }

    /// The move waiting behind the current one.
    pub fn buffered(&self) -> Option<SetPoint<P>> {
        self.buffered
    }

    /// The target the drive goes to or went to last (the target-reached reference), `None`
    /// before the first set-point.
    pub fn target(&self) -> Option<i64> {
        self.current.map(|s| s.target).or(self.last_target)
    }

    /// Whether a set-point is being processed (a move under way or waiting).
    pub fn busy(&self) -> bool {
        self.current.is_some()
    }

    /// The move under way has reached its target: the buffered one, if any, starts.
    pub fn reached(&mut self) {
        self.current = self.buffered.take();
    }

    /// The mode was selected; `previous_cw` is the controlword of the cycle before. Bit 4 set
    /// there and carried into the mode counts as a new set-point only where `start` (a
    /// profile's rule: the Σ-V-SD's dynamic mode change, §3.2 "New positioning will be started
    /// immediately"); CiA402 takes a set-point on a rising edge of bit 4, so there it waits for
    /// the next one. Bit 4 rising in the selecting cycle itself is an edge either way.
    pub fn enter(&mut self, previous_cw: u16, start: bool) {
        self.previous_new_set_point = !start && previous_cw & NEW_SET_POINT != 0;
    }

    /// A cycle in which set-points are not taken (the axis not enabled): bit 4 is still
    /// followed, so that the next rising edge is one against the controlword of the cycle
    /// before (CiA402 6040h bit 4), not against the last one seen while enabled.
    pub fn observe(&mut self, cw: u16) {
        self.previous_new_set_point = cw & NEW_SET_POINT != 0;
    }

    /// Drops every set-point (quick stop, disable, another mode): the drive holds
    /// `held_position` (user units), which relative set-points then add to.
    pub fn clear(&mut self, held_position: i64) {
        self.current = None;
        self.buffered = None;
        self.last_target = Some(held_position);
    }
}

/// Whether controlword `cw` has the halt bit (8) set.
pub fn halted(cw: u16) -> bool {
    cw & controlword::HALT != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    const CIA402: Rules = Rules {
        bit6_set_is_absolute: false,
        no_change_on_set_point: false,
        no_buffer: false,
    };
    const ENABLED: u16 = 0x0F;

    fn pp() -> ProfilePosition<u32> {
        ProfilePosition::new()
    }

    #[test]
    fn a_single_set_point_is_acknowledged_until_bit_4_falls() {
        let mut p = pp();
        assert_eq!(p.step(ENABLED, CIA402, 1000, 0, 7), 0);
        assert_eq!(p.current(), None);
        let ack = p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 7);
        assert_eq!(ack, SET_POINT_ACKNOWLEDGE);
        assert_eq!(
            p.current(),
            Some(SetPoint {
                target: 1000,
                profile: 7,
                pass_through: false
            })
        );
        assert_eq!(
            p.step(ENABLED | NEW_SET_POINT, CIA402, 5, 0, 7),
            SET_POINT_ACKNOWLEDGE
        );
        assert_eq!(
            p.current().unwrap().target,
            1000,
            "no new edge, no new set-point"
        );
        assert_eq!(
            p.step(ENABLED, CIA402, 5, 0, 7),
            0,
            "bit 4 fell, buffer free"
        );
    }

    /// Bit 4 carried into the mode: CiA402 waits for its next rising edge, the Σ-V-SD's
    /// dynamic mode change takes it at once.
    #[test]
    fn bit_4_held_across_a_mode_change_starts_only_by_the_rule() {
        // Rising in the selecting cycle: an edge.
        let mut p = pp();
        p.enter(ENABLED, false);
        let ack = p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 7);
        assert_eq!(ack, SET_POINT_ACKNOWLEDGE);
        // Carried in from the cycle before.
        let mut p = pp();
        p.enter(ENABLED | NEW_SET_POINT, false);
        assert_eq!(p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 7), 0);
        assert_eq!(p.current(), None, "CiA402: no edge");
        p.step(ENABLED, CIA402, 1000, 0, 7);
        p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 7);
        assert_eq!(p.current().map(|s| s.target), Some(1000), "the next edge");
        let mut p = pp();
        p.enter(ENABLED | NEW_SET_POINT, true);
        let ack = p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 7);
        assert_eq!(ack, SET_POINT_ACKNOWLEDGE, "started at the change");
        assert_eq!(p.current().map(|s| s.target), Some(1000));
    }

    #[test]
    fn set_of_set_points_buffers_one_and_refuses_a_third() {
        let mut p = pp();
        p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 1);
        p.step(ENABLED, CIA402, 0, 0, 1);
        // A second one while the first runs: buffered, bit 12 stays set after bit 4 falls.
        p.step(ENABLED | NEW_SET_POINT, CIA402, 2000, 0, 2);
        assert_eq!(p.step(ENABLED, CIA402, 0, 0, 2), SET_POINT_ACKNOWLEDGE);
        assert_eq!(p.buffered().unwrap().target, 2000);
        // A third: the buffer is full, not accepted.
        p.step(ENABLED | NEW_SET_POINT, CIA402, 3000, 0, 3);
        assert_eq!(p.buffered().unwrap().target, 2000);
        assert_eq!(p.step(ENABLED, CIA402, 0, 0, 3), SET_POINT_ACKNOWLEDGE);
        // The first reaches its target: the second starts, the buffer is free.
        p.reached();
        assert_eq!(p.current().unwrap().target, 2000);
        assert_eq!(p.step(ENABLED, CIA402, 0, 0, 3), 0);
        p.reached();
        assert!(!p.busy());
        assert_eq!(p.target(), Some(2000), "still the target-reached reference");
    }

    #[test]
    fn change_set_immediately_replaces_the_move_and_relative_targets_accumulate() {
        let mut p = pp();
        let rel = ENABLED | ABS_REL | CHANGE_SET_IMMEDIATELY;
        p.step(rel | NEW_SET_POINT, CIA402, 1000, 50, 0);
        assert_eq!(
            p.current().unwrap().target,
            1050,
            "relative to the held position"
        );
        p.step(rel, CIA402, 0, 300, 0);
        // Replaces the unfinished move: relative to its target, the remainder is kept (RSE
        // 6.7.3: increment 1 + increment 2).
        p.step(rel | NEW_SET_POINT, CIA402, 500, 300, 0);
        assert_eq!(p.current().unwrap().target, 1550);
        assert_eq!(p.buffered(), None);
        // Absolute, immediately, while moving.
        p.step(ENABLED | CHANGE_SET_IMMEDIATELY, CIA402, 0, 400, 0);
        p.step(
            ENABLED | CHANGE_SET_IMMEDIATELY | NEW_SET_POINT,
            CIA402,
            -20,
            400,
            0,
        );
        assert_eq!(p.current().unwrap().target, -20);
    }

    #[test]
    fn without_a_buffer_bit_12_holds_until_the_move_has_ended() {
        let rse = Rules {
            no_buffer: true,
            ..CIA402
        };
        let mut p = pp();
        assert_eq!(
            p.step(ENABLED | NEW_SET_POINT, rse, 1000, 0, 0),
            SET_POINT_ACKNOWLEDGE
        );
        // Bit 4 falls: bit 12 stays while the move runs.
        assert_eq!(p.step(ENABLED, rse, 1000, 0, 0), SET_POINT_ACKNOWLEDGE);
        // A new set-point without bit 5 meanwhile is not taken.
        p.step(ENABLED | NEW_SET_POINT, rse, 2000, 0, 0);
        p.step(ENABLED, rse, 2000, 0, 0);
        assert_eq!(p.current().unwrap().target, 1000);
        assert_eq!(p.buffered(), None, "no buffer");
        p.reached();
        assert_eq!(
            p.step(ENABLED, rse, 2000, 0, 0),
            0,
            "bit 12 falls at the target"
        );
        // With bit 5 the set-point replaces the move at once and bit 12 falls with bit 4.
        p.step(ENABLED | NEW_SET_POINT, rse, 3000, 0, 0);
        p.step(ENABLED, rse, 3000, 0, 0);
        assert_eq!(
            p.step(
                ENABLED | CHANGE_SET_IMMEDIATELY | NEW_SET_POINT,
                rse,
                4000,
                0,
                0
            ),
            SET_POINT_ACKNOWLEDGE
        );
        assert_eq!(p.current().unwrap().target, 4000);
        assert_eq!(p.step(ENABLED | CHANGE_SET_IMMEDIATELY, rse, 4000, 0, 0), 0);
    }

    #[test]
    fn bit6_polarity_and_bit9_follow_the_profile() {
        let sdv3 = Rules {
            bit6_set_is_absolute: true,
            ..CIA402
        };
        let mut p = pp();
        p.step(ENABLED | ABS_REL | NEW_SET_POINT, sdv3, 1000, 70, 0);
        assert_eq!(
            p.current().unwrap().target,
            1000,
            "bit 6 = 1: absolute (SDV3-E)"
        );
        let mut p = pp();
        p.step(ENABLED | NEW_SET_POINT, sdv3, 1000, 70, 0);
        assert_eq!(p.current().unwrap().target, 1070, "bit 6 = 0: incremental");

        for (rules, pass) in [
            (CIA402, true),
            (
                Rules {
                    no_change_on_set_point: true,
                    ..CIA402
                },
                false,
            ),
        ] {
            let mut p = pp();
            p.step(ENABLED | NEW_SET_POINT, rules, 1000, 0, 0);
            p.step(ENABLED, rules, 0, 0, 0);
            p.step(
                ENABLED | CHANGE_ON_SET_POINT | NEW_SET_POINT,
                rules,
                2000,
                0,
                0,
            );
            assert_eq!(p.current().unwrap().pass_through, pass);
        }
    }

    #[test]
    fn clear_drops_the_set_points_and_rebases_relative_moves() {
        let mut p = pp();
        p.step(ENABLED | NEW_SET_POINT, CIA402, 1000, 0, 0);
        p.step(ENABLED, CIA402, 0, 0, 0);
        p.step(ENABLED | NEW_SET_POINT, CIA402, 2000, 0, 0);
        p.clear(640);
        assert_eq!((p.current(), p.buffered()), (None, None));
        assert_eq!(p.step(ENABLED, CIA402, 0, 640, 0), 0);
        p.step(ENABLED | ABS_REL | NEW_SET_POINT, CIA402, 10, 640, 0);
        assert_eq!(p.current().unwrap().target, 650);
    }

    #[test]
    fn targets_extend_across_the_32_bit_wrap_and_relative_sums_saturate() {
        let mut p = pp();
        let near = i64::from(i32::MAX) - 5;
        p.step(ENABLED | NEW_SET_POINT, CIA402, i32::MIN + 4, near, 0);
        assert_eq!(p.current().unwrap().target, near + 10);
        let mut p = pp();
        p.clear(i64::MAX - 1);
        p.step(ENABLED | ABS_REL | NEW_SET_POINT, CIA402, i32::MAX, 0, 0);
        assert_eq!(p.current().unwrap().target, i64::MAX);
    }
}
