//! `drivectl sbus plan FILE.toml`: check the identifier plan of a whole SBus (manual ch. 5.5,
//! 5.6, P817) with `sbus_can::plan`.
//!
//! The file:
//!
//! ```toml
//! bitrate = "500k"                 # P816: 125k, 250k, 500k or 1M
//!
//! [[device]]
//! name = "device 1"
//! address = 0                      # P813; leave out for a node that is no SBus slave (a PLC)
//! group = 0                        # P814, 0 if left out
//! sync_id = 0                      # P817, 0 if left out
//! master_of = ["address 1", "group 2"]   # MOVLNK targets, master-slave groups
//! sends_sync = 0                   # the identifier it sends SYNC on, if it does
//!
//! [[device.object]]                # variable telegrams (IPOS _SBusCommDef)
//! id = 1024
//! kind = "cyclic"                  # cyclic, acyclic or receive
//! cycle_ms = 100                   # cyclic only
//! offset_ms = 0                    # cyclic only, 0 if left out
//! len = 8                          # data bytes, 0–8
//! format = "motorola"              # or "intel"
//! ```

use std::path::Path;

use drive_core::can::Bitrate;
use sbus_can::ids::{Address, SlaveIds};
use sbus_can::plan::{Device, Object, ObjectKind, Plan, Target};
use serde::Deserialize;
use serde_json::json;

use crate::error::{CliError, Result};
use crate::sbus::iface::parse_bitrate;

/// `drivectl sbus plan --example`: a plan file to start from, every key with what it means.
pub const EXAMPLE: &str = r#"# An SBus identifier plan for `drivectl sbus plan FILE`: the manual's example of ch. 5.5
# (Bild 35), a drive (address 0) that is MOVLNK master of drive 1 and of group 2, with one
# cyclic variable telegram.

bitrate = "500k"                 # P816: 125k, 250k, 500k or 1M

[[device]]
name = "drive 0"
address = 0                      # P813; leave out for a node that is no SBus slave (a PLC)
group = 0                        # P814, 0 if left out
sync_id = 0                      # P817, 0 if left out
master_of = ["address 1", "group 2"]   # MOVLNK targets and master-slave groups

[[device.object]]                # a variable telegram (IPOS _SBusCommDef)
id = 1024
kind = "cyclic"                  # cyclic, acyclic or receive
cycle_ms = 100                   # cyclic only
offset_ms = 0                    # cyclic only, 0 if left out
len = 8                          # data bytes, 0-8
format = "motorola"              # or "intel"

[[device]]
name = "drive 1"
address = 1
group = 2

[[device.object]]
id = 1024
kind = "receive"
len = 8
format = "motorola"
"#;

