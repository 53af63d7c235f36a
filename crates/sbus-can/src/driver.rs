//! The async SBus master (feature `tokio`): [`SbusMaster`] runs the sans-IO
//! [`Master`] on any [`CanIo`] (SocketCAN, an slcan adapter, the virtual bus of
//! `drive-transport`, an in-test channel).
//!
//! Every protocol rule (matching answers, timeouts, retries, late answers, the SYNC producer,
//! the PO-sync window) is the sans-IO master's; the driver moves frames, waits for the
//! master's deadlines on tokio's clock (paused in tests) and turns its results into return
//! values and a typed [`DriverError`].
//!
//! The driver runs only while one of its calls is awaited: the SYNC producer
//! ([`SyncProducer`]) sends while a call waits (a sync-mode answer, [`SbusMaster::sync_for`]);
//! between calls the bus sees no SYNC from it. A call whose future is dropped leaves its
//! request abandoned: the next call drops it and waits the late guard before transmitting.
//!
//! ```
//! # async fn demo<C: drive_core::rt::CanIo>(io: C) -> Result<(), sbus_can::driver::DriverError> {
//! use sbus_can::driver::SbusMaster;
//! use sbus_can::master::MasterConfig;
//! use sbus_can::{Address, ProcessData};
//!
//! let mut bus = SbusMaster::new(io, MasterConfig::default());
//! let drive = Address::new(1).unwrap();
//! let speed = bus.read(drive, 8318).await?; // P000 speed, 0.001 1/min
//! let pi = bus.process_data(drive, ProcessData([0x0006, 5000, 0])).await?;
//! # let _ = (speed, pi);
//! # Ok(()) }
//! ```

use std::io;
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use drive_core::Instant;
pub use drive_core::rt::{CanIo, ReceivedFrame};
use drive_core::rt::{Clock, Timebase, recv_frame, send_frame_at};
use drive_profile::sew::{AttributeInfo, ParamChannel, ReturnCode, ScaleInfo};

use crate::ids::Address;
use crate::master::{
    Answer, Handshake, Master, MasterConfig, MasterError, MasterEvent, MasterStats, RequestError,
    ScanEntry, SyncProducer,
};
use crate::telegram::ProcessData;

/// Why a driver call failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriverError {
    /// The drive refused the parameter service: its return code.
    #[error("the drive at SBus address {address} refused the service: {code}")]
    Drive {
        /// The drive's SBus address.
        address: Address,
        /// The return code.
        code: ReturnCode,
    },
    /// No answer in any attempt.
    #[error(
        "no answer from SBus address {address} after {attempts} attempts of {} ms each; check the address (P813), the bit rate (P816), wiring and termination, and the sync identifier (P817) for sync-mode services",
        .timeout.as_millis()
    )]
    Timeout {
        /// The drive's SBus address.
        address: Address,
        /// Transmissions made.
        attempts: u16,
        /// The wait of each attempt.
        timeout: Duration,
    },
    /// The request cannot be sent (e.g. a read to a group).
    #[error("invalid request: {0}")]
    Request(RequestError),
    /// The CAN interface failed.
    #[error(
        "CAN interface failed: {0}; check that the interface is up and no other program holds it"
    )]
    Io(#[source] io::Error),
    /// The CAN interface is gone (end of stream).
    #[error("the CAN interface was closed")]
    Closed,
}

impl From<MasterError> for DriverError {
    fn from(e: MasterError) -> Self {
        match e {
            MasterError::Drive { address, code } => DriverError::Drive { address, code },
            MasterError::Timeout {
                address,
                attempts,
                timeout,
            } => DriverError::Timeout {
                address,
                attempts,
                timeout,
            },
        }
    }
}

impl From<RequestError> for DriverError {
    fn from(e: RequestError) -> Self {
        DriverError::Request(e)
    }
}

fn io_error(e: io::Error) -> DriverError {
    if e.kind() == io::ErrorKind::UnexpectedEof {
        DriverError::Closed
    } else {
        DriverError::Io(e)
    }
}

/// One address that answered a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScanHit {
    /// The SBus address.
    pub address: Address,
    /// P070 unit type, or the drive's return code.
    pub unit_type: Result<u32, ReturnCode>,
}

/// The async SBus master; see the [module docs](self).
#[derive(Debug)]
pub struct SbusMaster<C> {
    io: C,
    master: Master,
    timebase: Timebase,
}

