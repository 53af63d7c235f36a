//! `drivectl gateway` end to end, as a plant runs it: the gateway binary as a process, a real
//! Mosquitto broker (`tests/common/mosquitto.rs`), and the drives as `drivectl sim … --pty`
//! processes (or the gateway's own `--simulate`). A test MQTT client checks what a SCADA
//! system would see.

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

use std::process::Command;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::{PtySim, ok_json};
use gateway::{Gateway, free_port, gw_state, metric, scrape, signal};
use mosquitto::{BrokerOptions, Mosquitto, TestClient};
use serde_json::{Value, json};

/// Every figure in the gateway's log is rounded to what is meaningful: no number with more
/// than four decimals (`demand=0.06797656140000001` was one), timestamps aside.
fn assert_figures_rounded(log: &str) {
    for line in log.lines() {
        // The timestamp at the start of a text line has its own fraction of a second.
        let rest = line.split_once(' ').map_or(line, |(first, rest)| {
            if first.contains('T') && first.ends_with('Z') {
                rest
            } else {
                line
            }
        });
        let bytes = rest.as_bytes();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] == b'.' && i > 0 && bytes[i - 1].is_ascii_digit() {
                let decimals = bytes[i + 1..]
                    .iter()
                    .take_while(|b| b.is_ascii_digit())
                    .count();
                assert!(decimals <= 4, "a figure not rounded in: {line}");
                i += decimals;
            }
            i += 1;
        }
    }
}

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

fn broker(options: BrokerOptions) -> Option<Mosquitto> {
    Mosquitto::start(options)
}

/// One simulated MOVILINK bus `ml` with drive `d1` at address 1 whose P130 is the point
/// `ramp`, polled every `period` (and `writable` or not).
fn simulated_bus(period: &str, writable: bool) -> String {
    format!(
        "[[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"{period}\"\nwritable = {writable}\n"
    )
}

/// The `[gateway]` table for `broker` with extra lines.
fn gateway_table(broker: &Mosquitto, extra: &str) -> String {
    format!(
        "[gateway]\nname = \"gw\"\nbroker = \"{}\"\nmetrics = \"off\"\nheartbeat = \"2s\"\n{extra}\n",
        broker.url()
    )
}

async fn subscriber(broker: &Mosquitto, id: &str) -> TestClient {
    TestClient::connect(broker.client_options(id, None), &["drivebus/gw/#"]).await
}

/// Every message a subscriber received, by topic, in order.
#[derive(Default)]
struct Seen(std::collections::HashMap<String, Vec<Vec<u8>>>);

impl Seen {
    /// The first message on `topic` (already received, or arriving within `wait`) whose
    /// payload satisfies `pred`; messages on other topics are kept for later calls.
    async fn wait(
        &mut self,
        c: &mut TestClient,
        topic: &str,
        wait: Duration,
        mut pred: impl FnMut(&[u8]) -> bool,
    ) -> Option<Vec<u8>> {
        let deadline = tokio::time::Instant::now() + wait;
        let mut checked = 0;
        loop {
            if let Some(list) = self.0.get(topic) {
                if let Some(p) = list.iter().skip(checked).find(|p| pred(p)) {
                    return Some(p.clone());
                }
                checked = list.len();
            }
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            if left.is_zero() {
                return None;
            }
            for p in c.collect(left.min(Duration::from_millis(100))).await {
                self.0
                    .entry(p.topic.clone())
                    .or_default()
                    .push(p.payload.to_vec());
            }
        }
    }

    /// Forget what was received on `topic`.
    fn clear(&mut self, topic: &str) {
        self.0.remove(topic);
    }

    /// A JSON message on `topic` satisfying `pred`, within `wait`; panics naming the topic.
    async fn json(
        &mut self,
        c: &mut TestClient,
        topic: &str,
        wait: Duration,
        mut pred: impl FnMut(&Value) -> bool,
    ) -> Value {
        let p = self
            .wait(c, topic, wait, |p| {
                serde_json::from_slice::<Value>(p).is_ok_and(|v| pred(&v))
            })
            .await;
        let p = p.unwrap_or_else(|| {
            panic!(
                "no such message on {topic} within {wait:?}; received there: {:?}",
                self.0.get(topic).map(|l| l
                    .iter()
                    .map(|p| String::from_utf8_lossy(p).into_owned())
                    .collect::<Vec<_>>())
            )
        });
        serde_json::from_slice(&p).unwrap()
    }
}

/// Publish a `set` and wait for its `result` (matched by `id`).
async fn set(seen: &mut Seen, c: &mut TestClient, topic: &str, body: Value) -> Value {
    let id = body["id"].clone();
    c.publish(&format!("{topic}/set"), body.to_string(), false)
        .await;
    seen.json(
        c,
        &format!("{topic}/result"),
        Duration::from_secs(10),
        |r| r["id"] == id,
    )
    .await
}

/// One bus of the end-to-end test: a simulator process on a pty and the config lines that
/// reach it, the writable point and the values to write.
struct Case {
    protocol: &'static str,
    sim: PtySim,
    /// `drivectl …` arguments that read the point directly (the simulator's own value).
    read: Vec<String>,
    bus: String,
    /// The topic of the writable point.
    topic: String,
    /// A value in range (as `value`) and its raw value.
    good: (Value, i64),
    /// A value out of range.
    bad: Value,
}

fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    // MOVILINK: P130 ramp t11 up CW, 2 s by default (raw ms).
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
    ]);
    out.push(Case {
        protocol: "movilink",
        read: ["movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json", "read", "P130"]
            .map(String::from)
            .to_vec(),
        bus: format!(
            "[[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
             [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"300ms\"\nwritable = true\n\
             [[bus.drive.param]]\nparam = \"P131\"\nname = \"ramp_down\"\nperiod = \"300ms\"\n",
            sim.path
        ),
        topic: "drivebus/gw/ml/d1/ramp".into(),
        good: (json!(3.5), 3500),
        bad: json!(99999),
        sim,
    });
    // SBus through a simulated slcan adapter: P131 ramp t11 down CW.
    let sim = PtySim::start(&["sim", "sbus", "--pty", "--addr", "1"]);
    let iface = format!("slcan:{}", sim.path);
    out.push(Case {
        protocol: "sbus",
        read: ["sbus", "--iface", &iface, "--addr", "1", "--json", "read", "P130"]
            .map(String::from)
            .to_vec(),
        bus: format!(
            "[[bus]]\nname = \"can\"\nprotocol = \"sbus\"\niface = \"{iface}\"\n\
             [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"300ms\"\nwritable = true\n\
             [[bus.drive.param]]\nparam = \"P131\"\nname = \"ramp_down\"\nperiod = \"300ms\"\n"
        ),
        topic: "drivebus/gw/can/d1/ramp".into(),
        good: (json!(4.3), 4300),
        bad: json!(-1),
        sim,
    });
    // USS: P102 acceleration time, parameter set 1.
    let sim = PtySim::start(&["sim", "uss", "--pty", "--parity", "none", "--addr", "1"]);
    out.push(Case {
        protocol: "uss",
        read: ["uss", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json", "read", "P102"]
            .map(String::from)
            .to_vec(),
        bus: format!(
            "[[bus]]\nname = \"uss\"\nprotocol = \"uss\"\nport = \"{}\"\nparity = \"none\"\n\
             [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P102\"\nset = 1\nname = \"ramp\"\nperiod = \"300ms\"\nwritable = true\n\
             [[bus.drive.param]]\nparam = \"P105\"\nset = 1\nname = \"fmax\"\nperiod = \"300ms\"\n",
            sim.path
        ),
        topic: "drivebus/gw/uss/d1/ramp".into(),
        good: (json!(7.5), 750),
        bad: json!(1e9),
        sim,
    });
    // Modbus RTU and ASCII: 481 fixed frequency 2 in data set 5 (the RAM image of 0).
    for (mode, name) in [("rtu", "modbus-rtu"), ("ascii", "modbus-ascii")] {
        let sim = PtySim::start(&[
            "sim",
            "bonfiglioli",
            "--pty",
            "--parity",
            "none",
            "--mode",
            mode,
        ]);
        out.push(Case {
            protocol: name,
            read: [
                "bonfiglioli", "--port", &sim.path, "--parity", "none", "--mode", mode,
                "--data-bits", "8", "--addr", "1", "--json", "read", "481", "--dataset", "5",
            ]
            .map(String::from)
            .to_vec(),
            bus: format!(
                "[[bus]]\nname = \"{mode}\"\nprotocol = \"{name}\"\nport = \"{}\"\nparity = \"none\"\ndata_bits = 8\n\
                 [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
                 [[bus.drive.param]]\nparam = \"481\"\ndata_set = 5\nname = \"ff2\"\nperiod = \"300ms\"\nwritable = true\n\
                 [[bus.drive.param]]\nparam = \"241\"\nname = \"frequency\"\nperiod = \"300ms\"\n",
                sim.path
            ),
            topic: format!("drivebus/gw/{mode}/d1/ff2"),
            good: (json!(12.5), 1250),
            bad: json!(1e12),
            sim,
        });
    }
    out
}

fn read_raw(case: &Case) -> i64 {
    let args: Vec<&str> = case.read.iter().map(String::as_str).collect();
    let v = ok_json(&case.sim.drivectl(&args));
    v[0]["raw"]
        .as_i64()
        .unwrap_or_else(|| panic!("{}: {v:?}", case.protocol))
}

/// Every family at once on one gateway: the published values are the simulators' values; a
/// `set` in range reaches the simulated drive (read back directly after the gateway stopped);
/// out-of-range and not-writable sets are refused and write nothing; SIGTERM publishes
/// `offline`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_family_end_to_end_over_ptys() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let cases = cases();
    let before: Vec<i64> = cases.iter().map(read_raw).collect();
    let config = format!(
        "{}{}",
        gateway_table(&broker, ""),
        cases
            .iter()
            .map(|c| c.bus.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let gw = Gateway::start(&config, &[]);
    let online = seen
        .wait(&mut c, "drivebus/gw/status", Duration::from_secs(10), |p| {
            gw_state(p) == "online"
        })
        .await;
    assert!(online.is_some(), "{}", gw.log());
    let mut gw = gw;
    for (case, raw) in cases.iter().zip(&before) {
        let v = seen
            .json(&mut c, &case.topic, Duration::from_secs(10), |_| true)
            .await;
        assert_eq!(v["raw"].as_i64(), Some(*raw), "{}: {v}", case.protocol);
        assert!(
            v["ts"]
                .as_u64()
                .is_some_and(|t| t.abs_diff(now_ms()) < 60_000),
            "{v}"
        );
        let bus_and_drive = case.topic.rsplit_once('/').unwrap().0;
        let st = seen
            .json(
                &mut c,
                &format!("{bus_and_drive}/status"),
                Duration::from_secs(10),
                |_| true,
            )
            .await;
        assert_eq!(st["state"], "online", "{}: {st}", case.protocol);
    }
    for case in &cases {
        let bad = json!({"value": case.bad, "id": "bad", "ts": now_ms()});
        let r = set(&mut seen, &mut c, &case.topic, bad).await;
        assert_eq!(r["ok"], false, "{}: {r}", case.protocol);
        assert_eq!(r["outcome"], "refused", "{}: {r}", case.protocol);
        let other = format!("{}/{}", case.topic.rsplit_once('/').unwrap().0, "ramp_down");
        if case.protocol == "movilink" || case.protocol == "sbus" {
            let r = set(&mut seen, &mut c, &other, json!({"raw": 100, "id": "nw"})).await;
            assert_eq!(r["reason"], "not_writable", "{r}");
        }
        let good = json!({"value": case.good.0, "id": 7, "ts": now_ms()});
        let r = set(&mut seen, &mut c, &case.topic, good).await;
        assert_eq!(r["ok"], true, "{}: {r}", case.protocol);
        assert_eq!(
            r["raw"].as_i64(),
            Some(case.good.1),
            "{}: {r}",
            case.protocol
        );
        let want = case.good.1;
        seen.json(&mut c, &case.topic, Duration::from_secs(10), |v| {
            v["raw"].as_i64() == Some(want)
        })
        .await;
    }
    let status = gw.terminate();
    assert!(status.success(), "{status:?}\n{}", gw.log());
    // The log is for the journal or a file: plain text, no terminal colours.
    assert!(
        gw.log().contains("INFO") && !gw.log().contains('\x1b'),
        "{}",
        gw.log()
    );
    let last = seen
        .wait(&mut c, "drivebus/gw/status", Duration::from_secs(5), |p| {
            gw_state(p) == "offline"
        })
        .await;
    assert!(last.is_some(), "offline at SIGTERM");
    for case in &cases {
        assert_eq!(
            read_raw(case),
            case.good.1,
            "{}: the simulated drive has the value",
            case.protocol
        );
    }
}

/// A free TCP port on 127.0.0.1.
/// A drive that stops answering is `timeout` within its period + timeout × attempts, and
/// `online` again after it answers; a drive that never answers costs its bus one timeout per
/// back-off and does not starve the drive beside it (counted on `/metrics`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drive_that_stops_answering_goes_timeout_and_comes_back() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
    ]);
    let port = free_port();
    let config = format!(
        "{}[[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
         timeout = \"50ms\"\nretries = 1\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\n\
         [[bus.drive]]\nname = \"missing\"\naddress = 3\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\n",
        gateway_table(&broker, "").replace(
            "metrics = \"off\"",
            &format!("metrics = \"127.0.0.1:{port}\"")
        ),
        sim.path
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let gw = Gateway::start(&config, &[]);
    let d1 = "drivebus/gw/ml/d1/status";
    seen.json(&mut c, d1, Duration::from_secs(10), |v| {
        v["state"] == "online"
    })
    .await;
    seen.json(
        &mut c,
        "drivebus/gw/ml/missing/status",
        Duration::from_secs(10),
        |v| v["state"] == "timeout",
    )
    .await;
    // Over 3 s, d1 keeps its 200 ms period although its neighbour never answers.
    let ok = "drivebus_transactions_total{bus=\"ml\",drive=\"d1\",op=\"read\",outcome=\"ok\"}";
    let a = metric(&scrape(port), ok);
    tokio::time::sleep(Duration::from_secs(3)).await;
    let text = scrape(port);
    let reads = metric(&text, ok) - a;
    assert!(
        reads >= 13.0,
        "d1 read {reads} times in 3 s at a 200 ms period:\n{text}"
    );
    let missed =
        "drivebus_transactions_total{bus=\"ml\",drive=\"missing\",op=\"read\",outcome=\"timeout\"}";
    assert!(
        metric(&text, missed) <= 6.0,
        "the missing drive is probed with a back-off:\n{text}"
    );

    // Stop the simulator: d1 goes `timeout` within 200 ms + 2 × 50 ms (+ the way through the
    // broker and this machine's scheduling).
    seen.clear(d1);
    signal(sim.pid(), "STOP");
    let stopped = Instant::now();
    seen.json(&mut c, d1, Duration::from_secs(5), |v| {
        v["state"] == "timeout"
    })
    .await;
    let took = stopped.elapsed();
    assert!(
        took < Duration::from_millis(300 + 400),
        "timeout reported after {took:?}"
    );
    signal(sim.pid(), "CONT");
    let resumed = Instant::now();
    seen.json(&mut c, d1, Duration::from_secs(5), |v| {
        v["state"] == "online"
    })
    .await;
    // The first probe comes 1 s after the timeout.
    let took = resumed.elapsed();
    assert!(
        took < Duration::from_millis(1000 + 400),
        "online again after {took:?}"
    );
    drop(gw);
}

