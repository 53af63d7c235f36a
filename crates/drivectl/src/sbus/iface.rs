//! `--iface`: which CAN interface `drivectl sbus` and `drivectl sim sbus` use
//! (`drive_transport::can::Iface`: `can0`, `slcan:PATH[@BITRATE]`, `virtual`), its refusals in
//! the command line's words.

use drive_core::can::Bitrate;
pub use drive_transport::can::Iface;
use drive_transport::can::IfaceError;

use crate::error::{CliError, Result};

/// Parse a bit rate: `500k`, `1M`, `500000`, `500kbit`.
pub fn parse_bitrate(text: &str) -> Result<Bitrate> {
    drive_transport::can::parse_bitrate(text).map_err(|e| CliError::usage(e.to_string()))
}

/// Parse `--iface`.
pub fn parse(text: &str) -> Result<Iface> {
    let t = text.trim();
    Iface::parse(text).map_err(|e| {
        CliError::usage(match e {
            IfaceError::Empty => "no CAN interface given; add --iface can0 (SocketCAN), --iface \
                                  slcan:/dev/ttyACM0 (an slcan USB-CAN adapter) or --iface \
                                  virtual (simulated drives)"
                .to_owned(),
            IfaceError::Bitrate(e) => e.to_string(),
            other => format!("--iface {t}: {other}"),
        })
    })
}

/// How an interface is named for a person and for the EEPROM-wear log (an slcan adapter by its
/// port's canonical path).
pub trait IfaceName {
    /// The name.
    fn name(&self) -> String;
}

impl IfaceName for Iface {
    fn name(&self) -> String {
        match self {
            Iface::SocketCan(n) => n.clone(),
            Iface::Slcan { path, .. } => {
                format!("slcan:{}", crate::tool::client::canonical_port(path))
            }
            Iface::Virtual => "virtual".to_owned(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_name_the_option() {
        assert!(
            parse("")
                .unwrap_err()
                .to_string()
                .contains("add --iface can0")
        );
        let e = parse("slcan:").unwrap_err().to_string();
        assert!(e.starts_with("--iface slcan:: no serial port"), "{e}");
        let e = parse("/dev/ttyUSB0").unwrap_err().to_string();
        assert!(
            e.starts_with("--iface /dev/ttyUSB0: not a SocketCAN"),
            "{e}"
        );
        let e = parse("slcan:/dev/x@fast").unwrap_err().to_string();
        assert!(e.starts_with("bit rate 'fast'"), "{e}");
        assert_eq!(parse("slcan:/dev/x@2M").unwrap_err().exit_code(), 2);
    }
}
