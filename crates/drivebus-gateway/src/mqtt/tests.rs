//! [`Mqtt::run`] against a real Mosquitto broker (started per test on a free port; where
//! Mosquitto cannot be had each test fails under CI and skips elsewhere, with one message), with
//! an update channel and fake bus set-receivers. Every wait has a timeout.

#[path = "../../tests/common/mosquitto.rs"]
mod mosquitto;

use std::sync::Arc;
use std::time::{Duration, SystemTime};

use serde_json::json;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::LocalSet;

use super::{BrokerState, Mqtt};
use crate::config::Plant;
use crate::metrics::Metrics;
use crate::model::{DriveStatus, SetOutcome, SetRequest, SetValue, Update};
use mosquitto::{BrokerOptions, Mosquitto, TestClient, json as payload_json};

const WAIT: Duration = Duration::from_secs(5);
/// How long "nothing arrives" is watched.
const QUIET: Duration = Duration::from_millis(400);

const BASE: &str = "drivebus/gw1/line1/conv";

fn plant(broker: &str, extra: &str) -> Arc<Plant> {
    let text = format!(
        "[gateway]\nname = \"gw1\"\nbroker = \"{broker}\"\nheartbeat = \"1s\"\n\
         max_set_age = \"10s\"\nmetrics = \"off\"\nkeep_alive = \"5s\"\n{extra}\n\
         [[bus]]\nname = \"line1\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"conv\"\naddress = 1\n\
         [bus.drive.process_data]\nperiod = \"10ms\"\nout = [6, 1500]\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"1s\"\nwritable = true\n\
         [[bus.drive.param]]\nparam = \"P700\"\nname = \"mode\"\nperiod = \"1s\"\n"
    );
    Arc::new(Plant::parse(&text, "test").unwrap())
}

/// A running `Mqtt::run` with its channels.
struct Gw {
    state: watch::Receiver<BrokerState>,
    updates: mpsc::Sender<Update>,
    sets: mpsc::Receiver<SetRequest>,
    stop: Option<oneshot::Sender<()>>,
    run: tokio::task::JoinHandle<crate::error::Result<()>>,
}

impl Gw {
    /// Start it on the current `LocalSet`.
    fn start(plant: &Arc<Plant>) -> Gw {
        let mqtt = Mqtt::prepare(plant).unwrap();
        let state = mqtt.broker_state();
        let (updates, update_rx) = mpsc::channel(64);
        let (set_tx, sets) = mpsc::channel(4);
        let (stop, stopped) = oneshot::channel::<()>();
        let metrics = Arc::new(Metrics::new(plant));
        let (_config, config) = watch::channel(crate::model::ConfigStatus {
            generation: 1,
            ..crate::model::ConfigStatus::default()
        });
        let run =
            tokio::task::spawn_local(mqtt.run(update_rx, vec![set_tx], metrics, config, async {
                let _ = stopped.await;
                crate::mqtt::End::Stop
            }));
        Gw {
            state,
            updates,
            sets,
            stop: Some(stop),
            run,
        }
    }

    async fn until(&mut self, what: &str, f: impl FnMut(&BrokerState) -> bool) -> BrokerState {
        let got = tokio::time::timeout(WAIT, self.state.wait_for(f))
            .await
            .map(|s| s.unwrap().clone());
        match got {
            Ok(s) => s,
            Err(_) => panic!("{what} within {WAIT:?}; state {:?}", self.state.borrow()),
        }
    }

    /// Connected and subscribed.
    async fn ready(&mut self) {
        self.until("connected and subscribed", |s| s.connected && s.subscribed)
            .await;
    }

    async fn send(&self, u: Update) {
        self.updates.send(u).await.unwrap();
    }

    async fn value(&self, point: usize, raw: i64) {
        self.send(Update::Value {
            bus: 0,
            drive: 0,
            point,
            raw,
            at: SystemTime::now(),
        })
        .await;
    }

    /// Shut down cleanly; `run` must return within the flush bound.
    async fn shutdown(mut self) {
        let _ = self.stop.take().unwrap().send(());
        tokio::time::timeout(Duration::from_secs(3), self.run)
            .await
            .expect("run ends within 3 s of the shutdown")
            .unwrap()
            .unwrap();
    }
}

