//! The session ([`Node`]) without a broker: what goes in, what comes out, decoded again.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use sparkplug_b::props;
use sparkplug_b::value::{self, Number, Value};
use sparkplug_b::{DataType, Metric, Payload};

use super::BdSeqStore;
use super::catalogue::{FAULT, STATE};
use super::node::{Message, Node, Out, Phase, parse_state};
use crate::config::Plant;
use crate::model::{DriveStatus, SetOutcome, SetValue, Update};

const NOW: u64 = 1_767_000_000_000;

fn plant(extra: &str) -> Plant {
    let text = format!(
        "[gateway]\nname = \"gw1\"\nbroker = \"mqtt://127.0.0.1:1883\"\nmetrics = \"off\"\n\
         max_set_age = \"10s\"\n\
         [sparkplug]\ngroup_id = \"plant\"\nedge_node_id = \"cabinet1\"\n{extra}\n\
         [[bus]]\nname = \"line1\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"conv\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"1s\"\nwritable = true\n\
         [[bus.drive.param]]\nparam = \"P700\"\nname = \"mode\"\nperiod = \"1s\"\n\
         [[bus.drive]]\nname = \"pump\"\naddress = 2\n\
         [[bus.drive.param]]\nparam = \"P000\"\nname = \"speed\"\nperiod = \"1s\"\n"
    );
    Plant::parse(&text, "test").unwrap()
}

fn node(extra: &str) -> Node {
    let p = plant(extra);
    let sp = p.sparkplug.clone().unwrap();
    Node::new(&p, &sp)
}

fn publishes(outs: &[Out]) -> Vec<(&str, Payload)> {
    outs.iter()
        .filter_map(|o| match o {
            Out::Publish(Message { topic, payload, .. }) => {
                Some((topic.as_str(), sparkplug_b::decode(payload).unwrap()))
            }
            _ => None,
        })
        .collect()
}

fn metric<'a>(p: &'a Payload, name: &str) -> &'a Metric {
    p.metrics
        .iter()
        .find(|m| m.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no metric {name} in {p:?}"))
}

/// When [`born`]'s births go out: the drives never answered, so after the settling limit.
const BORN: u64 = NOW + 10_000;

/// Connected with `bd`, every subscription acknowledged, the drives' first answers not waited
/// for any longer: the births.
fn born(n: &mut Node, bd: u8) -> Vec<Out> {
    let subs = n.connected(bd);
    let mut out = Vec::new();
    for _ in 0..subs.len() {
        out.extend(n.subscribed(NOW));
    }
    assert!(out.is_empty(), "born before the drives answered: {out:?}");
    assert!(n.flush(BORN - 1).is_empty());
    out.extend(n.flush(BORN));
    assert_eq!(n.phase(), Phase::Born);
    out
}

fn value_update(drive: usize, point: usize, raw: i64, at_ms: u64) -> Update {
    Update::Value {
        bus: 0,
        drive,
        point,
        raw,
        at: UNIX_EPOCH + Duration::from_millis(at_ms),
    }
}

fn status_update(drive: usize, status: DriveStatus) -> Update {
    Update::Status {
        bus: 0,
        drive,
        status,
        at: SystemTime::now(),
    }
}

fn encode(p: &Payload) -> Vec<u8> {
    let mut b = Vec::new();
    sparkplug_b::encode_into(p, &mut b);
    b
}

fn dcmd(metrics: Vec<Metric>, ts: Option<u64>) -> Vec<u8> {
    encode(&Payload {
        timestamp: ts,
        metrics,
        ..Payload::default()
    })
}

fn named(name: &str, datatype: Option<DataType>, v: Value<'_>, as_type: DataType) -> Metric {
    let mut m = Metric {
        name: Some(name.to_owned()),
        ..Metric::default()
    };
    value::set(&mut m, as_type, v).unwrap();
    m.datatype = datatype.map(|d| d as u32);
    m
}

