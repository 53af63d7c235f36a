//! End to end over a real pseudo-terminal: `drivectl sim bonfiglioli --pty` on one side,
//! `drivectl bonfiglioli --port <pty>` on the other, as separate processes, in RTU and ASCII.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::io::{BufRead, BufReader};
use std::ops::Deref;
use std::process::{Command, Output, Stdio};

use common::{PtySim, ok_json, stderr};

/// `drivectl sim bonfiglioli --pty` in one mode.
struct Sim {
    pty: PtySim,
    mode: &'static str,
}

impl Deref for Sim {
    type Target = PtySim;
    fn deref(&self) -> &PtySim {
        &self.pty
    }
}

impl Sim {
    fn start(mode: &'static str, extra: &[&str]) -> Sim {
        let mut args = vec![
            "sim",
            "bonfiglioli",
            "--pty",
            "--parity",
            "none",
            "--mode",
            mode,
        ];
        args.extend_from_slice(extra);
        Sim {
            pty: PtySim::start(&args),
            mode,
        }
    }

    fn run(&self, args: &[&str]) -> Output {
        let mut all = vec![
            "bonfiglioli",
            "--port",
            &self.path,
            "--parity",
            "none",
            "--mode",
            self.mode,
            // A pty takes 8 data bits only (ASCII's own are 7).
            "--data-bits",
            "8",
            "--addr",
            "1",
        ];
        all.extend_from_slice(args);
        self.drivectl(&all)
    }
}