fn broker(options: BrokerOptions) -> Option<Mosquitto> {
    Mosquitto::start(options)
}

fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .unwrap()
        .as_millis() as i64
}

#[tokio::test]
async fn values_are_published_retained_on_change_and_on_heartbeat() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let mut live =
                TestClient::connect(b.client_options("live", None), &["drivebus/gw1/#"]).await;
            gw.value(0, 2000).await;
            let p = live.next_on(&format!("{BASE}/ramp"), WAIT).await.unwrap();
            let v = payload_json(&p);
            assert_eq!(v["value"], json!(2.0));
            assert_eq!(v["unit"], json!("s"));
            assert_eq!(v["raw"], json!(2000));
            assert!(v["ts"].as_i64().unwrap() > 1_600_000_000_000, "{v}");
            // A value-list entry has its text; status and process data their JSON.
            gw.value(1, 11).await;
            let v = payload_json(&live.next_on(&format!("{BASE}/mode"), WAIT).await.unwrap());
            assert_eq!(
                (v["value"].clone(), v["text"].clone()),
                (json!(11), json!("CFC"))
            );
            gw.send(Update::Status {
                bus: 0,
                drive: 0,
                status: DriveStatus::Fault("F07 DC link overvoltage".into()),
                at: SystemTime::now(),
            })
            .await;
            let v = payload_json(&live.next_on(&format!("{BASE}/status"), WAIT).await.unwrap());
            assert_eq!(v["state"], json!("fault"));
            assert_eq!(v["text"], json!("F07 DC link overvoltage"));
            gw.send(Update::ProcessData {
                bus: 0,
                drive: 0,
                words: vec![0x0206, 1490],
                at: SystemTime::now(),
            })
            .await;
            let v = payload_json(&live.next_on(&format!("{BASE}/pd"), WAIT).await.unwrap());
            assert_eq!(
                (v["in"].clone(), v["out"].clone()),
                (json!([518, 1490]), json!([6, 1500]))
            );

            // The same raw value again within the heartbeat: nothing; changed: at once.
            gw.value(0, 2000).await;
            assert!(live.next_on(&format!("{BASE}/ramp"), QUIET).await.is_none());
            gw.value(0, 2500).await;
            let v = payload_json(&live.next_on(&format!("{BASE}/ramp"), WAIT).await.unwrap());
            assert_eq!(v["raw"], json!(2500));
            // Unchanged but a heartbeat (1 s) after its last publication: again.
            tokio::time::sleep(Duration::from_millis(1050)).await;
            gw.value(0, 2500).await;
            let v = payload_json(&live.next_on(&format!("{BASE}/ramp"), WAIT).await.unwrap());
            assert_eq!(v["raw"], json!(2500));

            // A client that subscribes later gets every latest value, retained.
            let mut late =
                TestClient::connect(b.client_options("late", None), &["drivebus/gw1/#"]).await;
            let all = late.collect(QUIET).await;
            let find = |t: &str| {
                all.iter()
                    .find(|p| p.topic == t)
                    .unwrap_or_else(|| panic!("{t} in {all:?}"))
            };
            assert!(all.iter().all(|p| p.retain), "{all:?}");
            assert_eq!(state(find("drivebus/gw1/status")), "online");
            assert_eq!(
                payload_json(find(&format!("{BASE}/ramp")))["raw"],
                json!(2500)
            );
            assert_eq!(
                payload_json(find(&format!("{BASE}/mode")))["raw"],
                json!(11)
            );
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn a_set_is_answered_through_the_bus() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let mut c = TestClient::connect(
                b.client_options("scada", None),
                &[&format!("{BASE}/+/result")],
            )
            .await;
            let body = json!({"value": 3.5, "id": "job-7", "ts": now_ms()}).to_string();
            c.publish(&format!("{BASE}/ramp/set"), body, false).await;
            let req = tokio::time::timeout(WAIT, gw.sets.recv())
                .await
                .unwrap()
                .unwrap();
            assert_eq!((req.drive, req.point), (0, 0));
            assert_eq!(req.value, SetValue::Value(json!(3.5)));
            assert!(req.max_age <= Duration::from_secs(10) && req.max_age > Duration::from_secs(5));
            req.reply
                .send(SetOutcome::Written {
                    raw: 3500,
                    differs: None,
                })
                .unwrap();
            let r = c
                .next_on(&format!("{BASE}/ramp/result"), WAIT)
                .await
                .unwrap();
            assert!(!r.retain);
            let v = payload_json(&r);
            assert_eq!(
                (
                    v["ok"].clone(),
                    v["outcome"].clone(),
                    v["raw"].clone(),
                    v["value"].clone(),
                    v["id"].clone()
                ),
                (
                    json!(true),
                    json!("written"),
                    json!(3500),
                    json!(3.5),
                    json!("job-7")
                )
            );
            // A raw set, answered with the drive's refusal.
            c.publish(&format!("{BASE}/ramp/set"), r#"{"raw": 9999999}"#, false)
                .await;
            let req = tokio::time::timeout(WAIT, gw.sets.recv())
                .await
                .unwrap()
                .unwrap();
            assert_eq!(req.value, SetValue::Raw(9_999_999));
            req.reply
                .send(SetOutcome::DeviceRefused {
                    message: "return code 0x0813: value too large".into(),
                })
                .unwrap();
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), WAIT)
                    .await
                    .unwrap(),
            );
            assert_eq!(v["outcome"], json!("device_refused"));
            assert_eq!(v["message"], json!("return code 0x0813: value too large"));
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn refused_sets_never_reach_the_bus() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let set = format!("{BASE}/ramp/set");
            // Retained before the gateway connects: delivered to it at its subscription.
            let c0 = TestClient::connect(b.client_options("early", None), &[]).await;
            c0.publish(&set, r#"{"value": 9}"#, true).await;
            tokio::time::sleep(Duration::from_millis(100)).await;

            let mut c = TestClient::connect(
                b.client_options("scada", None),
                &[&format!("{BASE}/+/result")],
            )
            .await;
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let result = |v: &serde_json::Value| (v["outcome"].clone(), v["reason"].clone());
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), WAIT)
                    .await
                    .unwrap(),
            );
            assert_eq!(result(&v), (json!("refused"), json!("retained")), "{v}");

            let big = format!(r#"{{"raw": 1, "pad": "{}"}}"#, "x".repeat(5000));
            let cases: Vec<(String, String, &str)> = vec![
                (
                    set.clone(),
                    json!({"value": 3, "ts": now_ms() - 60_000}).to_string(),
                    "stale",
                ),
                (
                    set.clone(),
                    json!({"value": 3, "ts": now_ms() + 60_000}).to_string(),
                    "stale",
                ),
                (
                    format!("{BASE}/mode/set"),
                    json!({"value": 3}).to_string(),
                    "not_writable",
                ),
                (set.clone(), "garbage".into(), "bad_request"),
                (
                    set.clone(),
                    "{\"value\": 1, \"raw\": 1}".into(),
                    "bad_request",
                ),
                (set.clone(), "{}".into(), "bad_request"),
                (set.clone(), "[]".into(), "bad_request"),
                (set.clone(), big, "bad_request"),
            ];
            for (topic, body, reason) in &cases {
                c.publish(topic, body.clone(), false).await;
                let rt = topic.replace("/set", "/result");
                let v = payload_json(&c.next_on(&rt, WAIT).await.unwrap());
                assert_eq!(
                    result(&v),
                    (json!("refused"), json!(reason)),
                    "{body:.80}: {v}"
                );
                assert!(v["message"].as_str().unwrap().len() > 10, "{v}");
            }
            // Unknown point, drive, bus: logged and counted, no result, no crash.
            for t in ["nope/set", "../ramp/set"] {
                c.publish(&format!("{BASE}/{t}"), "{\"value\": 1}", false)
                    .await;
            }
            c.publish("drivebus/gw1/line9/conv/ramp/set", "{\"value\": 1}", false)
                .await;
            assert!(c.collect(QUIET).await.is_empty());
            // A drive in timeout: refused as offline.
            gw.send(Update::Status {
                bus: 0,
                drive: 0,
                status: DriveStatus::Timeout,
                at: SystemTime::now(),
            })
            .await;
            tokio::time::sleep(Duration::from_millis(50)).await;
            c.publish(&set, "{\"value\": 1}", false).await;
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), WAIT)
                    .await
                    .unwrap(),
            );
            assert_eq!(result(&v), (json!("refused"), json!("offline")));
            assert!(gw.sets.try_recv().is_err(), "the bus received nothing");

            // The retained set was cleared: a new subscriber does not get it.
            let mut d = TestClient::connect(b.client_options("later", None), &[&set]).await;
            assert!(d.collect(QUIET).await.is_empty());
            // And the gateway still takes a good one.
            gw.send(Update::Status {
                bus: 0,
                drive: 0,
                status: DriveStatus::Online,
                at: SystemTime::now(),
            })
            .await;
            tokio::time::sleep(Duration::from_millis(50)).await;
            c.publish(&set, "{\"value\": 1}", false).await;
            let req = tokio::time::timeout(WAIT, gw.sets.recv())
                .await
                .unwrap()
                .unwrap();
            assert_eq!(req.value, SetValue::Value(json!(1)));
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn a_full_bus_queue_is_refused_as_busy() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let mut c = TestClient::connect(
                b.client_options("scada", None),
                &[&format!("{BASE}/ramp/result")],
            )
            .await;
            // The fake bus takes 4 and answers none.
            for i in 0..5 {
                c.publish(
                    &format!("{BASE}/ramp/set"),
                    json!({"raw": i, "id": i}).to_string(),
                    false,
                )
                .await;
            }
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), WAIT)
                    .await
                    .unwrap(),
            );
            assert_eq!(
                (v["reason"].clone(), v["id"].clone()),
                (json!("busy"), json!(4))
            );
            // A request the bus drops unanswered is answered `expired`.
            let req = gw.sets.recv().await.unwrap();
            drop(req);
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), WAIT)
                    .await
                    .unwrap(),
            );
            assert_eq!(
                (v["reason"].clone(), v["id"].clone()),
                (json!("expired"), json!(0))
            );
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn broker_restart_reconnects_and_republishes_only_the_latest() {
    let Some(mut b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            gw.value(0, 1000).await;
            let mut c =
                TestClient::connect(b.client_options("c1", None), &[&format!("{BASE}/ramp")]).await;
            assert!(c.next_on(&format!("{BASE}/ramp"), WAIT).await.is_some());
            drop(c);

            b.stop();
            gw.until("the gateway sees the broker gone", |s| !s.connected)
                .await;
            // Polling goes on while the broker is away.
            for raw in 1..=200 {
                gw.value(0, raw).await;
            }
            b.restart();
            let s = gw
                .until("reconnected", |s| {
                    s.connected && s.subscribed && s.connects == 2
                })
                .await;
            assert!(s.failures >= 1, "{s:?}");
            // A fresh broker (no persistence): everything it has came from the republication.
            let mut c =
                TestClient::connect(b.client_options("c2", None), &["drivebus/gw1/#"]).await;
            let all = c.collect(QUIET).await;
            let ramps: Vec<i64> = all
                .iter()
                .filter(|p| p.topic == format!("{BASE}/ramp"))
                .map(|p| payload_json(p)["raw"].as_i64().unwrap())
                .collect();
            assert_eq!(ramps, [200], "only the latest, once: {all:?}");
            assert!(
                all.iter()
                    .any(|p| p.topic == "drivebus/gw1/status" && state(p) == "online")
            );
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn a_result_ready_during_an_outage_is_published_at_reconnection() {
    let Some(mut b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let c = TestClient::connect(b.client_options("c1", None), &[]).await;
            c.publish(
                &format!("{BASE}/ramp/set"),
                r#"{"raw": 42, "id": "late"}"#,
                false,
            )
            .await;
            let req = tokio::time::timeout(WAIT, gw.sets.recv())
                .await
                .unwrap()
                .unwrap();
            drop(c);
            b.stop();
            gw.until("the gateway sees the broker gone", |s| !s.connected)
                .await;
            req.reply
                .send(SetOutcome::Written {
                    raw: 42,
                    differs: None,
                })
                .unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;
            b.restart();
            // Subscribe before the gateway is back, so the (unretained) result is seen.
            let mut c = TestClient::connect(
                b.client_options("c2", None),
                &[&format!("{BASE}/ramp/result")],
            )
            .await;
            let v = payload_json(
                &c.next_on(&format!("{BASE}/ramp/result"), Duration::from_secs(8))
                    .await
                    .unwrap(),
            );
            assert_eq!(
                (v["outcome"].clone(), v["id"].clone()),
                (json!("written"), json!("late"))
            );
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn offline_by_last_will_when_the_connection_dies_and_on_clean_shutdown() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    let status = "drivebus/gw1/status";
    let mut watcher = TestClient::connect(b.client_options("watch", None), &[status]).await;
    // The gateway dies without a DISCONNECT: its LocalSet (every task, the socket) is dropped.
    let local = LocalSet::new();
    let mut gw = local
        .run_until(async { Gw::start(&plant(&b.url(), "")) })
        .await;
    local.run_until(gw.ready()).await;
    let p = watcher.next_on(status, WAIT).await.unwrap();
    assert_eq!(state(&p), "online");
    // The running config: generation 1, no reload yet.
    let v = payload_json(&p);
    assert_eq!(v["config"]["generation"], json!(1), "{v}");
    assert_eq!(v["config"]["last_reload"], json!(null), "{v}");
    drop(local);
    let p = watcher
        .next_on(status, WAIT)
        .await
        .expect("the broker sends the last-will");
    assert_eq!(
        payload_json(&p),
        json!({"state": "offline", "reason": "connection lost"})
    );
    // Retained.
    let mut later = TestClient::connect(b.client_options("later", None), &[status]).await;
    let p = later.next_on(status, WAIT).await.unwrap();
    assert!(p.retain);
    assert_eq!(state(&p), "offline");
    drop(later);

    // Clean shutdown: `offline` published by the gateway, retained.
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            assert_eq!(
                state(&watcher.next_on(status, WAIT).await.unwrap()),
                "online"
            );
            gw.shutdown().await;
        })
        .await;
    let p = watcher.next_on(status, WAIT).await.unwrap();
    let v = payload_json(&p);
    assert_eq!(
        (&v["state"], &v["reason"]),
        (&json!("offline"), &json!("stopped")),
        "{v}"
    );
    assert!(v["ts"].is_u64(), "{v}");
    let mut later = TestClient::connect(b.client_options("later2", None), &[status]).await;
    assert_eq!(
        state(&later.next_on(status, WAIT).await.unwrap()),
        "offline"
    );
}

/// The `state` of the gateway's status topic.
fn state(p: &rumqttc::Publish) -> String {
    payload_json(p)["state"]
        .as_str()
        .unwrap_or_default()
        .to_owned()
}

fn tls_broker() -> Option<Mosquitto> {
    broker(BrokerOptions {
        users: vec![
            ("gw1".into(), "right horse".into()),
            ("scada".into(), "s".into()),
        ],
        tls: true,
        client_certificates: false,
    })
}

#[tokio::test]
async fn tls_with_the_generated_ca_and_a_password() {
    let Some(b) = tls_broker() else {
        return;
    };
    let pw = b.file("gw1.pw", "\u{feff}right horse\r\n");
    let url = format!("mqtts://gw1@localhost:{}", b.port);
    let extra = format!(
        "ca_file = \"{}\"\npassword_file = \"{}\"",
        b.ca_file().display(),
        pw.display()
    );
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&url, &extra));
            gw.ready().await;
            let mut c = TestClient::connect(
                b.client_options("scada", Some(("scada", "s"))),
                &[&format!("{BASE}/ramp")],
            )
            .await;
            gw.value(0, 1234).await;
            let v = payload_json(&c.next_on(&format!("{BASE}/ramp"), WAIT).await.unwrap());
            assert_eq!(v["raw"], json!(1234));
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn a_wrong_password_is_refused_with_a_clear_error_and_retried() {
    let Some(b) = tls_broker() else {
        return;
    };
    let pw = b.file("wrong.pw", "wrong horse\n");
    let url = format!("mqtts://gw1@localhost:{}", b.port);
    let extra = format!(
        "ca_file = \"{}\"\npassword_file = \"{}\"",
        b.ca_file().display(),
        pw.display()
    );
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&url, &extra));
            // 0.5 s, then 1 s: the third attempt within 5 s.
            let s = gw.until("two failed attempts", |s| s.failures >= 2).await;
            assert_eq!(s.connects, 0);
            let e = s.last_error.unwrap();
            assert!(e.contains("refused") && e.contains("password_file"), "{e}");
            assert!(!gw.run.is_finished());
            gw.shutdown().await;
        })
        .await;
}

