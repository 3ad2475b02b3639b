//! Digital outputs 60FEh (CiA402) on the standard drive, commanded by ethercrab in free run: the
//! holding brake (bit 0) is applied while the power stage is off and released while operation is
//! enabled; the bit mask 60FEh:02 selects the outputs whose level the master forces through
//! 60FEh:01 (the board's DO1/DO2 at bits 16/17); on leaving OP the forced outputs go to their
//! safe state (off, brake applied). The levels are read at the simulated board's pins.

use ethercrab::MainDevice;
use tests_host::csp;
use tests_host::{block_on, master};

const BRAKE: u32 = 1 << 0;
const DO1: u32 = 1 << 16;
const DO2: u32 = 1 << 17;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const CSP: i8 = 8;

#[test]
fn standard_brake_and_forced_outputs_follow_60feh() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let pins = || {
            m.shared.segment().drives()[0].servos[0]
                .io()
                .outputs
                .levels()
        };
        let group = csp::into_op_with_mode(&m, md, CSP).await;
        let mut s = csp::phase_locked(&m, md, &group, 0, 0, CSP).await;
        assert_eq!(pins(), BRAKE, "brake applied while the power stage is off");
        for cw in [0x06u16; 5]
            .into_iter()
            .chain([0x07; 5])
            .chain([ENABLE_OPERATION; 10])
        {
            s = csp::phase_locked(&m, md, &group, cw, s.position, CSP).await;
        }
        assert_eq!(s.statusword & STATE_MASK, OPERATION_ENABLED);
        assert_eq!(pins(), 0, "brake released in Operation Enabled");

        // DO1 and DO2 forced by the mask; DO1 on, DO2 off; the brake left to the drive.
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x60FE, 2, DO1 | DO2).await.expect("60FEh:02");
        sd.sdo_write(0x60FE, 1, DO1 | BRAKE)
            .await
            .expect("60FEh:01");
        for _ in 0..3 {
            s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, s.position, CSP).await;
        }
        assert_eq!(pins(), DO1, "only the masked outputs take 60FEh:01");
        // Forcing the brake applies it even while operation is enabled.
        sd.sdo_write(0x60FE, 2, DO1 | DO2 | BRAKE)
            .await
            .expect("60FEh:02");
        s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, s.position, CSP).await;
        assert_eq!(pins(), DO1 | BRAKE);
        sd.sdo_write(0x60FE, 2, DO1 | DO2).await.expect("60FEh:02");

        // Disable: the brake is applied again, the forced outputs stay.
        for _ in 0..5 {
            s = csp::phase_locked(&m, md, &group, 0x06, s.position, CSP).await;
        }
        assert_eq!(pins(), DO1 | BRAKE);

        // Leaving OP: the forced outputs go to their safe state.
        let group = group.into_safe_op(md).await.expect("OP -> SAFE-OP");
        m.shared.advance(csp::CYCLE_NS);
        assert_eq!(pins(), BRAKE, "safe state: outputs off, brake applied");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u32>(0x60FE, 1).await.expect("60FEh:01"),
            BRAKE
        );
    });
}
