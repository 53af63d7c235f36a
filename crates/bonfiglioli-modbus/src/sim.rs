//! Simulated ACT and ACU drives on a [`CharIo`] (feature `sim`).
//!
//! [`SimulatedDrive`] is the thin Modbus front-end onto the one drive model,
//! [`drive_sim::bonfiglioli::SimulatedBonfiglioli`]: the sans-IO [`Slave`] frames the requests
//! (RTU or ASCII), answers its own address (broadcast writes are executed without an answer),
//! keeps the FC 8 counters and the 10 ms answer delay, and hands parameter reads and writes to
//! the model, whose refusals carry the exception and set its VABus error register (parameter
//! 11). Every valid request feeds the model's watchdog (parameter 413). The drive's own line
//! parameters say what it serves: *baud rate* 10, *protocol type* 395, *Modbus parity* 1375 and
//! *Modbus address* 1376 are set from the line and mode it is created with. It follows a
//! written address and protocol type at once, as the drive does (ch. 5.2.2, 6): 2 RTU, 3 ASCII,
//! 0 or 1 (VCB bus, P-Bus) no Modbus at all, so it answers nothing until it is created again.
//! A written baud rate or parity takes effect on the drive after a reset (34 = 123) or power
//! cycle (ch. 5.2.1), which the simulation has not: the parameter shows the new value and the
//! line stays as it is. [`SimulatedBus`] puts several drives on one line; both are served by
//! the runtime layer's [`serve`](drive_core::rt::serve) loop.
//!
//! ```
//! use bonfiglioli_modbus::driver::{DriverConfig, ModbusDriver};
//! use bonfiglioli_modbus::frame::{Address, DataSet};
//! use bonfiglioli_modbus::framing::Mode;
//! use bonfiglioli_modbus::sim::SimulatedDrive;
//! use bonfiglioli_modbus::slave::Width;
//! use drive_sim::bonfiglioli::Variant;
//! use drive_transport::link::{self, LinkConfig};
//!
//! # #[tokio::main(flavor = "current_thread", start_paused = true)]
//! # async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let line = Mode::Rtu.line_settings(19200, drive_core::Parity::Even);
//! let (port, wire) = link::pair(LinkConfig::from_line(line));
//! let mut drive = SimulatedDrive::new(1, Variant::Acu, Mode::Rtu, line);
//! let sim = tokio::spawn(async move { drive.serve(wire).await });
//!
//! let mut master = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line));
//! let drive1 = Address::new(1).ok_or("address")?;
//! let ds2 = DataSet::new(2).ok_or("data set")?;
//! master.write(drive1, 372, ds2, Width::Word, 1390).await?; // rated speed, data set 2
//! assert_eq!(master.read(drive1, 372, ds2, Width::Word).await?, 1390);
//! drop(master); // closes the line: the simulated drive stops serving
//! sim.await??;
//! # Ok(())
//! # }
//! ```

use std::io;

use drive_core::rt::{self, Bus, CharIo, Clock, Shell, Simulated};
use drive_core::{Instant, LineSettings, SlaveEndpoint, Timers};
use drive_sim::Ticker;
/// Which drive is simulated (ACT or ACU): drive-sim's, re-exported for [`SimulatedDrive::new`].
pub use drive_sim::bonfiglioli::Variant;
use drive_sim::bonfiglioli::{self as model, SimulatedBonfiglioli};

use crate::frame::{Address, ExceptionCode, StartAddress};
use crate::framing::Mode;
use crate::slave::{Backend, Slave, SlaveConfig, SlaveEvent, Width};

/// The Modbus address parameter (ch. 5.2.2, 5.3.2).
pub const ADDRESS_PARAM: u16 = 1376;
/// The baud rate parameter (ch. 5.2.1).
pub const BAUD_PARAM: u16 = 10;
/// The protocol type parameter (ch. 6).
pub const PROTOCOL_PARAM: u16 = 395;
/// The Modbus parity parameter (ch. 5.2.1).
pub const PARITY_PARAM: u16 = 1375;

/// How often the model is advanced while something in it runs on time (a ramp, a holding
/// time, the watchdog), between requests.
pub const TICK: core::time::Duration = core::time::Duration::from_millis(10);

/// The [`Backend`] of a simulated drive: the drive model.
#[derive(Debug)]
struct DriveBackend {
    drive: SimulatedBonfiglioli,
    ticker: Ticker,
}

fn width(w: Width) -> model::Width {
    match w {
        Width::Word => model::Width::Word,
        Width::Long => model::Width::Long,
    }
}

impl Backend for DriveBackend {
    fn read(&mut self, start: StartAddress, w: Width, now: Instant) -> Result<u32, ExceptionCode> {
        // The raw fields: the model refuses an unknown parameter or data set itself.
        let data_set = (start.raw() >> 12) as u8;
        self.drive
            .read(start.param_bits(), data_set, width(w), now)
            .map_err(|r| ExceptionCode(r.exception()))
    }

    fn write(
        &mut self,
        start: StartAddress,
        w: Width,
        value: u32,
        now: Instant,
    ) -> Result<(), ExceptionCode> {
        let data_set = (start.raw() >> 12) as u8;
        self.drive
            .write(start.param_bits(), data_set, width(w), value, now)
            .map_err(|r| ExceptionCode(r.exception()))
    }

    fn valid_exchange(&mut self, now: Instant) {
        // The watchdog sees the quiet time up to this request before the request feeds it.
        self.drive.tick(now);
        self.drive.valid_exchange(now);
    }
}

