//! What the page does with one drive beyond its live values: read parameters on demand, check
//! and write them through the write guard, back the drive up, plan and run a restore, read its
//! fault memory.
//!
//! Every transaction goes to the drive's bus task as an [`Ask`]: the bus task runs it between
//! its polls (as it runs a `set`), counts its wire time and refuses it when the drive is offline
//! or the bus has too much waiting. The work itself is `drive-client`'s, the same as the
//! command line's: [`Remote`] is a [`ParamClient`] whose every call is one such ask, so a
//! backup from the page is the `drivebus-backup` v1 file `drivectl … backup` writes, and a
//! write passes the same guard.
//!
//! The jobs run on the gateway's thread (`drive-client`'s futures are not `Send`), in tasks the
//! [`Worker`] starts; a long job streams its progress to the page as JSON lines and stops
//! between two transactions when the page goes away.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use drive_client::backup::{self, BackupFile};
use drive_client::interrupt::{Cause, Interrupt};
use drive_client::progress::{Notice, Phase, Progress};
use drive_client::target::{Target, ValueText};
use drive_client::write::{WriteError, WriteRequest};
use drive_client::{ClientError, FileWearLog, ParamClient};
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value, json};
use tokio::sync::{mpsc, oneshot};

use crate::model::{Answer, Ask, AskOp, DriveIx, Facts};
use crate::mqtt::payload;

/// A job the page asks for, run on the gateway's thread: made where the request is taken
/// (`Send`), run where the bus clients live.
pub type Job = Box<dyn FnOnce() -> Pin<Box<dyn Future<Output = ()>>> + Send>;

/// Where the page's handlers hand their jobs.
#[derive(Debug, Clone)]
pub struct Jobs(mpsc::UnboundedSender<Job>);

impl Jobs {
    /// Run `job` on the gateway's thread; false when the gateway is stopping.
    pub fn run(&self, job: Job) -> bool {
        self.0.send(job).is_ok()
    }
}

/// Runs the page's jobs, each in its own task, until the page's handlers are gone.
#[derive(Debug)]
pub struct Worker(mpsc::UnboundedReceiver<Job>);

impl Worker {
    /// Take jobs until every [`Jobs`] is dropped. Must run on a `LocalSet`.
    pub async fn run(mut self) {
        while let Some(job) = self.0.recv().await {
            crate::tasks::spawn_local(job());
        }
    }
}

/// A pair of ends: handlers hand jobs to [`Jobs`], [`Worker::run`] runs them.
pub fn jobs() -> (Jobs, Worker) {
    let (tx, rx) = mpsc::unbounded_channel();
    (Jobs(tx), Worker(rx))
}

/// One drive of the plant as a [`ParamClient`]: every call is an [`Ask`] to its bus task.
#[derive(Debug)]
pub struct Remote {
    asks: mpsc::Sender<Ask>,
    drive: DriveIx,
    facts: Facts,
    max_age: Duration,
    /// What writing a link setting does, asked before the write (the trait's
    /// [`ParamClient::link_change`] cannot ask the bus task itself).
    link_text: Option<String>,
}

/// The bus task is gone (the gateway stops).
fn stopping() -> ClientError {
    ClientError::Request("the gateway is stopping: nothing was sent".into())
}

async fn ask(
    asks: &mpsc::Sender<Ask>,
    drive: DriveIx,
    max_age: Duration,
    op: AskOp,
) -> Result<Answer, ClientError> {
    let (reply, answer) = oneshot::channel();
    let a = Ask {
        drive,
        op,
        received: tokio::time::Instant::now(),
        max_age,
        reply,
    };
    asks.send(a).await.map_err(|_| stopping())?;
    answer.await.map_err(|_| stopping())?
}

fn unexpected() -> ClientError {
    ClientError::Request("the bus task answered another question".into())
}

impl Remote {
    /// The client of drive `drive` of the bus whose task takes `asks`; a request waits at most
    /// `max_age` for the bus.
    pub async fn connect(
        asks: mpsc::Sender<Ask>,
        drive: DriveIx,
        max_age: Duration,
    ) -> Result<Remote, ClientError> {
        match ask(&asks, drive, max_age, AskOp::Facts).await? {
            Answer::Facts(facts) => Ok(Remote {
                asks,
                drive,
                facts,
                max_age,
                link_text: None,
            }),
            _ => Err(unexpected()),
        }
    }

