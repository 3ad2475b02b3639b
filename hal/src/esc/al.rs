//! Application-layer registers: AL control/status/status code, AL event request, ECAT event
//! request, DL control and status, feature flags.

/// EtherCAT state machine state (ETG.1000.6 §6.4.1), as coded in AL control/status bits 0..3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum AlState {
    /// INIT.
    Init = 0x01,
    /// PRE-OPERATIONAL.
    PreOp = 0x02,
    /// BOOTSTRAP.
    Boot = 0x03,
    /// SAFE-OPERATIONAL.
    SafeOp = 0x04,
    /// OPERATIONAL.
    Op = 0x08,
}

impl AlState {
    /// Decodes the 4 state bits; `None` for a code that names no state (answered with AL
    /// status code 0x0012 "unknown requested state").
    pub const fn from_bits(bits: u8) -> Option<Self> {
        match bits & 0x0F {
            0x01 => Some(Self::Init),
            0x02 => Some(Self::PreOp),
            0x03 => Some(Self::Boot),
            0x04 => Some(Self::SafeOp),
            0x08 => Some(Self::Op),
            _ => None,
        }
    }
    /// The 4 state bits.
    pub const fn bits(self) -> u8 {
        self as u8
    }
}

/// AL control register 0x0120 (written by the master).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlControl {
    /// Requested state bits (may name no valid state).
    pub state_bits: u8,
    /// Bit 4: error indication acknowledge.
    pub ack: bool,
    /// Bit 5: device identification request.
    pub id_request: bool,
}

impl AlControl {
    const STATE_MASK: u16 = 0x000F;
    const ACK: u16 = 0x0010;
    const ID_REQUEST: u16 = 0x0020;

    /// Decodes the register value.
    pub const fn from_bits(v: u16) -> Self {
        Self {
            state_bits: (v & Self::STATE_MASK) as u8,
            ack: v & Self::ACK != 0,
            id_request: v & Self::ID_REQUEST != 0,
        }
    }
    /// Encodes the register value.
    pub const fn bits(self) -> u16 {
        (self.state_bits as u16 & Self::STATE_MASK)
            | if self.ack { Self::ACK } else { 0 }
            | if self.id_request { Self::ID_REQUEST } else { 0 }
    }
    /// The requested state, if the bits name one.
    pub const fn requested(self) -> Option<AlState> {
        AlState::from_bits(self.state_bits)
    }
}

/// AL status register 0x0130 (written by the slave).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlStatus {
    /// Current state.
    pub state: AlState,
    /// Bit 4: error indication (AL status code valid), held until acknowledged.
    pub error: bool,
    /// Bit 5: device identification value loaded into AL status code.
    pub id_loaded: bool,
}

impl AlStatus {
    const ERROR: u16 = 0x0010;
    const ID_LOADED: u16 = 0x0020;

    /// Encodes the register value.
    pub const fn bits(self) -> u16 {
        self.state.bits() as u16
            | if self.error { Self::ERROR } else { 0 }
            | if self.id_loaded { Self::ID_LOADED } else { 0 }
    }
    /// Decodes the register value; `None` if the state bits name no state.
    pub const fn from_bits(v: u16) -> Option<Self> {
        match AlState::from_bits(v as u8) {
            Some(state) => Some(Self {
                state,
                error: v & Self::ERROR != 0,
                id_loaded: v & Self::ID_LOADED != 0,
            }),
            None => None,
        }
    }
}

