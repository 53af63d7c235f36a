//! The scheduler of one bus (sans-IO: time is an argument, nothing here sleeps or does I/O).
//!
//! A bus runs one transaction at a time. The scheduler decides which one, from four kinds of
//! job ([`Job`]): process-data cycles (each drive with process data, at its period), parameter
//! polls (each point with a period), a fault-status read of every drive every
//! `status_period`, and writes asked for on MQTT. The bus task asks [`Scheduler::next`] what
//! to do, runs it, and reports with [`Scheduler::done`].
//!
//! # Order
//!
//! At every decision, among the jobs that are due:
//!
//! 1. a write that has waited longer than its `max_age` (or whose drive has gone offline) is
//!    handed back to be refused ([`Next::Refuse`]), never sent;
//! 2. a due process-data cycle (earliest due first);
//! 3. a waiting write (oldest first), unless the job just before was a write that already
//!    went ahead of due polls: a write never waits behind polls that are merely due, and a
//!    stream of writes never starves the polls (they alternate);
//! 4. a due parameter poll (earliest due first);
//! 5. a due status read, or the probe of an offline drive (earliest due first);
//! 6. otherwise the scheduler is idle until the next job is due ([`Next::Idle`]).
//!
//! # Wire time, spreading and stretching
//!
//! Every job's wire time comes from the protocol's line timing
//! ([`BusAccess::wire_time`](super::bus::BusAccess::wire_time)). The *demand* of a bus is
//! Σ wire time / period over its periodic jobs. Periodic jobs are spread: the jobs sharing a
//! period start staggered evenly over that period (and groups of different periods are
//! offset against each other), so neither the start nor the turn of a period brings a burst.
//! When the demand exceeds 1, every period is stretched by the same factor (the demand), so
//! that the bus is asked exactly what the wire allows; those polls count as late. A poll or
//! process-data cycle is *late* when it starts more than a tolerance after the time its
//! configured period made it due; the tolerance is a tenth of its period or twice the bus's
//! longest transaction, whichever is longer (the jitter spreading cannot avoid).
//!
//! *Utilisation* is the wire time of the transactions done (for an unanswered one: the time it
//! held the bus, timeouts and retries included) over the elapsed time.
//!
//! # Offline drives
//!
//! A drive that does not answer (after the bus's retries) costs one timeout: all its jobs are
//! suspended and after a back-off a single probe (a status read) is made: 1 s after the
//! timeout, then 2 s, 4 s, 8 s and from then on every 10 s. The first answer ends the back-off;
//! the drive's jobs resume, spread over their periods as at start. Writes for an offline drive
//! are refused (`offline`).

use std::collections::VecDeque;
use std::time::Duration;

use tokio::time::Instant;

use super::bus::Op;
use super::config::Bus;
use super::model::{BusFigures, DriveIx, PointIx};

/// The first back-off of an offline drive.
pub const BACKOFF_FIRST: Duration = Duration::from_secs(1);
/// The longest back-off of an offline drive (it doubles up to this).
pub const BACKOFF_MAX: Duration = Duration::from_secs(10);
/// How long [`Next::Idle`] waits when nothing at all is scheduled (a bus of offline drives
/// without probes does not exist, so this only bounds the wait).
const IDLE_MAX: Duration = Duration::from_secs(3600);

/// One transaction the scheduler asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Job {
    /// A process-data exchange with the drive.
    ProcessData {
        /// Drive.
        drive: DriveIx,
    },
    /// A read of one point.
    Poll {
        /// Drive.
        drive: DriveIx,
        /// Point.
        point: PointIx,
    },
    /// A read of the drive's fault status.
    Status {
        /// Drive.
        drive: DriveIx,
    },
    /// The probe of an offline drive (a status read).
    Probe {
        /// Drive.
        drive: DriveIx,
    },
    /// A write (with its read-back).
    Write {
        /// Drive.
        drive: DriveIx,
    },
}

impl Job {
    /// The drive the job talks to.
    pub fn drive(self) -> DriveIx {
        match self {
            Job::ProcessData { drive }
            | Job::Poll { drive, .. }
            | Job::Status { drive }
            | Job::Probe { drive }
            | Job::Write { drive } => drive,
        }
    }

