//! The drive (slave) side of SBus, sans-IO (manual ch. 5.1, 5.2): a [`Slave`] takes every CAN
//! frame on the bus, keeps those for its SBus address (P813), group address (P814) and sync
//! identifier (P817), hands parameter services and process data to a [`Backend`] (the drive)
//! and puts the answers out at the times the manual gives. It implements
//! [`CanEndpoint`].
//!
//! What the drive does, telegram by telegram (the choices the manual leaves open are marked
//! **decision**; `docs/protocols/sbus.md` has the reasons):
//!
//! | telegram | identifier | the drive |
//! |---|---|---|
//! | PO | 8a + 3 | takes the words at once, answers PI (8a + 4) after [`SlaveConfig::response_delay`] |
//! | PO sync | 8a + 5 | keeps the words; takes them at the next SYNC and answers PI then, in the first millisecond of the cycle. Outside the window [`SyncWindow`] after the last SYNC (2.5–4.5 ms, erratum SB-E30) or before any SYNC: **decision** dropped and counted ([`Rejection::OutsideSyncWindow`]) |
//! | GPO | 8g + 6 | takes the words, never answers |
//! | parameter request | 8a + 515 | handshake bit 0: executes, answers after the response delay; bit 1: executes at once (Bild 32), answers after the next SYNC |
//! | group parameter request | 8g + 518 | write services executed, never answered; every other service ignored and counted |
//! | SYNC | P817 | releases the synchronised answers |
//!
//! * **Decision, response delay:** [`SlaveConfig::response_delay`], 0 by default (the
//!   simulated drive executes in no simulated time; the frame's own time on the bus is its
//!   latency), at most 1 ms ([`ANSWER_WINDOW`]), the manual's limit for asynchronous process
//!   data. Synchronised answers go out the same delay after the SYNC.
//! * **Decision, one answer in flight:** a new parameter request while the answer to the
//!   previous one has not gone out (a synchronised answer waiting for its SYNC) drops that
//!   answer ([`Rejection::Superseded`]); the new request is executed and answered by its own
//!   handshake bit. A master that sends a new request has given up the old one; answering it
//!   later could be taken for the new one's answer. Likewise a newer PO sync replaces one not
//!   yet taken, and a newer PI replaces one not yet sent (it carries the newer state).
//! * **The special case of ch. 5.2** (wrong coding of the management byte): an undefined
//!   service code (9–15), a write service with a data length other than 4 bytes (the manual:
//!   "generell auf 4 Byte einzustellen") or the status bit set in a request are answered with
//!   class 5, code 5, additional code 0 ([`ReturnCode::ILLEGAL_SERVICE_CODING`]), without the
//!   backend. "No service" is echoed without the backend.
//! * The answer to a request always leaves on the identifier of that request's address, also
//!   when the request changed P813 (the master waits for it there); the slave's identifiers
//!   change with [`Slave::set_config`].
//! * A drive that is a master-slave master ([`SlaveConfig::group_telegrams`] off) takes no
//!   group telegrams (ch. 5.4).
//! * Everything else (other addresses, other drives' answers, variable telegrams, extended
//!   identifiers, remote frames, wrong lengths) is ignored and counted by reason in
//!   [`Slave::tally`]; nothing is answered, nothing panics.

use core::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_core::time::earliest;
use drive_profile::sew::{DataLength, ParamChannel, ReturnCode, Service};

use crate::ids::Address;
use crate::telegram::{DecodeError, ProcessData, Telegram};

/// The SBus time base: one SYNC every 5 ms (manual ch. 5.1).
pub const CYCLE: Duration = Duration::from_millis(5);

/// Synchronised answers and asynchronous PI go out within this time (the "1. Millisekunde").
pub const ANSWER_WINDOW: Duration = Duration::from_millis(1);

/// When the master's PO sync must arrive, after the SYNC that starts the cycle: "frühestens
/// 500 µs nach der 2. Millisekunde und spätestens 500 µs vor der 1. Millisekunde" (the manual
/// writes ms, erratum SB-E30), i.e. from 2.5 ms to 4.5 ms, both ends included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SyncWindow {
    /// Earliest arrival after the SYNC.
    pub earliest: Duration,
    /// Latest arrival after the SYNC.
    pub latest: Duration,
}

impl SyncWindow {
    /// The manual's window, 2.5 … 4.5 ms after the SYNC.
    pub const MANUAL: SyncWindow = SyncWindow {
        earliest: Duration::from_micros(2500),
        latest: Duration::from_micros(4500),
    };

    /// Whether a PO sync `since_sync` after the SYNC is inside.
    pub const fn contains(&self, since_sync: Duration) -> bool {
        since_sync.as_nanos() >= self.earliest.as_nanos()
            && since_sync.as_nanos() <= self.latest.as_nanos()
    }
}

