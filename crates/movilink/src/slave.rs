//! The drive (slave) protocol state machine, sans-IO.
//!
//! It frames requests, decides whether to answer, runs the cyclic handshake, delegates the
//! parameter services and process data to a [`Backend`] (the simulated drive), builds the
//! response and monitors the link (P812).
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
//! * P812: when the timeout is not zero, it is armed by each accepted cyclic request and fires
//!   [`SlaveEvent::Timeout`] (and [`Backend::on_timeout`]) once when no accepted cyclic request
//!   followed within it. Acyclic requests neither arm nor retrigger it (the manual: in acyclic
//!   operation the drive does not monitor the link).

use core::time::Duration;

use crate::codec;
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, ParamChannel, Service, Telegram};
use crate::queue::Queue;
use crate::receiver::{AddressFilter, Receiver, RxChar, RxEvent};
use crate::timing::{Instant, LineTiming};

/// The drive behind the protocol; the simulated drive implements it.
pub trait Backend {
    /// Execute the parameter service `request` (a defined service other than "no service").
    /// Return the answer's data or the return code.
    fn param(&mut self, request: &ParamChannel) -> Result<u32, ReturnCode>;

    /// Process data of an accepted request: `output` are the master's process output words
    /// (PO), `input` receives the drive's process input words (PI) for the response (same
    /// length; ignored for group and broadcast requests).
    fn process_data(&mut self, output: &[u16], input: &mut [u16]);

    /// The RS-485 timeout (P812) expired.
    fn on_timeout(&mut self);
}

/// Configuration of a [`Slave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Own address (P810), 0–99.
    pub address: Address,
    /// Group address (P811), 100–199; [`Address::NO_GROUP`] (100) for none.
    pub group: Address,
    /// RS-485 timeout (P812); zero switches the monitoring off.
    pub rs485_timeout: Duration,
    /// Answer point-to-point requests (254) with the own address instead of 254.
    pub reply_p2p_with_own_address: bool,
    /// Character time and start pause.
    pub timing: LineTiming,
}

impl SlaveConfig {
    /// Address `address`, no group, no timeout, MOVILINK timing.
    pub const fn new(address: Address) -> Self {
        Self {
            address,
            group: Address::NO_GROUP,
            rs485_timeout: Duration::ZERO,
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
    /// The RS-485 timeout (P812) expired.
    Timeout,
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
    last_handshake: bool,
    last_answer: ParamChannel,
    last_cyclic: Option<Instant>,
    timed_out: bool,
    events: Queue<SlaveEvent, 4>,
    pause_us: u64,
}

impl<B: Backend> Slave<B> {
    /// A drive with `config` executing on `backend`.
    pub fn new(config: SlaveConfig, backend: B) -> Self {
        let (_, pause_us) = config.timing.micros();
        Self {
            receiver: Receiver::new(
                Direction::Request,
                AddressFilter::Slave {
                    own: config.address,
                    group: config.group,
                },
                config.timing,
            ),
            config,
            backend,
            now: Instant::ZERO,
            tx: None,
            last_handshake: false,
            last_answer: ParamChannel::default(),
            last_cyclic: None,
            timed_out: false,
            events: Queue::new(),
            pause_us,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Change the configuration (e.g. after P810/P811/P812 were written); the timing is kept.
    pub fn set_config(&mut self, config: SlaveConfig) {
        let timing = self.config.timing;
        self.config = SlaveConfig { timing, ..config };
        self.receiver.set_filter(AddressFilter::Slave {
            own: config.address,
            group: config.group,
        });
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
    pub fn handle_char(&mut self, c: RxChar) {
        self.advance(c.time);
        let end = self.receiver.last_char_time();
        match self.receiver.handle_char(c) {
            None => {}
            Some(RxEvent::Rejected(r)) => self.events.push(SlaveEvent::Rejected(r)),
            // The request's end was confirmed by this character after an idle gap (the
            // confirmation time was not polled): execute it, but do not answer below.
            Some(RxEvent::Telegram(t)) => self.on_request(t, end.unwrap_or(c.time)),
        }
        // Someone else is talking: a response not yet sent would collide.
        self.tx = None;
    }

    /// Advance the time to `now`: the response may become due, P812 may expire.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        let end = self.receiver.last_char_time();
        match self.receiver.handle_timeout(self.now) {
            Some(RxEvent::Rejected(r)) => self.events.push(SlaveEvent::Rejected(r)),
            // The quiet line after the BCC confirmed the request's end.
            Some(RxEvent::Telegram(t)) => self.on_request(t, end.unwrap_or(self.now)),
            None => {}
        }
        if self
            .p812_deadline()
            .is_some_and(|deadline| self.now >= deadline)
        {
            self.timed_out = true;
            self.backend.on_timeout();
            self.events.push(SlaveEvent::Timeout);
        }
    }

    /// The response, if one is due at the latest time given. Returns the number of bytes
    /// written to `buf` (which must hold [`MAX_TELEGRAM_LEN`] bytes).
    pub fn poll_transmit(&mut self, buf: &mut [u8]) -> Option<usize> {
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

    /// When [`Slave::handle_timeout`] has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        [
            self.tx.map(|p| p.not_before),
            self.p812_deadline(),
            self.receiver.poll_timeout(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop()
    }

    fn advance(&mut self, now: Instant) {
        if now > self.now {
            self.now = now;
        }
    }

    fn p812_deadline(&self) -> Option<Instant> {
        if self.timed_out || self.config.rs485_timeout.is_zero() {
            return None;
        }
        self.last_cyclic.map(|t| t + self.config.rs485_timeout)
    }

    fn execute(&mut self, p: &ParamChannel) -> ParamChannel {
        match p.service() {
            None => p.answer(Err(ReturnCode::ILLEGAL_SERVICE_CODING)),
            Some(Service::NoService) => *p,
            Some(_) => p.answer(self.backend.param(p)),
        }
    }

    fn on_request(&mut self, request: Telegram, end: Instant) {
        let pdu_type = request.pdu_type();
        let cyclic = pdu_type.is_cyclic();
        if cyclic {
            self.last_cyclic = Some(end);
            self.timed_out = false;
        }
        let answer = request.param().map(|p| {
            if !cyclic {
                self.execute(&p)
            } else if p.management.handshake() != self.last_handshake {
                let a = self.execute(&p);
                self.last_handshake = p.management.handshake();
                self.last_answer = a;
                a
            } else {
                self.last_answer
            }
        });
        let mut input = [0u16; 3];
        let words = pdu_type.pd_words();
        if words > 0 {
            if let Some(input) = input.get_mut(..words) {
                self.backend.process_data(request.process_data(), input);
            }
        }
        let address = request.address();
        let answered = address.expects_response();
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
                    not_before: end.plus_micros(self.pause_us),
                });
            }
        }
        self.events.push(SlaveEvent::Received {
            telegram: request,
            answered,
        });
    }
}