/// The most a plan file may have (a plan of 64 devices with 32 objects each is far below).
const PLAN_LIMIT: u64 = 4 << 20;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    bitrate: Option<String>,
    #[serde(default)]
    device: Vec<DeviceFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceFile {
    name: String,
    address: Option<u8>,
    group: Option<u8>,
    sync_id: Option<u16>,
    #[serde(default)]
    master_of: Vec<String>,
    sends_sync: Option<u16>,
    #[serde(default)]
    object: Vec<ObjectFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectFile {
    id: u16,
    kind: String,
    cycle_ms: Option<u32>,
    offset_ms: Option<u32>,
    len: u8,
    format: Option<String>,
}

fn address(device: &str, what: &str, n: u8) -> Result<Address> {
    Address::new(n).ok_or_else(|| {
        CliError::usage(format!(
            "device '{device}': {what} {n} is out of range; SBus addresses are 0…63"
        ))
    })
}

fn target(device: &str, text: &str) -> Result<Target> {
    let bad = || {
        CliError::usage(format!(
            "device '{device}': master_of entry '{text}': write \"address N\" or \"group N\" \
             (N 0…63)"
        ))
    };
    let (what, n) = text.trim().split_once(' ').ok_or_else(bad)?;
    let n: u8 = n.trim().parse().map_err(|_| bad())?;
    let a = Address::new(n).ok_or_else(bad)?;
    match what {
        "address" => Ok(Target::Address(a)),
        "group" => Ok(Target::Group(a)),
        _ => Err(bad()),
    }
}

fn object(device: &str, o: &ObjectFile) -> Result<Object> {
    let intel = match o.format.as_deref().map(str::to_ascii_lowercase).as_deref() {
        None | Some("motorola") => false,
        Some("intel") => true,
        Some(other) => {
            return Err(CliError::usage(format!(
                "device '{device}', object {}: format '{other}': motorola or intel",
                o.id
            )));
        }
    };
    if o.len > 8 {
        return Err(CliError::usage(format!(
            "device '{device}', object {}: len {}: a variable telegram carries 0…8 bytes",
            o.id, o.len
        )));
    }
    let kind = match o.kind.as_str() {
        "cyclic" => ObjectKind::Cyclic {
            cycle_ms: o.cycle_ms.ok_or_else(|| {
                CliError::usage(format!(
                    "device '{device}', object {}: a cyclic object needs cycle_ms",
                    o.id
                ))
            })?,
            offset_ms: o.offset_ms.unwrap_or(0),
        },
        "acyclic" | "receive" if o.cycle_ms.is_some() || o.offset_ms.is_some() => {
            return Err(CliError::usage(format!(
                "device '{device}', object {}: cycle_ms and offset_ms are for cyclic objects only",
                o.id
            )));
        }
        "acyclic" => ObjectKind::Acyclic,
        "receive" => ObjectKind::Receive,
        other => {
            return Err(CliError::usage(format!(
                "device '{device}', object {}: kind '{other}': cyclic, acyclic or receive",
                o.id
            )));
        }
    };
    Ok(Object {
        id: o.id,
        len: u32::from(o.len) | if intel { 0x100 } else { 0 },
        kind,
    })
}

/// Parse a plan file's text (`source` names it in messages).
pub fn parse(text: &str, source: &str) -> Result<Plan> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let file: PlanFile = toml::from_str(text)
        .map_err(|e| CliError::usage(format!("{source}: {}", e.to_string().trim_end())))?;
    let bitrate = match &file.bitrate {
        Some(b) => parse_bitrate(b)?,
        None => Bitrate::K500,
    };
    let mut devices = Vec::new();
    for d in &file.device {
        let slave = match d.address {
            Some(a) => Some(SlaveIds {
                address: address(&d.name, "address", a)?,
                group: address(&d.name, "group", d.group.unwrap_or(0))?,
                sync_id: sync_id(&d.name, d.sync_id.unwrap_or(0))?,
            }),
            None if d.group.is_some() || d.sync_id.is_some() => {
                return Err(CliError::usage(format!(
                    "device '{}': group and sync_id are settings of an SBus slave; give its \
                     address too",
                    d.name
                )));
            }
            None => None,
        };
        devices.push(Device {
            name: d.name.clone(),
            slave,
            master_of: d
                .master_of
                .iter()
                .map(|t| target(&d.name, t))
                .collect::<Result<_>>()?,
            sends_sync: d.sends_sync.map(|s| sync_id(&d.name, s)).transpose()?,
            objects: d
                .object
                .iter()
                .map(|o| object(&d.name, o))
                .collect::<Result<_>>()?,
        });
    }
    Ok(Plan { bitrate, devices })
}

fn sync_id(device: &str, id: u16) -> Result<u16> {
    if id > 2047 {
        return Err(CliError::usage(format!(
            "device '{device}': sync identifier {id} is out of range (0…2047, P817)"
        )));
    }
    Ok(id)
}

