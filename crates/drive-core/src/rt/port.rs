//! A master's side of a line: the async glue between a sans-IO [`Endpoint`] and a [`CharIo`].

use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use super::time::Sleep;
use tokio::time::Instant as TokioInstant;

use super::clock::{Clock, Timebase};
use super::io::{
    CHUNK, CharIo, ReceivedChar, WireTime, Woken, read_or_sleep, write_all, write_all_at,
};
use crate::char::RxChar;
use crate::endpoint::Endpoint;
use crate::time::Instant;

/// The async side of a sans-IO master: it writes what the endpoint hands out, feeds every
/// received character with its arrival time, and calls the endpoint's `handle_timeout` when its
/// deadline is reached. Every protocol rule is the endpoint's; the port only waits and moves
/// bytes. Characters that are waiting are always fed before a deadline is handled, and a
/// deadline in the past is handled through the same timer as any other (so a loop of
/// [`Port::transmit`] and [`Port::wait`] always yields to the runtime).
///
/// Timing ([`Clock`]): on [`Clock::Real`] every pause is waited for on tokio's clock; when the
/// timer for a deadline ends (on tokio's next 1 ms tick), the endpoint is told the deadline as
/// its time, [`Port::now`] stays there until the next transmission or character (within
/// [`TIMER_RESOLUTION`]), and a frame the endpoint then sends is written with that time as
/// its intended start ([`write_all_at`]: exact on the wire model, on the tick on a real port).
/// On
/// [`Clock::Virtual`] the endpoint's clock advances one character time per character and jumps
/// to every deadline that needs only a quiet line ([`Endpoint::poll_quiet_timeout`]); its other
/// deadlines (a response timeout, a gap limit inside an answer) become real timers measured
/// from the last event (the last transmission or the last character received).
///
/// Stale characters: before a frame is sent, what already waits in the port is fed first
/// without waiting (a master with a request queued counts it as stale and holds the frame back
/// until the line was quiet for its idle gap), so an answer an earlier program left in the port
/// is never judged against the request sent after it. On a port whose characters are stamped
/// when read ([`WireTime::Real`], [`WireTime::None`]) the port also reads what waits right
/// after the write, tells the endpoint when the frame has left ([`Endpoint::frame_left`]:
/// when the write returned, on a real line not before the frame's wire time) and then feeds
/// those characters: they arrived while the frame was leaving and are stale too. On the wire
/// model ([`WireTime::Exact`]) the arrival times are exact and the endpoint's own wire time of
/// the frame decides; behind a wrapper that does not say ([`WireTime::Unknown`]) only what waits
/// before the frame is sent is stale. [`Driver::run`](super::Driver::run) counts the stale
/// characters in its [`Tally`](super::Tally).
///
/// [`TIMER_RESOLUTION`]: super::TIMER_RESOLUTION
#[derive(Debug)]
pub struct Port<IO> {
    io: IO,
    time: Timebase,
    rx: Box<[ReceivedChar]>,
    /// The wait timer, made on first use (so that `new` works outside a runtime), and the
    /// instant it is set to.
    sleep: Option<(Sleep, TokioInstant)>,
    /// Virtual clock: tokio time and endpoint time of the last event (a transmission or a
    /// received character), from which real timers are measured.
    anchor: Option<(TokioInstant, Instant)>,
    /// Virtual clock: the endpoint time at which a quiet deadline was last handled, so that an
    /// endpoint that makes no progress there is waited for instead of polled in a loop.
    quiet_handled_at: Option<Instant>,
    /// Arrival of the last character fed to the endpoint.
    last_rx: Option<TokioInstant>,
    /// Real clock: the endpoint time the last timer wake-up was handled at (the deadline,
    /// not tokio's late tick), until the next transmission or character.
    woken: Option<Instant>,
    /// When the last frame was meant to start on tokio's clock (see [`Port::last_tx_start`]).
    last_tx: Option<TokioInstant>,
    /// The frame buffer of [`Link::step`](super::Link::step), as long as the longest frame of
    /// the endpoints stepped so far.
    tx: Box<[u8]>,
}

