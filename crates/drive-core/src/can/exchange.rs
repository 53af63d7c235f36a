//! The transaction skeleton of a CAN master: [`CanExchange`].

use core::time::Duration;

use crate::exchange::{Busy, Verdict};
use crate::master::Carrier;
use crate::time::Instant;

/// The times and limits of a [`CanExchange`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanExchangeConfig {
    /// How long an attempt waits for its answer, from the request's hand-over (a protocol may
    /// set another deadline per attempt).
    pub response_timeout: Duration,
    /// Retransmissions after an attempt without an answer (0: one attempt; 255: 256 attempts,
    /// never more).
    pub retries: u8,
    /// After a request is given up or dropped while on the bus, how long the next transmission
    /// waits, so that a late answer to it arrives while nothing waits (and is counted, not
    /// taken).
    pub late_guard: Duration,
}

/// What a [`CanExchange`] counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct CanTally {
    /// Requests put on the bus (first transmissions).
    pub first_transmissions: u64,
    /// Retransmissions after an attempt without an answer.
    pub retries: u64,
    /// Requests given up.
    pub give_ups: u64,
    /// Responses received while a request waited to go out or before its first transmission.
    pub stale: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting to be transmitted.
    Queued,
    /// Transmitted; the attempt ends at `deadline`.
    Waiting { deadline: Instant },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Job {
    attempts: u16,
    /// When the first attempt was handed out: a frame received before it answers an earlier
    /// request, whenever it is processed.
    first_sent: Instant,
    phase: Phase,
}

/// The CAN counterpart of [`Exchange`](crate::Exchange): one request in flight, its attempts
/// and deadlines, retries, give-up and the late guard, and the stale rule of a bus (a response
/// received before the request's first transmission cannot answer it). The carrier of
/// [`Master`](crate::master::Master) on CAN; time is an argument.
#[derive(Debug, Clone)]
pub struct CanExchange {
    config: CanExchangeConfig,
    now: Instant,
    /// No transmission before this (after a give-up or an abort).
    hold_until: Instant,
    job: Option<Job>,
    tally: CanTally,
}

