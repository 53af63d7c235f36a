//! The USS slave state machine, sans-IO: receives the telegrams for its address and
//! broadcasts with [`UssFraming`], hands PKW orders and process data to a [`Backend`] (the
//! simulated drive) and answers after its response delay.
//!
//! * **Addresses.** A telegram to its address is executed and answered; a broadcast (ADR bit 5)
//!   is executed and not answered; a mirror telegram (bit 6) to its address is sent back
//!   unchanged and not executed; a special telegram (bit 7) is ignored. Telegrams for other
//!   addresses are dropped at their ADR byte.
//! * **The PKW order.** A drive works on one order at a time and keeps sending the answer to
//!   the previous order until the new one is done (BU 0255 section 4.6.1.1, "Plausibilitäts­
//!   prüfung"). The slave does the same: a PKW that differs from the current order is a new
//!   order, executed by the backend once [`Backend::processing_time`] has passed (at once by
//!   default); until then every answer carries the previous order's answer. The same order
//!   again is not executed again, so a repeated write telegram writes once. A new order that
//!   arrives before the current one is done replaces it (the replaced one is never executed).
//! * **Process data** go to [`Backend::process`] with every executed telegram (each one, not only
//!   new ones: the control word is cyclic).
//! * **Timing.** The answer starts [`SlaveConfig::response_delay`] after the request's last
//!   character, never sooner than the start delay; it is dropped if other characters arrive
//!   on the line before it was sent. A request must keep the residual run time.
//! * **3-word PKW.** The answer carries one value word; an answer that does not fit it (a
//!   double word) is replaced by AK 7 with error 5, "Unzulässiger Datentyp" (invalid data
//!   type).

use core::time::Duration;

use drive_core::time::earliest;
use drive_core::{Endpoint, Instant, LineSettings, Queue, RxChar, RxEvent, SlaveEndpoint, Timers};

use super::framing::{RunClock, Side, UssFraming, UssReceiver, UssTiming, receive};
use super::telegram::{Adr, FrameError, Layout, MAX_PZD, MAX_TELEGRAM, Telegram, UssAddress};
use crate::uss::pkw::{DriveError, Pkw, Reply};

/// The drive behind the protocol; the simulated drive implements it. Its own deadlines (a
/// ramp) are its [`Timers`].
pub trait Backend: Timers {
    /// Execute a new PKW order at `now` and return the answer channel.
    fn execute(&mut self, order: &Pkw, now: Instant) -> Pkw;

    /// How long the drive works on `order` before its answer is there (zero: within the
    /// telegram that brought it).
    fn processing_time(&self, order: &Pkw) -> Duration {
        let _ = order;
        Duration::ZERO
    }

    /// Process data: the request's PZD words in, the answer's PZD words (as many) out. Called
    /// for every executed telegram; for a broadcast `answer` is not sent.
    fn process(&mut self, request: &[u16], answer: &mut [u16], now: Instant);
}

/// Configuration of a [`Slave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Own address.
    pub address: UssAddress,
    /// The layout of the telegrams (the same setting as the master's).
    pub layout: Layout,
    /// The line.
    pub line: LineSettings,
    /// The USS times (start delay, character gap, residual run time).
    pub timing: UssTiming,
    /// From the end of a request to the start of the answer; at least the start delay.
    pub response_delay: Duration,
}

impl SlaveConfig {
    /// Address `address`, `layout`, on `line`, answering after the start delay (two character
    /// times, NORD's typical response delay).
    pub const fn new(address: UssAddress, layout: Layout, line: LineSettings) -> SlaveConfig {
        let timing = UssTiming::from_line(&line);
        SlaveConfig {
            address,
            layout,
            line,
            timing,
            response_delay: timing.start_delay,
        }
    }

    fn framing(&self) -> UssFraming {
        UssFraming::new(Side::Slave(self.address), self.layout, &self.line).with_timing(self.timing)
    }
}

/// What happened; drained with [`Slave::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlaveEvent {
    /// A telegram to this slave or a broadcast was executed.
    Executed {
        /// The request.
        request: Telegram,
        /// The answer queued (None for a broadcast).
        answer: Option<Telegram>,
    },
    /// The backend executed this PKW order (its answer is sent from now on).
    OrderDone(Pkw),
    /// A mirror telegram was queued to go back unchanged.
    Mirrored(Telegram),
    /// A special telegram (ADR bit 7) was ignored.
    Ignored(Telegram),
    /// Received characters were dropped (not counting telegrams for other addresses).
    Rejected(FrameError),
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    telegram: Telegram,
    not_before: Instant,
}

/// The order being worked on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Work {
    order: Pkw,
    /// When it is done; None once executed.
    due: Option<Instant>,
}

/// The slave state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Slave<B> {
    config: SlaveConfig,
    backend: B,
    receiver: UssReceiver,
    clock: RunClock,
    now: Instant,
    /// End of the last character received.
    last_rx: Instant,
    work: Option<Work>,
    /// The answer channel sent until the next order is done.
    answer: Pkw,
    tx: Option<Pending>,
    events: Queue<SlaveEvent, 4>,
}

