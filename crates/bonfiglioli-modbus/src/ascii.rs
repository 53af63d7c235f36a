//! Modbus ASCII (manual ch. 6.7.2): `:`, the address, PDU and LRC as hexadecimal digit pairs,
//! CR LF.
//!
//! | field | characters |
//! |---|---|
//! | start `:` (0x3A) | 1 |
//! | address | 2 |
//! | function code + data (the PDU) | 2 to 2 × 253 |
//! | LRC: two's complement of the byte sum of address and PDU | 2 |
//! | CR LF (0x0D 0x0A) | 2 |
//!
//! A frame is at most [`MAX_FRAME`] (513) characters and at least [`MIN_FRAME`] (9). drivebus
//! sends upper-case digits (as the manual's examples) and accepts lower case too.
//!
//! **Receiving** (ch. 6.7.2.2): a `:` starts a frame at any time, also inside one (the partial
//! frame is dropped); CR LF ends it; any other character than a hex digit inside a frame drops
//! it; up to one second may pass between two characters ([`DEFAULT_MAX_GAP`]; "unless the user
//! sets a longer time-out", so it can be changed with
//! [`ModbusFraming::with_ascii_max_gap`](crate::framing::ModbusFraming::with_ascii_max_gap)).
//! There is no start gap and no end silence: a frame is complete at its LF.
//!
//! **Characters** (ch. 6.7.2.1): 10 bits, 7 data bits with parity and one stop bit, or two stop
//! bits without parity ([`Mode::line_settings`](crate::framing::Mode::line_settings)). The
//! character time only matters for the gap measurement here.
//!
//! ```
//! use bonfiglioli_modbus::ascii;
//! // The manual's LRC example (ch. 6.7.2.3): 0x01 0x83 0x02 sum to 134, LRC 122 = 0x7A.
//! assert_eq!(ascii::lrc(&[0x01, 0x83, 0x02]), 0x7A);
//! ```

use core::time::Duration;

use drive_core::framing::FrameTiming;
use drive_core::{LineError, LineSettings};

use crate::frame::Address;
use crate::framing::FrameError;
use crate::pdu::{BufferTooSmall, MAX_PDU};

/// The longest ASCII frame: `:`, 2 × (address + 253 PDU bytes + LRC), CR LF.
pub const MAX_FRAME: usize = 1 + 2 * (1 + MAX_PDU + 1) + 2;
/// The shortest ASCII frame: `:`, address, function code, LRC, CR LF.
pub const MIN_FRAME: usize = 9;
/// Address, PDU and LRC of the longest frame, in bytes.
pub const MAX_BINARY: usize = 1 + MAX_PDU + 1;

/// The frame start `:`.
pub const START: u8 = b':';
/// CR, the first end character.
pub const CR: u8 = 0x0D;
/// LF, the last end character.
pub const LF: u8 = 0x0A;

/// The longest allowed time between two characters of a frame (ch. 6.7.2.2).
pub const DEFAULT_MAX_GAP: Duration = Duration::from_secs(1);

const HEX: &[u8; 16] = b"0123456789ABCDEF";

/// The LRC of `bytes` (address and PDU): the two's complement of their sum modulo 256.
pub fn lrc(bytes: &[u8]) -> u8 {
    bytes
        .iter()
        .fold(0u8, |sum, b| sum.wrapping_add(*b))
        .wrapping_neg()
}

/// The value of a hexadecimal digit (either case).
pub const fn hex_value(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    }
}

/// The receiver's times for ASCII on `line`: no start gap, no end silence, frames end at CR
/// LF, and a gap of more than `max_gap` breaks a frame off (the limit is `max_gap` plus one
/// nanosecond: a gap of exactly `max_gap` is allowed).
pub const fn timing(line: &LineSettings, max_gap: Duration) -> FrameTiming {
    FrameTiming {
        char_time: line.char_time(),
        start_gap: Duration::ZERO,
        max_gap: Duration::from_nanos(crate::framing::nanos(max_gap).saturating_add(1)),
        end_silence: Duration::ZERO,
        ends_by_silence: false,
    }
}

