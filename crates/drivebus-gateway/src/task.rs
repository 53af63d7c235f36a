//! The bus task: the [`Scheduler`] on tokio time, running each job on the bus's
//! [`BusAccess`] and reporting values, statuses and figures.
//!
//! * Every read is reported ([`Update::Value`], [`Update::ProcessData`]); the MQTT side decides
//!   what changed and what is due for its heartbeat.
//! * A drive's status is reported only when it changes ([`Update::Status`]): `Online` at its
//!   first answer, `Fault(text)` / `Online` from its status reads, `Timeout` when it stops
//!   answering (a warning in the log; an info line when it answers again).
//! * The figures ([`Update::Figures`], utilisation metrics, the link's retries and rejected
//!   frames) every [`FIGURES_EVERY`].
//! * Writes ([`SetRequest`]) are taken at any time, also while a transaction waits for its
//!   answer. A write that cannot be sent is answered at once (not writable, drive offline,
//!   already too old, a value that is no number or name, does not convert or does not fit the
//!   parameter's width); the others wait for their turn ([`Scheduler`]), pass the write guard
//!   (access, range, value list, EEPROM wear; RAM unless the point is `eeprom`), are written
//!   and read back: the answer is the value the drive holds.

use std::collections::HashSet;
use std::time::{Duration, SystemTime};

use drive_profile::Persistence;
use drive_profile::guard::GuardError;
use serde_json::{Map, Value};
use tokio::sync::mpsc;
use tokio::time::Instant;

use super::bus::{BusAccess, BusContext, Stop};
use super::config::{Bus, Point};
use super::metrics::Metrics;
use super::model::{
    Answer, Ask, AskOp, BusSlot, DriveIx, DriveStatus, Facts, SetOutcome, SetRequest, SetValue,
    Update,
};
use super::schedule::{Change, Job, Next, Outcome, Scheduler};

use drive_client::target::ValueError;
use drive_client::target::{Target, ValueText};
use drive_client::write::{WriteError, WriteRequest};
use drive_client::{ClientError, ParamClient};

/// How often a bus reports its figures.
pub const FIGURES_EVERY: Duration = Duration::from_secs(5);

/// Writes a bus keeps waiting at most; more are refused (`busy`).
pub const MAX_WAITING_WRITES: usize = 64;

/// The longest value text a `set` may carry.
const MAX_VALUE_TEXT: usize = 64;

/// A job waiting for the bus in the writes' queue.
#[derive(Debug)]
pub enum Pending {
    /// A `set`: the request and its raw value.
    Set {
        /// The request.
        req: SetRequest,
        /// Its raw value.
        raw: i64,
    },
    /// A transaction the page asked for.
    Ask(Ask),
}

/// What a job read.
enum Read {
    Value(i64),
    /// The input words, and the fault they show where they carry a status word
    /// ([`BusAccess::fault_in_inputs`]).
    ProcessData(Vec<u16>, Option<Option<String>>),
    Fault(Option<String>),
}

/// What the task reports to and where.
struct Out<'a> {
    ix: BusSlot,
    bus: &'a Bus,
    updates: &'a mpsc::Sender<Update>,
    metrics: &'a Metrics,
    status: Vec<Option<DriveStatus>>,
    /// Points whose poll the drive refused (logged once).
    refused: HashSet<(DriveIx, usize)>,
    retries: u64,
}

