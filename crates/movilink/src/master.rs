//! The master (controller) state machine, sans-IO.
//!
//! One request is in flight at a time. The driver around it:
//!
//! 1. calls `send` with a request telegram,
//! 2. writes what `poll_transmit` returns to the port (the bytes start on the wire at the time
//!    given to it),
//! 3. feeds received characters to `handle_char` / `handle_rx`,
//! 4. calls `handle_timeout` when the time of `poll_timeout` is reached,
//! 5. drains `poll_event` after each call.
//!
//! [`MovilinkMaster`] is drive-core's one master ([`drive_core::master::Master`]: one request
//! in flight, attempts, retries, give-up, late answers, stale characters) on the transaction
//! skeleton of a line ([`drive_core::Exchange`]: gate, response timeout), shared with every
//! protocol; this module is only MOVILINK's part of it, [`Movilink`]: its checks and its
//! cyclic handshake. What it enforces:
//!
//! * a start pause after the last bus activity before each request ([`TxGate`](crate::timing::TxGate)),
//! * the response timeout (default 50 ms, the manual's maximum response delay) from the end of
//!   the request's BCC to the start of the response's SD2,
//! * acceptance of a response only with SD2, the request's address (for a point-to-point
//!   request to 254 also any unicast address), the request's PDU type and a correct BCC, and
//!   only once the quiet line after its BCC confirmed its end (see [`Receiver`](crate::receiver::Receiver); reported by
//!   `handle_timeout` at the time of `poll_timeout`),
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

use drive_core::exchange::Busy;
use drive_core::master::{self, CharProtocol, Configure, Judgement, Protocol};
use drive_core::{Exchange, ExchangeConfig, Queue};
use drive_profile::sew::{Echo, MasterHandshake, Prepared};

use crate::codec;
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, ParamChannel, Telegram};
use crate::receiver::{AddressFilter, TelegramFraming};
use crate::timing::{BROADCAST_SPACING, DEFAULT_RESPONSE_TIMEOUT, LineTiming};

/// Configuration of a [`MovilinkMaster`].
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

/// What happened; drained with the master's `poll_event`.
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

/// Why the master's `send` refused a telegram.
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

impl From<Busy> for SendError {
    fn from(_: Busy) -> Self {
        SendError::Busy
    }
}

/// A request in flight: the telegram as transmitted and where its handshake stands.
#[derive(Debug, Clone, Copy)]
pub struct Job {
    /// The request as transmitted (handshake bit applied).
    request: Telegram,
    /// The user's parameter channel while a "no service" exchange learns the drive's handshake.
    deferred: Option<ParamChannel>,
    /// Completion waits for a parameter answer (a service in a telegram that gets a response).
    param_job: bool,
    /// Exchanges of a cyclic parameter service.
    cycles: u16,
}

impl Job {
    /// The request as it is transmitted next.
    pub fn request(&self) -> &Telegram {
        &self.request
    }

    /// Replace the process data of the request (used by its next transmission, e.g. the next
    /// cycle of a cyclic parameter service).
    pub fn set_process_data(&mut self, words: &[u16]) {
        self.request.set_process_data(words);
    }
}

/// An answer taken: the response telegram, and the parameter service's result when it
/// completed one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reply {
    /// The response.
    pub telegram: Telegram,
    /// The parameter service's result (the data, or the drive's return code).
    pub param: Option<Result<u32, ReturnCode>>,
}

/// A cyclic parameter service that the drive never executed (its handshake bit was not echoed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotExecuted {
    /// Exchanges made.
    pub cycles: u16,
}

/// The master state machine; see the [module docs](self): drive-core's one master with
/// [`Movilink`] on a line, an [`Endpoint`](drive_core::Endpoint). Its
/// [`stale_chars`](master::Master::stale_chars) counts what came before the request had left
/// (a process-data response does not say which request it answers); the request in flight is
/// its [`request_mut`](master::Master::request_mut) (a [`Job`]).
///
/// ```
/// use movilink::master::{MovilinkMaster, MasterConfig, MasterEvent};
/// use movilink::receiver::RxChar;
/// use movilink::timing::Instant;
/// use movilink::{codec, Address, ParamChannel, PduType, Telegram};
///
/// let mut m = MovilinkMaster::new(MasterConfig::default());
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
pub type MovilinkMaster = master::Master<Movilink, Exchange<TelegramFraming, MAX_TELEGRAM_LEN>>;

/// MOVILINK's part of the master: the checks of a response and the cyclic handshake of every
/// drive.
#[derive(Debug, Clone)]
pub struct Movilink {
    config: MasterConfig,
    /// Every drive's handshake bit (cyclic PDU types).
    handshake: MasterHandshake,
}

impl Configure for Movilink {
    type Config = MasterConfig;
    type Carrier = Exchange<TelegramFraming, MAX_TELEGRAM_LEN>;

