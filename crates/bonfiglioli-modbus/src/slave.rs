//! The drive (slave) state machine, sans-IO: frames requests with [`ModbusFraming`], keeps the
//! diagnostic counters of function code 8, checks what the manual checks, delegates parameter
//! reads and writes to a [`Backend`] (the simulated drive) and sends the response after the
//! drive's answer delay.
//!
//! * Addresses: its own address is answered; broadcast (0) writes are executed without an
//!   answer (a broadcast read or diagnostic is ignored, ch. 6.1); other addresses only count as
//!   bus messages.
//! * A request whose check fails, or with a UART error, gets no answer (ch. 6.5) and counts as
//!   a bus communication error (0x0C; an overrun also as 0x12).
//! * Exceptions (ch. 6.6): an unknown function or diagnostic sub-function → 1; a register
//!   count other than 1 → 2; a wrong length or a diagnostic data field other than 0 → 3; a
//!   parameter the backend refuses → what it says (2, 3 or 4: the backend keeps the VABus
//!   error register, parameter 11).
//! * The response starts no earlier than [`SlaveConfig::answer_delay`] after the request's end
//!   (the manual: 10 ms), and is dropped if other characters arrive on the bus before it was
//!   sent.
//! * Every accepted exchange for this drive is reported to the backend
//!   ([`Backend::valid_exchange`]: the watchdog of parameter 413).

use core::time::Duration;

use drive_core::framing::{LineError, Receiver, RxEvent};
use drive_core::time::earliest;
use drive_core::{
    CharError, Endpoint, Instant, LineSettings, Queue, RxChar, SlaveEndpoint, Timers,
};

use crate::frame::{Address, DiagSubFunction, ExceptionCode, Request, Response, StartAddress};
use crate::framing::{FrameError, MAX_FRAME, ModbusFraming, Mode, Received, Side, encode_response};
use crate::pdu::PduError;

/// How wide a parameter access is: function codes 3/6 or 100/101.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Width {
    /// 16 bits (FC 3 and 6).
    Word,
    /// 32 bits (FC 100 and 101).
    Long,
}

impl Width {
    /// The width the manual gives parameter `param` (uInt/Int: 16 bits, Long: 32 bits); None
    /// for a parameter outside the table or one whose data type the manual does not give
    /// (nothing is guessed: the caller asks its user).
    pub fn of_param(param: u16) -> Option<Width> {
        match drive_profile::bonfiglioli::by_number(param)?
            .data_type
            .bits()?
        {
            16 => Some(Width::Word),
            32 => Some(Width::Long),
            _ => None,
        }
    }
}

/// The drive behind the protocol; the simulated drive implements it. Its own deadlines (ramp,
/// watchdog) are its [`Timers`].
pub trait Backend: Timers {
    /// Read the parameter of `start` with `width`; the value (16-bit values in the low half)
    /// or the exception to answer (the backend sets its VABus error register for exception 4).
    fn read(
        &mut self,
        start: StartAddress,
        width: Width,
        now: Instant,
    ) -> Result<u32, ExceptionCode>;

    /// Write `value` to the parameter of `start` with `width`.
    fn write(
        &mut self,
        start: StartAddress,
        width: Width,
        value: u32,
        now: Instant,
    ) -> Result<(), ExceptionCode>;

    /// A valid request for this drive (own address or broadcast) was received at `now`.
    fn valid_exchange(&mut self, now: Instant) {
        let _ = now;
    }
}

/// The manual's answer delay: a drive answers no earlier than 10 ms after a request.
pub const ANSWER_DELAY: Duration = Duration::from_millis(10);

/// Configuration of a [`Slave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Own address, 1–247.
    pub address: Address,
    /// RTU or ASCII.
    pub mode: Mode,
    /// The line (timing of frames).
    pub line: LineSettings,
    /// From the end of a request to the start of the answer.
    pub answer_delay: Duration,
}

impl SlaveConfig {
    /// Address `address`, `mode`, on `line`, with the manual's answer delay.
    pub const fn new(address: Address, mode: Mode, line: LineSettings) -> Self {
        Self {
            address,
            mode,
            line,
            answer_delay: ANSWER_DELAY,
        }
    }
}

/// The diagnostic counters of function code 8 (ch. 6.4.5), 16 bits each, wrapping.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct Counters {
    /// 0x0B: valid messages (any address).
    pub bus_messages: u16,
    /// 0x0C: messages with a CRC/LRC, parity, framing or overrun error.
    pub bus_communication_errors: u16,
    /// 0x0D: exception responses sent.
    pub bus_exception_errors: u16,
    /// 0x0E: messages for this slave's address.
    pub slave_messages: u16,
    /// 0x0F: broadcast messages.
    pub slave_no_response: u16,
    /// 0x12: messages with a character overrun.
    pub bus_character_overruns: u16,
}

