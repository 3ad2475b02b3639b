//! Parameters that act at power-on (ethercrab in process; the simulated drive keeps its
//! parameter storage across a power cycle):
//!
//! - SDV3-E §3.7: P4.02 = 1 makes the drive write P4.01 into the configured station alias
//!   0x0012 at start-up; with P4.02 = 0 the alias comes from SII word 4.
//! - SDV3-E §3.5.1: P4.09 sets the input shift time 1C33h:03 = P4.09 × 62500 ns at power-on.
//! - Σ-V-SD §4.7: after a store with 1010h:01/:04 the drive enters Operation Enabled only after
//!   a power cycle.

use board_sim::Segment;
use tests_host::session::{power_cycle, session, Step};

/// SDV3-E parameter group 4 (3003h, sub = P4.yy): P4.01 node ID, P4.02 node ID setting,
/// P4.09 input shift time setting (§2.4, Table 6-3).
const GROUP4: u16 = 0x3003;
const P4_01: u8 = 1;
const P4_02: u8 = 2;
const P4_09: u8 = 9;
/// 1010h:01 "save" (CiA 301 §7.5.2.13).
const STORE: u16 = 0x1010;
const SIGNATURE_SAVE: u32 = u32::from_le_bytes(*b"save");
/// ESC configured station alias register (ETG.1000.4).
const STATION_ALIAS: u16 = 0x0012;
/// 1C33h:03 input shift time.
const SM_INPUT_PARAMETER: u16 = 0x1C33;
const SHIFT_TIME: u8 = 3;
/// §3.5.1: one P4.09 step.
const SHIFT_STEP_NS: u32 = 62_500;

fn value(r: &Result<u32, ethercrab::error::Error>) -> u32 {
    *r.as_ref().unwrap_or_else(|e| panic!("{e:?}"))
}

#[test]
fn sdv3e_p4_02_selects_p4_01_as_station_alias_after_a_power_cycle() {
    let p = od_gen::builtin("sdv3-e").expect("profile");
    assert_eq!(p.eeprom.station_alias, 0, "SII word 4");
    let segment = Segment::new("sdv3-e", 1).expect("profile");
    let (mut segment, out) = session(
        segment,
        &[
            Step::Register(STATION_ALIAS),
            Step::Write(GROUP4, P4_01, 0x1234),
            Step::Write(GROUP4, P4_02, 1),
            Step::Register(STATION_ALIAS),
            Step::Write(STORE, 1, SIGNATURE_SAVE),
        ],
    );
    assert_eq!(value(&out[0]), 0, "the SII's alias at first power-on");
    assert!(
        out[1].is_ok() && out[2].is_ok() && out[4].is_ok(),
        "{out:?}"
    );
    assert_eq!(value(&out[3]), 0, "takes effect only after a power cycle");
    power_cycle(&mut segment);
    let (mut segment, out) = session(
        segment,
        &[
            Step::Register(STATION_ALIAS),
            Step::Write(GROUP4, P4_02, 0),
            Step::Write(STORE, 1, SIGNATURE_SAVE),
        ],
    );
    assert_eq!(value(&out[0]), 0x1234, "P4.02 = 1: the alias is P4.01");
    power_cycle(&mut segment);
    let (_, out) = session(segment, &[Step::Register(STATION_ALIAS)]);
    assert_eq!(
        value(&out[0]),
        0,
        "P4.02 = 0: the alias of SII word 4 again"
    );
}

#[test]
fn sdv3e_p4_09_sets_the_input_shift_at_power_on() {
    let segment = Segment::new("sdv3-e", 1).expect("profile");
    let (mut segment, out) = session(
        segment,
        &[
            Step::Read(SM_INPUT_PARAMETER, SHIFT_TIME),
            Step::Write(GROUP4, P4_09, 3),
            Step::Write(STORE, 1, SIGNATURE_SAVE),
        ],
    );
    assert_eq!(value(&out[0]), 0, "default");
    assert!(out[1].is_ok() && out[2].is_ok(), "{out:?}");
    power_cycle(&mut segment);
    let (_, out) = session(segment, &[Step::Read(SM_INPUT_PARAMETER, SHIFT_TIME)]);
    assert_eq!(
        value(&out[0]),
        3 * SHIFT_STEP_NS,
        "1C33h:03 = P4.09 × 62500 ns"
    );
}

