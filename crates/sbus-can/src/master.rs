//! The SBus master (controller) state machine, sans-IO (manual ch. 5.1, 5.2).
//!
//! [`Master`] is a [`CanEndpoint`]: frames from the bus go to [`Master::handle_frame`], the
//! passing of time to [`Master::handle_timeout`] at [`Master::poll_timeout`], frames to send
//! come from [`Master::poll_transmit`] and results from [`Master::poll_event`]. One request is
//! in flight at a time; the synchronisation producer runs beside it.
//!
//! What it does:
//!
//! * **parameter services** to one drive ([`Master::param`]): every
//!   [`Service`], in both handshake modes ([`Handshake`]). The
//!   answer is the parameter response (8a + 516) of that address with the same service code,
//!   subindex and index ([`ParamChannel::is_answered_by`]); any other response is a counted
//!   rejection ([`Rejections::mismatch`]), never the answer. The status bit makes the answer a
//!   [`MasterError::Drive`] with the drive's [`ReturnCode`];
//! * **timeouts and retries**: each attempt waits [`MasterConfig::timeout`] (a sync-mode
//!   attempt from the first SYNC after the request, see below); after
//!   [`MasterConfig::retries`] retransmissions the request is given up with
//!   [`MasterError::Timeout`] naming the address, the attempts and the timeout. After a give-up
//!   the next transmission waits [`MasterConfig::late_guard`], so that a late answer to the
//!   abandoned request arrives while nothing waits and is counted
//!   ([`Rejections::unsolicited`]) instead of answering the next request;
//! * **group parameter writes** (8g + 518, write services only; anything else is refused with
//!   [`RequestError::GroupNeedsWrite`]), **process data** (PO 8a + 3 answered by PI 8a + 4;
//!   PO sync 8a + 5 answered after the next SYNC, sent in the window of ch. 5.1) and **group
//!   process data** (8g + 6): unanswered telegrams complete when handed out;
//! * **synchronisation** ([`SyncProducer`]): SYNC (identifier P817, no data) every
//!   [`MasterConfig::sync_period`] (5 ms); the SYNC starts the cycle, so it is in the cycle's
//!   first millisecond by construction. By default ([`SyncProducer::OnDemand`]) the master
//!   produces SYNC only while a sync-mode request waits, starting [`SYNC_LEAD`] after the
//!   request; with [`SyncProducer::External`] another node produces it. A sync-mode request
//!   cannot hang either way: before a SYNC is seen its attempt ends one sync period plus the
//!   timeout after the request;
//! * **scan** ([`Master::scan`]): a read of P070 unit type (index 8301, read-only, harmless) to
//!   every address of a range, all sent at once (each address answers on its own identifier),
//!   one attempt, one timeout after the last request; [`Master::scan_results`];
//! * **counters** ([`MasterStats`]): transactions, retries, timeouts, drive errors, SYNCs and
//!   rejected frames by reason. Frames of other nodes (their requests, variable telegrams,
//!   other protocols) are ignored and counted ([`Rejections::foreign`]).
//!
//! ```
//! use drive_core::can::{CanEndpoint, CanFrame};
//! use drive_core::Instant;
//! use drive_profile::sew::ParamChannel;
//! use sbus_can::master::{Answer, Handshake, Master, MasterConfig, MasterEvent};
//! use sbus_can::Address;
//!
//! let mut m = Master::new(MasterConfig::default());
//! let drive = Address::new(1).unwrap();
//! m.param(drive, ParamChannel::read(8318), Handshake::Async, Instant::ZERO).unwrap();
//! let req = m.poll_transmit(Instant::ZERO).unwrap();
//! assert_eq!(req.to_string(), "20B#3100207E00000000");
//! // The drive answers 1 000 000 (1000.000 1/min) on 8 × 1 + 516 = 524.
//! let answer = CanFrame::standard(524, &[0x31, 0, 0x20, 0x7E, 0x00, 0x0F, 0x42, 0x40]).unwrap();
//! m.handle_frame(&answer, Instant::from_micros(400));
//! match m.poll_event() {
//!     Some(MasterEvent::Done(Ok(Answer::Param(ch)))) => assert_eq!(ch.data, 1_000_000),
//!     other => panic!("{other:?}"),
//! }
//! ```