#[test]
fn subscriptions_then_nbirth_seq_0_with_the_connections_bdseq_then_every_dbirth() {
    let mut n = node("");
    let subs = n.connected(7);
    assert_eq!(
        subs,
        vec![
            Out::Subscribe("spBv1.0/plant/NCMD/cabinet1".into()),
            Out::Subscribe("spBv1.0/plant/DCMD/cabinet1/+".into()),
        ]
    );
    // Nothing is born before every subscription is acknowledged.
    assert!(n.subscribed(NOW).is_empty());
    assert!(n.subscribed(NOW).is_empty());
    assert_eq!(n.phase(), Phase::Settling(NOW));
    let out = n.flush(BORN);
    assert_eq!(n.phase(), Phase::Born);
    let p = publishes(&out);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/NBIRTH/cabinet1",
            "spBv1.0/plant/DBIRTH/cabinet1/conv",
            "spBv1.0/plant/DBIRTH/cabinet1/pump",
        ]
    );
    let seqs: Vec<u64> = p.iter().map(|(_, p)| p.seq.unwrap()).collect();
    assert_eq!(seqs, [0, 1, 2]);
    let nbirth = &p[0].1;
    assert_eq!(nbirth.timestamp, Some(BORN));
    let bd = metric(nbirth, "bdSeq");
    assert_eq!(bd.datatype, Some(DataType::Int64 as u32));
    assert_eq!(value::get(bd, DataType::Int64).unwrap(), Number::Int(7));
    let rebirth = metric(nbirth, "Node Control/Rebirth");
    assert_eq!(
        value::get(rebirth, DataType::Boolean).unwrap(),
        Number::Bool(false)
    );
    // The bus's figures before its first report: nothing done, the config's demand.
    let util = metric(nbirth, "Buses/line1/Utilisation");
    assert_eq!(
        value::get(util, DataType::Double).unwrap(),
        Number::Float(0.0)
    );
    let demand = metric(nbirth, "Buses/line1/Demand");
    let expect = (crate::families::wire::demand(&plant("").buses[0]) * 1e4).round() / 1e4;
    assert!(expect > 0.0);
    assert_eq!(
        value::get(demand, DataType::Double).unwrap(),
        Number::Float(expect)
    );
    // QoS 0, not retained (tck-id-topics-nbirth-mqtt, dbirth alike).
    for o in &out {
        if let Out::Publish(m) = o {
            assert!(!m.qos1 && !m.retain, "{}", m.topic);
        }
    }
    // Aliases are unique across the node and its devices.
    let mut aliases: Vec<u64> = p
        .iter()
        .flat_map(|(_, p)| p.metrics.iter().filter_map(|m| m.alias))
        .collect();
    // Every metric has one but Node Control/Rebirth, which a host asks for by name
    // (tck-id-operational-behavior-data-commands-rebirth-name-aliases).
    let without: Vec<_> = p
        .iter()
        .flat_map(|(_, p)| p.metrics.iter().filter(|m| m.alias.is_none()))
        .map(|m| m.name.clone().unwrap())
        .collect();
    assert_eq!(without, ["Node Control/Rebirth"]);
    let all = aliases.len();
    aliases.sort_unstable();
    aliases.dedup();
    assert_eq!(aliases.len(), all);
}

#[test]
fn a_dbirth_carries_every_point_with_its_datatype_unit_range_names_and_selector() {
    let mut n = node("");
    n.update(&value_update(0, 0, 2500, NOW - 300), NOW);
    let out = born(&mut n, 0);
    let p = publishes(&out);
    let conv = &p[1].1;
    assert_eq!(p[1].0, "spBv1.0/plant/DBIRTH/cabinet1/conv");
    let ramp = metric(conv, "ramp");
    let t = drive_client::target::Target::resolve(drive_profile::Family::Movidrive, "P130", 0..=0)
        .unwrap();
    let param = t.param.unwrap();
    let props = ramp.properties.as_ref().unwrap();
    let text = |k: &str| match props::get(props, k).and_then(|v| v.value.clone()) {
        Some(sparkplug_b::property_value::Value::StringValue(s)) => s,
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(text("parameter"), "P130");
    assert_eq!(text("nameEn"), param.name_en());
    assert_eq!(text("nameDe"), param.name_de());
    assert_eq!(text("engUnit"), param.unit());
    assert!(matches!(
        props::get(props, "writable").and_then(|v| v.value.clone()),
        Some(sparkplug_b::property_value::Value::BooleanValue(true))
    ));
    // The value: the table's physical value of raw 2500 with the read's timestamp.
    assert_eq!(ramp.timestamp, Some(NOW - 300));
    let expect = param.to_physical(2500);
    match value::get(
        ramp,
        DataType::try_from(ramp.datatype.unwrap() as i32).unwrap(),
    )
    .unwrap()
    {
        Number::Int(i) => assert_eq!(i as f64, expect),
        Number::Float(f) => assert!((f - expect).abs() < 1e-9, "{f} {expect}"),
        other => panic!("{other:?}"),
    }
    // A point not read yet is null; the status metrics are there; a writable point's result.
    assert_eq!(metric(conv, "mode").is_null, Some(true));
    assert_eq!(metric(conv, STATE).datatype, Some(DataType::String as u32));
    assert_eq!(metric(conv, FAULT).is_null, Some(true));
    assert!(
        conv.metrics
            .iter()
            .any(|m| m.name.as_deref() == Some("ramp/Write Result"))
    );
    assert!(
        !conv
            .metrics
            .iter()
            .any(|m| m.name.as_deref() == Some("mode/Write Result"))
    );
}

#[test]
fn ddata_by_exception_with_aliases_only_and_the_reads_timestamps() {
    let mut n = node("");
    let births = born(&mut n, 0);
    let pump_birth = publishes(&births)[2].1.clone();
    let speed_alias = metric(&pump_birth, "speed").alias.unwrap();
    n.update(&value_update(1, 0, 1200, NOW + 5), NOW + 10);
    let out = n.flush(NOW + 10);
    let p = publishes(&out);
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].0, "spBv1.0/plant/DDATA/cabinet1/pump");
    assert_eq!(p[0].1.seq, Some(3));
    let m = &p[0].1.metrics[0];
    assert_eq!(m.name, None);
    assert_eq!(m.alias, Some(speed_alias));
    assert_eq!(m.timestamp, Some(NOW + 5));
    // The same value again: nothing; another: one more DDATA, the next seq.
    n.update(&value_update(1, 0, 1200, NOW + 1005), NOW + 1010);
    assert!(n.flush(NOW + 1010).is_empty());
    n.update(&value_update(1, 0, 1300, NOW + 2005), NOW + 2010);
    let out_ = n.flush(NOW + 2010);
    let p = publishes(&out_).remove(0);
    assert_eq!(p.1.seq, Some(4));
    // Several values of one drive at once: one DDATA.
    n.update(&value_update(0, 0, 100, NOW + 3000), NOW + 3000);
    n.update(&value_update(0, 1, 2, NOW + 3000), NOW + 3000);
    let out_ = n.flush(NOW + 3001);
    let p = publishes(&out_);
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].1.metrics.len(), 2);
}

