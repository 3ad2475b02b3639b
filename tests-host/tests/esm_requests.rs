//! AL control requests from a real master (ethercrab, in process) that the ESM must refuse or
//! answer specially, each with the AL status code of ETG.1000.6 Table 11, and the
//! SM-synchronous cycle (1C32h:01 = 1) as an alternative to DC and free run.

use std::time::Duration;

use board_sim::inproc::InProcess;
use ethercrab::{Command, DcSync, MainDevice};
use hal::esc::regs;
use hal::pdi::EscPdi;
use tests_host::{block_on, master};

const STATION: u16 = 0x1000;
/// AL status / control values (ETG.1000.6 Table 9).
const INIT: u16 = 0x01;
const PREOP: u16 = 0x02;
const BOOT: u16 = 0x03;
const SAFEOP: u16 = 0x04;
const OP: u16 = 0x08;
const ERROR: u16 = 0x10;
const ACK: u16 = 0x10;
const ID_REQUEST: u16 = 0x20;
const ID_LOADED: u16 = 0x20;

async fn request(md: &MainDevice<'_>, control: u16) -> (u16, u16) {
    Command::fpwr(STATION, regs::AL_CONTROL.addr)
        .send(md, control)
        .await
        .expect("AL control");
    let status: u16 = Command::fprd(STATION, regs::AL_STATUS.addr)
        .receive(md)
        .await
        .expect("AL status");
    let code: u16 = Command::fprd(STATION, regs::AL_STATUS_CODE.addr)
        .receive(md)
        .await
        .expect("code");
    (status, code)
}

#[test]
fn invalid_and_unknown_state_requests_are_refused_with_their_codes() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let _group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        assert_eq!(request(md, INIT).await, (INIT, 0));
        // Skipping states upward (ETG.1000.6 Figure 21 has no INIT → SAFEOP/OP, PREOP → OP).
        assert_eq!(request(md, SAFEOP).await, (INIT | ERROR, 0x0011));
        assert_eq!(
            request(md, PREOP).await,
            (INIT | ERROR, 0x0011),
            "held until acknowledged"
        );
        assert_eq!(request(md, INIT | ACK).await, (INIT, 0));
        assert_eq!(request(md, OP).await, (INIT | ERROR, 0x0011));
        assert_eq!(request(md, PREOP | ACK).await, (PREOP, 0));
        assert_eq!(request(md, OP).await, (PREOP | ERROR, 0x0011));
        // A state code that names no state.
        assert_eq!(request(md, 0x0005 | ACK).await, (PREOP | ERROR, 0x0012));
        // BOOT from PRE-OP is not a transition; from INIT it needs a bootstrap mailbox, which
        // the standard profile does not declare.
        assert_eq!(request(md, BOOT | ACK).await, (PREOP | ERROR, 0x0011));
        assert_eq!(request(md, INIT | ACK).await, (INIT, 0));
        assert_eq!(request(md, BOOT).await, (INIT | ERROR, 0x0013));
        assert_eq!(request(md, INIT | ACK).await, (INIT, 0));
    });
}

#[test]
fn id_request_loads_the_station_alias_into_the_status_code() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let _group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        // The alias register is written from the PDI side (as a drive's rotary switch would).
        m.shared.segment().drives_mut()[0]
            .esc
            .write_u16(regs::STATION_ALIAS.addr, 0x0A55)
            .expect("alias");
        // ETG.1000.6 §6.4.1.2: AL control bit 5 → AL status bit 5 and the id in 0x0134.
        assert_eq!(
            request(md, PREOP | ID_REQUEST).await,
            (PREOP | ID_LOADED, 0x0A55)
        );
        assert_eq!(
            request(md, PREOP).await,
            (PREOP, 0),
            "a request without bit 5 clears it"
        );
    });
}

#[test]
fn wrong_mailbox_configuration_is_refused_with_0x16() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let _group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        assert_eq!(request(md, INIT).await, (INIT, 0));
        let sm0 = regs::sm(0).addr;
        Command::fpwr(STATION, sm0 + regs::sm_offset::ACTIVATE)
            .send(md, 0u8)
            .await
            .expect("disable");
        Command::fpwr(STATION, sm0 + regs::sm_offset::LENGTH)
            .send(md, 128u16)
            .await
            .expect("length");
        Command::fpwr(STATION, sm0 + regs::sm_offset::ACTIVATE)
            .send(md, 1u8)
            .await
            .expect("enable");
        assert_eq!(
            request(md, PREOP).await,
            (INIT | ERROR, 0x0016),
            "SM0 length ≠ SII mailbox size"
        );
    });
}

