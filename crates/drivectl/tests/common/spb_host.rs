//! A Sparkplug B host application nobody here wrote, for tests: `tests/sparkplug/host.py`
//! (pysparkplug and paho-mqtt from PyPI) run as a process against a broker.
//!
//! [`SpbHost::start`] runs the host with the python of `target/sparkplug/venv`, which
//! `scripts/setup-sparkplug` makes (scripts/test and CI's tools job run it); the harness installs
//! nothing. Where the venv is missing, `start` fails the test under CI (the `CI` variable set and
//! not empty: a check that cannot run must not pass) with a message naming
//! `scripts/setup-sparkplug`; elsewhere it prints one `SKIPPED` line and returns `None`, as
//! `drivebus-gateway/tests/common/mosquitto.rs` does for the broker.
//!
//! Every line the host prints is read into a typed [`Event`] by a thread; the decoded Sparkplug
//! messages ([`Msg`]) are kept in order, and [`SpbHost::wait_for`] finds the first one since the
//! last [`SpbHost::mark`] that satisfies a predicate, waiting for it up to a timeout. Commands
//! (DCMD, NCMD, STATE, raw bytes, encode) go to the host's standard input as JSON lines; each is
//! answered in order, and the methods here wait for that answer.
//!
//! Include it with `#[path = "common/spb_host.rs"] mod spb_host;`; it needs only std, serde and
//! serde_json.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    // The one line saying why a test is skipped, and the host's log on a failure.
    clippy::print_stderr,
    dead_code
)]

