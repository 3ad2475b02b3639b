//! CiA402 (IEC 61800-7-201) values the scenarios command and check, written once from the
//! standard: the statusword state patterns (Table 30), the homing mode's bits and the modes of
//! operation the scenarios use. The controlwords of the enable sequence are in [`crate::vendor`].

/// A statusword state pattern: (mask, value).
pub type State = (u16, u16);

/// Operation Enabled.
pub const OPERATION_ENABLED: State = (0x6F, 0x27);
/// Switched On.
pub const SWITCHED_ON: State = (0x6F, 0x23);
/// Ready to Switch On.
pub const READY_TO_SWITCH_ON: State = (0x6F, 0x21);
/// Quick Stop Active.
pub const QUICK_STOP_ACTIVE: State = (0x6F, 0x07);
/// Switch On Disabled.
pub const SWITCH_ON_DISABLED: State = (0x4F, 0x40);
/// Fault.
pub const FAULT: State = (0x4F, 0x08);

/// Whether `statusword` shows `state`.
pub fn is(statusword: u16, (mask, value): State) -> bool {
    statusword & mask == value
}

/// Statusword bit 10 "target reached".
pub const TARGET_REACHED: u16 = 1 << 10;
/// Homing mode: controlword bit 4 "homing operation start".
pub const HOMING_START: u16 = 1 << 4;
/// Homing mode: statusword bit 12 "homing attained".
pub const HOMING_ATTAINED: u16 = 1 << 12;
/// Homing mode: statusword bit 13 "homing error".
pub const HOMING_ERROR: u16 = 1 << 13;
/// Homing mode: the status bits 13/12/10.
pub const HOMING_BITS: u16 = TARGET_REACHED | HOMING_ATTAINED | HOMING_ERROR;

/// 6060h: homing mode.
pub const HOMING: i8 = 6;
/// 6060h: cyclic synchronous velocity.
pub const CYCLIC_SYNCHRONOUS_VELOCITY: i8 = 9;
/// 6060h: profile velocity.
pub const PROFILE_VELOCITY: i8 = 3;

/// The modes of operation `profile` supports: its 6502h (bit n−1 is mode n, CiA402: bit 0 PP …
/// bit 9 CST).
pub fn supported_modes(profile: &od_gen::Profile) -> u32 {
    profile
        .entry(0x6502, 0)
        .map(|e| e.initial_bytes())
        .and_then(|b| {
            b.get(..4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        })
        .expect("6502h")
}

/// Whether mode `mode` (1–10) is among `supported` ([`supported_modes`]).
pub fn supports(supported: u32, mode: i8) -> bool {
    (1..=32).contains(&mode) && supported & (1 << (mode - 1)) != 0
}
