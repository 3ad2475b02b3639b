//! FMMUs: bit-exact logical mapping, direction, working counters of logical commands.

use super::*;
use hal::esc::{regs, FmmuConfig, FmmuType};
use hal::pdi::EscPdi;

fn fmmu(ls: u32, len: u16, lsb: u8, leb: u8, ps: u16, psb: u8, kind: u8) -> [u8; 16] {
    FmmuConfig {
        logical_start: ls,
        length: len,
        logical_start_bit: lsb,
        logical_end_bit: leb,
        physical_start: ps,
        physical_start_bit: psb,
        kind: FmmuType(kind),
        active: true,
    }
    .to_bytes()
}

#[test]
fn fmmu_maps_bit_exact_logical_range() {
    // Logical bits 2..5 of 0x0001_0000 -> physical bits 4..7 of 0x0F81.
    let mut escs = ring(1);
    let phys = regs::USER_RAM.addr + 1;
    escs[0].write(phys, &[0x0F]).unwrap();
    fpwr(
        &mut escs,
        0,
        regs::fmmu(0).addr,
        &fmmu(0x1_0000, 1, 2, 5, phys, 4, FmmuType::WRITE),
    );
    let r = send(&mut escs, &[ldg(LWR, 0x1_0000, &[0b0010_1000])]).remove(0);
    assert_eq!(r.wkc, 1);
    assert_eq!(
        escs[0].read_u8(phys).unwrap(),
        0xAF,
        "bits 4..7 = 0b1010, bits 0..3 kept"
    );

    fpwr(&mut escs, 0, regs::fmmu(0).addr + 11, &[FmmuType::READ]);
    let r = send(&mut escs, &[ldg(LRD, 0x1_0000, &[0xFF])]).remove(0);
    assert_eq!((r.data[0], r.wkc), (0xEB, 1), "only bits 2..5 replaced");
}

#[test]
fn fmmu_mapping_spans_bytes_with_shifted_bits() {
    // 12 bits from logical bit 4 of byte 0x100 onto physical bit 0 of 0x0F90.
    let mut escs = ring(1);
    let phys = regs::USER_RAM.addr + 0x10;
    fpwr(
        &mut escs,
        0,
        regs::fmmu(1).addr,
        &fmmu(0x100, 2, 4, 7, phys, 0, FmmuType::WRITE),
    );
    let r = send(&mut escs, &[ldg(LWR, 0xFF, &[0x00, 0xA0, 0xCB, 0x00])]).remove(0);
    assert_eq!(r.wkc, 1);
    let mut b = [0; 2];
    escs[0].read(phys, &mut b).unwrap();
    assert_eq!(b, [0xBA, 0x0C]);
}

#[test]
fn logical_datagram_outside_every_fmmu_gets_no_wkc() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::fmmu(0).addr,
        &fmmu(
            0x100,
            4,
            0,
            7,
            regs::USER_RAM.addr,
            0,
            FmmuType::READ | FmmuType::WRITE,
        ),
    );
    assert_eq!(send(&mut escs, &[ldg(LRW, 0x200, &[0; 4])])[0].wkc, 0);
    assert_eq!(send(&mut escs, &[ldg(LRW, 0x102, &[0; 4])])[0].wkc, 3);
    assert_eq!(send(&mut escs, &[ldg(LWR, 0x0FE, &[0; 4])])[0].wkc, 1);
}

#[test]
fn soem_48_byte_write_configures_three_fmmus() {
    let mut escs = ring(1);
    let w = [
        fmmu(0, 4, 0, 7, 0x1200, 0, 2),
        fmmu(4, 4, 0, 7, 0x1300, 0, 1),
        fmmu(8, 1, 0, 7, regs::sm(1).addr + regs::sm_offset::STATUS, 0, 1),
    ]
    .concat();
    assert_eq!(fpwr(&mut escs, 0, regs::fmmu(0).addr, &w), 1);
    assert_eq!(fprd(&mut escs, 0, regs::fmmu(0).addr, 48).0, w);
}

#[test]
fn lrw_through_sms_counts_three_per_slave() {
    // Outputs via a write FMMU into SM2, inputs via a read FMMU from SM3, three slaves, LRW.
    let mut escs = ring(3);
    for k in 0..3 {
        let mut w = sm_bytes(0x1200, 2, 0x64, 1).to_vec();
        w.extend_from_slice(&sm_bytes(0x1300, 2, 0x20, 1));
        fpwr(&mut escs, k, regs::sm(2).addr, &w);
        let base = 4 * k as u32;
        let f = [
            fmmu(base, 2, 0, 7, 0x1200, 0, 2),
            fmmu(base + 2, 2, 0, 7, 0x1300, 0, 1),
        ]
        .concat();
        fpwr(&mut escs, k, regs::fmmu(0).addr, &f);
        escs[k]
            .write(0x1300, &[0x10 + k as u8, 0x20 + k as u8])
            .unwrap();
    }
    let out: Vec<u8> = (0..12).collect();
    let r = send(&mut escs, &[ldg(LRW, 0, &out)]).remove(0);
    assert_eq!(r.wkc, 9);
    assert_eq!(
        r.data,
        vec![0, 1, 0x10, 0x20, 4, 5, 0x11, 0x21, 8, 9, 0x12, 0x22]
    );
    for (k, e) in escs.iter_mut().enumerate() {
        let mut b = [0; 2];
        e.read(0x1200, &mut b).unwrap();
        assert_eq!(b, [4 * k as u8, 4 * k as u8 + 1]);
    }
}

#[test]
fn fmmu_can_map_sm_status_register_for_mailbox_polling() {
    // SOEM maps SM1 status 0x080D into the process image with an extra read FMMU.
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(1).addr,
        &sm_bytes(0x1100, 8, 0x22, 1),
    );
    fpwr(
        &mut escs,
        0,
        regs::fmmu(2).addr,
        &fmmu(
            0x40,
            1,
            0,
            7,
            regs::sm(1).addr + regs::sm_offset::STATUS,
            0,
            FmmuType::READ,
        ),
    );
    assert_eq!(
        send(&mut escs, &[ldg(LRD, 0x40, &[0])])[0].data[0] & 0x08,
        0
    );
    escs[0].write(0x1100, &[1; 8]).unwrap();
    let r = send(&mut escs, &[ldg(LRD, 0x40, &[0])]).remove(0);
    assert_eq!((r.data[0] & 0x08, r.wkc), (0x08, 1));
}
