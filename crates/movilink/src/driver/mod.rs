//! The async MOVILINK master (feature `tokio`).
//!
//! [`MasterDriver`] runs the sans-IO [`Master`] on a [`CharIo`]: it writes what
//! [`Master::poll_transmit`] hands out, feeds every received character with its arrival time
//! (microseconds since a fixed epoch per driver, taken from tokio's clock) and calls
//! [`Master::handle_timeout`] when [`Master::poll_timeout`] is reached. Every protocol rule
//! (start pause, response timeout, acceptance checks, retries, handshake, broadcast spacing)
//! is the sans-IO master's; the driver only waits and moves bytes.
//!
//! Timing profiles ([`DriverConfig::timing`]):
//!
//! * `true` (default): times are tokio's (paused in tests, real otherwise); the start pause,
//!   the two start pauses after a failed or aborted telegram and the 25 ms broadcast spacing
//!   are waited for. Tokio's timers have a resolution of 1 ms, so a wait may end up to 1 ms
//!   later than the rule asks, never earlier.
//! * `false`: a benchmark profile that measures software overhead: the master gets a virtual
//!   clock that advances by one character time per character and jumps over every pause; only
//!   the response timeout is a real timer.
//!
//! An example with a simulated drive is in the docs of the `sim` module.

mod cyclic;
pub(crate) mod io;

pub use self::cyclic::CyclicSession;

use std::pin::Pin;
use std::time::Duration;

use tokio::time::{Instant as TokioInstant, Sleep};

pub use self::io::{CharIo, ReceivedChar, Stream};
use self::io::{Woken, read_or_sleep, write_all};
use crate::error::{RejectReason, ReturnCode};
use crate::frame::{
    Address, AttributeInfo, MAX_TELEGRAM_LEN, ParamChannel, PduType, ScaleInfo, Telegram,
};
use crate::master::{Master, MasterConfig, MasterEvent};
use crate::receiver::RxChar;
use crate::timing::{self, Instant, LineTiming};

/// Index of P070 "unit type", read by [`MasterDriver::probe`].
pub const UNIT_TYPE_INDEX: u16 = 8301;

/// Received characters handled per read.
const RX_BUF: usize = 64;

/// Configuration of a [`MasterDriver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverConfig {
    /// Response timeout from the end of a request to the start of its response; default
    /// [`timing::DEFAULT_RESPONSE_TIMEOUT`] (50 ms, the manual's maximum response delay).
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a corrupt answer; default 2.
    pub retries: u8,
    /// `true` (default): start pause, two start pauses after a failure and the broadcast
    /// spacing are honoured on tokio's clock. `false`: benchmark profile measuring software
    /// overhead only (no waits except the response timeout); see the [module docs](self).
    pub timing: bool,
    /// Baud rate for the character time and the gap and timeout rules; default 9600.
    pub baud: u32,
    /// Longest gap accepted between the characters of a response; `None` (default): the
    /// manual's rule, less than a start pause. Real serial ports are timestamped when the
    /// operating system hands the characters over, and USB adapters deliver them in bursts
    /// (an FTDI chip every 16 ms by default): give such ports e.g. 20 ms, or the responses
    /// look broken off. The BCC, length and trailing-character checks stay in force.
    pub max_char_gap: Option<Duration>,
}

impl Default for DriverConfig {
    fn default() -> Self {
        Self {
            response_timeout: timing::DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            timing: true,
            baud: timing::BAUD_RATE,
            max_char_gap: None,
        }
    }
}

impl DriverConfig {
    /// Character time and start pause at [`DriverConfig::baud`]: the manual's 3.44 ms at
    /// 9600 baud, three character times at other rates.
    pub fn line_timing(&self) -> LineTiming {
        let line = if self.baud == timing::BAUD_RATE {
            LineTiming::MOVILINK
        } else {
            let char_time = timing::char_time(self.baud);
            let start_pause = char_time.saturating_mul(3);
            LineTiming {
                char_time,
                start_pause,
                max_gap: start_pause,
            }
        };
        match self.max_char_gap {
            Some(gap) => line.with_max_gap(gap),
            None => line,
        }
    }

