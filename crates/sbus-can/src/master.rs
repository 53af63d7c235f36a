//! The SBus master (controller) state machine, sans-IO (manual ch. 5.1, 5.2).
//!
//! [`SbusMaster`] is a [`CanEndpoint`]: frames from the bus go to [`SbusMaster::handle_frame`],
//! the passing of time to [`SbusMaster::handle_timeout`] at [`SbusMaster::poll_timeout`],
//! frames to send come from [`SbusMaster::poll_transmit`] and results from
//! [`SbusMaster::poll_event`]. One request is in flight at a time; the synchronisation
//! producer runs beside it.
//!
//! The request in flight is drive-core's one master ([`drive_core::master::Master`]) on the
//! transaction skeleton of a CAN bus ([`CanExchange`]: the attempts and their deadlines,
//! retries, give-up, the late guard, responses received before the request went out counted
//! as stale), with SBus's part, [`Sbus`], judging the answers. Around it this master keeps what
//! only SBus has: the SYNC producer, the PO-sync window and the scan.
//!
//! What it does:
//!
//! * **parameter services** to one drive ([`SbusMaster::param`]): every
//!   [`Service`], in both handshake modes ([`Handshake`]). The
//!   answer is the parameter response (8a + 516) of that address with the same service code,
//!   subindex and index ([`ParamChannel::is_answered_by`]); any other response is a counted
//!   rejection ([`Rejections::mismatch`]), never the answer. The status bit makes the answer a
//!   [`MasterError::Drive`] with the drive's [`ReturnCode`];
//! * **timeouts and retries**: each attempt waits [`MasterConfig::response_timeout`] (a sync-mode
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
//! * **scan** ([`SbusMaster::scan`]): a read of P070 unit type (index 8301, read-only, harmless) to
//!   every address of a range, all sent at once (each address answers on its own identifier),
//!   one attempt, one timeout after the last request; [`SbusMaster::scan_results`];
//! * **counters** ([`MasterStats`]): transactions, retries, timeouts, drive errors, SYNCs and
//!   rejected frames by reason. Frames of other nodes (their requests, variable telegrams,
//!   other protocols) are ignored and counted ([`Rejections::foreign`]).
//!
//! ```
//! use drive_core::can::{CanEndpoint, CanFrame};
//! use drive_core::Instant;
//! use drive_profile::sew::ParamChannel;
//! use sbus_can::master::{Answer, Handshake, MasterConfig, MasterEvent, SbusMaster};
//! use sbus_can::Address;
//!
//! let mut m = SbusMaster::new(MasterConfig::default());
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

use core::convert::Infallible;

use drive_core::Queue;
use drive_core::can::{CanEndpoint, CanExchange, CanExchangeConfig, CanFrame};
use drive_core::exchange::{Busy, Verdict};
use drive_core::master::{self, Control, FrameProtocol, Heard, Judgement, Protocol};
use drive_core::time::{Instant, duration_nanos};
use drive_profile::sew::{ParamChannel, ReturnCode, Service, index};

use crate::ids::{Address, DEFAULT_SYNC_ID, MAX_ADDRESS};
use crate::telegram::{DecodeError, ProcessData, Telegram};

/// Default time an attempt waits for its answer: 50 ms, MOVILINK's maximum response delay.
/// SBus drives answer process data within 1 ms (ch. 5.1); the margin covers parameter
/// services and USB adapters.
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(50);

/// Default scan timeout per round.
pub const DEFAULT_SCAN_TIMEOUT: Duration = Duration::from_millis(20);

/// The SBus cycle: 5 ms (ch. 5.1 "feste Zeitbasis von 5 Millisekunden").
pub const DEFAULT_SYNC_PERIOD: Duration = Duration::from_millis(5);

/// How long after a sync-mode request the on-demand producer sends its first SYNC: the
/// request must be on the bus at least 500 µs before the SYNC (ch. 5.1, erratum SB-E30); 1 ms
/// leaves room for the request's own time on the wire at 125 kbit/s.
pub const SYNC_LEAD: Duration = Duration::from_millis(1);

