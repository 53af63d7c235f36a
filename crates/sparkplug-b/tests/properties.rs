//! Property tests: the decoder on any bytes, values through encode and decode, sequence
//! numbers, topics.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use proptest::prelude::*;
use sparkplug_b::seq::Seq;
use sparkplug_b::topic::{self, Level, MessageType, Topic, TopicError};
use sparkplug_b::value::{self, Number, Value, ValueError};
use sparkplug_b::{DataType, DecodeError, Metric, Payload, decode, encode_into};

/// The datatypes `value::set` and `value::get` handle, and a few they refuse.
fn datatype() -> impl Strategy<Value = DataType> {
    (0i32..=34).prop_map(|c| DataType::try_from(c).unwrap())
}

/// Any value, with the edges of every integer datatype more likely than chance makes them.
fn any_value() -> impl Strategy<Value = OwnedValue> {
    let edges: Vec<i64> = vec![
        0,
        -1,
        i8::MIN.into(),
        i8::MAX.into(),
        u8::MAX.into(),
        i16::MIN.into(),
        i16::MAX.into(),
        u16::MAX.into(),
        i32::MIN.into(),
        i32::MAX.into(),
        u32::MAX.into(),
        i64::MIN,
        i64::MAX,
    ];
    prop_oneof![
        any::<i64>().prop_map(OwnedValue::Int),
        prop::sample::select(edges.clone()).prop_map(OwnedValue::Int),
        prop::sample::select(edges).prop_map(|e| OwnedValue::Int(e.wrapping_add(1))),
        any::<u64>().prop_map(OwnedValue::UInt),
        prop::sample::select(vec![0, u64::from(u32::MAX), 1 << 32, 1 << 63, u64::MAX])
            .prop_map(OwnedValue::UInt),
        any::<f32>().prop_map(OwnedValue::Float),
        any::<f64>().prop_map(OwnedValue::Double),
        any::<f32>().prop_map(|f| OwnedValue::Double(f.into())),
        any::<bool>().prop_map(OwnedValue::Bool),
        ".{0,20}".prop_map(OwnedValue::Text),
    ]
}

#[derive(Clone, Debug)]
enum OwnedValue {
    Int(i64),
    UInt(u64),
    Float(f32),
    Double(f64),
    Bool(bool),
    Text(String),
}

impl OwnedValue {
    fn as_value(&self) -> Value<'_> {
        match self {
            OwnedValue::Int(i) => Value::Int(*i),
            OwnedValue::UInt(u) => Value::UInt(*u),
            OwnedValue::Float(f) => Value::Float(*f),
            OwnedValue::Double(d) => Value::Double(*d),
            OwnedValue::Bool(b) => Value::Bool(*b),
            OwnedValue::Text(s) => Value::Text(s),
        }
    }
}

