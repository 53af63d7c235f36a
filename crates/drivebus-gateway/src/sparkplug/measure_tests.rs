//! What one changed value costs on the wire, JSON topics against Sparkplug B DDATA (issue 21,
//! "Measured"; `docs/sparkplug.md`), for the example plant with the values its simulated
//! drives report. The table:
//!
//! ```text
//! cargo nextest run -p drivebus-gateway measure_tests --no-capture
//! ```
//!
//! Counted per message: the MQTT PUBLISH packet as the client writes it to the socket — the
//! fixed header (the type-and-flags byte and the remaining length, 1–4 bytes), the topic's
//! length field (2 bytes) and the topic, the packet identifier (2 bytes, QoS 1 only), the
//! properties' length (1 byte, MQTT 5 only; no properties are sent) and the payload. The JSON
//! connection is MQTT 5 and publishes values with QoS 1, retained; the Sparkplug connection is
//! MQTT 3.1.1 and publishes DDATA with QoS 0. Not counted: TCP, IP and TLS framing, the
//! broker's PUBACK of each QoS 1 message (4 bytes the other way), and the broker's copies to
//! its subscribers (each in the subscriber's own protocol version and QoS).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, UNIX_EPOCH};

use sparkplug_b::value::{self, Number};
use sparkplug_b::{Metric, Payload};
use tokio::sync::{mpsc, watch};

use super::catalogue::PointMetric;
use super::node::{Message, Node, Out, Phase, SETTLE_LIMIT};
use crate::bus::BusContext;
use crate::config::Plant;
use crate::metrics::Metrics;
use crate::model::Update;
use crate::mqtt::outbox::Outbox;
use crate::mqtt::payload;

/// When the messages are made (ms since the epoch; 13 digits, as every date until 2286).
const NOW: u64 = 1_767_000_000_000;
/// When the values were read.
const READ_AT: u64 = NOW - 250;

/// The example plant (`--example-config`) with a `[sparkplug]` table, every bus simulated.
fn example_plant() -> Plant {
    let text = format!(
        "{}\n[sparkplug]\ngroup_id = \"plant-1\"\nedge_node_id = \"cabinet-1\"\n",
        crate::EXAMPLE_CONFIG
    );
    let mut plant = Plant::parse(&text, "example.toml").unwrap();
    crate::simulate_all(&mut plant);
    plant
}

/// The first value of every polled point, as the bus tasks read it from the simulated drives
/// (on the paused clock).
async fn simulated_values(plant: &Plant) -> HashMap<(usize, usize, usize), i64> {
    let metrics = Arc::new(Metrics::new(plant));
    let (tx, mut rx) = mpsc::channel(4096);
    let (_stop, stop_rx) = watch::channel(crate::bus::Stop::Run);
    let mut tasks = Vec::new();
    let mut keep = Vec::new();
    for (ix, bus) in plant.buses.iter().enumerate() {
        let (set_tx, set_rx) = mpsc::channel(1);
        keep.push(set_tx);
        let ctx = BusContext {
            ix: crate::model::BusSlot::new(ix),
            bus: bus.clone(),
            updates: tx.clone(),
            sets: set_rx,
            asks: BusContext::no_asks(),
            metrics: metrics.clone(),
            shutdown: stop_rx.clone(),
            announce: crate::bus::BusContext::no_announce(),
        };
        tasks.push(tokio::task::spawn_local(crate::families::run_bus(ctx)));
    }
    drop(tx);
    let want: usize = plant
        .buses
        .iter()
        .flat_map(|b| &b.drives)
        .map(|d| d.points.iter().filter(|p| p.period.is_some()).count())
        .sum();
    let mut values = HashMap::new();
    let end = tokio::time::Instant::now() + Duration::from_secs(60);
    while values.len() < want {
        tokio::select! {
            () = tokio::time::sleep_until(end) => break,
            u = rx.recv() => match u {
                Some(Update::Value { bus, drive, point, raw, .. }) => {
                    values.entry((bus, drive, point)).or_insert(raw);
                }
                Some(_) => {}
                None => break,
            },
        }
    }
    for t in &tasks {
        t.abort();
    }
    assert_eq!(
        values.len(),
        want,
        "not every point was read in 60 s: {values:?}"
    );
    values
}

/// Bytes of a protobuf varint (and of an MQTT remaining length, the same encoding).
fn varint_len(v: u64) -> usize {
    let bits = 64 - v.max(1).leading_zeros() as usize;
    bits.div_ceil(7)
}

