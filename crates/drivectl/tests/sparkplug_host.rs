//! The Sparkplug B test host (`tests/sparkplug/host.py`, pysparkplug and paho-mqtt from PyPI)
//! checked end to end without a gateway: a real Mosquitto, the host, and a Rust publisher
//! (rumqttc) that publishes bytes the Python library itself encoded. What the host decodes
//! from them through the broker is asserted value by value: births with datatypes, aliases and
//! properties, data by alias only resolved through the birth, sequence gaps, commands with and
//! without datatypes, deaths, retained STATE and the host's will, and bytes it cannot decode.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "../../drivebus-gateway/tests/common/mosquitto.rs"]
mod mosquitto;
#[path = "common/spb_host.rs"]
mod spb_host;

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use mosquitto::{BrokerOptions, Mosquitto, TestClient};
use serde_json::{Value, json};
use spb_host::{HostOptions, SpbHost};

const WAIT: Duration = Duration::from_secs(10);
const GROUP: &str = "plant";
const NODE: &str = "gw";

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

fn topic(kind: &str, device: Option<&str>) -> String {
    match device {
        Some(d) => format!("spBv1.0/{GROUP}/{kind}/{NODE}/{d}"),
        None => format!("spBv1.0/{GROUP}/{kind}/{NODE}"),
    }
}

/// A broker and a host on it, or `None` (skipped) where either is missing outside CI.
fn setup() -> Option<(Mosquitto, SpbHost)> {
    let broker = Mosquitto::start(BrokerOptions::default())?;
    let host = SpbHost::start(broker.port, GROUP)?;
    Some((broker, host))
}

/// A property of a birth metric as the encode command takes it.
fn prop(datatype: &str, value: Value) -> Value {
    json!({"datatype": datatype, "value": value})
}

/// The device birth of the tests: every integer width, a Double with the properties the
/// gateway gives a point, and a String status.
fn dbirth(seq: u64, ts: u64) -> Value {
    json!({
        "type": "DBIRTH", "seq": seq, "timestamp": ts,
        "metrics": [
            {"name": "P130", "alias": 10, "datatype": "Double", "value": 2.0,
             "properties": {
                 "engUnit": prop("String", json!("s")),
                 "engLow": prop("Double", json!(0.0)),
                 "engHigh": prop("Double", json!(2000.0)),
                 "writable": prop("Boolean", json!(true)),
                 "nameDe": prop("String", json!("Rampe t11 auf RECHTS")),
                 "nameEn": prop("String", json!("ramp t11 up clockwise")),
                 "parameter": prop("String", json!("P130")),
                 "index": prop("UInt32", json!(8470)),
                 "set": prop("UInt32", json!(1)),
             }},
            {"name": "s16", "alias": 11, "datatype": "Int16", "value": -5},
            {"name": "u16", "alias": 12, "datatype": "UInt16", "value": 65535},
            {"name": "s32", "alias": 13, "datatype": "Int32", "value": -70000},
            {"name": "u32", "alias": 14, "datatype": "UInt32", "value": 4_000_000_000u64},
            {"name": "Status/State", "alias": 15, "datatype": "String", "value": "online"},
            {"name": "Status/Fault", "alias": 16, "datatype": "String", "value": ""},
        ]
    })
}