/// A `set` that arrives retained (published while no gateway ran) or stale is refused with a
/// result and never written: a restarted gateway does not move a machine.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn retained_and_stale_sets_are_never_executed_also_after_restart() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let config = format!(
        "{}{}",
        gateway_table(&broker, "max_set_age = \"5s\""),
        simulated_bus("200ms", true)
    );
    let topic = "drivebus/gw/ml/d1/ramp";
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    // Left behind by someone while no gateway ran.
    c.publish(
        &format!("{topic}/set"),
        json!({"value": 9.9, "id": "r"}).to_string(),
        true,
    )
    .await;
    let mut gw = Gateway::start(&config, &[]);
    let r = seen
        .json(
            &mut c,
            &format!("{topic}/result"),
            Duration::from_secs(10),
            |r| r["id"] == "r",
        )
        .await;
    assert_eq!(r["reason"], "retained", "{r}");
    let stale = json!({"value": 3.5, "id": "s", "ts": now_ms() - 60_000});
    let r = set(&mut seen, &mut c, topic, stale).await;
    assert_eq!(r["reason"], "stale", "{r}");
    // Polled every 200 ms: still the factory 2 s after a second.
    tokio::time::sleep(Duration::from_secs(1)).await;
    seen.clear(topic);
    let v = seen
        .json(&mut c, topic, Duration::from_secs(5), |_| true)
        .await;
    assert_eq!(v["raw"], 2000, "{v}");

    // A retained `set` published while the gateway runs: the gateway subscribes with MQTT 5's
    // Retain As Published, so it arrives as retained (as a bridge passes a retained set on at
    // each of its reconnections) and is refused and cleared, never executed.
    c.publish(
        &format!("{topic}/set"),
        json!({"value": 7.7, "id": "r2"}).to_string(),
        true,
    )
    .await;
    let r = seen
        .json(
            &mut c,
            &format!("{topic}/result"),
            Duration::from_secs(10),
            |r| r["id"] == "r2",
        )
        .await;
    assert_eq!(
        (r["ok"].clone(), r["reason"].clone()),
        (json!(false), json!("retained")),
        "{r}"
    );
    tokio::time::sleep(Duration::from_secs(1)).await;
    seen.clear(topic);
    let v = seen
        .json(&mut c, topic, Duration::from_secs(5), |_| true)
        .await;
    assert_eq!(v["raw"], 2000, "the retained set was not executed: {v}");
    // Cleared by the gateway: a client that subscribes later does not get it.
    let mut later = subscriber(&broker, "later").await;
    let mut seen_later = Seen::default();
    assert!(
        seen_later
            .wait(
                &mut later,
                &format!("{topic}/set"),
                Duration::from_millis(500),
                |p| !p.is_empty()
            )
            .await
            .is_none(),
        "the retained set was cleared"
    );
    // Restarted (the simulated plant starts again at the factory 2 s): the retained copy
    // reaches the new connection and is refused, never written again.
    gw.terminate();
    gw.spawn(&[]);
    seen.clear(topic);
    seen.clear(&format!("{topic}/result"));
    // The stopped gateway left its values retained as stale; the new one's first read is
    // fresh.
    let first = seen
        .json(&mut c, topic, Duration::from_secs(10), |v| {
            v.get("stale").is_none()
        })
        .await;
    assert_eq!(first["raw"], 2000, "{first}");
    tokio::time::sleep(Duration::from_secs(1)).await;
    seen.clear(topic);
    let v = seen
        .json(&mut c, topic, Duration::from_secs(5), |_| true)
        .await;
    assert_eq!(
        v["raw"], 2000,
        "the retained set was not executed again: {v}"
    );
    let again = seen
        .wait(
            &mut c,
            &format!("{topic}/result"),
            Duration::from_millis(100),
            |_| true,
        )
        .await;
    if let Some(r) = again {
        let r: Value = serde_json::from_slice(&r).unwrap();
        assert_eq!(r["reason"], "retained", "{r}");
    }
}