impl<C: CanIo> SbusMaster<C> {
    /// A master on `io`; the epoch of its times is now.
    pub fn new(io: C, config: MasterConfig) -> Self {
        Self {
            io,
            master: Master::new(config),
            timebase: Timebase::new(Clock::Real, Duration::ZERO),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        self.master.config()
    }

    /// The counters so far (transactions, retries, timeouts, drive errors, SYNCs, rejected
    /// frames by reason).
    pub fn stats(&self) -> MasterStats {
        self.master.stats()
    }

    /// The sans-IO master.
    pub fn master(&self) -> &Master {
        &self.master
    }

    /// The interface.
    pub fn get_ref(&self) -> &C {
        &self.io
    }

    /// The interface (do not receive from it).
    pub fn get_mut(&mut self) -> &mut C {
        &mut self.io
    }

    /// The interface back.
    pub fn into_inner(self) -> C {
        self.io
    }

    /// Change the timeout of each attempt.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.master.set_timeout(timeout);
    }

    /// Change the number of retransmissions.
    pub fn set_retries(&mut self, retries: u8) {
        self.master.set_retries(retries);
    }

    /// Change who sends SYNC.
    pub fn set_sync_producer(&mut self, producer: SyncProducer) {
        let now = self.timebase.now();
        self.master.set_sync_producer(producer, now);
    }

    /// A parameter service in the configured handshake mode; the drive's answer channel.
    pub async fn param(
        &mut self,
        address: Address,
        channel: ParamChannel,
    ) -> Result<ParamChannel, DriverError> {
        let handshake = self.master.config().handshake;
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
        self.prepare();
        let now = self.timebase.now();
        self.master.param(address, channel, handshake, now)?;
        match self.complete().await? {
            Answer::Param(ch) => Ok(ch),
            _ => Err(DriverError::Request(RequestError::Busy)),
        }
    }

    /// Read the value of `index`.
    pub async fn read(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        Ok(self.param(address, ParamChannel::read(index)).await?.data)
    }

    /// Write `value` to `index`, non-volatile (EEPROM). Not for cyclic writes: EEPROMs wear
    /// out; use [`SbusMaster::write_volatile`].
    pub async fn write(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.param(address, ParamChannel::write(index, value))
            .await
            .map(drop)
    }

    /// Write `value` to `index`, volatile (RAM, lost at power-off).
    pub async fn write_volatile(
        &mut self,
        address: Address,
        index: u16,
        value: u32,
    ) -> Result<(), DriverError> {
        self.param(address, ParamChannel::write_volatile(index, value))
            .await
            .map(drop)
    }

