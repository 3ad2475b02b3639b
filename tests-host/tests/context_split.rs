//! The SYNC0 path does not wait for the mailbox: the mailbox side of the slave works on its own
//! copy of the object dictionary, so a process-data cycle can run on the core while an SDO
//! transfer is half done (on a board: SYNC0 preempting the ESC-event context), and both the
//! transfer and the process data come out right.
//!
//! The simulated drive is told to run a cycle inside every mailbox round that leaves a
//! segmented upload unfinished (`SimDrive::cycle_during_mailbox_transfer`); the master reads a
//! 1000-byte DOMAIN (2FF0h, several segments) while it runs the drive in OP. The SDO frames are
//! written by hand (ETG.1000.4 mailbox header, ETG.1000.6 SDO): ethercrab 0.7.1 fails on
//! segmented uploads of this length with `Wire(InvalidValue)`.

use board_sim::inproc::InProcess;
use ethercat_slave::od::DomainStore;
use ethercrab::subdevice_group::Op;
use ethercrab::{Command, DefaultLock, MainDevice, SubDeviceGroup};
use hal::esc::regs;
use tests_host::{block_on, master, FIRST_STATION};

/// Mailbox SMs of the standard profile (`[sm]` of standard.toml): SM0 out, SM1 in.
const MAILBOX_OUT: u16 = 0x1000;
const MAILBOX_IN: u16 = 0x1100;
const MAILBOX_LEN: usize = 256;
/// Mailbox header (ETG.1000.4 §5.6): length, address, channel/priority, type/counter.
const MBX_HEADER_LEN: usize = 6;
/// Mailbox type CoE; counter 0 = "not used" (no duplicate detection).
const MBX_TYPE_COE: u8 = 0x03;
/// CoE header (ETG.1000.6 §5.6.1): service in bits 12..15: 2 = SDO request, 3 = SDO response.
const COE_SDO_REQUEST: u16 = 2 << 12;
const COE_SDO_RESPONSE: u16 = 3 << 12;
/// SDO command specifiers (CiA 301 / ETG.1000.6 §5.6.2).
const CCS_UPLOAD_INIT: u8 = 2 << 5;
const CCS_UPLOAD_SEGMENT: u8 = 3 << 5;
const SCS_UPLOAD_INIT: u8 = 2 << 5;
const SCS_MASK: u8 = 0xE0;
const TOGGLE: u8 = 1 << 4;
const LAST_SEGMENT: u8 = 1 << 0;
/// SM status bit 3: mailbox full (ESC datasheet, 0x0805 + 8·n).
const SM_MAILBOX_FULL: u8 = 1 << 3;

/// Free-run cycle of the master, ns.
const CYCLE_NS: u64 = 1_000_000;
/// The test DOMAIN of the standard profile (2FF0h:00, domain id 0).
const TEST_DOMAIN: u16 = 0x2FF0;
const DOMAIN_ID: u8 = 0;
/// Longer than one mailbox (256 bytes): a segmented upload.
const DOMAIN_LEN: usize = 1000;
/// Controlwords of the power-up sequence (CiA402: shutdown, switch on, enable operation).
const POWER_UP: [u16; 3] = [0x06, 0x07, 0x0F];
/// Statusword bits that identify Operation Enabled (CiA402 Table 30).
const STATE_MASK: u16 = 0x006F;
const OPERATION_ENABLED: u16 = 0x0027;

fn pattern(i: usize) -> u8 {
    (i * 7 + 3) as u8
}

/// The standard drive taken to OP (free run) as a group.
async fn into_op(md: &MainDevice<'_>, m: &InProcess) -> SubDeviceGroup<4, 64, DefaultLock, Op> {
    let group = md
        .init_single_group::<4, 64>(m.shared.clock().now_fn())
        .await
        .expect("PRE-OP");
    let group = group.into_safe_op(md).await.expect("SAFE-OP");
    group.request_into_op(md).await.expect("OP")
}

/// Writes one SDO request (8 bytes after the CoE header) into SM0.
async fn send_sdo(md: &MainDevice<'_>, sdo: [u8; 8]) {
    let mut frame = [0u8; MAILBOX_LEN];
    let payload = 2 + sdo.len();
    frame[0..2].copy_from_slice(&(payload as u16).to_le_bytes());
    frame[5] = MBX_TYPE_COE;
    frame[6..8].copy_from_slice(&COE_SDO_REQUEST.to_le_bytes());
    frame[8..16].copy_from_slice(&sdo);
    Command::fpwr(FIRST_STATION, MAILBOX_OUT)
        .send(md, &frame[..])
        .await
        .expect("SM0 write");
}

/// Reads SM1 once it is full; returns the SDO bytes after the CoE header.
async fn receive_sdo(md: &MainDevice<'_>, m: &InProcess) -> Vec<u8> {
    for _ in 0..1000 {
        let status: u8 = Command::fprd(FIRST_STATION, regs::sm(1).addr + regs::sm_offset::STATUS)
            .receive(md)
            .await
            .expect("SM1 status");
        if status & SM_MAILBOX_FULL != 0 {
            let frame = Command::fprd(FIRST_STATION, MAILBOX_IN)
                .receive_slice(md, MAILBOX_LEN as u16)
                .await
                .expect("SM1 read");
            let len = usize::from(u16::from_le_bytes([frame[0], frame[1]]));
            let coe = u16::from_le_bytes([frame[6], frame[7]]);
            assert_eq!(coe & 0xF000, COE_SDO_RESPONSE, "an SDO response");
            return frame[MBX_HEADER_LEN + 2..MBX_HEADER_LEN + len].to_vec();
        }
        m.shared.advance(10_000);
    }
    panic!("no SDO response");
}

