//! Simulated MOVIDRIVE drives on SBus (feature `sim`).
//!
//! [`SimulatedSbusDrive`] is the thin SBus front-end onto the one drive model,
//! [`drive_sim::movidrive::Movidrive`] (the same model and parameter table as the MOVILINK
//! simulator): the sans-IO [`Slave`] picks the frames for the drive and times the answers, the
//! model executes the parameter services and process data, monitors P815 itself (the front-end
//! only wakes it at [`Movidrive::sbus_deadline`]) and decides its master-slave role. The
//! front-end follows P813 (address), P814 (group) and P817 (sync identifier) when they are
//! written, and, for a master-slave master (P750 = speed via SBus), sends the group process
//! telegram every 1 ms ([`MASTER_PERIOD`]).
//!
//! [`SimulatedSbusBus`] is several drives behind one CAN interface (one slcan adapter, one node
//! of the virtual bus); both are served by [`serve_can`], which also lets the drives hear each
//! other (a master's group telegrams reach the slaves beside it).

use std::io;
use std::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_core::rt::CanIo;
use drive_core::rt::can_serve::serve_can;
use drive_core::time::earliest;
use drive_profile::sew::{ParamChannel, ReturnCode};
use drive_sim::movidrive::{BusSource, MasterSlave, MasterSlaveError, Movidrive};
use tokio::time::Instant as TokioInstant;

use crate::ids::Address;
use crate::slave::{Backend, Slave, SlaveConfig, Tally};
use crate::telegram::{ProcessData, Telegram};

/// How often a master-slave master sends its group telegram (ch. 5.4: "jede Millisekunde").
pub const MASTER_PERIOD: Duration = Duration::from_millis(1);

/// The [`Backend`] of a simulated drive: the drive model.
#[derive(Debug)]
struct DriveBackend {
    drive: Movidrive,
}

impl Backend for DriveBackend {
    fn param(&mut self, request: &ParamChannel, now: Instant) -> Result<u32, ReturnCode> {
        self.drive.param(request, now)
    }

    fn process_data(&mut self, output: ProcessData, now: Instant) -> ProcessData {
        self.group_process_data(output, now);
        let mut pi = [0u16; 3];
        self.drive.process_input(&mut pi);
        ProcessData(pi)
    }

    fn group_process_data(&mut self, output: ProcessData, now: Instant) {
        self.drive.sbus_process_data_received(now);
        self.drive.process_output(&output.0, now);
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.drive.sbus_deadline()
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.drive.tick(now);
    }
}

/// The SBus slave front-end onto [`Movidrive`]; see the [module docs](self).
#[derive(Debug)]
pub struct SimulatedSbusDrive {
    slave: Slave<DriveBackend>,
    /// When the next master-slave group telegram is due (a master only).
    next_group: Option<Instant>,
    /// Why the drive, a master, does not send.
    master_error: Option<MasterSlaveError>,
    /// The epoch of the drive's time when served alone, kept across serves.
    epoch: Option<TokioInstant>,
}

impl SimulatedSbusDrive {
    /// A drive at SBus address `address` (P813, clamped to 0–63), with SBus as control and
    /// setpoint source (P100 = SBus, P101 = SBus), every other parameter at its factory
    /// setting (group 0, sync identifier 0, SBus timeout 100 ms with emergency stop / fault).
    pub fn new(address: u8) -> Self {
        let mut drive = Movidrive::new(0);
        drive.set_sbus_address(address);
        drive.set_bus_control(BusSource::SBus, Instant::ZERO);
        let config = config_of(&drive, SlaveConfig::new(Address::default()));
        let mut s = Self {
            slave: Slave::new(config, DriveBackend { drive }),
            next_group: None,
            master_error: None,
            epoch: None,
        };
        s.refresh(Instant::ZERO);
        s
    }

    /// The drive model.
    pub fn movidrive(&self) -> &Movidrive {
        &self.slave.backend().drive
    }

    /// The drive model, for changing (P813/P814/P817/P750 written here take effect with the
    /// next frame or deadline).
    pub fn movidrive_mut(&mut self) -> &mut Movidrive {
        &mut self.slave.backend_mut().drive
    }

    /// The protocol configuration in use (identifiers, response delay, sync window).
    pub fn slave_config(&self) -> SlaveConfig {
        *self.slave.config()
    }

    /// Change the simulator's protocol choices (response delay, PO sync window); address,
    /// group and sync identifier keep following the drive's parameters.
    pub fn set_slave_config(&mut self, config: SlaveConfig) {
        let wanted = config_of(self.movidrive(), config);
        self.slave.set_config(wanted);
    }

    /// Frames taken and rejected (by reason).
    pub fn tally(&self) -> &Tally {
        self.slave.tally()
    }

