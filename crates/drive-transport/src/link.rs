//! An in-memory, full-duplex serial line with a wire-time model and fault injection.
//!
//! [`pair`] returns two [`LinkEnd`]s. Each implements tokio's [`AsyncRead`] and [`AsyncWrite`];
//! bytes written to one end are read from the other. Protocol drivers and simulated drives are
//! tested over such a link instead of hardware.
//!
//! # Wire-time model
//!
//! With [`LinkConfig::timing`] on, every character occupies the line for
//! `bits_per_char / baud` seconds ([`LinkConfig::char_time`]). Characters of one direction are
//! serialised back to back: a character written while the line is busy starts when the previous
//! one ends, one written to an idle line starts at once, and it is *delivered* (readable by the
//! peer) when its last bit has arrived, i.e. at start + char time. An 18-byte telegram at
//! 9600 baud 8E1 thus arrives completely 18 × 11 / 9600 s = 20.625 ms after it was written.
//! The two directions are independent (full duplex).
//!
//! Time is tokio's clock ([`tokio::time::Instant`]), so tests run on the paused clock
//! (`#[tokio::test(start_paused = true)]`). Each character's exact arrival instant is
//! available through [`LinkEnd::read_timed`]; a reader waiting for data wakes through a tokio
//! timer, and tokio timers have a resolution of 1 ms, so a blocked reader is woken at the first
//! millisecond tick at or after the arrival and then receives every character that has arrived
//! by then. Readers therefore see characters arrive progressively, and can measure gaps exactly
//! from the timestamps.
//!
//! With timing off, characters are delivered immediately (benchmark mode: only software
//! overhead is measured); injected delays still apply.
//!
//! A frame can be written with the instant the protocol scheduled it to start
//! ([`CharIo::poll_write_at`], which [`drive_core::rt::Port`] and [`drive_core::rt::serve`] use
//! after a timer wake-up): its first character starts at that instant instead of now, but
//! never before the line is free (the end of the characters already written in that
//! direction, so the order of characters is kept) and never more than
//! [`drive_core::rt::TIMER_RESOLUTION`] (1 ms) in the past. The timer that
//! woke the writer ends on tokio's next millisecond tick, after the instant the protocol asked
//! for; this puts the frame on the wire where the protocol put it, not at the late wake-up. A
//! start further in the past counts from now minus that resolution. A reader that looked at
//! the line during that last millisecond may have seen it silent at a time a backdated
//! character now occupies: the model's resolution for such a race stays the timer's.
//!
//! [`AsyncWrite::poll_flush`] waits until every character written so far has left the line
//! (like `tcdrain`). Writes are accepted at once while fewer than [`LinkConfig::capacity`]
//! characters are in flight or unread in that direction, and wait otherwise.
//!
//! # Characters and parity
//!
//! The line carries 8-bit characters with their parity bit. [`LinkEnd::read_chars`] returns
//! [`WireChar`]s with a `parity_ok` flag the way a UART reports errors; plain
//! [`AsyncRead`] returns the bytes of all characters, flagged or not (nothing is dropped).
//!
//! # Fault model
//!
//! Faults act on characters in the direction in which they are transmitted, either at random
//! ([`FaultConfig`], per-character probabilities, deterministic for a given seed) or one-shot
//! ([`LinkEnd::inject`]). Per character, independently:
//!
//! - **delay**: the line stays idle for [`FaultConfig::delay_by`] (or the duration of
//!   [`Fault::Delay`]) before the character starts; everything after it shifts too, order is
//!   kept. This models a pause of the transmitter, i.e. an inter-character gap.
//! - **drop**: the character occupies the line for its wire time but is not delivered (the
//!   receiver missed it).
//! - **flip**: bits of the character's frame are inverted in transit. The frame has
//!   `max(bits_per_char, 10 + parity bits)` bits, numbered in wire order: bit 0 is the start
//!   bit, bits 1–8 the data bits (LSB first; frame bit `i` is data bit `i - 1`), bit 9 the parity
//!   bit when the link has parity, the remaining bits are stop bits. A random flip inverts
//!   [`FaultConfig::flip_bits`] distinct positions chosen uniformly over the whole frame;
//!   [`Fault::Flip`] inverts the positions set in its mask. The receiver then sees:
//!   the byte with every flipped data bit inverted; `parity_ok == false` when the number of
//!   flipped data + parity bits is odd (so a flipped parity bit alone fails parity, two flipped
//!   data bits pass it unnoticed); and `parity_ok == false` when the start bit or a stop bit was
//!   flipped, because a UART reports that framing error on the character (Linux reports parity
//!   and framing errors alike). Without parity, data flips go undetected.
//! - **insert**: after the character, an extra character (a random byte, or the byte of
//!   [`Fault::Insert`]) with correct parity is transmitted, taking its own wire time: noise
//!   that the receiver takes for a character.
//!
//! A dropped character is not also flipped. [`FaultStats`] counts what was injected.
//!
//! # An echoing adapter
//!
//! With [`LinkConfig::echo`] the first end of the [`pair`] hears its own characters, as a master
//! on a two-wire RS-485 adapter whose receiver stays on while it sends: each character it
//! writes also arrives at its own receiver, at the instant the other end gets it. What happens
//! on the wire happens to both copies (a flip, an inserted character); a drop is the far
//! receiver's alone, so the echo keeps the character. The echo is queued with what the other
//! end sends, in order of arrival.
//!
//! The random draws come from drivebus's one seeded generator, [`drive_core::SplitMix64`]; the
//! two directions of a link use independent streams derived from the seed.
//!
//! [`LinkEnd`] is also a [`drive_core::rt::CharIo`]: protocol drivers and simulated
//! devices read its characters with their exact arrival times and parity flags.

