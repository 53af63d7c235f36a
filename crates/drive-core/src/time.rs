//! The one notion of time of drivebus: an [`Instant`] the caller supplies.
//!
//! Sans-IO code never reads a clock. Every method that depends on time takes an `Instant`
//! argument: nanoseconds since an epoch the caller picks (a test starts at [`Instant::ZERO`],
//! an async driver uses the moment it opened its port, a simulated drive the moment it was
//! powered on). Nanoseconds, because character times are not whole microseconds (11 bits at
//! 9600 baud are 1 145 833 ns) and every protocol computes its pauses from them; `u64`
//! nanoseconds last 584 years.
//!
//! Arithmetic saturates instead of overflowing or panicking, and time that goes backwards is
//! treated as no time having passed ([`Instant::saturating_duration_since`]).

use core::fmt;
use core::ops::{Add, AddAssign};
use core::time::Duration;

/// A point in time: nanoseconds since an epoch chosen by the caller.
///
/// ```
/// use core::time::Duration;
/// use drive_core::Instant;
///
/// let t = Instant::from_micros(1_500);
/// assert_eq!(t + Duration::from_nanos(500), Instant::from_nanos(1_500_500));
/// assert_eq!(t.saturating_duration_since(Instant::from_millis(1)), Duration::from_micros(500));
/// assert_eq!(Instant::ZERO.saturating_duration_since(t), Duration::ZERO);
/// assert_eq!(Instant::MAX + Duration::from_secs(1), Instant::MAX);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Instant(u64);

impl Instant {
    /// The epoch.
    pub const ZERO: Instant = Instant(0);
    /// The latest representable instant (about 584 years after the epoch).
    pub const MAX: Instant = Instant(u64::MAX);

    /// `nanos` nanoseconds after the epoch.
    #[inline]
    pub const fn from_nanos(nanos: u64) -> Instant {
        Instant(nanos)
    }

    /// `micros` microseconds after the epoch (saturating).
    #[inline]
    pub const fn from_micros(micros: u64) -> Instant {
        Instant(micros.saturating_mul(1_000))
    }

    /// `millis` milliseconds after the epoch (saturating).
    pub const fn from_millis(millis: u64) -> Instant {
        Instant(millis.saturating_mul(1_000_000))
    }

    /// `secs` seconds after the epoch (saturating).
    pub const fn from_secs(secs: u64) -> Instant {
        Instant(secs.saturating_mul(1_000_000_000))
    }

    /// `since_epoch` after the epoch (saturating).
    pub const fn from_duration(since_epoch: Duration) -> Instant {
        Instant(duration_nanos(since_epoch))
    }

    /// Nanoseconds since the epoch.
    #[inline]
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// Whole microseconds since the epoch.
    #[inline]
    pub const fn as_micros(self) -> u64 {
        self.0 / 1_000
    }

    /// Time since the epoch.
    pub const fn as_duration(self) -> Duration {
        Duration::from_nanos(self.0)
    }

    /// Time from `earlier` to `self`; zero if `earlier` is later.
    #[inline]
    pub const fn saturating_duration_since(self, earlier: Instant) -> Duration {
        Duration::from_nanos(self.0.saturating_sub(earlier.0))
    }

    /// `self + d`, saturating at [`Instant::MAX`].
    #[must_use]
    #[inline]
    pub const fn saturating_add(self, d: Duration) -> Instant {
        Instant(self.0.saturating_add(duration_nanos(d)))
    }

    /// `self + nanos` nanoseconds, saturating (the hot paths of the receivers keep their times
    /// as nanoseconds).
    #[must_use]
    #[inline]
    pub const fn add_nanos(self, nanos: u64) -> Instant {
        Instant(self.0.saturating_add(nanos))
    }

    /// Nanoseconds from `earlier` to `self`; zero if `earlier` is later.
    #[inline]
    pub const fn nanos_since(self, earlier: Instant) -> u64 {
        self.0.saturating_sub(earlier.0)
    }

    /// `self - d`, saturating at the epoch.
    #[must_use]
    pub const fn saturating_sub(self, d: Duration) -> Instant {
        Instant(self.0.saturating_sub(duration_nanos(d)))
    }

    /// The later of the two.
    #[must_use]
    #[inline]
    pub const fn later(self, other: Instant) -> Instant {
        if other.0 > self.0 { other } else { self }
    }
}

/// The earlier of two optional deadlines (`None` means "no deadline").
///
/// Written out rather than as `[a, b].into_iter().flatten().min()`: the iterator copies the
/// options through memory, which costs a measurable share of a MOVILINK exchange.
#[must_use]
#[inline]
pub const fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
        (Some(x), None) | (None, Some(x)) => Some(x),
        (None, None) => None,
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;

    /// Saturating addition.
    fn add(self, rhs: Duration) -> Instant {
        self.saturating_add(rhs)
    }
}

impl AddAssign<Duration> for Instant {
    /// Saturating addition.
    fn add_assign(&mut self, rhs: Duration) {
        *self = self.saturating_add(rhs);
    }
}

impl From<Duration> for Instant {
    fn from(since_epoch: Duration) -> Instant {
        Instant::from_duration(since_epoch)
    }
}

impl fmt::Debug for Instant {
    /// `Instant(12.345678ms)`: the time since the epoch.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Instant({:?})", self.as_duration())
    }
}

/// Whole nanoseconds of `d`, saturating at `u64::MAX`.
pub const fn duration_nanos(d: Duration) -> u64 {
    let n = d.as_nanos();
    if n > u64::MAX as u128 {
        u64::MAX
    } else {
        n as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn earliest_ignores_missing_deadlines() {
        let (a, b) = (Instant::from_micros(5), Instant::from_micros(7));
        assert_eq!(earliest(Some(a), Some(b)), Some(a));
        assert_eq!(earliest(Some(b), Some(a)), Some(a));
        assert_eq!(earliest(None, Some(b)), Some(b));
        assert_eq!(earliest(Some(b), None), Some(b));
        assert_eq!(earliest(None, None), None);
        assert_eq!(earliest(Some(a), Some(a)), Some(a));
    }

    #[test]
    fn units_and_saturation() {
        assert_eq!(Instant::from_micros(3).as_nanos(), 3_000);
        assert_eq!(Instant::from_millis(3).as_micros(), 3_000);
        assert_eq!(Instant::from_secs(2).as_duration(), Duration::from_secs(2));
        assert_eq!(Instant::from_micros(u64::MAX), Instant::MAX);
        assert_eq!(Instant::from_duration(Duration::MAX), Instant::MAX);
        assert_eq!(Instant::MAX + Duration::from_secs(1), Instant::MAX);
        assert_eq!(
            Instant::from_nanos(5).saturating_sub(Duration::from_secs(1)),
            Instant::ZERO
        );
        let mut t = Instant::ZERO;
        t += Duration::from_nanos(1_145_833);
        assert_eq!(t.as_micros(), 1_145);
        assert_eq!(
            Instant::from_micros(7).later(Instant::from_micros(9)),
            Instant::from_micros(9)
        );
        assert_eq!(
            format!("{:?}", Instant::from_micros(1_500)),
            "Instant(1.5ms)"
        );
    }
}
