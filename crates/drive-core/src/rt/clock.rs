//! The clock a port or a serve loop runs on.

use core::time::Duration;

use tokio::time::Instant as TokioInstant;

use crate::time::Instant;

/// Which time a sans-IO endpoint is driven with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Clock {
    /// tokio's clock (paused in tests, real otherwise): every pause and timeout is waited for.
    /// tokio's timers tick in 1 ms steps, so a wait may end up to 1 ms later than a rule asks,
    /// never earlier.
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
            epoch: TokioInstant::now(),
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
            Clock::Real => self.to_instant(TokioInstant::now()),
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
            Clock::Real => TokioInstant::now()
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
