//! The master's transaction skeleton: one request in flight, its attempts, retries, give-up and
//! the bus timing around it, for any [`Framing`].
//!
//! A protocol's master keeps what is specific to it (building the request, matching an answer
//! to it, handshakes) and leaves the rest to an [`Exchange`]:
//!
//! 1. [`Exchange::begin`] starts a request;
//! 2. when [`Exchange::may_transmit`] says so, the protocol encodes the request and reports it
//!    with [`Exchange::transmitted`] (the gate then knows the bus is busy until its end);
//! 3. received characters go to [`Exchange::handle_char`], the passing of time to
//!    [`Exchange::handle_timeout`] at [`Exchange::poll_timeout`];
//! 4. each call may return an [`ExchangeEvent`]: a confirmed frame for the protocol to judge
//!    ([`Exchange::complete`] it, [`Exchange::requeue`] the next exchange of the same job, or
//!    [`Exchange::fail`] the attempt), a rejection, or no answer in time;
//! 5. as an [`Endpoint`](crate::Endpoint), the master forwards
//!    [`Endpoint::frame_left`](crate::Endpoint::frame_left) to [`Exchange::left_at`] (a port
//!    without wire time says when a frame has left) and reports [`Exchange::stale_chars`].
//!
//! What it enforces:
//!
//! * the idle gap before every transmission (the framing's start gap, at least
//!   [`ExchangeConfig::min_idle_gap`]), `retry_pause` after a failed attempt or an abort,
//!   `unanswered_hold` after a request that gets no response ([`TxGate`]);
//! * the response timeout, from the request's end to the start of the answer's first
//!   character (the answer's first character may complete up to one character time later);
//! * at most `retries` retransmissions: after `retries + 1` failed attempts the request is
//!   given up ([`Verdict::GiveUp`]), whatever `retries` is (255 means 256 attempts, not
//!   forever);
//! * late answers are never matched to a later request: a character that starts after the
//!   give-up time fails the attempt, the receiver forgets everything when the next request is
//!   transmitted, characters arriving while no request waits are only bus activity (they delay
//!   the next transmission until the line was quiet for the idle gap), and the protocol checks
//!   that a frame answers *its* request before completing it;
//! * stale characters are never an answer: a character that arrives while the request waits
//!   for the bus, or before the request has completely left the wire (its start plus its
//!   length × character time, or the instant a port without wire time reports with
//!   [`Exchange::left_at`]), cannot answer it. It is bus activity, never fed to the receiver,
//!   and counted ([`Exchange::stale_chars`]). Many answers do not name what they answer
//!   (Modbus FC 3, MOVILINK process data, USS PZD), so this rule, not the protocol's checks,
//!   is what keeps an answer an earlier program left in the port from being taken.

use core::time::Duration;

use crate::char::RxChar;
use crate::framing::{Framing, Receiver, RxEvent};
use crate::gate::TxGate;
use crate::time::Instant;

/// The times and limits of an [`Exchange`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ExchangeConfig {
    /// From the end of a request to the start of its answer.
    pub response_timeout: Duration,
    /// Retransmissions after a failed attempt (0: one attempt only).
    pub retries: u8,
    /// Silence the bus needs after a failed attempt or an aborted request before the next
    /// transmission (MOVILINK: two start pauses).
    pub retry_pause: Duration,
    /// How long a request that gets no response (group, broadcast) holds the bus after its end.
    pub unanswered_hold: Duration,
    /// The least idle time before any transmission, beyond the framing's own start gap (Modbus:
    /// 2 ms after an answer, while ASCII framing itself needs no gap); zero for none.
    pub min_idle_gap: Duration,
}

/// What happens after a failed attempt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Verdict {
    /// The request is transmitted again when the bus allows.
    Retry,
    /// The request is dropped after this many transmissions.
    GiveUp {
        /// Transmissions made.
        attempts: u16,
    },
}

