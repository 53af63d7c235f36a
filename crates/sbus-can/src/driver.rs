//! The async SBus driver (feature `tokio`): [`SbusDriver`] is drive-core's one runtime driver
//! ([`drive_core::rt::Driver`]) running the sans-IO [`SbusMaster`] on any [`CanIo`]
//! (SocketCAN, an slcan adapter, the virtual bus of `drive-transport`, an in-test channel)
//! through a [`CanPort`].
//!
//! Every protocol rule (matching answers, timeouts, retries, late answers, the SYNC producer,
//! the PO-sync window) is the sans-IO master's; the driver moves frames, waits for the
//! master's deadlines on tokio's clock (paused in tests) and turns its results into return
//! values and a typed [`DriverError`]. The SEW parameter services (read, write, …) are
//! [`drive_profile::sew::ParamServices`], written once for SBus and MOVILINK.
//!
//! The driver runs only while one of its calls is awaited: the SYNC producer
//! ([`SyncProducer`]) sends while a call waits (a sync-mode answer, [`SbusDriver::sync_for`]);
//! between calls the bus sees no SYNC from it. A call whose future is dropped leaves its
//! request abandoned: the next call drops it and waits the late guard before transmitting.
//!
//! ```
//! # async fn demo<C: drive_core::rt::CanIo>(io: C) -> Result<(), sbus_can::driver::DriverError> {
//! use sbus_can::driver::{ParamServices, SbusDriver};
//! use sbus_can::master::MasterConfig;
//! use sbus_can::{Address, ProcessData};
//!
//! let mut bus = SbusDriver::new(io, MasterConfig::default());
//! let drive = Address::new(1).unwrap();
//! let speed = bus.read(drive, 8318).await?; // P000 speed, 0.001 1/min
//! let pi = bus.process_data(drive, ProcessData([0x0006, 5000, 0])).await?;
//! # let _ = (speed, pi);
//! # Ok(()) }
//! ```

use drive_core::LinkFault;
use std::io;
use std::time::Duration;

pub use drive_core::rt::{CanIo, CanPort, ReceivedFrame};
use drive_core::rt::{Driver, Failed, Flow, Tally};
pub use drive_profile::sew::ParamServices;
use drive_profile::sew::{ParamChannel, ReturnCode};

use crate::ids::Address;
use crate::master::{
    Answer, Handshake, MasterConfig, MasterError, MasterEvent, MasterStats, RequestError,
    SbusMaster, ScanEntry, SyncProducer,
};
use crate::telegram::ProcessData;

/// Why a driver call failed: the drive refused ([`DriverError::Device`]), the bus failed
/// ([`DriverError::Link`]) or the request cannot be made ([`DriverError::Request`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive refused the parameter service: its return code.
    #[error("the drive at SBus address {address} refused the service: {code}")]
    Device {
        /// The drive's SBus address.
        address: Address,
        /// The return code.
        code: ReturnCode,
    },
    /// No answer, or the CAN interface.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The request cannot be sent (e.g. a read to a group).
    #[error("invalid request: {0}")]
    Request(RequestError),
}

/// How the bus failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// No answer in any attempt.
    #[error(
        "no answer from SBus address {address} after {attempts} attempts of {} ms each; check the address (P813), the bit rate (P816), wiring and termination, and the sync identifier (P817) for sync-mode services",
        .response_timeout.as_millis()
    )]
    Timeout {
        /// The drive's SBus address.
        address: Address,
        /// Transmissions made.
        attempts: u16,
        /// The wait of each attempt.
        response_timeout: Duration,
    },
    /// The CAN interface failed.
    #[error(
        "CAN interface failed: {0}; check that the interface is up and no other program holds it"
    )]
    Io(#[source] io::Error),
    /// The CAN interface is gone (end of stream).
    #[error("the CAN interface was closed")]
    Closed,
}

impl LinkError {
    /// What kind of link failure this is.
    pub fn fault(&self) -> LinkFault {
        match self {
            LinkError::Timeout { .. } => LinkFault::NoAnswer,
            LinkError::Io(_) | LinkError::Closed => LinkFault::Port,
        }
    }
}