/// Run the bus of `ctx` on `access` until the gateway stops (the receiver of `ctx.updates`
/// is dropped).
pub async fn run_bus<B: BusAccess>(ctx: BusContext, mut access: B) {
    let BusContext {
        ix,
        bus,
        updates,
        sets,
        asks,
        metrics,
        mut shutdown,
        mut announce,
    } = ctx;
    // Before the first cycle: what the drives controlled over process data should have set
    // (said once in the log; a drive that does not answer yet is checked no further).
    for d in &bus.drives {
        let Some(pd) = &d.process_data else { continue };
        match access
            .process_data_warnings(d.address, &pd.out, pd.period)
            .await
        {
            Ok(warnings) => {
                for w in warnings {
                    tracing::warn!(bus = %bus.name, drive = %d.name, "process data: {w}");
                }
            }
            Err(e) => {
                tracing::debug!(bus = %bus.name, drive = %d.name, error = %e, "process data settings not read")
            }
        }
    }
    // A drive that watches its link for requests (Bonfiglioli 413) against the longest gap the
    // gateway leaves between its requests to it.
    for d in &bus.drives {
        let gap = d
            .points
            .iter()
            .filter_map(|p| p.period)
            .chain(d.process_data.as_ref().map(|pd| pd.period))
            .fold(bus.status_period, Duration::min);
        match access.watchdog_warnings(d.address, gap).await {
            Ok(warnings) => {
                for w in warnings {
                    tracing::warn!(bus = %bus.name, drive = %d.name, "{w}");
                }
            }
            Err(e) => {
                tracing::debug!(bus = %bus.name, drive = %d.name, error = %e, "link watchdog not read")
            }
        }
    }
    let start = Instant::now();
    let mut sched: Scheduler<Pending> = Scheduler::new(&bus, |op| access.wire_time(op), start);
    tracing::info!(
        bus = %bus.name,
        drives = bus.drives.len(),
        demand = %super::logfmt::percent(sched.demand()),
        "bus polling starts"
    );
    if sched.stretch() > 1.0 {
        tracing::warn!(
            bus = %bus.name,
            demand = %super::logfmt::percent(sched.demand()),
            "the polls ask {:.0} % of what the wire carries: every period is stretched by {:.2}",
            sched.demand() * 100.0,
            sched.stretch()
        );
    }
    let mut out = Out {
        ix,
        bus: &bus,
        updates: &updates,
        metrics: &metrics,
        status: vec![None; bus.drives.len()],
        refused: HashSet::new(),
        retries: 0,
    };
    let mut next_figures = start + FIGURES_EVERY;
    let mut inbox = Inbox {
        sets,
        asks,
        sets_open: true,
        asks_open: true,
        held: Vec::new(),
    };
    // The drives a page drives (`page_control`).
    let mut driven: Vec<Option<control::Driven>> = bus.drives.iter().map(|_| None).collect();
    let facts: Vec<Facts> = bus
        .drives
        .iter()
        .map(|d| facts_of(&access.client(d.address)))
        .collect();
    let mut announce_open = true;
    // A transaction under way is finished; then the loop ends at the shutdown.
    while !updates.is_closed() && *shutdown.borrow() == Stop::Run {
        if announce.has_changed().unwrap_or(false) {
            announce.mark_unchanged();
            if !out.announce().await {
                return;
            }
        }
        for ask in std::mem::take(&mut inbox.held) {
            take_ask(ask, &bus, &facts, &mut sched, &mut access, &mut driven);
        }
        let now = Instant::now();
        if now >= next_figures {
            out.figures(&sched, &mut access, now);
            while next_figures <= now {
                next_figures += FIGURES_EVERY;
            }
        }
        match sched.next(now) {
            Next::Idle(until) => {
                tokio::select! {
                    () = tokio::time::sleep_until(until.min(next_figures)) => {}
                    _ = shutdown.changed() => {}
                    r = announce.changed(), if announce_open => match r {
                        Ok(()) => {
                            announce.mark_unchanged();
                            if !out.announce().await {
                                return;
                            }
                        }
                        Err(_) => announce_open = false,
                    },
                    req = inbox.sets.recv(), if inbox.sets_open => match req {
                        Some(req) => accept(req, &bus, &mut sched),
                        None => inbox.sets_open = false,
                    },
                    ask = inbox.asks.recv(), if inbox.asks_open => match ask {
                        Some(ask) => take_ask(ask, &bus, &facts, &mut sched, &mut access, &mut driven),
                        None => inbox.asks_open = false,
                    },
                }
            }
            Next::Refuse { write, reason } => {
                let (received, max_age, drive) = match &write {
                    Pending::Set { req, .. } => (req.received, req.max_age, req.drive),
                    Pending::Ask(a) => (a.received, a.max_age, a.drive),
                };
                let message = |what: &str| match reason {
                    super::schedule::Refusal::Expired => format!(
                        "{what} waited {} ms for the bus, longer than max_set_age ({} ms): nothing was sent",
                        received.elapsed().as_millis(),
                        max_age.as_millis()
                    ),
                    super::schedule::Refusal::Offline => offline_message(&bus, drive),
                };
                match write {
                    Pending::Set { req, .. } => answer(
                        req,
                        SetOutcome::Refused {
                            reason: reason.reason(),
                            message: message("the write"),
                        },
                    ),
                    Pending::Ask(a) => {
                        let _ = a
                            .reply
                            .send(Err(ClientError::Request(message("the request"))));
                    }
                }
            }
            Next::Run(job) => {
                let started = Instant::now();
                let page = match job {
                    Job::ProcessData { drive, .. } => {
                        driven.get_mut(drive).and_then(Option::as_mut)
                    }
                    _ => None,
                };
                let fut = run_job(&mut access, &bus, job, page);
                let result = inbox.meanwhile(fut, &bus, &mut sched).await;
                if let Some(slot) = driven.get_mut(job.drive())
                    && slot.as_ref().is_some_and(|d| d.released)
                {
                    *slot = None;
                }
                if !out.job_done(&mut sched, job, started, result).await {
                    return;
                }
            }
            Next::Write {
                drive,
                write: Pending::Set { req, raw },
            } => {
                let started = Instant::now();
                let point = req.point;
                let fut = write_point(&mut access, &bus, drive, point, raw);
                let (outcome, answered) = inbox.meanwhile(fut, &bus, &mut sched).await;
                if !out
                    .write_done(&mut sched, drive, point, started, &outcome, answered)
                    .await
                {
                    return;
                }
                answer(req, outcome);
            }
            Next::Write {
                drive,
                write: Pending::Ask(ask),
            } => {
                let started = Instant::now();
                let fut = run_ask(&mut access, &bus, drive, ask.op.clone());
                let result = inbox.meanwhile(fut, &bus, &mut sched).await;
                if !out
                    .ask_done(&mut sched, drive, &ask.op, started, &result)
                    .await
                {
                    let _ = ask.reply.send(result);
                    return;
                }
                let _ = ask.reply.send(result);
            }
        }
    }
    let stop = shutdown.borrow().clone();
    match stop {
        Stop::Run => {}
        Stop::Gateway => {
            control::at_gateway_stop(&bus, &driven, "gateway stop");
            stop_process_data(&mut access, &bus, &sched, &[]).await;
        }
        Stop::Retire { continued } => {
            // A drive a page drives gets its stop: the new config's words are not the page's.
            let continued: Vec<u8> = continued
                .into_iter()
                .filter(|a| {
                    !bus.drives.iter().zip(&driven).any(|(d, page)| {
                        d.address == *a && page.as_ref().is_some_and(|p| p.command.is_some())
                    })
                })
                .collect();
            control::at_gateway_stop(&bus, &driven, "config reload");
            stop_process_data(&mut access, &bus, &sched, &continued).await;
            tracing::info!(bus = %bus.name, "bus stopped for the reloaded config");
        }
    }
}

