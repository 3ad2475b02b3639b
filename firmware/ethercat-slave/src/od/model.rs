//! The object dictionary as data: what od-gen generates for every profile.
//!
//! Generated code (`OUT_DIR/profiles.rs`, from `od-gen/profiles/*.toml`) builds `static`
//! [`Profile`]s out of these types. Values that can change at run time live in one byte array
//! (the *OD RAM*) at the offset given by [`Value::Ram`]; a profile's [`Profile::defaults`] is the
//! initial content of that array. Multi-byte values are little-endian, exactly as on the wire, so
//! SDO transfers and PDO copies are plain byte copies.

use super::storable::StorageRules;

/// CoE data types (ETG.1000.6 Table 64 / CiA 301), as used in SDO information and SII PDO entries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum DataType {
    /// BOOLEAN (1 bit).
    Boolean = 0x0001,
    /// INTEGER8.
    Integer8 = 0x0002,
    /// INTEGER16.
    Integer16 = 0x0003,
    /// INTEGER32.
    Integer32 = 0x0004,
    /// UNSIGNED8.
    Unsigned8 = 0x0005,
    /// UNSIGNED16.
    Unsigned16 = 0x0006,
    /// UNSIGNED32.
    Unsigned32 = 0x0007,
    /// REAL32.
    Real32 = 0x0008,
    /// VISIBLE_STRING.
    VisibleString = 0x0009,
    /// OCTET_STRING.
    OctetString = 0x000A,
    /// UNICODE_STRING.
    UnicodeString = 0x000B,
    /// DOMAIN.
    Domain = 0x000F,
    /// INTEGER24.
    Integer24 = 0x0010,
    /// REAL64.
    Real64 = 0x0011,
    /// INTEGER64.
    Integer64 = 0x0015,
    /// UNSIGNED24.
    Unsigned24 = 0x0016,
    /// UNSIGNED64.
    Unsigned64 = 0x001B,
    /// BIT1..BIT8 padding/bit types (ETG.1000.6: 0x0030 + n - 1).
    Bit1 = 0x0030,
    /// BIT2.
    Bit2 = 0x0031,
    /// BIT3.
    Bit3 = 0x0032,
    /// BIT4.
    Bit4 = 0x0033,
    /// BIT5.
    Bit5 = 0x0034,
    /// BIT6.
    Bit6 = 0x0035,
    /// BIT7.
    Bit7 = 0x0036,
    /// BIT8.
    Bit8 = 0x0037,
}

impl DataType {
    /// The CoE type code.
    pub const fn code(self) -> u16 {
        self as u16
    }
    /// Whether values of the type have a length given by the entry rather than the type
    /// (strings and domains).
    pub const fn is_variable_length(self) -> bool {
        matches!(
            self,
            Self::VisibleString | Self::OctetString | Self::UnicodeString | Self::Domain
        )
    }
}

/// Object code (ETG.1000.6 Table 63).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ObjectCode {
    /// VAR: a single value at subindex 0.
    Var = 0x07,
    /// ARRAY: subindex 0 holds the number of entries, all entries share one type.
    Array = 0x08,
    /// RECORD: subindex 0 holds the highest subindex, entries may differ in type.
    Record = 0x09,
}

/// Access rights of one entry per EtherCAT state (same bit layout as the ObjAccess field of the
/// SDO information entry description, ETG.1000.6 Table 48).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access(pub u8);

impl Access {
    /// Readable in PREOP.
    pub const READ_PREOP: u8 = 1 << 0;
    /// Readable in SAFEOP.
    pub const READ_SAFEOP: u8 = 1 << 1;
    /// Readable in OP.
    pub const READ_OP: u8 = 1 << 2;
    /// Writable in PREOP.
    pub const WRITE_PREOP: u8 = 1 << 3;
    /// Writable in SAFEOP.
    pub const WRITE_SAFEOP: u8 = 1 << 4;
    /// Writable in OP.
    pub const WRITE_OP: u8 = 1 << 5;
    const READ_ALL: u8 = Self::READ_PREOP | Self::READ_SAFEOP | Self::READ_OP;
    const WRITE_ALL: u8 = Self::WRITE_PREOP | Self::WRITE_SAFEOP | Self::WRITE_OP;