    async fn ask(&self, op: AskOp) -> Result<Answer, ClientError> {
        ask(&self.asks, self.drive, self.max_age, op).await
    }

    /// What the drive's client knows without asking it.
    pub fn facts(&self) -> &Facts {
        &self.facts
    }

    /// What writing `raw` to the link setting `target` does, for the page.
    pub async fn link_change_text(&self, target: &Target, raw: i64) -> String {
        match self.ask(AskOp::LinkChange(*target, raw)).await {
            Ok(Answer::Text(t)) => t,
            _ => format!(
                "writing {raw} to {} changes how the drive is reached",
                target.label()
            ),
        }
    }
}

impl ParamClient for Remote {
    fn family(&self) -> Family {
        self.facts.family
    }
    async fn drive_key(&mut self) -> Result<String, ClientError> {
        match self.ask(AskOp::DriveKey).await? {
            Answer::Text(k) => Ok(k),
            _ => Err(unexpected()),
        }
    }
    fn link_settings(&self) -> &'static [u16] {
        self.facts.link_settings
    }
    fn link_change(&self, target: &Target, raw: i64) -> String {
        self.link_text.clone().unwrap_or_else(|| {
            format!(
                "writing {raw} to {} changes how the drive is reached",
                target.label()
            )
        })
    }
    fn not_restored(&self) -> &'static [u16] {
        self.facts.not_restored
    }
    fn device(&self) -> drive_client::meaning::Device {
        self.facts.device
    }
    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        match self.ask(AskOp::Read(*target)).await? {
            Answer::Raw(r) => Ok(r),
            _ => Err(unexpected()),
        }
    }
    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        match self.ask(AskOp::Write(*target, raw, persistence)).await? {
            Answer::Done => Ok(()),
            _ => Err(unexpected()),
        }
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        match self.ask(AskOp::Identify).await? {
            Answer::Identity(m) => Ok(m),
            _ => Err(unexpected()),
        }
    }
}

/// A parameter of `family` as the page names it: its bus index and sub-index (`8470.0`).
pub fn target_of(family: Family, key: &str) -> Option<Target> {
    let (index, sub): (u16, u16) = match key.split_once('.') {
        Some((i, s)) => (i.trim().parse().ok()?, s.trim().parse().ok()?),
        None => (key.trim().parse().ok()?, 0),
    };
    // The backup's rows hold every sub-index (data sets, array elements, parameter sets).
    if let Some(t) = backup::rows(family)
        .into_iter()
        .find(|t| t.index == index && t.sub == sub)
    {
        return Some(t);
    }
    drive_profile::family::params(family)
        .map(Target::of)
        .find(|t| t.index == index && t.sub == sub)
}

/// The page's key of `t`.
pub fn key_of(t: &Target) -> String {
    format!("{}.{}", t.index, t.sub)
}

/// The sub-index the page reads and writes a table parameter at: a Bonfiglioli data-set
/// parameter at data set 1 (data set 0 stands for all four), else the table's.
pub fn page_sub(p: drive_profile::family::AnyParam) -> u16 {
    if p.access().contains(drive_profile::Access::DATA_SET) {
        1
    } else {
        p.sub_index().unwrap_or(0)
    }
}

/// A value read for the page: the live event's payload (value, unit, meaning, raw, time).
pub fn value_of(t: &Target, raw: i64, facts: &Facts) -> Value {
    payload::value_json(
        t,
        raw,
        payload::millis(std::time::SystemTime::now()),
        &facts.device,
    )
}

/// A failed transaction for the page: `{"reason", "message"}` (`device`: the drive refused,
/// `link`: no answer or a garbled one, `not_sent`).
pub fn error_json(e: &ClientError) -> Value {
    let reason = match e {
        ClientError::Device(_) => "device",
        ClientError::Link(_) => "link",
        _ => "not_sent",
    };
    json!({"reason": reason, "message": e.to_string()})
}

