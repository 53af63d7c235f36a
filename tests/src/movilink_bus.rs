//! A MOVILINK master and drive on the two ends of an in-memory link with wire timing and fault
//! injection, for the fault-injection campaign (`tests/tests/movilink_faults.rs`).
//!
//! This is a minimal pump written for the tests, independent of the crate's async driver: the
//! sans-IO [`MovilinkMaster`] and [`Slave`] run on tokio's paused clock, which the pump moves
//! exactly (`tokio::time::advance`) from one event to the next: a state machine's
//! [`poll_timeout`](MovilinkMaster::poll_timeout) or the end of a burst of characters on the line.
//! Each received [`TimedChar`] becomes an [`RxChar`] stamped with its exact arrival time
//! (the time since the pump's epoch); a character the UART flagged (`parity_ok == false`:
//! parity or framing error) arrives with [`CharError::Parity`].
//!
//! The pump records every telegram each side puts on the wire and what the other side made of
//! it (accepted equal, accepted different = an undetected error, rejected with a reason, or
//! lost without any event), per direction, in [`DirStats`].
//!
//! The drive's [`TestBackend`] answers with known functions of the request ([`read_value`],
//! [`input_word`]) and checks that written values carry their own check ([`write_value`]), so
//! a wrong value is recognised wherever it surfaces.

use std::collections::BTreeMap;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use drive_transport::link::{self, Fault, FaultConfig, FaultStats, LinkConfig, LinkEnd, TimedChar};
use movilink::{
    Address, Backend, CharError, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel,
    RejectReason, RequestContext, ReturnCode, RxChar, Service, Slave, SlaveConfig, SlaveEvent,
    Telegram,
};
use tokio::io::AsyncWrite;
use tokio::time::Instant as TokioInstant;

pub use drive_core::rng::mix64;

/// The campaigns' seeded random generator: drivebus's one generator.
pub type Rng = drive_core::SplitMix64;

/// The value the test drive answers to a read of `index`/`subindex`.
pub fn read_value(index: u16, subindex: u8) -> u32 {
    mix64(u64::from(index) << 8 | u64::from(subindex)) as u32
}

/// A value to write: a 16-bit `nonce` in the high word and a check of index and nonce in the
/// low word, so the drive can tell a corrupted write (see [`write_value_ok`]).
pub fn write_value(index: u16, nonce: u16) -> u32 {
    let check = mix64(0x5752_0000_0000 | u64::from(index) << 16 | u64::from(nonce)) as u16;
    u32::from(nonce) << 16 | u32::from(check)
}

/// Whether `value` is a value [`write_value`] makes for `index`.
pub fn write_value_ok(index: u16, value: u32) -> bool {
    write_value(index, (value >> 16) as u16) == value
}

/// The drive's process input word `j` answering the process output words `output`.
pub fn input_word(output: &[u16], j: usize) -> u16 {
    let mut h = 0x5049_0000 | j as u64;
    for w in output {
        h = mix64(h ^ u64::from(*w));
    }
    h as u16
}

/// The drive behind the [`Slave`]: answers with known functions of the request.
#[derive(Debug, Clone, Default)]
pub struct TestBackend {
    /// Read services executed.
    pub reads: u64,
    /// Write services executed.
    pub writes: u64,
    /// Writes executed whose value fails its check: a corrupted request was executed.
    pub bad_writes: u64,
    /// Process data exchanges.
    pub pd_exchanges: u64,
}

impl Backend for TestBackend {
    fn param(&mut self, _ctx: &RequestContext, request: &ParamChannel) -> Result<u32, ReturnCode> {
        match request.service() {
            Some(Service::Read) => {
                self.reads += 1;
                Ok(read_value(request.index, request.subindex))
            }
            Some(Service::Write | Service::WriteVolatile) => {
                self.writes += 1;
                if !write_value_ok(request.index, request.data) {
                    self.bad_writes += 1;
                }
                Ok(request.data)
            }
            _ => Err(ReturnCode::NOT_IMPLEMENTED),
        }
    }