    /// The kind of transaction (a write's read-back is a further [`Op::Read`]).
    pub fn op(self, bus: &Bus) -> Op {
        match self {
            Job::ProcessData { drive } => Op::ProcessData(pd_words(bus, drive)),
            Job::Poll { .. } | Job::Status { .. } | Job::Probe { .. } => Op::Read,
            Job::Write { .. } => Op::Write,
        }
    }
}

/// Number of process-data output words of `drive` (0 without process data).
fn pd_words(bus: &Bus, drive: DriveIx) -> u8 {
    bus.drives
        .get(drive)
        .and_then(|d| d.process_data.as_ref())
        .map_or(0, |pd| u8::try_from(pd.out.len()).unwrap_or(u8::MAX))
}

/// Why a queued write is handed back unsent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// It waited longer than its `max_age`.
    Expired,
    /// Its drive went offline while it waited.
    Offline,
}

impl Refusal {
    /// The `reason` of the refusal.
    pub fn reason(self) -> &'static str {
        match self {
            Refusal::Expired => "expired",
            Refusal::Offline => "offline",
        }
    }
}

/// What the bus does next.
#[derive(Debug)]
pub enum Next<W> {
    /// Run this transaction, then call [`Scheduler::done`].
    Run(Job),
    /// Run this write on `drive`, then call [`Scheduler::done`] with [`Job::Write`].
    Write {
        /// Drive.
        drive: DriveIx,
        /// The write as queued.
        write: W,
    },
    /// Answer this queued write with the refusal; nothing is sent.
    Refuse {
        /// The write as queued.
        write: W,
        /// Why.
        reason: Refusal,
    },
    /// Nothing is due before this instant (a new write may change that).
    Idle(Instant),
}

/// How a transaction ended, as far as the scheduler cares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The drive answered (also negatively: it is there).
    Answered,
    /// No valid answer after the bus's retries.
    NoAnswer,
}

/// A drive's change of presence after [`Scheduler::done`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// The drive stopped answering: its jobs are suspended.
    WentOffline,
    /// The drive answered again: its jobs resume.
    BackOnline,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Class {
    ProcessData,
    Poll,
    Status,
}

/// A periodic job and its schedule.
#[derive(Debug)]
struct Periodic {
    job: Job,
    class: Class,
    /// Configured period.
    period: Duration,
    /// Period after stretching.
    stretched: Duration,
    /// Offset of its first due time (spreading).
    phase: Duration,
    /// Next due time.
    due: Instant,
    /// When its configured period makes it due (for lateness).
    nominal: Instant,
    /// Lateness tolerance.
    tolerance: Duration,
}

#[derive(Debug, Clone, Copy)]
struct Offline {
    probe_at: Instant,
    backoff: Duration,
}

#[derive(Debug)]
struct Queued<W> {
    drive: DriveIx,
    deadline: Instant,
    /// The wire time it takes when answered.
    wire: Duration,
    write: W,
}

/// The scheduler of one bus; `W` is what a queued write carries (the bus task's pending
/// [`SetRequest`](super::model::SetRequest)).
#[derive(Debug)]
pub struct Scheduler<W> {
    start: Instant,
    periodic: Vec<Periodic>,
    offline: Vec<Option<Offline>>,
    writes: VecDeque<Queued<W>>,
    demand: f64,
    stretch: f64,
    read_wire: Duration,
    write_wire: Duration,
    pd_wire: Vec<Duration>,
    /// The last job was a write that went ahead of due polls.
    write_went_ahead: bool,
    running: Option<(Job, Instant)>,
    /// The wire time of the queued job running now ([`Job::Write`]).
    running_wire: Duration,
    busy: Duration,
    figures: BusFigures,
}