/// What a character or a timeout meant for the request in flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExchangeEvent<Fr, E> {
    /// A confirmed frame arrived while the answer was awaited; the protocol decides whether it
    /// answers the request ([`Exchange::complete`], [`Exchange::requeue`]) or not
    /// ([`Exchange::fail`]).
    Frame(Fr),
    /// The receiver dropped characters of the answer; the attempt failed.
    Rejected(E, Verdict),
    /// Nothing started in time; the attempt failed.
    NoAnswer(Verdict),
}

/// [`Exchange::begin`] while a request is in flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("a request is already in flight")]
pub struct Busy;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting for the bus to allow the (re)transmission.
    Queued,
    /// Transmitted; it has completely left the wire at `left` (characters completing by then
    /// are stale); give up at `give_up` unless an answer is being received.
    Waiting { left: Instant, give_up: Instant },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Nanos {
    char_time: u64,
    response_timeout: u64,
    retry_pause: u64,
    unanswered_hold: u64,
}

impl Nanos {
    fn of(config: &ExchangeConfig, char_time: Duration) -> Self {
        use crate::time::duration_nanos;
        Self {
            char_time: duration_nanos(char_time),
            response_timeout: duration_nanos(config.response_timeout),
            retry_pause: duration_nanos(config.retry_pause),
            unanswered_hold: duration_nanos(config.unanswered_hold),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Job {
    attempts: u16,
    phase: Phase,
}

/// The transaction skeleton; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Exchange<F: Framing, const N: usize> {
    config: ExchangeConfig,
    /// The configuration's and the line's times in nanoseconds (on every transmission's path).
    ns: Nanos,
    receiver: Receiver<F, N>,
    gate: TxGate,
    now: Instant,
    job: Option<Job>,
    /// Characters that could not answer the request they arrived with (see the module docs).
    stale: u64,
}

impl<F: Framing, const N: usize> Exchange<F, N> {
    /// An exchange receiving answers with `framing`; the bus is assumed idle.
    pub fn new(framing: F, config: ExchangeConfig) -> Self {
        let receiver = Receiver::new(framing);
        let gate = TxGate::new(receiver.timing().start_gap.max(config.min_idle_gap));
        Self {
            ns: Nanos::of(&config, receiver.timing().char_time),
            config,
            receiver,
            gate,
            now: Instant::ZERO,
            job: None,
            stale: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ExchangeConfig {
        &self.config
    }

    /// Change the response timeout; applies from the next transmission on.
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.config.response_timeout = timeout;
        self.ns.response_timeout = crate::time::duration_nanos(timeout);
    }

    /// Change the number of retransmissions; applies to the request in flight too.
    pub fn set_retries(&mut self, retries: u8) {
        self.config.retries = retries;
    }

    /// The answer receiver (e.g. to set the address a master expects).
    pub fn receiver(&self) -> &Receiver<F, N> {
        &self.receiver
    }

    /// The answer receiver, for changing (e.g. the address a master expects). After changing
    /// its framing's times call [`Exchange::refresh_timing`], not the receiver's own.
    pub fn receiver_mut(&mut self) -> &mut Receiver<F, N> {
        &mut self.receiver
    }

    /// Read the framing's times again (the line's settings changed): the receiver's, the
    /// character time of the exchange and the gate's idle gap.
    pub fn refresh_timing(&mut self) {
        self.receiver.refresh_timing();
        let timing = *self.receiver.timing();
        self.ns = Nanos::of(&self.config, timing.char_time);
        self.gate
            .set_idle_gap(timing.start_gap.max(self.config.min_idle_gap));
    }

    /// The bus gate.
    pub fn gate(&self) -> &TxGate {
        &self.gate
    }

    /// The latest time seen.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Whether no request is in flight.
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// Whether a request was transmitted and its answer is awaited.
    pub fn is_awaiting_response(&self) -> bool {
        matches!(
            self.job,
            Some(Job {
                phase: Phase::Waiting { .. },
                ..
            })
        )
    }

    /// Characters received so far that could not answer the request they arrived with: while
    /// it waited for the bus, or before it had completely left the wire (an answer an earlier
    /// program left in the port, a late answer to an earlier attempt, another master). They
    /// were never fed to the receiver.
    pub fn stale_chars(&self) -> u64 {
        self.stale
    }

    /// When the request in flight has completely left the wire, while its answer is awaited:
    /// its start plus its length × character time unless [`Exchange::left_at`] said otherwise.
    pub fn request_left(&self) -> Option<Instant> {
        match self.job {
            Some(Job {
                phase: Phase::Waiting { left, .. },
                ..
            }) => Some(left),
            _ => None,
        }
    }

    /// The request just transmitted finished leaving the port at `at`, not at the end of its
    /// wire time: a port that carries frames without wire time (a pseudo-terminal, an
    /// in-memory pipe) has delivered it once the write returned, and the other side may answer
    /// from then on. Characters completing at or before `at` are stale. The response timeout
    /// still counts from the end of the wire time. No effect unless an answer is awaited.
    pub fn left_at(&mut self, at: Instant) {
        if let Some(Job {
            phase: Phase::Waiting { left, .. },
            ..
        }) = self.job.as_mut()
        {
            *left = at;
        }
    }

    /// Transmissions of the current exchange so far.
    pub fn attempts(&self) -> u16 {
        self.job.map_or(0, |j| j.attempts)
    }

    /// Start a request at `now`.
    pub fn begin(&mut self, now: Instant) -> Result<(), Busy> {
        if self.job.is_some() {
            return Err(Busy);
        }
        self.advance(now);
        self.job = Some(Job {
            attempts: 0,
            phase: Phase::Queued,
        });
        Ok(())
    }

    /// Whether the request should be transmitted now (it is queued and the bus allows it).
    pub fn may_transmit(&mut self, now: Instant) -> bool {
        self.advance(now);
        matches!(
            self.job,
            Some(Job {
                phase: Phase::Queued,
                ..
            })
        ) && self.gate.may_start(self.now)
    }

    /// The request was handed to the port at the latest time given, `chars` characters long;
    /// `answered`: whether a response is expected. Returns the end of its last character. A
    /// request without response is complete with this.
    pub fn transmitted(&mut self, chars: usize, answered: bool) -> Instant {
        let n = u64::try_from(chars).unwrap_or(u64::MAX);
        let end = self.now.add_nanos(self.ns.char_time.saturating_mul(n));
        self.gate.on_activity(end);
        if !answered {
            self.gate.hold_until(end.add_nanos(self.ns.unanswered_hold));
        }
        let Some(job) = self.job.as_mut() else {
            return end;
        };
        job.attempts = job.attempts.saturating_add(1);
        if answered {
            job.phase = Phase::Waiting {
                left: end,
                give_up: end
                    .add_nanos(self.ns.response_timeout)
                    .add_nanos(self.ns.char_time),
            };
            self.receiver.reset();
        } else {
            self.job = None;
        }
        end
    }

    /// The protocol refused a frame (or the attempt failed otherwise): retry or give up. Either
    /// way the next transmission waits `retry_pause` after the last bus activity (what failed
    /// may still be on the line, whichever request comes next).
    pub fn fail(&mut self) -> Verdict {
        let Some(job) = self.job.as_mut() else {
            return Verdict::GiveUp { attempts: 0 };
        };
        let last = self.gate.last_activity().unwrap_or(self.now);
        self.gate.hold_until(last.add_nanos(self.ns.retry_pause));
        if job.attempts <= u16::from(self.config.retries) {
            job.phase = Phase::Queued;
            Verdict::Retry
        } else {
            let attempts = job.attempts;
            self.job = None;
            Verdict::GiveUp { attempts }
        }
    }

    /// The request is done (its answer was accepted).
    pub fn complete(&mut self) {
        self.job = None;
    }

    /// The same job needs another exchange (e.g. a handshake cycle): queued again with a fresh
    /// set of attempts.
    pub fn requeue(&mut self) {
        if let Some(job) = self.job.as_mut() {
            job.attempts = 0;
            job.phase = Phase::Queued;
        }
    }

    /// The request could not be written completely at `now` (the frame on the wire is broken):
    /// it is dropped and the next transmission waits `retry_pause`.
    pub fn abort(&mut self, now: Instant) {
        self.advance(now);
        self.job = None;
        self.receiver.reset();
        self.gate.on_aborted(self.now, self.config.retry_pause);
    }

    /// When [`Exchange::handle_timeout`] (or a transmission) has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let job = self.job.as_ref()?;
        Some(match job.phase {
            Phase::Queued => self.gate.earliest_start().later(self.now),
            Phase::Waiting { give_up, .. } => self.receiver.poll_timeout().unwrap_or(give_up),
        })
    }

    /// The next deadline that needs only a quiet line: the transmission falling due, or the
    /// confirmation of a complete answer (see [`crate::Endpoint::poll_quiet_timeout`]).
    pub fn poll_quiet_timeout(&self) -> Option<Instant> {
        let job = self.job.as_ref()?;
        match job.phase {
            Phase::Queued => Some(self.gate.earliest_start().later(self.now)),
            Phase::Waiting { .. } => self.receiver.pending_confirmation(),
        }
    }

    /// The give-up time while an answer is awaited and none is being received: the deadline a
    /// virtual clock must not jump to (a real answer may still come).
    pub fn response_deadline(&self) -> Option<Instant> {
        match self.job {
            Some(Job {
                phase: Phase::Waiting { give_up, .. },
                ..
            }) if !self.receiver.is_receiving() => Some(give_up),
            _ => None,
        }
    }

    /// Feed one character received from the bus. While no request is in flight it is bus
    /// activity only; while the request waits for the bus or has not completely left the wire
    /// it is stale (counted, never an answer).
    #[inline]
    pub fn handle_char(&mut self, c: RxChar) -> Option<ExchangeEvent<F::Frame, F::Error>> {
        self.advance(c.time);
        self.gate.on_activity(c.time);
        let give_up = match self.job?.phase {
            Phase::Waiting { left, give_up } if c.time > left => give_up,
            // Queued, or it completed while the request was still on the wire: it cannot
            // answer it (an earlier answer left in the port, a late one, another master).
            _ => {
                self.stale = self.stale.saturating_add(1);
                return None;
            }
        };
        if !self.receiver.is_receiving() && c.time > give_up {
            // The answer did not start in time: this character is too late.
            return Some(ExchangeEvent::NoAnswer(self.fail()));
        }
        match self.receiver.handle_char(c)? {
            RxEvent::Rejected(e) => Some(ExchangeEvent::Rejected(e, self.fail())),
            RxEvent::Frame(f) => Some(ExchangeEvent::Frame(f)),
        }
    }

    /// Advance the time to `now`: a transmission may become due, an answer may be confirmed or
    /// time out.
    pub fn handle_timeout(&mut self, now: Instant) -> Option<ExchangeEvent<F::Frame, F::Error>> {
        self.advance(now);
        let give_up = self.give_up()?;
        match self.receiver.handle_timeout(self.now) {
            Some(RxEvent::Rejected(e)) => Some(ExchangeEvent::Rejected(e, self.fail())),
            Some(RxEvent::Frame(f)) => Some(ExchangeEvent::Frame(f)),
            None if !self.receiver.is_receiving() && self.now >= give_up => {
                Some(ExchangeEvent::NoAnswer(self.fail()))
            }
            None => None,
        }
    }

    #[inline]
    fn give_up(&self) -> Option<Instant> {
        match self.job {
            Some(Job {
                phase: Phase::Waiting { give_up, .. },
                ..
            }) => Some(give_up),
            _ => None,
        }
    }

    #[inline]
    fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
    }
}

#[cfg(test)]
mod tests;