/// Configuration of a [`Slave`]: the drive's P813, P814, P817 and the simulator's choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SlaveConfig {
    /// P813 SBus address.
    pub address: Address,
    /// P814 SBus group address.
    pub group: Address,
    /// P817 SBus sync identifier (0–2047; higher values are taken modulo 2048).
    pub sync_id: u16,
    /// Time from a request (or the SYNC) to its answer; clamped to [`ANSWER_WINDOW`].
    pub response_delay: Duration,
    /// When a PO sync is taken; `None`: at any time after a SYNC was seen.
    pub po_sync_window: Option<SyncWindow>,
    /// Whether group telegrams are taken (off for a master-slave master, ch. 5.4).
    pub group_telegrams: bool,
}

impl SlaveConfig {
    /// Address `address`, group 0, sync identifier 0 (factory settings of P814 and P817), no
    /// response delay, the manual's PO sync window, group telegrams taken.
    pub fn new(address: Address) -> Self {
        Self {
            address,
            group: Address::default(),
            sync_id: crate::ids::DEFAULT_SYNC_ID,
            response_delay: Duration::ZERO,
            po_sync_window: Some(SyncWindow::MANUAL),
            group_telegrams: true,
        }
    }
}

/// The drive behind the protocol; the simulated MOVIDRIVE implements it.
pub trait Backend {
    /// Execute the parameter service `request` (a defined service other than "no service")
    /// at `now`: the answer's data or the return code.
    fn param(&mut self, request: &ParamChannel, now: Instant) -> Result<u32, ReturnCode>;

    /// Process output data for this drive (PO, or PO sync at its SYNC), taken at `now`; the
    /// process input data of the answer.
    fn process_data(&mut self, output: ProcessData, now: Instant) -> ProcessData;

    /// Group process output data, taken at `now` (never answered).
    fn group_process_data(&mut self, output: ProcessData, now: Instant);

    /// A write service of a group parameter request (never answered; the result only
    /// counts).
    fn group_param(&mut self, request: &ParamChannel, now: Instant) -> Result<u32, ReturnCode> {
        self.param(request, now)
    }

    /// A SYNC arrived at `now` (before the synchronised data are taken).
    fn sync(&mut self, now: Instant) {
        let _ = now;
    }

    /// The backend's own next deadline (e.g. the SBus timeout P815), if any.
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }

    /// Time advanced to `now` (at or past [`Backend::poll_timeout`]).
    fn handle_timeout(&mut self, now: Instant) {
        let _ = now;
    }
}

/// Why a frame was not taken (or an answer not sent); counted in [`Tally`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Rejection {
    /// An extended (29-bit) identifier.
    ExtendedId,
    /// A remote frame.
    Remote,
    /// A standard identifier that is no SBus MOVILINK one (variable telegrams, other
    /// protocols, a foreign SYNC).
    NotSbus,
    /// An SBus identifier with the wrong number of data bytes.
    Length,
    /// An SBus telegram for another address or group.
    OtherAddress,
    /// A telegram a drive sends (PI, parameter response): another drive's, or an echo.
    FromDrive,
    /// A group parameter request with a service other than write (only writes are allowed).
    GroupNotWrite,
    /// A group telegram to a master-slave master (ch. 5.4).
    GroupToMaster,
    /// A PO sync outside the window after the SYNC, or before any SYNC.
    OutsideSyncWindow,
    /// An answer not yet sent was dropped for a newer request.
    Superseded,
}

impl Rejection {
    /// Every reason, in the order of [`Tally`].
    pub const ALL: [Rejection; 10] = [
        Rejection::ExtendedId,
        Rejection::Remote,
        Rejection::NotSbus,
        Rejection::Length,
        Rejection::OtherAddress,
        Rejection::FromDrive,
        Rejection::GroupNotWrite,
        Rejection::GroupToMaster,
        Rejection::OutsideSyncWindow,
        Rejection::Superseded,
    ];

    const fn slot(self) -> usize {
        match self {
            Rejection::ExtendedId => 0,
            Rejection::Remote => 1,
            Rejection::NotSbus => 2,
            Rejection::Length => 3,
            Rejection::OtherAddress => 4,
            Rejection::FromDrive => 5,
            Rejection::GroupNotWrite => 6,
            Rejection::GroupToMaster => 7,
            Rejection::OutsideSyncWindow => 8,
            Rejection::Superseded => 9,
        }
    }

