//! The master (controller) state machine, sans-IO.
//!
//! One request is in flight at a time. The driver around it:
//!
//! 1. calls [`Master::send`] with a request telegram,
//! 2. writes what [`Master::poll_transmit`] returns to the port (the bytes start on the wire at
//!    the time given to it),
//! 3. feeds received characters to [`Master::handle_char`] / [`Master::handle_rx`],
//! 4. calls [`Master::handle_timeout`] when the time of [`Master::poll_timeout`] is reached,
//! 5. drains [`Master::poll_event`] after each call.
//!
//! The transaction skeleton (gate, response timeout, retries, give-up, late answers) is
//! [`drive_core::Exchange`], shared with every protocol; this module adds MOVILINK's checks and
//! its cyclic handshake. What it enforces:
//!
//! * a start pause after the last bus activity before each request ([`TxGate`]),
//! * the response timeout (default 50 ms, the manual's maximum response delay) from the end of
//!   the request's BCC to the start of the response's SD2,
//! * acceptance of a response only with SD2, the request's address (for a point-to-point
//!   request to 254 also any unicast address), the request's PDU type and a correct BCC, and
//!   only once the quiet line after its BCC confirmed its end (see [`Receiver`](crate::receiver::Receiver); reported by
//!   [`Master::handle_timeout`] at the time of [`Master::poll_timeout`]),
//! * retries after a timeout or a rejected response, up to [`MasterConfig::retries`] (then
//!   [`MasterEvent::Timeout`], also with 255 retries), each at least two start pauses after the
//!   last bus activity,
//! * no response for group and broadcast requests ([`MasterEvent::Sent`]) and
//!   [`BROADCAST_SPACING`] after them,
//! * the cyclic handshake: a new parameter service in a cyclic PDU type toggles the handshake
//!   bit relative to the drive's last echo; the request is repeated until the drive echoes the
//!   sent bit (service executed) or [`MasterConfig::max_handshake_cycles`] is reached. If the
//!   drive's handshake state is not known yet, one exchange with "no service" learns it first.
//!   If the drive echoes the sent bit with the answer of another service (its bit was not the
//!   one the master remembered, e.g. after a request whose responses were all lost), the
//!   master reports [`RejectReason::ParamMismatch`] and toggles the bit again.
//!   Acyclic PDU types are always executed: their first valid response completes the service.

use core::time::Duration;

use drive_core::{Endpoint, Exchange, ExchangeConfig, ExchangeEvent, Queue, Verdict};
use drive_profile::sew::{Echo, MasterHandshake, Prepared};

use crate::codec;
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, ParamChannel, Telegram};
use crate::receiver::{AddressFilter, RxChar, TelegramFraming};
use crate::timing::{BROADCAST_SPACING, DEFAULT_RESPONSE_TIMEOUT, Instant, LineTiming, TxGate};

/// Configuration of a [`Master`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MasterConfig {
    /// Response timeout: from the end of the request to the start of the response. The manual
    /// allows a drive at most 50 ms ([`DEFAULT_RESPONSE_TIMEOUT`]); a longer value only slows
    /// down error detection (use it for converters with latency, e.g. USB adapters), a shorter
    /// one risks timeouts on answers that are in time.
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or rejected response (0 = one attempt only).
    pub retries: u8,
    /// Cyclic PDU types: how many exchanges to wait for the handshake echo of a parameter
    /// service before reporting [`MasterEvent::ParamNotExecuted`].
    pub max_handshake_cycles: u16,
    /// Character time and start pause.
    pub timing: LineTiming,
}

impl Default for MasterConfig {
    fn default() -> Self {
        Self {
            response_timeout: DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            max_handshake_cycles: 20,
            timing: LineTiming::MOVILINK,
        }
    }
}

impl MasterConfig {
    fn exchange(&self) -> ExchangeConfig {
        ExchangeConfig {
            response_timeout: self.response_timeout,
            retries: self.retries,
            retry_pause: self.timing.restart_pause(),
            unanswered_hold: BROADCAST_SPACING,
            min_idle_gap: Duration::ZERO,
        }
    }
}

