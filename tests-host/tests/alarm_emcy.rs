//! Errors reported as the profile's alarms (SDV3-E, through ethercrab in process, free run): the
//! firmware's drive over-temperature is alarm AH (Table 5-1: error code 4210h, error No. 26h,
//! auxiliary code 8003h), leaving OP while enabled is alarm ESr (8801h, 39h, 801Ch); each sets
//! 603Fh and sends an emergency whose manufacturer field carries error No. and auxiliary code
//! (Table 3-15: byte 3, bytes 4–5). No emergency is queued in Init (§3.6).
//!
//! The alarms by number: the SDV3-E's active alarms 3202h and alarm records 3200h/3201h
//! (§6.3.3), its non-resettable alarms (Table 5-1 reset column), the RSE's fault history 200Bh
//! and its clear command (7.3.12).

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::{block_on, emcy, master_for};

const CYCLE_NS: u64 = 1_000_000;
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const FAULT_BIT: u16 = 0x08;
const CSP: u8 = 8;

/// The drive from INIT to OP (free run): an ethercrab group in OP.
macro_rules! into_op {
    ($m:expr, $md:expr) => {
        $md.init_single_group::<4, 64>($m.shared.clock().now_fn())
            .await
            .expect("init")
            .into_safe_op($md)
            .await
            .expect("SAFE-OP")
            .request_into_op($md)
            .await
            .expect("request OP")
    };
}

/// One cycle with controlword `cw` in CSP (default RxPDO 1600h: 6040h, 607Ah, 60FFh, 6071h,
/// 6060h at byte 12); evaluates to the statusword (TxPDO 1A00h: 6041h first).
macro_rules! cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        {
            let mut out = sd.outputs_raw_mut();
            out.fill(0);
            out[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
            out[12] = CSP;
        }
        // Phase-locked to the drive's free-run cycle: every controlword is seen.
        let since = $m.shared.clock().now();
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.finish_cycle(since, CYCLE_NS);
        let inp = sd.inputs_raw();
        u16::from_le_bytes([inp[0], inp[1]])
    }};
}

/// Shutdown, switch on, enable operation (CiA402); asserts Operation Enabled.
macro_rules! enable {
    ($m:expr, $md:expr, $group:expr) => {{
        let mut sw = 0;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            sw = cycle!($m, $md, $group, cw);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
    }};
}

/// Cycles (the SDV3-E's `cycle!`) in Operation Enabled until the statusword shows a fault;
/// asserts it does within 300 cycles.
macro_rules! until_fault {
    ($m:expr, $md:expr, $group:expr) => {{
        let mut faulted = false;
        for _ in 0..300 {
            if cycle!($m, $md, $group, ENABLE_OPERATION) & FAULT_BIT != 0 {
                faulted = true;
                break;
            }
        }
        assert!(faulted, "the drive faults");
    }};
}

/// The RSE's free-run cycle (7.2: 1C32h:02 factory setting 4 ms).
const RSE_CYCLE_NS: u64 = 4_000_000;

/// One RSE cycle with controlword `cw`, phase-locked to its free-run cycle (every controlword
/// is seen) over its default PDOs (1600h: 6040h first; 1A00h: 603Fh, 6041h); evaluates to
/// (603Fh, statusword).
macro_rules! rse_cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        sd.outputs_raw_mut()[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
        let since = $m.shared.clock().now();
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.finish_cycle(since, RSE_CYCLE_NS);
        let inp = sd.inputs_raw();
        (
            u16::from_le_bytes([inp[0], inp[1]]),
            u16::from_le_bytes([inp[2], inp[3]]),
        )
    }};
}

/// The RSE from INIT to OP (free run) and Operation Enabled; evaluates to the group.
macro_rules! rse_enabled {
    ($m:expr, $md:expr) => {{
        let group = $md
            .init_single_group::<4, 64>($m.shared.clock().now_fn())
            .await
            .expect("init")
            .into_safe_op($md)
            .await
            .expect("SAFE-OP")
            .request_into_op($md)
            .await
            .expect("OP");
        let mut sw = 0;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            sw = rse_cycle!($m, $md, group, cw).1;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        group
    }};
}