#[tokio::test]
async fn a_broker_certificate_from_another_ca_is_refused() {
    let (Some(b), Some(other)) = (tls_broker(), tls_broker()) else {
        return;
    };
    let pw = b.file("gw1.pw", "right horse\n");
    let url = format!("mqtts://gw1@localhost:{}", b.port);
    let extra = format!(
        "ca_file = \"{}\"\npassword_file = \"{}\"",
        other.ca_file().display(),
        pw.display()
    );
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&url, &extra));
            let s = gw.until("a failed attempt", |s| s.failures >= 1).await;
            assert_eq!(s.connects, 0);
            let e = s.last_error.unwrap();
            assert!(e.contains("TLS") && e.contains("ca_file"), "{e}");
            gw.shutdown().await;
        })
        .await;
}

/// A write that the bus answers as the gateway stops (its last transaction) still gets its
/// `result`, published before `offline`.
#[tokio::test]
async fn a_result_ready_at_the_stop_is_published_before_offline() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    LocalSet::new()
        .run_until(async {
            let mut c = TestClient::connect(
                b.client_options("scada", None),
                &[&format!("{BASE}/+/result"), "drivebus/gw1/status"],
            )
            .await;
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            c.publish(
                &format!("{BASE}/ramp/set"),
                r#"{"value": 2, "id": "last"}"#,
                false,
            )
            .await;
            let req = tokio::time::timeout(WAIT, gw.sets.recv())
                .await
                .unwrap()
                .unwrap();
            // The bus answers and the gateway stops at the same moment.
            let _ = req.reply.send(SetOutcome::Written {
                raw: 2000,
                differs: None,
            });
            gw.shutdown().await;
            let got = c.collect(QUIET).await;
            let topics: Vec<String> = got
                .iter()
                .map(|p| format!("{} {}", p.topic, String::from_utf8_lossy(&p.payload)))
                .collect();
            let result = topics
                .iter()
                .position(|t| t.contains("/ramp/result") && t.contains("\"last\""));
            let offline = topics
                .iter()
                .position(|t| t.starts_with("drivebus/gw1/status ") && t.contains("\"offline\""));
            assert!(
                matches!((result, offline), (Some(r), Some(o)) if r < o),
                "the result, then offline: {topics:?}"
            );
        })
        .await;
}

