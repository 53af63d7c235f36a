//! The async master driver (feature `tokio`): drive-core's one runtime driver
//! ([`drive_core::rt::Driver`]) running the sans-IO [`ModbusMaster`] over any [`CharIo`] (a
//! serial port from drive-transport, an in-memory link), and the Bonfiglioli services on it.
//!
//! Parameter reads and writes take the width from the call (16-bit FC 3/6 or 32-bit
//! FC 100/101); the caller decides it from the parameter table (or from the user where the
//! manual gives no data type). After an exception 4 the driver reads the VABus error register
//! (parameter 11, which the read clears) and reports the cause with the exception
//! ([`DriverError::Device`]).
//!
//! On a line whose adapter's echo is not taken out (`drive_core::rt::echo`), the answer of FC 6,
//! FC 8 and FC 101, which repeats the request, cannot be told from the request's echo: such an
//! answer is taken only once the line is known not to echo. Until then the driver reads the
//! parameter (FC 3 or 100, whose answer never repeats the request) to find out; on a line that
//! echoes every call fails with [`LinkError::Echo`].

mod error;

use std::time::Duration;

use drive_core::LineSettings;
use drive_core::rt::echo::{self, EchoCheck};
pub use drive_core::rt::{CharIo, Clock, DriverStats, Port, ReceivedChar, Stream};
use drive_core::rt::{Driver, Failed, Flow, Tally};

pub use self::error::{DriverError, LinkError, RequestError};
use crate::frame::{
    Address, DataSet, DiagSubFunction, ExceptionCode, Request, Response, StartAddress,
};
use crate::framing::Mode;
use crate::master::{MasterConfig, MasterEvent, ModbusMaster};
use crate::slave::Width;

/// The VABus SST error register (ch. 6.6): reading it returns and clears the cause of the last
/// exception 4.
pub const ERROR_REGISTER: u16 = 11;

/// Configuration of a [`ModbusDriver`].
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

/// The async master; see the [module docs](self).
#[derive(Debug)]
pub struct ModbusDriver<IO> {
    driver: Driver<Port<IO>, ModbusMaster>,
    config: DriverConfig,
    stats: DriverStats,
}

