//! A profile's user units between the bus and the motor (`[units]` in the profile file): the
//! GHA-E converts positions with its electronic gear ratio 6091h (increments = instruction units
//! × 6091h:01 / 6091h:02) and velocities in instruction units/s; with the polarity 607Eh = 224
//! the same objects turn the motor the other way. Commanded by ethercrab over
//! PDOs with DC SYNC0 (the GHA-E runs in DC mode only), the simulated motor turns by the
//! converted amount and 6064h reads back in user units. The Σ-V-SD's user units 2301h–2304h
//! take effect on 2300h, within their ranges (else A.A20), the torque unit 2304h on every
//! torque object.

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, Sdo};
use tests_host::{block_on, master_for};

const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the simulated servo's encoder.
const CPR: u32 = 1 << 20;
/// 6091h: one instruction unit = 0.1° (3600 per revolution).
const UNITS_PER_REV: u32 = 3600;
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
/// 6060h modes: cyclic synchronous position / velocity.
const CSP: u8 = 8;
const CSV: u8 = 9;
/// The Σ-V-SD's 6060h for cyclic synchronous position, statusword bit 3 "fault".
const SIGMA_CSP: i8 = 8;
const FAULT: u16 = 0x08;
/// The Σ-V-SD's 1010h:03 "save" (23xxh and 6xxxh, §4.2 (5)) with its signature.
const STORE_23XX_6XXX: (u16, u8, u32) = (0x1010, 3, 0x6576_6173);

/// The Σ-V-SD's alarm A.A20 "user unit setting error" (§4.5 (3)-(6)).
fn a_a20(profile: &od_gen::Profile) -> &od_gen::model::Alarm {
    profile
        .alarms
        .iter()
        .find(|a| a.display == "A.A20")
        .expect("alarm A.A20")
}

#[test]
fn gear_ratio_scales_positions_and_velocities_between_bus_and_motor() {
    gha_e_csp_and_csv(0, 0);
}

/// GHA-E §5.7.3 2): 607Eh = 224 makes CW the positive direction: the same objects turn the
/// motor the other way (position, velocity and torque objects × −1), and the actual values read
/// back in the master's direction.
#[test]
fn gha_e_polarity_224_turns_the_motor_the_other_way() {
    gha_e_csp_and_csv(224, 0);
}

/// GHA-E §5.7.3: 6064h = 6063h / (6091h:01 / 6091h:02) + 607Ch, and §5.4.3: 6064h = 607Ch at
/// the home: the home offset is added to every position object, before homing too, and a new
/// 607Ch shifts 6064h at once. Absolute CSP targets are in the same frame: target 607Ch + 900
/// units turns the motor 90° from where 6064h read 607Ch. With the polarity 224 as well, the
/// offset is added after the direction flip (the motor turns the other way, 6064h still reads
/// 607Ch + 900).
#[test]
fn gha_e_home_offset_is_added_to_every_position() {
    gha_e_csp_and_csv(0, 5000);
    gha_e_csp_and_csv(224, -7000);
}

