//! The ways a bus's frames travel, as the gateway wraps them: one boxed character line for
//! every serial protocol ([`LineIo`]), a port that reopens itself after a failure with a
//! back-off ([`Reopen`]), one line shared by several per-drive masters that keeps the
//! protocol's idle gap between their telegrams ([`SharedLine`]), and fault injection that can
//! be switched on and off on a simulated line ([`FaultSwitch`]).

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::can::CanFrame;
use drive_core::rt::{CanIo, CharIo, ReceivedChar, ReceivedFrame, WireTime};
use drive_transport::link::{FaultConfig, FaultStats, LinkEnd};
use tokio::time::{Instant as TokioInstant, Sleep};

/// Any character line (a serial port, the wire model, a reopening port), boxed so that every
/// serial protocol's bus has one type whatever its endpoint.
pub struct LineIo(pub Box<dyn CharIo>);

impl std::fmt::Debug for LineIo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LineIo")
    }
}

impl CharIo for LineIo {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        self.0.poll_read_chars(cx, buf)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        self.0.poll_write(cx, buf)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        self.0.poll_flush(cx)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        self.0.poll_write_at(cx, buf, start)
    }

    fn honours_write_start(&self) -> bool {
        self.0.honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        self.0.wire_time()
    }

    fn echo_watch(&self) -> Option<drive_core::rt::echo::EchoWatch> {
        self.0.echo_watch()
    }

    fn confirm_echo(&mut self) {
        self.0.confirm_echo();
    }
}

/// The first wait after a port failed, doubled after every failed attempt up to
/// [`BACKOFF_MAX`].
pub const BACKOFF_MIN: Duration = Duration::from_secs(1);
/// The longest wait between two attempts to open a port.
pub const BACKOFF_MAX: Duration = Duration::from_secs(30);

/// Opens a port: the boxed future of one attempt (its error for a person).
pub type Opener<IO> =
    Box<dyn FnMut() -> Pin<Box<dyn Future<Output = Result<IO, String>> + Send>> + Send>;

enum State<IO> {
    Open(IO),
    Opening(Pin<Box<dyn Future<Output = Result<IO, String>> + Send>>),
    Waiting(Pin<Box<Sleep>>),
}

/// A port that opens itself on first use and reopens itself after an I/O error (a USB adapter
/// unplugged): while it is closed every call fails at once (the drives show `timeout`), and a
/// new attempt is made once the back-off (1 s, doubling to 30 s) has passed. Every failure is
/// logged with the port and what to check.
pub struct Reopen<IO> {
    /// The bus's name (logs).
    bus: String,
    /// The port as configured (logs).
    what: String,
    /// What to check when it cannot be opened.
    hint: &'static str,
    open: Opener<IO>,
    state: State<IO>,
    backoff: Duration,
    /// Attempts that failed in a row.
    failures: u32,
}

impl<IO> std::fmt::Debug for Reopen<IO> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reopen")
            .field("bus", &self.bus)
            .field("what", &self.what)
            .field("backoff", &self.backoff)
            .finish()
    }
}

impl<IO> Reopen<IO> {
    /// `what` on bus `bus`, opened by `open` on first use; `hint` says what to check when it
    /// fails.
    pub fn new(bus: &str, what: &str, hint: &'static str, mut open: Opener<IO>) -> Self {
        let first = open();
        Self {
            bus: bus.to_owned(),
            what: what.to_owned(),
            hint,
            open,
            state: State::Opening(first),
            backoff: BACKOFF_MIN,
            failures: 0,
        }
    }

    /// The wait before the next attempt after `failures` failed ones in a row.
    pub fn backoff_after(failures: u32) -> Duration {
        let factor = 1u32
            .checked_shl(failures.saturating_sub(1))
            .unwrap_or(u32::MAX);
        BACKOFF_MIN.saturating_mul(factor).min(BACKOFF_MAX)
    }

    fn closed_error(&self) -> io::Error {
        io::Error::new(
            io::ErrorKind::NotConnected,
            // The hint was logged with the failed open; the drivers add their own.
            format!(
                "{} is not open (next attempt within {} s)",
                self.what,
                self.backoff.as_secs()
            ),
        )
    }