/// At the gateway's stop: every drive the gateway controls over process data (and that
/// answers) gets the family's stop in its control word, as `drivectl pd` sends at its end; a
/// drive left running is logged as such. At a reload, the drives at the addresses in
/// `continued` keep their words: the new config's task carries on their process data.
async fn stop_process_data<B: BusAccess>(
    access: &mut B,
    bus: &Bus,
    sched: &Scheduler<Pending>,
    continued: &[u8],
) {
    for (i, d) in bus.drives.iter().enumerate() {
        let Some(pd) = &d.process_data else { continue };
        if continued.contains(&d.address) {
            tracing::info!(bus = %bus.name, drive = %d.name, "no stop sent: the reloaded config carries on its process data");
            continue;
        }
        if sched.is_offline(i) {
            tracing::warn!(bus = %bus.name, drive = %d.name, "the drive does not answer: no stop sent; its own bus timeout must stop it");
            continue;
        }
        match access.stop_process_data(d.address, &pd.out).await {
            Ok(Ok(inputs)) => {
                tracing::info!(bus = %bus.name, drive = %d.name, ?inputs, "stop sent in the process data")
            }
            Ok(Err(why)) => {
                tracing::warn!(bus = %bus.name, drive = %d.name, "no stop sent: {why}; the drive keeps the last process data until its own bus timeout")
            }
            Err(e) => {
                tracing::warn!(bus = %bus.name, drive = %d.name, error = %e, "the stop was not answered: the drive may still be running")
            }
        }
    }
}

/// The gateway's way out of a line whose adapter echoes what it sends while the bus's `echo`
/// is off.
fn echo_hint(e: &ClientError) -> &'static str {
    match e {
        ClientError::Link(l) if l.fault == drive_client::LinkFault::Echo => {
            "; set echo = true on the bus if its adapter echoes what it sends"
        }
        _ => "",
    }
}

/// What a bus-timeout fault means for the gateway (F43 RS-485, F47 SBus: the drive saw no
/// process data within its timeout).
fn fault_hint(text: &str) -> &'static str {
    if text.starts_with("F43") {
        " (RS-485 timeout: the drive saw no process data within its P812; check the process \
         data period, the bus's load and the line)"
    } else if text.starts_with("F47") {
        " (SBus timeout: the drive saw no process data within its P815; check the process \
         data period, the bus's load and the CAN line)"
    } else {
        ""
    }
}

fn answer(req: SetRequest, outcome: SetOutcome) {
    // The MQTT task may have given up on it (shutdown): nobody to tell.
    let _ = req.reply.send(outcome);
}

fn refuse(req: SetRequest, reason: &'static str, message: String) {
    answer(req, SetOutcome::Refused { reason, message });
}

fn offline_message(bus: &Bus, drive: DriveIx) -> String {
    let name = bus.drives.get(drive).map_or("?", |d| d.name.as_str());
    format!(
        "drive {name} on bus {} does not answer (status timeout): nothing was sent; write again when it is online",
        bus.name
    )
}

/// Take a write: refuse it at once when it cannot be sent, else queue it.
fn accept(req: SetRequest, bus: &Bus, sched: &mut Scheduler<Pending>) {
    let Some(drive) = bus.drives.get(req.drive) else {
        let m = format!("bus {} has no drive number {}", bus.name, req.drive);
        return refuse(req, "bad_request", m);
    };
    let Some(point) = drive.points.get(req.point) else {
        let m = format!("drive {} has no point number {}", drive.name, req.point);
        return refuse(req, "bad_request", m);
    };
    if !point.writable {
        let m = format!(
            "{} of drive {} is not writable: the config lists it without writable = true; nothing was sent",
            point.name, drive.name
        );
        return refuse(req, "not_writable", m);
    }
    if sched.is_offline(req.drive) {
        let m = offline_message(bus, req.drive);
        return refuse(req, "offline", m);
    }
    if req.received.elapsed() > req.max_age {
        let m = format!(
            "the write is older than max_set_age ({} ms): nothing was sent",
            req.max_age.as_millis()
        );
        return refuse(req, "expired", m);
    }
    if sched.writes_waiting() >= MAX_WAITING_WRITES {
        let m = format!(
            "bus {} already has {MAX_WAITING_WRITES} writes waiting: nothing was sent; write again later",
            bus.name
        );
        return refuse(req, "busy", m);
    }
    match raw_value(point, &req.value) {
        Ok(raw) => {
            let (drive, received, max_age) = (req.drive, req.received, req.max_age);
            sched.push_write(drive, received, max_age, Pending::Set { req, raw });
        }
        Err((reason, message)) => refuse(req, reason, message),
    }
}

