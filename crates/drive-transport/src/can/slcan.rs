//! slcan: the Lawicel ASCII protocol of common USB-CAN adapters, over a serial port.
//!
//! Every command and frame is one line of ASCII ending in `\r`:
//!
//! | line | meaning |
//! |---|---|
//! | `C` | close the CAN channel |
//! | `S0` … `S8` | bit rate 10, 20, 50, 100, 125, 250, 500, 800, 1000 kbit/s (channel closed) |
//! | `O` | open the channel |
//! | `Z0` | no time stamps on received frames (sent before `O`; some adapters keep the setting) |
//! | `tiiildd…` | standard data frame: 3 hex digits identifier, length digit 0–8, 2 hex digits per byte |
//! | `Tiiiiiiiildd…` | extended data frame: 8 hex digits identifier |
//! | `riiil`, `Riiiiiiiil` | standard and extended remote frame |
//!
//! The adapter answers a command with `\r` (OK) or `\x07` (BEL, error), a transmitted frame
//! with `z\r` (standard) or `Z\r` (extended) on most adapters and plain `\r` on some; all three
//! are accepted. Frames it receives from the bus arrive as `t`/`T`/`r`/`R` lines.
//!
//! * [`SlcanPort`]: the client, a [`CanIo`]. [`SlcanPort::open`] opens a serial port
//!   (8N1; USB adapters ignore the baud rate) and runs `C`, `Z0`, `S<n>`, `O`;
//!   [`SlcanPort::new`] does the same over any `AsyncRead + AsyncWrite`.
//!   Received lines are parsed strictly (hex digits, a length digit 0–8, exactly that many data
//!   bytes, nothing after them); every other line is a [`Rejection`], counted and kept
//!   ([`SlcanStats`]), never a panic or a wrong frame. A transmit waits for the adapter's
//!   answer: BEL is an error, no answer within [`SlcanPort::set_answer_timeout`] (100 ms) too.
//! * [`SlcanAdapter`]: a simulated adapter on the other end of a stream (a pty's master side),
//!   bridging to a [`VirtualNode`]: it speaks the same commands, answers BEL to unknown or
//!   malformed commands, to `S` while open, to `O` without a bit rate, and to frames before
//!   `O`. With a bit rate other than the virtual bus's it forwards nothing in either direction
//!   and answers BEL to transmits, as an adapter that never gets an acknowledge would fail.
//! * [`encode`], [`parse_frame`] and [`s_code`]: the line codec, no allocation.

use crate::link::poll_sleep;
use std::collections::VecDeque;
use std::future::poll_fn;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use std::time::Duration;

use drive_core::can::{Bitrate, CanFrame, ExtendedId, Frame, Id, StandardId};
use drive_core::line::{LineSettings, Parity};
use drive_core::rt::{CanIo, ReceivedFrame, send_frame};
use tokio::io::{AsyncRead, AsyncWrite, AsyncWriteExt, ReadBuf};
use tokio::time::{Instant, Sleep};

use super::virtual_bus::VirtualNode;
use crate::TransportError;
use crate::serial::{self, SerialConfig, SerialPort};

/// The longest frame line without its `\r`: `T` + 8 + 1 + 16.
pub const MAX_LINE: usize = 26;

const BEL: u8 = 0x07;
const CR: u8 = b'\r';

/// The bit rates with an `S` code, in code order (`S0` = 10 kbit/s … `S8` = 1000 kbit/s).
pub const BITRATES: [Bitrate; 9] = [
    Bitrate::K10,
    Bitrate::K20,
    Bitrate::K50,
    Bitrate::K100,
    Bitrate::K125,
    Bitrate::K250,
    Bitrate::K500,
    Bitrate::K800,
    Bitrate::M1,
];

