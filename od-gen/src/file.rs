//! The profile file format as TOML (serde types). See the crate docs and `README.md` for the
//! meaning of every key; [`crate::resolve`] turns a [`ProfileFile`] into a checked
//! [`crate::Profile`].

use std::collections::BTreeMap;

use serde::Deserialize;

/// A whole profile file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileFile {
    /// Profile name (`[a-z][a-z0-9_-]*`, the file stem); the Rust module name in the generated
    /// code is the name with `-` replaced by `_`.
    pub name: String,
    /// Free text describing the profile (ESI device comment is not emitted; for humans).
    #[serde(default)]
    pub description: String,
    /// `"drive"` (default: a CiA402 servo drive, the firmware's profiles) or `"device"` (any
    /// other EtherCAT device built on the slave stack: no `[motor_faults]`).
    #[serde(default)]
    pub kind: Option<String>,
    /// The vendor.
    pub vendor: VendorFile,
    /// Device identity.
    pub device: DeviceFile,
    /// SII EEPROM configuration area and size.
    pub eeprom: EepromFile,
    /// SyncManager layout.
    pub sm: SmFile,
    /// Mailbox protocols and CoE details.
    pub mailbox: MailboxFile,
    /// Synchronisation.
    pub sync: SyncFile,
    /// DC op modes (ESI `Dc/OpMode`, SII DC category).
    #[serde(default, rename = "dc_op_mode")]
    pub dc_op_modes: Vec<DcOpModeFile>,
    /// PDO limits and rules.
    pub pdo: PdoLimitsFile,
    /// EtherCAT state machine rules (optional: every key has a default).
    #[serde(default)]
    pub esm: EsmFile,
    /// `[emcy]`: how 1001h and the stack's own emergencies are formed (optional).
    #[serde(default)]
    pub emcy: EmcyFile,
    /// `[cia402]`: the profile's CiA402 behaviour rules (optional: CiA402 as written).
    #[serde(default)]
    pub cia402: Cia402File,
    /// `[units]`: how the position and velocity objects convert to the drive's internal units.
    #[serde(default)]
    pub units: UnitsFile,
    /// `[storage]`: the parameter storage rules (optional: the default rule and the CiA 301
    /// scopes of 1010h/1011h).
    #[serde(default)]
    pub storage: StorageFile,
    /// `[motor_faults]`: the CiA402 error code (603Fh, EMCY) of each internal motor fault, by
    /// fault name ([`crate::model::MOTOR_FAULT_NAMES`]). In a drive profile every fault must be
    /// mapped (an absent table is reported as every name missing); a device profile has none.
    #[serde(default)]
    pub motor_faults: BTreeMap<String, MotorFaultFile>,
    /// `[[alarm]]`: the drive's alarm / error table (one per row of the manual).
    #[serde(default, rename = "alarm")]
    pub alarms: Vec<AlarmFile>,
    /// `[alarm_objects]`: objects that show the alarms by number.
    #[serde(default)]
    pub alarm_objects: AlarmObjectsFile,
    /// `[warnings]`: drive conditions reported as warnings (statusword bit 7), by condition.
    #[serde(default)]
    pub warnings: BTreeMap<String, WarningFile>,
    /// `[[decision]]`: deviations from the manual, gaps filled and contradictions resolved.
    #[serde(default, rename = "decision")]
    pub decisions: Vec<DecisionFile>,
    /// `[[replicate]]`: object ranges copied to further axes (applied by [`crate::compose`];
    /// kept for the documentation).
    #[serde(default)]
    pub replicate: Vec<ReplicateFile>,
    /// RxPDOs (master → slave, SM2).
    #[serde(default, rename = "rxpdo")]
    pub rx_pdos: Vec<PdoFile>,
    /// TxPDOs (slave → master, SM3).
    #[serde(default, rename = "txpdo")]
    pub tx_pdos: Vec<PdoFile>,
    /// The declared objects.
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectFile>,
    /// `[[adjusting]]`: adjusting-service objects (a vendor's maintenance request/reply
    /// channel, the Σ-V-SD's 2310h).
    #[serde(default)]
    pub adjusting: Vec<AdjustingFile>,
    /// `[[split_value]]`: settings held both by a whole object and by two parameters that split
    /// it (the GHA-E's 6091h and Pn-006..009).
    #[serde(default, rename = "split_value")]
    pub split_values: Vec<SplitValueFile>,
}

/// `[[split_value]]`: `whole` = `high` × `radix` + `low`, kept equal by the drive.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitValueFile {
    /// The whole value's entry, `"0xIIII:S"`.
    pub whole: String,
    /// The parameter with the high part.
    pub high: String,
    /// The parameter with the low part (below `radix`).
    pub low: String,
    /// The factor of the high part (> 1).
    pub radix: u32,
}

/// `[[adjusting]]`: one adjusting-service object.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdjustingFile {
    /// The RECORD: :01 command STRING(16) RW, :02 status USINT RO, :03 reply STRING(16) RO.
    pub object: u16,
    /// The axis it adjusts (default 1).
    #[serde(default = "first_axis")]
    pub axis: u8,
    /// A selection with no further request for this long is aborted, ms.
    pub abort_after_ms: u32,
    /// An execution that has not ended after this long ends in error, ms.
    pub time_limit_ms: u32,
    /// The adjustments.
    pub commands: Vec<AdjustingCommandFile>,
}

fn first_axis() -> u8 {
    1
}

/// One adjustment: `{ code = 0x100E, action = "current_offset_calibration", preparation = false }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdjustingCommandFile {
    /// Request code (CDATA of the selection step), not 0.
    pub code: u16,
    /// `current_offset_calibration`, `multi_turn_reset` or `multi_turn_limit_setting`.
    pub action: String,
    /// Needs the preparation step before execution (default false).
    #[serde(default)]
    pub preparation: bool,
}

/// A `[motor_faults]` value: a CiA402 error code, or the `display` name of an `[[alarm]]`
/// (whose 603Fh code and EMCY bytes are then used).
#[derive(Debug, Clone)]
pub enum MotorFaultFile {
    /// The error code (603Fh and EMCY bytes 0–1; the manufacturer field is zero).
    Code(u16),
    /// An alarm's `display`.
    Alarm(String),
}

