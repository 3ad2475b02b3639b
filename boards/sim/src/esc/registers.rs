//! Per-byte register semantics (0x0000..0x0FFF) for the EtherCAT and PDI sides.
//!
//! Access rights follow the ET1100 datasheet (Section II register tables); where a register is
//! not listed here, neither side can write it and reads return the stored value (0 for reserved
//! addresses). Side effects that need the whole access (EEPROM command with its address, system
//! time written as 4 or 8 bytes, DC latch, SYNC activation) are collected in [`Effects`] and run
//! by [`Et1100::finish_write`].

use hal::esc::{regs, AlControl, AlEvent, DcCyclicUnitControl, DcSyncStatus, EcatEvent, EscConfig};

use super::access::{Effects, Side};
use super::sm;
use super::Et1100;

/// Whether `addr` lies in the FMMU block of FMMUs that exist.
fn fmmu_register(addr: u16) -> Option<(usize, u16)> {
    let rel = addr.checked_sub(regs::FMMU_BASE)?;
    let n = usize::from(rel / regs::FMMU_LEN);
    (n < usize::from(regs::ET1100_FMMUS)).then_some((n, rel % regs::FMMU_LEN))
}

/// Error counter groups: a write to any member clears the whole group (Section II 0x0300 ff.).
const ERROR_COUNTER_GROUPS: [regs::Reg; 4] = [
    regs::Reg::new(
        regs::RX_ERROR_COUNTERS.addr,
        regs::RX_ERROR_COUNTERS.len + regs::FORWARDED_RX_ERROR_COUNTERS.len,
    ),
    regs::ECAT_PU_ERROR_COUNTER,
    regs::Reg::new(
        regs::PDI_ERROR_COUNTER.addr,
        regs::PDI_ERROR_COUNTER.len + regs::PDI_ERROR_CODE.len,
    ),
    regs::LOST_LINK_COUNTERS,
];

/// Registers the ECAT side may write as plain storage.
const ECAT_PLAIN: [regs::Reg; 17] = [
    regs::STATION_ADDRESS,
    regs::WRITE_REG_ENABLE,
    regs::WRITE_REG_PROTECTION,
    regs::ESC_WRITE_ENABLE,
    regs::ESC_WRITE_PROTECTION,
    regs::RESET_ECAT,
    regs::DL_CONTROL,
    regs::PHYSICAL_RW_OFFSET,
    regs::RUN_LED_OVERRIDE,
    regs::ERR_LED_OVERRIDE,
    regs::ECAT_EVENT_MASK,
    regs::WATCHDOG_DIVIDER,
    regs::WATCHDOG_TIME_PDI,
    regs::WATCHDOG_TIME_PD,
    regs::MII_MANAGEMENT,
    regs::DC_SYSTEM_TIME_OFFSET,
    regs::DC_SYSTEM_TIME_DELAY,
];

/// DC registers the ECAT side may write as plain storage.
const ECAT_PLAIN_DC: [regs::Reg; 4] = [
    regs::DC_TIME_FILTER_DEPTH,
    regs::DC_SPEED_FILTER_DEPTH,
    regs::DC_CYCLIC_UNIT_CONTROL,
    regs::DC_LATCH_CONTROL,
];

/// Registers the PDI side may write as plain storage.
const PDI_PLAIN: [regs::Reg; 4] = [
    regs::STATION_ALIAS,
    regs::AL_STATUS_CODE,
    regs::AL_EVENT_MASK,
    regs::RESET_PDI,
];

/// Registers of the SYNC unit written by whichever side 0x0980 bit 0 assigns it to.
const SYNC_UNIT_PLAIN: [regs::Reg; 3] = [
    regs::DC_START_TIME,
    regs::DC_SYNC0_CYCLE,
    regs::DC_SYNC1_CYCLE,
];

fn in_any(set: &[regs::Reg], addr: u16) -> bool {
    set.iter().any(|r| r.contains(addr))
}

