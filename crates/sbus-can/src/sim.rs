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
//!
//! **The drive as master (MOVLNK, ch. 5.3).** A simulated drive can execute the IPOSplus
//! command `_Movilink(MI)` towards other nodes: [`SimulatedSbusDrive::movlnk`] starts a
//! [`MovlnkCommand`] with its data block [`MlData`] on the drive's own [`MovlnkMaster`], and
//! [`SimulatedSbusDrive::poll_movlnk`] gives the outcome ([`MovlnkDone`]: `MI.Result` and the
//! updated block). While served, [`SimulatedSbusBus::movlnk_handle`] gives a [`MovlnkHandle`]
//! whose [`execute`](MovlnkHandle::execute) runs one command from another task and returns its
//! outcome, as the IPOS program's blocking call would. The drive stays a slave at its own
//! address meanwhile; its MOVLNK frames go out on the interface and to the drives beside it,
//! and it takes the answers from either. Its own frames never reach itself (a CAN controller
//! does not receive what it sends): a command to its own address times out, and a group
//! command to its own group reaches only the others.
//!
//! Simulator decisions (the manual gives no timing for MOVLNK): one attempt of 50 ms per
//! exchange ([`movlnk_config`]: an IPOS program repeats the command itself and sees the failure
//! in `MI.Result`), asynchronous handshake, the SYNC identifier of the drive's P817.
//! "Der Movilink-Befehl ist nicht multimaster-fähig": while a command runs, no other master may
//! talk to the addressed drive; the simulator does not enforce this (answers are taken by
//! identifier, as on a real bus).

use std::io;
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_core::rt::can_serve::serve_can;
use drive_core::rt::{CanIo, ReceivedFrame};
use drive_core::time::earliest;
use drive_profile::sew::{ParamChannel, ReturnCode};
use drive_sim::movidrive::{BusSource, MasterSlave, MasterSlaveError, Movidrive};
use tokio::sync::{mpsc, oneshot};
use tokio::time::Instant as TokioInstant;

use crate::ids::Address;
use crate::master::{DEFAULT_RESPONSE_TIMEOUT, MasterConfig};
use crate::movlnk::{MlData, MovlnkCommand, MovlnkDone, MovlnkError, MovlnkMaster};
use crate::slave::{Backend, Slave, SlaveConfig, Tally};
use crate::telegram::{ProcessData, Telegram};

/// How often a master-slave master sends its group telegram (ch. 5.4: "jede Millisekunde").
pub const MASTER_PERIOD: Duration = Duration::from_millis(1);

