//! ESM reactions the drive takes by itself, under a real master (ethercrab, in process):
//! SM watchdog expiry in OP (0x001B), loss of SYNC0 (0x001A), SM reconfiguration in SAFEOP
//! (0x001D), and a SAFEOP → OP request that waits for outputs / the first SYNC0.

use std::time::Duration;

use board_sim::inproc::InProcess;
use ethercrab::subdevice_group::{DcConfiguration, HasDc, Op};
use ethercrab::{Command, DcSync, DefaultLock, MainDevice, SubDeviceGroup};
use tests_host::{block_on, master};

const STATION: u16 = 0x1000;
const AL_CONTROL: u16 = 0x0120;
const AL_STATUS: u16 = 0x0130;
const AL_STATUS_CODE: u16 = 0x0134;
const SM2_ACTIVATE: u16 = 0x0816;
const DC_ACTIVATION: u16 = 0x0981;
const CYCLE_NS: u64 = 1_000_000;
/// AL status values (ETG.1000.6 Table 9): state | 0x10 error indication.
const SAFEOP: u16 = 0x04;
const OP: u16 = 0x08;
const ERROR: u16 = 0x10;

type DcGroup = SubDeviceGroup<4, 64, DefaultLock, Op, HasDc>;

async fn al(md: &MainDevice<'_>) -> (u16, u16) {
    let status: u16 = Command::fprd(STATION, AL_STATUS)
        .receive(md)
        .await
        .expect("AL status");
    let code: u16 = Command::fprd(STATION, AL_STATUS_CODE)
        .receive(md)
        .await
        .expect("AL status code");
    (status, code)
}

/// INIT → OP with DC SYNC0 at 1 ms, cycling until OP.
/// `n` DC cycles of the master: process data exchanged, simulated time advanced one cycle.
async fn dc_cycles(m: &InProcess, group: &DcGroup, n: usize) {
    for _ in 0..n {
        group.tx_rx_dc(&m.maindevice).await.expect("tx/rx");
        m.shared.advance(CYCLE_NS);
    }
}

async fn into_op_with_dc(m: &InProcess) -> DcGroup {
    let md = &*m.maindevice;
    let mut group = md
        .init_single_group::<4, 64>(m.shared.clock().now_fn())
        .await
        .expect("init");
    for mut sd in group.iter_mut(md) {
        sd.set_dc_sync(DcSync::Sync0);
    }
    let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
    let group = group
        .configure_dc_sync(
            md,
            DcConfiguration {
                start_delay: Duration::from_millis(5),
                sync0_period: Duration::from_nanos(CYCLE_NS),
                sync0_shift: Duration::ZERO,
            },
        )
        .await
        .expect("DC");
    let group = group.into_safe_op(md).await.expect("SAFE-OP");
    let group = group.request_into_op(md).await.expect("request OP");
    for _ in 0..100 {
        let r = group.tx_rx_dc(md).await.expect("tx/rx");
        m.shared.advance(CYCLE_NS);
        if r.all_op() {
            return group;
        }
    }
    panic!("no OP after 100 cycles: {:?}", al(md).await);
}

#[test]
fn sm_watchdog_expiry_in_op_drops_to_safeop_with_0x1b() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        assert_eq!(al(md).await, (OP, 0));
        // The master stops writing outputs. The ESC's default process-data watchdog is
        // 1000 × 100 µs = 100 ms (ET1100 0x0400/0x0420 reset values).
        m.shared.advance(90 * CYCLE_NS);
        assert_eq!(al(md).await, (OP, 0), "not yet expired after 90 ms");
        m.shared.advance(20 * CYCLE_NS);
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x001B),
            "SAFEOP + error, SM watchdog"
        );
    });
}

#[test]
fn sync_unit_switched_off_in_op_is_a_fatal_sync_error_0x2c() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        let sd = group.iter(md).next().expect("drive");
        assert_eq!(
            sd.sdo_read::<u8>(0x1C32, 0x20).await.expect("1C32:20"),
            0,
            "no sync error yet"
        );
        // The master deactivates the cyclic unit (0x0981) while it keeps cycling: SYNC0 is gone
        // for good. One missed SYNC0 adds 3 to the counter; the limit 10F1:02 is 4.
        Command::fpwr(STATION, DC_ACTIVATION)
            .send(md, 0u8)
            .await
            .expect("0x0981 = 0");
        m.shared.advance(CYCLE_NS / 2);
        let mut tripped_after = None;
        for k in 1..=10 {
            group.tx_rx_dc(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
            if al(md).await.0 & ERROR != 0 {
                tripped_after = Some(k);
                break;
            }
        }
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x002C),
            "SAFEOP + error, fatal sync error"
        );
        assert!(
            matches!(tripped_after, Some(1..=3)),
            "tripped after {tripped_after:?} cycles"
        );
        assert_eq!(
            sd.sdo_read::<u8>(0x1C32, 0x20).await.expect("1C32:20"),
            1,
            "sync error flag"
        );
        assert!(
            sd.sdo_read::<u16>(0x1C32, 0x0B).await.expect("1C32:0B") >= 2,
            "missed events"
        );
        // Acknowledged, the drive goes back to PRE-OP.
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, 0x0012u16)
            .await
            .expect("PREOP + ack");
        assert_eq!(al(md).await, (0x0002, 0));
    });
}

#[test]
fn missed_sync0_pulses_give_sync_error_0x1a() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        // SYNC0 keeps running but only every second cycle: every other pulse is missed
        // (+3 per miss, -1 per pulse: 3, 2, 5 > 4 trips within a few cycles).
        const SYNC0_CYCLE: u16 = 0x09A0;
        Command::fpwr(STATION, SYNC0_CYCLE)
            .send(md, 2 * CYCLE_NS as u32)
            .await
            .expect("0x09A0");
        dc_cycles(&m, &group, 10).await;
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x001A),
            "SAFEOP + error, synchronization error"
        );
    });
}