/// The least response timeout a parameter answer can meet on the bus at `rate`: the request
/// and the response frame (8 data bytes, worst-case bit stuffing), the drive's answer window
/// (within the first millisecond, [`ANSWER_WINDOW`](crate::slave::ANSWER_WINDOW)) and, in sync
/// mode, the SYNC that releases the answer ([`SYNC_LEAD`] after the request, then its own
/// frame).
pub fn least_response_timeout(rate: drive_core::can::Bitrate, handshake: Handshake) -> Duration {
    let frame = crate::busload::frame_time(8, rate);
    let mut t = frame + crate::slave::ANSWER_WINDOW + frame;
    if handshake == Handshake::Sync {
        t += SYNC_LEAD + crate::busload::frame_time(0, rate);
    }
    t
}

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
    /// This master, every period, from [`SbusMaster::new`] (or
    /// [`SbusMaster::set_sync_producer`]) on.
    Always,
    /// Another node; this master sends none (except [`SbusMaster::sync`]) and uses the SYNCs it
    /// sees.
    External,
}

/// Configuration of a [`SbusMaster`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MasterConfig {
    /// How long an attempt waits for its answer: from the request's hand-over, for sync-mode
    /// requests from the first SYNC after it. Default [`DEFAULT_RESPONSE_TIMEOUT`].
    pub response_timeout: Duration,
    /// Retransmissions after a timeout (0 = one attempt; 255 = 256 attempts, never more).
    pub retries: u8,
    /// P817 of the drives: the SYNC identifier, 0–2047 (factory setting 0).
    pub sync_id: u16,
    /// The SBus cycle, 5 ms.
    pub sync_period: Duration,
    /// The handshake mode of services that do not name one (the async driver's
    /// `read`/`write`…, [`MovlnkMaster`](crate::movlnk::MovlnkMaster)); [`SbusMaster::param`] takes
    /// it as an argument.
    pub handshake: Handshake,
    /// The answer timeout of a scan (one attempt per address).
    pub scan_timeout: Duration,
    /// Who sends SYNC.
    pub sync_producer: SyncProducer,
    /// After a request is given up, how long the next transmission waits (late answers to the
    /// abandoned request are counted, not taken). Default: the response timeout.
    pub late_guard: Duration,
}

impl Default for MasterConfig {
    fn default() -> Self {
        Self {
            response_timeout: DEFAULT_RESPONSE_TIMEOUT,
            retries: 2,
            sync_id: DEFAULT_SYNC_ID,
            sync_period: DEFAULT_SYNC_PERIOD,
            handshake: Handshake::Async,
            scan_timeout: DEFAULT_SCAN_TIMEOUT,
            sync_producer: SyncProducer::OnDemand,
            late_guard: DEFAULT_RESPONSE_TIMEOUT,
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
        response_timeout: Duration,
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
                response_timeout,
            } => write!(
                f,
                "no answer from SBus address {address} after {attempts} attempts of {} ms each",
                response_timeout.as_millis()
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

impl From<Busy> for RequestError {
    fn from(_: Busy) -> Self {
        RequestError::Busy
    }
}

/// What the master reports; drained with [`SbusMaster::poll_event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MasterEvent {
    /// The request in flight is done.
    Done(Result<Answer, MasterError>),
    /// The scan is done; [`SbusMaster::scan_results`] has every address's entry.
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

/// Counters of a [`SbusMaster`].
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

/// What a request awaits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expect {
    /// Nothing: a group telegram or a SYNC, complete once handed out.
    Nothing,
    /// The parameter response of `address` to the service `sent`.
    Param {
        /// The drive.
        address: Address,
        /// The parameter channel sent (handshake bit applied, status bit clear).
        sent: ParamChannel,
    },
    /// The process input data of `address`.
    ProcessInput {
        /// The drive.
        address: Address,
    },
}

/// A request in flight: its frame, what it awaits and when it may go out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Request {
    frame: CanFrame,
    expect: Expect,
    /// Answered after the next SYNC.
    sync_mode: bool,
    /// A PO-sync telegram: sent in the cycle's window.
    po_window: bool,
}

impl Request {
    /// What it awaits.
    pub fn expect(&self) -> Expect {
        self.expect
    }

