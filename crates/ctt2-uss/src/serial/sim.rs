//! Simulated NORD drives on a USS line (feature `sim`).
//!
//! [`SimulatedDrive`] is the thin USS front-end onto the one drive model,
//! [`drive_sim::nord::SimulatedNord`]: the sans-IO [`Slave`] frames the telegrams, answers its
//! address after its response delay, executes broadcasts without answering and mirrors mirror
//! telegrams; the PKW orders become model calls and the process data go to the model's state
//! machine. [`SimulatedBus`] puts several drives (addresses 0–31) on one line; both are served
//! by the runtime layer's [`serve`](drive_core::rt::serve) loop on any [`CharIo`] (a pty, an
//! in-memory link).
//!
//! Orders ([`Order::kind`]) map onto the model as follows:
//!
//! | AK | model call | answer |
//! |---|---|---|
//! | 0 | none | AK 0 |
//! | 1, 6 | `read(pnu, element, set)`: element and set by the IND rule of section 4.6.1.2 ([`IndLayout`](crate::uss::IndLayout): set in bits 8–9 and element in bits 10–15 with parameter sets, else bits 8–15 the element; the element only for AK 6, 7, 8, 11, 12) | AK 1 / 4 with the value |
//! | 2, 3, 7, 8 | `write_width(…, eeprom = true)` (P560 decides whether EEPROM is written) | AK 1/2/4/5 repeating the value |
//! | 11–14 | `write_width(…, eeprom = false)` | as above |
//! | 9 | `array_len(pnu)` | AK 6 with the count |
//!
//! A [`PkwRefusal`](drive_sim::nord::PkwRefusal) becomes AK 7 with its error number in PWE2;
//! a reserved order ID (4, 5, 10, 15) or a word write whose PWE1 is neither 0000h nor FFFFh is
//! answered AK 7 with error 201 "Ungültiges Auftragselement im zuletzt empfangenen Auftrag"
//! (invalid order element).
//!
//! The PKW processing time is a setting ([`SimulatedDrive::set_processing_time`], zero by
//! default): with it, the drive keeps answering the previous order for that long, so the
//! master's plausibility check and repeat are exercised.
//!
//! ```
//! use ctt2_uss::client::{Address, ClientConfig, NordClient};
//! use ctt2_uss::serial::driver::{DriverConfig, UssDriver};
//! use ctt2_uss::serial::sim::SimulatedDrive;
//! use ctt2_uss::serial::{Layout, UssAddress};
//! use drive_core::LineSettings;
//! use drive_profile::nord::Width;
//! use ctt2_uss::uss::Storage;
//! use drive_transport::link::{self, LinkConfig};
//!
//! # #[tokio::main(flavor = "current_thread", start_paused = true)]
//! # async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let line = LineSettings::new(19200); // 8E1
//! let address = UssAddress::new(7).ok_or("address")?;
//! let (port, wire) = link::pair(LinkConfig::from_line(line));
//! let mut drive = SimulatedDrive::new(address, Layout::PKW4_PZD4, line);
//! let sim = tokio::spawn(async move { drive.serve(wire).await });
//!
//! let master = UssDriver::new(port, DriverConfig::new(address, Layout::PKW4_PZD4, line));
//! let mut client = NordClient::new(master, ClientConfig::default());
//! // P102 ramp time, parameter set 2: 2.50 s.
//! let p102 = Address { set: 1, ..Address::new(102) };
//! client.write(p102, Width::Word, Storage::Eeprom, 250).await?;
//! assert_eq!(client.read(p102).await?, 250);
//! drop(client); // closes the line: the simulated drive stops serving
//! sim.await??;
//! # Ok(())
//! # }
//! ```

use std::io;
use std::time::Duration;

use drive_core::rt::{self, Bus, CharIo, Clock, Shell, Simulated};
use drive_core::{Instant, LineSettings, SlaveEndpoint, Timers};
use drive_sim::Ticker;
use drive_sim::nord::SimulatedNord;

use super::slave::{Backend, Slave, SlaveConfig, SlaveEvent};
use super::telegram::{Layout, UssAddress};
use crate::uss::pkw::{DriveError, Order, Pkw, Reply};

/// How often the model is advanced while something in it runs on time (a ramp, a fault
/// reaction), between telegrams.
pub const TICK: Duration = Duration::from_millis(10);

/// Error 201: "Ungültiges Auftragselement im zuletzt empfangenen Auftrag".
const INVALID_ORDER: u16 = 201;

/// The [`Backend`] of a simulated drive: the drive model.
#[derive(Debug)]
struct NordBackend {
    drive: SimulatedNord,
    processing: Duration,
    ticker: Ticker,
}

impl Backend for NordBackend {
    fn execute(&mut self, order: &Pkw, now: Instant) -> Pkw {
        let reply = match Order::from_pkw(order) {
            Ok(o) => crate::sim::execute(&mut self.drive, &o, now),
            Err(_) => Reply::Error(DriveError(INVALID_ORDER)),
        };
        reply.to_pkw(order.pke.pnu(), order.ind)
    }

    fn processing_time(&self, _order: &Pkw) -> Duration {
        self.processing
    }