#[test]
fn a_timed_out_drive_dies_and_is_born_again_when_it_answers() {
    let mut n = node("");
    born(&mut n, 0);
    let out = n.update(&status_update(1, DriveStatus::Timeout), NOW);
    let p = publishes(&out);
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].0, "spBv1.0/plant/DDEATH/cabinet1/pump");
    assert_eq!(p[0].1.seq, Some(3));
    // Values while dead are kept, not published; a DCMD is refused as offline.
    n.update(&value_update(1, 0, 55, NOW + 1), NOW + 1);
    assert!(n.flush(NOW + 1).is_empty());
    let out = n.update(&status_update(1, DriveStatus::Online), NOW + 2);
    let p = publishes(&out);
    assert_eq!(p[0].0, "spBv1.0/plant/DBIRTH/cabinet1/pump");
    assert_eq!(p[0].1.seq, Some(4));
    // P000 is in 1/1000 1/min on the bus: the metric is the table's physical value.
    let speed = metric(&p[0].1, "speed");
    assert_eq!(speed.datatype, Some(DataType::Double as u32));
    assert_eq!(
        value::get(speed, DataType::Double).unwrap(),
        Number::Float(0.055)
    );
    let state = metric(&p[0].1, STATE);
    assert_eq!(
        value::get(state, DataType::String).unwrap(),
        Number::Text("online".into())
    );
    // A fault while born: the status metrics in a DDATA.
    n.update(
        &status_update(1, DriveStatus::Fault("F07 overvoltage".into())),
        NOW + 3,
    );
    let out_ = n.flush(NOW + 3);
    let p = publishes(&out_);
    let texts: Vec<Number> = p[0]
        .1
        .metrics
        .iter()
        .map(|m| value::get(m, DataType::String).unwrap())
        .collect();
    assert_eq!(
        texts,
        [
            Number::Text("fault".into()),
            Number::Text("F07 overvoltage".into())
        ]
    );
}

#[test]
fn the_births_wait_for_the_drives_first_answers() {
    let mut n = node("");
    let subs = n.connected(1);
    for _ in 0..subs.len() {
        assert!(n.subscribed(NOW).is_empty());
    }
    // conv answers with both its points, pump times out: born at once, with the values.
    for u in [
        status_update(0, DriveStatus::Online),
        value_update(0, 0, 2500, NOW + 1),
        status_update(1, DriveStatus::Timeout),
    ] {
        n.update(&u, NOW + 2);
        assert!(
            n.flush(NOW + 2).is_empty(),
            "born before every first answer"
        );
    }
    n.update(&value_update(0, 1, 3, NOW + 3), NOW + 3);
    let out_ = n.flush(NOW + 3);
    let p = publishes(&out_);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/NBIRTH/cabinet1",
            "spBv1.0/plant/DBIRTH/cabinet1/conv"
        ]
    );
    assert_eq!(metric(&p[1].1, "mode").is_null, None);
    assert_eq!(
        value::get(metric(&p[1].1, STATE), DataType::String).unwrap(),
        Number::Text("online".into())
    );
}

#[test]
fn a_drive_in_timeout_at_the_birth_gets_no_dbirth() {
    let mut n = node("");
    n.update(&status_update(0, DriveStatus::Timeout), NOW);
    let out_ = born(&mut n, 0);
    let p = publishes(&out_);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/NBIRTH/cabinet1",
            "spBv1.0/plant/DBIRTH/cabinet1/pump"
        ]
    );
}

#[test]
fn a_dcmd_by_name_or_alias_with_or_without_datatype_becomes_a_guarded_write() {
    let mut n = node("");
    let births = born(&mut n, 0);
    let conv = publishes(&births)[1].1.clone();
    let ramp = metric(&conv, "ramp");
    let dt = DataType::try_from(ramp.datatype.unwrap() as i32).unwrap();
    let v = |x: f64| {
        if dt == DataType::Double {
            Value::Double(x)
        } else {
            Value::Int(x as i64)
        }
    };
    let topic = "spBv1.0/plant/DCMD/cabinet1/conv";
    for m in [
        named("ramp", Some(dt), v(3.0), dt),
        named("ramp", None, v(3.0), dt),
        {
            let mut m = named("ramp", Some(dt), v(3.0), dt);
            m.name = None;
            m.alias = ramp.alias;
            m
        },
    ] {
        let out = n.incoming(topic, &dcmd(vec![m], Some(NOW - 100)), false, NOW);
        let writes: Vec<&Out> = out
            .iter()
            .filter(|o| matches!(o, Out::Write { .. }))
            .collect();
        assert_eq!(writes.len(), 1, "{out:?}");
        let Out::Write {
            device,
            point,
            value,
            max_age,
        } = writes[0]
        else {
            unreachable!()
        };
        assert_eq!((*device, *point), (0, 0));
        assert_eq!(
            *value,
            SetValue::Value(serde_json::json!(3.0)).clone_with_int(dt)
        );
        // The command's age counts against max_set_age.
        assert_eq!(*max_age, Duration::from_millis(9_900));
    }
}

trait IntValue {
    fn clone_with_int(&self, dt: DataType) -> SetValue;
}

impl IntValue for SetValue {
    /// `{"value": 3}` for an integer point, `3.0` for a Double one.
    fn clone_with_int(&self, dt: DataType) -> SetValue {
        match (self, dt) {
            (SetValue::Value(serde_json::Value::Number(n)), d) if d != DataType::Double => {
                SetValue::Value(serde_json::json!(n.as_f64().unwrap() as i64))
            }
            (s, _) => s.clone(),
        }
    }
}

