//! The character receiver every protocol shares, behind a small framing description.
//!
//! A serial protocol cuts a stream of characters into frames with a few rules, and only the
//! details differ:
//!
//! | protocol | a frame starts | its end is known by | inside a frame | the end is confirmed by |
//! |---|---|---|---|---|
//! | MOVILINK | SD1/SD2 after a start pause (3 characters) | its PDU type (byte 3) | a gap < start pause | a start pause of silence |
//! | Modbus RTU | any byte after 3.5 characters of silence | silence (> 1.5 characters) | a gap ≤ 1.5 characters | 3.5 characters of silence |
//! | Modbus ASCII | `:` at any time (also inside a frame) | CR LF | up to 1 s between characters | nothing |
//! | USS | STX after 2 characters of silence | LGE (byte 2) | a limited gap | nothing or a short silence |
//!
//! A [`Framing`] describes one of them: which byte may start a frame ([`Framing::start`]), when
//! the bytes so far form a complete frame or can no longer become one
//! ([`Framing::progress`]), how a complete frame is checked and decoded
//! ([`Framing::decode`]), and the times ([`FrameTiming`]). The [`Receiver`] does everything
//! else, the same way for all of them:
//!
//! * a frame starts only after the line was idle for [`FrameTiming::start_gap`] (the first
//!   character after [`Receiver::reset`] needs no gap);
//! * a gap of [`FrameTiming::max_gap`] or more inside a frame breaks it off
//!   ([`LineError::InterCharacterGap`]) — unless the framing ends frames by silence
//!   ([`FrameTiming::ends_by_silence`], Modbus RTU), where that gap *ends* the frame;
//! * a complete frame is accepted only once the line stayed quiet for
//!   [`FrameTiming::end_silence`] after its last character; a character that completes within
//!   that time rejects it ([`LineError::TrailingCharacter`]: the frame on the wire was longer
//!   than it said, which is how an inserted character is caught). This is a UART's idle timer
//!   restarted by every character: a character whose start bit falls into the last character
//!   time of the silence completes after the confirmation and counts as coming after the frame,
//!   whether or not the caller polled the timeout before handing it over. With a zero end
//!   silence a complete frame is accepted at once;
//! * a UART error flag on any character of a frame rejects the frame;
//! * after a rejection the receiver ignores characters until the next idle gap, then
//!   resynchronises on the next start character.
//!
//! Confirmation by silence is reported by [`Receiver::handle_timeout`] at the time of
//! [`Receiver::poll_timeout`]; a caller that misses it gets the frame with the next character.
//! Each call returns at most one event; where one character has two (it ends a frame and is
//! itself rejected as the next one's start), the second waits and [`Receiver::poll_timeout`]
//! is due at once.
//!
//! Gaps: a character's time is the end of its stop bit, so the idle gap before a character is
//! its time minus the previous character's time minus one character time.
//!
//! Memory is one `N`-byte buffer; nothing allocates and no input makes the receiver panic.
//!
//! ```
//! use core::time::Duration;
//! use drive_core::framing::{Framing, FrameTiming, LineError, Progress, Receiver, RxEvent, Start};
//! use drive_core::{Instant, RxChar};
//!
//! /// A toy framing: `0xAA`, a length byte n, n data bytes; the frame is the data's sum.
//! struct Toy;
//! impl Framing for Toy {
//!     type Frame = u8;
//!     type Error = LineError;
//!     fn timing(&self) -> FrameTiming {
//!         FrameTiming::uniform(Duration::from_micros(100), Duration::from_micros(300))
//!     }
//!     fn start(&self, byte: u8) -> Start<LineError> {
//!         if byte == 0xAA { Start::Begin } else { Start::Ignore }
//!     }
//!     fn progress(&self, frame: &[u8]) -> Progress<LineError> {
//!         match frame.get(1) {
//!             Some(&n) if frame.len() == usize::from(n) + 2 => Progress::Complete,
//!             _ => Progress::More,
//!         }
//!     }
//!     fn decode(&self, frame: &[u8]) -> Result<u8, LineError> {
//!         Ok(frame.iter().skip(2).fold(0u8, |a, b| a.wrapping_add(*b)))
//!     }
//! }
//!
//! let mut rx: Receiver<Toy, 16> = Receiver::new(Toy);
//! for (i, b) in [0xAA, 2, 5, 6].into_iter().enumerate() {
//!     assert_eq!(rx.handle_char(RxChar::new(b, Instant::from_micros(100 * (i as u64 + 1)))), None);
//! }
//! let confirm = rx.poll_timeout().unwrap(); // 300 µs of silence after the last character
//! assert_eq!(confirm, Instant::from_micros(700));
//! assert_eq!(rx.handle_timeout(confirm), Some(RxEvent::Frame(11)));
//! ```

