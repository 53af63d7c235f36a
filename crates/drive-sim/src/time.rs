//! Simulated time: a monotonic instant that the caller supplies.

use core::ops::Add;
use std::time::Duration;

/// A point in simulated time, in microseconds since an arbitrary epoch chosen by the caller.
///
/// The simulator never reads a clock: every operation that depends on time takes a `SimTime`
/// argument. Tests usually start at [`SimTime::ZERO`] and add [`Duration`]s; a front-end driven
/// by a real or paused clock converts its own instant into microseconds since its start.
///
/// Time that goes backwards is tolerated: it is treated as no time having passed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct SimTime(u64);

impl SimTime {
    /// The epoch.
    pub const ZERO: SimTime = SimTime(0);

    /// `micros` microseconds after the epoch.
    pub const fn from_micros(micros: u64) -> SimTime {
        SimTime(micros)
    }

    /// `millis` milliseconds after the epoch (saturating).
    pub const fn from_millis(millis: u64) -> SimTime {
        SimTime(millis.saturating_mul(1_000))
    }

    /// `secs` seconds after the epoch (saturating).
    pub const fn from_secs(secs: u64) -> SimTime {
        SimTime(secs.saturating_mul(1_000_000))
    }

    /// `since_epoch` after the epoch (saturating at `u64::MAX` microseconds).
    pub fn from_duration(since_epoch: Duration) -> SimTime {
        SimTime(u64::try_from(since_epoch.as_micros()).unwrap_or(u64::MAX))
    }

    /// Microseconds since the epoch.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Time since the epoch as a [`Duration`].
    pub const fn as_duration(self) -> Duration {
        Duration::from_micros(self.0)
    }

    /// Time elapsed from `earlier` to `self`, zero if `earlier` is later.
    pub const fn saturating_since(self, earlier: SimTime) -> Duration {
        Duration::from_micros(self.0.saturating_sub(earlier.0))
    }
}

impl Add<Duration> for SimTime {
    type Output = SimTime;

    /// Saturating addition (sub-microsecond parts are dropped).
    fn add(self, rhs: Duration) -> SimTime {
        let micros = u64::try_from(rhs.as_micros()).unwrap_or(u64::MAX);
        SimTime(self.0.saturating_add(micros))
    }
}

impl From<Duration> for SimTime {
    fn from(since_epoch: Duration) -> SimTime {
        SimTime::from_duration(since_epoch)
    }
}