    /// Read-only in every state.
    pub const RO: Self = Self(Self::READ_ALL);
    /// Read/write in every state.
    pub const RW: Self = Self(Self::READ_ALL | Self::WRITE_ALL);
    /// Readable always, writable in PREOP only (ESI `WriteRestrictions="PreOP"`).
    pub const RW_PREOP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP);
    /// Readable always, writable in PREOP and SAFEOP.
    pub const RW_PREOP_SAFEOP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP | Self::WRITE_SAFEOP);
    /// Write-only in every state.
    pub const WO: Self = Self(Self::WRITE_ALL);

    /// Readable in any state.
    pub const fn readable(self) -> bool {
        self.0 & Self::READ_ALL != 0
    }
    /// Writable in any state.
    pub const fn writable(self) -> bool {
        self.0 & Self::WRITE_ALL != 0
    }
}

/// Whether and how an entry may be mapped into a PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdoMappable {
    /// Not mappable.
    No,
    /// Mappable into RxPDOs (outputs, master → slave).
    Rx,
    /// Mappable into TxPDOs (inputs, slave → master).
    Tx,
    /// Mappable into both.
    RxTx,
}

impl PdoMappable {
    /// Mappable into an RxPDO.
    pub const fn rx(self) -> bool {
        matches!(self, Self::Rx | Self::RxTx)
    }
    /// Mappable into a TxPDO.
    pub const fn tx(self) -> bool {
        matches!(self, Self::Tx | Self::RxTx)
    }
}

/// Where an entry's value lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    /// A constant that never changes (identity, device name, ...): the bytes themselves.
    Const(&'static [u8]),
    /// A variable in the OD RAM at this byte offset; its length is the entry's byte length.
    Ram(u16),
    /// A DOMAIN whose data lives outside the OD RAM (up to 64 KiB, e.g. in flash), reached
    /// through a `DomainStore` by this domain id; the entry's `bit_len` is 0 and the current
    /// size comes from the store. Served by segmented SDO transfers only.
    Domain(u8),
}

/// One subindex of an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Subindex.
    pub subindex: u8,
    /// Name (SDO information).
    pub name: &'static str,
    /// Data type.
    pub data_type: DataType,
    /// Size in bits (for strings: 8 × maximum length).
    pub bit_len: u16,
    /// Access rights per state.
    pub access: Access,
    /// PDO mappability.
    pub pdo: PdoMappable,
    /// Storage of the value.
    pub value: Value,
    /// Default value, little-endian (empty when the profile gives none).
    pub default: &'static [u8],
    /// Minimum value, little-endian (empty = no limit beyond the type's).
    pub min: &'static [u8],
    /// Maximum value, little-endian (empty = no limit beyond the type's).
    pub max: &'static [u8],
}

impl Entry {
    /// Size in whole bytes (bit-sized entries round up).
    pub const fn byte_len(&self) -> usize {
        (self.bit_len as usize).div_ceil(8)
    }
}

/// One object (index) of the dictionary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Object {
    /// Index.
    pub index: u16,
    /// Object code.
    pub code: ObjectCode,
    /// Name (SDO information).
    pub name: &'static str,
    /// Entries sorted by subindex; for ARRAY and RECORD, `entries[0]` is subindex 0.
    pub entries: &'static [Entry],
}

impl Object {
    /// The entry with this subindex.
    pub fn entry(&self, subindex: u8) -> Option<&'static Entry> {
        // Most objects number their entries without gaps (subindex n at position n): one
        // comparison instead of a search.
        match self.entries.get(usize::from(subindex)) {
            Some(e) if e.subindex == subindex => Some(e),
            _ => self
                .entries
                .binary_search_by_key(&subindex, |e| e.subindex)
                .ok()
                .and_then(|i| self.entries.get(i)),
        }
    }
}