use std::collections::VecDeque;
use std::future::{Future as _, poll_fn};
use std::io;
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{Instant, Sleep};

use drive_core::line::{LineSettings, Parity};
use drive_core::rt::{CharIo, ReceivedChar, TIMER_RESOLUTION, WireTime};
use drive_core::{CharError, SplitMix64};

/// One character as a UART receives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct WireChar {
    /// The received data bits.
    pub byte: u8,
    /// `false` when the UART flagged the character: a parity error (odd number of flipped
    /// data + parity bits) or a framing error (flipped start or stop bit).
    pub parity_ok: bool,
}

impl WireChar {
    /// A character received without error.
    pub const fn new(byte: u8) -> Self {
        WireChar {
            byte,
            parity_ok: true,
        }
    }
}

/// A received character with the instant its last bit arrived.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TimedChar {
    /// The character.
    pub ch: WireChar,
    /// When it arrived: with timing on, the exact modelled arrival (start of transmission +
    /// char time); with timing off, when it was read (or, if delayed, when the delay ended).
    pub at: Instant,
}

/// Random fault injection, per character and per direction.
///
/// Probabilities are in `0.0..=1.0`; values outside are clamped by effect (≤ 0 never,
/// ≥ 1 always).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultConfig {
    /// Seed of the deterministic random generator.
    pub seed: u64,
    /// Probability that a character is lost.
    pub drop: f64,
    /// Probability that a random extra character follows a character.
    pub insert: f64,
    /// Probability that bits of a character's frame are flipped.
    pub flip: f64,
    /// How many distinct frame bits a random flip inverts (at least 1, at most the frame size).
    pub flip_bits: u32,
    /// Probability that the line idles for [`delay_by`](FaultConfig::delay_by) before a
    /// character.
    pub delay: f64,
    /// Length of an injected idle gap.
    pub delay_by: Duration,
}

impl FaultConfig {
    /// No random faults.
    pub const fn none() -> Self {
        FaultConfig {
            seed: 0x5EED_D121_7EB0_5000,
            drop: 0.0,
            insert: 0.0,
            flip: 0.0,
            flip_bits: 1,
            delay: 0.0,
            delay_by: Duration::from_millis(5),
        }
    }