/// What happened; drained with [`Master::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MasterEvent {
    /// A valid response to the current request (one per exchange, so a cyclic parameter
    /// service waiting for its handshake reports several; each carries fresh process data).
    Response {
        /// The response.
        telegram: Telegram,
    },
    /// The parameter service of the request completed: the data, or the drive's return code.
    ParamDone(Result<u32, ReturnCode>),
    /// A request without response (group, broadcast) was handed to the port; it is complete.
    Sent {
        /// Its address.
        address: Address,
    },
    /// No valid response after `attempts` transmissions (each timed out or was rejected; the
    /// rejections were reported as [`MasterEvent::Rejected`] before). The request is dropped.
    Timeout {
        /// Transmissions made (up to 256 with 255 retries).
        attempts: u16,
    },
    /// Received characters were dropped, or a response did not match the request.
    Rejected(RejectReason),
    /// Cyclic PDU type: the drive did not echo the handshake bit within
    /// [`MasterConfig::max_handshake_cycles`] exchanges. The request is dropped.
    ParamNotExecuted {
        /// Exchanges made.
        cycles: u16,
    },
}

/// Why [`Master::send`] refused a telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum SendError {
    /// A request is still in flight; wait for its completion event.
    #[error("a request is already in flight")]
    Busy,
    /// The telegram is a response (SD2), not a request.
    #[error("telegram is not a request")]
    NotARequest,
}

#[derive(Debug, Clone, Copy)]
struct Job {
    /// The request as transmitted (handshake bit applied).
    request: Telegram,
    /// The user's parameter channel while a "no service" exchange learns the drive's handshake.
    deferred: Option<ParamChannel>,
    /// Completion waits for a parameter answer (a service in a telegram that gets a response).
    param_job: bool,
    /// Exchanges of a cyclic parameter service.
    cycles: u16,
}

/// The master state machine; see the [module docs](self).
///
/// ```
/// use movilink::master::{Master, MasterConfig, MasterEvent};
/// use movilink::receiver::RxChar;
/// use movilink::timing::Instant;
/// use movilink::{codec, Address, ParamChannel, PduType, Telegram};
///
/// let mut m = Master::new(MasterConfig::default());
/// let drive = Address::new(1).unwrap();
/// let req = Telegram::request(drive, PduType::PARAM_0PD_ACYCLIC).with_param(ParamChannel::read(8318));
/// m.send(req, Instant::ZERO).unwrap();
/// let mut buf = [0u8; 18];
/// let n = m.poll_transmit(Instant::ZERO, &mut buf).unwrap();
/// assert_eq!(n, 12);
/// // The drive answers 5 ms after the request's end (12 characters × 1146 µs).
/// let answer = Telegram::response(drive, PduType::PARAM_0PD_ACYCLIC)
///     .with_param(ParamChannel::read(8318).answer(Ok(1500)));
/// let n = codec::encode(&answer, &mut buf).unwrap();
/// let t0 = 12 * 1146 + 5000;
/// for (i, b) in buf[..n].iter().enumerate() {
///     m.handle_char(RxChar::new(*b, Instant::from_micros(t0 + 1146 * (i as u64 + 1))));
/// }
/// // The response is accepted once the line stayed quiet for a start pause after its BCC.
/// assert_eq!(m.poll_event(), None);
/// let confirm = m.poll_timeout().unwrap();
/// assert_eq!(confirm.as_micros(), t0 + 12 * 1146 + 3440);
/// m.handle_timeout(confirm);
/// assert!(matches!(m.poll_event(), Some(MasterEvent::Response { .. })));
/// assert_eq!(m.poll_event(), Some(MasterEvent::ParamDone(Ok(1500))));
/// assert!(m.is_idle());
/// ```
#[derive(Debug, Clone)]
pub struct Master {
    config: MasterConfig,
    exchange: Exchange<TelegramFraming, MAX_TELEGRAM_LEN>,
    job: Option<Job>,
    /// Every drive's handshake bit (cyclic PDU types).
    handshake: MasterHandshake,
    events: Queue<MasterEvent, 8>,
}

