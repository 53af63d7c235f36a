//! The drive (slave) protocol state machine, sans-IO.
//!
//! It frames requests, decides whether to answer, runs the cyclic handshake, delegates the
//! parameter services and process data to a [`Backend`] (the simulated drive) and builds the
//! response.
//!
//! * Addresses: its own address (P810) and 254 (point-to-point) are answered; its group (P811,
//!   100 = no group) and 255 (broadcast) are executed without an answer.
//! * Point-to-point: the response carries address 254 like the request by default, so that a
//!   master checking "response address = request address" accepts it; with
//!   [`SlaveConfig::reply_p2p_with_own_address`] it carries the own address instead (the manual
//!   says the master learns from the address byte which drive answered, but does not say
//!   which of the two a drive sends).
//! * Cyclic PDU types: the parameter service runs only when the handshake bit differs from the
//!   one of the last executed service (initially 0, as in Bild 22 of the manual); otherwise the
//!   previous answer is sent again unchanged. Acyclic types always run the service.
//! * An undefined service code is answered with [`ReturnCode::ILLEGAL_SERVICE_CODING`];
//!   "no service" is echoed without calling the backend.
//! * A request is accepted once the quiet line after its BCC confirmed its end (a character
//!   right after the BCC rejects it, see [`Receiver`]); this happens in
//!   [`Slave::handle_timeout`] at the time of [`Slave::poll_timeout`], a start pause after
//!   the request's BCC, which is when the response is due. If other characters appear on the
//!   bus before the response was taken with [`Slave::poll_transmit`], it is dropped.
//! * The backend learns every accepted request with its [`RequestContext`] (its end, whether
//!   it is cyclic, its address) before its parameter service and process data, so a drive
//!   model can monitor the link itself (P812: the time between cyclic requests). Its own
//!   deadlines ([`Timers::poll_timeout`]) are part of [`Slave::poll_timeout`] and reach it
//!   through [`Timers::handle_timeout`]; the slave has no timer of its own beyond framing and
//!   the response.

use drive_core::time::earliest;
use drive_core::{Endpoint, Queue, SlaveEndpoint, Timers};
use drive_profile::sew::SlaveHandshake;

use crate::codec;
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, ParamChannel, Service, Telegram};
use crate::receiver::{AddressFilter, Receiver, RxChar, RxEvent, TelegramFraming};
use crate::timing::{Instant, LineTiming};

/// What the drive learns about an accepted request besides its contents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RequestContext {
    /// End of the request's last character (its BCC).
    pub end: Instant,
    /// A cyclic PDU type: the master promises to repeat it, the drive monitors the link
    /// (P812).
    pub cyclic: bool,
    /// The address the request was sent to (own, group, 254 or 255).
    pub address: Address,
    /// Whether a response goes back (own address and 254).
    pub answered: bool,
}

/// The drive behind the protocol; the simulated drive implements it. Its own deadlines (e.g.
/// the drive's RS-485 timeout) are its [`Timers`].
pub trait Backend: Timers {
    /// An accepted request: called once per request, before its parameter service and its
    /// process data (a cyclic request without process data, PARAM + 0PD, comes only here).
    fn on_request(&mut self, ctx: &RequestContext) {
        let _ = ctx;
    }

    /// Execute the parameter service `request` (a defined service other than "no service").
    /// Return the answer's data or the return code.
    fn param(&mut self, ctx: &RequestContext, request: &ParamChannel) -> Result<u32, ReturnCode>;

    /// Process data of an accepted request: `output` are the master's process output words
    /// (PO), `input` receives the drive's process input words (PI) for the response (same
    /// length; ignored for group and broadcast requests).
    fn process_data(&mut self, ctx: &RequestContext, output: &[u16], input: &mut [u16]);
}

