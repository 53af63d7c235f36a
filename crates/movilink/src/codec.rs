//! Telegram encoding and decoding; no allocation, no panics.
//!
//! Wire format (manual ch. 4.1/4.2): `SD ADR TYP PDU… BCC`, words big-endian (high byte
//! first), double words high word first; `BCC` = XOR of all bytes from `SD` to the last PDU
//! byte. The PDU is the parameter channel (if the type has one) followed by the process data.
//!
//! ```
//! use movilink::{codec, Address, PduType, Telegram};
//! // Bild 20 of the manual: 3 process data words, cyclic.
//! let t = Telegram::request(Address::new(1).unwrap(), PduType::PD3)
//!     .with_process_data(&[0x0006, 0x3A98, 0x01F4]);
//! let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
//! let n = codec::encode(&t, &mut buf).unwrap();
//! assert_eq!(&buf[..n], &[0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57]);
//! assert_eq!(codec::decode(&buf[..n]), Ok((t, n)));
//! ```

use crate::error::{DecodeError, EncodeError};
use crate::frame::{Address, Direction, ParamChannel, PduType, Telegram};

/// XOR of `bytes`: the block check character of a telegram without its BCC.
pub fn bcc(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, b| acc ^ b)
}

/// Encode `telegram` into `out`, returning the number of bytes written (its
/// [`Telegram::encoded_len`]). `out` may be longer; the rest is untouched.
pub fn encode(telegram: &Telegram, out: &mut [u8]) -> Result<usize, EncodeError> {
    let len = telegram.encoded_len();
    let available = out.len();
    let Some(out) = out.get_mut(..len) else {
        return Err(EncodeError::BufferTooSmall {
            needed: len,
            available,
        });
    };
    // Each byte goes straight to `out` and into the check sum as it is written: building the
    // telegram in a stack buffer and XOR-ing it afterwards read back bytes just stored one by
    // one, which stalls the CPU (store forwarding) for longer than the whole encode.
    let mut check = 0u8;
    let mut slots = out.iter_mut();
    let mut put = |b: u8| {
        if let Some(slot) = slots.next() {
            *slot = b;
            check ^= b;
        }
    };
    put(telegram.direction().start_character());
    put(telegram.address().get());
    put(telegram.pdu_type().raw());
    if let Some(p) = telegram.param() {
        for b in p.to_bytes() {
            put(b);
        }
    }
    for w in telegram.process_data() {
        let [hi, lo] = w.to_be_bytes();
        put(hi);
        put(lo);
    }
    // BCC at the last position: XOR of everything before it.
    if let Some(last) = slots.next() {
        *last = check;
    }
    Ok(len)
}

/// Length of the telegram starting at `bytes[0]`, once its first three bytes (SD, ADR, TYP)
/// are known; checks the start character and PDU type (not the address).
pub fn telegram_len(bytes: &[u8]) -> Result<usize, DecodeError> {
    let (_, _, typ) = header(bytes)?;
    let t = PduType::new(typ).ok_or(DecodeError::UnknownPduType { pdu_type: typ })?;
    Ok(t.telegram_len())
}

/// The start character's direction and the raw ADR and TYP bytes; a wrong start character is
/// reported before missing bytes.
#[inline]
fn header(bytes: &[u8]) -> Result<(Direction, u8, u8), DecodeError> {
    let sd = *bytes.first().ok_or(DecodeError::Truncated {
        needed: 3,
        available: 0,
    })?;
    let direction =
        Direction::from_start_character(sd).ok_or(DecodeError::BadStartCharacter { byte: sd })?;
    match (bytes.get(1), bytes.get(2)) {
        (Some(&adr), Some(&typ)) => Ok((direction, adr, typ)),
        _ => Err(DecodeError::Truncated {
            needed: 3,
            available: bytes.len(),
        }),
    }
}

/// Decode the telegram at the start of `bytes`, returning it and the number of bytes it took.
/// Bytes after the telegram are ignored.
#[inline]
pub fn decode(bytes: &[u8]) -> Result<(Telegram, usize), DecodeError> {
    let (direction, adr, typ) = header(bytes)?;
    let address = Address::new(adr).ok_or(DecodeError::InvalidAddress { address: adr })?;
    let pdu_type = PduType::new(typ).ok_or(DecodeError::UnknownPduType { pdu_type: typ })?;
    let len = pdu_type.telegram_len();
    let Some(frame) = bytes.get(..len) else {
        return Err(DecodeError::Truncated {
            needed: len,
            available: bytes.len(),
        });
    };
    let Some((&got, body)) = frame.split_last() else {
        return Err(DecodeError::Truncated {
            needed: len,
            available: bytes.len(),
        });
    };
    let expected = bcc(body);
    if expected != got {
        return Err(DecodeError::BadChecksum { expected, got });
    }
    let mut telegram = Telegram::new(direction, address, pdu_type);
    let mut pdu = body.get(3..).unwrap_or(&[]);
    if let Some(p) = telegram.param_mut() {
        let (head, rest) = pdu
            .split_at_checked(ParamChannel::LEN)
            .unwrap_or((&[], &[]));
        let raw: [u8; 8] = head.try_into().unwrap_or([0; 8]);
        *p = ParamChannel::from_bytes(raw);
        pdu = rest;
    }
    for (w, pair) in telegram
        .process_data_mut()
        .iter_mut()
        .zip(pdu.chunks_exact(2))
    {
        if let [hi, lo] = *pair {
            *w = u16::from_be_bytes([hi, lo]);
        }
    }
    Ok((telegram, len))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncated_and_bad_bytes() {
        assert_eq!(
            decode(&[]),
            Err(DecodeError::Truncated {
                needed: 3,
                available: 0
            })
        );
        assert_eq!(
            decode(&[0x02, 0x01]),
            Err(DecodeError::Truncated {
                needed: 3,
                available: 2
            })
        );
        assert_eq!(
            decode(&[0x03, 0x01]),
            Err(DecodeError::BadStartCharacter { byte: 3 })
        );
        assert_eq!(
            decode(&[0x02, 200, 0x05]),
            Err(DecodeError::InvalidAddress { address: 200 })
        );
        assert_eq!(
            decode(&[0x02, 1, 0x07]),
            Err(DecodeError::UnknownPduType { pdu_type: 7 })
        );
        assert_eq!(
            decode(&[0x02, 1, 0x05, 0]),
            Err(DecodeError::Truncated {
                needed: 10,
                available: 4
            })
        );
        assert_eq!(telegram_len(&[0x1D, 1, 0x86]), Ok(12));
        assert_eq!(
            telegram_len(&[0x1D]),
            Err(DecodeError::Truncated {
                needed: 3,
                available: 1
            })
        );
        assert_eq!(
            telegram_len(&[0x55]),
            Err(DecodeError::BadStartCharacter { byte: 0x55 })
        );
        let t = Telegram::request(Address::new(1).unwrap(), PduType::PARAM_3PD);
        assert_eq!(
            encode(&t, &mut [0; 17]),
            Err(EncodeError::BufferTooSmall {
                needed: 18,
                available: 17
            })
        );
    }
}
