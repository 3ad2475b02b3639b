//! The PDI side: `EscPdi` / `EscSignals` semantics.

use super::*;
use crate::esc::SimPdiError;
use hal::esc::{regs, AlEvent};
use hal::pdi::{EscPdi, EscSignals, PdiError, PdiErrorKind};

#[test]
fn pdi_access_beyond_the_address_space_is_out_of_range() {
    let mut e = esc();
    let err = e.read(0x2FFF, &mut [0; 2]).unwrap_err();
    assert_eq!(
        err,
        SimPdiError::OutOfRange {
            addr: 0x2FFF,
            len: 2
        }
    );
    assert_eq!(err.kind(), PdiErrorKind::OutOfRange);
    assert!(e.read(0x2FFF, &mut [0; 1]).is_ok());
}

#[test]
fn pdi_cannot_write_ecat_side_registers() {
    let mut escs = ring(1);
    escs[0]
        .write_u16(regs::STATION_ADDRESS.addr, 0x7777)
        .unwrap();
    escs[0].write_u16(regs::AL_CONTROL.addr, 0x0008).unwrap();
    escs[0].write_u8(regs::sm(0).addr, 0x55).unwrap();
    escs[0].write_u8(regs::fmmu(0).addr, 0x55).unwrap();
    assert_eq!(
        escs[0].read_u16(regs::STATION_ADDRESS.addr).unwrap(),
        station(0)
    );
    assert_eq!(escs[0].read_u16(regs::AL_CONTROL.addr).unwrap(), 0x0001);
    assert_eq!(escs[0].read_u8(regs::sm(0).addr).unwrap(), 0);
    assert_eq!(escs[0].read_u8(regs::fmmu(0).addr).unwrap(), 0);
}

#[test]
fn pdi_access_returns_al_event_as_at_start_of_access() {
    let mut escs = ring(1);
    send1(&mut escs, BWR, 0, regs::AL_CONTROL.addr, &[0x02, 0]);
    let ev = escs[0].read(regs::AL_CONTROL.addr, &mut [0; 2]).unwrap();
    assert_eq!(ev.0 & AlEvent::AL_CONTROL, AlEvent::AL_CONTROL);
    let ev = escs[0].read(regs::AL_CONTROL.addr, &mut [0; 2]).unwrap();
    assert_eq!(ev.0 & AlEvent::AL_CONTROL, 0);
}

#[test]
fn irq_follows_al_event_request_and_mask() {
    let mut escs = ring(1);
    assert!(!escs[0].irq_asserted());
    send1(&mut escs, BWR, 0, regs::AL_CONTROL.addr, &[0x02, 0]);
    assert!(
        escs[0].irq_asserted(),
        "bit 0 is unmasked at reset (0x0204 = 0x00FFFF0F)"
    );
    escs[0].write_u32(regs::AL_EVENT_MASK.addr, 0).unwrap();
    assert!(!escs[0].irq_asserted());
    escs[0]
        .write_u32(regs::AL_EVENT_MASK.addr, AlEvent::AL_CONTROL)
        .unwrap();
    assert!(escs[0].irq_asserted());
    escs[0].read_u16(regs::AL_CONTROL.addr).unwrap();
    assert!(!escs[0].irq_asserted());
}

#[test]
fn user_ram_is_shared_by_both_sides() {
    let mut escs = ring(1);
    fpwr(&mut escs, 0, regs::USER_RAM.addr, &[1, 2, 3]);
    let mut b = [0; 3];
    escs[0].write(regs::USER_RAM.addr + 3, &[4]).unwrap();
    escs[0].read(regs::USER_RAM.addr, &mut b).unwrap();
    assert_eq!(b, [1, 2, 3]);
    assert_eq!(fprd(&mut escs, 0, regs::USER_RAM.addr + 3, 1).0, vec![4]);
}
