//! Torque limits of every profile, end to end (ethercrab, DC SYNC0 at 1 ms): the rotor is held
//! still by the simulated load (a locked dynamometer), the drive runs cyclic synchronous torque
//! with a target torque 6071h far beyond the limits, and the actual torque 6077h must stay at
//! the tighter of the limits each manual names for the direction:
//!
//! | profile | positive | negative | manual |
//! |---|---|---|---|
//! | standard, gha-e, rse, sigma-v-sd | min(6072h, 60E0h) | min(6072h, 60E1h) | CiA402 §6.9; GHA-E §5.4 TQ "limited by 60E0h / 60E1h, 6072h max torque"; RSE 7.7; Σ-V-SD §6.6 |
//! | sdv3-e, osd-g-e | 60E0h | 60E1h | Table 6-2 (no 6072h) |
//!
//! All in ‰ of the rated torque (the vendors' 0.1 %). Where the manual's CST statusword has
//! bit 11 "internal limit active" (CiA402, the Σ-V-SD), it shows while the torque is limited;
//! the RSE's bit 11 shows the software position limits only (7.2) and stays clear.

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcGroup};
use tests_host::{block_on, master_for};

const CYCLE_NS: u64 = 1_000_000;
const CST: i8 = 10;
const INTERNAL_LIMIT: u16 = 1 << 11;
/// The limits set, ‰ of the rated torque: low enough that the drive's current limit is not
/// what limits.
const POSITIVE_LIMIT: i32 = 200;
const NEGATIVE_LIMIT: i32 = 120;
const MAX_TORQUE: i32 = 150;
/// The target: three times the largest limit.
const TARGET: i32 = 600;
/// The actual torque within this of its limit, ‰.
const TOLERANCE: i32 = 10;

/// Writes an integer object of whatever size the profile gives it.
async fn write(
    group: &DcGroup,
    md: &MainDevice<'_>,
    profile: &Profile,
    index: u16,
    value: i32,
) -> Result<(), String> {
    let sd = group.subdevice(md, 0).expect("drive");
    let len = profile.entry(index, 0).map(|e| e.byte_len());
    let result = match len {
        Some(2) => {
            let v = i16::try_from(value).map_err(|e| format!("{index:04X}h: {e}"))?;
            sd.sdo_write(index, 0, v).await
        }
        Some(4) => sd.sdo_write(index, 0, value).await,
        other => return Err(format!("{index:04X}h: {other:?} bytes")),
    };
    result.map_err(|e| format!("{index:04X}h = {value}: {e}"))
}

/// Reads the actual torque 6077h (INT, or a DINT where the profile has one).
async fn actual_torque(
    group: &DcGroup,
    md: &MainDevice<'_>,
    profile: &Profile,
) -> Result<i32, String> {
    let sd = group.subdevice(md, 0).expect("drive");
    let len = profile.entry(0x6077, 0).map(|e| e.byte_len());
    match len {
        Some(2) => sd.sdo_read::<i16>(0x6077, 0).await.map(i32::from),
        Some(4) => sd.sdo_read::<i32>(0x6077, 0).await,
        other => return Err(format!("6077h: {other:?} bytes")),
    }
    .map_err(|e| format!("6077h: {e}"))
}

async fn hold(m: &InProcess, md: &MainDevice<'_>, group: &DcGroup, cw: u16, n: usize) -> u16 {
    let mut sw = 0;
    for _ in 0..n {
        let inputs = vendor::exchange_dc_command(m, md, group, (cw, CST, 0), CYCLE_NS).await;
        sw = vendor::u16_at(&inputs, 0);
    }
    sw
}

/// The torque with target `target` after the limits settled, and the statusword.
async fn limited(
    (m, md, group): (&InProcess, &MainDevice<'_>, &DcGroup),
    profile: &Profile,
    target: i32,
) -> Result<(i32, u16), String> {
    write(group, md, profile, 0x6071, target).await?;
    let sw = hold(m, md, group, vendor::ENABLE_OPERATION, 100).await;
    Ok((actual_torque(group, md, profile).await?, sw))
}

async fn torque_limits(name: &str) -> Result<(), String> {
    let profile = od_gen::builtin(name).expect("profile");
    let has_6072 = profile.entry(0x6072, 0).is_some();
    // CiA402 and the Σ-V-SD show the limited torque on bit 11; the RSE's bit 11 is the
    // software position limit alone (7.2): clear here.
    let bit_11 = matches!(name, "standard" | "sigma-v-sd");
    let bit_11_clear = name == "rse";
    let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CST, CYCLE_NS).await;
    m.shared.segment().drives_mut()[0].servos[0]
        .plant
        .set_driven_speed(Some(0.0));
    write(&group, md, &profile, 0x60E0, POSITIVE_LIMIT).await?;
    write(&group, md, &profile, 0x60E1, NEGATIVE_LIMIT).await?;
    write(&group, md, &profile, 0x6071, 0).await?;
    for cw in vendor::enable_sequence(20) {
        hold(&m, md, &group, cw, 1).await;
    }
    let at = (&m, md, &group);
    let mut checks = vec![(TARGET, POSITIVE_LIMIT), (-TARGET, -NEGATIVE_LIMIT)];
    if has_6072 {
        checks.push((TARGET, i32::MAX));
    }
    for (k, (target, limit)) in checks.into_iter().enumerate() {
        let limit = if limit == i32::MAX {
            // 6072h below 60E0h: the tighter one limits.
            write(&group, md, &profile, 0x6072, MAX_TORQUE).await?;
            MAX_TORQUE
        } else {
            limit
        };
        let (torque, sw) = limited(at, &profile, target).await?;
        if (torque - limit).abs() > TOLERANCE {
            return Err(format!(
                "check {k}: 6071h = {target}: 6077h = {torque}, the limit is {limit}"
            ));
        }
        if bit_11 && sw & INTERNAL_LIMIT == 0 {
            return Err(format!("check {k}: bit 11 clear while limited: {sw:#06x}"));
        }
        if bit_11_clear && sw & INTERNAL_LIMIT != 0 {
            return Err(format!(
                "check {k}: bit 11 set by a torque limit: {sw:#06x}"
            ));
        }
    }
    // Within the limits the target is taken as it is.
    let (torque, sw) = limited(at, &profile, MAX_TORQUE / 2).await?;
    if (torque - MAX_TORQUE / 2).abs() > TOLERANCE {
        return Err(format!(
            "unlimited target {}: 6077h = {torque}",
            MAX_TORQUE / 2
        ));
    }
    if bit_11 && sw & INTERNAL_LIMIT != 0 {
        return Err(format!("bit 11 set without a limit: {sw:#06x}"));
    }
    Ok(())
}

fn check(name: &str) {
    block_on(async {
        if let Err(e) = torque_limits(name).await {
            panic!("{name}: {e}");
        }
    });
}

#[test]
fn standard_torque_limits() {
    check("standard");
}

#[test]
fn gha_e_torque_limits() {
    check("gha-e");
}

#[test]
fn rse_torque_limits() {
    check("rse");
}

#[test]
fn sdv3_e_torque_limits() {
    check("sdv3-e");
}

#[test]
fn sigma_v_sd_torque_limits() {
    check("sigma-v-sd");
}