    /// What it means, in English.
    pub const fn describe(self) -> &'static str {
        match self {
            Rejection::ExtendedId => "extended identifier",
            Rejection::Remote => "remote frame",
            Rejection::NotSbus => "no SBus MOVILINK identifier",
            Rejection::Length => "wrong data length",
            Rejection::OtherAddress => "for another address or group",
            Rejection::FromDrive => "sent by a drive",
            Rejection::GroupNotWrite => "group parameter request without a write service",
            Rejection::GroupToMaster => "group telegram to a master-slave master",
            Rejection::OutsideSyncWindow => "PO sync outside the sync window",
            Rejection::Superseded => "answer dropped for a newer request",
        }
    }
}

impl core::fmt::Display for Rejection {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.describe())
    }
}

impl From<DecodeError> for Rejection {
    fn from(e: DecodeError) -> Self {
        match e {
            DecodeError::ExtendedId { .. } => Rejection::ExtendedId,
            DecodeError::Remote { .. } => Rejection::Remote,
            DecodeError::Length { .. } => Rejection::Length,
            _ => Rejection::NotSbus,
        }
    }
}

/// How many frames were taken and how many were not, by reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Tally {
    taken: u64,
    rejected: [u64; Rejection::ALL.len()],
}

impl Tally {
    /// Frames taken (for this drive, its group, or SYNC).
    pub const fn taken(&self) -> u64 {
        self.taken
    }

    /// How often `reason` occurred.
    pub fn rejected(&self, reason: Rejection) -> u64 {
        self.rejected.get(reason.slot()).copied().unwrap_or(0)
    }

    /// All rejections.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().fold(0u64, |a, &b| a.saturating_add(b))
    }

    fn reject(&mut self, reason: Rejection) {
        if let Some(n) = self.rejected.get_mut(reason.slot()) {
            *n = n.saturating_add(1);
        }
    }
}

/// A frame waiting for its time.
#[derive(Debug, Clone, Copy)]
struct Pending {
    frame: CanFrame,
    not_before: Instant,
}

/// The SBus slave state machine; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Slave<B> {
    config: SlaveConfig,
    backend: B,
    now: Instant,
    last_sync: Option<Instant>,
    /// PI answering a PO or a PO sync.
    pi: Option<Pending>,
    /// The answer to a parameter request (asynchronous, or released by a SYNC).
    response: Option<Pending>,
    /// A PO sync waiting for the next SYNC.
    po_sync: Option<ProcessData>,
    /// A synchronised parameter answer waiting for the next SYNC.
    sync_response: Option<CanFrame>,
    tally: Tally,
}

impl<B: Backend> Slave<B> {
    /// A drive with `config` executing on `backend`.
    pub fn new(config: SlaveConfig, backend: B) -> Self {
        Self {
            config,
            backend,
            now: Instant::ZERO,
            last_sync: None,
            pi: None,
            response: None,
            po_sync: None,
            sync_response: None,
            tally: Tally::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// Change the configuration (after P813, P814 or P817 were written): the next frame is
    /// judged by the new identifiers. Answers already waiting keep theirs.
    pub fn set_config(&mut self, config: SlaveConfig) {
        self.config = config;
    }

    /// The backend.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The backend, for changing.
    pub fn backend_mut(&mut self) -> &mut B {
        &mut self.backend
    }

    /// Consume the state machine, returning the backend.
    pub fn into_backend(self) -> B {
        self.backend
    }

    /// Frames taken and rejected so far.
    pub fn tally(&self) -> &Tally {
        &self.tally
    }

    /// When the last SYNC arrived.
    pub fn last_sync(&self) -> Option<Instant> {
        self.last_sync
    }

    /// Feed one frame received at `now` (the end of its last bit).
    pub fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.advance(now);
        let now = self.now;
        let telegram = match Telegram::decode(frame, self.config.sync_id & 0x7FF) {
            Ok(t) => t,
            Err(e) => return self.tally.reject(e.into()),
        };
        let own = self.config.address;
        let group = self.config.group;
        match telegram {
            Telegram::Sync => {
                self.tally.taken += 1;
                self.on_sync(now);
            }
            Telegram::ProcessOutput {
                address,
                synchronised,
                data,
            } if address == own => {
                if synchronised {
                    self.on_po_sync(data, now);
                } else {
                    self.tally.taken += 1;
                    let pi = self.backend.process_data(data, now);
                    self.queue_pi(pi, now);
                }
            }
            Telegram::ParamRequest { address, channel } if address == own => {
                self.tally.taken += 1;
                self.on_param(address, channel, now);
            }
            Telegram::GroupProcessOutput { group: g, data } if g == group => {
                if !self.config.group_telegrams {
                    return self.tally.reject(Rejection::GroupToMaster);
                }
                self.tally.taken += 1;
                self.backend.group_process_data(data, now);
            }
            Telegram::GroupParamRequest { group: g, channel } if g == group => {
                if !self.config.group_telegrams {
                    return self.tally.reject(Rejection::GroupToMaster);
                }
                let write = channel.service().is_some_and(Service::is_write);
                if !write || coding_error(&channel) {
                    return self.tally.reject(Rejection::GroupNotWrite);
                }
                self.tally.taken += 1;
                let _ = self.backend.group_param(&channel, now);
            }
            Telegram::ProcessInput { .. } | Telegram::ParamResponse { .. } => {
                self.tally.reject(Rejection::FromDrive);
            }
            _ => self.tally.reject(Rejection::OtherAddress),
        }
    }

    /// Advance the time to `now`: answers may fall due, the backend's deadline may pass.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        if self
            .backend
            .poll_timeout()
            .is_some_and(|deadline| self.now >= deadline)
        {
            self.backend.handle_timeout(self.now);
        }
    }

