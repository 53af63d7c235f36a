//! The one runtime driver: [`Driver`], a sans-IO master on a [`Link`], one transaction at a
//! time. Every protocol's async driver is one.

use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::time::Duration;

use tokio::time::Instant as TokioInstant;

use super::io::CharIo;
use super::port::{Port, Step};
use crate::endpoint::Endpoint;
use crate::master::{Control, MasterEvent};
use crate::time::Instant;

/// The medium a [`Driver`] runs a sans-IO master `E` on: a serial [`Port`] (characters) or a
/// [`CanPort`](super::CanPort) (CAN frames). One step hears what waits, else sends what the
/// master has due, else waits for its next deadline or for input.
pub trait Link<E> {
    /// Now, as the master sees it.
    fn now(&self) -> Instant;

    /// A transaction starts (the link may reset what it keeps between steps).
    fn begin(&mut self) {}

    /// One step of the transaction (see [`Port::step`]): [`Step::Sent`] when the master's frame
    /// was written. After an error the frame on the wire is broken or the link gone.
    fn step(&mut self, endpoint: &mut E) -> impl Future<Output = io::Result<Step>>;

    /// When the last frame sent was meant to start, on tokio's clock.
    fn last_tx_start(&self) -> Option<TokioInstant>;

    /// When the last input fed to the master arrived, on tokio's clock.
    fn last_rx_at(&self) -> Option<TokioInstant>;
}

impl<IO: CharIo, E: Endpoint> Link<E> for Port<IO> {
    fn now(&self) -> Instant {
        Port::now(self)
    }

    async fn step(&mut self, endpoint: &mut E) -> io::Result<Step> {
        let mut buf = self.take_tx_buffer(endpoint.max_frame_len());
        let r = Port::step(self, endpoint, &mut buf).await;
        self.put_tx_buffer(buf);
        r
    }

    fn last_tx_start(&self) -> Option<TokioInstant> {
        Port::last_tx_start(self)
    }

    fn last_rx_at(&self) -> Option<TokioInstant> {
        Port::last_rx_at(self)
    }
}

/// What a master's event means to [`Driver::run`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow<T, R, F = Infallible> {
    /// The answer that completes the transaction with this result (the wire times of the
    /// exchange are recorded).
    Answered(T),
    /// An answer that does not complete it (another exchange of the same request follows, or
    /// another event of it); the wire times are recorded.
    Answer,
    /// The transaction is complete with this result without an answer (a request nobody
    /// answers, the end of a scan).
    Done(T),
    /// An answer was not taken (the master retries or gives up).
    Rejected(R),
    /// The master gave up after `attempts` transmissions.
    GaveUp {
        /// Transmissions made.
        attempts: u16,
    },
    /// The protocol ended the request without a result.
    Failed(F),
    /// An event the loop does not need.
    Other,
}

impl<A, R, F> From<MasterEvent<A, R, F>> for Flow<Option<A>, R, F> {
    /// The flow of drive-core's own master events: a response completes the transaction with
    /// it, a request nobody answers completes it with nothing.
    #[inline]
    fn from(event: MasterEvent<A, R, F>) -> Self {
        match event {
            MasterEvent::Response(a) => Flow::Answered(Some(a)),
            MasterEvent::Answer(_) => Flow::Answer,
            MasterEvent::Sent => Flow::Done(None),
            MasterEvent::Timeout { attempts } => Flow::GaveUp { attempts },
            MasterEvent::Rejected(r) => Flow::Rejected(r),
            MasterEvent::Failed(f) => Flow::Failed(f),
        }
    }
}

/// Why [`Driver::run`] ended without a result.
#[derive(Debug)]
pub enum Failed<R, F = Infallible> {
    /// Nothing answered in any of `attempts` transmissions (the master gave up, or ended the
    /// request without a result it could report).
    NoAnswer {
        /// Transmissions made.
        attempts: u32,
    },
    /// Answers came but the last one after the last transmission was rejected for `reason`;
    /// the master gave up after `attempts` transmissions.
    Corrupt {
        /// Why the last answer was rejected.
        reason: R,
        /// Transmissions made.
        attempts: u32,
    },
    /// The protocol ended the request without a result.
    Ended(F),
    /// The link failed; the master's request was aborted.
    Io(io::Error),
}

