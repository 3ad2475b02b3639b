//! Stop reactions (IEC 61800-7-201 §6.3.4–6.3.8, CiA402 objects 605Ah–605Eh): how the drive
//! brings the motor to rest for a quick stop, a shutdown, a disable operation, a halt and a
//! fault, and what follows the standstill (the axis runs the ramp itself:
//! `motor_control::ramp`).
//!
//! | object | cause | codes (CiA402) |
//! |---|---|---|
//! | 605Ah | quick stop | 0 disable drive function; 1/2/3/4 slow down on the slow-down ramp (6084h) / quick-stop ramp (6085h) / current limit / voltage limit, then Switch On Disabled; 5/6/7/8 the same, then stay in Quick Stop Active |
//! | 605Bh | shutdown | 0 disable drive function; 1 slow-down ramp, then disable |
//! | 605Ch | disable operation | 0 disable drive function; 1 slow-down ramp, then disable |
//! | 605Dh | halt | 1/2/3/4 slow-down ramp / quick-stop ramp / current limit / voltage limit, stay in Operation Enabled |
//! | 605Eh | fault reaction | 0 disable drive function; 1/2/3/4 as 605Dh, then Fault (disabled) |
//!
//! A code CiA402 does not define (reserved, manufacturer-specific) has no [`Reaction`]; the
//! caller decides (the device disables the drive function: the motor coasts). A profile gives
//! such codes a meaning with [`VendorCode`]s (the GHA-E stops on 6085h with code 2 of 605Bh and
//! 605Ch), and may ignore 605Eh altogether (its fault stop does not follow the object). A
//! profile without an object may still name the code the drive works with (the RSE halts as
//! with 605Dh = 1), and the commands may disable at once in the torque modes
//! ([`Reactions::commands_at_once`], the Σ-V-SD). In homing the slow-down ramp is the homing
//! acceleration 609Ah (the drive picks the ramp).

/// How the motor is brought to rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Deceleration {
    /// Disable the drive function at once: the motor coasts.
    Coast,
    /// Along the slow-down ramp: profile deceleration 6084h.
    ProfileRamp,
    /// Along the quick-stop ramp: quick stop deceleration 6085h.
    QuickStopRamp,
    /// As fast as the current limit allows.
    CurrentLimit,
    /// As fast as the DC-link voltage limit allows.
    VoltageLimit,
}

/// What follows the standstill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum After {
    /// The drive function is disabled (power stage off, brake applied).
    Disable,
    /// The drive holds the motor at rest, powered (Quick Stop Active with codes 5–8, halt).
    Hold,
}

/// A stop reaction: deceleration, then what follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reaction {
    /// How the motor is brought to rest.
    pub deceleration: Deceleration,
    /// What follows the standstill.
    pub after: After,
}

impl Reaction {
    /// Disable the drive function: the motor coasts.
    pub const COAST: Self = Self {
        deceleration: Deceleration::Coast,
        after: After::Disable,
    };
}

/// Why the drive stops (which option code object applies).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Cause {
    /// Controlword quick stop (605Ah).
    QuickStop,
    /// Controlword shutdown in Operation Enabled (605Bh).
    Shutdown,
    /// Controlword disable operation (605Ch).
    DisableOperation,
    /// Controlword bit 8 halt (605Dh).
    Halt,
    /// A fault (605Eh).
    Fault,
}

/// A profile's meaning of an option code that CiA402 reserves (or defines otherwise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VendorCode {
    /// The stop the code is for (its object).
    pub cause: Cause,
    /// The code.
    pub code: i16,
    /// What it does.
    pub reaction: Reaction,
}

/// The option codes 605Ah–605Eh as the master set them; `None` where the profile has no such
/// object (or ignores it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OptionCodes {
    /// 605Ah.
    pub quick_stop: Option<i16>,
    /// 605Bh.
    pub shutdown: Option<i16>,
    /// 605Ch.
    pub disable_operation: Option<i16>,
    /// 605Dh.
    pub halt: Option<i16>,
    /// 605Eh.
    pub fault_reaction: Option<i16>,
    /// The profile's own codes, before CiA402's.
    pub vendor: &'static [VendorCode],
}

impl OptionCodes {
    /// As a profile without the objects 605Ah–605Eh has them.
    pub const NONE: Self = Self {
        quick_stop: None,
        shutdown: None,
        disable_operation: None,
        halt: None,
        fault_reaction: None,
        vendor: &[],
    };

    /// The code that applies to `cause`, `None` without its object.
    pub const fn of(&self, cause: Cause) -> Option<i16> {
        match cause {
            Cause::QuickStop => self.quick_stop,
            Cause::Shutdown => self.shutdown,
            Cause::DisableOperation => self.disable_operation,
            Cause::Halt => self.halt,
            Cause::Fault => self.fault_reaction,
        }
    }

