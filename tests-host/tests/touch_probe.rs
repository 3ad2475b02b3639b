//! Touch probe (CiA402 60B8h–60BDh, 60D5h–60D8h) on the simulated servo, commanded by ethercrab:
//! the motor turns at a constant 100 rpm in profile velocity past two probe sensors (marks at
//! known angles in the simulated plant) and its encoder index (the absolute encoder's
//! single-turn zero at every whole revolution). The latched positions must equal the positions
//! of the simulated edges within one encoder count: the edges are taken at their edge time, not
//! at the next sample or bus cycle (at 100 rpm the motor moves 44 increments per PWM period and
//! 1748 per bus cycle).

use std::f64::consts::TAU;

use board_sim::plant::SwitchParams;
use ethercrab::MainDevice;
use tests_host::{block_on, csp, master, vendor};

const CPR: f64 = (1u32 << 20) as f64;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const PV: i8 = 3;
/// 60B8h bits of one probe.
const ENABLE: u16 = 1 << 0;
const CONTINUOUS: u16 = 1 << 1;
const SOURCE_INDEX: u16 = 1 << 2;
const RISING: u16 = 1 << 4;
const FALLING: u16 = 1 << 5;
/// Probe 1 sensor active from 0.3 to 0.6 revolutions, probe 2 from 1.45 to 1.55.
const PROBE1: (f64, f64) = (0.3, 0.6);
const PROBE2: (f64, f64) = (1.45, 1.55);

fn counts(rev: f64) -> i32 {
    (rev * CPR).round() as i32
}

/// Asserts `latched` is within one increment of the edge at `rev` revolutions.
fn assert_at(latched: i32, rev: f64, what: &str) {
    let expected = rev * CPR;
    assert!(
        (f64::from(latched) - expected).abs() <= 1.0,
        "{what}: latched {latched}, the edge is at {expected:.1}"
    );
}

#[test]
fn touch_probes_latch_the_edge_positions_of_inputs_and_index() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        vendor::place_probe_sensors(&m, 0, [PROBE1, PROBE2]);
        let group = csp::into_op_with_mode(&m, md, PV).await;
        let sd = group.subdevice(md, 0).expect("drive");
        // Probe 1: single trigger, both edges, its input. Probe 2: continuous, rising, on the
        // index.
        let function =
            (ENABLE | RISING | FALLING) | (ENABLE | CONTINUOUS | SOURCE_INDEX | RISING) << 8;
        sd.sdo_write(0x60B8, 0, function).await.expect("60B8h");
        sd.sdo_write(0x60FF, 0, counts(100.0 / 60.0))
            .await
            .expect("60FFh");
        let mut s = csp::phase_locked(&m, md, &group, 0, 0, PV).await;
        for cw in [0x06u16; 5]
            .into_iter()
            .chain([0x07; 5])
            .chain([ENABLE_OPERATION; 5])
        {
            s = csp::phase_locked(&m, md, &group, cw, 0, PV).await;
        }
        assert_eq!(s.statusword & STATE_MASK, OPERATION_ENABLED);
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status, 0x0101, "both probes enabled, nothing stored");

        // 0 → 0.7 rev: probe 1 rises at 0.3 and falls at 0.6.
        while s.revolutions < 0.7 {
            s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, PV).await;
        }
        assert!(
            (s.rpm - 100.0).abs() < 2.0,
            "constant speed: {:.1} rpm",
            s.rpm
        );
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status, 0x0107, "probe 1: both edges stored");
        let rising: i32 = sd.sdo_read(0x60BA, 0).await.expect("60BAh");
        let falling: i32 = sd.sdo_read(0x60BB, 0).await.expect("60BBh");
        assert_at(rising, PROBE1.0, "60BAh");
        assert_at(falling, PROBE1.1, "60BBh");
        // On to 2.2 rev: probe 2 (index, continuous) latches at 1 and at 2 revolutions; probe 2's
        // own input is not its source; probe 1 (single trigger) has nothing new to take.
        while s.revolutions < 2.2 {
            s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, PV).await;
        }
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status, 0x0307);
        let index: i32 = sd.sdo_read(0x60BC, 0).await.expect("60BCh");
        assert_at(index, 2.0, "60BCh (index)");
        let count: u16 = sd.sdo_read(0x60D7, 0).await.expect("60D7h");
        assert_eq!(count, 2, "60D7h: two index pulses");
        let counts1: (u16, u16) = (
            sd.sdo_read(0x60D5, 0).await.expect("60D5h"),
            sd.sdo_read(0x60D6, 0).await.expect("60D6h"),
        );
        assert_eq!(counts1, (1, 1), "single trigger: one edge each");
        assert_eq!(
            sd.sdo_read::<i32>(0x60BA, 0).await.expect("60BAh"),
            rising,
            "single trigger: kept"
        );
        // Switching probe 1 off clears its status, the values stay.
        sd.sdo_write(0x60B8, 0, function & 0xFF00)
            .await
            .expect("60B8h");
        csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, PV).await;
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status, 0x0300);
        assert_eq!(sd.sdo_read::<i32>(0x60BB, 0).await.expect("60BBh"), falling);
    });
}

