//! The master state machine, sans-IO: one request in flight over RTU or ASCII. It is drive-core's
//! one master ([`drive_core::master::Master`]: one request in flight, attempts, retries,
//! give-up, late answers, stale characters) on the transaction skeleton of a line
//! ([`drive_core::Exchange`]: gate, response timeout); this module is only Modbus's part of it,
//! [`Modbus`]:
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
//!
//! What the master counts as stale ([`master::Master::stale_chars`]) matters here: an FC 3 or
//! FC 100 answer names neither the parameter nor the data set, so an answer an earlier program
//! left in the port is told from this request's answer only by when it came.

use core::convert::Infallible;
use core::time::Duration;

use drive_core::exchange::Busy;
use drive_core::master::{self, CharProtocol, Configure, Judgement, Protocol};
use drive_core::{Exchange, ExchangeConfig, LineSettings, Queue};

use crate::frame::{Address, Request, Response};
use crate::framing::{FrameError, MAX_FRAME, ModbusFraming, Mode, Received, Side, encode_request};

/// The manual's master timeout (ch. 6.8).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(500);
/// The manual's pause after an answer before the next request.
pub const TURNAROUND: Duration = Duration::from_millis(2);
/// How long a broadcast holds the bus: the drives answer a request after 10 ms at the
/// earliest, so they have executed it by then.
pub const BROADCAST_HOLD: Duration = Duration::from_millis(10);

/// The longest frame of a parameter exchange, in characters: a 32-bit write (FC 101) and its
/// echo, address, function code, start address (2), value (4) and check: RTU 10 bytes with the
/// CRC (2), ASCII `:`, 9 bytes as 18 hex digits with the LRC, CR LF (ch. 6.7).
pub const fn longest_frame(mode: Mode) -> u32 {
    match mode {
        Mode::Rtu => 10,
        Mode::Ascii => 1 + 2 * 9 + 2,
    }
}

/// The least response timeout a parameter exchange can meet on `line`: the request and the
/// answer (the longest, [`longest_frame`]) at the line's character time and the drive's answer
/// delay ([`ANSWER_DELAY`](crate::slave::ANSWER_DELAY), 10 ms at the earliest, ch. 6.8), rounded
/// up to whole milliseconds. A shorter [`MasterConfig::response_timeout`] cannot be met.
pub fn least_response_timeout(mode: Mode, line: &LineSettings) -> Duration {
    let needed = crate::slave::ANSWER_DELAY + line.char_time() * (2 * longest_frame(mode));
    Duration::from_millis(u64::try_from(needed.as_micros().div_ceil(1000)).unwrap_or(u64::MAX))
}

/// Configuration of a [`ModbusMaster`].
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

impl From<FrameError> for RejectReason {
    fn from(e: FrameError) -> Self {
        RejectReason::Frame(e)
    }
}

/// What happened; drained with [`ModbusMaster::poll_event`](master::Master::poll_event):
/// drive-core's master events with a Modbus response as the answer.
///
/// * `Response`: the answer to the request (possibly an exception answer);
/// * `Sent`: a broadcast was handed to the port; it is complete (nobody answers);
/// * `Timeout { attempts }`: no valid answer after `attempts` transmissions; the request is
///   dropped;
/// * `Rejected`: an answer was not taken (the attempt failed; a retry or a timeout follows).
pub type MasterEvent = master::MasterEvent<Response, RejectReason>;

/// [`ModbusMaster`]'s `send` refused a request.
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

impl From<Busy> for SendError {
    fn from(_: Busy) -> Self {
        SendError::Busy
    }
}

/// Modbus's part of the master: the checks of a request and of its answer.
#[derive(Debug, Clone, Copy)]
pub struct Modbus {
    config: MasterConfig,
}

impl Configure for Modbus {
    type Config = MasterConfig;
    type Carrier = Exchange<ModbusFraming, MAX_FRAME>;

    fn build(config: MasterConfig) -> (Self, Self::Carrier) {
        let framing = ModbusFraming::new(config.mode, Side::Master, &config.line);
        let xc = config.exchange(&framing);
        (Self { config }, Exchange::new(framing, xc))
    }

