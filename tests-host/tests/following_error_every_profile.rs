//! The following error of every profile, end to end (ethercrab, DC SYNC0 at 1 ms; 6040h, 6060h,
//! 607Ah / 6041h, 6061h, 6064h mapped): in cyclic synchronous position the rotor is held still
//! by the simulated load (a locked dynamometer) while the target runs away at 1 rev/s, so the
//! deviation passes the following error window 6065h (0.2 rev, in the profile's position unit;
//! 6066h = 10 ms where the profile has it). What each manual says happens:
//!
//! | profile | reaction | manual |
//! |---|---|---|
//! | standard | Fault, 603Fh 8611h "following error" | CiA402 §6.4, CiA 402 error codes |
//! | rse | Fault AL.240 "position deviation too large", statusword bit 13 | 7.8 |
//! | sdv3-e, osd-g-e | Fault OF | Table 5-1 |
//! | sigma-v-sd | statusword bit 13 only, no alarm stated | §6.8 |
//! | gha-e | statusword bit 13 only; with the default 6065h = 0 no check at all | §5.4 (6065h "0; exceeding sets bit 13"), §6.7 |

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcGroup, Sdo};
use tests_host::{block_on, cia402, emcy, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSP: i8 = 8;
const FOLLOWING_ERROR: u16 = 1 << 13;
const WINDOW_REV: f64 = 0.2;
/// The target runs away at 1 rev/s for this long: 0.5 rev, well past the window.
const RUN_CYCLES: usize = 500;

/// What the manual says a following error does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reaction {
    /// Fault with the profile's alarm for it.
    Fault,
    /// Statusword bit 13, the drive stays in Operation Enabled.
    Bit13,
    /// Nothing (the check is off).
    None,
}

struct Run<'a> {
    m: &'a InProcess,
    md: &'a MainDevice<'a>,
    group: DcGroup,
}

impl Run<'_> {
    async fn cycle(&self, cw: u16, target: i32) -> u16 {
        let inputs =
            vendor::exchange_dc_command(self.m, self.md, &self.group, (cw, CSP, target), CYCLE_NS)
                .await;
        vendor::u16_at(&inputs, 0)
    }
}

/// The drive of `name` with `setup`, the rotor locked, the target running away; whether it
/// ended as `expected` says.
async fn run_away(
    name: &str,
    profile: &Profile,
    setup: &[Sdo],
    expected: Reaction,
) -> Result<(), String> {
    let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let mapping = (
        [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)],
        [(0x6041, 0, 16), (0x6061, 0, 8), (0x6064, 0, 32)],
    );
    let mut sdos = vendor::remap(0x1600, 0x1C12, &mapping.0);
    sdos.extend(vendor::remap(0x1A00, 0x1C13, &mapping.1));
    sdos.extend_from_slice(setup);
    let group = vendor::into_op_dc(&m, md, &sdos, CYCLE_NS).await;
    let run = Run { m: &m, md, group };
    // SYNC0 starts after its start delay.
    for _ in 0..vendor::SYNC0_START_CYCLES {
        run.cycle(0, 0).await;
    }
    let mut sw = 0;
    for cw in vendor::enable_sequence(30) {
        sw = run.cycle(cw, 0).await;
    }
    if !cia402::is(sw, cia402::OPERATION_ENABLED) {
        return Err(format!("not enabled: {sw:#06x}"));
    }
    while emcy::read(md, profile.sm.mailbox_in.start).await?.is_some() {}
    m.shared.segment().drives_mut()[0].servos[0]
        .plant
        .set_driven_speed(Some(0.0));
    let per_cycle = units::COUNTS_PER_REV / units::increments_per_unit(profile) / 1000.0;
    let mut bit_13 = false;
    for k in 0..RUN_CYCLES {
        sw = run
            .cycle(vendor::ENABLE_OPERATION, (k as f64 * per_cycle) as i32)
            .await;
        bit_13 |= sw & FOLLOWING_ERROR != 0;
        if cia402::is(sw, cia402::FAULT) {
            break;
        }
    }
    match expected {
        Reaction::Fault => {
            if !cia402::is(sw, cia402::FAULT) {
                return Err(format!("no Fault: {sw:#06x}"));
            }
            let index = od_gen::model::MOTOR_FAULT_NAMES
                .iter()
                .position(|k| *k == "following_error")
                .expect("following_error");
            let code = profile.motor_faults[index].error_code;
            let sd = run.group.subdevice(md, 0).expect("drive");
            let error: u16 = sd.sdo_read(0x603F, 0).await.map_err(|e| e.to_string())?;
            if error != code {
                return Err(format!("603Fh {error:04X}h, expected {code:04X}h"));
            }
        }
        Reaction::Bit13 | Reaction::None => {
            if !cia402::is(sw, cia402::OPERATION_ENABLED) {
                return Err(format!("left Operation Enabled: {sw:#06x}"));
            }
            let want = expected == Reaction::Bit13;
            if (sw & FOLLOWING_ERROR != 0) != want || bit_13 != want {
                return Err(format!("bit 13 {bit_13}, expected {want}: {sw:#06x}"));
            }
        }
    }
    Ok(())
}

/// 6065h = 0.2 rev in the profile's position unit, 6066h = 10 ms where it has one.
fn window(profile: &Profile) -> Vec<Sdo> {
    let units = WINDOW_REV * units::COUNTS_PER_REV / units::increments_per_unit(profile);
    let mut sdos = vec![Sdo::U32(0x6065, 0, units.round() as u32)];
    if profile.entry(0x6066, 0).is_some() {
        sdos.push(Sdo::U16(0x6066, 0, 10));
    }
    sdos
}

fn check(name: &str, cases: &[(bool, Reaction)]) {
    let profile = od_gen::builtin(name).expect("profile");
    block_on(async {
        for &(set_window, expected) in cases {
            let setup = if set_window {
                window(&profile)
            } else {
                Vec::new()
            };
            if let Err(e) = run_away(name, &profile, &setup, expected).await {
                panic!("{name} (window set: {set_window}, {expected:?}): {e}");
            }
        }
    });
}

#[test]
fn standard_following_error_is_a_fault() {
    check("standard", &[(true, Reaction::Fault)]);
}

#[test]
fn rse_following_error_is_al_240() {
    check("rse", &[(true, Reaction::Fault)]);
}

#[test]
fn sdv3_e_following_error_is_of() {
    check("sdv3-e", &[(true, Reaction::Fault)]);
}

#[test]
fn sigma_v_sd_following_error_is_bit_13_only() {
    check("sigma-v-sd", &[(true, Reaction::Bit13)]);
}

#[test]
fn gha_e_following_error_is_bit_13_only_and_off_with_window_0() {
    check("gha-e", &[(false, Reaction::None), (true, Reaction::Bit13)]);
}