use core::fmt;
use core::time::Duration;

use drive_core::Queue;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_core::time::{Instant, duration_nanos};
use drive_profile::sew::{ParamChannel, ReturnCode, Service, index};

use crate::ids::{Address, DEFAULT_SYNC_ID, MAX_ADDRESS};
use crate::telegram::{DecodeError, ProcessData, Telegram};

/// Default time an attempt waits for its answer: 50 ms, MOVILINK's maximum response delay.
/// SBus drives answer process data within 1 ms (ch. 5.1); the margin covers parameter
/// services and USB adapters.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(50);

/// Default scan timeout per round.
pub const DEFAULT_SCAN_TIMEOUT: Duration = Duration::from_millis(20);

/// The SBus cycle: 5 ms (ch. 5.1 "feste Zeitbasis von 5 Millisekunden").
pub const DEFAULT_SYNC_PERIOD: Duration = Duration::from_millis(5);

/// How long after a sync-mode request the on-demand producer sends its first SYNC: the
/// request must be on the bus at least 500 µs before the SYNC (ch. 5.1, erratum SB-E30); 1 ms
/// leaves room for the request's own time on the wire at 125 kbit/s.
pub const SYNC_LEAD: Duration = Duration::from_millis(1);

/// The PO-sync window in a cycle: from 2.5 ms after the SYNC ("frühestens 500 µs nach der
/// 2. Millisekunde") to 0.5 ms before the next one ("spätestens 500 µs vor der 1.
/// Millisekunde"); the manual prints ms for µs (erratum SB-E30).
pub const PO_SYNC_WINDOW_START: Duration = Duration::from_micros(2500);

/// See [`PO_SYNC_WINDOW_START`]: the window ends this long before the next SYNC.
pub const PO_SYNC_WINDOW_END_BEFORE: Duration = Duration::from_micros(500);

/// The index a scan reads: P070 unit type (read-only, present in every MOVIDRIVE).
pub const SCAN_INDEX: u16 = index::UNIT_TYPE;

/// When a parameter response is sent (management byte bit 6, ch. 5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Handshake {
    /// Bit 6 = 0: the drive answers at once.
    #[default]
    Async,
    /// Bit 6 = 1: the drive answers after the next SYNC, in the first millisecond of the cycle.
    Sync,
}

impl Handshake {
    /// Whether the handshake bit is set.
    pub const fn bit(self) -> bool {
        matches!(self, Handshake::Sync)
    }
}

/// Who sends the SYNC telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SyncProducer {
    /// This master, while a sync-mode request (parameter service with handshake bit 1, PO sync)
    /// waits for its answer; the first SYNC [`SYNC_LEAD`] after the request, then every period.
    #[default]
    OnDemand,
    /// This master, every period, from [`Master::new`] (or [`Master::set_sync_producer`]) on.
    Always,
    /// Another node; this master sends none (except [`Master::sync`]) and uses the SYNCs it sees.
    External,
}

/// Configuration of a [`Master`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MasterConfig {
    /// How long an attempt waits for its answer: from the request's hand-over, for sync-mode
    /// requests from the first SYNC after it. Default [`DEFAULT_TIMEOUT`].
    pub timeout: Duration,
    /// Retransmissions after a timeout (0 = one attempt; 255 = 256 attempts, never more).
    pub retries: u8,
    /// P817 of the drives: the SYNC identifier, 0–2047 (factory setting 0).
    pub sync_id: u16,
    /// The SBus cycle, 5 ms.
    pub sync_period: Duration,
    /// The handshake mode of services that do not name one (the async driver's
    /// `read`/`write`…, [`MovlnkMaster`](crate::movlnk::MovlnkMaster)); [`Master::param`] takes
    /// it as an argument.
    pub handshake: Handshake,
    /// The answer timeout of a scan (one attempt per address).
    pub scan_timeout: Duration,
    /// Who sends SYNC.
    pub sync_producer: SyncProducer,
    /// After a request is given up, how long the next transmission waits (late answers to the
    /// abandoned request are counted, not taken). Default: the timeout.
    pub late_guard: Duration,
}

