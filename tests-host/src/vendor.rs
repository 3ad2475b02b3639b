//! A master for the vendor-profile scenarios: one drive taken to OP in free run with the
//! profile's default PDOs and the SDO writes a scenario needs in PREOP, then cycles
//! phase-locked to the drive's free-run timer (every output is seen) over byte offsets of the
//! process images, which each scenario takes from its manual's default mapping.

use std::time::Duration;

use board_sim::inproc::InProcess;
use ethercrab::subdevice_group::{DcConfiguration, HasDc, Op, PreOp};
use ethercrab::{DcSync, DefaultLock, MainDevice, SubDeviceGroup};

/// A group of one drive in OP.
pub type Group = SubDeviceGroup<4, 64, DefaultLock, Op>;

/// A group of one drive in OP, synchronised to SYNC0 (a profile without free run).
pub type DcGroup = SubDeviceGroup<4, 64, DefaultLock, Op, HasDc>;

/// The SYNC0 start delay of [`into_op_dc`]: the drive's SYNC0 values appear in the inputs from
/// then on.
pub const SYNC0_START_DELAY: Duration = Duration::from_millis(10);

/// 1 ms cycles until SYNC0 runs after [`into_op_dc`] ([`SYNC0_START_DELAY`] and a margin).
pub const SYNC0_START_CYCLES: usize = 20;

/// The object of axis 1's `index` on axis `axis` (0-based): a two-axis drive's second axis has
/// its CiA402 objects at +800h (Σ-V-SD §2.4).
pub fn axis_object(index: u16, axis: usize) -> u16 {
    index + 0x800 * axis as u16
}

/// CiA402 controlwords of the enable sequence (Table 5): shutdown, switch on, enable operation.
pub const SHUTDOWN: u16 = 0x06;
/// Switch on.
pub const SWITCH_ON: u16 = 0x07;
/// Enable operation.
pub const ENABLE_OPERATION: u16 = 0x0F;

/// The controlwords that take a drive from Switch On Disabled to Operation Enabled: shutdown and
/// switch on 5 cycles each, then enable operation for `enable` cycles.
pub fn enable_sequence(enable: usize) -> impl Iterator<Item = u16> {
    std::iter::repeat_n(SHUTDOWN, 5)
        .chain(std::iter::repeat_n(SWITCH_ON, 5))
        .chain(std::iter::repeat_n(ENABLE_OPERATION, enable))
}

/// An SDO download of a scenario's set-up.
#[derive(Clone, Copy, Debug)]
pub enum Sdo {
    /// An INTEGER8.
    I8(u16, u8, i8),
    /// An UNSIGNED8.
    U8(u16, u8, u8),
    /// An INTEGER16.
    I16(u16, u8, i16),
    /// An UNSIGNED16.
    U16(u16, u8, u16),
    /// An INTEGER32.
    I32(u16, u8, i32),
    /// An UNSIGNED32.
    U32(u16, u8, u32),
}

/// A mapped object entry: index, subindex, bits.
pub type MappedEntry = (u16, u8, u8);

/// The SDO downloads that map `entries` (index, subindex, bit length) into PDO `pdo` and assign
/// it alone in `assign` (1C12h/1C13h): the assignment and the mapping cleared, the entries
/// written and counted, the PDO assigned (ETG.1020 §6.2.2: the order a master must follow).
pub fn remap(pdo: u16, assign: u16, entries: &[MappedEntry]) -> Vec<Sdo> {
    let mut sdos = vec![Sdo::U8(assign, 0, 0), Sdo::U8(pdo, 0, 0)];
    for (n, &(index, subindex, bits)) in (1u8..).zip(entries) {
        let mapping = u32::from(index) << 16 | u32::from(subindex) << 8 | u32::from(bits);
        sdos.push(Sdo::U32(pdo, n, mapping));
    }
    let count = u8::try_from(entries.len()).expect("at most 255 entries");
    sdos.extend([
        Sdo::U8(pdo, 0, count),
        Sdo::U16(assign, 1, pdo),
        Sdo::U8(assign, 0, 1),
    ]);
    sdos
}