    /// The next frame due at `now`: of two due, the one with the lower identifier (the one
    /// that wins arbitration: PI before the parameter response).
    pub fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        self.advance(now);
        let due = |p: &Option<Pending>| p.as_ref().filter(|p| p.not_before <= now).map(|p| p.frame);
        let slot = match (due(&self.pi), due(&self.response)) {
            (Some(a), Some(b)) if b.raw_id() < a.raw_id() => &mut self.response,
            (Some(_), _) => &mut self.pi,
            (None, Some(_)) => &mut self.response,
            (None, None) => return None,
        };
        slot.take().map(|p| p.frame)
    }

    /// When [`Slave::handle_timeout`] or [`Slave::poll_transmit`] has work: an answer falling
    /// due, or the backend's deadline.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let tx = earliest(
            self.pi.map(|p| p.not_before),
            self.response.map(|p| p.not_before),
        );
        earliest(tx, self.backend.poll_timeout())
    }

    fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
    }

    fn delay(&self) -> Duration {
        self.config.response_delay.min(ANSWER_WINDOW)
    }

    fn queue_pi(&mut self, pi: ProcessData, at: Instant) {
        let frame = Telegram::ProcessInput {
            address: self.config.address,
            data: pi,
        }
        .encode(self.config.sync_id);
        self.pi = Some(Pending {
            frame,
            not_before: at + self.delay(),
        });
    }

    fn on_sync(&mut self, now: Instant) {
        self.last_sync = Some(now);
        self.backend.sync(now);
        if let Some(po) = self.po_sync.take() {
            let pi = self.backend.process_data(po, now);
            self.queue_pi(pi, now);
        }
        if let Some(frame) = self.sync_response.take() {
            self.response = Some(Pending {
                frame,
                not_before: now + self.delay(),
            });
        }
    }

    fn on_po_sync(&mut self, data: ProcessData, now: Instant) {
        let in_window = match (self.config.po_sync_window, self.last_sync) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some(w), Some(sync)) => w.contains(now.saturating_duration_since(sync)),
        };
        if !in_window {
            return self.tally.reject(Rejection::OutsideSyncWindow);
        }
        self.tally.taken += 1;
        self.po_sync = Some(data);
    }

    fn on_param(&mut self, address: Address, request: ParamChannel, now: Instant) {
        // One answer in flight: a newer request drops the one not yet sent.
        if self.response.take().is_some() || self.sync_response.take().is_some() {
            self.tally.reject(Rejection::Superseded);
        }
        let answer = if coding_error(&request) {
            request.answer(Err(ReturnCode::ILLEGAL_SERVICE_CODING))
        } else {
            match request.service() {
                Some(Service::NoService) | None => request,
                Some(_) => request.answer(self.backend.param(&request, now)),
            }
        };
        let frame = Telegram::ParamResponse {
            address,
            channel: answer,
        }
        .encode(self.config.sync_id);
        if request.management.handshake() {
            self.sync_response = Some(frame);
        } else {
            self.response = Some(Pending {
                frame,
                not_before: now + self.delay(),
            });
        }
    }
}

/// The special case of ch. 5.2: a management byte with a wrong coding (undefined service, a
/// write of other than 4 bytes, the status bit set in a request).
fn coding_error(request: &ParamChannel) -> bool {
    let m = request.management;
    match m.service() {
        None => true,
        Some(s) => m.is_error() || (s.is_write() && m.data_length() != DataLength::Four),
    }
}

impl<B: Backend> CanEndpoint for Slave<B> {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        Slave::handle_frame(self, frame, now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        Slave::handle_timeout(self, now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        Slave::poll_transmit(self, now)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        Slave::poll_timeout(self)
    }
}
