//! The manual's telegrams (BU 0255 sections 4.3 and 5.1) carried in CTT2 messages and USS
//! telegrams, explained.

use super::*;
use crate::input::parse_hex;
use serde_json::Value;

fn capture(hex: &str) -> Capture {
    Capture {
        bytes: parse_hex(&[hex.to_owned()]).unwrap(),
        lines: Vec::new(),
    }
}

fn ctt2(hex: &str) -> Vec<Message> {
    split_ctt2(&capture(hex))
}

fn uss(hex: &str) -> Vec<Message> {
    split_uss(
        &capture(hex),
        UssLayout {
            pkw: 4,
            pzd: None,
            drive_first: false,
            names: SettingNames::default(),
        },
    )
}

fn meaning<'a>(m: &'a Message, field: &str) -> &'a str {
    m.fields
        .iter()
        .find(|f| f.name == field)
        .map_or("", |f| f.text.as_str())
}

#[test]
fn manual_5_1_3_p102_in_set_3_as_a_ctt2_write_and_its_read_back() {
    let m = ctt2(concat!(
        // NORD write request: 19 code, 47 (2Fh) PKW without address, 8 bytes,
        // PKE 70 66 (AK 7, PNU 66h = P102), IND 02 00 (set 3, erratum E4), PWE 00 00 03 E8.
        "13 2F 08 70 66 02 00 00 00 03 E8 ",
        // 83 (53h): write answer OK (says nothing about the order).
        "53 ",
        // NORD read request: 18 code, index 47, 8 bytes.
        "12 2F 08 ",
        // 82 (52h) read answer OK: PKE 40 66 (AK 4, P102), IND 02 00, PWE 00 00 03 E8.
        "52 40 66 02 00 00 00 03 E8"
    ));
    assert_eq!(m.len(), 4, "{m:?}");
    assert!(m.iter().all(|x| x.error.is_none()), "{m:?}");
    let w = &m[0];
    assert_eq!(
        (w.direction, w.code, w.index),
        ("request", Some(19), Some(47))
    );
    assert_eq!(
        (w.ak, w.parameter, w.ind, w.raw),
        (Some(7), Some(0x66), Some(0x0200), Some(1000))
    );
    assert!(meaning(w, "IND").contains("parameter set 3"), "{w:?}");
    assert!(meaning(w, "PWE2").contains("10.00 s"), "{w:?}");
    assert!(
        m[1].notes
            .iter()
            .any(|n| n.contains("read the PKW channel back"))
    );
    let a = &m[3];
    assert_eq!(
        (a.direction, a.ak, a.raw, a.value),
        ("response", Some(4), Some(1000), Some(10.0))
    );
    assert!(meaning(a, "PKE").contains("AK 4"), "{a:?}");
}

#[test]
fn the_ind_bytes_as_5_1_3_prints_them_are_named_as_erratum_e4() {
    // IND 00 02: set 1 with bits 0-7 = 02h.
    let m = ctt2("13 2F 08 70 66 00 02 00 00 03 E8");
    assert_eq!(m[0].ind, Some(0x0002));
    assert!(
        meaning(&m[0], "IND").contains("parameter set 1"),
        "{:?}",
        m[0]
    );
    assert!(m[0].notes.iter().any(|n| n.contains("E4")), "{:?}", m[0]);
}

#[test]
fn manual_5_1_4_and_5_1_5_read_p701_and_write_p102_set_2() {
    // 5.1.4: PKE 12 BD = AK 1, PNU 2BDh = P701 (erratum E5), IND 00 00, PWE 0.
    let m = ctt2("13 2F 08 12 BD 00 00 00 00 00 00");
    assert_eq!((m[0].ak, m[0].parameter), (Some(1), Some(701)));
    assert!(
        meaning(&m[0], "PKE").contains("P701 last fault"),
        "{:?}",
        m[0]
    );
    // 5.1.5: PKE 20 66 = AK 2 P102, IND 01 00 = parameter set 2 (erratum E6), 2.5 s = FAh.
    let m = ctt2("13 2F 08 20 66 01 00 00 00 00 FA");
    assert_eq!(
        (m[0].ak, m[0].raw, m[0].value),
        (Some(2), Some(250), Some(2.5))
    );
    assert!(meaning(&m[0], "IND").contains("parameter set 2"));
}

