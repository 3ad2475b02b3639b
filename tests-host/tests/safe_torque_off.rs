//! Safe torque off (the Σ-V-SD's HWBB, manual §3.11): a channel of the STO input opens on the
//! simulated board while the motor turns in profile velocity, commanded by ethercrab over PDOs
//! with DC SYNC0 at 1 ms (1600h: 6040h, 6060h, 60FFh; 1A00h: 6041h, 60FDh, 606Ch).
//!
//! - the power stage is cut in hardware and the drive follows: Operation Enabled → Switch On
//!   Disabled at once (§3.1 *4), no fault, the motor coasts (no braking ramp);
//! - the Σ-V-SD shows it: statusword bit 15 "HWBB active: 0: HWBB activated, 1: HWBB not
//!   activated" (§4.7, as written), 60FDh bits 24/25 HWBB1/HWBB2 "(0: Open, 1: Close)" (§6.11);
//! - closing the channel does not restart the motor: the drive stays in Switch On Disabled
//!   until the master enables it again, which then works as usual.
//!
//! The standard profile reacts alike (a drive whose power stage is cut is not enabled) and has
//! no display of its own for it.
//!
//! The drive's enable input (`hal::io::DigitalInputs::enable_input`, a functional permission,
//! not a safety function) withheld the same way: nothing in the power stage follows it, so the
//! firmware must cut the bridge itself; the PDS reacts as to safe torque off and nothing
//! restarts when the permission returns. The standard profile shows it in 60FDh bit 3
//! "interlock" (CiA402); the Σ-V-SD has that bit reserved (§6.11) and shows nothing, and its
//! HWBB display stays "not activated".

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, enable_sequence, i32_at, motor, u16_at, ENABLE_OPERATION};
use tests_host::{block_on, master_for};

const CYCLE_NS: u64 = 1_000_000;
const CPR: f64 = (1u32 << 20) as f64;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const SWITCH_ON_DISABLED: u16 = 0x40;
const FAULT: u16 = 1 << 3;
/// The Σ-V-SD's statusword bit 15 and 60FDh bits 24/25 (HWBB1, HWBB2).
const HWBB_NOT_ACTIVE: u16 = 1 << 15;
const HWBB1_CLOSED: u32 = 1 << 24;
const HWBB2_CLOSED: u32 = 1 << 25;
/// CiA402 60FDh bit 3: interlock.
const INTERLOCK: u32 = 1 << 3;
/// 6060h: profile velocity.
const PV: i8 = 3;
/// Image layouts (byte offsets).
const TX_SW: usize = 0;
const TX_INPUTS: usize = 2;
/// 300 rpm in increments/s (the velocity unit of both profiles by default).
const VELOCITY: i32 = (300.0 / 60.0 * CPR) as i32;

/// What a cycle brought back: statusword, 60FDh.
struct Inputs {
    sw: u16,
    digital_inputs: u32,
}

/// The input that withholds the drive's permission to run.
#[derive(Clone, Copy, PartialEq)]
enum Withheld {
    /// Safe-torque-off channel 1 opens.
    SafeTorqueOff,
    /// The enable input opens.
    EnableInput,
}

/// Opens (`open`) or closes the `input` on the simulated board.
fn set_input(m: &board_sim::inproc::InProcess, input: Withheld, open: bool) {
    let mut segment = m.shared.segment();
    let plant = &mut segment.drives_mut()[0].servos[0].plant;
    match input {
        Withheld::SafeTorqueOff => plant.set_safe_torque_off_channels([!open, true]),
        Withheld::EnableInput => plant.set_enable_input(!open),
    }
}