/// The `S` code digit (`b'0'`–`b'8'`) of `bitrate`.
///
/// # Errors
///
/// [`TransportError::SlcanBitrate`] (naming the valid rates) for a rate without a code.
pub fn s_code(bitrate: Bitrate) -> Result<u8, TransportError> {
    BITRATES
        .iter()
        .position(|b| *b == bitrate)
        .and_then(|i| u8::try_from(i).ok())
        .map(|i| b'0' + i)
        .ok_or(TransportError::SlcanBitrate {
            bitrate: bitrate.bits_per_second(),
        })
}

/// The bit rate of `S` code digit `code`, if it is one.
pub fn bitrate_of_code(code: u8) -> Option<Bitrate> {
    BITRATES.get(usize::from(code.checked_sub(b'0')?)).copied()
}

/// Why a received line was not taken as a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum Rejection {
    /// The line starts with a character that is no frame type the client expects.
    #[error("unexpected line starting with byte 0x{first:02X}")]
    UnknownLine {
        /// The first byte of the line.
        first: u8,
    },
    /// More than [`MAX_LINE`] characters without `\r`.
    #[error("line longer than {MAX_LINE} characters")]
    Overlong,
    /// The identifier is not 3 (standard) or 8 (extended) hex digits within range.
    #[error("bad identifier")]
    BadId,
    /// The length is not one digit 0–8.
    #[error("bad length digit")]
    BadLength,
    /// A data character is not a hex digit.
    #[error("data is not hex digits")]
    BadData,
    /// The line is longer or shorter than its length digit says.
    #[error("line has {got} characters, its length digit needs {expected}")]
    WrongLength {
        /// Characters the line should have (without `\r`).
        expected: usize,
        /// Characters it has.
        got: usize,
    },
    /// An answer (`\r`, `z`, `Z`, BEL) when no command was waiting for one.
    #[error("answer without a command")]
    StrayAnswer,
}

fn hex_value(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    }
}

fn parse_hex(digits: &[u8]) -> Option<u32> {
    digits
        .iter()
        .try_fold(0u32, |acc, &c| Some((acc << 4) | u32::from(hex_value(c)?)))
}