    fn master_config(&self) -> MasterConfig {
        MasterConfig {
            response_timeout: self.response_timeout,
            retries: self.retries,
            timing: self.line_timing(),
            ..MasterConfig::default()
        }
    }
}

/// Counters of a [`MasterDriver`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct DriverStats {
    /// Requests handed to the bus (each driver call that reached the bus).
    pub transactions: u64,
    /// Retransmissions after a timeout or a rejected answer.
    pub retries: u64,
    /// Requests that ended in [`DriverError::Timeout`].
    pub timeouts: u64,
    /// Received telegrams or characters dropped by the checks (parity, gap, address, PDU type,
    /// BCC, mismatching answer).
    pub rejected: u64,
    /// Negative answers of drives ([`DriverError::Device`], or an error in the parameter
    /// channel of an [`MasterDriver::exchange`] response).
    pub device_errors: u64,
}

/// Why a driver call failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive answered the parameter service negatively; the code says why.
    #[error("the drive refused the service: {} ({}); {}", .0.describe(), code_text(.0), device_hint(.0))]
    Device(ReturnCode),
    /// Nothing answered in time, in every attempt.
    #[error(
        "no answer from address {address} after {attempts} attempts; check address, baud rate, wiring, termination and P810"
    )]
    Timeout {
        /// The request's address.
        address: u8,
        /// Transmissions made.
        attempts: u32,
    },
    /// Answers arrived but kept failing the checks (parity, gaps, address, PDU type, BCC).
    #[error(
        "answers from address {address} kept failing the checks ({reason}) in {attempts} attempts; check baud rate and parity (9600 8E1), termination and for a second master on the bus"
    )]
    Corrupt {
        /// The request's address.
        address: u8,
        /// The last check that failed.
        reason: RejectReason,
        /// Transmissions made.
        attempts: u32,
    },
    /// Cyclic PDU type: the drive never echoed the handshake bit, so the parameter service
    /// was not executed.
    #[error(
        "the drive at address {address} did not execute the cyclic parameter service (handshake bit never echoed); use an acyclic pdu type or check that no other master sends to it"
    )]
    NotExecuted {
        /// The request's address.
        address: u8,
    },
    /// The request cannot be sent this way.
    #[error("invalid request: {0}")]
    InvalidRequest(&'static str),
    /// The port failed or was closed.
    #[error("port i/o failed: {0}; check that the port still exists and no other program uses it")]
    Io(#[from] std::io::Error),
}

fn code_text(rc: &ReturnCode) -> String {
    format!(
        "code {}/{}/{:#06x}",
        rc.error_class, rc.error_code, rc.additional_code
    )
}

fn device_hint(rc: &ReturnCode) -> &'static str {
    match *rc {
        ReturnCode::ILLEGAL_INDEX | ReturnCode::NOT_IMPLEMENTED => {
            "check the index against the drive's parameter list"
        }
        ReturnCode::READ_ONLY => "the parameter can only be read",
        ReturnCode::VALUE_TOO_LARGE | ReturnCode::VALUE_TOO_SMALL | ReturnCode::INVALID_VALUE => {
            "read the minimum and maximum and write a value in range"
        }
        ReturnCode::PARAMETER_LOCK => "switch the parameter lock P803 off first",
        ReturnCode::CONTROLLER_INHIBIT_REQUIRED | ReturnCode::OUTPUT_STAGE_ENABLED => {
            "set controller inhibit (control word bit 0) first"
        }
        ReturnCode::INTERNAL_COMMUNICATION_ERROR => "repeat the service",
        _ => "see the return code table of the manual (ch. 6.2)",
    }
}