/// Waits (cycling) until SM1 holds an emergency and reads it ([`emcy::read`]).
macro_rules! emergency {
    ($m:expr, $md:expr, $group:expr, $sm1_start:expr) => {{
        let mut emergency = None;
        for _ in 0..50 {
            emergency = emcy::read($md, $sm1_start).await.expect("a CoE emergency");
            if emergency.is_some() {
                break;
            }
            $group.tx_rx($md).await.expect("tx/rx");
            $m.shared.advance(CYCLE_NS);
        }
        emergency.expect("an emergency in SM1")
    }};
}

#[test]
fn a_motor_fault_sends_the_profiles_alarm_in_603fh_and_the_emcy() {
    let p = od_gen::builtin("sdv3-e").expect("profile");
    let alarm = p
        .alarms
        .iter()
        .find(|a| a.display == "AH")
        .expect("alarm AH");
    assert_eq!(
        alarm.emcy.data,
        [0x26, 0x03, 0x80, 0, 0],
        "Table 5-1: 26h, 8003h"
    );
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(120.0);
        until_fault!(m, md, group);
        let coe = emergency!(m, md, group, p.sm.mailbox_in.start);
        assert_eq!(coe.code, alarm.emcy.code, "EMCY code");
        assert_eq!(coe.error_register & 0x01, 0x01, "1001h generic error");
        assert_eq!(
            coe.data, alarm.emcy.data,
            "manufacturer field: error No., aux code"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            alarm.error_code
        );
    });
}

/// SDV3-E §3.6: an emergency is sent only when the ESM is not in Init. An error raised in Init
/// sets 1001h but queues no emergency (there is no mailbox to carry it).
#[test]
fn no_emergency_is_queued_in_init() {
    let mut seg = Segment::new("sdv3-e", 1).expect("profile");
    let now = seg.now_ns();
    let slave = &mut seg.drives_mut()[0].slave;
    let alarm = od_gen::builtin("sdv3-e")
        .expect("profile")
        .alarms
        .into_iter()
        .find(|a| a.display == "AH")
        .expect("alarm AH");
    let handed_back = slave.report_error(alarm.emcy.code, 0, alarm.emcy.data, None, now);
    assert!(
        handed_back.is_err(),
        "no mailbox in Init: the emergency is not queued"
    );
    assert_eq!(slave.pending_emcys(), 0);
    assert_eq!(slave.error_register() & 0x01, 0x01, "1001h generic error");
}

/// SDV3-E §5.2 10): leaving OP while the drive is Operation Enabled raises its alarm ESr: the
/// drive faults with 603Fh = 8801h and the emergency carries error No. 39h, aux code 801Ch.
#[test]
fn leaving_op_while_enabled_raises_the_profiles_alarm() {
    let p = od_gen::builtin("sdv3-e").expect("profile");
    let alarm = p
        .alarms
        .iter()
        .find(|a| a.display == "ESr")
        .expect("alarm ESr");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let coe = emergency!(m, md, group, p.sm.mailbox_in.start);
        assert_eq!(coe.code, alarm.emcy.code, "EMCY code");
        assert_eq!(
            coe.data,
            [0x39, 0x1C, 0x80, 0, 0],
            "error No. 39h, aux 801Ch"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), 0x8801);
    });
}

