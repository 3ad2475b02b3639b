//! Every built-in profile (the five seed drives, the two-axis Σ-V-SD and the standard drive)
//! under a real master, ethercrab in process: the identity and name the manual gives, every
//! object read over SDO equal to its default from the profile file, and the default PDO mapping
//! in OP at the profile's shortest and longest DC cycle; a cycle outside the profile's range is
//! refused at SAFE-OP with AL status code 0x0035; 1C32h/1C33h in the manual's own layout where a
//! profile declares them.
//!
//! The expectations come from the profile files (od-gen's model of the manual), read
//! independently of the firmware's generated dictionary.

use board_sim::Segment;
use ethercrab::subdevice_group::PreOp;
use ethercrab::{DefaultLock, MainDevice, SubDeviceGroup};
use od_gen::model::{DataType, Entry, Object, Profile, Role, Storage};
use tests_host::{al_status, block_on, dc_safe_op, master_for};

/// Largest process image of any profile's default mapping, with room (bytes).
const MAX_PDI: usize = 512;
/// ethercrab sizes its tables with a power of two ≥ 2; the tests use one drive.
const MAX_SUBDEVICES: usize = 4;
/// AL status error indication bit (ETG.1000.6 Table 9).
const AL_ERROR: u16 = 0x10;
/// AL status code "invalid DC SYNC configuration" / "DC SYNC0 cycle time" (ETG.1000.6
/// Table 11): 0x0035 for a cycle outside the supported range.
const AL_SYNC_CYCLE_INVALID: u16 = 0x0035;

type Group = SubDeviceGroup<MAX_SUBDEVICES, MAX_PDI, DefaultLock, PreOp>;

fn profiles() -> Vec<Profile> {
    od_gen::builtin_profiles().expect("built-in profiles load")
}

/// Entries whose value the running drive produces, so a read shows the drive's state, not the
/// file's default: process values the application writes (roles of the TxPDO side), the
/// active synchronisation (1C32h/1C33h, ETG.1020: the slave fills them in), the diagnosis
/// history (10F3h, ETG.1020 §13) and the serial number (1018h:04, set by the board).
fn is_live(p: &Profile, o: &Object, e: &Entry) -> bool {
    let written_by_application = matches!(
        p.role_of(o.index, e.subindex),
        Some(
            Role::Statusword
                | Role::ErrorCode
                | Role::ModesOfOperationDisplay
                | Role::PositionActualValue
                | Role::VelocityActualValue
                | Role::TorqueActualValue
        )
    );
    written_by_application
        || matches!(o.index, 0x1C32 | 0x1C33 | 0x10F3)
        || (o.index == 0x1018 && e.subindex == 4)
}

/// The default PDO mapping's process image sizes in bytes (outputs, inputs).
fn default_image(p: &Profile) -> (usize, usize) {
    (p.outputs_bits() as usize / 8, p.inputs_bits() as usize / 8)
}

/// What an SDO upload of the entry's default returns: the bytes, except that a VISIBLE_STRING
/// variable the master writes ends at its first NUL (CiA 301 §7.1.6.3: a visible string may be
/// shorter than its object; the stack sends the text, not the padding).
fn upload_of(e: &Entry) -> Vec<u8> {
    let mut bytes = e.initial_bytes();
    if e.data_type == DataType::VisibleString && e.storage == Storage::Ram && e.access.writable() {
        if let Some(nul) = bytes.iter().position(|b| *b == 0) {
            bytes.truncate(nul);
        }
    }
    bytes
}

async fn init(m: &board_sim::inproc::InProcess) -> Group {
    m.maindevice
        .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
        .await
        .expect("init")
}