/// Parses a frame line (`t`, `T`, `r` or `R`, without the `\r`), strictly.
///
/// ```
/// use drive_transport::can::slcan::parse_frame;
/// let f = parse_frame(b"t10B40006138800").unwrap_err(); // 4 bytes announced, 3 given
/// let f = parse_frame(b"t10B400061388").unwrap();
/// assert_eq!(f.to_string(), "10B#00061388");
/// ```
///
/// # Errors
///
/// The [`Rejection`] naming what is wrong.
pub fn parse_frame(line: &[u8]) -> Result<CanFrame, Rejection> {
    let Some((&kind, rest)) = line.split_first() else {
        return Err(Rejection::UnknownLine { first: CR });
    };
    let (id_len, remote) = match kind {
        b't' => (3, false),
        b'T' => (8, false),
        b'r' => (3, true),
        b'R' => (8, true),
        other => return Err(Rejection::UnknownLine { first: other }),
    };
    let id_digits = rest.get(..id_len).ok_or(Rejection::BadId)?;
    let raw = parse_hex(id_digits).ok_or(Rejection::BadId)?;
    let id: Id = if id_len == 3 {
        StandardId::new(u16::try_from(raw).map_err(|_| Rejection::BadId)?)
            .ok_or(Rejection::BadId)?
            .into()
    } else {
        ExtendedId::new(raw).ok_or(Rejection::BadId)?.into()
    };
    let len_char = *rest.get(id_len).ok_or(Rejection::BadLength)?;
    let len = match len_char {
        b'0'..=b'8' => usize::from(len_char - b'0'),
        _ => return Err(Rejection::BadLength),
    };
    let data_digits = rest.get(id_len + 1..).unwrap_or(&[]);
    let expected_digits = if remote { 0 } else { 2 * len };
    if data_digits.len() != expected_digits {
        return Err(Rejection::WrongLength {
            expected: 2 + id_len + expected_digits,
            got: line.len(),
        });
    }
    if remote {
        return CanFrame::remote_frame(id, len as u8).ok_or(Rejection::BadLength);
    }
    let mut data = [0u8; 8];
    for (dst, pair) in data.iter_mut().zip(data_digits.chunks_exact(2)) {
        let value = parse_hex(pair).ok_or(Rejection::BadData)?;
        *dst = value as u8;
    }
    Ok(CanFrame::from_array(id, data, len))
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn hex_digit(v: u32) -> u8 {
    HEX.get((v & 0xF) as usize).copied().unwrap_or(b'0')
}

/// Encodes `frame` as a transmit line with its `\r` into `out`; returns the length used.
///
/// ```
/// use drive_core::can::CanFrame;
/// use drive_transport::can::slcan::encode;
/// let mut buf = [0u8; 27];
/// let n = encode(&CanFrame::standard(0x10B, &[0, 6]).unwrap(), &mut buf);
/// assert_eq!(&buf[..n], b"t10B20006\r");
/// ```
pub fn encode(frame: &CanFrame, out: &mut [u8; MAX_LINE + 1]) -> usize {
    let mut n = 0;
    let mut put = |b: u8| {
        if let Some(slot) = out.get_mut(n) {
            *slot = b;
            n += 1;
        }
    };
    let remote = frame.is_remote_frame();
    match frame.id() {
        Id::Standard(s) => {
            put(if remote { b'r' } else { b't' });
            let raw = u32::from(s.as_raw());
            for shift in [8, 4, 0] {
                put(hex_digit(raw >> shift));
            }
        }
        Id::Extended(e) => {
            put(if remote { b'R' } else { b'T' });
            let raw = e.as_raw();
            for shift in (0..8).rev() {
                put(hex_digit(raw >> (shift * 4)));
            }
        }
    }
    put(b'0' + frame.dlc().min(8) as u8);
    for &b in frame.data() {
        put(hex_digit(u32::from(b) >> 4));
        put(hex_digit(u32::from(b)));
    }
    put(CR);
    n
}

/// One line or answer from the adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Incoming {
    /// `\r` alone, `z\r`, `Z\r`: a command or transmit succeeded.
    Ok,
    /// BEL: the adapter refused.
    Bel,
    /// A received frame.
    Frame(CanFrame),
    /// A line that is neither.
    Rejected(Rejection),
}

/// Splits the adapter's byte stream into lines and answers.
#[derive(Debug)]
struct LineSplitter {
    line: [u8; MAX_LINE],
    len: usize,
    overlong: bool,
}

impl LineSplitter {
    fn new() -> Self {
        LineSplitter {
            line: [0; MAX_LINE],
            len: 0,
            overlong: false,
        }
    }

    /// Feeds one byte; returns what it completes.
    fn push(&mut self, byte: u8) -> Option<Incoming> {
        match byte {
            BEL => {
                self.len = 0;
                self.overlong = false;
                Some(Incoming::Bel)
            }
            // Some adapters end lines with CR LF.
            b'\n' => None,
            CR => {
                let line = self.line.get(..self.len).unwrap_or(&[]);
                let out = if self.overlong {
                    Incoming::Rejected(Rejection::Overlong)
                } else {
                    match line {
                        [] | [b'z'] | [b'Z'] => Incoming::Ok,
                        _ => match parse_frame(line) {
                            Ok(frame) => Incoming::Frame(frame),
                            Err(r) => Incoming::Rejected(r),
                        },
                    }
                };
                self.len = 0;
                self.overlong = false;
                Some(out)
            }
            other => {
                match self.line.get_mut(self.len) {
                    Some(slot) => {
                        *slot = other;
                        self.len += 1;
                    }
                    None => self.overlong = true,
                }
                None
            }
        }
    }
}

/// Counters of an [`SlcanPort`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SlcanStats {
    /// Frames received.
    pub received: u64,
    /// Frames sent (acknowledged by the adapter).
    pub sent: u64,
    /// Lines rejected (malformed, unknown, stray answers).
    pub rejected: u64,
    /// The most recent rejection.
    pub last_rejection: Option<Rejection>,
    /// Received frames discarded because the receive queue was full.
    pub overruns: u64,
}