impl<'de> Deserialize<'de> for MotorFaultFile {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = MotorFaultFile;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a UINT error code (0x0000..=0xFFFF) or the display of an [[alarm]]")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                u16::try_from(v).map(MotorFaultFile::Code).map_err(|_| {
                    E::custom(format!("{v:#x} is not a UINT error code (0x0000..=0xFFFF)"))
                })
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                self.visit_i64(i64::try_from(v).unwrap_or(i64::MAX))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                Ok(MotorFaultFile::Alarm(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

/// `[[alarm]]`: one row of the drive's alarm table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlarmFile {
    /// The code the drive displays / the manual names the alarm by (unique).
    pub display: String,
    /// Name.
    pub name: String,
    /// 603Fh value while the alarm is active.
    pub error_code: u16,
    /// EMCY bytes 0–1 (default: `error_code`).
    #[serde(default)]
    pub emcy_code: Option<u16>,
    /// EMCY bytes 3–7: the manufacturer-specific error field (default zeros).
    #[serde(default)]
    pub emcy_data: Option<[u8; 5]>,
    /// Whether a fault reset (controlword bit 7) clears it.
    #[serde(default = "alarm_resettable")]
    pub resettable: bool,
    /// Whether it is a warning (statusword bit 7) rather than a fault.
    #[serde(default)]
    pub warning: bool,
    /// What causes it / what the manual says.
    #[serde(default)]
    pub description: String,
}

fn alarm_resettable() -> bool {
    true
}

/// One `[warnings]` row: the code reported while the condition holds (a CiA402 code or an
/// `[[alarm]]` display) and, for the overload conditions, the load that starts it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarningFile {
    /// The error code (603Fh, EMCY) or an `[[alarm]]` display.
    pub report: MotorFaultFile,
    /// Overloads: the I²t load, % of the trip level, from which the warning holds.
    #[serde(default)]
    pub load_percent: Option<u8>,
}

/// `[alarm_objects]`: objects that show the drive's alarms by number: the alarms active now,
/// the last ones (a list, or records selected one at a time), and the command that clears them.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlarmObjectsFile {
    /// What an alarm's number is: "error_number" (EMCY byte 3, the default), "display" (the
    /// digits of its display, e.g. AL.221 → 221) or "error_code" (603Fh).
    #[serde(default)]
    pub number: Option<String>,
    /// An ARRAY whose subindexes 1..n hold the numbers of the active alarms (0: none).
    #[serde(default)]
    pub active: Option<String>,
    /// An object whose subindexes 1..n hold the numbers of the last n alarms, newest at 1.
    #[serde(default)]
    pub history: Option<String>,
    /// An entry that clears the history when 1 is written to it (it reads 0 again).
    #[serde(default)]
    pub history_clear: Option<String>,
    /// An entry that selects the alarm record `history_record` shows: 1 the newest, up to its
    /// maximum.
    #[serde(default)]
    pub history_select: Option<String>,
    /// A RECORD showing the selected alarm record: subindex i is `history_fields[i - 1]`.
    #[serde(default)]
    pub history_record: Option<String>,
    /// What each subindex of `history_record` shows, from subindex 1: "number", "power_on_hours",
    /// "running_time" (s below 32768, else 32768 + h), "speed_rpm", "speed_rpm_5ms_before",
    /// "demand_speed_rpm", "demand_torque_percent", "current_percent", "torque_percent",
    /// "bus_voltage", "demand_position", "mode", "zero".
    #[serde(default)]
    pub history_fields: Vec<String>,
}

/// `[[decision]]`: a choice the profile makes where the manual is silent, wrong or
/// self-contradictory.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecisionFile {
    /// What it is about (an object, a rule, a value).
    pub subject: String,
    /// What the manual says (with the section).
    #[serde(default)]
    pub manual: String,
    /// What the profile does.
    pub choice: String,
    /// Why.
    #[serde(default)]
    pub reason: String,
}

/// `[[replicate]]`: copies of the objects in `first..=last` at `index + offset`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplicateFile {
    /// First index of the range.
    pub first: u16,
    /// Last index of the range (inclusive).
    pub last: u16,
    /// Added to each index.
    pub offset: u16,
}

/// `[units]`: `position` and `velocity`, each a factor table
/// `{ numerator, denominator, scale = [n, d] }` whose sides are integers or entries
/// (`"0x6091:1"`); `velocity` may also be `"position"` (position units per second).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitsFile {
    /// Increments per position unit.
    #[serde(default)]
    pub position: Option<toml::Value>,
    /// Increments/s per velocity unit.
    #[serde(default)]
    pub velocity: Option<toml::Value>,
    /// The acceleration unit (6083h–6085h, 609Ah): absent = the velocity unit per second; a
    /// factor table (increments/s² per unit); or `{ ms_to_rpm = N }` (the time in ms from 0 to
    /// N rpm).
    #[serde(default)]
    pub acceleration: Option<toml::Value>,
    /// Increments/s per unit of the velocity window 606Dh and threshold 606Fh: absent = the
    /// velocity unit; a factor table (e.g. whole rpm: the SDV3-E's, the RSE's).
    #[serde(default)]
    pub velocity_window: Option<toml::Value>,
    /// ‰ of the rated torque per unit of the torque objects (6071h, 6072h, 6074h, 6077h,
    /// 6087h, 60B2h, 60E0h, 60E1h): absent = 1 (CiA402's 0.1 %); a factor table (the
    /// Σ-V-SD's 2304h).
    #[serde(default)]
    pub torque: Option<toml::Value>,
}

/// `[storage]`: what the parameter storage (1010h/1011h) stores beyond the default rule (RAM,
/// writable, not PDO-mappable), the scopes of the 1010h/1011h subindexes, the entries an SDO
/// download stores at once and a condition for some 1010h/1011h subindexes. Entries are written
/// `"0xIIII"` (every entry of an object), `"0xIIII-0xJJJJ"` (of a range of objects) or
/// `"0xIIII:S"` (one entry).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StorageFile {
    /// PDO-mappable entries that are stored nonetheless (parameters a master may also map).
    #[serde(default)]
    pub stored_pdo_mappable: Vec<String>,
    /// Writable entries that are not stored (wins over `stored_pdo_mappable`).
    #[serde(default)]
    pub not_stored: Vec<String>,
    /// `[[storage.group]]`: the scopes of 1010h/1011h subindex 2 and above; given, they replace
    /// the CiA 301 defaults (sub 2 = 1000h–1FFFh, 3 = 6000h–9FFFh, 4 = 2000h–5FFFh).
    #[serde(default, rename = "group")]
    pub groups: Vec<StorageGroupFile>,
    /// `[[storage.auto_store]]`: entries an SDO download stores at once.
    #[serde(default)]
    pub auto_store: Vec<AutoStoreFile>,
    /// `[storage.write_condition]`: some 1010h/1011h subindexes are written only while it holds.
    #[serde(default)]
    pub write_condition: Option<WriteConditionFile>,
}

/// `[[storage.group]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StorageGroupFile {
    /// The 1010h/1011h subindex (≥ 2; 1 is always every parameter).
    pub subindex: u8,
    /// The entries it stores and restores.
    pub ranges: Vec<String>,
}