#[test]
fn identity_and_every_object_read_by_sdo_equals_the_profile() {
    for p in profiles() {
        block_on(async {
            let (m, transport) = master_for(Segment::new(&p.name, 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let group = init(&m).await;
            let sd = group.subdevice(md, 0).expect("drive");
            let id = sd.identity();
            assert_eq!(
                (id.vendor_id, id.product_id, id.revision),
                (p.vendor.id, p.device.product_code, p.device.revision),
                "{}: identity (SII)",
                p.name
            );
            assert_eq!(sd.name(), p.device.name, "{}: name (SII)", p.name);

            let mut read = 0;
            for o in &p.objects {
                for e in &o.entries {
                    if !e.access.readable() || e.data_type == DataType::Domain || is_live(&p, o, e)
                    {
                        continue;
                    }
                    let got = sd
                        .sdo_read::<heapless08::Vec<u8, 1024>>(o.index, e.subindex)
                        .await
                        .unwrap_or_else(|err| {
                            panic!(
                                "{}: {:#06x}:{:02x} {}: {err:?}",
                                p.name, o.index, e.subindex, e.name
                            )
                        });
                    let expected = upload_of(e);
                    assert_eq!(
                        got.as_slice(),
                        expected.as_slice(),
                        "{}: {:#06x}:{:02x} {} ({:?})",
                        p.name,
                        o.index,
                        e.subindex,
                        e.name,
                        e.storage == Storage::Const
                    );
                    read += 1;
                }
            }
            assert!(read > 20, "{}: only {read} entries read", p.name);
        });
    }
}

/// PRE-OP → SAFE-OP → OP with DC SYNC0 at `cycle_ns`; returns the AL status and code when the
/// drive refuses SAFE-OP, or the process image sizes in OP.
async fn run_dc(p: &Profile, cycle_ns: u64) -> Result<(usize, usize), (u16, u16)> {
    run_dc_assigned(p, cycle_ns, None).await
}

/// [`run_dc`], with `assignment` = (RxPDOs, TxPDOs) written to 1C12h/1C13h in PRE-OP first.
async fn run_dc_assigned(
    p: &Profile,
    cycle_ns: u64,
    assignment: Option<(&[u16], &[u16])>,
) -> Result<(usize, usize), (u16, u16)> {
    run_dc_reading(p, cycle_ns, assignment, &[])
        .await
        .map(|(sizes, _)| sizes)
}

/// What an SDO upload in OP answered: the bytes, or the abort code.
type Upload = Result<Vec<u8>, u32>;

/// [`run_dc_assigned`], uploading each of `reads` (index, subindex) by SDO while in OP; returns
/// the answers in the same order with the process image sizes.
async fn run_dc_reading(
    p: &Profile,
    cycle_ns: u64,
    assignment: Option<(&[u16], &[u16])>,
    reads: &[(u16, u8)],
) -> Result<((usize, usize), Vec<Upload>), (u16, u16)> {
    let (m, transport) = master_for(Segment::new(&p.name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group = init(&m).await;
    if let Some((rx, tx)) = assignment {
        let sd = group.subdevice(md, 0).expect("drive");
        for (assign, pdos) in [(0x1C12u16, rx), (0x1C13, tx)] {
            sd.sdo_write(assign, 0, 0u8)
                .await
                .expect("assignment :00 = 0");
            for (i, pdo) in pdos.iter().enumerate() {
                sd.sdo_write(assign, (i + 1) as u8, *pdo)
                    .await
                    .expect("assignment entry");
            }
            sd.sdo_write(assign, 0, pdos.len() as u8)
                .await
                .expect("assignment :00 = n");
        }
    }
    let group = dc_safe_op(&m, md, group, cycle_ns).await?;
    let group = group.request_into_op(md).await.expect("request OP");
    let mut in_op = false;
    for _ in 0..1000 {
        let r = group.tx_rx_dc(md).await.expect("tx/rx");
        m.shared.advance(cycle_ns);
        if r.all_op() {
            in_op = true;
            break;
        }
    }
    assert!(
        in_op,
        "{}: no OP at {cycle_ns} ns: {:?}",
        p.name,
        al_status(md).await
    );
    // A few cycles in OP with the right working counter (2 for the write + 1 for the read).
    for _ in 0..20 {
        let r = group.tx_rx_dc(md).await.expect("tx/rx");
        m.shared.advance(cycle_ns);
        assert!(r.all_op(), "{}: left OP at {cycle_ns} ns", p.name);
        assert_eq!(r.working_counter, 3, "{}: working counter", p.name);
    }
    let sd = group.subdevice(md, 0).expect("drive");
    // 1C32h:20 in sync without error: FALSE (ETG.1020 "sync error"), TRUE where the profile
    // defines the flag the other way round (RSE); absent where the manual's layout has none
    // (Σ-V-SD).
    for index in [0x1C32u16, 0x1C33] {
        if p.entry(index, 0x20).is_some() {
            let flag: u8 = sd.sdo_read(index, 0x20).await.expect(":20");
            assert_eq!(
                flag,
                u8::from(p.sync.sync_flag_in_sync),
                "{}: {index:#06x}:20",
                p.name
            );
        }
    }
    // One upload per cycle, between the process data exchanges (a master's mailbox traffic in
    // its cyclic task): the drive stays synchronised while it answers.
    let mut uploads = Vec::new();
    for (index, subindex) in reads {
        let since = m.shared.clock().now();
        let r = group.tx_rx_dc(md).await.expect("tx/rx");
        assert!(r.all_op(), "{}: left OP during the SDO reads", p.name);
        let r = sd
            .sdo_read::<heapless08::Vec<u8, 64>>(*index, *subindex)
            .await
            .map(|v| v.to_vec())
            .map_err(abort_code);
        uploads.push(r);
        m.shared.finish_cycle(since, cycle_ns);
    }
    let sizes = (sd.outputs_raw().len(), sd.inputs_raw().len());
    let _ = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
    Ok((sizes, uploads))
}

/// The shortest cycle the profile accepts: `min_cycle_ns` rounded up to the control step.
fn shortest(p: &Profile) -> u64 {
    let step = u64::from(p.sync.cycle_step_ns.max(1));
    u64::from(p.sync.min_cycle_ns).div_ceil(step) * step
}

/// The longest: `max_cycle_ns` rounded down to the control step.
fn longest(p: &Profile) -> u64 {
    let step = u64::from(p.sync.cycle_step_ns.max(1));
    u64::from(p.sync.max_cycle_ns) / step * step
}

#[test]
fn default_mapping_reaches_op_at_the_shortest_and_longest_dc_cycle() {
    for p in profiles().into_iter().filter(|p| p.sync.dc_sync0) {
        for cycle in [shortest(&p), longest(&p)] {
            let sizes = block_on(run_dc(&p, cycle))
                .unwrap_or_else(|s| panic!("{}: SAFE-OP refused at {cycle} ns: {s:?}", p.name));
            assert_eq!(sizes, default_image(&p), "{}: process image", p.name);
        }
    }
}

/// AL status code "DC SYNC0 cycle time" not supported (ETG.1000.6 Table 11).
const AL_SYNC0_CYCLE_TIME: u16 = 0x0036;

/// A profile with a fixed set of cycles (the GHA-E: 125/250/500/1000/2000 µs) refuses a cycle in
/// range that is a multiple of its step but not in the set, and accepts each one in it.
#[test]
fn a_cycle_outside_the_profiles_set_is_refused_with_0x36() {
    let mut checked = 0;
    for p in profiles()
        .into_iter()
        .filter(|p| !p.sync.allowed_cycles_ns.is_empty())
    {
        let set = &p.sync.allowed_cycles_ns;
        let step = u64::from(p.sync.cycle_step_ns.max(1));
        let gap = (u64::from(set[0])..=u64::from(set[set.len() - 1]))
            .step_by(step as usize)
            .find(|c| !set.iter().any(|s| u64::from(*s) == *c))
            .expect("a stepped cycle outside the set");
        let (status, code) = block_on(run_dc(&p, gap))
            .err()
            .unwrap_or_else(|| panic!("{}: OP at {gap} ns", p.name));
        assert_eq!(
            (status & AL_ERROR, code),
            (AL_ERROR, AL_SYNC0_CYCLE_TIME),
            "{}",
            p.name
        );
        for c in set {
            block_on(run_dc(&p, u64::from(*c)))
                .unwrap_or_else(|s| panic!("{}: {c} ns refused: {s:?}", p.name));
        }
        checked += 1;
    }
    assert_eq!(checked, 1, "the GHA-E");
}

#[test]
fn a_cycle_outside_the_profile_range_is_refused_at_safeop_with_0x35() {
    for p in profiles().into_iter().filter(|p| p.sync.dc_sync0) {
        let step = u64::from(p.sync.cycle_step_ns.max(1));
        let too_short = shortest(&p) - step;
        let too_long = longest(&p) + step;
        for cycle in [too_short, too_long].into_iter().filter(|c| *c > 0) {
            let (status, code) = block_on(run_dc(&p, cycle))
                .err()
                .unwrap_or_else(|| panic!("{}: OP at {cycle} ns", p.name));
            assert_eq!(
                (status & AL_ERROR, code),
                (AL_ERROR, AL_SYNC_CYCLE_INVALID),
                "{}: {cycle} ns",
                p.name
            );
        }
    }
}

/// CiA 301 / ETG.1000.6 SDO abort codes the PDO rules answer with.
mod abort {
    /// Object cannot be mapped to the PDO.
    pub const NOT_MAPPABLE: u32 = 0x0604_0041;
    /// Value of parameter written too high (subindex 0 beyond the highest subindex).
    pub const VALUE_TOO_HIGH: u32 = 0x0609_0031;
    /// Value range of parameter exceeded.
    pub const VALUE_RANGE: u32 = 0x0609_0030;
}
/// AL status code "invalid output mapping" (ETG.1000.6 Table 11).
const AL_INVALID_OUTPUT_MAPPING: u16 = 0x0025;

fn abort_code(e: ethercrab::error::Error) -> u32 {
    match e {
        ethercrab::error::Error::Mailbox(ethercrab::error::MailboxError::Aborted {
            code, ..
        }) => u32::from(code),
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

/// A mapping entry value: index, subindex, bit length (ETG.1000.6 §5.6.7.4.7).
fn mapping(index: u16, sub: u8, bits: u16) -> u32 {
    u32::from(index) << 16 | u32::from(sub) << 8 | u32::from(bits)
}

#[test]
fn pdo_remaps_that_break_the_profile_rules_are_refused() {
    let mut image_limit_checked = Vec::new();
    for p in profiles().into_iter().filter(|p| p.mailbox.coe.pdo_config) {
        let Some(rx) = p.rx_pdos.iter().find(|pdo| !pdo.fixed) else {
            continue;
        };
        let tx_only = p
            .objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
            .find(|(_, e)| e.pdo.tx() && !e.pdo.rx() && e.bit_len == 16)
            .expect("a TxPDO-only 16-bit entry");
        // 32-bit RxPDO-mappable entries, to fill a mapping.
        let rx32: Vec<u32> = p
            .objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
            .filter(|(_, e)| e.pdo.rx() && e.bit_len == 32)
            .map(|(i, e)| mapping(i, e.subindex, 32))
            .collect();
        let name = p.name.clone();
        let checked = block_on(async {
            let (m, transport) = master_for(Segment::new(&p.name, 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let group = init(&m).await;
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(0x1C12, 0, 0u8).await.expect("1C12h:00 = 0");
            sd.sdo_write(rx.index, 0, 0u8)
                .await
                .expect("mapping :00 = 0");

            // An entry that is not RxPDO-mappable.
            let e = sd
                .sdo_write(rx.index, 1, mapping(tx_only.0, tx_only.1.subindex, 16))
                .await
                .expect_err("TxPDO-only entry in an RxPDO");
            assert_eq!(abort_code(e), abort::NOT_MAPPABLE, "{name}");

            // More entries than the profile's PDO holds.
            let e = sd
                .sdo_write(rx.index, 0, p.max_pdo_entries + 1)
                .await
                .expect_err("too many entries");
            assert_eq!(abort_code(e), abort::VALUE_TOO_HIGH, "{name}");

            // More PDOs assigned than the profile allows.
            let e = sd
                .sdo_write(
                    0x1C12,
                    0,
                    p.max_assigned.unwrap_or(p.rx_pdos.len() as u8) + 1,
                )
                .await
                .expect_err("too many PDOs assigned");
            assert_eq!(abort_code(e), abort::VALUE_TOO_HIGH, "{name}");

            // A mapping within the PDO limits but beyond the profile's process image limit is
            // refused when the master asks for SAFE-OP.
            let fill = usize::from(p.max_pdo_entries).min(rx32.len());
            if fill * 4 > usize::from(p.max_process_bytes)
                && fill * 4 <= usize::from(p.max_pdo_bytes)
            {
                for (i, value) in rx32.iter().take(fill).enumerate() {
                    sd.sdo_write(rx.index, (i + 1) as u8, *value)
                        .await
                        .expect("entry");
                }
                sd.sdo_write(rx.index, 0, fill as u8)
                    .await
                    .expect("mapping :00 = n");
                sd.sdo_write(0x1C12, 1, rx.index).await.expect("1C12h:01");
                sd.sdo_write(0x1C12, 0, 1u8).await.expect("1C12h:00 = 1");
                let group = group.into_pre_op_pdi(md).await;
                let refused = match group {
                    Err(_) => true,
                    Ok(g) => g.into_safe_op(md).await.is_err(),
                };
                assert!(refused, "{name}: {} bytes of outputs accepted", fill * 4);
                let (status, code) = al_status(md).await;
                assert_eq!(
                    (status & AL_ERROR, code),
                    (AL_ERROR, AL_INVALID_OUTPUT_MAPPING),
                    "{name}"
                );
                return true;
            }
            false
        });
        if checked {
            image_limit_checked.push(p.name.clone());
        }
    }
    // The SDV3-E (and its rebrand) limit the process image to 32 bytes per direction.
    assert_eq!(image_limit_checked, ["osd-g-e", "sdv3-e"]);
}

/// PRE-OP: assign `rx` to 1C12h and `tx` to 1C13h (each replacing the default assignment), then
/// into OP with DC SYNC0 at the default cycle; returns the process image sizes.
async fn op_with_assignment(p: &Profile, rx: &[u16], tx: &[u16]) -> (usize, usize) {
    run_dc_assigned(p, u64::from(p.sync.default_cycle_ns), Some((rx, tx)))
        .await
        .unwrap_or_else(|s| panic!("{}: SAFE-OP refused with {rx:x?}/{tx:x?}: {s:?}", p.name))
}

/// Each alternative PDO a manual offers (the PDOs not assigned by default, e.g. the fixed
/// mappings of the GHA-E) brings the drive to OP in place of the default one, with the process
/// image it maps.
#[test]
fn every_alternative_pdo_reaches_op() {
    let mut tried = 0;
    for p in profiles().into_iter().filter(|p| p.mailbox.coe.pdo_assign) {
        let default_rx: Vec<u16> = p
            .rx_pdos
            .iter()
            .filter(|x| x.assigned)
            .map(|x| x.index)
            .collect();
        let default_tx: Vec<u16> = p
            .tx_pdos
            .iter()
            .filter(|x| x.assigned)
            .map(|x| x.index)
            .collect();
        let bytes = |pdos: &[od_gen::model::Pdo], chosen: &[u16]| -> usize {
            pdos.iter()
                .filter(|x| chosen.contains(&x.index))
                .map(|x| x.bits() as usize / 8)
                .sum()
        };
        for alt in p.rx_pdos.iter().filter(|x| !x.assigned) {
            let sizes = block_on(op_with_assignment(&p, &[alt.index], &default_tx));
            assert_eq!(
                sizes,
                (
                    bytes(&p.rx_pdos, &[alt.index]),
                    bytes(&p.tx_pdos, &default_tx)
                ),
                "{} {:#06x}",
                p.name,
                alt.index
            );
            tried += 1;
        }
        for alt in p.tx_pdos.iter().filter(|x| !x.assigned) {
            let sizes = block_on(op_with_assignment(&p, &default_rx, &[alt.index]));
            assert_eq!(
                sizes,
                (
                    bytes(&p.rx_pdos, &default_rx),
                    bytes(&p.tx_pdos, &[alt.index])
                ),
                "{} {:#06x}",
                p.name,
                alt.index
            );
            tried += 1;
        }
    }
    assert!(tried >= 20, "only {tried} alternative PDOs");
}

/// Little-endian bytes of `v` in an entry of `bytes` bytes.
fn le_bytes(v: i64, bytes: usize) -> Vec<u8> {
    v.to_le_bytes()[..bytes].to_vec()
}

/// An expedited SDO download of `v` into an integer entry of `len` (1, 2 or 4) bytes.
async fn write_int(
    sd: &ethercrab::SubDeviceRef<'_, &ethercrab::SubDevice>,
    index: u16,
    subindex: u8,
    v: i64,
    len: usize,
) -> Result<(), ethercrab::error::Error> {
    let b = le_bytes(v, len);
    match len {
        1 => sd.sdo_write(index, subindex, b[0]).await,
        2 => {
            sd.sdo_write(index, subindex, u16::from_le_bytes([b[0], b[1]]))
                .await
        }
        _ => {
            sd.sdo_write(
                index,
                subindex,
                u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            )
            .await
        }
    }
}

/// Entries with a list of accepted values (`allowed`, e.g. the modes 6060h a drive supports, the
/// homing methods of 6098h): every listed value is written by SDO, a value between them that is
/// not listed is refused with 0x06090030 and leaves the entry unchanged.
#[test]
fn values_outside_an_entrys_list_are_refused_with_0x06090030() {
    let mut checked = 0;
    for p in profiles() {
        let lists: Vec<(u16, &Entry)> = p
            .objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
            .filter(|(_, e)| !e.allowed.is_empty() && e.access.0 & 0x08 != 0)
            .collect();
        if lists.is_empty() {
            continue;
        }
        block_on(async {
            let (m, transport) = master_for(Segment::new(&p.name, 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let group = init(&m).await;
            let sd = group.subdevice(md, 0).expect("drive");
            for (index, e) in lists {
                let at = format!("{} {index:#06x}:{:02x}", p.name, e.subindex);
                let len = e.byte_len();
                let first = *e.allowed.first().expect("a value");
                let last = *e.allowed.last().expect("a value");
                // A value inside the list's span it does not hold, or (a list of one, e.g.
                // 60C0h = 0 only) the one above it.
                let gap = (first..=last)
                    .find(|v| !e.allowed.contains(v))
                    .unwrap_or(last + 1);
                for v in [first, last] {
                    write_int(&sd, index, e.subindex, v, len)
                        .await
                        .unwrap_or_else(|err| panic!("{at} = {v}: {err:?}"));
                }
                let r = write_int(&sd, index, e.subindex, gap, len).await;
                let err = r.expect_err(&format!("{at} = {gap} accepted"));
                assert_eq!(abort_code(err), abort::VALUE_RANGE, "{at} = {gap}");
                let now = sd
                    .sdo_read::<heapless08::Vec<u8, 8>>(index, e.subindex)
                    .await
                    .expect("read back");
                assert_eq!(
                    now.as_slice(),
                    le_bytes(last, len).as_slice(),
                    "{at}: unchanged"
                );
                checked += 1;
            }
        });
    }
    // SDV3-E/OSD-G-E 605Ah and 6060h, GHA-E 6060h, 607Eh and 6098h.
    assert!(checked >= 7, "{checked} lists checked");
}

/// 1C32h:01/:02 (the sync mode and cycle the master asks for) are read-only where the manual
/// says so (RSE and Σ-V-SD: both; SDV3-E: the mode, chosen by the drive at PREOP -> SAFEOP;
/// GHA-E: the cycle): a download is refused with 0x06010002; elsewhere it is served in PREOP.
#[test]
fn sync_mode_and_cycle_time_are_writable_as_the_profile_says() {
    const READ_ONLY: u32 = 0x0601_0002;
    for p in profiles() {
        block_on(async {
            let (m, transport) = master_for(Segment::new(&p.name, 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let group = init(&m).await;
            let sd = group.subdevice(md, 0).expect("drive");
            let mode: u16 = sd.sdo_read(0x1C32, 1).await.expect("1C32h:01");
            assert_eq!(mode, p.sync.default_sync_mode, "{}: 1C32h:01", p.name);
            let r = sd.sdo_write(0x1C32, 1, mode).await;
            match (p.sync.sync_mode_writable, r) {
                (true, Ok(())) => {}
                (false, Err(e)) => assert_eq!(abort_code(e), READ_ONLY, "{}", p.name),
                (w, r) => panic!("{}: 1C32h:01 writable {w}, download {r:?}", p.name),
            }
            let cycle = p.sync.default_cycle_ns;
            let r = sd.sdo_write(0x1C32, 2, cycle).await;
            match (p.sync.cycle_time_writable, r) {
                (true, Ok(())) => {}
                (false, Err(e)) => assert_eq!(abort_code(e), READ_ONLY, "{}", p.name),
                (w, r) => panic!("{}: 1C32h:02 writable {w}, download {r:?}", p.name),
            }
            // :0A (Sync0 cycle time, where the layout has one) is the stack's copy of the
            // SYNC0 cycle: read-only, also where the GHA-E manual prints RW (decision "1C32h:0A
            // SYNC0 cycle time read-only").
            if p.entry(0x1C32, 0x0A).is_some() {
                let e = sd
                    .sdo_write(0x1C32, 0x0A, cycle)
                    .await
                    .expect_err("1C32h:0A written");
                assert_eq!(abort_code(e), READ_ONLY, "{}: 1C32h:0A", p.name);
            }
        });
    }
}

/// SDO abort "subindex does not exist" (ETG.1000.6 Table 41).
const ABORT_NO_SUBINDEX: u32 = 0x0609_0011;

/// The upload of a little-endian unsigned value.
fn uint(r: &Upload) -> u64 {
    let bytes = r
        .as_ref()
        .unwrap_or_else(|code| panic!("aborted {code:#010x}"));
    let mut b = [0u8; 8];
    b[..bytes.len()].copy_from_slice(bytes);
    u64::from_le_bytes(b)
}

/// Every profile that declares 1C32h/1C33h in its manual's layout, in OP with DC SYNC0 at a
/// cycle other than its default: an SDO upload of every subindex 0..=0x20 of both objects finds
/// sub 0 and the constants as the profile declares them, :01 = 2 (DC SYNC0), :02 and :0A (where
/// present) = the SYNC0 cycle, RAM entries with their type's length, and every subindex the
/// layout lacks answered with abort 0x06090011. The manuals' key facts are asserted literally
/// too, so a transcription error in a profile fails here.
#[test]
fn declared_sm_parameters_read_in_op_as_the_manual_prints_them() {
    let declared: Vec<Profile> = profiles()
        .into_iter()
        .filter(|p| {
            [0x1C32, 0x1C33]
                .iter()
                .any(|i| p.object(*i).is_some_and(|o| !o.derived))
        })
        .collect();
    let names: Vec<&str> = declared.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "gha-e",
            "osd-g-e",
            "rse",
            "sdv3-e",
            "sigma-v-sd",
            "sigma-v-sd-2axis"
        ]
    );
    for p in &declared {
        let cycle = longest(p);
        assert_ne!(cycle, u64::from(p.sync.default_cycle_ns), "{}", p.name);
        let reads: Vec<(u16, u8)> = [0x1C32u16, 0x1C33]
            .into_iter()
            .flat_map(|i| (0..=0x20u8).map(move |s| (i, s)))
            .collect();
        let (_, uploads) = block_on(run_dc_reading(p, cycle, None, &reads))
            .unwrap_or_else(|s| panic!("{}: SAFE-OP refused at {cycle} ns: {s:?}", p.name));
        let got = |index: u16, sub: u8| -> &Upload {
            let at = reads.iter().position(|r| *r == (index, sub)).expect("read");
            &uploads[at]
        };

        // From the profile file.
        for index in [0x1C32u16, 0x1C33] {
            let o = p.object(index).expect("SM parameter object");
            for sub in 0..=0x20u8 {
                let at = format!("{} {index:#06x}:{sub:02x}", p.name);
                let r = got(index, sub);
                let Some(e) = o.entry(sub) else {
                    assert_eq!(r, &Err(ABORT_NO_SUBINDEX), "{at}: not in the layout");
                    continue;
                };
                match (sub, e.storage) {
                    (0, _) => {
                        let highest = o.entries.last().expect("entries").subindex;
                        assert_eq!(r, &Ok(vec![highest]), "{at}: highest subindex");
                    }
                    (_, Storage::Const) => assert_eq!(r, &Ok(e.initial_bytes()), "{at}"),
                    (1, _) => assert_eq!(r, &Ok(vec![2, 0]), "{at}: DC SYNC0"),
                    (2 | 0x0A, _) => assert_eq!(uint(r), cycle, "{at}: the SYNC0 cycle"),
                    _ => assert_eq!(
                        r.as_ref().map(Vec::len),
                        Ok(e.byte_len()),
                        "{at}: kept by the stack"
                    ),
                }
            }
        }

        // From the manuals, literally.
        let sub0 = |index| uint(got(index, 0));
        let absent = |index, sub| got(index, sub) == &Err(ABORT_NO_SUBINDEX);
        match p.name.as_str() {
            // SDV3-E Table 6-1 (OSD-G-E Table 6-1, word for word): sub 0 = 32, :07 Minimum
            // Delay Time, :08 Get Cycle Time u16, :0A Sync0 Cycle Time, no :0B/:0C; :04 = 5;
            // :05 printed 0, 250 µs by decision.
            "sdv3-e" | "osd-g-e" => {
                for index in [0x1C32, 0x1C33] {
                    assert_eq!(sub0(index), 32, "{}", p.name);
                    assert_eq!(got(index, 7), &Ok(vec![0; 4]), "{}", p.name);
                    assert_eq!(got(index, 8), &Ok(vec![0; 2]), "{}", p.name);
                    assert_eq!(uint(got(index, 0x0A)), cycle, "{}", p.name);
                    assert!(absent(index, 0x0B) && absent(index, 0x0C), "{}", p.name);
                    assert_eq!(uint(got(index, 4)), 5, "{}", p.name);
                    assert_eq!(uint(got(index, 5)), 250_000, "{}", p.name);
                    assert_eq!(
                        got(index, 0x20),
                        &Ok(vec![0]),
                        "{}: Sync Error FALSE",
                        p.name
                    );
                }
            }
            // GHA-E §4.1: sub 0 = 32, no :03/:08; :04 = 0004h, :05 = 125000, :06 = 10000,
            // :09 = 0; :0A SYNC0 cycle time; :0B/:0C UINT16 counters.
            "gha-e" => {
                for index in [0x1C32, 0x1C33] {
                    assert_eq!(sub0(index), 32);
                    assert!(absent(index, 3) && absent(index, 8));
                    assert_eq!(uint(got(index, 4)), 0x0004);
                    assert_eq!(uint(got(index, 5)), 125_000);
                    assert_eq!(uint(got(index, 6)), 10_000);
                    assert_eq!(uint(got(index, 9)), 0);
                    assert_eq!(uint(got(index, 0x0A)), cycle);
                    assert_eq!(got(index, 0x0B).as_ref().map(Vec::len), Ok(2));
                    assert_eq!(got(index, 0x0C).as_ref().map(Vec::len), Ok(2));
                }
            }
            // RSE 7.2: sub 0 = 32, subindexes 1, 2, 4, 5, 6, 9, 20h only; 1C33h:06 printed 1;
            // :20 TRUE while synchronised (the RSE's polarity).
            "rse" => {
                for index in [0x1C32, 0x1C33] {
                    assert_eq!(sub0(index), 32);
                    for sub in [3, 7, 8, 0x0A, 0x0B, 0x0C] {
                        assert!(absent(index, sub), "rse {index:#06x}:{sub:02x}");
                    }
                    assert_eq!(uint(got(index, 9)), 0);
                }
                assert_eq!(uint(got(0x1C32, 6)), 0);
                assert_eq!(uint(got(0x1C33, 6)), 1);
                assert_eq!(got(0x1C32, 0x20), &Ok(vec![1]), "in sync");
            }
            // Σ-V-SD §4.4 (3): sub 0 = 12 / 10; 1C32h:03 = 125000 fixed, :06 = 62500,
            // :09 = 125000; 1C32h:0C SM2 event miss count (UDINT); 1C33h:04 = 0x0025; no :20.
            "sigma-v-sd" | "sigma-v-sd-2axis" => {
                assert_eq!((sub0(0x1C32), sub0(0x1C33)), (12, 10), "{}", p.name);
                assert_eq!(uint(got(0x1C32, 3)), 125_000, "{}", p.name);
                assert_eq!(uint(got(0x1C32, 6)), 62_500, "{}", p.name);
                assert_eq!(uint(got(0x1C32, 9)), 125_000, "{}", p.name);
                // The count itself depends on the master's frame timing (sync_rules.rs tests it).
                let count = got(0x1C32, 0x0C).as_ref().map(Vec::len);
                assert_eq!(count, Ok(4), "{}: 1C32h:0C a UDINT", p.name);
                assert_eq!(uint(got(0x1C33, 4)), 0x0025, "{}", p.name);
                assert!(absent(0x1C32, 0x20) && absent(0x1C33, 0x0B), "{}", p.name);
            }
            other => panic!("{other}: no manual facts asserted"),
        }
    }
}