impl Master {
    /// A master with `config`; the bus is assumed idle.
    pub fn new(config: MasterConfig) -> Self {
        let framing = TelegramFraming::new(
            Direction::Response,
            AddressFilter::Master {
                expected: Address::POINT_TO_POINT,
            },
            config.timing,
        );
        Self {
            exchange: Exchange::new(framing, config.exchange()),
            job: None,
            handshake: MasterHandshake::new(),
            events: Queue::new(),
            config,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// Whether no request is in flight (a new one may be sent).
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// Change the response timeout; applies from the next transmission on (e.g. a short one
    /// for an address scan).
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.config.response_timeout = timeout;
        self.exchange.set_response_timeout(timeout);
    }

    /// Change the number of retransmissions; applies to the request in flight too.
    pub fn set_retries(&mut self, retries: u8) {
        self.config.retries = retries;
        self.exchange.set_retries(retries);
    }

    /// Whether a request was transmitted and its response is awaited (as opposed to a request
    /// waiting for the bus, or no request).
    pub fn is_awaiting_response(&self) -> bool {
        self.exchange.is_awaiting_response()
    }

    /// Characters received so far that were never taken as a response because they arrived
    /// while a request waited for the bus or before it had completely left the wire (a
    /// process-data response does not say which request it answers).
    pub fn stale_chars(&self) -> u64 {
        self.exchange.stale_chars()
    }

    /// The bus gate (earliest start of the next telegram).
    pub fn gate(&self) -> &TxGate {
        self.exchange.gate()
    }

    /// Start a request at `now`. See the [module docs](self) for the handshake handling of
    /// cyclic PDU types (the handshake bit of `request` is replaced).
    pub fn send(&mut self, request: Telegram, now: Instant) -> Result<(), SendError> {
        if self.job.is_some() {
            return Err(SendError::Busy);
        }
        if request.direction() != Direction::Request {
            return Err(SendError::NotARequest);
        }
        self.exchange.begin(now).map_err(|_| SendError::Busy)?;
        let mut request = request;
        let address = request.address();
        let cyclic = request.pdu_type().is_cyclic();
        let answered = address.expects_response();
        let mut deferred = None;
        let mut param_job = false;
        if let Some(p) = request.param_mut() {
            param_job = p.management.service_code() != 0 && answered;
            if cyclic {
                match self.handshake.prepare(address.get(), answered, *p) {
                    Prepared::Send(with_bit) => *p = with_bit,
                    Prepared::LearnFirst => {
                        deferred = Some(*p);
                        *p = ParamChannel::no_service();
                    }
                }
            }
        }
        self.job = Some(Job {
            request,
            deferred,
            param_job,
            cycles: 0,
        });
        Ok(())
    }

    /// Replace the process data of the request in flight (used by its next transmission,
    /// e.g. the next cycle of a cyclic parameter service). False if no request is in flight.
    pub fn set_process_data(&mut self, words: &[u16]) -> bool {
        match &mut self.job {
            Some(job) => {
                job.request.set_process_data(words);
                true
            }
            None => false,
        }
    }

    /// The driver could not finish writing the request at `now` (the telegram on the wire is
    /// broken): the request is dropped and the next one waits two start pauses.
    pub fn abort(&mut self, now: Instant) {
        self.job = None;
        self.exchange.abort(now);
    }

    /// The next request telegram, if one is due at `now` (`buf` must hold
    /// [`MAX_TELEGRAM_LEN`] bytes; a smaller buffer gets nothing). Returns the number of
    /// bytes written; they start on the wire at `now`.
    #[inline]
    pub fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let request = self.job.as_ref()?.request;
        if !self.exchange.may_transmit(now) {
            return None;
        }
        let n = codec::encode(&request, buf).ok()?;
        let address = request.address();
        let answered = address.expects_response();
        if answered {
            self.exchange.receiver_mut().framing_mut().filter =
                AddressFilter::Master { expected: address };
        }
        self.exchange.transmitted(n, answered);
        if !answered {
            self.job = None;
            self.events.push(MasterEvent::Sent { address });
        }
        Some(n)
    }

