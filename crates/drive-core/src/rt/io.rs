//! Character-level I/O: [`CharIo`], implemented for any tokio byte stream through [`Stream`]
//! (and, in `drive-transport`, for the in-memory wire model with exact arrival times and
//! parity flags).

use std::future::{Future as _, poll_fn};
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::Instant as TokioInstant;

use crate::char::CharError;

/// One received character with its arrival time on tokio's clock and the UART's error flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ReceivedChar {
    /// The data byte.
    pub byte: u8,
    /// When its last bit arrived (exact on the wire model; the time of the read otherwise).
    pub at: TokioInstant,
    /// A parity or framing error flagged by the UART.
    pub error: Option<CharError>,
}

impl ReceivedChar {
    /// A character received without error at `at`.
    pub const fn new(byte: u8, at: TokioInstant) -> Self {
        Self {
            byte,
            at,
            error: None,
        }
    }
}

/// A byte stream whose received characters carry their arrival time and UART error flag.
///
/// Implemented for any tokio byte stream through [`Stream`] (serial ports, ptys,
/// [`tokio::io::duplex`]: arrival time = time of the read, no error flags) and for `&mut T`;
/// `drive-transport` implements it for its in-memory wire model.
pub trait CharIo: Send {
    /// Poll for received characters; `Ready(Ok(0))` means end of file (for a non-empty `buf`).
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>>;

    /// Poll to write some of `buf`; returns the number of bytes taken.
    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>>;

    /// Poll until everything written has been handed on (on the wire model: has left the line).
    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>>;

    /// Poll to write some of `buf` as a frame the protocol scheduled to start at `start` on
    /// tokio's clock, which may lie a little in the past: the timer that woke the writer ends
    /// on tokio's next tick ([`TIMER_RESOLUTION`]), after the instant the protocol asked for.
    ///
    /// A real port cannot send in the past: the default ignores `start` and calls
    /// [`CharIo::poll_write`]. The wire model of `drive-transport` puts the first character on
    /// the line at `start` (never before the line is free, never before the characters
    /// already written), so a frame starts where the protocol put it, not at the late
    /// wake-up. Pass the same `start` for every part of one frame.
    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        let _ = start;
        self.poll_write(cx, buf)
    }

    /// Whether [`CharIo::poll_write_at`] honours `start` (the wire model does; a real port
    /// cannot). Only then does a runtime tell its endpoint a timer's exact deadline as the time
    /// of a wake-up; on a port that sends when it is written to, the endpoint keeps the time the
    /// frame really leaves (tokio's, up to 1 ms after the deadline), so its response timeout
    /// counts from the request's true end there too.
    fn honours_write_start(&self) -> bool {
        false
    }

    /// How a frame written here leaves and how received characters are timed: what a
    /// runtime needs to tell when a request has completely left, so that characters received
    /// before are judged stale ([`crate::Endpoint::frame_left`]). A byte stream that delivers
    /// at once ([`Stream`]: pseudo-terminals, pipes) says [`WireTime::None`], a real serial
    /// port [`WireTime::Real`], the wire model [`WireTime::Exact`]. The default,
    /// [`WireTime::Unknown`], is for wrappers that do not say (forward it from the wrapped
    /// I/O): only what waits before a frame is sent counts as stale then.
    fn wire_time(&self) -> WireTime {
        WireTime::Unknown
    }

    /// What the line's echo watch has seen ([`super::echo`]): whether its adapter echoes what
    /// is written, and what came back after the last frame. `None` where nothing watches (the
    /// default; a line whose echo is taken out). Wrappers forward it.
    fn echo_watch(&self) -> Option<super::echo::EchoWatch> {
        None
    }

    /// The protocol knows that an exact copy of the last frame cannot be its answer: the copy
    /// that came back ([`super::echo::Replay::Exact`]) was the adapter's echo. Wrappers
    /// forward it.
    fn confirm_echo(&mut self) {}
}

/// How a [`CharIo`] carries frames ([`CharIo::wire_time`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WireTime {
    /// A frame takes its wire time (length × character time) and every received character is
    /// stamped with its true arrival (drive-transport's wire model): the request has left at
    /// its start plus its wire time, exactly.
    Exact,
    /// A real line (a UART behind a serial port): a frame takes its wire time, but characters
    /// are stamped when the program reads them. What is waiting in the port right after a
    /// request was written arrived while it was leaving; it has left once the write returned
    /// (the port's flush waits for the transmitter) and not before its wire time.
    Real,
    /// No wire time (a pseudo-terminal, an in-memory pipe): a frame has left once the write
    /// returned, and the other side may answer at once.
    None,
    /// Not known (a wrapper that does not forward it): the frame is taken to have left when it
    /// was handed over, so only what waited in the port before counts as stale and no answer
    /// is ever discarded for arriving early.
    Unknown,
}

