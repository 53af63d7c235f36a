//! Simulated MOVIDRIVE drives on a [`CharIo`] (feature `sim`).
//!
//! [`SimulatedMovidrive`] is the thin MOVILINK front-end onto the one drive model,
//! [`drive_sim::movidrive::Movidrive`]: the sans-IO [`Slave`] frames the requests, decides
//! whether to answer (own address, point-to-point 254; its group P811 and broadcast 255 are
//! executed without an answer), runs the cyclic handshake and the P812 monitor, and calls the
//! drive through [`Backend`]. The front-end only maps the drive's return codes, feeds the
//! process data and the cyclic-telegram times, ticks the drive and follows P810/P811/P812
//! when they are written. [`SimulatedBus`] puts several of them on one line.
//!
//! Timing ([`SimulatedMovidrive::set_timing`]): by default the times are tokio's and a
//! response starts a start pause after the request (tokio's 1 ms timer resolution may add up
//! to 1 ms, the drive's response latency). Untimed, a virtual clock advances by one character
//! time per character received plus a start pause per response, and nothing is waited for
//! (benchmarks of the master's software overhead).
//!
//! ```
//! use movilink::driver::{DriverConfig, MasterDriver};
//! use movilink::sim::SimulatedMovidrive;
//! use movilink::Address;
//! use drive_transport::link::{self, LinkConfig};
//!
//! # #[tokio::main(flavor = "current_thread", start_paused = true)]
//! # async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let (port, wire) = link::pair(LinkConfig::new(9600));
//! let mut drive = SimulatedMovidrive::new(1);
//! let sim = tokio::spawn(async move { drive.serve(wire).await });
//!
//! let mut master = MasterDriver::new(port, DriverConfig::default());
//! let drive1 = Address::new(1).ok_or("address")?;
//! assert_eq!(master.read(drive1, 8301).await?, drive_sim::movidrive::UNIT_TYPE);
//! master.write_volatile(drive1, 8470, 1500).await?; // P130 ramp t11 up CW = 1.5 s
//! assert_eq!(master.read(drive1, 8470).await?, 1500);
//! drop(master); // closes the line: the simulated drive stops serving
//! sim.await??;
//! # Ok(())
//! # }
//! ```

use std::io;
use std::pin::Pin;
use std::time::Duration;

use drive_sim::SimTime;
use drive_sim::movidrive::{BusSource, Movidrive};
use tokio::time::{Instant as TokioInstant, Sleep};

use crate::driver::io::{Woken, read_or_sleep, write_all};
use crate::driver::{CharIo, ReceivedChar};
use crate::error::ReturnCode;
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, ParamChannel};
use crate::receiver::{AddressFilter, Receiver, RxChar, RxEvent};
use crate::slave::{Backend, Slave, SlaveConfig, SlaveEvent};
use crate::timing::{Instant, LineTiming};

/// Received characters handled per read.
const RX_BUF: usize = 64;

/// The [`Backend`] of a simulated drive: the drive model plus the time of the character
/// being processed.
#[derive(Debug)]
struct DriveBackend {
    drive: Movidrive,
    now: SimTime,
    /// Whether the request completed by the current character is cyclic (known before the
    /// slave processes it, from the serve loop's own framing).
    cyclic: bool,
}

fn return_code(rc: drive_sim::movidrive::ReturnCode) -> ReturnCode {
    ReturnCode::new(rc.error_class, rc.error_code, rc.additional_code)
}

impl Backend for DriveBackend {
    fn param(&mut self, request: &ParamChannel) -> Result<u32, ReturnCode> {
        let service = request.management.service_code();
        // drive-sim answers Read Attribute in MOVILINK's layout (`AttributeInfo`) already.
        let data = self
            .drive
            .param_request(service, request.index, request.data, self.now)
            .map_err(return_code)?;
        Ok(data)
    }

    fn process_data(&mut self, output: &[u16], input: &mut [u16]) {
        self.drive.process_output(output, self.now);
        if self.cyclic {
            self.drive.cyclic_telegram_received(self.now);
        }
        self.drive.process_input(input);
    }

    fn on_timeout(&mut self) {
        // The drive model runs its own P812 monitor (and P833 reaction) when it is advanced;
        // it fires once the time since the last cyclic telegram *exceeds* P812, the slave at
        // the deadline itself, hence the extra microsecond.
        self.drive.tick(self.now + Duration::from_micros(1));
    }
}

/// Clock of a serve loop.
#[derive(Debug, Clone, Copy)]
struct SimClock {
    timing: bool,
    epoch: Option<TokioInstant>,
    /// Virtual time (µs) of the untimed mode.
    virt: u64,
}

impl SimClock {
    fn new() -> Self {
        Self {
            timing: true,
            epoch: None,
            virt: 0,
        }
    }

    fn epoch(&mut self) -> TokioInstant {
        *self.epoch.get_or_insert_with(TokioInstant::now)
    }
}

