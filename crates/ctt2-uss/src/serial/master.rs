//! The USS master state machine, sans-IO: one telegram in flight. It is drive-core's one
//! master ([`drive_core::master::Master`]: one request in flight, attempts, retries, give-up,
//! late answers, stale characters) on the transaction skeleton of a line
//! ([`drive_core::Exchange`]: the start delay before every telegram, the response timeout);
//! this module is only what is USS's, [`Uss`]:
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

use core::convert::Infallible;
use core::time::Duration;

use drive_core::exchange::Busy;
use drive_core::master::{self, CharProtocol, Configure, Judgement, Protocol};
use drive_core::{Exchange, ExchangeConfig, LineSettings, Queue, RxChar};

use super::framing::{RunClock, Side, UssFraming, UssTiming};
use super::telegram::{Adr, FrameError, Layout, MAX_TELEGRAM, Telegram};
use crate::uss::pkw::{Order, OrderKind, Pkw, ak};

/// The USS limit of a slave's response delay (its processing time: under 20 ms).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(20);

/// Configuration of a [`UssMaster`].
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

/// What happened; drained with [`UssMaster`]'s `poll_event`: drive-core's master events with
/// the answer telegram.
///
/// * `Response`: the answer to the telegram;
/// * `Sent`: a broadcast was handed to the port; it is complete (nobody answers);
/// * `Timeout { attempts }`: no valid answer after `attempts` transmissions; the telegram is
///   dropped;
/// * `Rejected`: an answer was not taken (the attempt failed; a retry or a timeout follows).
pub type MasterEvent = master::MasterEvent<Telegram, RejectReason>;

/// [`UssMaster`]'s `send` refused a telegram.
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

impl From<Busy> for SendError {
    fn from(_: Busy) -> Self {
        SendError::Busy
    }
}

/// The master state machine; see the [module docs](self): drive-core's one master with [`Uss`]
/// on a line, an [`Endpoint`](drive_core::Endpoint). [`master::Master::stale_chars`] counts what
/// came before the telegram had left (the PZD of an answer do not say which telegram they
/// answer).
pub type UssMaster = master::Master<Uss, Exchange<UssFraming, MAX_TELEGRAM>>;

/// USS's part of the master: the checks of a telegram and of its answer, and the residual run
/// time of the answer being received.
#[derive(Debug, Clone, Copy)]
pub struct Uss {
    config: MasterConfig,
    clock: RunClock,
}

impl Configure for Uss {
    type Config = MasterConfig;
    type Carrier = Exchange<UssFraming, MAX_TELEGRAM>;

    fn build(config: MasterConfig) -> (Self, Self::Carrier) {
        let framing = UssFraming::new(Side::Master, Layout::PKW4_PZD2, &config.line)
            .with_timing(config.timing);
        let uss = Uss {
            config,
            clock: RunClock::default(),
        };
        (uss, Exchange::new(framing, config.exchange()))
    }

    fn config(&self) -> &MasterConfig {
        &self.config
    }
}

impl Protocol for Uss {
    type Input = Telegram;
    type Request = Telegram;
    type Frame = Telegram;
    type Answer = Telegram;
    type Reason = RejectReason;
    type Failure = Infallible;
    type Event = MasterEvent;
    type SendError = SendError;

    /// A telegram may be sent unless it is special, or a broadcast that is a mirror telegram
    /// or carries an order other than a write.
    fn prepare(&mut self, telegram: Telegram) -> Result<Telegram, SendError> {
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
        Ok(telegram)
    }

    #[inline]
    fn answered(&self, telegram: &Telegram) -> bool {
        !telegram.adr().is_broadcast()
    }

    fn judge(
        &mut self,
        request: &mut Telegram,
        answer: Telegram,
    ) -> Judgement<Telegram, RejectReason, Infallible> {
        // The answer just confirmed must have kept the residual run time.
        if let Err(e) = self.clock.check(&self.config.timing, answer.layout()) {
            return Judgement::Corrupt(e.into());
        }
        if answer.adr() != request.adr() {
            return Judgement::Foreign(RejectReason::WrongAddress {
                expected: request.adr(),
                got: answer.adr(),
            });
        }
        if request.adr().is_mirror() && answer != *request {
            return Judgement::Corrupt(RejectReason::MirrorChanged);
        }
        Judgement::Ours(answer)
    }

    fn settings_changed(&mut self, response_timeout: Duration, retries: u8) {
        (self.config.response_timeout, self.config.retries) = (response_timeout, retries);
    }

    #[inline]
    fn report(
        &mut self,
        _: &Telegram,
        event: MasterEvent,
        events: &mut Queue<MasterEvent, { master::EVENTS }>,
    ) {
        events.push(event);
    }
}

impl CharProtocol for Uss {
    type Framing = UssFraming;

    /// The answer is expected in the telegram's layout.
    #[inline]
    fn encode(
        &mut self,
        telegram: &Telegram,
        buf: &mut [u8],
        framing: &mut UssFraming,
    ) -> Option<usize> {
        framing.set_layout(telegram.layout());
        telegram.encode(buf).ok()
    }

    #[inline]
    fn heard(&mut self, c: &RxChar, was_receiving: bool, event: bool, receiving: bool) {
        self.clock.after_char(c, was_receiving, event, receiving);
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
