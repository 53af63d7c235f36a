//! USS framing on drive-core's character receiver: [`UssFraming`] for both sides, the USS
//! times from the real line settings ([`UssTiming`]) and the check of a telegram's run time.
//!
//! The rules (USS specification as published in the Siemens drive manuals, e.g. SINAMICS
//! CU240S operating instructions 11/2006 section 8.7, SINAMICS S110 function manual 01/2011
//! section 9.5; and NORD's own USS master rules, BU 0050 section 1.7; see
//! `docs/protocols/uss.md`):
//!
//! * **Start delay.** A telegram starts with STX after the line was quiet for at least two
//!   character times (9600 8E1: > 2.291 ms). The receiver takes an STX only after that gap
//!   and a master or slave sends nothing sooner ([`UssTiming::start_delay`]).
//! * **Character delay.** The gap between two characters of a telegram may be zero and must be
//!   shorter than the start delay ("the time between two characters must be shorter than the
//!   start delay"): a gap of [`UssTiming::max_char_gap`] (default: the start delay) breaks the
//!   telegram off, and the character after it may start the next one.
//! * **Residual run time.** From the end of STX to the end of BCC a telegram of n net bytes
//!   may take at most 1.5 × (n + 3) character times (the characters LGE, ADR, net data, BCC,
//!   with 50 % for gaps; NORD: "maximum total run time = 1.5 × consecutive telegram run
//!   time"). The master checks it on answers, the slave on requests
//!   ([`UssTiming::runtime_percent`], default 150; `None` switches it off).
//! * **Length** from LGE ([`Progress::Length`]), checked against the fixed [`Layout`].
//! * **End.** A telegram is accepted once the line stayed quiet for the start delay after its
//!   BCC: nothing may follow it sooner, so a character that does (an inserted character that
//!   pushed the real BCC out of the announced length) rejects it
//!   ([`LineError::TrailingCharacter`](drive_core::LineError::TrailingCharacter)). This costs nothing: an answer or the next request may
//!   start only after the start delay anyway.
//! * **BCC**: the XOR of every byte before it; even parity per character (8E1, 11 bits).
//!
//! A slave's framing ([`Side::Slave`]) drops telegrams for other addresses at their ADR byte
//! ([`FrameError::NotAddressed`]); a broadcast is for every slave.

use core::time::Duration;

use drive_core::framing::{FrameTiming, Framing, Progress, Receiver, RxEvent, Start};
use drive_core::{Instant, LineSettings, RxChar};

use super::telegram::{Adr, FrameError, Layout, MAX_TELEGRAM, STX, Telegram, UssAddress};

/// drive-core's receiver with USS framing.
pub type UssReceiver = Receiver<UssFraming, MAX_TELEGRAM>;

/// The USS times of a line; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UssTiming {
    /// One character on the wire (8E1: 11 bits).
    pub char_time: Duration,
    /// The least silence before a telegram's STX: two character times.
    pub start_delay: Duration,
    /// A gap this long or longer inside a telegram breaks it off; at most the start delay.
    pub max_char_gap: Duration,
    /// The longest residual run time in percent of the run time without gaps (150), `None`
    /// for no check.
    pub runtime_percent: Option<u16>,
}

impl UssTiming {
    /// The specification's times on `line`: start delay and gap limit two character times,
    /// residual run time 150 %.
    pub const fn from_line(line: &LineSettings) -> UssTiming {
        let start_delay = line.char_times(2, 1);
        UssTiming {
            char_time: line.char_time(),
            start_delay,
            max_char_gap: start_delay,
            runtime_percent: Some(150),
        }
    }

    /// The same times with another gap limit, clamped to the start delay (a longer gap would
    /// let the next telegram start inside this one).
    #[must_use]
    pub fn with_max_char_gap(self, gap: Duration) -> UssTiming {
        UssTiming {
            max_char_gap: gap.min(self.start_delay),
            ..self
        }
    }

    /// The same times with another residual run-time limit (`None`: no check).
    #[must_use]
    pub const fn with_runtime_percent(self, percent: Option<u16>) -> UssTiming {
        UssTiming {
            runtime_percent: percent,
            ..self
        }
    }

    /// The longest residual run time of a telegram of `layout` (from the end of STX to the
    /// end of BCC), if checked.
    pub fn max_runtime(&self, layout: Layout) -> Option<Duration> {
        let percent = self.runtime_percent?;
        let chars = u32::from(layout.lge()) + 1;
        let ns = self.char_time.as_nanos() * u128::from(chars) * u128::from(percent) / 100;
        Some(Duration::from_nanos(u64::try_from(ns).unwrap_or(u64::MAX)))
    }

    /// The receiver's times.
    pub const fn frame_timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: self.char_time,
            start_gap: self.start_delay,
            max_gap: self.max_char_gap,
            end_silence: self.start_delay,
            ends_by_silence: false,
        }
    }
}

/// Which telegrams a receiver takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The master: answers from any address (the master checks the address).
    Master,
    /// A slave with this address: requests to it and broadcasts.
    Slave(UssAddress),
}

/// The USS framing description; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UssFraming {
    side: Side,
    layout: Layout,
    timing: UssTiming,
}

