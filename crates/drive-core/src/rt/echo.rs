//! Adapters that echo what they send: two-wire RS-485 converters whose receiver stays on while
//! they transmit hand every request back to the master, byte for byte, before any answer.
//!
//! Unhandled, the echo is taken for an answer where a protocol's answer repeats its request
//! (Modbus FC 5, 6, 8: a write reported as done that no drive answered). [`EchoCancel`] wraps
//! a line and takes each written byte back out of what is received, in order: the master never
//! sees its own frames.
//!
//! * What comes back different once a frame's echo has begun is a **collision** (another
//!   transmitter on the line, or noise): the character is handed on flagged
//!   [`CharError::Collision`], as is the rest of that frame's echo, so the endpoint throws the
//!   frame away as it would a corrupt one and its retry rules apply.
//! * A character that comes while an echo is due but has not begun is **foreign** (a late
//!   answer, another station, or an adapter that does not echo after all): it is flagged, and
//!   the echo is still expected after it. No answer is ever taken from characters received
//!   while our own frame may still come back, so an echo cannot slip through behind a stray
//!   byte.
//! * Echoes come back in the order the frames were written, also when the next frame is written
//!   before the last one's echo was read (a broadcast, then a request, on a USB adapter that
//!   hands characters over late). An echo that has not begun [`ECHO_START`] after its frame was
//!   written is given up when the next frame is written: its first character comes back within
//!   a character time and an adapter's latency of its being sent, whatever the frame's length.
//!   So on an adapter that does not echo, every exchange fails (its answers are foreign): leave
//!   the echo off there.
//!
//! Why not in the endpoints: the echo is the adapter's, not the protocol's; every serial
//! family gets the same handling from one wrapper, and the endpoints' framing, stale-character
//! and timing rules see the line as it would be without the echo.
//!
//! **With the echo off** the wrapper watches instead ([`EchoWatch`], [`CharIo::echo_watch`]):
//! after each frame written it compares what comes back first with the frame. An echoing
//! adapter always hands the frame back first, so
//!
//! * nothing within [`ECHO_START`] of a frame, or something else first, shows the adapter does
//!   not echo ([`EchoBelief::Silent`]);
//! * two exact copies of the frame in a row (its echo and an answer that repeats it) show it
//!   does ([`EchoBelief::Echoes`]); so does one exact copy of a frame whose answer can never
//!   repeat it, which only the protocol knows: its driver says so ([`CharIo::confirm_echo`]);
//! * one exact copy of a frame whose answer may repeat it (Modbus FC 6, 8, 101; USS reads and
//!   mirror telegrams) is the echo or the answer ([`Replay::Exact`]): the driver does not take it
//!   while the belief is not [`EchoBelief::Silent`] ([`after_exchange`]). The wrapper never
//!   changes what it hands on: the drivers decide.

use std::collections::VecDeque;
use std::io;
use std::task::{Context, Poll};
use std::time::Duration;

use tokio::time::Instant as TokioInstant;

use super::io::{CharIo, ReceivedChar, WireTime};
use crate::char::CharError;

/// The most bytes written and not yet echoed that are kept (several of the longest frames of
/// any family); beyond, the oldest frames are given up.
const MAX_PENDING: usize = 2048;

/// How long after a frame is written its echo must have begun before the next frame gives it
/// up: a character time at the slowest rates (9 ms at 1200 baud) and a USB adapter's latency
/// (an FTDI's 16 ms), with room.
pub const ECHO_START: Duration = Duration::from_millis(100);

/// Whether a line's adapter echoes what is written, as far as the watch of a line whose echo is
/// off knows (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EchoBelief {
    /// Nothing shows it yet.
    Unknown,
    /// It echoes: its frames come back.
    Echoes,
    /// It does not: nothing came back after a frame in time, or something else came first.
    Silent,
}

