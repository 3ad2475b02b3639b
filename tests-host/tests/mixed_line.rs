//! A line of drives of different profiles (`Segment::line`): ethercrab (in process) brings
//! sdv3-e, rse and sigma-v-sd-2axis to OP together with DC SYNC0. Each drive answers with its
//! own profile: the identity in 1018h (read by SDO) and in the SII, and a process-data image of
//! its profile's default SM2/SM3 sizes. The built-in demo then enables every drive of the mixed
//! line through its own PDO layout.

use std::time::Duration;

use board_sim::demo::{self, Scenario};
use board_sim::Segment;
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{Command, DcSync, MainDevice};
use hal::esc::regs;
use tests_host::{block_on, expected_identity, master_for, FIRST_STATION};

/// The line, in ring order: three profiles of three vendors with three different default PDO
/// layouts (sigma-v-sd-2axis assigns two PDOs per direction and maps no 6060h).
const LINE: [&str; 3] = ["sdv3-e", "rse", "sigma-v-sd-2axis"];

/// Identity object (CiA 301): 1018h:01 vendor id, 1018h:02 product code.
const IDENTITY: u16 = 0x1018;

/// AL status (0x0130) and AL status code (0x0134) of the drive at `address`.
async fn al(md: &MainDevice<'_>, address: u16) -> (u16, u16) {
    let status = Command::fprd(address, regs::AL_STATUS.addr)
        .receive::<u16>(md)
        .await
        .unwrap_or(0xFFFF);
    let code = Command::fprd(address, regs::AL_STATUS_CODE.addr)
        .receive::<u16>(md)
        .await
        .unwrap_or(0xFFFF);
    (status, code)
}

/// Every drive's AL status and code, for failure messages.
async fn al_states(md: &MainDevice<'_>) -> String {
    let mut out = Vec::new();
    for (i, profile) in LINE.iter().enumerate() {
        let (status, code) = al(md, FIRST_STATION + i as u16).await;
        out.push(format!(
            "drive {i} ({profile}): AL status {status:#06x}, AL status code {code:#06x}"
        ));
    }
    out.join("; ")
}

/// `result`, or a panic naming the step and where every drive stopped.
async fn expect<T, E: std::fmt::Debug>(md: &MainDevice<'_>, step: &str, result: Result<T, E>) -> T {
    match result {
        Ok(v) => v,
        Err(e) => panic!("{step}: {e:?}; {}", al_states(md).await),
    }
}

#[test]
fn three_profiles_reach_op_together_with_their_own_identity_and_image() {
    let segment = Segment::line(&LINE).expect("mixed line");
    assert_eq!(segment.drives().len(), LINE.len());
    block_on(async {
        let (m, transport) = master_for(segment);
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let cycle = Duration::from_millis(1);
        let cycle_ns = cycle.as_nanos() as u64;

        let mut group = md
            .init_single_group::<4, 256>(m.shared.clock().now_fn())
            .await
            .expect("init");
        assert_eq!(group.len(), LINE.len(), "drives discovered");

        for (i, (mut sd, profile)) in group.iter_mut(md).zip(LINE).enumerate() {
            let p = od_gen::builtin(profile).expect("built-in profile");
            assert_eq!(
                sd.configured_address(),
                FIRST_STATION + i as u16,
                "station addresses in the order of the line"
            );
            // Identity by SDO: the object dictionary of this drive's own profile.
            let vendor = sd.sdo_read::<u32>(IDENTITY, 1).await.expect("1018h:01");
            let product = sd.sdo_read::<u32>(IDENTITY, 2).await.expect("1018h:02");
            assert_eq!(
                (vendor, product),
                (p.vendor.id, p.device.product_code),
                "drive {i} ({profile}): 1018h:01/02"
            );
            // Identity and name from the SII: this drive's own EEPROM.
            let (identity, name) = expected_identity(profile);
            let id = sd.identity();
            assert_eq!(
                (id.vendor_id, id.product_id, id.revision, id.serial),
                identity,
                "drive {i} ({profile}): SII identity"
            );
            assert_eq!(sd.name(), name, "drive {i} ({profile}): SII name");
            sd.set_dc_sync(DcSync::Sync0);
        }

        let group = expect(md, "PRE-OP → PDI", group.into_pre_op_pdi(md).await).await;
        for _ in 0..100 {
            group.tx_rx_sync_system_time(md).await.expect("DC sync");
            m.shared.advance(cycle_ns);
        }
        let group = expect(
            md,
            "configure DC SYNC0",
            group
                .configure_dc_sync(
                    md,
                    DcConfiguration {
                        start_delay: cycle * 10,
                        sync0_period: cycle,
                        sync0_shift: Duration::ZERO,
                    },
                )
                .await,
        )
        .await;
        let group = expect(md, "PRE-OP → SAFE-OP", group.into_safe_op(md).await).await;
        let group = expect(md, "SAFE-OP → OP request", group.request_into_op(md).await).await;
        let mut all_op = false;
        for _ in 0..1000 {
            let r = group.tx_rx_dc(md).await.expect("cyclic exchange");
            m.shared.advance(cycle_ns);
            if r.all_op() {
                all_op = true;
                break;
            }
        }
        assert!(all_op, "SAFE-OP → OP: {}", al_states(md).await);
        for (i, profile) in LINE.iter().enumerate() {
            assert_eq!(
                al(md, FIRST_STATION + i as u16).await,
                (0x0008, 0x0000),
                "drive {i} ({profile}): AL status OP, no AL status code"
            );
        }

        // Each drive's image: its profile's default SM2 (outputs) and SM3 (inputs) sizes.
        for (i, (sd, profile)) in group.iter(md).zip(LINE).enumerate() {
            let p = od_gen::builtin(profile).expect("built-in profile");
            let sizes = (sd.outputs_raw().len(), sd.inputs_raw().len());
            assert_eq!(
                sizes,
                (
                    usize::from(p.sm.outputs.length),
                    usize::from(p.sm.inputs.length)
                ),
                "drive {i} ({profile}): outputs/inputs bytes = default SM2/SM3 length"
            );
            assert_eq!(
                sizes,
                (
                    p.outputs_bits().div_ceil(8) as usize,
                    p.inputs_bits().div_ceil(8) as usize
                ),
                "drive {i} ({profile}): default PDO assignment size"
            );
        }
        // Each drive has outputs and inputs: 2 (write) + 1 (read) per drive (ETG.1000.4 §5.4.3).
        let r = group.tx_rx_dc(md).await.expect("cyclic exchange");
        assert_eq!(
            r.working_counter,
            3 * LINE.len() as u16,
            "LRW working counter"
        );

        let group = expect(md, "OP → SAFE-OP", group.into_safe_op(md).await).await;
        let group = expect(md, "SAFE-OP → PRE-OP", group.into_pre_op(md).await).await;
        expect(md, "PRE-OP → INIT", group.into_init(md).await).await;
    });
}