impl Default for MasterConfig {
    fn default() -> Self {
        Self {
            timeout: DEFAULT_TIMEOUT,
            retries: 2,
            sync_id: DEFAULT_SYNC_ID,
            sync_period: DEFAULT_SYNC_PERIOD,
            handshake: Handshake::Async,
            scan_timeout: DEFAULT_SCAN_TIMEOUT,
            sync_producer: SyncProducer::OnDemand,
            late_guard: DEFAULT_TIMEOUT,
        }
    }
}

/// A request's positive outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Answer {
    /// The drive's parameter response (status bit clear).
    Param(ParamChannel),
    /// The drive's process input data.
    ProcessInput(ProcessData),
    /// An unanswered telegram (group request, group process data, SYNC) was handed out.
    Sent,
}

/// A request's failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MasterError {
    /// The drive refused the parameter service (status bit set): its return code.
    Drive {
        /// The drive's SBus address.
        address: Address,
        /// The return code (bytes 4–7).
        code: ReturnCode,
    },
    /// No answer in any attempt.
    Timeout {
        /// The drive's SBus address.
        address: Address,
        /// Transmissions made.
        attempts: u16,
        /// The wait of each attempt.
        timeout: Duration,
    },
}

impl fmt::Display for MasterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MasterError::Drive { address, code } => {
                write!(
                    f,
                    "the drive at SBus address {address} refused the service: {code}"
                )
            }
            MasterError::Timeout {
                address,
                attempts,
                timeout,
            } => write!(
                f,
                "no answer from SBus address {address} after {attempts} attempts of {} ms each",
                timeout.as_millis()
            ),
        }
    }
}

impl core::error::Error for MasterError {}

/// Why a request was not started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum RequestError {
    /// A request is in flight; wait for its [`MasterEvent::Done`].
    Busy,
    /// Group parameter telegrams carry write services only (ch. 5.1); this one has another
    /// service code.
    GroupNeedsWrite {
        /// The service code (bits 0–3 of the management byte).
        service: u8,
    },
    /// A scan range with the first address after the last.
    EmptyRange,
}

impl fmt::Display for RequestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RequestError::Busy => f.write_str("a request is already in flight"),
            RequestError::GroupNeedsWrite { service } => {
                let name =
                    Service::from_code(*service).map_or("an undefined service", Service::name);
                write!(
                    f,
                    "group parameter telegrams carry write services only, not {name} (code {service}); drives never answer them"
                )
            }
            RequestError::EmptyRange => f.write_str("the scan range is empty"),
        }
    }
}

impl core::error::Error for RequestError {}

/// What the master reports; drained with [`Master::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MasterEvent {
    /// The request in flight is done.
    Done(Result<Answer, MasterError>),
    /// The scan is done; [`Master::scan_results`] has every address's entry.
    ScanDone,
}

/// Received frames the master did not take, by reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Rejections {
    /// A parameter response from the awaited address that answers another service, subindex
    /// or index.
    pub mismatch: u64,
    /// A response or process input data while nothing waits for it (late answers, answers to
    /// another master).
    pub unsolicited: u64,
    /// An SBus identifier with a wrong length, a remote frame or an extended identifier.
    pub malformed: u64,
    /// Frames of other nodes: requests and process output data of other masters, variable
    /// telegrams, other protocols.
    pub foreign: u64,
}

impl Rejections {
    /// All rejections.
    pub const fn total(&self) -> u64 {
        self.mismatch + self.unsolicited + self.malformed + self.foreign
    }
}

/// Counters of a [`Master`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct MasterStats {
    /// Requests put on the bus (first transmissions; scan requests count one each).
    pub transactions: u64,
    /// Retransmissions after a timeout.
    pub retries: u64,
    /// Requests given up.
    pub timeouts: u64,
    /// Negative answers (status bit set).
    pub drive_errors: u64,
    /// SYNC telegrams sent.
    pub syncs_sent: u64,
    /// SYNC telegrams of other producers seen.
    pub syncs_seen: u64,
    /// Cycles the producer could not send in time (the master was polled too late) and skipped.
    pub syncs_skipped: u64,
    /// Received frames not taken.
    pub rejected: Rejections,
    /// Responses and process input data received while a request waited to go out or before
    /// its first transmission (an answer an earlier program left in the adapter, a late
    /// answer to an earlier request): never its answer, and not counted as rejections.
    pub stale: u64,
}