/// The MOVILINK slave front-end onto [`drive_sim::movidrive::Movidrive`]; see the
/// [module docs](self).
#[derive(Debug)]
pub struct SimulatedMovidrive {
    slave: Slave<DriveBackend>,
    clock: SimClock,
}

impl SimulatedMovidrive {
    /// A drive at address `address` (P810, clamped to 0–99) with bus control via RS-485
    /// (P100 = RS485, P101 = RS485), so that process data move it.
    pub fn new(address: u8) -> Self {
        let mut drive = Movidrive::new(address);
        drive.set_bus_control(BusSource::Rs485, SimTime::ZERO);
        let config = config_of(&drive, SlaveConfig::new(Address::NO_GROUP));
        Self {
            slave: Slave::new(
                config,
                DriveBackend {
                    drive,
                    now: SimTime::ZERO,
                    cyclic: false,
                },
            ),
            clock: SimClock::new(),
        }
    }

    /// The drive model.
    pub fn movidrive(&self) -> &Movidrive {
        &self.slave.backend().drive
    }

    /// The drive model, for changing (communication parameters written here take effect with
    /// the next request).
    pub fn movidrive_mut(&mut self) -> &mut Movidrive {
        &mut self.slave.backend_mut().drive
    }

    /// The protocol configuration in use (address, group, P812 timeout).
    pub fn slave_config(&self) -> SlaveConfig {
        *self.slave.config()
    }

    /// Real (tokio) timing, the default, or a virtual clock that waits for nothing.
    pub fn set_timing(&mut self, on: bool) {
        self.clock.timing = on;
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails. Answers only correct
    /// telegrams addressed to the drive (own address and 254; its group and 255 are executed
    /// without an answer) and follows P810/P811/P812/P833 as they are written.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        let mut clock = self.clock;
        let r = serve_drives(std::slice::from_mut(self), &mut clock, io).await;
        self.clock = clock;
        r
    }

    /// The time of the character being processed, for the drive model and the slave.
    fn set_now(&mut self, now: Instant) {
        self.slave.backend_mut().now = SimTime::from_micros(now.as_micros());
    }

    /// Handle the slave's events: follow configuration changes, count cyclic telegrams
    /// without process data. Returns whether a response was queued.
    fn drain_events(&mut self) -> bool {
        let mut answered = false;
        while let Some(event) = self.slave.poll_event() {
            if let SlaveEvent::Received {
                telegram,
                answered: a,
            } = event
            {
                answered |= a;
                let backend = self.slave.backend_mut();
                let t = telegram.pdu_type();
                if t.is_cyclic() && t.pd_words() == 0 {
                    backend.drive.cyclic_telegram_received(backend.now);
                }
                let current = *self.slave.config();
                let wanted = config_of(&self.slave.backend().drive, current);
                if wanted != current {
                    self.slave.set_config(wanted);
                }
            }
        }
        answered
    }
}

/// The slave configuration the drive's parameters P810, P811 and P812 ask for.
fn config_of(drive: &Movidrive, current: SlaveConfig) -> SlaveConfig {
    SlaveConfig {
        address: Address::unicast(drive.address()).unwrap_or(current.address),
        group: Address::group(drive.group_address()).unwrap_or(Address::NO_GROUP),
        rs485_timeout: drive.rs485_timeout().unwrap_or(Duration::ZERO),
        ..current
    }
}

/// Several simulated drives on one line, each answering its own address.
#[derive(Debug)]
pub struct SimulatedBus {
    drives: Vec<SimulatedMovidrive>,
    clock: SimClock,
}

impl SimulatedBus {
    /// Drives at `addresses` (duplicates are kept once).
    pub fn new(addresses: &[u8]) -> Self {
        let mut drives: Vec<SimulatedMovidrive> = Vec::with_capacity(addresses.len());
        for &a in addresses {
            if !drives.iter().any(|d| d.movidrive().address() == a.min(99)) {
                drives.push(SimulatedMovidrive::new(a));
            }
        }
        Self {
            drives,
            clock: SimClock::new(),
        }
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails; see
    /// [`SimulatedMovidrive::serve`].
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        serve_drives(&mut self.drives, &mut self.clock, io).await
    }

    /// The drive currently at `address` (P810).
    pub fn drive(&self, address: u8) -> Option<&SimulatedMovidrive> {
        self.drives
            .iter()
            .find(|d| d.movidrive().address() == address)
    }

    /// The drive currently at `address` (P810), for changing.
    pub fn drive_mut(&mut self, address: u8) -> Option<&mut SimulatedMovidrive> {
        self.drives
            .iter_mut()
            .find(|d| d.movidrive().address() == address)
    }

    /// All drives.
    pub fn drives(&self) -> &[SimulatedMovidrive] {
        &self.drives
    }

    /// Real (tokio) timing, the default, or a virtual clock that waits for nothing.
    pub fn set_timing(&mut self, on: bool) {
        self.clock.timing = on;
    }
}

