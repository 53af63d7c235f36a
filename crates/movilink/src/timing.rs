//! Bus timing of MOVILINK as plain state: no sleeps, no clock reads.
//!
//! Every time value is passed in by the caller as an [`Instant`], a microsecond count since an
//! arbitrary epoch chosen by the caller (an async driver typically uses the time its port was
//! opened). The constants below come from chapter 4.1/4.2 of the MOVIDRIVE serial communication
//! manual:
//!
//! | constant | value | manual |
//! |---|---|---|
//! | [`CHAR_TIME`] | 1146 µs | 11 bits (start, 8 data, even parity, stop) at 9600 baud = 1145.8 µs, rounded up |
//! | [`START_PAUSE`] | 3.44 ms | idle time before SD1/SD2; = 3 character times (3 × 1.1458 ms = 3.4375 ms, rounded up to 3.44 ms) |
//! | [`RESTART_PAUSE`] | 6.88 ms | after the master aborted a request: two start pauses |
//! | [`BROADCAST_SPACING`] | 25 ms | from the BCC of a broadcast request to the next SD1 |
//! | [`MAX_RESPONSE_DELAY`] | 50 ms | from the request's BCC to the response's SD2, at most |
//!
//! The inter-character gap inside a telegram must stay below the start pause; a receiver that
//! sees a gap of a start pause or more treats the telegram as broken (and the character after
//! the gap as a possible new start).
//!
//! Character times: an [`RxChar`](crate::receiver::RxChar)'s time is the moment the character
//! was *completely* received (end of its stop bit). The idle gap before a character is therefore
//! `time - previous.time - char_time`.

use core::ops::Add;
use core::time::Duration;

/// A point in time: microseconds since an epoch chosen by the caller.
///
/// This is the only notion of time of the crate; it is never read from a clock.
/// Arithmetic saturates instead of overflowing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Instant(u64);

impl Instant {
    /// The epoch.
    pub const ZERO: Self = Self(0);

    /// An instant `micros` microseconds after the epoch.
    pub const fn from_micros(micros: u64) -> Self {
        Self(micros)
    }

    /// An instant `millis` milliseconds after the epoch (saturating).
    pub const fn from_millis(millis: u64) -> Self {
        Self(millis.saturating_mul(1000))
    }

    /// An instant `since_epoch` after the epoch (saturating at `u64::MAX` microseconds).
    pub fn from_duration(since_epoch: Duration) -> Self {
        Self(duration_micros(since_epoch))
    }

    /// Microseconds since the epoch.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Time since the epoch.
    pub const fn as_duration(self) -> Duration {
        Duration::from_micros(self.0)
    }

    /// Time from `earlier` to `self`, zero if `earlier` is later.
    pub const fn saturating_duration_since(self, earlier: Instant) -> Duration {
        Duration::from_micros(self.0.saturating_sub(earlier.0))
    }

    /// `self + d`, saturating.
    pub fn saturating_add(self, d: Duration) -> Self {
        Self(self.0.saturating_add(duration_micros(d)))
    }

    pub(crate) const fn plus_micros(self, us: u64) -> Self {
        Self(self.0.saturating_add(us))
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;

    /// Saturating addition.
    fn add(self, rhs: Duration) -> Instant {
        self.saturating_add(rhs)
    }
}

/// Whole microseconds of `d`, saturating at `u64::MAX`.
pub(crate) fn duration_micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

/// The fixed baud rate of MOVILINK over RS-485/RS-232.
pub const BAUD_RATE: u32 = 9600;
/// Bits per character: 1 start, 8 data, 1 even parity, 1 stop.
pub const BITS_PER_CHAR: u32 = 11;
/// Time of one character at 9600 baud (11 bits = 1145.8 µs, rounded up to whole microseconds).
pub const CHAR_TIME: Duration = char_time(BAUD_RATE);
/// Minimum idle time before a start character (3 character times, 3.44 ms as the manual says).
pub const START_PAUSE: Duration = Duration::from_micros(3440);
/// Minimum idle time before a new request after the master aborted a request (2 start pauses).
pub const RESTART_PAUSE: Duration = Duration::from_micros(2 * 3440);
/// Minimum time from the BCC of a broadcast (or group) request to the next SD1.
pub const BROADCAST_SPACING: Duration = Duration::from_millis(25);
/// The maximum response delay a drive may take (request BCC → response SD2).
pub const MAX_RESPONSE_DELAY: Duration = Duration::from_millis(50);
/// The master's default response timeout: the manual's maximum response delay.
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = MAX_RESPONSE_DELAY;

/// Time of one 11-bit character at `baud` (rounded up to whole microseconds; `baud` 0 → 0).
pub const fn char_time(baud: u32) -> Duration {
    if baud == 0 {
        return Duration::ZERO;
    }
    let bits_us = BITS_PER_CHAR as u64 * 1_000_000;
    Duration::from_micros(bits_us.div_ceil(baud as u64))
}

/// Line timing shared by the receiver and the state machines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LineTiming {
    /// Time of one character on the wire.
    pub char_time: Duration,
    /// Minimum idle time before a start character.
    pub start_pause: Duration,
    /// Longest idle time accepted between two characters of one received telegram; a longer
    /// gap rejects the telegram. The manual's rule is "shorter than the start pause" (the
    /// default). A master whose characters are timestamped when the operating system hands
    /// them over (USB serial adapters deliver in bursts, e.g. every 16 ms) needs more.
    pub max_gap: Duration,
}

