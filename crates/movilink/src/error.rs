//! Error types.
//!
//! Transport errors ([`DecodeError`], [`RejectReason`], timeouts in the master's events) are
//! separate from device errors: a drive's negative answer is a [`ReturnCode`] (SEW's, shared
//! with SBus and the simulated drive, from [`drive_profile::sew`]).

/// Why a byte slice is not a valid telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// Fewer bytes than the telegram needs (`needed` is known once the PDU type is read).
    #[error("telegram truncated: {needed} bytes needed, {available} available")]
    Truncated {
        /// Bytes needed for the header or the whole telegram.
        needed: usize,
        /// Bytes given.
        available: usize,
    },
    /// The first byte is neither SD1 (0x02) nor SD2 (0x1D).
    #[error("bad start character {byte:#04x}")]
    BadStartCharacter {
        /// The byte found.
        byte: u8,
    },
    /// The address byte is in the unused range 200–252.
    #[error("invalid address {address}")]
    InvalidAddress {
        /// The address byte.
        address: u8,
    },
    /// The PDU type byte is not one of the 14 standard types.
    #[error("unknown pdu type {pdu_type:#04x}")]
    UnknownPduType {
        /// The type byte.
        pdu_type: u8,
    },
    /// The block check character does not match.
    #[error("bad block check character: expected {expected:#04x}, got {got:#04x}")]
    BadChecksum {
        /// XOR of all bytes before the BCC.
        expected: u8,
        /// The BCC received.
        got: u8,
    },
}

/// Why a telegram could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small.
    #[error("output buffer too small: {needed} bytes needed, {available} available")]
    BufferTooSmall {
        /// Bytes the telegram needs.
        needed: usize,
        /// Bytes available.
        available: usize,
    },
}

pub use drive_core::CharError;

/// Why a receiver or state machine dropped received characters (manual ch. 4.2, "Verarbeitung
/// der Request-/Response-Telegramme"). Rejected telegrams are never answered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum RejectReason {
    /// A character of the telegram had a UART error (parity, framing, overrun).
    #[error("{0}")]
    Char(CharError),
    /// The line was idle for a start pause or longer inside a telegram.
    #[error("inter-character gap exceeded after {received} bytes")]
    InterCharacterGap {
        /// Bytes received before the gap.
        received: u8,
    },
    /// The address is not one this side accepts.
    #[error("wrong address {address}")]
    WrongAddress {
        /// The address byte.
        address: u8,
    },
    /// Unknown PDU type byte.
    #[error("unknown pdu type {pdu_type:#04x}")]
    UnknownPduType {
        /// The type byte.
        pdu_type: u8,
    },
    /// Block check character mismatch.
    #[error("bad block check character: expected {expected:#04x}, got {got:#04x}")]
    BadBcc {
        /// XOR of the bytes before the BCC.
        expected: u8,
        /// The BCC received.
        got: u8,
    },
    /// A character followed the telegram's last character (its BCC) without an idle gap: the
    /// telegram on the wire is longer than its PDU type says (e.g. noise inserted a character,
    /// which shifts the real BCC out of the telegram).
    #[error("character {byte:#04x} after the end of the telegram without an idle gap")]
    TrailingCharacter {
        /// The first character after the telegram.
        byte: u8,
    },
    /// After a start pause came a character that starts no telegram (neither SD1 nor SD2).
    #[error("bad start character {byte:#04x}")]
    BadStartCharacter {
        /// The character.
        byte: u8,
    },
    /// Master: the response has another PDU type than the request.
    #[error("response pdu type {got:#04x} does not match request type {expected:#04x}")]
    PduTypeMismatch {
        /// The request's type byte.
        expected: u8,
        /// The response's type byte.
        got: u8,
    },
    /// Master: the response's parameter channel answers another service or index.
    #[error("parameter channel of the response does not answer the request")]
    ParamMismatch,
    /// Another rejection of the shared receiver.
    #[error("{0}")]
    Line(drive_core::LineError),
    /// More characters than the longest telegram without a break (cannot happen with the
    /// MOVILINK framing, which ends every telegram at its length; kept for completeness).
    #[error("telegram longer than {capacity} bytes")]
    TooLong {
        /// The receive buffer's size.
        capacity: u16,
    },
}

impl From<drive_core::LineError> for RejectReason {
    fn from(e: drive_core::LineError) -> Self {
        use drive_core::LineError;
        match e {
            LineError::Char(c) => Self::Char(c),
            LineError::InterCharacterGap { received } => Self::InterCharacterGap {
                received: u8::try_from(received).unwrap_or(u8::MAX),
            },
            LineError::TrailingCharacter { byte } => Self::TrailingCharacter { byte },
            LineError::TooLong { capacity } => Self::TooLong { capacity },
            other => Self::Line(other),
        }
    }
}

impl From<CharError> for RejectReason {
    fn from(e: CharError) -> Self {
        Self::Char(e)
    }
}

impl From<DecodeError> for RejectReason {
    fn from(e: DecodeError) -> Self {
        match e {
            // The receiver only decodes complete telegrams; a truncated one is a gap.
            DecodeError::Truncated { available, .. } => Self::InterCharacterGap {
                received: u8::try_from(available).unwrap_or(u8::MAX),
            },
            DecodeError::BadStartCharacter { byte } => Self::BadStartCharacter { byte },
            DecodeError::InvalidAddress { address } => Self::WrongAddress { address },
            DecodeError::UnknownPduType { pdu_type } => Self::UnknownPduType { pdu_type },
            DecodeError::BadChecksum { expected, got } => Self::BadBcc { expected, got },
        }
    }
}

pub use drive_profile::sew::{ErrorClass, ReturnCode};