    /// The reaction to `cause`: [`Reaction::COAST`] for a code CiA402 does not define and for
    /// a missing object (the drive function is disabled, as a drive without stop options
    /// does); `None` for a halt without 605Dh or with a code CiA402 does not define (halt is
    /// not supported: bit 8 is ignored).
    pub fn reaction(&self, cause: Cause) -> Option<Reaction> {
        match (cause, self.of(cause)) {
            (Cause::Halt, None) => None,
            (Cause::Halt, Some(code)) => self.meaning(cause, code),
            (_, None) => Some(Reaction::COAST),
            (_, Some(code)) => Some(self.meaning(cause, code).unwrap_or(Reaction::COAST)),
        }
    }

    /// The profile's meaning of `code` for `cause`, else CiA402's.
    fn meaning(&self, cause: Cause, code: i16) -> Option<Reaction> {
        self.vendor
            .iter()
            .find(|v| v.cause == cause && v.code == code)
            .map(|v| v.reaction)
            .or_else(|| reaction(cause, code))
    }
}

/// The reactions of a drive's option codes, resolved when the codes (or the profile's rules)
/// change rather than in every cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reactions {
    /// 605Ah.
    pub quick_stop: Reaction,
    /// 605Bh.
    pub shutdown: Reaction,
    /// 605Ch.
    pub disable_operation: Reaction,
    /// 605Dh (`None`: halt is not supported, bit 8 is ignored).
    pub halt: Option<Reaction>,
    /// 605Eh.
    pub fault: Reaction,
}

impl Reactions {
    /// A drive without option codes: every stop disables the drive function, no halt.
    pub const NONE: Self = Self {
        quick_stop: Reaction::COAST,
        shutdown: Reaction::COAST,
        disable_operation: Reaction::COAST,
        halt: None,
        fault: Reaction::COAST,
    };

    /// These reactions with quick stop, shutdown and disable operation disabling the drive
    /// function at once (code 0): the Σ-V-SD's rule in its torque modes (§6.4).
    pub const fn commands_at_once(self) -> Self {
        Self {
            quick_stop: Reaction::COAST,
            shutdown: Reaction::COAST,
            disable_operation: Reaction::COAST,
            ..self
        }
    }

    /// The reaction to `cause` (`None`: a halt the drive does not support).
    pub const fn of(&self, cause: Cause) -> Option<Reaction> {
        match cause {
            Cause::QuickStop => Some(self.quick_stop),
            Cause::Shutdown => Some(self.shutdown),
            Cause::DisableOperation => Some(self.disable_operation),
            Cause::Halt => self.halt,
            Cause::Fault => Some(self.fault),
        }
    }
}

impl From<OptionCodes> for Reactions {
    fn from(codes: OptionCodes) -> Self {
        let or_coast = |cause| codes.reaction(cause).unwrap_or(Reaction::COAST);
        Self {
            quick_stop: or_coast(Cause::QuickStop),
            shutdown: or_coast(Cause::Shutdown),
            disable_operation: or_coast(Cause::DisableOperation),
            halt: codes.reaction(Cause::Halt),
            fault: or_coast(Cause::Fault),
        }
    }
}