#[test]
fn manual_5_1_1_and_5_1_2_process_data_through_write_read() {
    let m = ctt2(concat!(
        // 29 (1Dh) write/read, index 3 PZD, read 5, write 5: address 1, STW 04 7E, SW1 00 00.
        "1D 03 05 05 01 04 7E 00 00 ",
        // 93 (5Dh): address 1, ZSW 0B 31 (ready to switch on), IW1 00 00.
        "5D 01 0B 31 00 00 ",
        // 5.1.2: STW 04 7F (enable operation), SW1 20 00 = 50 %.
        "1D 03 05 05 01 04 7F 20 00 ",
        // ZSW 0B 37 (operation enabled), IW1 20 00 = 50 %.
        "5D 01 0B 37 20 00"
    ));
    assert_eq!(m.len(), 4, "{m:?}");
    assert!(m.iter().all(|x| x.error.is_none()), "{m:?}");
    assert_eq!(m[0].words, [0x047E, 0x0000]);
    assert!(meaning(&m[0], "STW").contains("shutdown"), "{:?}", m[0]);
    assert!(
        meaning(&m[1], "ZSW").contains("C ready to switch on"),
        "{:?}",
        m[1]
    );
    assert!(meaning(&m[2], "SW1").contains("50 %"), "{:?}", m[2]);
    assert!(
        meaning(&m[3], "ZSW").contains("E operation enabled"),
        "{:?}",
        m[3]
    );
    assert!(meaning(&m[3], "IW1").contains("50 %"));
}

#[test]
fn manual_4_3_1_objects_and_4_3_5_errors() {
    // Diagnosis object: 16 (10h), index 1, 3 bytes → 80 (50h): 0 no fault, 0, 45 °C.
    let m = ctt2("10 01 03 50 00 00 2D");
    assert_eq!(m.len(), 2);
    assert!(meaning(&m[1], "temperature").contains("45 °C"));
    // ID object, first two bytes: manufacturer 1, 137.
    let m = ctt2("10 00 02 50 01 89");
    assert!(meaning(&m[1], "ID byte 2").starts_with("137"), "{:?}", m[1]);
    // 144 (90h) error 4: busy.
    let m = ctt2("90 04");
    assert!(meaning(&m[0], "error code").contains("4"), "{:?}", m[0]);
    // The misprinted 177 (B1h) is read as 157 and said so (erratum E3).
    let m = ctt2("B1 02");
    assert!(m[0].notes.iter().any(|n| n.contains("E3")), "{:?}", m[0]);
    // A write longer than the channel: the double slave answers error 2.
    let m = ctt2("13 2F 09 70 66 02 00 00 00 03 E8 00");
    assert!(
        m[0].error.as_deref().unwrap_or("").contains("147"),
        "{:?}",
        m[0]
    );
    // An index the drive does not have.
    let m = ctt2("12 05 08");
    assert!(m[0].error.is_some());
    // A stray byte is reported and skipped.
    let m = ctt2("FF 10 01 03");
    assert_eq!((m[0].direction, m[1].code), ("unrecognised", Some(16)));
}