    /// Every fault type (drop, insert, flip of one bit, delay by 5 ms) with probability `p`.
    pub const fn uniform(seed: u64, p: f64) -> Self {
        FaultConfig {
            seed,
            drop: p,
            insert: p,
            flip: p,
            delay: p,
            ..FaultConfig::none()
        }
    }

    /// Whether any random fault can happen.
    pub fn is_active(&self) -> bool {
        self.drop > 0.0 || self.insert > 0.0 || self.flip > 0.0 || self.delay > 0.0
    }
}

impl Default for FaultConfig {
    fn default() -> Self {
        FaultConfig::none()
    }
}

/// A one-shot fault for the next character written (see [`LinkEnd::inject`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Fault {
    /// The character is lost (it still takes its wire time).
    Drop,
    /// This byte, with correct parity, is transmitted right after the character.
    Insert(u8),
    /// Invert the frame bits set in the mask: bit 0 start bit, bits 1–8 data bits (LSB first),
    /// bit 9 parity bit (with parity), higher bits stop bits. `Flip(1 << 9)` makes a parity
    /// error, `Flip(1 << 1)` inverts the byte's LSB and fails parity.
    Flip(u16),
    /// The line idles this long before the character.
    Delay(Duration),
}

/// Counters of the faults injected in one direction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct FaultStats {
    /// Characters written by the application (inserted ones not counted).
    pub written: u64,
    /// Characters dropped.
    pub dropped: u64,
    /// Extra characters inserted.
    pub inserted: u64,
    /// Characters whose frame had bits flipped.
    pub flipped: u64,
    /// Idle gaps inserted before characters.
    pub delayed: u64,
    /// Characters sent with `parity_ok == false` (a subset of the flipped ones).
    pub flagged: u64,
}

/// Configuration of an in-memory link (both directions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkConfig {
    /// Baud rate, data bits, parity and stop bits: the character time and the parity flag of
    /// [`WireChar`].
    pub line: LineSettings,
    /// Model wire time (`true`) or deliver immediately (`false`).
    pub timing: bool,
    /// Random faults, applied to both directions with independent random streams.
    pub faults: FaultConfig,
    /// Characters that may be in flight or unread per direction before writes wait.
    pub capacity: usize,
    /// The first end of the pair hears what it writes (see [An echoing
    /// adapter](self#an-echoing-adapter)).
    pub echo: bool,
}

impl Default for LinkConfig {
    /// 9600 baud, 8E1 (11 bits per character), timing on, no faults, capacity 4096.
    fn default() -> Self {
        LinkConfig::from_line(LineSettings::new(9600))
    }
}

impl LinkConfig {
    /// 8E1 at `baud` with timing on and no faults.
    pub fn new(baud: u32) -> Self {
        LinkConfig::from_line(LineSettings::new(baud))
    }

    /// A line with `line`'s settings, timing on, no faults.
    pub fn from_line(line: LineSettings) -> Self {
        LinkConfig {
            line,
            timing: true,
            faults: FaultConfig::none(),
            capacity: 4096,
            echo: false,
        }
    }

    /// Timing off: characters are delivered immediately (benchmarks).
    pub fn untimed() -> Self {
        LinkConfig {
            timing: false,
            ..LinkConfig::default()
        }
    }

    /// The same configuration with these random faults.
    pub fn with_faults(self, faults: FaultConfig) -> Self {
        LinkConfig { faults, ..self }
    }

    /// The same configuration with the first end's echo on ([`LinkConfig::echo`]).
    pub fn with_echo(self) -> Self {
        LinkConfig { echo: true, ..self }
    }

    /// Wire time of one character, whether or not timing is on.
    pub fn char_time(&self) -> Duration {
        self.line.char_time()
    }

    fn frame_len(&self) -> u32 {
        self.line
            .bits_per_char()
            .max(10 + self.line.parity.bits())
            .min(16)
    }
}

