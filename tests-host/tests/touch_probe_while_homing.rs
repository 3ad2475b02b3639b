//! Touch probes while homing runs, end to end (ethercrab, DC SYNC0 at 1 ms; 6040h, 6060h, 60FFh
//! / 6041h, 6061h, 606Ch mapped): both probes enabled on their inputs (rising edge, single) by
//! 60B8h, then a homing search (method 2, towards a positive limit switch the simulated axis does
//! not have) runs the motor past both probe sensors. Where the manual switches a probe off while
//! homing runs it neither shows as enabled in 60B9h nor latches; once homing ends (bit 4
//! cleared) it is enabled again, as 60B8h still asks:
//!
//! | profile | off while homing | manual |
//! |---|---|---|
//! | standard | neither | CiA402 |
//! | gha-e | both | §6.8 |
//! | sigma-v-sd | probe 1 (probe 2 goes on) | §6.9 |

use std::f64::consts::TAU;

use ethercrab::MainDevice;
use tests_host::vendor::{self, Sdo};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
/// Homing method 2: positive limit switch (and index).
const SEARCH_POSITIVE: i8 = 2;
const SEARCH_REV_S: f64 = 1.0;
/// 60B8h: each probe enabled, single trigger, input source, rising edge.
const FUNCTION: u16 = 0x0011 | 0x0011 << 8;
/// 60B9h bits of probe 1 (probe 2: << 8): enabled, rising edge stored.
const ENABLED: u16 = 1 << 0;
const RISING_STORED: u16 = 1 << 1;
const PROBE1: (f64, f64) = (0.3, 0.6);
const PROBE2: (f64, f64) = (1.45, 1.55);

async fn probes_while_homing(name: &str, off: [bool; 2]) -> Result<(), String> {
    let profile = od_gen::builtin(name).expect("profile");
    let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    vendor::place_probe_sensors(&m, 0, [PROBE1, PROBE2]);
    let setup = [
        Sdo::U16(0x60B8, 0, FUNCTION),
        Sdo::I8(0x6098, 0, SEARCH_POSITIVE),
        Sdo::U32(0x6099, 1, units::velocity(&profile, SEARCH_REV_S)),
        Sdo::U32(0x609A, 0, units::acceleration(&profile, 20.0)),
    ];
    let group = vendor::into_op_dc_velocity(&m, md, (0, &setup), cia402::HOMING, CYCLE_NS).await;
    let cycle = |cw: u16| {
        let (m, group) = (&m, &group);
        async move {
            let inputs =
                vendor::exchange_dc_command(m, md, group, (cw, cia402::HOMING, 0), CYCLE_NS).await;
            vendor::u16_at(&inputs, 0)
        }
    };
    let mut sw = 0;
    for cw in vendor::enable_sequence(20) {
        sw = cycle(cw).await;
    }
    if !cia402::is(sw, cia402::OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    let rotor = || {
        m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_angle_rad()
            / TAU
    };
    let mut cycles = 0;
    while rotor() < 2.0 {
        cycles += 1;
        if cycles > 5_000 {
            return Err(format!("the search did not get there: {:.2} rev", rotor()));
        }
        cycle(vendor::ENABLE_OPERATION | cia402::HOMING_START).await;
    }
    let sd = group.subdevice(md, 0).expect("drive");
    let status = sd
        .sdo_read::<u16>(0x60B9, 0)
        .await
        .map_err(|e| format!("60B9h: {e:?}"))?;
    let expected = off
        .iter()
        .enumerate()
        .filter(|(_, off)| !**off)
        .fold(0, |acc, (n, _)| acc | (ENABLED | RISING_STORED) << (8 * n));
    let mask = (ENABLED | RISING_STORED) * 0x0101;
    if status & mask != expected {
        return Err(format!(
            "while homing: 60B9h {status:#06x}, expected {expected:#06x} under {mask:#06x}"
        ));
    }
    // Homing interrupted (bit 4 cleared): every probe 60B8h enables is enabled again.
    for _ in 0..5 {
        cycle(vendor::ENABLE_OPERATION).await;
    }
    let status = sd
        .sdo_read::<u16>(0x60B9, 0)
        .await
        .map_err(|e| format!("60B9h: {e:?}"))?;
    if status & (ENABLED * 0x0101) != ENABLED * 0x0101 {
        return Err(format!(
            "after homing: 60B9h {status:#06x}, both probes enabled"
        ));
    }
    Ok(())
}

fn check(name: &str, off: [bool; 2]) {
    block_on(async {
        if let Err(e) = probes_while_homing(name, off).await {
            panic!("{name}: {e}");
        }
    });
}

#[test]
fn standard_probes_stay_on_while_homing() {
    check("standard", [false, false]);
}

#[test]
fn gha_e_probes_are_off_while_homing() {
    check("gha-e", [true, true]);
}

#[test]
fn sigma_v_sd_probe_1_is_off_while_homing() {
    check("sigma-v-sd", [true, false]);
}