/// Bytes of an MQTT PUBLISH packet: the fixed header, the topic's length field and the topic,
/// the packet identifier (QoS 1), the properties' length (MQTT 5, no properties), the payload.
fn publish_len(topic: &str, payload: usize, qos1: bool, v5: bool) -> usize {
    let rest = 2 + topic.len() + if qos1 { 2 } else { 0 } + usize::from(v5) + payload;
    1 + varint_len(rest as u64) + rest
}

/// The same counted by rumqttc's own encoders (what the client writes): MQTT 5 QoS 1 for the
/// JSON connection, MQTT 3.1.1 QoS 0 for the Sparkplug one.
fn rumqttc_len(topic: &str, payload: &[u8], json: bool) -> usize {
    if json {
        let mut p = rumqttc::v5::mqttbytes::v5::Publish::new(
            topic,
            rumqttc::v5::mqttbytes::QoS::AtLeastOnce,
            payload.to_vec(),
            None,
        );
        p.pkid = 1;
        p.retain = true;
        p.size()
    } else {
        rumqttc::Publish::new(topic, rumqttc::QoS::AtMostOnce, payload).size()
    }
}

/// Bytes of a protobuf field of `body` bytes with a length prefix (field number below 16).
fn len_field(body: usize) -> usize {
    1 + varint_len(body as u64) + body
}

/// Bytes of a metric's value field (field numbers 10–15 of the specification's `Metric`).
fn value_len(m: &Metric) -> usize {
    use sparkplug_b::proto::payload::metric::Value as V;
    match &m.value {
        Some(V::IntValue(x)) => 1 + varint_len(u64::from(*x)),
        Some(V::LongValue(x)) => 1 + varint_len(*x),
        Some(V::FloatValue(_)) => 1 + 4,
        Some(V::DoubleValue(_)) => 1 + 8,
        Some(V::BooleanValue(_)) => 1 + 1,
        Some(V::StringValue(s)) => len_field(s.len()),
        other => panic!("a value a point's DDATA never carries: {other:?}"),
    }
}

/// What a DDATA of `metrics` must take by the specification's schema: the payload's timestamp
/// (field 1) and `seq` (field 3), and per metric (field 2) its alias, timestamp and value,
/// nothing else (no datatype: the birth gave it, tck-id-payloads-metric-datatype-not-req).
fn ddata_len(ts: u64, seq: u64, metrics: &[Metric]) -> usize {
    let body = |m: &Metric| {
        1 + varint_len(m.alias.unwrap()) + 1 + varint_len(m.timestamp.unwrap()) + value_len(m)
    };
    1 + varint_len(ts)
        + metrics.iter().map(|m| len_field(body(m))).sum::<usize>()
        + 1
        + varint_len(seq)
}

/// A point's metric in a DDATA is what the catalogue says, by alias only, with the value read.
fn check_metric(m: &Metric, p: &PointMetric, raw: i64) {
    assert_eq!(m.name, None, "{}: DATA messages go by alias", p.name);
    assert_eq!(m.alias, Some(p.alias), "{}", p.name);
    assert_eq!(m.timestamp, Some(READ_AT), "{}", p.name);
    assert_eq!(m.datatype, None, "{}: the birth gave the datatype", p.name);
    assert_eq!(m.properties, None, "{}", p.name);
    let want = if p.scaled {
        Number::Float(p.physical(raw))
    } else {
        Number::Int(raw)
    };
    assert_eq!(value::get(m, p.datatype).unwrap(), want, "{}", p.name);
}

/// A node of `plant` past its births, every value null in them (the drives' answers not
/// waited for): each value given next is a change, published as DDATA at the next flush.
fn born(plant: &Plant) -> Node {
    let sp = plant.sparkplug.clone().unwrap();
    let mut n = Node::new(plant, &sp);
    let subs = n.connected(0);
    let start = NOW - u64::try_from(SETTLE_LIMIT.as_millis()).unwrap();
    for _ in &subs {
        assert!(n.subscribed(start).is_empty());
    }
    let births = n.flush(NOW);
    assert_eq!(
        births.len(),
        1 + plant.buses.iter().map(|b| b.drives.len()).sum::<usize>()
    );
    assert_eq!(n.phase(), Phase::Born);
    n
}