    fn process_data(&mut self, _ctx: &RequestContext, output: &[u16], input: &mut [u16]) {
        self.pd_exchanges += 1;
        for (j, w) in input.iter_mut().enumerate() {
            *w = input_word(output, j);
        }
    }
}

impl drive_core::Timers for TestBackend {}

/// Which side put a telegram on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The master (requests).
    Master,
    /// The drive (responses).
    Drive,
}

/// What became of the telegrams of one direction.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DirStats {
    /// Telegrams put on the wire.
    pub sent: u64,
    /// Of those, telegrams with at least one fault injected.
    pub faulted: u64,
    /// Characters written (inserted ones not counted).
    pub chars: u64,
    /// Faulted telegrams by fault kind: `"flip"`, `"drop"`, `"insert"`, `"multiple"`.
    pub faulted_by_kind: BTreeMap<&'static str, u64>,
    /// Clean telegrams accepted unchanged.
    pub clean_accepted: u64,
    /// Faulted telegrams accepted unchanged (e.g. a drop and an insert of the same byte).
    pub faulted_accepted_equal: u64,
    /// Telegrams accepted with content other than sent: undetected errors.
    pub undetected: u64,
    /// Faulted telegrams rejected, by reason.
    pub rejected: BTreeMap<&'static str, u64>,
    /// Faulted telegrams that caused no event at all on the receiving side.
    pub lost: u64,
    /// Clean telegrams rejected or lost (must stay 0).
    pub clean_failed: u64,
    /// Rejections after the telegram had already been judged (must stay 0).
    pub extra_events: u64,
    /// Master only: clean responses refused by the application checks (PDU type or
    /// parameter channel does not match the request, the consequence of an undetected error
    /// in the request), by reason.
    pub refused_by_master: BTreeMap<&'static str, u64>,
    /// Faulted telegrams accepted by the master's receiver but refused by its application
    /// checks (PDU type or parameter channel does not match the request): undetected by the
    /// wire checks, caught one level up.
    pub caught_by_master: u64,
    /// `(sent, faulted)` telegrams by telegram length.
    pub lengths: BTreeMap<usize, (u64, u64)>,
}

impl DirStats {
    /// Faulted telegrams rejected (all reasons).
    pub fn rejected_total(&self) -> u64 {
        self.rejected.values().sum()
    }
}

/// The name of a rejection reason for the statistics.
pub fn reason_name(r: &RejectReason) -> &'static str {
    match r {
        RejectReason::Char(CharError::Parity) => "parity",
        RejectReason::Char(CharError::Framing) => "framing",
        RejectReason::Char(_) => "overrun",
        RejectReason::InterCharacterGap { .. } => "gap (too short)",
        RejectReason::TrailingCharacter { .. } => "trailing character (too long)",
        RejectReason::WrongAddress { .. } => "address",
        RejectReason::UnknownPduType { .. } => "pdu type",
        RejectReason::BadBcc { .. } => "bcc",
        RejectReason::BadStartCharacter { .. } => "start character",
        RejectReason::PduTypeMismatch { .. } => "pdu type mismatch",
        RejectReason::ParamMismatch => "parameter channel mismatch",
        _ => "other",
    }
}

/// One telegram on the wire and its fate.
#[derive(Debug, Clone, Copy)]
struct OnWire {
    telegram: Telegram,
    faulted: bool,
    judged: bool,
}

/// Per-telegram fault plan: given the side and the telegram's bytes, the faults to inject as
/// `(character position, fault)`, positions ascending.
pub type FaultPlan = Box<dyn FnMut(Side, &[u8]) -> Vec<(usize, Fault)>>;