/// What came back first after the last frame written, on a watched line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Replay {
    /// Nothing yet (or the frame is still being compared).
    Pending,
    /// An exact copy of the frame (its echo, or an answer that repeats it).
    Exact,
    /// Something else came first.
    Differed,
    /// Nothing came within [`ECHO_START`].
    Nothing,
}

/// What the echo watch of a line with the echo off has seen ([`CharIo::echo_watch`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EchoWatch {
    /// Whether the adapter echoes.
    pub belief: EchoBelief,
    /// What came back after the last frame.
    pub last: Replay,
}

/// The most bytes of a frame the watch compares (longer frames: their start).
const WATCH_MAX: usize = 512;

/// The watch's state (echo off).
#[derive(Debug)]
struct Watch {
    belief: EchoBelief,
    /// The last frame written (its first [`WATCH_MAX`] bytes).
    frame: Vec<u8>,
    /// When it was written.
    at: Option<TokioInstant>,
    /// Bytes of the current copy compared so far.
    pos: usize,
    /// Exact copies seen.
    copies: u8,
    last: Replay,
    /// Nothing more to learn from what comes back after this frame.
    done: bool,
}

impl Watch {
    fn new() -> Watch {
        Watch {
            belief: EchoBelief::Unknown,
            frame: Vec::new(),
            at: None,
            pos: 0,
            copies: 0,
            last: Replay::Pending,
            done: true,
        }
    }

    fn silent(&mut self) {
        if self.belief == EchoBelief::Unknown {
            self.belief = EchoBelief::Silent;
        }
    }

    /// Nothing came after the frame for [`ECHO_START`] (at `now`).
    fn expired(&self, now: TokioInstant) -> bool {
        !self.done
            && self.last == Replay::Pending
            && self.pos == 0
            && self
                .at
                .is_some_and(|at| now.saturating_duration_since(at) >= ECHO_START)
    }

    fn nothing(&mut self) {
        self.last = Replay::Nothing;
        self.done = true;
        self.silent();
    }

    /// A frame (or its next part, `more`) was written at `now`.
    fn wrote(&mut self, bytes: &[u8], more: bool, now: TokioInstant) {
        if more {
            let room = WATCH_MAX.saturating_sub(self.frame.len());
            self.frame.extend(bytes.iter().take(room));
            return;
        }
        if self.expired(now) {
            self.nothing();
        }
        self.frame.clear();
        self.frame.extend(bytes.iter().take(WATCH_MAX));
        self.at = Some(now);
        self.pos = 0;
        self.copies = 0;
        self.last = Replay::Pending;
        self.done = self.frame.is_empty();
    }

    /// `c` was received.
    fn received(&mut self, c: &ReceivedChar) {
        if self.done {
            return;
        }
        if self.expired(c.at) {
            // Too late for an echo: an answer (or another station).
            self.nothing();
            return;
        }
        let fits = c.error.is_none() && self.frame.get(self.pos) == Some(&c.byte);
        if !fits {
            if self.last == Replay::Pending {
                self.last = Replay::Differed;
                self.silent();
            }
            self.done = true;
            return;
        }
        self.pos += 1;
        if self.pos == self.frame.len() {
            self.pos = 0;
            self.copies = self.copies.saturating_add(1);
            self.last = Replay::Exact;
            if self.copies >= 2 {
                // The echo, and an answer that repeats the request: the adapter echoes.
                self.belief = EchoBelief::Echoes;
                self.done = true;
            }
        }
    }

    fn view(&self, now: TokioInstant) -> EchoWatch {
        if self.expired(now) {
            let belief = match self.belief {
                EchoBelief::Unknown => EchoBelief::Silent,
                b => b,
            };
            return EchoWatch {
                belief,
                last: Replay::Nothing,
            };
        }
        EchoWatch {
            belief: self.belief,
            last: self.last,
        }
    }
}

