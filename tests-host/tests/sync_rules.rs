//! The synchronisation rules the vendor profiles give as data (`[sync]`, `[esm]
//! al_error_alarms`), under a real master (ethercrab, in process):
//!
//! - SDV3-E §3.5.2: in free run the master writes the cycle to 1C32h:02, 1 ms – 10 ms; the drive
//!   runs its cycle at that period; a shorter one (a valid DC cycle) is refused at SAFE-OP.
//! - Σ-V-SD §2.6 / §4.4 (3): the input shift time 1C33h:03 takes multiples of 125 µs up to the
//!   SYNC0 cycle − 125 µs.
//! - Σ-V-SD §4.4 (4): the sync error counter (+3 per SYNC0 without an SM2 event or a SYNC0 that
//!   did not come, −1 per good one) trips when it reaches 10F1h:02 and raises alarm A.A12
//!   (603Fh 0A12h, EMCY FF00h) with ESM → SAFEOP.
//! - GHA-E §6.1: a SYNC0 period outside the allowed set is alarm Co03.
//! - SDV3-E §5.2: the EtherCAT-layer alarms LL (link lost), Hr (PDI error), Pto (PDO watchdog)
//!   and cSD (outputs lost P4.03 times in a row in a cyclic synchronous mode), with their ESM
//!   state, AL status code and ERR LED.

use std::time::Duration;

use board_sim::inproc::InProcess;
use board_sim::{Segment, SimDevice};
use ethercrab::subdevice_group::{DcConfiguration, HasDc, Op, PreOp};
use ethercrab::{Command, DcSync, DefaultLock, MainDevice, SubDeviceGroup};
use od_gen::model::Profile;
use tests_host::session::{power_cycle, session, take_segment, Step};
use tests_host::{al_status, block_on, dc_safe_op, master_for, FIRST_STATION};

const MAX_SUBDEVICES: usize = 4;
const MAX_PDI: usize = 512;
type Group = SubDeviceGroup<MAX_SUBDEVICES, MAX_PDI, DefaultLock, PreOp>;
type OpGroup = SubDeviceGroup<MAX_SUBDEVICES, MAX_PDI, DefaultLock, Op, HasDc>;

