//! SII EEPROM: power-on load, CRC, and the EEPROM interface as ethercrab and SOEM drive it.

use super::*;
use crate::esc::SimPdiError;
use hal::esc::{regs, DlStatus, EepromControl};
use hal::pdi::EscPdi;

fn control(escs: &mut [Et1100]) -> u16 {
    u16le(&fprd(escs, 0, regs::EEPROM_CONTROL.addr, 2).0)
}

/// Polls 0x0502 until not busy (as masters do); returns the number of busy polls.
fn poll(escs: &mut [Et1100]) -> usize {
    for polls in 0..10 {
        if control(escs) & EepromControl::BUSY == 0 {
            return polls;
        }
    }
    panic!("EEPROM stays busy");
}

#[test]
fn sii_crc8_matches_the_ethercat_check_value() {
    // CRC-8 poly 0x07 init 0xFF, no reflection, no final XOR (ethercrab's ECAT_CRC_ALGORITHM
    // parameters). Over "123456789" that algorithm gives 0xFB (its `check: 0x80` field is not
    // verified by the crc crate and does not match the parameters).
    assert_eq!(sii_crc8(b"123456789"), 0xFB);
    assert_eq!(sii_crc8(&[]), 0xFF);
    assert_eq!(sii_crc8(&[0xFF]), 0x00);
}

#[test]
fn power_on_loads_configuration_words_and_alias() {
    let mut escs = ring(1);
    let r = fprd(&mut escs, 0, regs::PDI_CONTROL.addr, 2).0;
    assert_eq!(u16le(&r), W0_PDI_CONTROL);
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::PDI_CONFIG.addr, 2).0),
        W1_PDI_CONFIG
    );
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::DC_PULSE_LENGTH.addr, 2).0),
        W2_PULSE
    );
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::STATION_ALIAS.addr, 2).0),
        W4_ALIAS
    );
    let c = control(&mut escs);
    assert_eq!(
        c & (EepromControl::CHECKSUM_ERROR | EepromControl::NOT_LOADED),
        0
    );
    assert_ne!(c & EepromControl::READ_8_BYTES, 0, "ET1100 reads 8 bytes");
}

#[test]
fn bad_sii_crc_sets_checksum_error() {
    let mut img = sii();
    img[14] ^= 0xFF;
    let mut escs = vec![Et1100::new(&img)];
    send1(
        &mut escs,
        APWR,
        0,
        regs::STATION_ADDRESS.addr,
        &station(0).to_le_bytes(),
    );
    assert_ne!(control(&mut escs) & EepromControl::CHECKSUM_ERROR, 0);
    let dl = u16le(&fprd(&mut escs, 0, regs::DL_STATUS.addr, 2).0);
    assert_eq!(dl & DlStatus::PDI_OPERATIONAL, 0);
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::STATION_ALIAS.addr, 2).0),
        0,
        "alias not loaded"
    );
    assert_eq!(
        escs[0].read(regs::AL_CONTROL.addr, &mut [0; 2]),
        Err(SimPdiError::NotOperational)
    );
}

#[test]
fn eeprom_read_returns_8_bytes_at_word_address() {
    // ethercrab: one 6-byte FPWR at 0x0502 (read command + word address), poll busy, read 8 bytes.
    let mut escs = ring(1);
    let req = [0x00, 0x01, 0x40, 0x00, 0x00, 0x00];
    assert_eq!(fpwr(&mut escs, 0, regs::EEPROM_CONTROL.addr, &req), 1);
    assert_eq!(poll(&mut escs), 1, "busy is visible to the first poll");
    let (data, wkc) = fprd(&mut escs, 0, regs::EEPROM_DATA.addr, 8);
    assert_eq!(data, (0x80..0x88).collect::<Vec<u8>>());
    assert_eq!(wkc, 1);
}

#[test]
fn eeprom_command_written_separately_completes_after_simulated_time() {
    // SOEM: address first, then the command word; time advancing also ends busy.
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_ADDRESS.addr,
        &0x41u32.to_le_bytes(),
    );
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_CONTROL.addr,
        &EepromControl::CMD_READ.to_le_bytes(),
    );
    let t = escs[0].next_event_ns().unwrap();
    escs[0].advance_to(t);
    assert_eq!(
        escs[0].next_event_ns(),
        Some(100_000_000),
        "only the PDI watchdog remains"
    );
    assert_eq!(control(&mut escs) & EepromControl::BUSY, 0);
    assert_eq!(
        fprd(&mut escs, 0, regs::EEPROM_DATA.addr, 4).0,
        vec![0x82, 0x83, 0x84, 0x85]
    );
}