impl<B: Backend> Slave<B> {
    /// A slave with `config` executing on `backend`.
    pub fn new(config: SlaveConfig, backend: B) -> Slave<B> {
        Slave {
            receiver: UssReceiver::new(config.framing()),
            config,
            backend,
            clock: RunClock::default(),
            now: Instant::ZERO,
            last_rx: Instant::ZERO,
            work: None,
            answer: Pkw::default(),
            tx: None,
            events: Queue::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Answer `address` from now on.
    pub fn set_address(&mut self, address: UssAddress) {
        self.config.address = address;
        self.receiver.framing_mut().set_side(Side::Slave(address));
    }

    /// The backend.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The backend, for changing.
    pub fn backend_mut(&mut self) -> &mut B {
        &mut self.backend
    }

    /// The PKW answer sent now (the last order's that is done).
    pub fn current_answer(&self) -> Pkw {
        self.answer
    }

    /// Whether an order is being worked on.
    pub fn is_processing(&self) -> bool {
        self.work.is_some_and(|w| w.due.is_some())
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop()
    }

    /// The response delay in force: the configured one, at least the start delay.
    fn response_delay(&self) -> Duration {
        self.config
            .response_delay
            .max(self.config.timing.start_delay)
    }

    /// When the receiver needs the time: not before an answer could go out anyway (one wake-up
    /// per exchange instead of two; the receiver judges characters by their own times).
    fn receiver_deadline(&self) -> Option<Instant> {
        self.receiver
            .poll_timeout()
            .map(|t| t.later(self.last_rx + self.response_delay()))
    }

    fn on_rx(&mut self, ev: RxEvent<Telegram, FrameError>) {
        match ev {
            RxEvent::Frame(t) => self.on_request(t),
            RxEvent::Rejected(FrameError::NotAddressed(_)) => {}
            RxEvent::Rejected(e) => self.events.push(SlaveEvent::Rejected(e)),
        }
    }

    /// Finish the order in work if it is due by now.
    fn finish_due(&mut self) {
        let Some(work) = self.work.as_mut() else {
            return;
        };
        match work.due {
            Some(due) if self.now >= due => {
                work.due = None;
                let order = work.order;
                self.answer = self.backend.execute(&order, self.now);
                self.events.push(SlaveEvent::OrderDone(order));
            }
            _ => {}
        }
    }

    fn on_request(&mut self, request: Telegram) {
        let adr = request.adr();
        if adr.is_special() {
            self.events.push(SlaveEvent::Ignored(request));
            return;
        }
        let broadcast = adr.is_broadcast();
        if adr.is_mirror() && !broadcast {
            self.queue(request);
            self.events.push(SlaveEvent::Mirrored(request));
            return;
        }
        let now = self.now;
        self.finish_due();
        if let Some(order) = request.pkw()
            && self.work.map(|w| w.order) != Some(order)
        {
            let due = now + self.backend.processing_time(&order);
            self.work = Some(Work {
                order,
                due: Some(due),
            });
            self.finish_due();
        }
        let mut pzd = [0u16; MAX_PZD];
        let words = request.pzd().len();
        let out = pzd.get_mut(..words).unwrap_or(&mut []);
        self.backend.process(request.pzd(), out, now);
        let answer = if broadcast {
            None
        } else {
            let adr = Adr::new(self.config.address);
            let layout = self.config.layout;
            let pzd = pzd.get(..words).unwrap_or(&[]);
            let telegram = Telegram::new(adr, layout, self.answer, pzd).or_else(|_| {
                let refusal =
                    Reply::Error(DriveError(5)).to_pkw(self.answer.pke.pnu(), self.answer.ind);
                Telegram::new(adr, layout, refusal, pzd)
            });
            telegram.ok()
        };
        if let Some(t) = answer {
            self.queue(t);
        }
        self.events.push(SlaveEvent::Executed { request, answer });
    }

    fn queue(&mut self, telegram: Telegram) {
        self.tx = Some(Pending {
            telegram,
            // From the request's last character, not from the silence that confirmed it.
            not_before: (self.last_rx + self.response_delay()).later(self.now),
        });
    }
}

impl<B: Backend> SlaveEndpoint for Slave<B> {
    fn address(&self) -> u8 {
        self.config.address.get()
    }

    fn char_time(&self) -> Duration {
        self.config.line.char_time()
    }
}

impl<B: Backend> Endpoint for Slave<B> {
    #[inline]
    fn handle_char(&mut self, c: RxChar) {
        self.now = self.now.later(c.time);
        self.last_rx = c.time;
        // Bus activity before the answer went out: the answer is dropped.
        self.tx = None;
        if let Some(ev) = receive(&mut self.receiver, &mut self.clock, c) {
            self.on_rx(ev);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.now = self.now.later(now);
        if let Some(ev) = self.receiver.handle_timeout(now) {
            let ev = super::framing::judge(ev, &self.clock, self.receiver.framing());
            self.on_rx(ev);
        }
        self.finish_due();
        self.backend.handle_timeout(now);
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let p = self.tx?;
        if now < p.not_before {
            return None;
        }
        let n = p.telegram.encode(buf).ok()?;
        self.tx = None;
        self.receiver.reset();
        Some(n)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        let work = self.work.and_then(|w| w.due);
        earliest(
            earliest(self.receiver_deadline(), self.tx.map(|p| p.not_before)),
            earliest(work, self.backend.poll_timeout()),
        )
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        earliest(self.receiver_deadline(), self.tx.map(|p| p.not_before))
    }

    fn max_frame_len(&self) -> usize {
        MAX_TELEGRAM
    }
}
