//! Shared helpers of the end-to-end tests: a single-threaded runtime for the in-process
//! ethercrab master, the expected identity from the profile, the SOEM (pysoem) harness and a raw
//! mailbox SDO client for downloads longer than ethercrab's 4 bytes.

pub mod cia402;
pub mod csp;
pub mod emcy;
pub mod io_module;
pub mod raw_sdo;
pub mod session;
pub mod soem;
pub mod stops;
pub mod units;
pub mod vendor;

use std::future::Future;
use std::time::Duration;

use board_sim::inproc::{InMemoryTxRx, InProcess};
use board_sim::{Segment, SimDevice};
use ethercrab::subdevice_group::{DcConfiguration, HasDc, PreOp, SafeOp};
use ethercrab::{
    Command, DcSync, DefaultLock, MainDevice, MainDeviceConfig, SubDeviceGroup, Timeouts,
};
use hal::esc::regs;

/// Station address ethercrab gives the first drive.
pub const FIRST_STATION: u16 = 0x1000;

/// An ethercrab master connected in process to one simulated drive of the standard profile
/// (spawn the returned transport with `tokio::task::spawn_local` before using the master).
pub fn master() -> (InProcess, InMemoryTxRx) {
    master_for(Segment::new("standard", 1).expect("standard profile"))
}

/// An ethercrab master connected in process to `segment` (drives, or any other simulated
/// device). The wall-clock timeouts are generous
/// so that a loaded CI machine does not time out; the simulated drives answer at once.
pub fn master_for<D: SimDevice>(segment: Segment<D>) -> (InProcess<D>, InMemoryTxRx<D>) {
    const GENEROUS: Duration = Duration::from_secs(2);
    InProcess::connect(
        segment,
        Timeouts {
            pdu: Duration::from_millis(500),
            state_transition: GENEROUS,
            eeprom: GENEROUS,
            mailbox_response: GENEROUS,
            ..Timeouts::default()
        },
        MainDeviceConfig {
            dc_static_sync_iterations: 100,
            ..MainDeviceConfig::default()
        },
    )
}

/// AL status and AL status code of the first drive, read by the master.
pub async fn al_status(md: &MainDevice<'_>) -> (u16, u16) {
    let status: u16 = Command::fprd(FIRST_STATION, regs::AL_STATUS.addr)
        .receive(md)
        .await
        .expect("AL status");
    let code: u16 = Command::fprd(FIRST_STATION, regs::AL_STATUS_CODE.addr)
        .receive(md)
        .await
        .expect("AL status code");
    (status, code)
}

/// Runs `f` on a current-thread tokio runtime with a `LocalSet` (the in-process transport is
/// spawned locally).
pub fn block_on<F: Future>(f: F) -> F::Output {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .expect("tokio runtime"); // test harness only
    tokio::task::LocalSet::new().block_on(&rt, f)
}

/// Identity words of a built-in profile as its SII carries them: (vendor, product, revision, serial)
/// and the device name.
pub fn expected_identity(profile: &str) -> ((u32, u32, u32, u32), String) {
    let sii = od_gen::builtin(profile)
        .expect("built-in profile")
        .sii_image();
    let word = |w: usize| u32::from_le_bytes(sii[w * 2..w * 2 + 4].try_into().expect("4 bytes"));
    let identity = (word(0x08), word(0x0A), word(0x0C), word(0x0E));
    (identity, device_name(&sii))
}

/// Device name from the SII: the string the General category's order index points at, found
/// by walking the categories (independently of od-gen's writer).
fn device_name(sii: &[u8]) -> String {
    const FIRST_CATEGORY_WORD: usize = 0x40;
    const STRINGS: u16 = 10;
    const GENERAL: u16 = 30;
    const END: u16 = 0xFFFF;
    let mut strings: Vec<String> = Vec::new();
    let mut order_idx = 0usize;
    let mut at = FIRST_CATEGORY_WORD * 2;
    while at + 4 <= sii.len() {
        let kind = u16::from_le_bytes([sii[at], sii[at + 1]]);
        let words = u16::from_le_bytes([sii[at + 2], sii[at + 3]]) as usize;
        let data = &sii[at + 4..(at + 4 + words * 2).min(sii.len())];
        match kind {
            END => break,
            STRINGS => {
                let mut p = 1;
                for _ in 0..data.first().copied().unwrap_or(0) {
                    let len = data[p] as usize;
                    strings.push(String::from_utf8_lossy(&data[p + 1..p + 1 + len]).into_owned());
                    p += 1 + len;
                }
            }
            GENERAL => order_idx = data.get(2).copied().unwrap_or(0) as usize,
            _ => {}
        }
        at += 4 + words * 2;
    }
    strings
        .get(order_idx.wrapping_sub(1))
        .cloned()
        .unwrap_or_default()
}

/// PREOP → SAFEOP with DC SYNC0 at `cycle_ns` for every drive of `group`, as a DC master does
/// it: PDI in PREOP, 100 cycles of system-time synchronisation, SYNC0 starting 10 cycles later;
/// `Err` is the first drive's AL status and code when SAFEOP is refused.
pub async fn dc_safe_op<const N: usize, const P: usize>(
    m: &InProcess,
    md: &MainDevice<'_>,
    mut group: SubDeviceGroup<N, P, DefaultLock, PreOp>,
    cycle_ns: u64,
) -> Result<SubDeviceGroup<N, P, DefaultLock, SafeOp, HasDc>, (u16, u16)> {
    for mut sd in group.iter_mut(md) {
        sd.set_dc_sync(DcSync::Sync0);
    }
    let group = group.into_pre_op_pdi(md).await.expect("PRE-OP with PDI");
    for _ in 0..100 {
        group.tx_rx_sync_system_time(md).await.expect("time sync");
        m.shared.advance(cycle_ns);
    }
    let group = group
        .configure_dc_sync(
            md,
            DcConfiguration {
                start_delay: Duration::from_nanos(cycle_ns * 10),
                sync0_period: Duration::from_nanos(cycle_ns),
                sync0_shift: Duration::ZERO,
            },
        )
        .await
        .expect("DC configuration");
    match group.into_safe_op(md).await {
        Ok(g) => Ok(g),
        Err(_) => Err(al_status(md).await),
    }
}