/// The raw value of a `set`, or the refusal: the value as a number in the parameter's unit
/// or a value name, or the raw value; it must fit the parameter's bus width.
pub fn raw_value(point: &Point, value: &SetValue) -> Result<i64, (&'static str, String)> {
    let target = &point.target;
    let raw = match value {
        SetValue::Raw(raw) => *raw,
        SetValue::Value(v) => {
            let text = match v {
                Value::String(s) if s.chars().count() <= MAX_VALUE_TEXT => s.clone(),
                Value::String(_) => {
                    return Err((
                        "bad_request",
                        format!("\"value\" is longer than {MAX_VALUE_TEXT} characters"),
                    ));
                }
                Value::Number(n) => n
                    .as_i64()
                    .map(|i| i.to_string())
                    .or_else(|| n.as_u64().map(|u| u.to_string()))
                    .or_else(|| n.as_f64().filter(|f| f.is_finite()).map(|f| format!("{f}")))
                    .ok_or_else(|| ("bad_request", format!("\"value\" {n} is no finite number")))?,
                other => {
                    let kind = match other {
                        Value::Null => "null",
                        Value::Bool(_) => "a boolean",
                        Value::Array(_) => "an array",
                        _ => "an object",
                    };
                    return Err((
                        "bad_request",
                        format!(
                            "\"value\" is {kind}: give a number in the parameter's unit or a value name, or {{\"raw\": N}}"
                        ),
                    ));
                }
            };
            target
                .value_from_text(&text, &ValueText::default())
                .map_err(|e| value_refusal(target, &text, &e))?
                .raw
        }
    };
    if let Some(p) = target.param {
        drive_profile::guard::check_width(p, raw).map_err(|e| ("width", e.to_string()))?;
    } else {
        target
            .check_width(raw)
            .map_err(|e| ("width", e.to_string()))?;
    }
    Ok(raw)
}

/// Why `text` is no value of `target` ([`Target::value_from_text`]'s typed refusal), with a
/// message in the gateway's terms (no command-line option).
fn value_refusal(target: &Target, text: &str, e: &ValueError) -> (&'static str, String) {
    match e {
        ValueError::NotInSelection { .. } => ("value_list", e.to_string()),
        ValueError::NotANumber { unit, .. } => (
            "bad_request",
            format!(
                "`{text}` is not a number in {unit} nor a value name of {}; send {{\"raw\": N}} \
                 for a raw value",
                target.title()
            ),
        ),
        ValueError::OutOfRange { .. } => ("range", e.to_string()),
        ValueError::NotExact { .. } => ("resolution", e.to_string()),
        // A physical value past the bus width is past the table's range too: a set of a value
        // is refused for its range, as the table words it (a raw value past the width is a
        // `width` refusal, below).
        ValueError::PastWidth { .. } => {
            match (target.param, drive_client::text::parse_decimal(text)) {
                (Some(p), Some(x)) => match p.from_physical(x) {
                    Err(err) => ("range", format!("{} {}: {err}", p.label(), p.name_en())),
                    Ok(_) => ("width", e.to_string()),
                },
                _ => ("width", e.to_string()),
            }
        }
        ValueError::Width { .. } | ValueError::WidthRaw { .. } => ("width", e.to_string()),
        _ => ("bad_request", e.to_string()),
    }
}

/// The writes and asks that reach a bus task.
struct Inbox {
    sets: mpsc::Receiver<SetRequest>,
    asks: mpsc::Receiver<Ask>,
    sets_open: bool,
    asks_open: bool,
    /// Asks that came during a transaction, taken after it (the client is busy).
    held: Vec<Ask>,
}

impl Inbox {
    /// Run `fut` (a transaction) while taking the writes and asks that arrive meanwhile.
    async fn meanwhile<T>(
        &mut self,
        fut: impl std::future::Future<Output = T>,
        bus: &Bus,
        sched: &mut Scheduler<Pending>,
    ) -> T {
        tokio::pin!(fut);
        loop {
            tokio::select! {
                biased;
                r = &mut fut => break r,
                req = self.sets.recv(), if self.sets_open => match req {
                    Some(req) => accept(req, bus, sched),
                    None => self.sets_open = false,
                },
                ask = self.asks.recv(), if self.asks_open => match ask {
                    Some(ask) => self.held.push(ask),
                    None => self.asks_open = false,
                },
            }
        }
    }
}