/// Births, data and deaths published by a Rust client as the library encoded them reach the
/// host through Mosquitto and come out with the names, aliases, datatypes, values, properties
/// and sequence numbers that went in.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_host_decodes_what_the_library_encoded_published_through_mosquitto() {
    let Some((broker, mut host)) = setup() else {
        return;
    };
    let publisher = TestClient::connect(broker.client_options("edge", None), &[]).await;
    let ts = now_ms();

    // NBIRTH: the node's metrics, seq 0.
    let nbirth = host.encode(json!({
        "type": "NBIRTH", "seq": 0, "timestamp": ts,
        "metrics": [
            {"name": "bdSeq", "datatype": "UInt64", "value": 3},
            {"name": "Node Control/Rebirth", "alias": 1, "datatype": "Boolean", "value": false},
            {"name": "Buses/ml/Utilisation", "alias": 2, "datatype": "Double", "value": 0.25},
            {"name": "Buses/ml/Transactions", "alias": 3, "datatype": "UInt64",
             "value": 12_345_678_901u64},
        ]
    }));
    publisher
        .publish(&topic("NBIRTH", None), nbirth, false)
        .await;
    let m = host.expect_kind("NBIRTH", NODE, None, WAIT);
    assert_eq!(
        (m.group.as_str(), m.seq, m.expected_seq),
        (GROUP, Some(0), Some(0))
    );
    assert_eq!(m.timestamp, Some(ts));
    assert!(!m.retained);
    assert_eq!(m.metrics.len(), 4);
    let bd = m.get("bdSeq");
    assert_eq!(
        (bd.datatype.as_str(), bd.uint(), bd.alias),
        ("UInt64", 3, None)
    );
    let rebirth = m.get("Node Control/Rebirth");
    assert_eq!(
        (rebirth.datatype.as_str(), rebirth.boolean(), rebirth.alias),
        ("Boolean", false, Some(1))
    );
    assert_eq!(m.get("Buses/ml/Utilisation").float(), 0.25);
    assert_eq!(m.get("Buses/ml/Utilisation").datatype, "Double");
    // Beyond 32 bits: a UInt64 keeps every bit.
    assert_eq!(m.get("Buses/ml/Transactions").uint(), 12_345_678_901);
    assert!(m.metrics.iter().all(|x| x.datatype_sent && !x.is_null));
    assert!(m.metrics.iter().all(|x| x.timestamp == Some(ts)));

    // DBIRTH: each width with its sign, the properties with their datatypes.
    publisher
        .publish(
            &topic("DBIRTH", Some("d1")),
            host.encode(dbirth(1, ts)),
            false,
        )
        .await;
    let d = host.expect_kind("DBIRTH", NODE, Some("d1"), WAIT);
    assert_eq!((d.seq, d.expected_seq), (Some(1), Some(1)));
    let got: Vec<(&str, &str, Value)> = d
        .metrics
        .iter()
        .map(|x| {
            (
                x.name.as_deref().unwrap(),
                x.datatype.as_str(),
                x.value.clone(),
            )
        })
        .collect();
    assert_eq!(
        got,
        vec![
            ("P130", "Double", json!(2.0)),
            ("s16", "Int16", json!(-5)),
            ("u16", "UInt16", json!(65535)),
            ("s32", "Int32", json!(-70000)),
            ("u32", "UInt32", json!(4_000_000_000u64)),
            ("Status/State", "String", json!("online")),
            ("Status/Fault", "String", json!("")),
        ]
    );
    let p = d.get("P130");
    assert_eq!(p.alias, Some(10));
    assert_eq!(p.property("engUnit"), Some((&json!("s"), "String")));
    assert_eq!(p.property("engLow"), Some((&json!(0.0), "Double")));
    assert_eq!(p.property("engHigh"), Some((&json!(2000.0), "Double")));
    assert_eq!(p.property("writable"), Some((&json!(true), "Boolean")));
    assert_eq!(
        p.property("nameDe"),
        Some((&json!("Rampe t11 auf RECHTS"), "String"))
    );
    assert_eq!(p.property("index"), Some((&json!(8470), "UInt32")));
    assert_eq!(p.property("set"), Some((&json!(1), "UInt32")));
    assert_eq!(p.properties.len(), 9, "{p:?}");
    assert!(d.get("s16").properties.is_empty());

    // DDATA by alias only, without datatypes: resolved through the DBIRTH.
    let ddata = host.encode(json!({
        "type": "DDATA", "seq": 2, "timestamp": ts + 1, "include_dtypes": false,
        "metrics": [
            {"alias": 11, "datatype": "Int16", "value": -6, "timestamp": ts + 1},
            {"alias": 10, "datatype": "Double", "value": 3.5, "timestamp": ts + 1},
        ]
    }));
    publisher
        .publish(&topic("DDATA", Some("d1")), ddata, false)
        .await;
    let data = host.expect_kind("DDATA", NODE, Some("d1"), WAIT);
    assert_eq!((data.seq, data.expected_seq), (Some(2), Some(2)));
    assert_eq!(data.metrics.len(), 2);
    for (x, name, alias, datatype, value) in [
        (&data.metrics[0], "s16", 11, "Int16", json!(-6)),
        (&data.metrics[1], "P130", 10, "Double", json!(3.5)),
    ] {
        assert_eq!(x.name, None, "sent by alias only: {x:?}");
        assert_eq!(x.birth_name.as_deref(), Some(name));
        assert_eq!(x.alias, Some(alias));
        assert_eq!(x.datatype, datatype);
        assert!(!x.datatype_sent, "{x:?}");
        assert_eq!(x.value, value);
        assert_eq!(x.timestamp, Some(ts + 1));
    }

    // A gap in the node's sequence shows: seq 5 where 3 was due.
    host.mark();
    let gap = host.encode(json!({
        "type": "NDATA", "seq": 5,
        "metrics": [{"name": "Buses/ml/Utilisation", "datatype": "Double", "value": 0.5}]
    }));
    publisher.publish(&topic("NDATA", None), gap, false).await;
    let n = host.expect_kind("NDATA", NODE, None, WAIT);
    assert_eq!((n.seq, n.expected_seq), (Some(5), Some(3)));
    assert_eq!(n.get("Buses/ml/Utilisation").float(), 0.5);

    // An Int16 sent as the 32-bit two's complement (0xFFFFFFFA) rather than the 16-bit one
    // (65530, as pysparkplug and Tahu's Python write -6): pysparkplug refuses it.
    let wide = host.encode(json!({
        "type": "DDATA", "seq": 6, "include_dtypes": false,
        "metrics": [{"alias": 11, "datatype": "UInt32", "value": 0xFFFF_FFFAu32}]
    }));
    publisher
        .publish(&topic("DDATA", Some("d1")), wide, false)
        .await;
    let deadline = std::time::Instant::now() + WAIT;
    while host.undecodable().is_empty() && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let bad = host.undecodable().to_vec();
    assert_eq!(bad.len(), 1, "{bad:?}");
    assert_eq!(bad[0].0, topic("DDATA", Some("d1")));
    assert_eq!(bad[0].1.as_deref(), Some("DDATA"));
    assert!(bad[0].2.contains("Int16 overflow"), "{bad:?}");

    // DDEATH, then NDEATH with its bdSeq: after the NDEATH the births are void, and data by
    // alias cannot be resolved any more.
    let ddeath = host.encode(json!({"type": "DDEATH", "seq": 7}));
    publisher
        .publish(&topic("DDEATH", Some("d1")), ddeath, false)
        .await;
    let dd = host.expect_kind("DDEATH", NODE, Some("d1"), WAIT);
    assert_eq!(
        (dd.seq, dd.expected_seq, dd.metrics.len()),
        (Some(7), Some(7), 0)
    );
    let ndeath = host.encode(json!({
        "type": "NDEATH", "timestamp": ts + 2,
        "metrics": [{"name": "bdSeq", "datatype": "UInt64", "value": 3}]
    }));
    publisher
        .publish(&topic("NDEATH", None), ndeath, false)
        .await;
    let nd = host.expect_kind("NDEATH", NODE, None, WAIT);
    assert_eq!(nd.seq, None);
    assert_eq!(nd.timestamp, Some(ts + 2));
    let bd = nd.get("bdSeq");
    assert_eq!((bd.datatype.as_str(), bd.uint()), ("UInt64", 3));
    publisher
        .publish(
            &topic("NBIRTH", None),
            host.encode(json!({
                "type": "NBIRTH", "seq": 0,
                "metrics": [{"name": "bdSeq", "datatype": "UInt64", "value": 4}]
            })),
            false,
        )
        .await;
    host.expect_kind("NBIRTH", NODE, None, WAIT);
    let orphan = host.encode(json!({
        "type": "DDATA", "seq": 1, "include_dtypes": false,
        "metrics": [{"alias": 11, "datatype": "Int16", "value": 1}]
    }));
    publisher
        .publish(&topic("DDATA", Some("d1")), orphan, false)
        .await;
    // Bytes that are no protobuf at all.
    publisher
        .publish(&topic("DDATA", Some("d2")), vec![0x01, 0x02, 0xff], false)
        .await;
    let deadline = std::time::Instant::now() + WAIT;
    while host.undecodable().len() < 3 && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let bad = host.undecodable().to_vec();
    assert_eq!(bad.len(), 3, "{bad:?}");
    assert!(bad[1].2.contains("no birth"), "{bad:?}");
    assert_eq!(bad[2].0, topic("DDATA", Some("d2")));
    assert!(bad[2].2.contains("DecodeError"), "{bad:?}");
}

