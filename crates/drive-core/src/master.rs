//! The one master: every protocol's master is a [`Master`], the job/event shell, over a small
//! [`Protocol`] and a carrier for its medium.
//!
//! What the shell does, for every protocol and medium:
//!
//! * one request in flight ([`Master::send`] refuses a second one);
//! * its attempts, retries and give-up ([`MasterEvent::Timeout`] after `retries + 1` failed
//!   attempts, whatever `retries` is);
//! * a request nobody answers (group, broadcast) is complete once it is handed out
//!   ([`MasterEvent::Sent`]);
//! * late answers are never taken for a later request and stale input is counted: the carrier
//!   keeps the rule (see below);
//! * every received frame is judged by the protocol ([`Judgement`]), and the judgement is
//!   carried out the way the medium needs.
//!
//! The **carrier** is the medium's part ([`Carrier`]):
//!
//! * [`Exchange`] for a character framing: the gate and idle gap before every transmission, the
//!   response timeout from the request's end, the receiver, and the stale rule of a line:
//!   characters that arrive while the request waits for the bus or before it has completely
//!   left the wire are counted and never fed to the receiver. On a half-duplex line, a frame in
//!   the answer slot that is not the answer fails the attempt (a retry after the retry pause);
//! * [`CanExchange`] for CAN frames: the response timeout from the hand-over (a protocol may
//!   set each attempt's deadline), the late guard after a give-up or an abort, and the stale
//!   rule of a bus: a response received before the request's first transmission is stale. On
//!   CAN every node's frames interleave, so a frame that is not the answer is counted
//!   ([`Heard`]) and the attempt keeps waiting.
//!
//! The **protocol** ([`Protocol`], with [`CharProtocol`] or [`FrameProtocol`] for the encoding)
//! is only what is specific to it: preparing what the user sends into the request kept in
//! flight ([`Protocol::prepare`]: checks, a handshake bit), whether it is answered, encoding it,
//! judging a received frame against it ([`Protocol::judge`]) and reporting the shell's events in
//! its own vocabulary ([`Protocol::report`]).
//!
//! A protocol crate's master type is this shell with its protocol
//! (`type ModbusMaster = Master<Modbus, Exchange<ModbusFraming, MAX_FRAME>>`), made from the
//! protocol's configuration ([`Configure`]); a character master is an [`Endpoint`], and every
//! master has what the runtime driver needs ([`Control`]).

use core::convert::Infallible;
use core::fmt::Debug;
use core::time::Duration;

use crate::can::{CanExchange, CanFrame};
use crate::char::RxChar;
use crate::endpoint::Endpoint;
use crate::exchange::{Busy, Exchange, ExchangeEvent, Verdict};
use crate::framing::Framing;
use crate::queue::Queue;
use crate::time::Instant;

/// What kind of link failure ended a request, the same for every protocol and medium: what a
/// caller does about it differs (check the drive and the wiring, the line settings, the other
/// programs on the line, the port).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LinkFault {
    /// Nothing answered in any attempt: the drive is off, at another address or another line
    /// setting, or the wiring is broken.
    NoAnswer,
    /// Answers came but kept failing the protocol's checks (checksum, length, parity, gaps):
    /// line settings, termination, or a second master.
    Garbled,
    /// An answer passed the checks but does not answer the request (another kind, a service
    /// not executed): the drive's settings or another master.
    Unexpected,
    /// The port or interface failed or is gone.
    Port,
    /// What came back was the request itself: the adapter echoes what it sends and its echo is
    /// not taken out, so no answer on this line can be trusted ([`crate::rt::echo`]).
    Echo,
}

/// How many events a master keeps until they are polled (the oldest is dropped beyond).
pub const EVENTS: usize = 8;

/// What a protocol tells its [`Master`]; see the [module docs](self).
pub trait Protocol {
    /// What [`Master::send`] takes.
    type Input;
    /// The request as the master keeps it while it is in flight.
    type Request: Copy + Debug;
    /// A received frame as the carrier delivers it (decoded by the framing, or a CAN telegram
    /// decoded by the protocol's master).
    type Frame;
    /// What an answer taken gives.
    type Answer: Copy + Debug;
    /// Why a frame was not taken.
    type Reason: Copy + Debug;
    /// Why the protocol ended a request without a result ([`Infallible`] for most).
    type Failure: Copy + Debug;
    /// What the master reports to its user.
    type Event: Copy + Debug;
    /// Why [`Master::send`] refused.
    type SendError: From<Busy>;

