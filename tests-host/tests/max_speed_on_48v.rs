//! The simulated 400 W servo reaches its maximum speed on the 48 V bus through the bus, end to
//! end (ethercrab, standard profile, cyclic synchronous velocity at a 1 ms DC cycle): at
//! 4500 rpm under half the rated torque its back-EMF and q-axis drop (about 27 V) leave no room
//! in the 48/√3 = 27.7 V voltage circle, so the drive must weaken the field (a negative d
//! current) to keep control of the q current. The motor must reach the speed within 1 %, hold
//! it under the load, and the drive must stay in Operation Enabled (no over-current, no lost
//! control).

use ethercrab::MainDevice;
use tests_host::vendor;
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
/// The servo's maximum speed (`motor_control::servo::SERVO_400W`), rev/s.
const MAX_REV_S: f64 = 4500.0 / 60.0;
/// Half the rated torque (1.27 N·m), N·m: the load at speed.
const LOAD_NM: f64 = 0.635;

#[test]
fn standard_reaches_4500_rpm_on_48_v_with_field_weakening() {
    let profile = od_gen::builtin("standard").expect("profile");
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("standard", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CSV, CYCLE_NS).await;
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            let inputs = vendor::exchange_dc_command(&m, md, &group, (cw, CSV, 0), CYCLE_NS).await;
            sw = vendor::u16_at(&inputs, 0);
        }
        assert!(cia402::is(sw, cia402::OPERATION_ENABLED), "{sw:#06x}");
        let full = units::target_velocity(&profile, MAX_REV_S);
        let mut weakest_d = 0.0f64;
        // A ramp over 1.5 s, then 0.5 s at speed, then 0.5 s more under the load.
        for k in 0..2500 {
            if k == 2000 {
                m.shared.segment().drives_mut()[0].servos[0]
                    .plant
                    .set_load_torque(LOAD_NM);
            }
            let v = f64::from(full) * (f64::from(k).min(1500.0) / 1500.0);
            let inputs = vendor::exchange_dc_command(
                &m,
                md,
                &group,
                (vendor::ENABLE_OPERATION, CSV, v as i32),
                CYCLE_NS,
            )
            .await;
            sw = vendor::u16_at(&inputs, 0);
            assert!(
                cia402::is(sw, cia402::OPERATION_ENABLED),
                "cycle {k}: left Operation Enabled: {sw:#06x}"
            );
            let (id, _) = m.shared.segment().drives()[0].servos[0].plant.currents_dq();
            weakest_d = weakest_d.min(id);
        }
        let (rpm, _) = vendor::motor(&m);
        assert!(
            (rpm / 60.0 - MAX_REV_S).abs() < 0.01 * MAX_REV_S,
            "{rpm:.0} rpm under the load"
        );
        assert!(
            weakest_d < -1.0,
            "the field was weakened: d current down to {weakest_d:.2} A"
        );
    });
}