/// What a drive's client knows without asking the drive.
fn facts_of<C: ParamClient>(client: &C) -> Facts {
    Facts {
        family: client.family(),
        link_settings: client.link_settings(),
        not_restored: client.not_restored(),
        device: client.device(),
    }
}

/// Take an ask of the page: answer it at once when it needs no transaction or cannot be run,
/// else queue it with its wire time.
fn take_ask<B: BusAccess>(
    ask: Ask,
    bus: &Bus,
    facts: &[Facts],
    sched: &mut Scheduler<Pending>,
    access: &mut B,
    driven: &mut [Option<control::Driven>],
) {
    let Some(f) = facts.get(ask.drive) else {
        let m = format!("bus {} has no drive number {}", bus.name, ask.drive);
        let _ = ask.reply.send(Err(ClientError::Request(m)));
        return;
    };
    let now = match &ask.op {
        AskOp::Facts => Some(Ok(Answer::Facts(*f))),
        AskOp::LinkChange(t, raw) => Some(Ok(Answer::Text(link_change_text(
            bus, ask.drive, access, t, *raw,
        )))),
        _ if sched.is_offline(ask.drive) => {
            Some(Err(ClientError::Request(offline_message(bus, ask.drive))))
        }
        _ if sched.writes_waiting() >= MAX_WAITING_WRITES => {
            Some(Err(ClientError::Request(format!(
                "bus {} already has {MAX_WAITING_WRITES} jobs waiting: nothing was sent; try again later",
                bus.name
            ))))
        }
        _ => None,
    };
    if let Some(answer) = now {
        let _ = ask.reply.send(answer);
        return;
    }
    if let AskOp::Control(op) = &ask.op {
        let op = op.clone();
        return control::take(ask, op, bus, f.family, driven);
    }
    let (read, write) = sched.wire_times();
    let wire = match &ask.op {
        AskOp::Write(..) => write,
        // The identification reads a few parameters (device type, firmware, …).
        AskOp::Identify => read * 4,
        _ => read,
    };
    let (drive, received, max_age) = (ask.drive, ask.received, ask.max_age);
    sched.push_job(drive, received, max_age, wire, Pending::Ask(ask));
}

/// What writing `raw` to the link setting `t` of `drive` does, said for the page: the family's
/// words for the change and what it means for the gateway, which keeps talking over its config.
fn link_change_text<B: BusAccess>(
    bus: &Bus,
    drive: DriveIx,
    access: &mut B,
    t: &Target,
    raw: i64,
) -> String {
    let Some(d) = bus.drives.get(drive) else {
        return String::new();
    };
    let change = access.client(d.address).link_change(t, raw);
    format!(
        "{change}; the gateway keeps talking to {} as the config of bus {} says, so the drive may \
         show timeout until the config is changed to match",
        d.name, bus.name
    )
}

/// Run one ask on the drive's client.
async fn run_ask<B: BusAccess>(
    access: &mut B,
    bus: &Bus,
    drive: DriveIx,
    op: AskOp,
) -> Result<Answer, ClientError> {
    let Some(d) = bus.drives.get(drive) else {
        return Err(ClientError::Request(format!("no drive {drive}")));
    };
    let mut client = access.page_client(d.address);
    match op {
        AskOp::Facts => Ok(Answer::Facts(facts_of(&client))),
        AskOp::LinkChange(t, raw) => Ok(Answer::Text(client.link_change(&t, raw))),
        AskOp::DriveKey => client.drive_key().await.map(Answer::Text),
        AskOp::Read(t) => client.read(&t).await.map(Answer::Raw),
        AskOp::Write(t, raw, persistence) => client
            .write(&t, raw, persistence)
            .await
            .map(|()| Answer::Done),
        AskOp::Identify => client.identify().await.map(Answer::Identity),
        // Taken at once ([`take_ask`]), never queued.
        AskOp::Control(_) => Err(ClientError::Request(
            "a control request is no transaction".to_owned(),
        )),
    }
}

/// Run one read job.
async fn run_job<B: BusAccess>(
    access: &mut B,
    bus: &Bus,
    job: Job,
    page: Option<&mut control::Driven>,
) -> Result<Read, ClientError> {
    let Some(drive) = bus.drives.get(job.drive()) else {
        return Err(ClientError::Request(format!("no drive {}", job.drive())));
    };
    match job {
        Job::Poll { point, .. } => {
            let Some(p) = drive.points.get(point) else {
                return Err(ClientError::Request(format!("no point {point}")));
            };
            access
                .client(drive.address)
                .read(&p.target)
                .await
                .map(Read::Value)
        }
        Job::ProcessData { .. } => {
            let out = drive
                .process_data
                .as_ref()
                .map_or(&[][..], |pd| pd.out.as_slice());
            let words = match page {
                Some(d) => control::cycle(access, bus, job.drive(), drive.address, out, d).await?,
                None => access.process_data(drive.address, out).await?,
            };
            let fault = access.fault_in_inputs(drive.address, &words);
            Ok(Read::ProcessData(words, fault))
        }
        Job::Status { .. } | Job::Probe { .. } | Job::Write { .. } => {
            access.fault(drive.address).await.map(Read::Fault)
        }
    }
}

