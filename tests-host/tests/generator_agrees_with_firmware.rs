//! od-gen refuses every profile setting the firmware would refuse at run time, so that a profile
//! that generates also runs (issue 12 item 4). Each case loads the setting through both: the
//! generator's validation of a profile file, and the firmware's own check with the same value.

use firmware::slave::esm::sm_check;
use hal::esc::{AlStatusCode, SmActivate, SmConfig, SmControl, MAX_FIRMWARE_MAILBOX};
use od_gen::{Error, Invalid};

const STANDARD: &str = include_str!("../../od-gen/profiles/standard.toml");
const MAILBOX_OUT: &str = "mailbox_out = { start = 0x1000, size = 256, control = 0x26 }";
const MAILBOX_IN: &str = "mailbox_in = { start = 0x1100, size = 256, control = 0x22 }";

/// The standard profile with both mailboxes `size` bytes long (the input mailbox moved behind
/// the output one, the process data behind both, 1 KiB apart).
fn standard_with_mailboxes(size: u16) -> String {
    assert!(STANDARD.contains(MAILBOX_OUT) && STANDARD.contains(MAILBOX_IN));
    let inputs_at = 0x1000 + u32::from(size);
    let outputs_at = inputs_at + u32::from(size);
    STANDARD
        .replacen(
            MAILBOX_OUT,
            &format!("mailbox_out = {{ start = 0x1000, size = {size}, control = 0x26 }}"),
            1,
        )
        .replacen(
            MAILBOX_IN,
            &format!("mailbox_in = {{ start = {inputs_at:#06x}, size = {size}, control = 0x22 }}"),
            1,
        )
        .replacen(
            "outputs = { start = 0x1200",
            &format!("outputs = {{ start = {outputs_at:#06x}"),
            1,
        )
        .replacen(
            "inputs = { start = 0x1600",
            &format!("inputs = {{ start = {:#06x}", outputs_at + 0x400),
            1,
        )
}

/// What the firmware answers at INIT → PREOP when the master configures SM0/SM1 exactly as a
/// profile whose mailboxes are `size` bytes long declares them.
fn firmware_answer(size: u16) -> Result<(), AlStatusCode> {
    let mut device = firmware::profiles::by_name("standard")
        .expect("standard")
        .od
        .device;
    device.mailbox_out.length = size;
    device.mailbox_in.start = device.mailbox_out.start + size;
    device.mailbox_in.length = size;
    let sm = |layout: firmware::od::SmLayout| SmConfig {
        start: layout.start,
        length: layout.length,
        control: SmControl(layout.control),
        activate: SmActivate(1),
        ..SmConfig::default()
    };
    sm_check::check_mailbox(sm(device.mailbox_out), sm(device.mailbox_in), &device)
}

/// The generator's verdict on `text`: `Ok` or the key and error it names.
fn generator_answer(text: &str) -> Result<(), (String, Invalid)> {
    match od_gen::parse(text, "standard.toml") {
        Ok(_) => Ok(()),
        Err(Error::Invalid { key, error, .. }) => Err((key, error)),
        Err(e) => panic!("expected a validation verdict, got: {e}"),
    }
}

#[test]
fn a_mailbox_longer_than_the_firmware_buffers_is_refused_by_both() {
    // The firmware refuses it at INIT → PREOP with 0x0016 (ETG.1000.6 Table 11: invalid
    // mailbox configuration), so the generator must not produce it.
    let too_long = MAX_FIRMWARE_MAILBOX * 2;
    assert_eq!(
        firmware_answer(too_long),
        Err(AlStatusCode::InvalidMailboxConfig)
    );
    let (key, error) = generator_answer(&standard_with_mailboxes(too_long))
        .expect_err("od-gen accepted a mailbox the firmware refuses");
    assert_eq!(key, "sm.mailbox_out.size");
    assert!(
        error.to_string().contains("0x0016"),
        "the reason names the firmware's answer: {error}"
    );
    // One byte over the limit is refused by both as well.
    assert!(firmware_answer(MAX_FIRMWARE_MAILBOX + 1).is_err());
    assert!(generator_answer(&standard_with_mailboxes(MAX_FIRMWARE_MAILBOX + 1)).is_err());
}

#[test]
fn a_mailbox_at_the_firmware_limit_is_accepted_by_both() {
    assert_eq!(firmware_answer(MAX_FIRMWARE_MAILBOX), Ok(()));
    assert_eq!(
        generator_answer(&standard_with_mailboxes(MAX_FIRMWARE_MAILBOX)),
        Ok(())
    );
}

#[test]
fn sync_managers_beyond_the_et1100_process_ram_are_refused() {
    // 8 KiB of process RAM from 0x1000: an SM ending past 0x3000 does not exist on the ESC.
    let text = STANDARD.replacen(
        "outputs = { start = 0x1200",
        "outputs = { start = 0x2FF0",
        1,
    );
    let (key, error) = generator_answer(&text).expect_err("outputs past the process RAM");
    assert_eq!(key, "sm.outputs.start");
    assert!(error.to_string().contains("0x1000..0x3000"), "{error}");
}