/// AL status values (ETG.1000.6 Table 9): state | 0x10 error indication.
const PREOP: u16 = 0x02;
const SAFEOP: u16 = 0x04;
const AL_ERROR: u16 = 0x10;
/// AL status codes (ETG.1000.6 Table 11).
const SYNC_ERROR: u16 = 0x001A;
const INVALID_SYNC_CYCLE_TIME: u16 = 0x0035;
const SYNC0_CYCLE_TIME: u16 = 0x0036;
const FATAL_SYNC_ERROR: u16 = 0x002C;
const NO_SYNC_ERROR: u16 = 0x002D;
/// SDO abort "value range of parameter exceeded" (ETG.1000.6 Table 41).
const ABORT_VALUE_RANGE: u32 = 0x0609_0030;
/// 1C32h (SM output parameter) / 1C33h (SM input parameter), ETG.1020 §5.1.
const SM_OUTPUT_PARAMETER: u16 = 0x1C32;
const SM_INPUT_PARAMETER: u16 = 0x1C33;
const SUB_CYCLE_TIME: u8 = 0x02;
const SUB_SHIFT_TIME: u8 = 0x03;
/// The Σ-V-SD's "SM2 event miss count" (§4.4 (3): 1C32h:0C, UDINT; ETG.1020 has :0B).
const SIGMA_MISS_COUNT: u8 = 0x0C;
/// SDO abort "subindex does not exist" (ETG.1000.6 Table 41).
const ABORT_NO_SUBINDEX: u32 = 0x0609_0011;
/// 603Fh error code (CiA402).
const ERROR_CODE: u16 = 0x603F;
/// 1001h error register and its bit 0 "generic error" (CiA 301).
const ERROR_REGISTER: u16 = 0x1001;
const GENERIC_ERROR: u8 = 0x01;
/// 10F1h:02 sync error counter limit (ETG.1020); 0 switches the supervision off.
const ERROR_SETTINGS: u16 = 0x10F1;
/// Σ-V-SD §2.7: every emergency is FF00h.
const SIGMA_EMCY_CODE: u16 = 0xFF00;
/// AL status OP (ETG.1000.6 Table 9); SM watchdog AL status code (Table 11).
const OP: u16 = 0x08;
const INIT: u16 = 0x01;
const SM_WATCHDOG: u16 = 0x001B;
/// AL control register (ETG.1000.4 Table 33).
const AL_CONTROL: u16 = 0x0120;
/// ESC SYNC0 cycle time register (ETG.1000.4 Table 60).
const DC_SYNC0_CYCLE: u16 = 0x09A0;
/// SM1 status register (SM n at 0x0800 + 8n, status at +5), bit 3 "mailbox full".
const SM1_STATUS: u16 = 0x080D;
const MAILBOX_FULL: u8 = 0x08;
/// SDV3-E P4.03 "data synchronization detection setting" (3003h:03, §2.4) and the byte of
/// 6060h "modes of operation" in the default RxPDO1 (1600h: 6040h, 607Ah, 60FFh, 6071h, 6060h).
const GROUP4: u16 = 0x3003;
const P4_03: u8 = 3;
const MODE_BYTE: usize = 2 + 4 + 4 + 2;
/// CiA402 modes of operation: profile position, cyclic synchronous position.
const MODE_PP: u8 = 1;
const MODE_CSP: u8 = 8;
/// 1010h:01 "save" (CiA 301 §7.5.2.13).
const STORE: u16 = 0x1010;
const SIGNATURE_SAVE: u32 = u32::from_le_bytes(*b"save");
/// Mailbox header (6 bytes), type 3 = CoE; CoE service 1 = emergency.
const MAILBOX_HEADER: usize = 6;
const TYPE_COE: u8 = 3;
const COE_EMERGENCY: u16 = 1;

fn profile(name: &str) -> Profile {
    od_gen::builtin(name).expect("built-in profile")
}

/// The `[[alarm]]` of `p` with `display`.
fn alarm<'p>(p: &'p Profile, display: &str) -> &'p od_gen::model::Alarm {
    p.alarms
        .iter()
        .find(|a| a.display == display)
        .unwrap_or_else(|| panic!("alarm {display}"))
}

async fn init(m: &InProcess) -> Group {
    m.maindevice
        .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
        .await
        .expect("init")
}

