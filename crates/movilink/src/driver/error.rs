//! What a driver call can fail with: the drive's answer, or the line.

use crate::error::{RejectReason, ReturnCode};
use drive_core::LinkFault;

/// Why a driver call failed: the drive refused ([`DriverError::Device`]), the line failed
/// ([`DriverError::Link`]) or the request cannot be made ([`DriverError::Request`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive answered the parameter service negatively; the code says why.
    #[error("the drive refused the service: {}; {}", .0.describe(), device_hint(.0))]
    Device(ReturnCode),
    /// No answer, answers that kept failing the checks, or the port.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The request cannot be made; nothing was sent.
    #[error("invalid request: {0}")]
    Request(#[from] RequestError),
}

/// How the line failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// Nothing answered in time, in every attempt.
    #[error(
        "no answer from address {address} after {attempts} attempts; check address, baud rate, wiring, termination and P810"
    )]
    Timeout {
        /// The request's address.
        address: u8,
        /// Transmissions made.
        attempts: u32,
    },
    /// Answers arrived but kept failing the checks (parity, gaps, address, PDU type, BCC).
    #[error(
        "answers from address {address} kept failing the checks ({reason}) in {attempts} attempts; check baud rate and parity (9600 8E1), termination and for a second master on the bus"
    )]
    Corrupt {
        /// The request's address.
        address: u8,
        /// The last check that failed.
        reason: RejectReason,
        /// Transmissions made.
        attempts: u32,
    },
    /// Cyclic PDU type: the drive never echoed the handshake bit, so the parameter service
    /// was not executed.
    #[error(
        "the drive at address {address} did not execute the cyclic parameter service (handshake bit never echoed); use an acyclic pdu type or check that no other master sends to it"
    )]
    NotExecuted {
        /// The request's address.
        address: u8,
    },
    /// The answer passed the master's checks but carried no parameter channel.
    #[error("the answer carried no parameter channel")]
    NoParamChannel,
    /// The exchange completed without a response.
    #[error("the exchange completed without a response")]
    NoResponse,
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
}

impl LinkError {
    /// What kind of link failure this is.
    pub fn fault(&self) -> LinkFault {
        match self {
            LinkError::Timeout { .. } | LinkError::NoResponse => LinkFault::NoAnswer,
            LinkError::Corrupt { .. } => LinkFault::Garbled,
            LinkError::NotExecuted { .. } | LinkError::NoParamChannel => LinkFault::Unexpected,
            LinkError::Io(_) => LinkFault::Port,
        }
    }
}

/// Why a request cannot be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum RequestError {
    /// A parameter service in a PDU type without parameter channel.
    #[error("the pdu type has no parameter channel; use one of the PARAM types")]
    NoParamChannel,
    /// An answer asked of a group or broadcast address.
    #[error("group and broadcast addresses get no answer; use send_unanswered")]
    Unanswered,
    /// A response telegram where a request is due.
    #[error("the telegram is not a request")]
    NotARequest,
    /// An unanswered telegram to an address that answers.
    #[error(
        "only group (100-199) and broadcast (255) telegrams go unanswered; use exchange or param"
    )]
    Answered,
    /// A probe of a group or broadcast address.
    #[error("group and broadcast addresses cannot be probed")]
    NotProbeable,
    /// A cyclic session with an acyclic PDU type.
    #[error("a cyclic session needs a cyclic pdu type (0x00-0x06)")]
    NotCyclic,
    /// A cyclic session with a group or broadcast address.
    #[error("a cyclic session needs a single drive (0-99) or 254")]
    NotSingle,
    /// A cyclic session without a period.
    #[error("the cycle period must not be zero")]
    ZeroPeriod,
    /// A parameter service in a cyclic session whose PDU type has no parameter channel.
    #[error(
        "this cyclic pdu type has no parameter channel; use a PARAM type (0x00, 0x02, 0x04, 0x06)"
    )]
    NoParamInCycle,
}

impl From<std::io::Error> for DriverError {
    fn from(e: std::io::Error) -> Self {
        DriverError::Link(LinkError::Io(e))
    }
}

fn device_hint(rc: &ReturnCode) -> &'static str {
    match *rc {
        ReturnCode::ILLEGAL_INDEX | ReturnCode::NOT_IMPLEMENTED => {
            "check the index against the drive's parameter list"
        }
        ReturnCode::READ_ONLY => "the parameter can only be read",
        ReturnCode::VALUE_TOO_LARGE | ReturnCode::VALUE_TOO_SMALL | ReturnCode::INVALID_VALUE => {
            "read the minimum and maximum and write a value in range"
        }
        ReturnCode::PARAMETER_LOCK => "switch the parameter lock P803 off first",
        ReturnCode::CONTROLLER_INHIBIT_REQUIRED | ReturnCode::OUTPUT_STAGE_ENABLED => {
            "set controller inhibit (control word bit 0) first"
        }
        ReturnCode::INTERNAL_COMMUNICATION_ERROR => "repeat the service",
        _ => "see the return code table of the manual (ch. 6.2)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refusal_names_its_code_once() {
        let text = DriverError::Device(ReturnCode::VALUE_TOO_LARGE).to_string();
        assert_eq!(
            text,
            "the drive refused the service: value for parameter too large (error class 8, \
             error code 0, additional code 0x0015); read the minimum and maximum and write a \
             value in range"
        );
        // An unknown code still shows its numbers, once.
        let text = DriverError::Device(ReturnCode::new(8, 0, 0x0042)).to_string();
        assert_eq!(text.matches("0x0042").count(), 1, "{text}");
    }
}
