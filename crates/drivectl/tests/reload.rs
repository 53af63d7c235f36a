//! Issue 22, item 2: `drivectl gateway` reads its config again at SIGHUP, as `systemctl reload`
//! asks, against a real Mosquitto broker and a drive behind a pseudo-terminal: a bus whose
//! settings did not change keeps running (its port stays open, its polls keep their period, a
//! write under way is answered), a new drive appears, a removed one's retained topics are gone,
//! and a broken config changes nothing and says why on the gateway's status topic.

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

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::PtySim;
use gateway::{Gateway, free_port, free_ports, metric, scrape};
use mosquitto::{BrokerOptions, Mosquitto, TestClient};
use serde_json::{Value, json};

const WAIT: Duration = Duration::from_secs(15);

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

/// A subscriber that keeps what it received on other topics for later questions.
struct Inbox {
    c: TestClient,
    kept: Vec<(String, Value)>,
}

impl Inbox {
    async fn connect(broker: &Mosquitto, id: &str, topics: &[&str]) -> Inbox {
        Inbox {
            c: TestClient::connect(broker.client_options(id, None), topics).await,
            kept: Vec::new(),
        }
    }

    /// The first JSON message on `topic` (kept from before, or arriving within [`WAIT`]) that
    /// satisfies `pred`; it and the messages on `topic` before it are taken.
    async fn next(
        &mut self,
        topic: &str,
        what: &str,
        mut pred: impl FnMut(&Value) -> bool,
    ) -> Value {
        let deadline = tokio::time::Instant::now() + WAIT;
        loop {
            if let Some(i) = self.kept.iter().position(|(t, v)| t == topic && pred(v)) {
                let v = self.kept[i].1.clone();
                let mut k = 0;
                self.kept.retain(|(t, _)| {
                    let keep = !(t == topic && k <= i);
                    k += 1;
                    keep
                });
                return v;
            }
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            if left.is_zero() {
                panic!(
                    "no {what} on {topic} within {} s; got {:?}",
                    WAIT.as_secs(),
                    self.kept
                        .iter()
                        .filter(|(t, _)| t == topic)
                        .collect::<Vec<_>>()
                );
            }
            for p in self.c.collect(left.min(Duration::from_millis(100))).await {
                if !p.payload.is_empty()
                    && let Ok(v) = serde_json::from_slice(&p.payload)
                {
                    self.kept.push((p.topic.clone(), v));
                }
            }
        }
    }

    async fn publish(&self, topic: &str, payload: String) {
        self.c.publish(topic, payload, false).await;
    }
}

/// The kept bus's reads counted on `/metrics` every 20 ms, with when, until stopped.
struct Sampler {
    stop: Arc<AtomicBool>,
    samples: Arc<Mutex<Vec<(Instant, f64)>>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

const KEEP_READS: &str =
    "drivebus_transactions_total{bus=\"keep\",drive=\"d1\",op=\"read\",outcome=\"ok\"}";

impl Sampler {
    fn start(port: u16) -> Sampler {
        let stop = Arc::new(AtomicBool::new(false));
        let samples = Arc::new(Mutex::new(Vec::new()));
        let (s, v) = (stop.clone(), samples.clone());
        let thread = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                let n = metric(&scrape(port), KEEP_READS);
                v.lock().unwrap().push((Instant::now(), n));
                std::thread::sleep(Duration::from_millis(20));
            }
        });
        Sampler {
            stop,
            samples,
            thread: Some(thread),
        }
    }

    fn finish(mut self) -> Vec<(Instant, f64)> {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
        self.samples.lock().unwrap().clone()
    }
}

/// The times between one increase of the count and the next, in ms, for the samples in
/// `[from, to]`.
fn gaps(samples: &[(Instant, f64)], from: Instant, to: Instant) -> Vec<u64> {
    let mut out = Vec::new();
    let mut last: Option<(Instant, f64)> = None;
    for &(t, n) in samples.iter().filter(|(t, _)| *t >= from && *t <= to) {
        match last {
            Some((lt, ln)) if n > ln => {
                out.push(t.duration_since(lt).as_millis() as u64);
                last = Some((t, n));
            }
            None => last = Some((t, n)),
            _ => {}
        }
    }
    out
}