fn abort_code(e: ethercrab::error::Error) -> u32 {
    match e {
        ethercrab::error::Error::Mailbox(ethercrab::error::MailboxError::Aborted {
            code, ..
        }) => u32::from(code),
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

/// Waits (advancing `step_ns` per poll) until SM1 holds a mailbox and returns its CoE part:
/// CoE header, EMCY code, 1001h, manufacturer field.
async fn emergency(m: &InProcess, md: &MainDevice<'_>, sm1_start: u16, step_ns: u64) -> Vec<u8> {
    for _ in 0..50 {
        let status: u8 = Command::fprd(FIRST_STATION, SM1_STATUS)
            .receive(md)
            .await
            .expect("SM1 status");
        if status & MAILBOX_FULL != 0 {
            let mb: [u8; 64] = Command::fprd(FIRST_STATION, sm1_start)
                .receive(md)
                .await
                .expect("SM1");
            assert_eq!(mb[5] & 0x0F, TYPE_COE, "mailbox type");
            let coe = mb[MAILBOX_HEADER..MAILBOX_HEADER + 10].to_vec();
            assert_eq!(u16::from_le_bytes([coe[0], coe[1]]) >> 12, COE_EMERGENCY);
            return coe;
        }
        m.shared.advance(step_ns);
    }
    panic!("no emergency in SM1");
}

/// PREOP → OP with DC SYNC0 at `cycle_ns` ([`dc_safe_op`], then cycling until every drive is in
/// OP; the cycle that reached OP is completed).
async fn into_dc_op(m: &InProcess, md: &MainDevice<'_>, cycle_ns: u64) -> OpGroup {
    let group = init(m).await;
    let group = dc_safe_op(m, md, group, cycle_ns).await.expect("SAFE-OP");
    let group = group.request_into_op(md).await.expect("request OP");
    for _ in 0..100 {
        let r = group.tx_rx_dc(md).await.expect("tx/rx");
        m.shared.advance(cycle_ns);
        if r.all_op() {
            return group;
        }
    }
    panic!("no OP: {:?}", al_status(md).await);
}

#[test]
fn sdv3e_free_run_cycle_is_1c32h_02_and_must_be_1_to_10_ms() {
    let p = profile("sdv3-e");
    assert_eq!(
        (p.sync.free_run_min_cycle_ns, p.sync.free_run_max_cycle_ns),
        (1_000_000, 10_000_000),
        "§3.5.2"
    );
    // 500 µs: a valid DC cycle (the SDO range of 1C32h:02 is 250 µs – 10 ms), not a free-run one.
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(SM_OUTPUT_PARAMETER, SUB_CYCLE_TIME, 500_000u32)
            .await
            .expect("1C32h:02 = 500 µs is in the entry's range");
        assert!(group.into_safe_op(md).await.is_err(), "SAFE-OP refused");
        assert_eq!(
            al_status(md).await,
            (PREOP | AL_ERROR, INVALID_SYNC_CYCLE_TIME)
        );
    });
    // 2 ms: accepted, and the drive's cycle runs every 2 ms.
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(SM_OUTPUT_PARAMETER, SUB_CYCLE_TIME, 2_000_000u32)
            .await
            .expect("1C32h:02 = 2 ms");
        let group = group.into_safe_op(md).await.expect("SAFE-OP in free run");
        let cycles = || m.shared.segment().drives()[0].slave.cycles();
        let before = cycles();
        const SPAN_NS: u64 = 40_000_000;
        const STEP_NS: u64 = 500_000;
        for _ in 0..SPAN_NS / STEP_NS {
            group.tx_rx(md).await.expect("tx/rx");
            m.shared.advance(STEP_NS);
        }
        let ran = cycles() - before;
        assert!(
            (19..=21).contains(&ran),
            "{ran} cycles in 40 ms: the free-run period is not 2 ms"
        );
        let cycle: u32 = group
            .subdevice(md, 0)
            .expect("drive")
            .sdo_read(SM_OUTPUT_PARAMETER, SUB_CYCLE_TIME)
            .await
            .expect("1C32h:02");
        assert_eq!(cycle, 2_000_000);
    });
}

#[test]
fn sigma_v_sd_input_shift_takes_125_us_steps_up_to_the_cycle_minus_125_us() {
    const CYCLE_NS: u64 = 1_000_000;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let err = sd
            .sdo_write(SM_INPUT_PARAMETER, SUB_SHIFT_TIME, 130_000u32)
            .await
            .expect_err("not a multiple of 125 µs");
        assert_eq!(abort_code(err), ABORT_VALUE_RANGE);
        sd.sdo_write(SM_INPUT_PARAMETER, SUB_SHIFT_TIME, 875_000u32)
            .await
            .expect("7 × 125 µs");
        let shift: u32 = sd
            .sdo_read(SM_INPUT_PARAMETER, SUB_SHIFT_TIME)
            .await
            .expect("1C33h:03");
        assert_eq!(shift, 875_000);
        // 875 µs = 1 ms − 125 µs: the largest shift a 1 ms cycle takes.
        assert!(dc_safe_op(&m, md, group, CYCLE_NS).await.is_ok());
    });
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(SM_INPUT_PARAMETER, SUB_SHIFT_TIME, 1_000_000u32)
            .await
            .expect("in range for the longest cycle (4 ms)");
        let refused = dc_safe_op(&m, md, group, CYCLE_NS).await.err();
        assert_eq!(refused, Some((PREOP | AL_ERROR, INVALID_SYNC_CYCLE_TIME)));
    });
}