impl UssFraming {
    /// Telegrams of `layout` for `side` on `line`, with the specification's times.
    pub const fn new(side: Side, layout: Layout, line: &LineSettings) -> UssFraming {
        UssFraming {
            side,
            layout,
            timing: UssTiming::from_line(line),
        }
    }

    /// The same framing with other times (call the receiver's `refresh_timing` after changing
    /// a receiver's framing).
    #[must_use]
    pub const fn with_timing(self, timing: UssTiming) -> UssFraming {
        UssFraming { timing, ..self }
    }

    /// The side.
    pub const fn side(&self) -> Side {
        self.side
    }

    /// Change the side (a slave's new address).
    pub fn set_side(&mut self, side: Side) {
        self.side = side;
    }

    /// The layout expected.
    pub const fn layout(&self) -> Layout {
        self.layout
    }

    /// Expect telegrams of `layout` from now on (a master expects the answer in its request's
    /// layout).
    pub fn set_layout(&mut self, layout: Layout) {
        self.layout = layout;
    }

    /// The USS times.
    pub const fn uss_timing(&self) -> UssTiming {
        self.timing
    }

    fn bad_length(&self, got: u8) -> FrameError {
        FrameError::BadLength {
            expected: self.layout.lge(),
            got,
        }
    }
}

impl Framing for UssFraming {
    type Frame = Telegram;
    type Error = FrameError;

    fn timing(&self) -> FrameTiming {
        self.timing.frame_timing()
    }

    #[inline]
    fn start(&self, byte: u8) -> Start<FrameError> {
        if byte == STX {
            Start::Begin
        } else {
            // After a start delay only STX may come: anything else is garbage, dropped up to
            // the next start delay.
            Start::Reject(FrameError::BadStx(byte))
        }
    }

    #[inline]
    fn progress(&self, frame: &[u8]) -> Progress<FrameError> {
        let full = self.layout.telegram_len();
        match (frame, self.side) {
            ([_], _) => Progress::More,
            (&[_, lge], Side::Master) if lge == self.layout.lge() => Progress::Length(full),
            (&[_, lge], Side::Master) => Progress::Reject(self.bad_length(lge)),
            (&[_, lge], Side::Slave(_)) if lge < 2 => Progress::Reject(self.bad_length(lge)),
            ([_, _], Side::Slave(_)) => Progress::More,
            (&[_, lge, adr], Side::Slave(own)) => {
                let adr = Adr(adr);
                if !adr.is_broadcast() && adr.address() != own {
                    Progress::Reject(FrameError::NotAddressed(adr))
                } else if lge != self.layout.lge() {
                    Progress::Reject(self.bad_length(lge))
                } else {
                    Progress::Length(full)
                }
            }
            _ if frame.len() >= full => Progress::Complete,
            _ => Progress::More,
        }
    }

    #[inline]
    fn decode(&self, frame: &[u8]) -> Result<Telegram, FrameError> {
        Telegram::decode(frame, self.layout)
    }
}

/// Where the telegram being received started and ended, for the residual run-time check:
/// kept beside a receiver by whoever feeds it (the receiver itself knows no start times).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct RunClock {
    /// End of the STX of the telegram being received.
    start: Instant,
    /// End of its last character so far.
    last: Instant,
}

impl RunClock {
    /// `c` was fed to a receiver that was receiving (`was`) or not, returned `event` and is
    /// receiving now (`now_receiving`). Call [`RunClock::check`] on a frame event first.
    #[inline]
    pub(crate) fn after_char(&mut self, c: &RxChar, was: bool, event: bool, now_receiving: bool) {
        if !now_receiving {
            return;
        }
        if !was || event {
            // `c` started a telegram (after an idle line, or right after the previous one
            // ended or broke off).
            self.start = c.time;
        }
        self.last = c.time;
    }

    /// Whether the telegram just confirmed kept the residual run time.
    pub(crate) fn check(&self, timing: &UssTiming, layout: Layout) -> Result<(), FrameError> {
        let Some(limit) = timing.max_runtime(layout) else {
            return Ok(());
        };
        let took = self.last.saturating_duration_since(self.start);
        if took > limit {
            let us = |d: Duration| u32::try_from(d.as_micros()).unwrap_or(u32::MAX);
            return Err(FrameError::RuntimeExceeded {
                took_us: us(took),
                limit_us: us(limit),
            });
        }
        Ok(())
    }
}

/// A receiver with the run-time check: what master and slave wrap around drive-core's.
pub(crate) fn receive(
    rx: &mut UssReceiver,
    clock: &mut RunClock,
    c: RxChar,
) -> Option<RxEvent<Telegram, FrameError>> {
    let was = rx.is_receiving();
    let ev = rx.handle_char(c);
    let ev = ev.map(|e| judge(e, clock, rx.framing()));
    clock.after_char(&c, was, ev.is_some(), rx.is_receiving());
    ev
}

/// A frame event checked against the run-time limit.
#[inline]
pub(crate) fn judge(
    ev: RxEvent<Telegram, FrameError>,
    clock: &RunClock,
    framing: &UssFraming,
) -> RxEvent<Telegram, FrameError> {
    match ev {
        RxEvent::Frame(t) => match clock.check(&framing.timing, t.layout()) {
            Ok(()) => RxEvent::Frame(t),
            Err(e) => RxEvent::Rejected(e),
        },
        other => other,
    }
}
