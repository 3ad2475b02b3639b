//! The `[[adjusting]]` section → [`Adjusting`] services, checked against the resolved
//! dictionary: a vendor's maintenance request/reply channel (the Σ-V-SD's 2310h "SERVOPACK
//! Adjusting Command", §4.5 (8)) executed by the firmware's `adjust` module.
//!
//! The object must be a RECORD with :01 command (STRING of 16 bytes, writable, in RAM, not
//! PDO-mappable), :02 status (USINT, read-only, in RAM) and :03 reply (STRING of 16 bytes,
//! read-only, in RAM); the request codes are unique, the actions known, the times ≥ 1 ms, at
//! most [`MAX_SERVICES`] services with distinct objects and axes.

use crate::error::{fault, Fault, Invalid};
use crate::file::AdjustingFile;
use crate::model::*;

/// Services the firmware serves (`firmware::drive::MAX_ADJUSTING_SERVICES`).
pub const MAX_SERVICES: usize = 2;
/// The request and reply frames, bytes.
const FRAME_BYTES: usize = 16;
/// Subindexes of the record.
const SUB_COMMAND: u8 = 1;
const SUB_STATUS: u8 = 2;
const SUB_REPLY: u8 = 3;

/// Resolves `[[adjusting]]` of profile `p` (whose objects are complete).
pub(crate) fn resolve(f: &[AdjustingFile], p: &Profile) -> Result<Vec<Adjusting>, Fault> {
    if f.len() > MAX_SERVICES {
        return Err(fault(
            "adjusting",
            Invalid::Value(format!("at most {MAX_SERVICES} services")),
        ));
    }
    let mut out: Vec<Adjusting> = Vec::new();
    for (i, a) in f.iter().enumerate() {
        let key = |k: &str| format!("adjusting[{i}].{k}");
        check_object(p, a.object, &key("object"))?;
        if out.iter().any(|o| o.object == a.object || o.axis == a.axis) {
            return Err(fault(
                &key("object"),
                Invalid::Value("another service has this object or axis".into()),
            ));
        }
        if !(1..=MAX_SERVICES as u8).contains(&a.axis) {
            return Err(fault(
                &key("axis"),
                Invalid::Value(format!("must be 1..={MAX_SERVICES}")),
            ));
        }
        for (k, v) in [
            ("abort_after_ms", a.abort_after_ms),
            ("time_limit_ms", a.time_limit_ms),
        ] {
            if v == 0 {
                return Err(fault(&key(k), Invalid::Value("must be at least 1".into())));
            }
        }
        let mut commands: Vec<AdjustingCommand> = Vec::new();
        for (j, c) in a.commands.iter().enumerate() {
            let ckey = key(&format!("commands[{j}]"));
            let action = AdjustAction::parse(&c.action).ok_or_else(|| {
                fault(
                    &format!("{ckey}.action"),
                    Invalid::Value(format!(
                        "`{}` is not one of {}",
                        c.action,
                        AdjustAction::NAMES.join(", ")
                    )),
                )
            })?;
            if c.code == 0 || commands.iter().any(|o| o.code == c.code) {
                return Err(fault(
                    &format!("{ckey}.code"),
                    Invalid::Value(format!("{:#06x} is 0 (abort) or used twice", c.code)),
                ));
            }
            commands.push(AdjustingCommand {
                code: c.code,
                action,
                preparation: c.preparation,
            });
        }
        if commands.is_empty() {
            return Err(fault(
                &key("commands"),
                Invalid::Value("needs at least one adjustment".into()),
            ));
        }
        out.push(Adjusting {
            object: a.object,
            axis: a.axis,
            abort_after_ms: a.abort_after_ms,
            time_limit_ms: a.time_limit_ms,
            commands,
        });
    }
    Ok(out)
}

/// The record layout the firmware reads and writes.
fn check_object(p: &Profile, index: u16, key: &str) -> Result<(), Fault> {
    let bad = |why: String| Err(fault(key, Invalid::Value(format!("{index:#06x}: {why}"))));
    let Some(o) = p.objects.iter().find(|o| o.index == index) else {
        return bad("no such object".into());
    };
    let entry = |sub: u8| o.entries.iter().find(|e| e.subindex == sub);
    let frame = |e: Option<&Entry>, writable: bool| {
        e.is_some_and(|e| {
            e.data_type == DataType::VisibleString
                && e.byte_len() == FRAME_BYTES
                && e.storage == Storage::Ram
                && e.access.writable() == writable
                && e.pdo == PdoMapping::No
        })
    };
    let status = entry(SUB_STATUS).is_some_and(|e| {
        e.data_type == DataType::Usint && e.storage == Storage::Ram && !e.access.writable()
    });
    if o.code != ObjectCode::Record
        || !frame(entry(SUB_COMMAND), true)
        || !status
        || !frame(entry(SUB_REPLY), false)
    {
        return bad(
            "must be a RECORD with :01 STRING(16) writable, :02 USINT read-only, :03 STRING(16) read-only, all in RAM and not PDO-mappable"
                .into(),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_action_name_parses() {
        for name in AdjustAction::NAMES {
            assert!(AdjustAction::parse(name).is_some(), "{name}");
        }
        assert_eq!(AdjustAction::parse("format_disk"), None);
    }
}