/// Encode a frame: `:`, `address` and `pdu` in hex, the LRC in hex, CR LF into `out`; the
/// number of characters. The PDU must be 1 to 253 bytes long.
pub fn encode(address: Address, pdu: &[u8], out: &mut [u8]) -> Result<usize, BufferTooSmall> {
    let len = 2 * (pdu.len() + 2) + 3;
    if pdu.len() > MAX_PDU {
        return Err(BufferTooSmall { needed: len });
    }
    let dst = out.get_mut(..len).ok_or(BufferTooSmall { needed: len })?;
    let check = lrc(pdu).wrapping_sub(address.get());
    let bytes = core::iter::once(address.get())
        .chain(pdu.iter().copied())
        .chain(core::iter::once(check));
    let mut digits = dst.iter_mut();
    if let Some(c) = digits.next() {
        *c = START;
    }
    for b in bytes {
        for nibble in [b >> 4, b & 0x0F] {
            if let Some(c) = digits.next() {
                *c = HEX.get(usize::from(nibble)).copied().unwrap_or(b'0');
            }
        }
    }
    for end in [CR, LF] {
        if let Some(c) = digits.next() {
            *c = end;
        }
    }
    Ok(len)
}

/// Check a whole frame and decode its digits into `out`: the address and the PDU's length
/// (the PDU is `out[..len]`).
///
/// Errors, in this order: more than [`MAX_FRAME`] characters ([`LineError::TooLong`]), no `:`
/// first ([`FrameError::NoStart`]), no CR LF last ([`FrameError::NoEnd`]), a character
/// between them that is not a hex digit, or an odd number of digits ([`FrameError::BadHex`]),
/// fewer than three bytes (address, function code, LRC: [`FrameError::TooShort`] with the
/// frame's length in characters), a wrong LRC ([`FrameError::Checksum`]: computed as
/// `expected`, received as `got`), an address 248–255 ([`FrameError::ReservedAddress`]).
pub fn decode(frame: &[u8], out: &mut [u8; MAX_PDU]) -> Result<(Address, usize), FrameError> {
    if frame.len() > MAX_FRAME {
        return Err(FrameError::Line(LineError::TooLong {
            capacity: MAX_FRAME as u16,
        }));
    }
    let Some((&first, rest)) = frame.split_first() else {
        return Err(FrameError::TooShort(0));
    };
    if first != START {
        return Err(FrameError::NoStart(first));
    }
    let digits = match rest {
        [digits @ .., CR, LF] => digits,
        _ => return Err(FrameError::NoEnd),
    };
    if digits.len() % 2 != 0 {
        return Err(FrameError::BadHex);
    }
    let mut bin = [0u8; MAX_BINARY];
    let mut n = 0;
    for (pair, slot) in digits.chunks_exact(2).zip(bin.iter_mut()) {
        let (Some(hi), Some(lo)) = (
            pair.first().copied().and_then(hex_value),
            pair.get(1).copied().and_then(hex_value),
        ) else {
            return Err(FrameError::BadHex);
        };
        *slot = (hi << 4) | lo;
        n += 1;
    }
    if n < 3 {
        return Err(FrameError::TooShort(frame.len()));
    }
    let body = bin.get(..n - 1).unwrap_or(&[]);
    let got = bin.get(n - 1).copied().unwrap_or(0);
    let expected = lrc(body);
    if expected != got {
        return Err(FrameError::Checksum {
            expected: u16::from(expected),
            got: u16::from(got),
        });
    }
    let (&a, pdu) = body
        .split_first()
        .ok_or(FrameError::TooShort(frame.len()))?;
    let address = Address::new(a).ok_or(FrameError::ReservedAddress(a))?;
    let dst = out
        .get_mut(..pdu.len())
        .ok_or(FrameError::Line(LineError::TooLong {
            capacity: MAX_FRAME as u16,
        }))?;
    dst.copy_from_slice(pdu);
    Ok((address, pdu.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manuals_lrc_example() {
        // Ch. 6.7.2.3: address 0x01 + function 0x83 + exception 0x02 = 134; 256 − 134 = 122.
        assert_eq!(lrc(&[0x01, 0x83, 0x02]), 122);
        let a = Address::new(1).unwrap();
        let mut out = [0u8; MAX_FRAME];
        let n = encode(a, &[0x83, 0x02], &mut out).unwrap();
        assert_eq!(
            &out[..n],
            [
                0x3A, // ':' start of frame
                0x30, 0x31, // "01" address
                0x38, 0x33, // "83" function code 3 with bit 7 (exception)
                0x30, 0x32, // "02" exception code
                0x37, 0x41, // "7A" LRC ("7" = 0x37, "A" = 0x41)
                0x0D, 0x0A, // CR LF end of frame
            ]
        );
        assert_eq!(lrc(&[]), 0);
        assert_eq!(lrc(&[0x80, 0x80]), 0, "the sum wraps modulo 256");
    }

    #[test]
    fn decode_accepts_lower_case_and_rejects_garbage() {
        let mut pdu = [0u8; MAX_PDU];
        let a = Address::new(1).unwrap();
        assert_eq!(decode(b":0183027a\r\n", &mut pdu), Ok((a, 2)));
        assert_eq!(pdu[..2], [0x83, 0x02]);
        assert_eq!(decode(b":0183027A\r\n", &mut pdu), Ok((a, 2)));
        assert_eq!(decode(b"", &mut pdu), Err(FrameError::TooShort(0)));
        assert_eq!(
            decode(b"0183027A\r\n", &mut pdu),
            Err(FrameError::NoStart(b'0'))
        );
        assert_eq!(decode(b":0183027A\r", &mut pdu), Err(FrameError::NoEnd));
        assert_eq!(decode(b":0183027A\n\r", &mut pdu), Err(FrameError::NoEnd));
        assert_eq!(decode(b":0183027\r\n", &mut pdu), Err(FrameError::BadHex));
        assert_eq!(decode(b":01G3027A\r\n", &mut pdu), Err(FrameError::BadHex));
        assert_eq!(decode(b":01 3027A\r\n", &mut pdu), Err(FrameError::BadHex));
        assert_eq!(decode(b":0101\r\n", &mut pdu), Err(FrameError::TooShort(7)));
        assert_eq!(
            decode(b":0183027B\r\n", &mut pdu),
            Err(FrameError::Checksum {
                expected: 0x7A,
                got: 0x7B
            })
        );
        // Address 0xF8 with a correct LRC (0xF8 + 0x03 = 0xFB, LRC 0x05).
        assert_eq!(
            decode(b":F80305\r\n", &mut pdu),
            Err(FrameError::ReservedAddress(0xF8))
        );
        let long = [b'0'; MAX_FRAME + 1];
        assert_eq!(
            decode(&long, &mut pdu),
            Err(FrameError::Line(LineError::TooLong { capacity: 513 }))
        );
    }

    #[test]
    fn longest_frame_and_small_buffers() {
        let a = Address::new(247).unwrap();
        let pdu = [0xABu8; MAX_PDU];
        let mut out = [0u8; MAX_FRAME];
        assert_eq!(encode(a, &pdu, &mut out), Ok(MAX_FRAME));
        let mut back = [0u8; MAX_PDU];
        assert_eq!(decode(&out, &mut back), Ok((a, MAX_PDU)));
        assert_eq!(back, pdu);
        assert_eq!(
            encode(a, &[0x03], &mut [0u8; 8]),
            Err(BufferTooSmall { needed: 9 })
        );
        assert_eq!(
            encode(a, &[0u8; MAX_PDU + 1], &mut [0u8; 600]),
            Err(BufferTooSmall { needed: 515 })
        );
    }

    #[test]
    fn times() {
        let t = timing(&LineSettings::new(9600), DEFAULT_MAX_GAP);
        assert_eq!(t.max_gap, Duration::from_nanos(1_000_000_001));
        assert_eq!(
            (t.start_gap, t.end_silence),
            (Duration::ZERO, Duration::ZERO)
        );
        assert!(!t.ends_by_silence);
    }
}
