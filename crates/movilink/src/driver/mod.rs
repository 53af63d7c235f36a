//! The async MOVILINK master (feature `tokio`).
//!
//! [`MovilinkDriver`] is drive-core's one runtime driver ([`drive_core::rt::Driver`]) running
//! the sans-IO [`MovilinkMaster`] on a [`CharIo`] through the runtime layer's [`Port`] (shared
//! with every protocol of drivebus): the port writes what the master hands out, feeds every
//! received character with its arrival time and wakes the master at its deadlines. Every
//! protocol rule (start pause, response timeout, acceptance checks, retries, handshake,
//! broadcast spacing) is the sans-IO master's; the driver adds the service calls and their
//! errors. The SEW parameter services (read, write, …) are
//! [`drive_profile::sew::ParamServices`], written once for MOVILINK and SBus.
//!
//! The line's timing comes from [`DriverConfig::line`] (baud rate, data bits, parity, stop
//! bits). The clock ([`DriverConfig::clock`]):
//!
//! * [`Clock::Real`] (default): times are tokio's (paused in tests, real otherwise); the start
//!   pause, the two start pauses after a failed or aborted telegram and the 25 ms broadcast
//!   spacing are waited for. Tokio's timers have a resolution of 1 ms: a wait ends on the next
//!   tick, never earlier than the rule asks. The master is told the deadline as its time and a
//!   telegram it sends on that wake-up is written with the deadline as its intended start, so
//!   on drive-transport's wire model it starts exactly where the rule puts it; a real port
//!   sends it on the tick, up to 1 ms later.
//! * [`Clock::Virtual`]: a benchmark profile that measures software overhead: the master's
//!   clock advances by one character time per character and jumps over every pause; only the
//!   response timeout is a real timer.
//!
//! The module is split into the driver itself (here), its error ([`DriverError`]), the
//! services (`services.rs`: any parameter service, exchange, probe, and the bus's call of
//! [`ParamServices`]), one request through the runtime driver (`transact.rs`) and cyclic
//! sessions ([`CyclicSession`]). An example with a simulated drive
//! is in the docs of the `sim` module.

mod cyclic;
mod error;
mod services;
mod transact;

use std::time::Duration;

use drive_core::LineSettings;
use drive_core::rt::Driver;
pub use drive_core::rt::{CharIo, Clock, DriverStats, ExchangeTiming, Port, ReceivedChar, Stream};
pub use drive_profile::sew::ParamServices;

pub use self::cyclic::CyclicSession;
pub use self::error::{DriverError, LinkError, RequestError};
use crate::master::{MasterConfig, MovilinkMaster};
use crate::timing::{self, LineTiming};

/// Index of P070 "unit type", read by [`MovilinkDriver::probe`].
pub const UNIT_TYPE_INDEX: u16 = drive_profile::sew::index::UNIT_TYPE;

/// Configuration of a [`MovilinkDriver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverConfig {
    /// Response timeout from the end of a request to the start of its response; default
    /// [`timing::DEFAULT_RESPONSE_TIMEOUT`] (50 ms, the manual's maximum response delay).
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a corrupt answer; default 2 (255 means 256 attempts,
    /// never more).
    pub retries: u8,
    /// [`Clock::Real`] (default): every pause is honoured on tokio's clock.
    /// [`Clock::Virtual`]: benchmark profile measuring software overhead only; see the
    /// [module docs](self).
    pub clock: Clock,
    /// The line's settings, which every time follows (character time, start pause, gap
    /// limit); default 9600 8E1, MOVILINK's.
    pub line: LineSettings,
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
            clock: Clock::Real,
            line: timing::LINE,
            max_char_gap: None,
        }
    }
}

impl DriverConfig {
    /// Character time, start pause and gap limit of [`DriverConfig::line`].
    pub fn line_timing(&self) -> LineTiming {
        let line = LineTiming::new(self.line);
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

/// The async MOVILINK master; see the [module docs](self).
#[derive(Debug)]
pub struct MovilinkDriver<IO> {
    driver: Driver<Port<IO>, MovilinkMaster>,
    config: DriverConfig,
    /// `device_errors`: negative answers ([`DriverError::Device`], or an error in the
    /// parameter channel of an [`MovilinkDriver::exchange`] response).
    stats: DriverStats,
    /// Last process output words sent per address byte (used by [`MovilinkDriver::param`]
    /// with PDU types that carry process data).
    po: Box<[[u16; 3]]>,
    last_timing: Option<ExchangeTiming>,
}

impl<IO: CharIo> MovilinkDriver<IO> {
    /// A driver on `io` (the bus is assumed idle); the epoch of its times is now.
    pub fn new(io: IO, config: DriverConfig) -> Self {
        let port = Port::new(io, config.clock, config.line.char_time());
        Self {
            driver: Driver::new(port, MovilinkMaster::new(config.master_config())),
            config,
            stats: DriverStats::default(),
            po: vec![[0u16; 3]; 256].into_boxed_slice(),
            last_timing: None,
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
        self.driver.link().get_ref()
    }

    /// The port, e.g. to inject faults on the wire model (do not read from it).
    pub fn get_mut(&mut self) -> &mut IO {
        self.driver.link_mut().get_mut()
    }

    /// The port back.
    pub fn into_inner(self) -> IO {
        self.driver.into_link().into_inner()
    }

    /// Wire times of the last exchange that was answered.
    pub fn last_timing(&self) -> Option<ExchangeTiming> {
        self.last_timing
    }
}