/// Σ-V-SD in OP with DC SYNC0 at 1 ms; then `missed_cycle(k)` decides for 30 cycles whether
/// cycle k's SYNC0 comes without new outputs (the master skips its frame) or, with
/// `slow_sync0`, SYNC0 runs at 2 ms so that every other one does not come. Asserts the sync
/// error with alarm A.A12 and that it tripped after 4 missed events (counter 9 = the limit).
fn sigma_v_sd_sync_error(slow_sync0: bool, missed_cycle: fn(usize) -> bool) {
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sigma-v-sd");
    let alarm = alarm(&p, "A.A12");
    let limit = p.entry(0x10F1, 2).expect("10F1h:02").initial_bytes()[0];
    assert_eq!(limit, 9, "§4.4 (4): default 9");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        for _ in 0..5 {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (0x08, 0), "OP without error");
        if slow_sync0 {
            Command::fpwr(FIRST_STATION, DC_SYNC0_CYCLE)
                .send(md, 2 * CYCLE_NS as u32)
                .await
                .expect("0x09A0");
        }
        for k in 0..30 {
            let since = m.shared.clock().now();
            if !missed_cycle(k) {
                group.tx_rx_dc(md).await.expect("tx/rx");
            }
            m.shared.finish_cycle(since, CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (SAFEOP | AL_ERROR, SYNC_ERROR));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, CYCLE_NS).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
        assert_eq!(&coe[5..10], &alarm.emcy.data, "manufacturer field");
        assert_eq!(coe[4], GENERIC_ERROR, "§4.2: 1001h uses bit 0 only");
        let sd = group.subdevice(md, 0).expect("drive");
        let code: u16 = sd.sdo_read(ERROR_CODE, 0).await.expect("603Fh");
        assert_eq!(code, alarm.error_code, "603Fh = A.A12");
        let register: u8 = sd.sdo_read(ERROR_REGISTER, 0).await.expect("1001h");
        assert_eq!(register, GENERIC_ERROR, "§4.2: 1001h uses bit 0 only");
        // §4.4 (3): the miss count is 1C32h:0C (UDINT) on this drive.
        let missed: u32 = sd
            .sdo_read(SM_OUTPUT_PARAMETER, SIGMA_MISS_COUNT)
            .await
            .expect("1C32h:0C");
        assert_eq!(
            missed, 4,
            "tripped on reaching the limit: 3, 2, 5, 4, 7, 6, 9"
        );
    });
}

#[test]
fn sigma_v_sd_sync0_without_outputs_trips_at_the_limit_as_alarm_a_a12() {
    // §4.4 (4) worked example: the process data fail at every other SYNC0.
    sigma_v_sd_sync_error(false, |k| k % 2 == 0);
}

#[test]
fn sigma_v_sd_missed_sync0_trips_at_the_limit_as_alarm_a_a12() {
    sigma_v_sd_sync_error(true, |_| false);
}

