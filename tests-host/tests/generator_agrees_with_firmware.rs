//! od-gen refuses every profile setting the firmware would refuse at run time, so that a profile
//! that generates also runs (issue 12 item 4). Each case loads the setting through both: the
//! generator's validation of a profile file, and the firmware's own check with the same value:
//! mailbox sizes (INIT -> PREOP, 0x0016), SMs in the ESC's process RAM, SYNC0 cycles (an empty
//! range, a longest cycle off the step, a default outside the range, an op mode's fixed
//! cycle: PREOP -> SAFEOP, 0x0035 / 0x0036) and PDO mappings beyond what the firmware maps
//! (more entries than its copy plan holds, a PDO larger than the profile's image limit: 0x0025).

use firmware::od::{
    Access, DataType, Dictionary, Entry, Object, PdoMappable, Profile, SyncSupport, Value,
};
use firmware::pdo::{Direction, PdoPlan};
use firmware::slave::esm::sm_check;
use firmware::slave::esm::sync::{SyncConfig, SyncMode};
use hal::esc::{
    AlStatusCode, SmActivate, SmConfig, SmControl, MAX_FIRMWARE_MAILBOX,
    MAX_FIRMWARE_MAPPED_ENTRIES,
};
use od_gen::Invalid;

const STANDARD: &str = include_str!("../../od-gen/profiles/standard.toml");
const MAILBOX_OUT: &str = "mailbox_out = { start = 0x1000, size = 256, control = 0x26 }";
const MAILBOX_IN: &str = "mailbox_in = { start = 0x1100, size = 256, control = 0x22 }";

/// The standard profile with both mailboxes `size` bytes long (the input mailbox moved behind
/// the output one, the process data behind both, 1 KiB apart).
fn standard_with_mailboxes(size: u16) -> String {
    assert!(STANDARD.contains(MAILBOX_OUT) && STANDARD.contains(MAILBOX_IN));
    let inputs_at = 0x1000 + u32::from(size);
    let outputs_at = inputs_at + u32::from(size);
    STANDARD
        .replacen(
            MAILBOX_OUT,
            &format!("mailbox_out = {{ start = 0x1000, size = {size}, control = 0x26 }}"),
            1,
        )
        .replacen(
            MAILBOX_IN,
            &format!("mailbox_in = {{ start = {inputs_at:#06x}, size = {size}, control = 0x22 }}"),
            1,
        )
        .replacen(
            "outputs = { start = 0x1200",
            &format!("outputs = {{ start = {outputs_at:#06x}"),
            1,
        )
        .replacen(
            "inputs = { start = 0x1600",
            &format!("inputs = {{ start = {:#06x}", outputs_at + 0x400),
            1,
        )
}

/// What the firmware answers at INIT → PREOP when the master configures SM0/SM1 exactly as a
/// profile whose mailboxes are `size` bytes long declares them.
fn firmware_answer(size: u16) -> Result<(), AlStatusCode> {
    let mut device = firmware::profiles::by_name("standard")
        .expect("standard")
        .od
        .device;
    device.mailbox_out.length = size;
    device.mailbox_in.start = device.mailbox_out.start + size;
    device.mailbox_in.length = size;
    let sm = |layout: firmware::od::SmLayout| SmConfig {
        start: layout.start,
        length: layout.length,
        control: SmControl(layout.control),
        activate: SmActivate(1),
        ..SmConfig::default()
    };
    sm_check::check_mailbox(sm(device.mailbox_out), sm(device.mailbox_in), &device)
}

/// The generator's verdict on `text`: `Ok` or the key and error it names (the first, when it
/// finds several).
fn generator_answer(text: &str) -> Result<(), (String, Invalid)> {
    match od_gen::parse(text, "standard.toml") {
        Ok(_) => Ok(()),
        Err(e) => match e.invalids().first() {
            Some((key, error)) => Err((key.to_string(), (*error).clone())),
            None => panic!("expected a validation verdict, got: {e}"),
        },
    }
}

/// The generator refuses `text` naming `key`, and its reason names the AL status code `code`
/// the firmware refuses the same setting with.
fn generator_refuses(text: &str, key: &str, code: AlStatusCode) {
    let (k, error) =
        generator_answer(text).expect_err("od-gen accepted a setting the firmware refuses");
    assert_eq!(k, key, "{error}");
    let code = format!("{:#06x}", code.code());
    assert!(
        error.to_string().contains(&code),
        "the reason names the firmware's answer {code}: {error}"
    );
}