/// The lines a long job streams to the page.
#[derive(Debug, Clone)]
pub struct Lines(mpsc::UnboundedSender<String>);

impl Lines {
    /// A stream's two ends: the job writes [`Lines`], the answer's body reads the receiver.
    pub fn new() -> (Lines, mpsc::UnboundedReceiver<String>) {
        let (tx, rx) = mpsc::unbounded_channel();
        (Lines(tx), rx)
    }

    /// Send one JSON line.
    pub fn send(&self, v: &Value) {
        let _ = self.0.send(format!("{v}\n"));
    }

    /// Whether the page stopped reading (it closed, reloaded or lost its connection).
    pub fn gone(&self) -> bool {
        self.0.is_closed()
    }
}

/// The cause a job stops for when its page goes away.
fn page_gone() -> Cause {
    Cause {
        name: "the page going away".into(),
        code: 0,
    }
}

/// Progress as JSON lines: `{"type":"progress","phase","done","of"}` at the start, after each
/// step and at the end of each phase; notices as `{"type":"notice","text"}`. Before each step
/// it looks whether the page still reads: if not, it raises `stop`, which the job checks before
/// its next transaction.
#[derive(Debug)]
pub struct LineProgress {
    lines: Lines,
    stop: Interrupt,
    phase: &'static str,
    done: usize,
    of: usize,
}

impl LineProgress {
    /// Progress onto `lines`, raising `stop` when the page is gone.
    pub fn new(lines: Lines, stop: Interrupt) -> Self {
        LineProgress {
            lines,
            stop,
            phase: "",
            done: 0,
            of: 0,
        }
    }

    fn say(&self) {
        self.lines.send(&json!({
            "type": "progress", "phase": self.phase, "done": self.done, "of": self.of,
        }));
    }
}

fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Reading => "reading",
        Phase::Writing => "writing",
        Phase::Verifying => "verifying",
        _ => "working",
    }
}

impl Progress for LineProgress {
    fn start(&mut self, phase: Phase, steps: usize) {
        self.phase = phase_name(phase);
        self.done = 0;
        self.of = steps;
        self.say();
    }
    fn step(&mut self, _: &Target) {
        if self.lines.gone() {
            self.stop.raise(page_gone());
        }
    }
    fn done(&mut self) {
        self.done += 1;
        self.say();
    }
    fn notice(&mut self, notice: &Notice) {
        let text = match notice {
            Notice::Warning(w) => w.clone(),
            other => format!("{other:?}"),
        };
        self.lines.send(&json!({"type": "notice", "text": text}));
    }
}

/// Read `targets` one by one: a `{"type":"value","key","payload"}` or
/// `{"type":"error","key","reason","message"}` line each, with progress, then
/// `{"type":"end","read","failed"}`. Stops when the page goes away.
pub async fn read_all(client: &mut Remote, targets: Vec<Target>, lines: Lines) {
    let mut progress = LineProgress::new(lines.clone(), Interrupt::new());
    progress.start(Phase::Reading, targets.len());
    let (mut read, mut failed) = (0usize, 0usize);
    for t in &targets {
        if lines.gone() {
            return;
        }
        match client.read(t).await {
            Ok(raw) => {
                read += 1;
                let v = value_of(t, raw, client.facts());
                let mut o = json!({"type": "value", "payload": v});
                named(&mut o, t);
                lines.send(&o);
            }
            Err(e) => {
                failed += 1;
                let mut o = error_json(&e);
                if let Some(m) = o.as_object_mut() {
                    m.insert("type".into(), "error".into());
                }
                named(&mut o, t);
                lines.send(&o);
                // A drive that stopped answering answers no further read either.
                if matches!(e, ClientError::Link(_)) {
                    break;
                }
            }
        }
        progress.done();
    }
    lines.send(&json!({"type": "end", "read": read, "failed": failed}));
}

/// Put the key, label and names of `t` into the object `o` (several table rows share one bus
/// index: the line says which was read).
fn named(o: &mut Value, t: &Target) {
    if let Some(m) = o.as_object_mut() {
        m.insert("key".into(), key_of(t).into());
        m.insert("label".into(), t.label().into());
        m.insert("name_en".into(), t.param.map(|p| p.name_en()).into());
        m.insert("name_de".into(), t.param.map(|p| p.name_de()).into());
    }
}