/// The CiA402 meaning of option code `code` for `cause`, `None` for a code it does not define.
pub const fn reaction(cause: Cause, code: i16) -> Option<Reaction> {
    use After::{Disable, Hold};
    use Deceleration as D;
    let (deceleration, after) = match (cause, code) {
        (Cause::QuickStop | Cause::Shutdown | Cause::DisableOperation | Cause::Fault, 0) => {
            (D::Coast, Disable)
        }
        (Cause::QuickStop | Cause::Shutdown | Cause::DisableOperation | Cause::Fault, 1) => {
            (D::ProfileRamp, Disable)
        }
        (Cause::QuickStop | Cause::Fault, 2) => (D::QuickStopRamp, Disable),
        (Cause::QuickStop | Cause::Fault, 3) => (D::CurrentLimit, Disable),
        (Cause::QuickStop | Cause::Fault, 4) => (D::VoltageLimit, Disable),
        (Cause::QuickStop, 5) | (Cause::Halt, 1) => (D::ProfileRamp, Hold),
        (Cause::QuickStop, 6) | (Cause::Halt, 2) => (D::QuickStopRamp, Hold),
        (Cause::QuickStop, 7) | (Cause::Halt, 3) => (D::CurrentLimit, Hold),
        (Cause::QuickStop, 8) | (Cause::Halt, 4) => (D::VoltageLimit, Hold),
        _ => return None,
    };
    Some(Reaction {
        deceleration,
        after,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_at_once_disable_for_the_commands_only() {
        let ramp = Reaction {
            deceleration: Deceleration::QuickStopRamp,
            after: After::Disable,
        };
        let halt = Some(Reaction {
            deceleration: Deceleration::ProfileRamp,
            after: After::Hold,
        });
        let r = Reactions {
            quick_stop: ramp,
            shutdown: ramp,
            disable_operation: ramp,
            halt,
            fault: ramp,
        }
        .commands_at_once();
        assert_eq!(r.quick_stop, Reaction::COAST);
        assert_eq!(r.shutdown, Reaction::COAST);
        assert_eq!(r.disable_operation, Reaction::COAST);
        // Halt and the fault reaction keep their codes.
        assert_eq!(r.halt, halt);
        assert_eq!(r.fault, ramp);
    }

    #[test]
    fn quick_stop_codes_follow_cia402() {
        use After::*;
        use Deceleration::*;
        let expected = [
            (0, Coast, Disable),
            (1, ProfileRamp, Disable),
            (2, QuickStopRamp, Disable),
            (3, CurrentLimit, Disable),
            (4, VoltageLimit, Disable),
            (5, ProfileRamp, Hold),
            (6, QuickStopRamp, Hold),
            (7, CurrentLimit, Hold),
            (8, VoltageLimit, Hold),
        ];
        for (code, deceleration, after) in expected {
            assert_eq!(
                reaction(Cause::QuickStop, code),
                Some(Reaction {
                    deceleration,
                    after
                }),
                "605Ah = {code}"
            );
        }
        for code in [-1, 9, 100, i16::MIN] {
            assert_eq!(reaction(Cause::QuickStop, code), None);
        }
    }

    #[test]
    fn shutdown_disable_operation_halt_and_fault_codes_follow_cia402() {
        for cause in [Cause::Shutdown, Cause::DisableOperation] {
            assert_eq!(reaction(cause, 0), Some(Reaction::COAST));
            assert_eq!(
                reaction(cause, 1).map(|r| (r.deceleration, r.after)),
                Some((Deceleration::ProfileRamp, After::Disable))
            );
            assert_eq!(reaction(cause, 2), None);
        }
        assert_eq!(reaction(Cause::Halt, 0), None, "605Dh has no code 0");
        assert_eq!(
            reaction(Cause::Halt, 2).map(|r| (r.deceleration, r.after)),
            Some((Deceleration::QuickStopRamp, After::Hold))
        );
        assert_eq!(reaction(Cause::Fault, 0), Some(Reaction::COAST));
        assert_eq!(
            reaction(Cause::Fault, 3).map(|r| (r.deceleration, r.after)),
            Some((Deceleration::CurrentLimit, After::Disable))
        );
        assert_eq!(reaction(Cause::Fault, 5), None);
    }

    #[test]
    fn an_undefined_code_or_a_missing_object_coasts_and_halt_needs_605dh() {
        let codes = OptionCodes {
            quick_stop: Some(42),
            shutdown: None,
            disable_operation: Some(1),
            halt: None,
            fault_reaction: Some(2),
            vendor: &[],
        };
        assert_eq!(codes.reaction(Cause::QuickStop), Some(Reaction::COAST));
        assert_eq!(codes.reaction(Cause::Shutdown), Some(Reaction::COAST));
        assert_eq!(
            codes.reaction(Cause::Fault).map(|r| r.deceleration),
            Some(Deceleration::QuickStopRamp)
        );
        assert_eq!(codes.reaction(Cause::Halt), None, "no 605Dh: no halt");
        let with_halt = OptionCodes {
            halt: Some(0),
            ..codes
        };
        assert_eq!(
            with_halt.reaction(Cause::Halt),
            None,
            "605Dh = 0 is undefined"
        );
    }

    #[test]
    fn a_profile_code_comes_before_cia402_and_applies_to_its_object_only() {
        // The GHA-E: code 2 of 605Bh stops on the quick-stop ramp, then disables.
        const QUICK_STOP_RAMP_THEN_DISABLE: Reaction = Reaction {
            deceleration: Deceleration::QuickStopRamp,
            after: After::Disable,
        };
        let codes = OptionCodes {
            shutdown: Some(2),
            disable_operation: Some(2),
            quick_stop: Some(2),
            vendor: &[VendorCode {
                cause: Cause::Shutdown,
                code: 2,
                reaction: QUICK_STOP_RAMP_THEN_DISABLE,
            }],
            ..OptionCodes::NONE
        };
        assert_eq!(
            codes.reaction(Cause::Shutdown),
            Some(QUICK_STOP_RAMP_THEN_DISABLE)
        );
        // 605Ch = 2 is not the profile's: CiA402 reserves it, the motor coasts.
        assert_eq!(
            codes.reaction(Cause::DisableOperation),
            Some(Reaction::COAST)
        );
        assert_eq!(
            codes.reaction(Cause::QuickStop),
            reaction(Cause::QuickStop, 2)
        );
    }
}