    /// Check `input` and make it the request kept in flight.
    fn prepare(&mut self, input: Self::Input) -> Result<Self::Request, Self::SendError>;

    /// Whether `request` gets an answer (false: group and broadcast requests).
    fn answered(&self, request: &Self::Request) -> bool;

    /// Judge `frame`, received while `request` awaits its answer. The request may be changed
    /// for its next exchange (kept only with [`Judgement::Again`]).
    fn judge(
        &mut self,
        request: &mut Self::Request,
        frame: Self::Frame,
    ) -> Judgement<Self::Answer, Self::Reason, Self::Failure>;

    /// The response timeout or the retries were changed ([`Master::set_response_timeout`],
    /// [`Master::set_retries`]): a protocol that keeps them in its configuration updates it.
    fn settings_changed(&mut self, response_timeout: Duration, retries: u8) {
        let _ = (response_timeout, retries);
    }

    /// Report `event` of `request` to the user: push what it means in the protocol's words to
    /// `events` (nothing, one or several events).
    fn report(
        &mut self,
        request: &Self::Request,
        event: MasterEvent<Self::Answer, Self::Reason, Self::Failure>,
        events: &mut Queue<Self::Event, EVENTS>,
    );
}

/// A protocol on a character line ([`Exchange`]).
pub trait CharProtocol: Protocol {
    /// How its answers are framed.
    type Framing: Framing<Frame = Self::Frame>;

    /// Encode `request` into `buf`: its length, or `None` if it does not fit (it is then not
    /// sent). `framing` is the answer receiver's, to be told what to expect (an address, a
    /// layout) before the answer comes.
    fn encode(
        &mut self,
        request: &Self::Request,
        buf: &mut [u8],
        framing: &mut Self::Framing,
    ) -> Option<usize>;

    /// `c` was heard: the receiver was receiving before it (`was_receiving`) or not, it gave a
    /// frame or a rejection (`event`), and it is receiving now (`receiving`). For protocols
    /// that time frames themselves (USS's residual run time); nothing by default.
    #[inline]
    fn heard(&mut self, c: &RxChar, was_receiving: bool, event: bool, receiving: bool) {
        let _ = (c, was_receiving, event, receiving);
    }
}

/// A protocol on CAN ([`CanExchange`]).
pub trait FrameProtocol: Protocol {
    /// The frame of `request`.
    fn encode(&mut self, request: &Self::Request) -> CanFrame;

    /// When the attempt of `request` handed out at `sent` ends without an answer; by default
    /// `response_timeout` after it.
    fn attempt_deadline(
        &self,
        request: &Self::Request,
        sent: Instant,
        response_timeout: Duration,
    ) -> Instant {
        let _ = request;
        sent.saturating_add(response_timeout)
    }
}

/// What a protocol makes of a frame received while a request awaits its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Judgement<A, R, F> {
    /// The answer to the request: it is done.
    Ours(A),
    /// An answer to the request that calls for another exchange of the same job (MOVILINK's
    /// cyclic handshake): reported, and the request goes out again with a fresh set of
    /// attempts; with a reason, that is reported as a rejection after the answer.
    Again(A, Option<R>),
    /// An answer after which the protocol ends the request without a result (MOVILINK: the
    /// drive never echoed the handshake bit).
    Abandon(A, Option<R>, F),
    /// An answer to an earlier request (a late or repeated one): never this request's.
    Stale(R),
    /// Not an answer to this request: another node's frame, another drive's answer.
    Foreign(R),
    /// An answer that does not fit the request (a wrong echo, a run time exceeded).
    Corrupt(R),
}

/// What a [`Master`] reports; a protocol reports it in its own words
/// ([`Protocol::report`]), or as it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MasterEvent<A, R, F = Infallible> {
    /// The answer to the request: it is done.
    Response(A),
    /// An answer that does not end its request (another exchange of the same job follows).
    Answer(A),
    /// A request nobody answers was handed to the port; it is complete.
    Sent,
    /// No answer taken after `attempts` transmissions; the request is dropped.
    Timeout {
        /// Transmissions made (up to 256 with 255 retries).
        attempts: u16,
    },
    /// A frame was not taken (on a line the attempt failed; a retry or a timeout follows).
    Rejected(R),
    /// The protocol ended the request without a result.
    Failed(F),
}

