//! The example payloads of the Sparkplug 3.0 specification (ch. 6, "Payload Representation on
//! Host Applications": NBIRTH, DBIRTH, NDATA, DDATA, NCMD, DCMD), built with this crate's API,
//! encoded, decoded and checked field by field; and the fuzz seeds made from them.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use sparkplug_b::node::{self, BD_SEQ, NEXT_SERVER, REBIRTH, REBOOT};
use sparkplug_b::props::{PropertySetBuilder, Quality};
use sparkplug_b::seq::Seq;
use sparkplug_b::topic::{MessageType, Topic};
use sparkplug_b::value::{self, Number, Value};
use sparkplug_b::{DataType, Metric, Payload, decode, encode_into};
use std::path::PathBuf;

/// The timestamp of every example: 1486144502122 ms (2017-02-03 17:55:02.122 UTC).
const T: u64 = 1_486_144_502_122;

fn metric(name: &str, datatype: DataType, value: Value<'_>) -> Metric {
    let mut m = Metric {
        name: Some(name.into()),
        timestamp: Some(T),
        ..Metric::default()
    };
    value::set(&mut m, datatype, value).unwrap();
    m
}

fn payload(seq: Option<u64>, metrics: Vec<Metric>) -> Payload {
    Payload {
        timestamp: Some(T),
        metrics,
        seq,
        ..Payload::default()
    }
}

fn round_trip(p: &Payload) -> (Vec<u8>, Payload) {
    let mut buf = Vec::new();
    encode_into(p, &mut buf);
    let back = decode(&buf).unwrap();
    assert_eq!(&back, p);
    (buf, back)
}

/// (name, datatype, value) of a decoded metric, its value read for its own datatype.
fn fields(m: &Metric) -> (&str, DataType, Number) {
    let datatype = value::metric_type(m).unwrap().unwrap();
    (
        m.name.as_deref().unwrap(),
        datatype,
        value::get(m, datatype).unwrap(),
    )
}

fn nbirth() -> Payload {
    let mut seq = Seq::new(0);
    let mut bd_seq = node::bd_seq_metric(Seq::new(0), Some(T));
    bd_seq.timestamp = Some(T);
    payload(
        Some(seq.take()),
        vec![
            bd_seq,
            metric(REBOOT, DataType::Boolean, Value::Bool(false)),
            metric(REBIRTH, DataType::Boolean, Value::Bool(false)),
            metric(NEXT_SERVER, DataType::Boolean, Value::Bool(false)),
            metric("Node Control/Scan Rate", DataType::Int64, Value::Int(3000)),
            metric(
                "Properties/Hardware Make",
                DataType::String,
                Value::Text("Raspberry Pi"),
            ),
            metric(
                "Properties/Hardware Model",
                DataType::String,
                Value::Text("Pi 3 Model B"),
            ),
            metric("Properties/OS", DataType::String, Value::Text("Raspbian")),
            metric(
                "Properties/OS Version",
                DataType::String,
                Value::Text("Jessie with PIXEL/11.01.2017"),
            ),
            metric("Supply Voltage", DataType::Float, Value::Float(12.1)),
        ],
    )
}

fn dbirth() -> Payload {
    let mut names: Vec<String> = ["A", "B", "C", "D", "Button"]
        .iter()
        .map(|n| format!("Inputs/{n}"))
        .collect();
    names.extend(["E", "F", "G", "H"].iter().map(|n| format!("Outputs/{n}")));
    names.extend(
        ["Green", "Red", "Yellow"]
            .iter()
            .map(|n| format!("Outputs/LEDs/{n}")),
    );
    names.push("Outputs/Buzzer".into());
    let mut metrics: Vec<Metric> = names
        .iter()
        .map(|n| metric(n, DataType::Boolean, Value::Bool(false)))
        .collect();
    metrics.push(metric(
        "Properties/Hardware Make",
        DataType::String,
        Value::Text("Pibrella"),
    ));
    payload(Some(1), metrics)
}

fn ndata() -> Payload {
    payload(
        Some(2),
        vec![metric(
            "Supply Voltage",
            DataType::Float,
            Value::Float(12.3),
        )],
    )
}

fn ddata() -> Payload {
    payload(
        Some(0),
        vec![
            metric("Inputs/A", DataType::Boolean, Value::Bool(true)),
            metric("Inputs/C", DataType::Boolean, Value::Bool(true)),
        ],
    )
}

fn ncmd_rebirth() -> Payload {
    payload(
        None,
        vec![metric(REBIRTH, DataType::Boolean, Value::Bool(true))],
    )
}