/// Placement of one SyncManager as the profile declares it (and the SII/ESI carry it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SmLayout {
    /// Physical start address.
    pub start: u16,
    /// Default length in bytes (mailbox size; 0 for process data, whose size comes from the mapping).
    pub length: u16,
    /// Control byte.
    pub control: u8,
}

/// Synchronisation modes and cycle-time limits the device accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncSupport {
    /// Free-run (no synchronisation).
    pub free_run: bool,
    /// Synchronous with the SM2 event.
    pub sm_synchronous: bool,
    /// DC SYNC0.
    pub dc_sync0: bool,
    /// DC SYNC0 + SYNC1.
    pub dc_sync1: bool,
    /// Shortest accepted cycle in ns.
    pub min_cycle_ns: u32,
    /// Longest accepted cycle in ns.
    pub max_cycle_ns: u32,
    /// Granularity of the DC SYNC0 cycle in ns: an accepted cycle is a whole multiple of it
    /// (e.g. the control-loop period); 1 accepts any cycle in range.
    pub cycle_step_ns: u32,
    /// The only DC cycles accepted, when the drive has a fixed set (e.g. 125/250/500/1000/2000 µs
    /// on the GHA-E); empty: every multiple of `cycle_step_ns` in range.
    pub allowed_cycles_ns: &'static [u32],
    /// 1C32h:20 reads TRUE while DC-synchronised without error (the RSE's definition) instead
    /// of ETG.1020's TRUE = sync error.
    pub sync_flag_in_sync: bool,
    /// Shortest free-run cycle in ns: in free run 1C32h:02 is the local timer's period
    /// (ETG.1020) and must lie in `free_run_min_cycle_ns..=free_run_max_cycle_ns` at
    /// PREOP → SAFEOP (else AL status code 0x0035).
    pub free_run_min_cycle_ns: u32,
    /// Longest free-run cycle in ns.
    pub free_run_max_cycle_ns: u32,
    /// Granularity of the input shift time 1C33h:03 the master may write in PREOP, ns; 0: the
    /// entry is read-only. A value that is not a multiple is refused (abort 0x06090030).
    pub input_shift_step_ns: u32,
    /// In a DC mode the input shift must be at most the SYNC0 cycle minus this, ns (else
    /// PREOP → SAFEOP is refused with 0x0035).
    pub input_shift_reserve_ns: u32,
    /// A parameter (index, subindex) that sets 1C33h:03 at power-on, in
    /// [`Self::input_shift_step_ns`] units (SDV3-E P4.09); the master may still write 1C33h:03.
    pub input_shift_parameter: Option<(u16, u8)>,
    /// The sync error counter trips when it reaches 10F1h:02 instead of when it exceeds it.
    pub sync_error_at_limit: bool,
    /// In OP in a DC mode, a SYNC0 at which the master has not written the outputs (SM2) since
    /// the previous SYNC0 counts as a missed event for the sync error counter and 1C32h:0B
    /// (ETG.1020's SM-event supervision; the Σ-V-SD's rule); otherwise only SYNC0 events that
    /// did not come are counted.
    pub sync_error_on_missed_outputs: bool,
    /// The 1C32h subindex that counts missed events (ETG.1020: 0x0B "SM-event missed counter";
    /// the Σ-V-SD has it at 0x0C); 0: the profile's 1C32h has none (the counting still feeds the
    /// sync error counter).
    pub sm_event_missed_subindex: u8,
}