    fn config(&self) -> &MasterConfig {
        &self.config
    }
}

impl Protocol for Modbus {
    type Input = (Address, Request);
    type Request = (Address, Request);
    type Frame = Received;
    type Answer = Response;
    type Reason = RejectReason;
    type Failure = Infallible;
    type Event = MasterEvent;
    type SendError = SendError;

    fn prepare(
        &mut self,
        (address, request): (Address, Request),
    ) -> Result<Self::Request, SendError> {
        if address.is_broadcast() && !request.is_write() {
            return Err(SendError::BroadcastRead);
        }
        Ok((address, request))
    }

    #[inline]
    fn answered(&self, (address, _): &Self::Request) -> bool {
        !address.is_broadcast()
    }

    fn judge(
        &mut self,
        (sent_to, request): &mut Self::Request,
        frame: Received,
    ) -> Judgement<Response, RejectReason, Infallible> {
        let fc = request.function().code();
        let (address, response) = match frame {
            Received::Response(address, response) => (address, response),
            // A request on the line (another master?) is no answer.
            Received::Request(..) => {
                return Judgement::Foreign(RejectReason::WrongFunction {
                    expected: fc,
                    got: 0,
                });
            }
        };
        if address != *sent_to {
            return Judgement::Foreign(RejectReason::WrongAddress {
                expected: sent_to.get(),
                got: address.get(),
            });
        }
        if response.function_code() != fc {
            return Judgement::Corrupt(RejectReason::WrongFunction {
                expected: fc,
                got: response.function_code(),
            });
        }
        let echo_ok = match (*request, response) {
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
            return Judgement::Corrupt(RejectReason::EchoMismatch);
        }
        Judgement::Ours(response)
    }

    fn settings_changed(&mut self, response_timeout: Duration, retries: u8) {
        (self.config.response_timeout, self.config.retries) = (response_timeout, retries);
    }

    #[inline]
    fn report(
        &mut self,
        _: &Self::Request,
        event: MasterEvent,
        events: &mut Queue<MasterEvent, { master::EVENTS }>,
    ) {
        events.push(event);
    }
}

impl CharProtocol for Modbus {
    type Framing = ModbusFraming;

    #[inline]
    fn encode(
        &mut self,
        (address, request): &Self::Request,
        buf: &mut [u8],
        _: &mut ModbusFraming,
    ) -> Option<usize> {
        encode_request(self.config.mode, *address, request, buf).ok()
    }
}

/// The master state machine; see the [module docs](self): drive-core's one master with
/// [`Modbus`] on a line. It is an [`Endpoint`](drive_core::Endpoint); [`master::Master::send`]
/// takes the address and the request.
pub type ModbusMaster = master::Master<Modbus, Exchange<ModbusFraming, MAX_FRAME>>;

#[cfg(test)]
mod least_timeout_tests {
    use super::*;
    use drive_core::Parity;

    #[test]
    fn the_least_timeout_is_an_exchange_at_the_baud_rate() {
        let rtu = Mode::Rtu.line_settings(2400, Parity::None);
        // 11 bits at 2400 baud: 4.583 ms; 2 × 10 characters + 10 ms = 101.7 ms.
        assert_eq!(
            least_response_timeout(Mode::Rtu, &rtu),
            Duration::from_millis(102)
        );
        let ascii = Mode::Ascii.line_settings(9600, Parity::Even);
        // 10 bits at 9600 baud: 1.042 ms; 2 × 21 characters + 10 ms = 53.75 ms.
        assert_eq!(
            least_response_timeout(Mode::Ascii, &ascii),
            Duration::from_millis(54)
        );
        // The manual's 500 ms (the default) covers every rate the drive has.
        for (_, baud) in drive_profile::bonfiglioli::link::BAUD_RATES {
            for mode in [Mode::Rtu, Mode::Ascii] {
                let l = mode.line_settings(baud, Parity::Even);
                assert!(least_response_timeout(mode, &l) < DEFAULT_RESPONSE_TIMEOUT);
            }
        }
    }
}