impl<W> Scheduler<W> {
    /// The scheduler of `bus` starting at `start`; `wire` gives each transaction's wire time.
    pub fn new(bus: &Bus, wire: impl Fn(Op) -> Duration, start: Instant) -> Self {
        let read_wire = wire(Op::Read);
        let write_wire = wire(Op::Write);
        let pd_wire: Vec<Duration> = (0..bus.drives.len())
            .map(|d| wire(Op::ProcessData(pd_words(bus, d))))
            .collect();
        let mut jobs: Vec<(Job, Class, Duration, Duration)> = Vec::new();
        for (d, drive) in bus.drives.iter().enumerate() {
            if let Some(pd) = &drive.process_data {
                let w = pd_wire.get(d).copied().unwrap_or_default();
                jobs.push((
                    Job::ProcessData { drive: d },
                    Class::ProcessData,
                    pd.period,
                    w,
                ));
            }
            for (p, point) in drive.points.iter().enumerate() {
                if let Some(period) = point.period {
                    jobs.push((
                        Job::Poll { drive: d, point: p },
                        Class::Poll,
                        period,
                        read_wire,
                    ));
                }
            }
            jobs.push((
                Job::Status { drive: d },
                Class::Status,
                bus.status_period,
                read_wire,
            ));
        }
        let demand: f64 = jobs
            .iter()
            .map(|(_, _, period, w)| w.as_secs_f64() / period.as_secs_f64().max(1e-9))
            .sum();
        let stretch = demand.max(1.0);
        let longest = jobs
            .iter()
            .map(|j| j.3)
            .chain([read_wire + write_wire])
            .max()
            .unwrap_or_default();
        // Spreading: the jobs sharing a period are staggered evenly over it; each group starts
        // where the previous group's first job ends, so that the groups' first jobs do not
        // collide either.
        let mut periods: Vec<Duration> = jobs.iter().map(|j| j.2).collect();
        periods.sort();
        periods.dedup();
        let mut phases = vec![Duration::ZERO; jobs.len()];
        let mut offset = Duration::ZERO;
        for period in periods {
            let members: Vec<usize> = (0..jobs.len())
                .filter(|&i| jobs.get(i).is_some_and(|j| j.2 == period))
                .collect();
            let n = u32::try_from(members.len()).unwrap_or(u32::MAX).max(1);
            let stretched = period.mul_f64(stretch);
            let mut first_wire = Duration::ZERO;
            for (k, &i) in members.iter().enumerate() {
                let k = u32::try_from(k).unwrap_or(u32::MAX);
                let phase = stretched / n * k + offset;
                let phase_ns = phase.as_nanos() % stretched.as_nanos().max(1);
                if let Some(slot) = phases.get_mut(i) {
                    *slot = Duration::from_nanos(u64::try_from(phase_ns).unwrap_or(0));
                }
                if k == 0 {
                    first_wire = jobs.get(i).map_or(Duration::ZERO, |j| j.3);
                }
            }
            offset += first_wire;
        }
        let periodic = jobs
            .into_iter()
            .zip(phases)
            .map(|((job, class, period, _), phase)| Periodic {
                job,
                class,
                period,
                stretched: period.mul_f64(stretch),
                phase,
                due: start + phase,
                nominal: start + phase,
                tolerance: (period / 10).max(longest * 2),
            })
            .collect();
        Self {
            start,
            periodic,
            offline: vec![None; bus.drives.len()],
            writes: VecDeque::new(),
            demand,
            stretch,
            read_wire,
            write_wire,
            pd_wire,
            write_went_ahead: false,
            running: None,
            running_wire: Duration::ZERO,
            busy: Duration::ZERO,
            figures: BusFigures {
                demand,
                ..BusFigures::default()
            },
        }
    }

    /// Σ wire time / period of the periodic jobs (above 1 the periods are stretched).
    pub fn demand(&self) -> f64 {
        self.demand
    }

    /// The factor every period is stretched by (1 when the demand fits the wire).
    pub fn stretch(&self) -> f64 {
        self.stretch
    }

    /// Whether `drive` is offline (its jobs suspended until a probe is answered).
    pub fn is_offline(&self, drive: DriveIx) -> bool {
        matches!(self.offline.get(drive), Some(Some(_)))
    }