/// Creates a connected pair of link ends.
///
/// With timing on (or with delay faults), the ends must be used within a tokio runtime with
/// the time driver enabled.
pub fn pair(config: LinkConfig) -> (LinkEnd, LinkEnd) {
    let mut a_to_b = Pipe::new(&config, config.faults.seed);
    a_to_b.echo = config.echo.then(Vec::new);
    let a_to_b = Arc::new(Mutex::new(a_to_b));
    let b_to_a = Arc::new(Mutex::new(Pipe::new(
        &config,
        config.faults.seed ^ 0xD1B5_4A32_D192_ED03,
    )));
    let a = LinkEnd::new(a_to_b.clone(), b_to_a.clone());
    let b = LinkEnd::new(b_to_a, a_to_b);
    (a, b)
}

#[derive(Debug, Clone, Copy)]
struct Slot {
    ch: WireChar,
    /// Arrival instant; `None` means "available immediately" (timing off, no delay pending).
    at: Option<Instant>,
}

/// What happens to one character.
#[derive(Debug, Default)]
struct CharFaults {
    gap: Duration,
    drop: bool,
    flip_mask: u16,
    insert: Option<u8>,
}

/// One direction of the link.
#[derive(Debug)]
struct Pipe {
    queue: VecDeque<Slot>,
    busy_until: Option<Instant>,
    char_time: Duration,
    timing: bool,
    parity: Parity,
    frame_len: u32,
    capacity: usize,
    faults: FaultConfig,
    faults_active: bool,
    rng: SplitMix64,
    pending: VecDeque<Fault>,
    stats: FaultStats,
    rx_waker: Option<Waker>,
    tx_waker: Option<Waker>,
    tx_closed: bool,
    rx_closed: bool,
    /// With the writer's echo on: the characters it will hear, gathered by `transmit` until
    /// the write moves them to its own receiving direction.
    echo: Option<Vec<Slot>>,
}

impl Pipe {
    fn new(config: &LinkConfig, seed: u64) -> Self {
        Pipe {
            queue: VecDeque::new(),
            busy_until: None,
            char_time: if config.timing {
                config.char_time()
            } else {
                Duration::ZERO
            },
            timing: config.timing,
            parity: config.line.parity,
            frame_len: config.frame_len(),
            capacity: config.capacity.max(1),
            faults: config.faults,
            faults_active: config.faults.is_active(),
            rng: SplitMix64::new(seed),
            pending: VecDeque::new(),
            stats: FaultStats::default(),
            rx_waker: None,
            tx_waker: None,
            tx_closed: false,
            rx_closed: false,
            echo: None,
        }
    }

    /// Reserves the line for one character after an idle `gap`, starting no earlier than
    /// `start` (an intended start at most [`TIMER_RESOLUTION`] in the past; `None`: now) and
    /// the end of the previous character; returns its arrival instant (`None` = immediately
    /// available).
    fn schedule(
        &mut self,
        gap: Duration,
        now: &mut Option<Instant>,
        start: Option<Instant>,
    ) -> Option<Instant> {
        if !self.timing && gap.is_zero() {
            match self.busy_until {
                None => return None,
                Some(busy) => {
                    if busy <= *now.get_or_insert_with(Instant::now) {
                        self.busy_until = None;
                        return None;
                    }
                }
            }
        }
        let now = *now.get_or_insert_with(Instant::now);
        let earliest = start.map_or(now, |start| {
            let limit = now.checked_sub(TIMER_RESOLUTION).unwrap_or(now);
            start.max(limit).min(now)
        });
        let start = self.busy_until.map_or(earliest, |busy| busy.max(earliest)) + gap;
        let end = start + self.char_time;
        self.busy_until = Some(end);
        Some(end)
    }