/// The standard profile's `[sync]` limits as the firmware holds them.
fn standard_sync() -> SyncSupport {
    firmware::profiles::by_name("standard")
        .expect("standard")
        .od
        .device
        .sync
}

/// What the firmware answers at PREOP -> SAFEOP when the master runs SYNC0 at `cycle_ns`
/// with these `[sync]` limits.
fn firmware_dc_answer(support: &SyncSupport, cycle_ns: u32) -> Result<(), AlStatusCode> {
    SyncConfig {
        mode: SyncMode::DcSync0,
        cycle_ns,
    }
    .check(support)
}

#[test]
fn a_mailbox_longer_than_the_firmware_buffers_is_refused_by_both() {
    // The firmware refuses it at INIT → PREOP with 0x0016 (ETG.1000.6 Table 11: invalid
    // mailbox configuration), so the generator must not produce it.
    let too_long = MAX_FIRMWARE_MAILBOX * 2;
    assert_eq!(
        firmware_answer(too_long),
        Err(AlStatusCode::InvalidMailboxConfig)
    );
    let (key, error) = generator_answer(&standard_with_mailboxes(too_long))
        .expect_err("od-gen accepted a mailbox the firmware refuses");
    assert_eq!(key, "sm.mailbox_out.size");
    assert!(
        error.to_string().contains("0x0016"),
        "the reason names the firmware's answer: {error}"
    );
    // One byte over the limit is refused by both as well.
    assert!(firmware_answer(MAX_FIRMWARE_MAILBOX + 1).is_err());
    assert!(generator_answer(&standard_with_mailboxes(MAX_FIRMWARE_MAILBOX + 1)).is_err());
}

#[test]
fn a_mailbox_at_the_firmware_limit_is_accepted_by_both() {
    assert_eq!(firmware_answer(MAX_FIRMWARE_MAILBOX), Ok(()));
    assert_eq!(
        generator_answer(&standard_with_mailboxes(MAX_FIRMWARE_MAILBOX)),
        Ok(())
    );
}

#[test]
fn sync_managers_beyond_the_et1100_process_ram_are_refused() {
    // 8 KiB of process RAM from 0x1000: an SM ending past 0x3000 does not exist on the ESC.
    let text = STANDARD.replacen(
        "outputs = { start = 0x1200",
        "outputs = { start = 0x2FF0",
        1,
    );
    let (key, error) = generator_answer(&text).expect_err("outputs past the process RAM");
    assert_eq!(key, "sm.outputs.start");
    assert!(error.to_string().contains("0x1000..0x3000"), "{error}");
}

// --- Cycle limits -------------------------------------------------------------------------

const MIN_CYCLE: &str = "min_cycle_ns = 31_250";
const MAX_CYCLE: &str = "max_cycle_ns = 10_000_000";
const DEFAULT_CYCLE: &str = "default_cycle_ns = 1_000_000";

fn standard_with(from: &str, to: &str) -> String {
    assert!(
        STANDARD.contains(from),
        "test setup: `{from}` not in standard.toml"
    );
    STANDARD.replacen(from, to, 1)
}

#[test]
fn the_shortest_and_longest_cycles_of_a_profile_are_run_by_both() {
    let support = standard_sync();
    assert_eq!(firmware_dc_answer(&support, support.min_cycle_ns), Ok(()));
    assert_eq!(firmware_dc_answer(&support, support.max_cycle_ns), Ok(()));
    assert_eq!(generator_answer(STANDARD), Ok(()));
}

#[test]
fn an_empty_cycle_range_is_refused_by_both() {
    // min > max: the firmware refuses every SYNC0 cycle with 0x0035, the two ends included.
    let support = SyncSupport {
        min_cycle_ns: 2_000_000,
        max_cycle_ns: 1_000_000,
        ..standard_sync()
    };
    for cycle in [1_000_000, 2_000_000] {
        assert_eq!(
            firmware_dc_answer(&support, cycle),
            Err(AlStatusCode::DcInvalidSyncCycleTime)
        );
    }
    let text = standard_with(MIN_CYCLE, "min_cycle_ns = 2_000_000").replacen(
        MAX_CYCLE,
        "max_cycle_ns = 1_000_000",
        1,
    );
    generator_refuses(
        &text,
        "sync.min_cycle_ns",
        AlStatusCode::DcInvalidSyncCycleTime,
    );
}