#[test]
fn uss_telegrams_carry_the_same_data_with_stx_lge_adr_and_bcc() {
    let m = uss(concat!(
        // Master: STX, LGE 0Eh (ADR + 8 PKW + 4 PZD + BCC = 14), ADR 01,
        // PKE 70 66, IND 02 00, PWE 00 00 03 E8 (5.1.3), STW 04 7E, SW1 00 00, BCC 88.
        "02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88 ",
        // Drive: STX, LGE, ADR 01, PKE 40 66 (AK 4), IND, PWE, ZSW 0B 31, IW1 00 00, BCC F8.
        "02 0E 01 40 66 02 00 00 00 03 E8 0B 31 00 00 F8"
    ));
    assert_eq!(m.len(), 2, "{m:?}");
    assert!(m.iter().all(|x| x.error.is_none()), "{m:?}");
    assert_eq!((m[0].direction, m[1].direction), ("master", "drive"));
    assert_eq!((m[0].address, m[0].raw), (Some(1), Some(1000)));
    assert_eq!(m[1].value, Some(10.0));
    assert!(meaning(&m[1], "ZSW").contains("ready to switch on"));
    // A wrong BCC names the right one.
    let m = uss("02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 00");
    assert!(
        m[0].error.as_deref().unwrap().contains("expected 88"),
        "{:?}",
        m[0]
    );
    // --pzd checks the layout: 2 PZD words where 4 are set.
    let m = split_uss(
        &capture("02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88"),
        UssLayout {
            pkw: 4,
            pzd: Some(4),
            drive_first: false,
            names: SettingNames::default(),
        },
    );
    assert!(
        m[0].error.as_deref().unwrap().contains("LGE should be 18"),
        "{:?}",
        m[0]
    );
}

#[test]
fn json_has_the_parameter_and_the_value() {
    let m = ctt2("13 2F 08 70 66 02 00 00 00 03 E8");
    let v = telegram(&m[0], "ctt2", None).to_json();
    // The keys of `read --json` (issue 18: one shape for every decoder).
    assert_eq!(
        (
            &v["index"],
            &v["label"],
            &v["selector"],
            &v["raw"],
            &v["value"],
            &v["unit"]
        ),
        (
            &json!(102),
            &json!("P102 set 3"),
            &json!({"set": 3, "ind": "0x0200"}),
            &json!(1000),
            &json!(10.0),
            &json!("s")
        )
    );
    assert_eq!(
        (&v["code"], &v["ctt2_index"], &v["ak"]),
        (&json!(19), &json!(47), &json!(7))
    );
    // A refusal is no value: AK 7's error number is `pwe_error`, in words `refusal`.
    let m = ctt2("12 2F 08 52 70 66 02 00 00 00 00 01");
    let v = telegram(&m[1], "ctt2", None).to_json();
    assert_eq!((&v["raw"], &v["pwe_error"]), (&Value::Null, &json!(1)));
    assert!(
        v["refusal"].as_str().unwrap().contains("cannot be changed"),
        "{v}"
    );
    // Bytes that start no message are `skipped`.
    let m = ctt2("FF 10 01 03");
    assert_eq!(telegram(&m[0], "ctt2", None).to_json()["type"], "skipped");
}

/// 5.1.3 (P102 := 10.00 s in parameter set 3) as a CTT2 write and as a USS telegram through the
/// decoders a front end calls; a layout error names a setting only as the front end does.
#[test]
fn manual_5_1_3_decoded_in_both_transports() {
    let ctt2 = decode_ctt2(&capture("13 2F 08 70 66 02 00 00 00 03 E8 53"));
    assert_eq!((ctt2.telegrams(), ctt2.invalid()), (2, 0));
    let write = ctt2.entries[0].telegram.to_json();
    assert_eq!(
        (&write["label"], &write["raw"], &write["value"]),
        (&json!("P102 set 3"), &json!(1000), &json!(10.0))
    );
    assert!(
        ctt2.entries[0].text.contains("  PKE  "),
        "{}",
        ctt2.entries[0].text
    );
    let telegram = "02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88";
    let layout = UssLayout {
        pkw: 4,
        pzd: Some(3),
        drive_first: false,
        names: SettingNames::default(),
    };
    let plain = decode_uss(&capture(telegram), layout);
    let error = plain.entries[0].telegram.error.clone().unwrap();
    assert_eq!(
        error,
        "2 PZD words where the layout has 3: LGE should be 16"
    );
    let named = decode_uss(
        &capture(telegram),
        UssLayout {
            names: SettingNames {
                pkw: Some("--pkw"),
                pzd: Some("--pzd"),
            },
            ..layout
        },
    );
    assert_eq!(
        named.entries[0].telegram.error.as_deref(),
        Some("2 PZD words where the layout has 3 (--pzd): LGE should be 16")
    );
}