/// What a driver does with an exchange's answer on a watched line ([`after_exchange`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EchoCheck {
    /// Nothing against it.
    Fine,
    /// The adapter echoes and the line's echo is off: no answer on it can be trusted.
    Echoes,
    /// An exact copy of a request whose answer may repeat it came back, and whether the
    /// adapter echoes is not known yet: the driver sends a request whose answer cannot repeat
    /// it (a read) and asks again.
    Ambiguous,
}

/// Before a request on `io`: `true` when its adapter is known to echo while the echo is off
/// (nothing should be sent: no answer could be trusted).
pub fn echoes<IO: CharIo + ?Sized>(io: &IO) -> bool {
    io.echo_watch()
        .is_some_and(|w| w.belief == EchoBelief::Echoes)
}

/// After a request on `io` whose answer may repeat it (`may_repeat`) or not: what its answer
/// is worth (see the [module docs](self)). An exact copy of a request whose answer never
/// repeats it is the echo: the line is told ([`CharIo::confirm_echo`]).
pub fn after_exchange<IO: CharIo + ?Sized>(io: &mut IO, may_repeat: bool) -> EchoCheck {
    let Some(w) = io.echo_watch() else {
        return EchoCheck::Fine;
    };
    match (w.last, may_repeat) {
        (Replay::Exact, false) => {
            io.confirm_echo();
            EchoCheck::Echoes
        }
        (Replay::Exact, true) => match w.belief {
            EchoBelief::Silent => EchoCheck::Fine,
            EchoBelief::Echoes => EchoCheck::Echoes,
            EchoBelief::Unknown => EchoCheck::Ambiguous,
        },
        _ if w.belief == EchoBelief::Echoes => EchoCheck::Echoes,
        _ => EchoCheck::Fine,
    }
}

/// What an [`EchoCancel`] saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EchoStats {
    /// Bytes taken back out of the received stream (echoed as sent).
    pub echoed: u64,
    /// Frames whose echo differed from what was sent (collisions).
    pub collisions: u64,
    /// Characters that came while an echo was due but had not begun (flagged).
    pub foreign: u64,
    /// Bytes whose echo never came (given up).
    pub missing: u64,
}

/// A frame written whose echo has not all come back.
#[derive(Debug, Clone, Copy)]
struct Frame {
    /// Bytes of its echo still to come.
    left: usize,
    /// When it was written.
    at: TokioInstant,
    /// Whether its echo has begun.
    started: bool,
}

/// A line whose adapter echoes what is written (see the [module docs](self)); with echo off
/// it passes everything through untouched.
#[derive(Debug)]
pub struct EchoCancel<IO> {
    io: IO,
    on: bool,
    /// Bytes written whose echo has not come back yet, oldest first.
    pending: VecDeque<u8>,
    /// The frames those bytes belong to, oldest first (their `left` add up to `pending`).
    frames: VecDeque<Frame>,
    /// After a collision: how many more bytes of that frame's echo are flagged.
    garbled: usize,
    /// A frame is being written (bytes written since the last flush).
    writing: bool,
    stats: EchoStats,
    /// With the echo off: what comes back after each frame.
    watch: Watch,
}

impl<IO> EchoCancel<IO> {
    /// `io`, its echo taken out when `on`.
    pub fn new(io: IO, on: bool) -> Self {
        Self {
            io,
            on,
            pending: VecDeque::new(),
            frames: VecDeque::new(),
            garbled: 0,
            writing: false,
            stats: EchoStats::default(),
            watch: Watch::new(),
        }
    }

    /// Whether the echo is taken out.
    pub fn is_on(&self) -> bool {
        self.on
    }

    /// What was seen so far.
    pub fn stats(&self) -> EchoStats {
        self.stats
    }

    /// The line underneath.
    pub fn get_ref(&self) -> &IO {
        &self.io
    }

    /// The line underneath, for changing.
    pub fn get_mut(&mut self) -> &mut IO {
        &mut self.io
    }

    /// The line back.
    pub fn into_inner(self) -> IO {
        self.io
    }