/// Writes `sdo` to the first drive of `group` in PREOP.
/// Writes `sdo` to the drive `sd` (panics with the SDO on an abort: a scenario's set-up).
pub async fn write_to<S: std::ops::Deref<Target = ethercrab::SubDevice>>(
    sd: &ethercrab::SubDeviceRef<'_, S>,
    sdo: Sdo,
) {
    let r = match sdo {
        Sdo::I8(i, s, v) => sd.sdo_write(i, s, v).await,
        Sdo::U8(i, s, v) => sd.sdo_write(i, s, v).await,
        Sdo::I16(i, s, v) => sd.sdo_write(i, s, v).await,
        Sdo::U16(i, s, v) => sd.sdo_write(i, s, v).await,
        Sdo::I32(i, s, v) => sd.sdo_write(i, s, v).await,
        Sdo::U32(i, s, v) => sd.sdo_write(i, s, v).await,
    };
    r.unwrap_or_else(|e| panic!("SDO {sdo:?}: {e:?}"));
}

/// Writes `sdo` to every drive of the group.
async fn write(group: &SubDeviceGroup<4, 64, DefaultLock, PreOp>, md: &MainDevice<'_>, sdo: Sdo) {
    for sd in group.iter(md) {
        write_to(&sd, sdo).await;
    }
}

/// INIT → PREOP with `setup` written to every drive.
async fn preop(
    m: &InProcess,
    md: &MainDevice<'_>,
    setup: &[Sdo],
) -> SubDeviceGroup<4, 64, DefaultLock, PreOp> {
    let group = md
        .init_single_group::<4, 64>(m.shared.clock().now_fn())
        .await
        .expect("init");
    for &sdo in setup {
        write(&group, md, sdo).await;
    }
    group
}

/// INIT → OP in free run with `setup` written in PREOP.
pub async fn into_op(m: &InProcess, md: &MainDevice<'_>, setup: &[Sdo]) -> Group {
    preop(m, md, setup)
        .await
        .into_safe_op(md)
        .await
        .expect("SAFE-OP")
        .request_into_op(md)
        .await
        .expect("OP")
}

/// INIT → OP in DC mode (SYNC0 every `cycle_ns`, the system time synchronised first) with
/// `setup` written in PREOP.
pub async fn into_op_dc(
    m: &InProcess,
    md: &MainDevice<'_>,
    setup: &[Sdo],
    cycle_ns: u64,
) -> DcGroup {
    let mut group = preop(m, md, setup).await;
    for mut sd in group.iter_mut(md) {
        sd.set_dc_sync(DcSync::Sync0);
    }
    let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
    for _ in 0..100 {
        group.tx_rx_sync_system_time(md).await.expect("time");
        m.shared.advance(cycle_ns);
    }
    group
        .configure_dc_sync(
            md,
            DcConfiguration {
                start_delay: SYNC0_START_DELAY,
                sync0_period: Duration::from_nanos(cycle_ns),
                sync0_shift: Duration::ZERO,
            },
        )
        .await
        .expect("DC")
        .into_safe_op(md)
        .await
        .expect("SAFE-OP")
        .request_into_op(md)
        .await
        .expect("OP")
}

/// [`into_op_dc`] with the outputs 1600h mapping `outputs` and the inputs 1A00h mapping
/// `inputs` (index, subindex, bits each, in image order), assigned alone by 1C12h/1C13h.
pub async fn into_op_dc_mapped(
    m: &InProcess,
    md: &MainDevice<'_>,
    (outputs, inputs): (&[MappedEntry], &[MappedEntry]),
    cycle_ns: u64,
) -> DcGroup {
    into_op_dc(m, md, &mapping(outputs, inputs), cycle_ns).await
}

/// The SDO downloads that map `outputs` into 1600h and `inputs` into 1A00h (index, subindex,
/// bits each, in image order), each PDO assigned alone by 1C12h/1C13h.
pub fn mapping(outputs: &[MappedEntry], inputs: &[MappedEntry]) -> Vec<Sdo> {
    let mut setup = remap(0x1600, 0x1C12, outputs);
    setup.extend(remap(0x1A00, 0x1C13, inputs));
    setup
}

/// The position layout the per-profile scenarios share (outputs 6040h, 6060h, 607Ah; inputs
/// 6041h, 6064h): [`exchange_dc_command`]'s `(cw, mode, 607Ah)`, the statusword at byte 0 and
/// 6064h at byte 2 of the inputs.
pub const POSITION_MAPPING: ([MappedEntry; 3], [MappedEntry; 2]) = (
    [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)],
    [(0x6041, 0, 16), (0x6064, 0, 32)],
);