#[test]
fn sigma_v_sd_a_single_missing_frame_does_not_trip() {
    // One miss in ten cycles: +3 then −1 per good cycle never reaches 9.
    const CYCLE_NS: u64 = 1_000_000;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        for k in 0..100 {
            let since = m.shared.clock().now();
            if k % 10 != 0 {
                group.tx_rx_dc(md).await.expect("tx/rx");
            }
            m.shared.finish_cycle(since, CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (0x08, 0), "still OP");
        let sd = group.subdevice(md, 0).expect("drive");
        let missed: u32 = sd
            .sdo_read(SM_OUTPUT_PARAMETER, SIGMA_MISS_COUNT)
            .await
            .expect("1C32h:0C");
        assert_eq!(missed, 10, "every missing frame counted in 1C32h:0C");
        // §4.4 (3): the manual's layout, fixed values unchanged by the running cycle, :0A the
        // SYNC0 cycle.
        let sub0: u8 = sd.sdo_read(SM_OUTPUT_PARAMETER, 0).await.expect("1C32h:00");
        assert_eq!(sub0, 12);
        let sub0: u8 = sd.sdo_read(SM_INPUT_PARAMETER, 0).await.expect("1C33h:00");
        assert_eq!(sub0, 10);
        for (sub, value) in [
            (3u8, 125_000u32),
            (5, 250_000),
            (6, 62_500),
            (9, 125_000),
            (10, 1_000_000),
        ] {
            let v: u32 = sd.sdo_read(SM_OUTPUT_PARAMETER, sub).await.expect("1C32h");
            assert_eq!(v, value, "1C32h:{sub:02X}");
        }
        let supported: u16 = sd.sdo_read(SM_INPUT_PARAMETER, 4).await.expect("1C33h:04");
        assert_eq!(supported, 0x0025, "input shift with local timer");
        let err = sd
            .sdo_read::<u8>(SM_OUTPUT_PARAMETER, 0x20)
            .await
            .expect_err("no :20 on this drive");
        assert_eq!(abort_code(err), ABORT_NO_SUBINDEX);
    });
}

#[test]
fn sigma_v_sd_sm_watchdog_is_an_ff00h_emergency_with_the_generic_bit_only() {
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sigma-v-sd");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        // Sync supervision off, so that only the SM watchdog sees the master stop.
        group
            .subdevice(md, 0)
            .expect("drive")
            .sdo_write(ERROR_SETTINGS, 2, 0u32)
            .await
            .expect("10F1h:02 = 0");
        let group = dc_safe_op(&m, md, group, CYCLE_NS).await.expect("SAFE-OP");
        let group = group.request_into_op(md).await.expect("request OP");
        for _ in 0..100 {
            if group.tx_rx_dc(md).await.expect("tx/rx").all_op() {
                break;
            }
            m.shared.advance(CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (OP, 0));
        // The ESC's default process-data watchdog: 100 ms.
        m.shared.advance(120 * CYCLE_NS);
        assert_eq!(al_status(md).await, (SAFEOP | AL_ERROR, SM_WATCHDOG));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, CYCLE_NS).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            SIGMA_EMCY_CODE,
            "§2.7"
        );
        assert_eq!(coe[4], GENERIC_ERROR, "§4.2: bit 0 only");
        assert_eq!(
            u16::from_le_bytes([coe[6], coe[7]]),
            SM_WATCHDOG,
            "the AL status code where the alarm code goes"
        );
    });
}

#[test]
fn sdv3e_missed_sync0_is_cs_with_al_status_0x2c() {
    // §5.2 5): cS "SYNC signal out of step" → SafeOP, AL status 0x002C, alarm cS.
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sdv3-e");
    let alarm = alarm(&p, "cS");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        assert_eq!(al_status(md).await, (OP, 0));
        // SYNC0 at twice the configured period: every other event is missed.
        Command::fpwr(FIRST_STATION, DC_SYNC0_CYCLE)
            .send(md, 2 * CYCLE_NS as u32)
            .await
            .expect("0x09A0");
        for _ in 0..20 {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (SAFEOP | AL_ERROR, FATAL_SYNC_ERROR));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, CYCLE_NS).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
        assert_eq!(
            &coe[5..10],
            &alarm.emcy.data,
            "error No. 34h, auxiliary code 801Bh"
        );
    });
}