/// `input` opens while the motor turns in profile velocity on `profile`. `hwbb_display`: the
/// profile shows safe torque off (the Σ-V-SD); `interlock_display`: the profile shows the
/// enable input in 60FDh bit 3.
fn withheld_in_profile_velocity(
    profile: &str,
    input: Withheld,
    hwbb_display: bool,
    interlock_display: bool,
) {
    let hwbb_shown = hwbb_display && input == Withheld::SafeTorqueOff;
    let interlock_shown = interlock_display && input == Withheld::EnableInput;
    block_on(async {
        let (m, transport) = master_for(Segment::new(profile, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let outputs = [(0x6040, 0, 16), (0x6060, 0, 8), (0x60FF, 0, 32)];
        let inputs = [(0x6041, 0, 16), (0x60FD, 0, 32), (0x606C, 0, 32)];
        let group = vendor::into_op_dc_mapped(&m, md, (&outputs, &inputs), CYCLE_NS).await;
        let cycle = |cw: u16, velocity: i32| {
            let (m, group) = (&m, &group);
            async move {
                let inputs =
                    vendor::exchange_dc_command(m, md, group, (cw, PV, velocity), CYCLE_NS).await;
                Inputs {
                    sw: u16_at(&inputs, TX_SW),
                    digital_inputs: i32_at(&inputs, TX_INPUTS) as u32,
                }
            }
        };
        let rpm = || motor(&m).0;
        let mut s = cycle(0, 0).await;
        for cw in std::iter::repeat_n(0u16, 40).chain(enable_sequence(30)) {
            s = cycle(cw, 0).await;
        }
        assert_eq!(s.sw & STATE_MASK, OPERATION_ENABLED, "{:#06x}", s.sw);
        if hwbb_display {
            assert_ne!(s.sw & HWBB_NOT_ACTIVE, 0, "bit 15: HWBB not activated");
            assert_eq!(
                s.digital_inputs & (HWBB1_CLOSED | HWBB2_CLOSED),
                HWBB1_CLOSED | HWBB2_CLOSED,
                "60FDh: both channels closed"
            );
        }
        for _ in 0..600 {
            s = cycle(ENABLE_OPERATION, VELOCITY).await;
        }
        let turning = rpm();
        assert!((turning - 300.0).abs() < 10.0, "at speed: {turning:.1} rpm");

        assert_eq!(s.digital_inputs & INTERLOCK, 0, "60FDh: no interlock");

        // The input opens: Switch On Disabled at once, no fault, the motor coasts.
        set_input(&m, input, true);
        for _ in 0..3 {
            s = cycle(ENABLE_OPERATION, VELOCITY).await;
        }
        assert_eq!(s.sw & STATE_MASK, SWITCH_ON_DISABLED, "{:#06x}", s.sw);
        assert_eq!(s.sw & FAULT, 0, "not a fault");
        assert_eq!(
            s.digital_inputs & INTERLOCK != 0,
            interlock_shown,
            "60FDh bit 3: {:#010x}",
            s.digital_inputs
        );
        if hwbb_display && !hwbb_shown {
            assert_ne!(s.sw & HWBB_NOT_ACTIVE, 0, "bit 15: not HWBB");
        }
        if hwbb_shown {
            assert_eq!(s.sw & HWBB_NOT_ACTIVE, 0, "bit 15: HWBB activated");
            assert_eq!(
                s.digital_inputs & (HWBB1_CLOSED | HWBB2_CLOSED),
                HWBB2_CLOSED,
                "60FDh: HWBB1 open, HWBB2 closed"
            );
        }
        for _ in 0..20 {
            s = cycle(ENABLE_OPERATION, VELOCITY).await;
        }
        // No current flows: the bridge is off (the motor slows down by its friction alone).
        let currents = m.shared.segment().drives()[0].servos[0]
            .plant
            .phase_currents();
        assert!(
            currents.iter().all(|i| i.abs() < 1e-3),
            "no phase current: {currents:?} A"
        );
        let coasting = rpm();
        assert!(coasting < turning, "{turning:.1} -> {coasting:.1} rpm");

        // Closed again, the master still asking for enable operation: nothing restarts.
        set_input(&m, input, false);
        for _ in 0..200 {
            s = cycle(ENABLE_OPERATION, VELOCITY).await;
            assert_eq!(s.sw & STATE_MASK, SWITCH_ON_DISABLED, "{:#06x}", s.sw);
        }
        assert!(rpm() <= coasting + 1.0, "not driven: {:.1} rpm", rpm());
        assert_eq!(s.digital_inputs & INTERLOCK, 0, "60FDh: interlock gone");
        if hwbb_display {
            assert_ne!(s.sw & HWBB_NOT_ACTIVE, 0, "bit 15 back to 1");
            assert_eq!(
                s.digital_inputs & (HWBB1_CLOSED | HWBB2_CLOSED),
                HWBB1_CLOSED | HWBB2_CLOSED
            );
        }
        // A new enable sequence: back to speed.
        for cw in enable_sequence(600) {
            s = cycle(cw, VELOCITY).await;
        }
        assert_eq!(s.sw & STATE_MASK, OPERATION_ENABLED, "{:#06x}", s.sw);
        assert!(
            (rpm() - 300.0).abs() < 10.0,
            "at speed again: {:.1} rpm",
            rpm()
        );
    });
}

#[test]
fn sigma_v_sd_hwbb_switches_off_and_shows_in_statusword_bit_15_and_60fdh() {
    withheld_in_profile_velocity("sigma-v-sd", Withheld::SafeTorqueOff, true, false);
}

#[test]
fn standard_safe_torque_off_switches_off_without_restart() {
    withheld_in_profile_velocity("standard", Withheld::SafeTorqueOff, false, true);
}

#[test]
fn standard_enable_input_switches_the_bridge_off_shows_interlock_and_never_restarts() {
    withheld_in_profile_velocity("standard", Withheld::EnableInput, false, true);
}

#[test]
fn sigma_v_sd_enable_input_switches_off_without_hwbb_or_interlock_display() {
    withheld_in_profile_velocity("sigma-v-sd", Withheld::EnableInput, true, false);
}