use std::collections::VecDeque;
use std::io::{BufRead as _, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde::Deserialize;
use serde_json::{Value, json};

/// One metric of a decoded message, as pysparkplug decoded it.
#[derive(Debug, Clone, Deserialize)]
pub struct Metric {
    /// The name as it came on the wire; `None` for a metric sent by alias only.
    pub name: Option<String>,
    /// The name a host knows it by: the wire name, else the one its alias has in the last birth.
    pub birth_name: Option<String>,
    /// Its alias, when the message carried one.
    pub alias: Option<u64>,
    /// The Sparkplug datatype the value was decoded as (`"Int16"`, `"Double"`, `"String"`…).
    pub datatype: String,
    /// Whether the message itself carried the datatype (else it came from the birth).
    pub datatype_sent: bool,
    /// The value (bytes as hex, date-times as epoch milliseconds); `Null` when `is_null`.
    pub value: Value,
    /// The metric's `is_null` flag.
    pub is_null: bool,
    /// The metric's timestamp (epoch milliseconds).
    pub timestamp: Option<u64>,
    /// Its property set, each value decoded.
    pub properties: serde_json::Map<String, Value>,
    /// Each property's Sparkplug datatype.
    pub property_types: std::collections::BTreeMap<String, String>,
}

impl Metric {
    /// The name it is known by (wire or birth).
    pub fn known_name(&self) -> Option<&str> {
        self.birth_name.as_deref().or(self.name.as_deref())
    }

    /// The value as an integer (panics naming the metric if it is not one).
    pub fn int(&self) -> i64 {
        self.value
            .as_i64()
            .unwrap_or_else(|| panic!("{:?}: not an integer value: {self:?}", self.known_name()))
    }

    /// The value as an unsigned integer.
    pub fn uint(&self) -> u64 {
        self.value
            .as_u64()
            .unwrap_or_else(|| panic!("{:?}: not an unsigned value: {self:?}", self.known_name()))
    }

    /// The value as a number.
    pub fn float(&self) -> f64 {
        self.value
            .as_f64()
            .unwrap_or_else(|| panic!("{:?}: not a number: {self:?}", self.known_name()))
    }

    /// The value as text.
    pub fn text(&self) -> &str {
        self.value
            .as_str()
            .unwrap_or_else(|| panic!("{:?}: not text: {self:?}", self.known_name()))
    }

    /// The value as a boolean.
    pub fn boolean(&self) -> bool {
        self.value
            .as_bool()
            .unwrap_or_else(|| panic!("{:?}: not a boolean: {self:?}", self.known_name()))
    }

    /// The property `key` and its datatype, if present.
    pub fn property(&self, key: &str) -> Option<(&Value, &str)> {
        Some((
            self.properties.get(key)?,
            self.property_types.get(key)?.as_str(),
        ))
    }
}

/// A decoded Sparkplug message (NBIRTH, NDATA, NDEATH, DBIRTH, DDATA, DDEATH, NCMD, DCMD).
#[derive(Debug, Clone, Deserialize)]
pub struct Msg {
    /// The MQTT topic.
    pub topic: String,
    /// `"NBIRTH"`, `"DDATA"`…
    #[serde(rename = "type")]
    pub kind: String,
    /// The group id.
    pub group: String,
    /// The edge node id.
    pub node: String,
    /// The device id, for device messages.
    pub device: Option<String>,
    /// The payload's `seq` (none in an NDEATH).
    pub seq: Option<u64>,
    /// The seq the host expected from this edge node: 0 for an NBIRTH, the previous + 1 (mod
    /// 256) otherwise; `None` where it had nothing to go by (or for commands and NDEATH).
    pub expected_seq: Option<u64>,
    /// The payload's timestamp (epoch milliseconds).
    pub timestamp: Option<u64>,
    /// Whether the broker delivered it as retained.
    pub retained: bool,
    /// The metrics in payload order.
    pub metrics: Vec<Metric>,
}

impl Msg {
    /// The metric known by `name` (wire or birth name).
    pub fn metric(&self, name: &str) -> Option<&Metric> {
        self.metrics.iter().find(|m| m.known_name() == Some(name))
    }

    /// The metric known by `name`; panics listing the metrics there are.
    pub fn get(&self, name: &str) -> &Metric {
        self.metric(name).unwrap_or_else(|| {
            panic!(
                "{} has no metric {name:?}; it has {:?}",
                self.topic,
                self.metrics
                    .iter()
                    .map(Metric::known_name)
                    .collect::<Vec<_>>()
            )
        })
    }

    /// Whether this is a `kind` message of `device` (`None`: the node's own).
    pub fn is(&self, kind: &str, device: Option<&str>) -> bool {
        self.kind == kind && self.device.as_deref() == device
    }
}

/// The primary host's STATE message as the host decoded it.
#[derive(Debug, Clone, Deserialize)]
pub struct State {
    /// The MQTT topic (`spBv1.0/STATE/<host>`).
    pub topic: String,
    /// The host id.
    pub host: String,
    /// `online`.
    pub online: bool,
    /// `timestamp`.
    pub timestamp: u64,
    /// Whether the broker delivered it as retained.
    pub retained: bool,
}

/// One line the host printed.
#[derive(Debug, Clone)]
pub enum Event {
    /// Subscribed to the group's topics and to STATE.
    Ready,
    /// A Sparkplug message, decoded.
    Msg(Msg),
    /// A STATE message, decoded.
    State(State),
    /// A message the library could not decode, and its word on it.
    Undecodable {
        /// The topic.
        topic: String,
        /// The message type, where the topic gave one.
        kind: Option<String>,
        /// The library's error.
        error: String,
    },
    /// A command published these bytes on `topic`.
    Published {
        /// The topic.
        topic: String,
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// An `encode` command's bytes.
    Encoded(Vec<u8>),
    /// A command the host refused, and why.
    CommandError(String),
    /// The MQTT connection ended (paho's return code) or failed.
    Connection(Value),
}

fn hex(text: &str) -> Vec<u8> {
    assert!(text.len().is_multiple_of(2), "odd hex: {text}");
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).unwrap())
        .collect()
}

fn to_hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// One output line as an event; `Err` with the line when it is none the host prints.
fn parse(line: &str) -> Result<Event, String> {
    let v: Value = serde_json::from_str(line).map_err(|e| format!("not JSON ({e}): {line}"))?;
    let text = |k: &str| v[k].as_str().map(str::to_owned);
    if v["ready"] == true {
        return Ok(Event::Ready);
    }
    if let Some(error) = text("error") {
        return Ok(Event::Undecodable {
            topic: text("topic").unwrap_or_default(),
            kind: text("type"),
            error,
        });
    }
    if v["type"] == "STATE" {
        return serde_json::from_value(v)
            .map(Event::State)
            .map_err(|e| format!("{e}: {line}"));
    }
    if v.get("type").is_some() {
        return serde_json::from_value(v)
            .map(Event::Msg)
            .map_err(|e| format!("{e}: {line}"));
    }
    if let (Some(topic), Some(h)) = (text("published"), text("hex")) {
        return Ok(Event::Published {
            topic,
            bytes: hex(&h),
        });
    }
    if let Some(h) = text("encoded") {
        return Ok(Event::Encoded(hex(&h)));
    }
    if let Some(e) = text("command_error") {
        return Ok(Event::CommandError(e));
    }
    if v.get("disconnected").is_some()
        || v.get("connect_failed").is_some()
        || v.get("subscribe_failed").is_some()
    {
        return Ok(Event::Connection(v));
    }
    Err(format!("a line the host does not print: {line}"))
}