/// `[[storage.auto_store]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AutoStoreFile {
    /// The entries an SDO download stores at once.
    pub entries: Vec<String>,
    /// While this test holds (after the download), the download is not stored.
    #[serde(default)]
    pub unless: Option<EntryTestFile>,
}

/// A test of an entry's value: `{ entry = "0xIIII:S", mask, value }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EntryTestFile {
    /// The entry read (`"0xIIII:S"`, a readable unsigned entry of at most 32 bits).
    pub entry: String,
    /// The bits compared (default: every bit of the entry).
    #[serde(default)]
    pub mask: Option<u32>,
    /// Their expected value.
    pub value: u32,
}

/// `[storage.write_condition]`: `{ entry, mask, value, subindexes }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WriteConditionFile {
    /// The entry read (`"0xIIII:S"`).
    pub entry: String,
    /// The bits compared (default: every bit of the entry).
    #[serde(default)]
    pub mask: Option<u32>,
    /// Their expected value.
    pub value: u32,
    /// The 1010h/1011h subindexes written only while `(entry & mask) == value`.
    pub subindexes: Vec<u8>,
}

/// `[vendor]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VendorFile {
    /// ETG vendor ID (1018h:01, SII word 0x08).
    pub id: u32,
    /// Vendor name (ESI `Vendor/Name`).
    pub name: String,
}

/// `[device]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceFile {
    /// Device name: 1008h, ESI `Device/Name`, SII string 1.
    pub name: String,
    /// Order number / type text: ESI `Device/Type`.
    pub order_number: String,
    /// Product code (1018h:02).
    pub product_code: u32,
    /// Revision number (1018h:03).
    pub revision: u32,
    /// Serial number default (1018h:04, SII word 0x0E).
    #[serde(default)]
    pub serial: u32,
    /// Hardware version (1009h).
    pub hardware_version: String,
    /// Software version (100Ah).
    pub software_version: String,
    /// ESI group type (`Groups/Group/Type`, `Device/GroupType`).
    pub group_type: String,
    /// ESI group name.
    pub group_name: String,
    /// Physical ports (ESI `Device@Physics`, SII General PhysicalPort), e.g. "YY".
    #[serde(default = "default_physics")]
    pub physics: String,
    /// Device profile number (ESI `Profile/ProfileNo`), 402 for CiA402.
    #[serde(default)]
    pub profile_no: u16,
    /// Number of CiA402 axes (SII General DS402 channels).
    #[serde(default)]
    pub ds402_channels: u8,
}

fn default_physics() -> String {
    "YY".into()
}

/// `[eeprom]`: SII words 0..6 and the image size.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EepromFile {
    /// EEPROM size in bytes (ESI `Eeprom/ByteSize`, SII word 0x3E); a power of two ≥ 128.
    pub byte_size: usize,
    /// Word 0 low byte: PDI control (ESC register 0x0140).
    pub pdi_control: u8,
    /// Word 0 high byte: ESC configuration (0x0141).
    pub esc_config: u8,
    /// Word 1: PDI configuration (0x0150:0x0151).
    pub pdi_config: u16,
    /// Word 2: SYNC impulse length in 10 ns (0x0982).
    pub sync_impulse_len: u16,
    /// Word 3: extended PDI configuration (0x0152:0x0153).
    #[serde(default)]
    pub pdi_config2: u16,
    /// Word 4: configured station alias (0x0012).
    #[serde(default)]
    pub station_alias: u16,
    /// A parameter ("0xIIII:S", UNSIGNED16 in RAM) whose non-zero value the firmware writes to
    /// 0x0012 at power-on, in place of the SII's alias.
    #[serde(default)]
    pub station_alias_parameter: Option<String>,
    /// The parameter is used only while this entry holds this value (SDV3-E P4.02 = 1).
    #[serde(default)]
    pub station_alias_selector: Option<EntryValueFile>,
    /// Words 5 and 6: reserved, ESC-specific.
    #[serde(default)]
    pub reserved: [u16; 2],
}

/// `{ entry = "0xIIII:S", value = n }`: a condition on an entry's value.
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct EntryValueFile {
    /// The entry.
    pub entry: String,
    /// The value it must hold.
    pub value: u32,
}

/// One SyncManager: `{ start, size, control }`.
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct SmFileEntry {
    /// Physical start address.
    pub start: u16,
    /// Size in bytes (mailboxes only; process-data sizes come from the PDOs).
    #[serde(default)]
    pub size: Option<u16>,
    /// Control byte.
    pub control: u8,
}

/// `[sm]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SmFile {
    /// SM0: mailbox master → slave.
    pub mailbox_out: SmFileEntry,
    /// SM1: mailbox slave → master.
    pub mailbox_in: SmFileEntry,
    /// Bootstrap mailbox out (optional).
    #[serde(default)]
    pub boot_out: Option<SmFileEntry>,
    /// Bootstrap mailbox in (optional).
    #[serde(default)]
    pub boot_in: Option<SmFileEntry>,
    /// SM2: process-data outputs.
    pub outputs: SmFileEntry,
    /// SM3: process-data inputs.
    pub inputs: SmFileEntry,
}

/// `[mailbox]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MailboxFile {
    /// Supported protocols: any of "AoE", "EoE", "CoE", "FoE", "SoE", "VoE".
    pub protocols: Vec<String>,
    /// Mailbox data link layer (ESI `Mailbox@DataLinkLayer`, SII General flag b2).
    #[serde(default)]
    pub data_link_layer: bool,
    /// CoE details (required when CoE is listed).
    #[serde(default)]
    pub coe: Option<CoeFile>,
}

/// `[mailbox.coe]`: what the CoE implementation supports (SII General CoE details, ESI
/// `Mailbox/CoE` attributes).
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct CoeFile {
    /// SDO services.
    pub sdo: bool,
    /// SDO information service.
    pub sdo_info: bool,
    /// PDO assignment (1C12h/1C13h) writable.
    pub pdo_assign: bool,
    /// PDO mapping (16xxh/1Axxh) writable.
    pub pdo_config: bool,
    /// Upload of the PDO configuration at startup.
    pub upload_at_startup: bool,
    /// SDO complete access.
    pub complete_access: bool,
}