/// How many received frames an [`SlcanPort`] keeps unread before it discards further ones.
const RX_CAPACITY: usize = 256;

/// An answer to the command in flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Answer {
    Ok,
    Bel,
}

#[derive(Debug)]
enum SendState {
    Idle,
    Writing {
        buf: [u8; MAX_LINE + 1],
        len: usize,
        pos: usize,
    },
    Awaiting {
        deadline: Instant,
    },
}

/// An slcan adapter as a [`CanIo`] (see the module docs).
#[derive(Debug)]
pub struct SlcanPort<S> {
    io: S,
    name: String,
    splitter: LineSplitter,
    rx: VecDeque<ReceivedFrame>,
    answer: Option<Answer>,
    awaiting: bool,
    eof: bool,
    send: SendState,
    in_flight: Option<CanFrame>,
    answer_timeout: Duration,
    sleep: Option<Pin<Box<Sleep>>>,
    stats: SlcanStats,
}

impl SlcanPort<SerialPort> {
    /// Opens the adapter at `path` (8N1) and its CAN channel at `bitrate`.
    ///
    /// # Errors
    ///
    /// [`TransportError::SlcanBitrate`] for a rate without an `S` code (before the port is
    /// touched), the serial port's errors, and those of [`SlcanPort::new`].
    pub async fn open(path: &str, bitrate: Bitrate) -> Result<Self, TransportError> {
        s_code(bitrate)?;
        let config =
            SerialConfig::with_line(path, LineSettings::new(115_200).with_parity(Parity::None));
        let port = serial::open(&config)?;
        Self::new(port, path, bitrate).await
    }

    /// How many bytes the serial port's input held when it was opened (discarded: lines an
    /// earlier program left unread, see [`SerialPort::flushed_at_open`]).
    pub fn flushed_at_open(&self) -> u32 {
        self.io.flushed_at_open()
    }
}

impl<S: AsyncRead + AsyncWrite + Unpin + Send> SlcanPort<S> {
    /// Sets up the adapter on `io` (`name` is for messages): `C` (any answer), `Z0` (any
    /// answer), `S<n>` and `O` (both must answer OK).
    ///
    /// # Errors
    ///
    /// [`TransportError::SlcanBitrate`]; [`TransportError::SlcanRefused`] when `S` or `O` is
    /// answered with BEL; [`TransportError::SlcanNoAnswer`] when a command gets no answer
    /// within the answer timeout; [`TransportError::Io`] for I/O errors.
    pub async fn new(io: S, name: &str, bitrate: Bitrate) -> Result<Self, TransportError> {
        let code = s_code(bitrate)?;
        let mut port = SlcanPort {
            io,
            name: name.to_owned(),
            splitter: LineSplitter::new(),
            rx: VecDeque::new(),
            answer: None,
            awaiting: false,
            eof: false,
            send: SendState::Idle,
            in_flight: None,
            answer_timeout: Duration::from_millis(100),
            sleep: None,
            stats: SlcanStats::default(),
        };
        // Closing a closed channel is BEL on a Lawicel adapter: either answer is fine.
        port.command(b"C\r").await?;
        port.command(b"Z0\r").await?;
        let s = [b'S', code, CR];
        if port.command(&s).await? == Answer::Bel {
            return Err(port.refused(&format!("S{} ({bitrate})", char::from(code))));
        }
        if port.command(b"O\r").await? == Answer::Bel {
            return Err(port.refused("O (open the channel)"));
        }
        Ok(port)
    }

    fn refused(&self, command: &str) -> TransportError {
        TransportError::SlcanRefused {
            path: self.name.clone(),
            command: command.to_owned(),
        }
    }