    fn process(&mut self, request: &[u16], answer: &mut [u16], now: Instant) {
        match request.split_first() {
            Some((&control, setpoints)) => self.drive.process(control, setpoints, now),
            None => self.drive.tick(now),
        }
        self.ticker.advanced(now);
        let actuals = self.drive.actual_values();
        let words = core::iter::once(self.drive.status_word())
            .chain(actuals)
            .chain(core::iter::repeat(0));
        for (slot, w) in answer.iter_mut().zip(words) {
            *slot = w;
        }
    }
}

impl Timers for NordBackend {
    fn poll_timeout(&self) -> Option<Instant> {
        self.ticker.poll_timeout(&self.drive)
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.ticker.handle_timeout(&mut self.drive, now);
    }
}

/// What a simulated drive saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct SimStats {
    /// Telegrams to its address executed and answered.
    pub telegrams: u64,
    /// Broadcasts executed.
    pub broadcasts: u64,
    /// Mirror telegrams sent back.
    pub mirrored: u64,
    /// PKW orders executed (each new order once).
    pub orders: u64,
    /// Telegrams rejected (BCC, parity, length, gaps; not counting other addresses).
    pub rejected: u64,
}

/// A simulated NORD drive on a USS line; see the [module docs](self).
#[derive(Debug)]
pub struct SimulatedDrive {
    shell: Shell<Slave<NordBackend>>,
    stats: SimStats,
}

impl SimulatedDrive {
    /// A drive after power-on at `address`, with telegrams of `layout` on `line`.
    pub fn new(address: UssAddress, layout: Layout, line: LineSettings) -> SimulatedDrive {
        SimulatedDrive::with_config(SlaveConfig::new(address, layout, line))
    }

    /// A drive with a slave configuration of its own (response delay, times).
    pub fn with_config(config: SlaveConfig) -> SimulatedDrive {
        let backend = NordBackend {
            drive: SimulatedNord::new(),
            processing: Duration::ZERO,
            ticker: Ticker::new(TICK),
        };
        SimulatedDrive {
            shell: Shell::new(Slave::new(config, backend)),
            stats: SimStats::default(),
        }
    }

    /// The drive model.
    pub fn drive(&self) -> &SimulatedNord {
        &self.shell.slave.backend().drive
    }

    /// The drive model, for changing (faults, BusIO bits).
    pub fn drive_mut(&mut self) -> &mut SimulatedNord {
        &mut self.shell.slave.backend_mut().drive
    }

    /// How long the drive works on each new PKW order (answering the previous order's answer
    /// meanwhile).
    pub fn set_processing_time(&mut self, time: Duration) {
        self.shell.slave.backend_mut().processing = time;
    }

    /// The address.
    pub fn address(&self) -> UssAddress {
        self.shell.slave.config().address
    }

    /// What it saw.
    pub fn stats(&self) -> SimStats {
        self.stats
    }

    /// The PKW answer the drive sends now (the last order's that is done).
    pub fn current_answer(&self) -> Pkw {
        self.shell.slave.current_answer()
    }

    /// Whether the drive is still working on a PKW order.
    pub fn is_processing(&self) -> bool {
        self.shell.slave.is_processing()
    }

    /// The slave's configuration.
    pub fn config(&self) -> &SlaveConfig {
        self.shell.slave.config()
    }

    /// [`Clock::Real`] (tokio's clock, the default) or [`Clock::Virtual`] (waits for nothing).
    pub fn set_clock(&mut self, clock: Clock) {
        self.shell.set_clock(clock);
    }

    /// Serve telegrams on `io` until it closes (`Ok`) or fails.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        rt::serve_alone(self, io).await
    }
}

/// Several simulated drives on one line, each answering its own address: the runtime layer's
/// [`Bus`]. Build one with [`bus`]; [`Bus::station`] finds a drive by its address.
pub type SimulatedBus = Bus<SimulatedDrive>;

/// Drives at `addresses` (duplicates kept once) with telegrams of `layout` on `line`.
pub fn bus(addresses: &[UssAddress], layout: Layout, line: LineSettings) -> SimulatedBus {
    Bus::new(
        addresses
            .iter()
            .map(|&a| SimulatedDrive::new(a, layout, line)),
        line,
    )
}

impl Simulated for SimulatedDrive {
    /// Count what the slave did.
    fn follow_events(&mut self) {
        while let Some(event) = self.shell.slave.poll_event() {
            match event {
                SlaveEvent::Executed { answer, .. } => {
                    if answer.is_some() {
                        self.stats.telegrams += 1;
                    } else {
                        self.stats.broadcasts += 1;
                    }
                }
                SlaveEvent::Mirrored(_) => self.stats.mirrored += 1,
                SlaveEvent::OrderDone(_) => self.stats.orders += 1,
                SlaveEvent::Rejected(_) => self.stats.rejected += 1,
                _ => {}
            }
        }
    }

    fn shell(&self) -> &Shell<impl SlaveEndpoint> {
        &self.shell
    }

    fn shell_mut(&mut self) -> &mut Shell<impl SlaveEndpoint> {
        &mut self.shell
    }
}