    /// Its frame.
    pub fn frame(&self) -> &CanFrame {
        &self.frame
    }

    fn address(&self) -> Address {
        match self.expect {
            Expect::Param { address, .. } | Expect::ProcessInput { address } => address,
            Expect::Nothing => Address::default(),
        }
    }
}

/// Why a response was not taken (counted in [`Rejections`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reject {
    /// It answers another request or another master (another address, another kind).
    Unsolicited,
    /// A parameter response from the awaited address for another service, subindex or index.
    Mismatch,
}

/// SBus's part of the request in flight: judging a response by address, service, subindex and
/// index, and the sync-mode attempt's deadline.
#[derive(Debug, Clone, Copy)]
pub struct Sbus {
    config: MasterConfig,
    drive_errors: u64,
}

impl Protocol for Sbus {
    type Input = Request;
    type Request = Request;
    type Frame = Telegram;
    type Answer = Answer;
    type Reason = Reject;
    type Failure = Infallible;
    type Event = MasterEvent;
    type SendError = RequestError;

    fn prepare(&mut self, request: Request) -> Result<Request, RequestError> {
        Ok(request)
    }

    fn answered(&self, request: &Request) -> bool {
        request.expect != Expect::Nothing
    }

    fn judge(
        &mut self,
        request: &mut Request,
        t: Telegram,
    ) -> Judgement<Answer, Reject, Infallible> {
        match (t, request.expect) {
            (
                Telegram::ParamResponse { address, channel },
                Expect::Param {
                    address: awaited,
                    sent,
                },
            ) => {
                if address != awaited {
                    Judgement::Foreign(Reject::Unsolicited)
                } else if !sent.is_answered_by(&channel) {
                    Judgement::Corrupt(Reject::Mismatch)
                } else {
                    Judgement::Ours(Answer::Param(channel))
                }
            }
            (Telegram::ProcessInput { address, data }, Expect::ProcessInput { address: a })
                if a == address =>
            {
                Judgement::Ours(Answer::ProcessInput(data))
            }
            _ => Judgement::Foreign(Reject::Unsolicited),
        }
    }

    fn settings_changed(&mut self, response_timeout: Duration, retries: u8) {
        (self.config.response_timeout, self.config.retries) = (response_timeout, retries);
    }

    /// The request's end as SBus reports it: an answer with the status bit set is the drive's
    /// refusal.
    fn report(
        &mut self,
        request: &Request,
        event: master::MasterEvent<Answer, Reject>,
        events: &mut Queue<MasterEvent, { master::EVENTS }>,
    ) {
        let address = request.address();
        let result = match event {
            master::MasterEvent::Response(Answer::Param(channel)) => match channel.result() {
                Ok(_) => Ok(Answer::Param(channel)),
                Err(code) => {
                    self.drive_errors += 1;
                    Err(MasterError::Drive { address, code })
                }
            },
            master::MasterEvent::Response(answer) => Ok(answer),
            master::MasterEvent::Sent => Ok(Answer::Sent),
            master::MasterEvent::Timeout { attempts } => Err(MasterError::Timeout {
                address,
                attempts,
                response_timeout: self.config.response_timeout,
            }),
            _ => return,
        };
        events.push(MasterEvent::Done(result));
    }
}

impl FrameProtocol for Sbus {
    fn encode(&mut self, request: &Request) -> CanFrame {
        request.frame
    }