impl CanExchange {
    /// An exchange with `config`; nothing in flight, no hold.
    pub fn new(config: CanExchangeConfig) -> Self {
        Self {
            config,
            now: Instant::ZERO,
            hold_until: Instant::ZERO,
            job: None,
            tally: CanTally::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CanExchangeConfig {
        &self.config
    }

    /// Change the late guard.
    pub fn set_late_guard(&mut self, late_guard: Duration) {
        self.config.late_guard = late_guard;
    }

    /// What it counted so far.
    pub fn tally(&self) -> CanTally {
        self.tally
    }

    /// The latest time seen.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Advance the time to `now`.
    #[inline]
    pub fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
    }

    /// No transmission before this.
    pub fn hold_until(&self) -> Instant {
        self.hold_until
    }

    /// Hold the next transmission until `until` (replacing the hold).
    pub fn set_hold(&mut self, until: Instant) {
        self.hold_until = until;
    }

    /// Whether a request is in flight.
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// Whether the request in flight waits to be transmitted.
    pub fn is_queued(&self) -> bool {
        matches!(
            self.job,
            Some(Job {
                phase: Phase::Queued,
                ..
            })
        )
    }

    /// When the attempt awaiting its answer ends.
    pub fn deadline(&self) -> Option<Instant> {
        match self.job {
            Some(Job {
                phase: Phase::Waiting { deadline },
                ..
            }) => Some(deadline),
            _ => None,
        }
    }

    /// Move the end of the attempt awaiting its answer to `deadline` (e.g. from the SYNC that
    /// releases a synchronised answer).
    pub fn set_deadline(&mut self, deadline: Instant) {
        if let Some(Job {
            phase: Phase::Waiting { deadline: d },
            ..
        }) = self.job.as_mut()
        {
            *d = deadline;
        }
    }

    /// Whether the request may be transmitted at `now` (it is queued and nothing holds the
    /// bus).
    pub fn may_transmit(&mut self, now: Instant) -> bool {
        self.advance(now);
        self.is_queued() && self.now >= self.hold_until
    }

    /// The request was handed out at the latest time seen; `answered`: whether an answer is
    /// awaited (until `deadline`). A request without answer is complete with this.
    pub fn transmitted(&mut self, answered: bool, deadline: Instant) {
        let Some(job) = self.job.as_mut() else {
            return;
        };
        if job.attempts == 0 {
            self.tally.first_transmissions += 1;
            job.first_sent = self.now;
        }
        job.attempts = job.attempts.saturating_add(1);
        if answered {
            job.phase = Phase::Waiting { deadline };
        } else {
            self.job = None;
        }
    }

    /// Whether a response received at `at` cannot answer the request in flight: it came while
    /// the request waited to go out or before its first transmission.
    pub fn is_early(&self, at: Instant) -> bool {
        self.job
            .is_some_and(|j| j.attempts == 0 || at < j.first_sent)
    }

    /// Count a stale response.
    pub fn count_stale(&mut self) {
        self.tally.stale += 1;
    }

    /// Advance the time to `now`: the attempt awaiting its answer may end (its verdict).
    pub fn handle_timeout(&mut self, now: Instant) -> Option<Verdict> {
        self.advance(now);
        let deadline = self.deadline()?;
        if self.now < deadline {
            return None;
        }
        Some(self.end_attempt())
    }

    /// The attempt ended without an answer: queued again, or given up (the late guard then
    /// holds the next transmission).
    fn end_attempt(&mut self) -> Verdict {
        let Some(job) = self.job.as_mut() else {
            return Verdict::GiveUp { attempts: 0 };
        };
        if job.attempts <= u16::from(self.config.retries) {
            job.phase = Phase::Queued;
            self.tally.retries += 1;
            return Verdict::Retry;
        }
        let attempts = job.attempts;
        self.job = None;
        self.tally.give_ups += 1;
        self.hold_until = self.now.saturating_add(self.config.late_guard);
        Verdict::GiveUp { attempts }
    }

    /// When [`CanExchange::handle_timeout`] or a transmission has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let job = self.job.as_ref()?;
        Some(match job.phase {
            Phase::Waiting { deadline } => deadline,
            Phase::Queued => self.hold_until.later(self.now),
        })
    }
}

impl Carrier for CanExchange {
    fn begin(&mut self, now: Instant) -> Result<(), Busy> {
        if self.job.is_some() {
            return Err(Busy);
        }
        self.advance(now);
        self.job = Some(Job {
            attempts: 0,
            first_sent: Instant::MAX,
            phase: Phase::Queued,
        });
        Ok(())
    }

    fn fail(&mut self) -> Verdict {
        self.end_attempt()
    }

    fn complete(&mut self) {
        self.job = None;
    }

    fn requeue(&mut self) {
        if let Some(job) = self.job.as_mut() {
            *job = Job {
                attempts: 0,
                first_sent: Instant::MAX,
                phase: Phase::Queued,
            };
        }
    }

    /// Dropped at `now`: if it was on the bus, the late guard holds the next transmission.
    fn abort(&mut self, now: Instant) {
        self.advance(now);
        if self.job.is_some_and(|j| j.attempts > 0) {
            self.hold_until = self.now.saturating_add(self.config.late_guard);
        }
        self.job = None;
    }

    fn set_response_timeout(&mut self, timeout: Duration) {
        self.config.response_timeout = timeout;
    }

    fn set_retries(&mut self, retries: u8) {
        self.config.retries = retries;
    }

    fn response_timeout(&self) -> Duration {
        self.config.response_timeout
    }

    fn retries(&self) -> u8 {
        self.config.retries
    }

    fn attempts(&self) -> u16 {
        self.job.map_or(0, |j| j.attempts)
    }

    fn stale(&self) -> u64 {
        self.tally.stale
    }
}
