//! Modbus RTU (manual ch. 6.7.1): `address, PDU, CRC-16` in binary, frames separated by
//! silence.
//!
//! | field | bytes |
//! |---|---|
//! | slave address | 1 |
//! | function code + data (the PDU) | 1 to 253 |
//! | CRC-16/MODBUS, low byte first | 2 |
//!
//! A frame is at most [`MAX_FRAME`] (256) bytes and at least [`MIN_FRAME`] (4: address,
//! function code, CRC).
//!
//! **Timing** (ch. 6.7.1.3 and the Modbus serial line specification for the fixed values above
//! 19200 baud), from the real line ([`LineSettings`], 11-bit characters: 8 data bits, parity and
//! one stop bit, or two stop bits without parity, see [`Mode::line_settings`]):
//!
//! | time | ≤ 19200 baud | > 19200 baud | use |
//! |---|---|---|---|
//! | t3.5 | 3.5 character times | 1.75 ms | idle time before a frame; silence that confirms a frame's end |
//! | t1.5 | 1.5 character times | 0.75 ms | a gap *longer* than this ends the frame |
//!
//! On drive-core's [`Receiver`](drive_core::Receiver) this is [`FrameTiming::ends_by_silence`]:
//! a gap of more than t1.5 ends the frame; the frame stands if the line then stays quiet until
//! t3.5 after its last character. A character that completes within that t3.5 (its gap is
//! more than t1.5 but at most 2.5 character times: it *started* inside t3.5 − one character)
//! discards the frame, which is the Modbus rule "a gap of more than 1.5 characters inside a
//! frame discards it" ([`LineError::TrailingCharacter`](drive_core::LineError)); a character
//! whose gap is 2.5 to 3.5 character times completes after the t3.5 timer ran out, so the frame
//! stands, but the character does not start a frame (less than t3.5 of idle line before it)
//! and the receiver waits for the next idle gap.
//!
//! ```
//! use bonfiglioli_modbus::rtu;
//! // The manual's CRC example (ch. 6.7.1.4): 0x02 0x07 gives 0x1241, sent 0x41 0x12.
//! assert_eq!(rtu::crc(&[0x02, 0x07]), 0x1241);
//! ```

use core::time::Duration;

use crc::{CRC_16_MODBUS, Crc, Table};
use drive_core::framing::FrameTiming;
use drive_core::{LineError, LineSettings};

use crate::frame::Address;
use crate::framing::FrameError;
#[cfg(doc)]
use crate::framing::Mode;
use crate::pdu::{BufferTooSmall, MAX_PDU};

/// The longest RTU frame: address, 253 PDU bytes, CRC (ch. 6.7.1.2).
pub const MAX_FRAME: usize = 256;
/// The shortest RTU frame: address, function code, CRC.
pub const MIN_FRAME: usize = 4;

/// t3.5 above 19200 baud.
pub const T35_FIXED: Duration = Duration::from_micros(1750);
/// t1.5 above 19200 baud.
pub const T15_FIXED: Duration = Duration::from_micros(750);

/// The CRC-16/MODBUS engine (polynomial 0xA001 reflected, start 0xFFFF, ch. 6.7.1.4), with the
/// crc crate's fastest table variant (`Table<16>`, slice-by-16: 16 × 256 entries, 8 KiB of
/// constant data built at compile time).
static CRC16: Crc<u16, Table<16>> = Crc::<u16, Table<16>>::new(&CRC_16_MODBUS);

/// The CRC-16/MODBUS of `bytes`; it goes on the wire low byte first.
pub fn crc(bytes: &[u8]) -> u16 {
    CRC16.checksum(bytes)
}

/// t3.5 on `line`: 3.5 character times, or 1.75 ms above 19200 baud.
pub const fn t35(line: &LineSettings) -> Duration {
    if line.baud > 19200 {
        T35_FIXED
    } else {
        line.char_times(7, 2)
    }
}

/// t1.5 on `line`: 1.5 character times, or 0.75 ms above 19200 baud.
pub const fn t15(line: &LineSettings) -> Duration {
    if line.baud > 19200 {
        T15_FIXED
    } else {
        line.char_times(3, 2)
    }
}

/// The receiver's times for RTU on `line` (see the [module docs](self)). The gap limit is t1.5
/// plus one nanosecond, because a gap of exactly t1.5 is still inside the frame ("more than
/// 1.5 characters" ends it) and the receiver ends a frame at a gap of the limit or more.
pub const fn timing(line: &LineSettings) -> FrameTiming {
    let t35 = t35(line);
    FrameTiming {
        char_time: line.char_time(),
        start_gap: t35,
        max_gap: Duration::from_nanos(crate::framing::nanos(t15(line)).saturating_add(1)),
        end_silence: t35,
        ends_by_silence: true,
    }
}