#[test]
fn a_longest_cycle_off_the_step_is_refused_by_both() {
    // 10 ms + 1 ns is no multiple of the 31.25 µs step: the firmware refuses it with 0x0036.
    let support = SyncSupport {
        max_cycle_ns: 10_000_001,
        ..standard_sync()
    };
    assert_eq!(
        firmware_dc_answer(&support, 10_000_001),
        Err(AlStatusCode::DcSync0CycleTime)
    );
    generator_refuses(
        &standard_with(MAX_CYCLE, "max_cycle_ns = 10_000_001"),
        "sync.max_cycle_ns",
        AlStatusCode::DcSync0CycleTime,
    );
}

#[test]
fn a_default_cycle_outside_the_range_is_refused_by_both() {
    // 1C32h:02's default, 20 ms, beyond the 10 ms the profile runs: 0x0035 in DC mode and in
    // free run (whose range is the DC range here).
    let support = standard_sync();
    assert_eq!(
        firmware_dc_answer(&support, 20_000_000),
        Err(AlStatusCode::DcInvalidSyncCycleTime)
    );
    let free_run = SyncConfig {
        mode: SyncMode::FreeRun,
        cycle_ns: 20_000_000,
    };
    assert_eq!(
        free_run.check(&support),
        Err(AlStatusCode::DcInvalidSyncCycleTime)
    );
    let text = standard_with(DEFAULT_CYCLE, "default_cycle_ns = 20_000_000");
    generator_refuses(
        &text,
        "sync.default_cycle_ns",
        AlStatusCode::DcInvalidSyncCycleTime,
    );
    let all = od_gen::parse(&text, "standard.toml").expect_err("refused");
    assert!(
        all.invalids()
            .iter()
            .any(|(key, e)| *key == "sync.default_cycle_ns" && e.to_string().contains("free-run")),
        "the free-run default is reported too: {all}"
    );
}

#[test]
fn a_fixed_sync0_cycle_the_firmware_does_not_run_is_refused_by_both() {
    // An op mode whose ESI fixes SYNC0 at 20 µs (factor 0): a master configures 20 µs, below
    // the profile's 31.25 µs, which the firmware refuses with 0x0035.
    let support = standard_sync();
    assert_eq!(
        firmware_dc_answer(&support, 20_000),
        Err(AlStatusCode::DcInvalidSyncCycleTime)
    );
    let text = standard_with(
        "sync0_factor = 1              # SYNC0 cycle = 1 × the master's cycle",
        "sync0_cycle_ns = 20_000",
    );
    generator_refuses(
        &text,
        "dc_op_mode[1].sync0_cycle_ns",
        AlStatusCode::DcInvalidSyncCycleTime,
    );
}

// --- Process data beyond what the firmware maps -------------------------------------------

const RX_ENTRIES: &str = "entries = [\n    { index = 0x6040, sub = 0, bits = 16 },  # controlword\n    { index = 0x607A, sub = 0, bits = 32 },  # target position\n    { index = 0x6060, sub = 0, bits = 8 },   # modes of operation\n]";

/// The standard profile whose RxPDO 1600h (assigned by default) maps controlword `n` times.
fn standard_mapping_controlword(n: usize) -> String {
    let entries = vec!["{ index = 0x6040, sub = 0, bits = 16 }"; n].join(", ");
    standard_with("max_entries = 16", "max_entries = 254").replacen(
        RX_ENTRIES,
        &format!("entries = [{entries}]"),
        1,
    )
}