#[test]
fn sync1_is_refused_with_0x30_by_a_profile_without_it() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let mut group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        for mut sd in group.iter_mut(md) {
            sd.set_dc_sync(DcSync::Sync01 {
                sync1_period: Duration::from_micros(500),
            });
        }
        let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
        let group = group
            .configure_dc_sync(
                md,
                ethercrab::subdevice_group::DcConfiguration {
                    start_delay: Duration::from_millis(5),
                    sync0_period: Duration::from_millis(1),
                    sync0_shift: Duration::ZERO,
                },
            )
            .await
            .expect("DC");
        assert!(group.into_safe_op(md).await.is_err(), "SAFE-OP refused");
        let status: u16 = Command::fprd(STATION, regs::AL_STATUS.addr)
            .receive(md)
            .await
            .expect("status");
        let code: u16 = Command::fprd(STATION, regs::AL_STATUS_CODE.addr)
            .receive(md)
            .await
            .expect("code");
        assert_eq!(
            (status, code),
            (PREOP | ERROR, 0x0030),
            "invalid DC SYNC configuration"
        );
    });
}

#[test]
fn sm_synchronous_cycle_runs_on_every_sm2_event() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let sd = group.subdevice(md, 0).expect("drive");
        // ETG.1020: 1C32h:01 = 1 "synchronous with SM2 event".
        sd.sdo_write(0x1C32, 1, 1u16).await.expect("1C32:01");
        let group = group.into_safe_op(md).await.expect("SAFE-OP");
        let group = group.request_into_op(md).await.expect("request OP");
        for _ in 0..10 {
            if group.tx_rx(md).await.expect("tx/rx").all_op() {
                break;
            }
        }
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x1C32, 1).await.expect("1C32:01"), 1);
        let cycles_before = m.shared.segment().drives()[0].slave.cycles();
        // No simulated time passes: only the master's frames (SM2 events) drive the cycle.
        let mut statuswords = Vec::new();
        for i in 0..40u16 {
            let cw: u16 = match i {
                0..=9 => 0x06,
                10..=19 => 0x07,
                _ => 0x0F,
            };
            {
                let mut out = sd.outputs_raw_mut();
                out[0..2].copy_from_slice(&cw.to_le_bytes());
            }
            group.tx_rx(md).await.expect("tx/rx");
            let inp = sd.inputs_raw();
            statuswords.push(u16::from_le_bytes([inp[0], inp[1]]) & 0x6F);
        }
        let cycles = m.shared.segment().drives()[0].slave.cycles() - cycles_before;
        assert_eq!(cycles, 40, "one cycle per SM2 event");
        // Frame 10 carries "switch on" (0x07) for the first time; its own inputs still show
        // the cycle frame 9 triggered (ready to switch on, 0x21), frame 11's inputs the cycle
        // frame 10 triggered (switched on, 0x23): CiA402 Table 3 statusword patterns.
        assert_eq!(
            (statuswords[10], statuswords[11]),
            (0x21, 0x23),
            "inputs of a frame show the cycle the previous frame triggered"
        );
    });
}

/// Samples drive 0's LEDs every 10 ms for `ms` of simulated time: (RUN lit samples, ERR lit
/// samples, RUN toggles, ERR toggles).
fn sample_leds(m: &InProcess, ms: u64) -> (u64, u64, u64, u64) {
    const STEP_NS: u64 = 10_000_000;
    let start = m.shared.segment().drives()[0].leds;
    let (mut run, mut err) = (0, 0);
    for _ in 0..ms / 10 {
        m.shared.advance(STEP_NS);
        let leds = m.shared.segment().drives()[0].leds;
        run += u64::from(leds.run.on);
        err += u64::from(leds.err.on);
    }
    let end = m.shared.segment().drives()[0].leds;
    (
        run,
        err,
        end.run.toggles - start.run.toggles,
        end.err.toggles - start.err.toggles,
    )
}

#[test]
fn run_and_err_leds_show_the_etg1300_patterns() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let _group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        // PRE-OP: RUN blinking (200 ms on, 200 ms off), ERR off.
        let (run, err, run_toggles, _) = sample_leds(&m, 1200);
        assert_eq!((run, err), (60, 0), "RUN lit half of 1.2 s, ERR off");
        assert!(
            (5..=7).contains(&run_toggles),
            "{run_toggles} RUN toggles in 1.2 s"
        );
        // A refused request (INIT → SAFEOP): ERR blinking "invalid configuration".
        assert_eq!(request(md, INIT).await, (INIT, 0));
        assert_eq!(request(md, SAFEOP).await, (INIT | ERROR, 0x0011));
        let (run, err, _, err_toggles) = sample_leds(&m, 1200);
        assert_eq!(run, 0, "RUN off in INIT");
        assert_eq!(err, 60, "ERR blinking");
        assert!((5..=7).contains(&err_toggles));
        // Acknowledged: ERR off again.
        assert_eq!(request(md, INIT | ACK).await, (INIT, 0));
        let (_, err, _, _) = sample_leds(&m, 400);
        assert_eq!(err, 0);
    });
}