/// Commands: a DCMD by name with its datatype and by alias without (the value encoded as the
/// birth's datatype), an NCMD rebirth, hand-made bytes; each reaches a plain MQTT subscriber
/// as the bytes the host says it published, and the host decodes its own commands back.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commands_are_published_as_the_library_encodes_them() {
    let Some((broker, mut host)) = setup() else {
        return;
    };
    let mut edge = TestClient::connect(
        broker.client_options("edge", None),
        &[&format!("spBv1.0/{GROUP}/+/{NODE}/#")],
    )
    .await;
    let ts = now_ms();
    edge.publish(
        &topic("DBIRTH", Some("d1")),
        host.encode(dbirth(1, ts)),
        false,
    )
    .await;
    host.expect_kind("DBIRTH", NODE, Some("d1"), WAIT);
    // The DBIRTH comes back to the edge's own subscription: skip it.
    edge.next_on(&topic("DBIRTH", Some("d1")), WAIT)
        .await
        .expect("the birth through the broker");

    host.mark();
    let sent = host.dcmd(
        NODE,
        "d1",
        json!([{"name": "P130", "datatype": "Double", "value": 3.5}]),
    );
    let got = edge
        .next_on(&topic("DCMD", Some("d1")), WAIT)
        .await
        .expect("the DCMD at the edge node");
    assert_eq!(got.payload.to_vec(), sent);
    assert!(!got.retain);
    let c = host.expect_kind("DCMD", NODE, Some("d1"), WAIT);
    let x = c.get("P130");
    assert_eq!(
        (
            x.name.as_deref(),
            x.datatype.as_str(),
            x.datatype_sent,
            x.float()
        ),
        (Some("P130"), "Double", true, 3.5)
    );
    assert!(c.timestamp.is_some_and(|t| t >= ts), "{c:?}");

    host.mark();
    let sent = host.dcmd(NODE, "d1", json!([{"alias": 11, "value": -7}]));
    let got = edge
        .next_on(&topic("DCMD", Some("d1")), WAIT)
        .await
        .expect("the DCMD by alias at the edge node");
    assert_eq!(got.payload.to_vec(), sent);
    let c = host.expect_kind("DCMD", NODE, Some("d1"), WAIT);
    let x = &c.metrics[0];
    assert_eq!(x.name, None);
    assert_eq!(x.birth_name.as_deref(), Some("s16"));
    assert_eq!((x.datatype.as_str(), x.datatype_sent), ("Int16", false));
    assert_eq!(x.int(), -7);

    // A command whose metrics mix with and without datatypes is refused by the host.
    let mixed = host.publish_command(json!({
        "cmd": "DCMD", "node": NODE, "device": "d1",
        "metrics": [{"name": "P130", "datatype": "Double", "value": 1.0},
                    {"name": "s16", "value": 1}]
    }));
    assert!(mixed.is_err_and(|e| e.contains("every metric")));
    // So is a value that does not fit its datatype.
    let wide = host.publish_command(json!({
        "cmd": "DCMD", "node": NODE, "device": "d1",
        "metrics": [{"name": "s16", "datatype": "Int16", "value": 40000}]
    }));
    assert!(wide.is_err_and(|e| e.contains("overflow")));

    host.mark();
    let sent = host.rebirth(NODE);
    let got = edge
        .next_on(&topic("NCMD", None), WAIT)
        .await
        .expect("the NCMD at the edge node");
    assert_eq!(got.payload.to_vec(), sent);
    let r = host.expect_kind("NCMD", NODE, None, WAIT);
    let x = r.get("Node Control/Rebirth");
    assert_eq!((x.datatype.as_str(), x.boolean()), ("Boolean", true));

    host.raw(&topic("NCMD", None), b"\x01\x02");
    let got = edge
        .next_on(&topic("NCMD", None), WAIT)
        .await
        .expect("the raw bytes at the edge node");
    assert_eq!(got.payload.to_vec(), b"\x01\x02");
}

