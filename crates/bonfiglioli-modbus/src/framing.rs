//! RTU and ASCII framing on drive-core's character receiver: one [`ModbusFraming`] for both
//! [`Mode`]s and both [`Side`]s, whole-frame [`encode_request`] / [`encode_response`] /
//! [`decode_frame`], and the [`FrameError`]s.
//!
//! The receiver ([`Receiver`], drive-core's [`drive_core::Receiver`] with a [`MAX_FRAME`]-byte
//! buffer) hands out [`Received`] frames: on the drive's side ([`Side::Slave`]) every frame
//! with a good check becomes a [`Received::Request`], with the PDU decoded or the
//! [`PduError`] the drive answers with an exception; on the master's side ([`Side::Master`]) a
//! frame becomes a [`Received::Response`] only if its PDU decodes, else it is rejected with
//! [`FrameError::Pdu`]. Frames of every address 0–247 are handed out (the drive counts
//! messages to other drives in its diagnostic counters; the state machines filter); an
//! address 248–255 is rejected ([`FrameError::ReservedAddress`], with the byte).
//!
//! The modes' rules are in [`rtu`] and [`ascii`].
//!
//! ```
//! use bonfiglioli_modbus::frame::{Address, Request, StartAddress};
//! use bonfiglioli_modbus::framing::{self, Mode, ModbusFraming, Received, Receiver, Side};
//! use drive_core::{Instant, LineSettings, RxChar, RxEvent};
//!
//! let line = LineSettings::new(19200);
//! let req = Request::ReadWord { start: StartAddress::from_raw(0x2174), count: 1 };
//! let mut wire = [0u8; framing::MAX_FRAME];
//! let n = framing::encode_request(Mode::Rtu, Address::new(1).unwrap(), &req, &mut wire).unwrap();
//! assert_eq!(&wire[..n], [0x01, 0x03, 0x21, 0x74, 0x00, 0x01, 0xCE, 0x2C]);
//!
//! let mut rx = Receiver::new(ModbusFraming::new(Mode::Rtu, Side::Slave, &line));
//! let char_time = line.char_time().as_nanos() as u64;
//! for (i, b) in wire[..n].iter().enumerate() {
//!     assert_eq!(rx.handle_char(RxChar::new(*b, Instant::from_nanos(char_time * (i as u64 + 1)))), None);
//! }
//! // The frame ends by silence and stands once t3.5 passed after its last character.
//! let at = rx.poll_timeout().unwrap();
//! assert_eq!(rx.handle_timeout(at), None); // t1.5: the frame has ended, t3.5 not yet
//! let at = rx.poll_timeout().unwrap();
//! assert_eq!(rx.handle_timeout(at), Some(RxEvent::Frame(Received::Request(Address::new(1).unwrap(), Ok(req)))));
//! ```

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use drive_core::framing::{FrameTiming, Framing, Progress, Start};
use drive_core::{LineError, LineSettings, Parity, StopBits};

use crate::frame::{Address, Request, Response};
use crate::pdu::{BufferTooSmall, MAX_PDU, PduError};
use crate::{ascii, rtu};

/// Largest frame on the wire: 256 bytes (RTU), 513 characters (ASCII: `:` + 2 × 255 + CR LF).
pub const MAX_FRAME: usize = ascii::MAX_FRAME;

/// drive-core's receiver with Modbus framing, for frames of either mode.
pub type Receiver = drive_core::Receiver<ModbusFraming, MAX_FRAME>;

/// What the [`Receiver`] hands out.
pub type RxEvent = drive_core::RxEvent<Received, FrameError>;

/// The transmission mode (parameter 395 *Protokolltyp*: 2 = RTU, 3 = ASCII).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Binary frames with CRC-16, separated by silence (ch. 6.7.1).
    Rtu,
    /// Hexadecimal text frames `:` … LRC CR LF (ch. 6.7.2).
    Ascii,
}

impl Mode {
    /// The character format of the manual for this mode at `baud` with `parity` (parameter
    /// 1375): RTU 8 data bits, ASCII 7 (ch. 6.7.1.1, 6.7.2.1); one stop bit with parity, two
    /// without, so a character is 11 bits (RTU) or 10 bits (ASCII) either way.
    pub const fn line_settings(self, baud: u32, parity: Parity) -> LineSettings {
        LineSettings {
            baud,
            data_bits: match self {
                Mode::Rtu => 8,
                Mode::Ascii => 7,
            },
            parity,
            stop_bits: match parity {
                Parity::None => StopBits::Two,
                Parity::Even | Parity::Odd => StopBits::One,
            },
        }
    }

