//! The USS master state machine, sans-IO: one telegram in flight, on the shared transaction
//! skeleton [`drive_core::Exchange`] (start delay before every telegram, response timeout,
//! retries, give-up, late answers). This module adds what is USS's:
//!
//! * an answer is taken only with the request's ADR byte (the addressed slave answers with its
//!   address; a mirror telegram comes back with the mirror bit) and in the request's
//!   [`Layout`]; the answer to a mirror telegram must be the request unchanged. Anything else
//!   fails the attempt ([`RejectReason`]) and the telegram is sent again;
//! * every answer must keep the residual run time (see [`framing`](super::framing));
//! * a broadcast (ADR bit 5) gets no answer; it carries no order or a write order only (a
//!   read would have no answer) and holds the bus for [`MasterConfig::broadcast_hold`];
//! * the response timeout defaults to the USS limit of the response delay, 20 ms
//!   ([`DEFAULT_RESPONSE_TIMEOUT`]).
//!
//! Whether a PKW answer is the answer to the order (the drive repeats its previous answer
//! until a new order is done) is the business of the layer above
//! ([`Order::check`](crate::uss::pkw::Order::check)); the master delivers every well-formed
//! answer.

use core::time::Duration;

use drive_core::{
    Endpoint, Exchange, ExchangeConfig, ExchangeEvent, Instant, LineSettings, Queue, RxChar,
    RxEvent, Verdict,
};

use super::framing::{RunClock, Side, UssFraming, UssTiming, judge};
use super::telegram::{Adr, FrameError, Layout, MAX_TELEGRAM, Telegram};
use crate::uss::pkw::{Order, OrderKind, Pkw, ak};

/// The USS limit of a slave's response delay (its processing time: under 20 ms).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(20);

/// Configuration of a [`Master`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MasterConfig {
    /// The line (character time).
    pub line: LineSettings,
    /// The USS times (start delay, character gap, residual run time).
    pub timing: UssTiming,
    /// From the end of a telegram to the start of its answer.
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a rejected answer (0: one attempt).
    pub retries: u8,
    /// Extra silence after a broadcast before the next telegram (beyond the start delay).
    pub broadcast_hold: Duration,
}

impl MasterConfig {
    /// The specification's settings on `line`: 20 ms response timeout, 2 retries, no extra
    /// hold after a broadcast.
    pub const fn new(line: LineSettings) -> MasterConfig {
        MasterConfig {
            line,
            timing: UssTiming::from_line(&line),
            response_timeout: DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            broadcast_hold: Duration::ZERO,
        }
    }

    fn exchange(&self) -> ExchangeConfig {
        ExchangeConfig {
            response_timeout: self.response_timeout,
            retries: self.retries,
            retry_pause: self.timing.start_delay,
            unanswered_hold: self.broadcast_hold,
            min_idle_gap: self.timing.start_delay,
        }
    }
}

/// Why an answer was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum RejectReason {
    /// The characters did not make a telegram (UART error, gap, trailing character, start,
    /// run time).
    #[error("{0}")]
    Frame(FrameError),
    /// The block check character does not match.
    #[error("BCC error: computed {expected:#04x}, received {got:#04x}")]
    Bcc {
        /// Computed over the received bytes.
        expected: u8,
        /// Received.
        got: u8,
    },
    /// LGE does not fit the request's layout.
    #[error("answer with LGE {got}, the layout needs {expected}")]
    WrongLayout {
        /// The layout's LGE.
        expected: u8,
        /// The answer's.
        got: u8,
    },
    /// The answer's ADR byte is not the request's (another slave, or flags changed).
    #[error("answer with ADR {got:?}, expected {expected:?}")]
    WrongAddress {
        /// The request's ADR.
        expected: Adr,
        /// The answer's.
        got: Adr,
    },
    /// The answer to a mirror telegram differs from it.
    #[error("the mirror telegram came back changed")]
    MirrorChanged,
}

impl From<FrameError> for RejectReason {
    fn from(e: FrameError) -> Self {
        match e {
            FrameError::BadBcc { expected, got } => RejectReason::Bcc { expected, got },
            FrameError::BadLength { expected, got } => RejectReason::WrongLayout { expected, got },
            e => RejectReason::Frame(e),
        }
    }
}

/// What happened; drained with [`Master::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MasterEvent {
    /// The answer to the telegram.
    Response(Telegram),
    /// A broadcast was handed to the port; it is complete (nobody answers).
    Sent,
    /// No valid answer after `attempts` transmissions; the telegram is dropped.
    Timeout {
        /// Transmissions made.
        attempts: u16,
    },
    /// An answer was not taken (the attempt failed; a retry or a timeout follows).
    Rejected(RejectReason),
}

/// [`Master::send`] refused a telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum SendError {
    /// A telegram is still in flight.
    #[error("a telegram is already in flight")]
    Busy,
    /// A broadcast carries no order or a write order only: nobody answers it.
    #[error("a broadcast carries no order or a write order, not AK {0}")]
    BroadcastOrder(u8),
    /// A broadcast cannot be a mirror telegram (nobody answers a broadcast).
    #[error("a broadcast cannot be a mirror telegram")]
    BroadcastMirror,
    /// drivebus sends no special telegrams (ADR bit 7).
    #[error("special telegrams (ADR bit 7) are not supported")]
    Special,
}