/// `[sync]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SyncFile {
    /// Free run supported.
    pub free_run: bool,
    /// Synchronous with the SM2 event supported.
    pub sm_synchronous: bool,
    /// DC SYNC0 supported.
    pub dc_sync0: bool,
    /// DC SYNC1 supported.
    #[serde(default)]
    pub dc_sync1: bool,
    /// Shortest cycle in ns (1C32h:05).
    pub min_cycle_ns: u32,
    /// Longest cycle in ns.
    pub max_cycle_ns: u32,
    /// Default cycle time in ns (1C32h:02 / 1C33h:02 default).
    pub default_cycle_ns: u32,
    /// Calc-and-copy time in ns (1C32h:06 / 1C33h:06 default).
    #[serde(default)]
    pub calc_and_copy_ns: u32,
    /// Delay time in ns (1C32h:09 / 1C33h:09 default).
    #[serde(default)]
    pub delay_ns: u32,
    /// Granularity of the DC SYNC0 cycle in ns: an accepted cycle is a whole multiple of it
    /// (default 1: any cycle in range).
    #[serde(default = "one")]
    pub cycle_step_ns: u32,
    /// The only DC cycles accepted (ascending), when the drive has a fixed set; empty: every
    /// multiple of `cycle_step_ns` in range.
    #[serde(default)]
    pub allowed_cycles_ns: Vec<u32>,
    /// Default of 1C32h:01 / 1C33h:01: "free_run", "sm_synchronous" or "dc_sync0" (default:
    /// free run if supported, else SM-synchronous, else DC SYNC0).
    #[serde(default)]
    pub default_sync_mode: Option<String>,
    /// Whether the master may write 1C32h:01 / 1C33h:01 in PREOP (default true).
    #[serde(default = "yes")]
    pub sync_mode_writable: bool,
    /// Whether the master may write 1C32h:02 / 1C33h:02 in PREOP (default true).
    #[serde(default = "yes")]
    pub cycle_time_writable: bool,
    /// 1C32h:20 reads TRUE while DC-synchronised without error (default false: ETG.1020,
    /// TRUE = sync error).
    #[serde(default)]
    pub sync_flag_in_sync: bool,
    /// Shortest free-run cycle (1C32h:02 in free run, the local timer's period), ns; default
    /// `min_cycle_ns`.
    #[serde(default)]
    pub free_run_min_cycle_ns: Option<u32>,
    /// Longest free-run cycle, ns; default `max_cycle_ns`.
    #[serde(default)]
    pub free_run_max_cycle_ns: Option<u32>,
    /// The master may set the input shift time 1C33h:03 (absent: 1C33h:03 is read-only).
    #[serde(default)]
    pub input_shift: Option<InputShiftFile>,
    /// The sync error counter trips when it reaches 10F1h:02 (default false: when it exceeds
    /// it, ETG.1020).
    #[serde(default)]
    pub sync_error_at_limit: bool,
    /// In OP in a DC mode, a SYNC0 without new outputs (SM2) since the previous one counts as a
    /// missed event (default false: only SYNC0 events that did not come).
    #[serde(default)]
    pub sync_error_on_missed_outputs: bool,
    /// The 1C32h subindex that counts missed events (default 0x0B, ETG.1020); 0: none (a
    /// declared 1C32h without a counter).
    #[serde(default = "sm_event_missed_subindex")]
    pub sm_event_missed_subindex: u8,
}

fn sm_event_missed_subindex() -> u8 {
    0x0B
}

/// `[sync.input_shift]`: a writable input shift time 1C33h:03 (ETG.1020: inputs latched this long
/// after SYNC0).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputShiftFile {
    /// An SDO download must be a whole multiple of this, ns (else abort 0x06090030).
    pub step_ns: u32,
    /// At PREOP → SAFEOP in a DC mode the shift must be at most the SYNC0 cycle minus this, ns
    /// (else AL status code 0x0035).
    #[serde(default)]
    pub reserve_ns: u32,
    /// A parameter ("0xIIII:S") that sets 1C33h:03 at power-on, in `step_ns` units (SDV3-E
    /// P4.09).
    #[serde(default)]
    pub parameter: Option<String>,
}

fn one() -> u32 {
    1
}

/// `[esm]`: EtherCAT state machine rules of the profile.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EsmFile {
    /// SAFEOP → OP only after the master wrote the outputs once (default true).
    #[serde(default = "yes")]
    pub op_requires_outputs: bool,
    /// How long a SAFEOP → OP request may wait for the first SYNC0 / outputs, in ms (default
    /// 9000, the ETG ESI default; ESI `Info/StateMachine/Timeout/SafeopOpTimeout`).
    #[serde(default = "default_safeop_op_timeout_ms")]
    pub safeop_op_timeout_ms: u32,
    /// CiA402 error code (603Fh) raised when the EtherCAT state leaves OP while the drive is in
    /// Operation Enabled; absent: the drive is only disabled.
    #[serde(default)]
    pub op_exit_while_enabled_error: Option<MotorFaultFile>,
    /// Link loss on the input port (port 0) in PREOP, SAFEOP or OP: the slave goes to INIT with
    /// AL status code 0x0000 and the drive raises this error (a CiA402 code or an `[[alarm]]`
    /// display; the SDV3-E's LL); absent: no link supervision.
    #[serde(default)]
    pub link_loss_error: Option<MotorFaultFile>,
    /// The AL status code of a sync error the counter detects: 0x001A (default, ETG.1000.6
    /// "synchronization error") or 0x002C ("fatal sync error", the SDV3-E's cS).
    #[serde(default = "sync_error_al_code")]
    pub sync_error_al_code: u16,
    /// In SAFEOP with a DC mode configured, SYNC0 must start within this many ms, else the
    /// slave drops to PREOP with 0x002D (the SDV3-E's PLF); absent: only a SAFEOP → OP request
    /// waits for it (`safeop_op_timeout_ms`).
    #[serde(default)]
    pub sync_lock_timeout_ms: Option<u32>,
    /// AL errors the stack raises by itself (sync error, watchdog, PLL, refused cycle time, ...)
    /// that the drive also reports as one of its errors (603Fh, EMCY in place of the ESM
    /// transition emergency).
    #[serde(default)]
    pub al_error_alarms: Vec<AlErrorAlarmFile>,
    /// The ESC's PDI error counter (0x030D) counted an error: the slave goes to INIT with AL
    /// status code 0x0000, ERR LED on, and the drive raises this error (the SDV3-E's Hr);
    /// absent: the PDI is not supervised.
    #[serde(default)]
    pub pdi_error: Option<MotorFaultFile>,
    /// Outputs lost in a row in the cyclic synchronous modes (the SDV3-E's cSD); absent: not
    /// supervised.
    #[serde(default)]
    pub lost_outputs: Option<LostOutputsFile>,
}

