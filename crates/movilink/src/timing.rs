//! MOVILINK's bus times, computed from the real line settings.
//!
//! Time is [`Instant`] (nanoseconds since an epoch the caller picks), shared with every
//! drivebus crate; nothing here reads a clock. The times of chapter 4.1/4.2 of the MOVIDRIVE
//! serial communication manual:
//!
//! | time | at 9600 8E1 | rule |
//! |---|---|---|
//! | character time | 1145.833 µs | 11 bits (start, 8 data, even parity, stop) / 9600 baud: [`LineSettings::char_time`] |
//! | [start pause](LineTiming::start_pause) | 3.44 ms | idle time before SD1/SD2: three character times (3.4375 ms), rounded up to 10 µs as the manual prints it |
//! | restart pause | 6.88 ms | after an aborted or failed request: two start pauses |
//! | [`BROADCAST_SPACING`] | 25 ms | from the BCC of a broadcast (or group) request to the next SD1 |
//! | [`MAX_RESPONSE_DELAY`] | 50 ms | from the request's BCC to the response's SD2, at most |
//!
//! MOVILINK runs at 9600 baud, but the times follow whatever line a port is opened with (a
//! pseudo-terminal without parity has 10-bit characters, a test line may run at 19200 baud):
//! [`LineTiming::new`] computes them from [`LineSettings`].
//!
//! The inter-character gap inside a telegram must stay below the start pause; a receiver that
//! sees a gap of a start pause or more treats the telegram as broken (and the character after
//! the gap as a possible new start).
//!
//! A character's time is the moment it was *completely* received (end of its stop bit). The
//! idle gap before a character is therefore `time - previous.time - char_time`.

use core::time::Duration;

pub use drive_core::{Instant, LineSettings, TxGate};

/// The line MOVILINK specifies: 9600 baud, 8 data bits, even parity, 1 stop bit.
pub const LINE: LineSettings = LineSettings::new(9600);
/// Time of one character at 9600 8E1 (11 bits, 1 145 833 ns).
pub const CHAR_TIME: Duration = LINE.char_time();
/// The start pause at 9600 8E1, 3.44 ms as the manual says.
pub const START_PAUSE: Duration = start_pause(&LINE);
/// The restart pause at 9600 8E1: two start pauses (6.88 ms).
pub const RESTART_PAUSE: Duration = LineTiming::MOVILINK.restart_pause();
/// Minimum time from the BCC of a broadcast (or group) request to the next SD1.
pub const BROADCAST_SPACING: Duration = Duration::from_millis(25);
/// The maximum response delay a drive may take (request BCC → response SD2).
pub const MAX_RESPONSE_DELAY: Duration = Duration::from_millis(50);
/// The master's default response timeout: the manual's maximum response delay.
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = MAX_RESPONSE_DELAY;

/// The start pause of `line`: three character times, rounded up to whole 10 µs (the manual's
/// 3.44 ms at 9600 8E1 is 3 × 1.1458 ms = 3.4375 ms rounded the same way).
pub const fn start_pause(line: &LineSettings) -> Duration {
    let three = drive_core::time::duration_nanos(line.char_times(3, 1));
    Duration::from_nanos(three.div_ceil(10_000).saturating_mul(10_000))
}

/// The timing of one MOVILINK line, shared by the receiver and the state machines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LineTiming {
    /// The line settings the times come from.
    pub line: LineSettings,
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
    /// MOVILINK at 9600 8E1: [`CHAR_TIME`] and [`START_PAUSE`].
    pub const MOVILINK: Self = Self::new(LINE);

    /// The times of `line`.
    pub const fn new(line: LineSettings) -> Self {
        let pause = start_pause(&line);
        Self {
            line,
            char_time: line.char_time(),
            start_pause: pause,
            max_gap: pause,
        }
    }

    /// The same timing, accepting gaps up to `max_gap` inside a received telegram (never
    /// less than the start pause).
    #[must_use]
    pub fn with_max_gap(self, max_gap: Duration) -> Self {
        Self {
            max_gap: max_gap.max(self.start_pause),
            ..self
        }
    }

    /// Two start pauses: the silence after an aborted or failed request.
    pub const fn restart_pause(&self) -> Duration {
        self.start_pause.saturating_mul(2)
    }

    /// Wire time of `chars` characters.
    pub const fn wire_time(&self, chars: usize) -> Duration {
        self.line.wire_time(chars)
    }

    /// The receiver's times: a telegram starts after a start pause, breaks off at
    /// [`LineTiming::max_gap`] and is confirmed by a start pause of silence.
    pub fn frame_timing(&self) -> drive_core::FrameTiming {
        drive_core::FrameTiming {
            max_gap: self.max_gap.max(self.start_pause),
            ..drive_core::FrameTiming::uniform(self.char_time, self.start_pause)
        }
    }
}

impl core::fmt::Display for LineTiming {
    /// `19200 8N1: character 572.9 µs, start pause 1.72 ms, gap limit 1.72 ms`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let us = |d: Duration| d.as_nanos() as f64 / 1000.0;
        write!(
            f,
            "{}: character {:.1} µs, start pause {:.2} ms, gap limit {:.2} ms",
            self.line,
            us(self.char_time),
            us(self.start_pause) / 1000.0,
            us(self.max_gap) / 1000.0
        )
    }
}

impl Default for LineTiming {
    fn default() -> Self {
        Self::MOVILINK
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_core::Parity;

    #[test]
    fn times_of_the_manual_at_9600_8e1() {
        assert_eq!(CHAR_TIME, Duration::from_nanos(1_145_833));
        assert_eq!(START_PAUSE, Duration::from_micros(3440));
        assert_eq!(RESTART_PAUSE, Duration::from_micros(6880));
        assert_eq!(
            LineTiming::MOVILINK.wire_time(18),
            Duration::from_micros(20_625)
        );
    }

    #[test]
    fn times_follow_the_line() {
        let fast = LineTiming::new(LineSettings::new(19200));
        assert_eq!(fast.char_time, Duration::from_nanos(572_917));
        assert_eq!(fast.start_pause, Duration::from_micros(1720));
        let pty = LineTiming::new(LINE.with_parity(Parity::None));
        assert_eq!(pty.char_time, Duration::from_nanos(1_041_667));
        assert_eq!(pty.start_pause, Duration::from_micros(3130));
        assert_eq!(
            LineTiming::MOVILINK
                .with_max_gap(Duration::from_millis(20))
                .max_gap,
            Duration::from_millis(20)
        );
        assert_eq!(
            LineTiming::MOVILINK.with_max_gap(Duration::ZERO).max_gap,
            START_PAUSE
        );
        assert_eq!(
            fast.to_string(),
            "19200 8E1: character 572.9 µs, start pause 1.72 ms, gap limit 1.72 ms"
        );
    }
}
