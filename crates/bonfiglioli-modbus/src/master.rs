//! The master state machine, sans-IO: one request in flight over RTU or ASCII, on the shared
//! transaction skeleton [`drive_core::Exchange`] (gate, response timeout, retries, give-up,
//! late answers). This module adds Modbus's checks:
//!
//! * a response is taken only from the addressed drive, for the request's function code (or
//!   its exception, the function code with bit 7 set), and a write's echo must repeat the
//!   request's start address and value; anything else fails the attempt
//!   ([`RejectReason`]) and is retried;
//! * broadcast (address 0) carries writes only, gets no answer and holds the bus for
//!   [`MasterConfig::broadcast_hold`] (the drives execute it meanwhile);
//! * the next request starts no earlier than [`MasterConfig::turnaround`] after the last bus
//!   activity (the manual: at least 2 ms after an answer), and never before the framing's idle
//!   gap (3.5 characters in RTU);
//! * the default response timeout is the manual's 500 ms.

use core::time::Duration;

use drive_core::{
    Endpoint, Exchange, ExchangeConfig, ExchangeEvent, Instant, LineSettings, Queue, RxChar,
    Verdict,
};

use crate::frame::{Address, Request, Response};
use crate::framing::{FrameError, MAX_FRAME, ModbusFraming, Mode, Received, Side, encode_request};

/// The manual's master timeout (ch. 6.8).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(500);
/// The manual's pause after an answer before the next request.
pub const TURNAROUND: Duration = Duration::from_millis(2);
/// How long a broadcast holds the bus: the drives answer a request after 10 ms at the
/// earliest, so they have executed it by then.
pub const BROADCAST_HOLD: Duration = Duration::from_millis(10);

/// Configuration of a [`Master`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MasterConfig {
    /// RTU or ASCII.
    pub mode: Mode,
    /// The line (character time, RTU gaps).
    pub line: LineSettings,
    /// From the end of a request to the start of the answer.
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a rejected answer (0: one attempt).
    pub retries: u8,
    /// Least silence before a request (after an answer or any bus activity).
    pub turnaround: Duration,
    /// Silence after a broadcast before the next request.
    pub broadcast_hold: Duration,
}

impl MasterConfig {
    /// The manual's settings for `mode` on `line`.
    pub const fn new(mode: Mode, line: LineSettings) -> Self {
        Self {
            mode,
            line,
            response_timeout: DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            turnaround: TURNAROUND,
            broadcast_hold: BROADCAST_HOLD,
        }
    }

    fn exchange(&self, framing: &ModbusFraming) -> ExchangeConfig {
        ExchangeConfig {
            response_timeout: self.response_timeout,
            retries: self.retries,
            retry_pause: framing.timing().start_gap.max(self.turnaround),
            unanswered_hold: self.broadcast_hold,
            min_idle_gap: self.turnaround,
        }
    }
}

/// Why an answer was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RejectReason {
    /// The frame was broken (check, length, line error).
    #[error("{0}")]
    Frame(FrameError),
    /// Another drive answered.
    #[error("answer from address {got}, expected {expected}")]
    WrongAddress {
        /// The request's address.
        expected: u8,
        /// The answer's.
        got: u8,
    },
    /// The answer is for another function code.
    #[error("answer for function code {got}, expected {expected}")]
    WrongFunction {
        /// The request's.
        expected: u8,
        /// The answer's.
        got: u8,
    },
    /// A write's echo differs from the request.
    #[error("the write's echo differs from the request")]
    EchoMismatch,
}

/// What happened; drained with [`Master::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MasterEvent {
    /// The answer to the request (possibly an exception answer).
    Response(Response),
    /// A broadcast was handed to the port; it is complete (nobody answers).
    Sent,
    /// No valid answer after `attempts` transmissions; the request is dropped.
    Timeout {
        /// Transmissions made (up to 256 with 255 retries).
        attempts: u16,
    },
    /// An answer was not taken (the attempt failed; a retry or a timeout follows).
    Rejected(RejectReason),
}

/// [`Master::send`] refused a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum SendError {
    /// A request is still in flight.
    #[error("a request is already in flight")]
    Busy,
    /// A broadcast must be a write (ch. 6.1).
    #[error("a broadcast carries writes only")]
    BroadcastRead,
}