    /// Sends a command line and waits for its answer.
    async fn command(&mut self, line: &[u8]) -> Result<Answer, TransportError> {
        self.io.write_all(line).await?;
        self.io.flush().await?;
        self.answer = None;
        self.awaiting = true;
        let deadline = Instant::now() + self.answer_timeout;
        let result = poll_fn(|cx| {
            if let Err(e) = self.pump(cx) {
                return Poll::Ready(Err(TransportError::Io(e)));
            }
            if let Some(a) = self.answer.take() {
                return Poll::Ready(Ok(a));
            }
            if self.eof {
                return Poll::Ready(Err(TransportError::Io(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "the slcan adapter closed the line",
                ))));
            }
            ready!(poll_sleep(&mut self.sleep, deadline, cx));
            Poll::Ready(Err(TransportError::SlcanNoAnswer {
                path: self.name.clone(),
                command: String::from_utf8_lossy(line.strip_suffix(b"\r").unwrap_or(line))
                    .into_owned(),
            }))
        })
        .await;
        self.awaiting = false;
        result
    }

    /// How long a command or transmit waits for the adapter's answer (default 100 ms).
    pub fn set_answer_timeout(&mut self, timeout: Duration) {
        self.answer_timeout = timeout;
    }

    /// Counters, with the last rejected line's reason.
    pub fn stats(&self) -> SlcanStats {
        self.stats
    }

    /// Closes the channel (`C`) and returns the stream.
    ///
    /// # Errors
    ///
    /// I/O errors writing the command.
    pub async fn close(mut self) -> io::Result<S> {
        self.io.write_all(b"C\r").await?;
        self.io.flush().await?;
        Ok(self.io)
    }

    /// Reads what the adapter has sent and sorts it; `Err` only for I/O errors.
    fn pump(&mut self, cx: &mut Context<'_>) -> io::Result<()> {
        let mut buf = [0u8; 256];
        while !self.eof {
            let mut rb = ReadBuf::new(&mut buf);
            match Pin::new(&mut self.io).poll_read(cx, &mut rb) {
                Poll::Pending => break,
                Poll::Ready(Err(e)) => return Err(e),
                Poll::Ready(Ok(())) => {
                    let n = rb.filled().len();
                    if n == 0 {
                        self.eof = true;
                        break;
                    }
                    let now = Instant::now();
                    for &byte in buf.get(..n).unwrap_or(&[]) {
                        if let Some(incoming) = self.splitter.push(byte) {
                            self.handle(incoming, now);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn handle(&mut self, incoming: Incoming, now: Instant) {
        match incoming {
            Incoming::Ok | Incoming::Bel if self.awaiting && self.answer.is_none() => {
                self.answer = Some(if incoming == Incoming::Bel {
                    Answer::Bel
                } else {
                    Answer::Ok
                });
            }
            Incoming::Ok | Incoming::Bel => self.reject(Rejection::StrayAnswer),
            Incoming::Frame(frame) => {
                if self.rx.len() >= RX_CAPACITY {
                    self.stats.overruns += 1;
                } else {
                    self.rx.push_back(ReceivedFrame { frame, at: now });
                    self.stats.received += 1;
                }
            }
            Incoming::Rejected(r) => self.reject(r),
        }
    }

    fn reject(&mut self, r: Rejection) {
        self.stats.rejected += 1;
        self.stats.last_rejection = Some(r);
    }
}

impl<S: AsyncRead + AsyncWrite + Unpin + Send> CanIo for SlcanPort<S> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        self.pump(cx)?;
        if let Some(frame) = self.rx.pop_front() {
            return Poll::Ready(Ok(frame));
        }
        if self.eof {
            return Poll::Ready(Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                format!("the slcan adapter {} closed the line", self.name),
            )));
        }
        Poll::Pending
    }

    /// Writes the frame's line and waits for the adapter's answer (`z`, `Z` or `\r`: sent;
    /// BEL: an error of kind `Other`; none within the answer timeout: `TimedOut`).
    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        loop {
            match &mut self.send {
                SendState::Idle => {
                    let mut buf = [0u8; MAX_LINE + 1];
                    let len = encode(frame, &mut buf);
                    self.in_flight = Some(*frame);
                    self.send = SendState::Writing { buf, len, pos: 0 };
                }
                SendState::Writing { buf, len, pos } => {
                    while *pos < *len {
                        let rest = buf.get(*pos..*len).unwrap_or(&[]);
                        let n = ready!(Pin::new(&mut self.io).poll_write(cx, rest))?;
                        if n == 0 {
                            self.send = SendState::Idle;
                            return Poll::Ready(Err(io::ErrorKind::WriteZero.into()));
                        }
                        *pos += n;
                    }
                    ready!(Pin::new(&mut self.io).poll_flush(cx))?;
                    self.answer = None;
                    self.awaiting = true;
                    self.send = SendState::Awaiting {
                        deadline: Instant::now() + self.answer_timeout,
                    };
                }
                SendState::Awaiting { deadline } => {
                    let deadline = *deadline;
                    self.pump(cx)?;
                    let answer = self.answer.take();
                    let done = answer.is_some() || self.eof;
                    if !done && poll_sleep(&mut self.sleep, deadline, cx).is_pending() {
                        return Poll::Pending;
                    }
                    self.awaiting = false;
                    self.send = SendState::Idle;
                    let sent = self.in_flight.take();
                    let result = match answer {
                        Some(Answer::Ok) => {
                            self.stats.sent += 1;
                            Ok(())
                        }
                        Some(Answer::Bel) => Err(io::Error::other(format!(
                            "the slcan adapter {} refused the frame (BEL): is the channel open \
                             and the bus up?",
                            self.name
                        ))),
                        None if self.eof => Err(io::Error::new(
                            io::ErrorKind::UnexpectedEof,
                            format!("the slcan adapter {} closed the line", self.name),
                        )),
                        None => Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            format!(
                                "no answer from the slcan adapter {} to a transmitted frame",
                                self.name
                            ),
                        )),
                    };
                    if result.is_ok() && sent.is_some_and(|s| s != *frame) {
                        // The earlier send was abandoned by its caller after it reached the
                        // adapter: now send this one.
                        continue;
                    }
                    return Poll::Ready(result);
                }
            }
        }
    }
}