/// RSE 7.9 (60B8h): bit 2 "probe 1 trigger signal selection: 0 IN input signal, 1
/// meaningless": the drive has no index latch, so a master that sets bit 2 still latches the
/// probe input (CiA402 would latch the encoder index instead, as the test above shows). The
/// motor turns at 100 rpm in profile velocity past the probe 1 sensor (0.3 rev) and the encoder
/// index (1.0 rev); 60BAh must hold the sensor's edge.
#[test]
fn rse_touch_probe_source_bit_is_meaningless_the_input_latches() {
    use tests_host::master_for;
    use tests_host::vendor::{self, Sdo};
    // The RSE's free-run cycle (1C32h:02 default).
    const RSE_CYCLE_NS: u64 = 4_000_000;
    // RSE 1600h: 6040h at byte 0, 607Ah at 2, 60B8h at 6.
    const CONTROLWORD_AT: usize = 0;
    const TOUCH_PROBE_FUNCTION_AT: usize = 6;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("rse", 1).expect("rse"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_switches(SwitchParams {
                probes: [Some((PROBE1.0 * TAU, PROBE1.1 * TAU)), None],
                ..SwitchParams::default()
            });
        // Command units are increments (6091h 1:1 by default): 100 rpm, 10 rev/s² ramps, and
        // 607Fh (default 10000 units/s, 0.6 rpm) raised to 3000 rpm.
        let group = vendor::into_op(
            &m,
            md,
            &[
                Sdo::I8(0x6060, 0, PV),
                Sdo::I32(0x60FF, 0, counts(100.0 / 60.0)),
                Sdo::U32(0x6083, 0, (10.0 * CPR) as u32),
                Sdo::U32(0x6084, 0, (10.0 * CPR) as u32),
                Sdo::U32(0x607F, 0, (50.0 * CPR) as u32),
            ],
        )
        .await;
        let sd = group.subdevice(md, 0).expect("drive");
        let function = (ENABLE | SOURCE_INDEX | RISING).to_le_bytes();
        let mut inputs = Vec::new();
        for cw in vendor::enable_sequence(5) {
            inputs = vendor::exchange(
                &m,
                md,
                &group,
                &[
                    (CONTROLWORD_AT, &cw.to_le_bytes()),
                    (TOUCH_PROBE_FUNCTION_AT, &function),
                ],
                RSE_CYCLE_NS,
            )
            .await;
        }
        assert!(!inputs.is_empty());
        let status: u16 = sd.sdo_read(0x6041, 0).await.expect("6041h");
        assert_eq!(status & STATE_MASK, OPERATION_ENABLED);
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status & 0x0007, 0x0001, "probe 1 enabled, nothing stored");
        // Past the sensor (0.3 rev) and the index (1.0 rev).
        let mut cycles = 0;
        while vendor::motor(&m).1 < 1.3 {
            cycles += 1;
            assert!(cycles < 2_000, "the motor did not turn");
            vendor::exchange(
                &m,
                md,
                &group,
                &[
                    (CONTROLWORD_AT, &vendor::ENABLE_OPERATION.to_le_bytes()),
                    (TOUCH_PROBE_FUNCTION_AT, &function),
                ],
                RSE_CYCLE_NS,
            )
            .await;
        }
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(status & 0x0007, 0x0003, "probe 1: the rising edge stored");
        let latched: i32 = sd.sdo_read(0x60BA, 0).await.expect("60BAh");
        assert_at(
            latched,
            PROBE1.0,
            "60BAh (the input, not the index at 1.0 rev)",
        );
    });
}