/// The master state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Master {
    config: MasterConfig,
    exchange: Exchange<ModbusFraming, MAX_FRAME>,
    job: Option<(Address, Request)>,
    events: Queue<MasterEvent, 8>,
}

impl Master {
    /// A master with `config`; the bus is assumed idle.
    pub fn new(config: MasterConfig) -> Self {
        let framing = ModbusFraming::new(config.mode, Side::Master, &config.line);
        let xc = config.exchange(&framing);
        let exchange = Exchange::new(framing, xc);
        Self {
            config,
            exchange,
            job: None,
            events: Queue::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// Whether no request is in flight.
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// Characters received so far that were never taken as an answer because they arrived
    /// while a request waited for the bus or before it had completely left the wire: an FC 3
    /// or FC 100 answer names neither the parameter nor the data set, so an answer an earlier
    /// program left in the port is told from this request's answer only by when it came.
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

    /// Start `request` to `address` at `now`.
    pub fn send(
        &mut self,
        address: Address,
        request: Request,
        now: Instant,
    ) -> Result<(), SendError> {
        if self.job.is_some() {
            return Err(SendError::Busy);
        }
        if address.is_broadcast() && !request.is_write() {
            return Err(SendError::BroadcastRead);
        }
        self.exchange.begin(now).map_err(|_| SendError::Busy)?;
        self.job = Some((address, request));
        Ok(())
    }

    /// The driver could not finish writing the request: it is dropped.
    pub fn abort(&mut self, now: Instant) {
        self.job = None;
        self.exchange.abort(now);
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.events.pop()
    }

    fn on_exchange(&mut self, ev: ExchangeEvent<Received, FrameError>) {
        match ev {
            ExchangeEvent::Frame(Received::Response(address, response)) => {
                self.on_response(address, response)
            }
            // A request on the line (another master?) is no answer.
            ExchangeEvent::Frame(Received::Request(..)) => {
                self.reject(RejectReason::WrongFunction {
                    expected: self.job.map_or(0, |(_, r)| r.function().code()),
                    got: 0,
                });
            }
            ExchangeEvent::Rejected(e, verdict) => {
                self.events
                    .push(MasterEvent::Rejected(RejectReason::Frame(e)));
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

    fn on_response(&mut self, address: Address, response: Response) {
        let Some((sent_to, request)) = self.job else {
            return;
        };
        if address != sent_to {
            return self.reject(RejectReason::WrongAddress {
                expected: sent_to.get(),
                got: address.get(),
            });
        }
        let fc = request.function().code();
        if response.function_code() != fc {
            return self.reject(RejectReason::WrongFunction {
                expected: fc,
                got: response.function_code(),
            });
        }
        let echo_ok = match (request, response) {
            (Request::WriteWord { start, value }, Response::WriteWord { start: s, value: v }) => {
                (start, value) == (s, v)
            }
            (Request::WriteLong { start, value }, Response::WriteLong { start: s, value: v }) => {
                (start, value) == (s, v)
            }
            (Request::Diagnostics { sub, .. }, Response::Diagnostics { sub: s, .. }) => sub == s,
            _ => true,
        };
        if !echo_ok {
            return self.reject(RejectReason::EchoMismatch);
        }
        self.exchange.complete();
        self.job = None;
        self.events.push(MasterEvent::Response(response));
    }
}

impl Endpoint for Master {
    fn handle_char(&mut self, c: RxChar) {
        if let Some(ev) = self.exchange.handle_char(c) {
            self.on_exchange(ev);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        if let Some(ev) = self.exchange.handle_timeout(now) {
            self.on_exchange(ev);
        }
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let (address, request) = self.job?;
        if !self.exchange.may_transmit(now) {
            return None;
        }
        let n = encode_request(self.config.mode, address, &request, buf).ok()?;
        let answered = !address.is_broadcast();
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
        MAX_FRAME
    }

    fn frame_left(&mut self, at: Instant) {
        self.exchange.left_at(at);
    }

    fn stale_chars(&self) -> u64 {
        self.exchange.stale_chars()
    }
}