impl Out<'_> {
    fn drive_name(&self, drive: DriveIx) -> &str {
        self.bus.drives.get(drive).map_or("?", |d| d.name.as_str())
    }

    /// Report a job's result; false when the gateway is stopping.
    async fn job_done(
        &mut self,
        sched: &mut Scheduler<Pending>,
        job: Job,
        started: Instant,
        result: Result<Read, ClientError>,
    ) -> bool {
        let now = Instant::now();
        let drive = job.drive();
        let label = match &result {
            Ok(_) => "ok",
            Err(ClientError::Device(_)) => "device_error",
            Err(ClientError::Request(_)) => "not_sent",
            Err(_) => "timeout",
        };
        self.metrics.transaction(
            &self.bus.name,
            self.drive_name(drive),
            job.op(self.bus).label(),
            label,
            now.saturating_duration_since(started),
        );
        let outcome = match &result {
            // A request the client could not build was not sent: the drive is not offline.
            Ok(_) | Err(ClientError::Device(_) | ClientError::Request(_)) => Outcome::Answered,
            Err(_) => Outcome::NoAnswer,
        };
        let change = sched.done(job, now, outcome);
        let at = SystemTime::now();
        match result {
            Ok(Read::Value(raw)) => {
                if let Job::Poll { point, .. } = job {
                    self.send(Update::Value {
                        bus: self.ix.get(),
                        drive,
                        point,
                        raw,
                        at,
                    });
                }
                self.answered(drive).await
            }
            Ok(Read::ProcessData(words, fault)) => {
                self.send(Update::ProcessData {
                    bus: self.ix.get(),
                    drive,
                    words,
                    at,
                });
                // A fault the input words show is reported at once (an F47 SBus timeout at
                // the next cycle, not at the next status read).
                match fault {
                    Some(f) => {
                        self.set_status(drive, f.map_or(DriveStatus::Online, DriveStatus::Fault))
                            .await
                    }
                    None => self.answered(drive).await,
                }
            }
            Ok(Read::Fault(fault)) => {
                let status = fault.map_or(DriveStatus::Online, DriveStatus::Fault);
                self.set_status(drive, status).await
            }
            Err(e @ (ClientError::Device(_) | ClientError::Request(_))) => {
                if let Job::Poll { point, .. } = job
                    && self.refused.insert((drive, point))
                {
                    tracing::warn!(
                        bus = %self.bus.name,
                        drive = %self.drive_name(drive),
                        point = %self.bus.drives.get(drive).and_then(|d| d.points.get(point)).map_or("?", |p| p.name.as_str()),
                        "{} the poll: {e} (logged once)",
                        if matches!(e, ClientError::Device(_)) { "the drive refuses" } else { "nothing was sent for" }
                    );
                }
                self.answered(drive).await
            }
            Err(e) => {
                if change == Some(Change::WentOffline) {
                    tracing::warn!(
                        bus = %self.bus.name,
                        drive = %self.drive_name(drive),
                        "drive does not answer ({e}{}): status timeout; probing it after a back-off",
                        echo_hint(&e)
                    );
                    return self.set_status(drive, DriveStatus::Timeout).await;
                }
                true
            }
        }
    }

    /// Report the end of a transaction the page asked for; false when the gateway is stopping.
    async fn ask_done(
        &mut self,
        sched: &mut Scheduler<Pending>,
        drive: DriveIx,
        op: &AskOp,
        started: Instant,
        result: &Result<Answer, ClientError>,
    ) -> bool {
        let now = Instant::now();
        let label = match result {
            Ok(_) => "ok",
            Err(ClientError::Device(_)) => "device_error",
            Err(ClientError::Request(_)) => "not_sent",
            Err(_) => "timeout",
        };
        let op_label = if matches!(op, AskOp::Write(..)) {
            "write"
        } else {
            "read"
        };
        self.metrics.transaction(
            &self.bus.name,
            self.drive_name(drive),
            op_label,
            label,
            now.saturating_duration_since(started),
        );
        let answered = match result {
            Ok(_) | Err(ClientError::Device(_) | ClientError::Request(_)) => Outcome::Answered,
            Err(_) => Outcome::NoAnswer,
        };
        let change = sched.done(Job::Write { drive }, now, answered);
        if change == Some(Change::WentOffline) {
            tracing::warn!(
                bus = %self.bus.name,
                drive = %self.drive_name(drive),
                "drive does not answer a request of the page: status timeout; probing it after a back-off"
            );
            return self.set_status(drive, DriveStatus::Timeout).await;
        }
        if answered == Outcome::Answered {
            return self.answered(drive).await;
        }
        true
    }

    /// Report a write's end; false when the gateway is stopping.
    async fn write_done(
        &mut self,
        sched: &mut Scheduler<Pending>,
        drive: DriveIx,
        point: usize,
        started: Instant,
        outcome: &SetOutcome,
        answered: Outcome,
    ) -> bool {
        let now = Instant::now();
        let label = match outcome {
            SetOutcome::Written { .. } | SetOutcome::Refused { .. } => "ok",
            SetOutcome::DeviceRefused { .. } => "device_error",
            SetOutcome::LinkFailed { .. } => "timeout",
        };
        self.metrics.transaction(
            &self.bus.name,
            self.drive_name(drive),
            "write",
            label,
            now.saturating_duration_since(started),
        );
        let change = sched.done(Job::Write { drive }, now, answered);
        if let SetOutcome::Written { raw, .. } = outcome {
            self.send(Update::Value {
                bus: self.ix.get(),
                drive,
                point,
                raw: *raw,
                at: SystemTime::now(),
            });
        }
        if change == Some(Change::WentOffline) {
            tracing::warn!(
                bus = %self.bus.name,
                drive = %self.drive_name(drive),
                "drive does not answer during a write: status timeout; probing it after a back-off"
            );
            return self.set_status(drive, DriveStatus::Timeout).await;
        }
        if answered == Outcome::Answered {
            return self.answered(drive).await;
        }
        true
    }

    /// The drive answered something that says nothing about its fault: online unless known.
    async fn answered(&mut self, drive: DriveIx) -> bool {
        match self.status.get(drive) {
            Some(None | Some(DriveStatus::Timeout)) => {
                self.set_status(drive, DriveStatus::Online).await
            }
            _ => true,
        }
    }

    /// Report every drive's status known again (asked by the gateway); false when the gateway
    /// is stopping.
    async fn announce(&mut self) -> bool {
        for drive in 0..self.status.len() {
            let Some(status) = self.status.get(drive).cloned().flatten() else {
                continue;
            };
            if !self.report_status(drive, status).await {
                return false;
            }
        }
        true
    }

    /// Report `status` of `drive`; false when the gateway is stopping. A status is never
    /// dropped: wait for room, then read the bus's index (a reload that moved it while this
    /// task waited has its notice in the queue before this status).
    async fn report_status(&self, drive: DriveIx, status: DriveStatus) -> bool {
        let Ok(permit) = self.updates.reserve().await else {
            return false;
        };
        permit.send(Update::Status {
            bus: self.ix.get(),
            drive,
            status,
            at: SystemTime::now(),
        });
        true
    }

    /// Report `status` if it is new; false when the gateway is stopping.
    async fn set_status(&mut self, drive: DriveIx, status: DriveStatus) -> bool {
        let Some(slot) = self.status.get_mut(drive) else {
            return true;
        };
        if slot.as_ref() == Some(&status) {
            return true;
        }
        let was_timeout = *slot == Some(DriveStatus::Timeout);
        *slot = Some(status.clone());
        let name = self.drive_name(drive).to_owned();
        if was_timeout {
            tracing::info!(bus = %self.bus.name, drive = %name, state = status.state(), "drive answers again");
        }
        if let DriveStatus::Fault(text) = &status {
            tracing::warn!(bus = %self.bus.name, drive = %name, "drive in fault: {text}{}", fault_hint(text));
        }
        self.metrics
            .drive_status(&self.bus.name, &name, status.state());
        self.report_status(drive, status).await
    }

    /// Report a value; dropped (and logged) when the MQTT task is that far behind — the next
    /// poll brings it again.
    fn send(&self, u: Update) {
        if let Err(mpsc::error::TrySendError::Full(_)) = self.updates.try_send(u) {
            tracing::debug!(bus = %self.bus.name, "update queue full: a value was dropped");
        }
    }

    fn figures<B: BusAccess>(&mut self, sched: &Scheduler<Pending>, access: &mut B, now: Instant) {
        let tally = access.take_tally();
        self.retries += tally.retries;
        if tally.retries > 0 {
            self.metrics.retries(&self.bus.name, tally.retries);
        }
        for (reason, n) in &tally.rejected {
            self.metrics.rejected(&self.bus.name, reason, *n);
        }
        let mut figures = sched.figures(now);
        figures.retries = self.retries;
        self.metrics
            .utilisation(&self.bus.name, figures.utilisation, figures.demand);
        self.send(Update::Figures {
            bus: self.ix.get(),
            figures,
        });
    }
}