/// `[esm] lost_outputs`: in OP with DC synchronisation, while `while_entry` holds one of
/// `while_values`, `limit_parameter` SYNC0 events in a row without new outputs (no SM2 event
/// since the previous one) drop the slave to SAFEOP with `al_status_code` and raise `error`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LostOutputsFile {
    /// `"0xIIII:S"`: the parameter with the number of lost cycles in a row that trips (0 = no
    /// supervision), read at power-on.
    pub limit_parameter: String,
    /// `"0xIIII:S"`: the entry that selects when the outputs are supervised (6061h).
    pub while_entry: String,
    /// The values of `while_entry` under which they are (the cyclic synchronous modes).
    pub while_values: Vec<i64>,
    /// 0x001A (default) or 0x002C.
    #[serde(default = "sync_error_al_code")]
    pub al_status_code: u16,
    /// The drive error: a CiA402 error code or an `[[alarm]]` display.
    pub error: MotorFaultFile,
}

/// `[emcy]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmcyFile {
    /// `"cia301"` (default: every class bit of CiA 301) or `"generic"` (1001h bit 0 only).
    #[serde(default = "cia301")]
    pub error_register: String,
    /// Emergency code of an AL error that no `[esm] al_error_alarms` row names (default 0xA000,
    /// ETG.1000.6 "EtherCAT state machine transition").
    #[serde(default = "esm_transition_code")]
    pub al_error_code: u16,
    /// The EMCY byte (3–7, the manufacturer-specific field) that carries the number of the axis
    /// (1, 2, ...) a drive error belongs to (the Σ-V-SD's byte 7); none by default.
    #[serde(default)]
    pub axis_number_byte: Option<u8>,
    /// The emergency code of every motor fault given by its 603Fh code (`[motor_faults]`
    /// codes, not alarms): the 603Fh code then travels in the manufacturer field from
    /// `motor_fault_code_byte` on (little-endian; the Σ-V-SD's FF00h with the code in bytes
    /// 4–5). None: the 603Fh code is the emergency code (CiA402).
    #[serde(default)]
    pub motor_fault_code: Option<u16>,
    /// The first of the two EMCY bytes (3–6) that carry a motor fault's 603Fh code under
    /// `motor_fault_code`.
    #[serde(default)]
    pub motor_fault_code_byte: Option<u8>,
}

fn cia301() -> String {
    "cia301".into()
}

/// ETG.1000.6 emergency code 0xA000 (EtherCAT state machine transition).
pub const ESM_TRANSITION_EMCY: u16 = 0xA000;

fn esm_transition_code() -> u16 {
    ESM_TRANSITION_EMCY
}

impl Default for EmcyFile {
    fn default() -> Self {
        Self {
            error_register: cia301(),
            al_error_code: ESM_TRANSITION_EMCY,
            axis_number_byte: None,
            motor_fault_code: None,
            motor_fault_code_byte: None,
        }
    }
}

/// One `[esm] al_error_alarms` row.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlErrorAlarmFile {
    /// The AL status code (ETG.1000.6 Table 11).
    pub al_status_code: u16,
    /// The drive error: a CiA402 error code or an `[[alarm]]` display.
    pub error: MotorFaultFile,
    /// The ERR LED pattern the manual gives this error where it differs from ETG.1300's:
    /// `blinking`, `single_flash`, `double_flash` or `on`.
    #[serde(default)]
    pub err_led: Option<String>,
}

/// ETG.1000.6 AL status code 0x001A "synchronization error".
pub const AL_SYNC_ERROR: u16 = 0x001A;
/// ETG.1000.6 AL status code 0x002C "fatal sync error".
pub const AL_FATAL_SYNC_ERROR: u16 = 0x002C;

fn sync_error_al_code() -> u16 {
    AL_SYNC_ERROR
}

/// The ETG default SafeopOpTimeout of the ESI (ms).
pub const DEFAULT_SAFEOP_OP_TIMEOUT_MS: u32 = 9000;

fn default_safeop_op_timeout_ms() -> u32 {
    DEFAULT_SAFEOP_OP_TIMEOUT_MS
}

impl Default for EsmFile {
    fn default() -> Self {
        Self {
            op_requires_outputs: true,
            safeop_op_timeout_ms: DEFAULT_SAFEOP_OP_TIMEOUT_MS,
            op_exit_while_enabled_error: None,
            link_loss_error: None,
            sync_error_al_code: AL_SYNC_ERROR,
            sync_lock_timeout_ms: None,
            al_error_alarms: Vec::new(),
            pdi_error: None,
            lost_outputs: None,
        }
    }
}

/// `[[dc_op_mode]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DcOpModeFile {
    /// Name (ESI `OpMode/Name`).
    pub name: String,
    /// Description (ESI `OpMode/Desc`).
    #[serde(default)]
    pub description: String,
    /// Value for ESC registers 0x0980:0x0981.
    pub assign_activate: u16,
    /// SYNC0 cycle time in ns (0 = the master's cycle).
    #[serde(default)]
    pub sync0_cycle_ns: u32,
    /// SYNC0 cycle factor (ESI `CycleTimeSync0@Factor`).
    #[serde(default)]
    pub sync0_factor: i16,
    /// SYNC0 shift time in ns.
    #[serde(default)]
    pub sync0_shift_ns: u32,
    /// SYNC1 cycle time in ns (ESI only; the SII has no field for it).
    #[serde(default)]
    pub sync1_cycle_ns: u32,
    /// SYNC1 cycle factor.
    #[serde(default)]
    pub sync1_factor: i16,
    /// SYNC1 shift time in ns.
    #[serde(default)]
    pub sync1_shift_ns: u32,
}

/// `[pdo]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdoLimitsFile {
    /// Maximum number of entries in one PDO (capacity of each 16xxh/1Axxh object).
    pub max_entries: u8,
    /// SDO download to an entry mapped in the active RxPDO mapping in SAFEOP/OP: "blocked"
    /// (abort 0x06010006) or "allowed" (default).
    #[serde(default)]
    pub sdo_write_to_rx_mapped: Option<String>,
    /// How many PDOs 1C12h / 1C13h can assign at once (their highest subindex); default: all
    /// PDOs of the direction.
    #[serde(default)]
    pub max_assigned: Option<u8>,
    /// Largest byte length of one PDO's mapping (default 256, the stack's limit).
    #[serde(default)]
    pub max_pdo_bytes: Option<u16>,
    /// Largest process image per direction: the assigned PDOs of SM2 (and of SM3) together, in
    /// bytes (default 256, the stack's limit).
    #[serde(default)]
    pub max_process_bytes: Option<u16>,
}

/// `[[rxpdo]]` / `[[txpdo]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdoFile {
    /// PDO (mapping object) index.
    pub index: u16,
    /// Name.
    pub name: String,
    /// SyncManager: 2 for RxPDOs, 3 for TxPDOs.
    pub sm: u8,
    /// The mapping cannot be changed.
    #[serde(default)]
    pub fixed: bool,
    /// The PDO must be assigned (ESI `@Mandatory`).
    #[serde(default)]
    pub mandatory: bool,
    /// Part of the default assignment (1C12h/1C13h default, ESI `@Sm`, SII PDO SM byte).
    #[serde(default = "yes")]
    pub assigned: bool,
    /// Default mapping.
    pub entries: Vec<PdoEntryFile>,
}

