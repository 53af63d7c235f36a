//! Issue 18, the shared tool layer end to end over pseudo-terminals, for every family: restore,
//! watch, backup and write name the selector (data set, parameter set, array element) of every
//! value they show; a write the drive holds differently says so; a restore lists what it did
//! not write and why and writes a link setting only with `--yes`; output paths, empty and
//! foreign files, and a restore ended by SIGTERM.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::os::unix::fs::PermissionsExt as _;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use common::{PtySim, ok_json, stderr};
use serde_json::{Value, json};

/// A simulated drive on a pty and the `drivectl` options that reach it.
struct Drive {
    sim: PtySim,
    prefix: Vec<String>,
}

impl Drive {
    fn movilink(extra: &[&str]) -> Drive {
        let mut args = vec![
            "sim", "movilink", "--pty", "--parity", "none", "--addr", "1",
        ];
        args.extend_from_slice(extra);
        let sim = PtySim::start(&args);
        let mut prefix: Vec<String> = ["movilink", "--port", &sim.path, "--parity", "none"]
            .map(String::from)
            .to_vec();
        prefix.extend(extra.iter().map(|s| s.to_string()));
        prefix.extend(["--addr", "1"].map(String::from));
        Drive { sim, prefix }
    }

    fn sbus() -> Drive {
        let sim = PtySim::start(&["sim", "sbus", "--pty", "--addr", "1"]);
        let iface = format!("slcan:{}", sim.path);
        let prefix = ["sbus", "--iface", &iface, "--addr", "1"]
            .map(String::from)
            .to_vec();
        Drive { sim, prefix }
    }

    fn bonfiglioli(variant: &str) -> Drive {
        let sim = PtySim::start(&[
            "sim",
            "bonfiglioli",
            "--pty",
            "--parity",
            "none",
            "--mode",
            "rtu",
            "--variant",
            variant,
        ]);
        let prefix = [
            "bonfiglioli",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--addr",
            "1",
        ]
        .map(String::from)
        .to_vec();
        Drive { sim, prefix }
    }

    fn uss() -> Drive {
        let sim = PtySim::start(&["sim", "uss", "--pty", "--addr", "1", "--parity", "none"]);
        let prefix = [
            "uss", "--port", &sim.path, "--parity", "none", "--addr", "1",
        ]
        .map(String::from)
        .to_vec();
        Drive { sim, prefix }
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut c = self.sim.command();
        c.args(&self.prefix).args(args);
        c
    }

    fn run(&self, args: &[&str]) -> Output {
        self.command(args).output().expect("drivectl runs")
    }

