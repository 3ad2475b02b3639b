//! ESC configuration registers loaded from the SII configuration area or fixed by the chip:
//! port descriptor 0x0007, ESC configuration 0x0141, SYNC/LATCH PDI configuration 0x0151
//! (Beckhoff ESC datasheet Section II).

/// Port descriptor register 0x0007: 2 bits per port, port `n` in bits `2n..2n+1`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PortDescriptor(pub u8);

impl PortDescriptor {
    /// Port code 00: not implemented.
    pub const NOT_IMPLEMENTED: u8 = 0b00;
    /// Port code 01: not configured (SII EEPROM).
    pub const NOT_CONFIGURED: u8 = 0b01;
    /// Port code 10: EBUS.
    pub const EBUS: u8 = 0b10;
    /// Port code 11: MII / RMII / RGMII.
    pub const MII: u8 = 0b11;

    /// The descriptor with port `n` (0..3) set to `code` (one of the port codes above).
    pub const fn with(self, n: u8, code: u8) -> Self {
        let shift = (n & 0x03) << 1;
        Self((self.0 & !(0b11 << shift)) | ((code & 0b11) << shift))
    }
    /// The code of port `n` (0..3).
    pub const fn port(self, n: u8) -> u8 {
        (self.0 >> ((n & 0x03) << 1)) & 0b11
    }
}

/// ESC configuration register 0x0141 (loaded from SII word 0 high byte).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EscConfig(pub u8);

impl EscConfig {
    /// Bit 0: device emulation (the ESC copies AL control to AL status).
    pub const DEVICE_EMULATION: u8 = 1 << 0;
    /// Bit 1: enhanced link detection on all ports (mirrored to DL status bit 2).
    pub const ENHANCED_LINK_ALL: u8 = 1 << 1;
    /// Bit 2: distributed clocks SYNC out unit enabled.
    pub const DC_SYNC_OUT: u8 = 1 << 2;
    /// Bit 3: distributed clocks latch in unit enabled.
    pub const DC_LATCH_IN: u8 = 1 << 3;

    /// Whether device emulation is on.
    pub const fn device_emulation(self) -> bool {
        self.0 & Self::DEVICE_EMULATION != 0
    }
    /// Whether enhanced link detection is on for all ports.
    pub const fn enhanced_link(self) -> bool {
        self.0 & Self::ENHANCED_LINK_ALL != 0
    }
}

/// SYNC/LATCH PDI configuration register 0x0151 (loaded from SII word 1 high byte).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncLatchConfig(pub u8);

impl SyncLatchConfig {
    /// Bit 2: the SYNC0/LATCH0 pin is a SYNC0 output (0 = LATCH0 input).
    pub const SYNC0_OUTPUT: u8 = 1 << 2;
    /// Bit 3: SYNC0 is mapped to AL event request bit 2 ([`super::AlEvent::SYNC0`]).
    pub const SYNC0_TO_AL_EVENT: u8 = 1 << 3;
    /// Bit 6: the SYNC1/LATCH1 pin is a SYNC1 output (0 = LATCH1 input).
    pub const SYNC1_OUTPUT: u8 = 1 << 6;
    /// Bit 7: SYNC1 is mapped to AL event request bit 3 ([`super::AlEvent::SYNC1`]).
    pub const SYNC1_TO_AL_EVENT: u8 = 1 << 7;

    /// Whether SYNC`n` (0 or 1) drives its pin.
    pub const fn sync_output(self, n: u8) -> bool {
        let bit = if n == 0 {
            Self::SYNC0_OUTPUT
        } else {
            Self::SYNC1_OUTPUT
        };
        self.0 & bit != 0
    }
    /// Whether SYNC`n` (0 or 1) raises its AL event request bit.
    pub const fn sync_to_al_event(self, n: u8) -> bool {
        let bit = if n == 0 {
            Self::SYNC0_TO_AL_EVENT
        } else {
            Self::SYNC1_TO_AL_EVENT
        };
        self.0 & bit != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_0_and_1_mii_is_0x0f() {
        let d = PortDescriptor(0)
            .with(0, PortDescriptor::MII)
            .with(1, PortDescriptor::MII);
        assert_eq!(d.0, 0x0F);
        assert_eq!(d.port(1), PortDescriptor::MII);
        assert_eq!(d.port(2), PortDescriptor::NOT_IMPLEMENTED);
    }

    #[test]
    fn sync_latch_config_0xcc_maps_both_syncs_to_pins_and_events() {
        let c = SyncLatchConfig(0xCC);
        assert!(c.sync_output(0) && c.sync_output(1));
        assert!(c.sync_to_al_event(0) && c.sync_to_al_event(1));
        assert!(!SyncLatchConfig(0x44).sync_to_al_event(0));
    }
}