impl Default for Cia402File {
    fn default() -> Self {
        Self {
            enable_without_mode_error: None,
            mode_change_while_homing_error: None,
            stops_end_switched_off: false,
            switch_on_requires_main_power: false,
            pp_bit6_absolute: false,
            pp_change_on_set_point: true,
            pp_set_point_buffer: true,
            homing_methods: None,
            homing_method_aliases: Vec::new(),
            touch_probe_bit7: None,
            touch_probe_bit6_source: false,
            touch_probe_function_bits: None,
            touch_probe1_off_while_homing: false,
            touch_probe2_off_while_homing: false,
            following_error_fault: true,
            digital_inputs_limits_swapped: false,
            digital_inputs_without_interlock: false,
            following_error_zero_window_off: false,
            home_offset_added: false,
            home_offset_added_absolute: false,
            store_requires_power_cycle: Vec::new(),
            touch_probe_inputs: None,
            max_interpolation_speed: None,
            homing_error_alarm: None,
            safe_torque_off: None,
            torque_limit_statusword: None,
            csp_extrapolation: None,
            stop_codes: Vec::new(),
            fault_reaction_ignored: false,
            mode_statusword: Vec::new(),
            home_found_statusword: None,
            option_codes_without_object: OptionCodesFile::default(),
            torque_modes_stop_at_once: false,
            torque_modes_halt_zero_torque: false,
            software_limits_off: None,
            software_limits_need_reference: false,
            software_limits_less_home_offset: false,
            homing_here_while_disabled: false,
            homing_start_while_disabled_error: false,
            homing_here_needs_speed_zero: false,
            mode_entry_starts: false,
            torque_reached: None,
            unit_ranges: None,
        }
    }
}

/// One default mapping entry: `{ index, sub, bits }` or padding `{ pad = n }`.
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct PdoEntryFile {
    /// Object index.
    #[serde(default)]
    pub index: Option<u16>,
    /// Subindex.
    #[serde(default)]
    pub sub: Option<u8>,
    /// Bit length (must equal the object entry's).
    #[serde(default)]
    pub bits: Option<u16>,
    /// A gap of this many bits.
    #[serde(default)]
    pub pad: Option<u16>,
}

/// `[[object]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectFile {
    /// Index.
    pub index: u16,
    /// Name.
    pub name: String,
    /// "var" (default), "record" or "array".
    #[serde(default)]
    pub code: Option<String>,
    /// RECORD/ARRAY only: entries with subindex ≥ 1 (subindex 0 is generated).
    #[serde(default, rename = "entry")]
    pub entries: Vec<EntryFile>,
    /// Data type (ESI base type name: BOOL, SINT, INT, DINT, LINT, USINT, UINT, UDINT, ULINT,
    /// INT24, UINT24, REAL, LREAL, STRING, OCTET_STRING, UNICODE_STRING, DOMAIN, BIT1..BIT8).
    #[serde(default, rename = "type")]
    pub data_type: Option<String>,
    /// Bit length; required for strings without a default, otherwise implied by the type.
    #[serde(default)]
    pub bits: Option<u16>,
    /// "ro", "rw", "wo", "rw_preop", "rw_preop_safeop", "rw_preop_op", "rw_safeop",
    /// "rw_safeop_op", "rw_op".
    #[serde(default)]
    pub access: Option<String>,
    /// PDO mappability: "no" (default), "rx", "tx", "rxtx".
    #[serde(default)]
    pub pdo: Option<String>,
    /// Default value: integer, float, bool or string (strings: the text; integers may be given
    /// as "0x…" strings for 64-bit values).
    #[serde(default)]
    pub default: Option<toml::Value>,
    /// Minimum.
    #[serde(default)]
    pub min: Option<toml::Value>,
    /// Maximum.
    #[serde(default)]
    pub max: Option<toml::Value>,
    /// The only values an SDO download may write (integers); others are refused with
    /// 0x06090030.
    #[serde(default)]
    pub allowed: Option<Vec<toml::Value>>,
    /// "ram", "const" or "domain" (DOMAIN type only); default: RAM when writable, PDO-mappable
    /// or given a role.
    #[serde(default)]
    pub storage: Option<String>,
    /// Application role (an `AppVars` field name).
    #[serde(default)]
    pub role: Option<String>,
    /// Startup parameter ("setting", SDO information list type 5, ESI `Flags/Setting`); on a
    /// RECORD/ARRAY it marks every entry.
    #[serde(default)]
    pub setting: bool,
    /// Unit of the value (documentation: ESI comment, SDO information has none).
    #[serde(default)]
    pub unit: Option<String>,
    /// What the value means (documentation).
    #[serde(default)]
    pub description: Option<String>,
}

/// `[[object.entry]]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EntryFile {
    /// Subindex (≥ 1).
    pub sub: u8,
    /// Name.
    pub name: String,
    /// Data type (ESI base type name: BOOL, SINT, INT, DINT, LINT, USINT, UINT, UDINT, ULINT,
    /// INT24, UINT24, REAL, LREAL, STRING, OCTET_STRING, UNICODE_STRING, DOMAIN, BIT1..BIT8).
    #[serde(default, rename = "type")]
    pub data_type: Option<String>,
    /// Bit length; required for strings without a default, otherwise implied by the type.
    #[serde(default)]
    pub bits: Option<u16>,
    /// "ro", "rw", "wo", "rw_preop", "rw_preop_safeop", "rw_preop_op", "rw_safeop",
    /// "rw_safeop_op", "rw_op".
    #[serde(default)]
    pub access: Option<String>,
    /// PDO mappability: "no" (default), "rx", "tx", "rxtx".
    #[serde(default)]
    pub pdo: Option<String>,
    /// Default value: integer, float, bool or string (strings: the text; integers may be given
    /// as "0x…" strings for 64-bit values).
    #[serde(default)]
    pub default: Option<toml::Value>,
    /// Minimum.
    #[serde(default)]
    pub min: Option<toml::Value>,
    /// Maximum.
    #[serde(default)]
    pub max: Option<toml::Value>,
    /// The only values an SDO download may write (integers); others are refused with
    /// 0x06090030.
    #[serde(default)]
    pub allowed: Option<Vec<toml::Value>>,
    /// "ram", "const" or "domain" (DOMAIN type only); default: RAM when writable, PDO-mappable
    /// or given a role.
    #[serde(default)]
    pub storage: Option<String>,
    /// Application role (an `AppVars` field name).
    #[serde(default)]
    pub role: Option<String>,
    /// Startup parameter (see [`ObjectFile::setting`]).
    #[serde(default)]
    pub setting: bool,
    /// Unit of the value (documentation: ESI comment, SDO information has none).
    #[serde(default)]
    pub unit: Option<String>,
    /// What the value means (documentation).
    #[serde(default)]
    pub description: Option<String>,
}