fn dcmd() -> Payload {
    payload(
        None,
        vec![
            metric("Outputs/LEDs/Green", DataType::Boolean, Value::Bool(true)),
            metric("Outputs/LEDs/Yellow", DataType::Boolean, Value::Bool(true)),
        ],
    )
}

#[test]
fn nbirth_example() {
    // Topic: spBv1.0/Sparkplug B Devices/NBIRTH/Raspberry Pi.
    let topic = Topic::node("Sparkplug B Devices", MessageType::NBirth, "Raspberry Pi");
    assert_eq!(
        topic.to_string(),
        "spBv1.0/Sparkplug B Devices/NBIRTH/Raspberry Pi"
    );
    let (_, p) = round_trip(&nbirth());
    assert_eq!((p.timestamp, p.seq), (Some(T), Some(0)));
    let got: Vec<_> = p.metrics.iter().map(fields).collect();
    assert_eq!(got[0], (BD_SEQ, DataType::Int64, Number::Int(0)));
    assert_eq!(
        got[1],
        (
            "Node Control/Reboot",
            DataType::Boolean,
            Number::Bool(false)
        )
    );
    assert_eq!(
        got[2],
        (
            "Node Control/Rebirth",
            DataType::Boolean,
            Number::Bool(false)
        )
    );
    assert_eq!(
        got[3],
        (
            "Node Control/Next Server",
            DataType::Boolean,
            Number::Bool(false)
        )
    );
    assert_eq!(
        got[4],
        ("Node Control/Scan Rate", DataType::Int64, Number::Int(3000))
    );
    assert_eq!(
        got[8],
        (
            "Properties/OS Version",
            DataType::String,
            Number::Text("Jessie with PIXEL/11.01.2017".into())
        )
    );
    // 12.1 as a Float is the nearest f32, read back exactly.
    assert_eq!(
        got[9],
        (
            "Supply Voltage",
            DataType::Float,
            Number::Float(f64::from(12.1f32))
        )
    );
    assert!(p.metrics.iter().all(|m| m.timestamp == Some(T)));
    // The rebirth metric has no alias (ch. 5: it must not, when aliases are used).
    assert_eq!(p.metrics[2].alias, None);
}

#[test]
fn dbirth_example() {
    let (_, p) = round_trip(&dbirth());
    assert_eq!(p.seq, Some(1));
    assert_eq!(p.metrics.len(), 14);
    let got: Vec<_> = p.metrics.iter().map(fields).collect();
    assert_eq!(got[0], ("Inputs/A", DataType::Boolean, Number::Bool(false)));
    assert_eq!(
        got[4],
        ("Inputs/Button", DataType::Boolean, Number::Bool(false))
    );
    assert_eq!(
        got[11],
        (
            "Outputs/LEDs/Yellow",
            DataType::Boolean,
            Number::Bool(false)
        )
    );
    assert_eq!(
        got[12],
        ("Outputs/Buzzer", DataType::Boolean, Number::Bool(false))
    );
    assert_eq!(
        got[13],
        (
            "Properties/Hardware Make",
            DataType::String,
            Number::Text("Pibrella".into())
        )
    );
}

#[test]
fn ndata_and_ddata_examples() {
    let (_, p) = round_trip(&ndata());
    assert_eq!(p.seq, Some(2));
    assert_eq!(
        fields(&p.metrics[0]),
        (
            "Supply Voltage",
            DataType::Float,
            Number::Float(f64::from(12.3f32))
        )
    );
    let (_, p) = round_trip(&ddata());
    assert_eq!(p.seq, Some(0));
    let got: Vec<_> = p.metrics.iter().map(fields).collect();
    assert_eq!(
        got,
        [
            ("Inputs/A", DataType::Boolean, Number::Bool(true)),
            ("Inputs/C", DataType::Boolean, Number::Bool(true)),
        ]
    );
}

#[test]
fn ncmd_and_dcmd_examples() {
    let (_, p) = round_trip(&ncmd_rebirth());
    // Commands carry no sequence number.
    assert_eq!(p.seq, None);
    assert!(node::is_rebirth(&p.metrics[0]));
    let (_, p) = round_trip(&dcmd());
    assert_eq!(p.seq, None);
    let got: Vec<_> = p.metrics.iter().map(fields).collect();
    assert_eq!(
        got,
        [
            ("Outputs/LEDs/Green", DataType::Boolean, Number::Bool(true)),
            ("Outputs/LEDs/Yellow", DataType::Boolean, Number::Bool(true)),
        ]
    );
    assert!(!node::is_rebirth(&p.metrics[0]));
}

