//! The async master driver (feature `tokio`) on drive-core's runtime layer: the sans-IO
//! [`Master`] over any [`CharIo`] (a serial port from drive-transport, an in-memory link).
//!
//! Parameter reads and writes take the width from the call (16-bit FC 3/6 or 32-bit
//! FC 100/101); the caller decides it from the parameter table (or from the user where the
//! manual gives no data type). After an exception 4 the driver reads the VABus error register
//! (parameter 11, which the read clears) and reports the cause with the exception
//! ([`DriverError::Device`]).

mod error;

use std::time::Duration;

use drive_core::LineSettings;
pub use drive_core::rt::{CharIo, Clock, Port, ReceivedChar, Stream};
use drive_core::rt::{Failed, Flow, Tally};

pub use self::error::DriverError;
use crate::frame::{
    Address, DataSet, DiagSubFunction, ExceptionCode, Request, Response, StartAddress,
};
use crate::framing::{MAX_FRAME, Mode};
use crate::master::{Master, MasterConfig, MasterEvent};
use crate::slave::Width;

/// The VABus SST error register (ch. 6.6): reading it returns and clears the cause of the last
/// exception 4.
pub const ERROR_REGISTER: u16 = 11;

/// Configuration of a [`MasterDriver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverConfig {
    /// RTU or ASCII.
    pub mode: Mode,
    /// The line (timing).
    pub line: LineSettings,
    /// From the end of a request to the start of the answer (manual: 500 ms).
    pub response_timeout: Duration,
    /// Retransmissions after a timeout or a rejected answer.
    pub retries: u8,
    /// Real time, or the virtual clock of tests.
    pub clock: Clock,
    /// After an exception 4, read the VABus error register for its cause.
    pub read_error_register: bool,
}

impl DriverConfig {
    /// The manual's settings for `mode` on `line`, real time.
    pub fn new(mode: Mode, line: LineSettings) -> Self {
        Self {
            mode,
            line,
            response_timeout: crate::master::DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            clock: Clock::Real,
            read_error_register: true,
        }
    }

    fn master(&self) -> MasterConfig {
        MasterConfig {
            response_timeout: self.response_timeout,
            retries: self.retries,
            ..MasterConfig::new(self.mode, self.line)
        }
    }
}

/// Counts of what the driver did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct DriverStats {
    /// Requests started.
    pub transactions: u64,
    /// Retransmissions.
    pub retries: u64,
    /// Requests given up without any answer.
    pub timeouts: u64,
    /// Answers not taken.
    pub rejected: u64,
    /// Exception answers.
    pub exceptions: u64,
    /// Bytes never taken as an answer because they arrived before the request had left the
    /// port (an answer an earlier program left there, a late answer, another master): an
    /// FC 3/100 answer does not name what it answers, so only when it came tells it apart.
    pub stale: u64,
}

/// The async master; see the [module docs](self).
#[derive(Debug)]
pub struct MasterDriver<IO> {
    master: Master,
    port: Port<IO>,
    config: DriverConfig,
    stats: DriverStats,
}

