//! Mailbox header (ETG.1000.4 §5.6, Table 29): 6 bytes before every mailbox payload.

/// Header size in bytes.
pub const HEADER_LEN: usize = 6;

/// Mailbox protocol type (header byte 5, bits 0..3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum MailboxType {
    /// Mailbox error reply.
    Error = 0x0,
    /// ADS over EtherCAT.
    Aoe = 0x1,
    /// Ethernet over EtherCAT.
    Eoe = 0x2,
    /// CANopen over EtherCAT.
    Coe = 0x3,
    /// File access over EtherCAT.
    Foe = 0x4,
    /// Servo profile over EtherCAT.
    Soe = 0x5,
    /// Vendor specific.
    Voe = 0xF,
}

/// Mailbox error reply detail codes (ETG.1000.4 Table 30).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum MailboxErrorCode {
    /// Syntax of the 6-byte header is wrong.
    Syntax = 0x0001,
    /// The protocol is not supported.
    UnsupportedProtocol = 0x0002,
    /// Channel field contains a wrong value.
    InvalidChannel = 0x0003,
    /// The service in the protocol is not supported.
    ServiceNotSupported = 0x0004,
    /// The protocol header is not correct.
    InvalidHeader = 0x0005,
    /// Length of received mailbox data is too short.
    SizeTooShort = 0x0006,
    /// Mailbox protocol cannot be processed: not enough resources.
    NoMoreMemory = 0x0007,
    /// The length of the data is inconsistent.
    InvalidSize = 0x0008,
}

/// The "command" word of a mailbox error reply payload: 0x0001 = mailbox error.
pub const MAILBOX_ERROR_COMMAND: u16 = 0x0001;

/// A decoded mailbox header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MailboxHeader {
    /// Payload length after the header.
    pub length: u16,
    /// Station address of the source (master → slave) or destination.
    pub address: u16,
    /// Channel (6 bits).
    pub channel: u8,
    /// Priority (2 bits).
    pub priority: u8,
    /// Raw protocol type (4 bits); see [`MailboxType`].
    pub kind: u8,
    /// Counter 1..7 (0 = not used).
    pub counter: u8,
}

impl MailboxHeader {
    /// Decodes the header at the start of `buf`; `None` if `buf` is shorter than 6 bytes.
    pub fn parse(buf: &[u8]) -> Option<Self> {
        let b: &[u8; HEADER_LEN] = buf.get(..HEADER_LEN)?.try_into().ok()?;
        Some(Self {
            length: u16::from_le_bytes([b[0], b[1]]),
            address: u16::from_le_bytes([b[2], b[3]]),
            channel: b[4] & 0x3F,
            priority: b[4] >> 6,
            kind: b[5] & 0x0F,
            counter: (b[5] >> 4) & 0x07,
        })
    }

    /// Encodes the header.
    pub fn to_bytes(self) -> [u8; HEADER_LEN] {
        let l = self.length.to_le_bytes();
        let a = self.address.to_le_bytes();
        [
            l[0],
            l[1],
            a[0],
            a[1],
            (self.channel & 0x3F) | (self.priority << 6),
            (self.kind & 0x0F) | ((self.counter & 0x07) << 4),
        ]
    }
}

/// Next mailbox counter after `c`: 1, 2, ..., 7, 1, ... (0 is reserved for "no counter").
pub const fn next_counter(c: u8) -> u8 {
    match c.checked_add(1) {
        Some(next) if next <= 7 => next,
        _ => 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coe_header_with_counter_3_decodes() {
        let h = MailboxHeader::parse(&[0x0A, 0x00, 0x00, 0x00, 0x00, 0x33]).unwrap();
        assert_eq!(h.length, 10);
        assert_eq!(h.kind, MailboxType::Coe as u8);
        assert_eq!(h.counter, 3);
        assert_eq!(h.to_bytes(), [0x0A, 0x00, 0x00, 0x00, 0x00, 0x33]);
    }

    #[test]
    fn short_buffer_has_no_header() {
        assert_eq!(MailboxHeader::parse(&[0; 5]), None);
    }

    #[test]
    fn counter_cycles_1_to_7_skipping_0() {
        assert_eq!(next_counter(0), 1);
        assert_eq!(next_counter(6), 7);
        assert_eq!(next_counter(7), 1);
    }
}