    /// Read the smallest settable value of `index`.
    pub async fn read_minimum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        Ok(self
            .param(address, ParamChannel::read_minimum(index))
            .await?
            .data)
    }

    /// Read the largest settable value of `index`.
    pub async fn read_maximum(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        Ok(self
            .param(address, ParamChannel::read_maximum(index))
            .await?
            .data)
    }

    /// Read the default (factory setting) of `index`.
    pub async fn read_default(&mut self, address: Address, index: u16) -> Result<u32, DriverError> {
        Ok(self
            .param(address, ParamChannel::read_default(index))
            .await?
            .data)
    }

    /// Read the size and conversion index of `index`.
    pub async fn read_scale(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<ScaleInfo, DriverError> {
        let ch = self.param(address, ParamChannel::read_scale(index)).await?;
        Ok(ScaleInfo::from_data(ch.data))
    }

    /// Read the access attributes of `index` and the next available index.
    pub async fn read_attribute(
        &mut self,
        address: Address,
        index: u16,
    ) -> Result<AttributeInfo, DriverError> {
        let ch = self
            .param(address, ParamChannel::read_attribute(index))
            .await?;
        Ok(AttributeInfo::from_data(ch.data))
    }

    /// A group parameter write (8g + 518) to every drive of `group`: write or write volatile
    /// only, never answered; returns once the frame is on the interface.
    pub async fn group_write(
        &mut self,
        group: Address,
        channel: ParamChannel,
    ) -> Result<(), DriverError> {
        self.prepare();
        let now = self.timebase.now();
        self.master.group_param(group, channel, now)?;
        self.complete().await.map(drop)
    }

    /// Process output data to `address` (8a + 3); its process input data (8a + 4).
    pub async fn process_data(
        &mut self,
        address: Address,
        data: ProcessData,
    ) -> Result<ProcessData, DriverError> {
        self.prepare();
        let now = self.timebase.now();
        self.master.process_data(address, data, now)?;
        self.process_input().await
    }

    /// Synchronised process output data to `address` (8a + 5), sent in the cycle's PO-sync
    /// window; its process input data, sent by the drive after the next SYNC.
    pub async fn process_data_sync(
        &mut self,
        address: Address,
        data: ProcessData,
    ) -> Result<ProcessData, DriverError> {
        self.prepare();
        let now = self.timebase.now();
        self.master.process_data_sync(address, data, now)?;
        self.process_input().await
    }

    /// Group process output data (8g + 6) to every drive of `group`; never answered.
    pub async fn group_process_data(
        &mut self,
        group: Address,
        data: ProcessData,
    ) -> Result<(), DriverError> {
        self.prepare();
        let now = self.timebase.now();
        self.master.group_process_data(group, data, now)?;
        self.complete().await.map(drop)
    }

    /// One SYNC telegram now.
    pub async fn sync(&mut self) -> Result<(), DriverError> {
        self.prepare();
        let now = self.timebase.now();
        self.master.sync(now)?;
        self.complete().await.map(drop)
    }

    /// Produce SYNC every [`MasterConfig::sync_period`] for `duration` (frames received
    /// meanwhile are counted and dropped); the producer setting is restored afterwards.
    pub async fn sync_for(&mut self, duration: Duration) -> Result<(), DriverError> {
        self.prepare();
        let before = self.master.config().sync_producer;
        let start = self.timebase.now();
        self.master.set_sync_producer(SyncProducer::Always, start);
        let end = start.saturating_add(duration);
        let r = self.pump(Some(end)).await.map(drop);
        let now = self.timebase.now();
        self.master.set_sync_producer(before, now);
        r
    }

    /// Scan `first..=last` with a read of P070 unit type to each address (one attempt,
    /// [`MasterConfig::scan_timeout`]); the addresses that answered, in order.
    pub async fn scan(
        &mut self,
        first: Address,
        last: Address,
    ) -> Result<Vec<ScanHit>, DriverError> {
        self.prepare();
        let now = self.timebase.now();
        let timeout = self.master.config().scan_timeout;
        self.master.scan(first, last, timeout, now)?;
        loop {
            match self.pump(None).await? {
                Some(MasterEvent::ScanDone) => break,
                _ => continue,
            }
        }
        let hits = self
            .master
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

    /// Drop what an abandoned call left behind.
    fn prepare(&mut self) {
        if !self.master.is_idle() {
            let now = self.timebase.now();
            self.master.abort(now);
        }
        while self.master.poll_event().is_some() {}
    }

    /// Run until the request in flight is done.
    async fn complete(&mut self) -> Result<Answer, DriverError> {
        loop {
            if let Some(MasterEvent::Done(r)) = self.pump(None).await? {
                return r.map_err(DriverError::from);
            }
        }
    }

    /// Move frames and wait for deadlines until the master reports an event or `until` passes.
    async fn pump(&mut self, until: Option<Instant>) -> Result<Option<MasterEvent>, DriverError> {
        let mut now = self.timebase.now();
        loop {
            self.master.handle_timeout(now);
            if let Some(ev) = self.master.poll_event() {
                return Ok(Some(ev));
            }
            // Listen before talking: what waits in the interface arrived before anything sent
            // now, and the master hears it with the time it was read (read only after the
            // request, an answer an earlier program left there would look like its answer).
            if let Some(at) = self.feed_waiting()? {
                now = self.timebase.now().later(at);
                continue;
            }
            if let Some(frame) = self.master.poll_transmit(now) {
                // Scheduled for the master's time (a deadline, not tokio's later tick).
                let start = self.timebase.to_tokio(now);
                send_frame_at(&mut self.io, &frame, start)
                    .await
                    .map_err(io_error)?;
                if let Some(ev) = self.master.poll_event() {
                    return Ok(Some(ev));
                }
                now = self.timebase.now();
                continue;
            }
            if until.is_some_and(|u| now >= u) {
                return Ok(None);
            }
            let deadline = drive_core::time::earliest(self.master.poll_timeout(), until);
            let timer = deadline.map(|d| self.timebase.to_tokio(d));
            tokio::select! {
                r = recv_frame(&mut self.io) => {
                    let r = r.map_err(io_error)?;
                    let at = self.timebase.to_instant(r.at);
                    self.master.handle_frame(&r.frame, at);
                    now = self.timebase.now().later(at);
                }
                () = sleep_until(timer) => {
                    now = match deadline {
                        Some(d) => self.timebase.woken_at(d),
                        None => self.timebase.now(),
                    };
                }
            }
        }
    }
}

impl<C: CanIo> SbusMaster<C> {
    /// Feed the frames that wait in the interface now, without waiting; the time of the last
    /// one fed, if any.
    fn feed_waiting(&mut self) -> Result<Option<Instant>, DriverError> {
        let mut cx = Context::from_waker(Waker::noop());
        let mut last = None;
        for _ in 0..WAITING_FRAMES {
            match self.io.poll_recv(&mut cx) {
                Poll::Ready(Ok(r)) => {
                    let at = self.timebase.to_instant(r.at);
                    self.master.handle_frame(&r.frame, at);
                    last = Some(at);
                }
                Poll::Ready(Err(e)) => return Err(io_error(e)),
                Poll::Pending => break,
            }
        }
        Ok(last)
    }
}

/// Frames read from the interface before a transmission, at most (the rest are read while
/// waiting).
const WAITING_FRAMES: usize = 64;

async fn sleep_until(t: Option<tokio::time::Instant>) {
    match t {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}