/// AL status codes (ETG.1000.6 Table 11, ETG.1020).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum AlStatusCode {
    /// No error.
    NoError = 0x0000,
    /// Unspecified error.
    Unspecified = 0x0001,
    /// No memory.
    NoMemory = 0x0002,
    /// Invalid requested state change.
    InvalidStateChange = 0x0011,
    /// Unknown requested state.
    UnknownState = 0x0012,
    /// Bootstrap not supported.
    BootstrapNotSupported = 0x0013,
    /// No valid firmware.
    NoValidFirmware = 0x0014,
    /// Invalid mailbox configuration (BOOT).
    InvalidBootMailboxConfig = 0x0015,
    /// Invalid mailbox configuration (PREOP).
    InvalidMailboxConfig = 0x0016,
    /// Invalid sync manager configuration.
    InvalidSmConfig = 0x0017,
    /// No valid inputs available.
    NoValidInputs = 0x0018,
    /// No valid outputs.
    NoValidOutputs = 0x0019,
    /// Synchronization error.
    SyncError = 0x001A,
    /// Sync manager watchdog.
    SmWatchdog = 0x001B,
    /// Invalid sync manager types.
    InvalidSmTypes = 0x001C,
    /// Invalid output configuration.
    InvalidOutputConfig = 0x001D,
    /// Invalid input configuration.
    InvalidInputConfig = 0x001E,
    /// Invalid watchdog configuration.
    InvalidWatchdogConfig = 0x001F,
    /// Slave needs cold start.
    NeedsColdStart = 0x0020,
    /// Slave needs INIT.
    NeedsInit = 0x0021,
    /// Slave needs PREOP.
    NeedsPreOp = 0x0022,
    /// Slave needs SAFEOP.
    NeedsSafeOp = 0x0023,
    /// Invalid input mapping.
    InvalidInputMapping = 0x0024,
    /// Invalid output mapping.
    InvalidOutputMapping = 0x0025,
    /// Inconsistent settings.
    InconsistentSettings = 0x0026,
    /// Free-run not supported.
    FreeRunNotSupported = 0x0027,
    /// Synchronization not supported.
    SyncNotSupported = 0x0028,
    /// Free-run needs 3-buffer mode.
    FreeRunNeeds3Buffer = 0x0029,
    /// Background watchdog.
    BackgroundWatchdog = 0x002A,
    /// No valid inputs and outputs.
    NoValidInputsAndOutputs = 0x002B,
    /// Fatal sync error.
    FatalSyncError = 0x002C,
    /// No sync error (SYNC0 expected but not received).
    NoSyncError = 0x002D,
    /// Cycle time too small.
    CycleTimeTooSmall = 0x002E,
    /// Invalid DC SYNC configuration.
    InvalidDcSyncConfig = 0x0030,
    /// Invalid DC latch configuration.
    InvalidDcLatchConfig = 0x0031,
    /// PLL error.
    PllError = 0x0032,
    /// DC sync IO error.
    DcSyncIoError = 0x0033,
    /// DC sync timeout error.
    DcSyncTimeout = 0x0034,
    /// DC invalid sync cycle time.
    DcInvalidSyncCycleTime = 0x0035,
    /// DC SYNC0 cycle time.
    DcSync0CycleTime = 0x0036,
    /// DC SYNC1 cycle time.
    DcSync1CycleTime = 0x0037,
    /// Mailbox AoE.
    MailboxAoe = 0x0041,
    /// Mailbox EoE.
    MailboxEoe = 0x0042,
    /// Mailbox CoE.
    MailboxCoe = 0x0043,
    /// Mailbox FoE.
    MailboxFoe = 0x0044,
    /// Mailbox SoE.
    MailboxSoe = 0x0045,
    /// Mailbox VoE.
    MailboxVoe = 0x004F,
    /// EEPROM no access.
    EepromNoAccess = 0x0050,
    /// EEPROM error.
    EepromError = 0x0051,
    /// Slave restarted locally.
    RestartedLocally = 0x0060,
    /// Device identification value updated.
    DeviceIdUpdated = 0x0061,
    /// Application controller available.
    ApplicationControllerAvailable = 0x00F0,
}

impl AlStatusCode {
    /// The register value.
    pub const fn code(self) -> u16 {
        self as u16
    }
}

/// AL event request register 0x0220 (u32) and AL event mask 0x0204: bit assignments.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AlEvent(pub u32);