/// The configuration of a simulated drive's MOVLNK executor until
/// [`SimulatedSbusDrive::set_movlnk_config`] changes it (a simulator decision; the manual gives
/// no timing): one attempt of [`DEFAULT_RESPONSE_TIMEOUT`] (50 ms) per exchange, no retries (the IPOS
/// program repeats the command and sees the failure in `MI.Result`), asynchronous handshake,
/// the other settings [`MasterConfig::default`]; the SYNC identifier is always the drive's P817.
pub fn movlnk_config() -> MasterConfig {
    MasterConfig {
        response_timeout: DEFAULT_RESPONSE_TIMEOUT,
        retries: 0,
        ..MasterConfig::default()
    }
}

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
    /// The MOVLNK executor, from the first command on.
    movlnk: Option<MovlnkMaster>,
    /// Its configuration (the SYNC identifier replaced by P817 at each command).
    movlnk_config: MasterConfig,
    /// The outcome of the last command, until taken.
    movlnk_done: Option<MovlnkDone>,
    /// Where the outcome of the running command goes, if a [`MovlnkHandle`] started it.
    movlnk_reply: Option<oneshot::Sender<MovlnkDone>>,
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
            movlnk: None,
            movlnk_config: movlnk_config(),
            movlnk_done: None,
            movlnk_reply: None,
        };
        s.refresh(Instant::ZERO);
        s
    }

    /// The drive model.
    pub fn movidrive(&self) -> &Movidrive {
        &self.slave.backend().drive
    }

    /// The drive model, for changing (P813/P814/P817/P750 written here take effect from the
    /// next frame or deadline on, that frame included).
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
        let mut epoch = *self.epoch.get_or_insert_with(drive_core::rt::time::now);
        let r = serve_can(core::slice::from_mut(self), &mut epoch, io).await;
        self.epoch = Some(epoch);
        r
    }

    /// The drive's time: tokio's time since its first [`serve`](Self::serve) (zero before).
    pub fn now(&self) -> Instant {
        time_since(self.epoch)
    }

    /// Execute the MOVLNK command `command` with the data block `data` (IPOSplus
    /// `_Movilink(MI)`, ch. 5.3) as SBus master, starting at `now`; the frames go out with the
    /// drive's next [`poll_transmit`](CanEndpoint::poll_transmit), the outcome comes from
    /// [`poll_movlnk`](Self::poll_movlnk). Refused at once (nothing sent, nothing to poll)
    /// while a command runs ([`MovlnkError::Busy`]), for an RS-485 bus type and for PO values
    /// that do not fit a word.
    ///
    /// ```
    /// use drive_core::can::CanEndpoint;
    /// use drive_core::Instant;
    /// use sbus_can::movlnk::{MlData, MovlnkCommand};
    /// use sbus_can::sim::SimulatedSbusDrive;
    ///
    /// let (mut master, mut slave) = (SimulatedSbusDrive::new(5), SimulatedSbusDrive::new(1));
    /// // SBus, address 1, Param only, read P000 speed (8318), data block at H20.
    /// let cmd = MovlnkCommand::from_vars([5, 1, 6, 1, 8318, 20, 0]).unwrap();
    /// master.movlnk(cmd, MlData::default(), Instant::ZERO).unwrap();
    /// let t = Instant::from_micros(300);
    /// let request = master.poll_transmit(t).unwrap();
    /// assert_eq!(request.raw_id(), 523);
    /// slave.handle_frame(&request, t);
    /// master.handle_frame(&slave.poll_transmit(t).unwrap(), t);
    /// let done = master.poll_movlnk().unwrap();
    /// assert_eq!((done.result, done.data.read_par), (0, 0)); // a standing drive: 0 1/min
    /// ```
    pub fn movlnk(
        &mut self,
        command: MovlnkCommand,
        data: MlData,
        now: Instant,
    ) -> Result<(), MovlnkError> {
        let sync_id = self.movidrive().sbus_sync_id();
        let config = MasterConfig {
            sync_id,
            ..self.movlnk_config
        };
        let exec = match &mut self.movlnk {
            Some(m) if m.is_busy() => return Err(MovlnkError::Busy),
            Some(m) if *m.master().config() == config => m,
            slot => slot.insert(MovlnkMaster::new(config)),
        };
        exec.execute(command, data, now)?;
        self.movlnk_done = None;
        Ok(())
    }

    /// The outcome of the last MOVLNK command started with [`movlnk`](Self::movlnk), once it is
    /// done (taken).
    pub fn poll_movlnk(&mut self) -> Option<MovlnkDone> {
        self.movlnk_done.take()
    }

    /// Whether a MOVLNK command runs.
    pub fn movlnk_busy(&self) -> bool {
        self.movlnk.as_ref().is_some_and(MovlnkMaster::is_busy)
    }

    /// The MOVLNK executor (its master's counters), once a command was started.
    pub fn movlnk_master(&self) -> Option<&MovlnkMaster> {
        self.movlnk.as_ref()
    }

    /// Change the MOVLNK executor's configuration (timeout, retries, handshake mode) for the
    /// next command; the SYNC identifier always follows P817. Default: [`movlnk_config`].
    pub fn set_movlnk_config(&mut self, config: MasterConfig) {
        self.movlnk_config = config;
    }

    /// Start a command for a [`MovlnkHandle`]: its outcome goes to `reply`, a refusal at once.
    fn start_movlnk(&mut self, request: MovlnkRequest, now: Instant) {
        let MovlnkRequest {
            command,
            data,
            reply,
            ..
        } = request;
        match self.movlnk(command, data, now) {
            Ok(()) => self.movlnk_reply = Some(reply),
            Err(e) => {
                let _ = reply.send(refused(e, data));
            }
        }
    }

    /// Take the executor's outcome, if the command is done: to the waiting handle, or kept for
    /// [`poll_movlnk`](Self::poll_movlnk).
    fn collect_movlnk(&mut self) {
        let Some(done) = self.movlnk.as_mut().and_then(MovlnkMaster::poll_done) else {
            return;
        };
        match self.movlnk_reply.take() {
            // A handle whose caller went away: the outcome is kept for `poll_movlnk`.
            Some(reply) => {
                if let Err(done) = reply.send(done) {
                    self.movlnk_done = Some(done);
                }
            }
            None => self.movlnk_done = Some(done),
        }
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
        // P813/P814/P817 changed through `movidrive_mut` count for this frame already; what the
        // frame itself changes counts from the next one.
        self.refresh(now);
        self.slave.handle_frame(frame, now);
        self.refresh(now);
        if let Some(m) = self.movlnk.as_mut() {
            m.handle_frame(frame, now);
            self.collect_movlnk();
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.slave.handle_timeout(now);
        self.refresh(now);
        if let Some(m) = self.movlnk.as_mut() {
            m.handle_timeout(now);
            self.collect_movlnk();
        }
    }

    /// The slave's answers first, then the master-slave group telegram, then MOVLNK frames.
    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        if let Some(f) = self
            .slave
            .poll_transmit(now)
            .or_else(|| self.group_telegram(now))
        {
            return Some(f);
        }
        let f = self.movlnk.as_mut()?.poll_transmit(now);
        self.collect_movlnk();
        f
    }

    fn poll_timeout(&self) -> Option<Instant> {
        let movlnk = self.movlnk.as_ref().and_then(|m| m.poll_timeout());
        earliest(earliest(self.slave.poll_timeout(), self.next_group), movlnk)
    }
}