/// GHA-E Pn-410 "driver slave alias" (§2.2.1: 2004h:0Bh, effective after power-on).
const PN_410: (u16, u8) = (0x2004, 0x0B);

#[test]
fn gha_e_pn_410_is_the_station_alias_after_a_power_cycle() {
    let segment = Segment::new("gha-e", 1).expect("profile");
    // An SDO download to a Pn parameter is saved at once (§4.2, Pn-046 = 0): no 1010h needed.
    let (mut segment, out) = session(
        segment,
        &[
            Step::Register(STATION_ALIAS),
            Step::WriteU16(PN_410.0, PN_410.1, 0x0042),
            Step::Register(STATION_ALIAS),
        ],
    );
    assert_eq!(value(&out[0]), 0, "SII word 4");
    assert!(out[1].is_ok(), "{out:?}");
    assert_eq!(value(&out[2]), 0, "effective after power-on only");
    power_cycle(&mut segment);
    let (_, out) = session(segment, &[Step::Register(STATION_ALIAS)]);
    assert_eq!(
        value(&out[0]),
        0x0042,
        "Pn-410 loaded into 0x0012 at power-on"
    );
}

#[test]
fn the_input_shift_is_stored_on_the_sigma_v_sd_but_not_on_the_sdv3e() {
    // Σ-V-SD §4.4 (3): 1C33h:03 is kept in EEPROM (PnCCA). SDV3-E: P4.09 is the stored form.
    for (profile, kept) in [("sigma-v-sd", true), ("sdv3-e", false)] {
        let segment = Segment::new(profile, 1).expect("profile");
        let (mut segment, out) = session(
            segment,
            &[
                Step::Write(SM_INPUT_PARAMETER, SHIFT_TIME, 250_000),
                Step::Write(STORE, 1, SIGNATURE_SAVE),
            ],
        );
        assert!(out.iter().all(Result::is_ok), "{profile}: {out:?}");
        power_cycle(&mut segment);
        let (_, out) = session(segment, &[Step::Read(SM_INPUT_PARAMETER, SHIFT_TIME)]);
        let expected = if kept { 250_000 } else { 0 };
        assert_eq!(
            value(&out[0]),
            expected,
            "{profile}: 1C33h:03 after a power cycle"
        );
    }
}

/// Takes drive 0 of `segment` to OP (free run, 1 ms: the Σ-V-SD's 1C32h:02 default) with a fresh
/// master, sends the enable sequence (shutdown, switch on, enable operation) and returns the
/// segment with the statusword the drive ended in.
fn enable_in_op(segment: Segment) -> (Segment, u16) {
    use tests_host::session::take_segment;
    use tests_host::vendor;
    const CYCLE_NS: u64 = 1_000_000;
    tests_host::block_on(async {
        let (m, transport) = tests_host::master_for(segment);
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = vendor::into_op(&m, md, &[]).await;
        // Σ-V-SD 1600h: 6040h at byte 0; 1A00h: 6041h at byte 0.
        let mut inputs = Vec::new();
        for cw in vendor::enable_sequence(20) {
            inputs = vendor::exchange(&m, md, &group, &[(0, &cw.to_le_bytes())], CYCLE_NS).await;
        }
        let statusword = vendor::u16_at(&inputs, 0);
        (take_segment(&m), statusword)
    })
}