#[test]
fn sdv3e_sync0_not_locked_within_2_s_of_safeop_is_plf_in_preop() {
    // §5.2 7): PLF "PLL phase-locking failure": no lock within 2 s in SafeOP → PreOP, 0x002D.
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sdv3-e");
    let alarm = alarm(&p, "PLF");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut group = init(&m).await;
        for mut sd in group.iter_mut(md) {
            sd.set_dc_sync(DcSync::Sync0);
        }
        let group = group.into_pre_op_pdi(md).await.expect("PRE-OP with PDI");
        for _ in 0..100 {
            group.tx_rx_sync_system_time(md).await.expect("time sync");
            m.shared.advance(CYCLE_NS);
        }
        // The SYNC unit is activated with its first pulse 3 s away: no lock for 3 s.
        let group = group
            .configure_dc_sync(
                md,
                DcConfiguration {
                    start_delay: Duration::from_secs(3),
                    sync0_period: Duration::from_nanos(CYCLE_NS),
                    sync0_shift: Duration::ZERO,
                },
            )
            .await
            .expect("DC configuration");
        let _group = group.into_safe_op(md).await.expect("SAFE-OP");
        m.shared.advance(1_900_000_000);
        assert_eq!(
            al_status(md).await,
            (SAFEOP, 0),
            "still waiting after 1.9 s"
        );
        m.shared.advance(200_000_000);
        assert_eq!(al_status(md).await, (PREOP | AL_ERROR, NO_SYNC_ERROR));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, CYCLE_NS).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
    });
}

#[test]
fn sdv3e_input_link_lost_in_op_is_ll_in_init() {
    // §5.2 3): LL "link disconnection": the input port's link lost in PreOP/SafeOP/OP → Init,
    // AL status code 0x0000; the drive holds alarm LL (603Fh 8502h) until a fault reset.
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sdv3-e");
    let alarm = alarm(&p, "LL");
    let segment = block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        let transport = tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        assert_eq!(al_status(md).await, (OP, 0));
        // The cable is pulled for 30 ms, then plugged again.
        m.shared.segment().set_master_cable(false);
        m.shared.advance(30 * CYCLE_NS);
        m.shared.segment().set_master_cable(true);
        assert_eq!(
            al_status(md).await,
            (INIT, 0),
            "Init, AL status code 0x0000"
        );
        drop(group);
        transport.abort();
        take_segment(&m)
    });
    let (_, out) = session(segment, &[Step::ReadU16(ERROR_CODE, 0)]);
    assert_eq!(
        out[0].as_ref().ok().copied(),
        Some(u32::from(alarm.error_code)),
        "603Fh = LL"
    );
}

#[test]
fn sdv3e_link_loss_shows_the_err_led_blinking_until_the_next_request() {
    // §5.2 3): LL, ERR LED "Blinking" although the AL status carries no error flag.
    const CYCLE_NS: u64 = 1_000_000;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let _group = into_dc_op(&m, md, CYCLE_NS).await;
        m.shared.segment().set_master_cable(false);
        m.shared.advance(30 * CYCLE_NS);
        m.shared.segment().set_master_cable(true);
        assert_eq!(al_status(md).await, (INIT, 0));
        let (on, off) = err_led_over(&m, 2_000);
        assert!(on >= 4 && off >= 4, "blinking: {on} on, {off} off");
        // The master asks for PREOP: the error it could not see is history.
        Command::fpwr(FIRST_STATION, AL_CONTROL)
            .send(md, PREOP)
            .await
            .expect("AL control");
        m.shared.advance(10 * CYCLE_NS);
        assert_eq!(al_status(md).await, (PREOP, 0));
        let (on, _) = err_led_over(&m, 1_000);
        assert_eq!(on, 0, "ERR LED off");
    });
}

#[test]
fn sdv3e_pdi_error_is_hr_in_init_with_the_err_led_on() {
    // §5.2 1): Hr "ECAT hardware error; PDI interface access error", detected in every state:
    // ESM → Init, AL status code 0x0000, ERR LED on; 603Fh = Hr (8500h).
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("sdv3-e");
    let alarm = alarm(&p, "Hr");
    let segment = block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        let transport = tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        for _ in 0..5 {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
        }
        assert_eq!(al_status(md).await, (OP, 0));
        m.shared.segment().drives_mut()[0]
            .esc_mut()
            .inject_pdi_error();
        m.shared.advance(20 * CYCLE_NS);
        assert_eq!(
            al_status(md).await,
            (INIT, 0),
            "Init, AL status code 0x0000"
        );
        let (on, off) = err_led_over(&m, 2_000);
        assert_eq!((on, off), (20, 0), "ERR LED on, steady");
        drop(group);
        transport.abort();
        take_segment(&m)
    });
    let (_, out) = session(segment, &[Step::ReadU16(ERROR_CODE, 0)]);
    assert_eq!(
        out[0].as_ref().ok().copied(),
        Some(u32::from(alarm.error_code)),
        "603Fh = Hr"
    );
}

