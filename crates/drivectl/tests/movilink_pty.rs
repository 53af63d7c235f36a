//! End to end over a real pseudo-terminal: `drivectl sim movilink --pty` on one side,
//! `drivectl movilink --port <pty>` on the other, as separate processes.

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
use std::os::unix::fs::FileTypeExt as _;
use std::process::{Command, Output, Stdio};

use common::{PtySim, ok_json};

/// `drivectl sim movilink --pty` with drives at the given addresses.
struct Sim(PtySim);

impl Deref for Sim {
    type Target = PtySim;
    fn deref(&self) -> &PtySim {
        &self.0
    }
}

impl Sim {
    fn start(addrs: &[u8]) -> Sim {
        Sim::start_with(addrs, &[])
    }

    fn start_with(addrs: &[u8], extra: &[&str]) -> Sim {
        let addrs: Vec<String> = addrs.iter().map(u8::to_string).collect();
        let mut args = vec!["sim", "movilink", "--pty", "--parity", "none"];
        args.extend_from_slice(extra);
        for a in &addrs {
            args.extend(["--addr", a.as_str()]);
        }
        Sim(PtySim::start(&args))
    }

    fn run(&self, addr: u8, args: &[&str]) -> Output {
        let a = addr.to_string();
        let mut all = vec![
            "movilink", "--port", &self.path, "--parity", "none", "--addr", &a,
        ];
        all.extend_from_slice(args);
        self.drivectl(&all)
    }
}

#[test]
fn read_write_info_over_a_pty() {
    let sim = Sim::start(&[1]);
    // P130 ramp up: default 2 s (raw 2000 ms).
    let v = ok_json(&sim.run(1, &["--json", "read", "P130"]));
    assert_eq!(v[0]["index"], 8470);
    assert_eq!(v[0]["raw"], 2000);
    assert_eq!(v[0]["value"], 2.0);
    assert_eq!(v[0]["unit"], "s");

    // Physical value in, raw value back.
    let v = ok_json(&sim.run(1, &["--json", "write", "P130", "1.5", "--volatile"]));
    assert_eq!(v[0]["raw"], 1500);
    let v = ok_json(&sim.run(1, &["--json", "write", "8470", "700", "--raw"]));
    assert_eq!(v[0]["raw"], 700);
    let v = ok_json(&sim.run(1, &["--json", "read", "0x2116"]));
    assert_eq!(v[0]["raw"], 700);

    let v = ok_json(&sim.run(1, &["--json", "info", "P000"]));
    assert_eq!(v[0]["size_index"], 11);
    assert_eq!(v[0]["conversion_index"], 66);
    assert_eq!(v[0]["access"], "RO");
}