    /// `run` that must succeed; its standard output.
    fn ok(&self, args: &[&str]) -> String {
        let o = self.run(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }
}

/// Longer than the EEPROM-wear rule's shortest time between two EEPROM writes of one value.
const EEPROM_PAUSE: Duration = Duration::from_millis(1100);

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("drivectl-i18-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The JSON lines of standard output, whatever the exit code.
fn json_lines(o: &Output) -> Vec<Value> {
    stdout(o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect()
}

/// B6: a restore names the data set and the parameter set of every value it shows (dry run,
/// the report of what it wrote, JSON `label` + `selector`, no bare `sub`).
#[test]
fn issue18_b6_restore_names_data_sets_and_parameter_sets() {
    let d = dir("b6");
    // Bonfiglioli: 372 rated speed in data sets 2 and 3.
    let bf = Drive::bonfiglioli("act");
    let f = d.join("bf.json");
    let fs = f.to_str().unwrap();
    bf.ok(&["backup", "--out", fs]);
    bf.ok(&["write", "372", "1400", "--dataset", "2"]);
    bf.ok(&["write", "372", "1410", "--dataset", "3"]);
    // The EEPROM-wear rule holds back a second EEPROM write of a value within a second.
    std::thread::sleep(EEPROM_PAUSE);
    let text = bf.ok(&["restore", fs, "--dry-run"]);
    for (set, old) in [(2, 1400), (3, 1410)] {
        let line = format!(
            "372 data set {set} Rated speed: {old} 1/min (raw {old}) → 1390 1/min (raw 1390)"
        );
        assert!(text.contains(&line), "{line}\n{text}");
    }
    let v = ok_json(&bf.run(&["--json", "restore", fs, "--dry-run"]));
    let changes: Vec<&Value> = v.iter().filter(|c| c["type"] == "change").collect();
    assert_eq!(changes.len(), 2, "{v:?}");
    assert_eq!(changes[0]["label"], "372 data set 2");
    assert_eq!(changes[0]["selector"], json!({"dataset": 2}));
    assert_eq!(changes[1]["selector"], json!({"dataset": 3}));
    assert!(changes[0].get("sub").is_none(), "{}", changes[0]);
    // The restore itself reports what it wrote, by data set.
    let o = bf.run(&["restore", fs]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("372 data set 3 Rated speed: 1410 1/min (raw 1410) → 1390"),
        "{}",
        stdout(&o)
    );
    // USS: P102 in parameter set 2.
    let uss = Drive::uss();
    let f = d.join("uss.json");
    let fs = f.to_str().unwrap();
    uss.ok(&["backup", "--out", fs]);
    uss.ok(&["write", "P102", "3", "--set", "2"]);
    std::thread::sleep(EEPROM_PAUSE);
    let text = uss.ok(&["restore", fs, "--dry-run"]);
    assert!(
        text.contains("P102 set 2 acceleration time: 3.00 s (raw 300) → 2.00 s (raw 200)"),
        "{text}"
    );
    let v = ok_json(&uss.run(&["--json", "restore", fs]));
    let change = v.iter().find(|c| c["type"] == "change").unwrap();
    assert_eq!(change["label"], "P102 set 2");
    assert_eq!(change["selector"], json!({"set": 2, "ind": "0x0100"}));
    let _ = std::fs::remove_dir_all(&d);
}

/// B9: watch names the element and the data set in every shape, CSV headers are unique, and a
/// watch that could read nothing fails.
#[test]
fn issue18_b9_watch_names_elements_and_fails_when_nothing_was_read() {
    let uss = Drive::uss();
    let csv = uss.ok(&["watch", "P700", "--count", "1", "--csv"]);
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "time,P700 [-01] present fault,P700 [-02] present warning,\
         P700 [-03] reason for switch-on disabled"
    );
    let bf = Drive::bonfiglioli("act");
    let csv = bf.ok(&["watch", "372", "--dataset", "2", "--count", "1", "--csv"]);
    assert_eq!(
        csv.lines().next().unwrap(),
        "time,372 data set 2 Rated speed [1/min]"
    );
    // The same parameter twice: still one name per column.
    let csv = bf.ok(&["watch", "372", "372", "--count", "1", "--csv"]);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(header.len(), 3);
    assert_ne!(header[1], header[2], "{header:?}");
    // MOVILINK: index 9999 is refused in every poll.
    let ml = Drive::movilink(&[]);
    let o = ml.run(&["watch", "9999", "--count", "2", "--interval", "50"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no parameter could be read in 2 poll(s): index 9999"),
        "{}",
        stderr(&o)
    );
    // One of two never read: the watch shows the other, and fails naming the one.
    let o = ml.run(&[
        "--json",
        "watch",
        "P130",
        "9999",
        "--count",
        "2",
        "--interval",
        "50",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let samples = json_lines(&o);
    assert_eq!(samples.len(), 2);
    let refused = &samples[0]["values"][1];
    assert_eq!(refused["label"], "index 9999");
    assert!(refused["selector"].is_null() && refused["error"].is_string());
    assert!(
        stderr(&o).contains("1 of 2 parameter(s) could not be read in any of the 2 poll(s)"),
        "{}",
        stderr(&o)
    );
}

/// B10: a write whose read-back differs from what was sent says so.
#[test]
fn issue18_b10_a_write_the_drive_rounds_is_not_a_plain_success() {
    let ml = Drive::movilink(&[]);
    let o = ml.run(&["write", "P130", "--raw", "65536", "--volatile"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "warning: P130 was written with raw 65536 (65.54 s), but the drive holds 66000 \
             (66.00 s): it rounded the value to its step"
        ),
        "{}",
        stderr(&o)
    );
    let v = ok_json(&ml.run(&["--json", "write", "P130", "--raw", "65536", "--volatile"]));
    assert_eq!(
        (&v[0]["sent"], &v[0]["raw"]),
        (&json!(65536), &json!(66000))
    );
    assert_eq!(v[0]["differs"], true);
    let o = ml.run(&["--json", "write", "P130", "1.5", "--volatile"]);
    let v = ok_json(&o);
    assert_eq!(
        (&v[0]["sent"], &v[0]["differs"]),
        (&json!(1500), &json!(false))
    );
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
}

/// B12: an SBus restore writes P815 only with `--yes`, and lists everything it did not write.
#[test]
fn issue18_b12_restore_needs_yes_for_link_settings_and_lists_what_it_skips() {
    let d = dir("b12");
    let sb = Drive::sbus();
    let f = d.join("sb.json");
    let fs = f.to_str().unwrap();
    sb.ok(&["backup", "--out", fs]);
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    let p815 = saved["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["number"] == "P815")
        .unwrap()["raw"]
        .clone();
    sb.ok(&["write", "P815", "2", "--yes", "--volatile"]);
    sb.ok(&["write", "P130", "1.5", "--volatile"]);
    let o = sb.run(&["restore", fs]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("P815"), "{text}");
    assert!(text.contains("--yes"), "{text}");
    assert!(
        text.contains("P813"),
        "P813 is listed as not restored: {text}"
    );
    assert!(text.contains("P130 Ramp t11 up CW [s]: 1.50 s"), "{text}");
    let v = ok_json(&sb.run(&["--json", "read", "P815"]));
    assert_ne!(v[0]["raw"], p815, "P815 was not written without --yes");
    // JSON: every skipped entry with its reason.
    let v = ok_json(&sb.run(&["--json", "restore", fs, "--dry-run"]));
    let summary = v.last().unwrap();
    let skipped = summary["skipped"].as_array().unwrap();
    let reason = |label: &str| {
        skipped
            .iter()
            .find(|s| s["label"] == label)
            .map(|s| s["reason"].clone())
            .unwrap_or(Value::Null)
    };
    assert_eq!(reason("P815"), "needs_yes");
    assert_eq!(reason("P813"), "link_setting");
    assert_eq!(reason("P802"), "command");
    assert_eq!(reason("P000"), "read_only");
    // With --yes it is written and verified.
    let o = sb.run(&["restore", fs, "--yes"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = ok_json(&sb.run(&["--json", "read", "P815"]));
    assert_eq!(v[0]["raw"], p815);
    // Bonfiglioli: address, baud rate and protocol are link settings; control word and RAM
    // setpoints are RAM-only; every one is named.
    let bf = Drive::bonfiglioli("act");
    let f = d.join("bf.json");
    let fs = f.to_str().unwrap();
    bf.ok(&["backup", "--out", fs]);
    let v = ok_json(&bf.run(&["--json", "restore", fs, "--dry-run"]));
    let skipped = v.last().unwrap()["skipped"].as_array().unwrap().clone();
    for (label, why) in [
        ("1376", "link_setting"),
        ("10", "link_setting"),
        ("395", "link_setting"),
        ("410", "ram_only"),
        ("484", "ram_only"),
    ] {
        assert!(
            skipped
                .iter()
                .any(|s| s["label"] == label && s["reason"] == why),
            "{label}: {skipped:?}"
        );
    }
    let text = bf.ok(&["restore", fs, "--dry-run"]);
    assert!(text.contains("1376") && text.contains("484"), "{text}");
    let _ = std::fs::remove_dir_all(&d);
}

/// Output paths: `--overwrite` keeps the replaced file's mode; a path that cannot be used is a
/// usage error (exit 2) before anything is read.
#[test]
fn issue18_output_paths_keep_the_mode_and_unusable_ones_are_usage_errors() {
    let d = dir("out");
    let uss = Drive::uss();
    let f = d.join("b.json");
    let fs = f.to_str().unwrap();
    std::fs::write(&f, "old").unwrap();
    std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o600)).unwrap();
    uss.ok(&["backup", "--out", fs, "--overwrite"]);
    let mode = std::fs::metadata(&f).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);
    assert!(
        std::fs::read_to_string(&f)
            .unwrap()
            .contains("drivebus-backup")
    );
    let null_link = d.join("null.json");
    std::os::unix::fs::symlink("/dev/null", &null_link).unwrap();
    for (out, needle) in [
        ("/nonexistent/x.json", "/nonexistent does not exist"),
        ("/sys/x.json", "cannot be written"),
        ("/dev/null", "device node"),
        (null_link.to_str().unwrap(), "device node"),
    ] {
        let o = uss.run(&["backup", "--out", out, "--overwrite"]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{out}: {}", stderr(&o));
        assert!(!stderr(&o).contains("  "), "{out}: {}", stderr(&o));
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A file without parameters is said plainly; a file saved by Notepad (BOM, CR LF) restores.
#[test]
fn issue18_empty_and_notepad_files() {
    let d = dir("files");
    let bf = Drive::bonfiglioli("act");
    let f = d.join("empty.json");
    let doc = json!({"format": "drivebus-backup", "version": 1, "family": "bonfiglioli",
                     "device_type": null, "firmware": null, "parameters": []});
    std::fs::write(&f, doc.to_string()).unwrap();
    let o = bf.run(&["restore", f.to_str().unwrap()]);
    assert_ne!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("holds no parameters"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("no data type"), "{}", stderr(&o));
    let f = d.join("notepad.json");
    let fs = f.to_str().unwrap();
    bf.ok(&["backup", "--out", fs]);
    let text = std::fs::read_to_string(&f).unwrap();
    std::fs::write(&f, format!("\u{feff}{}", text.replace('\n', "\r\n"))).unwrap();
    bf.ok(&["write", "372", "1400", "--dataset", "4"]);
    std::thread::sleep(EEPROM_PAUSE);
    let text = bf.ok(&["restore", fs]);
    assert!(text.contains("372 data set 4 Rated speed"), "{text}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A raw value wider than the parameter is refused with the width message, never with a
/// suggestion of --force, whichever way it is typed.
#[test]
fn issue18_a_value_wider_than_the_parameter_never_suggests_force() {
    let bf = Drive::bonfiglioli("act");
    for args in [
        &["write", "410", "65536"][..],
        &["write", "410", "--raw", "65536"],
        &["write", "410", "65536", "--force"],
    ] {
        let o = bf.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = stderr(&o);
        assert!(e.contains("not even --force"), "{args:?}: {e}");
        assert!(!e.contains("or --force"), "{args:?}: {e}");
        assert!(!e.contains("  "), "{args:?}: {e}");
    }
    let ml = Drive::movilink(&[]);
    let o = ml.run(&["write", "P130", "5000000"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not even --force"), "{}", stderr(&o));
}

/// A restore ended by SIGTERM says what it wrote and what not (exit 143), and the same restore
/// run again finishes it.
#[test]
fn issue18_a_restore_ended_by_sigterm_says_how_far_it_got() {
    let d = dir("term");
    // 1200 baud: every exchange takes about a quarter of a second.
    let ml = Drive::movilink(&["--baud", "1200"]);
    let f = d.join("b.json");
    let mut params = Vec::new();
    for (i, index) in (8470..8474).chain(8476..8483).chain(8484..8488).enumerate() {
        params.push(json!({"index": index, "raw": 1100 + 100 * i}));
    }
    let doc = json!({"format": "drivebus-backup", "version": 1, "family": "movidrive",
                     "parameters": params});
    std::fs::write(&f, doc.to_string()).unwrap();
    let fs = f.to_str().unwrap();
    let child = ml
        .command(&["restore", fs])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Fifteen reads, then fifteen writes (about 0.12 s each): the signal comes in the middle
    // of the writes.
    std::thread::sleep(Duration::from_millis(3000));
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let o = child.wait_with_output().unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(143), "{e}");
    assert!(e.contains("SIGTERM"), "{e}");
    assert!(
        e.contains("half restored") || e.contains("nothing was written"),
        "{e}"
    );
    let o = ml.run(&["restore", fs]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("15 verified"), "{}", stdout(&o));
    let _ = std::fs::remove_dir_all(&d);
}