fn everyday(mode: &'static str) {
    let sim = Sim::start(mode, &[]);
    // ch. 8.1.1: 372 in data set 2 holds 1390 after writing it.
    ok_json(&sim.run(&["--json", "write", "372", "1390", "--dataset", "2"]));
    let v = ok_json(&sim.run(&["--json", "read", "372", "--dataset", "2"]));
    assert_eq!(
        (&v[0]["index"], &v[0]["selector"]["dataset"], &v[0]["raw"]),
        (
            &serde_json::json!(372),
            &serde_json::json!(2),
            &serde_json::json!(1390)
        )
    );
    assert_eq!(v[0]["unit"], "1/min");
    // ch. 8.1.2: 1.5 kW is raw 15.
    let v = ok_json(&sim.run(&["--json", "write", "376", "1.5", "--dataset", "4"]));
    assert_eq!(v[0]["raw"], 15);
    // ch. 8.1.3: the Long parameter 481 (FC 100/101), two decimals.
    let v = ok_json(&sim.run(&["--json", "write", "481", "12.5"]));
    assert_eq!(
        (v[0]["raw"].as_i64(), v[0]["value"].as_f64()),
        (Some(1250), Some(12.5))
    );
    // A refusal with its cause: 376 = 0 is not a valid rated power (ch. 8.1.2 example 2).
    let o = sim.run(&["write", "376", "0", "--raw", "--force", "--dataset", "2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("exception"), "{}", stderr(&o));
    // An unknown parameter (raw number): exception 4 with VABus 11.
    let o = sim.run(&["read", "1500", "--word"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("VABus error 11"), "{}", stderr(&o));
    // diag: the counters named.
    let v = ok_json(&sim.run(&["--json", "diag", "--clear"]));
    assert_eq!(v[0]["counters"]["bus_exception_errors"], 0);
    let v = ok_json(&sim.run(&["--json", "diag"]));
    assert!(v[0]["counters"]["slave_messages"].as_u64().unwrap() >= 1);
    // scan finds address 1 only.
    let v = ok_json(&sim.run(&["--json", "scan", "--from", "1", "--to", "3"]));
    assert_eq!(v.len(), 1);
    assert_eq!(v[0]["address"], 1);
    // control enable → status shows operation enabled; stop again.
    let o = sim.run(&["control", "enable", "--freq", "20"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("control stop"), "{}", stderr(&o));
    let v = ok_json(&sim.run(&["--json", "status"]));
    assert_eq!(v[0]["state"], "operation enabled", "{v:?}");
    let o = sim.run(&["control", "stop"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn everyday_commands_over_rtu() {
    everyday("rtu");
}

#[test]
fn everyday_commands_over_ascii() {
    everyday("ascii");
}

#[test]
fn backup_and_restore_round_trip() {
    let sim = Sim::start("rtu", &[]);
    let dir = std::env::temp_dir().join(format!("drivectl-bonf-backup-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drive.json");
    let f = file.to_str().unwrap();
    ok_json(&sim.run(&["--json", "write", "372", "1390", "--dataset", "2"]));
    let v = ok_json(&sim.run(&["--json", "backup", "--out", f, "--overwrite"]));
    assert!(v[0]["parameters"].as_u64().unwrap() > 48, "{v:?}");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let ds2 = doc["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["index"] == 372 && e["sub"] == 2)
        .expect("372 data set 2 is saved");
    assert_eq!(ds2["raw"], 1390);
    // Change it, restore, and it is back.
    ok_json(&sim.run(&[
        "--json",
        "write",
        "372",
        "1000",
        "--dataset",
        "2",
        "--force",
    ]));
    // The EEPROM-wear rule allows the next non-volatile write of 372 after a second.
    std::thread::sleep(std::time::Duration::from_millis(1100));
    let v = ok_json(&sim.run(&["--json", "restore", f]));
    assert_eq!(v.last().unwrap()["written"], 1, "{v:?}");
    let v = ok_json(&sim.run(&["--json", "read", "372", "--dataset", "2"]));
    assert_eq!(v[0]["raw"], 1390);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_is_refused_before_anything_is_sent() {
    let sim = Sim::start("rtu", &[]);
    for (args, needle) in [
        (&["read", "P9999"][..], "no bonfiglioli parameter"),
        (&["read", "415"][..], "--word"),
        (&["write", "372", "70000", "--raw"][..], "372"),
        (&["write", "372", "--5", "--raw"][..], "not an integer"),
        (&["write", "1376", "5", "--word"][..], "--yes"),
    ] {
        let o = sim.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    // Frequent EEPROM writes: the hint is --volatile, the one RAM-only option of every family
    // (issue 18 C; --ram is its alias here).
    ok_json(&sim.run(&["--json", "write", "372", "1391", "--dataset", "1"]));
    let o = sim.run(&["write", "372", "1392", "--dataset", "1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--volatile"), "{}", stderr(&o));
    let v = ok_json(&sim.run(&["--json", "write", "372", "1392", "--dataset", "1", "--ram"]));
    assert_eq!(v[0]["selector"], serde_json::json!({"dataset": 6}));
    assert_eq!(v[0]["label"], "372 data set 6");
}

#[test]
fn sim_refuses_parity_on_a_pty_and_duplicate_addresses() {
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&["sim", "bonfiglioli", "--pty"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--parity none"), "{}", stderr(&o));
    let o = run(&[
        "sim",
        "bonfiglioli",
        "--pty",
        "--parity",
        "none",
        "--addr",
        "3",
        "--addr",
        "3",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("twice"), "{}", stderr(&o));
}

#[test]
fn ascii_uses_the_manuals_7_data_bits_and_a_pty_refusing_them_names_the_option() {
    let sim = Sim::start("ascii", &[]);
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "bonfiglioli",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--mode",
            "ascii",
            "read",
            "372",
            "--dataset",
            "2",
        ])
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("7 data bits") && err.contains("--data-bits"),
        "{err}"
    );
    // RTU keeps 8 data bits, and without parity two stop bits (ch. 6.7.1.1).
    let v = sim.run(&["line", "--json"]);
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
}

/// The MOVILINK CLI's everyday behaviours hold for Bonfiglioli too (issue 8): options after the
/// subcommand, errors as JSON with `--json`, a closed pipe, output only to regular files, a
/// restore dry run, `watch` samples, the EEPROM-wear rule with its `--ram` hint, and the fault
/// and warning words named.
#[test]
fn the_everyday_behaviours_of_the_movilink_cli_hold_here_too() {
    let sim = Sim::start("rtu", &[]);
    let err = |o: &Output| String::from_utf8_lossy(&o.stderr).into_owned();
    // Every option after the subcommand.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "bonfiglioli",
            "read",
            "372",
            "--dataset",
            "2",
            "--json",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--addr",
            "1",
            "--timeout",
            "300",
        ])
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .output()
        .unwrap();
    assert_eq!(ok_json(&o)[0]["raw"], 1390);
    // An error as one JSON object on stderr.
    let o = sim.run(&["--json", "read", "1600"]);
    assert_eq!(o.status.code(), Some(2));
    let e: serde_json::Value = serde_json::from_str(err(&o).trim()).unwrap();
    assert_eq!(
        (e["type"].as_str(), e["exit_code"].as_u64()),
        (Some("error"), Some(2))
    );
    // Faults and warnings named.
    let v = ok_json(&sim.run(&["--json", "read", "260", "270"]));
    assert_eq!(
        (v[0]["meaning"].as_str(), v[1]["meaning"].as_str()),
        (Some("no fault"), Some("no warning"))
    );
    // A device node as backup output: refused before the first read.
    let o = sim.run(&["backup", "--out", "/dev/full"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(err(&o).contains("is a device node"), "{}", err(&o));
    // Backup, then a dry run changes nothing and says so.
    let dir = std::env::temp_dir().join(format!("drivectl-bonf-everyday-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("b.json");
    let fs = f.to_str().unwrap();
    ok_json(&sim.run(&["--json", "backup", "--out", fs]));
    let v = ok_json(&sim.run(&["--json", "restore", fs, "--dry-run"]));
    let last = v.last().unwrap();
    assert_eq!(
        (last["type"].as_str(), last["changes"].as_u64()),
        (Some("restore"), Some(0))
    );
    // Two EEPROM writes of one parameter in quick succession: the second is refused, with the
    // RAM data sets as the way out.
    assert!(
        sim.run(&["write", "376", "1.6", "--dataset", "3"])
            .status
            .success()
    );
    let o = sim.run(&["write", "376", "1.7", "--dataset", "3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(err(&o).contains("--volatile"), "{}", err(&o));
    assert!(
        sim.run(&["write", "376", "1.7", "--dataset", "3", "--ram"])
            .status
            .success()
    );
    // watch: timestamped samples.
    let v = ok_json(&sim.run(&[
        "--json",
        "watch",
        "241",
        "411",
        "--count",
        "2",
        "--interval",
        "100",
    ]));
    assert_eq!(v.len(), 2);
    assert!(
        v.iter()
            .all(|s| s["type"] == "sample" && s["time"].is_string())
    );
    // A closed pipe ends it quietly.
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "bonfiglioli",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--addr",
            "1",
            "watch",
            "241",
            "--interval",
            "100",
        ])
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    drop(out);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(141), "{}", err(&o));
    assert!(!err(&o).contains("panicked"), "{}", err(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Address 0 broadcasts a write to every drive on the bus; nobody answers, nothing is read
/// back, and a read from address 0 is refused (ch. 6.1).
#[test]
fn a_broadcast_write_reaches_every_drive() {
    let sim = Sim::start("rtu", &["--addr", "1", "--addr", "2"]);
    let run_at = |addr: &str, args: &[&str]| {
        let mut all = vec![
            "bonfiglioli",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--addr",
            addr,
        ];
        all.extend_from_slice(args);
        Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(&all)
            .env("DRIVECTL_STATE_DIR", &sim.state)
            .output()
            .unwrap()
    };
    let v = ok_json(&run_at(
        "0",
        &["--json", "write", "372", "1420", "--dataset", "2", "--ram"],
    ));
    assert_eq!(
        (v[0]["answered"].as_bool(), v[0]["address"].as_u64()),
        (Some(false), Some(0))
    );
    for addr in ["1", "2"] {
        let v = ok_json(&run_at(addr, &["--json", "read", "372", "--dataset", "2"]));
        assert_eq!(v[0]["raw"], 1420, "drive {addr}");
    }
    let o = run_at("0", &["read", "372", "--dataset", "2"]);
    assert_eq!(o.status.code(), Some(2));
}