fn result_text(n: &mut Node, out: &[Out], at: u64) -> String {
    let mut all: Vec<Out> = out.to_vec();
    all.extend(n.flush(at));
    let p = publishes(&all);
    let ddata = p
        .iter()
        .find(|(t, _)| *t == "spBv1.0/plant/DDATA/cabinet1/conv")
        .unwrap_or_else(|| panic!("no DDATA in {all:?}"));
    let texts: Vec<String> = ddata
        .1
        .metrics
        .iter()
        .filter_map(|m| match value::get(m, DataType::String) {
            Ok(Number::Text(t)) => Some(t),
            _ => None,
        })
        .collect();
    texts.join("|")
}

#[test]
fn refused_dcmds_write_nothing_and_say_why_in_the_write_result() {
    let mut n = node("");
    let births = born(&mut n, 0);
    let conv = publishes(&births)[1].1.clone();
    let ramp = metric(&conv, "ramp");
    let dt = DataType::try_from(ramp.datatype.unwrap() as i32).unwrap();
    let good = |ts| {
        dcmd(
            vec![named("ramp", None, Value::Double(3.0), DataType::Double).with_type(dt)],
            ts,
        )
    };
    let topic = "spBv1.0/plant/DCMD/cabinet1/conv";
    let cases: Vec<(Vec<u8>, bool, &str)> = vec![
        (
            good(Some(NOW - 20_000)),
            false,
            "refused stale: sent 20000 ms ago",
        ),
        (
            good(Some(NOW + 60_000)),
            false,
            "refused stale: timestamp is 60000 ms in the future",
        ),
        (good(Some(NOW)), true, "refused retained"),
        (
            dcmd(
                vec![named(
                    "ramp",
                    Some(DataType::Boolean),
                    Value::Bool(true),
                    DataType::Boolean,
                )],
                Some(NOW),
            ),
            false,
            "refused bad_request: datatype Boolean is not the birth's",
        ),
    ];
    for (payload, retained, expect) in cases {
        let out = n.incoming(topic, &payload, retained, NOW);
        assert!(
            !out.iter().any(|o| matches!(o, Out::Write { .. })),
            "{expect}: {out:?}"
        );
        let text = result_text(&mut n, &out, NOW);
        assert!(text.contains(expect), "{text:?} lacks {expect:?}");
        if retained {
            // Cleared, so that it is not refused again at every reconnection.
            assert!(out.iter().any(|o| matches!(o, Out::Publish(m) if m.topic == topic && m.retain && m.payload.is_empty())));
        }
    }
    // A point that is not writable: its DATA says why in a property.
    let mode = dcmd(
        vec![named("mode", None, Value::Int(1), DataType::Int64)],
        Some(NOW),
    );
    let out = n.incoming(topic, &mode, false, NOW);
    assert!(!out.iter().any(|o| matches!(o, Out::Write { .. })));
    let p = publishes(&out);
    let m = &p[0].1.metrics[0];
    let note = props::get(m.properties.as_ref().unwrap(), "writeResult").unwrap();
    assert!(
        matches!(&note.value, Some(sparkplug_b::property_value::Value::StringValue(s)) if s.starts_with("refused not_writable"))
    );
    // The drive timed out: refused as offline.
    n.update(&status_update(0, DriveStatus::Timeout), NOW);
    n.update(&status_update(0, DriveStatus::Online), NOW);
    n.update(&status_update(0, DriveStatus::Timeout), NOW);
    let out = n.incoming(topic, &good(Some(NOW)), false, NOW);
    assert!(!out.iter().any(|o| matches!(o, Out::Write { .. })));
    // Payloads that do not decode write nothing and do not panic.
    for junk in [&b"\xff\xff\xff"[..], b"", b"\x12\x05garbage"] {
        let out = n.incoming(topic, junk, false, NOW);
        assert!(!out.iter().any(|o| matches!(o, Out::Write { .. })));
    }
}

trait WithType {
    fn with_type(self, dt: DataType) -> Metric;
}

impl WithType for Metric {
    /// The same value as the point's own datatype (3.0 or 3).
    fn with_type(self, dt: DataType) -> Metric {
        let mut m = Metric {
            name: self.name,
            alias: self.alias,
            ..Metric::default()
        };
        let v = if dt == DataType::Double {
            Value::Double(3.0)
        } else {
            Value::Int(3)
        };
        value::set(&mut m, dt, v).unwrap();
        m
    }
}

#[test]
fn a_writes_outcome_is_a_ddata_of_the_read_back_value_and_the_result() {
    let mut n = node("");
    born(&mut n, 0);
    n.write_done(
        0,
        0,
        &SetOutcome::Written {
            raw: 4000,
            differs: None,
        },
        NOW,
    );
    let out_ = n.flush(NOW);
    let p = publishes(&out_);
    assert_eq!(p[0].0, "spBv1.0/plant/DDATA/cabinet1/conv");
    assert_eq!(p[0].1.metrics.len(), 2);
    let text = value::get(&p[0].1.metrics[1], DataType::String).unwrap();
    assert_eq!(text, Number::Text("written".into()));
    n.write_done(
        0,
        0,
        &SetOutcome::Refused {
            reason: "range",
            message: "P130 takes 0–2000 s".into(),
        },
        NOW,
    );
    let out_ = n.flush(NOW);
    let p = publishes(&out_);
    let text = value::get(&p[0].1.metrics[1], DataType::String).unwrap();
    assert_eq!(
        text,
        Number::Text("refused range: P130 takes 0–2000 s".into())
    );
}

