//! What the specifications allow a slave to answer: the oracles' reference, written from the
//! standards (not from the firmware's own tables, so a wrong firmware table is a finding).

/// SDO abort codes, ETG.1000.6 Table 41 (CiA 301 §7.2.4.3.17 plus the EtherCAT codes
/// 0x0601_0003..6).
pub const SDO_ABORT_CODES: &[u32] = &[
    0x0503_0000, // toggle bit not changed
    0x0504_0000, // SDO protocol timeout
    0x0504_0001, // client/server command specifier not valid or unknown
    0x0504_0005, // out of memory
    0x0601_0000, // unsupported access to an object
    0x0601_0001, // attempt to read a write-only object
    0x0601_0002, // attempt to write a read-only object
    0x0601_0003, // subindex cannot be written, SI0 must be 0 for write access
    0x0601_0004, // SDO complete access not supported for variable-length objects
    0x0601_0005, // object length exceeds mailbox size
    0x0601_0006, // object mapped to RxPDO, SDO download blocked
    0x0602_0000, // the object does not exist in the object directory
    0x0604_0041, // the object cannot be mapped into the PDO
    0x0604_0042, // the number and length of the objects to be mapped would exceed the PDO length
    0x0604_0043, // general parameter incompatibility reason
    0x0604_0047, // general internal incompatibility in the device
    0x0606_0000, // access failed due to a hardware error
    0x0607_0010, // data type does not match, length of service parameter does not match
    0x0607_0012, // data type does not match, length of service parameter too high
    0x0607_0013, // data type does not match, length of service parameter too low
    0x0609_0011, // subindex does not exist
    0x0609_0030, // value range of parameter exceeded (only for write access)
    0x0609_0031, // value of parameter written too high
    0x0609_0032, // value of parameter written too low
    0x0609_0036, // maximum value is less than minimum value
    0x0800_0000, // general error
    0x0800_0020, // data cannot be transferred or stored to the application
    0x0800_0021, // ... because of local control
    0x0800_0022, // ... because of the present device state
    0x0800_0023, // object dictionary dynamic generation fails or no object dictionary
];

/// Mailbox error reply detail codes, ETG.1000.4 Table 30 (mailbox type 0x00, type 0x0001).
pub const MAILBOX_ERROR_CODES: std::ops::RangeInclusive<u16> = 0x0001..=0x0008;

/// AL status codes of ETG.1000.6 Table 11; 0x8000..=0xFFFF are vendor-specific.
pub const AL_STATUS_CODES: &[u16] = &[
    0x0000, 0x0001, 0x0002, 0x0003, 0x0004, 0x0011, 0x0012, 0x0013, 0x0014, 0x0015, 0x0016, 0x0017,
    0x0018, 0x0019, 0x001A, 0x001B, 0x001C, 0x001D, 0x001E, 0x001F, 0x0020, 0x0021, 0x0022, 0x0023,
    0x0024, 0x0025, 0x0026, 0x0027, 0x0028, 0x0029, 0x002A, 0x002B, 0x002C, 0x002D, 0x002E, 0x002F,
    0x0030, 0x0031, 0x0032, 0x0033, 0x0034, 0x0035, 0x0036, 0x0037, 0x0041, 0x0042, 0x0043, 0x0044,
    0x0045, 0x004F, 0x0050, 0x0051, 0x0052, 0x0060, 0x0061, 0x0070,
];

/// Whether `code` may stand in the AL status code register (0x0134).
pub fn is_al_status_code(code: u16) -> bool {
    AL_STATUS_CODES.contains(&code) || code >= 0x8000
}

/// Mailbox types (ETG.1000.4 Table 29).
pub mod mailbox_type {
    /// Error reply.
    pub const ERROR: u8 = 0x0;
    /// CANopen over EtherCAT.
    pub const COE: u8 = 0x3;
}

/// CoE services (ETG.1000.6 Table 29, CoE header bits 12..15).
pub mod coe_service {
    /// Emergency.
    pub const EMERGENCY: u8 = 1;
    /// SDO request (also carries "Abort SDO Transfer").
    pub const SDO_REQUEST: u8 = 2;
    /// SDO response.
    pub const SDO_RESPONSE: u8 = 3;
    /// SDO information.
    pub const SDO_INFORMATION: u8 = 8;
}

/// SDO information opcodes a server sends (ETG.1000.6 Table 44): Get OD List response, Get
/// Object Description response, Get Entry Description response, SDO Info Error request.
pub const SDO_INFO_SERVER_OPCODES: &[u8] = &[0x02, 0x04, 0x06, 0x07];
/// The SDO information error request opcode.
pub const SDO_INFO_ERROR: u8 = 0x07;

/// The AL states (ETG.1000.6 Table 9, AL status bits 0..3).
pub mod state {
    /// INIT.
    pub const INIT: u8 = 0x1;
    /// PRE-OPERATIONAL.
    pub const PREOP: u8 = 0x2;
    /// BOOTSTRAP.
    pub const BOOT: u8 = 0x3;
    /// SAFE-OPERATIONAL.
    pub const SAFEOP: u8 = 0x4;
    /// OPERATIONAL.
    pub const OP: u8 = 0x8;
}

/// The state transitions ETG.1000.6 Figure 14 allows a slave to take *upwards* on a master's
/// request (every downward transition is allowed, on request or on an error).
pub fn is_upward_transition(from: u8, to: u8) -> bool {
    use state::*;
    matches!(
        (from, to),
        (INIT, PREOP) | (PREOP, SAFEOP) | (SAFEOP, OP) | (INIT, BOOT)
    )
}

/// Rank of a state for "lower than" (BOOT ranks with INIT's successors: it is left only to INIT).
pub fn rank(state: u8) -> u8 {
    match state {
        state::INIT => 0,
        state::PREOP | state::BOOT => 1,
        state::SAFEOP => 2,
        state::OP => 3,
        _ => u8::MAX,
    }
}