impl Timers for DriveBackend {
    fn poll_timeout(&self) -> Option<Instant> {
        self.ticker.poll_timeout(&self.drive)
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.ticker.handle_timeout(&mut self.drive, now);
    }
}

/// A simulated drive on a Modbus line; see the [module docs](self).
#[derive(Debug)]
pub struct SimulatedDrive {
    shell: Shell<Slave<DriveBackend>>,
    /// Protocol type 395 is neither RTU nor ASCII: the drive speaks no Modbus.
    silent: bool,
}

impl SimulatedDrive {
    /// A drive of `variant` at `address` (clamped to 1–247), speaking `mode` on `line`; its
    /// parameters 1376, 395, 1375 and 10 are set to them (10 stays at its factory 4 = 19200
    /// where the drive has no code for the line's rate: [`drive_profile::bonfiglioli::link`]).
    pub fn new(address: u8, variant: Variant, mode: Mode, line: LineSettings) -> Self {
        use drive_profile::bonfiglioli::link;
        let address = address.clamp(1, 247);
        let mut drive = SimulatedBonfiglioli::new(variant);
        let protocol = match mode {
            Mode::Rtu => link::PROTOCOL_RTU,
            Mode::Ascii => link::PROTOCOL_ASCII,
        };
        let settings = [
            (ADDRESS_PARAM, Some(u16::from(address))),
            (PROTOCOL_PARAM, Some(protocol)),
            (PARITY_PARAM, Some(link::parity_code(line.parity))),
            (BAUD_PARAM, link::baud_code(line.baud)),
        ];
        for (param, value) in settings {
            // 16-bit parameters that exist once, each value in its range: the writes cannot
            // fail.
            if let Some(v) = value {
                let _ = drive.write(param, 0, model::Width::Word, u32::from(v), Instant::ZERO);
            }
        }
        let config = SlaveConfig::new(
            Address::new(address).unwrap_or(Address::BROADCAST),
            mode,
            line,
        );
        Self {
            shell: Shell::new(Slave::new(
                config,
                DriveBackend {
                    drive,
                    ticker: Ticker::new(TICK),
                },
            )),
            silent: false,
        }
    }

    /// The drive model.
    pub fn drive(&self) -> &SimulatedBonfiglioli {
        &self.shell.slave.backend().drive
    }

    /// The drive model, for changing (inputs, faults).
    pub fn drive_mut(&mut self) -> &mut SimulatedBonfiglioli {
        &mut self.shell.slave.backend_mut().drive
    }

    /// The diagnostic counters of function code 8.
    pub fn counters(&self) -> &crate::slave::Counters {
        self.shell.slave.counters()
    }

    /// The address the drive answers.
    pub fn address(&self) -> Address {
        self.shell.slave.config().address
    }

    /// [`Clock::Real`] (tokio's clock, the default) or [`Clock::Virtual`] (waits for nothing).
    pub fn set_clock(&mut self, clock: Clock) {
        self.shell.set_clock(clock);
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        rt::serve_alone(self, io).await
    }
}

/// Several simulated drives on one line, each answering its own address (parameter 1376): the
/// runtime layer's [`Bus`]. Build one with [`bus`]; [`Bus::station`] finds a drive by its
/// address.
pub type SimulatedBus = Bus<SimulatedDrive>;

/// Drives of `variant` at `addresses` (duplicates kept once) speaking `mode` on `line`.
pub fn bus(addresses: &[u8], variant: Variant, mode: Mode, line: LineSettings) -> SimulatedBus {
    Bus::new(
        addresses
            .iter()
            .map(|&a| SimulatedDrive::new(a, variant, mode, line)),
        line,
    )
}

impl Simulated for SimulatedDrive {
    /// Follow the Modbus address (parameter 1376) and the protocol type (395) once a request
    /// wrote them.
    fn follow_events(&mut self) {
        while let Some(event) = self.shell.slave.poll_event() {
            if let SlaveEvent::Received { .. } = event {
                // From the store, not through a read: a read's refusal would land in the
                // drive's error register.
                let store = self.shell.slave.backend().drive.store();
                let protocol = store.read(PROTOCOL_PARAM, 0).ok();
                let wanted = store
                    .read(ADDRESS_PARAM, 0)
                    .or_else(|_| store.read(ADDRESS_PARAM, 1))
                    .ok()
                    .and_then(|a| u8::try_from(a).ok())
                    .and_then(Address::new)
                    .filter(|a| !a.is_broadcast());
                if let Some(a) = wanted
                    && a != self.shell.slave.config().address
                {
                    self.shell.slave.set_address(a);
                }
                match protocol.and_then(|p| u16::try_from(p).ok()) {
                    Some(drive_profile::bonfiglioli::link::PROTOCOL_RTU) => {
                        self.shell.slave.set_mode(Mode::Rtu);
                    }
                    Some(drive_profile::bonfiglioli::link::PROTOCOL_ASCII) => {
                        self.shell.slave.set_mode(Mode::Ascii);
                    }
                    Some(_) => self.silent = true,
                    None => {}
                }
            }
        }
    }

    /// VCB bus or P-Bus (395 = 0, 1): no Modbus frame is understood (ch. 5.1).
    fn hears(&self) -> bool {
        !self.silent
    }

    fn shell(&self) -> &Shell<impl SlaveEndpoint> {
        &self.shell
    }

    fn shell_mut(&mut self) -> &mut Shell<impl SlaveEndpoint> {
        &mut self.shell
    }
}