/// The serve loop shared by one drive and a bus.
async fn serve_drives<IO: CharIo>(
    drives: &mut [SimulatedMovidrive],
    clock: &mut SimClock,
    mut io: IO,
) -> io::Result<()> {
    let timing = drives
        .first()
        .map_or(LineTiming::MOVILINK, |d| d.slave.config().timing);
    let char_us = u64::try_from(timing.char_time.as_micros()).unwrap_or(u64::MAX);
    let pause_us = u64::try_from(timing.start_pause.as_micros()).unwrap_or(u64::MAX);
    let epoch = clock.epoch();
    let to_instant = |t: TokioInstant| Instant::from_duration(t.saturating_duration_since(epoch));
    let mut bus = Framing {
        receiver: Receiver::new(Direction::Request, AddressFilter::Any, timing),
        pause_us,
    };
    let mut rx = vec![ReceivedChar::new(0, epoch); RX_BUF];
    let mut sleep: Pin<Box<Sleep>> = Box::pin(tokio::time::sleep_until(epoch));
    let mut buf = [0u8; MAX_TELEGRAM_LEN];
    loop {
        for d in drives.iter_mut() {
            d.drain_events();
            while let Some(n) = d.slave.poll_transmit(&mut buf) {
                write_all(&mut io, buf.get(..n).unwrap_or(&[])).await?;
            }
        }
        let deadline = if clock.timing {
            drives
                .iter()
                .filter_map(|d| d.slave.poll_timeout())
                .chain(bus.receiver.poll_timeout())
                .min()
        } else {
            None
        };
        if let Some(deadline) = deadline {
            let at = epoch + deadline.as_duration();
            if at <= TokioInstant::now() {
                bus.timeout(drives, to_instant(TokioInstant::now()));
                continue;
            }
            sleep.as_mut().reset(at);
        }
        let armed = deadline.map(|_| sleep.as_mut());
        match read_or_sleep(&mut io, &mut rx, armed).await? {
            Woken::Read(0) => return Ok(()),
            Woken::Read(n) => {
                for c in rx.iter().take(n) {
                    let time = if clock.timing {
                        to_instant(c.at)
                    } else {
                        clock.virt = clock.virt.saturating_add(char_us);
                        Instant::from_micros(clock.virt)
                    };
                    bus.char(
                        drives,
                        RxChar {
                            byte: c.byte,
                            time,
                            error: c.error,
                        },
                    );
                }
                if !clock.timing {
                    // Untimed: jump to the confirmation of a complete request (the quiet line
                    // after it), which is also when its response is due.
                    if let Some(t) = bus.confirmation() {
                        clock.virt = clock.virt.max(t.as_micros());
                        bus.timeout(drives, t);
                    }
                }
            }
            Woken::Timer => bus.timeout(drives, to_instant(TokioInstant::now())),
        }
    }
}

/// The serve loop's own framing of every request on the line (any address), in step with the
/// drives' receivers: it tells the drive model whether a request is cyclic before the slave
/// processes it, and when the request ended.
struct Framing {
    receiver: Receiver,
    pause_us: u64,
}

impl Framing {
    /// Feed one character to the framing and to every drive.
    fn char(&mut self, drives: &mut [SimulatedMovidrive], c: RxChar) {
        let end = self.receiver.last_char_time();
        let event = self.receiver.handle_char(c);
        let (cyclic, now) = request_info(event, end, c.time);
        for d in drives.iter_mut() {
            d.set_now(now);
            d.slave.backend_mut().cyclic = cyclic;
            d.slave.handle_char(c);
            d.slave.backend_mut().cyclic = false;
            d.drain_events();
        }
    }

    /// Advance the framing and every drive to `now`.
    fn timeout(&mut self, drives: &mut [SimulatedMovidrive], now: Instant) {
        let end = self.receiver.last_char_time();
        let event = self.receiver.handle_timeout(now);
        let (cyclic, at) = request_info(event, end, now);
        for d in drives.iter_mut() {
            d.set_now(at);
            d.slave.backend_mut().cyclic = cyclic;
            d.slave.handle_timeout(now);
            d.slave.backend_mut().cyclic = false;
            d.set_now(now);
            d.drain_events();
        }
    }

    /// When a complete request's end will be confirmed, if one awaits confirmation.
    fn confirmation(&self) -> Option<Instant> {
        let (t, last) = (
            self.receiver.poll_timeout()?,
            self.receiver.last_char_time()?,
        );
        (t.as_micros() == last.as_micros().saturating_add(self.pause_us)).then_some(t)
    }
}

/// Whether `event` completed a cyclic request, and the time the drive model should see: the
/// request's end (`end`) for a completed request, else `now`.
fn request_info(event: Option<RxEvent>, end: Option<Instant>, now: Instant) -> (bool, Instant) {
    match event {
        Some(RxEvent::Telegram(t)) => (t.pdu_type().is_cyclic(), end.unwrap_or(now)),
        _ => (false, now),
    }
}