/// Wire times of the last answered exchange (see [`MasterDriver::last_timing`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ExchangeTiming {
    /// When the (last) request transmission was handed to the port: on an idle line of the
    /// wire model, the start of its first character.
    pub request_start: TokioInstant,
    /// Arrival of the response's last character (exact on the wire model).
    pub response_end: TokioInstant,
}

impl ExchangeTiming {
    /// From the start of the request to the end of the response.
    pub fn duration(&self) -> Duration {
        self.response_end
            .saturating_duration_since(self.request_start)
    }
}

/// What one request produced.
#[derive(Debug, Default)]
struct Outcome {
    response: Option<Telegram>,
    param: Option<Result<u32, ReturnCode>>,
}

/// The async MOVILINK master; see the [module docs](self).
#[derive(Debug)]
pub struct MasterDriver<IO> {
    io: IO,
    config: DriverConfig,
    master: Master,
    epoch: TokioInstant,
    /// Virtual clock (µs) of the untimed profile.
    virt: u64,
    char_us: u64,
    pause_us: u64,
    stats: DriverStats,
    rx: Box<[ReceivedChar]>,
    /// The wait timer, made on first use (so that `new` works outside a runtime).
    sleep: Option<Pin<Box<Sleep>>>,
    /// Last process output words sent per address byte (used by [`MasterDriver::param`] with
    /// PDU types that carry process data).
    po: Box<[[u16; 3]]>,
    last_timing: Option<ExchangeTiming>,
    /// Arrival of the last character fed to the master.
    rx_last_at: Option<TokioInstant>,
}