#[test]
fn sdv3e_pdo_watchdog_timeout_is_pto_with_the_err_led_flashing_once() {
    // §5.2 4): Pto "PDO watchdog timeout" → SafeOP, AL 0x001B, ERR LED "single flashing" (one
    // 200 ms flash per 1.2 s; ETG.1300 gives the watchdog a double flash).
    const CYCLE_NS: u64 = 1_000_000;
    const SAMPLE_NS: u64 = 10_000_000;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let _group = into_dc_op(&m, md, CYCLE_NS).await;
        // The master stops: no process data for longer than the SM watchdog (100 ms).
        m.shared.advance(300 * CYCLE_NS);
        assert_eq!(al_status(md).await, (SAFEOP | AL_ERROR, SM_WATCHDOG));
        // 10 ms samples over two periods and a half: the lengths of the on and off runs.
        let lit: Vec<bool> = (0..300)
            .map(|_| {
                m.shared.advance(SAMPLE_NS);
                m.shared.segment().drives_mut()[0].leds.err.on
            })
            .collect();
        let mut runs: Vec<(bool, usize)> = Vec::new();
        for on in lit {
            match runs.last_mut() {
                Some((state, n)) if *state == on => *n += 1,
                _ => runs.push((on, 1)),
            }
        }
        // Whole runs only (not the first and the last, cut by the sampling window).
        let inner = &runs[1..runs.len() - 1];
        assert!(inner.len() >= 3, "{runs:?}");
        for &(on, n) in inner {
            let expected = if on { 20 } else { 100 };
            assert!(
                n.abs_diff(expected) <= 1,
                "single flash 200 ms / 1000 ms: {runs:?}"
            );
        }
    });
}

/// Samples the first drive's ERR LED every 100 ms for `ms` of simulated time: (on, off) counts.
fn err_led_over(m: &InProcess, ms: u64) -> (u32, u32) {
    const SAMPLE_NS: u64 = 100_000_000;
    let (mut on, mut off) = (0, 0);
    for _ in 0..ms * 1_000_000 / SAMPLE_NS {
        // Half a blink period (200 ms on, 200 ms off) plus a little: samples land on both.
        m.shared.advance(SAMPLE_NS + 3_000_000);
        if m.shared.segment().drives_mut()[0].leds.err.on {
            on += 1;
        } else {
            off += 1;
        }
    }
    (on, off)
}