/// How late a tokio timer may end after its deadline: tokio's timers tick in 1 ms steps. A
/// frame whose protocol start lies at most this far in the past is put on the wire model at
/// that start ([`CharIo::poll_write_at`]); a wake-up later than this (a busy task) counts from
/// its own time.
pub const TIMER_RESOLUTION: core::time::Duration = core::time::Duration::from_millis(1);

impl<T: CharIo + ?Sized> CharIo for &mut T {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        (**self).poll_read_chars(cx, buf)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        (**self).poll_write(cx, buf)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        (**self).poll_flush(cx)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        (**self).poll_write_at(cx, buf, start)
    }

    fn honours_write_start(&self) -> bool {
        (**self).honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        (**self).wire_time()
    }

    fn echo_watch(&self) -> Option<super::echo::EchoWatch> {
        (**self).echo_watch()
    }

    fn confirm_echo(&mut self) {
        (**self).confirm_echo();
    }
}

/// Characters read per call into a stack buffer.
pub const CHUNK: usize = 64;

/// Any tokio byte stream as a [`CharIo`]: every character of a read gets the time of the read
/// ([`TokioInstant::now`]) and no error flag (serial ports, ptys, [`tokio::io::duplex`]).
///
/// A USB serial adapter that delivers characters in bursts makes the gaps between bursts look
/// like inter-character gaps: a master on such a port needs a wider gap limit (drivectl's
/// `--char-gap`), or the adapter's low-latency mode. The same latency makes an answer look
/// later than it was: its first character is judged against the response timeout by the time
/// it was read (an FTDI adapter's default latency timer adds up to 16 ms), so a response timeout
/// at the protocol's limit needs the adapter's low-latency mode or a few milliseconds more.
#[derive(Debug)]
pub struct Stream<T>(pub T);

impl<T: AsyncRead + AsyncWrite + Unpin + Send> CharIo for Stream<T> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        let mut bytes = [0u8; CHUNK];
        let want = buf.len().min(CHUNK);
        let mut rb = ReadBuf::new(bytes.get_mut(..want).unwrap_or(&mut []));
        match Pin::new(&mut self.0).poll_read(cx, &mut rb) {
            Poll::Ready(Ok(())) => {}
            Poll::Ready(Err(e)) => return Poll::Ready(Err(e)),
            Poll::Pending => return Poll::Pending,
        }
        let filled = rb.filled();
        let at = super::time::now();
        for (dst, &byte) in buf.iter_mut().zip(filled) {
            *dst = ReceivedChar::new(byte, at);
        }
        Poll::Ready(Ok(filled.len()))
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.0).poll_write(cx, buf)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.0).poll_flush(cx)
    }

    fn wire_time(&self) -> WireTime {
        WireTime::None
    }
}

/// Write all of `bytes`, then flush.
pub async fn write_all<IO: CharIo + ?Sized>(io: &mut IO, bytes: &[u8]) -> io::Result<()> {
    write_frame(io, bytes, None).await
}

/// Write all of `bytes` as a frame the protocol scheduled to start at `start` (see
/// [`CharIo::poll_write_at`]), then flush.
pub async fn write_all_at<IO: CharIo + ?Sized>(
    io: &mut IO,
    bytes: &[u8],
    start: TokioInstant,
) -> io::Result<()> {
    write_frame(io, bytes, Some(start)).await
}

async fn write_frame<IO: CharIo + ?Sized>(
    io: &mut IO,
    bytes: &[u8],
    start: Option<TokioInstant>,
) -> io::Result<()> {
    let mut rest = bytes;
    while !rest.is_empty() {
        let n = poll_fn(|cx| match start {
            Some(at) => io.poll_write_at(cx, rest, at),
            None => io.poll_write(cx, rest),
        })
        .await?;
        if n == 0 {
            return Err(io::Error::new(
                io::ErrorKind::WriteZero,
                "the port accepted no bytes",
            ));
        }
        rest = rest.get(n..).unwrap_or(&[]);
    }
    poll_fn(|cx| io.poll_flush(cx)).await
}

/// What a wait for characters or a timer ended with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Woken {
    /// This many characters were read (0: end of file).
    Read(usize),
    /// The timer expired.
    Timer,
}

/// Wait for received characters or, if given, the timer; characters win when both are ready.
pub async fn read_or_sleep<IO: CharIo + ?Sized>(
    io: &mut IO,
    buf: &mut [ReceivedChar],
    mut sleep: Option<Pin<&mut super::time::Sleep>>,
) -> io::Result<Woken> {
    poll_fn(|cx| {
        if let Poll::Ready(r) = io.poll_read_chars(cx, buf) {
            return Poll::Ready(r.map(Woken::Read));
        }
        if let Some(s) = sleep.as_mut()
            && s.as_mut().poll(cx).is_ready()
        {
            return Poll::Ready(Ok(Woken::Timer));
        }
        Poll::Pending
    })
    .await
}