/// One address's entry of a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ScanEntry {
    /// Not asked (outside the range).
    #[default]
    NotScanned,
    /// No answer.
    Silent,
    /// The drive answered P070 unit type.
    UnitType(u32),
    /// The drive answered with a return code (something is there).
    Refused(ReturnCode),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Expect {
    Nothing,
    Param {
        address: Address,
        sent: ParamChannel,
    },
    ProcessInput {
        address: Address,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting to be transmitted.
    Queued,
    /// Transmitted; the attempt ends at `deadline`; `synced`: a SYNC came after it.
    Waiting { deadline: Instant, synced: bool },
}

#[derive(Debug, Clone, Copy)]
struct Job {
    frame: CanFrame,
    expect: Expect,
    /// Answered after the next SYNC.
    sync_mode: bool,
    /// A PO-sync telegram: sent in the cycle's window.
    po_window: bool,
    attempts: u16,
    /// When the first attempt was handed out: a frame received before it answers an earlier
    /// request, whenever it is processed.
    first_sent: Instant,
    phase: Phase,
}

#[derive(Debug, Clone, Copy)]
struct Scan {
    next: u8,
    last: u8,
    /// Set when the last request was handed out.
    deadline: Option<Instant>,
    timeout: Duration,
}

/// The SBus master; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct Master {
    config: MasterConfig,
    job: Option<Job>,
    scan: Option<Scan>,
    results: [ScanEntry; 64],
    events: Queue<MasterEvent, 4>,
    stats: MasterStats,
    now: Instant,
    /// No transmission of a request before this (after a give-up).
    hold_until: Instant,
    /// The next SYNC of the running producer.
    next_sync: Option<Instant>,
    /// The last SYNC sent or seen.
    last_sync: Option<Instant>,
    /// The receive time of the frame being handled.
    rx_at: Instant,
}

