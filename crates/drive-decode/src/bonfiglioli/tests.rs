//! The manual's frames (ch. 8) explained.

use super::*;
use serde_json::json;

fn rtu(hex: &str) -> Vec<Frame> {
    split_rtu(&Capture {
        bytes: parse_hex(&[hex.to_owned()]).unwrap(),
        lines: Vec::new(),
    })
}

#[test]
fn manual_8_1_1_read_372_in_data_set_2_and_its_answer() {
    // Request: 01 address, 03 FC, 21 74 data set 2 | 372, 00 01 count, CE 2C CRC; answer:
    // 01 address, 03 FC, 02 byte count, 05 6E = 1390, 3A F8 CRC. One stream, split by CRC.
    let f = rtu("01 03 21 74 00 01 CE 2C 01 03 02 05 6E 3A F8");
    assert_eq!(f.len(), 2);
    assert_eq!((f[0].data_set, f[0].parameter), (Some(2), Some(372)));
    assert_eq!(f[0].direction, Some("request"));
    assert_eq!((f[1].parameter, f[1].raw), (Some(372), Some(1390)));
    assert!(f.iter().all(|x| x.error.is_none()));
}

#[test]
fn manual_8_1_exceptions_and_writes() {
    // 8.1.2 example 2: 03 86 04 E2 63: exception 4 to FC 6.
    let f = rtu("03 86 04 E2 63");
    assert_eq!((f[0].function, f[0].exception), (Some(6), Some(4)));
    // 8.1.2 example 1: write 376 in data set 4 = 15 (1.5 kW).
    let f = rtu("03 06 41 78 00 0F 5C 09");
    assert_eq!(
        (f[0].data_set, f[0].parameter, f[0].raw),
        (Some(4), Some(376), Some(15))
    );
    assert!(f[0].fields.iter().any(|x| x.text.contains("1.5 kW")));
    // 8.1.3 example 1: read 481 (FC 100) → 1000 = 10.00 Hz.
    let f = rtu("01 64 01 E1 81 DF 01 64 00 00 03 E8 70 BC");
    assert_eq!((f[1].parameter, f[1].raw), (Some(481), Some(1000)));
    assert!(
        f[1].fields.iter().any(|x| x.text.contains("10.00 Hz")),
        "{:?}",
        f[1].fields
    );
}

#[test]
fn a_wrong_crc_names_the_expected_one() {
    let f = rtu("01 03 21 74 00 01 2C CE");
    assert_eq!(f.len(), 1);
    let e = f[0].error.as_deref().unwrap();
    assert!(e.contains("CE 2C"), "{e}");
}

#[test]
fn manual_8_2_ascii_frames() {
    // 8.2.1 example 1, request and answer, as text.
    let chars = ascii_input(":010321740001 66\n:01030205 6E 87\n", false)
        .unwrap()
        .bytes;
    let f = split_ascii(&chars);
    assert_eq!(f.len(), 2);
    assert_eq!((f[0].data_set, f[0].parameter), (Some(2), Some(372)));
    assert_eq!(f[1].raw, Some(1390));
    assert!(f.iter().all(|x| x.error.is_none()), "{f:?}");
    // 8.2.3 example 2 as the manual's ASC row prints it (erratum E4): LRC 19 belongs to
    // exception code 02; as the Hex row, code 04 with LRC 17 is right.
    let f = split_ascii(&ascii_input(":01E40217\r\n", false).unwrap().bytes);
    assert!(f[0].error.as_deref().unwrap().contains("19"), "{f:?}");
    let f = split_ascii(
        &ascii_input("3A 30 31 45 34 30 34 31 37 0D 0A", false)
            .unwrap()
            .bytes,
    );
    assert_eq!((f[0].exception, f[0].error.as_deref()), (Some(4), None));
}

/// Ch. 8.1.1 (read 372 in data set 2 and its answer) and 8.2.1 (the same in ASCII) through the
/// decoders a front end calls: the answer is scaled by the request's parameter.
#[test]
fn manual_8_1_1_and_8_2_1_decoded() {
    let rtu = decode_rtu(&Capture::from_bytes(
        parse_hex(&["01 03 21 74 00 01 CE 2C 01 03 02 05 6E 3A F8"]).unwrap(),
    ));
    assert_eq!((rtu.telegrams(), rtu.invalid(), rtu.skipped()), (2, 0, 0));
    let answer = rtu.entries[1].telegram.to_json();
    assert_eq!(
        (&answer["label"], &answer["raw"], &answer["line"]),
        (&json!("372 data set 2"), &json!(1390), &json!(null))
    );
    assert!(
        rtu.entries[1]
            .text
            .starts_with("response frame at offset 8, 7 bytes: valid\n"),
        "{}",
        rtu.entries[1].text
    );
    let ascii = decode_ascii(&ascii_input(":01032174000166\n:010302056E87\n", false).unwrap());
    assert_eq!((ascii.telegrams(), ascii.invalid()), (2, 0));
    let request = ascii.entries[0].telegram.to_json();
    assert_eq!(
        (&request["chars"], &request["line"]),
        (&json!(":01032174000166\\r\\n"), &json!(1))
    );
    assert_eq!(
        ascii_input("# :01 in a comment\n", false),
        Err(AsciiError::NoFrames)
    );
    assert_eq!(ascii_input("0103", true), Err(AsciiError::NoColon));
}