impl SyncSupport {
    /// The DC SYNC0 cycles the profile runs (`min_cycle_ns`, `max_cycle_ns`, `cycle_step_ns`,
    /// `allowed_cycles_ns`), as the rule od-gen checks a profile's cycles with.
    pub const fn dc_cycle_rule(&self) -> hal::esc::DcCycleRule<'static> {
        hal::esc::DcCycleRule {
            min_ns: self.min_cycle_ns,
            max_ns: self.max_cycle_ns,
            step_ns: self.cycle_step_ns,
            allowed_ns: self.allowed_cycles_ns,
        }
    }

    /// The value of 1C32h:20 (BOOLEAN): ETG.1020 "sync error" = `error`; with
    /// [`Self::sync_flag_in_sync`] it is TRUE while `dc_synchronised` and no error.
    pub fn sync_error_flag(&self, error: bool, dc_synchronised: bool) -> u8 {
        let flag = if self.sync_flag_in_sync {
            dc_synchronised && !error
        } else {
            error
        };
        u8::from(flag)
    }

    /// Whether `shift_ns` is a value the master may write to the input shift time 1C33h:03: a
    /// whole multiple of [`Self::input_shift_step_ns`] (the range is the entry's).
    pub fn input_shift_on_step(&self, shift_ns: u32) -> bool {
        shift_ns.checked_rem(self.input_shift_step_ns) == Some(0)
    }
}

/// EtherCAT state machine rules of a profile (profile section `[esm]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EsmRules {
    /// SAFEOP → OP only after the master wrote the outputs once (Beckhoff SSC
    /// `OP_PD_REQUIRED`; ETG.1000.6 leaves it to the device).
    pub op_requires_outputs: bool,
    /// How long a SAFEOP → OP request may wait for the first SYNC0 / the first outputs before
    /// it is refused, in ms (ESI `Info/StateMachine/Timeout/SafeopOpTimeout`).
    pub safeop_op_timeout_ms: u32,
    /// The error the application raises (a drive: 603Fh, PDS Fault; and its EMCY) when the
    /// EtherCAT state leaves OP while the application was active (a drive: Operation Enabled or
    /// Quick Stop Active);
    /// `None`: the application only puts its outputs into their safe state.
    pub op_exit_while_enabled_error: Option<ErrorReport>,
    /// AL errors the stack raises by itself (sync error, SM watchdog, PLL, a refused cycle
    /// time, ...) that the drive also reports as one of its errors: the application raises the
    /// report (603Fh, PDS Fault) and its EMCY goes out in place of the ESM transition emergency.
    /// Sorted by AL status code.
    pub al_error_alarms: &'static [AlErrorAlarm],
    /// Link supervision of the input port (port 0): when its link is lost in PREOP, SAFEOP or
    /// OP the slave goes to INIT with AL status code 0x0000 and the application raises this
    /// error (the SDV3-E's LL, §5.2 3); `None`: the link is not supervised.
    pub link_loss_error: Option<ErrorReport>,
    /// The AL status code of a sync error the counter detects while the SYNC unit runs:
    /// 0x001A (ETG.1000.6 "synchronization error") or 0x002C ("fatal sync error", e.g. the
    /// SDV3-E's cS).
    pub sync_error_al_code: u16,
    /// In SAFEOP with a DC mode configured, SYNC0 must start within this many ms of entering
    /// SAFEOP, else the slave drops to PREOP with 0x002D (the SDV3-E's PLF, §5.2 7); `None`:
    /// only a SAFEOP → OP request waits for SYNC0 (`safeop_op_timeout_ms`).
    pub sync_lock_timeout_ms: Option<u32>,
    /// PDI supervision: when the ESC's PDI error counter (0x030D) counts an error, the slave
    /// goes to INIT with AL status code 0x0000, the ERR LED on (ETG.1300 "application
    /// controller failure"), and the application raises this error (the SDV3-E's Hr, §5.2 1);
    /// `None`: not supervised.
    pub pdi_error: Option<ErrorReport>,
    /// Supervision of the outputs in the cyclic synchronous modes (the SDV3-E's cSD, §5.2 6);
    /// `None`: not supervised.
    pub lost_outputs: Option<LostOutputsRule>,
    /// AL status codes whose ERR LED pattern the profile gives in place of ETG.1300's (the
    /// SDV3-E flashes once for its PDO watchdog timeout Pto, §5.2 4, where ETG.1300 flashes
    /// twice). Sorted by code.
    pub al_error_leds: &'static [(u16, ErrLed)],
}

