//! Simulated MOVIDRIVE drives on a [`CharIo`] (feature `sim`).
//!
//! [`SimulatedMovidrive`] is the thin MOVILINK front-end onto the one drive model,
//! [`drive_sim::movidrive::Movidrive`]: the sans-IO [`Slave`] frames the requests, decides
//! whether to answer (own address, point-to-point 254; its group P811 and broadcast 255 are
//! executed without an answer), runs the cyclic handshake, and hands each request to the drive
//! through [`Backend`] with its [`RequestContext`] (end time, cyclic or not). The drive model
//! answers in the shared parameter-channel types and monitors P812 itself (the front-end only
//! wakes it at [`Movidrive::rs485_deadline`]); the front-end follows P810/P811 when they are
//! written. [`SimulatedBus`] puts several of them on one line; both are served by the runtime
//! layer's [`serve`](drive_core::rt::serve) loop.
//!
//! Timing follows the line ([`SimulatedMovidrive::with_line`]; 9600 8E1 by default) and the
//! clock ([`SimulatedMovidrive::set_clock`]): on [`Clock::Real`] the times are tokio's and a
//! response starts a start pause after the request (tokio's 1 ms timer resolution may add up
//! to 1 ms, the drive's response latency). On [`Clock::Virtual`] the clock advances by one
//! character time per character received and jumps to each response, and nothing is waited
//! for (benchmarks of the master's software overhead).
//!
//! ```
//! use movilink::driver::{DriverConfig, MovilinkDriver, ParamServices};
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
//! let mut master = MovilinkDriver::new(port, DriverConfig::default());
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

use drive_core::rt::{self, Bus, CharIo, Clock, Shell, Simulated};
use drive_core::{Instant, LineSettings, SlaveEndpoint, Timers};
use drive_sim::movidrive::{BusSource, Movidrive};

use crate::error::ReturnCode;
use crate::frame::{Address, ParamChannel};
use crate::slave::{Backend, RequestContext, Slave, SlaveConfig, SlaveEvent};
use crate::timing::{LINE, LineTiming};

/// The [`Backend`] of a simulated drive: the drive model, in the shared types.
#[derive(Debug)]
struct DriveBackend {
    drive: Movidrive,
}

impl Backend for DriveBackend {
    fn on_request(&mut self, ctx: &RequestContext) {
        // An acyclic request reaches the model through its parameter service or its process
        // data, and both bring the model up to `ctx.end` first; a second tick here would double
        // the model's work per request. The one exception, PARAM + 0PD with "no service" or an
        // undefined service code, the slave answers by itself: nothing in that answer depends on
        // the model, which catches up with the next call.
        if ctx.cyclic {
            self.drive.cyclic_telegram_received(ctx.end);
        }
    }

    fn param(&mut self, ctx: &RequestContext, request: &ParamChannel) -> Result<u32, ReturnCode> {
        self.drive.param(request, ctx.end)
    }

    fn process_data(&mut self, ctx: &RequestContext, output: &[u16], input: &mut [u16]) {
        self.drive.process_output(output, ctx.end);
        self.drive.process_input(input);
    }
}

impl Timers for DriveBackend {
    fn poll_timeout(&self) -> Option<Instant> {
        self.drive.rs485_deadline()
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.drive.tick(now);
    }
}

/// The MOVILINK slave front-end onto [`drive_sim::movidrive::Movidrive`]; see the
/// [module docs](self).
#[derive(Debug)]
pub struct SimulatedMovidrive {
    shell: Shell<Slave<DriveBackend>>,
}

impl SimulatedMovidrive {
    /// A drive at address `address` (P810, clamped to 0–99) on a 9600 8E1 line, with bus
    /// control via RS-485 (P100 = RS485, P101 = RS485), so that process data move it.
    pub fn new(address: u8) -> Self {
        Self::with_line(address, LINE)
    }

    /// A drive at address `address` on a line with `line`'s settings (its character time and
    /// start pause follow them).
    pub fn with_line(address: u8, line: LineSettings) -> Self {
        let mut drive = Movidrive::new(address);
        drive.set_bus_control(BusSource::Rs485, Instant::ZERO);
        let config = SlaveConfig {
            timing: LineTiming::new(line),
            ..config_of(&drive, SlaveConfig::new(Address::NO_GROUP))
        };
        Self {
            shell: Shell::new(Slave::new(config, DriveBackend { drive })),
        }
    }

    /// The drive model.
    pub fn movidrive(&self) -> &Movidrive {
        &self.shell.slave.backend().drive
    }

    /// The drive model, for changing (communication parameters written here take effect with
    /// the next request).
    pub fn movidrive_mut(&mut self) -> &mut Movidrive {
        &mut self.shell.slave.backend_mut().drive
    }

    /// The protocol configuration in use (address, group, line timing).
    pub fn slave_config(&self) -> SlaveConfig {
        *self.shell.slave.config()
    }

    /// [`Clock::Real`] (tokio's clock, the default) or [`Clock::Virtual`] (waits for nothing).
    pub fn set_clock(&mut self, clock: Clock) {
        // The slave keeps its line history: its time goes on from where it is.
        self.shell.set_clock(clock);
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails. Answers only correct
    /// telegrams addressed to the drive (own address and 254; its group and 255 are executed
    /// without an answer) and follows P810/P811/P812/P833 as they are written.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        rt::serve_alone(self, io).await
    }
}

/// The slave configuration the drive's parameters P810 and P811 ask for.
fn config_of(drive: &Movidrive, current: SlaveConfig) -> SlaveConfig {
    SlaveConfig {
        address: Address::unicast(drive.address()).unwrap_or(current.address),
        group: Address::group(drive.group_address()).unwrap_or(Address::NO_GROUP),
        ..current
    }
}

/// Several simulated MOVIDRIVEs on one line, each answering its own address (P810): the
/// runtime layer's [`Bus`]. Build one with [`bus`]; [`Bus::station`] finds a drive by its
/// address.
pub type SimulatedBus = Bus<SimulatedMovidrive>;

/// Drives at `addresses` (duplicates are kept once) on a line with `line`'s settings
/// ([`LINE`]: 9600 8E1).
pub fn bus(addresses: &[u8], line: LineSettings) -> SimulatedBus {
    Bus::new(
        addresses
            .iter()
            .map(|&a| SimulatedMovidrive::with_line(a, line)),
        line,
    )
}

impl Simulated for SimulatedMovidrive {
    /// Follow P810/P811 when they were written.
    fn follow_events(&mut self) {
        while let Some(event) = self.shell.slave.poll_event() {
            if let SlaveEvent::Received { .. } = event {
                let current = *self.shell.slave.config();
                let wanted = config_of(&self.shell.slave.backend().drive, current);
                if wanted != current {
                    self.shell.slave.set_config(wanted);
                }
            }
        }
    }

    /// P810, also when it was written on the model directly (the slave follows it with the
    /// next request).
    fn station_address(&self) -> u8 {
        self.movidrive().address()
    }

    fn shell(&self) -> &Shell<impl SlaveEndpoint> {
        &self.shell
    }

    fn shell_mut(&mut self) -> &mut Shell<impl SlaveEndpoint> {
        &mut self.shell
    }
}