/// What the firmware's PREOP -> SAFEOP answers to the standard profile's dictionary whose
/// RxPDO 1600h maps controlword `n` times (a 1600h with `n` mapping entries, in OD RAM behind
/// the profile's own).
fn firmware_mapping_controlword(n: usize) -> Result<(), AlStatusCode> {
    let od = &firmware::profiles::by_name("standard")
        .expect("standard")
        .od;
    let controlword = od.object(0x6040).and_then(|o| o.entry(0)).expect("6040h");
    assert!(controlword.pdo.rx());
    let base = u16::try_from(od.defaults.len()).expect("a small OD RAM");
    let mut defaults = od.defaults.to_vec();
    let count = u8::try_from(n).expect("at most 255 entries");
    defaults.push(count);
    let entry = |subindex: u8, data_type, bit_len, at: usize| Entry {
        subindex,
        name: "mapping",
        data_type,
        bit_len,
        access: Access::RW_PREOP,
        pdo: PdoMappable::No,
        value: Value::Ram(base + u16::try_from(at).expect("offset")),
        default: &[],
        min: &[],
        max: &[],
    };
    let mut entries = vec![entry(0, DataType::Unsigned8, 8, 0)];
    for sub in 1..=count {
        entries.push(entry(
            sub,
            DataType::Unsigned32,
            32,
            defaults.len() - od.defaults.len(),
        ));
        defaults.extend_from_slice(&0x6040_0010u32.to_le_bytes());
    }
    let entries: &'static [Entry] = Box::leak(entries.into_boxed_slice());
    let objects: Vec<Object> = od
        .objects
        .iter()
        .map(|o| {
            if o.index == 0x1600 {
                Object { entries, ..*o }
            } else {
                *o
            }
        })
        .collect();
    let profile: &'static Profile = Box::leak(Box::new(Profile {
        objects: Box::leak(objects.into_boxed_slice()),
        defaults: Box::leak(defaults.clone().into_boxed_slice()),
        ..*od
    }));
    let mut ram = defaults;
    assert_eq!(
        Dictionary::new(profile, &mut ram).read_u32(0x1C12, 1),
        Some(0x1600),
        "1600h is assigned"
    );
    PdoPlan::build(&Dictionary::new(profile, &mut ram), Direction::Rx).map(|_| ())
}

#[test]
fn a_default_mapping_of_more_entries_than_the_firmware_maps_is_refused_by_both() {
    let limit = usize::from(MAX_FIRMWARE_MAPPED_ENTRIES);
    assert_eq!(firmware_mapping_controlword(limit), Ok(()));
    assert_eq!(
        generator_answer(&standard_mapping_controlword(limit)),
        Ok(())
    );
    assert_eq!(
        firmware_mapping_controlword(limit + 1),
        Err(AlStatusCode::InvalidOutputMapping)
    );
    generator_refuses(
        &standard_mapping_controlword(limit + 1),
        "rxpdo",
        AlStatusCode::InvalidOutputMapping,
    );
}

#[test]
fn a_pdo_beyond_the_process_image_limit_is_refused_by_both() {
    // `max_process_bytes = 8` and an RxPDO of three target positions (12 bytes), not assigned
    // by default: the firmware refuses every assignment of it with 0x0025.
    let firmware = {
        let p = firmware::profiles::by_name("standard").expect("standard");
        let profile: &'static Profile = Box::leak(Box::new(Profile {
            device: firmware::od::DeviceInfo {
                max_process_bytes: 8,
                ..p.od.device
            },
            ..p.od
        }));
        let mut ram = profile.defaults.to_vec();
        let mut od = Dictionary::new(profile, &mut ram);
        let set = |od: &mut Dictionary<'_>, sub: u8, bytes: &[u8]| {
            let e = od.entry(0x1600, sub).expect("1600h entry");
            od.set_value(e, bytes).expect("RAM");
        };
        for sub in 1..=3 {
            set(&mut od, sub, &0x607A_0020u32.to_le_bytes());
        }
        set(&mut od, 0, &[3]);
        PdoPlan::build(&od, Direction::Rx).map(|_| ())
    };
    assert_eq!(firmware, Err(AlStatusCode::InvalidOutputMapping));
    let spare = "[[rxpdo]]\nindex = 0x1601\nname = \"spare\"\nsm = 2\nassigned = false\n\
                 entries = [{ index = 0x607A, sub = 0, bits = 32 }, \
                 { index = 0x607A, sub = 0, bits = 32 }, { index = 0x607A, sub = 0, bits = 32 }]\n\n";
    let text = standard_with(
        "max_entries = 16",
        "max_entries = 16\nmax_process_bytes = 8",
    )
    .replacen(
        "[[txpdo]]\nindex = 0x1A00",
        &format!("{spare}[[txpdo]]\nindex = 0x1A00"),
        1,
    );
    generator_refuses(
        &text,
        "rxpdo[0x1601].entries",
        AlStatusCode::InvalidOutputMapping,
    );
}