/// Σ-V-SD §4.7 (and §4.2 (5)): "after storing with 1010h sub 1 or sub 4, a power-on reset is
/// required before the drive can enter Operation Enabled". Enable operation then stops in
/// Switched On; after a power cycle the drive enables again. A store of another subindex
/// (sub 2, the communication objects) does not lock it.
#[test]
fn sigma_v_sd_a_parameter_store_needs_a_power_cycle_before_operation_enabled() {
    const STATE_MASK: u16 = 0x6F;
    const SWITCHED_ON: u16 = 0x23;
    const OPERATION_ENABLED: u16 = 0x27;
    let segment = Segment::new("sigma-v-sd", 1).expect("profile");
    // Sub 2 (1xxxh objects): no power cycle needed.
    let (segment, out) = session(segment, &[Step::Write(STORE, 2, SIGNATURE_SAVE)]);
    assert!(out[0].is_ok(), "{out:?}");
    let (_, sw) = enable_in_op(segment);
    assert_eq!(
        sw & STATE_MASK,
        OPERATION_ENABLED,
        "after 1010h:02: {sw:#06x}"
    );
    for sub in [1, 4] {
        let (mut segment, sw) = enable_in_op(segment_fresh_after(sub));
        assert_eq!(
            sw & STATE_MASK,
            SWITCHED_ON,
            "after 1010h:{sub:02}: enable operation stops in Switched On ({sw:#06x})"
        );
        power_cycle(&mut segment);
        let (_, sw) = enable_in_op(segment);
        assert_eq!(
            sw & STATE_MASK,
            OPERATION_ENABLED,
            "after the power cycle: {sw:#06x}"
        );
    }
}

/// A fresh Σ-V-SD whose parameters were just stored with 1010h:`sub` (in PREOP, Switch On
/// Disabled: the state the profile allows it in).
fn segment_fresh_after(sub: u8) -> Segment {
    let segment = Segment::new("sigma-v-sd", 1).expect("profile");
    let (segment, out) = session(segment, &[Step::Write(STORE, sub, SIGNATURE_SAVE)]);
    assert!(out[0].is_ok(), "1010h:{sub:02}: {out:?}");
    segment
}

/// GHA-E §2.2.2 / §5.7.3: 6091h:01 = Pn-006 × 10000 + Pn-007 and 6091h:02 = Pn-008 × 10000 +
/// Pn-009 are one setting in two forms: a write to either updates the other. The Pn parameters
/// are saved at once (§4.2, Pn-046 = 0), 6091h only by 1010h: after a power cycle the Pn form
/// holds the last write to it and sets 6091h; a 6091h write that was not stored is gone.
#[test]
fn gha_e_gear_ratio_6091h_and_pn_006_to_009_are_one_setting() {
    const GEAR: u16 = 0x6091;
    const PN: u16 = 0x2000;
    const PN_006: u8 = 0x07;
    const PN_007: u8 = 0x08;
    const PN_008: u8 = 0x09;
    const PN_009: u8 = 0x0A;
    let segment = Segment::new("gha-e", 1).expect("profile");
    let (mut segment, out) = session(
        segment,
        &[
            // The defaults agree: 131072 = 13 × 10000 + 1072, 10000 = 1 × 10000 + 0.
            Step::Read(GEAR, 1),
            Step::ReadU16(PN, PN_006),
            Step::ReadU16(PN, PN_007),
            // 6091h:01 written: Pn-006/007 follow.
            Step::Write(GEAR, 1, 262_144),
            Step::ReadU16(PN, PN_006),
            Step::ReadU16(PN, PN_007),
            // Pn-008 written: 6091h:02 follows.
            Step::WriteU16(PN, PN_008, 2),
            Step::Read(GEAR, 2),
            Step::ReadU16(PN, PN_009),
        ],
    );
    let values: Vec<u32> = out.iter().map(value).collect();
    assert_eq!(&values[..3], &[131_072, 13, 1_072], "defaults");
    assert_eq!(
        &values[4..6],
        &[26, 2_144],
        "Pn-006/007 from 6091h:01 = 262144"
    );
    assert_eq!(&values[7..9], &[20_000, 0], "6091h:02 from Pn-008 = 2");
    power_cycle(&mut segment);
    let (_, out) = session(
        segment,
        &[
            Step::Read(GEAR, 1),
            Step::ReadU16(PN, PN_006),
            Step::Read(GEAR, 2),
            Step::ReadU16(PN, PN_008),
        ],
    );
    let values: Vec<u32> = out.iter().map(value).collect();
    assert_eq!(
        values,
        [131_072, 13, 20_000, 2],
        "6091h:01 not stored (the default again), Pn-008 saved at once sets 6091h:02"
    );
}