/// A GHA-E with 6091h = 0.1° per unit, polarity 607Eh = `polarity` (0 or 224) and home offset
/// 607Ch = `home_offset`: a CSP move of 900 units from 607Ch and a CSV run at 1800 units/s; the
/// motor turns by the converted amount, against its own positive direction with 224, and
/// 6064h/606Ch read the objects' values.
fn gha_e_csp_and_csv(polarity: u8, home_offset: i32) {
    let sign = if polarity == 0 { 1.0 } else { -1.0 };
    block_on(async {
        let (m, transport) = master_for(Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // RxPDO: controlword, target position, mode; TxPDO: statusword, position actual.
        let mut setup = vec![
            Sdo::U32(0x6091, 1, CPR),
            Sdo::U32(0x6091, 2, UNITS_PER_REV),
            Sdo::U8(0x607E, 0, polarity),
            Sdo::I32(0x607C, 0, home_offset / 2),
        ];
        setup.extend(vendor::remap(
            0x1600,
            0x1C12,
            &[(0x6040, 0, 16), (0x607A, 0, 32), (0x6060, 0, 8)],
        ));
        setup.extend(vendor::remap(
            0x1A00,
            0x1C13,
            &[(0x6041, 0, 16), (0x6064, 0, 32)],
        ));
        let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let cycle = |cw: u16, target: i32, mode: u8| {
            {
                let mut out = sd.outputs_raw_mut();
                out[0..2].copy_from_slice(&cw.to_le_bytes());
                out[2..6].copy_from_slice(&target.to_le_bytes());
                out[6] = mode;
            }
            let fut = group.tx_rx_dc(md);
            async {
                fut.await.expect("tx/rx");
                m.shared.advance(CYCLE_NS);
                let inp = sd.inputs_raw();
                (
                    u16::from_le_bytes([inp[0], inp[1]]),
                    i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
                )
            }
        };
        // The motor at its power-on position: 6064h reads 607Ch, and a new 607Ch at once.
        let mut actual = 0;
        // Past the SYNC0 start delay (10 ms).
        for _ in 0..20 {
            cycle(SHUTDOWN, home_offset / 2, CSP).await;
        }
        for offset in [home_offset / 2, home_offset] {
            sd.sdo_write(0x607C, 0, offset).await.expect("607Ch");
            // Inputs of a cycle show the previous SYNC0's values.
            for _ in 0..2 {
                (_, actual) = cycle(SHUTDOWN, offset, CSP).await;
            }
            assert!(
                (actual - offset).abs() <= 1,
                "6064h {actual} units at the start, 607Ch = {offset}"
            );
        }
        let mut sw = 0;
        for cw in [SHUTDOWN; 20]
            .into_iter()
            .chain([SWITCH_ON; 10])
            .chain([ENABLE_OPERATION; 40])
        {
            (sw, _) = cycle(cw, home_offset, CSP).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);

        // CSP: 900 units (90°) from 607Ch in 300 ms, then hold.
        let quarter_units = (UNITS_PER_REV / 4) as i32;
        for k in 0..=300 {
            (_, actual) = cycle(ENABLE_OPERATION, home_offset + quarter_units * k / 300, CSP).await;
        }
        for _ in 0..100 {
            (_, actual) = cycle(ENABLE_OPERATION, home_offset + quarter_units, CSP).await;
        }
        let rotor = m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_angle_rad();
        let rotor_counts = rotor / std::f64::consts::TAU * f64::from(CPR);
        assert!(
            (rotor_counts - sign * f64::from(CPR / 4)).abs() < 300.0,
            "rotor at {rotor_counts:.0} increments, expected {} (900 units × {CPR}/{UNITS_PER_REV})",
            CPR / 4
        );
        assert!(
            (actual - home_offset - quarter_units).abs() <= 1,
            "6064h {actual} units, 607Ch = {home_offset}"
        );

        // CSV: 60FFh = 1800 units/s (half a revolution per second) for 0.4 s.
        sd.sdo_write(0x60FF, 0, 1800i32).await.expect("60FFh");
        let before = m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_angle_rad();
        for _ in 0..400 {
            cycle(ENABLE_OPERATION, 0, CSV).await;
        }
        let after = m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_angle_rad();
        let turned = sign * (after - before) / std::f64::consts::TAU;
        // 0.5 rev/s for 0.4 s = 0.2 rev, less the acceleration at the start.
        assert!((0.17..=0.21).contains(&turned), "turned {turned:.3} rev");
        let velocity: i32 = sd.sdo_read(0x606C, 0).await.expect("606Ch");
        assert!((velocity - 1800).abs() < 60, "606Ch {velocity} units/s");
    });
}

/// Σ-V-SD §4.5 (2): new user units (2301h) take effect only when 1 is written to 2300h in
/// Switch On Disabled (2300h then reads 0); written while the drive runs they change nothing.
/// 6064h follows the unit in force; a CSP move in the new unit turns the motor by the converted
/// amount.
#[test]
fn sigma_v_sd_user_units_take_effect_on_2300h() {
    use tests_host::csp;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, SIGMA_CSP).await;
        let rotor = || {
            m.shared.segment().drives()[0].servos[0]
                .plant
                .mech_angle_rad()
                / std::f64::consts::TAU
                * f64::from(CPR)
        };
        let (_, before) = csp::cycle(&m, md, &group, 0, 0).await;
        let sd = group.subdevice(md, 0).expect("drive");
        // 1 Pos. unit = 2 increments, written but not yet in force.
        sd.sdo_write(0x2301, 1, 2u32).await.expect("2301h:01");
        let (_, still) = csp::cycle(&m, md, &group, 0, 0).await;
        assert!(
            (still - before).abs() <= 2,
            "not in force yet: {before} -> {still}"
        );
        sd.sdo_write(0x2300, 0, 1u32).await.expect("2300h = 1");
        assert_eq!(
            sd.sdo_read::<u32>(0x2300, 0).await.expect("2300h"),
            0,
            "done"
        );
        let (_, halved) = csp::cycle(&m, md, &group, 0, 0).await;
        assert!(
            (f64::from(halved) - f64::from(before) / 2.0).abs() <= 2.0,
            "6064h in the new unit: {before} -> {halved}"
        );
        // Enable and move 1000 units = 2000 increments.
        let mut position = halved;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 20])
        {
            (_, position) = csp::cycle(&m, md, &group, cw, position).await;
        }
        let start_units = position;
        let start_rotor = rotor();
        for k in 0..=200 {
            csp::cycle(
                &m,
                md,
                &group,
                ENABLE_OPERATION,
                start_units + 1000 * k / 200,
            )
            .await;
        }
        for _ in 0..100 {
            (_, position) = csp::cycle(&m, md, &group, ENABLE_OPERATION, start_units + 1000).await;
        }
        let moved = rotor() - start_rotor;
        assert!((moved - 2000.0).abs() < 30.0, "moved {moved:.0} increments");
        assert!(
            (position - start_units - 1000).abs() <= 10,
            "6064h {position}"
        );
        // While enabled a new unit and 2300h = 1 change nothing (2300h still reads 0 again).
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x2301, 1, 4u32).await.expect("2301h:01");
        sd.sdo_write(0x2300, 0, 1u32).await.expect("2300h = 1");
        assert_eq!(sd.sdo_read::<u32>(0x2300, 0).await.expect("2300h"), 0);
        let (_, after) = csp::cycle(&m, md, &group, ENABLE_OPERATION, start_units + 1000).await;
        assert!(
            (after - position).abs() <= 10,
            "unit unchanged while enabled: {after}"
        );
    });
}