impl From<MasterError> for DriverError {
    fn from(e: MasterError) -> Self {
        match e {
            MasterError::Drive { address, code } => DriverError::Device { address, code },
            MasterError::Timeout {
                address,
                attempts,
                response_timeout,
            } => LinkError::Timeout {
                address,
                attempts,
                response_timeout,
            }
            .into(),
        }
    }
}

impl From<RequestError> for DriverError {
    fn from(e: RequestError) -> Self {
        DriverError::Request(e)
    }
}

fn io_error(e: io::Error) -> DriverError {
    DriverError::Link(if e.kind() == io::ErrorKind::UnexpectedEof {
        LinkError::Closed
    } else {
        LinkError::Io(e)
    })
}

/// One address that answered a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScanHit {
    /// The SBus address.
    pub address: Address,
    /// P070 unit type, or the drive's return code.
    pub unit_type: Result<u32, ReturnCode>,
}

/// The async SBus driver; see the [module docs](self).
#[derive(Debug)]
pub struct SbusDriver<C> {
    driver: Driver<CanPort<C>, SbusMaster>,
}

/// The SEW parameter services on CAN: each one a parameter request in the configured handshake
/// mode ([`MasterConfig::handshake`]).
impl<C: CanIo> ParamServices for SbusDriver<C> {
    type Address = Address;
    type Error = DriverError;

    async fn service(
        &mut self,
        address: Address,
        request: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        self.param(address, request).await
    }

    fn return_code(error: &DriverError) -> Option<ReturnCode> {
        match error {
            DriverError::Device { code, .. } => Some(*code),
            _ => None,
        }
    }
}

impl<C: CanIo> SbusDriver<C> {
    /// A driver on `io`; the epoch of its times is now.
    pub fn new(io: C, config: MasterConfig) -> Self {
        Self {
            driver: Driver::new(CanPort::new(io), SbusMaster::new(config)),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        self.driver.master().config()
    }

    /// The counters so far (transactions, retries, timeouts, drive errors, SYNCs, rejected
    /// frames by reason).
    pub fn stats(&self) -> MasterStats {
        self.driver.master().stats()
    }

    /// The sans-IO master.
    pub fn master(&self) -> &SbusMaster {
        self.driver.master()
    }

    /// The interface.
    pub fn get_ref(&self) -> &C {
        self.driver.link().get_ref()
    }

    /// The interface (do not receive from it).
    pub fn get_mut(&mut self) -> &mut C {
        self.driver.link_mut().get_mut()
    }

    /// The interface back.
    pub fn into_inner(self) -> C {
        self.driver.into_link().into_inner()
    }

    /// Change the response timeout of each attempt.
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.driver.master_mut().set_response_timeout(timeout);
    }

    /// Change the number of retransmissions.
    pub fn set_retries(&mut self, retries: u8) {
        self.driver.master_mut().set_retries(retries);
    }

    /// Change who sends SYNC.
    pub fn set_sync_producer(&mut self, producer: SyncProducer) {
        let now = self.driver.link().now();
        self.driver.master_mut().set_sync_producer(producer, now);
    }

    /// A parameter service in the configured handshake mode; the drive's answer channel.
    pub async fn param(
        &mut self,
        address: Address,
        channel: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        let handshake = self.config().handshake;
        self.param_with(address, channel, handshake).await
    }

    /// A parameter service in handshake mode `handshake`; the drive's answer channel. In sync
    /// mode the answer comes after the next SYNC (sent by this master while it waits, unless
    /// [`SyncProducer::External`]).
    pub async fn param_with(
        &mut self,
        address: Address,
        channel: ParamChannel,
        handshake: Handshake,
    ) -> Result<ParamChannel, DriverError> {
        let now = self.driver.prepare();
        self.driver
            .master_mut()
            .param(address, channel, handshake, now)?;
        match self.complete().await? {
            Answer::Param(ch) => Ok(ch),
            _ => Err(DriverError::Request(RequestError::Busy)),
        }
    }

    /// A group parameter write (8g + 518) to every drive of `group`: write or write volatile
    /// only, never answered; returns once the frame is on the interface.
    pub async fn group_write(
        &mut self,
        group: Address,
        channel: ParamChannel,
    ) -> Result<(), DriverError> {
        let now = self.driver.prepare();
        self.driver.master_mut().group_param(group, channel, now)?;
        self.complete().await.map(drop)
    }