/// The broker restarts (losing every retained message): the gateway reconnects and publishes
/// its status and every latest value again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn broker_restart_reconnection_and_republication() {
    let Some(mut broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let config = format!(
        "{}{}",
        gateway_table(&broker, "heartbeat = \"1h\"").replace("heartbeat = \"2s\"\n", ""),
        simulated_bus("30s", false)
    );
    let gw = Gateway::start(&config, &[]);
    {
        let mut c = subscriber(&broker, "scada").await;
        let mut seen = Seen::default();
        seen.json(
            &mut c,
            "drivebus/gw/ml/d1/ramp",
            Duration::from_secs(10),
            |v| v["raw"] == 2000,
        )
        .await;
    }
    broker.restart();
    // A fresh subscriber on the fresh broker: nothing is retained there but what the gateway
    // publishes again after reconnecting (the value is polled only every 30 s, the heartbeat
    // is an hour: this is republication, not a new poll).
    let mut c = subscriber(&broker, "scada2").await;
    let mut seen = Seen::default();
    let online = seen
        .wait(&mut c, "drivebus/gw/status", Duration::from_secs(15), |p| {
            gw_state(p) == "online"
        })
        .await;
    assert!(online.is_some(), "{}", gw.log());
    seen.json(
        &mut c,
        "drivebus/gw/ml/d1/ramp",
        Duration::from_secs(5),
        |v| v["raw"] == 2000,
    )
    .await;
    seen.json(
        &mut c,
        "drivebus/gw/ml/d1/status",
        Duration::from_secs(5),
        |v| v["state"] == "online",
    )
    .await;
}

/// TLS with a generated CA and password authentication; a wrong password is refused (logged,
/// retried, never online, never a crash).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tls_and_password_authentication_and_a_wrong_password() {
    let options = BrokerOptions {
        users: vec![
            ("gw".into(), "s3cret".into()),
            ("scada".into(), "view".into()),
        ],
        tls: true,
        client_certificates: false,
    };
    let Some(broker) = broker(options) else {
        return;
    };
    let plant = |password: &str| {
        let pw = broker.file(&format!("pw-{password}"), &format!("{password}\n"));
        format!(
            "[gateway]\nname = \"gw\"\nbroker = \"mqtts://gw@localhost:{}\"\nca_file = \"{}\"\n\
             password_file = \"{}\"\nmetrics = \"off\"\n{}",
            broker.port,
            broker.ca_file().display(),
            pw.display(),
            simulated_bus("1s", false)
        )
    };
    let mut c = TestClient::connect(
        broker.client_options("scada", Some(("scada", "view"))),
        &["drivebus/gw/#"],
    )
    .await;
    let log = accepted_then_refused(&mut c, &plant("s3cret"), &plant("wrong")).await;
    let lower = log.to_lowercase();
    assert!(
        lower.contains("not authori") || lower.contains("refused"),
        "a wrong password is named as such: {log}"
    );
}

