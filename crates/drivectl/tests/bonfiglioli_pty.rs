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
    assert_eq!(v[0]["selector"], serde_json::json!({"dataset": 1}));
    assert_eq!(v[0]["label"], "372 data set 1");
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

/// `drivectl <args>` from a shell, as a user pastes it: the `drivectl` of this build first on
/// the path.
fn paste(sim: &PtySim, command_line: &str) -> Output {
    let bin = std::path::Path::new(env!("CARGO_BIN_EXE_drivectl"))
        .parent()
        .unwrap()
        .to_str()
        .unwrap()
        .to_owned();
    let path = format!("{bin}:{}", std::env::var("PATH").unwrap_or_default());
    Command::new("sh")
        .args(["-c", command_line])
        .env("PATH", path)
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .output()
        .unwrap()
}

/// The command a hint on standard error gives between backticks after `marker`.
fn hint_after(err: &str, marker: &str) -> String {
    let at = err
        .find(marker)
        .unwrap_or_else(|| panic!("no {marker:?} in {err}"));
    let rest = &err[at..];
    let start = rest
        .find('`')
        .unwrap_or_else(|| panic!("no hint in {rest}"))
        + 1;
    let len = rest[start..].find('`').unwrap();
    rest[start..start + len].to_owned()
}

/// Issue 18 B8: the status word 411 is decoded wherever it is read (read, watch), with the
/// device it was decoded for and how that was found; 260 and 270 carry their decoded keys.
#[test]
fn issue18_b8_the_status_word_is_decoded_in_read_and_watch() {
    let sim = Sim::start("rtu", &[]);
    let o = sim.run(&["--json", "read", "411", "260", "270"]);
    let v = ok_json(&o);
    let d = &v[0]["decoded"];
    assert_eq!(d["state"], "switched on", "{v:?}");
    assert_eq!(d["variant"], "act", "{v:?}");
    assert_eq!(d["status_word"], "0x0023");
    assert!(
        d["bits"]
            .as_array()
            .unwrap()
            .contains(&"no quick stop".into())
    );
    assert!(
        v[0]["meaning"].as_str().unwrap().contains("switched on"),
        "{v:?}"
    );
    // The ACT was found by reading 484, which only the ACT answers (ch. 10.2.3); said once.
    assert!(stderr(&o).contains("484"), "{}", stderr(&o));
    assert_eq!(v[1]["decoded"]["fault"], "F0000", "{v:?}");
    assert_eq!(v[2]["decoded"]["warnings"], serde_json::json!([]), "{v:?}");
    // In text, the word in hex with its state.
    let o = sim.run(&["read", "411"]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("0x0023: switched on"), "{out}");
    // watch decodes it the same way.
    let v = ok_json(&sim.run(&[
        "--json",
        "watch",
        "411",
        "--count",
        "1",
        "--interval",
        "100",
    ]));
    assert_eq!(
        v[0]["values"][0]["decoded"]["state"], "switched on",
        "{v:?}"
    );
    // Given, the variant is not detected, and the decoding says which was assumed.
    let o = sim.run(&["--json", "--variant", "act", "read", "411"]);
    assert_eq!(ok_json(&o)[0]["decoded"]["variant"], "act");
    assert!(!stderr(&o).contains("484"), "{}", stderr(&o));
}