    fn build(config: MasterConfig) -> (Self, Self::Carrier) {
        let framing = TelegramFraming::new(
            Direction::Response,
            AddressFilter::Master {
                expected: Address::POINT_TO_POINT,
            },
            config.timing,
        );
        let movilink = Movilink {
            config,
            handshake: MasterHandshake::new(),
        };
        (movilink, Exchange::new(framing, config.exchange()))
    }

    fn config(&self) -> &MasterConfig {
        &self.config
    }
}

impl Protocol for Movilink {
    type Input = Telegram;
    type Request = Job;
    type Frame = Telegram;
    type Answer = Reply;
    type Reason = RejectReason;
    type Failure = NotExecuted;
    type Event = MasterEvent;
    type SendError = SendError;

    /// A request telegram, its handshake bit replaced for a cyclic PDU type (see the
    /// [module docs](self)).
    fn prepare(&mut self, request: Telegram) -> Result<Job, SendError> {
        if request.direction() != Direction::Request {
            return Err(SendError::NotARequest);
        }
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
        Ok(Job {
            request,
            deferred,
            param_job,
            cycles: 0,
        })
    }

    #[inline]
    fn answered(&self, job: &Job) -> bool {
        job.request.address().expects_response()
    }

    fn judge(
        &mut self,
        job: &mut Job,
        response: Telegram,
    ) -> Judgement<Reply, RejectReason, NotExecuted> {
        let sent_type = job.request.pdu_type();
        if response.pdu_type() != sent_type {
            return Judgement::Corrupt(RejectReason::PduTypeMismatch {
                expected: sent_type.raw(),
                got: response.pdu_type().raw(),
            });
        }
        let reply = |param| Reply {
            telegram: response,
            param,
        };
        let (Some(sent), Some(got)) = (job.request.param(), response.param()) else {
            return Judgement::Ours(reply(None));
        };
        if !sent_type.is_cyclic() {
            if job.param_job && !sent.is_answered_by(&got) {
                return Judgement::Corrupt(RejectReason::ParamMismatch);
            }
            return Judgement::Ours(reply(job.param_job.then(|| got.result())));
        }
        // Cyclic: learn the drive's handshake bit.
        let address = job.request.address();
        self.handshake
            .learn(address.get(), got.management.handshake());
        if let Some(real) = job.deferred.take() {
            if let Some(p) = job.request.param_mut() {
                *p = real.with_handshake(!got.management.handshake());
            }
            return Judgement::Again(reply(None), None);
        }
        if !job.param_job {
            return Judgement::Ours(reply(None));
        }
        let echo = MasterHandshake::echo(&sent, &got);
        if echo == Echo::Done {
            return Judgement::Ours(reply(Some(got.result())));
        }
        let mut note = None;
        if echo == Echo::Stale {
            // The drive already holds the sent bit from an earlier service (our record of its
            // bit was stale, e.g. after a request whose responses were all lost): it repeats
            // that service's answer and will not execute ours until the bit toggles again.
            note = Some(RejectReason::ParamMismatch);
            if let Some(p) = job.request.param_mut() {
                *p = p.with_handshake(!got.management.handshake());
            }
        }
        job.cycles = job.cycles.saturating_add(1);
        if job.cycles >= self.config.max_handshake_cycles {
            Judgement::Abandon(reply(None), note, NotExecuted { cycles: job.cycles })
        } else {
            Judgement::Again(reply(None), note)
        }
    }

    fn settings_changed(&mut self, response_timeout: Duration, retries: u8) {
        (self.config.response_timeout, self.config.retries) = (response_timeout, retries);
    }

    /// The shell's events in MOVILINK's words: a response, then the parameter service's result
    /// when it completed one.
    fn report(
        &mut self,
        job: &Job,
        event: master::MasterEvent<Reply, RejectReason, NotExecuted>,
        events: &mut Queue<MasterEvent, { master::EVENTS }>,
    ) {
        use master::MasterEvent as Shell;
        match event {
            Shell::Response(reply) | Shell::Answer(reply) => {
                events.push(MasterEvent::Response {
                    telegram: reply.telegram,
                });
                if let Some(result) = reply.param {
                    events.push(MasterEvent::ParamDone(result));
                }
            }
            Shell::Sent => events.push(MasterEvent::Sent {
                address: job.request.address(),
            }),
            Shell::Timeout { attempts } => events.push(MasterEvent::Timeout { attempts }),
            Shell::Rejected(reason) => events.push(MasterEvent::Rejected(reason)),
            Shell::Failed(NotExecuted { cycles }) => {
                events.push(MasterEvent::ParamNotExecuted { cycles });
            }
            _ => {}
        }
    }
}

impl CharProtocol for Movilink {
    type Framing = TelegramFraming;

    /// The request's telegram; the answer receiver expects the request's address.
    #[inline]
    fn encode(
        &mut self,
        job: &Job,
        buf: &mut [u8],
        framing: &mut TelegramFraming,
    ) -> Option<usize> {
        let n = codec::encode(&job.request, buf).ok()?;
        let address = job.request.address();
        if address.expects_response() {
            framing.filter = AddressFilter::Master { expected: address };
        }
        Some(n)
    }
}
