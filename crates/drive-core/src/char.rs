//! Received characters: a byte, the moment its last bit arrived and the UART's error flag.

use crate::time::Instant;

/// An error the UART reported for one received character.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum CharError {
    /// The parity bit does not match the data bits.
    #[error("parity error")]
    Parity,
    /// The stop bit was missing.
    #[error("framing error")]
    Framing,
    /// The UART lost characters before this one.
    #[error("receiver overrun")]
    Overrun,
    /// What came back from an echoing adapter is not the echo of what was sent: another
    /// transmitter on the line, noise, or an adapter that does not echo (see `rt::echo`).
    #[error("bus collision or no echo (what came back is not the echo of what was sent)")]
    Collision,
}

/// One character from the UART.
///
/// `time` is the moment the character was *completely* received (the end of its stop bit), so
/// the idle gap before a character is `time - previous.time - char_time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RxChar {
    /// The data byte.
    pub byte: u8,
    /// When the character was completely received.
    pub time: Instant,
    /// A UART error flagged for this character.
    pub error: Option<CharError>,
}

impl RxChar {
    /// A character received without error.
    pub const fn new(byte: u8, time: Instant) -> Self {
        Self {
            byte,
            time,
            error: None,
        }
    }

    /// A character received with `error`.
    pub const fn with_error(byte: u8, time: Instant, error: CharError) -> Self {
        Self {
            byte,
            time,
            error: Some(error),
        }
    }
}