    /// Drop the oldest frame's echo still to come; how many bytes it had left.
    fn drop_front(&mut self) -> usize {
        let left = self.frames.pop_front().map_or(0, |f| f.left);
        for _ in 0..left {
            self.pending.pop_front();
        }
        left
    }

    /// Give up the oldest frame's echo: it never came.
    fn give_up_front(&mut self) {
        self.stats.missing += self.drop_front() as u64;
    }

    /// A frame (or part of one) of `bytes` was written: its echo is expected after whatever
    /// is still pending. At the start of a frame (after a flush), earlier echoes that have
    /// not begun [`ECHO_START`] after their frame was written are given up.
    fn wrote(&mut self, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        let now = super::time::now();
        if !self.on {
            self.watch.wrote(bytes, self.writing, now);
            self.writing = true;
            return;
        }
        match self.frames.back_mut() {
            Some(f) if self.writing => f.left += bytes.len(),
            _ => {
                while self
                    .frames
                    .front()
                    .is_some_and(|f| !f.started && now.duration_since(f.at) >= ECHO_START)
                {
                    self.give_up_front();
                }
                self.frames.push_back(Frame {
                    left: bytes.len(),
                    at: now,
                    started: false,
                });
            }
        }
        self.writing = true;
        self.pending.extend(bytes);
        while self.pending.len() > MAX_PENDING && self.frames.len() > 1 {
            self.give_up_front();
        }
    }

    /// Take the echo out of `buf[..n]` in place; the number of characters left.
    fn cancel(&mut self, buf: &mut [ReceivedChar], n: usize) -> usize {
        let mut kept = 0;
        for i in 0..n {
            let Some(mut c) = buf.get(i).copied() else {
                break;
            };
            if self.garbled > 0 {
                self.garbled -= 1;
                c.error = Some(CharError::Collision);
            } else if let (Some(&sent), Some(front)) =
                (self.pending.front(), self.frames.front_mut())
            {
                if c.byte == sent && c.error.is_none() {
                    self.pending.pop_front();
                    front.left -= 1;
                    front.started = true;
                    if front.left == 0 {
                        self.frames.pop_front();
                    }
                    self.stats.echoed += 1;
                    continue;
                }
                if front.started {
                    // The echo began and then differed: the frame on the line was not ours.
                    // The rest of its echo is garbled too; later frames' echoes still come.
                    self.stats.collisions += 1;
                    self.garbled = self.drop_front().saturating_sub(1);
                } else {
                    // Something came before the echo: never an answer, and the echo is still
                    // due after it.
                    self.stats.foreign += 1;
                }
                c.error = Some(CharError::Collision);
            }
            if let Some(slot) = buf.get_mut(kept) {
                *slot = c;
            }
            kept += 1;
        }
        kept
    }
}