/// The attributes of one value (a VAR object or a RECORD/ARRAY entry), as written.
#[derive(Debug, Default, Clone)]
pub struct EntryAttrs {
    /// See [`ObjectFile::data_type`].
    pub data_type: Option<String>,
    /// Bit length.
    pub bits: Option<u16>,
    /// Access.
    pub access: Option<String>,
    /// PDO mappability.
    pub pdo: Option<String>,
    /// Default.
    pub default: Option<toml::Value>,
    /// Minimum.
    pub min: Option<toml::Value>,
    /// Maximum.
    pub max: Option<toml::Value>,
    /// Accepted values.
    pub allowed: Option<Vec<toml::Value>>,
    /// Storage.
    pub storage: Option<String>,
    /// Role.
    pub role: Option<String>,
    /// Startup parameter.
    pub setting: bool,
    /// Unit (documentation).
    pub unit: Option<String>,
    /// Meaning (documentation).
    pub description: Option<String>,
}

macro_rules! attrs_of {
    ($t:ty) => {
        impl $t {
            /// The value attributes given on this item.
            pub fn attrs(&self) -> EntryAttrs {
                EntryAttrs {
                    data_type: self.data_type.clone(),
                    bits: self.bits,
                    access: self.access.clone(),
                    pdo: self.pdo.clone(),
                    default: self.default.clone(),
                    min: self.min.clone(),
                    max: self.max.clone(),
                    allowed: self.allowed.clone(),
                    storage: self.storage.clone(),
                    role: self.role.clone(),
                    setting: self.setting,
                    unit: self.unit.clone(),
                    description: self.description.clone(),
                }
            }
        }
    };
}
attrs_of!(ObjectFile);
attrs_of!(EntryFile);

/// `[cia402]`: CiA402 behaviour a manual adds to the standard.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cia402File {
    /// Enable operation (transition 4) requested while no mode of operation is selected
    /// (6061h = 0): the drive refuses and raises this error (a CiA402 code or an `[[alarm]]`
    /// display; the SDV3-E's oPE); absent: the drive enables and holds the position.
    #[serde(default)]
    pub enable_without_mode_error: Option<MotorFaultFile>,
    /// A change of 6060h while a homing run is under way is refused and raises this error (a
    /// CiA402 code or an `[[alarm]]` display; the SDV3-E's oPE); absent: the new mode is taken.
    #[serde(default)]
    pub mode_change_while_homing_error: Option<MotorFaultFile>,
    /// Shutdown and disable operation end in Switch On Disabled after their stop (default
    /// false: CiA402's Ready to Switch On / Switched On).
    #[serde(default)]
    pub stops_end_switched_off: bool,
    /// Switched On needs the main power (default false).
    #[serde(default)]
    pub switch_on_requires_main_power: bool,
    /// Profile position: controlword bit 6 set means an absolute target (default false:
    /// CiA402's relative).
    #[serde(default)]
    pub pp_bit6_absolute: bool,
    /// Profile position: controlword bit 9 "change on set-point" is supported (default true).
    #[serde(default = "yes")]
    pub pp_change_on_set_point: bool,
    /// Profile position: a set-point given without bit 5 waits in a buffer of one while a
    /// move runs (default true); false: no buffer, bit 12 stays set until the move ends.
    #[serde(default = "yes")]
    pub pp_set_point_buffer: bool,
    /// The homing methods (6098h values) the drive runs (default: every CiA402 method).
    #[serde(default)]
    pub homing_methods: Option<Vec<i8>>,
    /// `[vendor method, CiA402 method]`: a vendor number that runs a CiA402 method.
    #[serde(default)]
    pub homing_method_aliases: Vec<[i8; 2]>,
    /// What 60B9h bit 7 (15) shows: "none" (default), "toggle" (on every stored position) or
    /// "level" (the probe input).
    #[serde(default)]
    pub touch_probe_bit7: Option<String>,
    /// 60B9h bit 6 (14) shows the trigger source (1 = index).
    #[serde(default)]
    pub touch_probe_bit6_source: bool,
    /// The 60B8h bits the profile defines (the rest are reserved and ignored); default every
    /// bit (CiA402).
    #[serde(default)]
    pub touch_probe_function_bits: Option<u16>,
    /// Touch probe 1 is switched off while homing runs.
    #[serde(default)]
    pub touch_probe1_off_while_homing: bool,
    /// Touch probe 2 is switched off while homing runs.
    #[serde(default)]
    pub touch_probe2_off_while_homing: bool,
    /// A following error beyond 6065h for longer than 6066h is a fault (default true); false:
    /// statusword bit 13 only.
    #[serde(default = "yes")]
    pub following_error_fault: bool,
    /// 60FDh bit 0 is the positive and bit 1 the negative limit switch (CiA402: the reverse).
    #[serde(default)]
    pub digital_inputs_limits_swapped: bool,
    /// 60FDh bit 3 (interlock: the drive's enable input withholds operation) is not supported
    /// and stays 0 (CiA402 defines it).
    #[serde(default)]
    pub digital_inputs_without_interlock: bool,
    /// 6065h = 0 switches the following-error check off (CiA402: only FFFF FFFFh does).
    #[serde(default)]
    pub following_error_zero_window_off: bool,
    /// The home offset 607Ch is added to every position object (6064h = 6063h / ratio + 607Ch)
    /// instead of only setting the home's position.
    #[serde(default)]
    pub home_offset_added: bool,
    /// With an absolute encoder, 607Ch as it is at power-on is added to every position object
    /// from power-on (a later write acts at the next power-on or homing).
    #[serde(default)]
    pub home_offset_added_absolute: bool,
    /// 1010h subindexes after whose store Operation Enabled needs a power-on first.
    #[serde(default)]
    pub store_requires_power_cycle: Vec<u8>,
    /// The probe inputs must be assigned to a physical input first.
    #[serde(default)]
    pub touch_probe_inputs: Option<TouchProbeInputsFile>,
    /// CSP/IP targets at or above this speed (increments per ms) are ignored.
    #[serde(default)]
    pub max_interpolation_speed: Option<u32>,
    /// A failed homing run also raises this alarm (display) or 603Fh code.
    #[serde(default)]
    pub homing_error_alarm: Option<MotorFaultFile>,
    /// How the safe-torque-off input shows.
    #[serde(default)]
    pub safe_torque_off: Option<SafeTorqueOffFile>,
    /// A statusword bit showing the torque demand at its limit.
    #[serde(default)]
    pub torque_limit_statusword: Option<StatuswordFlagFile>,
    /// The parameter (`"0xIIII:S"`) whose value 1, at power-on, makes CSP extrapolate over a
    /// cycle without new outputs.
    #[serde(default)]
    pub csp_extrapolation: Option<String>,
    /// `[[cia402.stop_codes]]`: option codes the profile defines where CiA402 reserves them.
    #[serde(default)]
    pub stop_codes: Vec<StopCodeFile>,
    /// 605Eh is accepted but has no effect: a fault disables the drive function at once.
    #[serde(default)]
    pub fault_reaction_ignored: bool,
    /// `[[cia402.mode_statusword]]`: statusword bits 10-13 of a mode where the manual's table
    /// differs from CiA402's.
    #[serde(default)]
    pub mode_statusword: Vec<ModeStatuswordFile>,
    /// A statusword bit showing that homing has completed since power-on.
    #[serde(default)]
    pub home_found_statusword: Option<StatuswordFlagFile>,
    /// `[cia402.option_codes_without_object]`: the codes the drive works with where the profile
    /// has no 605Ah-605Eh object.
    #[serde(default)]
    pub option_codes_without_object: OptionCodesFile,
    /// Quick stop, shutdown and disable operation disable the drive at once in PT and CST.
    #[serde(default)]
    pub torque_modes_stop_at_once: bool,
    /// Halt in PT and CST takes the torque demand to zero (not a speed ramp).
    #[serde(default)]
    pub torque_modes_halt_zero_torque: bool,
    /// The parameter (`"0xIIII:S"`) whose value 1, at power-on, switches the software position
    /// limits 607Dh off.
    #[serde(default)]
    pub software_limits_off: Option<String>,
    /// The software position limits 607Dh act only once the position is referenced: after a
    /// homing run, or at once with an absolute encoder.
    #[serde(default)]
    pub software_limits_need_reference: bool,
    /// 607Dh is relative to the machine home: the limits a target is compared with are
    /// 607Dh - 607Ch.
    #[serde(default)]
    pub software_limits_less_home_offset: bool,
    /// The current-position homing methods (35, 37) also run while the drive is disabled.
    #[serde(default)]
    pub homing_here_while_disabled: bool,
    /// A homing start while the drive is disabled is a homing error.
    #[serde(default)]
    pub homing_start_while_disabled_error: bool,
    /// The current-position homing methods run only at speed zero (else a homing error).
    #[serde(default)]
    pub homing_here_needs_speed_zero: bool,
    /// A mode change into PP or homing with controlword bit 4 set starts at once.
    #[serde(default)]
    pub mode_entry_starts: bool,
    /// The parameters (`"0xIIII:S"`, 0.1 % of the rated torque) of the torque-reached
    /// condition: the reference A, the "on" margin B and the "off" margin C (on above A + B,
    /// off below A + C).
    #[serde(default)]
    pub torque_reached: Option<[String; 3]>,
    /// `[cia402.unit_ranges]`: the ratios the unit factors may have, and the error outside.
    #[serde(default)]
    pub unit_ranges: Option<UnitRangesFile>,
}

