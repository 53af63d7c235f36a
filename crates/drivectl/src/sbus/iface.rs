//! `--iface`: which CAN interface `drivectl sbus` and `drivectl sim sbus` use.
//!
//! * `can0`, `vcan0`, …: a SocketCAN network interface (Linux; its bit rate is the interface's,
//!   set with `ip link`);
//! * `slcan:PATH` or `slcan:PATH@BITRATE`: an slcan (Lawicel) USB-CAN adapter on a serial port,
//!   opened at BITRATE (125k, 250k, 500k, 1M or bit/s; 500k, the SBus factory setting, by
//!   default);
//! * `virtual`: the built-in virtual bus with simulated MOVIDRIVEs in this process.

use drive_core::can::Bitrate;

use crate::error::{CliError, Result};

/// A parsed `--iface`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Iface {
    /// A SocketCAN interface by name.
    SocketCan(String),
    /// An slcan adapter on a serial port, at a bit rate.
    Slcan {
        /// The serial port.
        path: String,
        /// The CAN bit rate to open the adapter with.
        bitrate: Bitrate,
    },
    /// The in-process virtual bus with simulated drives.
    Virtual,
}

/// Parse a bit rate: `500k`, `1M`, `500000`, `500kbit`.
pub fn parse_bitrate(text: &str) -> Result<Bitrate> {
    let t = text.trim().to_ascii_lowercase();
    let t = t
        .strip_suffix("bit/s")
        .or_else(|| t.strip_suffix("bps"))
        .or_else(|| t.strip_suffix("bit"))
        .unwrap_or(&t);
    let (digits, factor) = if let Some(d) = t.strip_suffix('k') {
        (d, 1_000)
    } else if let Some(d) = t.strip_suffix('m') {
        (d, 1_000_000)
    } else {
        (t, 1)
    };
    let bad = || {
        CliError::usage(format!(
            "bit rate '{text}': give 125k, 250k, 500k or 1M (the SBus rates, P816), or bit/s up \
             to 1000000"
        ))
    };
    let n: u32 = digits.parse().map_err(|_| bad())?;
    let bps = n.checked_mul(factor).ok_or_else(bad)?;
    Bitrate::new(bps).ok_or_else(bad)
}

impl Iface {
    /// Parse `--iface`.
    pub fn parse(text: &str) -> Result<Iface> {
        let t = text.trim();
        if t.is_empty() {
            return Err(CliError::usage(
                "no CAN interface given; add --iface can0 (SocketCAN), --iface slcan:/dev/ttyACM0 \
                 (an slcan USB-CAN adapter) or --iface virtual (simulated drives)",
            ));
        }
        if t == "virtual" {
            return Ok(Iface::Virtual);
        }
        if let Some(rest) = t.strip_prefix("slcan:") {
            let (path, bitrate) = match rest.rsplit_once('@') {
                Some((p, b)) => (p, parse_bitrate(b)?),
                None => (rest, Bitrate::K500),
            };
            if let Err(e) = drive_transport::can::slcan::s_code(bitrate) {
                return Err(CliError::usage(format!("--iface {t}: {e}")));
            }
            if path.is_empty() {
                return Err(CliError::usage(format!(
                    "--iface {t}: no serial port after slcan: (e.g. slcan:/dev/ttyACM0@500k)"
                )));
            }
            return Ok(Iface::Slcan {
                path: path.to_owned(),
                bitrate,
            });
        }
        // A Linux network interface name: at most 15 bytes, no '/', no white space.
        if t.len() > 15 || t.contains('/') || t.contains(char::is_whitespace) || t.contains(':') {
            return Err(CliError::usage(format!(
                "--iface {t}: not a SocketCAN interface name (at most 15 characters, no '/' or \
                 ':'); a serial adapter is slcan:PATH, the simulated bus is virtual"
            )));
        }
        Ok(Iface::SocketCan(t.to_owned()))
    }

    /// The interface's name in a candump log (one token: `can0`, `slcan0`, `virtual0`).
    pub fn log_name(&self) -> String {
        match self {
            Iface::SocketCan(n) => n.clone(),
            Iface::Slcan { .. } => "slcan0".to_owned(),
            Iface::Virtual => "virtual0".to_owned(),
        }
    }

    /// The bit rate the interface is opened at, where `--iface` says it (slcan); the virtual
    /// bus takes `--bitrate`, a SocketCAN interface has the rate `ip link` gave it.
    pub fn bitrate(&self) -> Option<Bitrate> {
        match self {
            Iface::Slcan { bitrate, .. } => Some(*bitrate),
            Iface::SocketCan(_) | Iface::Virtual => None,
        }
    }

    /// How the interface is named for a person and for the EEPROM-wear log.
    pub fn name(&self) -> String {
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
    fn interfaces_parse() {
        assert_eq!(
            Iface::parse("can0").unwrap(),
            Iface::SocketCan("can0".into())
        );
        assert_eq!(Iface::parse("virtual").unwrap(), Iface::Virtual);
        assert_eq!(
            Iface::parse("slcan:/dev/ttyACM0").unwrap(),
            Iface::Slcan {
                path: "/dev/ttyACM0".into(),
                bitrate: Bitrate::K500
            }
        );
        assert_eq!(
            Iface::parse("slcan:/dev/pts/3@1M").unwrap(),
            Iface::Slcan {
                path: "/dev/pts/3".into(),
                bitrate: Bitrate::M1
            }
        );
        for bad in [
            "",
            "slcan:",
            "slcan:/dev/x@2M",
            "slcan:/dev/x@fast",
            "/dev/ttyUSB0",
            "averyveryverylongname",
        ] {
            assert!(Iface::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn bit_rates_parse_strictly() {
        assert_eq!(parse_bitrate("125k").unwrap(), Bitrate::K125);
        assert_eq!(parse_bitrate("250000").unwrap(), Bitrate::K250);
        assert_eq!(parse_bitrate("1M").unwrap(), Bitrate::M1);
        assert_eq!(parse_bitrate("500kbit").unwrap(), Bitrate::K500);
        // Past every width: refused, not wrapped.
        assert!(parse_bitrate("4294968k").is_err());
        assert!(parse_bitrate("0").is_err());
        assert!(parse_bitrate("-500k").is_err());
        assert!(parse_bitrate("2M").is_err());
    }
}