/// The gateway with `good` credentials gets online and publishes P130 (2 s); with `bad` it
/// never gets online, logs why, keeps trying, and stops cleanly at SIGTERM. The bad run's log.
async fn accepted_then_refused(c: &mut TestClient, good: &str, bad: &str) -> String {
    let mut seen = Seen::default();
    let gw = Gateway::start(good, &[]);
    let online = seen
        .wait(c, "drivebus/gw/status", Duration::from_secs(10), |p| {
            gw_state(p) == "online"
        })
        .await;
    assert!(online.is_some(), "{}", gw.log());
    seen.json(c, "drivebus/gw/ml/d1/ramp", Duration::from_secs(5), |v| {
        v["raw"] == 2000
    })
    .await;
    drop(gw);
    seen.clear("drivebus/gw/status");
    let mut gw = Gateway::start(bad, &[]);
    let online = seen
        .wait(c, "drivebus/gw/status", Duration::from_secs(3), |p| {
            gw_state(p) == "online"
        })
        .await;
    assert!(online.is_none(), "refused credentials must not get online");
    let log = gw.log();
    assert!(log.contains("broker"), "the refusal is logged: {log}");
    let status = gw.terminate();
    assert!(
        status.success(),
        "still running, stopped cleanly: {status:?}\n{log}"
    );
    log
}

/// The example config runs as it is with `--simulate` (and `--broker`): every drive of every
/// family is online, every point is published, and every writable point takes a `set`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_example_config_runs_with_simulate() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let out = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let example = String::from_utf8(out.stdout).unwrap();
    // The documented sequence (docs/gateway.md, README): the example serves /metrics on
    // 127.0.0.1:9464, which `curl` then reads. Here on a free port, as tests run side by side.
    let documented = "metrics = \"127.0.0.1:9464\"";
    assert!(example.contains(documented), "{example}");
    let port = free_port();
    let example = example.replace(documented, &format!("metrics = \"127.0.0.1:{port}\""));
    let mut c = TestClient::connect(
        broker.client_options("scada", None),
        &["drivebus/cabinet-1/#"],
    )
    .await;
    let mut seen = Seen::default();
    let gw = Gateway::start(&example, &["--simulate", "--broker", &broker.url()]);
    let online = seen
        .wait(
            &mut c,
            "drivebus/cabinet-1/status",
            Duration::from_secs(10),
            |p| gw_state(p) == "online",
        )
        .await;
    assert!(online.is_some(), "{}", gw.log());
    let metrics = scrape(port);
    assert!(metrics.contains("drivebus_broker_connected 1"), "{metrics}");
    // The drives and writable points of the example, from the file itself.
    let plant: toml::Value = toml::from_str(&example).unwrap();
    let mut sets = 0;
    for bus in plant["bus"].as_array().unwrap() {
        let b = bus["name"].as_str().unwrap();
        for drive in bus["drive"].as_array().unwrap() {
            let d = drive["name"].as_str().unwrap();
            let st = seen
                .json(
                    &mut c,
                    &format!("drivebus/cabinet-1/{b}/{d}/status"),
                    Duration::from_secs(15),
                    |_| true,
                )
                .await;
            assert_eq!(st["state"], "online", "{b}/{d}: {st}");
            for p in drive["param"].as_array().unwrap() {
                let topic = format!("drivebus/cabinet-1/{b}/{d}/{}", p["name"].as_str().unwrap());
                let v = seen
                    .json(&mut c, &topic, Duration::from_secs(40), |_| true)
                    .await;
                let raw = v["raw"].as_i64().unwrap_or_else(|| panic!("{topic}: {v}"));
                if p.get("writable").and_then(toml::Value::as_bool) == Some(true) {
                    let id = format!("{b}/{d}");
                    let r = set(
                        &mut seen,
                        &mut c,
                        &topic,
                        json!({"raw": raw, "id": id, "ts": now_ms()}),
                    )
                    .await;
                    assert_eq!(r["ok"], true, "{topic}: {r}");
                    sets += 1;
                }
            }
        }
    }
    assert!(sets >= 5, "a writable point on every bus");
}

/// Client-certificate authentication: a broker that requires a certificate signed by its CA
/// takes the gateway's (`client_cert`/`client_key`) and refuses one signed by another CA.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_certificate_authentication() {
    let options = BrokerOptions {
        tls: true,
        client_certificates: true,
        ..BrokerOptions::default()
    };
    let Some(broker) = broker(options) else {
        return;
    };
    let plant = |who: &str| {
        format!(
            "[gateway]\nname = \"gw\"\nbroker = \"mqtts://localhost:{}\"\nca_file = \"{}\"\n\
             client_cert = \"{d}/{who}.pem\"\nclient_key = \"{d}/{who}.key\"\nmetrics = \"off\"\n{}",
            broker.port,
            broker.ca_file().display(),
            simulated_bus("1s", false),
            d = broker.dir.display()
        )
    };
    let mut c = TestClient::connect(broker.client_options("scada", None), &["drivebus/gw/#"]).await;
    accepted_then_refused(&mut c, &plant("gw"), &plant("rogue")).await;
}