impl Master {
    /// A master with `config`. With [`SyncProducer::Always`] the first SYNC is due at once.
    pub fn new(config: MasterConfig) -> Self {
        Self {
            next_sync: (config.sync_producer == SyncProducer::Always).then_some(Instant::ZERO),
            config,
            job: None,
            scan: None,
            results: [ScanEntry::NotScanned; 64],
            events: Queue::new(),
            stats: MasterStats::default(),
            now: Instant::ZERO,
            hold_until: Instant::ZERO,
            last_sync: None,
            rx_at: Instant::ZERO,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// The counters so far.
    pub fn stats(&self) -> MasterStats {
        self.stats
    }

    /// Change the timeout of each attempt; applies from the next transmission on.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.config.timeout = timeout;
    }

    /// Change the number of retransmissions; applies to the request in flight too.
    pub fn set_retries(&mut self, retries: u8) {
        self.config.retries = retries;
    }

    /// Change who sends SYNC, at `now` ([`SyncProducer::Always`] starts at once).
    pub fn set_sync_producer(&mut self, producer: SyncProducer, now: Instant) {
        self.advance(now);
        self.config.sync_producer = producer;
        match producer {
            SyncProducer::Always if self.next_sync.is_none() => self.next_sync = Some(self.now),
            SyncProducer::External => self.next_sync = None,
            _ => {}
        }
    }

    /// Whether neither a request nor a scan is in flight.
    pub fn is_idle(&self) -> bool {
        self.job.is_none() && self.scan.is_none()
    }

    /// The last SYNC sent or seen.
    pub fn last_sync(&self) -> Option<Instant> {
        self.last_sync
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.events.pop()
    }

    /// The entries of the last (or running) scan, by address 0–63.
    pub fn scan_results(&self) -> &[ScanEntry; 64] {
        &self.results
    }

    /// Drop the request or scan in flight (the caller gave up on it, e.g. a cancelled call); a
    /// late answer to it is then counted as unsolicited. The next transmission waits
    /// [`MasterConfig::late_guard`] if it was on the bus.
    pub fn abort(&mut self, now: Instant) {
        self.advance(now);
        let on_bus = matches!(self.job, Some(j) if j.attempts > 0) || self.scan.is_some();
        self.job = None;
        self.scan = None;
        if on_bus {
            self.hold_until = self.now.saturating_add(self.config.late_guard);
        }
        self.stop_sync_if_idle();
    }

    /// A parameter service `channel` to the drive at `address`, answered at once or after the
    /// next SYNC (`handshake` replaces bit 6 of the management byte; the status bit is cleared).
    /// Any service code is sent as given (an undefined one gets the drive's 5/5 answer).
    pub fn param(
        &mut self,
        address: Address,
        channel: ParamChannel,
        handshake: Handshake,
        now: Instant,
    ) -> Result<(), RequestError> {
        let mut channel = channel.with_handshake(handshake.bit());
        channel.management = channel.management.with_error(false);
        let frame = Telegram::ParamRequest { address, channel }.encode(self.config.sync_id);
        self.begin(
            frame,
            Expect::Param {
                address,
                sent: channel,
            },
            handshake == Handshake::Sync,
            false,
            now,
        )
    }

    /// A group parameter request (8g + 518) to every drive of `group`: write and write-volatile
    /// only, never answered ([`Answer::Sent`] once handed out). The handshake bit is cleared.
    pub fn group_param(
        &mut self,
        group: Address,
        channel: ParamChannel,
        now: Instant,
    ) -> Result<(), RequestError> {
        if !channel.service().is_some_and(Service::is_write) {
            return Err(RequestError::GroupNeedsWrite {
                service: channel.management.service_code(),
            });
        }
        let mut channel = channel.with_handshake(false);
        channel.management = channel.management.with_error(false);
        let frame = Telegram::GroupParamRequest { group, channel }.encode(self.config.sync_id);
        self.begin(frame, Expect::Nothing, false, false, now)
    }

    /// Process output data to `address` (8a + 3), answered at once with its process input data
    /// (8a + 4).
    pub fn process_data(
        &mut self,
        address: Address,
        data: ProcessData,
        now: Instant,
    ) -> Result<(), RequestError> {
        self.process_output(address, data, false, now)
    }

    /// Synchronised process output data to `address` (8a + 5): sent in the cycle's window
    /// (2.5 ms after a SYNC to 0.5 ms before the next), taken by the drive at the next SYNC and
    /// answered with its process input data in the first millisecond. With no cycle running,
    /// a master that produces SYNC sends one first (a drive drops a PO sync seen before any
    /// SYNC); with [`SyncProducer::External`] it goes out at once.
    pub fn process_data_sync(
        &mut self,
        address: Address,
        data: ProcessData,
        now: Instant,
    ) -> Result<(), RequestError> {
        self.process_output(address, data, true, now)
    }

    /// Group process output data (8g + 6) to every drive of `group`; never answered.
    pub fn group_process_data(
        &mut self,
        group: Address,
        data: ProcessData,
        now: Instant,
    ) -> Result<(), RequestError> {
        let frame = Telegram::GroupProcessOutput { group, data }.encode(self.config.sync_id);
        self.begin(frame, Expect::Nothing, false, false, now)
    }

    /// One SYNC telegram, as a request ([`Answer::Sent`] once handed out); it also starts the
    /// cycle for waiting sync-mode requests.
    pub fn sync(&mut self, now: Instant) -> Result<(), RequestError> {
        let frame = Telegram::Sync.encode(self.config.sync_id);
        self.begin(frame, Expect::Nothing, false, false, now)
    }

    /// Scan the addresses `first..=last` (clamped to 63): a read of P070 unit type to each, all
    /// sent one after another, one attempt, answers awaited until `timeout` after the last
    /// request. Ends with [`MasterEvent::ScanDone`]; entries in [`Master::scan_results`].
    pub fn scan(
        &mut self,
        first: Address,
        last: Address,
        timeout: Duration,
        now: Instant,
    ) -> Result<(), RequestError> {
        if !self.is_idle() {
            return Err(RequestError::Busy);
        }
        if first > last {
            return Err(RequestError::EmptyRange);
        }
        self.advance(now);
        for (a, e) in self.results.iter_mut().enumerate() {
            let a = u8::try_from(a).unwrap_or(u8::MAX);
            *e = if a >= first.get() && a <= last.get() {
                ScanEntry::Silent
            } else {
                ScanEntry::NotScanned
            };
        }
        self.scan = Some(Scan {
            next: first.get(),
            last: last.get().min(MAX_ADDRESS),
            deadline: None,
            timeout,
        });
        Ok(())
    }

    fn process_output(
        &mut self,
        address: Address,
        data: ProcessData,
        synchronised: bool,
        now: Instant,
    ) -> Result<(), RequestError> {
        let frame = Telegram::ProcessOutput {
            address,
            synchronised,
            data,
        }
        .encode(self.config.sync_id);
        self.begin(
            frame,
            Expect::ProcessInput { address },
            synchronised,
            synchronised,
            now,
        )
    }

    fn begin(
        &mut self,
        frame: CanFrame,
        expect: Expect,
        sync_mode: bool,
        po_window: bool,
        now: Instant,
    ) -> Result<(), RequestError> {
        if !self.is_idle() {
            return Err(RequestError::Busy);
        }
        self.advance(now);
        self.job = Some(Job {
            frame,
            expect,
            sync_mode,
            po_window,
            attempts: 0,
            first_sent: Instant::MAX,
            phase: Phase::Queued,
        });
        Ok(())
    }

    /// Feed one frame received at `now` (the end of its last bit). A response received before
    /// the request in flight was first handed out is never its answer, even if it is fed
    /// later (an interface's queue read after the request was sent).
    pub fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.advance(now);
        self.rx_at = now;
        let telegram = match Telegram::decode(frame, self.config.sync_id) {
            Ok(t) => t,
            Err(DecodeError::NotSbus { .. }) => {
                self.stats.rejected.foreign += 1;
                return;
            }
            Err(_) => {
                self.stats.rejected.malformed += 1;
                return;
            }
        };
        match telegram {
            Telegram::Sync => {
                self.stats.syncs_seen += 1;
                self.on_sync(self.now);
            }
            Telegram::ParamResponse { address, channel } => self.on_param(address, channel),
            Telegram::ProcessInput { address, data } => self.on_pi(address, data),
            _ => self.stats.rejected.foreign += 1,
        }
    }