impl Counters {
    /// The value sub-function `sub` returns (0x10 and 0x11 are always 0), if it is a counter.
    pub const fn get(&self, sub: DiagSubFunction) -> Option<u16> {
        Some(match sub.0 {
            0x0B => self.bus_messages,
            0x0C => self.bus_communication_errors,
            0x0D => self.bus_exception_errors,
            0x0E => self.slave_messages,
            0x0F => self.slave_no_response,
            0x10 | 0x11 => 0,
            0x12 => self.bus_character_overruns,
            _ => return None,
        })
    }
}

fn bump(c: &mut u16) {
    *c = c.wrapping_add(1);
}

/// What happened; drained with [`Slave::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlaveEvent {
    /// A request for this drive (or a broadcast) was processed.
    Received {
        /// The address it was sent to.
        address: Address,
        /// The request, or why its PDU did not decode.
        request: Result<Request, PduError>,
        /// The response queued for it (None for a broadcast).
        response: Option<Response>,
    },
    /// Received characters were dropped.
    Rejected(FrameError),
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    bytes: [u8; MAX_FRAME],
    len: usize,
    not_before: Instant,
}

/// The drive state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Slave<B> {
    config: SlaveConfig,
    backend: B,
    receiver: Receiver<ModbusFraming, MAX_FRAME>,
    counters: Counters,
    now: Instant,
    /// End of the last character received (a request's end, once it is confirmed).
    last_rx: Instant,
    tx: Option<Pending>,
    events: Queue<SlaveEvent, 4>,
}