    fn draw_faults(&mut self) -> CharFaults {
        let mut f = CharFaults::default();
        if let Some(fault) = self.pending.pop_front() {
            match fault {
                Fault::Drop => f.drop = true,
                Fault::Insert(byte) => f.insert = Some(byte),
                Fault::Flip(mask) => f.flip_mask = mask & frame_mask(self.frame_len),
                Fault::Delay(gap) => f.gap = gap,
            }
            return f;
        }
        if !self.faults_active {
            return f;
        }
        let cfg = self.faults;
        if self.rng.chance(cfg.delay) {
            f.gap = cfg.delay_by;
        }
        f.drop = self.rng.chance(cfg.drop);
        if self.rng.chance(cfg.flip) && !f.drop {
            let k = cfg.flip_bits.clamp(1, self.frame_len);
            while f.flip_mask.count_ones() < k {
                f.flip_mask |= 1 << self.rng.below(u64::from(self.frame_len));
            }
        }
        if self.rng.chance(cfg.insert) {
            f.insert = Some(self.rng.next_u64() as u8);
        }
        f
    }

    /// Puts one application byte on the line, with its faults, no earlier than `start`.
    fn transmit(&mut self, byte: u8, now: &mut Option<Instant>, start: Option<Instant>) {
        self.stats.written += 1;
        let f = self.draw_faults();
        if !f.gap.is_zero() {
            self.stats.delayed += 1;
        }
        let at = self.schedule(f.gap, now, start);
        let ch = apply_flip(byte, f.flip_mask, self.parity, self.frame_len);
        if let Some(echo) = &mut self.echo {
            // The drop is the far receiver's: the echo hears the character as the wire has it.
            let ch = if f.drop { WireChar::new(byte) } else { ch };
            echo.push(Slot { ch, at });
        }
        if f.drop {
            self.stats.dropped += 1;
        } else {
            if f.flip_mask != 0 {
                self.stats.flipped += 1;
                if !ch.parity_ok {
                    self.stats.flagged += 1;
                }
            }
            self.queue.push_back(Slot { ch, at });
        }
        if let Some(extra) = f.insert {
            self.stats.inserted += 1;
            let at = self.schedule(Duration::ZERO, now, start);
            let slot = Slot {
                ch: WireChar::new(extra),
                at,
            };
            self.queue.push_back(slot);
            if let Some(echo) = &mut self.echo {
                echo.push(slot);
            }
        }
    }
}

fn frame_mask(frame_len: u32) -> u16 {
    if frame_len >= 16 {
        u16::MAX
    } else {
        (1u16 << frame_len) - 1
    }
}

/// Receives a character whose frame bits in `mask` were inverted (see the module docs).
fn apply_flip(byte: u8, mask: u16, parity: Parity, frame_len: u32) -> WireChar {
    if mask == 0 {
        return WireChar::new(byte);
    }
    let data_flips = ((mask >> 1) & 0xFF) as u8;
    let received = byte ^ data_flips;
    let parity_flipped = parity != Parity::None && mask & (1 << 9) != 0;
    let parity_ok =
        data_flips.count_ones() % 2 == u32::from(parity_flipped) % 2 || parity == Parity::None;
    let stop_from = 9 + parity.bits();
    let stop_mask = frame_mask(frame_len) & !frame_mask(stop_from);
    let framing_ok = mask & 1 == 0 && mask & stop_mask == 0;
    WireChar {
        byte: received,
        parity_ok: parity_ok && framing_ok,
    }
}

fn lock(pipe: &Mutex<Pipe>) -> MutexGuard<'_, Pipe> {
    // A panic while holding the lock cannot leave a `Pipe` inconsistent in a way that matters
    // more than losing the link, so recover the guard instead of propagating the poison.
    pipe.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// One end of an in-memory link: reads what the other end writes and vice versa.
///
/// Dropping an end makes the other end read end of file (after the characters still on the
/// line) and makes its writes fail with [`io::ErrorKind::BrokenPipe`].
#[derive(Debug)]
pub struct LinkEnd {
    tx: Arc<Mutex<Pipe>>,
    rx: Arc<Mutex<Pipe>>,
    read_sleep: Option<Pin<Box<Sleep>>>,
    flush_sleep: Option<Pin<Box<Sleep>>>,
}