/// The velocity layout the per-profile scenarios share (outputs 6040h, 6060h, 60FFh; inputs
/// 6041h, 6061h, 606Ch): every manual lets 1600h/1A00h be remapped in PREOP.
pub const VELOCITY_MAPPING: ([MappedEntry; 3], [MappedEntry; 3]) = (
    [(0x6040, 0, 16), (0x6060, 0, 8), (0x60FF, 0, 32)],
    [(0x6041, 0, 16), (0x6061, 0, 8), (0x606C, 0, 32)],
);

/// The outputs of a scenario that commands every mode: 6040h, 6060h, 607Ah, 60FFh, 6071h, in
/// this order ([`Command::image`]).
pub const COMMAND_OUTPUTS: [MappedEntry; 5] = [
    (0x6040, 0, 16),
    (0x6060, 0, 8),
    (0x607A, 0, 32),
    (0x60FF, 0, 32),
    (0x6071, 0, 16),
];

/// The byte length of the [`COMMAND_OUTPUTS`] image.
pub const COMMAND_IMAGE_LEN: usize = 13;

/// One cycle's outputs in the [`COMMAND_OUTPUTS`] layout.
#[derive(Clone, Copy, Debug, Default)]
pub struct Command {
    /// 6040h.
    pub cw: u16,
    /// 6060h.
    pub mode: i8,
    /// 607Ah.
    pub position: i32,
    /// 60FFh.
    pub velocity: i32,
    /// 6071h.
    pub torque: i16,
}

impl Command {
    /// The output image: each object little-endian at its place in [`COMMAND_OUTPUTS`].
    pub fn image(&self) -> [u8; COMMAND_IMAGE_LEN] {
        let mut image = [0; COMMAND_IMAGE_LEN];
        image[0..2].copy_from_slice(&self.cw.to_le_bytes());
        image[2] = self.mode as u8;
        image[3..7].copy_from_slice(&self.position.to_le_bytes());
        image[7..11].copy_from_slice(&self.velocity.to_le_bytes());
        image[11..13].copy_from_slice(&self.torque.to_le_bytes());
        image
    }
}

/// INIT → OP in DC with [`VELOCITY_MAPPING`] of axis `axis` (its objects, and its PDOs 1600h and
/// 1A00h plus 10h per axis, assigned alone) and then `setup` written in PREOP, followed by
/// [`SYNC0_START_CYCLES`] cycles with controlword 0 and 6060h = `mode`, so that SYNC0 runs.
pub async fn into_op_dc_velocity(
    m: &InProcess,
    md: &MainDevice<'_>,
    (axis, setup): (usize, &[Sdo]),
    mode: i8,
    cycle_ns: u64,
) -> DcGroup {
    let on_axis = |entries: [MappedEntry; 3]| entries.map(|(i, s, b)| (axis_object(i, axis), s, b));
    let (outputs, inputs) = VELOCITY_MAPPING;
    let pdo_offset = 0x10 * axis as u16;
    let mut sdos = remap(0x1600 + pdo_offset, 0x1C12, &on_axis(outputs));
    sdos.extend(remap(0x1A00 + pdo_offset, 0x1C13, &on_axis(inputs)));
    sdos.extend_from_slice(setup);
    let group = into_op_dc(m, md, &sdos, cycle_ns).await;
    for _ in 0..SYNC0_START_CYCLES {
        exchange_dc_command(m, md, &group, (0, mode, 0), cycle_ns).await;
    }
    group
}

/// One DC cycle of `cycle_ns`: `outputs` (byte offset, little-endian bytes) written into the
/// output image, the frame exchanged, the clock advanced; the input image the drive sent back
/// (the values of the previous SYNC0).
pub async fn exchange_dc(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    outputs: &[(usize, &[u8])],
    cycle_ns: u64,
) -> Vec<u8> {
    let sd = group.subdevice(md, 0).expect("drive");
    put(&mut sd.outputs_raw_mut(), outputs);
    group.tx_rx_dc(md).await.expect("tx/rx");
    m.shared.advance(cycle_ns);
    let inputs = sd.inputs_raw().to_vec();
    inputs
}