/// Issue 22, item 3: a drive in timeout and the gateway's stop leave no value that looks
/// current: the retained values and process data say `stale`, and a read after the timeout
/// makes them fresh; after the stop the drive's status says `stale` too.
#[tokio::test]
async fn retained_values_say_stale_after_a_timeout_and_after_the_stop() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    let ramp = format!("{BASE}/ramp");
    let pd = format!("{BASE}/pd");
    let status = format!("{BASE}/status");
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            let mut live =
                TestClient::connect(b.client_options("live", None), &["drivebus/gw1/#"]).await;
            gw.value(0, 2000).await;
            let p = live.next_on(&ramp, WAIT).await.unwrap();
            assert_eq!(payload_json(&p).get("stale"), None);
            let words = Update::ProcessData {
                bus: 0,
                drive: 0,
                words: vec![0x0007, 1500],
                at: SystemTime::now(),
            };
            gw.send(words.clone()).await;
            let p = live.next_on(&pd, WAIT).await.unwrap();
            assert_eq!(payload_json(&p).get("stale"), None);
            gw.send(Update::Status {
                bus: 0,
                drive: 0,
                status: DriveStatus::Timeout,
                at: SystemTime::now(),
            })
            .await;
            let p = live.next_on(&pd, WAIT).await.unwrap();
            let v = payload_json(&p);
            assert_eq!(
                (&v["stale"], &v["in"]),
                (&json!(true), &json!([7, 1500])),
                "{v}"
            );
            let p = live.next_on(&ramp, WAIT).await.unwrap();
            let v = payload_json(&p);
            assert_eq!(v["stale"], json!(true), "{v}");
            assert_eq!(v["raw"], json!(2000));
            assert!(v["stale_since"].as_i64().unwrap() >= v["ts"].as_i64().unwrap());
            // A consumer that comes later reads the retained value: stale.
            let mut later =
                TestClient::connect(b.client_options("later", None), &[ramp.as_str()]).await;
            let p = later.next_on(&ramp, WAIT).await.unwrap();
            assert!(p.retain);
            assert_eq!(payload_json(&p)["stale"], json!(true));
            // Answering again: the same value, fresh, at once.
            gw.send(Update::Status {
                bus: 0,
                drive: 0,
                status: DriveStatus::Online,
                at: SystemTime::now(),
            })
            .await;
            gw.value(0, 2000).await;
            let p = live.next_on(&ramp, WAIT).await.unwrap();
            assert_eq!(payload_json(&p).get("stale"), None);
            gw.send(words).await;
            let p = live.next_on(&pd, WAIT).await.unwrap();
            assert_eq!(payload_json(&p).get("stale"), None, "the same words, fresh");
            gw.shutdown().await;
            let p = live.next_on(&ramp, WAIT).await.unwrap();
            assert_eq!(payload_json(&p)["stale"], json!(true), "at the stop");
        })
        .await;
    let mut after = TestClient::connect(
        b.client_options("after", None),
        &[ramp.as_str(), pd.as_str(), status.as_str()],
    )
    .await;
    // The broker hands the retained messages over in an order of its own.
    let retained = after.collect(Duration::from_secs(1)).await;
    for topic in [&ramp, &pd, &status] {
        let p = retained
            .iter()
            .find(|p| &p.topic == topic)
            .unwrap_or_else(|| panic!("nothing retained on {topic}: {retained:?}"));
        assert!(p.retain, "{topic}");
        let v = payload_json(p);
        assert_eq!(v["stale"], json!(true), "{topic}: {v}");
    }
}