impl<B: Backend> Slave<B> {
    /// A drive with `config` executing on `backend`.
    pub fn new(config: SlaveConfig, backend: B) -> Self {
        Self {
            receiver: Receiver::new(ModbusFraming::new(config.mode, Side::Slave, &config.line)),
            config,
            backend,
            counters: Counters::default(),
            now: Instant::ZERO,
            last_rx: Instant::ZERO,
            tx: None,
            events: Queue::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Answer `address` from now on (the drive's address parameter was written).
    pub fn set_address(&mut self, address: Address) {
        self.config.address = address;
    }

    /// Receive in `mode` from now on (the drive's protocol type was written: effective at once,
    /// ch. 6). An answer already queued goes out as it was framed; a frame being received is
    /// dropped.
    pub fn set_mode(&mut self, mode: Mode) {
        if mode != self.config.mode {
            self.config.mode = mode;
            self.receiver = Receiver::new(ModbusFraming::new(mode, Side::Slave, &self.config.line));
        }
    }

    /// The diagnostic counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The backend.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The backend, for changing.
    pub fn backend_mut(&mut self) -> &mut B {
        &mut self.backend
    }

    /// When the receiver needs the time: not before the answer could go out anyway. The
    /// receiver judges characters by their own times, so a frame confirmed late is the same
    /// frame; waking once, at the answer time, instead of at the confirmation and again at the
    /// answer, spares a timer (a runtime's timer ends late by up to its resolution, 1 ms with
    /// tokio) on every exchange.
    fn receiver_deadline(&self) -> Option<Instant> {
        self.receiver
            .poll_timeout()
            .map(|t| t.later(self.last_rx + self.config.answer_delay))
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop()
    }

    fn on_rx(&mut self, ev: RxEvent<Received, FrameError>) {
        match ev {
            RxEvent::Frame(Received::Request(address, request)) => {
                self.on_request(address, request)
            }
            // A response on the bus (another drive answering): a valid message.
            RxEvent::Frame(Received::Response(..)) => bump(&mut self.counters.bus_messages),
            RxEvent::Rejected(e) => {
                if matches!(
                    e,
                    FrameError::Checksum { .. } | FrameError::Line(LineError::Char(_))
                ) {
                    bump(&mut self.counters.bus_communication_errors);
                }
                if matches!(e, FrameError::Line(LineError::Char(CharError::Overrun))) {
                    bump(&mut self.counters.bus_character_overruns);
                }
                self.events.push(SlaveEvent::Rejected(e));
            }
        }
    }

    fn on_request(&mut self, address: Address, request: Result<Request, PduError>) {
        bump(&mut self.counters.bus_messages);
        let now = self.now;
        let broadcast = address.is_broadcast();
        if broadcast {
            bump(&mut self.counters.slave_no_response);
        } else if address == self.config.address {
            bump(&mut self.counters.slave_messages);
        } else {
            return;
        }
        self.backend.valid_exchange(now);
        let response = match request {
            Err(e) => exception_for(0, e),
            Ok(req) => self.execute(&req, broadcast),
        };
        let response = match response {
            Some(r) if !broadcast => Some(r),
            _ => None,
        };
        if let Some(r) = response {
            if matches!(r, Response::Exception { .. }) {
                bump(&mut self.counters.bus_exception_errors);
            }
            let mut bytes = [0u8; MAX_FRAME];
            if let Ok(len) = encode_response(self.config.mode, address, &r, &mut bytes) {
                self.tx = Some(Pending {
                    bytes,
                    len,
                    // From the request's end (its last character), not from the silence that
                    // confirmed it.
                    not_before: (self.last_rx + self.config.answer_delay).later(now),
                });
            }
        }
        self.events.push(SlaveEvent::Received {
            address,
            request,
            response,
        });
    }

    /// The response to `req` (None: nothing to answer, a broadcast read).
    fn execute(&mut self, req: &Request, broadcast: bool) -> Option<Response> {
        let now = self.now;
        let fc = req.function().code();
        let exc = |code| Response::Exception { function: fc, code };
        if broadcast && !req.is_write() {
            return None;
        }
        Some(match *req {
            Request::ReadWord { count, .. } if count != 1 => {
                exc(ExceptionCode::ILLEGAL_DATA_ADDRESS)
            }
            Request::ReadWord { start, .. } => match self.backend.read(start, Width::Word, now) {
                Ok(v) => Response::ReadWord { value: v as u16 },
                Err(code) => exc(code),
            },
            Request::ReadLong { start } => match self.backend.read(start, Width::Long, now) {
                Ok(value) => Response::ReadLong { value },
                Err(code) => exc(code),
            },
            Request::WriteWord { start, value } => {
                match self
                    .backend
                    .write(start, Width::Word, u32::from(value), now)
                {
                    Ok(()) => Response::WriteWord { start, value },
                    Err(code) => exc(code),
                }
            }
            Request::WriteLong { start, value } => {
                match self.backend.write(start, Width::Long, value, now) {
                    Ok(()) => Response::WriteLong { start, value },
                    Err(code) => exc(code),
                }
            }
            Request::Diagnostics { sub, .. } if !sub.is_supported() => {
                exc(ExceptionCode::ILLEGAL_FUNCTION)
            }
            Request::Diagnostics { data, .. } if data != 0 => {
                exc(ExceptionCode::ILLEGAL_DATA_VALUE)
            }
            Request::Diagnostics { sub, .. } if sub == DiagSubFunction::CLEAR_COUNTERS => {
                self.counters = Counters::default();
                Response::Diagnostics { sub, data: 0 }
            }
            Request::Diagnostics { sub, .. } => Response::Diagnostics {
                sub,
                data: self.counters.get(sub).unwrap_or(0),
            },
        })
    }
}

/// The exception answer to a PDU that did not decode.
fn exception_for(_: u8, e: PduError) -> Option<Response> {
    let function = match e {
        PduError::UnknownFunction(f) => f,
        PduError::Length { function, .. } => function,
        _ => return None,
    };
    Some(Response::Exception {
        function: function & 0x7F,
        code: e.exception(),
    })
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
    fn handle_char(&mut self, c: RxChar) {
        self.now = self.now.later(c.time);
        self.last_rx = c.time;
        // Bus activity before the answer went out: the answer is dropped.
        self.tx = None;
        if let Some(ev) = self.receiver.handle_char(c) {
            self.on_rx(ev);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.now = self.now.later(now);
        if let Some(ev) = self.receiver.handle_timeout(now) {
            self.on_rx(ev);
        }
        self.backend.handle_timeout(now);
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let p = self.tx.as_ref()?;
        if now < p.not_before {
            return None;
        }
        let dst = buf.get_mut(..p.len)?;
        dst.copy_from_slice(p.bytes.get(..p.len)?);
        let n = p.len;
        self.tx = None;
        self.receiver.reset();
        Some(n)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        earliest(
            earliest(self.receiver_deadline(), self.tx.map(|p| p.not_before)),
            self.backend.poll_timeout(),
        )
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        earliest(self.receiver_deadline(), self.tx.map(|p| p.not_before))
    }

    fn max_frame_len(&self) -> usize {
        MAX_FRAME
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_come_from_the_table_and_unknown_types_are_not_guessed() {
        // 372 rated speed: uInt; 481 fixed frequency 2: Long (ch. 8.1); 412 Local/Remote: the
        // manual gives no type; 1600: no such parameter.
        assert_eq!(Width::of_param(372), Some(Width::Word));
        assert_eq!(Width::of_param(481), Some(Width::Long));
        assert_eq!(Width::of_param(412), None);
        assert_eq!(Width::of_param(1600), None);
    }
}