use core::time::Duration;

use crate::char::{CharError, RxChar};
use crate::time::Instant;

/// The times of a framing (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FrameTiming {
    /// Time of one character on the wire.
    pub char_time: Duration,
    /// Idle time the line needs before a start character (MOVILINK's start pause, RTU's 3.5
    /// characters; zero where a start character may come at any time).
    pub start_gap: Duration,
    /// A gap of this length or more inside a frame breaks it off (or, with
    /// [`FrameTiming::ends_by_silence`], ends it).
    pub max_gap: Duration,
    /// Silence after a complete frame's last character that confirms its end; zero accepts a
    /// complete frame at once.
    pub end_silence: Duration,
    /// Frames end by silence ([`FrameTiming::max_gap`]) rather than by
    /// [`Progress::Complete`] (Modbus RTU).
    pub ends_by_silence: bool,
}

impl FrameTiming {
    /// One pause for everything: start gap, gap limit and end silence are `pause`; frames end by
    /// their length (MOVILINK's rules).
    pub const fn uniform(char_time: Duration, pause: Duration) -> FrameTiming {
        FrameTiming {
            char_time,
            start_gap: pause,
            max_gap: pause,
            end_silence: pause,
            ends_by_silence: false,
        }
    }
}

/// What a character that arrives while no frame is being received means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Start<E> {
    /// It starts a frame.
    Begin,
    /// It is not for this receiver, but not an error (e.g. the other direction's start
    /// character on a shared line); the receiver waits for the next idle gap.
    Ignore,
    /// It is garbage where a frame should start.
    Reject(E),
}

/// What the bytes received so far mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Progress<E> {
    /// The frame goes on.
    More,
    /// The frame is this many bytes long (known from a header, e.g. MOVILINK's PDU type or
    /// USS's length byte): the receiver collects them without asking again and then treats the
    /// frame as [`Progress::Complete`].
    Length(usize),
    /// The frame is complete (it is checked and decoded now, and accepted once its end is
    /// confirmed by silence).
    Complete,
    /// The bytes can no longer become a frame for this receiver (wrong address, unknown type).
    Reject(E),
}

/// The rejections the receiver itself makes; a framing's error type converts them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum LineError {
    /// A character of the frame had a UART error.
    #[error("{0}")]
    Char(CharError),
    /// The line was idle for the gap limit or longer inside a frame.
    #[error("inter-character gap exceeded after {received} bytes")]
    InterCharacterGap {
        /// Bytes received before the gap.
        received: u16,
    },
    /// A character followed a complete frame before its end was confirmed by silence.
    #[error("character {byte:#04x} after the end of the frame without an idle gap")]
    TrailingCharacter {
        /// The first character after the frame.
        byte: u8,
    },
    /// The frame grew beyond the receiver's buffer.
    #[error("frame longer than {capacity} bytes")]
    TooLong {
        /// The buffer size.
        capacity: u16,
    },
}

impl From<CharError> for LineError {
    fn from(e: CharError) -> Self {
        LineError::Char(e)
    }
}

/// A protocol's framing rules; see the [module docs](self).
pub trait Framing {
    /// A decoded frame.
    type Frame: Copy + core::fmt::Debug;
    /// Why characters were dropped.
    type Error: Copy + core::fmt::Debug + From<LineError>;

    /// The times of the line.
    fn timing(&self) -> FrameTiming;

    /// What `byte`, arriving after the start gap while no frame is being received, means.
    fn start(&self, byte: u8) -> Start<Self::Error>;

    /// Whether the received bytes `frame` (at least the start byte; the newest byte last) are
    /// complete, need more, or can no longer become a frame.
    fn progress(&self, frame: &[u8]) -> Progress<Self::Error>;

    /// Check and decode a complete frame.
    fn decode(&self, frame: &[u8]) -> Result<Self::Frame, Self::Error>;

    /// Whether `byte` inside a frame abandons it and starts a new one at once (Modbus ASCII's
    /// `:`); the abandoned frame is rejected with an [`LineError::InterCharacterGap`].
    fn restarts(&self, byte: u8) -> bool {
        let _ = byte;
        false
    }
}

