//! The CTT2 side of the AS-i double slave (the 2nd slave, BU 0255 sections 3.3, 4.2 and 4.3),
//! sans-IO: a whole request goes in with [`DoubleSlave::handle_request`], the answer comes out
//! of [`DoubleSlave::poll_answer`] once it is due, and [`DoubleSlave::poll_timeout`] says when
//! that is. The drive behind it is a [`Backend`] (the simulated drive implements it).
//!
//! What the double slave does (section 4.3.5), and the choices where the manual is silent
//! (errata E17 and E18):
//!
//! * It checks code, index and lengths ([`Request::decode`]) and answers a failing request with
//!   [`DecodeError::answer`](super::DecodeError::answer): error 1 for an index it does not have, 2 for a length it does not
//!   allow, and 144 + 3 for a code it does not know.
//! * Reads return what was asked for, but never more than the object or channel has.
//! * **Answer window:** the answer must begin within [`SlaveConfig::window`] (200 ms) of the
//!   complete request. The drive needs [`Backend::answer_time`] for a request; when that is
//!   longer than the window the double slave answers error 4 when the window ends, and the
//!   request has no effect (choice: the manual only says the drive "could not process it in
//!   time").
//! * **One request at a time:** a request that arrives while the previous one has not been
//!   answered is answered at once with error 5 and has no effect. The previous request is still
//!   carried out and answered (choice).
//! * **Drive address:** the PZD channel and the PKW channel with address carry the drive's
//!   address, always 1. The double slave hands the USS telegram on to the drive, which answers
//!   only its own address; a write to any other address therefore gets no answer from the drive,
//!   and the double slave answers error 4 when the window ends (choice).
//! * **Parameter channel:** a write hands the order to the drive and is answered at once (83):
//!   the answer says nothing about the order. The drive works on it with low priority for
//!   [`Backend::pkw_time`]; until it is done, a read returns the answer to the previous order.
//!   A new write before that replaces the unfinished order (choice). Before the first write, a
//!   read returns AK 7 with PWE2 error 9 ("… a READ command without a previous WRITE command",
//!   section 4.6.1.1) for PNU 0, IND 0 (erratum E17). An order with a reserved AK is answered
//!   AK 7 with error 201 ("invalid order element in the last order received").
//! * **Process data** are processed at once (high priority, section 4.2): a PZD write passes
//!   control word and setpoints to [`Backend::process`]; a PZD read returns the present status
//!   word and actual values ([`Backend::process_data`]).

use core::time::Duration;

use drive_core::Instant;
use drive_core::time::earliest;
use drive_profile::nord::Ctt2MessageType;

use super::message::{Channel, Data, ErrorCode, Request, Response, StandardIndex};
use super::object::{DiagnosisObject, IdObject, ObjectError};
use crate::uss::pkw::{DriveError, Ind, Order, Pkw, Reply};
use crate::uss::pzd::{PzdIn, PzdOut};

/// The time within which an answer must begin (section 4.3.5).
pub const ANSWER_WINDOW: Duration = Duration::from_millis(200);

/// PWE2 error 9: "READ without previous WRITE" (the answer to a PKW read before any order).
pub const READ_WITHOUT_WRITE: DriveError = DriveError(9);

/// PWE2 error 201: "invalid order element in the last order received".
pub const INVALID_ORDER: DriveError = DriveError(201);

/// The drive behind the double slave.
pub trait Backend {
    /// The ID object (section 4.3.1).
    fn id_object(&mut self, now: Instant) -> IdObject;

    /// The diagnosis object.
    fn diagnosis(&mut self, now: Instant) -> DiagnosisObject;

    /// Process a control word and setpoints; return the status word and all three actual
    /// values after it.
    fn process(&mut self, out: PzdOut, now: Instant) -> PzdIn;

    /// The present status word and all three actual values.
    fn process_data(&mut self, now: Instant) -> PzdIn;

    /// Carry out a parameter order (never AK 0: the double slave answers that itself).
    fn execute(&mut self, order: Order, now: Instant) -> Reply;

    /// How long the drive works on `order` (low priority) before its answer replaces the
    /// previous one.
    fn pkw_time(&self, order: &Order) -> Duration {
        let _ = order;
        Duration::ZERO
    }