/// SDV3-E §7.12 / §5.2 11: EXT1 and EXT2 are the EI functions 40 and 41, which only EI3–EI5
/// (P3.03–P3.05 = 3002h:03–05) can take. A 60B8h write that enables a probe latch on EXT while
/// its function is assigned to none of them raises Act (603Fh 8802h, Fault); with the function
/// assigned the same write latches as usual; the encoder Z source needs no assignment.
#[test]
fn sdv3_e_a_probe_on_an_unassigned_ext_input_is_act() {
    use tests_host::master_for;
    use tests_host::vendor;
    const CYCLE_NS: u64 = 1_000_000;
    const ACT: u16 = 0x8802;
    const FAULT_BIT: u16 = 0x08;
    const FAULT_RESET: u16 = 0x80;
    const EI3_FUNCTION: (u16, u8) = (0x3002, 3);
    const EI5_FUNCTION: (u16, u8) = (0x3002, 5);
    const EXT1: i32 = 40;
    const EXT2: i32 = 41;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("sdv3-e", 1).expect("sdv3-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op(&m, md, &[]).await;
        let sd = group.subdevice(md, 0).expect("drive");
        // SDV3-E 1600h: 6040h at byte 0; 1A00h: 6041h at byte 0.
        let run = |cw: u16| {
            let (m, group) = (&m, &group);
            async move {
                let mut inputs = Vec::new();
                for _ in 0..5 {
                    inputs =
                        vendor::exchange(m, md, group, &[(0, &cw.to_le_bytes())], CYCLE_NS).await;
                }
                vendor::u16_at(&inputs, 0)
            }
        };
        let sd = &sd;
        let error_code = || async move { sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh") };
        let probe = |function: u16| async move {
            sd.sdo_write(0x60B8, 0, function).await.expect("60B8h");
        };
        assert_eq!(run(0).await & FAULT_BIT, 0);
        // EXT1 rising edge, nothing assigned: Act.
        probe(ENABLE | RISING).await;
        let sw = run(0).await;
        assert_ne!(sw & FAULT_BIT, 0, "Fault: {sw:#06x}");
        assert_eq!(error_code().await, ACT);
        // Reset; the Z source needs no input.
        probe(0).await;
        run(FAULT_RESET).await;
        assert_eq!(run(0).await & FAULT_BIT, 0, "reset");
        probe(ENABLE | SOURCE_INDEX | RISING).await;
        assert_eq!(run(0).await & FAULT_BIT, 0, "Z phase: no Act");
        assert_eq!(error_code().await, 0);
        // EXT1 assigned to EI3: no error; EXT2 (probe 2) still unassigned: Act.
        probe(0).await;
        sd.sdo_write(EI3_FUNCTION.0, EI3_FUNCTION.1, EXT1)
            .await
            .expect("P3.03");
        probe(ENABLE | RISING).await;
        assert_eq!(run(0).await & FAULT_BIT, 0, "EXT1 assigned");
        assert_eq!(error_code().await, 0);
        probe((ENABLE | RISING) | (ENABLE | RISING) << 8).await;
        assert_ne!(run(0).await & FAULT_BIT, 0, "EXT2 unassigned");
        assert_eq!(error_code().await, ACT);
        // EXT2 on EI5: both probes run.
        probe(0).await;
        run(FAULT_RESET).await;
        sd.sdo_write(EI5_FUNCTION.0, EI5_FUNCTION.1, EXT2)
            .await
            .expect("P3.05");
        probe((ENABLE | RISING) | (ENABLE | RISING) << 8).await;
        assert_eq!(run(0).await & FAULT_BIT, 0, "both assigned");
        let status: u16 = sd.sdo_read(0x60B9, 0).await.expect("60B9h");
        assert_eq!(
            status & 0x0101,
            0x0101,
            "both probes enabled: {status:#06x}"
        );
    });
}