#[test]
fn guard_and_device_errors_are_one_clear_line() {
    let sim = Sim::start(&[1]);
    // Read-only in the table: refused before anything is sent.
    let o = sim.run(1, &["write", "P000", "100"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.to_lowercase().contains("read-only"), "{err}");
    // Out of range in the table: refused with the limits.
    let o = sim.run(1, &["write", "P813", "64"]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // --force sends it; the drive answers "value too large" (0x0015).
    let o = sim.run(1, &["write", "P813", "64", "--raw", "--force"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr).to_lowercase();
    assert!(err.contains("too large"), "{err}");
    // Nobody at address 7: a timeout that says what to check.
    let o = sim.run(7, &["read", "P000"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr).to_lowercase();
    assert!(err.contains("address") && err.contains("baud"), "{err}");
}

#[test]
fn scan_finds_exactly_the_simulated_drives() {
    let sim = Sim::start(&[1, 3]);
    let v = ok_json(&sim.run(
        0,
        &[
            "--json",
            "--timeout",
            "20",
            "scan",
            "--from",
            "0",
            "--to",
            "5",
        ],
    ));
    let found: Vec<u64> = v.iter().filter_map(|o| o["address"].as_u64()).collect();
    assert_eq!(found, vec![1, 3]);
    assert!(v.iter().all(|o| o["firmware"].as_u64().unwrap_or(0) > 0));
}

#[test]
fn process_data_enable_moves_the_drive() {
    let sim = Sim::start(&[1]);
    // 3PD acyclic: control word 1 = enable, speed 5000 = 1000 1/min.
    let v = ok_json(&sim.run(
        1,
        &[
            "--json",
            "pd",
            "--type",
            "0x85",
            "--out",
            "0x0006,5000,0",
            "--count",
            "3",
            "--interval",
            "200",
        ],
    ));
    assert_eq!(v.len(), 3);
    let status = v[2]["in"][0].as_u64().unwrap();
    assert_eq!(status & 0x0001, 1, "output stage enabled: 0x{status:04X}");
    let speed = v[2]["in"][1].as_i64().unwrap();
    assert!(speed > 0, "the drive ramps up: {speed}");
}

#[test]
fn backup_and_restore_round_trip() {
    let sim = Sim::start(&[1]);
    let dir = std::env::temp_dir().join(format!("drivectl-backup-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drive1.json");
    let f = file.to_str().unwrap();
    // Change two parameters, back up, change them again, restore, and read them back.
    ok_json(&sim.run(1, &["--json", "write", "P130", "1.2", "--volatile"]));
    ok_json(&sim.run(1, &["--json", "write", "P131", "3", "--volatile"]));
    let v = ok_json(&sim.run(1, &["--json", "backup", "--out", f]));
    assert!(v[0]["parameters"].as_u64().unwrap() > 200, "{v:?}");
    let text = std::fs::read_to_string(&file).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(doc["format"], "drivebus-backup");
    assert_eq!(doc["family"], "movidrive");
    assert_eq!(doc["address"], 1);
    ok_json(&sim.run(1, &["--json", "write", "P130", "0.1", "--volatile"]));
    ok_json(&sim.run(1, &["--json", "write", "P131", "0.1", "--volatile"]));
    let v = ok_json(&sim.run(1, &["--json", "restore", f]));
    assert_eq!(v.last().unwrap()["mismatches"], 0);
    // Exactly the two changed parameters were written, on the one write path: they are in
    // the EEPROM-wear log.
    assert_eq!(v.last().unwrap()["written"], 2, "{v:?}");
    let log: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(sim.state.join("eeprom-writes.json")).unwrap(),
    )
    .unwrap();
    for index in ["8470", "8471"] {
        assert!(
            log.as_object()
                .unwrap()
                .keys()
                .any(|k| k.ends_with(&format!("movidrive {index} 0"))),
            "{log}"
        );
    }
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        1200
    );
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P131"]))[0]["raw"],
        3000
    );
    // A backup of the first drivectl versions (MOVILINK-only format) is still restored,
    // including an unsigned value above 2^31 that format stored sign-extended (P221 =
    // 3 000 000 000 as -1 294 967 296).
    ok_json(&sim.run(1, &["--json", "write", "P130", "0.1", "--volatile"]));
    let legacy = serde_json::json!({
        "format": "drivebus-movilink-backup", "version": 1, "address": 1,
        "parameters": [
            {"index": 8470, "number": "P130", "raw": 1200, "writable": true},
            {"index": 8502, "number": "P221", "raw": -1_294_967_296_i64, "writable": true},
        ],
    });
    std::fs::write(&file, legacy.to_string()).unwrap();
    let v = ok_json(&sim.run(1, &["--json", "restore", f]));
    assert_eq!(v.last().unwrap()["mismatches"], 0);
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        1200
    );
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P221"]))[0]["raw"],
        3_000_000_000_u64
    );
    // A corrupt file is refused before anything is written.
    std::fs::write(&file, text.replace("\"raw\": 1200", "\"raw\": 99999999")).unwrap();
    let o = sim.run(1, &["restore", f]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        1200
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn decode_explains_the_manual_example() {
    // Ch. 4.3 application example, acyclic 3PD (see docs/errata.md about "type 5").
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "decode",
            "movilink",
            "02 01 85 00 06 20 00 0B B8 13",
            "--json",
        ])
        .output()
        .unwrap();
    let v = ok_json(&o);
    assert_eq!(v[0]["valid"], true);
    assert_eq!(v[0]["direction"], "request");
    let fields = v[0]["fields"].as_array().unwrap();
    assert_eq!(fields.len(), 7);
    assert_eq!(fields[3]["name"], "PO1");
    assert_eq!(fields[3]["value"], 6);
    assert!(fields[3]["text"].as_str().unwrap().contains("enable"));
    assert_eq!(v[0]["process_data"], serde_json::json!([6, 0x2000, 0x0BB8]));
    // Bild 20: BCC 0x57 of 02 01 05 0006 3A98 01F4; a wrong BCC is named with the right one.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["decode", "movilink", "020105 0006 3A98 01F4 58"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stdout).contains("expected 0x57"));
}

