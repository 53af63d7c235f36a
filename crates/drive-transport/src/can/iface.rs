//! Naming a CAN interface in one string, as a front end takes it (`drivectl sbus --iface`, the
//! gateway's `iface = …`):
//!
//! * `can0`, `vcan0`, …: a SocketCAN network interface (Linux; its bit rate is the interface's,
//!   set with `ip link`);
//! * `slcan:PATH` or `slcan:PATH@BITRATE`: an slcan (Lawicel) USB-CAN adapter on a serial port,
//!   opened at BITRATE (125k, 250k, 500k, 1M or bit/s; 500k, the SBus factory setting, by
//!   default);
//! * `virtual`: an in-process [`VirtualBus`](super::VirtualBus) (the front end attaches the
//!   simulated drives).

use drive_core::can::Bitrate;
use drive_core::rt::CanIo;

use crate::TransportError;

/// A CAN port opened by [`Iface::open`].
pub struct OpenedPort {
    /// The port.
    pub io: Box<dyn CanIo>,
    /// How many bytes the adapter's serial port held when it was opened (discarded: left by an
    /// earlier program); 0 for SocketCAN.
    pub flushed_at_open: u32,
}

impl core::fmt::Debug for OpenedPort {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("OpenedPort")
            .field("flushed_at_open", &self.flushed_at_open)
            .finish_non_exhaustive()
    }
}

/// A bit rate that is none of the CAN rates.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "bit rate '{text}': give 125k, 250k, 500k or 1M (the SBus rates, P816), or bit/s up to 1000000"
)]
pub struct BitrateError {
    /// What was given.
    pub text: String,
}

/// Why a text names no CAN interface.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum IfaceError {
    /// Nothing was given.
    #[error("no CAN interface given")]
    Empty,
    /// The bit rate after `@` is none.
    #[error(transparent)]
    Bitrate(#[from] BitrateError),
    /// A CAN bit rate an slcan adapter cannot be opened at.
    #[error("{0}")]
    SlcanRate(String),
    /// `slcan:` without a path.
    #[error("no serial port after slcan: (e.g. slcan:/dev/ttyACM0@500k)")]
    NoPath,
    /// Not a Linux network interface name.
    #[error(
        "not a SocketCAN interface name (at most 15 characters, no '/' or ':'); a serial adapter \
         is slcan:PATH, the simulated bus is virtual"
    )]
    NotAName,
}

/// Parse a bit rate: `500k`, `1M`, `500000`, `500kbit`.
pub fn parse_bitrate(text: &str) -> Result<Bitrate, BitrateError> {
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
    let bad = || BitrateError {
        text: text.to_owned(),
    };
    let n: u32 = digits.parse().map_err(|_| bad())?;
    let bps = n.checked_mul(factor).ok_or_else(bad)?;
    Bitrate::new(bps).ok_or_else(bad)
}

/// A CAN interface by name.
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
    /// The in-process virtual bus.
    Virtual,
}

impl Iface {
    /// Parse `text` (surrounding white space ignored).
    pub fn parse(text: &str) -> Result<Iface, IfaceError> {
        let t = text.trim();
        if t.is_empty() {
            return Err(IfaceError::Empty);
        }
        if t == "virtual" {
            return Ok(Iface::Virtual);
        }
        if let Some(rest) = t.strip_prefix("slcan:") {
            let (path, bitrate) = match rest.rsplit_once('@') {
                Some((p, b)) => (p, parse_bitrate(b)?),
                None => (rest, Bitrate::K500),
            };
            if let Err(e) = super::slcan::s_code(bitrate) {
                return Err(IfaceError::SlcanRate(e.to_string()));
            }
            if path.is_empty() {
                return Err(IfaceError::NoPath);
            }
            return Ok(Iface::Slcan {
                path: path.to_owned(),
                bitrate,
            });
        }
        // A Linux network interface name: at most 15 bytes, no '/', no white space.
        if t.len() > 15 || t.contains('/') || t.contains(char::is_whitespace) || t.contains(':') {
            return Err(IfaceError::NotAName);
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

    /// Open a SocketCAN interface, or an slcan adapter at the bit rate its name gives. `None`
    /// for the virtual bus: there is no port to open, the front end makes the bus and attaches
    /// its nodes (simulated drives) itself.
    pub async fn open(&self) -> Option<Result<OpenedPort, TransportError>> {
        Some(match self {
            #[cfg(target_os = "linux")]
            Iface::SocketCan(name) => super::SocketCanPort::open(name).map(|p| OpenedPort {
                io: Box::new(p),
                flushed_at_open: 0,
            }),
            #[cfg(not(target_os = "linux"))]
            Iface::SocketCan(_) => Err(TransportError::Io(std::io::Error::other(
                "SocketCAN interfaces exist on Linux only",
            ))),
            Iface::Slcan { path, bitrate } => {
                super::SlcanPort::open(path, *bitrate)
                    .await
                    .map(|p| OpenedPort {
                        flushed_at_open: p.flushed_at_open(),
                        io: Box::new(p),
                    })
            }
            Iface::Virtual => return None,
        })
    }

    /// The bit rate the interface is opened at, where its name says it (slcan); the virtual
    /// bus takes the caller's, a SocketCAN interface has the rate `ip link` gave it.
    pub fn bitrate(&self) -> Option<Bitrate> {
        match self {
            Iface::Slcan { bitrate, .. } => Some(*bitrate),
            Iface::SocketCan(_) | Iface::Virtual => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interfaces_parse() {
        assert_eq!(Iface::parse("can0"), Ok(Iface::SocketCan("can0".into())));
        assert_eq!(Iface::parse(" virtual "), Ok(Iface::Virtual));
        assert_eq!(
            Iface::parse("slcan:/dev/ttyACM0"),
            Ok(Iface::Slcan {
                path: "/dev/ttyACM0".into(),
                bitrate: Bitrate::K500
            })
        );
        assert_eq!(
            Iface::parse("slcan:/dev/pts/3@1M"),
            Ok(Iface::Slcan {
                path: "/dev/pts/3".into(),
                bitrate: Bitrate::M1
            })
        );
        assert_eq!(Iface::parse(""), Err(IfaceError::Empty));
        assert_eq!(Iface::parse("slcan:"), Err(IfaceError::NoPath));
        assert!(matches!(
            Iface::parse("slcan:/dev/x@fast"),
            Err(IfaceError::Bitrate(_))
        ));
        assert!(matches!(
            Iface::parse("slcan:/dev/x@2M"),
            Err(IfaceError::Bitrate(_))
        ));
        assert_eq!(Iface::parse("/dev/ttyUSB0"), Err(IfaceError::NotAName));
        assert_eq!(
            Iface::parse("averyveryverylongname"),
            Err(IfaceError::NotAName)
        );
    }

    #[test]
    fn bit_rates_parse_strictly() {
        assert_eq!(parse_bitrate("125k"), Ok(Bitrate::K125));
        assert_eq!(parse_bitrate("250000"), Ok(Bitrate::K250));
        assert_eq!(parse_bitrate("1M"), Ok(Bitrate::M1));
        assert_eq!(parse_bitrate("500kbit"), Ok(Bitrate::K500));
        // Past every width: refused, not wrapped.
        for bad in ["4294968k", "0", "-500k", "2M"] {
            assert!(parse_bitrate(bad).is_err(), "{bad}");
        }
    }
}