impl<IO: CharIo> CharIo for EchoCancel<IO> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        loop {
            let n = match self.io.poll_read_chars(cx, buf) {
                Poll::Ready(Ok(n)) => n,
                other => return other,
            };
            if n == 0 {
                return Poll::Ready(Ok(n));
            }
            if !self.on {
                for c in buf.iter().take(n) {
                    self.watch.received(c);
                }
                return Poll::Ready(Ok(n));
            }
            let kept = self.cancel(buf, n);
            if kept > 0 {
                return Poll::Ready(Ok(kept));
            }
            // Only echo: read again (the line is polled until it is pending, so the waker
            // is registered).
        }
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        let r = self.io.poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = r {
            self.wrote(buf.get(..n).unwrap_or(buf));
        }
        r
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = self.io.poll_flush(cx);
        if let Poll::Ready(Ok(())) = r {
            self.writing = false;
        }
        r
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        let r = self.io.poll_write_at(cx, buf, start);
        if let Poll::Ready(Ok(n)) = r {
            self.wrote(buf.get(..n).unwrap_or(buf));
        }
        r
    }

    fn honours_write_start(&self) -> bool {
        self.io.honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        self.io.wire_time()
    }

    fn echo_watch(&self) -> Option<EchoWatch> {
        (!self.on).then(|| self.watch.view(super::time::now()))
    }

    fn confirm_echo(&mut self) {
        if !self.on {
            self.watch.belief = EchoBelief::Echoes;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::task::Waker;

    /// A line with scripted received bytes (all of them handed out at the next read) that
    /// keeps what is written.
    #[derive(Default)]
    struct Script {
        rx: VecDeque<u8>,
        written: Vec<u8>,
    }

    impl CharIo for Script {
        fn poll_read_chars(
            &mut self,
            _cx: &mut Context<'_>,
            buf: &mut [ReceivedChar],
        ) -> Poll<io::Result<usize>> {
            if self.rx.is_empty() {
                return Poll::Pending;
            }
            let at = TokioInstant::now();
            let mut n = 0;
            for slot in buf.iter_mut() {
                let Some(b) = self.rx.pop_front() else { break };
                *slot = ReceivedChar::new(b, at);
                n += 1;
            }
            Poll::Ready(Ok(n))
        }

        fn poll_write(&mut self, _cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
            self.written.extend_from_slice(buf);
            Poll::Ready(Ok(buf.len()))
        }

        fn poll_flush(&mut self, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }
    }

    fn send(e: &mut EchoCancel<Script>, frame: &[u8]) {
        let mut cx = Context::from_waker(Waker::noop());
        assert!(matches!(e.poll_write(&mut cx, frame), Poll::Ready(Ok(_))));
        assert!(matches!(e.poll_flush(&mut cx), Poll::Ready(Ok(()))));
    }

    /// What a read hands on: (byte, flagged as a collision).
    fn read(e: &mut EchoCancel<Script>, arriving: &[u8]) -> Vec<(u8, bool)> {
        e.get_mut().rx.extend(arriving);
        let mut cx = Context::from_waker(Waker::noop());
        let mut buf = [ReceivedChar::new(0, TokioInstant::now()); 64];
        match e.poll_read_chars(&mut cx, &mut buf) {
            Poll::Ready(Ok(n)) => buf[..n]
                .iter()
                .map(|c| (c.byte, c.error == Some(CharError::Collision)))
                .collect(),
            Poll::Ready(Err(err)) => panic!("{err}"),
            Poll::Pending => Vec::new(),
        }
    }

    fn clean(bytes: &[u8]) -> Vec<(u8, bool)> {
        bytes.iter().map(|&b| (b, false)).collect()
    }

    /// Modbus FC 6 to address 1, register 0x0010 = 0x0003 (CRC included): its answer is the
    /// same eight bytes.
    const FC6: [u8; 8] = [0x01, 0x06, 0x00, 0x10, 0x00, 0x03, 0xC8, 0x0E];

    #[tokio::test]
    async fn the_echo_is_taken_out_and_an_identical_answer_after_it_is_heard() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        assert_eq!(e.get_ref().written, FC6);
        // The echo alone: nothing for the master (a silent bus is a timeout, not an answer).
        assert_eq!(read(&mut e, &FC6), []);
        // The drive's answer, identical to the request, comes after it.
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        // Echo and answer in one read.
        send(&mut e, &FC6);
        let both: Vec<u8> = FC6.iter().chain(&FC6).copied().collect();
        assert_eq!(read(&mut e, &both), clean(&FC6));
        assert_eq!(
            e.stats(),
            EchoStats {
                echoed: 16,
                ..EchoStats::default()
            }
        );
    }

    #[tokio::test]
    async fn an_echo_that_differs_is_a_collision_and_the_rest_of_it_is_flagged() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        let mut garbled = FC6;
        garbled[3] = 0x11;
        let got = read(&mut e, &garbled);
        // The first three matched and were taken out; from the fourth on, all flagged.
        assert_eq!(got.len(), 5);
        assert!(got.iter().all(|&(_, flagged)| flagged), "{got:?}");
        assert_eq!(e.stats().collisions, 1);
        assert_eq!(e.stats().missing, 0);
        // The next answer is clean again.
        assert_eq!(
            read(&mut e, &[0x01, 0x83, 0x02]),
            clean(&[0x01, 0x83, 0x02])
        );
    }

    #[tokio::test]
    async fn what_comes_before_the_echo_is_flagged_and_the_echo_behind_it_is_still_taken_out() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        // A stray byte (another station, a late answer) before the echo: flagged, and the
        // FC 6 echo behind it never reaches the master as an answer.
        let arriving: Vec<u8> = [0x55].iter().chain(&FC6).copied().collect();
        assert_eq!(read(&mut e, &arriving), [(0x55, true)]);
        assert_eq!(e.stats().foreign, 1);
        // A station's whole frame where the echo should be: every character flagged.
        send(&mut e, &FC6);
        let got = read(&mut e, &[0x02, 0x83, 0x02, 0xC0, 0xF1]);
        assert!(got.iter().all(|&(_, flagged)| flagged), "{got:?}");
        // The echo comes after all and is taken out.
        assert_eq!(read(&mut e, &FC6), []);
        // One that starts like the echo and then differs is a collision: all of it flagged.
        send(&mut e, &FC6);
        let got = read(&mut e, &[0x01, 0x83, 0x02, 0xC0, 0xF1]);
        assert_eq!(got.len(), 4);
        assert!(got.iter().all(|&(_, flagged)| flagged), "{got:?}");
        assert_eq!(e.stats().collisions, 1);
    }

    #[tokio::test(start_paused = true)]
    async fn echoes_come_in_order_and_one_that_never_begins_is_given_up_at_a_later_frame() {
        let mut e = EchoCancel::new(Script::default(), true);
        let mut cx = Context::from_waker(Waker::noop());
        // A frame written in parts is one echo.
        let _ = e.poll_write(&mut cx, &FC6[..3]);
        let _ = e.poll_write(&mut cx, &FC6[3..]);
        let _ = e.poll_flush(&mut cx);
        assert_eq!(read(&mut e, &FC6), []);
        // A broadcast, then a request before the broadcast's echo was read (a USB adapter's
        // latency): both echoes come, in order, and both are taken out.
        let read1 = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A];
        let broadcast = [0x00, 0x06, 0x00, 0x10, 0x00, 0x03, 0xC9, 0xDF];
        send(&mut e, &broadcast);
        send(&mut e, &read1);
        let both: Vec<u8> = broadcast.iter().chain(&read1).copied().collect();
        assert_eq!(read(&mut e, &both), []);
        // An echo that has not begun ECHO_START after its frame is given up by the next frame
        // (an adapter that does not echo): that frame's echo is then taken out.
        send(&mut e, &read1);
        tokio::time::advance(ECHO_START).await;
        send(&mut e, &FC6);
        assert_eq!(read(&mut e, &FC6), []);
        assert_eq!(e.stats().missing, 8);
        assert_eq!(e.stats().echoed, 32);
        // Within ECHO_START it is kept: a late echo is still taken out.
        send(&mut e, &read1);
        tokio::time::advance(ECHO_START / 2).await;
        send(&mut e, &FC6);
        let both: Vec<u8> = read1.iter().chain(&FC6).copied().collect();
        assert_eq!(read(&mut e, &both), []);
        assert_eq!(e.stats().missing, 8);
    }

    #[tokio::test]
    async fn with_echo_off_everything_passes() {
        let mut e = EchoCancel::new(Script::default(), false);
        send(&mut e, &FC6);
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        assert_eq!(e.stats(), EchoStats::default());
    }

    fn watch(e: &EchoCancel<Script>) -> EchoWatch {
        e.echo_watch().expect("watched with the echo off")
    }

    /// Issue 22, item 5: with the echo off the watch hands everything on unchanged and learns
    /// whether the adapter echoes: something else first, or nothing within [`ECHO_START`],
    /// shows it does not; an exact copy is the echo or an answer that repeats the request.
    #[tokio::test(start_paused = true)]
    async fn with_the_echo_off_the_watch_tells_an_adapter_that_does_not_echo() {
        // An answer that differs from the request comes first: no echo.
        let mut e = EchoCancel::new(Script::default(), false);
        assert_eq!(watch(&e).belief, EchoBelief::Unknown);
        send(&mut e, &FC6);
        let answer = [0x01, 0x86, 0x02, 0xC3, 0xA1];
        assert_eq!(read(&mut e, &answer), clean(&answer), "handed on unchanged");
        assert_eq!(
            watch(&e),
            EchoWatch {
                belief: EchoBelief::Silent,
                last: Replay::Differed
            }
        );
        // From now on an exact copy is an answer: taken.
        send(&mut e, &FC6);
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        assert_eq!(watch(&e).last, Replay::Exact);
        assert_eq!(after_exchange(&mut e, true), EchoCheck::Fine);

        // Nothing within ECHO_START: no echo (one would have begun by then).
        let mut e = EchoCancel::new(Script::default(), false);
        send(&mut e, &FC6);
        assert_eq!(watch(&e).last, Replay::Pending);
        tokio::time::advance(ECHO_START).await;
        assert_eq!(watch(&e).belief, EchoBelief::Silent);
        // A copy that comes that late is an answer, not an echo: the belief stays.
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        assert_eq!(
            watch(&e),
            EchoWatch {
                belief: EchoBelief::Silent,
                last: Replay::Nothing
            }
        );
        assert_eq!(after_exchange(&mut e, true), EchoCheck::Fine);
        assert!(!echoes(&e));
    }

    #[tokio::test(start_paused = true)]
    async fn with_the_echo_off_an_exact_copy_is_an_echo_when_the_answer_cannot_repeat_the_request()
    {
        // FC 3 read: its answer never repeats it, so a copy of it is the echo.
        const FC3: [u8; 8] = [0x01, 0x03, 0x01, 0x74, 0x00, 0x01, 0xC5, 0xE8];
        let mut e = EchoCancel::new(Script::default(), false);
        send(&mut e, &FC3);
        assert_eq!(read(&mut e, &FC3), clean(&FC3));
        assert_eq!(
            watch(&e),
            EchoWatch {
                belief: EchoBelief::Unknown,
                last: Replay::Exact
            }
        );
        assert_eq!(after_exchange(&mut e, false), EchoCheck::Echoes);
        assert!(echoes(&e), "the driver told the line");
        // Every later answer is refused, also one that differs (the echo comes first).
        send(&mut e, &FC6);
        assert_eq!(after_exchange(&mut e, true), EchoCheck::Echoes);

        // FC 6: one copy is the echo or the answer (ambiguous until the line is known); two
        // copies in a row are the echo and the answer.
        let mut e = EchoCancel::new(Script::default(), false);
        send(&mut e, &FC6);
        read(&mut e, &FC6);
        assert_eq!(after_exchange(&mut e, true), EchoCheck::Ambiguous);
        send(&mut e, &FC6);
        let both: Vec<u8> = FC6.iter().chain(&FC6).copied().collect();
        assert_eq!(read(&mut e, &both), clean(&both), "handed on unchanged");
        assert_eq!(watch(&e).belief, EchoBelief::Echoes);
        assert_eq!(after_exchange(&mut e, true), EchoCheck::Echoes);
        // A stray byte later never makes it silent again.
        send(&mut e, &FC3);
        read(&mut e, &[0x55]);
        assert_eq!(watch(&e).belief, EchoBelief::Echoes);

        // With the echo taken out there is nothing to watch.
        let e = EchoCancel::new(Script::default(), true);
        assert_eq!(e.echo_watch(), None);
    }
}