    fn on_param(&mut self, address: Address, channel: ParamChannel) {
        if let Some(scan) = self.scan {
            let in_range = address.get() <= scan.last
                && address.get() < scan.next
                && self
                    .results
                    .get(usize::from(address.get()))
                    .is_some_and(|e| *e == ScanEntry::Silent);
            if !in_range {
                self.stats.rejected.unsolicited += 1;
            } else if !ParamChannel::read(SCAN_INDEX).is_answered_by(&channel) {
                self.stats.rejected.mismatch += 1;
            } else if let Some(e) = self.results.get_mut(usize::from(address.get())) {
                *e = match channel.result() {
                    Ok(v) => ScanEntry::UnitType(v),
                    Err(rc) => {
                        self.stats.drive_errors += 1;
                        ScanEntry::Refused(rc)
                    }
                };
            }
            return;
        }
        let rx_at = self.rx_at;
        let Some(job) = self.job.filter(|j| j.attempts > 0 && rx_at >= j.first_sent) else {
            self.count_unanswering();
            return;
        };
        let Expect::Param { address: a, sent } = job.expect else {
            self.stats.rejected.unsolicited += 1;
            return;
        };
        if a != address {
            self.stats.rejected.unsolicited += 1;
        } else if !sent.is_answered_by(&channel) {
            self.stats.rejected.mismatch += 1;
        } else {
            let result = match channel.result() {
                Ok(_) => Ok(Answer::Param(channel)),
                Err(code) => {
                    self.stats.drive_errors += 1;
                    Err(MasterError::Drive { address, code })
                }
            };
            self.finish(result);
        }
    }

