//! Advancing a drive model between requests: while something in it runs on time (a ramp, a
//! holding time, a fault reaction, a watchdog), a protocol's slave wakes it every period.

use core::time::Duration;

use drive_core::Instant;

/// A drive model with work that runs on time.
pub trait Timed {
    /// Whether something in the model runs on time now, so it must be advanced without
    /// requests.
    fn busy(&self) -> bool;

    /// Advance the model to `now`.
    fn tick(&mut self, now: Instant);
}

/// Wakes a [`Timed`] model every period while it is busy: the deadline and timeout of a
/// protocol slave's backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ticker {
    period: Duration,
    /// When the model was last advanced.
    last: Instant,
}

impl Ticker {
    /// A ticker of `period`, the model last advanced at [`Instant::ZERO`].
    pub const fn new(period: Duration) -> Self {
        Self {
            period,
            last: Instant::ZERO,
        }
    }

    /// The next wake-up of `model`: a period after it was last advanced, while it is busy.
    pub fn poll_timeout(&self, model: &impl Timed) -> Option<Instant> {
        model.busy().then(|| self.last + self.period)
    }

    /// Time advanced to `now`: advance `model` if a period has passed since it last was.
    pub fn handle_timeout(&mut self, model: &mut impl Timed, now: Instant) {
        if now >= self.last + self.period {
            model.tick(now);
            self.last = now;
        }
    }

    /// The model was advanced to `now` otherwise (by a request).
    pub fn advanced(&mut self, now: Instant) {
        self.last = now;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Model {
        busy: bool,
        ticks: Vec<Instant>,
    }

    impl Timed for Model {
        fn busy(&self) -> bool {
            self.busy
        }
        fn tick(&mut self, now: Instant) {
            self.ticks.push(now);
        }
    }

    fn ms(n: u64) -> Instant {
        Instant::ZERO + Duration::from_millis(n)
    }

    #[test]
    fn a_busy_model_is_woken_a_period_after_it_was_last_advanced() {
        let mut t = Ticker::new(Duration::from_millis(10));
        let mut m = Model::default();
        assert_eq!(t.poll_timeout(&m), None, "an idle model needs no wake-up");
        m.busy = true;
        assert_eq!(t.poll_timeout(&m), Some(ms(10)));
        t.handle_timeout(&mut m, ms(9));
        assert!(m.ticks.is_empty(), "not due yet");
        t.handle_timeout(&mut m, ms(12));
        assert_eq!(m.ticks, [ms(12)]);
        assert_eq!(t.poll_timeout(&m), Some(ms(22)));
        t.advanced(ms(20));
        assert_eq!(t.poll_timeout(&m), Some(ms(30)));
    }
}