/// A write as the page asks for it.
#[derive(Debug, Clone, serde::Deserialize)]
pub struct WriteAsk {
    /// The parameter ([`target_of`]).
    pub key: String,
    /// The value in the parameter's unit or a value name, as typed.
    pub value: String,
    /// Write to EEPROM too (else RAM only).
    #[serde(default)]
    pub eeprom: bool,
    /// The person confirmed what writing a link setting does.
    #[serde(default)]
    pub confirm: bool,
}

/// What the guard says of a write before anything is sent, as the page shows it:
/// `{"ok", "raw", "value", "unit", "warning", "link_change", "reason", "message", "nearest"}`.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The request, when the value converts and the guard lets it pass.
    pub request: Option<WriteRequest>,
    /// The page's JSON.
    pub json: Value,
}

/// Check `ask` for the drive of `client` without writing anything: the value's conversion
/// (range, resolution with the nearest value, value list, width), the guard (access, EEPROM
/// wear), and whether it is a link setting (then what the write would do).
pub async fn check(client: &mut Remote, ask: &WriteAsk) -> Checked {
    let refused = |reason: &str, message: String, extra: Option<(&str, Value)>| {
        let mut o = json!({"ok": false, "reason": reason, "message": message});
        if let (Some((k, v)), Some(m)) = (extra, o.as_object_mut()) {
            m.insert(k.into(), v);
        }
        Checked {
            request: None,
            json: o,
        }
    };
    let Some(target) = target_of(client.family(), &ask.key) else {
        return refused(
            "bad_request",
            format!("{} has no parameter {}", client.family(), ask.key),
            None,
        );
    };
    let Some(param) = target.param else {
        return refused(
            "access",
            format!(
                "{} is not in the table: the page writes only what the table describes",
                target.label()
            ),
            None,
        );
    };
    let text = ask.value.trim();
    if text.is_empty() || text.chars().count() > 64 {
        return refused(
            "bad_request",
            "give a value (at most 64 characters)".into(),
            None,
        );
    }
    let raw = match target.value_from_text(text, &ValueText::default()) {
        Ok(p) => p.raw,
        Err(e) => {
            use drive_client::target::ValueError;
            let (reason, nearest) = match &e {
                ValueError::NotInSelection { .. } => ("value_list", None),
                ValueError::OutOfRange { .. } => ("range", None),
                ValueError::NotExact { .. } => {
                    let near = drive_client::text::parse_decimal(text)
                        .and_then(|x| param.from_physical(x).ok())
                        .map(|r| drive_client::text::physical_text(param, r));
                    ("resolution", near)
                }
                ValueError::PastWidth { .. }
                | ValueError::Width { .. }
                | ValueError::WidthRaw { .. } => ("width", None),
                _ => ("bad_request", None),
            };
            return refused(
                reason,
                e.to_string(),
                nearest.map(|n| ("nearest", Value::from(n))),
            );
        }
    };
    let persistence = if ask.eeprom {
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
    // The wear rule needs the drive's key (its log entry), only for an EEPROM write.
    let key = if ask.eeprom {
        match client.drive_key().await {
            Ok(k) => k,
            Err(e) => return refused("link", e.to_string(), None),
        }
    } else {
        String::new()
    };
    let log = FileWearLog::from_env();
    let warning = match drive_client::write::check(&key, &req, &log) {
        Ok(w) => w,
        Err(e) => {
            let (reason, message) = refusal(&e);
            return refused(reason, message, None);
        }
    };
    let link = client.link_settings().contains(&target.index);
    let link_change = if link {
        Some(client.link_change_text(&target, raw).await)
    } else {
        None
    };
    client.link_text.clone_from(&link_change);
    let mut o = payload::value_json(&target, raw, 0, &client.facts.device);
    if let Some(m) = o.as_object_mut() {
        m.remove("ts");
        m.insert("ok".into(), true.into());
        m.insert("key".into(), key_of(&target).into());
        m.insert("label".into(), target.label().into());
        m.insert("eeprom".into(), ask.eeprom.into());
        m.insert("warning".into(), warning.into());
        m.insert("link_change".into(), link_change.into());
    }
    Checked {
        request: Some(req),
        json: o,
    }
}

/// A refusal of the write path in the page's words: the reason code (as the gateway's `set`
/// results name them) and the message.
pub fn refusal(e: &WriteError) -> (&'static str, String) {
    match e {
        WriteError::LinkSetting { label, change } => (
            "confirm",
            format!(
                "{label} is a setting of the link the gateway talks over: {change}; confirm to \
                 write it"
            ),
        ),
        WriteError::Client {
            error: ClientError::Device(_),
            ..
        } => ("device", e.to_string()),
        WriteError::Client { .. } | WriteError::Key(_) => ("link", e.to_string()),
        WriteError::ReadBack { .. } => ("read_back", e.to_string()),
        _ => crate::task::write_refusal(
            e,
            "write to RAM only, or wait before the next EEPROM write",
            "the gateway needs a writable DRIVECTL_STATE_DIR to keep the EEPROM-wear rule: write \
             to RAM only",
        ),
    }
}

/// Check and write `ask`, then read it back: `{"outcome":"written","payload","differs",
/// "link_note"}` or `{"outcome":"refused","reason","message"}`.
pub async fn write(client: &mut Remote, ask: &WriteAsk) -> Value {
    let checked = check(client, ask).await;
    let Some(req) = checked.request else {
        let mut o = checked.json;
        if let Some(m) = o.as_object_mut() {
            m.insert("outcome".into(), "refused".into());
        }
        return o;
    };
    let log = FileWearLog::from_env();
    let mut warnings = Vec::new();
    let mut warn = |w: &str| warnings.push(w.to_owned());
    let result =
        drive_client::write::write_checked(client, &req, ask.confirm, &log, &mut warn).await;
    match result {
        Ok(w) => json!({
            "outcome": "written",
            "key": key_of(&req.target),
            "payload": value_of(&req.target, w.back, client.facts()),
            "sent_raw": w.sent,
            "differs": w.differs,
            "link_note": w.link_note,
            "warnings": warnings,
        }),
        Err(e) => {
            let (reason, message) = refusal(&e);
            // Nothing was sent for any refusal but a failed read-back or a failed link.
            let sent = matches!(reason, "read_back")
                || matches!(
                    &e,
                    WriteError::Client {
                        error: ClientError::Link(_),
                        ..
                    }
                );
            json!({"outcome": if sent { "unknown" } else { "refused" }, "reason": reason,
                   "message": message, "warnings": warnings})
        }
    }
}

/// Back the drive up: progress lines, then `{"type":"backup","file","complete","absent",
/// "unreadable"}` with the file's text, or `{"type":"error","message"}`.
pub async fn backup(client: &mut Remote, lines: Lines) {
    let stop = Interrupt::new();
    let mut progress = LineProgress::new(lines.clone(), stop.clone());
    match backup::backup(client, &mut progress, &stop).await {
        Ok(b) => match b.text() {
            Ok(text) => lines.send(&json!({
                "type": "backup", "file": text, "complete": b.is_complete(), "absent": b.absent,
                "unreadable": b.unreadable.iter().map(|(t, d)| json!({"label": t.label(), "message": d.message})).collect::<Vec<_>>(),
            })),
            Err(e) => lines.send(&json!({"type": "error", "message": e.to_string()})),
        },
        Err(e) => lines.send(&json!({"type": "error", "message": e.to_string()})),
    }
}

/// The plan of restoring `file` (a backup file's bytes): progress lines, then
/// `{"type":"plan","changes":[…],"refused":[…],"summary":{…}}`; with `apply`, the changes are
/// then written (if none is refused) and verified: `{"type":"written",…}` per change and
/// `{"type":"restored","report"}` or `{"type":"halted","report","message"}`.
/// Returns the outcome for the action log: `planned`, `refused`, `restored`, `halted` or
/// `failed`.
pub async fn restore(
    client: &mut Remote,
    file: Vec<u8>,
    name: String,
    apply: bool,
    lines: Lines,
) -> &'static str {
    use drive_client::restore;
    let stop = Interrupt::new();
    let front = drive_client::front::Plain;
    let fail = |m: String| {
        lines.send(&json!({"type": "error", "message": m}));
        "failed"
    };
    let loaded = match BackupFile::parse(
        &file,
        client.family(),
        client.not_restored(),
        client.link_settings(),
    ) {
        Ok(f) => f,
        Err(e) => return fail(format!("{name}: {e}")),
    };
    let log = FileWearLog::from_env();
    let mut progress = LineProgress::new(lines.clone(), stop.clone());
    let opts = restore::Options::default();
    let plan = match restore::plan(client, &loaded, &opts, &log, &mut progress, &stop).await {
        Ok(p) => p,
        Err(e) => return fail(e.to_string()),
    };
    let refused: Vec<String> = plan.refusals.iter().map(|r| refusal(r).1).collect();
    lines.send(&json!({
        "type": "plan",
        "changes": plan.changes.iter().map(restore::Change::to_json).collect::<Vec<_>>(),
        "refused": refused,
        "summary": plan.dry_run_json(&name, &refused, &front),
    }));
    if !apply {
        return "planned";
    }
    if !refused.is_empty() {
        fail(format!(
            "{} change(s) refused: nothing was written",
            refused.len()
        ));
        return "refused";
    }
    let applied = match restore::apply(client, &plan, &log, &mut progress, &stop).await {
        Ok(a) => a,
        Err(restore::RestoreError::Halted(h)) => {
            lines.send(
                &json!({"type": "halted", "report": h.report_json(&plan, &name, &front),
                               "message": h.state_text()}),
            );
            return "halted";
        }
        Err(e) => return fail(e.to_string()),
    };
    for c in &applied.written {
        let mut o = c.to_json();
        if let Some(m) = o.as_object_mut() {
            m.insert("type".into(), "written".into());
        }
        lines.send(&o);
    }
    match restore::verify(client, &plan, &mut progress, &stop).await {
        Ok(mismatches) => {
            lines.send(&json!({
                "type": "restored",
                "report": plan.report_json(&applied, &mismatches, &name, &front),
                "mismatches": mismatches.iter().map(restore::Mismatch::to_json).collect::<Vec<_>>(),
                "shortfalls": plan.shortfalls(&applied, &mismatches),
            }));
            "restored"
        }
        Err(e) => fail(e.to_string()),
    }
}

