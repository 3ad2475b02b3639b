//! Errors reported as the profile's alarms (SDV3-E, through ethercrab in process, free run): the
//! firmware's drive over-temperature is alarm AH (Table 5-1: error code 4210h, error No. 26h,
//! auxiliary code 8003h), leaving OP while enabled is alarm ESr (8801h, 39h, 801Ch); each sets
//! 603Fh and sends an emergency whose manufacturer field carries error No. and auxiliary code
//! (Table 3-15: byte 3, bytes 4–5). No emergency is queued in Init (§3.6).

use board_sim::Segment;
use ethercrab::{Command, MainDevice};
use tests_host::{block_on, master_for, FIRST_STATION};

const CYCLE_NS: u64 = 1_000_000;
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const FAULT_BIT: u16 = 0x08;
const CSP: u8 = 8;
/// SM1 status register (ETG.1000.4 Table 58: SM n at 0x0800 + 8n, status at +5), bit 3
/// "mailbox full".
const SM1_STATUS: u16 = 0x080D;
const MAILBOX_FULL: u8 = 0x08;
/// Mailbox header (6 bytes) type 3 = CoE; CoE header service 1 = emergency (ETG.1000.6).
const MAILBOX_HEADER: usize = 6;
const TYPE_COE: u8 = 3;
const COE_EMERGENCY: u16 = 1;

/// The drive from INIT to OP (free run): an ethercrab group in OP.
macro_rules! into_op {
    ($m:expr, $md:expr) => {
        $md.init_single_group::<4, 64>($m.shared.clock().now_fn())
            .await
            .expect("init")
            .into_safe_op($md)
            .await
            .expect("SAFE-OP")
            .request_into_op($md)
            .await
            .expect("request OP")
    };
}

/// One cycle with controlword `cw` in CSP (default RxPDO 1600h: 6040h, 607Ah, 60FFh, 6071h,
/// 6060h at byte 12); evaluates to the statusword (TxPDO 1A00h: 6041h first).
macro_rules! cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        {
            let mut out = sd.outputs_raw_mut();
            out.fill(0);
            out[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
            out[12] = CSP;
        }
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.advance(CYCLE_NS);
        let inp = sd.inputs_raw();
        u16::from_le_bytes([inp[0], inp[1]])
    }};
}

/// Shutdown, switch on, enable operation (CiA402); asserts Operation Enabled.
macro_rules! enable {
    ($m:expr, $md:expr, $group:expr) => {{
        let mut sw = 0;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            sw = cycle!($m, $md, $group, cw);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
    }};
}

/// Waits (cycling) until SM1 holds a mailbox and reads it whole, as SOEM does; evaluates to the
/// CoE part (after the 6-byte mailbox header): CoE header, EMCY code, 1001h, manufacturer field.
macro_rules! emergency {
    ($m:expr, $md:expr, $group:expr, $sm1_start:expr) => {{
        let mut mailbox = None;
        for _ in 0..50 {
            let status: u8 = Command::fprd(FIRST_STATION, SM1_STATUS)
                .receive($md)
                .await
                .expect("SM1 status");
            if status & MAILBOX_FULL != 0 {
                let data: [u8; 256] = Command::fprd(FIRST_STATION, $sm1_start)
                    .receive($md)
                    .await
                    .expect("SM1");
                mailbox = Some(data);
                break;
            }
            $group.tx_rx($md).await.expect("tx/rx");
            $m.shared.advance(CYCLE_NS);
        }
        let mb = mailbox.expect("an emergency in SM1");
        assert_eq!(mb[5] & 0x0F, TYPE_COE, "mailbox type");
        let coe = mb[MAILBOX_HEADER..MAILBOX_HEADER + 10].to_vec();
        assert_eq!(u16::from_le_bytes([coe[0], coe[1]]) >> 12, COE_EMERGENCY);
        coe
    }};
}

#[test]
fn a_motor_fault_sends_the_profiles_alarm_in_603fh_and_the_emcy() {
    let p = od_gen::builtin("sdv3-e").expect("profile");
    let alarm = p
        .alarms
        .iter()
        .find(|a| a.display == "AH")
        .expect("alarm AH");
    assert_eq!(
        alarm.emcy.data,
        [0x26, 0x03, 0x80, 0, 0],
        "Table 5-1: 26h, 8003h"
    );
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(120.0);
        let faulted = async {
            for _ in 0..300 {
                if cycle!(m, md, group, ENABLE_OPERATION) & FAULT_BIT != 0 {
                    return true;
                }
            }
            false
        };
        assert!(faulted.await, "the drive faults");
        let coe = emergency!(m, md, group, p.sm.mailbox_in.start);
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
        assert_eq!(coe[4] & 0x01, 0x01, "1001h generic error");
        assert_eq!(
            coe[5..10],
            alarm.emcy.data,
            "manufacturer field: error No., aux code"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            alarm.error_code
        );
    });
}

/// SDV3-E §3.6: an emergency is sent only when the ESM is not in Init. An error raised in Init
/// sets 1001h but queues no emergency (there is no mailbox to carry it).
#[test]
fn no_emergency_is_queued_in_init() {
    let mut seg = Segment::new("sdv3-e", 1).expect("profile");
    let now = seg.now_ns();
    let slave = &mut seg.drives_mut()[0].slave;
    let alarm = od_gen::builtin("sdv3-e")
        .expect("profile")
        .alarms
        .into_iter()
        .find(|a| a.display == "AH")
        .expect("alarm AH");
    let handed_back = slave.report_error(alarm.emcy.code, 0, alarm.emcy.data, None, now);
    assert!(
        handed_back.is_err(),
        "no mailbox in Init: the emergency is not queued"
    );
    assert_eq!(slave.pending_emcys(), 0);
    assert_eq!(slave.error_register() & 0x01, 0x01, "1001h generic error");
}

/// SDV3-E §5.2 10): leaving OP while the drive is Operation Enabled raises its alarm ESr: the
/// drive faults with 603Fh = 8801h and the emergency carries error No. 39h, aux code 801Ch.
#[test]
fn leaving_op_while_enabled_raises_the_profiles_alarm() {
    let p = od_gen::builtin("sdv3-e").expect("profile");
    let alarm = p
        .alarms
        .iter()
        .find(|a| a.display == "ESr")
        .expect("alarm ESr");
    block_on(async {
        let (m, transport) = master_for(Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op!(m, md);
        enable!(m, md, group);
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        let coe = emergency!(m, md, group, p.sm.mailbox_in.start);
        assert_eq!(
            u16::from_le_bytes([coe[2], coe[3]]),
            alarm.emcy.code,
            "EMCY code"
        );
        assert_eq!(
            coe[5..10],
            [0x39, 0x1C, 0x80, 0, 0],
            "error No. 39h, aux 801Ch"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), 0x8801);
    });
}