#[test]
fn rebirth_in_an_ncmd_sends_nbirth_seq_0_with_the_same_bdseq_and_every_dbirth() {
    let mut n = node("");
    born(&mut n, 42);
    n.update(&value_update(1, 0, 9, NOW), NOW);
    n.flush(NOW);
    let cmd = dcmd(
        vec![named(
            "Node Control/Rebirth",
            Some(DataType::Boolean),
            Value::Bool(true),
            DataType::Boolean,
        )],
        Some(NOW),
    );
    let out = n.incoming("spBv1.0/plant/NCMD/cabinet1", &cmd, false, NOW);
    let p = publishes(&out);
    assert_eq!(p.len(), 3);
    assert_eq!(p[0].0, "spBv1.0/plant/NBIRTH/cabinet1");
    assert_eq!(p[0].1.seq, Some(0));
    assert_eq!(
        value::get(metric(&p[0].1, "bdSeq"), DataType::Int64).unwrap(),
        Number::Int(42)
    );
    assert_eq!(p[2].1.seq, Some(2));
    // Rebirth false, another group's NCMD, a retained NCMD: nothing.
    let no = dcmd(
        vec![named(
            "Node Control/Rebirth",
            None,
            Value::Bool(false),
            DataType::Boolean,
        )],
        Some(NOW),
    );
    assert!(
        n.incoming("spBv1.0/plant/NCMD/cabinet1", &no, false, NOW)
            .is_empty()
    );
    assert!(
        n.incoming("spBv1.0/other/NCMD/cabinet1", &cmd, false, NOW)
            .is_empty()
    );
    let out = n.incoming("spBv1.0/plant/NCMD/cabinet1", &cmd, true, NOW);
    assert!(publishes(&out).iter().all(|(_, p)| p.metrics.is_empty()));
}

#[test]
fn with_a_primary_host_the_births_wait_for_its_state_online() {
    let mut n = node("primary_host_id = \"scada\"\n");
    let subs = n.connected(3);
    assert!(subs.contains(&Out::Subscribe("spBv1.0/STATE/scada".into())));
    let mut out = Vec::new();
    for _ in 0..subs.len() {
        out.extend(n.subscribed(NOW));
    }
    assert!(out.is_empty());
    assert_eq!(n.phase(), Phase::WaitingForHost);
    // Another host's STATE, an offline one, garbage: still waiting.
    assert!(
        n.incoming(
            "spBv1.0/STATE/other",
            br#"{"online":true,"timestamp":5}"#,
            true,
            NOW
        )
        .is_empty()
    );
    assert!(
        n.incoming(
            "spBv1.0/STATE/scada",
            br#"{"online":false,"timestamp":5}"#,
            true,
            NOW
        )
        .is_empty()
    );
    assert!(
        n.incoming("spBv1.0/STATE/scada", b"online", true, NOW)
            .is_empty()
    );
    assert_eq!(n.phase(), Phase::WaitingForHost);
    let out_ = n.incoming(
        "spBv1.0/STATE/scada",
        br#"{"online":true,"timestamp":10}"#,
        true,
        NOW,
    );
    assert!(out_.is_empty());
    assert_eq!(n.phase(), Phase::Settling(NOW));
    let out_ = n.flush(BORN);
    let p = publishes(&out_);
    assert_eq!(p[0].0, "spBv1.0/plant/NBIRTH/cabinet1");
    // An offline older than the online: not this session's, ignored.
    assert!(
        n.incoming(
            "spBv1.0/STATE/scada",
            br#"{"online":false,"timestamp":9}"#,
            false,
            NOW
        )
        .is_empty()
    );
    assert_eq!(n.phase(), Phase::Born);
    // Offline at or after it: NDEATH, then the disconnect.
    let out = n.incoming(
        "spBv1.0/STATE/scada",
        br#"{"online":false,"timestamp":10}"#,
        false,
        NOW,
    );
    assert_eq!(out.len(), 2);
    assert!(matches!(&out[1], Out::Disconnect));
    let death = publishes(&out).remove(0);
    assert_eq!(death.0, "spBv1.0/plant/NDEATH/cabinet1");
    assert_eq!(death.1.seq, None);
    assert_eq!(
        value::get(metric(&death.1, "bdSeq"), DataType::Int64).unwrap(),
        Number::Int(3)
    );
    assert_eq!(n.phase(), Phase::Leaving);
}

#[test]
fn the_stop_publishes_ndeath_with_bdseq_and_no_seq_then_disconnects() {
    let mut n = node("");
    assert!(n.stopping(NOW).is_empty(), "nothing to say while offline");
    born(&mut n, 255);
    let out = n.stopping(NOW);
    let Out::Publish(m) = &out[0] else {
        panic!("{out:?}")
    };
    assert!(m.qos1 && !m.retain);
    let p = sparkplug_b::decode(&m.payload).unwrap();
    assert_eq!(p.seq, None);
    assert_eq!(p.metrics.len(), 1);
    assert_eq!(
        value::get(&p.metrics[0], DataType::Int64).unwrap(),
        Number::Int(255)
    );
    assert_eq!(out[1], Out::Disconnect);
    // The will is the same message.
    assert_eq!(n.death(255, NOW).payload, m.payload);
}

