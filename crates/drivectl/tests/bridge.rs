//! The broker bridge of `docs/deploying.md` ("Scaling past one broker"), run for real: a cabinet
//! broker and a plant broker, two Mosquitto processes, joined by the bridge block of the docs
//! (read from the docs themselves, so that what is tested is what is written there), with the
//! plant broker's access rules also taken from the docs. `drivectl gateway` runs against the
//! cabinet broker with one MOVILINK drive simulated by `drivectl sim movilink --pty`.
//!
//! The plant broker listens with TLS (the harness's generated CA; the bridge checks the
//! certificate with `bridge_cafile`, as the docs show), a password file and the ACL; it keeps
//! persistence on, as Debian's default `mosquitto.conf` does, so that its retained values and the
//! bridge's session outlive a restart. The bridge reaches it through a small TCP relay in this
//! test, which can cut the link while the plant broker runs (a network outage) and which keeps it
//! cut after the plant broker comes back, so that a `set` can be queued there for the bridge.
//! The one line the test adds to the docs' block is `restart_timeout 1` (the default waits 5 to
//! 30 s before each reconnection).

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;
#[path = "common/gateway.rs"]
mod gateway;
#[path = "../../drivebus-gateway/tests/common/mosquitto.rs"]
mod mosquitto;

use std::path::PathBuf;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use common::{PtySim, ok_json};
use gateway::Gateway;
use mosquitto::{BrokerOptions, Mosquitto, TestClient};
use rumqttc::Publish;
use serde_json::{Value, json};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

/// The gateway's `name`: the one of the docs' bridge block.
const GW: &str = "cabinet-12";
/// The writable point.
const VALUE: &str = "drivebus/cabinet-12/ml/d1/ramp";
/// Where a bridge with `notifications true` says whether it is up (`1`) or not (`0`), on both
/// brokers (mosquitto.conf(5): `$SYS/broker/connection/<remote_clientid>/state`).
const BRIDGE_STATE: &str = "$SYS/broker/connection/bridge-cabinet-12/state";
/// The gateway's `max_set_age` in this test.
const MAX_SET_AGE: Duration = Duration::from_secs(3);
/// How long any one thing may take to happen on a loaded machine before the test fails. A
/// bridge reconnection is one `restart_timeout` plus Mosquitto's own loop (about 5 s here).
const WAIT: Duration = Duration::from_secs(20);

const BRIDGE_PASSWORD: &str = "bridge secret";
const OPERATOR: (&str, &str) = ("operator-anna", "anna secret");
const DASHBOARD: (&str, &str) = ("grafana", "grafana secret");

/// A client id not used before in this test.
fn client_id(tag: &str) -> String {
    static SEQ: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("bridge-test-{tag}-{n}")
}

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

fn set_topic(point: &str) -> String {
    format!("{point}/set")
}

fn result_topic(point: &str) -> String {
    format!("{point}/result")
}

/// The fenced block of `docs/deploying.md` that has a line equal to `line`.
fn docs_block(line: &str) -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/deploying.md");
    let text = std::fs::read_to_string(path).unwrap();
    let mut blocks = Vec::new();
    let mut current: Option<Vec<&str>> = None;
    for l in text.lines() {
        if l.starts_with("```") {
            match current.take() {
                Some(b) => blocks.push(b),
                None => current = Some(Vec::new()),
            }
        } else if let Some(b) = current.as_mut() {
            b.push(l);
        }
    }
    let found: Vec<_> = blocks
        .into_iter()
        .filter(|b| b.iter().any(|l| l.trim() == line))
        .collect();
    assert_eq!(
        found.len(),
        1,
        "docs/deploying.md has one code block with the line {line:?}"
    );
    found[0].join("\n") + "\n"
}

/// Replace the line starting with `key ` in `block` by `key value`; the docs must have it.
fn with_line(block: &str, key: &str, value: &str) -> String {
    let prefix = format!("{key} ");
    let mut hit = false;
    let out: Vec<String> = block
        .lines()
        .map(|l| {
            if l.starts_with(&prefix) {
                hit = true;
                format!("{key} {value}")
            } else {
                l.to_owned()
            }
        })
        .collect();
    assert!(hit, "the docs' bridge block has no `{key}` line:\n{block}");
    out.join("\n") + "\n"
}