/// Issue 18 B8: `--variant` is one option of the family; by default the drive is asked, and an
/// ACU is found (its status word bit 4, or 484 it cannot read) for read, status and backup.
#[test]
fn issue18_b8_an_acu_is_detected_and_the_variant_applies_to_every_command() {
    let sim = Sim::start("rtu", &["--variant", "acu"]);
    let v = ok_json(&sim.run(&["--json", "read", "411"]));
    assert_eq!(v[0]["decoded"]["variant"], "acu", "{v:?}");
    assert_eq!(v[0]["decoded"]["mains_voltage"], true, "{v:?}");
    let v = ok_json(&sim.run(&["--json", "status"]));
    assert_eq!(v[0]["variant"], "acu", "{v:?}");
    // Said to be an ACT, the drive contradicts it: bit 4 is set, which an ACT never sets.
    let o = sim.run(&["--variant", "act", "status"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("bit 4"), "{}", stderr(&o));
    // The backup's identity says which device it came from.
    let dir = std::env::temp_dir().join(format!("drivectl-bonf-variant-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("acu.json");
    ok_json(&sim.run(&["--json", "backup", "--out", f.to_str().unwrap()]));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    assert_eq!(doc["variant"], "acu", "{doc}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 18 C: `info` shows what the table knows and the drive's value in every data set, with
/// the keys of `drivectl movilink info --json` where they mean the same.
#[test]
fn issue18_c_info_shows_the_table_and_the_drives_values() {
    let sim = Sim::start("rtu", &[]);
    ok_json(&sim.run(&["--json", "write", "372", "1390", "--dataset", "2"]));
    let v = ok_json(&sim.run(&["--json", "info", "372"]));
    let i = &v[0];
    for key in [
        "index", "number", "name_de", "name_en", "unit", "range", "default", "access",
    ] {
        assert!(i.get(key).is_some(), "{key} missing: {i}");
    }
    assert_eq!(i["index"], 372);
    assert_eq!(i["data_type"], "uInt");
    assert_eq!(i["bits"], 16);
    assert_eq!(i["data_sets"], true);
    assert_eq!(i["range"]["max"], 65535);
    let current = i["current"].as_array().unwrap();
    assert_eq!(current.len(), 4, "{i}");
    assert_eq!(current[1]["selector"]["dataset"], 2);
    assert_eq!(current[1]["raw"], 1390);
    // One data set asked for: only that one is read.
    let v = ok_json(&sim.run(&["--json", "info", "372", "--dataset", "2"]));
    assert_eq!(v[0]["current"].as_array().unwrap().len(), 1);
    // Text: the table's facts and the value.
    let o = sim.run(&["info", "372"]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.contains("data set 2") && out.contains("1390"), "{out}");
}

/// Issue 18 C: a response timeout shorter than an exchange at the line's baud rate is refused
/// before the port opens, naming the least that works; that one works when pasted.
#[test]
fn issue18_c_a_timeout_shorter_than_the_line_needs_is_refused() {
    let sim = Sim::start("rtu", &["--baud", "2400"]);
    let o = sim.run(&["--baud", "2400", "--timeout", "20", "read", "372"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("2400 baud"), "{err}");
    let at = err.find("--timeout ").unwrap() + "--timeout ".len();
    let least: u64 = err[at..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(least > 20 && least < 200, "{err}");
    let v = ok_json(&sim.run(&[
        "--baud",
        "2400",
        "--timeout",
        &least.to_string(),
        "--json",
        "read",
        "372",
    ]));
    assert_eq!(v[0]["index"], 372);
    let o = sim.run(&[
        "--baud",
        "2400",
        "--timeout",
        &(least - 1).to_string(),
        "read",
        "372",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// The slave-messages counter of the simulated drive (FC 8): how many requests reached it.
fn slave_messages(sim: &Sim) -> u64 {
    ok_json(&sim.run(&["--json", "diag"]))[0]["counters"]["slave_messages"]
        .as_u64()
        .unwrap()
}

/// Issue 18, rough edges: `--dataset` on a parameter that exists once is refused before
/// anything is sent, naming the parameter.
#[test]
fn issue18_a_data_set_of_a_parameter_without_data_sets_is_refused_before_sending() {
    let sim = Sim::start("rtu", &[]);
    let before = slave_messages(&sim);
    for args in [
        &["read", "260", "--dataset", "2"][..],
        &["watch", "411", "--dataset", "1", "--count", "1"][..],
        &["write", "1376", "5", "--dataset", "3", "--word", "--yes"][..],
    ] {
        let o = sim.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains(args[1]) && err.contains("data set"), "{err}");
    }
    // Only the diag of this test reached the drive (8 counters).
    assert_eq!(slave_messages(&sim), before + 8);
}

/// Issue 18, rough edges: a link setting written with the value it has says nothing changes;
/// a new baud rate says when it takes effect and which --baud reaches the drive then.
#[test]
fn issue18_an_unchanged_link_setting_says_nothing_changes() {
    let sim = Sim::start("rtu", &[]);
    let o = sim.run(&["write", "10", "3", "--word", "--yes"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains("another baud rate"), "{err}");
    assert!(err.contains("nothing changes"), "{err}");
    std::thread::sleep(std::time::Duration::from_millis(1100));
    let o = sim.run(&["write", "10", "4", "--word", "--yes"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("--baud 19200") && err.contains("34 = 123"),
        "{err}"
    );
    // A new address applies at once: the note's command reaches the drive there.
    let o = sim.run(&["write", "1376", "5", "--word", "--yes"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let there = hint_after(&stderr(&o), "from now on");
    assert!(
        there.contains("--addr 5") && there.ends_with("status"),
        "{there}"
    );
    let o = paste(&sim, &there);
    assert!(o.status.success(), "{there}: {}", stderr(&o));
}

/// Issue 18, rough edges: the simulator's own line parameters say what it serves.
#[test]
fn issue18_the_simulator_reports_the_line_it_serves() {
    let sim = Sim::start("rtu", &["--addr", "3"]);
    let run = |args: &[&str]| {
        let mut all = vec![
            "bonfiglioli",
            "--port",
            &sim.path,
            "--parity",
            "none",
            "--addr",
            "3",
            "--json",
            "read",
            "--word",
        ];
        all.extend_from_slice(args);
        ok_json(&sim.drivectl(&all))
    };
    let v = run(&["10", "395", "1375", "1376"]);
    let raws: Vec<i64> = v.iter().map(|x| x["raw"].as_i64().unwrap()).collect();
    // 9600 baud = 3, Modbus RTU = 2, no parity = 2, address 3.
    assert_eq!(raws, [3, 2, 2, 3], "{v:?}");
    let ascii = Sim::start("ascii", &["--baud", "19200"]);
    let v = ok_json(&ascii.run(&["--baud", "19200", "--json", "read", "--word", "10", "395"]));
    let raws: Vec<i64> = v.iter().map(|x| x["raw"].as_i64().unwrap()).collect();
    assert_eq!(raws, [4, 3], "{v:?}");
    // A rate the drive does not have is refused, naming the ones it has.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "sim",
            "bonfiglioli",
            "--pty",
            "--parity",
            "none",
            "--baud",
            "1200",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("2400"), "{}", stderr(&o));
}

/// Issue 18 B11: the hints of `control` carry the line options and work when pasted: a slow
/// line without parity, ASCII with 8 data bits on a pty, a port path with a space.
#[test]
fn issue18_b11_the_stop_hint_works_when_pasted() {
    for (mode, extra) in [
        ("rtu", &["--baud", "2400"][..]),
        ("ascii", &["--data-bits", "8"][..]),
    ] {
        let sim = Sim::start(mode, extra);
        let dir =
            std::env::temp_dir().join(format!("drivectl bonf hint {} {mode}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("my drive");
        std::os::unix::fs::symlink(&sim.path, &link).unwrap();
        let port = link.to_str().unwrap();
        let mut args = vec!["bonfiglioli", "--port", port, "--parity", "none"];
        args.extend_from_slice(&["--mode", mode]);
        args.extend_from_slice(extra);
        if mode == "ascii" {
            // Already in `extra`: the pty takes 8 data bits only.
        } else {
            args.extend_from_slice(&["--data-bits", "8"]);
        }
        args.extend_from_slice(&["control", "enable", "--freq", "5"]);
        let o = sim.drivectl(&args);
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
        let stop = hint_after(&stderr(&o), "stop it with");
        for option in extra {
            assert!(stop.contains(option), "{stop}");
        }
        assert!(stop.contains("'") && stop.contains("my drive"), "{stop}");
        let o = paste(&sim, &stop);
        assert!(o.status.success(), "{stop}: {}", stderr(&o));
        let status = paste(&sim, &stop.replace("control stop", "--json status"));
        let v = ok_json(&status);
        assert_eq!(v[0]["state"], "switched on", "{v:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Issue 18, rough edges: Modbus ASCII's 7 data bits refused by a pty: the message says what
/// the manual says (ASCII uses 7 data bits) and how to run over a pty: 8 on both sides, both
/// commands pasteable.
#[test]
fn issue18_ascii_7_data_bits_on_a_pty_say_the_manuals_7_and_how_to_run() {
    let sim = Sim::start("ascii", &["--data-bits", "8"]);
    let o = sim.drivectl(&[
        "bonfiglioli",
        "--port",
        &sim.path,
        "--parity",
        "none",
        "--mode",
        "ascii",
        "read",
        "372",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(!err.contains("normally use 8"), "{err}");
    assert!(
        err.contains("7 data bits") && err.contains("6.7.2.1"),
        "{err}"
    );
    let retry = hint_after(&err, "run both sides");
    assert!(
        retry.contains("sim bonfiglioli") && retry.contains("--data-bits 8"),
        "{retry}"
    );
    let master = hint_after(&err[err.find(&retry).unwrap() + retry.len()..], "and");
    assert!(
        master.contains("--data-bits 8") && !master.contains("read 372"),
        "{master}"
    );
    let o = paste(&sim, &format!("{master} read 372 --json"));
    assert_eq!(ok_json(&o)[0]["index"], 372, "{master}");
}

/// Issue 18, rough edges: `control enable` leaves 412 = 1 in RAM, a backup reads it (a read
/// returns the value in use: the manual has no read of the stored one), and a restore never
/// writes 412: it would store 1 in the EEPROM of all four data sets.
#[test]
fn issue18_a_backup_after_control_never_restores_412() {
    let sim = Sim::start("rtu", &[]);
    let o = sim.run(&["control", "enable", "--freq", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(sim.run(&["control", "stop"]).status.success());
    let dir = std::env::temp_dir().join(format!("drivectl-bonf-412-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("after-control.json");
    let fs = f.to_str().unwrap();
    ok_json(&sim.run(&["--json", "backup", "--out", fs]));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    let saved: Vec<&serde_json::Value> = doc["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["index"] == 412)
        .collect();
    assert_eq!(saved.len(), 4, "412 in four data sets");
    assert!(saved.iter().all(|e| e["raw"] == 1), "{saved:?}");
    // Back to the keypad's mode in RAM: the file's 412 = 1 now differs from the drive.
    ok_json(&sim.run(&["--json", "write", "412", "44", "--word", "--ram"]));
    let v = ok_json(&sim.run(&["--json", "restore", fs, "--dry-run"]));
    assert!(
        v.iter().all(|c| c["index"] != 412),
        "412 would be restored: {v:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// An ACU with positioning control (configuration 30 = x40) has no shortcut 4' from switch-on
/// disabled (ch. 10.2): `control enable` goes through 2, 3 and 4 instead of waiting for a
/// transition the drive does not make.
#[test]
fn issue18_control_enables_an_acu_with_positioning_control() {
    let sim = Sim::start("rtu", &["--variant", "acu"]);
    ok_json(&sim.run(&["--json", "write", "30", "240", "--word", "--force"]));
    let started = std::time::Instant::now();
    let o = sim.run(&["control", "enable", "--freq", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        started.elapsed() < std::time::Duration::from_secs(10),
        "{:?}",
        started.elapsed()
    );
    let v = ok_json(&sim.run(&["--json", "status"]));
    assert_eq!(v[0]["state"], "operation enabled", "{v:?}");
    assert!(sim.run(&["control", "stop"]).status.success());
}

/// Issue 18 B7: on an ACTIVE Cube 484 is write-only, and `control enable --freq` read it back
/// and failed every time. The reference is never read back; the output says how the write was
/// confirmed (the drive's echo of the write) and shows the actual frequency.
#[test]
fn issue18_b7_a_write_only_reference_is_confirmed_by_its_echo_on_an_acu() {
    let sim = Sim::start("rtu", &["--variant", "acu"]);
    for variant in [&[][..], &["--variant", "acu"][..]] {
        let mut args = variant.to_vec();
        args.extend_from_slice(&["control", "enable", "--freq", "5"]);
        let o = sim.run(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            out.contains("confirmed by the drive's echo") && out.contains("never read back"),
            "{out}"
        );
        assert!(
            stderr(&o).contains("keeps running after drivectl ends"),
            "{}",
            stderr(&o)
        );
        let mut json = vec!["--json"];
        json.extend_from_slice(&args);
        let v = ok_json(&sim.run(&json));
        assert_eq!(v[0]["reference"]["confirmed_by"], "echo", "{v:?}");
        assert_eq!(v[0]["reference"]["hz"], 5.0, "{v:?}");
        assert!(sim.run(&["control", "stop"]).status.success());
    }
}