/// A master and a drive on an in-memory link; see the [module docs](self).
pub struct LinkBus {
    /// The master state machine.
    pub master: MovilinkMaster,
    /// The drive state machine.
    pub slave: Slave<TestBackend>,
    master_end: LinkEnd,
    drive_end: LinkEnd,
    epoch: TokioInstant,
    char_time: Duration,
    /// When the last character written in each direction ends on the line.
    line_end: [Option<TokioInstant>; 2],
    last: [Option<OnWire>; 2],
    plan: Option<FaultPlan>,
    /// Statistics of the requests (master → drive) and responses (drive → master).
    pub stats: [DirStats; 2],
    /// Master events of the current transaction, drained by the caller.
    pub events: Vec<MasterEvent>,
    /// Transmissions that became due while the pump was processing characters received
    /// earlier (written late; must stay 0 for exact timing).
    pub late_transmissions: u64,
    /// Pump steps taken.
    pub steps: u64,
}

impl std::fmt::Debug for LinkBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LinkBus")
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

const REQ: usize = 0;
const RESP: usize = 1;

fn dir(side: Side) -> usize {
    match side {
        Side::Master => REQ,
        Side::Drive => RESP,
    }
}

/// The drive's address on the test bus.
pub fn drive_address() -> Address {
    Address::new(1).unwrap_or(Address::POINT_TO_POINT)
}

impl LinkBus {
    /// A bus over `link::pair(LinkConfig::new(9600))` with `faults` as the link's random faults
    /// and `plan` choosing one-shot faults per telegram. Must be called on a runtime with the
    /// clock paused.
    pub fn new(faults: FaultConfig, plan: Option<FaultPlan>) -> Self {
        let config = LinkConfig::new(9600).with_faults(faults);
        let (master_end, drive_end) = link::pair(config);
        Self {
            master: MovilinkMaster::new(MasterConfig::default()),
            slave: Slave::new(SlaveConfig::new(drive_address()), TestBackend::default()),
            master_end,
            drive_end,
            epoch: TokioInstant::now(),
            char_time: config.char_time(),
            line_end: [None, None],
            last: [None, None],
            plan,
            stats: [DirStats::default(), DirStats::default()],
            events: Vec::new(),
            late_transmissions: 0,
            steps: 0,
        }
    }

    /// The faults injected into the characters written by `side`.
    pub fn fault_stats(&self, side: Side) -> FaultStats {
        match side {
            Side::Master => self.master_end.fault_stats(),
            Side::Drive => self.drive_end.fault_stats(),
        }
    }

    /// Change the random faults of both directions.
    pub fn set_faults(&self, faults: FaultConfig) {
        self.master_end.set_faults(faults);
        self.drive_end.set_faults(faults);
    }

    /// The time since the epoch as a protocol instant.
    pub fn now(&self) -> movilink::Instant {
        self.to_protocol(TokioInstant::now())
    }

    fn to_protocol(&self, t: TokioInstant) -> movilink::Instant {
        movilink::Instant::from_duration(t.saturating_duration_since(self.epoch))
    }

    fn to_tokio(&self, t: movilink::Instant) -> TokioInstant {
        self.epoch + t.as_duration()
    }

    /// Send `request` and run until the master is idle again; the master's events are in
    /// [`LinkBus::events`].
    pub async fn transact(&mut self, request: Telegram) {
        self.events.clear();
        let now = self.now();
        if self.master.send(request, now).is_err() {
            panic!("master busy at the start of a transaction");
        }
        self.run_until_idle().await;
    }

    /// Run until the master has no request in flight.
    pub async fn run_until_idle(&mut self) {
        for _ in 0..100_000 {
            self.steps += 1;
            self.step().await;
            if self.master.is_idle() {
                return;
            }
            let now = TokioInstant::now();
            let next = [self.master.poll_timeout(), self.slave.poll_timeout()]
                .into_iter()
                .flatten()
                .map(|t| self.to_tokio(t))
                .chain(self.line_end.iter().flatten().copied().filter(|t| *t > now))
                .min();
            let Some(next) = next else {
                panic!("master busy but nothing scheduled");
            };
            // At least one microsecond of progress (a deadline already due was handled).
            let target = next.max(now + Duration::from_micros(1));
            tokio::time::advance(target - now).await;
        }
        panic!("the bus did not settle");
    }