    /// The master-slave role, or why a master does not send (e.g. P816 at 125 kbit/s).
    pub fn master_slave(&self) -> Result<MasterSlave, MasterSlaveError> {
        match self.master_error {
            Some(e) => Err(e),
            None => Ok(self.movidrive().master_slave()),
        }
    }

    /// Serve the bus on `io` until it closes (`Ok`) or fails; the drive's time goes on across
    /// serves.
    pub async fn serve<IO: CanIo>(&mut self, io: IO) -> io::Result<()> {
        let epoch = *self.epoch.get_or_insert_with(TokioInstant::now);
        serve_can(core::slice::from_mut(self), epoch, io).await
    }

    /// Follow P813/P814/P817 and the master-slave role after anything that may have changed
    /// them.
    fn refresh(&mut self, now: Instant) {
        let current = *self.slave.config();
        let wanted = config_of(self.movidrive(), current);
        if wanted != current {
            self.slave.set_config(wanted);
        }
        match self.movidrive().master_group_output() {
            Ok(Some(_)) => {
                self.master_error = None;
                if self.next_group.is_none() {
                    self.next_group = Some(now);
                }
            }
            Ok(None) => {
                self.master_error = None;
                self.next_group = None;
            }
            Err(e) => {
                self.master_error = Some(e);
                self.next_group = None;
            }
        }
    }

    /// The master's group telegram, if one is due at `now`.
    fn group_telegram(&mut self, now: Instant) -> Option<CanFrame> {
        let due = self.next_group.filter(|&t| t <= now)?;
        let drive = self.movidrive_mut();
        drive.tick(now);
        let words = drive.master_group_output().ok().flatten()?;
        let group = Address::new(drive.sbus_group_address()).unwrap_or_default();
        let sync_id = drive.sbus_sync_id();
        let next = due + MASTER_PERIOD;
        self.next_group = Some(if next <= now {
            now + MASTER_PERIOD
        } else {
            next
        });
        Some(
            Telegram::GroupProcessOutput {
                group,
                data: ProcessData(words),
            }
            .encode(sync_id),
        )
    }
}

impl CanEndpoint for SimulatedSbusDrive {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.slave.handle_frame(frame, now);
        self.refresh(now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.slave.handle_timeout(now);
        self.refresh(now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        self.slave
            .poll_transmit(now)
            .or_else(|| self.group_telegram(now))
    }

    fn poll_timeout(&self) -> Option<Instant> {
        earliest(self.slave.poll_timeout(), self.next_group)
    }
}

/// The slave configuration the drive's parameters ask for (P813, P814, P817, master role).
fn config_of(drive: &Movidrive, current: SlaveConfig) -> SlaveConfig {
    SlaveConfig {
        address: Address::new(drive.sbus_address()).unwrap_or(current.address),
        group: Address::new(drive.sbus_group_address()).unwrap_or(current.group),
        sync_id: drive.sbus_sync_id(),
        group_telegrams: drive.master_slave() != MasterSlave::Master,
        ..current
    }
}

/// Several simulated MOVIDRIVEs behind one CAN interface, each answering its own SBus address.
#[derive(Debug)]
pub struct SimulatedSbusBus {
    drives: Vec<SimulatedSbusDrive>,
    epoch: Option<TokioInstant>,
}

impl SimulatedSbusBus {
    /// Drives at the SBus addresses `addresses` (duplicates kept once; above 63 clamped).
    pub fn new(addresses: &[u8]) -> Self {
        let mut drives: Vec<SimulatedSbusDrive> = Vec::new();
        for &a in addresses {
            if !drives
                .iter()
                .any(|d| d.movidrive().sbus_address() == a.min(63))
            {
                drives.push(SimulatedSbusDrive::new(a));
            }
        }
        Self {
            drives,
            epoch: None,
        }
    }

    /// Serve the bus on `io` until it closes (`Ok`) or fails; the time goes on across serves.
    pub async fn serve<IO: CanIo>(&mut self, io: IO) -> io::Result<()> {
        let epoch = *self.epoch.get_or_insert_with(TokioInstant::now);
        serve_can(&mut self.drives, epoch, io).await
    }

    /// The drive answering SBus address `address` now.
    pub fn drive(&self, address: u8) -> Option<&SimulatedSbusDrive> {
        self.drives
            .iter()
            .find(|d| d.slave_config().address.get() == address)
    }

    /// The drive answering SBus address `address` now, for changing.
    pub fn drive_mut(&mut self, address: u8) -> Option<&mut SimulatedSbusDrive> {
        self.drives
            .iter_mut()
            .find(|d| d.slave_config().address.get() == address)
    }

    /// All drives.
    pub fn drives(&self) -> &[SimulatedSbusDrive] {
        &self.drives
    }

    /// All drives, for changing.
    pub fn drives_mut(&mut self) -> &mut [SimulatedSbusDrive] {
        &mut self.drives
    }
}