/// A client that remembers the last error of the drive or the link, so that a write's
/// failure is told apart (the tool layer's errors are for a person).
struct Watched<C> {
    inner: C,
    error: Option<ClientError>,
}

impl<C: ParamClient> Watched<C> {
    fn keep<T>(&mut self, r: Result<T, ClientError>) -> Result<T, ClientError> {
        r.inspect_err(|e| {
            self.error = Some(e.clone());
        })
    }
}

impl<C: ParamClient> ParamClient for Watched<C> {
    fn family(&self) -> drive_profile::Family {
        self.inner.family()
    }
    async fn drive_key(&mut self) -> Result<String, ClientError> {
        let r = self.inner.drive_key().await;
        self.keep(r)
    }
    fn link_settings(&self) -> &'static [u16] {
        self.inner.link_settings()
    }
    fn link_change(&self, target: &Target, raw: i64) -> String {
        self.inner.link_change(target, raw)
    }
    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        self.inner.follow_link_change(target, raw)
    }
    fn not_restored(&self) -> &'static [u16] {
        self.inner.not_restored()
    }
    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        let r = self.inner.read(target).await;
        self.keep(r)
    }
    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        let r = self.inner.write(target, raw, persistence).await;
        self.keep(r)
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        let r = self.inner.identify().await;
        self.keep(r)
    }
}