/// Encode a frame: `address`, `pdu`, CRC (low byte first) into `out`; the number of bytes.
/// The PDU must be 1 to 253 bytes long (longer ones do not fit a frame and are refused as a
/// buffer the size of a longest frame would be).
pub fn encode(address: Address, pdu: &[u8], out: &mut [u8]) -> Result<usize, BufferTooSmall> {
    let len = pdu.len() + 3;
    if pdu.len() > MAX_PDU {
        return Err(BufferTooSmall { needed: len });
    }
    let dst = out.get_mut(..len).ok_or(BufferTooSmall { needed: len })?;
    let (body, check) = dst.split_at_mut(len - 2);
    let (a, p) = body.split_at_mut(1);
    a.copy_from_slice(&[address.get()]);
    p.copy_from_slice(pdu);
    check.copy_from_slice(&crc(body).to_le_bytes());
    Ok(len)
}

/// Check a whole frame and split it: the address and the PDU (a slice of `frame`).
///
/// Errors: fewer than [`MIN_FRAME`] bytes ([`FrameError::TooShort`]), more than [`MAX_FRAME`]
/// ([`LineError::TooLong`]), a wrong CRC ([`FrameError::Checksum`] with the computed value as
/// `expected` and the received one as `got`), an address 248–255
/// ([`FrameError::ReservedAddress`]), in this order.
pub fn decode(frame: &[u8]) -> Result<(Address, &[u8]), FrameError> {
    if frame.len() < MIN_FRAME {
        return Err(FrameError::TooShort(frame.len()));
    }
    if frame.len() > MAX_FRAME {
        return Err(FrameError::Line(LineError::TooLong {
            capacity: MAX_FRAME as u16,
        }));
    }
    let (body, check) = frame.split_at(frame.len() - 2);
    let got = match *check {
        [lo, hi] => u16::from_le_bytes([lo, hi]),
        _ => 0,
    };
    let expected = crc(body);
    if expected != got {
        return Err(FrameError::Checksum { expected, got });
    }
    let (&a, pdu) = body
        .split_first()
        .ok_or(FrameError::TooShort(frame.len()))?;
    let address = Address::new(a).ok_or(FrameError::ReservedAddress(a))?;
    Ok((address, pdu))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manual's bit-by-bit procedure (ch. 6.7.1.4), returning the register after every
    /// shift, to compare with the manual's table.
    fn crc_steps(bytes: &[u8]) -> ([u16; 16], u16) {
        let mut reg = 0xFFFFu16;
        let mut steps = [0u16; 16];
        let mut i = 0;
        for b in bytes {
            reg ^= u16::from(*b);
            for _ in 0..8 {
                let lsb = reg & 1;
                reg >>= 1;
                if lsb == 1 {
                    reg ^= 0xA001;
                }
                if let Some(s) = steps.get_mut(i) {
                    *s = reg;
                }
                i += 1;
            }
        }
        (steps, reg)
    }

    #[test]
    fn the_manuals_crc_example_step_by_step() {
        // Ch. 6.7.1.4: the message 0x02 0x07; the register after each of the 16 shifts (after
        // the ExOR with 0xA001 where the shifted-out bit was 1), as the manual's table prints it.
        let (steps, result) = crc_steps(&[0x02, 0x07]);
        assert_eq!(
            steps,
            [
                // 1st character 0x02: 0xFFFF ^ 0x02 = 0xFFFD
                0b1101_1111_1111_1111, // 1st shift, bit out 1 → ExOR
                0b1100_1111_1111_1110, // 2nd shift, bit out 1 → ExOR
                0b0110_0111_1111_1111, // 3rd shift, bit out 0
                0b1001_0011_1111_1110, // 4th shift, bit out 1 → ExOR
                0b0100_1001_1111_1111, // 5th shift, bit out 0
                0b1000_0100_1111_1110, // 6th shift, bit out 1 → ExOR
                0b0100_0010_0111_1111, // 7th shift, bit out 0
                0b1000_0001_0011_1110, // 8th shift, bit out 1 → ExOR
                // 2nd character 0x07: 0x813E ^ 0x07 = 0x8139
                0b1110_0000_1001_1101, // 1st shift, bit out 1 → ExOR
                0b1101_0000_0100_1111, // 2nd shift, bit out 1 → ExOR
                0b1100_1000_0010_0110, // 3rd shift, bit out 1 → ExOR
                0b0110_0100_0001_0011, // 4th shift, bit out 0
                0b1001_0010_0000_1000, // 5th shift, bit out 1 → ExOR
                0b0100_1001_0000_0100, // 6th shift, bit out 0
                0b0010_0100_1000_0010, // 7th shift, bit out 0
                0b0001_0010_0100_0001, // 8th shift, bit out 0: result 0x1241
            ]
        );
        assert_eq!(result, 0x1241);
        // The table-driven CRC gives the same ("Ergebnis: 4673 = 0x1241").
        assert_eq!(crc(&[0x02, 0x07]), 4673);
        // On the wire: low byte 0x41, then high byte 0x12.
        assert_eq!(crc(&[0x02, 0x07]).to_le_bytes(), [0x41, 0x12]);
        // The catalogue's check value of CRC-16/MODBUS.
        assert_eq!(crc(b"123456789"), 0x4B37);
    }

    #[test]
    fn table_and_bitwise_agree_on_every_length() {
        let data: [u8; 300] = core::array::from_fn(|i| (i as u8).wrapping_mul(37) ^ 0x5A);
        for n in 0..data.len() {
            let mut reg = 0xFFFFu16;
            for b in &data[..n] {
                reg ^= u16::from(*b);
                for _ in 0..8 {
                    reg = if reg & 1 == 1 {
                        (reg >> 1) ^ 0xA001
                    } else {
                        reg >> 1
                    };
                }
            }
            assert_eq!(crc(&data[..n]), reg, "length {n}");
        }
    }

    #[test]
    fn times_follow_the_line() {
        // 19200 8E1: 11 bits = 572.917 µs; t3.5 = 2.005 ms, t1.5 = 859.375 µs.
        let l = LineSettings::new(19200);
        assert_eq!(t35(&l), Duration::from_nanos(2_005_208));
        assert_eq!(t15(&l), Duration::from_nanos(859_375));
        // 9600 8N2 has 11 bits too: the same as 9600 8E1.
        let n2 = LineSettings::new(9600)
            .with_parity(drive_core::Parity::None)
            .with_stop_bits(drive_core::StopBits::Two);
        assert_eq!(t35(&n2), t35(&LineSettings::new(9600)));
        assert_eq!(t35(&n2), Duration::from_nanos(4_010_417));
        // Above 19200 baud the fixed values.
        for baud in [38400, 57600, 115_200] {
            let l = LineSettings::new(baud);
            assert_eq!((t35(&l), t15(&l)), (T35_FIXED, T15_FIXED));
        }
        let t = timing(&LineSettings::new(57600));
        assert!(t.ends_by_silence);
        assert_eq!(t.max_gap, Duration::from_nanos(750_001));
        assert_eq!((t.start_gap, t.end_silence), (T35_FIXED, T35_FIXED));
        assert_eq!(t.char_time, Duration::from_nanos(190_972));
    }

    #[test]
    fn encode_and_decode_check_lengths_crc_and_address() {
        let a = Address::new(1).unwrap();
        let mut out = [0u8; MAX_FRAME];
        let n = encode(a, &[0x03, 0x21, 0x74, 0x00, 0x01], &mut out).unwrap();
        assert_eq!(&out[..n], [0x01, 0x03, 0x21, 0x74, 0x00, 0x01, 0xCE, 0x2C]);
        assert_eq!(decode(&out[..n]), Ok((a, &out[1..6])));
        let mut small = [0u8; 7];
        assert_eq!(
            encode(a, &[0x03, 0x21, 0x74, 0x00, 0x01], &mut small),
            Err(BufferTooSmall { needed: 8 })
        );
        assert_eq!(
            encode(a, &[0; MAX_PDU + 1], &mut [0u8; 300]),
            Err(BufferTooSmall { needed: 257 })
        );
        assert_eq!(decode(&[1, 3, 0x41]), Err(FrameError::TooShort(3)));
        assert_eq!(
            decode(&[0u8; 257]),
            Err(FrameError::Line(LineError::TooLong { capacity: 256 }))
        );
        assert_eq!(
            decode(&[0x01, 0x03, 0x21, 0x74, 0x00, 0x01, 0x2C, 0xCE]),
            Err(FrameError::Checksum {
                expected: 0x2CCE,
                got: 0xCE2C
            })
        );
        // Address 248 with a correct CRC.
        let mut f = [0xF8, 0x03, 0, 0];
        let c = crc(&f[..2]).to_le_bytes();
        f[2..].copy_from_slice(&c);
        assert_eq!(decode(&f), Err(FrameError::ReservedAddress(0xF8)));
    }
}