/// SDV3-E §6.3.3: the alarms by number. Alarm AH (drive overheating, error No. 26h) shows in
/// 3202h:01 while active, and as the newest record of 3201h (3200h = 1) with the drive's state
/// at the alarm (DC link 48 V, mode of operation 8); a fault reset once it cooled clears it from
/// 3202h, the record stays.
#[test]
fn sdv3_e_active_alarms_and_alarm_records() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u8>(0x3202, 1).await.expect("3202h:01"), 0);
        assert_eq!(
            sd.sdo_read::<i32>(0x3201, 1).await.expect("3201h:01"),
            0,
            "no record yet"
        );
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(120.0);
        until_fault!(m, md, group);
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u8>(0x3202, 1).await.expect("3202h:01"),
            0x26,
            "AH active"
        );
        assert_eq!(sd.sdo_read::<u8>(0x3202, 2).await.expect("3202h:02"), 0);
        sd.sdo_write(0x3200, 0, 1u8).await.expect("3200h = 1");
        assert_eq!(sd.sdo_read::<i32>(0x3201, 1).await.expect("3201h:01"), 0x26);
        let volts = sd.sdo_read::<i32>(0x3201, 11).await.expect("3201h:11");
        assert!((volts - 48).abs() <= 1, "DC link {volts} V");
        assert_eq!(
            sd.sdo_read::<i32>(0x3201, 14).await.expect("3201h:14"),
            i32::from(CSP)
        );
        // The second record does not exist yet.
        sd.sdo_write(0x3200, 0, 2u8).await.expect("3200h = 2");
        assert_eq!(sd.sdo_read::<i32>(0x3201, 1).await.expect("3201h:01"), 0);

        // Cooled down: a fault reset clears AH (resettable) from 3202h; the record stays.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(40.0);
        for cw in [0x80u16, 0x00, 0x80] {
            let _ = cycle!(m, md, group, cw);
        }
        let sw = cycle!(m, md, group, 0x00);
        assert_eq!(sw & FAULT_BIT, 0, "reset");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u8>(0x3202, 1).await.expect("3202h:01"), 0);
        sd.sdo_write(0x3200, 0, 1u8).await.expect("3200h = 1");
        assert_eq!(sd.sdo_read::<i32>(0x3201, 1).await.expect("3201h:01"), 0x26);
    });
}

/// SDV3-E Table 5-1: encoder error ET1 cannot be reset ("No" in the reset column): after the
/// encoder fault the drive stays in Fault with 603Fh = 7305h through fault resets.
#[test]
fn sdv3_e_a_non_resettable_alarm_holds_through_fault_resets() {
    use board_sim::plant::EncoderFaultInjection;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        // A position jump: encoder error ET1 (Table 5-1: reset "No").
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_encoder_fault(Some(EncoderFaultInjection::Jump { counts: 1 << 19 }));
        until_fault!(m, md, group);
        let sd = group.subdevice(md, 0).expect("drive");
        let code = sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh");
        let number = sd.sdo_read::<u8>(0x3202, 1).await.expect("3202h:01");
        let p = od_gen::builtin("sdv3-e").expect("profile");
        let alarm = p
            .alarms
            .iter()
            .find(|a| a.error_code == code && a.emcy.data[0] == number)
            .expect("the alarm 603Fh and 3202h name");
        assert_eq!(alarm.display, "ET1");
        assert!(!alarm.resettable);
        for _ in 0..20 {
            let _ = cycle!(m, md, group, 0x00);
        }
        for cw in [0x80u16, 0x00, 0x80, 0x00] {
            let _ = cycle!(m, md, group, cw);
        }
        let sw = cycle!(m, md, group, 0x00);
        assert_ne!(sw & FAULT_BIT, 0, "ET1 holds through fault resets");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), code);
        assert_eq!(
            sd.sdo_read::<u8>(0x3202, 1).await.expect("3202h:01"),
            number,
            "still active"
        );
    });
}

/// RSE 7.3.12: the fault history 200Bh:01-0A holds the AL numbers, newest at 01; 200Bh:0B = 1
/// clears it and reads 0 again.
#[test]
fn rse_fault_history_and_its_clear_command() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("rse", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = rse_enabled!(m, md);
        let mut sw = 0;
        let hot = |c: f64| {
            m.shared.segment().drives_mut()[0].servos[0]
                .plant
                .set_drive_temperature(c)
        };
        // Two faults (drive over-temperature, AL.248), reset in between.
        for round in 0..2 {
            hot(120.0);
            let mut faulted = false;
            for _ in 0..300 {
                if rse_cycle!(m, md, group, ENABLE_OPERATION).1 & FAULT_BIT != 0 {
                    faulted = true;
                    break;
                }
            }
            assert!(faulted, "round {round}");
            // Fault Reaction Active until the reaction has ended, then Fault.
            for _ in 0..100 {
                sw = rse_cycle!(m, md, group, 0x00).1;
                if sw & 0x4F == FAULT_BIT {
                    break;
                }
            }
            assert_eq!(sw & 0x4F, FAULT_BIT, "Fault");

            hot(40.0);
            for cw in [0x00u16, 0x80, 0x00] {
                sw = rse_cycle!(m, md, group, cw).1;
            }
            for cw in [SHUTDOWN; 5]
                .into_iter()
                .chain([SWITCH_ON; 5])
                .chain([ENABLE_OPERATION; 30])
            {
                sw = rse_cycle!(m, md, group, cw).1;
            }
            assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "round {round}");
        }
        let sd = group.subdevice(md, 0).expect("drive");
        let record = |sub: u8| sd.sdo_read::<u16>(0x200B, sub);
        assert_eq!(
            record(1).await.expect("200Bh:01"),
            248,
            "AL.248, the newest"
        );
        assert_eq!(record(2).await.expect("200Bh:02"), 248);
        assert_eq!(record(3).await.expect("200Bh:03"), 0);
        sd.sdo_write(0x200B, 0x0B, 1u16).await.expect("clear");
        assert_eq!(record(0x0B).await.expect("200Bh:0B"), 0, "reads 0 again");
        for sub in 1..=10 {
            assert_eq!(
                record(sub).await.expect("record"),
                0,
                "200Bh:{sub:02X} cleared"
            );
        }
    });
}