impl AlEvent {
    /// AL control register written by the master (cleared by a PDI read of 0x0120).
    pub const AL_CONTROL: u32 = 1 << 0;
    /// DC latch event.
    pub const DC_LATCH: u32 = 1 << 1;
    /// DC SYNC0 (acknowledge mode; cleared by reading 0x098E).
    pub const SYNC0: u32 = 1 << 2;
    /// DC SYNC1 (acknowledge mode; cleared by reading 0x098F).
    pub const SYNC1: u32 = 1 << 3;
    /// SyncManager activation register changed (cleared by a PDI read of the SM activate byte).
    pub const SM_ACTIVATION: u32 = 1 << 4;
    /// EEPROM emulation command pending.
    pub const EEPROM_EMULATION: u32 = 1 << 5;
    /// Process-data watchdog expired (cleared by reading 0x0440).
    pub const WATCHDOG_PD: u32 = 1 << 6;
    /// Reset value of the AL event mask 0x0204 (Section II 0x0204).
    pub const MASK_RESET: u32 = 0x00FF_FF0F;
    /// SyncManager `n` event (buffer written/read by the master).
    pub const fn sm(n: u8) -> u32 {
        bit_u32(8, n)
    }
    /// Whether any of `bits` is set.
    pub const fn any(self, bits: u32) -> bool {
        self.0 & bits != 0
    }
}

/// ECAT event request register 0x0210 (u16) and ECAT event mask 0x0200: bit assignments
/// (Section II 0x0210). The ESC ORs request & mask into the IRQ field of every datagram.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EcatEvent(pub u16);

impl EcatEvent {
    /// Bit 0: DC latch event.
    pub const DC_LATCH: u16 = 1 << 0;
    /// Bit 2: DL status changed (cleared by an ECAT read of 0x0110).
    pub const DL_STATUS: u16 = 1 << 2;
    /// Bit 3: AL status changed (cleared by an ECAT read of 0x0130).
    pub const AL_STATUS: u16 = 1 << 3;
    /// Mirror of SyncManager `n`'s status (n = 0..7): bit 4 + n.
    pub const fn sm(n: u8) -> u16 {
        bit_u16(4, n)
    }
}

/// DL control register 0x0100 (u32, Section II 0x0100).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DlControl(pub u32);

impl DlControl {
    /// Bit 0: forwarding rule (1 = non-EtherCAT frames are destroyed).
    pub const FORWARDING_RULE: u32 = 1 << 0;
    /// Bits 16..18: RX FIFO size.
    pub const RX_FIFO_SIZE_MASK: u32 = 0x0007_0000;
    /// Bit 24 (0x0103 bit 0): the station alias 0x0012 is used for FPxx addressing.
    pub const STATION_ALIAS: u32 = 1 << 24;
    /// Reset value: forwarding rule set, RX FIFO size 7.
    pub const RESET: u32 = Self::FORWARDING_RULE | Self::RX_FIFO_SIZE_MASK;

    /// Whether FPxx datagrams may address the station alias.
    pub const fn station_alias(self) -> bool {
        self.0 & Self::STATION_ALIAS != 0
    }
}

/// DL status register 0x0110.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DlStatus(pub u16);

impl DlStatus {
    /// PDI operational: EEPROM loaded correctly.
    pub const PDI_OPERATIONAL: u16 = 1 << 0;
    /// PDI watchdog status: 1 = not expired.
    pub const PDI_WATCHDOG_OK: u16 = 1 << 1;
    /// Enhanced link detection active.
    pub const ENHANCED_LINK: u16 = 1 << 2;
    /// Physical link on port `n` (n = 0..3).
    pub const fn link(n: u8) -> u16 {
        bit_u16(4, n)
    }
    /// Loop closed on port `n`.
    pub const fn loop_closed(n: u8) -> u16 {
        bit_u16(8, n.saturating_mul(2))
    }
    /// Stable communication on port `n`.
    pub const fn communication(n: u8) -> u16 {
        bit_u16(9, n.saturating_mul(2))
    }
}

/// ESC feature register 0x0008.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EscFeatures(pub u16);

