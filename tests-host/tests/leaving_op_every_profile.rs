//! Leaving OP while the drive is Operation Enabled, on every profile, end to end (ethercrab,
//! DC SYNC0 at 1 ms, cyclic synchronous velocity at rest; the master requests SAFE-OP):
//!
//! - the GHA-E raises Co02 "EtherCAT state machine conversion abnormal", 603Fh = FF06h (§6.1:
//!   "When CiA402 is in Operation Enabled" and the ESM leaves OP);
//! - the SDV3-E and OSD-G-E raise ESr, 603Fh = 8801h, error No. 39h, auxiliary code 801Ch
//!   (Table 5-1, §5.2 10));
//! - the standard profile, the RSE and the Σ-V-SD have no such alarm (CiA402 and their manuals
//!   state none): the drive is disabled, without a fault.
//!
//! Each ends with the bridge off (not Operation Enabled) and the ESM in SAFE-OP as requested.

use ethercrab::MainDevice;
use tests_host::vendor;
use tests_host::{block_on, cia402, emcy, master_for};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;

/// What the manual says leaving OP while enabled raises: an alarm (display, 603Fh, EMCY
/// manufacturer bytes) or nothing.
fn manual(name: &str) -> Option<(&'static str, u16, [u8; 5])> {
    match name {
        "gha-e" => Some(("Co02", 0xFF06, [0; 5])),
        "sdv3-e" | "osd-g-e" => Some(("ESr", 0x8801, [0x39, 0x1C, 0x80, 0, 0])),
        _ => None,
    }
}

/// What a drive of `name` did; an error message if it is not what its manual says.
fn leave_op(name: &str) -> Result<(), String> {
    let profile = od_gen::builtin(name).expect("profile");
    let expected = manual(name);
    if let Some((display, code, _)) = expected {
        // The alarm is a row of the profile's table with the manual's code.
        let row = profile.alarms.iter().find(|a| a.display == display);
        if row.map(|a| a.error_code) != Some(code) {
            return Err(format!("no alarm {display} with 603Fh {code:04X}h"));
        }
    }
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CSV, CYCLE_NS).await;
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            let inputs = vendor::exchange_dc_command(&m, md, &group, (cw, CSV, 0), CYCLE_NS).await;
            sw = vendor::u16_at(&inputs, 0);
        }
        if !cia402::is(sw, cia402::OPERATION_ENABLED) {
            return Err(format!("not enabled: {sw:#06x}"));
        }
        while emcy::read(md, profile.sm.mailbox_in.start).await?.is_some() {}
        let group = group
            .into_safe_op(md)
            .await
            .map_err(|e| format!("OP -> SAFE-OP: {e:?}"))?;
        // Let the drive's background run (its event handler and the next SYNC0s).
        let mut emergency = None;
        for _ in 0..50 {
            group
                .tx_rx_dc(md)
                .await
                .map_err(|e| format!("tx/rx: {e:?}"))?;
            m.shared.advance(CYCLE_NS);
            if let Some(e) = emcy::read(md, profile.sm.mailbox_in.start).await? {
                emergency.get_or_insert(e);
            }
        }
        let sd = group.subdevice(md, 0).expect("drive");
        let sw: u16 = sd
            .sdo_read(0x6041, 0)
            .await
            .map_err(|e| format!("6041h: {e:?}"))?;
        let code: u16 = sd
            .sdo_read(0x603F, 0)
            .await
            .map_err(|e| format!("603Fh: {e:?}"))?;
        if cia402::is(sw, cia402::OPERATION_ENABLED) {
            return Err(format!("still enabled: {sw:#06x}"));
        }
        match expected {
            Some((display, error_code, data)) => {
                if !cia402::is(sw, cia402::FAULT) || code != error_code {
                    return Err(format!(
                        "{display}: statusword {sw:#06x}, 603Fh {code:04X}h, expected Fault and {error_code:04X}h"
                    ));
                }
                match emergency {
                    Some(e) if e.code == error_code && e.data == data => Ok(()),
                    other => Err(format!("{display}: emergency {other:04x?}")),
                }
            }
            None => {
                if cia402::is(sw, cia402::FAULT) || code != 0 {
                    return Err(format!(
                        "a fault the manual does not have: {sw:#06x}, 603Fh {code:04X}h"
                    ));
                }
                match emergency {
                    None => Ok(()),
                    Some(e) => Err(format!("an emergency: {e:04x?}")),
                }
            }
        }
    })
}

#[test]
fn leaving_op_while_enabled_on_every_profile() {
    let failures: Vec<String> = [
        "standard",
        "gha-e",
        "rse",
        "sdv3-e",
        "osd-g-e",
        "sigma-v-sd",
    ]
    .iter()
    .filter_map(|name| leave_op(name).err().map(|e| format!("{name}: {e}")))
    .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
