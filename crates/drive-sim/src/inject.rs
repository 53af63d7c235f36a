//! Communication fault injection: delayed and dropped answers, with a seeded RNG.
//!
//! Protocol front-ends ask [`FaultInjector::should_respond`] once per request they would answer
//! and honour the result, so that masters can be tested against slow and silent drives. The
//! random draws come from drivebus's one seeded generator, [`drive_core::SplitMix64`].

use std::time::Duration;

use drive_core::{Instant, SplitMix64};

/// What a front-end should do with a request it would answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Response {
    /// Answer at once.
    Now,
    /// Answer after this delay.
    After(Duration),
    /// Do not answer at all.
    Drop,
}

/// The seed [`FaultInjector::default`] uses.
pub const DEFAULT_SEED: u64 = 0x6472_6976_6562_7573; // "drivebus"

/// Knobs for delayed and dropped answers.
///
/// Decision order in [`FaultInjector::should_respond`]: a pending [`FaultInjector::drop_next`]
/// count, then an offline window, then the drop probability (one RNG draw per call while the
/// probability is above 0), then the response delay.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultInjector {
    rng: SplitMix64,
    delay: Duration,
    drop_probability: f64,
    drop_next: u32,
    offline_until: Option<Instant>,
}

impl Default for FaultInjector {
    fn default() -> FaultInjector {
        FaultInjector::new(DEFAULT_SEED)
    }
}

impl FaultInjector {
    /// No faults, RNG seeded with `seed`.
    pub const fn new(seed: u64) -> FaultInjector {
        FaultInjector {
            rng: SplitMix64::new(seed),
            delay: Duration::ZERO,
            drop_probability: 0.0,
            drop_next: 0,
            offline_until: None,
        }
    }

    /// Re-seed the RNG.
    pub fn reseed(&mut self, seed: u64) {
        self.rng = SplitMix64::new(seed);
    }

    /// Answer every request this much later.
    pub fn set_response_delay(&mut self, delay: Duration) {
        self.delay = delay;
    }

    /// The configured response delay.
    pub const fn response_delay(&self) -> Duration {
        self.delay
    }

    /// Drop each answer with probability `p` (clamped to `0..=1`; NaN counts as 0).
    pub fn set_drop_probability(&mut self, p: f64) {
        self.drop_probability = if p.is_nan() { 0.0 } else { p.clamp(0.0, 1.0) };
    }

    /// The configured drop probability.
    pub const fn drop_probability(&self) -> f64 {
        self.drop_probability
    }

    /// Drop the next `n` answers (replaces any pending count).
    pub fn drop_next(&mut self, n: u32) {
        self.drop_next = n;
    }

    /// Answers still to be dropped by [`FaultInjector::drop_next`].
    pub const fn pending_drops(&self) -> u32 {
        self.drop_next
    }

    /// Drop every answer until `until` (exclusive); `None` ends an offline window.
    pub fn set_offline_until(&mut self, until: Option<Instant>) {
        self.offline_until = until;
    }

    /// Remove every injected communication fault (the RNG state is kept).
    pub fn clear(&mut self) {
        self.delay = Duration::ZERO;
        self.drop_probability = 0.0;
        self.drop_next = 0;
        self.offline_until = None;
    }

    /// Decide about one answer at time `now`.
    pub fn should_respond(&mut self, now: Instant) -> Response {
        if self.drop_next > 0 {
            self.drop_next -= 1;
            return Response::Drop;
        }
        if self.offline_until.is_some_and(|until| now < until) {
            return Response::Drop;
        }
        if self.drop_probability > 0.0 && self.rng.next_f64() < self.drop_probability {
            return Response::Drop;
        }
        if self.delay.is_zero() {
            Response::Now
        } else {
            Response::After(self.delay)
        }
    }
}