/// What a [`SlcanAdapter`] did, returned when its stream ends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AdapterStats {
    /// Frames put on the bus.
    pub transmitted: u64,
    /// Frames forwarded from the bus to the stream.
    pub forwarded: u64,
    /// Commands answered with BEL.
    pub refused: u64,
}

/// A simulated slcan adapter bridging a stream to a virtual bus node (see the module docs).
#[derive(Debug)]
pub struct SlcanAdapter<S> {
    io: S,
    node: VirtualNode,
    bus_bitrate: Bitrate,
    bitrate: Option<Bitrate>,
    open: bool,
    stats: AdapterStats,
}

enum AdapterEvent {
    Bytes(usize),
    Frame(ReceivedFrame),
    BusEnded,
}

impl<S: AsyncRead + AsyncWrite + Unpin + Send> SlcanAdapter<S> {
    /// An adapter (channel closed, no bit rate) on `io`, attached through `node` to a bus
    /// running at `bus_bitrate`.
    pub fn new(io: S, node: VirtualNode, bus_bitrate: Bitrate) -> Self {
        SlcanAdapter {
            io,
            node,
            bus_bitrate,
            bitrate: None,
            open: false,
            stats: AdapterStats::default(),
        }
    }

    /// Serves the stream until it ends (end of file: `Ok`) or the bus ends.
    ///
    /// # Errors
    ///
    /// I/O errors on the stream.
    pub async fn run(mut self) -> io::Result<AdapterStats> {
        let mut buf = [0u8; 256];
        let mut splitter = CommandSplitter::new();
        loop {
            let event = poll_fn(|cx| {
                let mut rb = ReadBuf::new(&mut buf);
                if let Poll::Ready(r) = Pin::new(&mut self.io).poll_read(cx, &mut rb) {
                    return Poll::Ready(r.map(|()| AdapterEvent::Bytes(rb.filled().len())));
                }
                match self.node.poll_recv(cx) {
                    Poll::Ready(Ok(f)) => Poll::Ready(Ok(AdapterEvent::Frame(f))),
                    Poll::Ready(Err(e)) if e.kind() == io::ErrorKind::UnexpectedEof => {
                        Poll::Ready(Ok(AdapterEvent::BusEnded))
                    }
                    Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
                    Poll::Pending => Poll::Pending,
                }
            })
            .await?;
            match event {
                AdapterEvent::Bytes(0) | AdapterEvent::BusEnded => return Ok(self.stats),
                AdapterEvent::Bytes(n) => {
                    for &byte in buf.get(..n).unwrap_or(&[]) {
                        if let Some(line) = splitter.push(byte) {
                            let (cmd, len) = line;
                            let cmd = cmd.get(..len).map(<[u8]>::to_vec).unwrap_or_default();
                            self.command(&cmd, splitter.overlong_flag()).await?;
                        }
                    }
                }
                AdapterEvent::Frame(received) => {
                    if self.open && self.bitrate == Some(self.bus_bitrate) {
                        let mut line = [0u8; MAX_LINE + 1];
                        let n = encode(&received.frame, &mut line);
                        self.io.write_all(line.get(..n).unwrap_or(&[])).await?;
                        self.io.flush().await?;
                        self.stats.forwarded += 1;
                    }
                }
            }
        }
    }