    /// The longest frame on the wire in this mode.
    pub const fn max_frame(self) -> usize {
        match self {
            Mode::Rtu => rtu::MAX_FRAME,
            Mode::Ascii => ascii::MAX_FRAME,
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Mode::Rtu => "rtu",
            Mode::Ascii => "ascii",
        })
    }
}

/// A string is neither `rtu` nor `ascii`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("invalid Modbus mode: expected rtu or ascii")]
pub struct ParseModeError;

impl FromStr for Mode {
    type Err = ParseModeError;

    /// `rtu` or `ascii`, any case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("rtu") {
            Ok(Mode::Rtu)
        } else if t.eq_ignore_ascii_case("ascii") {
            Ok(Mode::Ascii)
        } else {
            Err(ParseModeError)
        }
    }
}

/// Which frames a receiver decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// A bus master: frames are responses.
    Master,
    /// A drive: frames are requests.
    Slave,
}

/// The received frame: an address and a PDU decoded for the side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Received {
    /// On the drive's side: a request, or why its PDU does not decode (the drive answers with
    /// [`PduError::exception`] unless it was a broadcast).
    Request(Address, Result<Request, PduError>),
    /// On the master's side: a response.
    Response(Address, Response),
}

impl Received {
    /// The frame's address.
    pub const fn address(&self) -> Address {
        match *self {
            Received::Request(a, _) | Received::Response(a, _) => a,
        }
    }
}

/// Why a frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The receiver dropped the characters (UART error, a gap, a character right after a
    /// frame, too long).
    #[error("{0}")]
    Line(#[from] LineError),
    /// The CRC (RTU) or LRC (ASCII) does not match.
    #[error("checksum error: computed {expected:#06x}, received {got:#06x}")]
    Checksum {
        /// The check computed over the received address and PDU.
        expected: u16,
        /// The check that arrived.
        got: u16,
    },
    /// Too few bytes (RTU) or characters (ASCII) for address, function code and check.
    #[error("frame of {0} characters is too short")]
    TooShort(usize),
    /// An ASCII frame with a character that is not a hexadecimal digit between `:` and CR LF,
    /// or an odd number of digits.
    #[error("invalid character in an ASCII frame (hexadecimal digits expected)")]
    BadHex,
    /// An ASCII frame does not start with `:` (only from [`decode_frame`]: the receiver
    /// waits for a `:`).
    #[error("ASCII frame starts with {0:#04x}, not ':'")]
    NoStart(u8),
    /// An ASCII frame does not end with CR LF.
    #[error("ASCII frame does not end with CR LF")]
    NoEnd,
    /// The address byte is 248–255, reserved by Modbus.
    #[error("reserved address {0} (248 to 255)")]
    ReservedAddress(u8),
    /// A response PDU that does not decode (master's side).
    #[error("{0}")]
    Pdu(PduError),
}

/// One framing description for both modes and sides; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ModbusFraming {
    mode: Mode,
    side: Side,
    timing: FrameTiming,
    line: LineSettings,
    ascii_max_gap: Duration,
}

impl ModbusFraming {
    /// Frames of `mode` for `side` on `line` (its character time sets the RTU gaps).
    pub const fn new(mode: Mode, side: Side, line: &LineSettings) -> Self {
        Self {
            mode,
            side,
            timing: timing_of(mode, line, ascii::DEFAULT_MAX_GAP),
            line: *line,
            ascii_max_gap: ascii::DEFAULT_MAX_GAP,
        }
    }

    /// The same framing with another longest gap between ASCII characters (default one
    /// second); no effect in RTU. Call [`Receiver::refresh_timing`](drive_core::Receiver::refresh_timing)
    /// after changing a receiver's framing.
    #[must_use]
    pub const fn with_ascii_max_gap(self, max_gap: Duration) -> Self {
        Self {
            timing: timing_of(self.mode, &self.line, max_gap),
            ascii_max_gap: max_gap,
            ..self
        }
    }

    /// The receiver's times.
    pub const fn timing(&self) -> FrameTiming {
        self.timing
    }

    /// The mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// The side.
    pub const fn side(&self) -> Side {
        self.side
    }

    /// A checked frame's PDU decoded for this side.
    fn received(&self, address: Address, pdu: &[u8]) -> Result<Received, FrameError> {
        match self.side {
            Side::Slave => Ok(Received::Request(address, Request::decode(pdu))),
            Side::Master => Response::decode(pdu)
                .map(|r| Received::Response(address, r))
                .map_err(FrameError::Pdu),
        }
    }