    /// Queue a write for `drive`, received at `received`, refused once older than `max_age`.
    pub fn push_write(&mut self, drive: DriveIx, received: Instant, max_age: Duration, write: W) {
        let wire = self.write_wire + self.read_wire;
        self.push_job(drive, received, max_age, wire, write);
    }

    /// Queue another transaction for `drive` in the writes' queue (a read or write the page
    /// asks for), taking `wire` on the wire when answered; handed back as [`Next::Write`] and
    /// ended with [`Job::Write`].
    pub fn push_job(
        &mut self,
        drive: DriveIx,
        received: Instant,
        max_age: Duration,
        wire: Duration,
        write: W,
    ) {
        self.writes.push_back(Queued {
            drive,
            deadline: received + max_age,
            wire,
            write,
        });
    }

    /// The wire time of a parameter read and of a write (without its read-back).
    pub fn wire_times(&self) -> (Duration, Duration) {
        (self.read_wire, self.write_wire)
    }

    /// Writes waiting.
    pub fn writes_waiting(&self) -> usize {
        self.writes.len()
    }

    /// What to do at `now` (see the [module docs](self) for the order).
    pub fn next(&mut self, now: Instant) -> Next<W> {
        // 1. Writes that may no longer be sent.
        let stale = self
            .writes
            .iter()
            .position(|q| now > q.deadline || matches!(self.offline.get(q.drive), Some(Some(_))));
        if let Some(i) = stale
            && let Some(q) = self.writes.remove(i)
        {
            let reason = if now > q.deadline {
                Refusal::Expired
            } else {
                Refusal::Offline
            };
            return Next::Refuse {
                write: q.write,
                reason,
            };
        }
        // 2. Process data.
        if let Some(i) = self.due(now, Class::ProcessData) {
            return self.start_periodic(i, now);
        }
        // 3. A write before merely due polls (but not twice in a row ahead of them).
        let polls_due = self.due(now, Class::Poll).is_some() || self.status_due(now).is_some();
        if !(polls_due && self.write_went_ahead)
            && let Some(q) = self.writes.pop_front()
        {
            self.write_went_ahead = polls_due;
            return self.start_write(q, now);
        }
        // 4. Polls, 5. status reads and probes.
        if let Some(i) = self.due(now, Class::Poll) {
            return self.start_periodic(i, now);
        }
        match self.status_due(now) {
            Some(Ok(i)) => return self.start_periodic(i, now),
            Some(Err(drive)) => {
                self.write_went_ahead = false;
                if let Some(Some(o)) = self.offline.get_mut(drive) {
                    // No second probe before this one is done.
                    o.probe_at = now + IDLE_MAX;
                }
                let job = Job::Probe { drive };
                self.running = Some((job, now));
                return Next::Run(job);
            }
            None => {}
        }
        // 6. A write ahead of nothing.
        if let Some(q) = self.writes.pop_front() {
            self.write_went_ahead = false;
            return self.start_write(q, now);
        }
        let periodic = self
            .periodic
            .iter()
            .filter(|p| self.online(p.job.drive()))
            .map(|p| p.due);
        let probes = self.offline.iter().flatten().map(|o| o.probe_at);
        Next::Idle(
            periodic
                .chain(probes)
                .min()
                .unwrap_or(now + IDLE_MAX)
                .max(now),
        )
    }

    fn online(&self, drive: DriveIx) -> bool {
        matches!(self.offline.get(drive), Some(None))
    }

    /// The earliest due periodic job of `class` of an online drive.
    fn due(&self, now: Instant, class: Class) -> Option<usize> {
        self.periodic
            .iter()
            .enumerate()
            .filter(|(_, p)| p.class == class && p.due <= now && self.online(p.job.drive()))
            .min_by_key(|(_, p)| p.due)
            .map(|(i, _)| i)
    }

