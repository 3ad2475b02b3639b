//! The EtherCAT slave stack without a drive: the 16-channel digital I/O module
//! (`tests-host/io-module/io16.toml`, `tests_host::io_module`) on the simulated ET1100, brought
//! INIT → PREOP → SAFEOP → OP by ethercrab, with its identity, dictionary and process data as
//! the profile file declares them.

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::io_module::{SimIoModule, DIGITAL_OUTPUTS, SAFE_OUTPUT_STATE};
use tests_host::{block_on, master_for};

/// Free-run cycle the master runs (the module's local timer runs at 1 ms too).
const CYCLE_NS: u64 = 1_000_000;
/// Cycles of process data in OP.
const CYCLES: usize = 50;
/// Identity of the profile file: vendor, product code, revision.
const VENDOR: u32 = 0x7E57_0402;
const PRODUCT: u32 = 0x0000_1616;
const REVISION: u32 = 0x0000_0001;
/// 1000h of a CiA401 module with digital inputs and outputs.
const DEVICE_TYPE: u32 = 0x0003_0191;

#[test]
fn io_module_reaches_op_and_exchanges_its_inputs_and_outputs() {
    block_on(async {
        let module = SimIoModule::new().expect("io16 fits its RAM");
        let (m, transport) = master_for(Segment::from_devices(vec![module]));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = md
            .init_single_group::<2, 16>(m.shared.clock().now_fn())
            .await
            .expect("PRE-OP");
        {
            let sd = group.subdevice(md, 0).expect("the module");
            let id = sd.identity();
            assert_eq!(
                (id.vendor_id, id.product_id, id.revision),
                (VENDOR, PRODUCT, REVISION),
                "identity from the SII"
            );
            assert_eq!(sd.name(), "Open IO16");
            // The dictionary is the profile's: read over CoE.
            assert_eq!(
                sd.sdo_read::<u32>(0x1000, 0).await.expect("1000h"),
                DEVICE_TYPE
            );
            assert_eq!(
                sd.sdo_read::<u32>(0x1018, 2).await.expect("1018h:02"),
                PRODUCT
            );
            assert_eq!(
                sd.sdo_read::<u32>(0x1600, 1).await.expect("1600h:01"),
                0x7000_0010,
                "RxPDO maps 7000h:00, 16 bits"
            );
            // Safe output state for when the master's outputs are gone.
            sd.sdo_write(SAFE_OUTPUT_STATE, 0, 0x00FFu16)
                .await
                .expect("8000h writable");
        }
        let group = group.into_safe_op(md).await.expect("SAFE-OP");
        let group = group.request_into_op(md).await.expect("request OP");
        let sd = group.subdevice(md, 0).expect("the module");
        assert_eq!(sd.outputs_raw().len(), 2, "SM2 = 16 output bits");
        assert_eq!(sd.inputs_raw().len(), 2, "SM3 = 16 input bits");

        let mut seen_inputs = Vec::new();
        for k in 0..CYCLES {
            let out = 0xA5C3u16.rotate_left(k as u32);
            sd.outputs_raw_mut().copy_from_slice(&out.to_le_bytes());
            m.shared.segment().drives_mut()[0].set_inputs(0x1000 + k as u16);
            let response = group.tx_rx(md).await.expect("tx/rx");
            assert_eq!(
                response.working_counter, 3,
                "LRW: 2 for the write, 1 for the read (ETG.1000.4 §5.4.3)"
            );
            m.shared.advance(CYCLE_NS);
            let inp = sd.inputs_raw();
            seen_inputs.push(u16::from_le_bytes([inp[0], inp[1]]));
            if k > 2 {
                // One cycle of the module's timer later the output pins show the outputs.
                assert_eq!(
                    m.shared.segment().drives()[0].outputs(),
                    out,
                    "cycle {k}: output pins follow 7000h"
                );
            }
        }
        // Inputs travel pin → 6000h → SM3 → master, at most two cycles late (the module's
        // cycle and the master's frame are not aligned in free run).
        for (k, v) in seen_inputs.iter().enumerate().skip(3) {
            let k = k as u16;
            assert!(
                (0x1000 + k - 2..=0x1000 + k).contains(v),
                "cycle {k}: inputs {v:#06x}"
            );
        }
        let last = 0xA5C3u16.rotate_left(CYCLES as u32 - 1);
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        assert_eq!(
            m.shared.segment().drives()[0].outputs(),
            0x00FF,
            "leaving OP puts the outputs into the safe state 8000h (not {last:#06x})"
        );
        let sd = group.subdevice(md, 0).expect("the module");
        assert_eq!(
            sd.sdo_read::<u16>(DIGITAL_OUTPUTS, 0).await.expect("7000h"),
            0x00FF
        );
        let group = group.into_pre_op(md).await.expect("SAFE-OP -> PRE-OP");
        group.into_init(md).await.expect("PRE-OP -> INIT");
    });
}