impl EscFeatures {
    /// FMMU bit-wise operation supported.
    pub const FMMU_BIT_OPERATION: u16 = 1 << 0;
    /// Distributed clocks available.
    pub const DC: u16 = 1 << 2;
    /// 64-bit DC.
    pub const DC_64BIT: u16 = 1 << 3;
    /// Low jitter EBUS.
    pub const LOW_JITTER_EBUS: u16 = 1 << 4;
    /// Enhanced link detection EBUS.
    pub const ENHANCED_LINK_EBUS: u16 = 1 << 5;
    /// Enhanced link detection MII.
    pub const ENHANCED_LINK_MII: u16 = 1 << 6;
    /// Separate handling of FCS errors.
    pub const SEPARATE_FCS: u16 = 1 << 7;
    /// Enhanced DC SYNC activation.
    pub const ENHANCED_DC_SYNC: u16 = 1 << 8;
    /// LRW not supported (set = not supported).
    pub const LRW_NOT_SUPPORTED: u16 = 1 << 9;
    /// BRW/APRW/FPRW not supported (set = not supported).
    pub const RW_NOT_SUPPORTED: u16 = 1 << 10;
    /// Fixed FMMU/SM configuration.
    pub const FIXED_FMMU_SM: u16 = 1 << 11;
}

/// Bit `base + n` of a 32-bit register; 0 for an `n` past its top (a SyncManager or port that
/// does not exist has no bit).
const fn bit_u32(base: u8, n: u8) -> u32 {
    match base.checked_add(n) {
        Some(pos) => match 1u32.checked_shl(pos as u32) {
            Some(bit) => bit,
            None => 0,
        },
        None => 0,
    }
}

/// Bit `base + n` of a 16-bit register; 0 for an `n` past its top.
const fn bit_u16(base: u8, n: u8) -> u16 {
    let bit = bit_u32(base, n);
    if bit > u16::MAX as u32 {
        0
    } else {
        bit as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn al_control_preop_with_ack_decodes_from_0x0012() {
        let c = AlControl::from_bits(0x0012);
        assert_eq!(c.requested(), Some(AlState::PreOp));
        assert!(c.ack);
        assert!(!c.id_request);
        assert_eq!(c.bits(), 0x0012);
    }

    #[test]
    fn al_status_safeop_with_error_is_0x14() {
        let s = AlStatus {
            state: AlState::SafeOp,
            error: true,
            id_loaded: false,
        };
        assert_eq!(s.bits(), 0x0014);
        assert_eq!(AlStatus::from_bits(0x0014), Some(s));
    }

    #[test]
    fn unknown_state_bits_decode_to_none() {
        assert_eq!(AlState::from_bits(0x05), None);
        assert_eq!(AlState::from_bits(0x00), None);
        assert_eq!(AlState::from_bits(0x03), Some(AlState::Boot));
    }

    #[test]
    fn ecat_event_sm_bits_start_at_bit_4() {
        assert_eq!(EcatEvent::sm(0), 0x0010);
        assert_eq!(EcatEvent::sm(7), 0x0800);
    }

    #[test]
    fn dl_control_reset_is_forwarding_rule_and_fifo_7() {
        assert_eq!(DlControl::RESET.to_le_bytes(), [0x01, 0x00, 0x07, 0x00]);
        assert!(DlControl(0x0100_0000).station_alias());
    }

    #[test]
    fn al_event_sm_bits_start_at_bit_8() {
        assert_eq!(AlEvent::sm(0), 0x100);
        assert_eq!(AlEvent::sm(3), 0x800);
        assert_eq!(AlEvent::sm(23), 1 << 31);
        assert_eq!(AlEvent::sm(24), 0, "no SM 24: no bit");
        assert_eq!(AlEvent::sm(u8::MAX), 0);
        assert_eq!(EcatEvent::sm(12), 0, "no bit beyond 15");
        assert_eq!(DlStatus::communication(3), 1 << 15);
        assert_eq!(DlStatus::communication(4), 0);
    }
}
