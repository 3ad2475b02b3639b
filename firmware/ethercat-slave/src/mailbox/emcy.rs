//! CoE Emergency (ETG.1000.6 §5.6.4) and the error register 1001h (CiA 301 §7.5.2.2).
//!
//! An emergency is one CoE frame of service 1 (CoE header: number 0, service
//! [`CoeService::Emergency`]) carrying the 8 bytes CiA 301 §7.2.7.3.1 defines:
//!
//! | CoE payload byte | 0..=1 | 2..=3 | 4 | 5..=9 |
//! |---|---|---|---|---|
//! | field | CoE header (0x1000 LE) | error code (u16 LE) | error register (1001h) | manufacturer data |
//!
//! The same 8 bytes are what ethercrab 0.7 (`EmergencyData`, 8 bytes: u16 code, u8 register,
//! 5 bytes) and SOEM 1.4 (`ec_emcyt`: ErrorCode, ErrorReg, bData, w1, w2) decode.
//!
//! Emergencies wait in an [`EmcyQueue`] that the mailbox data-link layer drains only when no
//! mailbox response is waiting to be posted (see [`super::dll`]), so an emergency never takes
//! the place of an SDO response.

use heapless::{Deque, Vec};

use super::coe::{CoeService, COE_HEADER_LEN};

/// Bytes of emergency data after the CoE header (error code, register, 5 bytes data).
pub const EMCY_DATA_LEN: usize = 8;
/// Length of an emergency's mailbox payload (CoE header + data).
pub const EMCY_PAYLOAD_LEN: usize = COE_HEADER_LEN + EMCY_DATA_LEN;
/// Emergencies that can wait for the mailbox (SSC `MAX_EMERGENCIES` has the same role).
pub const EMCY_QUEUE_LEN: usize = 8;
/// Errors that can be active at the same time in an [`ActiveErrors`] set.
pub const MAX_ACTIVE_ERRORS: usize = 8;

/// Emergency error codes (CiA 301 Table 21 "Emergency error codes"; the EtherCAT ones from
/// ETG.1000.6 / the SSC's `EMCY_SM_ERRORCODE`).
pub mod code {
    /// Error reset or no error: sent when the last active error clears.
    pub const ERROR_RESET: u16 = 0x0000;
    /// Generic error.
    pub const GENERIC: u16 = 0x1000;
    /// Current (class 0x2xxx).
    pub const CURRENT: u16 = 0x2000;
    /// Voltage (class 0x3xxx).
    pub const VOLTAGE: u16 = 0x3000;
    /// Temperature (class 0x4xxx).
    pub const TEMPERATURE: u16 = 0x4000;
    /// Device hardware (class 0x5xxx).
    pub const DEVICE_HARDWARE: u16 = 0x5000;
    /// Device software (class 0x6xxx).
    pub const DEVICE_SOFTWARE: u16 = 0x6000;
    /// Monitoring (class 0x8xxx).
    pub const MONITORING: u16 = 0x8000;
    /// Monitoring / communication (0x81xx).
    pub const COMMUNICATION: u16 = 0x8100;
    /// Monitoring / protocol error (0x82xx).
    pub const PROTOCOL: u16 = 0x8200;
    /// EtherCAT state machine: a transition was refused or the slave dropped to a lower state
    /// (SSC `EMCY_SM_ERRORCODE` 0xA000, "Emergency and Diagnosis code for an SyncManager error";
    /// the data bytes carry the AL status code, see `Slave::report_al_error`).
    pub const ESM_TRANSITION: u16 = 0xA000;
    /// Device specific (0xFFxx).
    pub const DEVICE_SPECIFIC: u16 = 0xFF00;
}

/// Bits of the error register 1001h (CiA 301 §7.5.2.2, Table 47).
pub mod register {
    /// Generic error: set whenever any error is active.
    pub const GENERIC: u8 = 1 << 0;
    /// Current.
    pub const CURRENT: u8 = 1 << 1;
    /// Voltage.
    pub const VOLTAGE: u8 = 1 << 2;
    /// Temperature.
    pub const TEMPERATURE: u8 = 1 << 3;
    /// Communication error (overrun, error state).
    pub const COMMUNICATION: u8 = 1 << 4;
    /// Device profile specific.
    pub const DEVICE_PROFILE: u8 = 1 << 5;
    /// Manufacturer specific.
    pub const MANUFACTURER: u8 = 1 << 7;
}