/// RSE 9 / 6.2.2: AL.480 "positive limit valid" is a warning: while the positive limit switch is
/// actuated, statusword bit 7 is set and 603Fh shows its code (8612h) with an EMCY, the drive
/// stays in Operation Enabled; released, bit 7 and 603Fh clear.
#[test]
fn rse_a_limit_switch_is_a_warning_not_a_fault() {
    use board_sim::plant::SwitchParams;
    const WARNING: u16 = 1 << 7;
    let p = od_gen::builtin("rse").expect("profile");
    let alarm = p
        .alarms
        .iter()
        .find(|a| a.display == "AL.480")
        .expect("AL.480");
    assert!(alarm.warning);
    block_on(async {
        let (m, transport) = master_for(Segment::new("rse", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = rse_enabled!(m, md);
        let (code, sw) = rse_cycle!(m, md, group, ENABLE_OPERATION);
        assert_eq!((code, sw & WARNING), (0, 0), "no warning yet");
        // The positive limit switch actuated where the motor stands.
        let switches = |limit: Option<f64>| {
            m.shared.segment().drives_mut()[0].servos[0]
                .plant
                .set_switches(SwitchParams {
                    limit_pos_rad: limit,
                    ..SwitchParams::default()
                })
        };
        switches(Some(-0.1));
        let mut s = (0, 0);
        for _ in 0..5 {
            s = rse_cycle!(m, md, group, ENABLE_OPERATION);
        }
        assert_ne!(s.1 & WARNING, 0, "bit 7: {:#06x}", s.1);
        assert_eq!(s.0, alarm.error_code, "603Fh = AL.480's code");
        assert_eq!(s.1 & STATE_MASK, OPERATION_ENABLED, "still enabled");
        let coe = emergency!(m, md, group, p.sm.mailbox_in.start);
        assert_eq!(coe.code, alarm.emcy.code, "EMCY");
        switches(None);
        for _ in 0..5 {
            s = rse_cycle!(m, md, group, ENABLE_OPERATION);
        }
        assert_eq!((s.0, s.1 & WARNING), (0, 0), "cleared: {:#06x}", s.1);
        assert_eq!(s.1 & STATE_MASK, OPERATION_ENABLED);
    });
}

/// The SDV3-E's power stage overheats while `cycle` (one cycle of the scenario's command, its
/// statusword) runs: the alarm AH within 300 cycles. Then the newest alarm record (3200h = 1)
/// is AH's (3201h:01 = 26h).
async fn overheat_to_the_ah_record<F, S>(
    m: &InProcess,
    sd: &ethercrab::SubDeviceRef<'_, S>,
    mut cycle: impl FnMut() -> F,
) where
    F: std::future::Future<Output = u16>,
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    m.shared.segment().drives_mut()[0].servos[0]
        .plant
        .set_drive_temperature(120.0);
    let mut faulted = false;
    for _ in 0..300 {
        if cycle().await & FAULT_BIT != 0 {
            faulted = true;
            break;
        }
    }
    assert!(faulted, "AH");
    sd.sdo_write(0x3200, 0, 1u8).await.expect("3200h = 1");
    assert_eq!(sd.sdo_read::<i32>(0x3201, 1).await.expect("3201h:01"), 0x26);
}

/// SDV3-E §6.3.3 alarm record fields 05–07 (feedback speed, the speed 5 ms before, command
/// speed, rpm): the motor runs at 300 rpm in CSV (60FFh in 0.1 rpm over the default PDOs) when
/// the power stage overheats (AH); the newest record holds 300 rpm in all three.
#[test]
fn sdv3_e_an_alarm_record_holds_the_speed_at_the_alarm() {
    use tests_host::vendor;
    const CSV: u8 = 9;
    const RPM: f64 = 300.0;
    // SDV3-E 1600h: 6040h at byte 0, 60FFh (0.1 rpm) at 6, 6060h at 12; 1A00h: 6041h first.
    let out = |cw: u16, rpm: f64| {
        [
            (0usize, cw.to_le_bytes().to_vec()),
            (6, ((rpm * 10.0) as i32).to_le_bytes().to_vec()),
            (12, vec![CSV]),
        ]
    };
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op(&m, md, &[]).await;
        let cycle = |cw: u16, rpm: f64| {
            let (m, group) = (&m, &group);
            let o = out(cw, rpm);
            async move {
                let refs: Vec<(usize, &[u8])> = o.iter().map(|(at, b)| (*at, &b[..])).collect();
                let inputs = vendor::exchange(m, md, group, &refs, CYCLE_NS).await;
                vendor::u16_at(&inputs, 0)
            }
        };
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            sw = cycle(cw, 0.0).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        // A 300 ms ramp to 300 rpm, then 200 ms there.
        for k in 0..500 {
            cycle(ENABLE_OPERATION, RPM * f64::from(k.min(300)) / 300.0).await;
        }
        let (rpm, _) = vendor::motor(&m);
        assert!((rpm - RPM).abs() < 5.0, "{rpm:.1} rpm");
        let sd = group.subdevice(md, 0).expect("drive");
        overheat_to_the_ah_record(&m, &sd, || cycle(ENABLE_OPERATION, RPM)).await;
        for (sub, what) in [
            (5, "feedback speed"),
            (6, "feedback speed 5 ms before"),
            (7, "command speed"),
        ] {
            let rpm = sd.sdo_read::<i32>(0x3201, sub).await.expect("3201h");
            assert!(
                (f64::from(rpm) - RPM).abs() <= 5.0,
                "3201h:{sub:02} {what}: {rpm} rpm"
            );
        }
    });
}