impl<IO: CharIo> MasterDriver<IO> {
    /// A driver on `io` (the bus is assumed idle); the epoch of its times is now.
    pub fn new(io: IO, config: DriverConfig) -> Self {
        let epoch = TokioInstant::now();
        let line = config.line_timing();
        let char_us = u64::try_from(line.char_time.as_micros()).unwrap_or(u64::MAX);
        let pause_us = u64::try_from(line.start_pause.as_micros()).unwrap_or(u64::MAX);
        Self {
            io,
            master: Master::new(config.master_config()),
            config,
            epoch,
            virt: 0,
            char_us,
            pause_us,
            stats: DriverStats::default(),
            rx: vec![ReceivedChar::new(0, epoch); RX_BUF].into_boxed_slice(),
            sleep: None,
            po: vec![[0u16; 3]; 256].into_boxed_slice(),
            last_timing: None,
            rx_last_at: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// The counters so far.
    pub fn stats(&self) -> DriverStats {
        self.stats
    }

    /// The port.
    pub fn get_ref(&self) -> &IO {
        &self.io
    }

    /// The port, e.g. to inject faults on the wire model (do not read from it).
    pub fn get_mut(&mut self) -> &mut IO {
        &mut self.io
    }

    /// The port back.
    pub fn into_inner(self) -> IO {
        self.io
    }

    /// Wire times of the last exchange that was answered.
    pub fn last_timing(&self) -> Option<ExchangeTiming> {
        self.last_timing
    }

    /// One parameter-channel service on `address` in a telegram of type `pdu` (normally
    /// [`PduType::PARAM_0PD_ACYCLIC`]); returns the answer's parameter channel. Cyclic types
    /// toggle the handshake bit (the sans-IO master learns the drive's bit first if needed).
    /// Types with process data repeat the process output words last sent to `address` with
    /// [`MasterDriver::exchange`] (zeros before).
    pub async fn param(
        &mut self,
        address: Address,
        pdu: PduType,
        request: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        if !pdu.has_param() {
            return Err(DriverError::InvalidRequest(
                "the pdu type has no parameter channel; use one of the PARAM types",
            ));
        }
        if !address.expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses get no answer; use send_unanswered",
            ));
        }
        let po = self.po_of(address);
        let telegram = Telegram::request(address, pdu)
            .with_param(request)
            .with_process_data(&po);
        let out = self
            .transact(telegram, self.config.response_timeout, self.config.retries)
            .await?;
        if let Some(Err(rc)) = out.param {
            return Err(DriverError::Device(rc));
        }
        out.response
            .and_then(|t| t.param())
            .ok_or(DriverError::InvalidRequest(
                "the answer carried no parameter channel",
            ))
    }

    /// Read the value of `index` (acyclic PARAM + 0PD).
    pub async fn read(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read(index)).await
    }

    /// Write `value` to `index`, non-volatile (EEPROM). Not for cyclic writes: EEPROMs wear
    /// out; see [`crate::guard::WriteGuard`] and [`MasterDriver::write_volatile`].
    pub async fn write(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.service(address, ParamChannel::write(index, value))
            .await
            .map(drop)
    }

    /// Write `value` to `index`, volatile (RAM, lost at power-off).
    pub async fn write_volatile(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.service(address, ParamChannel::write_volatile(index, value))
            .await
            .map(drop)
    }

    /// Read the smallest settable value of `index`.
    pub async fn read_minimum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_minimum(index))
            .await
    }

    /// Read the largest settable value of `index`.
    pub async fn read_maximum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_maximum(index))
            .await
    }

    /// Read the default (factory setting) of `index`.
    pub async fn read_default(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        self.service(address, ParamChannel::read_default(index))
            .await
    }

    /// Read the size and conversion index of `index`.
    pub async fn read_scale(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<ScaleInfo, DriverError> {
        self.service(address, ParamChannel::read_scale(index))
            .await
            .map(ScaleInfo::from_data)
    }

    /// Read the access attributes of `index` and the next available index.
    pub async fn read_attribute(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<AttributeInfo, DriverError> {
        self.service(address, ParamChannel::read_attribute(index))
            .await
            .map(AttributeInfo::from_data)
    }

    /// Process data exchange with any PDU type (with or without parameter channel); returns
    /// the response telegram. A negative parameter answer is not an error here: read it with
    /// `response.param().map(|p| p.result())`. The process output words are remembered for
    /// [`MasterDriver::param`].
    pub async fn exchange(&mut self, request: Telegram) -> Result<Telegram, DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        if !request.address().expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses get no answer; use send_unanswered",
            ));
        }
        self.remember_po(&request);
        let out = self
            .transact(request, self.config.response_timeout, self.config.retries)
            .await?;
        out.response.ok_or(DriverError::InvalidRequest(
            "the exchange completed without a response",
        ))
    }

    /// A group (100–199) or broadcast (255) telegram: sent, never answered. Returns when the
    /// telegram has left the port; the next telegram waits the 25 ms broadcast spacing.
    pub async fn send_unanswered(&mut self, request: Telegram) -> Result<(), DriverError> {
        if request.direction() != crate::Direction::Request {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        if request.address().expects_response() {
            return Err(DriverError::InvalidRequest(
                "only group (100-199) and broadcast (255) telegrams go unanswered; use exchange or param",
            ));
        }
        self.remember_po(&request);
        self.transact(request, self.config.response_timeout, 0)
            .await
            .map(drop)
    }

    /// Probe `address` with one read of P070 "unit type" (index 8301), one attempt, response
    /// timeout `timeout`: `Ok(Some(unit type))` if a drive answers, `Ok(None)` if nothing
    /// does. A negative answer ([`DriverError::Device`]) or garbled answers
    /// ([`DriverError::Corrupt`]) also mean that something is there.
    pub async fn probe(
        &mut self,
        address: Address,
        timeout: Duration,
    ) -> Result<Option<u32>, DriverError> {
        if !address.expects_response() {
            return Err(DriverError::InvalidRequest(
                "group and broadcast addresses cannot be probed",
            ));
        }
        let telegram = Telegram::request(address, PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::read(UNIT_TYPE_INDEX));
        match self.transact(telegram, timeout, 0).await {
            Ok(Outcome {
                param: Some(Ok(v)), ..
            }) => Ok(Some(v)),
            Ok(Outcome {
                param: Some(Err(rc)),
                ..
            }) => Err(DriverError::Device(rc)),
            Ok(_) => Err(DriverError::InvalidRequest(
                "the answer carried no parameter channel",
            )),
            Err(DriverError::Timeout { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    // ----- internals -----

    async fn service(
        &mut self,
        address: Address,
        request: ParamChannel,
    ) -> Result<u32, DriverError> {
        let p = self
            .param(address, PduType::PARAM_0PD_ACYCLIC, request)
            .await?;
        Ok(p.data)
    }

    fn po_of(&self, address: Address) -> [u16; 3] {
        self.po
            .get(usize::from(address.get()))
            .copied()
            .unwrap_or_default()
    }

    /// Set the process output words remembered for `address` (used by cyclic sessions).
    fn set_po(&mut self, address: Address, words: &[u16]) {
        if let Some(slot) = self.po.get_mut(usize::from(address.get())) {
            for (dst, src) in slot.iter_mut().zip(words) {
                *dst = *src;
            }
        }
    }

    fn remember_po(&mut self, request: &Telegram) {
        let words = request.process_data();
        if words.is_empty() {
            return;
        }
        if let Some(slot) = self.po.get_mut(usize::from(request.address().get())) {
            for (dst, src) in slot.iter_mut().zip(words) {
                *dst = *src;
            }
        }
    }

    /// The master's notion of now.
    fn now(&self) -> Instant {
        if self.config.timing {
            self.to_instant(TokioInstant::now())
        } else {
            Instant::from_micros(self.virt)
        }
    }

    fn to_instant(&self, t: TokioInstant) -> Instant {
        Instant::from_duration(t.saturating_duration_since(self.epoch))
    }

    fn to_tokio(&self, t: Instant) -> TokioInstant {
        self.epoch + t.as_duration()
    }

    /// Run one request through the sans-IO master until it completes.
    async fn transact(
        &mut self,
        request: Telegram,
        timeout: Duration,
        retries: u8,
    ) -> Result<Outcome, DriverError> {
        let address = request.address().get();
        let now = self.now();
        if !self.master.is_idle() {
            // A previous call was cancelled mid-request: its telegram broke off.
            self.master.abort(now);
        }
        while self.master.poll_event().is_some() {}
        self.master.set_response_timeout(timeout);
        self.master.set_retries(retries);
        if self.master.send(request, now).is_err() {
            return Err(DriverError::InvalidRequest("the telegram is not a request"));
        }
        self.stats.transactions += 1;
        let mut out = Outcome::default();
        let mut transmissions: u32 = 0;
        let mut answered = false;
        let mut last_reject: Option<RejectReason> = None;
        let mut request_start = TokioInstant::now();
        let mut waiting_since = TokioInstant::now();
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        loop {
            while let Some(event) = self.master.poll_event() {
                match event {
                    MasterEvent::Response { telegram } => {
                        answered = true;
                        out.response = Some(telegram);
                        if let Some(end) = self.rx_last_at {
                            self.last_timing = Some(ExchangeTiming {
                                request_start,
                                response_end: end,
                            });
                        }
                        if telegram.param().is_some_and(|p| p.management.is_error()) {
                            self.stats.device_errors += 1;
                        }
                    }
                    MasterEvent::ParamDone(result) => out.param = Some(result),
                    MasterEvent::Sent { .. } => {}
                    MasterEvent::Rejected(reason) => {
                        self.stats.rejected += 1;
                        last_reject = Some(reason);
                    }
                    MasterEvent::Timeout { attempts } => {
                        let attempts = u32::from(attempts);
                        return Err(match last_reject {
                            Some(reason) => DriverError::Corrupt {
                                address,
                                reason,
                                attempts,
                            },
                            None => {
                                self.stats.timeouts += 1;
                                DriverError::Timeout { address, attempts }
                            }
                        });
                    }
                    MasterEvent::ParamNotExecuted { .. } => {
                        return Err(DriverError::NotExecuted { address });
                    }
                }
            }
            if self.master.is_idle() {
                return Ok(out);
            }
            if let Some(n) = self.master.poll_transmit(&mut buf) {
                if transmissions > 0 && !answered {
                    self.stats.retries += 1;
                }
                transmissions = transmissions.saturating_add(1);
                answered = false;
                last_reject = None;
                request_start = TokioInstant::now();
                let bytes = buf.get(..n).unwrap_or(&[]);
                if let Err(e) = write_all(&mut self.io, bytes).await {
                    self.abort_after_failed_write().await;
                    return Err(DriverError::Io(e));
                }
                if !self.config.timing {
                    let n = u64::try_from(n).unwrap_or(u64::MAX);
                    self.virt = self.virt.saturating_add(n.saturating_mul(self.char_us));
                }
                waiting_since = TokioInstant::now();
                continue;
            }
            self.wait(waiting_since).await?;
        }
    }

    /// Wait for the master's next deadline or received characters, and feed what happened.
    async fn wait(&mut self, waiting_since: TokioInstant) -> Result<(), DriverError> {
        let Some(deadline) = self.master.poll_timeout() else {
            return Ok(());
        };
        let timer_at = if self.config.timing {
            let at = self.to_tokio(deadline);
            if at <= TokioInstant::now() {
                self.master.handle_timeout(self.now());
                return Ok(());
            }
            at
        } else if !self.master.is_awaiting_response()
            || deadline.as_micros() == self.virt.saturating_add(self.pause_us)
        {
            // Untimed profile: jump over a pause before a transmission, or to the
            // confirmation of a complete response (the quiet line after its last character,
            // which was the last thing to advance the virtual clock).
            self.virt = self.virt.max(deadline.as_micros());
            self.master.handle_timeout(self.now());
            return Ok(());
        } else {
            // Untimed profile: only the response timeout (plus one character) is real.
            waiting_since
                + self.master.config().response_timeout
                + self.config.line_timing().char_time
        };
        let sleep = self
            .sleep
            .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(timer_at)));
        sleep.as_mut().reset(timer_at);
        let woken = read_or_sleep(&mut self.io, &mut self.rx, Some(sleep.as_mut())).await;
        match woken {
            Ok(Woken::Read(0)) => {
                self.master.abort(self.now());
                Err(DriverError::Io(std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    "the port was closed",
                )))
            }
            Ok(Woken::Read(n)) => {
                self.feed(n);
                Ok(())
            }
            Ok(Woken::Timer) => {
                if !self.config.timing {
                    let due = self.master.poll_timeout().unwrap_or(deadline);
                    self.virt = self.virt.max(due.as_micros());
                }
                self.master.handle_timeout(self.now());
                Ok(())
            }
            Err(e) => {
                self.master.abort(self.now());
                Err(DriverError::Io(e))
            }
        }
    }

    /// Feed the first `n` characters of the receive buffer to the master.
    fn feed(&mut self, n: usize) {
        for i in 0..n {
            let Some(c) = self.rx.get(i).copied() else {
                break;
            };
            let time = if self.config.timing {
                self.to_instant(c.at)
            } else {
                self.virt = self.virt.saturating_add(self.char_us);
                Instant::from_micros(self.virt)
            };
            if self.master.is_awaiting_response() {
                self.rx_last_at = Some(c.at);
            }
            self.master.handle_char(RxChar {
                byte: c.byte,
                time,
                error: c.error,
            });
        }
    }

    /// A write failed: let what did get out leave the line (best effort), then tell the
    /// master, which holds the bus for two start pauses.
    async fn abort_after_failed_write(&mut self) {
        let io = &mut self.io;
        let flush = std::future::poll_fn(|cx| io.poll_flush(cx));
        let _ = tokio::time::timeout(Duration::from_secs(1), flush).await;
        let now = self.now();
        self.master.abort(now);
    }
}