/// CiA402 statusword bits 0..3, 5, 6 (CiA402 Table 30): operation enabled.
const STATE_MASK: u16 = 0x006F;
const OPERATION_ENABLED: u16 = 0x0027;

#[test]
fn the_demo_enables_every_drive_of_a_mixed_line() {
    let scenario = Scenario {
        cycles: 300,
        ..Scenario::default()
    };
    let report = block_on(demo::run_line(&LINE, &scenario, &mut |_| {}))
        .unwrap_or_else(|e| panic!("demo on {LINE:?} failed: {e}"));
    assert_eq!(
        report.states,
        ["PRE-OP", "SAFE-OP", "OP", "SAFE-OP", "PRE-OP", "INIT"]
    );
    assert_eq!(report.drives.len(), LINE.len());
    for (i, (d, profile)) in report.drives.iter().zip(LINE).enumerate() {
        assert_eq!(d.profile, profile);
        assert_eq!(d.identity, expected_identity(profile).0, "drive {i}");
        let p = od_gen::builtin(profile).expect("built-in profile");
        let layout = &report.layouts[i];
        assert_eq!(
            (layout.output_bytes(), layout.input_bytes()),
            (
                usize::from(p.sm.outputs.length),
                usize::from(p.sm.inputs.length)
            ),
            "drive {i} ({profile}): PDO layout read by SDO"
        );
    }
    // sigma-v-sd-2axis: two PDOs per direction, no 6060h in the outputs (the demo sets CSP by
    // SDO); rse maps no 6060h either.
    assert_eq!(report.layouts[2].rx_pdos, [0x1600, 0x1610]);
    assert_eq!(report.layouts[2].tx_pdos, [0x1A00, 0x1A10]);
    assert_eq!(report.layouts[1].output(0x6060), None);
    assert_eq!(report.layouts[2].output(0x6060), None);
    assert!(report.layouts[0].output(0x6060).is_some());

    assert_eq!(report.expected_wkc, 3 * LINE.len() as u16);
    assert_eq!(report.wkc_errors, 0, "cycles with a wrong working counter");
    for (i, (sw, actual)) in report.last_inputs.iter().enumerate() {
        assert_eq!(
            sw & STATE_MASK,
            OPERATION_ENABLED,
            "drive {i} ({}): statusword {sw:#06x}",
            LINE[i]
        );
        // Enabled in CSP: the position follows the ramp of 100 increments per cycle (the last
        // target sent was 29 900).
        assert!(
            (29_000..=30_000).contains(actual),
            "drive {i} ({}): position actual {actual}",
            LINE[i]
        );
    }
    assert_eq!(report.sync_parameters, vec![(2, 1_000_000); LINE.len()]);
}