/// Run `drivectl sbus plan FILE`.
pub fn run(path: &str, forbidden: bool, json: bool) -> Result<()> {
    let bytes = crate::tool::infile::read_limited(Path::new(path), true, PLAN_LIMIT)?;
    let text =
        String::from_utf8(bytes).map_err(|_| CliError::usage(format!("{path}: not UTF-8 text")))?;
    let plan = parse(&text, path)?;
    if forbidden {
        for (i, d) in plan.devices.iter().enumerate() {
            let Some(f) = plan.forbidden(i) else { continue };
            if json {
                outln!(
                    "{}",
                    json!({"type": "forbidden", "device": d.name, "transmit": f.transmit, "receive": f.receive})
                )?;
            } else {
                outln!(
                    "{}: variable objects may not use\n  transmit: {}\n  receive:  {}",
                    d.name,
                    list(&f.transmit),
                    list(&f.receive)
                )?;
            }
        }
    }
    let violations = plan.check();
    for v in &violations {
        if json {
            outln!("{}", json!({"type": "violation", "message": v.to_string()}))?;
        } else {
            outln!("violation: {v}")?;
        }
    }
    if violations.is_empty() {
        if json {
            outln!(
                "{}",
                json!({"type": "summary", "devices": plan.devices.len(), "violations": 0})
            )?;
        } else {
            outln!(
                "{} device(s) at {}: no violation of the identifier rules",
                plan.devices.len(),
                plan.bitrate
            )?;
        }
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "{} violation(s) of the identifier rules in {path}",
            violations.len()
        )))
    }
}

fn list(ids: &[u16]) -> String {
    ids.iter().map(u16::to_string).collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manual's example of ch. 5.5 (Bild 35) as a plan file.
    const MANUAL: &str = r#"
bitrate = "500k"
[[device]]
name = "device 1"
address = 0
group = 0
master_of = ["address 1", "group 2"]
[[device]]
name = "device 2"
address = 1
group = 2
"#;

    #[test]
    fn the_printed_example_parses_and_checks_clean() {
        let plan = parse(EXAMPLE, "example").unwrap();
        assert_eq!(plan.devices.len(), 2);
        assert!(plan.check().is_empty(), "{:?}", plan.check());
    }

    #[test]
    fn the_manual_example_parses_and_checks_clean() {
        let plan = parse(MANUAL, "t").unwrap();
        assert_eq!(plan.devices.len(), 2);
        assert!(plan.check().is_empty(), "{:?}", plan.check());
        // A Notepad copy: BOM and CR LF.
        let notepad = format!("\u{feff}{}", MANUAL.replace('\n', "\r\n"));
        assert_eq!(parse(&notepad, "t").unwrap().devices.len(), 2);
    }

    #[test]
    fn a_variable_object_on_a_movilink_id_is_a_violation() {
        let text = format!(
            "{MANUAL}[[device.object]]\nid = 12\nkind = \"cyclic\"\ncycle_ms = 10\nlen = 8\n"
        );
        let plan = parse(&text, "t").unwrap();
        let v = plan.check();
        assert!(!v.is_empty());
        assert!(v.iter().any(|v| v.to_string().contains("12")), "{v:?}");
    }

    #[test]
    fn bad_files_are_named() {
        for (text, needle) in [
            ("[[device]]\nname = \"x\"\naddress = 64\n", "0…63"),
            ("[[device]]\nname = \"x\"\naddress = 300\n", "t:"),
            (
                "[[device]]\nname = \"x\"\nmaster_of = [\"slave 1\"]\n",
                "address N",
            ),
            ("bitrate = \"2M\"\n", "bit rate"),
            ("[[device]]\nname = \"x\"\nadress = 1\n", "adress"),
            (
                "[[device]]\nname = \"x\"\n[[device.object]]\nid = 5\nkind = \"cyclic\"\nlen = 8\n",
                "cycle_ms",
            ),
            (
                "[[device]]\nname = \"x\"\n[[device.object]]\nid = 5\nkind = \"receive\"\nlen = 9\n",
                "0…8",
            ),
        ] {
            let e = parse(text, "t").unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