/// The master state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Master {
    config: MasterConfig,
    exchange: Exchange<UssFraming, MAX_TELEGRAM>,
    clock: RunClock,
    job: Option<Telegram>,
    events: Queue<MasterEvent, 8>,
}

impl Master {
    /// A master with `config`; the bus is assumed idle.
    pub fn new(config: MasterConfig) -> Master {
        let framing = UssFraming::new(Side::Master, Layout::PKW4_PZD2, &config.line)
            .with_timing(config.timing);
        Master {
            exchange: Exchange::new(framing, config.exchange()),
            config,
            clock: RunClock::default(),
            job: None,
            events: Queue::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// Whether no telegram is in flight.
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// Transmissions of the telegram in flight so far.
    pub fn attempts(&self) -> u16 {
        self.exchange.attempts()
    }

    /// Characters received so far that were never taken as an answer because they arrived
    /// while a telegram waited for the bus or before it had completely left the wire (the PZD
    /// of an answer do not say which telegram they answer).
    pub fn stale_chars(&self) -> u64 {
        self.exchange.stale_chars()
    }

    /// Change the response timeout (from the next transmission on).
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.config.response_timeout = timeout;
        self.exchange.set_response_timeout(timeout);
    }

    /// Change the number of retransmissions.
    pub fn set_retries(&mut self, retries: u8) {
        self.config.retries = retries;
        self.exchange.set_retries(retries);
    }

    /// Start `telegram` at `now`; its answer is expected in the same layout.
    pub fn send(&mut self, telegram: Telegram, now: Instant) -> Result<(), SendError> {
        if self.job.is_some() {
            return Err(SendError::Busy);
        }
        let adr = telegram.adr();
        if adr.is_special() {
            return Err(SendError::Special);
        }
        if adr.is_broadcast() {
            if adr.is_mirror() {
                return Err(SendError::BroadcastMirror);
            }
            if let Some(pkw) = telegram.pkw()
                && !broadcastable(&pkw)
            {
                return Err(SendError::BroadcastOrder(pkw.pke.ak()));
            }
        }
        self.exchange.begin(now).map_err(|_| SendError::Busy)?;
        self.exchange
            .receiver_mut()
            .framing_mut()
            .set_layout(telegram.layout());
        self.job = Some(telegram);
        Ok(())
    }

    /// The driver could not finish writing the telegram: it is dropped.
    pub fn abort(&mut self, now: Instant) {
        self.job = None;
        self.exchange.abort(now);
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.events.pop()
    }

    fn on_exchange(&mut self, ev: ExchangeEvent<Telegram, FrameError>) {
        match ev {
            ExchangeEvent::Frame(answer) => {
                match judge(
                    RxEvent::Frame(answer),
                    &self.clock,
                    self.exchange.receiver().framing(),
                ) {
                    RxEvent::Frame(t) => self.on_answer(t),
                    RxEvent::Rejected(e) => self.reject(e.into()),
                }
            }
            ExchangeEvent::Rejected(e, verdict) => {
                self.events.push(MasterEvent::Rejected(e.into()));
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

    fn reject(&mut self, reason: RejectReason) {
        self.events.push(MasterEvent::Rejected(reason));
        let verdict = self.exchange.fail();
        self.on_verdict(verdict);
    }

    fn on_answer(&mut self, answer: Telegram) {
        let Some(request) = self.job else {
            return;
        };
        if answer.adr() != request.adr() {
            return self.reject(RejectReason::WrongAddress {
                expected: request.adr(),
                got: answer.adr(),
            });
        }
        if request.adr().is_mirror() && answer != request {
            return self.reject(RejectReason::MirrorChanged);
        }
        self.exchange.complete();
        self.job = None;
        self.events.push(MasterEvent::Response(answer));
    }
}

impl Endpoint for Master {
    #[inline]
    fn handle_char(&mut self, c: RxChar) {
        let was = self.exchange.receiver().is_receiving();
        let ev = self.exchange.handle_char(c);
        let fed = ev.is_some() && !matches!(ev, Some(ExchangeEvent::NoAnswer(_)));
        // Check a confirmed answer against the telegram that ended before this character.
        if let Some(ev) = ev {
            self.on_exchange(ev);
        }
        let receiving = self.exchange.receiver().is_receiving();
        self.clock.after_char(&c, was, fed, receiving);
    }

    fn handle_timeout(&mut self, now: Instant) {
        if let Some(ev) = self.exchange.handle_timeout(now) {
            self.on_exchange(ev);
        }
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let telegram = self.job?;
        if !self.exchange.may_transmit(now) {
            return None;
        }
        let n = telegram.encode(buf).ok()?;
        let answered = !telegram.adr().is_broadcast();
        self.exchange.transmitted(n, answered);
        if !answered {
            self.job = None;
            self.events.push(MasterEvent::Sent);
        }
        Some(n)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.job?;
        self.exchange.poll_timeout()
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.job?;
        self.exchange.poll_quiet_timeout()
    }

    fn max_frame_len(&self) -> usize {
        MAX_TELEGRAM
    }

    fn frame_left(&mut self, at: Instant) {
        self.exchange.left_at(at);
    }

    fn stale_chars(&self) -> u64 {
        self.exchange.stale_chars()
    }
}

/// Whether a broadcast may carry `pkw`: no order, or a write order.
fn broadcastable(pkw: &Pkw) -> bool {
    pkw.pke.ak() == ak::NONE
        || matches!(
            Order::from_pkw(pkw).map(|o| o.kind()),
            Ok(OrderKind::Write { .. })
        )
}