    /// The line the times come from.
    pub const fn line(&self) -> LineSettings {
        self.line
    }
}

const fn timing_of(mode: Mode, line: &LineSettings, ascii_max_gap: Duration) -> FrameTiming {
    match mode {
        Mode::Rtu => rtu::timing(line),
        Mode::Ascii => ascii::timing(line, ascii_max_gap),
    }
}

/// A duration in nanoseconds, saturating.
pub(crate) const fn nanos(d: Duration) -> u64 {
    drive_core::time::duration_nanos(d)
}

impl Framing for ModbusFraming {
    type Frame = Received;
    type Error = FrameError;

    fn timing(&self) -> FrameTiming {
        self.timing
    }

    #[inline]
    fn start(&self, byte: u8) -> Start<FrameError> {
        match self.mode {
            Mode::Rtu => Start::Begin,
            Mode::Ascii if byte == ascii::START => Start::Begin,
            // Between ASCII frames anything but ':' is ignored (ch. 6.7.2.2: the drives watch
            // the line for the colon).
            Mode::Ascii => Start::Ignore,
        }
    }

    #[inline]
    fn progress(&self, frame: &[u8]) -> Progress<FrameError> {
        match self.mode {
            // RTU frames end by silence; only the length is limited.
            Mode::Rtu if frame.len() > rtu::MAX_FRAME => {
                Progress::Reject(FrameError::Line(LineError::TooLong {
                    capacity: rtu::MAX_FRAME as u16,
                }))
            }
            // A master knows an answer's length from its function code: the frame is then
            // complete at that length and only awaits the silence that confirms it (so a
            // virtual clock may jump to it). A drive must see a request of a wrong length end
            // by silence, to answer it with exception 3.
            Mode::Rtu if self.side == Side::Master => match rtu_response_len(frame) {
                Some(n) => Progress::Length(n),
                None => Progress::More,
            },
            Mode::Rtu => Progress::More,
            Mode::Ascii => match *frame {
                [_] => Progress::More,
                [.., ascii::CR, ascii::LF] => Progress::Complete,
                [.., ascii::CR, _] | [.., ascii::LF] => Progress::Reject(FrameError::NoEnd),
                [.., ascii::CR] => Progress::More,
                [.., c] if ascii::hex_value(c).is_some() => Progress::More,
                _ => Progress::Reject(FrameError::BadHex),
            },
        }
    }

    fn decode(&self, frame: &[u8]) -> Result<Received, FrameError> {
        match self.mode {
            // RTU: the PDU is a slice of the frame, decoded in place.
            Mode::Rtu => {
                let (address, pdu) = rtu::decode(frame)?;
                self.received(address, pdu)
            }
            Mode::Ascii => {
                let mut pdu = [0u8; MAX_PDU];
                let (address, n) = ascii::decode(frame, &mut pdu)?;
                self.received(address, pdu.get(..n).unwrap_or(&[]))
            }
        }
    }

    #[inline]
    fn restarts(&self, byte: u8) -> bool {
        self.mode == Mode::Ascii && byte == ascii::START
    }
}

/// The length of an RTU answer frame from its first bytes (address, function code and, for
/// FC 3, the byte count), if they tell it: FC 3 `3 + count + 2`, FC 6 and 8 8 bytes, FC 100 9,
/// FC 101 11, an exception 5. None while unknown or for another function code (the silence
/// then ends the frame and the check judges it).
fn rtu_response_len(frame: &[u8]) -> Option<usize> {
    let &fc = frame.get(1)?;
    Some(match fc {
        3 => 3 + usize::from(*frame.get(2)?) + 2,
        6 | 8 => 8,
        100 => 9,
        101 => 11,
        f if f & 0x80 != 0 => 5,
        _ => return None,
    })
}

/// Encode a whole request frame (address, PDU, check; ASCII adds `:` hex LRC CR LF) into
/// `out`; the number of bytes. [`MAX_FRAME`] bytes are always enough.
pub fn encode_request(
    mode: Mode,
    address: Address,
    req: &Request,
    out: &mut [u8],
) -> Result<usize, BufferTooSmall> {
    match mode {
        Mode::Rtu => rtu_frame(address, out, |pdu| req.encode(pdu)),
        Mode::Ascii => {
            let mut pdu = [0u8; LONGEST_PDU];
            let n = req.encode(&mut pdu)?;
            ascii::encode(address, pdu.get(..n).unwrap_or(&[]), out)
        }
    }
}