#[test]
fn eeprom_write_needs_write_enable_in_the_same_access() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_ADDRESS.addr,
        &0x50u32.to_le_bytes(),
    );
    fpwr(&mut escs, 0, regs::EEPROM_DATA.addr, &[0xDE, 0xAD]);
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_CONTROL.addr,
        &EepromControl::CMD_WRITE.to_le_bytes(),
    );
    assert_ne!(control(&mut escs) & EepromControl::WRITE_ENABLE_ERROR, 0);
    assert_eq!(&escs[0].sii()[0xA0..0xA2], &[0xA0, 0xA1]);
    fpwr(&mut escs, 0, regs::EEPROM_CONTROL.addr, &[0, 0]);
    assert_eq!(
        control(&mut escs) & EepromControl::WRITE_ENABLE_ERROR,
        0,
        "command 0 clears errors"
    );
    let cmd = EepromControl::CMD_WRITE | EepromControl::WRITE_ENABLE;
    fpwr(&mut escs, 0, regs::EEPROM_CONTROL.addr, &cmd.to_le_bytes());
    poll(&mut escs);
    assert_eq!(&escs[0].sii()[0xA0..0xA2], &[0xDE, 0xAD]);
    assert_eq!(
        control(&mut escs) & EepromControl::WRITE_ENABLE,
        0,
        "write enable self-clears"
    );
}

#[test]
fn invalid_eeprom_command_sets_ack_error() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_CONTROL.addr,
        &0x0300u16.to_le_bytes(),
    );
    let c = control(&mut escs);
    assert_ne!(c & EepromControl::ACK_ERROR, 0);
    assert_eq!(c & EepromControl::BUSY, 0);
}

#[test]
fn writes_to_eeprom_interface_while_busy_are_ignored() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_CONTROL.addr,
        &[0x00, 0x01, 0x40, 0x00, 0x00, 0x00],
    );
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_ADDRESS.addr,
        &0x44u32.to_le_bytes(),
    );
    poll(&mut escs);
    assert_eq!(
        fprd(&mut escs, 0, regs::EEPROM_DATA.addr, 2).0,
        vec![0x80, 0x81]
    );
    assert_eq!(
        u32le(&fprd(&mut escs, 0, regs::EEPROM_ADDRESS.addr, 4).0),
        0x40
    );
}

#[test]
fn pdi_cannot_use_the_interface_unless_offered_and_taken() {
    let mut escs = ring(1);
    escs[0]
        .write(regs::EEPROM_ADDRESS.addr, &0x40u32.to_le_bytes())
        .unwrap();
    assert_eq!(
        u32le(&fprd(&mut escs, 0, regs::EEPROM_ADDRESS.addr, 4).0),
        0
    );
    escs[0].write_u8(regs::EEPROM_PDI_ACCESS.addr, 1).unwrap();
    assert_eq!(
        escs[0].read_u8(regs::EEPROM_PDI_ACCESS.addr).unwrap(),
        0,
        "not offered"
    );
    fpwr(&mut escs, 0, regs::EEPROM_CONFIG.addr, &[1]);
    escs[0].write_u8(regs::EEPROM_PDI_ACCESS.addr, 1).unwrap();
    escs[0]
        .write(
            regs::EEPROM_CONTROL.addr,
            &[0x00, 0x01, 0x40, 0x00, 0x00, 0x00],
        )
        .unwrap();
    fpwr(
        &mut escs,
        0,
        regs::EEPROM_ADDRESS.addr,
        &0x10u32.to_le_bytes(),
    );
    assert_eq!(
        u32le(&fprd(&mut escs, 0, regs::EEPROM_ADDRESS.addr, 4).0),
        0x40,
        "ECAT locked out"
    );
    // SOEM's "0x0500 = 2" forces ECAT access back.
    fpwr(&mut escs, 0, regs::EEPROM_CONFIG.addr, &[2]);
    assert_eq!(escs[0].read_u8(regs::EEPROM_PDI_ACCESS.addr).unwrap(), 0);
}

#[test]
fn reload_reloads_configuration_but_not_alias_and_checks_crc() {
    let mut escs = ring(1);
    escs[0].write_u16(regs::STATION_ALIAS.addr, 0x5555).unwrap();
    let write_word = |escs: &mut Vec<Et1100>, w: u32, v: u16| {
        fpwr(escs, 0, regs::EEPROM_ADDRESS.addr, &w.to_le_bytes());
        fpwr(escs, 0, regs::EEPROM_DATA.addr, &v.to_le_bytes());
        let cmd = EepromControl::CMD_WRITE | EepromControl::WRITE_ENABLE;
        fpwr(escs, 0, regs::EEPROM_CONTROL.addr, &cmd.to_le_bytes());
        poll(escs);
    };
    let reload = |escs: &mut Vec<Et1100>| {
        fpwr(
            escs,
            0,
            regs::EEPROM_CONTROL.addr,
            &EepromControl::CMD_RELOAD.to_le_bytes(),
        );
        poll(escs);
    };
    write_word(&mut escs, 2, 200);
    reload(&mut escs);
    assert_ne!(
        control(&mut escs) & EepromControl::CHECKSUM_ERROR,
        0,
        "CRC no longer matches"
    );
    let mut head = escs[0].sii()[..14].to_vec();
    head[4..6].copy_from_slice(&200u16.to_le_bytes());
    write_word(&mut escs, 7, u16::from(sii_crc8(&head)));
    reload(&mut escs);
    assert_eq!(control(&mut escs) & EepromControl::CHECKSUM_ERROR, 0);
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::DC_PULSE_LENGTH.addr, 2).0),
        200
    );
    assert_eq!(
        u16le(&fprd(&mut escs, 0, regs::STATION_ALIAS.addr, 2).0),
        0x5555
    );
}