/// A point with `eeprom = true` is written to EEPROM under the wear rule of `drivectl write`:
/// a second write of the same parameter of the same drive within a second is refused (`wear`),
/// and nothing is sent.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn eeprom_writes_keep_the_wear_rule() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let config = format!(
        "{}{}eeprom = true\n",
        gateway_table(&broker, ""),
        simulated_bus("200ms", true)
    );
    let topic = "drivebus/gw/ml/d1/ramp";
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let gw = Gateway::start(&config, &[]);
    seen.json(&mut c, topic, Duration::from_secs(10), |v| v["raw"] == 2000)
        .await;
    let r = set(&mut seen, &mut c, topic, json!({"value": 3.5, "id": 1})).await;
    assert_eq!(r["outcome"], "written", "{r}\n{}", gw.log());
    let r = set(&mut seen, &mut c, topic, json!({"value": 3.6, "id": 2})).await;
    assert_eq!(r["reason"], "wear", "{r}");
    seen.clear(topic);
    tokio::time::sleep(Duration::from_millis(500)).await;
    let v = seen
        .json(&mut c, topic, Duration::from_secs(5), |_| true)
        .await;
    assert_eq!(v["raw"], 3500, "the refused write was not sent: {v}");
    // The wear log is the gateway's state directory's, as for drivectl write.
    assert!(gw.dir.join("state").join("eeprom-writes.json").is_file());
}

/// Sets for points the gateway does not have are ignored (no result, no crash), counted on
/// `/metrics`, and a flood of them is logged once per 10 s, not once each.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_of_sets_for_unknown_points_is_logged_once() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let port = free_port();
    let config = format!(
        "{}{}",
        gateway_table(&broker, "").replace(
            "metrics = \"off\"",
            &format!("metrics = \"127.0.0.1:{port}\"")
        ),
        simulated_bus("1s", true)
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let gw = Gateway::start(&config, &[]);
    seen.wait(&mut c, "drivebus/gw/status", Duration::from_secs(10), |p| {
        gw_state(p) == "online"
    })
    .await
    .expect("online");
    for i in 0..200 {
        c.publish(
            &format!("drivebus/gw/ml/d1/nothing{i}/set"),
            "{\"value\": 1}",
            false,
        )
        .await;
    }
    // The gateway still answers a real set after the flood.
    let r = set(
        &mut seen,
        &mut c,
        "drivebus/gw/ml/d1/ramp",
        json!({"value": 3.5, "id": "after"}),
    )
    .await;
    assert_eq!(r["ok"], true, "{r}");
    let text = scrape(port);
    assert_eq!(
        metric(&text, "drivebus_sets_total{outcome=\"unknown_topic\"}"),
        200.0,
        "{text}"
    );
    let logged = gw.log().matches("a set for no point").count();
    assert_eq!(logged, 1, "{}", gw.log());
    assert!(
        seen.0
            .keys()
            .all(|t| !t.contains("nothing") || t.ends_with("/set")),
        "no result for an unknown point"
    );
}

/// A drive the gateway controls over process data is stopped when the gateway stops (SIGTERM),
/// as `drivectl pd` stops it at its end: read back directly afterwards, it is no longer enabled.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_stops_the_drives_the_gateway_controls() {
    stops_the_drives_at("TERM").await;
}

/// Issue 18: SIGQUIT stops the gateway as SIGTERM does, with the stop in the process data; it
/// killed it without one (the signal's default action) and left the drive enabled. (SIGHUP
/// reloads the config since issue 22, or stops the gateway when its terminal closed:
/// `tests/reload.rs`.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue18_sigquit_stops_the_drives_the_gateway_controls() {
    stops_the_drives_at("QUIT").await;
}

/// A MOVILINK drive enabled over process data by the gateway, then `sig` to the gateway: it
/// exits successfully, says it stopped on `sig`, and the drive read back is no longer enabled.
async fn stops_the_drives_at(sig: &str) {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
    ]);
    let config = format!(
        "{}[[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [bus.drive.process_data]\nperiod = \"50ms\"\nout = [6, 7500, 0]\n",
        gateway_table(&broker, ""),
        sim.path
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let mut gw = Gateway::start(&config, &[]);
    // PI1 = status word 1; while no fault is shown its high byte is the unit status: 4 =
    // enable.
    let pd = seen
        .json(
            &mut c,
            "drivebus/gw/ml/d1/pd",
            Duration::from_secs(10),
            |v| v["in"][0].as_u64().is_some_and(|w| w >> 8 == 4),
        )
        .await;
    assert_eq!(pd["out"], json!([6, 7500, 0]), "{pd}");
    let status = gw.stop_with(sig);
    assert!(status.success(), "SIG{sig}: {status:?}\n{}", gw.log());
    assert_figures_rounded(&gw.log());
    assert!(
        gw.log()
            .lines()
            .any(|l| l.contains("bus polling starts") && l.contains(" %") && l.contains("demand=")),
        "{}",
        gw.log()
    );
    assert!(
        gw.log().contains(&format!("signal=\"SIG{sig}\""))
            || gw.log().contains(&format!("signal=SIG{sig}")),
        "{}",
        gw.log()
    );
    assert!(
        gw.log().contains("stop sent in the process data"),
        "{}",
        gw.log()
    );
    // Said at the start: the simulated MOVIDRIVE has its RS-485 timeout off (factory).
    assert!(
        gw.log()
            .lines()
            .any(|l| l.contains("process data: the drive's RS-485 timeout P812 is 0")),
        "{}",
        gw.log()
    );
    let p010 = ok_json(&sim.drivectl(&[
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json", "read",
        "P010",
    ]));
    let raw = p010[0]["raw"].as_i64().unwrap();
    assert_ne!(
        raw >> 8 & 0xFF,
        4,
        "still enabled after the gateway stopped: {p010:?}"
    );
}