impl LineTiming {
    /// MOVILINK at 9600 baud: [`CHAR_TIME`] and [`START_PAUSE`].
    pub const MOVILINK: Self = Self {
        char_time: CHAR_TIME,
        start_pause: START_PAUSE,
        max_gap: START_PAUSE,
    };

    /// The same timing, accepting gaps up to `max_gap` inside a received telegram (never
    /// less than the start pause).
    pub fn with_max_gap(self, max_gap: Duration) -> Self {
        Self {
            max_gap: max_gap.max(self.start_pause),
            ..self
        }
    }

    /// Wire time of `chars` characters.
    pub fn wire_time(&self, chars: usize) -> Duration {
        let n = u32::try_from(chars).unwrap_or(u32::MAX);
        self.char_time.saturating_mul(n)
    }

    pub(crate) fn micros(&self) -> (u64, u64) {
        (
            duration_micros(self.char_time),
            duration_micros(self.start_pause),
        )
    }

    pub(crate) fn max_gap_micros(&self) -> u64 {
        duration_micros(self.max_gap.max(self.start_pause))
    }
}

impl Default for LineTiming {
    fn default() -> Self {
        Self::MOVILINK
    }
}

/// Decides when the next telegram may start on the bus.
///
/// Feed it every bus activity (characters sent or received, with the time their last bit
/// ended); it answers the earliest start of the next telegram:
///
/// * a start pause after the last activity,
/// * [`RESTART_PAUSE`] after an aborted request ([`TxGate::on_aborted`]),
/// * [`BROADCAST_SPACING`] after a request that expects no response ([`TxGate::on_request_sent`]).
///
/// ```
/// use movilink::timing::{Instant, TxGate, LineTiming};
/// let mut gate = TxGate::new(LineTiming::MOVILINK);
/// gate.on_activity(Instant::from_micros(10_000));
/// assert_eq!(gate.earliest_start(), Instant::from_micros(13_440));
/// assert!(!gate.may_start(Instant::from_micros(13_439)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TxGate {
    start_pause_us: u64,
    last_activity: Option<Instant>,
    not_before: Instant,
}

impl TxGate {
    /// A gate for a bus with `timing`, with no activity seen yet (the bus is assumed idle; call
    /// [`TxGate::on_activity`] with the opening time of a port to require a first start pause).
    pub fn new(timing: LineTiming) -> Self {
        Self {
            start_pause_us: duration_micros(timing.start_pause),
            last_activity: None,
            not_before: Instant::ZERO,
        }
    }

    /// A character ended on the bus at `end` (sent or received).
    pub fn on_activity(&mut self, end: Instant) {
        self.last_activity = Some(match self.last_activity {
            Some(last) if last > end => last,
            _ => end,
        });
    }

    /// No telegram may start before `t`.
    pub fn hold_until(&mut self, t: Instant) {
        if t > self.not_before {
            self.not_before = t;
        }
    }

    /// A complete request to `address` ended at `end`; requests without a response (group,
    /// broadcast) hold the bus for [`BROADCAST_SPACING`].
    pub fn on_request_sent(&mut self, end: Instant, address: crate::Address) {
        self.on_activity(end);
        if !address.expects_response() {
            self.hold_until(end + BROADCAST_SPACING);
        }
    }

    /// The master aborted a request at `at` (the line is quiet from `at` on, even if the
    /// whole telegram had been announced with [`TxGate::on_request_sent`]): the next request
    /// waits two start pauses from `at`.
    pub fn on_aborted(&mut self, at: Instant) {
        self.last_activity = Some(at);
        self.hold_until(at.plus_micros(self.start_pause_us.saturating_mul(2)));
    }

    /// The last activity seen, if any.
    pub fn last_activity(&self) -> Option<Instant> {
        self.last_activity
    }

    /// Earliest start of the next telegram's start character.
    pub fn earliest_start(&self) -> Instant {
        let after_pause = match self.last_activity {
            Some(last) => last.plus_micros(self.start_pause_us),
            None => Instant::ZERO,
        };
        after_pause.max(self.not_before)
    }

    /// Whether a telegram may start at `now`.
    pub fn may_start(&self, now: Instant) -> bool {
        now >= self.earliest_start()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn char_time_is_11_bits_at_9600() {
        assert_eq!(CHAR_TIME, Duration::from_micros(1146));
        // 3 character times ≈ the manual's 3.44 ms start pause.
        let three = 3.0 * 11.0 / 9600.0;
        assert!((three - 0.00344_f64).abs() < 0.000_01);
        assert_eq!(RESTART_PAUSE, START_PAUSE * 2);
        assert_eq!(char_time(0), Duration::ZERO);
    }

    #[test]
    fn instant_saturates() {
        let max = Instant::from_micros(u64::MAX);
        assert_eq!(max + Duration::from_secs(1), max);
        assert_eq!(Instant::ZERO.saturating_duration_since(max), Duration::ZERO);
        assert_eq!(Instant::from_duration(Duration::MAX), max);
        assert_eq!(Instant::from_millis(3).as_micros(), 3000);
    }
}