/// Σ-V-SD §4.5 (3)-(6): a user unit outside its "available value range" raises alarm A.A20
/// when 2300h = 1 would make it take effect (603Fh 0A20h, EMCY FF00h with the alarm code and
/// the axis number, §2.7); the unit in force stays; a fault reset does not clear it (the
/// profile's decision: it needs corrected units and 2300h, or a power cycle). Inside the range,
/// at its ends where they belong to it, 2300h takes the unit.
#[test]
fn sigma_v_sd_user_units_outside_their_range_raise_a_a20() {
    use tests_host::{csp, emcy};
    const FAULT_RESET: u16 = 0x80;
    let p = od_gen::builtin("sigma-v-sd").expect("profile");
    let a_a20 = a_a20(&p);
    // (object, numerator, in range): 2301h 1/4096 < N/D < 4096; 2302h 1/128 <= N/D <= 524288;
    // 2303h 1/128 <= N/D <= 16384; 2304h 1/256 <= N/D <= 1 (its denominator 10 by default).
    let cases: [(u16, u32, bool); 8] = [
        (0x2301, 4095, true),
        (0x2301, 4096, false),
        (0x2302, 524_288, true),
        (0x2302, 524_289, false),
        (0x2303, 16_384, true),
        (0x2303, 16_385, false),
        (0x2304, 10, true),
        (0x2304, 11, false),
    ];
    for (object, numerator, inside) in cases {
        block_on(async {
            let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let group = csp::into_op_with_mode(&m, md, SIGMA_CSP).await;
            let (_, before) = csp::cycle(&m, md, &group, 0, 0).await;
            while emcy::read(md, p.sm.mailbox_in.start)
                .await
                .expect("mailbox")
                .is_some()
            {}
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(object, 1, numerator).await.expect("numerator");
            sd.sdo_write(0x2300, 0, 1u32).await.expect("2300h = 1");
            let mut sw = 0;
            let mut emergency = None;
            for _ in 0..10 {
                (sw, _) = csp::cycle(&m, md, &group, 0, 0).await;
                if let Some(e) = emcy::read(md, p.sm.mailbox_in.start)
                    .await
                    .expect("mailbox")
                {
                    emergency.get_or_insert(e);
                }
            }
            let code: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
            let what = format!("{object:04X}h:01 = {numerator}");
            if inside {
                assert_eq!(sw & FAULT, 0, "{what}: no fault ({sw:#06x})");
                assert_eq!(emergency, None, "{what}");
                return;
            }
            assert_ne!(sw & FAULT, 0, "{what}: A.A20 ({sw:#06x})");
            assert_eq!(code, a_a20.error_code, "{what}: 603Fh");
            let e = emergency.expect("an emergency");
            assert_eq!((e.code, e.data), (0xFF00, a_a20.emcy.data), "{what}: EMCY");
            // The unit in force stayed (6064h unchanged).
            let (_, after) = csp::cycle(&m, md, &group, 0, 0).await;
            assert!((after - before).abs() <= 2, "{what}: {before} -> {after}");
            // A fault reset does not clear it.
            for cw in [0, FAULT_RESET, 0] {
                for _ in 0..5 {
                    (sw, _) = csp::cycle(&m, md, &group, cw, 0).await;
                }
            }
            assert_ne!(sw & FAULT, 0, "{what}: A.A20 holds through a reset");
        });
    }
}