    /// A sync-mode attempt is bounded even if no SYNC ever comes; the first SYNC after it
    /// narrows it to that SYNC plus the response timeout.
    fn attempt_deadline(
        &self,
        request: &Request,
        sent: Instant,
        response_timeout: Duration,
    ) -> Instant {
        let timeout = duration_nanos(response_timeout);
        if request.sync_mode {
            sent.add_nanos(duration_nanos(self.config.sync_period))
                .add_nanos(duration_nanos(SYNC_LEAD))
                .add_nanos(timeout)
        } else {
            sent.add_nanos(timeout)
        }
    }
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
pub struct SbusMaster {
    /// The request in flight.
    core: master::Master<Sbus, CanExchange>,
    scan: Option<Scan>,
    results: [ScanEntry; 64],
    /// The scan's events (a request's are the core's).
    events: Queue<MasterEvent, 4>,
    /// SYNCs, rejections and scan refusals; the rest is the core's.
    stats: MasterStats,
    /// Scan requests put on the bus.
    scan_requests: u64,
    now: Instant,
    /// The next SYNC of the running producer.
    next_sync: Option<Instant>,
    /// The last SYNC sent or seen.
    last_sync: Option<Instant>,
    /// A SYNC came after the transmission awaiting its answer (its deadline was narrowed).
    synced: bool,
}

impl SbusMaster {
    /// A master with `config`. With [`SyncProducer::Always`] the first SYNC is due at once.
    pub fn new(config: MasterConfig) -> Self {
        let exchange = CanExchange::new(CanExchangeConfig {
            response_timeout: config.response_timeout,
            retries: config.retries,
            late_guard: config.late_guard,
        });
        let sbus = Sbus {
            config,
            drive_errors: 0,
        };
        Self {
            next_sync: (config.sync_producer == SyncProducer::Always).then_some(Instant::ZERO),
            core: master::Master::from_parts(sbus, exchange),
            scan: None,
            results: [ScanEntry::NotScanned; 64],
            events: Queue::new(),
            stats: MasterStats::default(),
            scan_requests: 0,
            now: Instant::ZERO,
            last_sync: None,
            synced: false,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.core.protocol().config
    }

    fn config_mut(&mut self) -> &mut MasterConfig {
        &mut self.core.protocol_mut().config
    }

    /// The counters so far.
    pub fn stats(&self) -> MasterStats {
        let tally = self.core.carrier().tally();
        MasterStats {
            transactions: self.scan_requests + tally.first_transmissions,
            retries: tally.retries,
            timeouts: tally.give_ups,
            drive_errors: self.stats.drive_errors + self.core.protocol().drive_errors,
            stale: tally.stale,
            ..self.stats
        }
    }

    /// Change the response timeout of each attempt; applies from the next transmission on.
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.core.set_response_timeout(timeout);
    }

    /// Change the number of retransmissions; applies to the request in flight too.
    pub fn set_retries(&mut self, retries: u8) {
        self.core.set_retries(retries);
    }

    /// Change who sends SYNC, at `now` ([`SyncProducer::Always`] starts at once).
    pub fn set_sync_producer(&mut self, producer: SyncProducer, now: Instant) {
        self.advance(now);
        self.config_mut().sync_producer = producer;
        match producer {
            SyncProducer::Always if self.next_sync.is_none() => self.next_sync = Some(self.now),
            SyncProducer::External => self.next_sync = None,
            _ => {}
        }
    }

    /// Whether neither a request nor a scan is in flight.
    pub fn is_idle(&self) -> bool {
        self.core.is_idle() && self.scan.is_none()
    }