/// Floats compared by bits, so that NaN is itself.
fn same(a: &Number, b: &Number) -> bool {
    match (a, b) {
        (Number::Float(x), Number::Float(y)) => {
            x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan())
        }
        _ => a == b,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Any bytes decode or are refused with a typed error; never a panic. What decodes
    /// re-encodes to bytes that decode to the same payload.
    #[test]
    fn decode_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        match decode(&bytes) {
            Ok(p) => {
                let mut once = Vec::new();
                encode_into(&p, &mut once);
                let again = decode(&once).unwrap();
                let mut twice = Vec::new();
                encode_into(&again, &mut twice);
                prop_assert_eq!(once, twice);
                for m in &p.metrics {
                    for code in 0..=34 {
                        let _ = value::get(m, DataType::try_from(code).unwrap());
                    }
                }
            }
            Err(DecodeError::Protobuf(e)) => prop_assert!(!e.to_string().is_empty()),
            Err(e) => prop_assert!(false, "{e} for {} bytes", bytes.len()),
        }
    }

    /// Bytes that look like a payload of metrics (field 2 repeated, each a few bytes of any
    /// content) reach further into the metric decoder than random bytes do.
    #[test]
    fn decode_never_panics_on_metric_shaped_bytes(
        metrics in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..40), 0..8)
    ) {
        let mut bytes = Vec::new();
        for m in &metrics {
            bytes.push(0x12);
            bytes.push(m.len() as u8);
            bytes.extend(m);
        }
        if let Ok(p) = decode(&bytes) {
            prop_assert_eq!(p.metrics.len(), metrics.len());
            for m in &p.metrics {
                for code in 0..=34 {
                    let _ = value::get(m, DataType::try_from(code).unwrap());
                }
            }
        }
    }

    /// Any value that `set` accepts comes back from `get` after encode and decode, with its
    /// datatype; what `set` refuses leaves the metric as it was.
    #[test]
    fn accepted_values_round_trip(datatype in datatype(), value in any_value(), alias in any::<u64>()) {
        let mut metric = Metric { alias: Some(alias), ..Metric::default() };
        let before = metric.clone();
        match value::set(&mut metric, datatype, value.as_value()) {
            Err(_) => prop_assert_eq!(metric, before),
            Ok(()) => {
                let mut buf = Vec::new();
                encode_into(&Payload { metrics: vec![metric], ..Payload::default() }, &mut buf);
                let p = decode(&buf).unwrap();
                let m = &p.metrics[0];
                prop_assert_eq!(value::metric_type(m), Ok(Some(datatype)));
                prop_assert_eq!(m.alias, Some(alias));
                let got = value::get(m, datatype);
                let want = match value {
                    OwnedValue::Int(i) => Number::Int(i),
                    OwnedValue::UInt(u) => match i64::try_from(u) {
                        Ok(i) => Number::Int(i),
                        // Sent as it is, but a Number holds no more than i64::MAX.
                        Err(_) => {
                            prop_assert_eq!(got, Err(ValueError::TooLarge { datatype, value: u }));
                            return Ok(());
                        }
                    },
                    OwnedValue::Float(f) => Number::Float(f.into()),
                    OwnedValue::Double(d) => Number::Float(d),
                    OwnedValue::Bool(b) => Number::Bool(b),
                    OwnedValue::Text(s) => Number::Text(s),
                };
                let got = got.unwrap();
                prop_assert!(same(&got, &want), "{:?}: got {:?}, want {:?}", datatype, got, want);
            }
        }
    }

    /// A value `set` refuses for an integer datatype is one outside its range (or not an
    /// integer): every integer in range is accepted.
    #[test]
    fn integers_in_range_are_accepted(min in any::<i64>(), max in any::<i64>(), pick in any::<u64>()) {
        let datatype = value::integer_type(min, max);
        let (lo, hi) = (min.min(max), min.max(max));
        let span = (i128::from(hi) - i128::from(lo)) as u128 + 1;
        let n = (i128::from(lo) + (u128::from(pick) % span) as i128) as i64;
        let mut metric = Metric::default();
        prop_assert_eq!(value::set(&mut metric, datatype, Value::Int(n)), Ok(()));
        prop_assert_eq!(value::get(&metric, datatype), Ok(Number::Int(n)));
        prop_assert_eq!(value::set(&mut metric, datatype, Value::Int(lo)), Ok(()));
        prop_assert_eq!(value::set(&mut metric, datatype, Value::Int(hi)), Ok(()));
    }

    /// `take` gives v, v+1, …, 255, 0, 1, … from any start.
    #[test]
    fn seq_take_wraps(start in any::<u8>(), n in 0usize..600) {
        let mut seq = Seq::new(start);
        for i in 0..n {
            prop_assert_eq!(seq.take(), ((usize::from(start) + i) % 256) as u64);
        }
    }

    /// A topic of valid ids formats and parses back to itself.
    #[test]
    fn topics_round_trip(
        group in "[^/+#\u{0}]{1,12}",
        node in "[^/+#\u{0}]{1,12}",
        device in "[^/+#\u{0}]{1,12}",
        kind in prop::sample::select(MessageType::ALL.to_vec()),
    ) {
        let t = match kind {
            MessageType::State => Topic::state(&node),
            k if k.has_device() => Topic::device(&group, k, &node, &device),
            k => Topic::node(&group, k, &node),
        };
        prop_assert_eq!(t.check(), Ok(()));
        prop_assert_eq!(topic::check_id(&group), Ok(()));
        let text = t.to_string();
        // A group named STATE under a device-less type would read as a STATE topic only with
        // three levels; these have four or five.
        prop_assert_eq!(Topic::parse(&text), Ok(t));
    }

    /// An id with `/`, `+`, `#` or U+0000 is refused, by `check_id` and in any topic level.
    #[test]
    fn ids_with_reserved_characters_are_refused(
        head in "[a-z ]{0,5}",
        tail in "[a-z ]{0,5}",
        bad in prop::sample::select(vec!['/', '+', '#', '\0']),
    ) {
        let id = format!("{head}{bad}{tail}");
        let err = topic::check_id(&id).unwrap_err();
        prop_assert_eq!(err, TopicError::Reserved { level: Level::Id, found: bad });
        // In a topic: '/' adds a level, the others are refused where they stand.
        for topic in [
            format!("spBv1.0/{id}/NDATA/n"),
            format!("spBv1.0/g/NDATA/{id}"),
            format!("spBv1.0/g/DDATA/n/{id}"),
        ] {
            prop_assert!(Topic::parse(&topic).is_err(), "{} parsed", topic);
        }
        prop_assert!(Topic::device("g", MessageType::DData, "n", &id).check().is_err());
    }
}

#[test]
fn seq_take_300_times_yields_0_to_255_then_0_again() {
    let mut seq = Seq::default();
    let taken: Vec<u64> = (0..300).map(|_| seq.take()).collect();
    let want: Vec<u64> = (0..=255).chain(0..44).collect();
    assert_eq!(taken, want);
}

#[test]
fn empty_ids_are_refused() {
    assert_eq!(topic::check_id(""), Err(TopicError::Empty(Level::Id)));
    for t in [
        "spBv1.0//NDATA/n",
        "spBv1.0/g/NDATA/",
        "spBv1.0/g/DDATA/n/",
        "spBv1.0/STATE/",
    ] {
        assert!(matches!(Topic::parse(t), Err(TopicError::Empty(_))), "{t}");
    }
}