#[test]
fn seq_wraps_after_255_through_data_messages() {
    let mut n = node("");
    born(&mut n, 0);
    let mut seqs = Vec::new();
    for i in 0..300u64 {
        n.update(&value_update(1, 0, i as i64, NOW + i), NOW + i);
        for (_, p) in publishes(&n.flush(NOW + i)) {
            seqs.push(p.seq.unwrap());
        }
    }
    let expect: Vec<u64> = (3..300 + 3).map(|s| s % 256).collect();
    assert_eq!(seqs, expect);
}

#[test]
fn bus_figures_are_ndata_of_what_changed() {
    let mut n = node("");
    born(&mut n, 0);
    let f = crate::model::BusFigures {
        utilisation: 0.25,
        demand: 0.3,
        transactions: 10,
        ..Default::default()
    };
    n.update(
        &Update::Figures {
            bus: 0,
            figures: f.clone(),
        },
        NOW,
    );
    let out_ = n.flush(NOW);
    let p = publishes(&out_);
    assert_eq!(p[0].0, "spBv1.0/plant/NDATA/cabinet1");
    // Utilisation, demand, transactions: what changed from the start's figures.
    assert_eq!(p[0].1.metrics.len(), 3);
    // A change in the fifth decimal of a share is no news.
    let g = crate::model::BusFigures {
        transactions: 11,
        utilisation: 0.250_04,
        ..f
    };
    n.update(&Update::Figures { bus: 0, figures: g }, NOW + 1);
    let out_ = n.flush(NOW + 1);
    let p = publishes(&out_);
    assert_eq!(p[0].1.metrics.len(), 1);
    assert_eq!(
        value::get(&p[0].1.metrics[0], DataType::UInt64).unwrap(),
        Number::Int(11)
    );
}

