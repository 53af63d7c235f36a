//! SBus frames of the manual (ch. 5) explained.

use super::*;
use serde_json::Value;

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

#[test]
fn manual_5_3_read_of_8318() {
    let e = explain(&frame(523, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
    assert_eq!(e.kind, "parameter request");
    assert_eq!(e.address, Some(1));
    assert_eq!(e.index, Some(8318));
    assert_eq!(
        e.formed.as_deref(),
        Some("8 × SBus address 1 + 512 + 3 = 523")
    );
    assert!(
        e.fields[0].text.contains("answer at once"),
        "{:?}",
        e.fields[0]
    );
    let r = explain(&frame(524, &[0x71, 0, 0x20, 0x7E, 0, 0x0F, 0x42, 0x40]), 0);
    assert_eq!(r.kind, "parameter response");
    assert_eq!(r.raw, Some(1_000_000));
    assert!(r.fields[0].text.contains("after the next SYNC"));
    assert!(r.error.is_none());
}

#[test]
fn process_data_sync_and_errors() {
    let e = explain(&frame(267, &[0, 6, 0x13, 0x88, 0, 0]), 0);
    assert_eq!(e.kind, "process output data (PO)");
    assert_eq!(e.words, [6, 5000, 0]);
    assert!(e.fields[1].text.contains("1000 1/min"), "{:?}", e.fields[1]);
    let s = explain(&frame(0, &[]), 0);
    assert_eq!(s.kind, "SYNC");
    let bad = explain(&frame(267, &[0, 6]), 0);
    assert!(bad.error.as_deref().unwrap().contains("expected 6"));
    let group_read = explain(&frame(8 * 2 + 518, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
    assert!(
        group_read
            .error
            .as_deref()
            .unwrap()
            .contains("write services only")
    );
    let wrong = explain(&frame(523, &[0x3F, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
    assert!(wrong.error.as_deref().unwrap().contains("class 5, code 5"));
}

/// The manual's variable telegram (ch. 5.5) in both byte orders.
#[test]
fn variables_of_the_manual() {
    let (m, _) = variables(&[0x55, 0x66, 0x77, 0x88, 0x11, 0x22, 0x33, 0x44]);
    assert_eq!(split64(m), "DataLow 11223344h, DataHigh 55667788h");
    let (_, i) = variables(&[0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0x66, 0x55]);
    assert_eq!(split64(i), "DataLow 11223344h, DataHigh 55667788h");
    let e = explain(
        &frame(1024, &[0x55, 0x66, 0x77, 0x88, 0x11, 0x22, 0x33, 0x44]),
        0,
    );
    assert_eq!(e.kind, "variable telegram or other protocol");
    assert!(e.fields[0].text.starts_with("MOTOROLA: DataLow 11223344h"));
}

#[test]
fn identifiers_parse_strictly() {
    assert_eq!(
        parse_id("0x10B", false).unwrap(),
        Id::Standard(drive_core::can::StandardId::new(267).unwrap())
    );
    assert_eq!(
        parse_id("10Bh", false).unwrap(),
        parse_id("267", false).unwrap()
    );
    assert!(parse_id("2048", false).is_err());
    assert!(parse_id("4294967296", false).is_err());
    // Past every width: said as too large, not as "not a number" (issue 18).
    let e = parse_id("99999999999999999999", true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("too large") && e.contains("29 bits"), "{e}");
    assert!(parse_id("-1", false).is_err());
    assert!(parse_id("0x1FFFFFFF", true).is_ok());
    assert!(parse_id("0x20000000", true).is_err());
}

/// Ch. 5.3: the read of index 8318 to SBus address 1 (identifier 8 × 1 + 512 + 3 = 523) through
/// the decoder a front end calls, as text and in the common shape.
#[test]
fn manual_5_3_read_request_decoded() {
    let id = parse_id("523", false).unwrap();
    let entry = decode_frame(
        &data_frame(id, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]).unwrap(),
        0,
    );
    let v = entry.telegram.to_json();
    assert_eq!(
        (
            &v["direction"],
            &v["index"],
            &v["raw"],
            &v["id"],
            &v["valid"]
        ),
        (
            &json!("request"),
            &json!(8318),
            &Value::Null,
            &json!(523),
            &json!(true)
        )
    );
    assert!(
        entry
            .text
            .contains("  identifier 523: 8 × SBus address 1 + 512 + 3 = 523\n"),
        "{}",
        entry.text
    );
    assert_eq!(data_frame(id, &[0; 9]), Err(FrameError::TooLong { len: 9 }));
}
