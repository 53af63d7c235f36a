use super::*;
use crate::tool::fake::{FakeClient, refusal};
use drive_profile::sew::index;
use serde_json::{Value, json};

/// Every read answers the index as value, except: P000 "speed" (8318) is absent, P001
/// "user display" (8501) refuses reading.
fn answers(i: u16) -> std::result::Result<i64, ClientError> {
    match i {
        8318 => Err(refusal(DeviceErrorKind::Absent, "not implemented")),
        8501 => Err(refusal(DeviceErrorKind::Refused, "access denied")),
        i => Ok(i64::from(i)),
    }
}

#[test]
fn absent_parameters_are_skipped_and_refused_ones_make_the_backup_fail_loudly() {
    let dir = std::env::temp_dir().join(format!("drivectl-backup-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("b.json");
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap();
    let r = rt.block_on(backup(
        &mut FakeClient::new(answers),
        &out,
        false,
        true,
        &Interrupt::never(),
    ));
    let err = r.unwrap_err().to_string();
    assert!(err.contains("incomplete"), "{err}");
    assert!(err.contains("P001 (access denied)"), "{err}");
    assert!(!err.contains("P000"), "{err}");
    // The file holds everything else.
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let list = doc["parameters"].as_array().unwrap();
    assert!(list.iter().any(|e| e["index"] == index::RAMP_T11_UP_CW));
    assert!(
        !list
            .iter()
            .any(|e| e["index"] == 8318 || e["index"] == 8501)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

mod load_tests {
    use super::*;
    use crate::movilink::{LINK_SETTINGS, NOT_RESTORED};

    #[test]
    fn commands_and_link_settings_in_a_file_are_not_restored() {
        let dir = std::env::temp_dir().join(format!("drivectl-load-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("b.json");
        let doc = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "parameters": [
                {"index": 8470, "raw": 1200},
                // P804 = 1 would clear the fault memory; P810 would move the drive.
                {"index": 8596, "raw": 1},
                {"index": 8597, "raw": 7},
            ],
        });
        std::fs::write(&file, doc.to_string()).unwrap();
        // Kept aside (drive-client's tests say why each).
        let loaded = load(&file, Family::Movidrive, NOT_RESTORED, LINK_SETTINGS).unwrap();
        let indices: Vec<u16> = loaded.entries.iter().map(|e| e.target.index).collect();
        assert_eq!((indices, loaded.skipped.len()), (vec![8470], 2));
        // A file of another family, and one that names none.
        let err = load(&file, Family::Nord, &[], &[]).unwrap_err().to_string();
        assert!(
            err.ends_with("is a backup of a movidrive drive, not of a nord drive"),
            "{err}"
        );
        // One parameter twice.
        let twice = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "parameters": [
                {"index": 8470, "raw": 1200}, {"index": 8471, "raw": 1}, {"index": 8470, "raw": 1300},
            ],
        });
        std::fs::write(&file, twice.to_string()).unwrap();
        let err = load(&file, Family::Movidrive, &[], &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.ends_with("entry 3: P130 appears twice (entries 1 and 3)"),
            "{err}"
        );
        std::fs::write(&file, doc.to_string()).unwrap();
        let mut doc = doc;
        doc.as_object_mut().unwrap().remove("family");
        std::fs::write(&file, doc.to_string()).unwrap();
        let err = load(&file, Family::Movidrive, &[], &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.ends_with("names no drive family (`family`); it is not a movidrive backup"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

mod restore_tests {
    use super::*;
    use crate::tool::fake::FakeClient;

    /// Every read answers the index as value (writes do not change it).
    fn index_as_value(i: u16) -> std::result::Result<i64, ClientError> {
        Ok(i64::from(i))
    }

    /// A backup file in a fresh directory with P130…P133 (8470…8473) set to 1000 and the
    /// device type `device_type`; the directory is removed by the caller.
    fn file_with(name: &str, device_type: u64) -> (std::path::PathBuf, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("drivectl-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("b.json");
        let doc = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "device_type": device_type, "firmware": 822_609_711,
            "parameters": [
                {"index": 8470, "raw": 1000}, {"index": 8471, "raw": 1000},
                {"index": 8472, "raw": 1000}, {"index": 8473, "raw": 8473},
            ],
        });
        // As Notepad saves it: a byte order mark and CRLF line ends.
        let text = format!("\u{feff}{}", serde_json::to_string_pretty(&doc).unwrap())
            .replace('\n', "\r\n");
        std::fs::write(&file, text).unwrap();
        (dir, file)
    }

    fn drive(device_type: u64) -> FakeClient {
        let mut c = FakeClient::new(index_as_value);
        c.identity.insert("device_type".into(), device_type.into());
        c.identity.insert("firmware".into(), 822_609_711.into());
        c
    }

    fn run(c: &mut FakeClient, file: &Path, opts: RestoreOptions, stop: &Interrupt) -> Result<()> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        // The wear log of these tests lives in their own directory.
        rt.block_on(restore(
            c,
            file,
            RestoreOptions {
                rules: restoring::Options {
                    force: true,
                    ..opts.rules
                },
                ..opts
            },
            true,
            stop,
        ))
    }

    /// The error of a plain restore of `file` onto `c`.
    fn refusal_of(c: &mut FakeClient, file: &Path) -> String {
        run(c, file, RestoreOptions::default(), &Interrupt::never())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn issue7_a_restore_cut_short_by_the_link_says_what_was_written_and_how_to_finish() {
        let (dir, file) = file_with("restore-link", 7);
        let mut c = drive(7);
        c.link_dies_after = Some(1);
        let e = refusal_of(&mut c, &file);
        assert_eq!(c.written.len(), 1);
        assert!(
            e.contains("half restored: 1 of 3 change(s) written (P130)"),
            "{e}"
        );
        assert!(e.contains("2 not written (P131, P132)"), "{e}");
        assert!(
            e.contains("P131 was being written when the link failed"),
            "{e}"
        );
        assert!(e.contains("run the same restore again"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_ctrl_c_during_a_restore_finishes_the_write_in_flight_and_reports() {
        let (dir, file) = file_with("restore-int", 7);
        let stop = Interrupt::never();
        let mut c = drive(7);
        c.interrupt_after = Some((2, stop.clone()));
        let e = run(&mut c, &file, RestoreOptions::default(), &stop).unwrap_err();
        // The exit code a shell reports for the signal.
        assert_eq!(e.exit_code(), 130);
        let e = e.to_string();
        assert_eq!(c.written.len(), 2);
        assert!(
            e.contains("restore stopped (interrupted by Ctrl-C (SIGINT))"),
            "{e}"
        );
        assert!(
            e.contains("2 of 3 change(s) written (P130, P131), 1 not written (P132)"),
            "{e}"
        );
        assert!(!e.contains("may or may not"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_restore_checks_the_device_type_and_dry_run_writes_nothing() {
        let (dir, file) = file_with("restore-type", 7);
        let mut c = drive(8);
        let e = refusal_of(&mut c, &file);
        assert!(
            e.contains("device type 7; this drive is device type 8"),
            "{e}"
        );
        assert!(e.contains("--any-device"), "{e}");
        assert!(c.written.is_empty());
        let any_device = restoring::Options {
            any_device: true,
            ..restoring::Options::default()
        };
        let dry = RestoreOptions {
            dry_run: true,
            rules: any_device,
        };
        run(&mut c, &file, dry, &Interrupt::never()).unwrap();
        assert!(c.written.is_empty());
        // Written, and every value read back differs (this drive ignores writes): a mismatch
        // names what was expected.
        let any = RestoreOptions {
            rules: any_device,
            ..RestoreOptions::default()
        };
        let e = run(&mut c, &file, any, &Interrupt::never())
            .unwrap_err()
            .to_string();
        assert_eq!(c.written.len(), 3);
        assert!(e.contains("3 value(s) differ"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A file with P130…P133 and the identity fields `identity`, in a fresh directory.
    fn file_identified(name: &str, identity: Value) -> (std::path::PathBuf, std::path::PathBuf) {
        let (dir, file) = file_with(name, 7);
        let text = std::fs::read_to_string(&file).unwrap();
        let mut doc: Value = serde_json::from_str(text.trim_start_matches('\u{feff}')).unwrap();
        for (k, v) in identity.as_object().unwrap() {
            doc[k] = v.clone();
        }
        std::fs::write(&file, doc.to_string()).unwrap();
        (dir, file)
    }

    #[test]
    fn issue18_every_identity_field_both_sides_know_must_match_but_the_address() {
        let (dir, file) =
            file_identified("restore-variant", json!({"variant": "act", "address": 1}));
        let opts = RestoreOptions::default();
        // Another variant: refused, named, with the way out.
        let mut c = drive(7);
        c.identity.insert("variant".into(), "acu".into());
        c.identity.insert("address".into(), 2.into());
        let e = run(&mut c, &file, opts, &Interrupt::never()).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let e = e.to_string();
        assert!(
            e.contains("saved from a drive of variant act; this drive is variant acu"),
            "{e}"
        );
        assert!(e.contains("--any-device"), "{e}");
        assert!(c.written.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue18_a_file_without_parameters_says_so() {
        let (dir, file) = file_with("restore-empty", 7);
        let doc = json!({"format": FORMAT, "version": VERSION, "family": "movidrive",
                         "parameters": []});
        std::fs::write(&file, doc.to_string()).unwrap();
        let e = check_file(&file, Family::Movidrive, &[]).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(
            e.to_string()
                .ends_with("holds no parameters; there is nothing to restore"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_a_value_wider_than_the_parameter_in_a_file_is_refused_before_any_write() {
        let (dir, file) = file_with("restore-wide", 7);
        let text = std::fs::read_to_string(&file).unwrap();
        std::fs::write(&file, text.replacen("1000", "1099511627776", 1)).unwrap();
        let mut c = drive(7);
        let e = refusal_of(&mut c, &file);
        assert!(e.contains("entry 1") && e.contains("1099511627776"), "{e}");
        assert!(c.written.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