/// What became of a CAN frame ([`Master::handle_frame`]); a protocol's master counts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Heard<R> {
    /// It was the request's answer (or an answer that continues its job).
    Taken,
    /// No request awaits an answer.
    Unsolicited,
    /// It was received while the request waited to go out or before its first transmission,
    /// or the protocol judged it an answer to an earlier request: counted as stale.
    Stale,
    /// Not taken, for this reason; the attempt keeps waiting.
    Rejected(R),
}

/// The medium's part of a [`Master`]: [`Exchange`] on a line, [`CanExchange`] on CAN.
pub trait Carrier {
    /// Start a request at `now`.
    fn begin(&mut self, now: Instant) -> Result<(), Busy>;
    /// The attempt failed: retry or give up.
    fn fail(&mut self) -> Verdict;
    /// The request is done.
    fn complete(&mut self);
    /// The same job needs another exchange: queued again with a fresh set of attempts.
    fn requeue(&mut self);
    /// The request was dropped at `now` (it broke off, or its caller gave up).
    fn abort(&mut self, now: Instant);
    /// Change the response timeout (from the next transmission on).
    fn set_response_timeout(&mut self, timeout: Duration);
    /// Change the number of retransmissions (the request in flight too).
    fn set_retries(&mut self, retries: u8);
    /// The response timeout.
    fn response_timeout(&self) -> Duration;
    /// The number of retransmissions.
    fn retries(&self) -> u8;
    /// Transmissions of the request in flight so far.
    fn attempts(&self) -> u16;
    /// Input that could not answer the request it arrived with, so far (characters on a line,
    /// frames on CAN).
    fn stale(&self) -> u64;
}

impl<F: Framing, const N: usize> Carrier for Exchange<F, N> {
    fn begin(&mut self, now: Instant) -> Result<(), Busy> {
        Exchange::begin(self, now)
    }
    fn fail(&mut self) -> Verdict {
        Exchange::fail(self)
    }
    fn complete(&mut self) {
        Exchange::complete(self);
    }
    fn requeue(&mut self) {
        Exchange::requeue(self);
    }
    fn abort(&mut self, now: Instant) {
        Exchange::abort(self, now);
    }
    fn set_response_timeout(&mut self, timeout: Duration) {
        Exchange::set_response_timeout(self, timeout);
    }
    fn set_retries(&mut self, retries: u8) {
        Exchange::set_retries(self, retries);
    }
    fn response_timeout(&self) -> Duration {
        self.config().response_timeout
    }
    fn retries(&self) -> u8 {
        self.config().retries
    }
    fn attempts(&self) -> u16 {
        Exchange::attempts(self)
    }
    fn stale(&self) -> u64 {
        self.stale_chars()
    }
}

/// The master shell; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Master<P: Protocol, X> {
    protocol: P,
    carrier: X,
    job: Option<P::Request>,
    events: Queue<P::Event, EVENTS>,
}

/// A protocol whose master is made from a configuration: `Master::new(config)`.
pub trait Configure: Protocol + Sized {
    /// The master's configuration.
    type Config;
    /// The carrier it runs on.
    type Carrier: Carrier;

    /// The protocol's state and the carrier for `config`.
    fn build(config: Self::Config) -> (Self, Self::Carrier);

    /// The configuration.
    fn config(&self) -> &Self::Config;
}

impl<P: Configure> Master<P, P::Carrier> {
    /// A master with `config`; nothing in flight, the bus assumed idle.
    pub fn new(config: P::Config) -> Self {
        let (protocol, carrier) = P::build(config);
        Self::from_parts(protocol, carrier)
    }

    /// The configuration (with the response timeout and retries as last set).
    pub fn config(&self) -> &P::Config {
        self.protocol.config()
    }
}

impl<P: Protocol, X> Master<P, X> {
    /// A master speaking `protocol` over `carrier`; nothing in flight.
    pub fn from_parts(protocol: P, carrier: X) -> Self {
        Self {
            protocol,
            carrier,
            job: None,
            events: Queue::new(),
        }
    }