    fn on_pi(&mut self, address: Address, data: ProcessData) {
        match self.job {
            Some(Job {
                expect: Expect::ProcessInput { address: a },
                attempts,
                first_sent,
                ..
            }) if a == address && attempts > 0 && self.rx_at >= first_sent => {
                self.finish(Ok(Answer::ProcessInput(data)));
            }
            _ => self.count_unanswering(),
        }
    }

    /// A response that answers nothing: stale if it was received before the request in
    /// flight went out, else unsolicited.
    fn count_unanswering(&mut self) {
        match self.job {
            Some(j) if j.attempts == 0 || self.rx_at < j.first_sent => self.stats.stale += 1,
            _ => self.stats.rejected.unsolicited += 1,
        }
    }

    fn finish(&mut self, result: Result<Answer, MasterError>) {
        self.job = None;
        self.events.push(MasterEvent::Done(result));
        self.stop_sync_if_idle();
    }

    fn stop_sync_if_idle(&mut self) {
        if self.config.sync_producer == SyncProducer::OnDemand
            && !self.job.is_some_and(|j| j.sync_mode)
        {
            self.next_sync = None;
        }
    }

    /// A SYNC went out or came in at `t`.
    fn on_sync(&mut self, t: Instant) {
        self.last_sync = Some(t);
        let timeout = duration_nanos(self.config.timeout);
        if let Some(job) = self.job.as_mut()
            && job.sync_mode
            && let Phase::Waiting {
                deadline,
                synced: false,
            } = job.phase
        {
            job.phase = Phase::Waiting {
                deadline: deadline.min(t.add_nanos(timeout)),
                synced: true,
            };
        }
    }

