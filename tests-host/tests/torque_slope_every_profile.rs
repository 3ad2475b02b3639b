//! Profile torque (6060h = 4) with its torque slope, end to end (ethercrab, DC SYNC0 at 1 ms;
//! 6040h, 6060h, 6071h / 6041h, 6061h, 6077h mapped): with the rotor held by a locked load, a
//! step of the target torque 6071h to 50 % of the rated torque must come out as a ramp at the
//! torque slope 6087h (100 %/s: half-way after 0.25 s, there after 0.5 s), where the profile has
//! 6087h (CiA402; GHA-E §5.4 "6087h torque slope (0.1 %/s)"; RSE 7.7; Σ-V-SD §6.6 "6071h ramped at
//! 6087h"); the SDV3-E has no torque slope (§7.9) and takes the step at once.

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcGroup, Sdo};
use tests_host::{block_on, cia402, master_for};

const CYCLE_NS: u64 = 1_000_000;
const PT: i8 = 4;
/// 6087h: 100 % of the rated torque per second, in ‰/s (the vendors' 0.1 %/s).
const SLOPE: u32 = 1000;
/// The step: 50 % of the rated torque, ‰.
const TARGET: i32 = 500;
/// The actual torque within this of where the ramp is, ‰.
const TOLERANCE: f64 = 25.0;

/// Little-endian bytes of `value` in `len` bytes.
fn bytes(value: i32, len: usize) -> Vec<u8> {
    value.to_le_bytes()[..len].to_vec()
}

/// A signed little-endian integer of `len` bytes at `at`.
fn signed(image: &[u8], at: usize, len: usize) -> i32 {
    match len {
        2 => i32::from(i16::from_le_bytes([image[at], image[at + 1]])),
        _ => vendor::i32_at(image, at),
    }
}

async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    (cw, torque): (u16, i32),
    (out_len, in_len): (usize, usize),
) -> (u16, i32) {
    let [c0, c1] = cw.to_le_bytes();
    let mut image = vec![c0, c1, PT as u8];
    image.extend(bytes(torque, out_len));
    let inputs = vendor::exchange_dc(m, md, group, &[(0, &image)], CYCLE_NS).await;
    (vendor::u16_at(&inputs, 0), signed(&inputs, 3, in_len))
}

/// The torque 6077h of every cycle after the step, or what went wrong.
async fn step_response(name: &str, profile: &Profile) -> Result<Vec<i32>, String> {
    let len = |index| profile.entry(index, 0).map_or(2, |e| e.byte_len());
    let lens = (len(0x6071), len(0x6077));
    let bits = |n: usize| u8::try_from(8 * n).expect("bits");
    let mut setup = vendor::remap(
        0x1600,
        0x1C12,
        &[(0x6040, 0, 16), (0x6060, 0, 8), (0x6071, 0, bits(lens.0))],
    );
    setup.extend(vendor::remap(
        0x1A00,
        0x1C13,
        &[(0x6041, 0, 16), (0x6061, 0, 8), (0x6077, 0, bits(lens.1))],
    ));
    if profile.entry(0x6087, 0).is_some() {
        setup.push(Sdo::U32(0x6087, 0, SLOPE));
    }
    let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
    m.shared.segment().drives_mut()[0].servos[0]
        .plant
        .set_driven_speed(Some(0.0));
    for _ in 0..vendor::SYNC0_START_CYCLES {
        cycle(&m, md, &group, (0, 0), lens).await;
    }
    let mut sw = 0;
    for cw in vendor::enable_sequence(20) {
        sw = cycle(&m, md, &group, (cw, 0), lens).await.0;
    }
    if !cia402::is(sw, cia402::OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    let mut torques = Vec::new();
    for _ in 0..700 {
        let (_, torque) = cycle(&m, md, &group, (vendor::ENABLE_OPERATION, TARGET), lens).await;
        torques.push(torque);
    }
    Ok(torques)
}

fn torque_slope(name: &str) {
    let profile = od_gen::builtin(name).expect("profile");
    let sloped = profile.entry(0x6087, 0).is_some();
    let torques = block_on(step_response(name, &profile)).unwrap_or_else(|e| panic!("{name}: {e}"));
    // Where the ramp (or the step) is after `ms` (the inputs lag the command by a cycle or two).
    let expected = |ms: usize| {
        if sloped {
            (f64::from(SLOPE) * ms as f64 / 1000.0).min(f64::from(TARGET))
        } else {
            f64::from(TARGET)
        }
    };
    for ms in [50, 250, 400, 650] {
        let got = f64::from(torques[ms]);
        assert!(
            (got - expected(ms)).abs() <= TOLERANCE,
            "{name}: 6077h = {got} ‰ after {ms} ms, expected {:.0} ‰ (6087h: {sloped})",
            expected(ms)
        );
    }
}

#[test]
fn standard_torque_slope() {
    torque_slope("standard");
}

#[test]
fn gha_e_torque_slope() {
    torque_slope("gha-e");
}

#[test]
fn rse_torque_slope() {
    torque_slope("rse");
}

#[test]
fn sigma_v_sd_torque_slope() {
    torque_slope("sigma-v-sd");
}

#[test]
fn sdv3_e_torque_step_without_a_slope() {
    torque_slope("sdv3-e");
}