/// The one message a flush gives, decoded.
fn only_message(outs: Vec<Out>) -> (Message, Payload) {
    let [Out::Publish(m)] = <[Out; 1]>::try_from(outs).unwrap() else {
        panic!("not a publish");
    };
    let p = sparkplug_b::decode(&m.payload).unwrap();
    (m, p)
}

fn value_update(bus: usize, drive: usize, point: usize, raw: i64) -> Update {
    Update::Value {
        bus,
        drive,
        point,
        raw,
        at: UNIX_EPOCH + Duration::from_millis(READ_AT),
    }
}

/// One row of the table: a point's changed value both ways.
#[derive(Debug)]
struct Row {
    what: String,
    datatype: &'static str,
    json_payload: usize,
    json_wire: usize,
    spb_payload: usize,
    spb_wire: usize,
}

#[allow(clippy::print_stdout)]
#[tokio::test(start_paused = true)]
async fn a_changed_value_as_one_metric_ddata_takes_fewer_bytes_on_the_wire_than_its_json_topic() {
    let plant = example_plant();
    let values = tokio::task::LocalSet::new()
        .run_until(simulated_values(&plant))
        .await;
    let g = &plant.gateway;
    let mut outbox = Outbox::new(&plant);
    let mut node = born(&plant);
    let mut burst_node = born(&plant);
    let cat = node.catalogue().clone();
    let now = tokio::time::Instant::now();
    let mut rows = Vec::new();
    let mut bursts = Vec::new();
    for dev in &cat.devices {
        let bus = &plant.buses[dev.bus];
        let drive = &bus.drives[dev.drive];
        let mut json_burst = 0;
        let mut metrics = Vec::new();
        for p in &dev.points {
            let point = &drive.points[p.point];
            let raw = values[&(dev.bus, dev.drive, p.point)];
            let u = value_update(dev.bus, dev.drive, p.point, raw);
            // JSON: the topic and payload as the gateway's outbox publishes them.
            assert!(outbox.update(u.clone(), now, &plant));
            let mut json = Vec::new();
            outbox.flush(now, |o| {
                json.push((o.topic.to_owned(), o.payload.to_owned(), o.retain));
                true
            });
            let [(topic, body, retain)] = <[_; 1]>::try_from(json).unwrap();
            assert!(retain);
            assert_eq!(
                topic,
                format!(
                    "{}/{}/{}/{}/{}",
                    g.prefix, g.name, bus.name, drive.name, point.name
                )
            );
            assert_eq!(
                body,
                payload::value(&point.target, raw, READ_AT, &drive.device)
            );
            let json_wire = publish_len(&topic, body.len(), true, true);
            assert_eq!(json_wire, rumqttc_len(&topic, body.as_bytes(), true));
            json_burst += json_wire;
            // Sparkplug: the DDATA the node makes of the same change.
            assert!(node.update(&u, NOW).is_empty());
            let (m, p_dec) = only_message(node.flush(NOW));
            assert_eq!(
                m.topic,
                format!("spBv1.0/plant-1/DDATA/cabinet-1/{}", drive.name)
            );
            assert!(!m.qos1 && !m.retain);
            let [metric] = <[Metric; 1]>::try_from(p_dec.metrics.clone()).unwrap();
            check_metric(&metric, p, raw);
            assert_eq!(p_dec.timestamp, Some(NOW));
            // Sequence numbers up to 127 take one byte, 128–255 two.
            assert!(p_dec.seq.unwrap() < 128);
            assert_eq!(
                m.payload.len(),
                ddata_len(NOW, p_dec.seq.unwrap(), &p_dec.metrics)
            );
            let spb_wire = publish_len(&m.topic, m.payload.len(), false, false);
            assert_eq!(spb_wire, rumqttc_len(&m.topic, &m.payload, false));
            rows.push(Row {
                what: format!("{}/{}/{}", bus.name, drive.name, point.name),
                datatype: p.datatype.as_str_name(),
                json_payload: body.len(),
                json_wire,
                spb_payload: m.payload.len(),
                spb_wire,
            });
            // The burst: every point of the drive changed at once.
            assert!(burst_node.update(&u, NOW).is_empty());
            metrics.push((p, raw));
        }
        let (m, p_dec) = only_message(burst_node.flush(NOW));
        assert_eq!(p_dec.metrics.len(), metrics.len());
        for (metric, (p, raw)) in p_dec.metrics.iter().zip(&metrics) {
            check_metric(metric, p, *raw);
        }
        assert_eq!(
            m.payload.len(),
            ddata_len(NOW, p_dec.seq.unwrap(), &p_dec.metrics)
        );
        let spb_wire = publish_len(&m.topic, m.payload.len(), false, false);
        bursts.push((dev.id.clone(), metrics.len(), json_burst, spb_wire));
    }

    println!(
        "one changed value, bytes (wire = the whole MQTT PUBLISH packet; JSON: MQTT 5 QoS 1, \
         Sparkplug: MQTT 3.1.1 QoS 0)"
    );
    println!(
        "{:<34} {:<7} {:>8} {:>6} {:>8} {:>6} {:>6}",
        "point", "type", "json pay", "wire", "spb pay", "wire", "ratio"
    );
    for r in &rows {
        println!(
            "{:<34} {:<7} {:>8} {:>6} {:>8} {:>6} {:>6.2}",
            r.what,
            r.datatype,
            r.json_payload,
            r.json_wire,
            r.spb_payload,
            r.spb_wire,
            r.spb_wire as f64 / r.json_wire as f64
        );
    }
    let sum = |f: fn(&Row) -> usize| rows.iter().map(f).sum::<usize>();
    let (jp, jw, sp, sw) = (
        sum(|r| r.json_payload),
        sum(|r| r.json_wire),
        sum(|r| r.spb_payload),
        sum(|r| r.spb_wire),
    );
    let n = rows.len();
    println!(
        "{:<34} {:<7} {:>8.1} {:>6.1} {:>8.1} {:>6.1} {:>6.2}",
        format!("mean of {n} points"),
        "",
        jp as f64 / n as f64,
        jw as f64 / n as f64,
        sp as f64 / n as f64,
        sw as f64 / n as f64,
        sw as f64 / jw as f64
    );
    println!(
        "\nevery point of a drive changed at once: N JSON messages against one DDATA, wire bytes"
    );
    println!(
        "{:<12} {:>2} {:>10} {:>10} {:>6}",
        "drive", "N", "json wire", "ddata wire", "ratio"
    );
    for (id, k, j, s) in &bursts {
        println!(
            "{id:<12} {k:>2} {j:>10} {s:>10} {:>6.2}",
            *s as f64 / *j as f64
        );
    }
    let (bj, bs) = bursts
        .iter()
        .fold((0, 0), |(a, b), (_, _, j, s)| (a + j, b + s));
    println!(
        "{:<12} {n:>2} {bj:>10} {bs:>10} {:>6.2}",
        "all drives",
        bs as f64 / bj as f64
    );
    println!(
        "(not counted: TCP/IP/TLS framing; the broker's PUBACK of each JSON message, {} bytes)",
        rumqttc::v5::mqttbytes::v5::PubAck::new(1, None).size()
    );

    // Every point: the DDATA's payload and its whole message are smaller than the JSON's.
    for r in &rows {
        assert!(r.spb_payload < r.json_payload, "{r:?}");
        assert!(r.spb_wire < r.json_wire, "{r:?}");
    }
    for (id, k, j, s) in &bursts {
        assert!(s < j, "{id}: {k} points: one DDATA {s} bytes, JSON {j}");
    }
    // The figures themselves, so that they cannot change unnoticed (`docs/sparkplug.md`).
    assert_eq!(n, 24);
    let payload_ratio = sp as f64 / jp as f64;
    let wire_ratio = sw as f64 / jw as f64;
    let burst_ratio = bs as f64 / bj as f64;
    println!(
        "totals: payload {sp} of {jp} bytes ({payload_ratio:.3}), wire {sw} of {jw} \
         ({wire_ratio:.3}), bursts {bs} of {bj} ({burst_ratio:.3})"
    );
    // Measured: 0.387, 0.575 and 0.327 (650 of 1679 payload bytes, 1655 of 2879 on the wire,
    // 942 of 2879 in bursts).
    assert!((0.36..0.41).contains(&payload_ratio), "{payload_ratio}");
    assert!((0.55..0.60).contains(&wire_ratio), "{wire_ratio}");
    assert!((0.30..0.35).contains(&burst_ratio), "{burst_ratio}");
    // A one-metric DDATA is 22–29 bytes whatever the point (Double: 29), the JSON at least 51.
    assert!(
        rows.iter().all(|r| (22..=29).contains(&r.spb_payload)),
        "{rows:?}"
    );
    assert!(rows.iter().all(|r| r.json_payload >= 51), "{rows:?}");
}
