//! Tests of targets and values.
use super::*;
use crate::text::{parse_decimal, parse_int};

#[test]
fn targets_and_values() {
    let t = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
    assert_eq!((t.index, t.label()), (8470, "P130".to_owned()));
    assert_eq!(t.raw_from_text("1.5", false).unwrap(), 1500);
    assert_eq!(t.raw_from_text("1500", true).unwrap(), 1500);
    let raw = Target::resolve(Family::Movidrive, "9999", 1000..=0xFFFF).unwrap();
    assert!(raw.param.is_none());
    assert!(Target::resolve(Family::Movidrive, "999", 1000..=0xFFFF).is_err());
    assert!(Target::resolve(Family::Movidrive, "P9999", 1000..=0xFFFF).is_err());
    let p870 = Target::resolve(Family::Movidrive, "P870", 1000..=0xFFFF).unwrap();
    assert_eq!(p870.raw_from_text("control word 1", false).unwrap(), 9);
    assert_eq!(parse_int("-0x10"), Some(-16));
    assert_eq!(parse_int("x"), None);
}

#[test]
fn issue7_numbers_are_parsed_strictly() {
    for bad in [
        "--5", "0x-5", "-0x-5", "+5", "", "-", "0x", "5 000", "1e3", "1.0", "٣",
    ] {
        assert_eq!(parse_int(bad), None, "{bad:?}");
    }
    assert_eq!(parse_int(" -5 "), Some(-5));
    assert_eq!(parse_int("0xFFFFFFFF"), Some(0xFFFF_FFFF));
    assert_eq!(parse_int("-9223372036854775808"), Some(i64::MIN));
    assert_eq!(parse_int("9223372036854775808"), None);
    for bad in [
        "--1.5", "1.5.2", "1,5,2", "inf", "NaN", "1e3", ".", "1.", "+1", "1 5", "0x10",
    ] {
        assert_eq!(parse_decimal(bad), None, "{bad:?}");
    }
    assert_eq!(parse_decimal("1,5"), Some(1.5));
    assert_eq!(parse_decimal("-0.25"), Some(-0.25));
    assert_eq!(parse_decimal(".5"), Some(0.5));
    // `--5 --raw` is not +5.
    let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
    assert!(p130.raw_from_text("--5", true).is_err());
    assert_eq!(p130.raw_from_text("1,5", false).unwrap(), 1500);
}

#[test]
fn issue7_selections_take_integers_or_names_and_rounding_is_never_silent() {
    let p700 = Target::resolve(Family::Movidrive, "P700", 1000..=0xFFFF).unwrap();
    let e = p700.raw_from_text("2.5", false).unwrap_err().to_string();
    assert!(
        e.contains("not a value of P700") && e.contains("16 (SERVO)"),
        "{e}"
    );
    let e = p700
        .raw_from_text("servo-ish", false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("it takes one of: 0 ("), "{e}");
    assert_eq!(p700.raw_from_text("16", false).unwrap(), 16);
    assert_eq!(p700.raw_from_text("SERVO", false).unwrap(), 16);
    // 1.25 s lies in P130's 0.1 s steps (1…10 s): refused, named, or rounded when asked.
    let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
    let e = p130.raw_from_text("1.25", false).unwrap_err().to_string();
    assert!(
        e.contains("cannot hold 1.25 exactly") && e.contains("1.30 s (raw 1300)"),
        "{e}"
    );
    let how = ValueText {
        round: true,
        ..ValueText::default()
    };
    assert_eq!(
        p130.value_from_text("1.25", &how).unwrap(),
        Parsed {
            raw: 1300,
            rounded_from: Some(1.25)
        }
    );
    // An address of 0.4 is no address.
    let p810 = Target::resolve(Family::Movidrive, "P810", 1000..=0xFFFF).unwrap();
    assert!(p810.raw_from_text("0.4", false).is_err());
}

#[test]
fn issue7_force_lifts_the_range_of_a_physical_value_but_not_the_width() {
    let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
    assert!(p130.raw_from_text("3000", false).is_err());
    let forced = ValueText {
        force: true,
        ..ValueText::default()
    };
    assert_eq!(
        p130.value_from_text("3000", &forced).unwrap().raw,
        3_000_000
    );
    // Off the steps but on the resolution (1 ms): exact when forced.
    assert_eq!(p130.value_from_text("1.25", &forced).unwrap().raw, 1250);
    let e = p130
        .value_from_text("5000000", &forced)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bus width"), "{e}");
}

#[test]
fn no_value_is_ever_cut() {
    // 2^40 for an unsigned 32-bit parameter, for an index outside the table, and -1 for an
    // unsigned one: refused, whatever else is forced.
    let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
    assert!(p130.check_width(1 << 40).is_err());
    assert!(p130.check_width(-1).is_err());
    p130.check_width(4_294_967_295).unwrap();
    let raw = Target::resolve(Family::Movidrive, "9999", 1000..=0xFFFF).unwrap();
    assert!(raw.check_width(1 << 40).is_err());
    raw.check_width(-1).unwrap();
    raw.check_width(4_294_967_295).unwrap();
    let e = raw.check_width(4_294_967_296).unwrap_err().to_string();
    assert!(e.contains("nothing was sent"), "{e}");
}