/// SDV3-E §6.3.3 alarm record field 13 (command position, in the position unit): the motor
/// holds a CSP target (607Ah over the default PDOs) when the power stage overheats (AH); the
/// newest record holds the target, the position demand 6062h of the cycle that raised the
/// alarm.
#[test]
fn sdv3_e_an_alarm_record_holds_the_command_position_at_the_alarm() {
    use tests_host::vendor;
    // SDV3-E 1600h: 6040h at byte 0, 607Ah at 2, 6060h at 12.
    const TARGET: i32 = 200_000;
    const STEP: i32 = 500;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op(&m, md, &[]).await;
        let cycle = |cw: u16, target: i32| {
            let (m, group) = (&m, &group);
            async move {
                let (cw, target) = (cw.to_le_bytes(), target.to_le_bytes());
                let outputs: [(usize, &[u8]); 3] = [(0, &cw), (2, &target), (12, &[CSP])];
                let inputs = vendor::exchange(m, md, group, &outputs, CYCLE_NS).await;
                vendor::u16_at(&inputs, 0)
            }
        };
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            sw = cycle(cw, 0).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        let mut target = 0;
        while target < TARGET {
            target += STEP;
            cycle(ENABLE_OPERATION, target).await;
        }
        for _ in 0..200 {
            sw = cycle(ENABLE_OPERATION, TARGET).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        let sd = group.subdevice(md, 0).expect("drive");
        overheat_to_the_ah_record(&m, &sd, || cycle(ENABLE_OPERATION, TARGET)).await;
        let position = sd.sdo_read::<i32>(0x3201, 13).await.expect("3201h:0D");
        assert_eq!(position, TARGET, "3201h:0D command position");
    });
}