impl LinkEnd {
    fn new(tx: Arc<Mutex<Pipe>>, rx: Arc<Mutex<Pipe>>) -> Self {
        LinkEnd {
            tx,
            rx,
            read_sleep: None,
            flush_sleep: None,
        }
    }

    /// Queues a one-shot fault for the characters this end writes next: the first queued
    /// fault applies to the next character, the second to the one after, and so on. A
    /// character with a one-shot fault gets no random fault.
    pub fn inject(&self, fault: Fault) {
        lock(&self.tx).pending.push_back(fault);
    }

    /// Replaces the random faults of the direction this end writes to; the random stream
    /// continues (it is not reseeded).
    pub fn set_faults(&self, faults: FaultConfig) {
        let mut tx = lock(&self.tx);
        tx.faults = faults;
        tx.faults_active = faults.is_active();
    }

    /// Faults injected into characters written by this end.
    pub fn fault_stats(&self) -> FaultStats {
        lock(&self.tx).stats
    }

    /// Faults injected into characters written by the other end (received by this one).
    pub fn rx_fault_stats(&self) -> FaultStats {
        lock(&self.rx).stats
    }

    /// Polls for received characters with their parity flags; like
    /// [`AsyncRead::poll_read`], `Ready(Ok(0))` means end of file (for a non-empty `buf`).
    pub fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [WireChar],
    ) -> Poll<io::Result<usize>> {
        let max = buf.len();
        let mut out = buf.iter_mut();
        self.poll_deliver(cx, max, |slot| {
            if let Some(dst) = out.next() {
                *dst = slot.ch;
            }
        })
    }

    /// Reads received characters with their parity flags; `Ok(0)` means end of file.
    pub async fn read_chars(&mut self, buf: &mut [WireChar]) -> io::Result<usize> {
        poll_fn(|cx| self.poll_read_chars(cx, buf)).await
    }

    /// Polls for received characters with their arrival instants.
    pub fn poll_read_timed(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [TimedChar],
    ) -> Poll<io::Result<usize>> {
        let max = buf.len();
        let mut out = buf.iter_mut();
        let mut now = None;
        self.poll_deliver(cx, max, |slot| {
            let at = slot
                .at
                .unwrap_or_else(|| *now.get_or_insert_with(Instant::now));
            if let Some(dst) = out.next() {
                *dst = TimedChar { ch: slot.ch, at };
            }
        })
    }

    /// Reads received characters with their arrival instants; `Ok(0)` means end of file.
    pub async fn read_timed(&mut self, buf: &mut [TimedChar]) -> io::Result<usize> {
        poll_fn(|cx| self.poll_read_timed(cx, buf)).await
    }

    /// Delivers up to `max` arrived characters to `sink`.
    fn poll_deliver(
        &mut self,
        cx: &mut Context<'_>,
        max: usize,
        mut sink: impl FnMut(Slot),
    ) -> Poll<io::Result<usize>> {
        if max == 0 {
            return Poll::Ready(Ok(0));
        }
        loop {
            let mut rx = lock(&self.rx);
            let mut now = None;
            let mut n = 0;
            let mut wait_until = None;
            while n < max {
                let Some(front) = rx.queue.front().copied() else {
                    break;
                };
                if let Some(at) = front.at
                    && at > *now.get_or_insert_with(Instant::now)
                {
                    wait_until = Some(at);
                    break;
                }
                rx.queue.pop_front();
                sink(front);
                n += 1;
            }
            if n > 0 {
                let waker = rx.tx_waker.take();
                drop(rx);
                if let Some(waker) = waker {
                    waker.wake();
                }
                return Poll::Ready(Ok(n));
            }
            let Some(deadline) = wait_until else {
                if rx.tx_closed {
                    return Poll::Ready(Ok(0));
                }
                rx.rx_waker = Some(cx.waker().clone());
                return Poll::Pending;
            };
            drop(rx);
            // The earliest character arrives at `deadline`; nothing written later can arrive
            // before it, so the timer alone decides when to look again.
            if poll_sleep(&mut self.read_sleep, deadline, cx).is_pending() {
                return Poll::Pending;
            }
        }
    }
}