/// A refusal of the write path as an outcome, with the gateway's way out where there is one
/// (its config keys, never a command-line option).
fn refusal_of(e: &WriteError) -> SetOutcome {
    let (reason, message) = write_refusal(
        e,
        "writes of this point go to EEPROM (eeprom = true in the config): write less often, or \
         list it without eeprom for RAM writes",
        "give the gateway a writable DRIVECTL_STATE_DIR (the systemd unit's StateDirectory), or \
         list the point without eeprom for RAM writes",
    );
    SetOutcome::Refused { reason, message }
}

/// The reason code (as the `set` results and the page name them) and the message of a refusal
/// of the write path; `wear` and `no_log` are the front end's way out of an EEPROM write too
/// soon after the last and of a wear log that cannot be kept.
pub(crate) fn write_refusal(e: &WriteError, wear: &str, no_log: &str) -> (&'static str, String) {
    match e {
        WriteError::Width(_) => ("width", e.to_string()),
        WriteError::Guard { error, message } => match error {
            GuardError::DoesNotFit { .. } => ("width", message.clone()),
            GuardError::ReadOnly { .. } => ("access", message.clone()),
            GuardError::OutOfRange { .. } => ("range", message.clone()),
            GuardError::NotInValueList { .. } => ("value_list", message.clone()),
            GuardError::TooFrequent { .. } => ("wear", format!("{message}; {wear}")),
            _ => ("refused", message.clone()),
        },
        // The EEPROM-wear log cannot be kept: the rule would be off.
        WriteError::WearLog(w) => ("wear", format!("{w}; {no_log}")),
        WriteError::NotInTable { .. } | WriteError::LinkSetting { .. } => ("access", e.to_string()),
        _ => ("refused", e.to_string()),
    }
}

/// Check, write and read back `raw` to `point` of `drive`: the outcome, and whether the drive
/// answered.
async fn write_point<B: BusAccess>(
    access: &mut B,
    bus: &Bus,
    drive: DriveIx,
    point: usize,
    raw: i64,
) -> (SetOutcome, Outcome) {
    let Some(d) = bus.drives.get(drive) else {
        let message = format!("no drive number {drive}");
        return (
            SetOutcome::Refused {
                reason: "bad_request",
                message,
            },
            Outcome::Answered,
        );
    };
    let Some(p) = d.points.get(point) else {
        let message = format!("no point number {point}");
        return (
            SetOutcome::Refused {
                reason: "bad_request",
                message,
            },
            Outcome::Answered,
        );
    };
    let target = p.target;
    let refused = |reason, message| (SetOutcome::Refused { reason, message }, Outcome::Answered);
    if target.param.is_none() {
        return refused(
            "access",
            format!(
                "{} is not in the {} parameter table: the gateway writes only parameters the table describes; nothing was sent",
                target.label(),
                target.family
            ),
        );
    }
    let persistence = if p.eeprom {
        Persistence::NonVolatile
    } else {
        Persistence::Volatile
    };
    let req = WriteRequest {
        target,
        raw,
        persistence,
        force: false,
    };
    let mut client = Watched {
        inner: access.client(d.address),
        error: None,
    };
    if client.link_settings().contains(&target.index) {
        return refused(
            "access",
            format!(
                "{} is a setting of the link the gateway talks over (address, baud rate, timeout): the gateway does not write it; nothing was sent",
                target.label()
            ),
        );
    }
    let (bus_name, drive_name) = (&bus.name, &d.name);
    let mut warn = |w: &str| {
        tracing::warn!(bus = %bus_name, drive = %drive_name, point = %p.name, "{w}");
    };
    let log = drive_client::FileWearLog::from_env();
    let result = drive_client::write::write_checked(&mut client, &req, false, &log, &mut warn)
        .await
        .map(|w| (w.back, w.differs.map(|d| (w.sent, d))));
    match (result, client.error.take()) {
        (Ok((back, differs)), _) => (
            SetOutcome::Written { raw: back, differs },
            Outcome::Answered,
        ),
        (Err(e), Some(ClientError::Device(_))) => (
            SetOutcome::DeviceRefused {
                message: e.to_string(),
            },
            Outcome::Answered,
        ),
        (Err(e), Some(_)) => (
            SetOutcome::LinkFailed {
                message: e.to_string(),
            },
            Outcome::NoAnswer,
        ),
        (Err(e), None) => (refusal_of(&e), Outcome::Answered),
    }
}

/// A scripted bus for the gateway's tests: drives that answer after their wire time on
/// tokio's clock, drives that are dead (each attempt waits the timeout), and a record of every
/// transaction.
/// The page's control of a drive over process data.
pub mod control;

#[cfg(test)]
pub(crate) mod fake;

#[cfg(test)]
mod tests;

/// Whatever a `set` carries, converting it to a raw value never panics and never yields a
/// value outside the parameter's bus width.
#[cfg(test)]
mod set_value_props;