    /// The earliest due status read (`Ok(periodic index)`) or probe (`Err(drive)`).
    fn status_due(&self, now: Instant) -> Option<Result<usize, DriveIx>> {
        let status = self
            .due(now, Class::Status)
            .and_then(|i| self.periodic.get(i).map(|p| (p.due, Ok(i))));
        let probe = self
            .offline
            .iter()
            .enumerate()
            .filter_map(|(d, o)| o.map(|o| (o.probe_at, Err(d))))
            .filter(|(at, _)| *at <= now)
            .min_by_key(|(at, _)| *at);
        match (status, probe) {
            (Some(s), Some(p)) => Some(if p.0 < s.0 { p.1 } else { s.1 }),
            (s, p) => s.or(p).map(|x| x.1),
        }
    }

    fn start_periodic(&mut self, i: usize, now: Instant) -> Next<W> {
        self.write_went_ahead = false;
        let Some(p) = self.periodic.get_mut(i) else {
            return Next::Idle(now);
        };
        if p.class != Class::Status && now > p.nominal + p.tolerance {
            self.figures.late_polls += 1;
        }
        p.nominal = now + p.period;
        // Keep the phase (the spreading): a job that fell more than a period behind (after a
        // long timeout) skips the cycles it missed instead of running them back to back, and
        // is not moved to `now + period` either, where it would meet every other job that fell
        // behind.
        let stretched = p.stretched.as_nanos().max(1);
        let behind = now.saturating_duration_since(p.due).as_nanos();
        let cycles = u32::try_from(behind / stretched + 1).unwrap_or(u32::MAX);
        p.due += p.stretched.saturating_mul(cycles);
        let job = p.job;
        self.running = Some((job, now));
        Next::Run(job)
    }

    fn start_write(&mut self, q: Queued<W>, now: Instant) -> Next<W> {
        let job = Job::Write { drive: q.drive };
        self.running = Some((job, now));
        self.running_wire = q.wire;
        Next::Write {
            drive: q.drive,
            write: q.write,
        }
    }

    /// The wire time of `job` when answered.
    fn wire(&self, job: Job) -> Duration {
        match job {
            Job::ProcessData { drive } => self.pd_wire.get(drive).copied().unwrap_or_default(),
            Job::Poll { .. } | Job::Status { .. } | Job::Probe { .. } => self.read_wire,
            Job::Write { .. } => self.running_wire,
        }
    }

    /// `job` ended at `now` with `outcome`; returns the drive's change of presence, if any.
    pub fn done(&mut self, job: Job, now: Instant, outcome: Outcome) -> Option<Change> {
        let started = match self.running.take() {
            Some((j, at)) if j == job => at,
            other => {
                self.running = other;
                now
            }
        };
        self.figures.transactions += 1;
        self.busy += match outcome {
            Outcome::Answered => self.wire(job),
            Outcome::NoAnswer => now.saturating_duration_since(started),
        };
        let drive = job.drive();
        let slot = self.offline.get_mut(drive)?;
        match (outcome, slot.as_mut()) {
            (Outcome::NoAnswer, None) => {
                self.figures.timeouts += 1;
                *slot = Some(Offline {
                    probe_at: now + BACKOFF_FIRST,
                    backoff: BACKOFF_FIRST,
                });
                Some(Change::WentOffline)
            }
            (Outcome::NoAnswer, Some(o)) => {
                self.figures.timeouts += 1;
                o.backoff = (o.backoff * 2).min(BACKOFF_MAX);
                o.probe_at = now + o.backoff;
                None
            }
            (Outcome::Answered, Some(_)) => {
                *slot = None;
                for p in self.periodic.iter_mut().filter(|p| p.job.drive() == drive) {
                    p.due = now + p.phase;
                    p.nominal = p.due;
                }
                Some(Change::BackOnline)
            }
            (Outcome::Answered, None) => None,
        }
    }

    /// The bus's figures at `now` (`retries` is the link's to fill in).
    pub fn figures(&self, now: Instant) -> BusFigures {
        let elapsed = now.saturating_duration_since(self.start).as_secs_f64();
        BusFigures {
            utilisation: if elapsed > 0.0 {
                self.busy.as_secs_f64() / elapsed
            } else {
                0.0
            },
            ..self.figures.clone()
        }
    }
}

#[cfg(test)]
mod tests;
