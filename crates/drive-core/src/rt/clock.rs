//! The clock a port or a serve loop runs on.

use core::time::Duration;

use tokio::time::Instant as TokioInstant;

use super::io::TIMER_RESOLUTION;
use crate::time::Instant;

/// Which time a sans-IO endpoint is driven with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Clock {
    /// tokio's clock (paused in tests, real otherwise): every pause and timeout is waited for.
    ///
    /// tokio's timers tick in 1 ms steps ([`TIMER_RESOLUTION`]): a wait ends on the first tick
    /// at or after its deadline, never earlier. On an I/O that places a frame at an intended
    /// start ([`CharIo::honours_write_start`]: the wire model of `drive-transport`), the
    /// endpoint is told the deadline itself as its time (not the late tick) and a frame it
    /// sends because of that wake-up is written with the deadline as its start
    /// ([`CharIo::poll_write_at`]): it starts on the wire exactly where the protocol put it. On
    /// a real port the frame leaves on tokio's tick, up to 1 ms later than the rule asks, and
    /// the endpoint is told that time.
    ///
    /// [`CharIo::poll_write_at`]: super::CharIo::poll_write_at
    /// [`CharIo::honours_write_start`]: super::CharIo::honours_write_start
    #[default]
    Real,
    /// A virtual clock for benchmarks of software overhead: it advances one character time per
    /// character and jumps over every pause that needs only a quiet line; only a response
    /// timeout is a real timer (the answer comes in real time).
    Virtual,
}

/// The time base of one port or serve loop: its [`Clock`], the epoch of its [`Instant`]s (on
/// tokio's clock) and the virtual time.
#[derive(Debug, Clone, Copy)]
pub struct Timebase {
    clock: Clock,
    epoch: TokioInstant,
    virt: Instant,
    char_time: Duration,
}

impl Timebase {
    /// A time base whose epoch is now, for a line with `char_time`.
    pub fn new(clock: Clock, char_time: Duration) -> Self {
        Self {
            clock,
            epoch: super::time::now(),
            virt: Instant::ZERO,
            char_time,
        }
    }

    /// The clock.
    pub fn clock(&self) -> Clock {
        self.clock
    }

    /// The epoch on tokio's clock.
    pub fn epoch(&self) -> TokioInstant {
        self.epoch
    }

    /// The character time of the line.
    pub fn char_time(&self) -> Duration {
        self.char_time
    }

    /// Now, as the endpoint sees it.
    pub fn now(&self) -> Instant {
        match self.clock {
            Clock::Real => self.to_instant(super::time::now()),
            Clock::Virtual => self.virt,
        }
    }

    /// A tokio instant as an endpoint [`Instant`] (before the epoch: the epoch).
    pub fn to_instant(&self, t: TokioInstant) -> Instant {
        Instant::from_duration(t.saturating_duration_since(self.epoch))
    }

    /// An endpoint [`Instant`] on tokio's clock.
    pub fn to_tokio(&self, t: Instant) -> TokioInstant {
        self.epoch + t.as_duration()
    }

    /// The time an endpoint is told when the timer for its deadline `d` has ended: on the
    /// real clock `d` itself when tokio woke at most [`TIMER_RESOLUTION`] after it (the timer
    /// ends on tokio's next tick, the protocol's time is the deadline), otherwise (a wake-up
    /// delayed by a busy task) now; on the virtual clock now.
    pub fn woken_at(&self, d: Instant) -> Instant {
        let now = self.now();
        match self.clock {
            Clock::Real if d <= now && now.saturating_duration_since(d) <= TIMER_RESOLUTION => d,
            _ => now,
        }
    }

    /// The instant on tokio's clock at which a frame the endpoint sends at its time `t` is
    /// meant to start, if it differs from now and can still be honoured: only on the real
    /// clock, for a `t` at most [`TIMER_RESOLUTION`] in the past (see [`Timebase::woken_at`]).
    pub fn intended_start(&self, t: Instant) -> Option<TokioInstant> {
        if self.clock != Clock::Real {
            return None;
        }
        let at = self.to_tokio(t);
        let now = super::time::now();
        (at <= now && now.saturating_duration_since(at) <= TIMER_RESOLUTION).then_some(at)
    }

    /// The time of a received character that arrived at `at`: exact on the real clock; one
    /// character time after the previous event on the virtual clock.
    pub fn arrival(&mut self, at: TokioInstant) -> Instant {
        match self.clock {
            Clock::Real => self.to_instant(at),
            Clock::Virtual => {
                self.virt += self.char_time;
                self.virt
            }
        }
    }

    /// `chars` characters were sent: the virtual clock advances by their wire time.
    pub fn sent(&mut self, chars: usize) {
        if self.clock == Clock::Virtual {
            let n = u32::try_from(chars).unwrap_or(u32::MAX);
            self.virt += self.char_time.saturating_mul(n);
        }
    }

    /// The same time base on `clock`, continuing from the time an endpoint sees now: an
    /// endpoint that keeps its state across the switch sees its time go on, not start again at
    /// zero (which would make every gap since its last character look like none).
    #[must_use]
    pub fn switched_to(self, clock: Clock) -> Self {
        let now = self.now();
        let epoch = match clock {
            Clock::Real => super::time::now()
                .checked_sub(now.as_duration())
                .unwrap_or(self.epoch),
            Clock::Virtual => self.epoch,
        };
        Self {
            clock,
            epoch,
            virt: now,
            char_time: self.char_time,
        }
    }

    /// The virtual clock jumps forward to `t` (no effect on the real clock).
    pub fn jump_to(&mut self, t: Instant) {
        if self.clock == Clock::Virtual {
            self.virt = self.virt.later(t);
        }
    }
}
