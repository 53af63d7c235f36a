//! `drivectl ports [--json]`: the serial ports of this machine, as `drive_transport::ports`
//! lists them, rendered as a table or JSON.

use crate::error::{CliError, Result};
use clap::Args;
use drive_transport::ports::{PortInfo, UsbInfo, list_ports};
use serde_json::{Value, json};
use std::fmt::Write as _;

/// Examples below `drivectl ports --help`.
const AFTER_HELP: &str = "\
Examples:
  drivectl ports                 one line per port: path, type, USB VID:PID, serial, maker
  drivectl ports --json          one JSON object per port
  drivectl movilink --port /dev/ttyUSB0 --addr 1 read P000    then talk to a drive on one";

/// Arguments of `drivectl ports`.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct PortsArgs {
    /// One JSON object per port: path, type, vid, pid (4 hex digits), serial_number,
    /// manufacturer, product (null where unknown).
    #[arg(long)]
    json: bool,
}

/// What is printed when no port is found.
const NONE_FOUND: &str = "no serial ports found: plug in the USB-RS-485 adapter (Linux: `dmesg` \
                          shows it as ttyUSB or ttyACM) or check the port's driver";

/// Run `drivectl ports`.
pub fn run(args: &PortsArgs) -> Result<()> {
    let ports = list_ports().map_err(|e| CliError::failed(e.to_string()))?;
    if ports.is_empty() {
        // Nothing for a script to parse: the line goes to stderr with --json.
        if args.json {
            errln!("drivectl: {NONE_FOUND}");
        } else {
            outln!("{NONE_FOUND}")?;
        }
        return Ok(());
    }
    out!("{}", render(&ports, args.json))?;
    Ok(())
}

/// One port as JSON.
fn to_json(p: &PortInfo) -> Value {
    let usb = p.usb.as_ref();
    json!({
        "path": p.path,
        "type": p.kind.name(),
        "vid": usb.map(|u| format!("{:04x}", u.vid)),
        "pid": usb.map(|u| format!("{:04x}", u.pid)),
        "serial_number": usb.and_then(|u| u.serial_number.clone()),
        "manufacturer": usb.and_then(|u| u.manufacturer.clone()),
        "product": usb.and_then(|u| u.product.clone()),
    })
}

/// The listing: a table, or one JSON object per line.
fn render(ports: &[PortInfo], json: bool) -> String {
    let mut out = String::new();
    if json {
        for p in ports {
            let _ = writeln!(out, "{}", to_json(p));
        }
        return out;
    }
    let width = ports
        .iter()
        .map(|p| p.path.chars().count())
        .max()
        .unwrap_or(0)
        .max("port".len());
    let _ = writeln!(
        out,
        "{:<width$}  {:<9}  {:<9}  {:<16}  manufacturer / product",
        "port", "type", "vid:pid", "serial"
    );
    for p in ports {
        let usb = p.usb.as_ref();
        let id = usb.map_or_else(|| "-".to_owned(), UsbInfo::id);
        let serial = usb.and_then(|u| u.serial_number.as_deref()).unwrap_or("-");
        let names = usb.map(UsbInfo::names).unwrap_or_default();
        let names = if names.is_empty() {
            "-".to_owned()
        } else {
            names.join(" / ")
        };
        let _ = writeln!(
            out,
            "{:<width$}  {:<9}  {:<9}  {:<16}  {}",
            p.path,
            p.kind.name(),
            id,
            serial,
            names
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_transport::ports::PortKind;

    fn sample() -> Vec<PortInfo> {
        vec![
            PortInfo {
                path: "/dev/ttyS0".into(),
                kind: PortKind::Unknown,
                usb: None,
            },
            PortInfo {
                path: "/dev/ttyUSB0".into(),
                kind: PortKind::Usb,
                usb: Some(UsbInfo {
                    vid: 0x0403,
                    pid: 0x6001,
                    serial_number: Some("A50285BI".into()),
                    manufacturer: Some("FTDI".into()),
                    product: Some("FT232R USB UART".into()),
                }),
            },
        ]
    }

    #[test]
    fn table_names_type_ids_serial_and_maker() {
        let text = render(&sample(), false);
        let lines: Vec<_> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert!(lines[0].starts_with("port"), "{text}");
        assert!(lines[1].starts_with("/dev/ttyS0    unknown"), "{text}");
        assert!(lines[1].ends_with("  -"), "{text}");
        for part in [
            "/dev/ttyUSB0",
            "usb",
            "0403:6001",
            "A50285BI",
            "FTDI / FT232R USB UART",
        ] {
            assert!(lines[2].contains(part), "{part}: {text}");
        }
    }

    #[test]
    fn json_is_one_object_per_port_with_nulls_where_unknown() {
        let text = render(&sample(), true);
        let v: Vec<Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(v.len(), 2);
        assert_eq!(v[0]["path"], "/dev/ttyS0");
        assert_eq!(v[0]["type"], "unknown");
        assert_eq!(v[0]["vid"], Value::Null);
        assert_eq!(v[0]["serial_number"], Value::Null);
        assert_eq!(v[1]["type"], "usb");
        assert_eq!(v[1]["vid"], "0403");
        assert_eq!(v[1]["pid"], "6001");
        assert_eq!(v[1]["serial_number"], "A50285BI");
        assert_eq!(v[1]["manufacturer"], "FTDI");
        assert_eq!(v[1]["product"], "FT232R USB UART");
    }
}
