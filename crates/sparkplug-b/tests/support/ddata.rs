//! The DDATA message of the size test and the benchmark: a drive's changed points by alias,
//! each with the timestamp of its bus read, alternately Int16 and Double values.

use sparkplug_b::value::{self, Value};
use sparkplug_b::{DataType, Metric, Payload};

/// A millisecond timestamp of 2026 (six varint bytes, as every current one).
pub const NOW: u64 = 1_780_000_000_000;

/// A DDATA payload with `n` metrics: aliases 1.., even ones Int16 (-300, -100, 100, …, the
/// negative ones sign-extended to five varint bytes), odd ones Double (49.87, 50.87, …).
pub fn ddata(n: usize, seq: u64) -> Payload {
    let metrics = (0..n)
        .map(|i| {
            let mut m = Metric {
                alias: Some(i as u64 + 1),
                timestamp: Some(NOW - 20 * i as u64),
                ..Metric::default()
            };
            let set = if i % 2 == 0 {
                value::set(&mut m, DataType::Int16, Value::Int(i as i64 * 100 - 300))
            } else {
                value::set(&mut m, DataType::Double, Value::Double(49.87 + i as f64))
            };
            set.expect("the values fit their datatypes");
            // DATA messages leave the datatype out (the birth gave it).
            m.datatype = None;
            m
        })
        .collect();
    Payload {
        timestamp: Some(NOW),
        metrics,
        seq: Some(seq),
        ..Payload::default()
    }
}