    /// The open port, or why there is none (after starting an attempt when one is due).
    fn poll_ready(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<&mut IO>> {
        loop {
            match &mut self.state {
                State::Open(_) => break,
                State::Opening(fut) => match fut.as_mut().poll(cx) {
                    Poll::Pending => return Poll::Pending,
                    Poll::Ready(Ok(io)) => {
                        if self.failures > 0 {
                            tracing::info!(bus = %self.bus, port = %self.what, "port open again");
                        } else {
                            tracing::info!(bus = %self.bus, port = %self.what, "port open");
                        }
                        self.failures = 0;
                        self.backoff = BACKOFF_MIN;
                        self.state = State::Open(io);
                    }
                    Poll::Ready(Err(e)) => {
                        self.failures = self.failures.saturating_add(1);
                        self.backoff = Self::backoff_after(self.failures);
                        tracing::warn!(
                            bus = %self.bus,
                            port = %self.what,
                            retry_in_s = self.backoff.as_secs(),
                            "cannot open the port: {e}; {}",
                            self.hint
                        );
                        self.state = State::Waiting(Box::pin(tokio::time::sleep(self.backoff)));
                        return Poll::Ready(Err(self.closed_error()));
                    }
                },
                State::Waiting(sleep) => {
                    if sleep.as_mut().poll(cx).is_pending() {
                        return Poll::Ready(Err(self.closed_error()));
                    }
                    self.state = State::Opening((self.open)());
                }
            }
        }
        let closed = self.closed_error();
        match &mut self.state {
            State::Open(io) => Poll::Ready(Ok(io)),
            _ => Poll::Ready(Err(closed)),
        }
    }

    /// `r` of the open port: an error closes it (reopened after [`BACKOFF_MIN`]).
    fn check<T>(&mut self, r: Poll<io::Result<T>>) -> Poll<io::Result<T>> {
        if let Poll::Ready(Err(e)) = &r {
            tracing::warn!(
                bus = %self.bus,
                port = %self.what,
                "the port failed: {e}; closing it and reopening in {} s; {}",
                BACKOFF_MIN.as_secs(),
                self.hint
            );
            self.failures = 1;
            self.backoff = BACKOFF_MIN;
            self.state = State::Waiting(Box::pin(tokio::time::sleep(BACKOFF_MIN)));
        }
        r
    }
}

macro_rules! ready_io {
    ($self:ident, $cx:ident) => {
        match $self.poll_ready($cx) {
            Poll::Ready(Ok(io)) => io,
            Poll::Ready(Err(e)) => return Poll::Ready(Err(e)),
            Poll::Pending => return Poll::Pending,
        }
    };
}

impl CharIo for Reopen<LineIo> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        let io = ready_io!(self, cx);
        let r = io.poll_read_chars(cx, buf);
        // End of file on a serial port: the device is gone.
        let r = match r {
            Poll::Ready(Ok(0)) if !buf.is_empty() => Poll::Ready(Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the port was closed",
            ))),
            other => other,
        };
        self.check(r)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        let io = ready_io!(self, cx);
        let r = io.poll_write(cx, buf);
        self.check(r)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let io = ready_io!(self, cx);
        let r = io.poll_flush(cx);
        self.check(r)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        let io = ready_io!(self, cx);
        let r = io.poll_write_at(cx, buf, start);
        self.check(r)
    }

    fn honours_write_start(&self) -> bool {
        match &self.state {
            State::Open(io) => io.honours_write_start(),
            _ => false,
        }
    }

    fn wire_time(&self) -> WireTime {
        match &self.state {
            State::Open(io) => io.wire_time(),
            _ => WireTime::Unknown,
        }
    }

    // A port opened again is a new adapter, perhaps: its watch starts again.
    fn echo_watch(&self) -> Option<drive_core::rt::echo::EchoWatch> {
        match &self.state {
            State::Open(io) => io.echo_watch(),
            _ => None,
        }
    }

    fn confirm_echo(&mut self) {
        if let State::Open(io) = &mut self.state {
            io.confirm_echo();
        }
    }
}

/// A boxed CAN interface.
pub type CanBox = Box<dyn CanIo>;

impl CanIo for Reopen<CanBox> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        let io = ready_io!(self, cx);
        let r = io.poll_recv(cx);
        self.check(r)
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        let io = ready_io!(self, cx);
        let r = io.poll_send(cx, frame);
        self.check(r)
    }

    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: TokioInstant,
    ) -> Poll<io::Result<()>> {
        let io = ready_io!(self, cx);
        let r = io.poll_send_at(cx, frame, start);
        self.check(r)
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

struct Shared {
    io: LineIo,
    /// When the last character was received (its arrival).
    last_rx: Option<TokioInstant>,
    /// The idle time the protocol needs before a telegram.
    gap: Duration,
}

/// One line shared by several masters (USS: one per drive, each with its own telegram state),
/// one transaction at a time. A master does not see the others' traffic, so the line keeps
/// the protocol's idle gap itself: a telegram never starts sooner than `gap` after the last
/// character received.
pub struct SharedLine {
    inner: Arc<Mutex<Shared>>,
    /// The wait for the gap on a port that cannot place a frame.
    gate: Option<Pin<Box<Sleep>>>,
}

impl std::fmt::Debug for SharedLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SharedLine")
    }
}

impl SharedLine {
    /// `io`, shared; telegrams start at least `gap` after the last received character.
    pub fn new(io: LineIo, gap: Duration) -> Self {
        Self {
            inner: Arc::new(Mutex::new(Shared {
                io,
                last_rx: None,
                gap,
            })),
            gate: None,
        }
    }

    /// Another handle on the same line.
    pub fn handle(&self) -> Self {
        Self {
            inner: self.inner.clone(),
            gate: None,
        }
    }