    /// The last SYNC sent or seen.
    pub fn last_sync(&self) -> Option<Instant> {
        self.last_sync
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.core.poll_event().or_else(|| self.events.pop())
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
        // The request's late guard is the core's.
        self.core.abort(self.now);
        if self.scan.take().is_some() {
            let guard = self.now.saturating_add(self.config().late_guard);
            self.core.carrier_mut().set_hold(guard);
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
        let frame = self.encode(Telegram::ParamRequest { address, channel });
        let expect = Expect::Param {
            address,
            sent: channel,
        };
        self.begin(frame, expect, handshake == Handshake::Sync, false, now)
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
        let frame = self.encode(Telegram::GroupParamRequest { group, channel });
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
        let frame = self.encode(Telegram::GroupProcessOutput { group, data });
        self.begin(frame, Expect::Nothing, false, false, now)
    }

    /// One SYNC telegram, as a request ([`Answer::Sent`] once handed out); it also starts the
    /// cycle for waiting sync-mode requests.
    pub fn sync(&mut self, now: Instant) -> Result<(), RequestError> {
        let frame = self.encode(Telegram::Sync);
        self.begin(frame, Expect::Nothing, false, false, now)
    }

    /// Scan the addresses `first..=last` (clamped to 63): a read of P070 unit type to each, all
    /// sent one after another, one attempt, answers awaited until `timeout` after the last
    /// request. Ends with [`MasterEvent::ScanDone`]; entries in [`SbusMaster::scan_results`].
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

    fn encode(&self, telegram: Telegram) -> CanFrame {
        telegram.encode(self.config().sync_id)
    }

    fn process_output(
        &mut self,
        address: Address,
        data: ProcessData,
        synchronised: bool,
        now: Instant,
    ) -> Result<(), RequestError> {
        let frame = self.encode(Telegram::ProcessOutput {
            address,
            synchronised,
            data,
        });
        let expect = Expect::ProcessInput { address };
        self.begin(frame, expect, synchronised, synchronised, now)
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
        let request = Request {
            frame,
            expect,
            sync_mode,
            po_window,
        };
        self.core.send(request, self.now)
    }

    /// Feed one frame received at `now` (the end of its last bit). A response received before
    /// the request in flight was first handed out is never its answer, even if it is fed
    /// later (an interface's queue read after the request was sent).
    pub fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.advance(now);
        let telegram = match Telegram::decode(frame, self.config().sync_id) {
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
            Telegram::ParamResponse { address, channel } if self.scan.is_some() => {
                self.on_scan_answer(address, channel);
            }
            Telegram::ParamResponse { .. } | Telegram::ProcessInput { .. } => {
                match self.core.handle_frame(telegram, now) {
                    Heard::Taken => self.stop_sync_if_idle(),
                    Heard::Stale => {}
                    Heard::Unsolicited | Heard::Rejected(Reject::Unsolicited) => {
                        self.stats.rejected.unsolicited += 1;
                    }
                    Heard::Rejected(Reject::Mismatch) => self.stats.rejected.mismatch += 1,
                }
            }
            _ => self.stats.rejected.foreign += 1,
        }
    }

    fn on_scan_answer(&mut self, address: Address, channel: ParamChannel) {
        let Some(scan) = self.scan else { return };
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
    }

    fn stop_sync_if_idle(&mut self) {
        if self.config().sync_producer == SyncProducer::OnDemand
            && !self.core.request().is_some_and(|r| r.sync_mode)
        {
            self.next_sync = None;
        }
    }

    /// A SYNC went out or came in at `t`: the first after a sync-mode request's transmission
    /// narrows its attempt to `t` plus the response timeout.
    fn on_sync(&mut self, t: Instant) {
        self.last_sync = Some(t);
        let timeout = duration_nanos(self.config().response_timeout);
        if !self.synced
            && self.core.request().is_some_and(|r| r.sync_mode)
            && let Some(deadline) = self.core.carrier().deadline()
        {
            let narrowed = deadline.min(t.add_nanos(timeout));
            self.core.carrier_mut().set_deadline(narrowed);
            self.synced = true;
        }
    }

    /// Advance the time to `now`: an attempt may time out, a scan end.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
        if let Some(scan) = self.scan
            && scan.deadline.is_some_and(|d| self.now >= d)
        {
            self.scan = None;
            self.core.carrier_mut().set_hold(self.now);
            self.events.push(MasterEvent::ScanDone);
        }
        if let Some(Verdict::GiveUp { .. }) = self.core.handle_timeout(self.now) {
            self.stop_sync_if_idle();
        }
    }