/// An ERR LED pattern a manual gives an AL error (ETG.1300 Table 4 patterns).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrLed {
    /// 200 ms on, 200 ms off (ETG.1300: invalid configuration).
    Blinking,
    /// One 200 ms flash per 1.2 s (ETG.1300: local error).
    SingleFlash,
    /// Two 200 ms flashes per 1.6 s (ETG.1300: process-data watchdog timeout).
    DoubleFlash,
    /// Steady on (ETG.1300: application controller failure).
    On,
}

/// `[esm] lost_outputs`: in OP with DC synchronisation, while an entry holds one of the given
/// values (the drive's cyclic synchronous modes in 6061h), a SYNC0 without new outputs (no SM2
/// event since the previous SYNC0) counts one lost cycle, a SYNC0 with new outputs restarts
/// the count; when it reaches the limit the slave drops to SAFEOP with the given AL status code
/// and the application raises the error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LostOutputsRule {
    /// The parameter holding the number of consecutive lost cycles that trips (0: no
    /// supervision); read at power-on (the SDV3-E's P4.03 takes effect after a power cycle).
    pub limit_parameter: (u16, u8),
    /// The entry whose value decides whether the outputs are supervised (6061h).
    pub while_entry: (u16, u8),
    /// The values of [`Self::while_entry`] (as read, zero-extended) under which they are.
    pub while_values: &'static [u32],
    /// The AL status code of the error: 0x001A "synchronization error" or 0x002C "fatal sync
    /// error" (ETG.1000.6 Table 11; the SDV3-E's cSD is 0x002C).
    pub al_status_code: u16,
    /// The error the application raises.
    pub error: ErrorReport,
}

/// How a profile forms the error register 1001h and the stack's own emergencies (`[emcy]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmcyRules {
    /// The 1001h bits the drive uses: 0xFF for every CiA 301 class bit, 0x01 for a drive that
    /// sets only the generic bit (Σ-V-SD §4.2). Applied to 1001h and the register byte of
    /// every emergency.
    pub register_mask: u8,
    /// The emergency code of an AL error the profile does not report as one of its alarms
    /// (ETG.1000.6: 0xA000 "EtherCAT state machine transition"; FF00h on a drive whose every
    /// emergency is FF00h).
    pub al_error_code: u16,
}

impl EmcyRules {
    /// CiA 301 error register classes and ETG's AL error emergency.
    pub const CIA301: Self = Self {
        register_mask: 0xFF,
        al_error_code: 0xA000,
    };
}

/// One `[esm] al_error_alarms` row: an AL status code and the error the drive reports with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlErrorAlarm {
    /// AL status code (ETG.1000.6 Table 11).
    pub al_status_code: u16,
    /// The drive's error.
    pub report: ErrorReport,
}

/// An application error as the profile reports it: the error code the application holds (a
/// drive's 603Fh) and the EMCY message (e.g. a vendor alarm: the Σ-V-SD sends FF00h with its
/// alarm number in the manufacturer field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ErrorReport {
    /// The application's error code (603Fh).
    pub error_code: u16,
    /// EMCY bytes 0–1.
    pub emcy_code: u16,
    /// EMCY bytes 3–7 (manufacturer-specific error field).
    pub emcy_data: [u8; 5],
}

impl ErrorReport {
    /// The same code in the application and the EMCY, no manufacturer data.
    pub const fn code(code: u16) -> Self {
        Self {
            error_code: code,
            emcy_code: code,
            emcy_data: [0; 5],
        }
    }
}