    /// Process output data to `address` (8a + 3); its process input data (8a + 4).
    pub async fn process_data(
        &mut self,
        address: Address,
        data: ProcessData,
    ) -> Result<ProcessData, DriverError> {
        let now = self.driver.prepare();
        self.driver.master_mut().process_data(address, data, now)?;
        self.process_input().await
    }

    /// Synchronised process output data to `address` (8a + 5), sent in the cycle's PO-sync
    /// window; its process input data, sent by the drive after the next SYNC.
    pub async fn process_data_sync(
        &mut self,
        address: Address,
        data: ProcessData,
    ) -> Result<ProcessData, DriverError> {
        let now = self.driver.prepare();
        self.driver
            .master_mut()
            .process_data_sync(address, data, now)?;
        self.process_input().await
    }

    /// Group process output data (8g + 6) to every drive of `group`; never answered.
    pub async fn group_process_data(
        &mut self,
        group: Address,
        data: ProcessData,
    ) -> Result<(), DriverError> {
        let now = self.driver.prepare();
        self.driver
            .master_mut()
            .group_process_data(group, data, now)?;
        self.complete().await.map(drop)
    }

    /// One SYNC telegram now.
    pub async fn sync(&mut self) -> Result<(), DriverError> {
        let now = self.driver.prepare();
        self.driver.master_mut().sync(now)?;
        self.complete().await.map(drop)
    }

    /// Produce SYNC every [`MasterConfig::sync_period`] for `duration` (frames received
    /// meanwhile are counted and dropped); the producer setting is restored afterwards.
    pub async fn sync_for(&mut self, duration: Duration) -> Result<(), DriverError> {
        let start = self.driver.prepare();
        let before = self.config().sync_producer;
        let (port, master) = self.driver.parts_mut();
        master.set_sync_producer(SyncProducer::Always, start);
        let end = start.saturating_add(duration);
        let r = port.run_until(master, end).await.map_err(io_error);
        let now = port.now();
        master.set_sync_producer(before, now);
        r
    }

    /// Scan `first..=last` with a read of P070 unit type to each address (one attempt,
    /// [`MasterConfig::scan_timeout`]); the addresses that answered, in order.
    pub async fn scan(
        &mut self,
        first: Address,
        last: Address,
    ) -> Result<Vec<ScanHit>, DriverError> {
        let now = self.driver.prepare();
        let timeout = self.config().scan_timeout;
        self.driver.master_mut().scan(first, last, timeout, now)?;
        let mut tally = Tally::default();
        self.driver
            .run(&mut tally, |m| {
                m.poll_event().map(|e| match e {
                    MasterEvent::ScanDone => Flow::<_, (), _>::Done(()),
                    _ => Flow::Other,
                })
            })
            .await
            .map_err(failed)?;
        let hits = self
            .master()
            .scan_results()
            .iter()
            .enumerate()
            .filter_map(|(a, e)| {
                let address = Address::new(u8::try_from(a).ok()?)?;
                let unit_type = match *e {
                    ScanEntry::UnitType(v) => Ok(v),
                    ScanEntry::Refused(rc) => Err(rc),
                    _ => return None,
                };
                Some(ScanHit { address, unit_type })
            })
            .collect();
        Ok(hits)
    }

    async fn process_input(&mut self) -> Result<ProcessData, DriverError> {
        match self.complete().await? {
            Answer::ProcessInput(pd) => Ok(pd),
            _ => Err(DriverError::Request(RequestError::Busy)),
        }
    }

    /// Run until the request in flight is done.
    async fn complete(&mut self) -> Result<Answer, DriverError> {
        let mut tally = Tally::default();
        let done = self
            .driver
            .run(&mut tally, |m| {
                m.poll_event().map(|e| match e {
                    MasterEvent::Done(r) => Flow::<_, (), _>::Answered(r),
                    _ => Flow::Other,
                })
            })
            .await
            .map_err(failed)?;
        done.map_err(DriverError::from)
    }
}

/// The runtime driver's end without the master's result: only the interface can fail (the
/// master reports every end of a request, a timeout too, as its result).
fn failed(f: Failed<()>) -> DriverError {
    match f {
        Failed::Io(e) => io_error(e),
        Failed::NoAnswer { .. } | Failed::Corrupt { .. } => {
            DriverError::Request(RequestError::Busy)
        }
        Failed::Ended(never) => match never {},
    }
}