/// The venv's python, or why there is none.
fn python() -> Result<PathBuf, String> {
    // The workspace root: crates/drivectl's grandparent.
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = manifest.ancestors().nth(2).unwrap_or(manifest);
    let python = root.join("target/sparkplug/venv/bin/python");
    if python.is_file() {
        Ok(python)
    } else {
        Err(format!(
            "no Sparkplug host here ({} is missing); install it with scripts/setup-sparkplug, \
             which scripts/test runs",
            python.display()
        ))
    }
}

fn under_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
}

/// The host script.
pub fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sparkplug/host.py")
}

/// How the host connects.
#[derive(Debug, Clone, Default)]
pub struct HostOptions {
    /// Its MQTT client id (default: one of its own per process).
    pub client_id: Option<String>,
    /// Set the connection's will to `spBv1.0/STATE/<id>` offline (retained), as a primary host.
    pub will_host: Option<String>,
}

static SEQ: AtomicU32 = AtomicU32::new(0);

/// A running host; killed when dropped (its log printed if the test is failing).
pub struct SpbHost {
    child: Child,
    stdin: ChildStdin,
    rx: mpsc::Receiver<Result<Event, String>>,
    /// Every decoded message so far, in order.
    msgs: Vec<Msg>,
    /// Every STATE message so far.
    states: Vec<State>,
    /// Every message the library could not decode: (topic, type, error).
    undecodable: Vec<(String, Option<String>, String)>,
    /// Answers to commands not yet taken.
    replies: VecDeque<Event>,
    /// Connection events (disconnects).
    connection: Vec<Value>,
    /// Where `wait_for` starts looking.
    mark: usize,
    state_mark: usize,
    log: PathBuf,
    /// The group id it subscribed to.
    pub group: String,
}

impl SpbHost {
    /// Start the host against `127.0.0.1:port` for `group` and wait until it has subscribed
    /// (10 s at most). Without the venv: a panic under CI, else `None` with one `SKIPPED` line.
    pub fn start(port: u16, group: &str) -> Option<SpbHost> {
        Self::start_with(port, group, HostOptions::default())
    }