    /// Everything due now: received characters (in arrival order, with the state machines'
    /// deadlines between them), timeouts, transmissions, events.
    async fn step(&mut self) {
        let now = self.now();
        let mut chars = Vec::new();
        drain(&mut self.drive_end, REQ, &mut chars);
        drain(&mut self.master_end, RESP, &mut chars);
        chars.sort_by_key(|(_, c)| c.at);
        for (direction, c) in chars {
            let time = self.to_protocol(c.at);
            // Deadlines before this character are handled first, at their own time.
            while let Some(due) = self.next_deadline().filter(|d| *d < time) {
                self.master.handle_timeout(due);
                self.slave.handle_timeout(due);
                self.collect();
                self.transmit(due, true).await;
                if self.next_deadline() == Some(due) {
                    break;
                }
            }
            let rx = RxChar {
                byte: c.ch.byte,
                time,
                error: (!c.ch.parity_ok).then_some(CharError::Parity),
            };
            if direction == REQ {
                self.slave.handle_char(rx);
            } else {
                self.master.handle_char(rx);
            }
            self.collect();
        }
        self.master.handle_timeout(now);
        self.slave.handle_timeout(now);
        self.collect();
        self.transmit(now, false).await;
        self.collect();
    }

    fn next_deadline(&self) -> Option<movilink::Instant> {
        [self.master.poll_timeout(), self.slave.poll_timeout()]
            .into_iter()
            .flatten()
            .min()
    }

    async fn transmit(&mut self, now: movilink::Instant, late: bool) {
        let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
        if let Some(n) = self.master.poll_transmit(now, &mut buf) {
            self.late_transmissions += u64::from(late);
            self.write(Side::Master, &buf[..n]).await;
        }
        if let Some(n) = self.slave.poll_transmit(now, &mut buf) {
            self.late_transmissions += u64::from(late);
            self.write(Side::Drive, &buf[..n]).await;
        }
    }

    async fn write(&mut self, side: Side, bytes: &[u8]) {
        let d = dir(side);
        // The previous telegram of this direction was judged by now, or it never will be.
        self.finish(d);
        let faults = match &mut self.plan {
            Some(plan) => plan(side, bytes),
            None => Vec::new(),
        };
        let before = self.fault_stats(side);
        let end = match side {
            Side::Master => &mut self.master_end,
            Side::Drive => &mut self.drive_end,
        };
        let mut pos = 0;
        for (at, fault) in faults {
            let at = at.min(bytes.len() - 1);
            write_all(end, &bytes[pos..at]);
            end.inject(fault);
            pos = at;
        }
        write_all(end, &bytes[pos..]);
        let after = self.fault_stats(side);
        let dropped = after.dropped - before.dropped;
        let inserted = after.inserted - before.inserted;
        let flipped = after.flipped - before.flipped;
        let slots = bytes.len() as u32 + inserted as u32;
        let now = TokioInstant::now();
        let start = self.line_end[d].map_or(now, |t| t.max(now));
        self.line_end[d] = Some(start + self.char_time * slots);
        let faulted = dropped + inserted + flipped > 0;
        let s = &mut self.stats[d];
        s.sent += 1;
        s.chars += bytes.len() as u64;
        let entry = s.lengths.entry(bytes.len()).or_default();
        entry.0 += 1;
        if faulted {
            s.faulted += 1;
            entry.1 += 1;
            let kind = match (dropped, inserted, flipped) {
                (0, 0, 1) => "flip",
                (1, 0, 0) => "drop",
                (0, 1, 0) => "insert",
                _ => "multiple",
            };
            *s.faulted_by_kind.entry(kind).or_default() += 1;
        }
        let telegram = match movilink::decode(bytes) {
            Ok((t, _)) => t,
            Err(e) => panic!("{side:?} wrote an invalid telegram: {e}"),
        };
        self.last[d] = Some(OnWire {
            telegram,
            faulted,
            judged: false,
        });
    }

