//! SDO abort codes (ETG.1000.6 §5.6.2.7.2, Table 41).
//!
//! The values are those of CiA 301 plus the EtherCAT-specific codes (`0x0601_0003`..`0x0601_0006`).
//! An abort travels in an *Abort SDO Transfer Request* frame (see `crate::mailbox::coe::sdo`).

/// SDO abort code, ETG.1000.6 Table 41. The discriminant is the value carried on the wire
/// (little-endian u32 in the abort frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u32)]
pub enum AbortCode {
    /// Toggle bit not changed (a segment repeated or out of sequence).
    ToggleBit = 0x0503_0000,
    /// SDO protocol timeout.
    SdoTimeout = 0x0504_0000,
    /// Client/server command specifier not valid or unknown.
    InvalidCommand = 0x0504_0001,
    /// Out of memory.
    OutOfMemory = 0x0504_0005,
    /// Unsupported access to an object (also: complete access where not supported).
    UnsupportedAccess = 0x0601_0000,
    /// Attempt to read a write-only object.
    WriteOnlyRead = 0x0601_0001,
    /// Attempt to write a read-only object.
    ReadOnlyWrite = 0x0601_0002,
    /// Subindex cannot be written, SI0 must be 0 for write access (PDO mapping/assignment editing).
    SubindexNotWritableSi0NonZero = 0x0601_0003,
    /// SDO complete access not supported for objects of variable length such as ENUM object types.
    CompleteAccessVariableLength = 0x0601_0004,
    /// Object length exceeds mailbox size.
    ObjectExceedsMailbox = 0x0601_0005,
    /// Object mapped to RxPDO, SDO download blocked.
    MappedToRxPdo = 0x0601_0006,
    /// The object does not exist in the object dictionary.
    ObjectNotFound = 0x0602_0000,
    /// The object cannot be mapped into the PDO.
    NotMappable = 0x0604_0041,
    /// The number and length of the objects to be mapped would exceed the PDO length.
    PdoLengthExceeded = 0x0604_0042,
    /// General parameter incompatibility reason.
    ParameterIncompatible = 0x0604_0043,
    /// General internal incompatibility in the device.
    InternalIncompatible = 0x0604_0047,
    /// Access failed due to a hardware error.
    HardwareError = 0x0606_0000,
    /// Data type does not match, length of service parameter does not match.
    LengthMismatch = 0x0607_0010,
    /// Data type does not match, length of service parameter too high.
    LengthTooHigh = 0x0607_0012,
    /// Data type does not match, length of service parameter too low.
    LengthTooLow = 0x0607_0013,
    /// Subindex does not exist.
    SubindexNotFound = 0x0609_0011,
    /// Value range of parameter exceeded (only for write access).
    ValueRange = 0x0609_0030,
    /// Value of parameter written too high.
    ValueTooHigh = 0x0609_0031,
    /// Value of parameter written too low.
    ValueTooLow = 0x0609_0032,
    /// Maximum value is less than minimum value.
    MaxLessThanMin = 0x0609_0036,
    /// General error.
    General = 0x0800_0000,
    /// Data cannot be transferred or stored to the application.
    DataNotStored = 0x0800_0020,
    /// Data cannot be transferred or stored to the application because of local control.
    DataNotStoredLocalControl = 0x0800_0021,
    /// Data cannot be transferred or stored to the application because of the present device
    /// state (the entry's access rights exclude the current EtherCAT state).
    DataNotStoredDeviceState = 0x0800_0022,
    /// Object dictionary dynamic generation failed or no object dictionary is present.
    NoObjectDictionary = 0x0800_0023,
}

impl AbortCode {
    /// The value carried on the wire.
    pub const fn code(self) -> u32 {
        self as u32
    }
}

#[cfg(test)]
mod tests {
    use super::AbortCode;

    #[test]
    fn abort_codes_carry_the_etg_1000_6_table_41_values() {
        assert_eq!(AbortCode::ToggleBit.code(), 0x0503_0000);
        assert_eq!(AbortCode::InvalidCommand.code(), 0x0504_0001);
        assert_eq!(AbortCode::SubindexNotWritableSi0NonZero.code(), 0x0601_0003);
        assert_eq!(AbortCode::NotMappable.code(), 0x0604_0041);
        assert_eq!(AbortCode::DataNotStoredDeviceState.code(), 0x0800_0022);
    }
}