    /// Advance the time to `now`: an attempt may time out, a scan end.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        if let Some(scan) = self.scan
            && scan.deadline.is_some_and(|d| self.now >= d)
        {
            self.scan = None;
            self.hold_until = self.now;
            self.events.push(MasterEvent::ScanDone);
        }
        let Some(job) = self.job.as_mut() else { return };
        let Phase::Waiting { deadline, .. } = job.phase else {
            return;
        };
        if self.now < deadline {
            return;
        }
        if job.attempts <= u16::from(self.config.retries) {
            job.phase = Phase::Queued;
            self.stats.retries += 1;
            return;
        }
        let address = match job.expect {
            Expect::Param { address, .. } | Expect::ProcessInput { address } => address,
            Expect::Nothing => Address::default(),
        };
        let error = MasterError::Timeout {
            address,
            attempts: job.attempts,
            timeout: self.config.timeout,
        };
        self.stats.timeouts += 1;
        self.hold_until = self.now.saturating_add(self.config.late_guard);
        self.finish(Err(error));
    }

    /// The next frame to send at `now`: a due SYNC first, then the request or scan request.
    pub fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        self.advance(now);
        if let Some(f) = self.poll_sync() {
            return Some(f);
        }
        if self.now < self.hold_until {
            return None;
        }
        if let Some(mut scan) = self.scan {
            if scan.deadline.is_some() {
                return None;
            }
            let address = Address::new(scan.next)?;
            let frame = Telegram::ParamRequest {
                address,
                channel: ParamChannel::read(SCAN_INDEX),
            }
            .encode(self.config.sync_id);
            self.stats.transactions += 1;
            if scan.next >= scan.last {
                scan.deadline = Some(self.now.saturating_add(scan.timeout));
            }
            scan.next = scan.next.saturating_add(1);
            self.scan = Some(scan);
            return Some(frame);
        }
        let job = self.job?;
        if job.phase != Phase::Queued {
            return None;
        }
        if job.po_window {
            match self.po_window_opens() {
                Some(opens) if opens > self.now => return None,
                Some(_) => {}
                // No cycle running and this master produces SYNC: a drive drops a PO sync
                // that comes before any SYNC, so the cycle starts now and the telegram goes
                // out in its window.
                None if self.config.sync_producer != SyncProducer::External => {
                    self.next_sync = Some(self.now);
                    return self.poll_sync();
                }
                None => {}
            }
        }
        Some(self.transmit(job))
    }

    fn transmit(&mut self, mut job: Job) -> CanFrame {
        if job.attempts == 0 {
            self.stats.transactions += 1;
            job.first_sent = self.now;
        }
        job.attempts = job.attempts.saturating_add(1);
        let frame = job.frame;
        if job.expect == Expect::Nothing {
            if Telegram::decode(&frame, self.config.sync_id) == Ok(Telegram::Sync) {
                self.stats.syncs_sent += 1;
                self.on_sync(self.now);
            }
            self.job = None;
            self.events.push(MasterEvent::Done(Ok(Answer::Sent)));
            return frame;
        }
        let timeout = duration_nanos(self.config.timeout);
        let deadline = if job.sync_mode {
            // Bounded even if no SYNC ever comes; narrowed to SYNC + timeout by the first one.
            self.now
                .add_nanos(duration_nanos(self.config.sync_period))
                .add_nanos(duration_nanos(SYNC_LEAD))
                .add_nanos(timeout)
        } else {
            self.now.add_nanos(timeout)
        };
        job.phase = Phase::Waiting {
            deadline,
            synced: false,
        };
        self.job = Some(job);
        if job.sync_mode
            && self.config.sync_producer == SyncProducer::OnDemand
            && self.next_sync.is_none()
        {
            self.next_sync = Some(self.now.saturating_add(SYNC_LEAD));
        }
        frame
    }

    /// When the PO-sync window of the current cycle opens (`None`: no cycle running, send at
    /// once). Past the window's end, the next cycle's window.
    ///
    /// A drive checks the window against the last SYNC it received. Past that SYNC's window the
    /// next window follows the next SYNC really sent: this master's own next SYNC when it
    /// produces them (none scheduled: no cycle is running), or, with an external producer, the
    /// next one on its grid.
    fn po_window_opens(&self) -> Option<Instant> {
        let last = self.last_sync?;
        let period = duration_nanos(self.config.sync_period);
        let start = duration_nanos(PO_SYNC_WINDOW_START).min(period / 2);
        let end = period
            .saturating_sub(duration_nanos(PO_SYNC_WINDOW_END_BEFORE))
            .max(start);
        let since = self.now.nanos_since(last);
        if since < start {
            return Some(last.add_nanos(start));
        }
        if since <= end {
            return Some(self.now);
        }
        if self.config.sync_producer != SyncProducer::External {
            return self
                .next_sync
                .map(|next| next.later(self.now).add_nanos(start));
        }
        if since > period.saturating_mul(2) {
            return None; // the cycle stopped
        }
        let in_cycle = since % period.max(1);
        let cycle_start = self.now.saturating_sub(Duration::from_nanos(in_cycle));
        if in_cycle < start {
            Some(cycle_start.add_nanos(start))
        } else if in_cycle <= end {
            Some(self.now)
        } else {
            Some(cycle_start.add_nanos(period + start))
        }
    }

    fn poll_sync(&mut self) -> Option<CanFrame> {
        let next = self.next_sync?;
        if self.now < next {
            return None;
        }
        let period = duration_nanos(self.config.sync_period).max(1);
        let mut following = next.add_nanos(period);
        // More than a millisecond late: the cycles missed are skipped (the grid stays).
        while following <= self.now {
            following = following.add_nanos(period);
            self.stats.syncs_skipped += 1;
        }
        self.next_sync = Some(following);
        self.stats.syncs_sent += 1;
        self.on_sync(self.now);
        Some(Telegram::Sync.encode(self.config.sync_id))
    }

    /// When [`Master::handle_timeout`] or [`Master::poll_transmit`] has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let request = if let Some(scan) = self.scan {
            Some(scan.deadline.unwrap_or(self.hold_until.later(self.now)))
        } else {
            self.job.map(|job| match job.phase {
                Phase::Waiting { deadline, .. } => deadline,
                Phase::Queued => {
                    let mut t = self.hold_until.later(self.now);
                    if job.po_window
                        && let Some(w) = self.po_window_opens()
                    {
                        t = t.later(w);
                    }
                    t
                }
            })
        };
        drive_core::time::earliest(request, self.next_sync)
    }

    fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
    }
}

impl CanEndpoint for Master {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        Master::handle_frame(self, frame, now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        Master::handle_timeout(self, now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        Master::poll_transmit(self, now)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        Master::poll_timeout(self)
    }
}