fn median(v: &[u64]) -> u64 {
    let mut s = v.to_vec();
    s.sort_unstable();
    s.get(s.len() / 2).copied().unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue22_sighup_reloads_the_config_and_keeps_what_did_not_change() {
    let Some(broker) = Mosquitto::start(BrokerOptions::default()) else {
        return;
    };
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
    ]);
    let port = free_port();
    let head = format!(
        "[gateway]\nname = \"gw\"\nbroker = \"{}\"\nmetrics = \"127.0.0.1:{port}\"\n\
         heartbeat = \"2s\"\nmax_set_age = \"10s\"\n",
        broker.url()
    );
    // On a real port: reads every 100 ms (a MOVILINK read at 9600 baud takes about 25 ms).
    let keep = format!(
        "[[bus]]\nname = \"keep\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P000\"\nname = \"speed\"\nperiod = \"100ms\"\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"1s\"\nwritable = true\n",
        sim.path
    );
    let gone = "[[bus]]\nname = \"gone\"\nprotocol = \"modbus-rtu\"\nsimulate = true\n\
                [[bus.drive]]\nname = \"d2\"\naddress = 1\n\
                [[bus.drive.param]]\nparam = \"241\"\nname = \"frequency\"\nperiod = \"500ms\"\n";
    let fresh = "[[bus]]\nname = \"fresh\"\nprotocol = \"sbus\"\nsimulate = true\n\
                 [[bus.drive]]\nname = \"d3\"\naddress = 3\n\
                 [[bus.drive.param]]\nparam = \"P000\"\nname = \"speed\"\nperiod = \"500ms\"\n";
    let mut c = Inbox::connect(&broker, "scada", &["drivebus/gw/#"]).await;
    let mut gw = Gateway::start(&format!("{head}{keep}{gone}"), &[]);
    let status = "drivebus/gw/status";
    let v = c.next(status, "online", |v| v["state"] == "online").await;
    assert_eq!(v["config"]["generation"], 1, "{v}");
    let file = gw.dir.join("plant.toml");
    assert_eq!(
        v["config"]["file"],
        json!(std::fs::canonicalize(&file).unwrap().to_string_lossy()),
        "the status names the config file: {v}"
    );
    c.next("drivebus/gw/gone/d2/frequency", "a value", |_| true)
        .await;
    c.next("drivebus/gw/keep/d1/speed", "a value", |_| true)
        .await;

    // The reload: `fresh` before `keep` (which moves from bus 0 to bus 1), `gone` removed, and
    // a write of the kept bus on its way.
    let sampler = Sampler::start(port);
    tokio::time::sleep(Duration::from_millis(1500)).await;
    gw.write_config(&format!("{head}{fresh}{keep}"));
    c.publish(
        "drivebus/gw/keep/d1/ramp/set",
        json!({"value": 3.5, "ts": now_ms(), "id": "w1"}).to_string(),
    )
    .await;
    let reload_at = Instant::now();
    gw.signal("HUP");
    let v = c
        .next(status, "generation 2", |v| v["config"]["generation"] == 2)
        .await;
    let effect = Instant::now();
    assert_eq!(v["state"], "online", "{v}");
    assert_eq!(v["config"]["last_reload"]["ok"], true, "{v}");
    // The write under way was executed, on the bus that ran on.
    let r = c
        .next("drivebus/gw/keep/d1/ramp/result", "w1's result", |r| {
            r["id"] == "w1"
        })
        .await;
    assert_eq!(
        (&r["outcome"], &r["raw"]),
        (&json!("written"), &json!(3500)),
        "{r}"
    );
    // The new drive appears.
    let st = c
        .next("drivebus/gw/fresh/d3/status", "d3's status", |_| true)
        .await;
    assert_eq!(st["state"], "online", "{st}");
    c.next("drivebus/gw/fresh/d3/speed", "d3's value", |_| true)
        .await;
    // A write to the kept bus at its new place, after the reload.
    c.publish(
        "drivebus/gw/keep/d1/ramp/set",
        json!({"value": 4.5, "ts": now_ms(), "id": "w2"}).to_string(),
    )
    .await;
    let r = c
        .next("drivebus/gw/keep/d1/ramp/result", "w2's result", |r| {
            r["id"] == "w2"
        })
        .await;
    assert_eq!(
        (&r["outcome"], &r["raw"]),
        (&json!("written"), &json!(4500)),
        "{r}"
    );
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let samples = sampler.finish();

    // The kept bus kept its period across the reload: the longest time without a read around
    // it is that of the minutes before, not a restart's.
    let before = gaps(&samples, reload_at - Duration::from_millis(1500), reload_at);
    let across = gaps(
        &samples,
        reload_at - Duration::from_millis(200),
        effect + Duration::from_millis(1000),
    );
    let (typical, worst) = (median(&before), across.iter().copied().max().unwrap_or(0));
    eprintln!(
        "kept bus reads: median gap before the reload {typical} ms (of {} gaps), longest across \
         it {worst} ms (of {}); the reload took {} ms from SIGHUP to the new status",
        before.len(),
        across.len(),
        effect.duration_since(reload_at).as_millis()
    );
    assert!(before.len() >= 5 && across.len() >= 5, "{samples:?}");
    assert!(
        worst <= 400,
        "the kept bus stopped polling for {worst} ms across the reload (typical {typical} ms)"
    );
    // Its counts went on (no restart of its series).
    let last = samples.last().map_or(0.0, |s| s.1);
    assert!(last > samples[0].1, "{samples:?}");
    // Its port was opened once, and never again.
    let log = gw.log();
    let opened = log
        .lines()
        .filter(|l| l.contains("port open") && l.contains("bus=keep"))
        .count();
    assert_eq!(opened, 1, "{log}");

    // The removed bus's retained topics are gone: a new subscriber gets none of them.
    let mut late =
        TestClient::connect(broker.client_options("late", None), &["drivebus/gw/gone/#"]).await;
    let left: Vec<String> = late
        .collect(Duration::from_millis(700))
        .await
        .into_iter()
        .filter(|p| !p.payload.is_empty())
        .map(|p| p.topic)
        .collect();
    assert!(
        left.is_empty(),
        "retained topics of the removed bus: {left:?}"
    );
    // Nor does /metrics have its series; it counts the reload.
    let text = scrape(port);
    assert!(!text.contains("bus=\"gone\""), "{text}");
    assert!(text.contains("bus=\"fresh\""), "{text}");
    assert_eq!(metric(&text, "drivebus_config_generation "), 2.0, "{text}");
    assert_eq!(
        metric(&text, "drivebus_config_reloads_total{outcome=\"applied\"}"),
        1.0,
        "{text}"
    );

    // A broken config changes nothing and says why, on the status topic and in the log.
    gw.write_config(&format!(
        "{head}[[bus]]\nname = \"x\"\nprotocol = \"movilink\"\nperiod = 5\n"
    ));
    gw.signal("HUP");
    let v = c
        .next(status, "the refused reload", |v| {
            v["config"]["last_reload"]["ok"] == false
        })
        .await;
    assert_eq!(v["config"]["generation"], 2, "{v}");
    let error = v["config"]["last_reload"]["error"].as_str().unwrap();
    assert!(
        error.contains("plant.toml:") && error.contains("period"),
        "{error}"
    );
    assert!(
        gw.log().contains("the reloaded config was refused"),
        "{}",
        gw.log()
    );
    let text = scrape(port);
    assert_eq!(
        metric(&text, "drivebus_config_reloads_total{outcome=\"refused\"}"),
        1.0,
        "{text}"
    );
    assert_eq!(metric(&text, "drivebus_config_generation "), 2.0, "{text}");
    // Still polling both buses, nothing cleared.
    let mut after = TestClient::connect(
        broker.client_options("after", None),
        &["drivebus/gw/fresh/#", "drivebus/gw/keep/#"],
    )
    .await;
    let got = after.collect(Duration::from_millis(1200)).await;
    for t in ["drivebus/gw/fresh/d3/status", "drivebus/gw/keep/d1/speed"] {
        assert!(
            got.iter().any(|p| p.topic == t && !p.payload.is_empty()),
            "{t} in {:?}",
            got.iter().map(|p| &p.topic).collect::<Vec<_>>()
        );
    }
    assert!(gw.running(), "{}", gw.log());
    let status = gw.terminate();
    assert!(status.success(), "{status:?}\n{}", gw.log());
}

