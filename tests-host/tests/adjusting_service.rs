//! The Σ-V-SD's adjusting service 2310h (§4.5 (8) "SERVOPACK Adjusting Command"), driven by
//! ethercrab over SDO on the simulated drive:
//!
//! - step 1 (CADDRESS 2000H = request code) and 3 (2001H = 0001H execute) of 100EH "automatic
//!   offset adjustment of motor current detection signals": status 1 after each accepted step,
//!   255 while executing, 1 when done; the drive measured the plant's current-sensor offsets;
//! - its execution conditions: not with the main power OFF, the motor running or the servo ON;
//! - the preparation step (2001H = 0002H) where the table requires it, the abort (2000H = 0),
//!   the automatic abort 10 s after the last step, unknown request codes; 1008H executed after
//!   its preparation is refused (the encoder interface has no multi-turn commands yet).
//!
//! The 16-byte request is a normal SDO download, which ethercrab 0.7.1 cannot send: the requests
//! go through `tests_host::raw_sdo` (mailbox datagrams sent by ethercrab). SOEM runs the
//! sequence in `adjusting_soem.rs`.

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::subdevice_group::PreOp;
use ethercrab::{DefaultLock, MainDevice, SubDeviceGroup};
use tests_host::raw_sdo::RawSdo;
use tests_host::{block_on, csp, master_for, FIRST_STATION};

const MAX_SUBDEVICES: usize = 2;
const MAX_PDI: usize = 64;
type Group = SubDeviceGroup<MAX_SUBDEVICES, MAX_PDI, DefaultLock, PreOp>;

/// 2310h: :01 command, :02 status, :03 reply (§4.5 (8)).
const ADJUSTING: u16 = 0x2310;
const COMMAND: u8 = 1;
const STATUS: u8 = 2;
const REPLY: u8 = 3;
/// Status values (§4.5 (8) table).
const ACCEPTED: u8 = 1;
const ERROR: u8 = 2;
const EXECUTING: u8 = 255;
/// Request codes (§4.5 (8) "Executable Adjustments").
const ABSOLUTE_ENCODER_RESET: u16 = 0x1008;
const OFFSET_ADJUSTMENT: u16 = 0x100E;
/// CADDRESS of the steps and CDATA of steps 2 and 3.
const ADDRESS_REQUEST_CODE: u32 = 0x2000;
const ADDRESS_EXECUTION: u32 = 0x2001;
const PREPARE: u16 = 0x0002;
const EXECUTE: u16 = 0x0001;
const ABORT: u16 = 0x0000;
/// "Processing time 5 s max."; "aborted if no command within 10 s after step 1".
const TIME_LIMIT_NS: u64 = 5_000_000_000;
const ABORT_AFTER_NS: u64 = 10_000_000_000;

/// A write request (CCMD 01h, CSIZE 2): bytes 2 CCMD, 3 CSIZE, 4-7 CADDRESS, 8-9 CDATA.
fn write_request(address: u32, data: u16) -> [u8; 16] {
    let mut f = [0u8; 16];
    f[2] = 0x01;
    f[3] = 2;
    f[4..8].copy_from_slice(&address.to_le_bytes());
    f[8..10].copy_from_slice(&data.to_le_bytes());
    f
}

async fn init(m: &InProcess) -> Group {
    m.maindevice
        .init_single_group::<MAX_SUBDEVICES, MAX_PDI>(m.shared.clock().now_fn())
        .await
        .expect("init")
}

fn sdo() -> RawSdo {
    RawSdo::new(
        &od_gen::builtin("sigma-v-sd").expect("profile"),
        FIRST_STATION,
    )
}

/// Writes one request and returns the status (:02) read right after it.
async fn step(md: &MainDevice<'_>, _group: &Group, address: u32, data: u16) -> u8 {
    sdo()
        .download(md, ADJUSTING, COMMAND, &write_request(address, data))
        .await
        .expect("2310h:01");
    status(md, _group).await
}

async fn status(md: &MainDevice<'_>, _group: &Group) -> u8 {
    let v = sdo().upload(md, ADJUSTING, STATUS).await.expect("2310h:02");
    assert_eq!(v.len(), 1, "USINT");
    v[0]
}

async fn reply(md: &MainDevice<'_>, _group: &Group) -> [u8; 16] {
    let v = sdo().upload(md, ADJUSTING, REPLY).await.expect("2310h:03");
    v.try_into().expect("STRING[16]")
}

#[test]
fn sigma_v_sd_offset_adjustment_is_accepted_executes_and_measures_the_offsets() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        // Step 1: the request code; status 1 and the request echoed in the reply.
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, OFFSET_ADJUSTMENT).await,
            ACCEPTED
        );
        let r = reply(md, &group).await;
        assert_eq!(r[0], ACCEPTED, "reply byte 0 = status");
        assert_eq!(r[2], 0x01, "RCMD echoes CCMD");
        assert_eq!(&r[4..8], &ADDRESS_REQUEST_CODE.to_le_bytes(), "RADDRESS");
        // Step 3 (100EH needs no preparation): executing.
        assert_eq!(
            step(md, &group, ADDRESS_EXECUTION, EXECUTE).await,
            EXECUTING
        );
        assert_eq!(reply(md, &group).await[0], EXECUTING);
        // Well within the 5 s limit the offsets are measured.
        m.shared.advance(200_000_000);
        assert_eq!(status(md, &group).await, ACCEPTED, "done, no error");
        let mut segment = m.shared.segment();
        let servo = &mut segment.drives_mut()[0].servos[0];
        assert_eq!(servo.feedback().offset_calibrations, 1);
        let offsets = servo.axis.current_offsets();
        let truth = servo.plant.config().sensing.offset_a;
        for (got, want) in [offsets.a, offsets.b, offsets.c].into_iter().zip(truth) {
            assert!(
                (f64::from(got) - want).abs() < 0.01,
                "offset {got} A vs the plant's {want} A"
            );
        }
        assert!(!servo.latched().gates, "gates stayed off");
    });
}