/// Σ-V-SD §4.5: user units stored outside their range (1010h sub 3, the 23xxh objects) raise
/// A.A20 at the next power-on: the drive comes up in Fault with 603Fh 0A20h and announces it
/// with its emergency once it cycles.
#[test]
fn sigma_v_sd_stored_user_units_outside_their_range_raise_a_a20_at_power_on() {
    use tests_host::session::{power_cycle, session, Step};
    use tests_host::{csp, emcy};
    let p = od_gen::builtin("sigma-v-sd").expect("profile");
    let a_a20 = a_a20(&p);
    let segment = Segment::new("sigma-v-sd", 1).expect("profile");
    let (mut segment, out) = session(
        segment,
        &[
            Step::Write(0x2301, 1, 8192),
            Step::Write(STORE_23XX_6XXX.0, STORE_23XX_6XXX.1, STORE_23XX_6XXX.2),
        ],
    );
    assert!(out.iter().all(Result::is_ok), "{out:?}");
    power_cycle(&mut segment);
    block_on(async {
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, SIGMA_CSP).await;
        let (sw, _) = csp::cycle(&m, md, &group, 0, 0).await;
        // Announced like any alarm, once the drive cycles: its emergency (§2.7).
        let mut emergencies = Vec::new();
        while let Some(e) = emcy::read(md, p.sm.mailbox_in.start)
            .await
            .expect("mailbox")
        {
            emergencies.push((e.code, e.data));
        }
        assert_eq!(emergencies, [(0xFF00, a_a20.emcy.data)], "EMCY");
        let sd = group.subdevice(md, 0).expect("drive");
        let code: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
        assert_ne!(sw & FAULT, 0, "A.A20 from power-on: {sw:#06x}");
        assert_eq!(code, a_a20.error_code, "603Fh");
    });
}