    /// The protocol's state.
    pub fn protocol(&self) -> &P {
        &self.protocol
    }

    /// The protocol's state, for changing.
    pub fn protocol_mut(&mut self) -> &mut P {
        &mut self.protocol
    }

    /// The carrier (the exchange of the medium).
    pub fn carrier(&self) -> &X {
        &self.carrier
    }

    /// The carrier, for changing (e.g. a receiver's framing).
    pub fn carrier_mut(&mut self) -> &mut X {
        &mut self.carrier
    }

    /// Whether no request is in flight (a new one may be sent).
    #[inline]
    pub fn is_idle(&self) -> bool {
        self.job.is_none()
    }

    /// The request in flight.
    pub fn request(&self) -> Option<&P::Request> {
        self.job.as_ref()
    }

    /// The request in flight, for changing what its next transmission carries.
    pub fn request_mut(&mut self) -> Option<&mut P::Request> {
        self.job.as_mut()
    }

    /// The next event.
    #[inline]
    pub fn poll_event(&mut self) -> Option<P::Event> {
        self.events.pop()
    }

    /// Whether events wait to be polled.
    pub fn has_events(&self) -> bool {
        !self.events.is_empty()
    }

    /// Drop the events not yet polled.
    pub fn clear_events(&mut self) {
        self.events.clear();
    }

    fn report(
        &mut self,
        request: &P::Request,
        event: MasterEvent<P::Answer, P::Reason, P::Failure>,
    ) {
        self.protocol.report(request, event, &mut self.events);
    }
}

impl<P: Protocol, X: Carrier> Master<P, X> {
    /// Start `input` at `now` (see [`Protocol::prepare`]).
    pub fn send(&mut self, input: P::Input, now: Instant) -> Result<(), P::SendError> {
        if self.job.is_some() {
            return Err(Busy.into());
        }
        let request = self.protocol.prepare(input)?;
        self.carrier.begin(now)?;
        self.job = Some(request);
        Ok(())
    }

    /// The request in flight is dropped at `now` (the driver could not finish writing it, or
    /// its caller gave up on it); a late answer to it is never taken for the next one.
    pub fn abort(&mut self, now: Instant) {
        self.job = None;
        self.carrier.abort(now);
    }

    /// Change the response timeout; applies from the next transmission on.
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.carrier.set_response_timeout(timeout);
        self.protocol
            .settings_changed(self.carrier.response_timeout(), self.carrier.retries());
    }

    /// Change the number of retransmissions; applies to the request in flight too.
    pub fn set_retries(&mut self, retries: u8) {
        self.carrier.set_retries(retries);
        self.protocol
            .settings_changed(self.carrier.response_timeout(), self.carrier.retries());
    }

    /// Transmissions of the request in flight so far.
    pub fn attempts(&self) -> u16 {
        self.carrier.attempts()
    }

    /// Input received so far that could not answer the request it arrived with (see the
    /// carrier).
    pub fn stale(&self) -> u64 {
        self.carrier.stale()
    }

    /// Carry out `judgement` of a frame received for `request` (the job in flight); `fail`
    /// says whether a frame that is not the answer fails the attempt (a line) or not (CAN).
    fn carry_out(
        &mut self,
        mut request: P::Request,
        frame: P::Frame,
        fail: bool,
    ) -> Heard<P::Reason> {
        let original = request;
        match self.protocol.judge(&mut request, frame) {
            Judgement::Ours(answer) => {
                self.carrier.complete();
                self.job = None;
                self.report(&request, MasterEvent::Response(answer));
                Heard::Taken
            }
            Judgement::Again(answer, note) => {
                self.report(&request, MasterEvent::Answer(answer));
                if let Some(reason) = note {
                    self.report(&request, MasterEvent::Rejected(reason));
                }
                self.job = Some(request);
                self.carrier.requeue();
                Heard::Taken
            }
            Judgement::Abandon(answer, note, failure) => {
                self.report(&request, MasterEvent::Answer(answer));
                if let Some(reason) = note {
                    self.report(&request, MasterEvent::Rejected(reason));
                }
                self.report(&request, MasterEvent::Failed(failure));
                self.carrier.complete();
                self.job = None;
                Heard::Taken
            }
            Judgement::Stale(reason) => self.not_taken(original, reason, fail, Heard::Stale),
            Judgement::Foreign(reason) | Judgement::Corrupt(reason) => {
                self.not_taken(original, reason, fail, Heard::Rejected(reason))
            }
        }
    }

    fn not_taken(
        &mut self,
        request: P::Request,
        reason: P::Reason,
        fail: bool,
        heard: Heard<P::Reason>,
    ) -> Heard<P::Reason> {
        if fail {
            self.report(&request, MasterEvent::Rejected(reason));
            let verdict = self.carrier.fail();
            self.on_verdict(request, verdict);
        }
        heard
    }

    fn on_verdict(&mut self, request: P::Request, verdict: Verdict) {
        if let Verdict::GiveUp { attempts } = verdict {
            self.job = None;
            self.report(&request, MasterEvent::Timeout { attempts });
        }
    }
}