    /// Close the books on the last telegram of direction `d`.
    fn finish(&mut self, d: usize) {
        if let Some(w) = self.last[d].take()
            && !w.judged
        {
            if w.faulted {
                self.stats[d].lost += 1;
            } else {
                self.stats[d].clean_failed += 1;
            }
        }
    }

    /// Close the books on both directions (at the end of a campaign).
    pub fn finish_all(&mut self) {
        self.finish(REQ);
        self.finish(RESP);
    }

    fn accepted(&mut self, d: usize, got: &Telegram) {
        let stats = &mut self.stats[d];
        match &mut self.last[d] {
            Some(w) if !w.judged => {
                w.judged = true;
                if *got != w.telegram {
                    stats.undetected += 1;
                } else if w.faulted {
                    stats.faulted_accepted_equal += 1;
                } else {
                    stats.clean_accepted += 1;
                }
            }
            // A telegram nobody sent (or accepted twice): undetected.
            _ => stats.undetected += 1,
        }
    }

    fn rejected(&mut self, d: usize, r: &RejectReason) {
        let stats = &mut self.stats[d];
        match &mut self.last[d] {
            Some(w) if !w.judged => {
                w.judged = true;
                if w.faulted {
                    *stats.rejected.entry(reason_name(r)).or_default() += 1;
                } else {
                    stats.clean_failed += 1;
                }
            }
            _ => stats.extra_events += 1,
        }
    }

    fn collect(&mut self) {
        while let Some(e) = self.slave.poll_event() {
            match e {
                SlaveEvent::Received { telegram, .. } => self.accepted(REQ, &telegram),
                SlaveEvent::Rejected(r) => self.rejected(REQ, &r),
                _ => {}
            }
        }
        while let Some(e) = self.master.poll_event() {
            match e {
                MasterEvent::Response { telegram } => self.accepted(RESP, &telegram),
                MasterEvent::Rejected(
                    r @ (RejectReason::PduTypeMismatch { .. } | RejectReason::ParamMismatch),
                ) => {
                    let stats = &mut self.stats[RESP];
                    match &mut self.last[RESP] {
                        Some(w) if !w.judged && w.faulted => {
                            w.judged = true;
                            stats.caught_by_master += 1;
                        }
                        Some(w) => {
                            w.judged = true;
                            *stats.refused_by_master.entry(reason_name(&r)).or_default() += 1;
                        }
                        None => stats.extra_events += 1,
                    }
                }
                MasterEvent::Rejected(r) => self.rejected(RESP, &r),
                _ => {}
            }
            self.events.push(e);
        }
    }
}

/// Writes `bytes` to `end` at once (the link accepts writes immediately below its capacity).
fn write_all(end: &mut LinkEnd, mut bytes: &[u8]) {
    let mut cx = Context::from_waker(Waker::noop());
    while !bytes.is_empty() {
        match Pin::new(&mut *end).poll_write(&mut cx, bytes) {
            Poll::Ready(Ok(n)) => bytes = &bytes[n..],
            other => panic!("link write did not complete at once: {other:?}"),
        }
    }
}

/// Takes every character that has arrived at `end` by now.
fn drain(end: &mut LinkEnd, direction: usize, out: &mut Vec<(usize, TimedChar)>) {
    let mut cx = Context::from_waker(Waker::noop());
    let mut buf = [TimedChar {
        ch: drive_transport::link::WireChar::new(0),
        at: TokioInstant::now(),
    }; 64];
    loop {
        match end.poll_read_timed(&mut cx, &mut buf) {
            Poll::Ready(Ok(n)) if n > 0 => out.extend(buf[..n].iter().map(|c| (direction, *c))),
            _ => return,
        }
    }
}