/// The outcome of a command refused before anything was sent: `MI.Result` the refusal's code,
/// the data block unchanged.
fn refused(e: MovlnkError, data: MlData) -> MovlnkDone {
    MovlnkDone {
        result: e.result_code(),
        error: Some(e),
        data,
    }
}

/// Tokio's time since `epoch` as drive time (zero without an epoch).
fn time_since(epoch: Option<TokioInstant>) -> Instant {
    epoch.map_or(Instant::ZERO, |e| {
        Instant::from_duration(drive_core::rt::time::now().saturating_duration_since(e))
    })
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

/// A MOVLNK command for the drive at position `drive` of a bus, from a [`MovlnkHandle`].
#[derive(Debug)]
struct MovlnkRequest {
    drive: usize,
    command: MovlnkCommand,
    data: MlData,
    reply: oneshot::Sender<MovlnkDone>,
}

/// The simulated drive has gone: its [`SimulatedSbusBus`] was dropped (or the command with it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the simulated drive is gone: its bus was dropped before the MOVLNK command finished")]
pub struct SimulatorGone;

/// Runs MOVLNK commands on one drive of a [`SimulatedSbusBus`] while the bus is served, from
/// any task ([`SimulatedSbusBus::movlnk_handle`]).
///
/// A command waits until the bus is served; it then runs as the drive's
/// [`movlnk`](SimulatedSbusDrive::movlnk), and its outcome comes back when done (every command
/// ends: a missing answer ends in a timeout). A refusal (a command already running on the
/// drive, an RS-485 bus type, a PO value out of range) is an outcome too, with its `MI.Result`
/// code and the data block unchanged, as the IPOS program would see it.
#[derive(Debug, Clone)]
pub struct MovlnkHandle {
    drive: usize,
    tx: mpsc::UnboundedSender<MovlnkRequest>,
}

impl MovlnkHandle {
    /// Execute `command` with the data block `data`; its outcome (`MI.Result` and the updated
    /// block).
    pub async fn execute(
        &self,
        command: MovlnkCommand,
        data: MlData,
    ) -> Result<MovlnkDone, SimulatorGone> {
        let (reply, done) = oneshot::channel();
        self.tx
            .send(MovlnkRequest {
                drive: self.drive,
                command,
                data,
                reply,
            })
            .map_err(|_| SimulatorGone)?;
        done.await.map_err(|_| SimulatorGone)
    }

    /// Execute the command of the IPOS variables `mi` (`MI.BusType` … `MI.Result`, H … H + 6)
    /// with the data block `mld` (H' … H' + 7); both blocks afterwards, `MI.Result` set. A
    /// command structure that does not parse is not sent: `MI.Result` is its code (−2).
    pub async fn execute_vars(
        &self,
        mi: [i32; 7],
        mld: [i32; 8],
    ) -> Result<([i32; 7], [i32; 8]), SimulatorGone> {
        let data = MlData::from_vars(mld);
        let mut mi = mi;
        let done = match MovlnkCommand::from_vars(mi) {
            Ok(command) => self.execute(command, data).await?,
            Err(e) => refused(e, data),
        };
        if let Some(result) = mi.last_mut() {
            *result = done.result;
        }
        Ok((mi, done.data.to_vars()))
    }
}

/// The MOVLNK requests of a bus's handles.
#[derive(Debug)]
struct Mailbox {
    tx: mpsc::UnboundedSender<MovlnkRequest>,
    rx: mpsc::UnboundedReceiver<MovlnkRequest>,
}

impl Mailbox {
    fn new() -> Self {
        let (tx, rx) = mpsc::unbounded_channel();
        Self { tx, rx }
    }
}

/// The bus's interface as [`serve_can`] sees it: the interface, and a MOVLNK request from a
/// handle ends the serve (as the end of the interface would, while no frame is waiting and
/// nothing is being sent) so that the request can be handed to its drive; serving then goes
/// on, with every drive's state kept.
struct WithMailbox<'a, IO> {
    io: &'a mut IO,
    rx: &'a mut mpsc::UnboundedReceiver<MovlnkRequest>,
    taken: &'a mut Option<MovlnkRequest>,
}