#[test]
fn disabling_sm2_in_safeop_gives_0x1d_with_safeop_and_error() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let _group = group.into_safe_op(md).await.expect("SAFE-OP");
        assert_eq!(al(md).await, (SAFEOP, 0));
        Command::fpwr(STATION, SM2_ACTIVATE)
            .send(md, 0u8)
            .await
            .expect("disable SM2");
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x001D),
            "ETG.1000.6 Table 11: 0x001D in SAFEOP/OP → SAFEOP + error"
        );
    });
}

#[test]
fn op_request_waits_for_outputs_and_completes_when_they_arrive() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let group = group.into_safe_op(md).await.expect("SAFE-OP (free run)");
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, OP)
            .await
            .expect("request OP");
        for _ in 0..50 {
            m.shared.advance(CYCLE_NS);
        }
        assert_eq!(
            al(md).await,
            (SAFEOP, 0),
            "waits in SAFEOP without error until outputs arrive"
        );
        group.tx_rx(md).await.expect("first process data");
        m.shared.advance(CYCLE_NS);
        group.tx_rx(md).await.expect("process data");
        assert_eq!(al(md).await, (OP, 0), "OP once the master wrote outputs");
    });
}

#[test]
fn op_request_without_outputs_is_refused_with_0x19_after_the_timeout() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let _group = group.into_safe_op(md).await.expect("SAFE-OP (free run)");
        Command::fpwr(STATION, AL_CONTROL)
            .send(md, OP)
            .await
            .expect("request OP");
        // The ESI default SafeopOpTimeout is 9 s.
        m.shared.advance(8_000 * CYCLE_NS);
        assert_eq!(al(md).await, (SAFEOP, 0));
        m.shared.advance(2_000 * CYCLE_NS);
        assert_eq!(al(md).await, (SAFEOP | ERROR, 0x0019), "no valid outputs");
    });
}

#[test]
fn sm_parameters_report_measured_calc_and_copy_time() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        let sd = group.iter(md).next().expect("drive");
        let out_calc: u32 = sd.sdo_read(0x1C32, 0x06).await.expect("1C32:06");
        let in_calc: u32 = sd.sdo_read(0x1C33, 0x06).await.expect("1C33:06");
        let delay: u32 = sd.sdo_read(0x1C32, 0x09).await.expect("1C32:09");
        // Measured from the cycle (the simulated board reports the SPI bus time of its PDI
        // accesses: one SM2 read and one SM3 write of 7 bytes each), not a profile constant.
        assert!(
            out_calc > 1_000 && out_calc < 50_000,
            "1C32:06 = {out_calc} ns"
        );
        assert_eq!(in_calc, out_calc);
        assert_eq!(delay, out_calc);
        assert_eq!(
            sd.sdo_read::<u32>(0x1C32, 0x03).await.expect("1C32:03"),
            out_calc,
            "shift"
        );
        assert_eq!(
            sd.sdo_read::<u16>(0x1C32, 0x0C).await.expect("1C32:0C"),
            0,
            "cycle fits"
        );
        assert_eq!(
            sd.sdo_read::<u32>(0x1C32, 0x05).await.expect("1C32:05"),
            31_250,
            "min cycle"
        );
    });
}

#[test]
fn a_phase_lock_the_board_lost_is_a_pll_error_0x32_in_op_only() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        // Before SAFEOP no lock is expected: a report is ignored.
        m.shared.segment().drives_mut()[0]
            .slave
            .report_phase_lock_lost();
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        assert_eq!(al(md).await, (OP, 0));
        // In OP the board's PWM cannot follow SYNC0 any more (its period trim is exhausted).
        m.shared.segment().drives_mut()[0]
            .slave
            .report_phase_lock_lost();
        dc_cycles(&m, &group, 3).await;
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x0032),
            "SAFEOP + error, PLL error"
        );
    });
}

#[test]
fn sync0_served_late_within_the_pll_tolerance_keeps_op_beyond_it_is_a_pll_error_0x32() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        assert_eq!(al(md).await, (OP, 0));
        let set_latency = |max_ns: u64| {
            for d in m.shared.segment().drives_mut() {
                d.sync0_latency_max_ns = max_ns;
            }
        };
        // Interrupt latency of up to 8 % of the cycle: intervals between served SYNC0s vary by
        // as much, which the control loop's PLL follows.
        set_latency(CYCLE_NS * 8 / 100);
        dc_cycles(&m, &group, 2_000).await;
        assert_eq!(al(md).await, (OP, 0), "locked through the latency");
        // Up to half a cycle: intervals off the period by more than the PLL follows, three in a
        // row within a few cycles.
        set_latency(CYCLE_NS / 2);
        dc_cycles(&m, &group, 200).await;
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x0032),
            "SAFEOP + error, PLL error"
        );
    });
}

#[test]
fn sync0_at_another_period_than_configured_is_a_pll_error_0x32() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = into_op_with_dc(&m).await;
        dc_cycles(&m, &group, 10).await;
        assert_eq!(al(md).await, (OP, 0));
        // SYNC0 now comes every 1.4 ms while the drive was configured for 1 ms: its control
        // loop cannot phase-lock (3 intervals off the period in a row).
        const SYNC0_CYCLE: u16 = 0x09A0;
        Command::fpwr(STATION, SYNC0_CYCLE)
            .send(md, 1_400_000u32)
            .await
            .expect("0x09A0");
        dc_cycles(&m, &group, 10).await;
        assert_eq!(
            al(md).await,
            (SAFEOP | ERROR, 0x0032),
            "SAFEOP + error, PLL error"
        );
    });
}