impl<IO: CharIo> ModbusDriver<IO> {
    /// A driver on `io` with `config`.
    pub fn new(io: IO, config: DriverConfig) -> Self {
        let master = ModbusMaster::new(config.master());
        let port = Port::new(io, config.clock, config.line.char_time());
        Self {
            driver: Driver::new(port, master),
            config,
            stats: DriverStats::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// What the driver did so far (`device_errors`: exception answers).
    pub fn stats(&self) -> DriverStats {
        self.stats
    }

    /// The port, for closing or inspection.
    pub fn into_inner(self) -> IO {
        self.driver.into_link().into_inner()
    }

    /// One request through the master; the answer (an exception answer too) or why none came.
    /// A broadcast returns `Ok(None)` once it was sent. On a line whose adapter echoes what it
    /// sends while its echo is not taken out, [`LinkError::Echo`] (see the [module docs](self)).
    pub async fn transact(
        &mut self,
        address: Address,
        request: Request,
        timeout: Duration,
    ) -> Result<Option<Response>, DriverError> {
        let broadcast = address.is_broadcast();
        let echo = |sent| {
            DriverError::Link(LinkError::Echo {
                address: address.get(),
                sent,
            })
        };
        if !broadcast && echo::echoes(self.driver.link_mut().get_mut()) {
            return Err(echo(false));
        }
        let r = self.exchange(address, request, timeout).await;
        if broadcast {
            return r;
        }
        match echo::after_exchange(self.driver.link_mut().get_mut(), may_repeat(&request)) {
            EchoCheck::Fine => r,
            EchoCheck::Echoes => Err(echo(true)),
            EchoCheck::Ambiguous => {
                // A request whose answer never repeats it tells the echo from an answer.
                let _ = self.exchange(address, probe_for(&request), timeout).await;
                match echo::after_exchange(self.driver.link_mut().get_mut(), false) {
                    EchoCheck::Echoes => Err(echo(true)),
                    _ => r,
                }
            }
        }
    }

    /// One request through the master, as [`ModbusDriver::transact`] without the echo rules.
    async fn exchange(
        &mut self,
        address: Address,
        request: Request,
        timeout: Duration,
    ) -> Result<Option<Response>, DriverError> {
        let now = self.driver.prepare();
        let master = self.driver.master_mut();
        master.set_response_timeout(timeout);
        master
            .send((address, request), now)
            .map_err(RequestError::Invalid)?;
        self.stats.transactions += 1;
        let mut tally = Tally::default();
        let device_errors = &mut self.stats.device_errors;
        let r = self
            .driver
            .run(&mut tally, |m| {
                m.poll_event().map(|event| {
                    if matches!(event, MasterEvent::Response(Response::Exception { .. })) {
                        *device_errors += 1;
                    }
                    Flow::from(event)
                })
            })
            .await;
        self.stats.count(&tally, &r);
        let address = address.get();
        r.map_err(|failed| {
            DriverError::Link(match failed {
                Failed::NoAnswer { attempts } => LinkError::Timeout { address, attempts },
                Failed::Corrupt { reason, attempts } => LinkError::Corrupt {
                    address,
                    reason,
                    attempts,
                },
                Failed::Ended(never) => match never {},
                Failed::Io(e) => LinkError::Io(e),
            })
        })
    }

    async fn call(&mut self, address: Address, request: Request) -> Result<Response, DriverError> {
        let timeout = self.config.response_timeout;
        match self.transact(address, request, timeout).await? {
            Some(Response::Exception { code, .. }) => Err(self.device_error(address, code).await),
            Some(r) => Ok(r),
            None => Err(RequestError::Invalid(crate::master::SendError::BroadcastRead).into()),
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
            _ => Err(unexpected(address)),
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
                value: u16::try_from(value).map_err(|_| RequestError::TooWide { value })?,
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
            _ => Err(unexpected(address)),
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
        self.driver.master_mut().set_retries(0);
        let request = Request::Diagnostics {
            sub: DiagSubFunction::BUS_MESSAGES,
            data: 0,
        };
        let r = self.transact(address, request, timeout).await;
        self.driver.master_mut().set_retries(retries);
        match r {
            Ok(_) => Ok(true),
            Err(DriverError::Link(LinkError::Timeout { .. })) => Ok(false),
            Err(e) => Err(e),
        }
    }
}

/// Whether the answer to `request` repeats it (FC 6, 8, 101): its echo looks like its answer.
fn may_repeat(request: &Request) -> bool {
    matches!(
        request,
        Request::WriteWord { .. } | Request::WriteLong { .. } | Request::Diagnostics { .. }
    )
}

/// The parameter read by which a driver tells the echo of `request` from its answer (an FC 3
/// or FC 100 answer never repeats its request): the parameter written, or for a diagnostic
/// the drive's Modbus address, parameter 1376.
fn probe_for(request: &Request) -> Request {
    match *request {
        Request::WriteLong { start, .. } | Request::ReadLong { start } => {
            Request::ReadLong { start }
        }
        Request::WriteWord { start, .. } | Request::ReadWord { start, .. } => {
            Request::ReadWord { start, count: 1 }
        }
        Request::Diagnostics { .. } => Request::ReadWord {
            start: StartAddress::from_raw(ADDRESS_PARAMETER),
            count: 1,
        },
    }
}

/// The drive's Modbus address, parameter 1376 in data set 0 (ch. 6): a parameter every drive
/// has, read to tell an echo from an answer.
const ADDRESS_PARAMETER: u16 = 1376;

fn start(param: u16, data_set: DataSet) -> Result<StartAddress, DriverError> {
    StartAddress::new(data_set, param).ok_or(RequestError::NoSuchParameter(param).into())
}

/// An answer of another kind than the call asked for (the master's function code check makes
/// it impossible).
fn unexpected(address: Address) -> DriverError {
    LinkError::Unexpected {
        address: address.get(),
    }
    .into()
}