impl<IO: CanIo> CanIo for WithMailbox<'_, IO> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        if let Poll::Ready(r) = self.io.poll_recv(cx) {
            return Poll::Ready(r);
        }
        match self.rx.poll_recv(cx) {
            Poll::Ready(Some(request)) => {
                *self.taken = Some(request);
                Poll::Ready(Err(io::ErrorKind::UnexpectedEof.into()))
            }
            // The bus keeps a sender: the channel does not close while it is served.
            Poll::Ready(None) | Poll::Pending => Poll::Pending,
        }
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        self.io.poll_send(cx, frame)
    }

    // Forwarded, not left to the default: the interface underneath may place a frame at its
    // intended start (the virtual bus does), which the default would lose.
    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: TokioInstant,
    ) -> Poll<io::Result<()>> {
        self.io.poll_send_at(cx, frame, start)
    }
}

/// Several simulated MOVIDRIVEs behind one CAN interface, each answering its own SBus address.
#[derive(Debug)]
pub struct SimulatedSbusBus {
    drives: Vec<SimulatedSbusDrive>,
    epoch: Option<TokioInstant>,
    mailbox: Mailbox,
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
            mailbox: Mailbox::new(),
        }
    }

    /// Serve the bus on `io` until it closes (`Ok`) or fails; the time goes on across serves.
    /// MOVLNK commands of the bus's [`MovlnkHandle`]s are taken meanwhile.
    pub async fn serve<IO: CanIo>(&mut self, mut io: IO) -> io::Result<()> {
        let mut epoch = *self.epoch.get_or_insert_with(drive_core::rt::time::now);
        loop {
            let mut taken = None;
            let wrapped = WithMailbox {
                io: &mut io,
                rx: &mut self.mailbox.rx,
                taken: &mut taken,
            };
            let served = serve_can(&mut self.drives, &mut epoch, wrapped).await;
            self.epoch = Some(epoch);
            served?;
            let Some(request) = taken else {
                return Ok(());
            };
            let now = time_since(Some(epoch));
            if let Some(drive) = self.drives.get_mut(request.drive) {
                drive.start_movlnk(request, now);
            }
        }
    }

    /// The bus's time: tokio's time since its first [`serve`](Self::serve) (zero before); the
    /// `now` for [`SimulatedSbusDrive::movlnk`] between serves.
    pub fn now(&self) -> Instant {
        time_since(self.epoch)
    }

    /// A handle that runs MOVLNK commands on the drive answering SBus address `address` now
    /// (it stays with that drive if its P813 changes later), while the bus is served.
    pub fn movlnk_handle(&self, address: u8) -> Option<MovlnkHandle> {
        let drive = self
            .drives
            .iter()
            .position(|d| d.slave_config().address.get() == address)?;
        Some(MovlnkHandle {
            drive,
            tx: self.mailbox.tx.clone(),
        })
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