impl<IO: CharIo> Port<IO> {
    /// A port on `io` for a line with `char_time`; the epoch of its times is now.
    pub fn new(io: IO, clock: Clock, char_time: Duration) -> Self {
        let time = Timebase::new(clock, char_time);
        Self {
            io,
            rx: vec![ReceivedChar::new(0, time.epoch()); CHUNK].into_boxed_slice(),
            time,
            sleep: None,
            anchor: None,
            quiet_handled_at: None,
            last_rx: None,
            woken: None,
            last_tx: None,
            tx: Box::default(),
        }
    }

    /// The frame buffer for an endpoint whose frames are at most `len` bytes long (made once,
    /// on first use), taken out until [`Port::put_tx_buffer`].
    pub(super) fn take_tx_buffer(&mut self, len: usize) -> Box<[u8]> {
        if self.tx.len() < len {
            self.tx = vec![0; len].into_boxed_slice();
        }
        std::mem::take(&mut self.tx)
    }

    /// The frame buffer back.
    pub(super) fn put_tx_buffer(&mut self, buf: Box<[u8]>) {
        self.tx = buf;
    }

    /// Now, as the endpoint sees it: right after a timer wake-up on the real clock, the
    /// deadline it was woken for (see [`Clock::Real`]).
    pub fn now(&self) -> Instant {
        self.exact_now().unwrap_or_else(|| self.time.now())
    }

    /// The deadline of the last timer wake-up, while a frame sent now can still start there.
    fn exact_now(&self) -> Option<Instant> {
        self.woken
            .filter(|&t| self.time.intended_start(t).is_some())
    }

    /// The time base.
    pub fn timebase(&self) -> &Timebase {
        &self.time
    }

    /// The I/O object.
    pub fn get_ref(&self) -> &IO {
        &self.io
    }

    /// The I/O object, e.g. to inject faults on the wire model (do not read from it).
    pub fn get_mut(&mut self) -> &mut IO {
        &mut self.io
    }

    /// The I/O object back.
    pub fn into_inner(self) -> IO {
        self.io
    }

    /// Arrival (on tokio's clock) of the last character fed to the endpoint.
    pub fn last_rx_at(&self) -> Option<TokioInstant> {
        self.last_rx
    }

    /// When the last frame [`Port::transmit`] wrote was meant to start, on tokio's clock: the
    /// deadline it was sent for after a timer wake-up (where the wire model starts it), else
    /// the time it was handed to the port.
    pub fn last_tx_start(&self) -> Option<TokioInstant> {
        self.last_tx
    }