/// The docs' bridge block, pointed at the plant broker through `relay_port`.
fn bridge_block(plant: &Mosquitto, relay_port: u16) -> String {
    let block = docs_block("connection central");
    let block = with_line(&block, "address", &format!("127.0.0.1:{relay_port}"));
    let block = with_line(
        &block,
        "bridge_cafile",
        &plant.ca_file().display().to_string(),
    );
    let block = with_line(&block, "remote_password", BRIDGE_PASSWORD);
    block + "restart_timeout 1\n"
}

/// A TCP relay 127.0.0.1:`port` → 127.0.0.1:`target` that can be cut (open connections closed,
/// new ones closed at once) and restored: the network between the two brokers.
struct Relay {
    port: u16,
    open: watch::Sender<bool>,
    task: tokio::task::JoinHandle<()>,
}

impl Relay {
    async fn start(target: u16) -> Relay {
        let listener = TcpListener::bind(("127.0.0.1", 0)).await.unwrap();
        let port = listener.local_addr().unwrap().port();
        let (open, rx) = watch::channel(true);
        let task = tokio::spawn(async move {
            loop {
                let Ok((mut down, _)) = listener.accept().await else {
                    continue;
                };
                if !*rx.borrow() {
                    continue;
                }
                let mut rx = rx.clone();
                tokio::spawn(async move {
                    let Ok(mut up) = TcpStream::connect(("127.0.0.1", target)).await else {
                        return;
                    };
                    tokio::select! {
                        _ = tokio::io::copy_bidirectional(&mut down, &mut up) => {}
                        _ = rx.wait_for(|open| !*open) => {}
                    }
                });
            }
        });
        Relay { port, open, task }
    }

    fn cut(&self) {
        self.open.send_replace(false);
    }

    fn restore(&self) {
        self.open.send_replace(true);
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.cut();
        self.task.abort();
    }
}

/// Prints the end of both brokers' logs if the test fails (dropped before the brokers, which
/// remove their directories).
struct BrokerLogs(Vec<(&'static str, PathBuf)>);

impl Drop for BrokerLogs {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            return;
        }
        for (name, dir) in &self.0 {
            let log = std::fs::read_to_string(dir.join("mosquitto.log")).unwrap_or_default();
            let lines: Vec<&str> = log.lines().collect();
            let tail = lines[lines.len().saturating_sub(60)..].join("\n");
            eprintln!("{name} broker log (last 60 lines):\n{tail}");
        }
    }
}

/// A test client and everything it received, in order.
struct Inbox {
    /// Which client, for failure messages.
    who: &'static str,
    client: TestClient,
    seen: Vec<Publish>,
}

impl Inbox {
    async fn connect(
        who: &'static str,
        broker: &Mosquitto,
        login: Option<(&str, &str)>,
        topics: &[&str],
    ) -> Inbox {
        let id = client_id("inbox");
        let client = TestClient::connect(broker.client_options(&id, login), topics).await;
        Inbox {
            who,
            client,
            seen: Vec::new(),
        }
    }

    /// How many messages were received so far (a mark for [`Inbox::wait`]).
    fn mark(&self) -> usize {
        self.seen.len()
    }