impl EsmRules {
    /// [`Self::safeop_op_timeout_ms`] in ns.
    pub const fn safeop_op_timeout_ns(&self) -> u64 {
        // A u32 of ms is below 2^52 ns: never saturates.
        (self.safeop_op_timeout_ms as u64).saturating_mul(1_000_000)
    }

    /// [`Self::sync_lock_timeout_ms`] in ns.
    pub fn sync_lock_timeout_ns(&self) -> Option<u64> {
        self.sync_lock_timeout_ms
            .map(|ms| u64::from(ms) * 1_000_000)
    }

    /// The ERR LED pattern the profile gives AL status code `code`, if it differs from ETG's.
    pub fn al_error_led(&self, code: u16) -> Option<ErrLed> {
        // Linear, as `al_error_alarm`: a short table on the error path.
        self.al_error_leds
            .iter()
            .find(|(c, _)| *c == code)
            .map(|(_, led)| *led)
    }

    /// The drive error the profile reports with AL status code `code`, if any.
    pub fn al_error_alarm(&self, code: u16) -> Option<ErrorReport> {
        // A linear scan of a short table, on the error path only: core's binary search keeps
        // a slice-index panic branch the cycle interrupt must not reach (`panic-paths`).
        self.al_error_alarms
            .iter()
            .find(|a| a.al_status_code == code)
            .map(|a| a.report)
    }
}

/// What an SDO download to an entry mapped in the active RxPDO mapping does in SAFEOP and OP
/// (profile key `pdo.sdo_write_to_rx_mapped`). In PREOP no PDO runs and the write is always
/// served.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RxMappedWrite {
    /// Refused with abort 0x06010006 "object mapped to RxPDO, SDO download blocked"
    /// (ETG.1000.6 Table 41).
    Blocked,
    /// Written; the next process-data cycle overwrites the value.
    Allowed,
}

/// CoE services the device supports (SII General CoE details, ESI `Mailbox/CoE` attributes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoeDetails {
    /// SDO upload/download.
    pub sdo: bool,
    /// SDO information service.
    pub sdo_info: bool,
    /// PDO assignment (1C12h/1C13h) writable.
    pub pdo_assign: bool,
    /// PDO mapping (16xxh/1Axxh) writable.
    pub pdo_config: bool,
    /// Upload of the PDO configuration at start-up.
    pub upload_at_startup: bool,
    /// SDO complete access.
    pub complete_access: bool,
}

/// Identity and communication layout of a device: the facts the ESM checks the master's
/// configuration against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Profile name (the od-gen file stem).
    pub profile: &'static str,
    /// Device name (1008h, SII name string).
    pub name: &'static str,
    /// Vendor ID (1018h:01).
    pub vendor_id: u32,
    /// Product code (1018h:02).
    pub product_code: u32,
    /// Revision (1018h:03).
    pub revision: u32,
    /// SM0: mailbox master → slave.
    pub mailbox_out: SmLayout,
    /// SM1: mailbox slave → master.
    pub mailbox_in: SmLayout,
    /// Bootstrap mailbox out, if BOOT is supported.
    pub boot_mailbox_out: Option<SmLayout>,
    /// Bootstrap mailbox in, if BOOT is supported.
    pub boot_mailbox_in: Option<SmLayout>,
    /// SM2: process data outputs.
    pub outputs: SmLayout,
    /// SM3: process data inputs.
    pub inputs: SmLayout,
    /// Accepted synchronisation.
    pub sync: SyncSupport,
    /// Maximum number of entries in one PDO.
    pub max_pdo_entries: u8,
    /// Largest byte length of one PDO (≤ [`crate::pdo::rules::MAX_PDO_BYTES`]); a mapping
    /// beyond it is refused with 0x06040042.
    pub max_pdo_bytes: u16,
    /// Largest process image per direction in bytes (≤ [`crate::pdo::MAX_IMAGE`]); an
    /// assignment beyond it is refused at PREOP → SAFEOP with 0x0025 (outputs) / 0x0024 (inputs).
    pub max_process_bytes: u16,
    /// Mailbox protocols (SII word 0x1C bits: 0x01 AoE, 0x02 EoE, 0x04 CoE, 0x08 FoE, 0x10 SoE,
    /// 0x20 VoE).
    pub mailbox_protocols: u16,
    /// CoE services.
    pub coe: CoeDetails,
    /// ESM rules.
    pub esm: EsmRules,
    /// SDO download to an RxPDO-mapped entry in SAFEOP/OP.
    pub sdo_write_to_rx_mapped: RxMappedWrite,
    /// A parameter (index, subindex; UNSIGNED16) whose value, if not 0, the slave writes to the
    /// configured station alias 0x0012 at power-on ([`crate::slave::SlaveCore::start`]), in
    /// place of the alias the ESC loaded from SII word 4 (e.g. the GHA-E's Pn-410).
    pub station_alias_parameter: Option<(u16, u8)>,
    /// The alias parameter applies only while this entry (index, subindex) holds this value
    /// (SDV3-E P4.02 = 1); `None`: whenever it is not 0.
    pub station_alias_selector: Option<(u16, u8, u32)>,
    /// How the error register and emergencies are formed (profile section `[emcy]`).
    pub emcy: EmcyRules,
    /// The startup parameters ("settings": profile `setting = true`; SDO information list
    /// type 5, ObjAccess bit 9), as `(index, subindex)` sorted ascending.
    pub settings: &'static [(u16, u8)],
}

