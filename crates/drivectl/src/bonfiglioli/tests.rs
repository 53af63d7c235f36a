use super::*;
use crate::tool::client::{ClientError, DeviceErrorKind};

/// A driver error of an access with `width` as the command line's client error.
fn client_error(width: Width, e: DriverError) -> ClientError {
    drive_client::bonfiglioli::client_error(width, e, &Cli)
}
use bonfiglioli_modbus::frame::ExceptionCode;

#[test]
fn widths_come_from_the_table_or_the_user() {
    let t372 = resolve("372", 2).unwrap();
    assert_eq!(t372.sub, 2);
    assert_eq!(table_width(&t372, None), Some(Width::Word));
    let t481 = resolve("P481", 0).unwrap();
    assert_eq!(table_width(&t481, None), Some(Width::Long));
    // 415 has no data type in the manual: refused without --word/--long.
    let t415 = resolve("415", 0).unwrap();
    assert_eq!(table_width(&t415, None), None);
    let e = check_width_known(&t415, None).unwrap_err().to_string();
    assert!(e.contains("--word") && e.contains("--long"), "{e}");
    assert_eq!(table_width(&t415, Some(Width::Long)), Some(Width::Long));
}

#[test]
fn raw_values_keep_their_sign() {
    let t241 = resolve("241", 0).unwrap();
    assert_eq!(raw_of(&t241, Width::Long, 0xFFFF_FFFF), -1);
    let t372 = resolve("372", 0).unwrap();
    assert_eq!(raw_of(&t372, Width::Word, 0xFFFF), 65535);
    assert_eq!(data_of(Width::Word, 65536), None);
    assert_eq!(data_of(Width::Word, -1), Some(0xFFFF));
    assert_eq!(data_of(Width::Long, -1), Some(0xFFFF_FFFF));
    assert_eq!(data_of(Width::Long, 1 << 33), None);
}

#[test]
fn bad_values_are_refused_before_the_port_opens() {
    let how = ValueText::default();
    let a = Access::default();
    // 376 1.5 kW → raw 15 (ch. 8.1.2).
    assert_eq!(write_value("376", "1.5", a, &how).unwrap().raw, 15);
    assert!(write_value("9999", "1", a, &how).is_err());
    assert!(write_value("415", "1", a, &how).is_err());
    let raw = ValueText { raw: true, ..how };
    assert!(write_value("372", "--5", a, &raw).is_err());
    // 372 is uInt: 70000 does not fit.
    assert!(write_value("372", "70000", a, &raw).is_err());
    let word = Access { word: true, ..a };
    assert!(write_value("415", "70000", word, &raw).is_err());
    assert_eq!(write_value("415", "300", word, &raw).unwrap().raw, 300);
}

#[test]
fn refusals_name_the_cause_and_the_way_out() {
    let e = |exception, vabus| DriverError::Device {
        exception: ExceptionCode(exception),
        vabus,
    };
    match client_error(Width::Word, e(4, Some(9))) {
        ClientError::Device(d) => {
            assert_eq!(d.kind, DeviceErrorKind::Refused);
            assert!(d.message.contains("--dataset 1"), "{}", d.message);
        }
        other => panic!("{other:?}"),
    }
    match client_error(Width::Word, e(4, Some(11))) {
        ClientError::Device(d) => assert_eq!(d.kind, DeviceErrorKind::Absent),
        other => panic!("{other:?}"),
    }
    for (x, v) in [(2, None), (4, Some(14)), (4, Some(10))] {
        match client_error(Width::Word, e(x, v)) {
            ClientError::Device(d) => assert!(
                d.message.contains("is not 16-bit: try --long"),
                "{}",
                d.message
            ),
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn issue18_412_is_never_restored() {
    // `control` leaves 412 = 1 in RAM; a backup reads it; a restore would store it in the
    // EEPROM of all four data sets.
    assert!(NOT_RESTORED.contains(&param::LOCAL_REMOTE));
}

#[test]
fn issue18_a_data_set_the_parameter_has_not_is_refused() {
    let refused = |key: &str, ds: u8| {
        check_data_set(&resolve(key, ds).unwrap())
            .err()
            .map(|e| e.to_string())
    };
    let e = refused("260", 2).unwrap();
    assert!(e.starts_with("260 Current fault exists once"), "{e}");
    assert!(!e.contains("--volatile"), "read-only: {e}");
    assert!(refused("1376", 3).unwrap().contains("--volatile"));
    assert!(
        refused("484", 5)
            .unwrap()
            .contains("always addressed as data set 0")
    );
    // Data sets 0 and 5 of a parameter that exists once; any of a data-set parameter; any
    // number outside the table.
    for (key, ds) in [("260", 0), ("1376", 5), ("372", 4), ("372", 9), ("1500", 3)] {
        assert_eq!(refused(key, ds), None, "{key} {ds}");
    }
}

#[test]
fn issue18_a_link_setting_says_what_changes_and_when() {
    let a = Address::new(1).unwrap();
    let t10 = resolve("10", 0).unwrap();
    assert_eq!(
        link_change_text(&t10, 3, a, Some(3), None),
        "10 already holds 3 (9600 baud): nothing changes for the link"
    );
    let e = link_change_text(&t10, 4, a, Some(3), None);
    assert!(
        e.contains("19200 baud after the next reset (34 = 123)")
            && e.contains("until then 3 (9600 baud)")
            && e.ends_with("then use --baud 19200"),
        "{e}"
    );
    let t1375 = resolve("1375", 0).unwrap();
    assert!(link_change_text(&t1375, 2, a, None, None).ends_with("then use --parity none"));
    let t395 = resolve("395", 0).unwrap();
    assert!(link_change_text(&t395, 3, a, Some(2), None).ends_with("use --mode ascii"));
    assert!(link_change_text(&t395, 0, a, Some(2), None).contains("KP500"));
    let t1376 = resolve("1376", 0).unwrap();
    assert!(link_change_text(&t1376, 5, a, Some(1), None).contains("use --addr 5"));
    // With the command that reaches the drive then: that command, to paste.
    let e = link_change_text(
        &t1376,
        5,
        a,
        Some(1),
        Some("drivectl bonfiglioli --addr 5 status"),
    );
    assert!(
        e.ends_with(": `drivectl bonfiglioli --addr 5 status`"),
        "{e}"
    );
}

#[test]
fn link_settings_are_the_tables_bus_parameters() {
    for p in LINK_SETTINGS {
        assert!(bonfiglioli::by_index(*p).is_some(), "{p}");
    }
    assert!(NOT_RESTORED.contains(&param::ADDRESS));
}