impl<R, F> Failed<R, F> {
    fn gave_up(attempts: u32, last_reject: Option<R>) -> Self {
        match last_reject {
            Some(reason) => Failed::Corrupt { reason, attempts },
            None => Failed::NoAnswer { attempts },
        }
    }
}

/// The counters of a protocol's async driver, the same in every protocol crate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct DriverStats {
    /// Requests handed to the master (each call that reached the bus).
    pub transactions: u64,
    /// Retransmissions after a timeout or a rejected answer.
    pub retries: u64,
    /// Requests given up without any answer.
    pub timeouts: u64,
    /// Received frames or characters dropped by the checks.
    pub rejected: u64,
    /// Negative answers of drives (a return code, an exception).
    pub device_errors: u64,
    /// Input never taken as an answer because it arrived before the request had left the port
    /// (an answer an earlier program left there, a late answer, another master): bytes on a
    /// line, frames on CAN.
    pub stale: u64,
}

impl DriverStats {
    /// Count what a transaction's `tally` says and how it ended.
    pub fn count<T, R, F>(&mut self, tally: &Tally, result: &Result<T, Failed<R, F>>) {
        self.retries += u64::from(tally.retries);
        self.rejected += u64::from(tally.rejected);
        self.stale += u64::from(tally.stale);
        if matches!(result, Err(Failed::NoAnswer { .. })) {
            self.timeouts += 1;
        }
    }
}

/// Wire times of an answered exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ExchangeTiming {
    /// When the (last) request transmission was handed to the port: on an idle line of the
    /// wire model, the start of its first character (after a timer wake-up, the deadline it
    /// was sent for).
    pub request_start: TokioInstant,
    /// Arrival of the answer's last character (exact on the wire model).
    pub response_end: TokioInstant,
}

impl ExchangeTiming {
    /// From the start of the request to the end of the response.
    pub fn duration(&self) -> Duration {
        self.response_end
            .saturating_duration_since(self.request_start)
    }
}

/// What [`Driver::run`] counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct Tally {
    /// Transmissions (the first and every retry, and every further exchange of a request).
    pub sent: u32,
    /// Retransmissions: transmissions after one that got no answer.
    pub retries: u32,
    /// Answers not taken.
    pub rejected: u32,
    /// Input never taken as an answer because it arrived before the request had left (an
    /// answer an earlier program left in the port, a late one, another master): characters on
    /// a line, frames on CAN.
    pub stale: u32,
    /// The wire times of the last answered exchange.
    pub timing: Option<ExchangeTiming>,
}

/// The one runtime driver: a sans-IO master `M` on a link `L` ([`Port`] or
/// [`CanPort`](super::CanPort)), one transaction at a time.
///
/// A transaction: [`Driver::prepare`] drops what a cancelled call left (the master's request
/// in flight and its events) and gives the time to start the new request at; the protocol
/// starts it on [`Driver::master_mut`]; [`Driver::run`] then reads the master's events as
/// [`Flow`]s and steps the link until the transaction completes, the master gives up, or the
/// link fails (the request is then aborted).
#[derive(Debug)]
pub struct Driver<L, M> {
    link: L,
    master: M,
}

impl<L, M> Driver<L, M> {
    /// `master` on `link`.
    pub fn new(link: L, master: M) -> Self {
        Self { link, master }
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.link
    }

    /// The link, for changing (e.g. fault injection on its I/O).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// The master.
    pub fn master(&self) -> &M {
        &self.master
    }

    /// The master, for starting a request or changing its settings.
    pub fn master_mut(&mut self) -> &mut M {
        &mut self.master
    }