#[test]
fn eeprom_writes_in_quick_succession_are_refused_across_runs() {
    let sim = Sim::start(&[1]);
    ok_json(&sim.run(1, &["--json", "write", "P131", "1.0"]));
    // A second non-volatile write of the same parameter within a second, from a new process.
    let o = sim.run(1, &["write", "P131", "1.1"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("EEPROM") && err.contains("--volatile"),
        "{err}"
    );
    // The volatile service is never rate-limited, and the refused value was not written.
    let v = ok_json(&sim.run(1, &["--json", "write", "P131", "1.2", "--volatile"]));
    assert_eq!(v[0]["raw"], 1200);
    // Another parameter is not affected.
    ok_json(&sim.run(1, &["--json", "write", "P130", "1.0"]));
}

#[test]
fn group_and_broadcast_writes_reach_every_drive_unanswered() {
    let sim = Sim::start(&[1, 3]);
    // Put both drives into group 101 (P811, RAM only; a link setting, so --yes).
    for a in [1, 3] {
        ok_json(&sim.run(
            a,
            &["--json", "write", "P811", "101", "--volatile", "--yes"],
        ));
    }
    let v = ok_json(&sim.run(101, &["--json", "write", "P130", "0.8", "--volatile"]));
    assert_eq!(v[0]["answered"], false);
    let v = ok_json(&sim.run(255, &["--json", "write", "P131", "0.9", "--volatile"]));
    assert_eq!(v[0]["answered"], false);
    for a in [1, 3] {
        assert_eq!(
            ok_json(&sim.run(a, &["--json", "read", "P130"]))[0]["raw"],
            800,
            "drive {a}"
        );
        assert_eq!(
            ok_json(&sim.run(a, &["--json", "read", "P131"]))[0]["raw"],
            900,
            "drive {a}"
        );
    }
    // Reading from a group cannot work: nobody answers by design.
    let o = sim.run(101, &["read", "P130"]);
    assert_eq!(o.status.code(), Some(2));
}

/// `--baud` reaches the master's timing: `line` shows what the driver was built with (character
/// time and start pause of 19200 8N1, not of 9600).
#[test]
fn baud_rate_reaches_the_master_timing() {
    let sim = Sim::start(&[1]);
    let line = |baud: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(["movilink", "--port", &sim.path, "--parity", "none"])
            .args(["--baud", baud, "--char-gap", "0", "--json", "line"])
            .output()
            .unwrap();
        ok_json(&o).remove(0)
    };
    let fast = line("19200");
    assert_eq!(fast["baud"], 19200);
    assert_eq!(fast["bits_per_char"], 10);
    assert_eq!(fast["char_time_us"], 520.833);
    assert_eq!(fast["start_pause_us"], 1570.0);
    assert_eq!(fast["max_gap_us"], 1570.0);
    let slow = line("9600");
    assert_eq!(slow["char_time_us"], 1041.667);
    assert_eq!(slow["start_pause_us"], 3130.0);
    // And the driver works with it.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1",
        ])
        .args(["--baud", "19200", "--json", "read", "P130"])
        .output()
        .unwrap();
    assert_eq!(ok_json(&o)[0]["raw"], 2000);
}

/// `--baud` reaches the simulated drive's timing: it answers a start pause after a request,
/// which at 19200 8N1 is 1.57 ms. The smallest of ten answer delays is never below the start
/// pause (a hard bound) and, at 19200, below the smallest at 9600 (where the pause is 3.13 ms).
#[test]
fn baud_rate_reaches_the_simulator_timing() {
    use drive_transport::serial::{self, LineSettings, Parity, SerialConfig};
    use std::time::{Duration, Instant};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    // Read P130 (index 8470) from drive 1, acyclic PARAM + 0PD.
    let mut request = [0x02, 0x01, 0x86, 0x31, 0x00, 0x21, 0x16, 0, 0, 0, 0, 0];
    request[11] = request[..11].iter().fold(0, |a, b| a ^ b);
    let smallest_delay = |baud: u32| -> Duration {
        let b = baud.to_string();
        let sim = Sim::start_with(&[1], &["--baud", &b]);
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            let line = LineSettings::new(baud).with_parity(Parity::None);
            let mut port = serial::open(&SerialConfig::with_line(sim.path.clone(), line)).unwrap();
            let mut best = Duration::MAX;
            for _ in 0..10 {
                tokio::time::sleep(Duration::from_millis(20)).await;
                let t0 = Instant::now();
                port.write_all(&request).await.unwrap();
                let mut answer = [0u8; 12];
                let n = port.read(&mut answer).await.unwrap();
                let delay = t0.elapsed();
                assert!(n > 0 && answer[0] == 0x1D, "{:?}", &answer[..n]);
                if n < 12 {
                    port.read_exact(&mut answer[n..]).await.unwrap();
                }
                best = best.min(delay);
            }
            best
        })
    };
    let fast = smallest_delay(19200);
    let slow = smallest_delay(9600);
    assert!(fast >= Duration::from_micros(1570), "{fast:?}");
    assert!(slow >= Duration::from_micros(3130), "{slow:?}");
    eprintln!("smallest answer delay: 19200 {fast:?}, 9600 {slow:?}");
    assert!(fast < slow, "19200: {fast:?}, 9600: {slow:?}");
}

