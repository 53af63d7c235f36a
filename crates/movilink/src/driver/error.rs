//! What a driver call can fail with: the drive's answer, or the line.

use crate::error::{RejectReason, ReturnCode};

/// Why a driver call failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive answered the parameter service negatively; the code says why.
    #[error("the drive refused the service: {}; {}", .0.describe(), device_hint(.0))]
    Device(ReturnCode),
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
    /// The request cannot be sent this way.
    #[error("invalid request: {0}")]
    InvalidRequest(&'static str),
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
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
