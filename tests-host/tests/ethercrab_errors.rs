//! Wrong requests from ethercrab get the answers ETG.1000 specifies, not a hang.

use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::Command;
use tests_host::{block_on, master};

const FIRST_STATION: u16 = 0x1000;
const AL_STATUS: u16 = 0x0130;
const AL_STATUS_CODE: u16 = 0x0134;
const SM2_LENGTH: u16 = 0x0812;
const SM2_ACTIVATE: u16 = 0x0816;

#[test]
fn sdo_read_of_missing_object_aborts_0x06020000() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let sd = group.iter(md).next().expect("one drive");
        let err = sd
            .sdo_read::<u32>(0x2FFF, 0)
            .await
            .expect_err("object 2FFFh does not exist");
        match err {
            Error::Mailbox(MailboxError::Aborted {
                code,
                address,
                sub_index,
            }) => {
                assert_eq!(code, CoeAbortCode::NotFound, "ETG.1000.6 abort 0x06020000");
                assert_eq!((address, sub_index), (0x2FFF, 0));
            }
            other => panic!("expected an SDO abort, got {other:?}"),
        }
        // The mailbox keeps working after the abort.
        let device_type = sd.sdo_read::<u32>(0x1000, 0).await.expect("1000h");
        assert_eq!(device_type & 0xFFFF, 402, "CiA402 device profile number");
    });
}

#[test]
fn safeop_with_wrong_sm2_length_is_refused_with_0x1d_and_error_flag() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let group = group
            .into_pre_op_pdi(md)
            .await
            .expect("PRE-OP with SM2/SM3 configured");
        let len: u16 = Command::fprd(FIRST_STATION, SM2_LENGTH)
            .receive(md)
            .await
            .expect("SM2 length");
        assert!(len > 0, "the default mapping has outputs");
        // SM registers are writable only while the SM is disabled (ET1100 datasheet §8).
        Command::fpwr(FIRST_STATION, SM2_ACTIVATE)
            .send(md, 0u8)
            .await
            .expect("disable SM2");
        Command::fpwr(FIRST_STATION, SM2_LENGTH)
            .send(md, len + 1)
            .await
            .expect("SM2 length");
        Command::fpwr(FIRST_STATION, SM2_ACTIVATE)
            .send(md, 1u8)
            .await
            .expect("enable SM2");

        let r = group.into_safe_op(md).await;
        assert!(r.is_err(), "SAFE-OP must be refused");
        let status: u16 = Command::fprd(FIRST_STATION, AL_STATUS)
            .receive(md)
            .await
            .expect("AL status");
        let code: u16 = Command::fprd(FIRST_STATION, AL_STATUS_CODE)
            .receive(md)
            .await
            .expect("AL status code");
        assert_eq!(
            status, 0x0012,
            "stays in PRE-OP with the error indication bit (ETG.1000.6 Table 9)"
        );
        assert_eq!(
            code, 0x001D,
            "invalid output configuration (ETG.1000.6 Table 11)"
        );

        // The error is held until acknowledged, then INIT is reachable.
        Command::fpwr(FIRST_STATION, 0x0120)
            .send(md, 0x0001u16)
            .await
            .expect("INIT without ack");
        m.shared.advance(1_000_000);
        let status: u16 = Command::fprd(FIRST_STATION, AL_STATUS)
            .receive(md)
            .await
            .expect("AL status");
        assert_eq!(
            status, 0x0012,
            "a request without acknowledge is ignored while the error is set"
        );
        Command::fpwr(FIRST_STATION, 0x0120)
            .send(md, 0x0011u16)
            .await
            .expect("INIT with ack");
        let status: u16 = Command::fprd(FIRST_STATION, AL_STATUS)
            .receive(md)
            .await
            .expect("AL status");
        assert_eq!(status, 0x0001, "INIT, error cleared");
    });
}