/// A port that refuses a setting is named with the setting, what to try, and the drivectl
/// option that changes it (the transport library itself names no command-line option).
#[test]
fn a_refused_parity_names_the_option() {
    let sim = Sim::start(&[1]);
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "movilink", "--port", &sim.path, "--addr", "1", "read", "P000",
        ])
        .output()
        .unwrap();
    // Exit 2, as `sim movilink --pty` refuses parity (issue 7 #15): a setting to change.
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("does not support parity even"), "{err}");
    assert!(
        err.contains("pseudo-terminals accept only no parity"),
        "{err}"
    );
    assert!(err.contains("(option --parity even|odd|none)"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}

/// Restore goes through the write path's checks, with restore's own ways out: a parameter
/// written to EEPROM a moment ago is not written again (and the message names no option
/// `restore` does not have).
#[test]
fn restore_right_after_an_eeprom_write_is_refused_before_writing() {
    let sim = Sim::start(&[1]);
    let dir = std::env::temp_dir().join(format!("drivectl-restore-wear-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("one.json");
    let doc = serde_json::json!({
        "format": "drivebus-backup", "version": 1, "family": "movidrive",
        "parameters": [{"index": 8470, "raw": 1200}],
    });
    std::fs::write(&file, doc.to_string()).unwrap();
    ok_json(&sim.run(1, &["--json", "write", "P130", "0.5"]));
    let o = sim.run(1, &["restore", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("restore again in a second, or use --force"),
        "{err}"
    );
    assert!(err.contains("nothing was written"), "{err}");
    assert!(!err.contains("--volatile"), "{err}");
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        500
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `drivectl movilink …` with the given arguments only (no defaults from [`Sim::run`]).
fn drivectl(sim: &Sim, args: &[&str]) -> Output {
    sim.drivectl(args)
}

#[test]
fn issue7_line_options_before_or_after_the_subcommand() {
    let sim = Sim::start(&[1]);
    let p = sim.path.as_str();
    let before = [
        "movilink",
        "--port",
        p,
        "--parity",
        "none",
        "--baud",
        "19200",
        "--timeout",
        "70",
        "--retries",
        "5",
        "--char-gap",
        "0",
        "--addr",
        "1",
        "line",
        "--json",
    ];
    let after = [
        "movilink",
        "line",
        "--json",
        "--port",
        p,
        "--parity",
        "none",
        "--baud",
        "19200",
        "--timeout",
        "70",
        "--retries",
        "5",
        "--char-gap",
        "0",
        "--addr",
        "1",
    ];
    let mixed = [
        "movilink",
        "--baud",
        "19200",
        "--port",
        p,
        "line",
        "--parity",
        "none",
        "--timeout",
        "70",
        "--json",
        "--retries",
        "5",
        "--char-gap",
        "0",
    ];
    for args in [&before[..], &after, &mixed] {
        let v = ok_json(&drivectl(&sim, args));
        assert_eq!(v[0]["baud"], 19200, "{args:?}");
        assert_eq!(v[0]["parity"], "none", "{args:?}");
        assert_eq!(v[0]["response_timeout_ms"], 70, "{args:?}");
        assert_eq!(v[0]["retries"], 5, "{args:?}");
    }
    // A parameter read with every option after the subcommand.
    let v = ok_json(&drivectl(
        &sim,
        &[
            "movilink", "read", "P130", "--json", "--port", p, "--parity", "none", "--addr", "1",
        ],
    ));
    assert_eq!(v[0]["raw"], 2000);
}

#[test]
fn issue7_timeout_and_gap_options_have_limits_named_in_help() {
    let sim = Sim::start(&[1]);
    let p = sim.path.as_str();
    for (opt, bad) in [
        ("--timeout", "0"),
        ("--timeout", "60001"),
        ("--timeout", "18446744073709551615"),
        ("--char-gap", "10001"),
        ("--retries", "256"),
        ("--baud", "0"),
    ] {
        let o = drivectl(
            &sim,
            &[
                "movilink", "--port", p, "--parity", "none", opt, bad, "read", "P000",
            ],
        );
        assert_eq!(o.status.code(), Some(2), "{opt} {bad}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(opt), "{opt} {bad}: {err}");
    }
    let help = drivectl(&sim, &["movilink", "--help"]);
    let help = String::from_utf8_lossy(&help.stdout);
    for limit in ["1–60000", "0–255", "0–10000", "1–4000000"] {
        assert!(help.contains(limit), "{limit} in {help}");
    }
}

fn stderr_of(o: &Output) -> String {
    common::stderr(o)
}

#[test]
fn issue7_link_settings_need_yes_and_say_where_the_drive_answers() {
    let sim = Sim::start(&[1]);
    // No --yes: refused before anything is sent, with the consequence named.
    let o = sim.run(1, &["write", "P810", "5"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr_of(&o);
    assert!(err.contains("--yes") && err.contains("address 5"), "{err}");
    // 0.4 is no address: refused, not rounded to 0.
    let o = sim.run(1, &["write", "P810", "0.4", "--yes"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    let v = ok_json(&sim.run(1, &["--json", "read", "P810"]));
    assert_eq!(v[0]["raw"], 1);
    // With --yes: written, read back at the new address, and said.
    let o = sim.run(1, &["--json", "write", "P810", "5", "--yes"]);
    let v = ok_json(&o);
    assert_eq!(v[0]["raw"], 5);
    assert!(stderr_of(&o).contains("use --addr 5"), "{}", stderr_of(&o));
    let v = ok_json(&sim.run(5, &["--json", "read", "P810"]));
    assert_eq!(v[0]["raw"], 5);
    // A group write of an address would give every drive of the group the same one.
    let o = sim.run(101, &["write", "P810", "7", "--volatile"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
}

#[test]
fn issue7_values_are_parsed_strictly_and_never_rounded_silently() {
    let sim = Sim::start(&[1]);
    for (args, what) in [
        (
            &["write", "P130", "--5", "--raw", "--volatile"][..],
            "`--5`",
        ),
        (&["write", "P130", "0x-5", "--raw", "--volatile"], "`0x-5`"),
        (&["write", "P700", "2.5", "--volatile"], "it takes one of"),
        (&["write", "P700", "SERVOX", "--volatile"], "16 (SERVO)"),
        (
            &["write", "P130", "1.25", "--volatile"],
            "1.30 s (raw 1300)",
        ),
    ] {
        let o = sim.run(1, args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(stderr_of(&o).contains(what), "{args:?}: {}", stderr_of(&o));
    }
    // Nothing was written.
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        2000
    );
    // A decimal comma; rounding when asked, and said.
    let v = ok_json(&sim.run(1, &["--json", "write", "P130", "1,5", "--volatile"]));
    assert_eq!(v[0]["raw"], 1500);
    let o = sim.run(
        1,
        &["--json", "write", "P130", "1.25", "--volatile", "--round"],
    );
    assert_eq!(ok_json(&o)[0]["raw"], 1300);
    assert!(
        stderr_of(&o).contains("cannot hold 1.25 exactly"),
        "{}",
        stderr_of(&o)
    );
    // --force lifts the range of a physical value (the drive decides), not the width.
    let o = sim.run(1, &["write", "P130", "3000", "--volatile"]);
    assert_eq!(o.status.code(), Some(2));
    let o = sim.run(1, &["write", "P130", "3000", "--volatile", "--force"]);
    assert!(
        stderr_of(&o).contains("the drive refused"),
        "{}",
        stderr_of(&o)
    );
    let o = sim.run(1, &["write", "P130", "5000000", "--volatile", "--force"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr_of(&o).contains("bus width"), "{}", stderr_of(&o));
}

#[test]
fn issue7_the_eeprom_wear_rule_is_keyed_on_the_drive_and_cannot_be_switched_off() {
    let sim = Sim::start(&[1]);
    let p = sim.path.clone();
    let dir = std::env::temp_dir().join(format!("drivectl-wear-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("port-link");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&p, &link).unwrap();
    let link = link.to_str().unwrap().to_owned();
    let doubled = p.replacen("/dev/", "/dev//", 1);
    let write = |port: &str, addr: &str, value: &str| {
        drivectl(
            &sim,
            &[
                "movilink", "--port", port, "--parity", "none", "--addr", addr, "write", "P130",
                value,
            ],
        )
    };
    assert!(write(&p, "1", "1.4").status.success());
    // The same drive by a symlink, by `//`, and point-to-point: the same drive, refused.
    for (port, addr) in [
        (link.as_str(), "1"),
        (doubled.as_str(), "1"),
        (p.as_str(), "254"),
    ] {
        let o = write(port, addr, "1.5");
        assert_eq!(o.status.code(), Some(2), "{port} {addr}: {}", stderr_of(&o));
        assert!(stderr_of(&o).contains("--volatile"), "{}", stderr_of(&o));
    }
    // A state directory that cannot be written refuses (nothing sent), unless --force.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "movilink", "--port", &p, "--parity", "none", "--addr", "1", "write", "P131", "1.5",
        ])
        .env("DRIVECTL_STATE_DIR", "/proc/drivectl-cannot-be-here")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr_of(&o).contains("EEPROM-wear log") && stderr_of(&o).contains("nothing was sent"),
        "{}",
        stderr_of(&o)
    );
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P131"]))[0]["raw"],
        2000
    );
    // A damaged log refuses too, and names the file.
    std::fs::write(sim.state.join("eeprom-writes.json"), "{not json").unwrap();
    let o = sim.run(1, &["write", "P132", "1.5"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr_of(&o).contains("is damaged"), "{}", stderr_of(&o));
    // An entry from the future (a clock set back) counts as a write made now.
    let future = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_millis()
        + 3_600_000;
    let key = format!("{p} 1 movidrive 8472 0");
    std::fs::write(
        sim.state.join("eeprom-writes.json"),
        serde_json::json!({ key: future as u64 }).to_string(),
    )
    .unwrap();
    let o = sim.run(1, &["write", "P132", "1.5"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn issue7_backups_go_only_to_regular_files_checked_before_the_first_read() {
    let sim = Sim::start(&[1]);
    let dir = std::env::temp_dir().join(format!("drivectl-bk7-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let d = dir.to_str().unwrap();
    let started = std::time::Instant::now();
    for (out, why) in [
        ("/dev/full", "is a device node"),
        (d, "is a directory"),
        ("/proc/drivectl-nowhere/b.json", "nothing was read"),
    ] {
        let o = sim.run(1, &["backup", "--out", out, "--overwrite"]);
        assert_ne!(o.status.code(), Some(0), "{out}");
        assert!(stderr_of(&o).contains(why), "{out}: {}", stderr_of(&o));
    }
    // Refused at once, not after reading hundreds of parameters (about 2 s here).
    assert!(started.elapsed() < std::time::Duration::from_secs(1));
    assert!(
        std::fs::metadata("/dev/full")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    // A new file, then the same name again: not replaced without --overwrite.
    let f = dir.join("b.json");
    let fs = f.to_str().unwrap();
    ok_json(&sim.run(1, &["--json", "backup", "--out", fs]));
    let o = sim.run(1, &["backup", "--out", fs]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr_of(&o).contains("--overwrite"), "{}", stderr_of(&o));
    // Through a symlink with --overwrite: the target is written, the link stays.
    std::fs::write(&f, "old").unwrap();
    let link = dir.join("link.json");
    std::os::unix::fs::symlink(&f, &link).unwrap();
    let v = ok_json(&sim.run(
        1,
        &[
            "--json",
            "backup",
            "--out",
            link.to_str().unwrap(),
            "--overwrite",
        ],
    ));
    assert_eq!(v[0]["type"], "backup");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        std::fs::read_to_string(&f)
            .unwrap()
            .contains("drivebus-backup")
    );
    // Nothing else was left in the directory (no temporary files).
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["b.json", "link.json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn issue7_restore_dry_run_shows_old_and_new_and_the_report_is_honest() {
    let sim = Sim::start(&[1]);
    let dir = std::env::temp_dir().join(format!("drivectl-rs7-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("b.json");
    let fs = f.to_str().unwrap();
    ok_json(&sim.run(1, &["--json", "write", "P130", "1.2", "--volatile"]));
    ok_json(&sim.run(1, &["--json", "backup", "--out", fs]));
    // Nothing differs: said so, nothing written.
    let o = sim.run(1, &["restore", fs]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("already held the saved values; nothing was written"),
        "{text}"
    );
    // One change: the dry run shows it as old → new and writes nothing.
    ok_json(&sim.run(1, &["--json", "write", "P130", "0.5", "--volatile"]));
    let o = sim.run(1, &["restore", fs, "--dry-run"]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("P130 Ramp t11 up CW [s]: 0.50 s (raw 500) → 1.20 s (raw 1200)"),
        "{text}"
    );
    assert!(text.contains("1 of "), "{text}");
    let v = ok_json(&sim.run(1, &["--json", "restore", fs, "--dry-run"]));
    assert_eq!(v[0]["type"], "change");
    assert_eq!(
        (v[0]["from_raw"].as_i64(), v[0]["to_raw"].as_i64()),
        (Some(500), Some(1200))
    );
    assert_eq!(v[1]["type"], "restore");
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        500
    );
    // A file from another device type is refused.
    let text = std::fs::read_to_string(&f).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    doc["device_type"] = serde_json::json!(1);
    std::fs::write(&f, doc.to_string()).unwrap();
    let o = sim.run(1, &["restore", fs]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr_of(&o).contains("--any-device"), "{}", stderr_of(&o));
    // The value of 2^40 for a parameter: refused, nothing sent.
    doc["device_type"] =
        serde_json::from_str::<serde_json::Value>(&text).unwrap()["device_type"].clone();
    let list = doc["parameters"].as_array_mut().unwrap();
    let e = list.iter_mut().find(|e| e["index"] == 8470).unwrap();
    e["raw"] = serde_json::json!(1_099_511_627_776_i64);
    std::fs::write(&f, format!("\u{feff}{doc}")).unwrap();
    let o = sim.run(1, &["restore", fs]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr_of(&o).contains("1099511627776"), "{}", stderr_of(&o));
    assert_eq!(
        ok_json(&sim.run(1, &["--json", "read", "P130"]))[0]["raw"],
        500
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The speed in 1/min the drive reports (P000).
fn speed(sim: &Sim) -> f64 {
    ok_json(&sim.run(1, &["--json", "read", "P000"]))[0]["value"]
        .as_f64()
        .unwrap()
}

#[test]
fn issue7_pd_stops_the_drive_at_its_end_unless_asked_not_to() {
    let sim = Sim::start(&[1]);
    let enable = [
        "pd",
        "--out",
        "0x0006,5000,0",
        "--count",
        "5",
        "--interval",
        "100",
    ];
    // --keep-running: left running at 1000 1/min, and said so.
    let mut args = enable.to_vec();
    args.push("--keep-running");
    let o = sim.run(1, &args);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let err = stderr_of(&o);
    // The simulated drive has no RS-485 timeout (P812 = 0): warned.
    assert!(err.contains("P812 is 0"), "{err}");
    assert!(err.contains("--keep-running"), "{err}");
    std::thread::sleep(std::time::Duration::from_millis(700));
    assert!(speed(&sim) > 900.0);
    // A normal end: the stop is sent and reported.
    let o = sim.run(1, &enable);
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(
        stderr_of(&o).contains("sent stop (control word 0x0002)"),
        "{}",
        stderr_of(&o)
    );
    assert!(stderr_of(&o).contains("no enable"), "{}", stderr_of(&o));
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(speed(&sim) < 900.0, "decelerating on the ramp");
    // `--stop inhibit`.
    let mut args = enable.to_vec();
    args.extend(["--stop", "inhibit"]);
    let o = sim.run(1, &args);
    assert!(
        stderr_of(&o).contains("sent controller inhibit (control word 0x0001)"),
        "{}",
        stderr_of(&o)
    );
}

#[test]
fn issue7_pd_stops_the_drive_on_ctrl_c_and_on_a_closed_pipe() {
    let sim = Sim::start(&[1]);
    let args = [
        "movilink",
        "--port",
        &sim.path,
        "--parity",
        "none",
        "--addr",
        "1",
        "pd",
        "--type",
        "0x05",
        "--out",
        "0x0006,5000,0",
        "--count",
        "100000",
        "--interval",
        "50",
    ];
    // Ctrl-C after a few exchanges.
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    for _ in 0..3 {
        lines.next().unwrap().unwrap();
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    for _ in lines {}
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0));
    assert!(stderr_of(&o).contains("interrupted"), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("sent stop"), "{}", stderr_of(&o));
    // `--count 0` runs until Ctrl-C, which also cuts a long pause short.
    let endless = [
        "movilink",
        "--port",
        &sim.path,
        "--parity",
        "none",
        "--addr",
        "1",
        "pd",
        "--out",
        "0x0006,5000,0",
        "--count",
        "0",
        "--interval",
        "60000",
    ];
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(endless)
        .env("DRIVECTL_STATE_DIR", &sim.state)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    lines.next().unwrap().unwrap();
    let asked = std::time::Instant::now();
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    for _ in lines {}
    let o = child.wait_with_output().unwrap();
    assert!(asked.elapsed() < std::time::Duration::from_secs(5));
    assert!(stderr_of(&o).contains("sent stop"), "{}", stderr_of(&o));
    // `pd … | head -2`: the pipe closes, the stop is still sent.
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
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
    assert_eq!(o.status.code(), Some(141), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("sent stop"), "{}", stderr_of(&o));
}

/// Issue 7 #13: the status and fault words P010–P013 are decoded, as `pd` decodes status
/// word 1, in text and JSON.
#[test]
fn read_decodes_status_and_fault_words() {
    let sim = Sim::start(&[1]);
    // One parameter per call: this test is about the decoding, not about several in one call.
    let o = sim.run(1, &["read", "P012"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains(": no fault (raw "), "{text}");

    let v = ok_json(&sim.run(1, &["--json", "read", "P010"]));
    let status = v[0]["raw"].as_u64().unwrap() & 0xFFFF;
    assert_eq!(status & 0x20, 0, "no fault after power-on: 0x{status:04X}");
    let d = &v[0]["decoded"];
    assert_eq!(d["status_word"], format!("0x{status:04X}"));
    assert_eq!(d["fault"], serde_json::Value::Null);
    assert_eq!(d["unit_status"]["code"], status >> 8);
    let meaning = v[0]["meaning"].as_str().unwrap();
    assert!(
        meaning.contains("ready") && meaning.contains(&format!("unit status {}", status >> 8)),
        "{meaning}"
    );
    let v = ok_json(&sim.run(1, &["--json", "read", "P012"]));
    assert_eq!(v[0]["meaning"], "no fault");
    let v = ok_json(&sim.run(1, &["--json", "read", "P013"]));
    assert_eq!(v[0]["meaning"], "parameter set 1");
}

/// Issue 7 #20: several parameters in one call, in the order given; a refusal is reported
/// for its parameter and the others are still read; a bad name fails before anything is read.
#[test]
fn read_takes_several_parameters() {
    let sim = Sim::start(&[1]);
    let v = ok_json(&sim.run(1, &["--json", "read", "P130", "P000", "8318", "P010"]));
    let numbers: Vec<&str> = v.iter().map(|o| o["number"].as_str().unwrap()).collect();
    assert_eq!(numbers, ["P130", "P000", "P000", "P010"]);
    assert_eq!(v[0]["raw"], 2000);

    // Index 9999 is not in the drive: refused, and P130 after it is still read.
    let o = sim.run(1, &["--json", "read", "P000", "9999", "P130"]);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    let read: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(
        (read.len(), &read[1]["number"]),
        (2, &serde_json::json!("P130"))
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("index 9999: the drive refused"), "{err}");
    assert!(
        err.lines()
            .last()
            .unwrap()
            .contains("1 of 3 parameters could not be read: index 9999"),
        "{err}"
    );

    // A name that does not resolve: exit 2, nothing read.
    let o = sim.run(1, &["read", "P000", "P9999"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("`P9999`"));
}

/// Issue 7 #19: `watch` polls several parameters; piped, it writes one JSON object per poll
/// (`"type": "sample"`, an RFC 3339 UTC time with milliseconds) or CSV with a header row.
#[test]
fn watch_polls_with_timestamps_as_json_and_csv() {
    let sim = Sim::start(&[1]);
    let v = ok_json(&sim.run(
        1,
        &[
            "--json",
            "watch",
            "P000",
            "P130",
            "--interval",
            "100",
            "--count",
            "3",
        ],
    ));
    assert_eq!(v.len(), 3);
    let mut times = Vec::new();
    for s in &v {
        assert_eq!(s["type"], "sample");
        let t = s["time"].as_str().unwrap().to_owned();
        let b = t.as_bytes();
        assert!(
            t.len() == 24 && b[10] == b'T' && b[19] == b'.' && t.ends_with('Z'),
            "{t}"
        );
        assert_eq!(s["values"][0]["number"], "P000");
        assert_eq!(s["values"][1]["raw"], 2000);
        times.push(t);
    }
    assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");

    let o = sim.run(
        1,
        &[
            "watch",
            "P000",
            "P130",
            "--interval",
            "100",
            "--count",
            "3",
            "--csv",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows.len(), 4, "{out}");
    assert_eq!(rows[0], "time,P000 Speed [1/min],P130 Ramp t11 up CW [s]");
    for r in &rows[1..] {
        let f: Vec<&str> = r.split(',').collect();
        assert_eq!((f.len(), f[2]), (3, "2.00"), "{r}");
    }
}

/// Issue 7 #22: scan names the device type only where a manual codes P070 (none does, so the
/// name is null and the text says why), and shows the rated current (P071) the manual gives.
#[test]
fn issue7_22_scan_names_no_device_type_it_cannot_and_shows_the_rated_current() {
    let sim = Sim::start(&[2]);
    let scan = ["--timeout", "20", "scan", "--from", "1", "--to", "3"];
    let json: Vec<&str> = ["--json"].iter().chain(scan.iter()).copied().collect();
    let v = ok_json(&sim.run(0, &json));
    assert_eq!(v.len(), 1, "{v:?}");
    assert_eq!(v[0]["address"], 2);
    assert_eq!(v[0]["device_type"], 60_001_553);
    assert!(v[0]["device_type_name"].is_null(), "{v:?}");
    assert_eq!(v[0]["rated_current_a"], 4.0);
    let o = sim.run(0, &scan);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains(
            "address  2: device type 60001553 (no designation: the manual does not code P070), \
             rated current 4 A, firmware 822 609 7.11"
        ),
        "{text}"
    );
}

use common::stderr_json;

#[test]
fn issue7_json_is_one_schema_per_kind_and_errors_are_json_too() {
    let sim = Sim::start(&[1]);
    // `info` speaks as `params` does: unit, raw and physical range and default.
    let info = &ok_json(&sim.run(1, &["--json", "info", "P130"]))[0];
    let params = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["params", "movidrive", "show", "P130", "--json"])
        .output()
        .unwrap();
    let params = &ok_json(&params)[0];
    for key in [
        "index",
        "number",
        "name_de",
        "name_en",
        "unit",
        "default",
        "default_value",
    ] {
        assert_eq!(info[key], params[key], "{key}");
    }
    for key in ["min", "max", "min_value", "max_value"] {
        assert_eq!(info["range"][key], params["range"][key], "range.{key}");
    }
    // pd: a kind, a timestamp, the PDU type as hex with its name.
    let o = sim.run(1, &["--json", "pd", "--out", "0,0,0"]);
    let pd = &ok_json(&o)[0];
    assert_eq!(pd["type"], "pd");
    assert_eq!(pd["pdu_type"], "0x85");
    assert_eq!(pd["pdu_name"], "3PD acyclic");
    assert!(pd["time"].as_str().unwrap().ends_with('Z'), "{pd}");
    // Its warnings and notes on stderr are JSON objects as well.
    let msgs = stderr_json(&o);
    assert!(msgs.iter().any(|m| m["type"] == "warning"), "{msgs:?}");
    assert!(msgs.iter().any(|m| m["type"] == "note"), "{msgs:?}");
    // An error of the command, and one of the command line, as JSON on stderr.
    let o = sim.run(1, &["--json", "read", "P9999"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr_json(&o);
    assert_eq!(
        (e.len(), &e[0]["type"], &e[0]["exit_code"]),
        (1, &"error".into(), &2.into())
    );
    let o = sim.run(1, &["--json", "--timeout", "0", "read", "P000"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr_json(&o);
    assert!(
        e[0]["message"].as_str().unwrap().contains("--timeout"),
        "{e:?}"
    );
    // Without --json, errors stay one line of text.
    let o = sim.run(1, &["read", "P9999"]);
    assert!(
        stderr_of(&o).starts_with("drivectl: no movidrive parameter"),
        "{}",
        stderr_of(&o)
    );
}