/// Polls a reusable timer set to `deadline` (the wire model, the virtual CAN bus and the slcan
/// port all wait this way).
pub(crate) fn poll_sleep(
    sleep: &mut Option<Pin<Box<Sleep>>>,
    deadline: Instant,
    cx: &mut Context<'_>,
) -> Poll<()> {
    let timer = match sleep {
        Some(timer) => {
            if timer.deadline() != deadline {
                timer.as_mut().reset(deadline);
            }
            timer
        }
        None => sleep.insert(Box::pin(tokio::time::sleep_until(deadline))),
    };
    timer.as_mut().poll(cx)
}

impl AsyncRead for LinkEnd {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let unfilled = buf.initialize_unfilled();
        let max = unfilled.len();
        let mut out = unfilled.iter_mut();
        match this.poll_deliver(cx, max, |slot| {
            if let Some(dst) = out.next() {
                *dst = slot.ch.byte;
            }
        }) {
            Poll::Ready(Ok(n)) => {
                buf.advance(n);
                Poll::Ready(Ok(()))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
            Poll::Pending => Poll::Pending,
        }
    }
}

impl LinkEnd {
    /// Writes what fits of `buf`, the first character no earlier than `start` (see the module
    /// docs).
    fn write_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: Option<Instant>,
    ) -> Poll<io::Result<usize>> {
        if buf.is_empty() {
            return Poll::Ready(Ok(0));
        }
        let mut tx = lock(&self.tx);
        if tx.rx_closed || tx.tx_closed {
            return Poll::Ready(Err(io::Error::new(
                io::ErrorKind::BrokenPipe,
                if tx.tx_closed {
                    "link end was shut down"
                } else {
                    "the other end of the link was dropped"
                },
            )));
        }
        let space = tx.capacity.saturating_sub(tx.queue.len());
        if space == 0 {
            tx.tx_waker = Some(cx.waker().clone());
            return Poll::Pending;
        }
        let n = space.min(buf.len());
        let mut now = None;
        for &byte in buf.iter().take(n) {
            tx.transmit(byte, &mut now, start);
        }
        let waker = tx.rx_waker.take();
        let echo = tx.echo.as_mut().map(std::mem::take);
        drop(tx);
        if let Some(waker) = waker {
            waker.wake();
        }
        if let Some(echo) = echo {
            self.hear(echo);
        }
        Poll::Ready(Ok(n))
    }

    /// Queues this end's echo in its receiving direction, each character behind those that
    /// arrive no later than it does.
    fn hear(&mut self, echo: Vec<Slot>) {
        let mut rx = lock(&self.rx);
        for slot in echo {
            let behind = match slot.at {
                None => rx.queue.len(),
                Some(at) => rx
                    .queue
                    .iter()
                    .rposition(|q| q.at.is_none_or(|q| q <= at))
                    .map_or(0, |i| i + 1),
            };
            rx.queue.insert(behind, slot);
        }
        let waker = rx.rx_waker.take();
        drop(rx);
        if let Some(waker) = waker {
            waker.wake();
        }
    }
}

impl AsyncWrite for LinkEnd {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        self.get_mut().write_chars(cx, buf, None)
    }

    /// Waits until every character written so far has left the line.
    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let busy_until = lock(&this.tx).busy_until;
        match busy_until {
            Some(until) if until > Instant::now() => {
                poll_sleep(&mut this.flush_sleep, until, cx).map(Ok)
            }
            _ => Poll::Ready(Ok(())),
        }
    }

    /// Closes the sending direction: the other end reads end of file after the characters
    /// still on the line.
    fn poll_shutdown(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let mut tx = lock(&self.tx);
        tx.tx_closed = true;
        let waker = tx.rx_waker.take();
        drop(tx);
        if let Some(waker) = waker {
            waker.wake();
        }
        Poll::Ready(Ok(()))
    }
}

