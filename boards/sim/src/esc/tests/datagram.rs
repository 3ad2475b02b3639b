//! Datagram commands, addressing and working counters (ETG.1000.4 §5.4), register access rights.

use super::*;
use hal::esc::{regs, AlEvent, DlStatus};
use hal::pdi::EscPdi;

#[test]
fn aprd_addresses_slave_whose_adp_reaches_zero() {
    // Every ESC increments ADP; the one that sees 0 is addressed (ETG.1000.4 auto-increment).
    let mut escs = ring(3);
    let r = send(
        &mut escs,
        &[dg(APRD, 0xFFFE, regs::STATION_ADDRESS.addr, &[0, 0])],
    )
    .remove(0);
    assert_eq!(u16le(&r.data), station(2));
    assert_eq!(r.wkc, 1);
    assert_eq!(r.adp, 0xFFFE_u16.wrapping_add(3));
}

#[test]
fn fprd_addresses_by_station_address_and_alias_only_when_enabled() {
    let mut escs = ring(2);
    // Alias 0x0A11 comes from SII word 4 (both ESCs); not used until 0x0103 bit 0 is set.
    let (_, wkc) = send1(
        &mut escs,
        FPRD,
        W4_ALIAS,
        regs::STATION_ADDRESS.addr,
        &[0, 0],
    );
    assert_eq!(wkc, 0);
    fpwr(&mut escs, 1, regs::DL_CONTROL_ALIAS.addr, &[1]);
    let (data, wkc) = send1(
        &mut escs,
        FPRD,
        W4_ALIAS,
        regs::STATION_ADDRESS.addr,
        &[0, 0],
    );
    assert_eq!((u16le(&data), wkc), (station(1), 1));
}

#[test]
fn brd_ors_data_across_slaves() {
    let mut escs = ring(3);
    for (k, e) in escs.iter_mut().enumerate() {
        e.write(regs::USER_RAM.addr, &[1 << k]).unwrap();
    }
    let (data, wkc) = send1(&mut escs, BRD, 0, regs::USER_RAM.addr, &[0x80]);
    assert_eq!((data, wkc), (vec![0x87], 3));
}

#[test]
fn multi_slave_ring_wkc_counts_every_slave() {
    let mut escs = ring(3);
    assert_eq!(send1(&mut escs, BRD, 0, regs::TYPE.addr, &[0]).1, 3);
    assert_eq!(send1(&mut escs, BWR, 0, regs::USER_RAM.addr, &[5]).1, 3);
    for k in 0..3 {
        assert_eq!(fprd(&mut escs, k, regs::USER_RAM.addr, 1).0, vec![5]);
    }
    assert_eq!(send1(&mut escs, FPRD, 0x7777, regs::TYPE.addr, &[0]).1, 0);
}

#[test]
fn aprw_and_fprw_count_one_for_read_and_two_for_write() {
    let mut escs = ring(2);
    escs[0].write(regs::USER_RAM.addr, &[0x11]).unwrap();
    let (data, wkc) = send1(&mut escs, APRW, 0, regs::USER_RAM.addr, &[0x22]);
    assert_eq!((data, wkc), (vec![0x11], 3));
    let (data, wkc) = send1(&mut escs, FPRW, station(0), regs::USER_RAM.addr, &[0x33]);
    assert_eq!((data, wkc), (vec![0x22], 3));
}

#[test]
fn frmw_addressed_slave_reads_others_write() {
    let mut escs = ring(3);
    escs[1].write(regs::USER_RAM.addr, &[0x42]).unwrap();
    let (data, wkc) = send1(&mut escs, FRMW, station(1), regs::USER_RAM.addr, &[0]);
    // ESC0 writes the arriving 0 (+1), ESC1 reads 0x42 (+1), ESC2 writes 0x42 (+1).
    assert_eq!((data, wkc), (vec![0x42], 3));
    assert_eq!(fprd(&mut escs, 0, regs::USER_RAM.addr, 1).0, vec![0]);
    assert_eq!(fprd(&mut escs, 2, regs::USER_RAM.addr, 1).0, vec![0x42]);
}

#[test]
fn armw_slave_at_adp_zero_reads_others_write() {
    let mut escs = ring(2);
    escs[0].write(regs::USER_RAM.addr, &[0x99]).unwrap();
    let (data, wkc) = send1(&mut escs, ARMW, 0, regs::USER_RAM.addr, &[0]);
    assert_eq!((data, wkc), (vec![0x99], 2));
    assert_eq!(fprd(&mut escs, 1, regs::USER_RAM.addr, 1).0, vec![0x99]);
}