/// The parameters that show a drive's present fault and its fault memory, in the manual's
/// order: MOVIDRIVE P012 status word 1 and the fault memory P080–P084 (group 08, each with its
/// entries); NORD P700 [-01]–[-03] and P701 [-01]–[-05]; Bonfiglioli 260 current fault and 270
/// warnings (its Modbus manual describes no fault memory).
pub fn fault_targets(family: Family) -> Vec<Target> {
    match family {
        Family::Nord => backup::rows(family)
            .into_iter()
            .filter(|t| {
                t.param
                    .is_some_and(|p| matches!(p.number(), Some(700 | 701)))
                    && drive_client::target::nord_sub_parts(t.index, t.sub)
                        .1
                        .unwrap_or(1)
                        == 1
            })
            .collect(),
        Family::Bonfiglioli => ["260", "270"]
            .iter()
            .filter_map(|k| drive_profile::family::lookup(family, k))
            .map(Target::of)
            .collect(),
        _ => {
            let mut v: Vec<Target> = drive_profile::family::lookup(family, "P012")
                .map(Target::of)
                .into_iter()
                .collect();
            v.extend(
                drive_profile::family::params(family)
                    .map(Target::of)
                    .filter(|t| {
                        matches!(
                            t.label().get(..4),
                            Some("P080" | "P081" | "P082" | "P083" | "P084")
                        )
                    }),
            );
            v
        }
    }
}

/// The page's jobs need the drive's bus: `Err` for a bus or drive the plant does not have.
pub fn asks_for(
    asks: &Arc<[mpsc::Sender<Ask>]>,
    bus: usize,
    drive: usize,
    plant: &crate::config::Plant,
) -> Option<mpsc::Sender<Ask>> {
    plant.buses.get(bus)?.drives.get(drive)?;
    asks.get(bus).cloned()
}