impl Drop for LinkEnd {
    fn drop(&mut self) {
        let mut tx = lock(&self.tx);
        tx.tx_closed = true;
        let rx_waker = tx.rx_waker.take();
        drop(tx);
        let mut rx = lock(&self.rx);
        rx.rx_closed = true;
        let tx_waker = rx.tx_waker.take();
        drop(rx);
        for waker in [rx_waker, tx_waker].into_iter().flatten() {
            waker.wake();
        }
    }
}

/// Characters read per call into a stack buffer by the [`CharIo`] implementation.
const CHAR_CHUNK: usize = 64;

impl CharIo for LinkEnd {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        let Some(first) = buf.first() else {
            return Poll::Ready(Ok(0));
        };
        let filler = TimedChar {
            ch: WireChar::new(0),
            at: first.at,
        };
        let mut scratch = [filler; CHAR_CHUNK];
        let want = buf.len().min(CHAR_CHUNK);
        let scratch = scratch.get_mut(..want).unwrap_or(&mut []);
        let n = match self.poll_read_timed(cx, scratch) {
            Poll::Ready(Ok(n)) => n,
            other => return other,
        };
        for (dst, src) in buf.iter_mut().zip(scratch.iter().take(n)) {
            *dst = ReceivedChar {
                byte: src.ch.byte,
                at: src.at,
                // The link (like Linux) reports parity and framing errors alike.
                error: (!src.ch.parity_ok).then_some(CharError::Parity),
            };
        }
        Poll::Ready(Ok(n))
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        AsyncWrite::poll_write(Pin::new(self), cx, buf)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        AsyncWrite::poll_flush(Pin::new(self), cx)
    }

    /// The first character starts at `start` (at most 1 ms in the past), never before the
    /// line is free; see the module docs.
    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: Instant,
    ) -> Poll<io::Result<usize>> {
        self.write_chars(cx, buf, Some(start))
    }

    fn honours_write_start(&self) -> bool {
        // With wire timing off the link delivers at once: nothing to place.
        true
    }

    fn wire_time(&self) -> WireTime {
        if lock(&self.tx).timing {
            WireTime::Exact
        } else {
            // Delivered at once, timed when read.
            WireTime::None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flip_model() {
        let even = Parity::Even;
        // No flip.
        assert_eq!(apply_flip(0x55, 0, even, 11), WireChar::new(0x55));
        // One data bit: byte changes, parity fails.
        let ch = apply_flip(0x00, 1 << 1, even, 11);
        assert_eq!((ch.byte, ch.parity_ok), (0x01, false));
        // Two data bits: byte changes, parity passes.
        let ch = apply_flip(0x00, 0b110, even, 11);
        assert_eq!((ch.byte, ch.parity_ok), (0x03, true));
        // Parity bit alone: byte unchanged, parity fails.
        let ch = apply_flip(0xA5, 1 << 9, even, 11);
        assert_eq!((ch.byte, ch.parity_ok), (0xA5, false));
        // One data bit plus parity bit: even count, passes.
        let ch = apply_flip(0x80, (1 << 8) | (1 << 9), even, 11);
        assert_eq!((ch.byte, ch.parity_ok), (0x00, true));
        // Start bit / stop bit: framing error, byte unchanged.
        assert!(!apply_flip(0x12, 1, even, 11).parity_ok);
        assert!(!apply_flip(0x12, 1 << 10, even, 11).parity_ok);
        // Without parity, data flips go unnoticed; bit 9 is the stop bit.
        assert!(apply_flip(0x12, 1 << 1, Parity::None, 10).parity_ok);
        assert!(!apply_flip(0x12, 1 << 9, Parity::None, 10).parity_ok);
    }
}