/// Σ-V-SD §1.2.3 / §4.5 (6): 1 Trq. unit = 2304h:01 / 2304h:02 % of the rated torque (default
/// 1/10 = 0.1 %), for every torque object (6071h, 6077h, 60E0h, ...), in force after 2300h = 1.
/// With 1/1 (1 %) a target 6071h = 20 gives the torque 6071h = 200 gives at the default
/// (20 % of the rated 1.27 N·m on a locked rotor), 6077h reads it in the same unit, and a
/// positive torque limit 60E0h = 10 holds it at 10 %.
#[test]
fn sigma_v_sd_torque_user_unit_2304h_scales_every_torque_object() {
    const CST: i8 = 10;
    /// 6076h of the Σ-V-SD profile, N·m.
    const RATED_NM: f64 = 1.27;
    // 2304h:02 with 2304h:01 = 1 (None: the default 1/10).
    let run = |per_cent_denominator: Option<u32>, target: i16, limit: Option<i16>| {
        block_on(async move {
            let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let mut setup = Vec::new();
            if let Some(denominator) = per_cent_denominator {
                // In PREOP, Switch On Disabled: 2300h = 1 puts the unit in force.
                setup.extend([
                    Sdo::U32(0x2304, 1, 1),
                    Sdo::U32(0x2304, 2, denominator),
                    Sdo::U32(0x2300, 0, 1),
                ]);
            }
            let group = vendor::into_op_dc_velocity(&m, md, (0, &setup), CST, CYCLE_NS).await;
            m.shared.segment().drives_mut()[0].servos[0]
                .plant
                .set_driven_speed(Some(0.0));
            let sd = group.subdevice(md, 0).expect("drive");
            if let Some(limit) = limit {
                sd.sdo_write(0x60E0, 0, limit as u16).await.expect("60E0h");
            }
            sd.sdo_write(0x6071, 0, target).await.expect("6071h");
            for cw in vendor::enable_sequence(20).chain([ENABLE_OPERATION; 100]) {
                vendor::exchange_dc_command(&m, md, &group, (cw, CST, 0), CYCLE_NS).await;
            }
            let actual: i16 = sd.sdo_read(0x6077, 0).await.expect("6077h");
            let torque_nm = m.shared.segment().drives()[0].servos[0]
                .plant
                .electromagnetic_torque_nm();
            (actual, torque_nm)
        })
    };
    let check = |what: &str, (actual, torque_nm): (i16, f64), object: i16, per_cent: f64| {
        let expected_nm = per_cent / 100.0 * RATED_NM;
        assert!(
            (torque_nm - expected_nm).abs() < 0.03 * expected_nm,
            "{what}: {torque_nm:.4} N·m, {expected_nm:.4} expected"
        );
        assert!(
            (actual - object).abs() <= 1 + object / 50,
            "{what}: 6077h = {actual}, {object} expected"
        );
    };
    check("0.1 %, 6071h = 200", run(None, 200, None), 200, 20.0);
    check("1 %, 6071h = 20", run(Some(1), 20, None), 20, 20.0);
    check("1 %, 60E0h = 10", run(Some(1), 30, Some(10)), 10, 10.0);
}

/// Σ-V-SD §4.9 (1): "When an absolute encoder is connected to the SERVOPACK, the home offset is
/// added to the encoder absolute position (the position actual value) in power up phase." With
/// the reference servo's absolute encoder, 607Ch written and stored changes 6064h at the next
/// power-on by exactly its value (the rotor at rest), not at the write.
#[test]
fn sigma_v_sd_absolute_encoder_adds_the_home_offset_at_power_on() {
    use tests_host::csp;
    use tests_host::session::{power_cycle, take_segment};
    const OFFSET: i32 = 5_000;
    let mut segment = block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, SIGMA_CSP).await;
        let (_, before) = csp::cycle(&m, md, &group, 0, 0).await;
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x607C, 0, OFFSET).await.expect("607Ch");
        let (_, written) = csp::cycle(&m, md, &group, 0, 0).await;
        assert!(
            (written - before).abs() <= 2,
            "not before the next power-on: {before} -> {written}"
        );
        sd.sdo_write(STORE_23XX_6XXX.0, STORE_23XX_6XXX.1, STORE_23XX_6XXX.2)
            .await
            .expect("1010h:03");
        (before, take_segment(&m))
    });
    let before = segment.0;
    power_cycle(&mut segment.1);
    block_on(async move {
        let (m, transport) = master_for(segment.1);
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, SIGMA_CSP).await;
        let (_, after) = csp::cycle(&m, md, &group, 0, 0).await;
        assert!(
            (after - before - OFFSET).abs() <= 2,
            "6064h = the encoder's position + 607Ch: {before} -> {after}"
        );
    });
}