/// Issue 22, item 3: retained topics under the gateway's that no point, drive or bus of the
/// config has (an earlier config's) are cleared when it connects; its own are kept, another
/// gateway's are not touched, and a `set` (which both subscriptions match) reaches the bus once.
#[tokio::test]
async fn retained_topics_of_an_earlier_config_are_cleared_at_the_start() {
    let Some(b) = broker(BrokerOptions::default()) else {
        return;
    };
    let old_point = format!("{BASE}/old_point");
    let old_drive = "drivebus/gw1/line1/gone/status";
    let other_gw = "drivebus/gw2/line1/conv/ramp";
    let c = TestClient::connect(b.client_options("old", None), &[]).await;
    for t in [old_point.as_str(), old_drive, other_gw] {
        c.publish(t, r#"{"value":1,"raw":1,"ts":1}"#, true).await;
    }
    let ramp = format!("{BASE}/ramp");
    LocalSet::new()
        .run_until(async {
            let mut gw = Gw::start(&plant(&b.url(), ""));
            gw.ready().await;
            gw.value(0, 2000).await;
            let mut live = TestClient::connect(b.client_options("live", None), &[&ramp]).await;
            live.next_on(&ramp, WAIT).await.unwrap();
            // One set: handed to the bus once.
            c.publish(
                &format!("{ramp}/set"),
                json!({"value": 3.0, "id": "once"}).to_string(),
                false,
            )
            .await;
            let first = tokio::time::timeout(WAIT, gw.sets.recv()).await.unwrap();
            assert!(first.is_some());
            let again = tokio::time::timeout(QUIET, gw.sets.recv()).await;
            assert!(again.is_err(), "a set reached the bus twice");
            gw.shutdown().await;
        })
        .await;
    let mut after = TestClient::connect(
        b.client_options("after", None),
        &["drivebus/gw1/#", "drivebus/gw2/#"],
    )
    .await;
    let seen: std::collections::HashSet<String> = after
        .collect(Duration::from_secs(1))
        .await
        .into_iter()
        .filter(|p| !p.payload.is_empty())
        .map(|p| p.topic.clone())
        .collect();
    assert!(!seen.contains(&old_point), "{seen:?}");
    assert!(!seen.contains(old_drive), "{seen:?}");
    assert!(
        seen.contains(other_gw),
        "another gateway's topics are not this one's: {seen:?}"
    );
    assert!(seen.contains(&ramp), "{seen:?}");
    assert!(seen.contains("drivebus/gw1/status"), "{seen:?}");
}