    /// When [`Master::handle_timeout`] (or [`Master::poll_transmit`]) has work to do.
    #[inline]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.job.as_ref()?;
        self.exchange.poll_timeout()
    }

    /// The next event.
    #[inline]
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.events.pop()
    }

    /// Feed characters received from the bus.
    pub fn handle_rx(&mut self, chars: &[RxChar]) {
        for c in chars {
            self.handle_char(*c);
        }
    }

    /// Feed one character received from the bus.
    #[inline]
    pub fn handle_char(&mut self, c: RxChar) {
        if let Some(ev) = self.exchange.handle_char(c) {
            self.on_exchange(ev);
        }
    }

    /// Advance the time to `now`: transmissions may become due, a response may time out.
    #[inline]
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(ev) = self.exchange.handle_timeout(now) {
            self.on_exchange(ev);
        }
    }

    fn on_exchange(&mut self, ev: ExchangeEvent<Telegram, RejectReason>) {
        match ev {
            ExchangeEvent::Frame(t) => self.on_response(t),
            ExchangeEvent::Rejected(r, verdict) => {
                self.events.push(MasterEvent::Rejected(r));
                self.on_verdict(verdict);
            }
            ExchangeEvent::NoAnswer(verdict) => self.on_verdict(verdict),
        }
    }

    fn on_verdict(&mut self, verdict: Verdict) {
        if let Verdict::GiveUp { attempts } = verdict {
            self.events.push(MasterEvent::Timeout { attempts });
            self.job = None;
        }
    }

    /// The current exchange failed: retry or give up.
    fn fail_attempt(&mut self) {
        let verdict = self.exchange.fail();
        self.on_verdict(verdict);
    }

    fn done(&mut self) {
        self.exchange.complete();
        self.job = None;
    }

    fn on_response(&mut self, response: Telegram) {
        let Some(mut job) = self.job else { return };
        let sent_type = job.request.pdu_type();
        if response.pdu_type() != sent_type {
            self.events
                .push(MasterEvent::Rejected(RejectReason::PduTypeMismatch {
                    expected: sent_type.raw(),
                    got: response.pdu_type().raw(),
                }));
            self.fail_attempt();
            return;
        }
        let (Some(sent), Some(got)) = (job.request.param(), response.param()) else {
            self.events
                .push(MasterEvent::Response { telegram: response });
            self.done();
            return;
        };
        if !sent_type.is_cyclic() {
            if job.param_job && !sent.is_answered_by(&got) {
                self.events
                    .push(MasterEvent::Rejected(RejectReason::ParamMismatch));
                self.fail_attempt();
                return;
            }
            self.events
                .push(MasterEvent::Response { telegram: response });
            if job.param_job {
                self.events.push(MasterEvent::ParamDone(got.result()));
            }
            self.done();
            return;
        }
        // Cyclic: learn the drive's handshake bit.
        let address = job.request.address();
        self.handshake
            .learn(address.get(), got.management.handshake());
        self.events
            .push(MasterEvent::Response { telegram: response });
        if let Some(real) = job.deferred.take() {
            if let Some(p) = job.request.param_mut() {
                *p = real.with_handshake(!got.management.handshake());
            }
            self.requeue(job);
        } else if !job.param_job {
            self.done();
        } else if MasterHandshake::echo(&sent, &got) == Echo::Done {
            self.events.push(MasterEvent::ParamDone(got.result()));
            self.done();
        } else {
            if MasterHandshake::echo(&sent, &got) == Echo::Stale {
                // The drive already holds the sent bit from an earlier service (our record of
                // its bit was stale, e.g. after a request whose responses were all lost): it
                // repeats that service's answer and will not execute ours until the bit
                // toggles again.
                self.events
                    .push(MasterEvent::Rejected(RejectReason::ParamMismatch));
                if let Some(p) = job.request.param_mut() {
                    *p = p.with_handshake(!got.management.handshake());
                }
            }
            job.cycles = job.cycles.saturating_add(1);
            if job.cycles >= self.config.max_handshake_cycles {
                self.events
                    .push(MasterEvent::ParamNotExecuted { cycles: job.cycles });
                self.done();
            } else {
                self.requeue(job);
            }
        }
    }

    /// Next exchange of the same job (handshake cycle): a fresh set of attempts.
    fn requeue(&mut self, job: Job) {
        self.job = Some(job);
        self.exchange.requeue();
    }
}

impl Endpoint for Master {
    fn handle_char(&mut self, c: RxChar) {
        Master::handle_char(self, c);
    }

    fn handle_timeout(&mut self, now: Instant) {
        Master::handle_timeout(self, now);
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        Master::poll_transmit(self, now, buf)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        Master::poll_timeout(self)
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.job.as_ref()?;
        self.exchange.poll_quiet_timeout()
    }

    fn max_frame_len(&self) -> usize {
        MAX_TELEGRAM_LEN
    }

    fn frame_left(&mut self, at: Instant) {
        self.exchange.left_at(at);
    }

    fn stale_chars(&self) -> u64 {
        Master::stale_chars(self)
    }
}