/// The 1001h bits an active error with `code` sets, from its class (CiA 301 Table 21 code
/// ranges → Table 47 bits): 0x2xxx current, 0x3xxx voltage, 0x4xxx temperature, 0x8xxx
/// communication, 0xAxxx (EtherCAT state machine, a communication error) communication,
/// 0xFFxx manufacturer; always the generic bit. [`code::ERROR_RESET`] sets none.
pub const fn register_bits(code: u16) -> u8 {
    if code == code::ERROR_RESET {
        return 0;
    }
    let class = match code >> 12 {
        0x2 => register::CURRENT,
        0x3 => register::VOLTAGE,
        0x4 => register::TEMPERATURE,
        0x8 | 0xA => register::COMMUNICATION,
        0xF if code >= code::DEVICE_SPECIFIC => register::MANUFACTURER,
        _ => 0,
    };
    register::GENERIC | class
}

/// One emergency message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Emergency {
    /// Emergency error code (CiA 301 Table 21, see [`code`]).
    pub code: u16,
    /// Error register 1001h at the time of the error.
    pub register: u8,
    /// Manufacturer-specific error field.
    pub data: [u8; 5],
}

impl Emergency {
    /// An emergency.
    pub const fn new(code: u16, register: u8, data: [u8; 5]) -> Self {
        Self {
            code,
            register,
            data,
        }
    }

    /// The mailbox payload: CoE header (service 1, number 0) + code + register + data.
    pub fn to_payload(&self) -> [u8; EMCY_PAYLOAD_LEN] {
        let [h0, h1] = CoeService::Emergency.header();
        let [c0, c1] = self.code.to_le_bytes();
        let d = self.data;
        [h0, h1, c0, c1, self.register, d[0], d[1], d[2], d[3], d[4]]
    }

    /// Decodes a mailbox payload of type CoE; `None` if it is not an emergency.
    pub fn from_payload(payload: &[u8]) -> Option<Self> {
        let p: &[u8; EMCY_PAYLOAD_LEN] = payload.get(..EMCY_PAYLOAD_LEN)?.try_into().ok()?;
        if [p[0], p[1]] != CoeService::Emergency.header() {
            return None;
        }
        Some(Self {
            code: u16::from_le_bytes([p[2], p[3]]),
            register: p[4],
            data: [p[5], p[6], p[7], p[8], p[9]],
        })
    }
}

/// Emergencies waiting for the mailbox, oldest first.
#[derive(Debug, Default)]
pub struct EmcyQueue {
    queue: Deque<Emergency, EMCY_QUEUE_LEN>,
}

impl EmcyQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            queue: Deque::new(),
        }
    }

    /// Appends `emcy`; when the queue is full it is handed back (the caller decides whether
    /// to drop it or retry).
    pub fn post(&mut self, emcy: Emergency) -> Result<(), Emergency> {
        self.queue.push_back(emcy)
    }

    /// Puts `emcy` back in front (an emergency withdrawn from SM1 before the master read it).
    pub fn requeue(&mut self, emcy: Emergency) -> Result<(), Emergency> {
        self.queue.push_front(emcy)
    }

    /// The oldest emergency.
    pub fn peek(&self) -> Option<&Emergency> {
        self.queue.front()
    }

    /// Takes the oldest emergency.
    pub fn pop(&mut self) -> Option<Emergency> {
        self.queue.pop_front()
    }

    /// Number of waiting emergencies.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Nothing waiting.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Drops every waiting emergency (mailbox reset on the way to INIT).
    pub fn clear(&mut self) {
        self.queue.clear();
    }
}

/// One active error: its code and the 1001h bits it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActiveError {
    /// Emergency error code.
    pub code: u16,
    /// 1001h bits held while the error is active ([`register_bits`] plus any the caller adds,
    /// e.g. [`register::DEVICE_PROFILE`]).
    pub bits: u8,
}

/// What [`ActiveErrors::raise`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Raised {
    /// The error became active.
    New,
    /// The error was already active (its bits were merged).
    AlreadyActive,
    /// The set is full: the error is not tracked individually but keeps the generic bit set
    /// until every error has cleared.
    Overflow,
}

/// The errors active now; the source of 1001h.
#[derive(Clone, Debug, Default)]
pub struct ActiveErrors {
    errors: Vec<ActiveError, MAX_ACTIVE_ERRORS>,
    overflow: bool,
}

impl ActiveErrors {
    /// No error active.
    pub const fn new() -> Self {
        Self {
            errors: Vec::new(),
            overflow: false,
        }
    }

    /// Marks `code` active with [`register_bits`]`(code) | extra_bits`.
    pub fn raise(&mut self, code: u16, extra_bits: u8) -> Raised {
        let bits = register_bits(code) | extra_bits;
        if let Some(e) = self.errors.iter_mut().find(|e| e.code == code) {
            e.bits |= bits;
            return Raised::AlreadyActive;
        }
        match self.errors.push(ActiveError { code, bits }) {
            Ok(()) => Raised::New,
            Err(_) => {
                self.overflow = true;
                Raised::Overflow
            }
        }
    }