    /// [`SpbHost::start`] with options.
    pub fn start_with(port: u16, group: &str, options: HostOptions) -> Option<SpbHost> {
        let python = match python() {
            Ok(p) => p,
            Err(why) => {
                if under_ci() {
                    panic!(
                        "{why}; CI is set, so a Sparkplug test that cannot run fails instead of \
                         skipping"
                    );
                }
                eprintln!("SKIPPED: {why}");
                return None;
            }
        };
        let log = std::env::temp_dir().join(format!(
            "drivebus-spb-host-{}-{}.log",
            std::process::id(),
            SEQ.fetch_add(1, Ordering::Relaxed)
        ));
        let mut cmd = Command::new(python);
        cmd.arg(script())
            .arg("127.0.0.1")
            .arg(port.to_string())
            .arg(group);
        if let Some(id) = &options.client_id {
            cmd.arg("--client-id").arg(id);
        }
        if let Some(h) = &options.will_host {
            cmd.arg("--will-host").arg(h);
        }
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap())
            // Unbuffered: a line is there when it is printed (the host flushes too).
            .env("PYTHONUNBUFFERED", "1")
            // Nothing written next to the script.
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .spawn()
            .expect("the venv's python runs host.py");
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(parse(&line)).is_err() {
                    break;
                }
            }
        });
        let mut host = SpbHost {
            child,
            stdin,
            rx,
            msgs: Vec::new(),
            states: Vec::new(),
            undecodable: Vec::new(),
            replies: VecDeque::new(),
            connection: Vec::new(),
            mark: 0,
            state_mark: 0,
            log,
            group: group.to_owned(),
        };
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            match host.next_event(deadline) {
                Some(Event::Ready) => return Some(host),
                Some(Event::Connection(v)) => panic!("the host could not connect: {v}"),
                Some(other) => host.keep(other),
                None => panic!(
                    "the Sparkplug host did not subscribe within 10 s; its log:\n{}",
                    host.log()
                ),
            }
        }
    }

    /// What the host wrote on standard error.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// The next event before `deadline`; `None` at the deadline or when the host has exited.
    fn next_event(&mut self, deadline: Instant) -> Option<Event> {
        let left = deadline.saturating_duration_since(Instant::now());
        match self.rx.recv_timeout(left) {
            Ok(Ok(e)) => Some(e),
            Ok(Err(line)) => panic!("the host printed {line}"),
            Err(_) => None,
        }
    }

    fn keep(&mut self, e: Event) {
        match e {
            Event::Msg(m) => self.msgs.push(m),
            Event::State(s) => self.states.push(s),
            Event::Undecodable { topic, kind, error } => {
                self.undecodable.push((topic, kind, error));
            }
            Event::Connection(v) => self.connection.push(v),
            Event::Ready => {}
            reply => self.replies.push_back(reply),
        }
    }

    /// Take in everything printed so far (without waiting).
    pub fn drain(&mut self) {
        while let Ok(e) = self.rx.try_recv() {
            match e {
                Ok(e) => self.keep(e),
                Err(line) => panic!("the host printed {line}"),
            }
        }
    }

    /// Look only at messages received from now on (in `wait_for`, `since_mark`).
    pub fn mark(&mut self) {
        self.drain();
        self.mark = self.msgs.len();
        self.state_mark = self.states.len();
    }

    /// The messages received since the last [`SpbHost::mark`] (after taking in what is there).
    pub fn since_mark(&mut self) -> &[Msg] {
        self.drain();
        &self.msgs[self.mark..]
    }

    /// Every message received.
    pub fn all(&mut self) -> &[Msg] {
        self.drain();
        &self.msgs
    }

    /// Every message the library could not decode so far: (topic, type, error).
    pub fn undecodable(&mut self) -> &[(String, Option<String>, String)] {
        self.drain();
        &self.undecodable
    }

    /// The first message since the mark that satisfies `pred`, waiting up to `timeout` for it.
    pub fn wait_for(
        &mut self,
        timeout: Duration,
        mut pred: impl FnMut(&Msg) -> bool,
    ) -> Option<Msg> {
        let deadline = Instant::now() + timeout;
        let mut checked = self.mark;
        loop {
            self.drain();
            if let Some(m) = self.msgs[checked..].iter().find(|m| pred(m)) {
                return Some(m.clone());
            }
            checked = self.msgs.len();
            let e = self.next_event(deadline)?;
            self.keep(e);
        }
    }

    /// [`SpbHost::wait_for`], panicking with `what`, the messages since the mark, anything
    /// undecodable and the host's log when nothing matches.
    pub fn expect(&mut self, what: &str, timeout: Duration, pred: impl FnMut(&Msg) -> bool) -> Msg {
        if let Some(m) = self.wait_for(timeout, pred) {
            return m;
        }
        let seen: Vec<String> = self.msgs[self.mark..]
            .iter()
            .map(|m| {
                format!(
                    "{} seq {:?}: {:?}",
                    m.topic,
                    m.seq,
                    m.metrics
                        .iter()
                        .map(|x| (x.known_name().unwrap_or("?").to_owned(), x.value.clone()))
                        .collect::<Vec<_>>()
                )
            })
            .collect();
        panic!(
            "no {what} within {timeout:?}.\nreceived since the mark:\n  {}\nundecodable: {:?}\n\
             host log:\n{}",
            seen.join("\n  "),
            self.undecodable,
            self.log()
        );
    }

    /// The first `kind` message of `device` (`None`: the node itself) from `node` since the mark.
    pub fn expect_kind(
        &mut self,
        kind: &str,
        node: &str,
        device: Option<&str>,
        timeout: Duration,
    ) -> Msg {
        let what = format!("{kind} from {node}/{}", device.unwrap_or("-"));
        self.expect(&what, timeout, |m| m.node == node && m.is(kind, device))
    }

    /// The first STATE message since the mark that satisfies `pred`.
    pub fn wait_for_state(
        &mut self,
        timeout: Duration,
        mut pred: impl FnMut(&State) -> bool,
    ) -> Option<State> {
        let deadline = Instant::now() + timeout;
        let mut checked = self.state_mark;
        loop {
            self.drain();
            if let Some(s) = self.states[checked..].iter().find(|s| pred(s)) {
                return Some(s.clone());
            }
            checked = self.states.len();
            let e = self.next_event(deadline)?;
            self.keep(e);
        }
    }

    /// Send one command line and wait for its answer (10 s at most).
    fn command(&mut self, cmd: &Value) -> Event {
        writeln!(self.stdin, "{cmd}").expect("the host reads its commands");
        self.stdin.flush().unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(r) = self.replies.pop_front() {
                return r;
            }
            match self.next_event(deadline) {
                Some(e) => self.keep(e),
                None => panic!(
                    "the host did not answer {cmd} within 10 s; its log:\n{}",
                    self.log()
                ),
            }
        }
    }

    /// Send a publishing command; the bytes published, or the host's refusal.
    pub fn publish_command(&mut self, cmd: Value) -> Result<Vec<u8>, String> {
        match self.command(&cmd) {
            Event::Published { bytes, .. } => Ok(bytes),
            Event::CommandError(e) => Err(e),
            other => panic!("{cmd}: answered {other:?}"),
        }
    }

    /// A DCMD to `node`/`device` with `metrics` (`[{"name"|"alias": …, "datatype"?: …,
    /// "value": …}]`); the bytes published. Panics if the host refuses it.
    pub fn dcmd(&mut self, node: &str, device: &str, metrics: Value) -> Vec<u8> {
        let cmd = json!({"cmd": "DCMD", "node": node, "device": device, "metrics": metrics});
        self.publish_command(cmd.clone())
            .unwrap_or_else(|e| panic!("{cmd}: {e}"))
    }

    /// An NCMD to `node`; the bytes published.
    pub fn ncmd(&mut self, node: &str, metrics: Value) -> Vec<u8> {
        let cmd = json!({"cmd": "NCMD", "node": node, "metrics": metrics});
        self.publish_command(cmd.clone())
            .unwrap_or_else(|e| panic!("{cmd}: {e}"))
    }

    /// The NCMD a host sends to ask `node` for its births again.
    pub fn rebirth(&mut self, node: &str) -> Vec<u8> {
        self.ncmd(
            node,
            json!([{"name": "Node Control/Rebirth", "datatype": "Boolean", "value": true}]),
        )
    }

    /// Publish the primary host `host`'s retained STATE (`online` or not).
    pub fn state(&mut self, host: &str, online: bool) -> Vec<u8> {
        let cmd = json!({"cmd": "STATE", "host": host, "online": online});
        self.publish_command(cmd.clone())
            .unwrap_or_else(|e| panic!("{cmd}: {e}"))
    }

    /// Publish `bytes` on `topic` as they are (QoS 0, not retained).
    pub fn raw(&mut self, topic: &str, bytes: &[u8]) {
        let cmd = json!({"cmd": "raw", "topic": topic, "hex": to_hex(bytes)});
        self.publish_command(cmd.clone())
            .unwrap_or_else(|e| panic!("{cmd}: {e}"));
    }

    /// The bytes the library encodes for `cmd` (`{"type": "NBIRTH"|…, "seq"?, "metrics": […]}`;
    /// the `cmd` key is added), or its refusal.
    pub fn try_encode(&mut self, mut cmd: Value) -> Result<Vec<u8>, String> {
        cmd["cmd"] = json!("encode");
        match self.command(&cmd) {
            Event::Encoded(b) => Ok(b),
            Event::CommandError(e) => Err(e),
            other => panic!("{cmd}: answered {other:?}"),
        }
    }

    /// [`SpbHost::try_encode`], panicking on a refusal.
    pub fn encode(&mut self, cmd: Value) -> Vec<u8> {
        let shown = cmd.to_string();
        self.try_encode(cmd)
            .unwrap_or_else(|e| panic!("encode {shown}: {e}"))
    }

    /// Kill the host (SIGKILL): its connection drops without a DISCONNECT, so the broker
    /// publishes its will.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Connection events so far (paho's disconnects), as the host printed them.
    pub fn connection_events(&mut self) -> &[Value] {
        self.drain();
        &self.connection
    }
}

impl Drop for SpbHost {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "{}", json!({"cmd": "quit"}));
        let _ = self.stdin.flush();
        let deadline = Instant::now() + Duration::from_secs(2);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        if std::thread::panicking() {
            eprintln!(
                "Sparkplug host log ({}):\n{}",
                self.log.display(),
                self.log()
            );
        }
        let _ = std::fs::remove_file(&self.log);
    }
}
