//! Fuzz the Sparkplug B payload decoder: `sparkplug_b::decode` on any bytes; on success every
//! metric (and every template member) is read with `value::get` for every datatype and its
//! properties with `props`, and the payload re-encodes to bytes that decode to a payload that
//! encodes to the same bytes again.
//!
//! Input: the raw payload bytes (an NCMD or DCMD as it arrives). Seeds: the specification's
//! example payloads and a few built ones (`fuzz/seeds/README.md`).
//!
//! `cargo fuzz run sparkplug_decode` (from the worktree root or `fuzz/`), or `scripts/fuzz`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sparkplug_b::payload::metric;
use sparkplug_b::{DataType, Metric, PropertySet, decode, encode_into, node, props, value};

fn read_properties(set: &PropertySet) {
    for key in &set.keys {
        let _ = props::get(set, key);
        let _ = props::text(set, key);
        let _ = props::int(set, key);
        let _ = props::bool(set, key);
    }
    let _ = props::quality(set);
}

fn read_metric(m: &Metric, depth: u32) {
    for code in 0..=34 {
        let datatype = DataType::try_from(code).unwrap();
        if let Err(e) = value::get(m, datatype) {
            let _ = e.to_string();
        }
    }
    let _ = value::metric_type(m);
    let _ = node::is_rebirth(m);
    if let Some(set) = &m.properties {
        read_properties(set);
    }
    if let (Some(metric::Value::TemplateValue(t)), true) = (&m.value, depth < 8) {
        for member in &t.metrics {
            read_metric(member, depth + 1);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let payload = match decode(data) {
        Ok(p) => p,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    for m in &payload.metrics {
        read_metric(m, 0);
    }
    let mut once = Vec::new();
    encode_into(&payload, &mut once);
    // Encoding is deterministic and decode(encode(p)) is p: compared as bytes, since a NaN
    // float value is not equal to itself.
    let again = decode(&once).unwrap();
    let mut twice = Vec::new();
    encode_into(&again, &mut twice);
    assert_eq!(once, twice);
    assert_eq!(again.metrics.len(), payload.metrics.len());
});
