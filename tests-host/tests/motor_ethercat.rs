//! The motor behind the bus: a CSP move commanded by ethercrab over the default PDO mapping
//! moves the simulated motor, and a motor protection trip reaches the master as a CiA402 fault
//! with the profile's 603Fh code and the error register 1001h, cleared by a fault reset once
//! its cause is gone.

use ethercrab::MainDevice;
use tests_host::{block_on, master};

/// Simulated time per cycle (free run).
const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the simulated servo's encoder.
const CPR: i64 = 1 << 20;
/// CiA402 controlwords (Table 5) and statusword masks/patterns (Table 3).
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const FAULT_RESET: u16 = 0x80;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const SWITCH_ON_DISABLED: u16 = 0x40;
const FAULT_BIT: u16 = 0x08;
/// Modes of operation 6060h: cyclic synchronous position.
const MODE_CSP: u8 = 8;
/// The standard profile's 603Fh code of `drive_over_temperature` (od-gen/profiles/standard.toml:
/// 0x4210 "excess temperature device").
const DRIVE_OVER_TEMPERATURE: u16 = 0x4210;
/// 1001h bit 3: temperature (CiA 301 Table 48, class 0x4xxx).
const ERROR_REGISTER_TEMPERATURE: u8 = 0x08;

/// One cycle with controlword `cw` and target `target` (default RxPDO 1600h: 6040h, 607Ah,
/// 6060h = CSP); evaluates to (statusword, position actual) from the default TxPDO 1A00h
/// (6041h, 6064h). Simulated time advances by one cycle (free run).
macro_rules! cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        {
            let mut out = sd.outputs_raw_mut();
            out[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
            out[2..6].copy_from_slice(&($target as i32).to_le_bytes());
            out[6] = MODE_CSP;
        }
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.advance(CYCLE_NS);
        let inp = sd.inputs_raw();
        (
            u16::from_le_bytes([inp[0], inp[1]]),
            i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
        )
    }};
}

/// The drive from INIT to OP (free run), as an ethercrab group in OP.
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

/// Shutdown, switch on, enable operation (CiA402 Table 5) in CSP holding position 0; the axis
/// calibrates its current offsets and runs. Evaluates to the last statusword.
macro_rules! power_up {
    ($m:expr, $md:expr, $group:expr) => {{
        let mut sw = 0u16;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            (sw, _) = cycle!($m, $md, $group, cw, 0);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        sw
    }};
}

#[test]
fn csp_moves_the_motor_and_a_motor_fault_reaches_the_master() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);

        // Power up (CiA402) and hold: the axis calibrates its current offsets and runs.
        let mut sw = power_up!(m, md, group);

        // A quarter revolution in 250 ms, then hold: the rotor (the plant's true angle) ends
        // where the master sent it.
        let quarter = (CPR / 4) as i32;
        let mut actual = 0;
        for k in 0..=250 {
            (_, actual) = cycle!(m, md, group, ENABLE_OPERATION, quarter * k / 250);
        }
        for _ in 0..50 {
            (_, actual) = cycle!(m, md, group, ENABLE_OPERATION, quarter);
        }
        let rotor = {
            let seg = m.shared.segment();
            seg.drives()[0].servos[0].plant.mech_angle_rad()
        };
        let rotor_counts = rotor / std::f64::consts::TAU * CPR as f64;
        assert!(
            (rotor_counts - f64::from(quarter)).abs() < 150.0,
            "rotor at {rotor_counts:.0} increments, target {quarter}"
        );
        assert!((actual - quarter).abs() < 150, "6064h {actual}");

        // The power stage overheats: after the protection's confirmation time the drive is in
        // Fault, the gates are off, 603Fh holds the profile's code and 1001h the temperature bit.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(120.0);
        let mut cycles_to_fault = None;
        for k in 0..300 {
            (sw, _) = cycle!(m, md, group, ENABLE_OPERATION, quarter);
            if sw & FAULT_BIT != 0 {
                cycles_to_fault = Some(k);
                break;
            }
        }
        let k = cycles_to_fault.expect("the drive faults");
        // ProtectionConfig default: 0.1 s of confirmation; the cycle grid adds a few ms.
        assert!((95..=110).contains(&k), "fault after {k} ms");
        {
            let seg = m.shared.segment();
            let servo = &seg.drives()[0].servos[0];
            assert!(!servo.latched().gates, "gates off");
        }
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            DRIVE_OVER_TEMPERATURE
        );
        let register = sd.sdo_read::<u8>(0x1001, 0).await.expect("1001h");
        assert_ne!(
            register & ERROR_REGISTER_TEMPERATURE,
            0,
            "1001h {register:#04x}"
        );

        // Reset while still hot: the axis trips again at once.
        cycle!(m, md, group, 0, quarter);
        for _ in 0..5 {
            (sw, _) = cycle!(m, md, group, FAULT_RESET, quarter);
        }
        for _ in 0..150 {
            (sw, _) = cycle!(m, md, group, 0, quarter);
        }
        assert_ne!(sw & FAULT_BIT, 0, "still hot: the fault stays");
        // Cooled down: a reset leaves Fault, 603Fh and 1001h clear.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(25.0);
        cycle!(m, md, group, 0, quarter);
        for _ in 0..5 {
            (sw, _) = cycle!(m, md, group, FAULT_RESET, quarter);
        }
        for _ in 0..5 {
            (sw, _) = cycle!(m, md, group, 0, quarter);
        }
        assert_eq!(sw & STATE_MASK, SWITCH_ON_DISABLED, "fault reset");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), 0);
        assert_eq!(sd.sdo_read::<u8>(0x1001, 0).await.expect("1001h"), 0);
    });
}