/// Without a usable EEPROM-wear log (its state directory is a file) an EEPROM point is refused
/// (`wear`, nothing sent) with the gateway's way out, not the command line's options; a RAM
/// point beside it is written.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unusable_wear_log_refuses_eeprom_writes_only() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let not_a_dir = broker.file("state-is-a-file", "");
    let config = format!(
        "{}{}eeprom = true\n[[bus.drive.param]]\nparam = \"P131\"\nname = \"ramp_down\"\nperiod = \"1s\"\nwritable = true\n",
        gateway_table(&broker, ""),
        simulated_bus("200ms", true)
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let gw = Gateway::start_with_state(&config, not_a_dir);
    seen.json(
        &mut c,
        "drivebus/gw/ml/d1/ramp",
        Duration::from_secs(10),
        |v| v["raw"] == 2000,
    )
    .await;
    let r = set(
        &mut seen,
        &mut c,
        "drivebus/gw/ml/d1/ramp",
        json!({"value": 3.5, "id": 1}),
    )
    .await;
    assert_eq!(r["reason"], "wear", "{r}\n{}", gw.log());
    let m = r["message"].as_str().unwrap();
    assert!(
        m.contains("DRIVECTL_STATE_DIR") && m.contains("without eeprom"),
        "{m}"
    );
    assert!(
        !m.contains("--volatile") && !m.contains("--force"),
        "no command-line options: {m}"
    );
    let r = set(
        &mut seen,
        &mut c,
        "drivebus/gw/ml/d1/ramp_down",
        json!({"value": 3.5, "id": 2}),
    )
    .await;
    assert_eq!(r["outcome"], "written", "{r}");
}