impl Et1100 {
    /// The side that owns the SYNC unit registers (0x0980 bit 0).
    fn sync_unit_owner(&self) -> Side {
        if DcCyclicUnitControl(self.u8_at(regs::DC_CYCLIC_UNIT_CONTROL.addr)).sync_unit_pdi() {
            Side::Pdi
        } else {
            Side::Ecat
        }
    }

    /// Reads one register byte with the side effects of `side`.
    pub(crate) fn read_register(&mut self, side: Side, addr: u16, fx: &mut Effects) -> u8 {
        if regs::DC_SYSTEM_TIME.contains(addr) {
            let t = match fx.system_time {
                Some(t) => t,
                None => {
                    let t = self.system_time_at(fx.time);
                    fx.system_time = Some(t);
                    t
                }
            };
            let i = usize::from(addr - regs::DC_SYSTEM_TIME.addr);
            return t.to_le_bytes().get(i).copied().unwrap_or(0);
        }
        let v = self.u8_at(addr);
        match side {
            Side::Pdi => {
                if regs::AL_CONTROL.contains(addr) {
                    self.set_al_event_bits(AlEvent::AL_CONTROL, false);
                } else if let Some((n, off)) = sm::sm_register(addr) {
                    self.sm_register_pdi_read(n, off);
                } else if regs::DC_SYNC0_STATUS.contains(addr) {
                    self.set_u8(addr, v & !DcSyncStatus::ACTIVE);
                    self.set_al_event_bits(AlEvent::SYNC0, false);
                } else if regs::DC_SYNC1_STATUS.contains(addr) {
                    self.set_u8(addr, v & !DcSyncStatus::ACTIVE);
                    self.set_al_event_bits(AlEvent::SYNC1, false);
                } else if regs::WATCHDOG_STATUS_PD.contains(addr) {
                    self.set_al_event_bits(AlEvent::WATCHDOG_PD, false);
                }
            }
            Side::Ecat => {
                if regs::AL_STATUS.contains(addr) {
                    self.set_ecat_event_bits(EcatEvent::AL_STATUS, false);
                } else if regs::DL_STATUS.contains(addr) {
                    self.set_ecat_event_bits(EcatEvent::DL_STATUS, false);
                }
            }
        }
        v
    }

    /// Writes one register byte (already merged with an FMMU bit mask) with the rights and side
    /// effects of `side`.
    pub(crate) fn write_register(&mut self, side: Side, addr: u16, v: u8, fx: &mut Effects) {
        match side {
            Side::Ecat => self.ecat_write_register(addr, v, fx),
            Side::Pdi => self.pdi_write_register(addr, v, fx),
        }
    }

    fn ecat_write_register(&mut self, addr: u16, v: u8, fx: &mut Effects) {
        if in_any(&ECAT_PLAIN, addr)
            || in_any(&ECAT_PLAIN_DC, addr)
            || regs::USER_RAM.contains(addr)
        {
            self.set_u8(addr, v);
        } else if regs::AL_CONTROL.contains(addr) {
            self.set_u8(addr, v);
            fx.al_control_written = true;
        } else if let Some(group) = ERROR_COUNTER_GROUPS.iter().find(|g| g.contains(addr)) {
            for a in group.addr..group.end() {
                self.set_u8(a, 0);
            }
        } else if regs::WATCHDOG_COUNTER_PD.contains(addr)
            || regs::WATCHDOG_COUNTER_PDI.contains(addr)
        {
            self.set_u8(addr, 0);
        } else if regs::EEPROM_CONFIG.contains(addr) {
            self.eeprom_config_ecat_write(v);
        } else if self.eeprom_interface_reg(addr) {
            self.eeprom_register_write(Side::Ecat, addr, v, fx);
        } else if let Some((_, off)) = fmmu_register(addr) {
            if off <= regs::fmmu_offset::ACTIVATE {
                self.set_u8(addr, v);
            }
        } else if let Some((n, off)) = sm::sm_register(addr) {
            self.sm_register_ecat_write(n, off, v);
        } else if regs::DC_RECEIVE_TIME_PORT0.contains(addr) {
            fx.dc_latch = true;
        } else if regs::DC_SYSTEM_TIME.contains(addr) {
            let i = addr - regs::DC_SYSTEM_TIME.addr;
            if let Some(b) = fx.systime_bytes.get_mut(usize::from(i)) {
                *b = v;
                fx.systime_mask |= 1 << i;
            }
        } else if regs::DC_SPEED_COUNTER_START.contains(addr) {
            self.set_u8(addr, v);
            fx.speed_counter_written = true;
        } else {
            self.sync_unit_write(Side::Ecat, addr, v, fx);
        }
        // Everything else (identity, AL status, DL status, event requests, reserved addresses,
        // FMMU/SM 8..15) is read-only or absent: ignored.
    }