    /// The next frame to send at `now`: a due SYNC first, then the request or scan request.
    pub fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        self.advance(now);
        if let Some(f) = self.poll_sync() {
            return Some(f);
        }
        if self.now < self.core.carrier().hold_until() {
            return None;
        }
        if let Some(mut scan) = self.scan {
            if scan.deadline.is_some() {
                return None;
            }
            let address = Address::new(scan.next)?;
            let frame = self.encode(Telegram::ParamRequest {
                address,
                channel: ParamChannel::read(SCAN_INDEX),
            });
            self.scan_requests += 1;
            if scan.next >= scan.last {
                scan.deadline = Some(self.now.saturating_add(scan.timeout));
            }
            scan.next = scan.next.saturating_add(1);
            self.scan = Some(scan);
            return Some(frame);
        }
        let request = *self.core.request()?;
        if !self.core.carrier().is_queued() {
            return None;
        }
        if request.po_window {
            match self.po_window_opens() {
                Some(opens) if opens > self.now => return None,
                Some(_) => {}
                // No cycle running and this master produces SYNC: a drive drops a PO sync
                // that comes before any SYNC, so the cycle starts now and the telegram goes
                // out in its window.
                None if self.config().sync_producer != SyncProducer::External => {
                    self.next_sync = Some(self.now);
                    return self.poll_sync();
                }
                None => {}
            }
        }
        self.transmit(request)
    }

    fn transmit(&mut self, request: Request) -> Option<CanFrame> {
        let frame = self.core.poll_transmit(self.now)?;
        self.synced = false;
        if request.expect == Expect::Nothing {
            if Telegram::decode(&frame, self.config().sync_id) == Ok(Telegram::Sync) {
                self.stats.syncs_sent += 1;
                self.on_sync(self.now);
            }
            return Some(frame);
        }
        if request.sync_mode
            && self.config().sync_producer == SyncProducer::OnDemand
            && self.next_sync.is_none()
        {
            self.next_sync = Some(self.now.saturating_add(SYNC_LEAD));
        }
        Some(frame)
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
        let config = self.config();
        let period = duration_nanos(config.sync_period);
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
        if config.sync_producer != SyncProducer::External {
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
        let period = duration_nanos(self.config().sync_period).max(1);
        let mut following = next.add_nanos(period);
        // More than a millisecond late: the cycles missed are skipped (the grid stays).
        while following <= self.now {
            following = following.add_nanos(period);
            self.stats.syncs_skipped += 1;
        }
        self.next_sync = Some(following);
        self.stats.syncs_sent += 1;
        self.on_sync(self.now);
        Some(self.encode(Telegram::Sync))
    }

    /// When [`SbusMaster::handle_timeout`] or [`SbusMaster::poll_transmit`] has work to do.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let hold = self.core.carrier().hold_until().later(self.now);
        let request = if let Some(scan) = self.scan {
            Some(scan.deadline.unwrap_or(hold))
        } else {
            self.core.request().map(|request| {
                if let Some(deadline) = self.core.carrier().deadline() {
                    return deadline;
                }
                match self.po_window_opens() {
                    Some(w) if request.po_window => hold.later(w),
                    _ => hold,
                }
            })
        };
        drive_core::time::earliest(request, self.next_sync)
    }

    fn advance(&mut self, now: Instant) {
        self.now = self.now.later(now);
        self.core.carrier_mut().advance(self.now);
    }
}

impl CanEndpoint for SbusMaster {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        SbusMaster::handle_frame(self, frame, now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        SbusMaster::handle_timeout(self, now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        SbusMaster::poll_transmit(self, now)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        SbusMaster::poll_timeout(self)
    }
}

/// What the runtime driver needs: a scan is in flight as much as a request.
impl Control for SbusMaster {
    fn is_idle(&self) -> bool {
        SbusMaster::is_idle(self)
    }

    fn abort(&mut self, now: Instant) {
        SbusMaster::abort(self, now);
    }

    fn clear_events(&mut self) {
        self.core.clear_events();
        self.events.clear();
    }

    fn stale(&self) -> u64 {
        self.core.stale()
    }
}