/// Modes of operation 6060h −1 (manufacturer-specific): motor identification.
const MODE_IDENTIFICATION: u8 = 0xFF;
/// Statusword bit 12 in mode −1: identification finished.
const IDENTIFIED_BIT: u16 = 0x1000;
/// 1010h:01 "save all parameters" signature (CiA 301: ASCII "save").
const SAVE: u32 = 0x6576_6173;

#[test]
fn commissioning_over_ethercat_identifies_stores_and_applies_the_motor_data() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        let run = |cw: u16| {
            let sd = group.subdevice(md, 0).expect("drive");
            let mut out = sd.outputs_raw_mut();
            out[0..2].copy_from_slice(&cw.to_le_bytes());
            out[6] = MODE_IDENTIFICATION;
        };
        // Power up in mode −1: the drive identifies R, L and the inertia and sets bit 12.
        let mut sw = 0u16;
        let mut finished_at = None;
        for k in 0..3_000 {
            let cw = match k {
                0..=4 => SHUTDOWN,
                5..=9 => SWITCH_ON,
                _ => ENABLE_OPERATION,
            };
            run(cw);
            group.tx_rx(md).await.expect("tx/rx");
            m.shared.advance(CYCLE_NS);
            let sd = group.subdevice(md, 0).expect("drive");
            let inp = sd.inputs_raw();
            sw = u16::from_le_bytes([inp[0], inp[1]]);
            if sw & IDENTIFIED_BIT != 0 {
                finished_at = Some(k);
                break;
            }
        }
        assert!(
            finished_at.is_some(),
            "identification finished (statusword {sw:#06x})"
        );
        assert_eq!(sw & FAULT_BIT, 0, "no fault");

        // The results, read by SDO, against the simulated motor's true parameters.
        let truth = m.shared.segment().drives()[0].servos[0]
            .plant
            .config()
            .clone();
        let sd = group.subdevice(md, 0).expect("drive");
        let read = |sub: u8| {
            let sd = &sd;
            async move { sd.sdo_read::<u32>(0x2100, sub).await.expect("2100h") as f64 }
        };
        let r = read(1).await * 1e-6;
        let ld = read(2).await * 1e-9;
        let lq = read(3).await * 1e-9;
        let j = read(4).await * 1e-9;
        let within = |what: &str, x: f64, truth: f64, tol: f64| {
            assert!(
                (x / truth - 1.0).abs() < tol,
                "{what}: identified {x:e}, true {truth:e}"
            );
        };
        within("R", r, truth.motor.r_ohm, 0.05);
        within("Ld", ld, truth.motor.ld_h, 0.10);
        within("Lq", lq, truth.motor.lq_h, 0.10);
        within(
            "J",
            j,
            truth.motor.rotor_inertia_kgm2 + truth.mechanics.load_inertia_kgm2,
            0.10,
        );

        // Stored (1010h) and applied after a power cycle: the loops are tuned for them.
        sd.sdo_write(0x1010, 1, SAVE).await.expect("save");
        let stored = [read(1).await, read(2).await, read(3).await, read(4).await];
        {
            let mut seg = m.shared.segment();
            let drive = &mut seg.drives_mut()[0];
            drive.power_cycle().expect("power cycle");
            let od = drive.slave.dictionary();
            for (sub, value) in (1..=4).zip(stored) {
                assert_eq!(
                    od.read_u32(0x2100, sub).expect("2100h") as f64,
                    value,
                    "2100:{sub:02} restored at power-on"
                );
            }
        }
        m.shared.advance(CYCLE_NS);
        let model = m.shared.segment().drives()[0].servos[0].axis.motor_model();
        within(
            "applied R",
            f64::from(model.resistance_ohm),
            stored[0] * 1e-6,
            1e-4,
        );
        within("applied Ld", f64::from(model.ld_h), stored[1] * 1e-9, 1e-4);
        within("applied Lq", f64::from(model.lq_h), stored[2] * 1e-9, 1e-4);
        within(
            "applied J",
            f64::from(model.inertia_kgm2),
            stored[3] * 1e-9,
            1e-4,
        );
    });
}

#[test]
fn leaving_op_disables_the_motor() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        power_up!(m, md, group);
        assert!(
            m.shared.segment().drives()[0].servos[0].latched().gates,
            "motor powered"
        );
        // The master takes the drive down to PRE-OP: no more cycles run, the motor must still
        // stop.
        let group = group.into_safe_op(md).await.expect("SAFE-OP");
        let _group = group.into_pre_op(md).await.expect("PRE-OP");
        m.shared.advance(5 * CYCLE_NS);
        let seg = m.shared.segment();
        let servo = &seg.drives()[0].servos[0];
        assert!(!servo.latched().gates, "gates off after leaving OP");
    });
}