/// [`exchange_dc`] for an output image that starts with the controlword 6040h, the mode of
/// operation 6060h and one 32-bit value (e.g. 607Ah or 60FFh), in that order: `(cw, mode,
/// value)`.
pub async fn exchange_dc_command(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    (cw, mode, value): (u16, i8, i32),
    cycle_ns: u64,
) -> Vec<u8> {
    let [c0, c1] = cw.to_le_bytes();
    let [v0, v1, v2, v3] = value.to_le_bytes();
    let image = [c0, c1, mode as u8, v0, v1, v2, v3];
    exchange_dc(m, md, group, &[(0, &image)], cycle_ns).await
}

/// Drive 0 of a DC group, commanded cycle by cycle with [`exchange_dc_command`] (an output
/// image that starts with 6040h, 6060h and one 32-bit value).
pub struct DcDrive<'a> {
    pub m: &'a InProcess,
    pub md: &'a MainDevice<'a>,
    pub group: DcGroup,
    pub cycle_ns: u64,
}

impl DcDrive<'_> {
    /// `n` cycles of `command` (controlword, mode, 32-bit value); the input image of the last
    /// one (empty when `n` is 0).
    pub async fn hold(&self, command: (u16, i8, i32), n: usize) -> Vec<u8> {
        let mut inputs = Vec::new();
        for _ in 0..n {
            inputs =
                exchange_dc_command(self.m, self.md, &self.group, command, self.cycle_ns).await;
        }
        inputs
    }

    /// [`Self::hold`], the last statusword (the image's first word; 0 when `n` is 0).
    pub async fn hold_statusword(&self, command: (u16, i8, i32), n: usize) -> u16 {
        let inputs = self.hold(command, n).await;
        if inputs.len() < 2 {
            return 0;
        }
        u16_at(&inputs, 0)
    }
}

/// One cycle of `cycle_ns` phase-locked to the drive's free-run timer: `outputs` (byte offset,
/// little-endian bytes) written into the output image, the frame exchanged; the input image the
/// drive sent back.
pub async fn exchange(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &Group,
    outputs: &[(usize, &[u8])],
    cycle_ns: u64,
) -> Vec<u8> {
    let sd = group.subdevice(md, 0).expect("drive");
    put(&mut sd.outputs_raw_mut(), outputs);
    let since = m.shared.clock().now();
    group.tx_rx(md).await.expect("tx/rx");
    m.shared.finish_cycle(since, cycle_ns);
    let inputs = sd.inputs_raw().to_vec();
    inputs
}

/// Writes `outputs` (byte offset, little-endian bytes) into an output image.
fn put(image: &mut [u8], outputs: &[(usize, &[u8])]) {
    for (at, bytes) in outputs {
        image[*at..*at + bytes.len()].copy_from_slice(bytes);
    }
}

/// Heats the power stage of the first drive's axis `axis` 10 °C over its protection's limit
/// (the drive over-temperature fault trips after its confirmation time).
pub fn overheat_power_stage(m: &InProcess, axis: usize) {
    let mut segment = m.shared.segment();
    let servo = &mut segment.drives_mut()[0].servos[axis];
    let level = servo.axis.config().protection.drive_over_temperature_c;
    servo.plant.set_drive_temperature(f64::from(level) + 10.0);
}

/// Puts the two touch-probe sensors of the first drive's axis `axis` at `probes`: each input is
/// active between its two angles, revolutions.
pub fn place_probe_sensors(m: &InProcess, axis: usize, probes: [(f64, f64); 2]) {
    let turn = std::f64::consts::TAU;
    m.shared.segment().drives_mut()[0].servos[axis]
        .plant
        .set_switches(board_sim::plant::SwitchParams {
            probes: probes.map(|(a, b)| Some((a * turn, b * turn))),
            ..Default::default()
        });
}

/// The little-endian u16 at byte `at` of an image.
pub fn u16_at(image: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([image[at], image[at + 1]])
}

/// The little-endian i32 at byte `at` of an image.
pub fn i32_at(image: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([image[at], image[at + 1], image[at + 2], image[at + 3]])
}

/// The simulated motor of the first drive: its speed, rpm, and angle, revolutions.
pub fn motor(m: &InProcess) -> (f64, f64) {
    motor_of_axis(m, 0)
}

/// [`motor`] of axis `axis` (0 = the first).
pub fn motor_of_axis(m: &InProcess, axis: usize) -> (f64, f64) {
    let segment = m.shared.segment();
    let plant = &segment.drives()[0].servos[axis].plant;
    (
        plant.mech_speed_rad_s() / std::f64::consts::TAU * 60.0,
        plant.mech_angle_rad() / std::f64::consts::TAU,
    )
}
