//! A master that runs a drive in cyclic synchronous position, free run, over a default mapping
//! that starts with controlword 6040h and target position 607Ah (outputs) and statusword 6041h
//! and position actual value 6064h (inputs): the Σ-V-SD's 1600h/1A00h. The ethercrab group is
//! sized for one drive.

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;

/// A group of one drive in OP.
pub type OpGroup = crate::vendor::Group;

/// Simulated time per cycle (free run).
pub const CYCLE_NS: u64 = 1_000_000;
/// 6060h "modes of operation" (CiA402).
const MODES_OF_OPERATION: u16 = 0x6060;

/// INIT → OP in free run, with 6060h = `mode` written by SDO in PREOP.
pub async fn into_op_with_mode(m: &InProcess, md: &MainDevice<'_>, mode: i8) -> OpGroup {
    crate::vendor::into_op(
        m,
        md,
        &[crate::vendor::Sdo::I8(MODES_OF_OPERATION, 0, mode)],
    )
    .await
}

/// One cycle with controlword `cw` and target position `target`; returns the statusword and
/// the position actual value the drive sent back.
pub async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &OpGroup,
    cw: u16,
    target: i32,
) -> (u16, i32) {
    let sd = group.subdevice(md, 0).expect("drive");
    {
        let mut out = sd.outputs_raw_mut();
        out[0..2].copy_from_slice(&cw.to_le_bytes());
        out[2..6].copy_from_slice(&target.to_le_bytes());
    }
    group.tx_rx(md).await.expect("tx/rx");
    m.shared.advance(CYCLE_NS);
    let inp = sd.inputs_raw();
    (
        u16::from_le_bytes([inp[0], inp[1]]),
        i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
    )
}

/// Cycles through `cws`, each holding the position the drive reported last (no motion asked);
/// returns the last statusword and the masked state (`sw & state_mask`) after each change.
pub async fn hold_through(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &OpGroup,
    cws: impl IntoIterator<Item = u16>,
    state_mask: u16,
) -> (u16, Vec<u16>) {
    let (mut sw, mut position) = (0, 0);
    let mut states = Vec::new();
    for cw in cws {
        (sw, position) = cycle(m, md, group, cw, position).await;
        if states.last() != Some(&(sw & state_mask)) {
            states.push(sw & state_mask);
        }
    }
    (sw, states)
}

/// What the drive sent back in one [`phase_locked`] cycle, and the plant's true motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// 6041h.
    pub statusword: u16,
    /// 6064h.
    pub position: i32,
    /// 6061h.
    pub mode_display: i8,
    /// The simulated motor's true speed, rpm.
    pub rpm: f64,
    /// The simulated motor's true angle, revolutions.
    pub revolutions: f64,
}

/// One cycle with controlword `cw`, target position `target` and 6060h `mode` over the default
/// mapping (6040h, 607Ah, 6060h / 6041h, 6064h, 6061h). The frame's wire time is part of the
/// cycle, so the master stays in phase with the drive's free-run timer (a drifting master would
/// now and then send nothing new in a cycle).
pub async fn phase_locked(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &OpGroup,
    cw: u16,
    target: i32,
    mode: i8,
) -> Sample {
    let sd = group.subdevice(md, 0).expect("drive");
    {
        let mut out = sd.outputs_raw_mut();
        out[0..2].copy_from_slice(&cw.to_le_bytes());
        out[2..6].copy_from_slice(&target.to_le_bytes());
        out[6] = mode as u8;
    }
    let since = m.shared.clock().now();
    group.tx_rx(md).await.expect("tx/rx");
    m.shared.finish_cycle(since, CYCLE_NS);
    let inp = sd.inputs_raw();
    let segment = m.shared.segment();
    let plant = &segment.drives()[0].servos[0].plant;
    Sample {
        statusword: u16::from_le_bytes([inp[0], inp[1]]),
        position: i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
        mode_display: inp[6] as i8,
        rpm: plant.mech_speed_rad_s() / std::f64::consts::TAU * 60.0,
        revolutions: plant.mech_angle_rad() / std::f64::consts::TAU,
    }
}
