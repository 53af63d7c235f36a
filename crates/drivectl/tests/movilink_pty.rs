//! End to end over a real pseudo-terminal: `drivectl sim movilink --pty` on one side,
//! `drivectl movilink --port <pty>` on the other, as separate processes.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};

struct Sim {
    child: Child,
    path: String,
    state: std::path::PathBuf,
}

impl Sim {
    fn start(addrs: &[u8]) -> Sim {
        Sim::start_with(addrs, &[])
    }

    fn start_with(addrs: &[u8], extra: &[&str]) -> Sim {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_drivectl"));
        cmd.args(["sim", "movilink", "--pty", "--parity", "none"]);
        cmd.args(extra);
        for a in addrs {
            cmd.args(["--addr", &a.to_string()]);
        }
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("sim starts");
        let stdout = child.stdout.take().expect("stdout");
        let mut line = String::new();
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("sim prints its pty path");
        let path = line.trim().to_owned();
        assert!(
            path.starts_with("/dev/"),
            "first line is the pty path: {path:?}"
        );
        // Each simulated drive gets its own EEPROM-write log.
        let state = std::env::temp_dir().join(format!("drivectl-state-{}", path.replace('/', "_")));
        let _ = std::fs::remove_dir_all(&state);
        Sim { child, path, state }
    }

    fn run(&self, addr: u8, args: &[&str]) -> Output {
        let a = addr.to_string();
        let mut all = vec![
            "movilink", "--port", &self.path, "--parity", "none", "--addr", &a,
        ];
        all.extend_from_slice(args);
        Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(&all)
            .env("DRIVECTL_STATE_DIR", &self.state)
            .output()
            .expect("drivectl runs")
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.state);
    }
}

fn ok_json(o: &Output) -> Vec<serde_json::Value> {
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect()
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
    assert_eq!(fields[3]["field"], "PO1");
    assert!(fields[3]["meaning"].as_str().unwrap().contains("enable"));
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
    // Put both drives into group 101 (P811, RAM only).
    for a in [1, 3] {
        ok_json(&sim.run(a, &["--json", "write", "P811", "101", "--volatile"]));
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
    assert_eq!(o.status.code(), Some(1));
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