/// Configuration of a [`Slave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Own address (P810), 0–99.
    pub address: Address,
    /// Group address (P811), 100–199; [`Address::NO_GROUP`] (100) for none.
    pub group: Address,
    /// Answer point-to-point requests (254) with the own address instead of 254.
    pub reply_p2p_with_own_address: bool,
    /// Character time and start pause.
    pub timing: LineTiming,
}

impl SlaveConfig {
    /// Address `address`, no group, MOVILINK timing (9600 8E1).
    pub const fn new(address: Address) -> Self {
        Self {
            address,
            group: Address::NO_GROUP,
            reply_p2p_with_own_address: false,
            timing: LineTiming::MOVILINK,
        }
    }
}

/// What happened; drained with [`Slave::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlaveEvent {
    /// An accepted request was processed.
    Received {
        /// The request.
        telegram: Telegram,
        /// Whether a response is queued for it.
        answered: bool,
    },
    /// Received characters were dropped. On a multi-drop bus, requests for other drives show
    /// up here as [`RejectReason::WrongAddress`].
    Rejected(RejectReason),
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    bytes: [u8; MAX_TELEGRAM_LEN],
    len: usize,
    not_before: Instant,
}

/// The drive state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Slave<B> {
    config: SlaveConfig,
    backend: B,
    receiver: Receiver,
    now: Instant,
    tx: Option<Pending>,
    handshake: SlaveHandshake,
    events: Queue<SlaveEvent, 4>,
}

impl<B: Backend> Slave<B> {
    /// A drive with `config` executing on `backend`.
    pub fn new(config: SlaveConfig, backend: B) -> Self {
        Self {
            receiver: Receiver::new(TelegramFraming::new(
                Direction::Request,
                AddressFilter::Slave {
                    own: config.address,
                    group: config.group,
                },
                config.timing,
            )),
            config,
            backend,
            now: Instant::ZERO,
            tx: None,
            handshake: SlaveHandshake::new(),
            events: Queue::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Change the configuration (e.g. after P810/P811 were written); the timing is kept.
    pub fn set_config(&mut self, config: SlaveConfig) {
        let timing = self.config.timing;
        self.config = SlaveConfig { timing, ..config };
        self.receiver.framing_mut().filter = AddressFilter::Slave {
            own: config.address,
            group: config.group,
        };
    }

    /// The backend.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The backend, for changing.
    pub fn backend_mut(&mut self) -> &mut B {
        &mut self.backend
    }

    /// Consume the state machine, returning the backend.
    pub fn into_backend(self) -> B {
        self.backend
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
        self.advance(c.time);
        let end = self.receiver.last_char_time();
        match self.receiver.handle_char(c) {
            None => {}
            Some(RxEvent::Rejected(r)) => self.events.push(SlaveEvent::Rejected(r)),
            // The request's end was confirmed by this character after an idle gap (the
            // confirmation time was not polled): execute it, but do not answer below.
            Some(RxEvent::Frame(t)) => self.on_request(t, end.unwrap_or(c.time)),
        }
        // Someone else is talking: a response not yet sent would collide.
        self.tx = None;
    }

    /// Advance the time to `now`: the response may become due, the backend's deadline may pass.
    #[inline]
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        let end = self.receiver.last_char_time();
        match self.receiver.handle_timeout(self.now) {
            Some(RxEvent::Rejected(r)) => self.events.push(SlaveEvent::Rejected(r)),
            // The quiet line after the BCC confirmed the request's end.
            Some(RxEvent::Frame(t)) => self.on_request(t, end.unwrap_or(self.now)),
            None => {}
        }
        if self
            .backend_deadline()
            .is_some_and(|deadline| self.now >= deadline)
        {
            self.backend.handle_timeout(self.now);
        }
    }

    /// When the backend is due, but never while a complete request awaits its end
    /// confirmation: that request arrived when its last character did, and the backend hears
    /// of it (with that time) before its own deadline is judged. A cyclic request whose check
    /// byte ends just before the drive's link-monitor deadline is in time.
    #[inline]
    fn backend_deadline(&self) -> Option<Instant> {
        let deadline = self.backend.poll_timeout()?;
        Some(match self.receiver.pending_confirmation() {
            Some(confirmation) => deadline.later(confirmation),
            None => deadline,
        })
    }

    /// The response, if one is due at `now`. Returns the number of bytes written to `buf`
    /// (which must hold [`MAX_TELEGRAM_LEN`] bytes); they start on the wire at `now`.
    #[inline]
    pub fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        self.advance(now);
        let p = self.tx.as_ref()?;
        if self.now < p.not_before {
            return None;
        }
        let out = buf.get_mut(..p.len)?;
        out.copy_from_slice(p.bytes.get(..p.len)?);
        let n = p.len;
        self.tx = None;
        Some(n)
    }

