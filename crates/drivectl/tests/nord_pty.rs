//! End to end over a real pseudo-terminal: `drivectl sim uss --pty` on one side, `drivectl uss
//! --port <pty>` on the other, as separate processes (pseudo-terminals refuse parity: both
//! sides use `--parity none`).

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
use std::time::{Duration, Instant};

use common::{PtySim, ok_json, stderr};
use serde_json::{Value, json};

/// `drivectl sim uss --pty --parity none …`.
struct Sim(PtySim);

impl Deref for Sim {
    type Target = PtySim;
    fn deref(&self) -> &PtySim {
        &self.0
    }
}

impl Sim {
    fn start(extra: &[&str]) -> Sim {
        let mut args = vec!["sim", "uss", "--pty", "--parity", "none"];
        args.extend_from_slice(extra);
        Sim(PtySim::start(&args))
    }

    /// `drivectl uss` to the drive at `addr` with `args`, to be completed by the caller.
    fn command(&self, addr: &str, args: &[&str]) -> Command {
        let mut c = self.0.command();
        c.args([
            "uss", "--port", &self.path, "--parity", "none", "--addr", addr,
        ])
        .args(args);
        c
    }

    fn run(&self, args: &[&str]) -> Output {
        self.command("1", args).output().expect("drivectl runs")
    }
}

/// The index, the selector's array element and set, and the raw value of a `read --json`
/// object (issue 18: one vocabulary, the selector an object).
fn psr(v: &Value) -> (Value, Value, Value, Value) {
    (
        v["index"].clone(),
        v["selector"]["array"].clone(),
        v["selector"]["set"].clone(),
        v["raw"].clone(),
    )
}