#[test]
fn sdv3e_outputs_lost_p4_03_times_in_a_row_in_csp_are_csd() {
    // §5.2 6) / §2.4: cSD when the data of a cyclic synchronous mode is lost P4.03 times in a
    // row (P4.03 acts after a power cycle); OP, DC: ESM → SafeOP, AL status 0x002C, alarm cSD
    // (8102h, error No. 35h, aux 801Bh), not cS, which shares the AL status code.
    const CYCLE_NS: u64 = 1_000_000;
    const LIMIT: u32 = 3;
    let p = profile("sdv3-e");
    let alarm = alarm(&p, "cSD");
    let (mut segment, out) = session(
        Segment::new("sdv3-e", 1).expect("profile"),
        &[
            Step::Write(GROUP4, P4_03, LIMIT),
            Step::Write(STORE, 1, SIGNATURE_SAVE),
        ],
    );
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    power_cycle(&mut segment);
    block_on(async {
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        // `lost[k]`: the master's frame of cycle k does not come; otherwise it writes `mode`.
        let run = |mode: u8, lost: &'static [bool]| {
            let group = &group;
            let m = &m;
            async move {
                for &skip in lost {
                    let since = m.shared.clock().now();
                    if !skip {
                        let sd = group.subdevice(md, 0).expect("drive");
                        sd.outputs_raw_mut()[MODE_BYTE] = mode;
                        group.tx_rx_dc(md).await.expect("tx/rx");
                    }
                    m.shared.finish_cycle(since, CYCLE_NS);
                }
            }
        };
        const GOOD: &[bool] = &[false; 5];
        const LOST_TEN: &[bool] = &[true; 10];
        const LOST_TWICE_THEN_GOOD: &[bool] = &[true, true, false, true, true, false, false];
        const LOST_LIMIT: &[bool] = &[true, true, true];
        // Profile position is not a cyclic synchronous mode: not supervised.
        run(MODE_PP, GOOD).await;
        run(MODE_PP, LOST_TEN).await;
        run(MODE_PP, GOOD).await;
        assert_eq!(al_status(md).await, (OP, 0), "PP: no cSD");
        // CSP: two lost in a row are below P4.03 = 3.
        run(MODE_CSP, GOOD).await;
        run(MODE_CSP, LOST_TWICE_THEN_GOOD).await;
        assert_eq!(al_status(md).await, (OP, 0), "CSP, two lost in a row");
        run(MODE_CSP, LOST_LIMIT).await;
        assert_eq!(al_status(md).await, (SAFEOP | AL_ERROR, FATAL_SYNC_ERROR));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, CYCLE_NS).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code 8102h"
        );
        assert_eq!(&coe[5..10], &alarm.emcy.data, "error No. 35h, aux 801Bh");
        let sd = group.subdevice(md, 0).expect("drive");
        let code: u16 = sd.sdo_read(ERROR_CODE, 0).await.expect("603Fh");
        assert_eq!(code, alarm.error_code, "603Fh = cSD");
    });
}

#[test]
fn gha_e_counts_missed_events_in_both_sm_parameter_objects() {
    // GHA-E §4.1: 1C32h and 1C33h both have :0B "SM event missed counter".
    const CYCLE_NS: u64 = 1_000_000;
    let p = profile("gha-e");
    assert!(p.entry(0x1C32, 0x0B).is_some() && p.entry(0x1C33, 0x0B).is_some());
    block_on(async {
        let (m, transport) = master_for(Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_dc_op(&m, md, CYCLE_NS).await;
        Command::fpwr(FIRST_STATION, DC_SYNC0_CYCLE)
            .send(md, 2 * CYCLE_NS as u32)
            .await
            .expect("0x09A0");
        for _ in 0..20 {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
        }
        let sd = group.subdevice(md, 0).expect("drive");
        let outputs: u16 = sd
            .sdo_read(SM_OUTPUT_PARAMETER, 0x0B)
            .await
            .expect("1C32h:0B");
        let inputs: u16 = sd
            .sdo_read(SM_INPUT_PARAMETER, 0x0B)
            .await
            .expect("1C33h:0B");
        assert!(outputs > 0, "SYNC0 events were missed");
        assert_eq!(inputs, outputs, "the same SYNC0 drives both SMs");
    });
}

#[test]
fn gha_e_sync0_period_outside_the_allowed_set_is_alarm_co03() {
    let p = profile("gha-e");
    let alarm = alarm(&p, "Co03");
    block_on(async {
        let (m, transport) = master_for(Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        // 375 µs: inside 125 µs – 2 ms, a multiple of 125 µs, not one of 125/250/500 µs, 1/2 ms.
        let refused = dc_safe_op(&m, md, group, 375_000).await.err();
        assert_eq!(refused, Some((PREOP | AL_ERROR, SYNC0_CYCLE_TIME)));
        let coe = emergency(&m, md, p.sm.mailbox_in.start, 1_000_000).await;
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
        let group = init(&m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let code: u16 = sd.sdo_read(ERROR_CODE, 0).await.expect("603Fh");
        assert_eq!(code, alarm.error_code, "603Fh = Co03");
    });
}