/// A character master: the shell over an [`Exchange`].
impl<P, F, const N: usize> Master<P, Exchange<F, N>>
where
    P: CharProtocol<Framing = F>,
    F: Framing<Frame = P::Frame>,
    P::Reason: From<F::Error>,
{
    /// Feed one character received from the bus.
    #[inline]
    pub fn handle_char(&mut self, c: RxChar) {
        let was = self.carrier.receiver().is_receiving();
        let ev = self.carrier.handle_char(c);
        let fed = matches!(
            ev,
            Some(ExchangeEvent::Frame(_) | ExchangeEvent::Rejected(..))
        );
        if let Some(ev) = ev {
            self.on_exchange(ev);
        }
        let receiving = self.carrier.receiver().is_receiving();
        self.protocol.heard(&c, was, fed, receiving);
    }

    /// Feed characters received from the bus.
    pub fn handle_rx(&mut self, chars: &[RxChar]) {
        for c in chars {
            self.handle_char(*c);
        }
    }

    /// Advance the time to `now`: a transmission may become due, an answer may be confirmed or
    /// time out.
    #[inline]
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(ev) = self.carrier.handle_timeout(now) {
            self.on_exchange(ev);
        }
    }

    /// The request's frame, if it is due at `now`: written to `buf`, its length returned (its
    /// bytes start on the wire at `now`).
    #[inline]
    pub fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let request = self.job?;
        if !self.carrier.may_transmit(now) {
            return None;
        }
        let framing = self.carrier.receiver_mut().framing_mut();
        let n = self.protocol.encode(&request, buf, framing)?;
        let answered = self.protocol.answered(&request);
        self.carrier.transmitted(n, answered);
        if !answered {
            self.job = None;
            self.report(&request, MasterEvent::Sent);
        }
        Some(n)
    }

    /// When [`Master::handle_timeout`] (or [`Master::poll_transmit`]) has work to do.
    #[inline]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.job.as_ref()?;
        self.carrier.poll_timeout()
    }

    /// The next deadline that needs only a quiet line (see
    /// [`Endpoint::poll_quiet_timeout`]).
    pub fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.job.as_ref()?;
        self.carrier.poll_quiet_timeout()
    }

    /// The frame just transmitted has left the port at `at` (see [`Endpoint::frame_left`]).
    pub fn frame_left(&mut self, at: Instant) {
        self.carrier.left_at(at);
    }

    /// Characters received so far that were never taken as an answer because they arrived
    /// while a request waited for the bus or before it had completely left the wire.
    pub fn stale_chars(&self) -> u64 {
        self.carrier.stale_chars()
    }

    /// Whether a request was transmitted and its answer is awaited (as opposed to a request
    /// waiting for the bus, or no request).
    pub fn is_awaiting_response(&self) -> bool {
        self.carrier.is_awaiting_response()
    }

    /// The bus gate (earliest start of the next frame).
    pub fn gate(&self) -> &crate::gate::TxGate {
        self.carrier.gate()
    }

    fn on_exchange(&mut self, ev: ExchangeEvent<P::Frame, F::Error>) {
        let Some(request) = self.job else { return };
        match ev {
            ExchangeEvent::Frame(frame) => {
                self.carry_out(request, frame, true);
            }
            ExchangeEvent::Rejected(e, verdict) => {
                self.report(&request, MasterEvent::Rejected(e.into()));
                self.on_verdict(request, verdict);
            }
            ExchangeEvent::NoAnswer(verdict) => self.on_verdict(request, verdict),
        }
    }
}

