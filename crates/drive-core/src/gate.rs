//! When the next frame may start on a half-duplex bus.

use core::time::Duration;

use crate::time::Instant;

/// Decides when the next frame may start on the bus.
///
/// Feed it every bus activity (characters sent or received, with the time their last bit
/// ended); it answers the earliest start of the next frame:
///
/// * the idle gap a frame needs after the last activity ([`TxGate::new`]: MOVILINK's start
///   pause, Modbus RTU's 3.5 characters),
/// * longer holds where a protocol asks for them ([`TxGate::hold_until`]): after a request
///   nobody answers (MOVILINK's 25 ms broadcast spacing, Modbus' turnaround delay), after an
///   aborted or failed request ([`TxGate::on_aborted`]).
///
/// ```
/// use core::time::Duration;
/// use drive_core::{Instant, TxGate};
/// let mut gate = TxGate::new(Duration::from_micros(3440));
/// gate.on_activity(Instant::from_micros(10_000));
/// assert_eq!(gate.earliest_start(), Instant::from_micros(13_440));
/// assert!(!gate.may_start(Instant::from_micros(13_439)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TxGate {
    /// The idle gap in nanoseconds (the gate is on every character's path).
    idle_gap_ns: u64,
    last_activity: Option<Instant>,
    not_before: Instant,
}

impl TxGate {
    /// A gate that needs `idle_gap` of silence before each frame, with no activity seen yet
    /// (the bus is assumed idle; call [`TxGate::on_activity`] with the opening time of a port
    /// to require a first gap).
    pub const fn new(idle_gap: Duration) -> Self {
        Self {
            idle_gap_ns: crate::time::duration_nanos(idle_gap),
            last_activity: None,
            not_before: Instant::ZERO,
        }
    }

    /// The idle gap before each frame.
    pub const fn idle_gap(&self) -> Duration {
        Duration::from_nanos(self.idle_gap_ns)
    }

    /// Change the idle gap (the line's settings changed); the history is kept.
    pub fn set_idle_gap(&mut self, idle_gap: Duration) {
        self.idle_gap_ns = crate::time::duration_nanos(idle_gap);
    }

    /// A character ended on the bus at `end` (sent or received).
    #[inline]
    pub fn on_activity(&mut self, end: Instant) {
        self.last_activity = Some(self.last_activity.map_or(end, |last| last.later(end)));
    }

    /// No frame may start before `t`.
    pub fn hold_until(&mut self, t: Instant) {
        self.not_before = self.not_before.later(t);
    }

    /// A complete request ended at `end`; one that gets no response holds the bus for
    /// `unanswered_hold` after its end.
    pub fn on_request_sent(&mut self, end: Instant, answered: bool, unanswered_hold: Duration) {
        self.on_activity(end);
        if !answered {
            self.hold_until(end + unanswered_hold);
        }
    }

    /// A request was aborted at `at` (the line is quiet from `at` on, even if more of it had
    /// been announced with [`TxGate::on_request_sent`]): the next frame waits `pause` from `at`.
    pub fn on_aborted(&mut self, at: Instant, pause: Duration) {
        self.last_activity = Some(at);
        self.hold_until(at + pause);
    }

    /// The last activity seen, if any.
    pub const fn last_activity(&self) -> Option<Instant> {
        self.last_activity
    }

    /// Earliest start of the next frame's first character.
    pub fn earliest_start(&self) -> Instant {
        let after_gap = self
            .last_activity
            .map_or(Instant::ZERO, |last| last.add_nanos(self.idle_gap_ns));
        after_gap.later(self.not_before)
    }

    /// Whether a frame may start at `now`.
    pub fn may_start(&self, now: Instant) -> bool {
        now >= self.earliest_start()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_and_activity() {
        let pause = Duration::from_micros(3440);
        let mut g = TxGate::new(pause);
        assert!(g.may_start(Instant::ZERO));
        g.on_request_sent(Instant::from_millis(10), false, Duration::from_millis(25));
        assert_eq!(g.earliest_start(), Instant::from_millis(35));
        g.on_activity(Instant::from_millis(5)); // older activity does not move it back
        assert_eq!(g.last_activity(), Some(Instant::from_millis(10)));
        g.on_aborted(Instant::from_millis(40), pause * 2);
        assert_eq!(g.earliest_start(), Instant::from_micros(46_880));
        assert_eq!(g.idle_gap(), pause);
    }
}