/// `[cia402.unit_ranges]`: the range of numerator/denominator of each unit factor, checked when
/// the factors take effect (the Σ-V-SD's A.A20, §4.5 (3)-(5)); `error` is raised outside.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitRangesFile {
    /// The error (a code or an alarm's display).
    pub error: MotorFaultFile,
    /// `[units] position`'s range.
    #[serde(default)]
    pub position: Option<RatioRangeFile>,
    /// `[units] velocity`'s range.
    #[serde(default)]
    pub velocity: Option<RatioRangeFile>,
    /// `[units] acceleration`'s range (of its numerator/denominator, before its scale).
    #[serde(default)]
    pub acceleration: Option<RatioRangeFile>,
    /// `[units] torque`'s range (of its numerator/denominator, before its scale).
    #[serde(default)]
    pub torque: Option<RatioRangeFile>,
}

/// A range of ratios: `min` and `max` as `[numerator, denominator]`, the ends included or not.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RatioRangeFile {
    /// The smallest ratio.
    pub min: [u32; 2],
    /// The largest ratio.
    pub max: [u32; 2],
    /// The ends belong to the range.
    pub inclusive: bool,
}

/// `[cia402.option_codes_without_object]`: a code per option-code object the profile lacks.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptionCodesFile {
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
}

/// `[[cia402.mode_statusword]]`: what statusword bits 10, 11, 12 and 13 show in a mode.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeStatuswordFile {
    /// The 6060h values the layout is for.
    pub modes: Vec<i8>,
    /// Bits 10, 11, 12, 13: each one of `ModeBit::NAMES`.
    pub bits: [String; 4],
}

/// `[[cia402.stop_codes]]`: an option code of 605Ah–605Eh and the stop it selects.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopCodeFile {
    /// The option-code object, `"0x605B"`.
    pub object: String,
    /// The code.
    pub code: i16,
    /// How the motor is brought to rest: `coast`, `profile_ramp` (6084h), `quick_stop_ramp`
    /// (6085h), `current_limit`, `voltage_limit`.
    pub stop: String,
    /// The drive holds the motor at rest afterwards (a quick stop staying in Quick Stop
    /// Active, a halt) instead of disabling it.
    #[serde(default)]
    pub hold: bool,
}

/// `[cia402.torque_limit_statusword]`: a manufacturer-specific statusword bit and its value
/// while the condition holds.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatuswordFlagFile {
    /// Statusword bit (8, 14 or 15).
    pub statusword_bit: u8,
    /// Its value while the condition holds.
    pub statusword_while_active: bool,
}

/// `[cia402.safe_torque_off]`: the statusword bit that shows safe torque off and its value while
/// it holds, and the 60FDh bits of its two channels (1 = closed).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafeTorqueOffFile {
    /// Statusword bit (8, 14 or 15).
    pub statusword_bit: u8,
    /// Its value while safe torque off holds.
    pub statusword_while_active: bool,
    /// 60FDh bits of channel 1 and 2 (16-31).
    pub digital_input_bits: [u8; 2],
}

/// `[cia402.touch_probe_inputs]`: the parameters that assign input functions, the function of
/// each probe's input, the error when a probe is enabled on an unassigned input.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TouchProbeInputsFile {
    /// `"0xIIII:S"` entries, each an input's function.
    pub entries: Vec<String>,
    /// The function value of probe 1's and probe 2's input.
    pub functions: [u32; 2],
    /// The error: an `[[alarm]]` display or a 603Fh code.
    pub unassigned_error: MotorFaultFile,
}

fn yes() -> bool {
    true
}