#[test]
fn nord_write_and_read_back_p102_in_parameter_set_3() {
    // The drive works 30 ms on every order, answering the previous one meanwhile: the master
    // repeats its telegram until the answer fits (section 4.6.1.1).
    let sim = Sim::start(&["--addr", "1", "--pkw-time", "30"]);
    // 5.1.3: P102 = 10 s in parameter set 3 is raw 1000 (3E8h).
    let v = ok_json(&sim.run(&["--json", "write", "P102", "10", "--set", "3"]));
    assert_eq!(psr(&v[0]), (json!(102), Value::Null, json!(3), json!(1000)));
    let v = ok_json(&sim.run(&["--json", "read", "P102", "--set", "3"]));
    assert_eq!(psr(&v[0]), (json!(102), Value::Null, json!(3), json!(1000)));
    assert_eq!(
        (v[0]["value"].as_f64(), &v[0]["unit"]),
        (Some(10.0), &json!("s"))
    );
    // The other sets keep their own values.
    let v = ok_json(&sim.run(&["--json", "read", "P102", "--set", "1"]));
    assert_ne!(v[0]["raw"], json!(1000));
    // 5.1.5: 2,5 s (decimal comma) in set 2 is raw 250.
    let v = ok_json(&sim.run(&[
        "--json",
        "write",
        "P102",
        "2,5",
        "--set",
        "2",
        "--no-eeprom",
    ]));
    assert_eq!(psr(&v[0]), (json!(102), Value::Null, json!(2), json!(250)));
    // Text output names the set.
    // A refused write, then a read of the same parameter: the read gets its own answer, not
    // the refusal the drive keeps sending while it works on the read (erratum E21).
    let o = sim.run(&[
        "write",
        "P102",
        "400",
        "--set",
        "3",
        "--force",
        "--no-eeprom",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let o = sim.run(&["read", "P102", "--set", "3"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.starts_with("P102 set 3 acceleration time"), "{text}");
    assert!(text.contains("10.00 s (raw 1000)"), "{text}");
    // Options after the subcommand.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "uss", "read", "P102", "--set", "3", "--json", "--port", &sim.path,
        ])
        .args(["--parity", "none", "--addr", "1"])
        .output()
        .unwrap();
    assert_eq!(ok_json(&o)[0]["raw"], 1000);
}

#[test]
fn nord_array_element_p543_02_is_read_and_written_by_its_element() {
    let sim = Sim::start(&["--addr", "1"]);
    let v = ok_json(&sim.run(&["--json", "read", "P543", "--array", "2"]));
    assert_eq!(
        (&v[0]["index"], &v[0]["selector"], &v[0]["label"]),
        (
            &json!(543),
            &json!({"array": 2, "ind": "0x0100"}),
            &json!("P543 [-02]")
        )
    );
    assert_eq!(v[0]["name_en"], "bus actual value 2");
    let v = ok_json(&sim.run(&[
        "--json",
        "write",
        "P543",
        "8",
        "--array",
        "2",
        "--no-eeprom",
    ]));
    assert_eq!(
        (&v[0]["selector"]["array"], &v[0]["raw"]),
        (&json!(2), &json!(8))
    );
    // The other elements are untouched, and `read P543` shows all three.
    let v = ok_json(&sim.run(&["--json", "read", "P543"]));
    let elements: Vec<(Value, Value)> = v
        .iter()
        .map(|x| (x["selector"]["array"].clone(), x["raw"].clone()))
        .collect();
    assert_eq!(elements.len(), 3);
    assert_eq!(elements[1], (json!(2), json!(8)));
    assert_ne!(elements[0].1, json!(8));
    // P700 [-01..-03]: present fault, warning, reason for switch-on disabled.
    let v = ok_json(&sim.run(&["--json", "read", "P700"]));
    assert_eq!(v.len(), 3, "{v:?}");
    assert_eq!(v[0]["meaning"], "no fault");
}

#[test]
fn nord_refused_writes_send_nothing() {
    let sim = Sim::start(&["--addr", "1"]);
    let before = ok_json(&sim.run(&["--json", "read", "P102", "--set", "2"]))[0]["raw"].clone();
    // Checked before the port opens: a port that does not exist is never reached.
    for (args, why) in [
        (&["write", "P102", "400", "--set", "2"][..], "outside"),
        // Beyond the 16-bit word: the width's refusal, which --force cannot lift (issue 18).
        (&["write", "P102", "700", "--set", "2"], "not even --force"),
        (
            &["write", "P102", "70000", "--raw", "--set", "2"],
            "does not fit",
        ),
        (&["write", "P102", "1099511627776", "--raw"], "does not fit"),
        (&["write", "P102", "--5", "--raw"], "not an integer"),
        (&["write", "P102", "1", "--array", "1"], "no array"),
        (&["write", "P560", "1", "--set", "2"], "no parameter sets"),
        (&["write", "P543", "1"], "--array 1…3"),
        (&["write", "P543", "1", "--array", "4"], "none of them"),
        (&["read", "P9999"], "no nord parameter"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args([
                "uss",
                "--port",
                "/dev/drivectl-no-such-port",
                "--parity",
                "none",
            ])
            .args(args)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let e = stderr(&o).to_lowercase();
        assert!(e.contains(&why.to_lowercase()), "{args:?}: {e}");
        assert!(
            !e.contains("no-such-port"),
            "{args:?} reached the port: {e}"
        );
    }
    // Read-only P700: refused by the table before anything is sent.
    let o = sim.run(&["write", "P700", "5", "--array", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("read-only"), "{}", stderr(&o));
    // Forced, the drive refuses it itself (PWE2 error 1), typed.
    let o = sim.run(&["write", "P700", "5", "--array", "1", "--force"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("error 1: parameter value cannot be changed"),
        "{}",
        stderr(&o)
    );
    let after = ok_json(&sim.run(&["--json", "read", "P102", "--set", "2"]))[0]["raw"].clone();
    assert_eq!(before, after);
    // With --json the error is a JSON object too.
    let o = sim.run(&["--json", "write", "P102", "700"]);
    let e: Value = serde_json::from_str(stderr(&o).lines().last().unwrap()).unwrap();
    assert_eq!((&e["type"], &e["exit_code"]), (&json!("error"), &json!(2)));
}

#[test]
fn nord_no_eeprom_writes_are_never_held_back_and_the_wear_rule_offers_them() {
    let sim = Sim::start(&["--addr", "1"]);
    ok_json(&sim.run(&["--json", "write", "P102", "1.5"]));
    // A second EEPROM write of the same parameter within a second: refused, with the way out.
    let o = sim.run(&["write", "P102", "1.6"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // The way out is --volatile, which works in every family (--no-eeprom is its alias).
    assert!(stderr(&o).contains("--volatile"), "{}", stderr(&o));
    // RAM only (AK 14), as often as needed.
    for v in ["1.6", "1.7", "1.8"] {
        let r = ok_json(&sim.run(&["--json", "write", "P102", v, "--no-eeprom"]));
        assert_eq!(r[0]["value"].as_f64(), v.parse::<f64>().ok());
    }
}

/// Poll `status --json` until `ok` holds or `secs` pass; the last answer.
fn status_until(sim: &Sim, secs: u64, ok: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + Duration::from_secs(secs);
    loop {
        let v = ok_json(&sim.run(&["--json", "status"])).remove(0);
        if ok(&v) || Instant::now() > deadline {
            return v;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn nord_enable_at_50_percent_runs_up_and_stop_brings_it_back() {
    let sim = Sim::start(&["--addr", "1"]);
    // Power-on: switch-on disabled (B).
    let v = status_until(&sim, 0, |_| true);
    assert_eq!(v["state"], "B", "{v}");
    let o = sim.run(&["control", "enable", "--setpoint", "50"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("E operation enabled"));
    // The motor keeps running after drivectl ends, and drivectl says so.
    assert!(
        stderr(&o).contains("the motor is enabled"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("control stop"), "{}", stderr(&o));
    // Operation enabled, the frequency ramping toward 50 % (P102 2.00 s for 0 → P105).
    let first = status_until(&sim, 5, |v| v["actuals"][0]["percent"].as_f64() > Some(0.0));
    assert_eq!(first["state"], "E", "{first}");
    assert_eq!(first["actuals"][0]["unit"], "Hz");
    let reached = status_until(&sim, 5, |v| {
        v["actuals"][0]["percent"].as_f64() >= Some(49.9)
    });
    assert_eq!(reached["state"], "E", "{reached}");
    assert!(
        reached["actuals"][0]["value"].as_f64().unwrap() > 24.9,
        "50 % of 50 Hz: {reached}"
    );
    assert_eq!(reached["hex"], "0x0B37", "the manual's 5.1.2 status word");
    let o = sim.run(&["--json", "control", "stop"]);
    let v = ok_json(&o).remove(0);
    assert_eq!((&v["state"], &v["reached"]), (&json!("C"), &json!(true)));
    let v = status_until(&sim, 0, |_| true);
    assert_eq!((&v["state"], &v["hex"]), (&json!("C"), &json!("0x0B31")));
}

#[test]
fn nord_scan_finds_the_drives_on_the_line() {
    let sim = Sim::start(&["--addr", "1", "--addr", "7"]);
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "uss", "--port", &sim.path, "--parity", "none", "scan", "--json",
        ])
        .output()
        .unwrap();
    let found: Vec<Value> = ok_json(&o).iter().map(|v| v["address"].clone()).collect();
    assert_eq!(found, [json!(1), json!(7)]);
}

#[test]
fn nord_backup_and_restore_round_trip_every_set() {
    let sim = Sim::start(&["--addr", "1"]);
    let file = sim.state.with_extension("backup.json");
    let _ = std::fs::remove_file(&file);
    ok_json(&sim.run(&["--json", "write", "P102", "10", "--set", "3", "--no-eeprom"]));
    let v = ok_json(&sim.run(&["--json", "backup", "--out", file.to_str().unwrap()]));
    assert_eq!(v[0]["type"], "backup");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let entries = doc["parameters"].as_array().unwrap();
    let numbers: Vec<&str> = entries
        .iter()
        .map(|e| e["number"].as_str().unwrap())
        .collect();
    for label in [
        "P102 set 1",
        "P102 set 4",
        "P105 set 2",
        "P543 [-02]",
        "P480 [-12]",
    ] {
        assert!(numbers.contains(&label), "{label} in {numbers:?}");
    }
    assert_eq!(numbers.last(), Some(&"P560"), "P560 last");
    assert!(
        entries
            .iter()
            .any(|e| e["number"] == "P102 set 3" && e["raw"] == 1000 && e["sub"] == 0x0200)
    );
    // Change it, then restore: the dry run shows the change, the restore writes it back.
    ok_json(&sim.run(&["--json", "write", "P102", "5", "--set", "3", "--no-eeprom"]));
    let v = ok_json(&sim.run(&["--json", "restore", file.to_str().unwrap(), "--dry-run"]));
    assert!(
        v.iter()
            .any(|c| c["type"] == "change" && c["from_raw"] == 500 && c["to_raw"] == 1000),
        "{v:?}"
    );
    let o = sim.run(&["restore", file.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = ok_json(&sim.run(&["--json", "read", "P102", "--set", "3"]));
    assert_eq!(v[0]["raw"], 1000);
    // An existing file is not overwritten without being asked.
    let o = sim.run(&["backup", "--out", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let _ = std::fs::remove_file(&file);
}

#[test]
fn nord_ctrl_c_ends_watch_cleanly_and_a_stop_in_progress_says_what_was_sent() {
    let sim = Sim::start(&["--addr", "1"]);
    // Watch: Ctrl-C after two polls ends it with exit 0.
    let mut child = sim
        .command("1", &["watch", "P102", "P740", "--interval", "100"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    for _ in 0..2 {
        lines.next().unwrap().unwrap();
    }
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    for _ in lines {}
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A long braking ramp (P102 = 20 s in set 1 is also the braking time): Ctrl-C while
    // `control stop` waits for it.
    ok_json(&sim.run(&["--json", "write", "P102", "20", "--no-eeprom"]));
    assert!(
        sim.run(&["control", "enable", "--setpoint", "50"])
            .status
            .success()
    );
    status_until(&sim, 5, |v| v["actuals"][0]["percent"].as_f64() > Some(5.0));
    let child = sim
        .command("1", &["control", "stop", "--wait", "60"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(700));
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("sent shutdown 0x047E"),
        "{}",
        stderr(&o)
    );
    // The drive ramps down: still E, the frequency falling.
    let v = status_until(&sim, 0, |_| true);
    assert_eq!(v["state"], "E", "{v}");
}

/// `drivectl … | head` with the reader already gone (see tests/cli.rs): repeated until the
/// write meets the closed pipe.
fn into_closed_pipe(sim: &Sim, args: &[&str]) -> Output {
    let run = || {
        let mut child = sim
            .command("1", args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        child.wait_with_output().unwrap()
    };
    let mut o = run();
    for _ in 0..20 {
        if o.status.code() != Some(0) {
            break;
        }
        o = run();
    }
    o
}

#[test]
fn nord_a_closed_pipe_ends_quietly_but_never_hides_a_running_motor() {
    let sim = Sim::start(&["--addr", "1"]);
    let o = into_closed_pipe(&sim, &["read", "P102", "P105"]);
    assert_eq!((o.status.code(), stderr(&o)), (Some(141), String::new()));
    let o = into_closed_pipe(&sim, &["watch", "P102", "--interval", "50", "--count", "3"]);
    assert_eq!((o.status.code(), stderr(&o)), (Some(141), String::new()));
    // The status line cannot be written, the note that the motor runs still is.
    let o = into_closed_pipe(&sim, &["control", "enable", "--setpoint", "10"]);
    assert_eq!(o.status.code(), Some(141), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the motor is enabled"),
        "{}",
        stderr(&o)
    );
    assert!(sim.run(&["control", "disable"]).status.success());
}

#[test]
fn nord_output_goes_only_to_regular_files() {
    let sim = Sim::start(&["--addr", "1"]);
    let o = sim.run(&["backup", "--out", "/dev/null"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("/dev/null"), "{}", stderr(&o));
}

/// With P560 = 0 the drive keeps every write in RAM: a second write within a second wears no
/// EEPROM and is not refused as if it did (the refusal named P560 = 0 as the way out while
/// P560 was already 0). P560 itself still counts as an EEPROM write.
#[test]
fn nord_p560_zero_writes_are_ram_only_and_not_held_back_by_the_wear_rule() {
    let sim = Sim::start(&["--addr", "1"]);
    ok_json(&sim.run(&["--json", "write", "P560", "0"]));
    let first = sim.run(&["--json", "write", "P105", "40"]);
    let v = ok_json(&first);
    assert_eq!(v[0]["raw"], 400);
    assert!(
        stderr(&first).contains("P560"),
        "says the value stays in RAM: {}",
        stderr(&first)
    );
    let v = ok_json(&sim.run(&["--json", "write", "P105", "45"]));
    assert_eq!(v[0]["raw"], 450);
    // Back to RAM and EEPROM: P560 was written to EEPROM 1 s ago at most, so this write of
    // P560 is held back, and after it P105 writes count again.
    let o = sim.run(&["write", "P560", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    std::thread::sleep(Duration::from_millis(1100));
    ok_json(&sim.run(&["--json", "write", "P560", "1"]));
    ok_json(&sim.run(&["--json", "write", "P105", "50"]));
    let o = sim.run(&["write", "P105", "41"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("EEPROM"), "{}", stderr(&o));
}

/// A second Ctrl-C ends a backup at once, and still leaves no temporary file behind (it did:
/// the immediate exit skipped the clean-up of the first).
#[test]
fn nord_a_second_ctrl_c_during_a_backup_leaves_no_temporary_file() {
    // Orders take 400 ms: the first Ctrl-C waits for the exchange in progress, the second
    // comes meanwhile.
    let sim = Sim::start(&["--addr", "1", "--pkw-time", "400"]);
    let dir = std::env::temp_dir().join(format!("drivectl-nord-int-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("b.json");
    let child = sim
        .command("1", &["backup", "--out", out.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let pid = child.id().to_string();
    for _ in 0..2 {
        Command::new("kill").args(["-INT", &pid]).status().unwrap();
        std::thread::sleep(Duration::from_millis(100));
    }
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("stopped at once"), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 18: a write the table refuses is refused first, before anything is read or sent: with
/// P560 = 0 a read-only P700 [-01] got a note that it would be kept in RAM (P560 had been read)
/// before the refusal. The refusal comes before the port is opened.
#[test]
fn issue18_a_write_the_table_refuses_reads_and_sends_nothing() {
    let sim = Sim::start(&["--addr", "1"]);
    ok_json(&sim.run(&["--json", "write", "P560", "0"]));
    let o = sim.run(&["write", "P700", "1", "--array", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("read-only"), "{e}");
    assert!(!e.contains("P560"), "P560 was read first: {e}");
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "uss",
            "--port",
            "/dev/drivectl-no-such-port",
            "--parity",
            "none",
        ])
        .args(["write", "P700", "1", "--array", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("read-only"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("no-such-port"), "{}", stderr(&o));
    // A write the drive takes, with P560 = 0: said once, after the write.
    let o = sim.run(&["write", "P105", "40"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("kept in RAM"), "{}", stderr(&o));
}

/// Issue 18: a drive that does not answer is reported with the line as it is set (the message
/// said "parity (8E1)" with --parity none).
#[test]
fn issue18_no_answer_names_the_line_as_it_is_set() {
    let sim = Sim::start(&["--addr", "1"]);
    let o = sim
        .command("5", &["--baud", "9600", "--retries", "0", "read", "P102"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("9600 8N1"), "{e}");
    assert!(!e.contains("8E1"), "{e}");
}

/// Issue 18: `info` exists for USS as for every family: the table's range, default, unit,
/// resolution, sets, elements and access, the drive's values in every set or element, and for
/// an array the drive's count (AK 9); the keys of `movilink info --json` where they mean the
/// same.
#[test]
fn issue18_info_shows_the_table_and_the_drives_values() {
    let sim = Sim::start(&["--addr", "1"]);
    ok_json(&sim.run(&["--json", "write", "P102", "10", "--set", "3", "--no-eeprom"]));
    let v = ok_json(&sim.run(&["--json", "info", "P102"])).remove(0);
    assert_eq!(
        (&v["index"], &v["number"], &v["unit"]),
        (&json!(102), &json!("P102"), &json!("s"))
    );
    assert_eq!(v["range"]["max"], 32000);
    assert_eq!(v["range"]["max_value"].as_f64(), Some(320.0));
    assert_eq!(v["resolution"]["step"].as_f64(), Some(0.01));
    assert_eq!(
        (&v["access"], &v["parameter_set"], &v["array_len"]),
        (&json!("RW"), &json!(true), &Value::Null)
    );
    assert_eq!(v["limits_from"], "table");
    let values = v["current"].as_array().unwrap();
    assert_eq!(values.len(), 4, "{v}");
    assert_eq!(
        (&values[2]["label"], &values[2]["raw"]),
        (&json!("P102 set 3"), &json!(1000))
    );
    // One set; an array with the drive's count.
    let v = ok_json(&sim.run(&["--json", "info", "P102", "--set", "3"])).remove(0);
    assert_eq!(v["current"].as_array().unwrap().len(), 1);
    let v = ok_json(&sim.run(&["--json", "info", "P700"])).remove(0);
    assert_eq!(
        (&v["array_len"], &v["array_len_drive"], &v["access"]),
        (&json!(3), &json!(3), &json!("RO"))
    );
    assert_eq!(v["current"][0]["meaning"], "no fault");
    // Text, and refusals checked before the port opens as for read.
    let o = sim.run(&["info", "P543", "--array", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("P543 [-02]") && text.contains("the drive counts 3 (AK 9)"),
        "{text}"
    );
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "uss",
            "--port",
            "/dev/drivectl-no-such-port",
            "--parity",
            "none",
        ])
        .args(["info", "P543", "--array", "4"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("none of them"), "{}", stderr(&o));
}