/// The primary host's STATE is retained: a host that connects later receives it (flagged
/// retained) with its timestamp; offline replaces it; a host killed with its will set
/// leaves STATE offline behind.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn state_is_retained_and_the_will_says_offline() {
    let Some((broker, mut host)) = setup() else {
        return;
    };
    let before = now_ms();
    let bytes = host.state("scada", true);
    let sent: Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(sent["online"], true);
    let live = host
        .wait_for_state(WAIT, |s| s.host == "scada")
        .expect("the host's own STATE");
    assert!(live.online && !live.retained);
    assert!(live.timestamp >= before && live.timestamp <= now_ms());

    let mut later = SpbHost::start(broker.port, GROUP).expect("a second host");
    let kept = later
        .wait_for_state(WAIT, |s| s.host == "scada")
        .expect("the retained STATE");
    assert_eq!(
        (
            kept.online,
            kept.retained,
            kept.timestamp,
            kept.topic.as_str()
        ),
        (true, true, live.timestamp, "spBv1.0/STATE/scada")
    );

    host.state("scada", false);
    let off = later
        .wait_for_state(WAIT, |s| s.host == "scada" && !s.online)
        .expect("STATE offline");
    assert!(!off.retained);

    let mut primary = SpbHost::start_with(
        broker.port,
        GROUP,
        HostOptions {
            client_id: Some("primary".into()),
            will_host: Some("primary".into()),
        },
    )
    .expect("a host with a will");
    primary.state("primary", true);
    later
        .wait_for_state(WAIT, |s| s.host == "primary" && s.online)
        .expect("primary online");
    primary.kill();
    let will = later
        .wait_for_state(WAIT, |s| s.host == "primary" && !s.online)
        .expect("the will: primary offline");
    assert!(will.timestamp <= now_ms());
    drop(host);
}