#[test]
fn sigma_v_sd_offset_adjustment_is_refused_with_main_power_off_or_the_motor_running() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        let servo = |f: &dyn Fn(&mut board_sim::servo::SimServo)| {
            f(&mut m.shared.segment().drives_mut()[0].servos[0]);
        };
        // Main circuit power OFF.
        servo(&|s| s.plant.set_bus_voltage(0.0));
        m.shared.advance(10_000_000);
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, OFFSET_ADJUSTMENT).await,
            ACCEPTED
        );
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        assert_eq!(reply(md, &group).await[0], ERROR);
        // Power back, the motor turned by the load at 60 rpm.
        servo(&|s| {
            s.plant.set_bus_voltage(48.0);
            s.plant.set_driven_speed(Some(std::f64::consts::TAU));
        });
        m.shared.advance(10_000_000);
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        // Standing still with power: the same selection executes.
        servo(&|s| s.plant.set_driven_speed(Some(0.0)));
        m.shared.advance(10_000_000);
        assert_eq!(
            step(md, &group, ADDRESS_EXECUTION, EXECUTE).await,
            EXECUTING
        );
        m.shared.advance(200_000_000);
        assert_eq!(status(md, &group).await, ACCEPTED);
    });
}

#[test]
fn sigma_v_sd_adjusting_sequence_errors_abort_and_timeout() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = init(&m).await;
        // An unknown request code, and an execution with nothing selected.
        assert_eq!(step(md, &group, ADDRESS_REQUEST_CODE, 0x1234).await, ERROR);
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        // 1008H needs the preparation step first.
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, ABSOLUTE_ENCODER_RESET).await,
            ACCEPTED
        );
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, PREPARE).await, ACCEPTED);
        // Prepared, but the multi-turn commands to the encoder do not exist yet (profile
        // decision "2310h adjustments"): refused, and the selection stays.
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        // Abort: accepted, and the prepared selection is gone.
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, ABORT).await,
            ACCEPTED
        );
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, PREPARE).await, ERROR);
        // 100EH selected, then nothing for more than 10 s: aborted automatically.
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, OFFSET_ADJUSTMENT).await,
            ACCEPTED
        );
        m.shared.advance(ABORT_AFTER_NS - 500_000_000);
        assert_eq!(
            status(md, &group).await,
            ACCEPTED,
            "still selected at 9.5 s"
        );
        m.shared.advance(1_000_000_000);
        assert_eq!(step(md, &group, ADDRESS_EXECUTION, EXECUTE).await, ERROR);
        // Within 10 s of the selection the execution is accepted and ends within 5 s.
        assert_eq!(
            step(md, &group, ADDRESS_REQUEST_CODE, OFFSET_ADJUSTMENT).await,
            ACCEPTED
        );
        m.shared.advance(ABORT_AFTER_NS - 500_000_000);
        assert_eq!(
            step(md, &group, ADDRESS_EXECUTION, EXECUTE).await,
            EXECUTING
        );
        m.shared.advance(TIME_LIMIT_NS);
        assert_eq!(status(md, &group).await, ACCEPTED);
    });
}

#[test]
fn sigma_v_sd_offset_adjustment_is_refused_while_the_servo_is_on() {
    // §4.5 (8): "Adjustment is disabled ... while the servo is ON".
    /// Controlwords (CiA402): shutdown, switch on, enable operation; statusword state mask
    /// and Operation Enabled.
    const SHUTDOWN: u16 = 0x06;
    const SWITCH_ON: u16 = 0x07;
    const ENABLE_OPERATION: u16 = 0x0F;
    const STATE_MASK: u16 = 0x6F;
    const OPERATION_ENABLED: u16 = 0x27;
    const MODE_CSP: i8 = 8;
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, MODE_CSP).await;
        let cws = [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 100]);
        let (statusword, _) = csp::hold_through(&m, md, &group, cws, STATE_MASK).await;
        assert_eq!(statusword & STATE_MASK, OPERATION_ENABLED, "servo ON");
        let sdo = sdo();
        sdo.download(
            md,
            ADJUSTING,
            COMMAND,
            &write_request(ADDRESS_REQUEST_CODE, OFFSET_ADJUSTMENT),
        )
        .await
        .expect("step 1");
        sdo.download(
            md,
            ADJUSTING,
            COMMAND,
            &write_request(ADDRESS_EXECUTION, EXECUTE),
        )
        .await
        .expect("step 3");
        let status = sdo.upload(md, ADJUSTING, STATUS).await.expect("2310h:02");
        assert_eq!(status, [ERROR], "refused with the servo ON");
        let calibrations = m.shared.segment().drives_mut()[0].servos[0]
            .feedback()
            .offset_calibrations;
        assert_eq!(calibrations, 1, "only the one at enable");
    });
}
