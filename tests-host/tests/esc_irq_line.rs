//! The ESC's IRQ line (AL event request 0x0220 AND AL event mask 0x0204, ET1100 datasheet) is
//! released whenever the slave has nothing left to do, so that the next event gives the MCU a
//! new edge. A board triggers on the falling edge (boards/stm32g474: EXTI, falling): a line
//! held asserted by an event nobody acknowledges hides every later event from it.
//!
//! Two events stay pending by the ESC's rules unless the slave acts:
//! - SM activation changed (bit 4) is cleared only when the activate byte of every SM the master
//!   wrote has been read, and ethercrab's start-up writes zeros over the whole SM block, the SMs
//!   the drive does not use included;
//! - SM1's event (bit 9, the master read the slave's mailbox) is cleared only by the next write
//!   to SM1, which may never come: the slave keeps it masked while no frame waits for SM1.

use ethercrab::Command;
use hal::esc::{regs, AlEvent};
use hal::pdi::EscSignals;
use tests_host::{block_on, master};

/// Simulated time for the drive's event rounds and its background poll (10 ms) to run.
const SETTLE_NS: u64 = 20_000_000;

/// AL event request, AL event mask and whether the IRQ line is asserted, from the ESC.
fn irq_state(m: &board_sim::inproc::InProcess) -> (u32, u32, bool) {
    let mut seg = m.shared.segment();
    let esc = &mut seg.drives_mut()[0].esc;
    let request = esc.al_event_request().0;
    let mut mask = [0u8; 4];
    esc.peek(regs::AL_EVENT_MASK.addr, &mut mask);
    let mask = u32::from_le_bytes(mask);
    (request, mask, esc.irq_asserted())
}

#[test]
fn the_irq_line_is_released_after_start_up_and_after_a_mailbox_exchange() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        m.shared.advance(SETTLE_NS);
        let (request, mask, asserted) = irq_state(&m);
        assert!(
            !asserted,
            "PRE-OP after start-up: request {request:#010x}, mask {mask:#010x}"
        );
        assert_eq!(
            request & AlEvent::SM_ACTIVATION,
            0,
            "SM activation acknowledged"
        );

        // A mailbox exchange: the master reads the response from SM1.
        let sd = group.iter(md).next().expect("one drive");
        let device_type: u32 = sd.sdo_read(0x1000, 0).await.expect("1000h");
        assert_ne!(device_type, 0);
        m.shared.advance(SETTLE_NS);
        let (request, mask, asserted) = irq_state(&m);
        assert!(
            !asserted,
            "idle after an SDO upload: request {request:#010x}, mask {mask:#010x}"
        );
        // The ESC still holds SM1's event (nothing was written to SM1 since the master read
        // it); the mask keeps it off the line.
        assert_ne!(
            request & AlEvent::sm(1),
            0,
            "SM1 read event pending in 0x0220"
        );
        assert_eq!(mask & AlEvent::sm(1), 0, "SM1's event masked while idle");

        // The next request still gets its answer (SM0's event asserts the line).
        let again: u32 = sd.sdo_read(0x1000, 0).await.expect("1000h again");
        assert_eq!(again, device_type);
        // And the master sees what the MCU sees: AL event mask readable over the bus.
        let bus_mask = Command::fprd(sd.configured_address(), regs::AL_EVENT_MASK.addr)
            .receive::<u32>(md)
            .await
            .expect("0x0204");
        assert_eq!(bus_mask & AlEvent::sm(1), 0);
    });
}