    /// From the complete request to the start of the drive's answer. Longer than the answer
    /// window means error 4.
    fn answer_time(&self, request: &Request) -> Duration {
        let _ = request;
        Duration::ZERO
    }
}

/// Settings of a [`DoubleSlave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// The answer window (section 4.3.5: 200 ms).
    pub window: Duration,
}

impl Default for SlaveConfig {
    fn default() -> Self {
        Self {
            window: ANSWER_WINDOW,
        }
    }
}

/// An answer waiting to be sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Queued {
    due: Instant,
    response: Response,
    /// The error-5 answer to a request that came too early (it does not block further
    /// requests).
    overlap: bool,
}

/// An order the drive is working on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Working {
    order: Order,
    due: Instant,
}

/// Counters of a [`DoubleSlave`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SlaveCounters {
    /// Requests received.
    pub requests: u64,
    /// Answers sent.
    pub answers: u64,
    /// Negative answers sent, by error code 1–5 (index 0 = error 1).
    pub errors: [u64; 5],
    /// Parameter orders carried out.
    pub orders: u64,
}

/// The CTT2 double slave over a [`Backend`] (see the [module docs](self)).
#[derive(Debug)]
pub struct DoubleSlave<B> {
    backend: B,
    config: SlaveConfig,
    queue: [Option<Queued>; 2],
    pkw_answer: Pkw,
    working: Option<Working>,
    counters: SlaveCounters,
}

impl<B: Backend> DoubleSlave<B> {
    /// A double slave over `backend`, freshly powered on.
    pub fn new(backend: B, config: SlaveConfig) -> Self {
        Self {
            backend,
            config,
            queue: [None; 2],
            pkw_answer: Reply::Error(READ_WITHOUT_WRITE).to_pkw(0, Ind::ZERO),
            working: None,
            counters: SlaveCounters::default(),
        }
    }

    /// The backend.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The backend, mutable.
    pub fn backend_mut(&mut self) -> &mut B {
        &mut self.backend
    }

    /// The settings.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// The counters.
    pub fn counters(&self) -> &SlaveCounters {
        &self.counters
    }

    /// What a PKW read returns now.
    pub fn pkw_answer(&self) -> Pkw {
        self.pkw_answer
    }

    /// Whether a request is waiting for its answer (a new one now would get error 5).
    pub fn is_busy(&self) -> bool {
        self.queue.iter().flatten().any(|q| !q.overlap)
    }

    /// Whether the drive is still working on a parameter order.
    pub fn is_working(&self) -> bool {
        self.working.is_some()
    }

    /// A whole request arrived at `now`.
    pub fn handle_request(&mut self, bytes: &[u8], now: Instant) {
        self.handle_timeout(now);
        self.counters.requests += 1;
        if self.is_busy() {
            let kind = bytes
                .first()
                .and_then(|c| super::message::kind_of_request(*c))
                .unwrap_or(Ctt2MessageType::StandardRead);
            self.push(Queued {
                due: now,
                response: Response::error(kind, ErrorCode::PreviousPending),
                overlap: true,
            });
            return;
        }
        let (response, due) = match Request::decode(bytes) {
            Err(e) => (e.answer(), now),
            Ok(request) => self.carry_out(&request, now),
        };
        self.push(Queued {
            due,
            response,
            overlap: false,
        });
    }

    /// The answer due at `now`, if any (its first byte leaves at `now`).
    pub fn poll_answer(&mut self, now: Instant) -> Option<Response> {
        self.handle_timeout(now);
        let slot = self
            .queue
            .iter_mut()
            .filter(|q| q.is_some_and(|q| q.due <= now))
            .min_by_key(|q| q.map(|q| q.due))?;
        let q = slot.take()?;
        self.counters.answers += 1;
        if let Response::Error { error, .. } = q.response
            && let Some(c) = self.counters.errors.get_mut(usize::from(error.code() - 1))
        {
            *c += 1;
        }
        Some(q.response)
    }