    fn pdi_write_register(&mut self, addr: u16, v: u8, fx: &mut Effects) {
        if in_any(&PDI_PLAIN, addr) || regs::USER_RAM.contains(addr) {
            self.set_u8(addr, v);
        } else if regs::AL_STATUS.contains(addr) {
            if self.u8_at(addr) != v {
                self.set_ecat_event_bits(EcatEvent::AL_STATUS, true);
            }
            self.set_u8(addr, v);
        } else if regs::EEPROM_PDI_ACCESS.contains(addr) {
            self.eeprom_pdi_access_write(v);
        } else if self.eeprom_interface_reg(addr) {
            self.eeprom_register_write(Side::Pdi, addr, v, fx);
        } else if let Some((n, off)) = sm::sm_register(addr) {
            self.sm_register_pdi_write(n, off, v);
        } else {
            self.sync_unit_write(Side::Pdi, addr, v, fx);
        }
    }

    /// Writes of the SYNC unit registers (activation, start time, cycle times) by their owner.
    fn sync_unit_write(&mut self, side: Side, addr: u16, v: u8, fx: &mut Effects) {
        if self.sync_unit_owner() != side {
            return;
        }
        if regs::DC_ACTIVATION.contains(addr) {
            self.set_u8(addr, v);
            fx.activation_written = true;
        } else if in_any(&SYNC_UNIT_PLAIN, addr) {
            // The start time is not writable while cyclic operation runs (it reads back the next
            // SYNC0 pulse then).
            if regs::DC_START_TIME.contains(addr) && self.sync_active() {
                return;
            }
            self.set_u8(addr, v);
        }
    }

    /// Runs the hooks of a completed write access.
    pub(crate) fn finish_write(&mut self, side: Side, fx: &mut Effects) {
        if fx.al_control_written {
            self.set_al_event_bits(AlEvent::AL_CONTROL, true);
            if EscConfig(self.u8_at(regs::ESC_CONFIG.addr)).device_emulation() {
                let control = AlControl::from_bits(self.u16_at(regs::AL_CONTROL.addr));
                self.set_u16(regs::AL_STATUS.addr, u16::from(control.state_bits));
                self.set_ecat_event_bits(EcatEvent::AL_STATUS, true);
            }
        }
        if fx.speed_counter_written {
            self.dc.reset_loop(fx.time);
        }
        if fx.dc_latch && side == Side::Ecat {
            self.dc_latch(fx);
        }
        if fx.systime_mask != 0 && side == Side::Ecat {
            self.dc_system_time_written(fx);
        }
        if fx.activation_written {
            self.sync_activation_written();
        }
        if fx.eeprom_command_written {
            self.eeprom_execute(side, fx.eeprom_write_enable);
        }
        *fx = Effects {
            time: fx.time,
            frame: fx.frame,
            system_time: fx.system_time,
            ..Effects::default()
        };
    }
}