    /// The first message on `topic` received after `since` that satisfies `pred`, waiting up to
    /// `within`; the failure names what was waited for and lists what came on that topic.
    async fn wait(
        &mut self,
        what: &str,
        topic: &str,
        since: usize,
        within: Duration,
        pred: impl Fn(&Publish) -> bool,
    ) -> Publish {
        let deadline = Instant::now() + within;
        let mut checked = since;
        loop {
            if let Some(p) = self.seen[checked..]
                .iter()
                .find(|p| p.topic == topic && pred(p))
            {
                return p.clone();
            }
            checked = self.seen.len();
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                let there: Vec<String> = self.seen[since..]
                    .iter()
                    .filter(|p| p.topic == topic)
                    .map(|p| {
                        format!(
                            "{}{}",
                            if p.retain { "(retained) " } else { "" },
                            String::from_utf8_lossy(&p.payload)
                        )
                    })
                    .collect();
                panic!(
                    "{}: waited {within:?} for {what} on {topic}; received there meanwhile: {there:?}",
                    self.who
                );
            }
            self.seen.extend(
                self.client
                    .collect(left.min(Duration::from_millis(50)))
                    .await,
            );
        }
    }

    /// [`Inbox::wait`] for a JSON payload.
    async fn wait_json(
        &mut self,
        what: &str,
        topic: &str,
        since: usize,
        pred: impl Fn(&Value) -> bool,
    ) -> Value {
        let p = self
            .wait(what, topic, since, WAIT, |p| {
                serde_json::from_slice::<Value>(&p.payload).is_ok_and(|v| pred(&v))
            })
            .await;
        serde_json::from_slice(&p.payload).unwrap()
    }

    async fn publish(&self, topic: &str, payload: Value) {
        self.client.publish(topic, payload.to_string(), false).await;
    }

    /// Publish a `set` of `value` (with `ts` now and `id`) to the test point and wait for its
    /// result, which comes back here: the result's payload.
    async fn set(&mut self, value: f64, id: &str) -> Value {
        let since = self.mark();
        self.publish(
            &set_topic(VALUE),
            json!({"value": value, "ts": now_ms(), "id": id}),
        )
        .await;
        self.wait_json(
            &format!("the result of set {id}"),
            &result_topic(VALUE),
            since,
            |r| r["id"] == id,
        )
        .await
    }

    /// Publish retained (what a `set` must never be).
    async fn publish_retained(&self, topic: &str, payload: Value) {
        self.client.publish(topic, payload.to_string(), true).await;
    }
}

/// The retained message a new subscriber of `broker` gets on `topic` (its payload), waiting up
/// to `within`; `None` if none came.
async fn retained(
    broker: &Mosquitto,
    login: Option<(&str, &str)>,
    topic: &str,
    within: Duration,
) -> Option<Vec<u8>> {
    let id = client_id("retained");
    let mut c = TestClient::connect(broker.client_options(&id, login), &[topic]).await;
    let p = c.next_where(topic, within, |p| p.retain).await?;
    Some(p.payload.to_vec())
}