#[test]
fn writes_to_absent_fmmus_and_sms_are_ignored_but_counted() {
    // ethercrab blanks FMMU/SM 8..15 one by one and ignores the WKC; the ESC ignores the data.
    let mut escs = ring(1);
    assert_eq!(fpwr(&mut escs, 0, regs::fmmu(12).addr, &[0xFF; 16]), 1);
    assert_eq!(fpwr(&mut escs, 0, regs::sm(9).addr, &[0xFF; 8]), 1);
    assert_eq!(fprd(&mut escs, 0, regs::fmmu(12).addr, 16).0, vec![0; 16]);
    assert_eq!(fprd(&mut escs, 0, regs::sm(9).addr, 8).0, vec![0; 8]);
}

#[test]
fn access_beyond_address_space_gets_no_wkc() {
    let mut escs = ring(1);
    assert_eq!(fpwr(&mut escs, 0, 0x3000, &[1]), 0);
    assert_eq!(fprd(&mut escs, 0, 0xFFFF, 4).1, 0);
}

#[test]
fn sm0_sm1_16_byte_write_configures_both() {
    // SOEM writes SM0+SM1 in one 16-byte FPWR; status (+5) and PDI control (+7) stay untouched.
    let mut escs = ring(1);
    let mut w = Vec::new();
    let mut sm0 = sm_bytes(0x1000, 128, 0x26, 1);
    let mut sm1 = sm_bytes(0x1080, 128, 0x22, 1);
    sm0[5] = 0xFF;
    sm0[7] = 0xFF;
    sm1[5] = 0xFF;
    sm1[7] = 0xFF;
    w.extend_from_slice(&sm0);
    w.extend_from_slice(&sm1);
    assert_eq!(fpwr(&mut escs, 0, regs::sm(0).addr, &w), 1);
    let (r, _) = fprd(&mut escs, 0, regs::sm(0).addr, 16);
    assert_eq!(
        r,
        [
            sm_bytes(0x1000, 128, 0x26, 1),
            sm_bytes(0x1080, 128, 0x22, 1)
        ]
        .concat()
    );
}

#[test]
fn sm_start_length_control_are_write_protected_while_enabled() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1200, 4, 0x64, 1),
    );
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1400, 8, 0x20, 1),
    );
    let r = fprd(&mut escs, 0, regs::sm(2).addr, 8).0;
    assert_eq!(r[..5], sm_bytes(0x1200, 4, 0x64, 1)[..5]);
    assert_eq!(r[5], 0x30, "3-buffer status: no buffer written yet");
    // Disable and reconfigure in two datagrams works.
    fpwr(&mut escs, 0, regs::sm(2).addr + 6, &[0]);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1400, 8, 0x20, 1),
    );
    assert_eq!(
        fprd(&mut escs, 0, regs::sm(2).addr, 5).0,
        sm_bytes(0x1400, 8, 0x20, 1)[..5].to_vec()
    );
}

#[test]
fn u64_write_to_09a0_also_zeroes_09a4() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::DC_SYNC1_CYCLE.addr,
        &500u32.to_le_bytes(),
    );
    assert_eq!(
        fpwr(
            &mut escs,
            0,
            regs::DC_SYNC0_CYCLE.addr,
            &1_000_000u64.to_le_bytes()
        ),
        1
    );
    let (r, _) = fprd(&mut escs, 0, regs::DC_SYNC0_CYCLE.addr, 8);
    assert_eq!((u32le(&r), u32le(&r[4..])), (1_000_000, 0));
}

#[test]
fn twelve_byte_write_sets_offset_and_delay() {
    // IgH writes 0x0920 (offset, u64) and 0x0928 (delay, u32) in one 12-byte datagram.
    let mut escs = ring(1);
    let mut w = 0x0123_4567_89AB_CDEFu64.to_le_bytes().to_vec();
    w.extend_from_slice(&777u32.to_le_bytes());
    fpwr(&mut escs, 0, regs::DC_SYSTEM_TIME_OFFSET.addr, &w);
    assert_eq!(
        fprd(&mut escs, 0, regs::DC_SYSTEM_TIME_OFFSET.addr, 12).0,
        w
    );
}

#[test]
fn al_control_write_raises_al_event_and_pdi_read_clears_it() {
    let mut escs = ring(1);
    assert_eq!(
        fpwr(
            &mut escs,
            0,
            regs::AL_CONTROL.addr,
            &0x0012u16.to_le_bytes()
        ),
        1
    );
    assert!(escs[0].al_event_request().any(AlEvent::AL_CONTROL));
    let ev = escs[0].read(regs::AL_CONTROL.addr, &mut [0; 2]).unwrap();
    assert!(
        ev.any(AlEvent::AL_CONTROL),
        "event returned as at the start of the access"
    );
    assert!(!escs[0].al_event_request().any(AlEvent::AL_CONTROL));
    assert_eq!(escs[0].read_u16(regs::AL_CONTROL.addr).unwrap(), 0x0012);
}