/// A CAN master: the shell over a [`CanExchange`].
impl<P: FrameProtocol> Master<P, CanExchange> {
    /// Feed a frame received at `at` (the end of its last bit), decoded by the protocol's
    /// master: what became of it. A frame received while the request waits to go out or before
    /// its first transmission is stale, however late it is fed.
    pub fn handle_frame(&mut self, frame: P::Frame, at: Instant) -> Heard<P::Reason> {
        self.carrier.advance(at);
        let Some(request) = self.job else {
            return Heard::Unsolicited;
        };
        if self.carrier.is_early(at) {
            self.carrier.count_stale();
            return Heard::Stale;
        }
        let heard = self.carry_out(request, frame, false);
        if matches!(heard, Heard::Stale) {
            self.carrier.count_stale();
        }
        heard
    }

    /// Advance the time to `now`: an attempt may end without an answer (the verdict: a retry,
    /// or the give-up reported as [`MasterEvent::Timeout`]).
    pub fn handle_timeout(&mut self, now: Instant) -> Option<Verdict> {
        self.carrier.advance(now);
        let request = self.job?;
        let verdict = self.carrier.handle_timeout(now)?;
        self.on_verdict(request, verdict);
        Some(verdict)
    }

    /// The request's frame, if it may go out at `now` (queued, and no hold on the bus).
    pub fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        let request = self.job?;
        if !self.carrier.may_transmit(now) {
            return None;
        }
        let frame = self.protocol.encode(&request);
        let answered = self.protocol.answered(&request);
        let sent = self.carrier.now();
        let deadline =
            self.protocol
                .attempt_deadline(&request, sent, self.carrier.config().response_timeout);
        self.carrier.transmitted(answered, deadline);
        if !answered {
            self.job = None;
            self.report(&request, MasterEvent::Sent);
        }
        Some(frame)
    }

    /// When [`Master::handle_timeout`] or [`Master::poll_transmit`] has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.job.as_ref()?;
        self.carrier.poll_timeout()
    }
}

/// What a runtime driver needs of a sans-IO master beyond its medium's interface
/// ([`Endpoint`], [`CanEndpoint`](crate::can::CanEndpoint)): every [`Master`] has it, a
/// protocol master with more than one kind of work in flight (SBus: a scan) implements it
/// itself.
pub trait Control {
    /// Whether nothing is in flight.
    fn is_idle(&self) -> bool;
    /// Drop what is in flight at `now` (a cancelled call left it, or the port failed).
    fn abort(&mut self, now: Instant);
    /// Drop the events not yet polled.
    fn clear_events(&mut self);
    /// Input never taken as an answer because it could not answer the request it arrived with
    /// (cumulative: characters on a line, frames on CAN).
    fn stale(&self) -> u64;
}

impl<P: Protocol, X: Carrier> Control for Master<P, X> {
    #[inline]
    fn is_idle(&self) -> bool {
        Master::is_idle(self)
    }
    fn abort(&mut self, now: Instant) {
        Master::abort(self, now);
    }
    fn clear_events(&mut self) {
        Master::clear_events(self);
    }
    fn stale(&self) -> u64 {
        Master::stale(self)
    }
}

/// A character master is an [`Endpoint`].
impl<P, F, const N: usize> Endpoint for Master<P, Exchange<F, N>>
where
    P: CharProtocol<Framing = F>,
    F: Framing<Frame = P::Frame>,
    P::Reason: From<F::Error>,
{
    #[inline]
    fn handle_char(&mut self, c: RxChar) {
        Self::handle_char(self, c);
    }

    #[inline]
    fn handle_timeout(&mut self, now: Instant) {
        Self::handle_timeout(self, now);
    }

    #[inline]
    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        Self::poll_transmit(self, now, buf)
    }

    #[inline]
    fn poll_timeout(&self) -> Option<Instant> {
        Self::poll_timeout(self)
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        Self::poll_quiet_timeout(self)
    }

    fn max_frame_len(&self) -> usize {
        N
    }

    fn frame_left(&mut self, at: Instant) {
        Self::frame_left(self, at);
    }

    fn stale_chars(&self) -> u64 {
        Self::stale_chars(self)
    }
}

#[cfg(test)]
mod tests;