    /// Clears `code`; returns whether it was active. The overflow marker clears together
    /// with the last tracked error.
    pub fn clear(&mut self, code: u16) -> bool {
        let Some(i) = self.errors.iter().position(|e| e.code == code) else {
            return false;
        };
        self.errors.swap_remove(i);
        if self.errors.is_empty() {
            self.overflow = false;
        }
        true
    }

    /// Whether `code` is active.
    pub fn is_active(&self, code: u16) -> bool {
        self.errors.iter().any(|e| e.code == code)
    }

    /// No error active.
    pub fn is_empty(&self) -> bool {
        self.errors.is_empty() && !self.overflow
    }

    /// The error register 1001h: the union of the active errors' bits.
    pub fn register(&self) -> u8 {
        let bits = self.errors.iter().fold(0, |acc, e| acc | e.bits);
        if self.overflow {
            bits | register::GENERIC
        } else {
            bits
        }
    }

    /// Forgets every error.
    pub fn reset(&mut self) {
        self.errors.clear();
        self.overflow = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emergency_payload_is_coe_service_1_then_code_register_data() {
        let e = Emergency::new(0xA000, 0x11, [0x1D, 0x00, 0x02, 0x04, 0x00]);
        assert_eq!(
            e.to_payload(),
            [0x00, 0x10, 0x00, 0xA0, 0x11, 0x1D, 0x00, 0x02, 0x04, 0x00]
        );
        assert_eq!(Emergency::from_payload(&e.to_payload()), Some(e));
        // An SDO response header is not an emergency.
        assert_eq!(
            Emergency::from_payload(&[0x00, 0x30, 0, 0, 0, 0, 0, 0, 0, 0]),
            None
        );
        assert_eq!(Emergency::from_payload(&[0x00, 0x10]), None);
    }

    #[test]
    fn register_bits_follow_the_cia301_classes() {
        assert_eq!(register_bits(code::ERROR_RESET), 0);
        assert_eq!(register_bits(0x1000), 0x01);
        assert_eq!(register_bits(0x2310), 0x03);
        assert_eq!(register_bits(0x3210), 0x05);
        assert_eq!(register_bits(0x4210), 0x09);
        assert_eq!(register_bits(0x5000), 0x01);
        assert_eq!(register_bits(0x8130), 0x11);
        assert_eq!(register_bits(code::ESM_TRANSITION), 0x11);
        assert_eq!(register_bits(0xF000), 0x01);
        assert_eq!(register_bits(0xFF42), 0x81);
    }

    #[test]
    fn register_is_the_union_and_clears_with_the_last_error() {
        let mut a = ActiveErrors::new();
        assert_eq!(a.register(), 0);
        assert_eq!(a.raise(0x3210, 0), Raised::New);
        assert_eq!(a.raise(0x4210, register::DEVICE_PROFILE), Raised::New);
        assert_eq!(a.raise(0x3210, 0), Raised::AlreadyActive);
        assert_eq!(a.register(), 0x01 | 0x04 | 0x08 | 0x20);
        assert!(a.clear(0x3210));
        assert!(!a.clear(0x3210));
        assert_eq!(a.register(), 0x01 | 0x08 | 0x20);
        assert!(a.clear(0x4210));
        assert_eq!(a.register(), 0);
        assert!(a.is_empty());
    }

    #[test]
    fn overflowing_errors_keep_the_generic_bit() {
        let mut a = ActiveErrors::new();
        for i in 0..MAX_ACTIVE_ERRORS as u16 {
            assert_eq!(a.raise(0x5000 + i, 0), Raised::New);
        }
        assert_eq!(a.raise(0x2000, 0), Raised::Overflow);
        for i in 0..MAX_ACTIVE_ERRORS as u16 - 1 {
            a.clear(0x5000 + i);
        }
        assert_eq!(a.register(), register::GENERIC);
        a.clear(0x5000 + MAX_ACTIVE_ERRORS as u16 - 1);
        assert_eq!(a.register(), 0);
    }

    #[test]
    fn queue_is_fifo_and_hands_back_when_full() {
        let mut q = EmcyQueue::new();
        for i in 0..EMCY_QUEUE_LEN as u16 {
            assert_eq!(q.post(Emergency::new(i, 0, [0; 5])), Ok(()));
        }
        let extra = Emergency::new(0xFFFF, 0, [0; 5]);
        assert_eq!(q.post(extra), Err(extra));
        assert_eq!(q.pop().map(|e| e.code), Some(0));
        let first = Emergency::new(0x1234, 0, [0; 5]);
        assert_eq!(q.requeue(first), Ok(()));
        assert_eq!(q.peek().map(|e| e.code), Some(0x1234));
        assert_eq!(q.len(), EMCY_QUEUE_LEN);
        q.clear();
        assert!(q.is_empty());
    }
}