/// A drive enabled over process data by the gateway of `config`'s bus `ml` (PI1's unit status
/// 4 = enable, while no fault shows).
fn enabled(sim: &PtySim) -> bool {
    let p010 = common::ok_json(&sim.drivectl(&[
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json", "read",
        "P010",
    ]));
    p010[0]["raw"].as_i64().unwrap() >> 8 & 0xFF == 4
}

/// SIGHUP is a reload: a drive the gateway controls over process data keeps running (no stop
/// is sent); but when the gateway's terminal closes (the SIGHUP of a hang-up), it stops as at
/// SIGTERM, and the drive gets its stop.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue22_sighup_reloads_with_the_drives_running_a_closed_terminal_stops_them() {
    let Some(broker) = Mosquitto::start(BrokerOptions::default()) else {
        return;
    };
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
    ]);
    let config = format!(
        "[gateway]\nname = \"gw\"\nbroker = \"{}\"\nmetrics = \"off\"\nheartbeat = \"1s\"\n\
         [[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [bus.drive.process_data]\nperiod = \"50ms\"\nout = [6, 7500, 0]\n",
        broker.url(),
        sim.path
    );
    let mut c = Inbox::connect(&broker, "scada", &["drivebus/gw/#"]).await;
    let mut gw = Gateway::start(&config, &[]);
    c.next("drivebus/gw/ml/d1/pd", "the drive enabled", |v| {
        v["in"][0].as_u64().is_some_and(|w| w >> 8 == 4)
    })
    .await;
    gw.signal("HUP");
    let v = c
        .next("drivebus/gw/status", "the reload's outcome", |v| {
            v["config"]["last_reload"]["ok"] == true
        })
        .await;
    assert_eq!(v["config"]["generation"], 1, "the config is unchanged: {v}");
    // Still enabled after the reload (the process data, published every heartbeat, read
    // after it).
    let after = now_ms();
    let pd = c
        .next(
            "drivebus/gw/ml/d1/pd",
            "process data after the reload",
            |v| v["ts"].as_u64().is_some_and(|t| t > after + 200),
        )
        .await;
    assert_eq!(pd["in"][0].as_u64().unwrap() >> 8, 4, "enabled: {pd}");
    assert!(gw.running(), "{}", gw.log());
    assert!(!gw.log().contains("stop sent"), "{}", gw.log());
    assert!(gw.log().contains("the config is unchanged"), "{}", gw.log());
    // A changed bus (a point added) is restarted on the same port: the drive whose process
    // data the new config carries on gets no stop, and runs on.
    gw.write_config(&format!(
        "{config}[[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"1s\"\n"
    ));
    gw.signal("HUP");
    c.next("drivebus/gw/status", "generation 2", |v| {
        v["config"]["generation"] == 2
    })
    .await;
    c.next("drivebus/gw/ml/d1/ramp", "the new point", |_| true)
        .await;
    let after = now_ms();
    let pd = c
        .next(
            "drivebus/gw/ml/d1/pd",
            "process data after the restart",
            |v| v["ts"].as_u64().is_some_and(|t| t > after),
        )
        .await;
    assert_eq!(pd["in"][0].as_u64().unwrap() >> 8, 4, "enabled: {pd}");
    let log = gw.log();
    assert!(!log.contains("stop sent in the process data"), "{log}");
    assert!(
        log.contains("no stop sent: the reloaded config carries on its process data"),
        "{log}"
    );
    let status = gw.terminate();
    assert!(status.success(), "{status:?}");
    assert!(!enabled(&sim), "the stop at SIGTERM");

    // In a terminal (a pseudo-terminal as the gateway's controlling terminal, python's
    // pty.fork): SIGHUP with the terminal there reloads; the terminal closing stops it.
    let dir = std::env::temp_dir().join(format!("drivebus-reload-pty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("plant.toml");
    let log = dir.join("gateway.log");
    std::fs::write(&cfg, &config).unwrap();
    let script = r#"
import os, pty, sys, time
exe, cfg, log = sys.argv[1], sys.argv[2], sys.argv[3]
pid, fd = pty.fork()
if pid == 0:
    f = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    os.dup2(f, 2)
    os.execv(exe, [exe, "gateway", "--config", cfg])
def wait_for(text):
    deadline = time.time() + 15
    while time.time() < deadline:
        if os.path.exists(log) and text in open(log).read():
            return
        time.sleep(0.05)
    sys.exit("no " + text)
wait_for("connected to the broker")
time.sleep(1.0)
os.kill(pid, 1)
wait_for("SIGHUP: reading the config again")
time.sleep(0.5)
os.close(fd)
_, status = os.waitpid(pid, 0)
print(os.waitstatus_to_exitcode(status))
"#;
    let python = std::process::Command::new("python3")
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_drivectl"))
        .arg(&cfg)
        .arg(&log)
        .output();
    let out = match python {
        Ok(o) => o,
        Err(e) if std::env::var_os("CI").is_none() => {
            eprintln!("SKIPPED the terminal part: python3 cannot run ({e})");
            return;
        }
        Err(e) => panic!("python3 (for a pseudo-terminal as controlling terminal): {e}"),
    };
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stderr),
        text
    );
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "0",
        "the gateway's exit code\n{text}"
    );
    assert!(text.contains("the config is unchanged"), "{text}");
    assert!(text.contains("SIGHUP: the terminal closed"), "{text}");
    assert!(text.contains("stop sent in the process data"), "{text}");
    assert!(!enabled(&sim), "stopped when the terminal closed");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The retained topics `topics` hold at `broker`, as a new subscriber gets them (empty ones,
/// clears, left out).
async fn retained(broker: &Mosquitto, id: &str, topics: &[&str]) -> Vec<(String, Value)> {
    let mut c = TestClient::connect(broker.client_options(id, None), topics).await;
    c.collect(Duration::from_millis(800))
        .await
        .into_iter()
        .filter(|p| p.retain && !p.payload.is_empty())
        .map(|p| (p.topic.clone(), serde_json::from_slice(&p.payload).unwrap()))
        .collect()
}

/// `GET path` on 127.0.0.1:`port`: the status line and the body, or why there is none.
fn http_get(port: u16, path: &str) -> Result<String, std::io::Error> {
    use std::io::{Read as _, Write as _};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port))?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    s.write_all(
        format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n").as_bytes(),
    )?;
    let mut out = String::new();
    s.read_to_string(&mut out)?;
    Ok(out)
}