/// Bytes written by hand from the protobuf encoding rules: the NDATA example, field by field.
#[test]
fn ndata_example_bytes() {
    let mut buf = Vec::new();
    encode_into(&ndata(), &mut buf);
    let ts = [0xEA, 0xF2, 0xF5, 0xA8, 0xA0, 0x2B]; // 1486144502122 as a varint
    let mut want = vec![0x08]; // field 1 (timestamp), varint
    want.extend(ts);
    want.extend([0x12, 0x1E]); // field 2 (metrics), 30 bytes
    want.extend([0x0A, 0x0E]); //   field 1 (name), 14 bytes
    want.extend(b"Supply Voltage");
    want.push(0x18); //   field 3 (timestamp), varint
    want.extend(ts);
    want.extend([0x20, 0x09]); //   field 4 (datatype) = 9, Float
    want.push(0x65); //   field 12 (float_value), 32-bit
    want.extend(12.3f32.to_le_bytes());
    want.extend([0x18, 0x02]); // field 3 (seq) = 2
    assert_eq!(buf, want);
}

/// A command as a host sends it to a drive: by alias, without datatype, negative Int16.
fn dcmd_by_alias() -> Payload {
    let mut m = Metric {
        alias: Some(12),
        timestamp: Some(T),
        ..Metric::default()
    };
    value::set(&mut m, DataType::Int16, Value::Int(-1500)).unwrap();
    m.datatype = None;
    payload(None, vec![m])
}

/// A DBIRTH of a drive point as the gateway sends one: name, alias, datatype from the
/// parameter's range, and its description as properties.
fn dbirth_drive_point() -> Payload {
    let mut m = metric(
        "P130 Ramp up/Rampe t11 auf RECHTS",
        value::integer_type(0, 65535),
        Value::UInt(2000),
    );
    m.alias = Some(130);
    m.properties = Some(
        PropertySetBuilder::default()
            .text("engUnit", "ms")
            .int("number", 130)
            .int("index", 8470)
            .uint("engLow", 0)
            .uint("engHigh", 65535)
            .bool("writable", true)
            .set(
                "names",
                PropertySetBuilder::default()
                    .text("de", "Rampe t11 auf RECHTS")
                    .build(),
            )
            .quality(Quality::Good)
            .build(),
    );
    payload(Some(2), vec![m])
}

#[test]
fn drive_point_birth_round_trips() {
    let (_, p) = round_trip(&dbirth_drive_point());
    let m = &p.metrics[0];
    assert_eq!(fields(m).1, DataType::UInt16);
    let props = m.properties.as_ref().unwrap();
    assert_eq!(sparkplug_b::props::text(props, "engUnit"), Some("ms"));
    assert_eq!(sparkplug_b::props::int(props, "index"), Some(8470));
    assert_eq!(sparkplug_b::props::bool(props, "writable"), Some(true));
    assert_eq!(sparkplug_b::props::quality(props), Some(Quality::Good));
}

/// What goes into `fuzz/seeds/sparkplug_decode/`: each example payload, encoded.
fn seeds() -> Vec<(&'static str, Payload)> {
    vec![
        ("spec_nbirth.bin", nbirth()),
        ("spec_dbirth.bin", dbirth()),
        ("spec_ndata.bin", ndata()),
        ("spec_ddata.bin", ddata()),
        ("spec_ncmd_rebirth.bin", ncmd_rebirth()),
        ("spec_dcmd.bin", dcmd()),
        ("built_ndeath_bdseq_7.bin", node::death(Seq::new(7), None)),
        ("built_dcmd_alias_int16_minus1500.bin", dcmd_by_alias()),
        (
            "built_dbirth_drive_point_properties.bin",
            dbirth_drive_point(),
        ),
    ]
}

/// The committed seeds are these payloads' bytes. `SPARKPLUG_WRITE_SEEDS=1 cargo test -p
/// sparkplug-b --test spec_examples` writes them (once, or after a change here).
#[test]
fn fuzz_seeds_are_the_example_payloads() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds/sparkplug_decode");
    let write = std::env::var_os("SPARKPLUG_WRITE_SEEDS").is_some();
    for (name, p) in seeds() {
        let mut buf = Vec::new();
        encode_into(&p, &mut buf);
        let path = dir.join(name);
        if write {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &buf).unwrap();
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| {
            panic!("{}: {e}; SPARKPLUG_WRITE_SEEDS=1 writes it", path.display())
        });
        assert_eq!(
            committed, buf,
            "{name} differs; SPARKPLUG_WRITE_SEEDS=1 rewrites it"
        );
        assert_eq!(decode(&committed).unwrap(), p);
    }
}
