//! What a driver call can fail with: the drive's answer, the line, or the request itself.

use crate::frame::ExceptionCode;
use crate::master::{RejectReason, SendError};
use drive_core::LinkFault;

/// Why a driver call failed: the drive refused ([`DriverError::Device`]), the line failed
/// ([`DriverError::Link`]) or the request cannot be made ([`DriverError::Request`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive answered with an exception; for exception 4 the cause from its VABus error
    /// register (parameter 11), when it could be read.
    #[error("the drive refused: {exception}{}", vabus_text(*.vabus))]
    Device {
        /// The Modbus exception code.
        exception: ExceptionCode,
        /// The VABus error register's value read right after it.
        vabus: Option<u16>,
    },
    /// No answer, answers that kept failing the checks, or the port.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The request cannot be made; nothing was sent.
    #[error(transparent)]
    Request(#[from] RequestError),
}

/// How the line failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// Nothing answered in time, in every attempt.
    #[error(
        "no answer from address {address} after {attempts} attempts; check address (parameter 1376), mode (RTU/ASCII, parameter 395), baud rate and parity, wiring and termination"
    )]
    Timeout {
        /// The request's address.
        address: u8,
        /// Transmissions made.
        attempts: u32,
    },
    /// Answers arrived but kept failing the checks.
    #[error(
        "answers from address {address} kept failing the checks ({reason}) in {attempts} attempts; check mode (RTU/ASCII), baud rate and parity, termination and for a second master on the bus"
    )]
    Corrupt {
        /// The request's address.
        address: u8,
        /// The last check that failed.
        reason: RejectReason,
        /// Transmissions made.
        attempts: u32,
    },
    /// The answer passed the master's checks but is not the kind the call asked for.
    #[error("the answer from address {address} does not fit the request")]
    Unexpected {
        /// The request's address.
        address: u8,
    },
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
    /// What came back was the request itself: the adapter echoes what it sends (a two-wire
    /// RS-485 converter whose receiver stays on) and its echo is not taken out, so no answer on
    /// the line can be told from the request's echo.
    #[error(
        "what came back for address {address} is the request itself: the adapter echoes what it sends and its echo is not taken out, so no answer can be told from the echo{}",
        if *sent { "; whether a drive received it is unknown" } else { "; nothing was sent" }
    )]
    Echo {
        /// The request's address.
        address: u8,
        /// The request was sent (a write's outcome is then unknown).
        sent: bool,
    },
}

impl LinkError {
    /// What kind of link failure this is.
    pub fn fault(&self) -> LinkFault {
        match self {
            LinkError::Timeout { .. } => LinkFault::NoAnswer,
            LinkError::Corrupt { .. } => LinkFault::Garbled,
            LinkError::Unexpected { .. } => LinkFault::Unexpected,
            LinkError::Io(_) => LinkFault::Port,
            LinkError::Echo { .. } => LinkFault::Echo,
        }
    }
}

/// Why a request cannot be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RequestError {
    /// The parameter number is outside 0–1599.
    #[error("parameter {0} does not exist (parameter numbers are 0–1599)")]
    NoSuchParameter(u16),
    /// A value that does not fit 16 bits for a 16-bit write.
    #[error("value {value} does not fit a 16-bit parameter; nothing was sent")]
    TooWide {
        /// The value.
        value: u32,
    },
    /// The master refused it (a broadcast read).
    #[error("invalid request: {0}")]
    Invalid(SendError),
}

fn vabus_text(v: Option<u16>) -> String {
    match v {
        None => String::new(),
        Some(code) => match drive_profile::bonfiglioli::vabus_error(code) {
            Some(e) => format!("; VABus error {code}: {}", e.name_en),
            None => format!("; VABus error {code}"),
        },
    }
}
