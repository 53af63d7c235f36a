//! The serial ports of this machine, as plain data.
//!
//! [`list_ports`] asks the operating system (on Linux: `/sys/class/tty`) which serial devices
//! exist and, for USB adapters, their vendor and product IDs, serial number, manufacturer and
//! product strings. Pseudo-terminals are not listed.

use std::fmt;
use std::io;

use crate::TransportError;

/// How a serial port is attached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum PortKind {
    /// A USB adapter (details in [`PortInfo::usb`]).
    Usb,
    /// A PCI card (a permanent port).
    Pci,
    /// A Bluetooth serial link (e.g. `/dev/rfcomm0`).
    Bluetooth,
    /// The system does not say (on-board UARTs, platform devices).
    Unknown,
}

impl PortKind {
    /// The lowercase name used in output: `usb`, `pci`, `bluetooth`, `unknown`.
    pub const fn name(self) -> &'static str {
        match self {
            PortKind::Usb => "usb",
            PortKind::Pci => "pci",
            PortKind::Bluetooth => "bluetooth",
            PortKind::Unknown => "unknown",
        }
    }
}

impl fmt::Display for PortKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a USB adapter says about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UsbInfo {
    /// USB vendor ID.
    pub vid: u16,
    /// USB product ID.
    pub pid: u16,
    /// Serial number, where the adapter has one.
    pub serial_number: Option<String>,
    /// Manufacturer string.
    pub manufacturer: Option<String>,
    /// Product string.
    pub product: Option<String>,
}

impl UsbInfo {
    /// The vendor and product ID as `vid:pid`, four lowercase hex digits each: `0403:6001`.
    pub fn id(&self) -> String {
        format!("{:04x}:{:04x}", self.vid, self.pid)
    }

    /// The manufacturer and product strings the adapter gives, in that order.
    pub fn names(&self) -> Vec<&str> {
        [self.manufacturer.as_deref(), self.product.as_deref()]
            .into_iter()
            .flatten()
            .collect()
    }
}

/// One serial port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// The path to open, e.g. `/dev/ttyUSB0` (`COM3` on Windows).
    pub path: String,
    /// How the port is attached.
    pub kind: PortKind,
    /// USB details, for [`PortKind::Usb`].
    pub usb: Option<UsbInfo>,
}

impl From<tokio_serial::SerialPortInfo> for PortInfo {
    fn from(p: tokio_serial::SerialPortInfo) -> PortInfo {
        let (kind, usb) = match p.port_type {
            tokio_serial::SerialPortType::UsbPort(u) => (
                PortKind::Usb,
                Some(UsbInfo {
                    vid: u.vid,
                    pid: u.pid,
                    serial_number: non_empty(u.serial_number),
                    manufacturer: non_empty(u.manufacturer),
                    product: non_empty(u.product),
                }),
            ),
            tokio_serial::SerialPortType::PciPort => (PortKind::Pci, None),
            tokio_serial::SerialPortType::BluetoothPort => (PortKind::Bluetooth, None),
            tokio_serial::SerialPortType::Unknown => (PortKind::Unknown, None),
        };
        PortInfo {
            path: p.port_name,
            kind,
            usb,
        }
    }
}

fn non_empty(s: Option<String>) -> Option<String> {
    s.map(|s| s.trim().to_owned()).filter(|s| !s.is_empty())
}

/// The serial ports the operating system knows, sorted by path. An empty list means none were
/// found.
///
/// # Errors
///
/// [`TransportError::Io`] when the system cannot be asked (on Linux: `/sys/class/tty` is
/// missing or unreadable, e.g. sysfs not mounted in a container).
pub fn list_ports() -> Result<Vec<PortInfo>, TransportError> {
    // Without libudev, the enumeration panics when /sys/class/tty cannot be read: check first.
    #[cfg(target_os = "linux")]
    if let Err(e) = std::fs::read_dir("/sys/class/tty") {
        return Err(TransportError::Io(io::Error::new(
            e.kind(),
            format!("cannot list serial ports: /sys/class/tty: {e} (is sysfs mounted?)"),
        )));
    }
    let found = tokio_serial::available_ports()
        .map_err(|e| io::Error::other(format!("cannot list serial ports: {e}")))?;
    let mut ports: Vec<PortInfo> = found.into_iter().map(PortInfo::from).collect();
    ports.sort_by(|a, b| a.path.cmp(&b.path));
    ports.dedup_by(|a, b| a.path == b.path);
    Ok(ports)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_convert_without_usb_details() {
        for (t, kind) in [
            (tokio_serial::SerialPortType::PciPort, PortKind::Pci),
            (
                tokio_serial::SerialPortType::BluetoothPort,
                PortKind::Bluetooth,
            ),
            (tokio_serial::SerialPortType::Unknown, PortKind::Unknown),
        ] {
            let p = PortInfo::from(tokio_serial::SerialPortInfo {
                port_name: "/dev/ttyS0".into(),
                port_type: t,
            });
            assert_eq!(p.kind, kind);
            assert_eq!(p.usb, None);
            assert_eq!(p.path, "/dev/ttyS0");
        }
        assert_eq!(PortKind::Usb.to_string(), "usb");
    }

    #[test]
    fn usb_ids_are_four_hex_digits_and_names_skip_what_is_unknown() {
        let mut u = UsbInfo {
            vid: 0x403,
            pid: 0x6001,
            serial_number: None,
            manufacturer: None,
            product: Some("FT232R USB UART".into()),
        };
        assert_eq!(u.id(), "0403:6001");
        assert_eq!(u.names(), ["FT232R USB UART"]);
        u.manufacturer = Some("FTDI".into());
        assert_eq!(u.names(), ["FTDI", "FT232R USB UART"]);
    }

    #[test]
    fn blank_usb_strings_are_none() {
        assert_eq!(non_empty(Some("  ".into())), None);
        assert_eq!(non_empty(Some(" FTDI ".into())), Some("FTDI".into()));
        assert_eq!(non_empty(None), None);
    }

    #[test]
    fn listing_does_not_fail_where_sysfs_exists() {
        if std::path::Path::new("/sys/class/tty").is_dir() {
            let ports = list_ports().unwrap();
            assert!(ports.windows(2).all(|w| w[0].path < w[1].path));
        }
    }
}