/// Issue 18 A2, end to end: `drivectl gateway --check` refuses a NORD parameter set, a NORD
/// array element and a Bonfiglioli data set the table does not give the parameter, and a
/// write to a read-only parameter, naming the file's line and the config key (exit 2, nothing
/// on standard output); the example config passes.
#[test]
fn issue18_check_refuses_selectors_the_table_does_not_have() {
    let dir = std::env::temp_dir().join(format!("drivebus-gw-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let head = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://127.0.0.1:1883\"\n\n";
    let cases = [
        (
            "[[bus]]\nname = \"line1\"\nprotocol = \"uss\"\nport = \"/dev/ttyUSB0\"\n\n\
             [[bus.drive]]\nname = \"pump\"\naddress = 1\n\n\
             [[bus.drive.param]]\nparam = \"P102\"\nname = \"ramp\"\nperiod = \"1s\"\nset = 5\n",
            "set = 5",
            "bus \"line1\" drive \"pump\" point \"ramp\": set = 5: P102 acceleration time has parameter sets 1–4",
        ),
        (
            "[[bus]]\nname = \"line1\"\nprotocol = \"uss\"\nport = \"/dev/ttyUSB0\"\n\n\
             [[bus.drive]]\nname = \"pump\"\naddress = 1\n\n\
             [[bus.drive.param]]\nparam = \"P543\"\nname = \"actual\"\nperiod = \"1s\"\n",
            "param = ",
            "point \"actual\": P543 bus actual value is an array of 3 elements ([-01]…[-03]): give array = 1…3",
        ),
        (
            "[[bus]]\nname = \"line3\"\nprotocol = \"modbus-rtu\"\nport = \"/dev/ttyUSB2\"\n\n\
             [[bus.drive]]\nname = \"fan\"\naddress = 1\n\n\
             [[bus.drive.param]]\nparam = \"260\"\nname = \"fault\"\nperiod = \"1s\"\ndata_set = 2\n",
            "data_set = 2",
            "point \"fault\": data_set = 2: 260 Current fault has no data sets",
        ),
        (
            "[[bus]]\nname = \"line1\"\nprotocol = \"uss\"\nport = \"/dev/ttyUSB0\"\n\n\
             [[bus.drive]]\nname = \"pump\"\naddress = 1\n\n\
             [[bus.drive.param]]\nparam = \"P700\"\narray = 1\nname = \"fault\"\nwritable = true\n",
            "writable = true",
            "point \"fault\": writable = true: P700 present fault is read-only",
        ),
    ];
    for (bus, key, needle) in cases {
        let text = format!("{head}{bus}");
        let path = dir.join("plant.toml");
        std::fs::write(&path, &text).unwrap();
        let line = text.lines().position(|l| l.starts_with(key)).unwrap() + 1;
        let out = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(["gateway", "--check", "--config"])
            .arg(&path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            out.stdout.is_empty(),
            "{}",
            String::from_utf8_lossy(&out.stdout)
        );
        let at = format!("{}:{line}: ", path.display());
        assert!(stderr.contains(&at), "not at {at}: {stderr}");
        assert!(stderr.contains(needle), "`{needle}` not in: {stderr}");
        assert!(!stderr.contains("--"), "a command-line option in: {stderr}");
    }
    // The example config passes --check as it is.
    let example = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    std::fs::write(dir.join("example.toml"), &example.stdout).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["gateway", "--check", "--config"])
        .arg(dir.join("example.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 18 A4: a retained 1.5 MiB message on a `set` topic (over the gateway's 1 MiB limit)
/// does not end the gateway's connection: it stays connected (one ConnAck, no reconnection,
/// its status never `offline`), normal sets are executed, and the oversize message is never
/// executed. Beside it: a retained 1.5 MiB message on a topic the gateway does not subscribe
/// to changes nothing, and a live set just under the limit arrives and is refused as
/// `bad_request` on its result.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue18_an_oversize_retained_set_does_not_end_the_connection() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let topic = "drivebus/gw/ml/d1/ramp";
    // A publisher that may send large messages, subscribed to nothing.
    let mut big = broker.client_options("big", None);
    big.set_max_packet_size(4 << 20, 4 << 20);
    let publisher = TestClient::connect(big, &[]).await;
    let huge = |n: usize| {
        let mut body = json!({"value": 9.9, "id": "huge", "pad": ""}).to_string();
        body.insert_str(body.len() - 2, &"x".repeat(n));
        body
    };
    publisher
        .publish(&format!("{topic}/set"), huge(3 << 19), true)
        .await;
    publisher
        .publish("drivebus/gw/ml/other/status", huge(3 << 19), true)
        .await;
    // SCADA watches the gateway's topics, not the set topics (the huge message is over its
    // own client's limit too).
    let mut c = TestClient::connect(
        broker.client_options("scada", None),
        &[
            "drivebus/gw/status",
            "drivebus/gw/ml/d1/status",
            topic,
            &format!("{topic}/result"),
        ],
    )
    .await;
    let mut seen = Seen::default();
    let config = format!(
        "{}{}",
        gateway_table(&broker, ""),
        simulated_bus("200ms", true)
    );
    let mut gw = Gateway::start(&config, &[]);
    seen.wait(&mut c, "drivebus/gw/status", Duration::from_secs(10), |p| {
        gw_state(p) == "online"
    })
    .await
    .unwrap_or_else(|| panic!("never online:\n{}", gw.log()));
    seen.json(&mut c, topic, Duration::from_secs(10), |v| v["raw"] == 2000)
        .await;
    // Several seconds of operation: a reconnection would have come twice a second.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let r = set(
        &mut seen,
        &mut c,
        topic,
        json!({"value": 2.5, "id": 1, "ts": now_ms()}),
    )
    .await;
    assert_eq!(r["outcome"], "written", "{r}\n{}", gw.log());
    // Just under the limit: taken from the broker, refused as too large for a set.
    publisher
        .publish(&format!("{topic}/set"), huge((1 << 20) - 200), false)
        .await;
    let r = seen
        .json(
            &mut c,
            &format!("{topic}/result"),
            Duration::from_secs(10),
            |v| v["outcome"] == "refused",
        )
        .await;
    // Refused before it is parsed: its id is not read.
    assert_eq!(r["reason"], "bad_request", "{r}");
    assert!(r["message"].as_str().unwrap().contains("4096"), "{r}");
    seen.wait(&mut c, "drivebus/gw/status", Duration::from_secs(1), |_| {
        false
    })
    .await;
    let statuses = seen
        .0
        .get("drivebus/gw/status")
        .cloned()
        .unwrap_or_default();
    assert!(
        statuses.iter().all(|p| gw_state(p) == "online"),
        "the status flapped: {:?}",
        statuses
            .iter()
            .map(|p| String::from_utf8_lossy(p).into_owned())
            .collect::<Vec<_>>()
    );
    let log = gw.log();
    assert_eq!(
        log.matches("connected to the broker").count(),
        1,
        "reconnected:\n{log}"
    );
    assert!(!log.contains("lost the broker connection"), "{log}");
    assert_figures_rounded(&log);
    // The broker dropped the oversize set for the gateway (MQTT 5: it honours the client's
    // Maximum Packet Size) and logged that it did; the gateway never saw it, so it could not
    // answer it on its result.
    let broker_log = std::fs::read_to_string(broker.dir.join("mosquitto.log")).unwrap();
    assert!(
        broker_log.contains("Dropping too large outgoing PUBLISH for drivebus-gw"),
        "{broker_log}"
    );
    assert!(gw.terminate().success());
    let results = seen
        .0
        .get(&format!("{topic}/result"))
        .cloned()
        .unwrap_or_default();
    assert_eq!(results.len(), 2, "one written, one bad_request");
}

/// Issue 18: two gateways with one `client_id` on a broker. The broker ends the older
/// connection when the newer one connects (Mosquitto closes it without a DISCONNECT); the log
/// says the client id is probably in use by another client and names the key to change (it
/// said only "Connection closed by peer abruptly").
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue18_two_gateways_with_one_client_id_are_told_apart_in_the_log() {
    let Some(broker) = broker(BrokerOptions::default()) else {
        return;
    };
    let config = format!(
        "{}{}",
        gateway_table(&broker, "client_id = \"cabinet\""),
        simulated_bus("1s", false)
    );
    let mut c = subscriber(&broker, "scada").await;
    let mut seen = Seen::default();
    let mut first = Gateway::start(&config, &[]);
    seen.wait(&mut c, "drivebus/gw/status", Duration::from_secs(10), |p| {
        gw_state(p) == "online"
    })
    .await
    .unwrap_or_else(|| panic!("never online:\n{}", first.log()));
    let mut second = Gateway::start(&config, &[]);
    let deadline = Instant::now() + Duration::from_secs(10);
    let said = "the client id \"cabinet\" is probably in use by another client";
    while !first.log().contains(said) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
    }
    let log = first.log();
    assert!(log.contains(said), "{log}");
    assert!(log.contains("[gateway] client_id"), "{log}");
    assert!(!log.contains("closed by peer abruptly"), "{log}");
    assert!(first.terminate().success());
    assert!(second.terminate().success());
}