    /// Both, for a protocol's own loop.
    pub fn parts_mut(&mut self) -> (&mut L, &mut M) {
        (&mut self.link, &mut self.master)
    }

    /// The link back.
    pub fn into_link(self) -> L {
        self.link
    }
}

impl<L: Link<M>, M: Control> Driver<L, M> {
    /// Drop what an abandoned call left (a request in flight is aborted: its frame broke off,
    /// or a late answer to it must not be taken for the next one; its events are dropped) and
    /// return the time the next request starts at.
    pub fn prepare(&mut self) -> Instant {
        let now = self.link.now();
        if !self.master.is_idle() {
            self.master.abort(now);
        }
        self.master.clear_events();
        now
    }

    /// Run the transaction started on the master: `next` takes the master's events one at a
    /// time and says what each means ([`Flow`]). The first [`Flow::Answered`] or [`Flow::Done`]
    /// completes it; [`Flow::GaveUp`] ends it with [`Failed::NoAnswer`], or
    /// [`Failed::Corrupt`] with the reason the last answer was rejected if one came after the
    /// last transmission; [`Flow::Failed`] with [`Failed::Ended`], a link failure with
    /// [`Failed::Io`] after aborting the request. A master that is idle without having
    /// completed the transaction ends it the same way as a give-up (it can never complete). `tally` counts what happened.
    pub async fn run<T, R, F>(
        &mut self,
        tally: &mut Tally,
        mut next: impl FnMut(&mut M) -> Option<Flow<T, R, F>>,
    ) -> Result<T, Failed<R, F>> {
        let stale_before = self.master.stale();
        self.link.begin();
        let mut last_reject = None;
        // Whether a transmission was made, and whether the last one got an answer.
        let (mut transmitted, mut answered) = (false, false);
        let mut request_start = None;
        let result = 'transaction: loop {
            while let Some(flow) = next(&mut self.master) {
                match flow {
                    Flow::Answered(t) => {
                        self.answered(tally, request_start);
                        break 'transaction Ok(t);
                    }
                    Flow::Answer => {
                        answered = true;
                        self.answered(tally, request_start);
                    }
                    Flow::Done(t) => break 'transaction Ok(t),
                    Flow::Rejected(reason) => {
                        tally.rejected = tally.rejected.saturating_add(1);
                        last_reject = Some(reason);
                    }
                    Flow::GaveUp { attempts } => {
                        break 'transaction Err(Failed::gave_up(u32::from(attempts), last_reject));
                    }
                    Flow::Failed(f) => break 'transaction Err(Failed::Ended(f)),
                    Flow::Other => {}
                }
            }
            if self.master.is_idle() {
                break 'transaction Err(Failed::gave_up(0, last_reject));
            }
            match self.link.step(&mut self.master).await {
                Ok(Step::Sent(_)) => {
                    if transmitted && !answered {
                        tally.retries = tally.retries.saturating_add(1);
                    }
                    tally.sent = tally.sent.saturating_add(1);
                    (transmitted, answered) = (true, false);
                    last_reject = None;
                    request_start =
                        Some(self.link.last_tx_start().unwrap_or_else(super::time::now));
                }
                Ok(Step::Waited) => {}
                Err(e) => {
                    let now = self.link.now();
                    self.master.abort(now);
                    break 'transaction Err(Failed::Io(e));
                }
            }
        };
        let stale = self.master.stale().saturating_sub(stale_before);
        tally.stale = tally
            .stale
            .saturating_add(u32::try_from(stale).unwrap_or(u32::MAX));
        result
    }

    /// An answer arrived for the request sent at `request_start`: its wire times.
    fn answered(&self, tally: &mut Tally, request_start: Option<TokioInstant>) {
        if let (Some(request_start), Some(response_end)) = (request_start, self.link.last_rx_at()) {
            tally.timing = Some(ExchangeTiming {
                request_start,
                response_end,
            });
        }
    }
}