    /// When an answer falls due or a parameter order is done.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let answers = self.queue.iter().flatten().map(|q| q.due).min();
        earliest(answers, self.working.map(|w| w.due))
    }

    /// Time advanced to `now`: finish a parameter order that is due.
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(w) = self.working
            && w.due <= now
        {
            self.working = None;
            let reply = self.backend.execute(w.order, now);
            self.counters.orders += 1;
            self.pkw_answer = reply.to_pkw(w.order.pnu(), w.order.ind());
        }
    }

    fn push(&mut self, q: Queued) {
        let slot = match self.queue.iter().position(Option::is_none) {
            Some(i) => self.queue.get_mut(i),
            // Both taken: one is an earlier error-5 answer; the newer one replaces it.
            None => self.queue.iter_mut().find(|s| s.is_some_and(|s| s.overlap)),
        };
        if let Some(slot) = slot {
            *slot = Some(q);
        }
    }

    /// The answer to a valid request and when it begins.
    fn carry_out(&mut self, request: &Request, now: Instant) -> (Response, Instant) {
        let kind = request.kind();
        let window = now + self.config.window;
        if self.backend.answer_time(request) > self.config.window {
            return (Response::error(kind, ErrorCode::Busy), window);
        }
        let due = now + self.backend.answer_time(request);
        match self.effect(request, now) {
            Ok(data) => (Response::Ok { kind, data }, due),
            Err(ErrorCode::Busy) => (Response::error(kind, ErrorCode::Busy), window),
            Err(error) => (Response::error(kind, error), due),
        }
    }

    /// Carry out a valid request; the data read.
    fn effect(&mut self, request: &Request, now: Instant) -> Result<Data, ErrorCode> {
        match *request {
            Request::StandardRead { index, len } => Ok(match index {
                StandardIndex::Id => self.backend.id_object(now).to_data(),
                StandardIndex::Diagnosis => self.backend.diagnosis(now).to_data(),
            }
            .truncated(len.min(index.max_len()))),
            Request::NordRead { index, len } => Ok(self.read(index, None, now).truncated(len)),
            Request::NordWrite { index, data } => {
                self.write(index, &data, now)?;
                Ok(Data::EMPTY)
            }
            Request::NordWriteRead {
                index,
                read_len,
                data,
            } => {
                let pzd = self.write(index, &data, now)?;
                Ok(self.read(index, pzd, now).truncated(read_len))
            }
        }
    }

    /// Write a channel; for PZD the process data after it.
    fn write(
        &mut self,
        index: Channel,
        data: &Data,
        now: Instant,
    ) -> Result<Option<PzdIn>, ErrorCode> {
        let map = |e: ObjectError| match e {
            // The drive does not answer a USS telegram for another address.
            ObjectError::BadAddress(_) => ErrorCode::Busy,
            _ => ErrorCode::InvalidLength,
        };
        match index {
            Channel::Pzd => {
                let out = data.to_pzd_out().map_err(map)?;
                Ok(Some(self.backend.process(out, now)))
            }
            Channel::Pkw | Channel::PkwWithAddress => {
                let pkw = data.to_pkw(index).map_err(map)?;
                self.submit(pkw, now);
                Ok(None)
            }
        }
    }

    /// Read a channel (the whole channel; the caller truncates).
    fn read(&mut self, index: Channel, pzd: Option<PzdIn>, now: Instant) -> Data {
        match index {
            Channel::Pzd => {
                let pzd = match pzd {
                    Some(p) => p,
                    None => self.backend.process_data(now),
                };
                Data::from_pzd_in(&pzd)
            }
            Channel::Pkw | Channel::PkwWithAddress => {
                self.handle_timeout(now);
                Data::from_pkw(index, &self.pkw_answer).unwrap_or_default()
            }
        }
    }

    /// Hand a parameter order to the drive.
    fn submit(&mut self, pkw: Pkw, now: Instant) {
        match Order::from_pkw(&pkw) {
            Ok(order) if order.ak() == 0 => {
                self.working = None;
                self.pkw_answer = Reply::None.to_pkw(order.pnu(), order.ind());
            }
            Ok(order) => {
                let due = now + self.backend.pkw_time(&order);
                self.working = Some(Working { order, due });
                self.handle_timeout(now);
            }
            Err(_) => {
                self.working = None;
                self.pkw_answer = Reply::Error(INVALID_ORDER).to_pkw(pkw.pke.pnu(), pkw.ind);
            }
        }
    }
}

impl<B> DoubleSlave<B> {
    /// The backend back.
    pub fn into_backend(self) -> B {
        self.backend
    }
}
