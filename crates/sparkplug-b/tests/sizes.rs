//! Encoded sizes of the gateway's DDATA messages, printed for comparison with the JSON topics
//! (`cargo test -p sparkplug-b --test sizes -- --nocapture`).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "support/ddata.rs"]
mod support;

use sparkplug_b::{decode, encode_into};

#[test]
fn payload_sizes() {
    let mut buf = Vec::new();
    // (metrics, the most bytes the message may take)
    for (n, limit) in [(1, 32), (8, 180), (31, 700)] {
        let payload = support::ddata(n, 17);
        encode_into(&payload, &mut buf);
        println!(
            "DDATA with {n:2} metric(s) (alias, timestamp, value): {:4} bytes, {:.1} per metric",
            buf.len(),
            buf.len() as f64 / n as f64
        );
        assert!(
            buf.len() <= limit,
            "{n} metrics: {} bytes > {limit}",
            buf.len()
        );
        assert_eq!(decode(&buf).unwrap(), payload);
    }
    // One Int16 metric, byte by byte: payload timestamp 7, seq 2, metric 2 + alias 2 +
    // timestamp 7 + int_value 4 (-300 as 0xFED4, Int16's own width: a three-byte varint; a
    // sign-extended 0xFFFF_FED4 would take five).
    encode_into(&support::ddata(1, 17), &mut buf);
    assert_eq!(buf.len(), 7 + 2 + 2 + 2 + 7 + 4);
}