    /// Write the frame the endpoint has due now, if any; returns its length. What waits in the
    /// port is fed first, and on a port whose characters are stamped when read what waits right
    /// after the write is fed as having arrived while the frame was leaving (see the
    /// [type docs](Port)). What was fed may have ended the endpoint's work (an answer, a
    /// give-up): look at its events before [`Port::wait`], which waits for input alone when
    /// the endpoint has no deadline ([`Port::step`] does this in the right order). After an
    /// error the frame on the wire is broken or the line gone: tell the endpoint (its
    /// `abort`) and call [`Port::settle`].
    pub async fn transmit<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        buf: &mut [u8],
    ) -> io::Result<Option<usize>> {
        // Listen before talking: what waits in the port came before this frame.
        self.feed_waiting(endpoint, None)?;
        self.send_due(endpoint, buf).await
    }

    /// [`Port::transmit`] once what waits in the port has been fed: write the frame the
    /// endpoint has due now, if any.
    async fn send_due<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        buf: &mut [u8],
    ) -> io::Result<Option<usize>> {
        let exact = self.exact_now();
        let now = exact.unwrap_or_else(|| self.time.now());
        let Some(n) = endpoint.poll_transmit(now, buf) else {
            return Ok(None);
        };
        self.woken = None;
        let frame = frame_of(buf, n)?;
        match exact.and_then(|t| self.time.intended_start(t)) {
            Some(start) => {
                self.last_tx = Some(start);
                write_all_at(&mut self.io, frame, start).await?;
            }
            None => {
                self.last_tx = Some(super::time::now());
                write_all(&mut self.io, frame).await?;
            }
        }
        self.time.sent(n);
        self.anchor = Some((super::time::now(), self.time.now()));
        self.after_write(endpoint, now, n)?;
        Ok(Some(n))
    }

    /// After a frame of `chars` characters that started at `start` was written: on a port whose
    /// characters are stamped when read, the endpoint learns when the frame has left, then
    /// hears what waits in the port now (it arrived while the frame was leaving).
    fn after_write<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        start: Instant,
        chars: usize,
    ) -> io::Result<()> {
        let wire = self.io.wire_time();
        // Exact arrival times (the wire model) need no help; the virtual clock's are made up.
        if wire == WireTime::Exact || self.time.clock() == Clock::Virtual {
            return Ok(());
        }
        if wire == WireTime::Unknown {
            // Nothing is known of the line: only what waited before the frame was sent (fed
            // already) is stale.
            endpoint.frame_left(start);
            return Ok(());
        }
        let n = self.read_ready()?;
        let returned = self.time.now();
        let left = match wire {
            // The port's flush waited for the transmitter, but a USB adapter may still be
            // sending: never before the frame's wire time.
            WireTime::Real => {
                let n = u64::try_from(chars).unwrap_or(u64::MAX);
                let wire = crate::time::duration_nanos(self.time.char_time()).saturating_mul(n);
                returned.later(start.add_nanos(wire))
            }
            _ => returned,
        };
        endpoint.frame_left(left);
        if n > 0 {
            self.feed(endpoint, n, Some(left));
            self.feed_waiting(endpoint, Some(left))?;
        }
        Ok(())
    }

    /// Feed what waits in the port now, without waiting (a bounded number of reads); with
    /// `not_after`, characters are timed no later than that (they were waiting then). Returns
    /// how many characters were fed.
    fn feed_waiting<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        not_after: Option<Instant>,
    ) -> io::Result<usize> {
        let mut fed = 0;
        for _ in 0..DRAIN_READS {
            let n = self.read_ready()?;
            if n == 0 {
                break;
            }
            self.feed(endpoint, n, not_after);
            fed += n;
        }
        Ok(fed)
    }

    /// Read what the port holds now into the receive buffer, without waiting: the number of
    /// characters (0: none, or end of file, which the next [`Port::wait`] reports).
    fn read_ready(&mut self) -> io::Result<usize> {
        let mut cx = Context::from_waker(Waker::noop());
        match self.io.poll_read_chars(&mut cx, &mut self.rx) {
            Poll::Ready(r) => r,
            Poll::Pending => Ok(0),
        }
    }

    /// Feed the first `n` characters of the receive buffer with their arrival times (with
    /// `not_after`, no later than that).
    fn feed<E: Endpoint>(&mut self, endpoint: &mut E, n: usize, not_after: Option<Instant>) {
        self.woken = None;
        for c in self.rx.iter().take(n) {
            let arrived = self.time.arrival(c.at);
            let time = not_after.map_or(arrived, |t| arrived.min(t));
            self.last_rx = Some(c.at);
            endpoint.handle_char(RxChar {
                byte: c.byte,
                time,
                error: c.error,
            });
        }
        if self.time.clock() == Clock::Virtual
            && let Some(at) = self.last_rx
        {
            self.anchor = Some((at, self.time.now()));
        }
    }

    /// Wait for the endpoint's next deadline or for received characters, and feed what
    /// happened. Returns `false` when the port was closed (end of file).
    pub async fn wait<E: Endpoint>(&mut self, endpoint: &mut E) -> io::Result<bool> {
        let deadline = endpoint.poll_timeout();
        let timer_at = match self.time.clock() {
            Clock::Real => deadline.map(|d| self.time.to_tokio(d)),
            Clock::Virtual => {
                if let Some(q) = endpoint.poll_quiet_timeout() {
                    let now = self.time.now();
                    if q > now || self.quiet_handled_at != Some(now) {
                        self.time.jump_to(q);
                        let now = self.time.now();
                        self.quiet_handled_at = Some(now);
                        endpoint.handle_timeout(now);
                        return Ok(true);
                    }
                }
                deadline.map(|d| {
                    let (real, virt) = self
                        .anchor
                        .unwrap_or_else(|| (super::time::now(), self.time.now()));
                    real + d.saturating_duration_since(virt)
                })
            }
        };
        let sleep = match timer_at {
            Some(at) => {
                let (s, armed) = self
                    .sleep
                    .get_or_insert_with(|| (super::time::sleep_until(at), at));
                if *armed != at {
                    Pin::new(&mut *s).reset(at);
                    *armed = at;
                }
                Some(Pin::new(s))
            }
            None => None,
        };
        match read_or_sleep(&mut self.io, &mut self.rx, sleep).await? {
            Woken::Read(0) => Ok(false),
            Woken::Read(n) => {
                self.feed(endpoint, n, None);
                Ok(true)
            }
            Woken::Timer => {
                let now = match (self.time.clock(), deadline) {
                    (Clock::Real, Some(d)) if self.io.honours_write_start() => {
                        // Never before a character already fed.
                        let floor = self.last_rx.map(|at| self.time.to_instant(at));
                        let now =
                            floor.map_or(self.time.woken_at(d), |f| self.time.woken_at(d).later(f));
                        self.woken = Some(now);
                        now
                    }
                    (_, d) => {
                        if let Some(d) = d {
                            self.time.jump_to(d);
                        }
                        self.time.now()
                    }
                };
                endpoint.handle_timeout(now);
                Ok(true)
            }
        }
    }

    /// One step of a master's transaction, the same for every protocol's driver (the serial
    /// [`Link`](super::Link) of [`Driver`](super::Driver)): feed what
    /// waits in the port ([`Step::Waited`]: the endpoint may have events now), else send the
    /// frame the endpoint has due now ([`Step::Sent`]), else wait for its next deadline or for
    /// received characters and feed them ([`Step::Waited`]). A failed write is settled first
    /// (what did get out leaves the line); a closed port is `UnexpectedEof`. After an error
    /// the frame on the wire is broken or the line gone: the caller drops its request (its
    /// master's `abort`).
    ///
    /// Whatever the endpoint hears ends the step: input may complete its request or make it
    /// give up, and an endpoint with nothing in flight has no deadline, so a wait after that
    /// would wait for input alone, for ever.
    pub async fn step<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        buf: &mut [u8],
    ) -> io::Result<Step> {
        // What waits is heard before anything is sent (and may complete or fail the request:
        // the caller drains the endpoint's events before the next step). The port is read
        // once: a second read before sending could hear the end of an answer and leave the
        // step waiting for a request that is already done.
        if self.feed_waiting(endpoint, None)? > 0 {
            return Ok(Step::Waited);
        }
        match self.send_due(endpoint, buf).await {
            Ok(Some(n)) => return Ok(Step::Sent(n)),
            Ok(None) => {}
            Err(e) => {
                self.settle().await;
                return Err(e);
            }
        }
        if self.wait(endpoint).await? {
            Ok(Step::Waited)
        } else {
            Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the port was closed",
            ))
        }
    }

    /// After a failed write: let what did get out leave the line (best effort, at most 1 s).
    pub async fn settle(&mut self) {
        let io = &mut self.io;
        let flush = std::future::poll_fn(|cx| io.poll_flush(cx));
        let _ = super::time::timeout(Duration::from_secs(1), flush).await;
    }
}

/// Reads of what waits in the port before and right after a frame is sent, at most
/// ([`CHUNK`] characters each); the rest is read by the next wait.
const DRAIN_READS: usize = 16;

/// The first `n` bytes of `buf`, the frame an endpoint said it wrote there; an endpoint that
/// reports more than the buffer holds is a bug, reported instead of sending a cut frame.
pub(super) fn frame_of(buf: &[u8], n: usize) -> io::Result<&[u8]> {
    buf.get(..n).ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "the endpoint reported a {n}-byte frame in a {}-byte buffer",
                buf.len()
            ),
        )
    })
}

/// What [`Port::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// A frame of this many bytes was written.
    Sent(usize),
    /// Time passed or characters arrived; the endpoint was told.
    Waited,
}