/// Wait until the plant broker's retained `topic` is the cabinet broker's, byte for byte (the
/// bridge may still be delivering); that payload.
async fn same_retained(plant: &Mosquitto, cabinet: &Mosquitto, topic: &str) -> Vec<u8> {
    let deadline = Instant::now() + WAIT;
    loop {
        let c = retained(cabinet, None, topic, Duration::from_secs(5)).await;
        let p = retained(plant, Some(DASHBOARD), topic, Duration::from_secs(2)).await;
        if let Some(c) = c.as_ref().filter(|c| Some(*c) == p.as_ref()) {
            return c.clone();
        }
        assert!(
            Instant::now() < deadline,
            "waited {WAIT:?} for the plant broker's retained {topic} to be the cabinet's:\n\
             cabinet: {:?}\nplant:   {:?}",
            c.map(|c| String::from_utf8_lossy(&c).into_owned()),
            p.map(|p| String::from_utf8_lossy(&p).into_owned()),
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// How many lines of `broker`'s log contain `needle`.
fn log_count(broker: &Mosquitto, needle: &str) -> usize {
    std::fs::read_to_string(broker.dir.join("mosquitto.log"))
        .unwrap_or_default()
        .lines()
        .filter(|l| l.contains(needle))
        .count()
}

/// Wait until `broker`'s log has more than `before` lines containing `needle`.
async fn wait_log(broker: &Mosquitto, needle: &str, before: usize) {
    let deadline = Instant::now() + WAIT;
    while log_count(broker, needle) <= before {
        assert!(
            Instant::now() < deadline,
            "waited {WAIT:?} for another {needle:?} in the broker's log"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn raw_of(payload: &[u8]) -> Option<i64> {
    serde_json::from_slice::<Value>(payload).ok()?["raw"].as_i64()
}

/// An MQTT 5 consumer of `filter` at `broker` (logged in as `login`): what it received as
/// (topic, payload, retained).
struct Consumer5 {
    rx: mpsc::UnboundedReceiver<(String, Vec<u8>, bool)>,
    task: tokio::task::JoinHandle<()>,
}

impl Consumer5 {
    async fn connect(broker: &Mosquitto, id: &str, login: (&str, &str), filter: &str) -> Self {
        use rumqttc::v5::mqttbytes::QoS;
        use rumqttc::v5::mqttbytes::v5::{Packet, SubscribeReasonCode};
        use rumqttc::v5::{AsyncClient, Event, MqttOptions};
        // The harness's options (TLS with its CA, the server name) carried over to MQTT 5.
        let v4 = broker.client_options(id, Some(login));
        let (host, port) = v4.broker_address();
        let mut o = MqttOptions::new(id, host, port);
        o.set_transport(v4.transport());
        o.set_credentials(login.0, login.1);
        o.set_keep_alive(Duration::from_secs(5));
        let (client, mut el) = AsyncClient::new(o, 64);
        client.subscribe(filter, QoS::AtLeastOnce).await.unwrap();
        let (tx, rx) = mpsc::unbounded_channel();
        let (ack_tx, mut ack_rx) = mpsc::unbounded_channel();
        let task = tokio::spawn(async move {
            let _client = client;
            loop {
                match el.poll().await {
                    Ok(Event::Incoming(Packet::Publish(p))) => {
                        let topic = String::from_utf8_lossy(&p.topic).into_owned();
                        let _ = tx.send((topic, p.payload.to_vec(), p.retain));
                    }
                    Ok(Event::Incoming(Packet::SubAck(a))) => {
                        let _ = ack_tx.send(a.return_codes);
                    }
                    Ok(_) => {}
                    Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
                }
            }
        });
        let codes = tokio::time::timeout(WAIT, ack_rx.recv())
            .await
            .unwrap_or_else(|_| panic!("{id}: no SUBACK for {filter} within {WAIT:?}"))
            .unwrap();
        assert!(
            matches!(codes.as_slice(), [SubscribeReasonCode::Success(_)]),
            "{id}: the broker refused {filter}: {codes:?}"
        );
        Consumer5 { rx, task }
    }

    /// Everything received so far.
    fn drain(&mut self) -> Vec<(String, Vec<u8>, bool)> {
        let mut out = Vec::new();
        while let Ok(m) = self.rx.try_recv() {
            out.push(m);
        }
        out
    }
}

impl Drop for Consumer5 {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// P130 read directly from the simulated drive (the gateway stopped): its raw value.
fn read_drive(sim: &PtySim) -> i64 {
    let v = ok_json(&sim.drivectl(&[
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json", "read",
        "P130",
    ]));
    v[0]["raw"].as_i64().unwrap_or_else(|| panic!("{v:?}"))
}

/// The two brokers joined by the docs' bridge, the link between them, the simulated drive and
/// the gateway, running, with a client at each broker; the fields are dropped in this order
/// (the logs printed first if the test failed).
struct Bridged {
    _logs: BrokerLogs,
    gw: Gateway,
    sim: PtySim,
    /// P130 of the simulated drive before the gateway started.
    factory: i64,
    /// A dashboard at the plant broker: `drivebus/#` and the bridges' states.
    dash: Inbox,
    /// A client at the cabinet broker: the same topics.
    local: Inbox,
    /// An operator at the plant broker: the point's results.
    op: Inbox,
    relay: Relay,
    cabinet: Mosquitto,
    plant: Mosquitto,
}

impl Bridged {
    /// Everything started, the bridge up (its state `1` at both brokers) and the drive's first
    /// value published at the cabinet broker; `None` (the test skipped) without Mosquitto.
    async fn start() -> Option<Bridged> {
        let plant_options = BrokerOptions {
            users: vec![
                ("bridge-cabinet-12".into(), BRIDGE_PASSWORD.into()),
                (OPERATOR.0.into(), OPERATOR.1.into()),
                (DASHBOARD.0.into(), DASHBOARD.1.into()),
            ],
            tls: true,
            client_certificates: false,
        };
        // The docs' ACL, and the dashboard allowed to watch the bridges, as the docs' comment
        // on the bridge's lines says.
        let acl = docs_block("user bridge-cabinet-12")
            + "\nuser grafana\ntopic read $SYS/broker/connection/#\n";
        let plant = Mosquitto::start_with(
            plant_options,
            &[("acl", &acl)],
            "acl_file {dir}/acl\npersistence true\npersistence_location {dir}/\n",
        )?;
        let relay = Relay::start(plant.port).await;
        let cabinet = Mosquitto::start_with(
            BrokerOptions::default(),
            &[],
            &bridge_block(&plant, relay.port),
        )
        .expect("the plant broker started, so Mosquitto is here");
        let logs = BrokerLogs(vec![
            ("plant", plant.dir.clone()),
            ("cabinet", cabinet.dir.clone()),
        ]);

        // The bridge is up: its notification says so on both brokers.
        let mut dash = Inbox::connect(
            "dashboard at the plant broker",
            &plant,
            Some(DASHBOARD),
            &["drivebus/#", "$SYS/broker/connection/#"],
        )
        .await;
        dash.wait("the bridge's state 1", BRIDGE_STATE, 0, WAIT, |p| {
            &p.payload[..] == b"1"
        })
        .await;
        let mut local = Inbox::connect(
            "client at the cabinet broker",
            &cabinet,
            None,
            &["drivebus/#", "$SYS/broker/connection/#"],
        )
        .await;
        local
            .wait("the bridge's state 1", BRIDGE_STATE, 0, WAIT, |p| {
                &p.payload[..] == b"1"
            })
            .await;
        let op = Inbox::connect(
            "operator at the plant broker",
            &plant,
            Some(OPERATOR),
            &[&result_topic(VALUE)],
        )
        .await;

        let sim = PtySim::start(&[
            "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
        ]);
        let factory = read_drive(&sim);
        // A long heartbeat: a value is published when it changes, so every value message
        // below is one the test caused.
        let config = format!(
            "[gateway]\nname = \"{GW}\"\nbroker = \"{}\"\nmetrics = \"off\"\nheartbeat = \"10m\"\n\
             max_set_age = \"{}s\"\n\
             [[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
             [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"300ms\"\nwritable = true\n",
            cabinet.url(),
            MAX_SET_AGE.as_secs(),
            sim.path
        );
        let gw = Gateway::start(&config, &[]);
        local
            .wait_json("the first value", VALUE, 0, |v| {
                v["raw"].as_i64() == Some(factory)
            })
            .await;
        Some(Bridged {
            _logs: logs,
            gw,
            sim,
            factory,
            dash,
            local,
            op,
            relay,
            cabinet,
            plant,
        })
    }
}

/// The bridge of `docs/deploying.md` between a cabinet broker and a plant broker, with
/// `drivectl gateway` on the cabinet broker: values reach the plant broker retained and
/// unchanged, a `set` published there is executed and its result comes back, the gateway and
/// the cabinet broker keep working while the plant broker is down, the plant broker has the
/// latest values once the bridge is back (not the ones it kept from before), a `set` queued
/// for the bridge during the outage arrives late and is refused as `stale`, and a shared
/// subscription at the plant broker hands each value to one consumer of its group.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bridged_cabinet_broker_values_out_sets_in_and_an_outage() {
    let Some(mut b) = Bridged::start().await else {
        return;
    };
    let factory = b.factory;

    // 1. Values reach the plant broker, retained, with the cabinet's payload.
    b.dash
        .wait_json("the first value, bridged", VALUE, 0, |v| {
            v["raw"].as_i64() == Some(factory)
        })
        .await;
    let first = same_retained(&b.plant, &b.cabinet, VALUE).await;
    assert_eq!(raw_of(&first), Some(factory));
    for topic in [
        "drivebus/cabinet-12/status",
        "drivebus/cabinet-12/ml/d1/status",
    ] {
        same_retained(&b.plant, &b.cabinet, topic).await;
    }

    // 2. A set published at the plant broker (with ts, not retained) is executed, and its
    // result comes back there.
    let since = b.dash.mark();
    let r = b.op.set(3.5, "plant-1").await;
    assert_eq!(
        (&r["ok"], &r["outcome"], &r["raw"]),
        (&json!(true), &json!("written"), &json!(3500)),
        "{r}"
    );
    b.dash
        .wait_json("the value written by plant-1", VALUE, since, |v| {
            v["raw"] == 3500
        })
        .await;
    // The set went into the cabinet once and did not come back out (no loop).
    let sets = b.dash.seen[since..]
        .iter()
        .filter(|p| p.topic == set_topic(VALUE))
        .count();
    assert_eq!(sets, 1, "set plant-1 seen {sets} times at the plant broker");
    let before_outage = same_retained(&b.plant, &b.cabinet, VALUE).await;
    assert_eq!(raw_of(&before_outage), Some(3500));

    // 3. The outage: the link goes, then the plant broker stops (cleanly: it saves its
    // retained values and the bridge's session). The bridge's last will says so at the
    // plant broker, its local notification at the cabinet broker.
    let since_local = b.local.mark();
    b.relay.cut();
    b.dash
        .wait("the bridge's state 0", BRIDGE_STATE, 0, WAIT, |p| {
            &p.payload[..] == b"0"
        })
        .await;
    b.local
        .wait(
            "the bridge's state 0",
            BRIDGE_STATE,
            since_local,
            WAIT,
            |p| &p.payload[..] == b"0",
        )
        .await;
    b.plant.terminate();
    let cut_at = now_ms();

    // The gateway keeps working at the cabinet broker: a set there is executed, the value and
    // the bus's figures keep coming.
    let since = b.local.mark();
    let r = b.local.set(4.2, "cabinet-1").await;
    assert_eq!((&r["ok"], &r["raw"]), (&json!(true), &json!(4200)), "{r}");
    b.local
        .wait_json("the value written by cabinet-1", VALUE, since, |v| {
            v["raw"] == 4200
        })
        .await;
    b.local
        .wait_json(
            "the bus's figures, published during the outage",
            "drivebus/cabinet-12/ml/status",
            since,
            |v| v["ts"].as_u64().is_some_and(|ts| ts > cut_at),
        )
        .await;
    assert!(
        !b.local
            .seen
            .iter()
            .any(|p| p.topic == "drivebus/cabinet-12/status"
                && serde_json::from_slice::<Value>(&p.payload)
                    .is_ok_and(|v| v["state"] == "offline")),
        "the gateway went offline during the outage:\n{}",
        b.gw.log()
    );

    // 4. The plant broker is back, the link not yet: it still holds the value from before the
    // outage, and a set published there now is queued for the bridge's session.
    b.plant.restart();
    b.dash = Inbox::connect(
        "dashboard at the plant broker",
        &b.plant,
        Some(DASHBOARD),
        &["drivebus/#", "$SYS/broker/connection/#"],
    )
    .await;
    let kept = retained(&b.plant, Some(DASHBOARD), VALUE, WAIT).await;
    assert_eq!(
        kept.as_deref(),
        Some(&before_outage[..]),
        "the restarted plant broker keeps its retained value from before the outage"
    );
    b.op = Inbox::connect(
        "operator at the plant broker",
        &b.plant,
        Some(OPERATOR),
        &[&result_topic(VALUE)],
    )
    .await;
    let late_ts = now_ms();
    b.op.publish(
        &set_topic(VALUE),
        json!({"value": 9.9, "ts": late_ts, "id": "late"}),
    )
    .await;
    // It must be older than max_set_age when it arrives: the outage lasts that long.
    let old_enough = late_ts + MAX_SET_AGE.as_millis() as u64 + 500;
    tokio::time::sleep(Duration::from_millis(old_enough.saturating_sub(now_ms()))).await;
    b.relay.restore();
    let since = b.dash.mark();
    b.dash
        .wait("the bridge's state 1", BRIDGE_STATE, since, WAIT, |p| {
            &p.payload[..] == b"1"
        })
        .await;

    // The queued set arrived late and was refused as stale; the result came back.
    let r =
        b.op.wait_json(
            "the result of the queued set",
            &result_topic(VALUE),
            0,
            |r| r["id"] == "late",
        )
        .await;
    assert_eq!(
        (&r["ok"], &r["outcome"], &r["reason"]),
        (&json!(false), &json!("refused"), &json!("stale")),
        "{r}"
    );
    // The plant broker has the latest value, not the one it kept.
    let latest = same_retained(&b.plant, &b.cabinet, VALUE).await;
    assert_eq!(
        raw_of(&latest),
        Some(4200),
        "{:?}",
        String::from_utf8_lossy(&latest)
    );
    assert_ne!(latest, before_outage);
    same_retained(&b.plant, &b.cabinet, "drivebus/cabinet-12/ml/d1/status").await;

    // 5. Shared subscriptions (MQTT 5) at the plant broker: two consumers of one group get
    // each live value once between them. At its subscription each of them gets the retained
    // values, as a plain subscriber does (Mosquitto does so; MQTT 5 sends retained messages
    // at subscription only for non-shared subscriptions, and docs/deploying.md says both).
    let filter = "$share/historian/drivebus/+/+/+/+";
    let mut group = [
        Consumer5::connect(&b.plant, "historian-a", DASHBOARD, filter).await,
        Consumer5::connect(&b.plant, "historian-b", DASHBOARD, filter).await,
    ];
    let mut got: [Vec<(String, Vec<u8>, bool)>; 2] = [Vec::new(), Vec::new()];
    let has_retained =
        |g: &[(String, Vec<u8>, bool)]| g.iter().any(|(t, p, r)| *r && t == VALUE && *p == latest);
    let deadline = Instant::now() + WAIT;
    while !got.iter().all(|g| has_retained(g)) {
        assert!(
            Instant::now() < deadline,
            "waited {WAIT:?} for each member of the group to get the retained {VALUE} \
             (Mosquitto 2.0 sends it at a shared subscription too); got: a {:?}, b {:?}",
            got[0],
            got[1]
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
        for (g, c) in got.iter_mut().zip(group.iter_mut()) {
            g.extend(c.drain());
        }
    }
    let mut plain = Inbox::connect(
        "plain subscriber at the plant broker",
        &b.plant,
        Some(DASHBOARD),
        &["drivebus/+/+/+/+"],
    )
    .await;
    plain
        .wait("the retained value", VALUE, 0, WAIT, |p| p.retain)
        .await;
    let mut want = Vec::new();
    for (i, value) in [5.0, 5.1, 5.2, 5.3, 5.4, 5.5].into_iter().enumerate() {
        let id = format!("shared-{i}");
        let r = b.op.set(value, &id).await;
        assert_eq!(r["ok"], true, "{r}");
        want.push(r["raw"].as_i64().unwrap());
    }
    let last = *want.last().unwrap();
    plain
        .wait("the last value", VALUE, 0, WAIT, |p| {
            raw_of(&p.payload) == Some(last)
        })
        .await;
    // The live values the group got, by member.
    let live = |got: &[Vec<(String, Vec<u8>, bool)>; 2]| -> Vec<(usize, Vec<u8>)> {
        got.iter()
            .enumerate()
            .flat_map(|(i, g)| {
                g.iter()
                    .filter(|(t, _, r)| t == VALUE && !r)
                    .map(move |(_, p, _)| (i, p.clone()))
            })
            .collect()
    };
    let deadline = Instant::now() + WAIT;
    loop {
        for (g, c) in got.iter_mut().zip(group.iter_mut()) {
            g.extend(c.drain());
        }
        let raws: Vec<i64> = live(&got).iter().filter_map(|(_, p)| raw_of(p)).collect();
        if want.iter().all(|w| raws.contains(w)) || Instant::now() > deadline {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let shared = live(&got);
    let show: Vec<String> = shared
        .iter()
        .map(|(i, p)| format!("{}: {}", ["a", "b"][*i], String::from_utf8_lossy(p)))
        .collect();
    let plain_values: Vec<Vec<u8>> = plain
        .seen
        .iter()
        .filter(|p| p.topic == VALUE && !p.retain)
        .map(|p| p.payload.to_vec())
        .collect();
    assert_eq!(plain_values.len(), want.len(), "one value message per set");
    for p in &plain_values {
        let n = shared.iter().filter(|(_, s)| s == p).count();
        assert_eq!(
            n,
            1,
            "{} reached the group {n} times; the group got {show:?}",
            String::from_utf8_lossy(p)
        );
    }
    assert_eq!(
        shared.len(),
        plain_values.len(),
        "the group got other values than the plain subscriber: {show:?}"
    );
    assert!(
        (0..2).all(|i| shared.iter().any(|(m, _)| *m == i)),
        "Mosquitto hands a group's messages round, so each member gets some: {show:?}"
    );

    // The drive holds the last value written (read directly, the gateway stopped).
    let status = b.gw.terminate();
    assert!(status.success(), "{status:?}\n{}", b.gw.log());
    assert_eq!(read_drive(&b.sim), last);
}

/// A `set` published retained at the plant broker is never executed, neither when it first
/// comes over the bridge nor at a reconnection of the bridge. The plant broker sends its
/// retained copy to the bridge at every reconnection (the bridge subscribes again), and the
/// cabinet broker forwards it to the connected gateway. Before the fix, it came as a live message
/// (the retain flag cleared, MQTT 5's default) and was executed at each reconnection, moving the
/// drive back to the retained value with nobody asking; the gateway now subscribes to its set
/// topics with "retain as published", so it arrives retained and is refused and cleared.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_retained_set_at_the_plant_broker_is_not_executed_again_at_each_bridge_reconnection() {
    let Some(mut b) = Bridged::start().await else {
        return;
    };
    // Published retained at the plant broker, without ts: what the docs tell never to do. It
    // reaches the gateway retained: refused, never written.
    let since = b.op.mark();
    b.op.publish_retained(&set_topic(VALUE), json!({"value": 7.7, "id": "retained"}))
        .await;
    let first =
        b.op.wait_json(
            "the retained set's first result",
            &result_topic(VALUE),
            since,
            |r| r["id"] == "retained",
        )
        .await;
    assert_eq!(
        (&first["outcome"], &first["reason"]),
        (&json!("refused"), &json!("retained")),
        "{first}"
    );
    // Someone at the cabinet sets another value.
    let r = b.local.set(3.0, "local").await;
    assert_eq!(r["raw"], 3000, "{r}");

    // The bridge reconnects. Once the plant broker has acknowledged the bridge's subscription,
    // its retained messages are queued for the bridge ahead of anything published later.
    let suback = "Sending SUBACK to bridge-cabinet-12";
    let subacks = log_count(&b.plant, suback);
    let since_op = b.op.mark();
    let since_local = b.local.mark();
    b.relay.cut();
    b.local
        .wait(
            "the bridge's state 0",
            BRIDGE_STATE,
            since_local,
            WAIT,
            |p| &p.payload[..] == b"0",
        )
        .await;
    b.relay.restore();
    wait_log(&b.plant, suback, subacks).await;
    // A probe through the bridge, behind whatever the reconnection brought; its result comes
    // after theirs.
    b.op.publish(
        &set_topic(VALUE),
        json!({"value": 3.0, "ts": now_ms(), "id": "probe"}),
    )
    .await;
    b.op.wait_json("the probe's result", &result_topic(VALUE), since_op, |r| {
        r["id"] == "probe"
    })
    .await;
    let again: Vec<Value> = b.op.seen[since_op..]
        .iter()
        .filter(|p| p.topic == result_topic(VALUE))
        .filter_map(|p| serde_json::from_slice::<Value>(&p.payload).ok())
        .filter(|r| r["id"] == "retained" && r["outcome"] == "written")
        .collect();
    assert!(
        again.is_empty(),
        "the retained set was executed again at the bridge's reconnection (the drive moved \
         from 3.0 back to 7.7 with nobody asking): {again:?}"
    );
}
