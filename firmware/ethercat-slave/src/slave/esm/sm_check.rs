//! SyncManager configuration checks: what the master wrote into SM0..SM3 against the device's
//! declared layout (the same facts the SII and ESI carry, from the profile).

use hal::esc::{AlStatusCode, SmConfig, SmDirection, SmMode};

use crate::mailbox::MAX_MAILBOX;
use crate::od::{DeviceInfo, SmLayout};

/// Checks one mailbox SM against its layout: enabled, same start and length, mailbox mode,
/// the right direction.
fn mailbox_sm_ok(sm: SmConfig, layout: &SmLayout, direction: SmDirection) -> bool {
    sm.active()
        && sm.start == layout.start
        && sm.length == layout.length
        && (sm.length as usize) <= MAX_MAILBOX
        && sm.control.mode() == SmMode::Mailbox
        && sm.control.direction() == direction
}

/// INIT → PREOP: SM0 (master → slave) and SM1 (slave → master) must match the mailbox layout
/// (ETG.1000.6 §6.4.2), else AL status code 0x0016.
pub fn check_mailbox(
    sm0: SmConfig,
    sm1: SmConfig,
    device: &DeviceInfo,
) -> Result<(), AlStatusCode> {
    check_mailbox_layout(sm0, sm1, &device.mailbox_out, &device.mailbox_in)
        .map_err(|()| AlStatusCode::InvalidMailboxConfig)
}

/// INIT → BOOT: SM0/SM1 must match the bootstrap mailbox layout (SII words 0x14..0x17), else
/// 0x0015; a device without one refuses BOOT with 0x0013 (ETG.1000.6 Table 11).
pub fn check_boot_mailbox(
    sm0: SmConfig,
    sm1: SmConfig,
    device: &DeviceInfo,
) -> Result<(), AlStatusCode> {
    let (Some(out), Some(inp)) = (&device.boot_mailbox_out, &device.boot_mailbox_in) else {
        return Err(AlStatusCode::BootstrapNotSupported);
    };
    check_mailbox_layout(sm0, sm1, out, inp).map_err(|()| AlStatusCode::InvalidBootMailboxConfig)
}

fn check_mailbox_layout(
    sm0: SmConfig,
    sm1: SmConfig,
    out: &SmLayout,
    inp: &SmLayout,
) -> Result<(), ()> {
    if mailbox_sm_ok(sm0, out, SmDirection::EcatWrite)
        && mailbox_sm_ok(sm1, inp, SmDirection::EcatRead)
    {
        Ok(())
    } else {
        Err(())
    }
}

/// PREOP → SAFEOP: a process-data SM must be a buffered SM at the declared start address, in
/// the given direction, whose length equals the mapped size `bytes`. With nothing mapped the SM
/// must be disabled or of length 0. A mismatch gives `code` (0x001D for SM2, 0x001E for SM3).
pub fn check_process_data(
    sm: SmConfig,
    layout: &SmLayout,
    direction: SmDirection,
    bytes: u16,
    code: AlStatusCode,
) -> Result<(), AlStatusCode> {
    let ok = if bytes == 0 {
        !sm.active()
    } else {
        sm.active()
            && sm.start == layout.start
            && sm.length == bytes
            && sm.control.mode() == SmMode::Buffered
            && sm.control.direction() == direction
    };
    if ok {
        Ok(())
    } else {
        Err(code)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hal::esc::{SmActivate, SmControl};

    const OUT: SmLayout = SmLayout {
        start: 0x1200,
        length: 0,
        control: 0x64,
    };

    fn sm(start: u16, length: u16, control: u8, enable: bool) -> SmConfig {
        SmConfig {
            start,
            length,
            control: SmControl(control),
            activate: SmActivate(enable as u8),
            ..SmConfig::default()
        }
    }

    #[test]
    fn outputs_sm_with_mapped_length_passes() {
        assert_eq!(
            check_process_data(
                sm(0x1200, 7, 0x64, true),
                &OUT,
                SmDirection::EcatWrite,
                7,
                AlStatusCode::InvalidOutputConfig
            ),
            Ok(())
        );
    }

    #[test]
    fn outputs_sm_with_wrong_length_is_0x1d() {
        assert_eq!(
            check_process_data(
                sm(0x1200, 8, 0x64, true),
                &OUT,
                SmDirection::EcatWrite,
                7,
                AlStatusCode::InvalidOutputConfig
            ),
            Err(AlStatusCode::InvalidOutputConfig)
        );
    }

    #[test]
    fn outputs_sm_at_wrong_address_or_mode_is_refused() {
        let code = AlStatusCode::InvalidOutputConfig;
        assert!(check_process_data(
            sm(0x1300, 7, 0x64, true),
            &OUT,
            SmDirection::EcatWrite,
            7,
            code
        )
        .is_err());
        assert!(check_process_data(
            sm(0x1200, 7, 0x66, true),
            &OUT,
            SmDirection::EcatWrite,
            7,
            code
        )
        .is_err());
        assert!(check_process_data(
            sm(0x1200, 7, 0x60, true),
            &OUT,
            SmDirection::EcatWrite,
            7,
            code
        )
        .is_err());
        assert!(check_process_data(
            sm(0x1200, 7, 0x64, false),
            &OUT,
            SmDirection::EcatWrite,
            7,
            code
        )
        .is_err());
    }

    #[test]
    fn boot_mailbox_is_checked_against_the_bootstrap_layout() {
        let mut device = crate::od::test_device();
        let (sm0, sm1) = (sm(0x1000, 256, 0x26, true), sm(0x1100, 256, 0x22, true));
        assert_eq!(
            check_boot_mailbox(sm0, sm1, &device),
            Err(AlStatusCode::BootstrapNotSupported)
        );
        device.boot_mailbox_out = Some(SmLayout {
            start: 0x1000,
            length: 256,
            control: 0x26,
        });
        device.boot_mailbox_in = Some(SmLayout {
            start: 0x1100,
            length: 256,
            control: 0x22,
        });
        assert_eq!(check_boot_mailbox(sm0, sm1, &device), Ok(()));
        let short = sm(0x1000, 128, 0x26, true);
        assert_eq!(
            check_boot_mailbox(short, sm1, &device).map_err(|c| c.code()),
            Err(0x0015)
        );
    }

    #[test]
    fn nothing_mapped_requires_disabled_sm() {
        let code = AlStatusCode::InvalidInputConfig;
        assert_eq!(
            check_process_data(sm(0, 0, 0, false), &OUT, SmDirection::EcatRead, 0, code),
            Ok(())
        );
        assert_eq!(
            check_process_data(
                sm(0x1200, 4, 0x20, true),
                &OUT,
                SmDirection::EcatRead,
                0,
                code
            ),
            Err(code)
        );
    }
}