#[test]
fn state_payloads() {
    assert_eq!(
        parse_state(br#"{"online":true,"timestamp":1668114759262}"#),
        Some((true, 1_668_114_759_262))
    );
    assert_eq!(
        parse_state(br#"{"online":false,"timestamp":0}"#),
        Some((false, 0))
    );
    for bad in [
        &b""[..],
        b"{}",
        br#"{"online":"yes","timestamp":1}"#,
        br#"{"online":true}"#,
        b"\xff",
    ] {
        assert_eq!(parse_state(bad), None);
    }
}

#[test]
fn bdseq_is_kept_across_restarts_and_wraps() {
    let dir = std::env::temp_dir().join(format!("drivebus-bdseq-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = BdSeqStore::new(Some(dir.join("state")), "plant", "cabinet1");
    assert_eq!(s.next().get(), 0);
    s.save(0).unwrap();
    assert_eq!(s.next().get(), 1);
    s.save(255).unwrap();
    assert_eq!(s.next().get(), 0);
    std::fs::write(s.path().unwrap(), "banana").unwrap();
    assert_eq!(s.next().get(), 0);
    // An unwritable place is an error the task logs, not a panic.
    let blocked = BdSeqStore::new(Some(std::path::PathBuf::from("/proc/drivebus")), "g", "n");
    assert!(blocked.save(1).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn config_refuses_what_sparkplug_cannot_carry() {
    let base = |sp: &str, drives: &str| {
        format!(
            "[gateway]\nname = \"gw1\"\nbroker = \"mqtt://h\"\n{sp}\n\
             [[bus]]\nname = \"a\"\nprotocol = \"movilink\"\nsimulate = true\n\
             [[bus.drive]]\nname = \"conv\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P000\"\nperiod = \"1s\"\n\
             [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
             [[bus.drive]]\nname = \"{drives}\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P000\"\nperiod = \"1s\"\n"
        )
    };
    let ok = Plant::parse(
        &base(
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"",
            "pump",
        ),
        "t",
    )
    .unwrap();
    let sp = ok.sparkplug.clone().unwrap();
    assert!(sp.json);
    assert_eq!(sp.client_id, "drivebus-gw1-spb");
    assert!(ok.publishes_json());
    let only = Plant::parse(
        &base(
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"\njson = false",
            "pump",
        ),
        "t",
    )
    .unwrap();
    assert!(!only.publishes_json());
    for (sp, drives, says) in [
        (
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"",
            "conv",
            "unique in the node",
        ),
        (
            "[sparkplug]\ngroup_id = \"a/b\"\nedge_node_id = \"n\"",
            "pump",
            "group_id",
        ),
        (
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n+\"",
            "pump",
            "edge_node_id",
        ),
        (
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"\nprimary_host_id = \"#\"",
            "pump",
            "primary_host_id",
        ),
        (
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"\nclient_id = \"drivebus-gw1\"",
            "pump",
            "JSON connection's",
        ),
        ("[sparkplug]\ngroup_id = \"g\"", "pump", "edge_node_id"),
        (
            "[sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"\nbogus = 1",
            "pump",
            "bogus",
        ),
    ] {
        let e = Plant::parse(&base(sp, drives), "t")
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{sp}: {e}");
    }
    let off = "[gateway]\nname = \"gw1\"\nbroker = \"off\"\n[ui]\nlisten = \"127.0.0.1:0\"\n\
               [sparkplug]\ngroup_id = \"g\"\nedge_node_id = \"n\"\n\
               [[bus]]\nname = \"a\"\nprotocol = \"movilink\"\nsimulate = true\n\
               [[bus.drive]]\nname = \"conv\"\naddress = 1\n\
               [[bus.drive.param]]\nparam = \"P000\"\nperiod = \"1s\"\n";
    assert!(
        Plant::parse(off, "t")
            .unwrap_err()
            .to_string()
            .contains("needs a broker")
    );
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    /// A command metric: a name the drive has (or not), an alias (or not), any datatype code,
    /// any value field.
    fn command_metric() -> impl Strategy<Value = Metric> {
        let names = prop::sample::select(vec![
            Some("ramp"),
            Some("mode"),
            Some("ramp/Write Result"),
            Some("Status/State"),
            Some("Node Control/Rebirth"),
            Some("nothing"),
            None,
        ]);
        let value = prop_oneof![
            Just(None),
            any::<u32>().prop_map(|v| Some(sparkplug_b::metric::Value::IntValue(v))),
            any::<u64>().prop_map(|v| Some(sparkplug_b::metric::Value::LongValue(v))),
            any::<f32>().prop_map(|v| Some(sparkplug_b::metric::Value::FloatValue(v))),
            any::<f64>().prop_map(|v| Some(sparkplug_b::metric::Value::DoubleValue(v))),
            any::<bool>().prop_map(|v| Some(sparkplug_b::metric::Value::BooleanValue(v))),
            ".{0,12}".prop_map(|v| Some(sparkplug_b::metric::Value::StringValue(v))),
        ];
        (
            names,
            prop::option::of(0u64..40),
            prop::option::of(0u32..40),
            prop::option::of(any::<bool>()),
            value,
        )
            .prop_map(|(name, alias, datatype, is_null, value)| Metric {
                name: name.map(str::to_owned),
                alias,
                datatype,
                is_null,
                value,
                ..Metric::default()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Any bytes on a command topic: no panic, and nothing written unless they decode.
        #[test]
        fn any_bytes_on_a_command_topic_are_taken_or_refused(
            bytes in prop::collection::vec(any::<u8>(), 0..200),
            retained in any::<bool>(),
            device in any::<bool>(),
        ) {
            let mut n = node("");
            born(&mut n, 0);
            let topic = if device {
                "spBv1.0/plant/DCMD/cabinet1/conv"
            } else {
                "spBv1.0/plant/NCMD/cabinet1"
            };
            let out = n.incoming(topic, &bytes, retained, NOW);
            let writes = out.iter().filter(|o| matches!(o, Out::Write { .. })).count();
            if retained || sparkplug_b::decode(&bytes).is_err() {
                prop_assert_eq!(writes, 0);
            }
        }

        /// Any well-formed command: a write only of the writable point, with a value its
        /// datatype carries; everything else refused or ignored.
        #[test]
        fn a_write_comes_only_from_a_valid_command_of_the_writable_point(
            metrics in prop::collection::vec(command_metric(), 0..6),
            age in 0u64..30_000,
        ) {
            let mut n = node("");
            born(&mut n, 0);
            let ramp = n.catalogue().devices[0].points[0].clone();
            let payload = dcmd(metrics.clone(), Some(NOW - age));
            let out = n.incoming("spBv1.0/plant/DCMD/cabinet1/conv", &payload, false, NOW);
            for o in &out {
                if let Out::Write { device, point, value, max_age } = o {
                    prop_assert_eq!((*device, *point), (0, 0));
                    prop_assert!(age <= 10_000, "a stale command was written");
                    prop_assert!(*max_age <= Duration::from_secs(10));
                    // It came from a metric naming ramp with its datatype (or none) and a value.
                    let from = metrics.iter().find(|m| {
                        let named = match (&m.name, m.alias) {
                            (Some(name), _) => name == "ramp",
                            (None, Some(a)) => a == ramp.alias,
                            (None, None) => false,
                        };
                        named
                            && m.datatype.is_none_or(|d| d == ramp.datatype as u32)
                            && m.is_null != Some(true)
                            && value::get(m, ramp.datatype).is_ok()
                    });
                    prop_assert!(from.is_some(), "{value:?} from {metrics:?}");
                }
            }
        }
    }
}

/// The example config's commented `[sparkplug]` block, uncommented, is a valid table with what
/// its comments say; the example's drive names are unique, as Sparkplug needs.
#[test]
fn the_example_configs_sparkplug_block_runs_uncommented() {
    let mut out = String::new();
    let mut inside = false;
    for line in crate::EXAMPLE_CONFIG.lines() {
        if line == "# [sparkplug]" {
            inside = true;
        } else if inside && !line.starts_with("# ") {
            inside = false;
        }
        let line = match line.strip_prefix("# ") {
            Some(rest) if inside => rest,
            _ => line,
        };
        out.push_str(line);
        out.push('\n');
    }
    assert!(
        out.contains("\n[sparkplug]\n"),
        "no [sparkplug] block in the example"
    );
    let plant = Plant::parse(&out, "example").unwrap();
    let sp = plant.sparkplug.unwrap();
    assert_eq!(
        (sp.group_id.as_str(), sp.edge_node_id.as_str()),
        ("plant-1", "cabinet-1")
    );
    assert_eq!(sp.primary_host_id.as_deref(), Some("scada"));
    assert!(sp.json);
    assert_eq!(sp.client_id, "drivebus-cabinet-1-spb");
    // As shipped (commented out): no Sparkplug.
    assert!(
        Plant::parse(crate::EXAMPLE_CONFIG, "example")
            .unwrap()
            .sparkplug
            .is_none()
    );
}

/// `--check` says what the node will publish.
#[test]
fn the_check_report_names_the_edge_node() {
    let (text, verdict) = crate::families::check_report(&plant("primary_host_id = \"scada\"\n"));
    verdict.unwrap();
    let last = text.lines().last().unwrap();
    // Node: bdSeq, rebirth, six per bus; conv: 2 status + ramp, its result, mode; pump: 2 + speed.
    let n = Node::new(&plant(""), &plant("").sparkplug.unwrap());
    assert_eq!(n.catalogue().node.len(), 8);
    assert_eq!(
        last,
        "sparkplug: edge node spBv1.0/plant/…/cabinet1, 2 device(s), 16 metrics, waits for \
         primary host \"scada\", beside the JSON topics"
    );
}

/// Issue 22, item 2: a reload on the same connection sends DDEATH for a device that went and
/// then every birth again (NBIRTH seq 0 with the same bdSeq, a DBIRTH per device with the new
/// catalogue's aliases), with the values of the drives whose bus runs on.
#[test]
fn a_reload_kills_the_devices_that_went_and_is_born_again_with_the_values_it_had() {
    let one = plant("");
    let sp = one.sparkplug.clone().unwrap();
    let mut n = Node::new(&one, &sp);
    born(&mut n, 3);
    n.update(&value_update(0, 0, 2500, NOW), BORN);
    n.flush(BORN);
    // A second bus in front of the first, which runs on unchanged (its index becomes 1); the
    // new bus's drive `fan` is new; none went.
    let text = "[gateway]\nname = \"gw1\"\nbroker = \"mqtt://127.0.0.1:1883\"\nmetrics = \"off\"\n\
         max_set_age = \"10s\"\n\
         [sparkplug]\ngroup_id = \"plant\"\nedge_node_id = \"cabinet1\"\n\
         [[bus]]\nname = \"line0\"\nprotocol = \"modbus-rtu\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"fan\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"241\"\nname = \"frequency\"\nperiod = \"1s\"\n\
         [[bus]]\nname = \"line1\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"conv\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"1s\"\nwritable = true\n\
         [[bus.drive.param]]\nparam = \"P700\"\nname = \"mode\"\nperiod = \"1s\"\n";
    let two = Plant::parse(text, "test").unwrap();
    let r = crate::model::Reconfig {
        generation: 2,
        plant: std::sync::Arc::new(two.clone()),
        // line1 stays but lost its drive `pump`: it is a changed bus, restarted.
        kept: vec![None],
        sets: Vec::new(),
        asks: Vec::new(),
        json: std::sync::Mutex::new(None),
        sparkplug: std::sync::Mutex::new(None),
    };
    let out = n.reconfigure(&r, two.sparkplug.as_ref().unwrap(), BORN + 5);
    let p = publishes(&out);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/DDEATH/cabinet1/conv",
            "spBv1.0/plant/DDEATH/cabinet1/pump",
        ]
    );
    // Born again once the restarted and the new drives have answered.
    assert!(n.flush(BORN + 6).is_empty(), "not before they answer");
    let at = |bus: usize, drive: usize, point: usize, raw: i64| Update::Value {
        bus,
        drive,
        point,
        raw,
        at: UNIX_EPOCH + Duration::from_millis(BORN + 7),
    };
    for (bus, drive, points) in [(0, 0, 1), (1, 0, 2)] {
        n.update(
            &Update::Status {
                bus,
                drive,
                status: DriveStatus::Online,
                at: SystemTime::now(),
            },
            BORN + 7,
        );
        for point in 0..points {
            n.update(&at(bus, drive, point, 2500), BORN + 7);
        }
    }
    let mut out = out;
    out.extend(n.flush(BORN + 8));
    let p = publishes(&out);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/DDEATH/cabinet1/conv",
            "spBv1.0/plant/DDEATH/cabinet1/pump",
            "spBv1.0/plant/NBIRTH/cabinet1",
            "spBv1.0/plant/DBIRTH/cabinet1/fan",
            "spBv1.0/plant/DBIRTH/cabinet1/conv",
        ]
    );
    // The DDEATHs carry the next seq of the old session; the rebirth starts at 0 with the
    // connection's bdSeq.
    let nbirth = &p[2].1;
    assert_eq!(nbirth.seq, Some(0));
    assert_eq!(
        value::get(metric(nbirth, "bdSeq"), DataType::Int64).unwrap(),
        Number::Int(3),
        "{nbirth:?}"
    );
    assert_eq!(n.phase(), Phase::Born);

    // Now the same bus runs on (kept): its drive's value is in its DBIRTH, no DDEATH.
    let three = two.clone();
    let r = crate::model::Reconfig {
        generation: 3,
        plant: std::sync::Arc::new(three.clone()),
        kept: vec![Some(0), Some(1)],
        sets: Vec::new(),
        asks: Vec::new(),
        json: std::sync::Mutex::new(None),
        sparkplug: std::sync::Mutex::new(None),
    };
    n.update(
        &Update::Value {
            bus: 1,
            drive: 0,
            point: 0,
            raw: 3000,
            at: UNIX_EPOCH + Duration::from_millis(NOW),
        },
        BORN + 6,
    );
    let out = n.reconfigure(&r, three.sparkplug.as_ref().unwrap(), BORN + 7);
    let p = publishes(&out);
    let topics: Vec<&str> = p.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/plant/NBIRTH/cabinet1",
            "spBv1.0/plant/DBIRTH/cabinet1/fan",
            "spBv1.0/plant/DBIRTH/cabinet1/conv",
        ]
    );
    let conv = &p[2].1;
    assert_eq!(
        value::get(metric(conv, "ramp"), DataType::Double).unwrap(),
        Number::Float(3.0),
        "{conv:?}"
    );
}