/// What a character or a timeout completed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RxEvent<F, E> {
    /// A valid frame whose end was confirmed.
    Frame(F),
    /// Characters were dropped; see the reason.
    Rejected(E),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State<F> {
    /// Waiting for a start character after an idle gap.
    Idle,
    /// Collecting a frame of `len` bytes so far, `expected` in all once the framing said so
    /// (0 while unknown).
    Receiving { len: usize, expected: usize },
    /// A valid frame is complete; waiting for the silence that confirms its end.
    Complete { frame: F },
}

/// The times of a [`FrameTiming`] in nanoseconds, for the per-character path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Nanos {
    char_time: u64,
    start_gap: u64,
    max_gap: u64,
    end_silence: u64,
}

impl Nanos {
    const fn of(t: &FrameTiming) -> Self {
        use crate::time::duration_nanos;
        Self {
            char_time: duration_nanos(t.char_time),
            start_gap: duration_nanos(t.start_gap),
            max_gap: duration_nanos(t.max_gap),
            end_silence: duration_nanos(t.end_silence),
        }
    }
}

/// The receiver; see the [module docs](self). `N` is the longest frame it can hold.
#[derive(Debug, Clone)]
pub struct Receiver<F: Framing, const N: usize> {
    framing: F,
    timing: FrameTiming,
    ns: Nanos,
    state: State<F::Frame>,
    last: Option<Instant>,
    /// The event of a character that ended one frame and was itself rejected as the start of
    /// the next (one character, two events): delivered by the next call.
    pending: Option<RxEvent<F::Frame, F::Error>>,
    buf: [u8; N],
}

impl<F: Framing, const N: usize> Receiver<F, N> {
    /// A receiver for `framing`, with no line history (the first start character needs no gap).
    pub fn new(framing: F) -> Self {
        let timing = framing.timing();
        Self {
            framing,
            ns: Nanos::of(&timing),
            timing,
            state: State::Idle,
            last: None,
            pending: None,
            buf: [0; N],
        }
    }

    /// The framing.
    pub fn framing(&self) -> &F {
        &self.framing
    }

    /// The framing, for changing (e.g. the address a master expects next); call
    /// [`Receiver::refresh_timing`] if its times changed.
    pub fn framing_mut(&mut self) -> &mut F {
        &mut self.framing
    }

    /// Read the framing's times again.
    pub fn refresh_timing(&mut self) {
        self.timing = self.framing.timing();
        self.ns = Nanos::of(&self.timing);
    }

    /// The times in use.
    pub fn timing(&self) -> &FrameTiming {
        &self.timing
    }