    /// When [`Slave::handle_timeout`] has work to do: a request's end confirmation, a gap
    /// limit, the response falling due, or the backend's own deadline.
    #[inline]
    pub fn poll_timeout(&self) -> Option<Instant> {
        earliest(
            earliest(self.tx.map(|p| p.not_before), self.receiver.poll_timeout()),
            self.backend_deadline(),
        )
    }

    /// The next event.
    #[inline]
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop()
    }

    fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
    }

    fn execute(&mut self, ctx: &RequestContext, p: &ParamChannel) -> ParamChannel {
        match p.service() {
            None => p.answer(Err(ReturnCode::ILLEGAL_SERVICE_CODING)),
            Some(Service::NoService) => *p,
            Some(_) => p.answer(self.backend.param(ctx, p)),
        }
    }

    fn on_request(&mut self, request: Telegram, end: Instant) {
        let pdu_type = request.pdu_type();
        let cyclic = pdu_type.is_cyclic();
        let address = request.address();
        let answered = address.expects_response();
        let ctx = RequestContext {
            end,
            cyclic,
            address,
            answered,
        };
        self.backend.on_request(&ctx);
        let answer = request.param().map(|p| {
            if cyclic {
                let mut handshake = self.handshake;
                let a = handshake.handle(&p, |p| self.execute(&ctx, p));
                self.handshake = handshake;
                a
            } else {
                self.execute(&ctx, &p)
            }
        });
        let mut input = [0u16; 3];
        let words = pdu_type.pd_words();
        if words > 0
            && let Some(input) = input.get_mut(..words)
        {
            self.backend
                .process_data(&ctx, request.process_data(), input);
        }
        if answered {
            let reply_address =
                if address.is_point_to_point() && self.config.reply_p2p_with_own_address {
                    self.config.address
                } else {
                    address
                };
            let mut response = Telegram::response(reply_address, pdu_type)
                .with_process_data(input.get(..words).unwrap_or(&[]));
            if let Some(a) = answer {
                response = response.with_param(a);
            }
            let mut bytes = [0u8; MAX_TELEGRAM_LEN];
            if let Ok(len) = codec::encode(&response, &mut bytes) {
                self.tx = Some(Pending {
                    bytes,
                    len,
                    not_before: end + self.config.timing.start_pause,
                });
            }
        }
        self.events.push(SlaveEvent::Received {
            telegram: request,
            answered,
        });
    }
}

impl<B: Backend> Endpoint for Slave<B> {
    fn handle_char(&mut self, c: RxChar) {
        Slave::handle_char(self, c);
    }

    fn handle_timeout(&mut self, now: Instant) {
        Slave::handle_timeout(self, now);
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        Slave::poll_transmit(self, now, buf)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        Slave::poll_timeout(self)
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        earliest(
            self.tx.map(|p| p.not_before),
            self.receiver.pending_confirmation(),
        )
    }

    fn max_frame_len(&self) -> usize {
        MAX_TELEGRAM_LEN
    }
}

impl<B: Backend> SlaveEndpoint for Slave<B> {
    fn address(&self) -> u8 {
        self.config.address.get()
    }

    fn char_time(&self) -> core::time::Duration {
        self.config.timing.char_time
    }
}