/// Encode a whole response frame into `out`; the number of bytes. [`MAX_FRAME`] bytes are
/// always enough.
pub fn encode_response(
    mode: Mode,
    address: Address,
    resp: &Response,
    out: &mut [u8],
) -> Result<usize, BufferTooSmall> {
    match mode {
        Mode::Rtu => rtu_frame(address, out, |pdu| resp.encode(pdu)),
        Mode::Ascii => {
            let mut pdu = [0u8; LONGEST_PDU];
            let n = resp.encode(&mut pdu)?;
            ascii::encode(address, pdu.get(..n).unwrap_or(&[]), out)
        }
    }
}

/// The longest PDU a [`Request`] or [`Response`] encodes to (FC 101: 7 bytes).
const LONGEST_PDU: usize = 7;

/// An RTU frame built in place: the address, the PDU `pdu` writes straight behind it (no
/// intermediate buffer), and the CRC.
#[inline]
fn rtu_frame(
    address: Address,
    out: &mut [u8],
    pdu: impl FnOnce(&mut [u8]) -> Result<usize, BufferTooSmall>,
) -> Result<usize, BufferTooSmall> {
    let (first, rest) = out.split_first_mut().ok_or(BufferTooSmall {
        needed: rtu::MIN_FRAME,
    })?;
    *first = address.get();
    let n = pdu(rest).map_err(|e| BufferTooSmall {
        needed: e.needed + 3,
    })?;
    let len = n + 3;
    let frame = out.get_mut(..len).ok_or(BufferTooSmall { needed: len })?;
    let (body, check) = frame.split_at_mut(len - 2);
    check.copy_from_slice(&rtu::crc(body).to_le_bytes());
    Ok(len)
}

/// Decode a whole frame (for `drivectl decode` and tests): check it and copy its PDU into
/// `pdu_out`; the address and the PDU's length. See [`rtu::decode`] and [`ascii::decode`] for
/// the checks.
pub fn decode_frame(
    mode: Mode,
    frame: &[u8],
    pdu_out: &mut [u8; MAX_PDU],
) -> Result<(Address, usize), FrameError> {
    match mode {
        Mode::Rtu => {
            let (address, pdu) = rtu::decode(frame)?;
            let dst = pdu_out
                .get_mut(..pdu.len())
                .ok_or(FrameError::Line(LineError::TooLong {
                    capacity: rtu::MAX_FRAME as u16,
                }))?;
            dst.copy_from_slice(pdu);
            Ok((address, pdu.len()))
        }
        Mode::Ascii => ascii::decode(frame, pdu_out),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_text_and_line_settings() {
        assert_eq!(Mode::Rtu.to_string(), "rtu");
        assert_eq!(Mode::Ascii.to_string(), "ascii");
        assert_eq!(" ASCII ".parse(), Ok(Mode::Ascii));
        assert_eq!("Rtu".parse(), Ok(Mode::Rtu));
        assert_eq!("tcp".parse::<Mode>(), Err(ParseModeError));
        // Ch. 6.7.1.1: 11 bits; ch. 6.7.2.1: 10 bits; with or without parity.
        for parity in [Parity::Even, Parity::Odd, Parity::None] {
            assert_eq!(Mode::Rtu.line_settings(19200, parity).bits_per_char(), 11);
            assert_eq!(Mode::Ascii.line_settings(19200, parity).bits_per_char(), 10);
        }
        assert_eq!(
            Mode::Ascii.line_settings(9600, Parity::Even).to_string(),
            "9600 7E1"
        );
        assert_eq!(
            Mode::Rtu.line_settings(9600, Parity::None).to_string(),
            "9600 8N2"
        );
        assert_eq!((Mode::Rtu.max_frame(), Mode::Ascii.max_frame()), (256, 513));
    }

    #[test]
    fn framing_times_per_mode() {
        let line = LineSettings::new(19200);
        let rtu = ModbusFraming::new(Mode::Rtu, Side::Master, &line);
        assert_eq!(rtu.timing(), rtu::timing(&line));
        let ascii = ModbusFraming::new(Mode::Ascii, Side::Slave, &line);
        assert_eq!(ascii.timing().max_gap, Duration::from_nanos(1_000_000_001));
        let longer = ascii.with_ascii_max_gap(Duration::from_secs(3));
        assert_eq!(longer.timing().max_gap, Duration::from_nanos(3_000_000_001));
        assert_eq!(
            rtu.with_ascii_max_gap(Duration::from_secs(3)).timing(),
            rtu.timing()
        );
        assert_eq!(
            (longer.mode(), longer.side(), longer.line()),
            (Mode::Ascii, Side::Slave, line)
        );
    }
}