    /// Drop a partial frame and forget the line history: the next start character starts a
    /// frame even without a preceding idle gap.
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.last = None;
        self.pending = None;
    }

    /// Whether a frame is being received (including a complete one whose end is not yet
    /// confirmed).
    #[inline]
    pub fn is_receiving(&self) -> bool {
        !matches!(self.state, State::Idle)
    }

    /// Time of the last character seen.
    pub fn last_char_time(&self) -> Option<Instant> {
        self.last
    }

    /// Feed one character; returns a confirmed or rejected frame.
    #[inline]
    pub fn handle_char(&mut self, c: RxChar) -> Option<RxEvent<F::Frame, F::Error>> {
        // The common case, a character in the middle of a frame whose length is known, takes
        // the short way.
        if let (&State::Receiving { len, expected }, Some(prev)) = (&self.state, self.last)
            && c.error.is_none()
            && len + 1 < expected
            && c.time >= prev
            && self.gap(prev, c.time) < self.ns.max_gap
            && !self.framing.restarts(c.byte)
            && let Some(slot) = self.buf.get_mut(len)
        {
            *slot = c.byte;
            self.state = State::Receiving {
                len: len + 1,
                expected,
            };
            self.last = Some(c.time);
            return None;
        }
        // (A left-over event means the receiver is not receiving: the short way never skips
        // one.)
        self.handle_char_in_general(c)
    }

    /// Every character the short way does not take.
    #[inline]
    fn handle_char_in_general(&mut self, c: RxChar) -> Option<RxEvent<F::Frame, F::Error>> {
        if self.pending.is_none() {
            self.handle_any_char(c)
        } else {
            self.handle_char_after_leftover(c)
        }
    }

    /// A character while an event is left over: events come out in order, the left-over one
    /// first, this character's next.
    #[cold]
    #[inline(never)]
    fn handle_char_after_leftover(&mut self, c: RxChar) -> Option<RxEvent<F::Frame, F::Error>> {
        let earlier = self.pending.take();
        // The receiver is idle after a left-over event, so this character can set nothing
        // pending itself; at most one event waits.
        let ev = self.handle_any_char(c);
        if self.pending.is_none() {
            self.pending = ev;
        }
        earlier
    }

    fn handle_any_char(&mut self, c: RxChar) -> Option<RxEvent<F::Frame, F::Error>> {
        let gap = self.last.map(|prev| self.gap(prev, c.time));
        let idle = gap.is_none_or(|g| g >= self.ns.start_gap);
        let broke_off = gap.is_none_or(|g| g >= self.ns.max_gap);
        // A frame's end is confirmed `end_silence` after its last character completed, as a
        // UART's idle timer restarted by every character confirms it: a character completing
        // after that instant comes after the confirmation, whether or not the caller polled
        // the timeout first (it may only have started within the silence).
        let confirmed = self
            .last
            .is_none_or(|prev| c.time.nanos_since(prev) >= self.ns.end_silence);
        self.last = Some(self.last.map_or(c.time, |prev| prev.later(c.time)));
        match self.state {
            State::Receiving { len, .. } if broke_off && self.timing.ends_by_silence => {
                // The silence ended the frame; it stands if the silence was long enough.
                let frame = self.finish(len);
                match frame {
                    Err(e) => {
                        self.state = State::Idle;
                        if idle {
                            self.pending = self.start(c);
                        }
                        Some(RxEvent::Rejected(e))
                    }
                    Ok(frame) if confirmed => {
                        self.state = State::Idle;
                        if idle {
                            self.pending = self.start(c);
                        }
                        Some(RxEvent::Frame(frame))
                    }
                    Ok(_) => {
                        self.state = State::Idle;
                        Some(RxEvent::Rejected(
                            LineError::TrailingCharacter { byte: c.byte }.into(),
                        ))
                    }
                }
            }
            State::Receiving { len, .. } if broke_off => {
                // The frame broke off; after a long enough gap this character may start the
                // next one.
                self.state = State::Idle;
                if idle {
                    self.pending = self.start(c);
                }
                Some(RxEvent::Rejected(gap_error(len)))
            }
            State::Receiving { len, .. } if self.framing.restarts(c.byte) => {
                self.state = State::Idle;
                self.pending = self.start(c);
                Some(RxEvent::Rejected(gap_error(len)))
            }
            State::Receiving { len, expected } => self.continue_with(c, len, expected),
            State::Complete { frame } if confirmed => {
                // The confirmation was not polled in time, but the line was quiet long enough:
                // the frame stands, and this character may start the next one.
                self.state = State::Idle;
                if idle {
                    self.pending = self.start(c);
                }
                Some(RxEvent::Frame(frame))
            }
            State::Complete { .. } => {
                // A character right after the frame: it was longer than it said.
                self.state = State::Idle;
                Some(RxEvent::Rejected(
                    LineError::TrailingCharacter { byte: c.byte }.into(),
                ))
            }
            State::Idle if idle => self.start(c),
            State::Idle => None,
        }
    }

    /// Feed characters, calling `on_event` for each event.
    pub fn handle_chars(
        &mut self,
        chars: &[RxChar],
        mut on_event: impl FnMut(RxEvent<F::Frame, F::Error>),
    ) {
        for c in chars {
            if let Some(ev) = self.handle_char(*c) {
                on_event(ev);
            }
        }
    }

    /// Tell the receiver the time is `now` without a new character: a complete frame whose end
    /// silence has passed is accepted; a partial frame whose gap reached the limit is rejected
    /// (or, ending by silence, completed).
    pub fn handle_timeout(&mut self, now: Instant) -> Option<RxEvent<F::Frame, F::Error>> {
        if self.pending.is_some() {
            return self.pending.take();
        }
        let last = self.last?;
        match self.state {
            State::Complete { frame } => {
                if now.nanos_since(last) >= self.ns.end_silence {
                    self.state = State::Idle;
                    return Some(RxEvent::Frame(frame));
                }
                None
            }
            State::Receiving { len, .. } if self.gap(last, now) >= self.ns.max_gap => {
                if !self.timing.ends_by_silence {
                    self.state = State::Idle;
                    return Some(RxEvent::Rejected(gap_error(len)));
                }
                match self.finish(len) {
                    Err(e) => {
                        self.state = State::Idle;
                        Some(RxEvent::Rejected(e))
                    }
                    Ok(frame) => {
                        self.state = State::Complete { frame };
                        self.handle_timeout(now)
                    }
                }
            }
            _ => None,
        }
    }

    /// When [`Receiver::handle_timeout`] will accept a complete frame or end a partial one, if
    /// one is in progress.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let last = self.last?;
        if self.pending.is_some() {
            return Some(last);
        }
        match self.state {
            State::Receiving { .. } => {
                Some(last.add_nanos(self.ns.char_time.saturating_add(self.ns.max_gap)))
            }
            State::Complete { .. } => Some(last.add_nanos(self.ns.end_silence)),
            State::Idle => None,
        }
    }

    /// When a complete frame's end will be confirmed by silence, if one awaits confirmation
    /// (the one deadline of the receiver that needs nothing but a quiet line).
    pub fn pending_confirmation(&self) -> Option<Instant> {
        if self.pending.is_some() {
            return self.last;
        }
        match (self.state, self.last) {
            (State::Complete { .. }, Some(last)) => Some(last.add_nanos(self.ns.end_silence)),
            _ => None,
        }
    }

    /// Idle time (ns) between a character completed at `prev` and one completed at `now`.
    #[inline]
    fn gap(&self, prev: Instant, now: Instant) -> u64 {
        now.nanos_since(prev).saturating_sub(self.ns.char_time)
    }

    fn start(&mut self, c: RxChar) -> Option<RxEvent<F::Frame, F::Error>> {
        if let Some(e) = c.error {
            return Some(RxEvent::Rejected(LineError::Char(e).into()));
        }
        match self.framing.start(c.byte) {
            Start::Begin => {
                let Some(first) = self.buf.first_mut() else {
                    return Some(RxEvent::Rejected(too_long::<F>(N)));
                };
                *first = c.byte;
                self.check(1)
            }
            Start::Ignore => None,
            Start::Reject(e) => Some(RxEvent::Rejected(e)),
        }
    }

    fn continue_with(
        &mut self,
        c: RxChar,
        len: usize,
        expected: usize,
    ) -> Option<RxEvent<F::Frame, F::Error>> {
        if let Some(e) = c.error {
            self.state = State::Idle;
            return Some(RxEvent::Rejected(LineError::Char(e).into()));
        }
        let Some(slot) = self.buf.get_mut(len) else {
            self.state = State::Idle;
            return Some(RxEvent::Rejected(too_long::<F>(N)));
        };
        *slot = c.byte;
        let len = len + 1;
        if expected == 0 {
            return self.check(len);
        }
        if len < expected {
            self.state = State::Receiving { len, expected };
            return None;
        }
        self.complete(len)
    }

    /// The frame has `len` bytes now: ask the framing what they mean.
    fn check(&mut self, len: usize) -> Option<RxEvent<F::Frame, F::Error>> {
        let bytes = self.buf.get(..len).unwrap_or(&[]);
        match self.framing.progress(bytes) {
            Progress::More => {
                self.state = State::Receiving { len, expected: 0 };
                None
            }
            Progress::Length(expected) if len < expected => {
                self.state = State::Receiving { len, expected };
                None
            }
            Progress::Length(_) => self.complete(len),
            Progress::Reject(e) => {
                self.state = State::Idle;
                Some(RxEvent::Rejected(e))
            }
            Progress::Complete => self.complete(len),
        }
    }

    /// The frame of `len` bytes is complete: decode it; accept it at once without an end
    /// silence, else wait for the silence.
    fn complete(&mut self, len: usize) -> Option<RxEvent<F::Frame, F::Error>> {
        match self.finish(len) {
            Err(e) => {
                self.state = State::Idle;
                Some(RxEvent::Rejected(e))
            }
            Ok(frame) if self.ns.end_silence == 0 => {
                self.state = State::Idle;
                Some(RxEvent::Frame(frame))
            }
            Ok(frame) => {
                self.state = State::Complete { frame };
                None
            }
        }
    }

    fn finish(&self, len: usize) -> Result<F::Frame, F::Error> {
        self.framing.decode(self.buf.get(..len).unwrap_or(&[]))
    }
}

fn gap_error<E: From<LineError>>(len: usize) -> E {
    LineError::InterCharacterGap {
        received: u16::try_from(len).unwrap_or(u16::MAX),
    }
    .into()
}

fn too_long<F: Framing>(capacity: usize) -> F::Error {
    LineError::TooLong {
        capacity: u16::try_from(capacity).unwrap_or(u16::MAX),
    }
    .into()
}

#[cfg(test)]
mod tests;