/// What the gateway's crate encodes, the PyPI host decodes: every integer width at its ends
/// (negative Int8 and Int16 in their own width, which pysparkplug takes and Tahu's Java decoder
/// reads too), UInt32 in long_value, Double, Boolean, String, null.
#[test]
fn the_host_decodes_every_datatype_as_the_gateways_crate_encodes_it() {
    use sparkplug_b::value::{self, Value as V};
    use sparkplug_b::{DataType as T, Metric, Payload};
    let Some((_broker, mut host)) = setup() else {
        return;
    };
    let cases: Vec<(&str, T, V<'_>, Value)> = vec![
        ("i8min", T::Int8, V::Int(-128), json!(-128)),
        ("i8neg", T::Int8, V::Int(-1), json!(-1)),
        ("i8max", T::Int8, V::Int(127), json!(127)),
        ("i16min", T::Int16, V::Int(-32768), json!(-32768)),
        ("i16neg", T::Int16, V::Int(-300), json!(-300)),
        ("i16max", T::Int16, V::Int(32767), json!(32767)),
        (
            "i32min",
            T::Int32,
            V::Int(i64::from(i32::MIN)),
            json!(i32::MIN),
        ),
        (
            "i32max",
            T::Int32,
            V::Int(i64::from(i32::MAX)),
            json!(i32::MAX),
        ),
        ("i64min", T::Int64, V::Int(i64::MIN), json!(i64::MIN)),
        ("u8max", T::UInt8, V::Int(255), json!(255)),
        ("u16max", T::UInt16, V::Int(65535), json!(65535)),
        (
            "u32max",
            T::UInt32,
            V::UInt(u64::from(u32::MAX)),
            json!(u32::MAX),
        ),
        ("u64max", T::UInt64, V::UInt(u64::MAX), json!(u64::MAX)),
        ("double", T::Double, V::Double(-2.5), json!(-2.5)),
        ("bool", T::Boolean, V::Bool(true), json!(true)),
        (
            "text",
            T::String,
            V::Text("F07 Überspannung"),
            json!("F07 Überspannung"),
        ),
    ];
    let ts = now_ms();
    let mut metrics = Vec::new();
    for (alias, (name, dt, v, _)) in cases.iter().enumerate() {
        let mut m = Metric {
            name: Some((*name).to_owned()),
            alias: Some(alias as u64),
            timestamp: Some(ts),
            ..Metric::default()
        };
        value::set(&mut m, *dt, *v).unwrap();
        metrics.push(m);
    }
    let mut null = Metric {
        name: Some("null".into()),
        alias: Some(99),
        timestamp: Some(ts),
        ..Metric::default()
    };
    value::set_null(&mut null, T::Int16).unwrap();
    metrics.push(null);
    let payload = Payload {
        timestamp: Some(ts),
        seq: Some(1),
        metrics,
        ..Payload::default()
    };
    let mut bytes = Vec::new();
    sparkplug_b::encode_into(&payload, &mut bytes);
    host.mark();
    host.raw(&topic("DBIRTH", Some("widths")), &bytes);
    let m = host.expect_kind("DBIRTH", NODE, Some("widths"), WAIT);
    for (name, dt, _, expect) in &cases {
        let got = m.get(name);
        assert_eq!(got.datatype, dt.as_str_name(), "{name}: {got:?}");
        assert_eq!(&got.value, expect, "{name}: {got:?}");
    }
    let null = m.get("null");
    assert!(null.is_null, "{null:?}");
    assert_eq!(null.datatype, "Int16");
}