    async fn answer(&mut self, bytes: &[u8]) -> io::Result<()> {
        if bytes == [BEL] {
            self.stats.refused += 1;
        }
        self.io.write_all(bytes).await?;
        self.io.flush().await
    }

    async fn command(&mut self, line: &[u8], overlong: bool) -> io::Result<()> {
        const OK: &[u8] = b"\r";
        const ERR: &[u8] = &[BEL];
        if overlong {
            return self.answer(ERR).await;
        }
        match line {
            b"C" if self.open => {
                self.open = false;
                self.answer(OK).await
            }
            [b'S', code] if !self.open => match bitrate_of_code(*code) {
                Some(rate) => {
                    self.bitrate = Some(rate);
                    self.answer(OK).await
                }
                None => self.answer(ERR).await,
            },
            b"O" if !self.open && self.bitrate.is_some() => {
                self.open = true;
                self.answer(OK).await
            }
            b"Z0" if !self.open => self.answer(OK).await,
            b"V" => self.answer(b"V1013\r").await,
            [b't' | b'T' | b'r' | b'R', ..] if self.open => {
                let Ok(frame) = parse_frame(line) else {
                    return self.answer(ERR).await;
                };
                if self.bitrate != Some(self.bus_bitrate) {
                    return self.answer(ERR).await;
                }
                if send_frame(&mut self.node, &frame).await.is_err() {
                    return self.answer(ERR).await;
                }
                self.stats.transmitted += 1;
                let ack: &[u8] = if frame.is_extended() { b"Z\r" } else { b"z\r" };
                self.answer(ack).await
            }
            _ => self.answer(ERR).await,
        }
    }
}

/// Splits commands at `\r` (the adapter's side; `\n` ignored, overlong lines flagged).
struct CommandSplitter {
    line: [u8; MAX_LINE],
    len: usize,
    overlong: bool,
    last_overlong: bool,
}

impl CommandSplitter {
    fn new() -> Self {
        CommandSplitter {
            line: [0; MAX_LINE],
            len: 0,
            overlong: false,
            last_overlong: false,
        }
    }

    fn push(&mut self, byte: u8) -> Option<([u8; MAX_LINE], usize)> {
        match byte {
            b'\n' => None,
            CR => {
                let out = (self.line, self.len);
                self.last_overlong = self.overlong;
                self.len = 0;
                self.overlong = false;
                Some(out)
            }
            other => {
                match self.line.get_mut(self.len) {
                    Some(slot) => {
                        *slot = other;
                        self.len += 1;
                    }
                    None => self.overlong = true,
                }
                None
            }
        }
    }

    fn overlong_flag(&self) -> bool {
        self.last_overlong
    }
}
