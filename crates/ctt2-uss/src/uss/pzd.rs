//! USS process data (PZD), BU 0255 sections 4.1.1 and 4.5: the control word and up to three
//! setpoints from master to drive, the status word and up to three actual values back. Every
//! word travels high byte first.
//!
//! Setpoints and actual values are percent of P105 (frequency) or P112 (current), 4000h = 100 %
//! ([`drive_profile::nord::percent_from_word`]), bit fields, or a 32-bit position across two
//! words ([`position_from_words`]).

use drive_profile::nord::{ControlWord, StatusWord};

/// At most this many setpoints or actual values.
pub const MAX_VALUES: usize = 3;

/// Why bytes are not valid process data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum PzdError {
    /// Not 2, 4, 6 or 8 bytes (the first word and 0–3 whole words after it).
    #[error("process data of {0} bytes (must be 2, 4, 6 or 8: a word and 0 to 3 whole words)")]
    BadLength(u8),
    /// The output buffer is too small.
    #[error("output buffer of {got} bytes is too small for {needed}")]
    BufferTooSmall {
        /// Bytes needed.
        needed: u8,
        /// Bytes available.
        got: u8,
    },
}

/// A first word and up to three value words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
struct Words {
    first: u16,
    values: [u16; MAX_VALUES],
    count: u8,
}

impl Words {
    #[inline]
    fn decode(bytes: &[u8]) -> Result<Words, PzdError> {
        // One slice pattern per length: direct loads, no loop, no copy of a variable length.
        let w = u16::from_be_bytes;
        let (first, values, count) = match *bytes {
            [a, b] => (w([a, b]), [0; MAX_VALUES], 0),
            [a, b, c, d] => (w([a, b]), [w([c, d]), 0, 0], 1),
            [a, b, c, d, e, f] => (w([a, b]), [w([c, d]), w([e, f]), 0], 2),
            [a, b, c, d, e, f, g, h] => (w([a, b]), [w([c, d]), w([e, f]), w([g, h])], 3),
            _ => return Err(PzdError::BadLength(bytes.len().min(255) as u8)),
        };
        Ok(Words {
            first,
            values,
            count,
        })
    }

    fn len(&self) -> usize {
        2 + 2 * usize::from(self.count)
    }

    fn encode(&self, out: &mut [u8]) -> Result<usize, PzdError> {
        let n = self.len();
        let Some(dst) = out.get_mut(..n) else {
            return Err(PzdError::BufferTooSmall {
                needed: n as u8,
                got: out.len().min(255) as u8,
            });
        };
        let words = core::iter::once(self.first).chain(self.values.iter().copied());
        for (pair, word) in dst.chunks_exact_mut(2).zip(words) {
            pair.copy_from_slice(&word.to_be_bytes());
        }
        Ok(n)
    }

    fn values(&self) -> &[u16] {
        self.values
            .get(..usize::from(self.count))
            .unwrap_or(&self.values)
    }

    fn with(first: u16, values: &[u16]) -> Words {
        let mut w = Words {
            first,
            ..Words::default()
        };
        for (slot, v) in w.values.iter_mut().zip(values) {
            *slot = *v;
        }
        w.count = values.len().min(MAX_VALUES) as u8;
        w
    }
}

/// Master → drive: the control word (STW) and 0–3 setpoints (SW1–SW3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct PzdOut(Words);

impl PzdOut {
    /// Control word and setpoints (only the first three of `setpoints` are used).
    pub fn new(control: ControlWord, setpoints: &[u16]) -> PzdOut {
        PzdOut(Words::with(control.0, setpoints))
    }

    /// The control word.
    pub fn control(&self) -> ControlWord {
        ControlWord(self.0.first)
    }

    /// The setpoints sent (0–3).
    pub fn setpoints(&self) -> &[u16] {
        self.0.values()
    }

    /// Bytes on the wire: 2 + 2 per setpoint.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Never empty (the control word is always there).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Decode 2, 4, 6 or 8 bytes.
    pub fn decode(bytes: &[u8]) -> Result<PzdOut, PzdError> {
        Words::decode(bytes).map(PzdOut)
    }

    /// Encode to the front of `out`; returns the length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, PzdError> {
        self.0.encode(out)
    }
}

/// Drive → master: the status word (ZSW) and 0–3 actual values (IW1–IW3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct PzdIn(Words);

impl PzdIn {
    /// Status word and actual values (only the first three of `actuals` are used).
    pub fn new(status: StatusWord, actuals: &[u16]) -> PzdIn {
        PzdIn(Words::with(status.0, actuals))
    }

    /// The status word.
    pub fn status(&self) -> StatusWord {
        StatusWord(self.0.first)
    }

    /// The actual values received (0–3).
    pub fn actuals(&self) -> &[u16] {
        self.0.values()
    }

    /// Bytes on the wire: 2 + 2 per actual value.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Never empty (the status word is always there).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Decode 2, 4, 6 or 8 bytes.
    #[inline]
    pub fn decode(bytes: &[u8]) -> Result<PzdIn, PzdError> {
        Words::decode(bytes).map(PzdIn)
    }

    /// Encode to the front of `out`; returns the length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, PzdError> {
        self.0.encode(out)
    }
}

/// A 32-bit position from its low and high word (section 4.5.4: positions need two setpoint or
/// actual-value words; which word carries which half is set by P546/P543).
pub const fn position_from_words(low: u16, high: u16) -> i32 {
    (((high as u32) << 16) | low as u32) as i32
}

/// The low and high word of a 32-bit position.
pub const fn position_to_words(position: i32) -> (u16, u16) {
    (position as u16, (position as u32 >> 16) as u16)
}

/// A position sent as the low word only: −32768…32767 increments (section 4.5.4).
pub const fn position_from_low_word(low: u16) -> i32 {
    low as i16 as i32
}
