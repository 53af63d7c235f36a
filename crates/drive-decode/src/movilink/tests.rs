//! Splitting and explaining MOVILINK captures.

use super::*;
use crate::input::parse_text;

/// A read request of P070 (index 8301) to address 1, with its correct BCC.
const READ_8301: [u8; 12] = [
    0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x6D, 0x00, 0x00, 0x00, 0x00, 0xF9,
];
/// Its response: 60 001 553, BCC correct.
const ANSWER_8301: [u8; 12] = [
    0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x6D, 0x03, 0x93, 0x8D, 0x11, 0xEA,
];

fn kinds(items: &[Item]) -> Vec<(usize, usize, bool)> {
    items
        .iter()
        .map(|i| match i {
            Item::Telegram(e) => (e.offset, e.len, e.error.is_none()),
            Item::Unrecognised { offset, bytes, .. } => (*offset, bytes.len(), false),
        })
        .collect()
}

#[test]
fn a_stream_splits_into_telegrams_and_resynchronises() {
    // Noise, a request, noise, its answer, a truncated request at the end.
    let bytes = [
        &[0x55, 0xAA][..],
        &READ_8301,
        &[0xFF],
        &ANSWER_8301,
        &READ_8301[..5],
    ]
    .concat();
    let items = split(&Capture {
        bytes,
        lines: Vec::new(),
    });
    assert_eq!(
        kinds(&items),
        [
            (0, 2, false),
            (2, 12, true),
            (14, 1, false),
            (15, 12, true),
            (27, 5, false)
        ]
    );
    let Some(Item::Telegram(answer)) = items.get(3) else {
        panic!("{items:?}")
    };
    assert_eq!(answer.address, Some(1));
    assert_eq!(answer.index, Some(8301));
    assert_eq!(answer.raw, Some(60_001_553));
    assert_eq!(answer.service, Some("read"));
    // An unknown PDU type after a start character is skipped to the next start character.
    let items = split(&Capture {
        bytes: [&[0x02, 0x01, 0x07, 0x00][..], &READ_8301].concat(),
        lines: Vec::new(),
    });
    assert_eq!(kinds(&items), [(0, 4, false), (4, 12, true)]);
}

#[test]
fn lines_bound_broken_telegrams_but_not_wrapped_ones() {
    // Line 1 is cut short; line 2 is whole: the cut one does not eat line 2.
    let text = "02 01 86 31 00\n02 01 86 31 00 20 6D 00 00 00 00 F9\n";
    let items = split(&parse_text(text, "t").unwrap());
    assert_eq!(kinds(&items), [(0, 5, false), (5, 12, true)]);
    // A dump wrapped at 8 bytes a line: the check character proves the telegram whole.
    let text = "02 01 86 31 00 20 6D 00\n00 00 00 F9\n";
    let items = split(&parse_text(text, "t").unwrap());
    assert_eq!(kinds(&items), [(0, 12, true)]);
}

#[test]
fn splitting_never_panics() {
    // Every short prefix of every start, plus pseudo-random streams.
    let mut seed: u32 = 0x1234_5678;
    for round in 0..2000 {
        let len = round % 40;
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                match (seed >> 16) % 5 {
                    0 => SD1,
                    1 => SD2,
                    _ => (seed >> 8) as u8,
                }
            })
            .collect();
        let lines = (0..len).map(|i| 1 + i / 7).collect();
        let capture = Capture { bytes, lines };
        let items = split(&capture);
        let covered: usize = items
            .iter()
            .map(|i| match i {
                Item::Telegram(e) => e.len,
                Item::Unrecognised { bytes, .. } => bytes.len(),
            })
            .sum();
        assert_eq!(covered, capture.bytes.len(), "{:02X?}", capture.bytes);
    }
}

/// Bild 20 of the manual (ch. 4.2): a cyclic request with 3 process data words to drive 1,
/// through the decoder a front end calls: SD1 02, ADR 01, TYP 05 (3PD cyclic), PO1 0006
/// (control word 1: enable), PO2 3A98 (speed setpoint), PO3 01F4, BCC 57.
#[test]
fn manual_bild_20_three_process_data_words_decoded() {
    let capture = Capture::from_bytes(vec![
        0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57,
    ]);
    let decoded = decode(&capture);
    assert_eq!((decoded.telegrams(), decoded.invalid()), (1, 0));
    let t = &decoded.entries[0].telegram;
    assert_eq!(t.process_data, [0x0006, 0x3A98, 0x01F4]);
    assert_eq!(t.kind.as_deref(), Some("3PD cyclic"));
    let v = t.to_json();
    assert_eq!(
        (&v["direction"], &v["address"], &v["pdu_type"], &v["valid"]),
        (
            &serde_json::json!("request"),
            &serde_json::json!(1),
            &serde_json::json!("0x05"),
            &serde_json::json!(true)
        )
    );
    let text = &decoded.entries[0].text;
    assert!(
        text.starts_with("request telegram at offset 0, 10 bytes: valid\n"),
        "{text}"
    );
    assert!(
        text.contains("  BCC         block check character: correct"),
        "{text}"
    );
    assert!(
        text.contains("speed setpoint by default (P871): 3000 1/min"),
        "{text}"
    );
}