impl DeviceInfo {
    /// Whether this is the profile `name`; `-` and `_` are the same character, so the CLI name
    /// `sigma-v-sd` and the Rust module spelling `sigma_v_sd` both match.
    pub fn is_profile(&self, name: &str) -> bool {
        let a = self.profile.as_bytes();
        a.len() == name.len()
            && a.iter()
                .zip(name.bytes())
                .all(|(&x, y)| x == y || (matches!(x, b'-' | b'_') && matches!(y, b'-' | b'_')))
    }
    /// Whether `index:subindex` is a startup parameter ([`Self::settings`]).
    pub fn is_setting(&self, index: u16, subindex: u8) -> bool {
        self.settings.binary_search(&(index, subindex)).is_ok()
    }
}

/// The object dictionary of one device: what the slave stack knows about a profile.
#[derive(Clone, Copy, Debug)]
pub struct Profile {
    /// Identity and SM layout.
    pub device: DeviceInfo,
    /// All objects, sorted by index.
    pub objects: &'static [Object],
    /// Initial OD RAM content; its length is the OD RAM size.
    pub defaults: &'static [u8],
    /// Entries that accept only listed values (profile key `allowed`), sorted by
    /// (index, subindex): an SDO download of another value is refused with 0x06090030.
    pub value_lists: &'static [ValueList],
    /// What the parameter storage stores, per 1010h/1011h subindex and on SDO download, and
    /// when (profile section `[storage]`; see [`crate::params`]).
    pub storage: StorageRules,
}

/// The values an entry accepts (e.g. the modes of operation a drive supports in 6060h).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ValueList {
    /// Index.
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// The accepted values.
    pub values: &'static [i64],
}

impl Profile {
    /// The values `index:subindex` accepts, if the profile lists them.
    pub fn value_list(&self, index: u16, subindex: u8) -> Option<&'static [i64]> {
        self.value_lists
            .binary_search_by_key(&(index, subindex), |l| (l.index, l.subindex))
            .ok()
            .and_then(|i| self.value_lists.get(i))
            .map(|l| l.values)
    }
    /// The object with this index.
    pub fn object(&self, index: u16) -> Option<&'static Object> {
        self.objects
            .binary_search_by_key(&index, |o| o.index)
            .ok()
            .and_then(|i| self.objects.get(i))
    }
    /// Size of the OD RAM in bytes.
    pub const fn ram_size(&self) -> usize {
        self.defaults.len()
    }
}
