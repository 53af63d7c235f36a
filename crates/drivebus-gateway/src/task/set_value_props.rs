use proptest::prelude::*;
use serde_json::Value;

use super::super::config::{Plant, Point};
use super::super::model::SetValue;
use super::raw_value;

fn points() -> Vec<Point> {
    let plant = Plant::parse(super::super::families::EXAMPLE_CONFIG, "example").unwrap();
    plant
        .buses
        .into_iter()
        .flat_map(|b| b.drives)
        .flat_map(|d| d.points)
        .collect()
}

fn json_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<i64>().prop_map(Value::from),
        any::<u64>().prop_map(Value::from),
        any::<f64>()
            .prop_map(|f| serde_json::Number::from_f64(f).map_or(Value::Null, Value::Number)),
        ".{0,300}".prop_map(Value::from),
        "[-+]?[0-9]{0,40}(\\.[0-9]{0,40})?(e[-+]?[0-9]{1,4})?".prop_map(Value::from),
        Just(Value::Null),
        any::<bool>().prop_map(Value::from),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    /// Any bytes on a `…/set` topic: a `SetMessage` or a `bad_request`, never a panic.
    #[test]
    fn any_set_payload_parses_or_is_refused(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        // Anything that is not a JSON object is refused, with a message saying what to send.
        match crate::mqtt::payload::parse_set(&bytes) {
            Ok(_) => prop_assert!(
                serde_json::from_slice::<Value>(&bytes).is_ok_and(|v| v.is_object())
            ),
            Err(bad) => prop_assert!(bad.message.contains("send") || bad.message.len() > 10, "{}", bad.message),
        }
    }

    /// JSON-shaped payloads with every key the parser knows and some it does not.
    #[test]
    fn json_set_payloads_parse_or_are_refused(
        v in json_value(), ts in any::<i64>(), id in json_value(), extra in "[a-z]{0,6}",
    ) {
        let mut m = serde_json::Map::new();
        m.insert("value".into(), v.clone());
        m.insert("ts".into(), Value::from(ts));
        m.insert("id".into(), id);
        if !extra.is_empty() {
            m.insert(extra.clone(), v);
        }
        let known = extra.is_empty() || ["value", "ts", "id"].contains(&extra.as_str());
        let parsed = crate::mqtt::payload::parse_set(Value::Object(m).to_string().as_bytes());
        // An unknown key is refused (a misspelt "raw" must not pass as a value).
        if !known {
            prop_assert!(parsed.is_err());
        }
    }

    #[test]
    fn no_set_value_panics_or_leaves_the_bus_width(v in json_value(), raw in any::<i64>(), which in any::<usize>()) {
        let points = points();
        let p = &points[which % points.len()];
        for value in [SetValue::Value(v.clone()), SetValue::Raw(raw)] {
            if let Ok(r) = raw_value(p, &value) {
                let meta = p.target.param.unwrap();
                let (lo, hi) = meta.wire_range();
                prop_assert!((lo..=hi).contains(&r), "{} {value:?} -> {r} outside {lo}..={hi}", p.name);
            }
        }
    }
}