/// A reload that changes what the connections and listeners depend on: another broker (the old
/// one is left with the values stale and the status offline, the new one gets everything), the
/// gateway's name (every retained topic under the old name cleared), the page added and
/// `/metrics` moved, all without a restart of the bus.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue22_a_reload_moves_broker_name_page_and_metrics_without_a_restart() {
    let (Some(a), Some(b)) = (
        Mosquitto::start(BrokerOptions::default()),
        Mosquitto::start(BrokerOptions::default()),
    ) else {
        return;
    };
    let bus = "[[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nsimulate = true\n\
               [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
               [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\n";
    let [m1, m2, page] = free_ports();
    let config = |broker: &Mosquitto, name: &str, metrics: u16, ui: &str| {
        format!(
            "[gateway]\nname = \"{name}\"\nbroker = \"{}\"\nmetrics = \"127.0.0.1:{metrics}\"\n{ui}{bus}",
            broker.url()
        )
    };
    let mut at_a = Inbox::connect(&a, "a", &["drivebus/#"]).await;
    let mut at_b = Inbox::connect(&b, "b", &["drivebus/#"]).await;
    let mut gw = Gateway::start(&config(&a, "gw", m1, ""), &[]);
    at_a.next("drivebus/gw/ml/d1/ramp", "a value at a", |_| true)
        .await;
    assert!(
        http_get(m1, "/metrics")
            .unwrap()
            .starts_with("HTTP/1.1 200")
    );

    // Another broker.
    gw.write_config(&config(&b, "gw", m1, ""));
    gw.signal("HUP");
    let v = at_b
        .next("drivebus/gw/status", "online at b", |v| {
            v["state"] == "online"
        })
        .await;
    assert_eq!(v["config"]["generation"], 2, "{v}");
    at_b.next("drivebus/gw/ml/d1/ramp", "a value at b", |v| {
        v.get("stale").is_none()
    })
    .await;
    let old = retained(&a, "a2", &["drivebus/#"]).await;
    let find = |t: &str| old.iter().find(|(x, _)| x == t).map(|(_, v)| v.clone());
    let status = find("drivebus/gw/status").expect("the old broker keeps a status");
    assert_eq!(
        (&status["state"], &status["reason"]),
        (&json!("offline"), &json!("reconfigured")),
        "{status}"
    );
    let ramp = find("drivebus/gw/ml/d1/ramp").expect("the old broker keeps the value");
    assert_eq!(ramp["stale"], true, "{ramp}");

    // Another name, the page added, /metrics moved.
    gw.write_config(&config(
        &b,
        "gw2",
        m2,
        &format!("[ui]\nlisten = \"127.0.0.1:{page}\"\n"),
    ));
    gw.signal("HUP");
    let v = at_b
        .next("drivebus/gw2/status", "online as gw2", |v| {
            v["state"] == "online"
        })
        .await;
    assert_eq!(v["config"]["generation"], 3, "{v}");
    at_b.next("drivebus/gw2/ml/d1/ramp", "a value as gw2", |_| true)
        .await;
    let left: Vec<String> = retained(&b, "b2", &["drivebus/gw/#"])
        .await
        .into_iter()
        .map(|(t, _)| t)
        .collect();
    assert!(
        left.is_empty(),
        "the old name's topics are cleared: {left:?}"
    );
    let plant = http_get(page, "/api/plant").unwrap();
    assert!(plant.starts_with("HTTP/1.1 200"), "{plant}");
    assert!(plant.contains("\"generation\":3"), "{plant}");
    // The page started by the reload knows the drive's status (the buses report their
    // statuses again for it: a status is sent only when it changes).
    let deadline = Instant::now() + WAIT;
    loop {
        let plant = http_get(page, "/api/plant").unwrap();
        if plant.contains("\"status\":{\"state\":\"online\"") {
            break;
        }
        assert!(Instant::now() < deadline, "no status on the page: {plant}");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(
        http_get(m2, "/metrics")
            .unwrap()
            .starts_with("HTTP/1.1 200")
    );
    assert!(
        http_get(m1, "/metrics").is_err(),
        "the old /metrics address is free"
    );
    // The bus never stopped: its simulated drive answered all along, one bus start in the log.
    let log = gw.log();
    assert_eq!(
        log.matches("bus polling starts").count(),
        1,
        "the bus was not restarted:\n{log}"
    );
    assert!(gw.terminate().success(), "{}", gw.log());
}