    /// The earliest start of a telegram now.
    fn earliest(s: &Shared) -> Option<TokioInstant> {
        s.last_rx.map(|t| t + s.gap)
    }

    /// On a port that cannot place a frame: wait until `earliest`.
    fn poll_gate(&mut self, cx: &mut Context<'_>, earliest: TokioInstant) -> Poll<()> {
        if earliest <= TokioInstant::now() {
            return Poll::Ready(());
        }
        let sleep = self
            .gate
            .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(earliest)));
        if sleep.deadline() != earliest {
            sleep.as_mut().reset(earliest);
        }
        match sleep.as_mut().poll(cx) {
            Poll::Ready(()) => {
                self.gate = None;
                Poll::Ready(())
            }
            Poll::Pending => Poll::Pending,
        }
    }

    fn write(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: Option<TokioInstant>,
    ) -> Poll<io::Result<usize>> {
        let (earliest, honours) = {
            let s = lock(&self.inner);
            (Self::earliest(&s), s.io.honours_write_start())
        };
        if honours {
            let at = match (start, earliest) {
                (Some(s), Some(e)) => Some(s.max(e)),
                (None, Some(e)) if e > TokioInstant::now() => Some(e),
                (s, _) => s,
            };
            let mut s = lock(&self.inner);
            return match at {
                Some(at) => s.io.poll_write_at(cx, buf, at),
                None => s.io.poll_write(cx, buf),
            };
        }
        if let Some(e) = earliest
            && self.poll_gate(cx, e).is_pending()
        {
            return Poll::Pending;
        }
        lock(&self.inner).io.poll_write(cx, buf)
    }
}

impl CharIo for SharedLine {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        let mut s = lock(&self.inner);
        let r = s.io.poll_read_chars(cx, buf);
        if let Poll::Ready(Ok(n)) = &r
            && let Some(last) = buf.get(..*n).and_then(|b| b.iter().map(|c| c.at).max())
        {
            s.last_rx = Some(s.last_rx.map_or(last, |l| l.max(last)));
        }
        r
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        self.write(cx, buf, None)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        lock(&self.inner).io.poll_flush(cx)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        self.write(cx, buf, Some(start))
    }

    fn honours_write_start(&self) -> bool {
        lock(&self.inner).io.honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        lock(&self.inner).io.wire_time()
    }

    fn echo_watch(&self) -> Option<drive_core::rt::echo::EchoWatch> {
        lock(&self.inner).io.echo_watch()
    }

    fn confirm_echo(&mut self) {
        lock(&self.inner).io.confirm_echo();
    }
}

#[derive(Debug, Default)]
struct Switch {
    faults: FaultConfig,
    generation: u64,
    /// Faults injected into what each end wrote: `[master, drives]`.
    stats: [FaultStats; 2],
}

/// Switches the random faults of a simulated line (both directions) while it runs, and
/// reports what was injected.
#[derive(Debug, Clone, Default)]
pub struct FaultControl {
    switch: Arc<Mutex<Switch>>,
}

// Switched by the fault-injection and load tests (the gateway's simulated buses run without
// faults).
#[cfg_attr(not(test), allow(dead_code))]
impl FaultControl {
    /// From now on, inject `faults` in both directions.
    pub fn set(&self, faults: FaultConfig) {
        let mut s = lock(&self.switch);
        s.faults = faults;
        s.generation += 1;
    }

    /// What was injected so far: into the master's telegrams, and into the drives'.
    pub fn stats(&self) -> [FaultStats; 2] {
        lock(&self.switch).stats
    }

    /// One end of a link under this control (`side` 0: the master's, 1: the drives').
    pub fn wrap(&self, end: LinkEnd, side: usize) -> FaultSwitch {
        FaultSwitch {
            end,
            switch: self.switch.clone(),
            seen: 0,
            side,
        }
    }
}

/// One end of a wire-model link whose faults a [`FaultControl`] switches.
#[derive(Debug)]
pub struct FaultSwitch {
    end: LinkEnd,
    switch: Arc<Mutex<Switch>>,
    seen: u64,
    side: usize,
}

impl FaultSwitch {
    fn before_write(&mut self) {
        let s = lock(&self.switch);
        if s.generation != self.seen {
            self.seen = s.generation;
            self.end.set_faults(s.faults);
        }
    }

    fn after_write(&mut self) {
        let stats = self.end.fault_stats();
        if let Some(slot) = lock(&self.switch).stats.get_mut(self.side) {
            *slot = stats;
        }
    }
}

impl CharIo for FaultSwitch {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        CharIo::poll_read_chars(&mut self.end, cx, buf)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        self.before_write();
        let r = CharIo::poll_write(&mut self.end, cx, buf);
        self.after_write();
        r
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        CharIo::poll_flush(&mut self.end, cx)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        self.before_write();
        let r = self.end.poll_write_at(cx, buf, start);
        self.after_write();
        r
    }

    fn honours_write_start(&self) -> bool {
        self.end.honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        CharIo::wire_time(&self.end)
    }
}