impl<IO: CharIo> MasterDriver<IO> {
    /// A driver on `io` with `config`.
    pub fn new(io: IO, config: DriverConfig) -> Self {
        let master = Master::new(config.master());
        let char_time = config.line.char_time();
        Self {
            master,
            port: Port::new(io, config.clock, char_time),
            config,
            stats: DriverStats::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// What the driver did so far.
    pub fn stats(&self) -> DriverStats {
        self.stats
    }

    /// The port, for closing or inspection.
    pub fn into_inner(self) -> IO {
        self.port.into_inner()
    }

    /// One request through the master; the answer (an exception answer too) or why none came.
    /// A broadcast returns `Ok(None)` once it was sent.
    pub async fn transact(
        &mut self,
        address: Address,
        request: Request,
        timeout: Duration,
    ) -> Result<Option<Response>, DriverError> {
        let now = self.port.now();
        if !self.master.is_idle() {
            // A previous call was cancelled mid-request.
            self.master.abort(now);
        }
        while self.master.poll_event().is_some() {}
        self.master.set_response_timeout(timeout);
        self.master
            .send(address, request, now)
            .map_err(DriverError::InvalidRequest)?;
        self.stats.transactions += 1;
        let mut buf = [0u8; MAX_FRAME];
        let mut tally = Tally::default();
        let exceptions = &mut self.stats.exceptions;
        let r = self
            .port
            .transact(
                &mut self.master,
                &mut buf,
                &mut tally,
                |m| {
                    m.poll_event().map(|event| match event {
                        MasterEvent::Response(r) => {
                            if matches!(r, Response::Exception { .. }) {
                                *exceptions += 1;
                            }
                            Flow::Done(Some(r))
                        }
                        MasterEvent::Sent => Flow::Done(None),
                        MasterEvent::Rejected(reason) => Flow::Rejected(reason),
                        MasterEvent::Timeout { attempts } => Flow::GaveUp { attempts },
                    })
                },
                |m, now| m.abort(now),
            )
            .await;
        self.stats.retries += u64::from(tally.retries());
        self.stats.rejected += u64::from(tally.rejected);
        self.stats.stale += u64::from(tally.stale);
        let address = address.get();
        r.map_err(|failed| match failed {
            Failed::NoAnswer {
                attempts,
                last_reject: Some(reason),
            } => DriverError::Corrupt {
                address,
                reason,
                attempts,
            },
            Failed::NoAnswer {
                attempts,
                last_reject: None,
            } => {
                self.stats.timeouts += 1;
                DriverError::Timeout { address, attempts }
            }
            Failed::Io(e) => DriverError::Io(e),
        })
    }

    async fn call(&mut self, address: Address, request: Request) -> Result<Response, DriverError> {
        let timeout = self.config.response_timeout;
        match self.transact(address, request, timeout).await? {
            Some(Response::Exception { code, .. }) => Err(self.device_error(address, code).await),
            Some(r) => Ok(r),
            None => Err(DriverError::InvalidRequest(
                crate::master::SendError::BroadcastRead,
            )),
        }
    }

    /// The typed refusal for exception `code`: for exception 4 with the cause read from the
    /// VABus error register (unless that read fails too).
    async fn device_error(&mut self, address: Address, code: ExceptionCode) -> DriverError {
        let mut vabus = None;
        if code == ExceptionCode::SLAVE_DEVICE_FAILURE
            && self.config.read_error_register
            && let Some(start) = StartAddress::new(DataSet::ALL, ERROR_REGISTER)
        {
            let timeout = self.config.response_timeout;
            if let Ok(Some(Response::ReadWord { value })) = self
                .transact(address, Request::ReadWord { start, count: 1 }, timeout)
                .await
            {
                vabus = Some(value);
            }
        }
        DriverError::Device {
            exception: code,
            vabus,
        }
    }

    /// Read a parameter of `width` in `data_set` (16-bit values in the low half).
    pub async fn read(
        &mut self,
        address: Address,
        param: u16,
        data_set: DataSet,
        width: Width,
    ) -> Result<u32, DriverError> {
        let start = start(param, data_set)?;
        let request = match width {
            Width::Word => Request::ReadWord { start, count: 1 },
            Width::Long => Request::ReadLong { start },
        };
        match self.call(address, request).await? {
            Response::ReadWord { value } => Ok(u32::from(value)),
            Response::ReadLong { value } => Ok(value),
            _ => Err(DriverError::InvalidRequest(crate::master::SendError::Busy)),
        }
    }

    /// Write a parameter of `width` in `data_set` (1–4 and 0 reach the EEPROM, 5–9 RAM only).
    /// To broadcast (address 0) the call returns once the request is sent.
    pub async fn write(
        &mut self,
        address: Address,
        param: u16,
        data_set: DataSet,
        width: Width,
        value: u32,
    ) -> Result<(), DriverError> {
        let start = start(param, data_set)?;
        let request = match width {
            Width::Word => Request::WriteWord {
                start,
                value: u16::try_from(value).map_err(|_| DriverError::TooWide { value })?,
            },
            Width::Long => Request::WriteLong { start, value },
        };
        if address.is_broadcast() {
            let timeout = self.config.response_timeout;
            self.transact(address, request, timeout).await?;
            return Ok(());
        }
        self.call(address, request).await.map(|_| ())
    }

    /// A diagnostic sub-function (0x0A clears all counters and returns 0).
    pub async fn diagnostics(
        &mut self,
        address: Address,
        sub: DiagSubFunction,
    ) -> Result<u16, DriverError> {
        match self
            .call(address, Request::Diagnostics { sub, data: 0 })
            .await?
        {
            Response::Diagnostics { data, .. } => Ok(data),
            _ => Err(DriverError::InvalidRequest(crate::master::SendError::Busy)),
        }
    }

    /// Whether a drive answers at `address` within `timeout` (any answer, an exception too,
    /// counts), without retries: for an address scan.
    pub async fn probe(
        &mut self,
        address: Address,
        timeout: Duration,
    ) -> Result<bool, DriverError> {
        let retries = self.config.retries;
        self.master.set_retries(0);
        let request = Request::Diagnostics {
            sub: DiagSubFunction::BUS_MESSAGES,
            data: 0,
        };
        let r = self.transact(address, request, timeout).await;
        self.master.set_retries(retries);
        match r {
            Ok(_) => Ok(true),
            Err(DriverError::Timeout { .. }) => Ok(false),
            Err(e) => Err(e),
        }
    }
}

fn start(param: u16, data_set: DataSet) -> Result<StartAddress, DriverError> {
    StartAddress::new(data_set, param).ok_or(DriverError::NoSuchParameter(param))
}