#[test]
fn cycles_run_while_a_segmented_upload_is_half_done() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        {
            let mut seg = m.shared.segment();
            let drive = &mut seg.drives_mut()[0];
            let data: Vec<u8> = (0..DOMAIN_LEN).map(pattern).collect();
            let domains = &mut drive.domains;
            domains
                .begin_write(DOMAIN_ID, DOMAIN_LEN as u32)
                .expect("begin");
            domains.write(DOMAIN_ID, 0, &data).expect("write");
            domains
                .commit(DOMAIN_ID, DOMAIN_LEN as u32)
                .expect("commit");
            drive.cycle_during_mailbox_transfer = true;
        }
        let group = into_op(md, &m).await;
        let sd = group.subdevice(md, 0).expect("drive");

        // Process data: enable the drive and keep exchanging (controlword at byte 0,
        // statusword at byte 0 of the default mappings).
        let pdo = async {
            let mut statusword = 0u16;
            for k in 0..60usize {
                let cw = POWER_UP[(k / 10).min(POWER_UP.len() - 1)];
                sd.outputs_raw_mut()[0..2].copy_from_slice(&cw.to_le_bytes());
                let r = group.tx_rx(md).await.expect("tx/rx");
                assert_eq!(r.working_counter, 3, "cycle {k}");
                m.shared.advance(CYCLE_NS);
                let inputs = sd.inputs_raw();
                statusword = u16::from_le_bytes([inputs[0], inputs[1]]);
                tokio::task::yield_now().await;
            }
            statusword
        };
        let upload = async {
            let mut reads = Vec::new();
            for _ in 0..3 {
                let [i0, i1] = TEST_DOMAIN.to_le_bytes();
                send_sdo(md, [CCS_UPLOAD_INIT, i0, i1, 0, 0, 0, 0, 0]).await;
                let init = receive_sdo(md, &m).await;
                assert_eq!(init[0] & SCS_MASK, SCS_UPLOAD_INIT, "upload init response");
                let size = u32::from_le_bytes([init[4], init[5], init[6], init[7]]) as usize;
                assert_eq!(size, DOMAIN_LEN);
                let mut data = init[8..].to_vec();
                let mut toggle = 0u8;
                while data.len() < size {
                    send_sdo(md, [CCS_UPLOAD_SEGMENT | toggle, 0, 0, 0, 0, 0, 0, 0]).await;
                    let seg = receive_sdo(md, &m).await;
                    assert_eq!(seg[0] & TOGGLE, toggle, "segment toggle");
                    data.extend_from_slice(&seg[1..]);
                    toggle ^= TOGGLE;
                    if seg[0] & LAST_SEGMENT != 0 {
                        break;
                    }
                }
                data.truncate(size);
                reads.push(data);
                tokio::task::yield_now().await;
            }
            reads
        };
        let (statusword, reads) = tokio::join!(pdo, upload);

        for (n, data) in reads.iter().enumerate() {
            for (i, &b) in data.iter().enumerate() {
                assert_eq!(b, pattern(i), "read {n}, byte {i}");
            }
        }
        assert_eq!(
            statusword & STATE_MASK,
            OPERATION_ENABLED,
            "the process data drove the drive to Operation Enabled meanwhile"
        );
        let inside = m.shared.segment().drives()[0].cycles_during_mailbox_transfer;
        // Each read leaves the transfer open after its first rounds (1000 bytes in segments of
        // at most the mailbox payload).
        assert!(
            inside >= 3,
            "cycles ran while an upload was half done: {inside}"
        );
    });
}

/// Statusword 6041h:00.
const STATUSWORD: u16 = 0x6041;
/// CiA402 states the power-up sequence passes (statusword & [`STATE_MASK`]): ready to switch
/// on, switched on, operation enabled (CiA402 Table 30).
const POWER_UP_STATES: [u16; 3] = [0x0021, 0x0023, OPERATION_ENABLED];

/// The mailbox side copies the OD RAM only for a round that answers a request (the rounds the
/// process-data cycles start copy nothing): an SDO upload after many such rounds still reads
/// the value of the moment it is answered, not of the last request.
#[test]
fn an_upload_after_rounds_without_a_request_reads_the_present_value() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op(md, &m).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let mut seen = Vec::new();
        for cw in POWER_UP {
            let mut statusword = 0u16;
            for _ in 0..10 {
                sd.outputs_raw_mut()[0..2].copy_from_slice(&cw.to_le_bytes());
                group.tx_rx(md).await.expect("tx/rx");
                m.shared.advance(CYCLE_NS);
                let inputs = sd.inputs_raw();
                statusword = u16::from_le_bytes([inputs[0], inputs[1]]);
            }
            let [i0, i1] = STATUSWORD.to_le_bytes();
            send_sdo(md, [CCS_UPLOAD_INIT, i0, i1, 0, 0, 0, 0, 0]).await;
            let response = receive_sdo(md, &m).await;
            assert_eq!(response[0] & SCS_MASK, SCS_UPLOAD_INIT, "upload response");
            let uploaded = u16::from_le_bytes([response[4], response[5]]);
            seen.push((statusword & STATE_MASK, uploaded & STATE_MASK));
        }
        let expected: Vec<(u16, u16)> = POWER_UP_STATES.iter().map(|&s| (s, s)).collect();
        assert_eq!(seen, expected, "(process data, SDO upload) after each step");
    });
}
