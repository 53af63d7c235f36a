//! The async MOVILINK master (feature `tokio`).
//!
//! [`MasterDriver`] runs the sans-IO [`Master`] on a [`CharIo`] through
//! the runtime layer's [`Port`] (shared with every protocol of drivebus): the port writes what
//! the master hands out, feeds every received character with its arrival time and wakes the
//! master at its deadlines. Every protocol rule (start pause, response timeout, acceptance
//! checks, retries, handshake, broadcast spacing) is the sans-IO master's; the driver adds the
//! service calls and their errors.
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
//! services (`services.rs`: read, write, …, exchange, probe), the transaction loop
//! (`transact.rs`) and cyclic sessions ([`CyclicSession`]). An example with a simulated drive
//! is in the docs of the `sim` module.

mod cyclic;
mod error;
mod services;
mod transact;

use std::time::Duration;

use drive_core::LineSettings;
pub use drive_core::rt::{CharIo, Clock, Port, ReceivedChar, Stream};
use tokio::time::Instant as TokioInstant;

pub use self::cyclic::CyclicSession;
pub use self::error::DriverError;
use crate::master::{Master, MasterConfig};
use crate::timing::{self, LineTiming};

/// Index of P070 "unit type", read by [`MasterDriver::probe`].
pub const UNIT_TYPE_INDEX: u16 = drive_profile::sew::index::UNIT_TYPE;

/// Configuration of a [`MasterDriver`].
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
    /// Bytes never taken as a response because they arrived before the request had left the
    /// port (a response an earlier program left there, a late response, another master).
    pub stale: u64,
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

/// The async MOVILINK master; see the [module docs](self).
#[derive(Debug)]
pub struct MasterDriver<IO> {
    port: Port<IO>,
    config: DriverConfig,
    master: Master,
    stats: DriverStats,
    /// Last process output words sent per address byte (used by [`MasterDriver::param`] with
    /// PDU types that carry process data).
    po: Box<[[u16; 3]]>,
    last_timing: Option<ExchangeTiming>,
}

impl<IO: CharIo> MasterDriver<IO> {
    /// A driver on `io` (the bus is assumed idle); the epoch of its times is now.
    pub fn new(io: IO, config: DriverConfig) -> Self {
        Self {
            port: Port::new(io, config.clock, config.line.char_time()),
            master: Master::new(config.master_config()),
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
        self.port.get_ref()
    }

    /// The port, e.g. to inject faults on the wire model (do not read from it).
    pub fn get_mut(&mut self) -> &mut IO {
        self.port.get_mut()
    }

    /// The port back.
    pub fn into_inner(self) -> IO {
        self.port.into_inner()
    }

    /// Wire times of the last exchange that was answered.
    pub fn last_timing(&self) -> Option<ExchangeTiming> {
        self.last_timing
    }
}
