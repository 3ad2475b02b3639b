//! Emergencies against ethercrab (in process): ethercrab 0.7 asserts that the answer to an SDO
//! request is not an emergency (`assert_ne!(.., CoeService::Emergency)` in
//! `mailbox_write_read`), so the drive must never let an emergency stand where ethercrab expects
//! its SDO response. The mailbox queue posts emergencies only into an idle mailbox and
//! withdraws an unread one when a request arrives behind it.

use std::cell::Cell;
use std::rc::Rc;

use ethercrab::Command;
use tests_host::master;
use tests_host::{block_on, expected_identity};

const FIRST_STATION: u16 = 0x1000;
const SM2_LENGTH: u16 = 0x0812;
const SM2_ACTIVATE: u16 = 0x0816;
const AL_CONTROL: u16 = 0x0120;
const AL_STATUS: u16 = 0x0130;
/// CiA 301 Table 21 class 0x81xx (communication) → 1001h bits 0 and 4.
const COMM_ERROR: u16 = 0x8130;

#[test]
fn errors_raised_while_ethercrab_reads_sdos_never_answer_an_sdo_request() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let sd = group.iter(md).next().expect("one drive");
        let ((vendor, ..), _) = expected_identity("standard");

        // Between any two frames, raise and clear an error: each raise queues an emergency,
        // each clear the "error reset" emergency.
        let stop = Rc::new(Cell::new(false));
        let queued = Rc::new(Cell::new(0u32));
        let raiser = {
            let (shared, stop, queued) = (m.shared.clone(), stop.clone(), queued.clone());
            tokio::task::spawn_local(async move {
                let mut i = 0u8;
                while !stop.get() {
                    {
                        let mut seg = shared.segment();
                        let now = seg.now_ns();
                        let slave = &mut seg.drives_mut()[0].slave;
                        if i % 2 == 0 {
                            if slave
                                .report_error(COMM_ERROR, 0, [i, 0, 0, 0, 0], None, now)
                                .is_ok()
                            {
                                queued.set(queued.get() + 1);
                            }
                        } else if slave.clear_error(COMM_ERROR).is_ok() {
                            queued.set(queued.get() + 1);
                        }
                    }
                    i = i.wrapping_add(1);
                    tokio::task::yield_now().await;
                }
            })
        };
        for k in 0..300 {
            // ethercrab panics if an emergency comes back as the answer.
            let v = sd
                .sdo_read::<u32>(0x1018, 1)
                .await
                .unwrap_or_else(|e| panic!("SDO read {k}: {e:?}"));
            assert_eq!(v, vendor, "read {k} got the 1018h:01 response");
        }
        stop.set(true);
        raiser.await.expect("raiser");
        assert!(
            queued.get() > 100,
            "emergencies were queued and drained all along ({} accepted)",
            queued.get()
        );
    });
}

#[test]
fn a_refused_safeop_raises_1001h_and_a_10f3h_message_readable_by_sdo() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let group = group.into_pre_op_pdi(md).await.expect("PRE-OP");
        let len: u16 = Command::fprd(FIRST_STATION, SM2_LENGTH)
            .receive(md)
            .await
            .expect("SM2 length");
        for (reg, v) in [
            (SM2_ACTIVATE, 0u16),
            (SM2_LENGTH, len + 1),
            (SM2_ACTIVATE, 1),
        ] {
            if reg == SM2_LENGTH {
                Command::fpwr(FIRST_STATION, reg)
                    .send(md, v)
                    .await
                    .expect("SM2");
            } else {
                Command::fpwr(FIRST_STATION, reg)
                    .send(md, v as u8)
                    .await
                    .expect("SM2");
            }
        }
        // Request SAFE-OP directly (the group stays usable for SDOs).
        Command::fpwr(FIRST_STATION, AL_CONTROL)
            .send(md, 0x0004u16)
            .await
            .expect("request SAFE-OP");
        m.shared.advance(1_000_000);
        let status: u16 = Command::fprd(FIRST_STATION, AL_STATUS)
            .receive(md)
            .await
            .expect("AL status");
        assert_eq!(status, 0x0012, "refused: PRE-OP + error");
        let sd = group.iter(md).next().expect("one drive");
        // 1001h: generic + communication (the ESM error class 0xA000).
        let reg = sd.sdo_read::<u8>(0x1001, 0).await.expect("1001h");
        assert_eq!(reg, 0x11);
        let newest = sd.sdo_read::<u8>(0x10F3, 2).await.expect("10F3h:02");
        assert_eq!(newest, 6, "the first message slot");
        assert!(sd.sdo_read::<bool>(0x10F3, 4).await.expect("10F3h:04"));
        let msg = sd.sdo_read::<[u8; 28]>(0x10F3, 6).await.expect("10F3h:06");
        assert_eq!(msg[..4], [0x00, 0xE8, 0x00, 0xA0], "diag code 0xA000_E800");
        assert_eq!(
            msg[4..6],
            [0x12, 0x03],
            "error, local time stamp, 3 parameters"
        );
        assert_eq!(
            msg[16..20],
            [0x06, 0x00, 0x1D, 0x00],
            "UNSIGNED16 AL status code 0x001D"
        );
        assert_eq!(msg[20..23], [0x05, 0x00, 0x02], "from PRE-OP");
        // The master acknowledges it.
        sd.sdo_write(0x10F3, 3, 6u8).await.expect("ack");
        assert!(!sd.sdo_read::<bool>(0x10F3, 4).await.expect("10F3h:04"));
        let drive_register = m.shared.segment().drives()[0].slave.error_register();
        assert_eq!(
            drive_register, 0x11,
            "still active until the AL error is acknowledged"
        );
    });
}