#[test]
fn al_status_is_read_only_for_ecat_and_written_by_pdi() {
    let mut escs = ring(1);
    assert_eq!(fpwr(&mut escs, 0, regs::AL_STATUS.addr, &[0x08, 0]), 1);
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::AL_STATUS.addr, 2).0),
        0x0001
    );
    escs[0].write_u16(regs::AL_STATUS.addr, 0x0002).unwrap();
    escs[0]
        .write_u16(regs::AL_STATUS_CODE.addr, 0x0016)
        .unwrap();
    let (r, _) = fprd(&mut escs, 0, regs::AL_STATUS.addr, 6);
    assert_eq!((u16le(&r), u16le(&r[4..])), (0x0002, 0x0016));
}

#[test]
fn device_emulation_copies_al_control_to_al_status() {
    let mut img = sii();
    img[1] = 0x01; // 0x0141 bit 0
    img[14] = sii_crc8(&img[..14]);
    let mut escs = vec![Et1100::new(&img)];
    send1(&mut escs, BWR, 0, regs::AL_CONTROL.addr, &[0x02, 0]);
    assert_eq!(
        u16le(&send1(&mut escs, BRD, 0, regs::AL_STATUS.addr, &[0, 0]).0),
        0x0002
    );
}

#[test]
fn datagram_irq_field_carries_masked_ecat_events() {
    let mut escs = ring(1);
    escs[0].write_u16(regs::AL_STATUS.addr, 0x0002).unwrap(); // ECAT event bit 3 (AL status)
    let r = send(&mut escs, &[dg(BRD, 0, 0, &[0])]).remove(0);
    assert_eq!(r.irq, 0, "masked by 0x0200 = 0");
    send1(
        &mut escs,
        BWR,
        0,
        regs::ECAT_EVENT_MASK.addr,
        &0x0008u16.to_le_bytes(),
    );
    let r = send(&mut escs, &[dg(BRD, 0, 0, &[0])]).remove(0);
    assert_eq!(r.irq, 0x0008);
    // Reading AL status from ECAT clears the AL status event.
    fprd(&mut escs, 0, regs::AL_STATUS.addr, 2);
    assert_eq!(send(&mut escs, &[dg(BRD, 0, 0, &[0])]).remove(0).irq, 0);
}

#[test]
fn dl_status_shows_open_ports_for_topology() {
    // SOEM: a port is open when (dl >> (8 + 2n)) & 3 == 0b10 (communication, loop open).
    let mut escs = ring(3);
    let open = |dl: u16, p: u16| (dl >> (8 + 2 * p)) & 0x3 == 0x2;
    for k in 0..3 {
        let dl = u16le(&fprd(&mut escs, k, regs::DL_STATUS.addr, 2).0);
        assert!(open(dl, 0));
        assert_eq!(open(dl, 1), k < 2, "port 1 of ESC {k}");
        assert!(!open(dl, 2) && !open(dl, 3));
        assert!(dl & DlStatus::PDI_OPERATIONAL != 0);
    }
}

#[test]
fn identity_registers_describe_an_et1100_with_64_bit_dc() {
    let mut escs = ring(1);
    let (r, _) = fprd(&mut escs, 0, regs::TYPE.addr, 10);
    assert_eq!((r[0], r[4], r[5], r[6]), (0x11, 8, 8, 8));
    let features = u16le(&r[8..]);
    assert_eq!(features & 0x000D, 0x000D, "FMMU bit op, DC, 64-bit DC");
}

#[test]
fn error_counter_write_clears_its_group() {
    let mut escs = ring(1);
    assert_eq!(
        send1(&mut escs, BWR, 0, regs::RX_ERROR_COUNTERS.addr, &[0; 8]).1,
        1
    );
    assert_eq!(
        fprd(&mut escs, 0, regs::RX_ERROR_COUNTERS.addr, 20).0,
        vec![0; 20]
    );
}

#[test]
fn eeprom_config_u16_write_also_hitting_0501_is_tolerated() {
    // ethercrab writes u16 2 to 0x0500; 0x0501 is read-only for ECAT.
    let mut escs = ring(1);
    assert_eq!(
        fpwr(&mut escs, 0, regs::EEPROM_CONFIG.addr, &2u16.to_le_bytes()),
        1
    );
    assert_eq!(
        fprd(&mut escs, 0, regs::EEPROM_CONFIG.addr, 2).0,
        vec![2, 0]
    );
}
