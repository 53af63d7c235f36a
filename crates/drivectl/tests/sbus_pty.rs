//! End to end over a real pseudo-terminal: `drivectl sim sbus --pty` (simulated MOVIDRIVEs on a
//! virtual CAN bus behind a simulated slcan adapter) on one side, `drivectl sbus --iface
//! slcan:<pty>` on the other, as separate processes.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::ops::Deref;
use std::process::Output;

use common::{PtySim, ok_json, stderr};

/// `drivectl sim sbus --pty --addr 1 --addr 2 …`.
struct Sim(PtySim);

impl Deref for Sim {
    type Target = PtySim;
    fn deref(&self) -> &PtySim {
        &self.0
    }
}

impl Sim {
    fn start(extra: &[&str]) -> Sim {
        let mut args = vec!["sim", "sbus", "--pty", "--addr", "1", "--addr", "2"];
        args.extend_from_slice(extra);
        Sim(PtySim::start(&args))
    }

    /// `drivectl sbus --iface slcan:<pty> --addr <addr> <args>`.
    fn at(&self, addr: &str, args: &[&str]) -> Output {
        let iface = format!("slcan:{}", self.path);
        let mut all = vec!["sbus", "--iface", &iface, "--addr", addr];
        all.extend_from_slice(args);
        self.drivectl(&all)
    }

    fn run(&self, args: &[&str]) -> Output {
        self.at("1", args)
    }
}

#[test]
fn read_json_has_index_and_raw_in_both_handshake_modes() {
    let sim = Sim::start(&[]);
    for mode in ["async", "sync"] {
        let v = ok_json(&sim.run(&["--handshake", mode, "read", "8318", "P130", "--json"]));
        assert_eq!(v[0]["index"], 8318, "{mode}");
        assert_eq!(v[0]["raw"], 0, "{mode}: a drive at rest");
        assert_eq!(v[1]["index"], 8470, "{mode}");
        assert!(v[1]["raw"].as_i64().unwrap() > 0, "{mode}: {}", v[1]);
    }
}

#[test]
fn write_volatile_then_read_back_on_the_other_drive_too() {
    let sim = Sim::start(&[]);
    let w = sim.run(&["write", "P130", "0.7", "--volatile", "--json"]);
    let v = ok_json(&w);
    assert_eq!(v[0]["raw"], 700, "{}", stderr(&w));
    assert_eq!(
        ok_json(&sim.run(&["read", "P130", "--json"]))[0]["raw"],
        700
    );
    // Drive 2 is another drive: untouched.
    assert_ne!(
        ok_json(&sim.at("2", &["read", "P130", "--json"]))[0]["raw"],
        700
    );
    // A group write reaches both (group 0 is the factory P814), unanswered.
    let g = sim.run(&[
        "write",
        "P130",
        "0.9",
        "--volatile",
        "--group",
        "0",
        "--json",
    ]);
    let v = ok_json(&g);
    assert_eq!(v[0]["answered"], false);
    for a in ["1", "2"] {
        assert_eq!(
            ok_json(&sim.at(a, &["read", "P130", "--json"]))[0]["raw"],
            900,
            "drive {a}"
        );
    }
}

#[test]
fn scan_finds_both_drives() {
    let sim = Sim::start(&[]);
    let v = ok_json(&sim.run(&["scan", "--json"]));
    let found: Vec<i64> = v.iter().map(|x| x["address"].as_i64().unwrap()).collect();
    assert_eq!(found, [1, 2]);
    assert!(v[0]["device_type"].as_u64().unwrap() > 0);
}

#[test]
fn info_reads_the_limits() {
    let sim = Sim::start(&[]);
    let v = ok_json(&sim.run(&["info", "P130", "--json"]));
    assert_eq!(v[0]["index"], 8470);
    assert!(v[0]["range"]["max"].as_i64().unwrap() > v[0]["range"]["min"].as_i64().unwrap());
}

#[test]
fn pd_enables_the_drive_and_stops_it_at_the_end() {
    let sim = Sim::start(&[]);
    let o = sim.run(&[
        "pd",
        "--out",
        "0x0006,5000,0",
        "--count",
        "5",
        "--interval",
        "20",
        "--json",
    ]);
    let v = ok_json(&o);
    assert_eq!(v.len(), 5);
    assert_eq!(v[0]["out"], serde_json::json!([6, 5000, 0]));
    let err = stderr(&o);
    assert!(err.contains("at the end"), "{err}");
    // Synchronous process data: PO sync and SYNC.
    let s = sim.run(&[
        "pd",
        "--out",
        "0x0006,5000,0",
        "--count",
        "3",
        "--sync",
        "--json",
    ]);
    let v = ok_json(&s);
    assert_eq!(v.len(), 3);
    assert_eq!(v[0]["sync"], true);
}

#[test]
fn sync_counts_its_telegrams() {
    let sim = Sim::start(&[]);
    let v = ok_json(&sim.run(&["sync", "--period", "5", "--count", "20", "--json"]));
    assert_eq!(v[0]["sent"], 20);
    let ms = v[0]["elapsed_ms"].as_u64().unwrap();
    assert!((90..2000).contains(&ms), "{ms} ms for 20 SYNC at 5 ms");
}

#[test]
fn backup_and_dry_run_restore() {
    let sim = Sim::start(&[]);
    let dir = std::env::temp_dir().join(format!("sbus-backup-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drive1.json");
    let b = sim.run(&["backup", "--out", file.to_str().unwrap()]);
    assert!(b.status.success(), "{}", stderr(&b));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("8470"), "the backup holds P130");
    let r = sim.run(&["restore", file.to_str().unwrap(), "--dry-run"]);
    assert!(r.status.success(), "{}", stderr(&r));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_is_refused_before_the_bus_is_touched() {
    let sim = Sim::start(&[]);
    for (args, needle) in [
        (vec!["--addr", "64", "read", "P000"], "64"),
        (vec!["pd", "--out", "1,2"], "three words"),
        (vec!["pd", "--out", "1,2,70000"], "16-bit"),
        (
            vec!["write", "P130", "1099511627776", "--raw"],
            "1099511627776",
        ),
        (vec!["read", "P9999"], "P9999"),
        (vec!["--handshake", "fast", "read", "P000"], "fast"),
    ] {
        let iface = format!("slcan:{}", sim.path);
        let mut all = vec!["sbus", "--iface", &iface];
        all.extend_from_slice(&args);
        let o = sim.drivectl(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    // A drive that is not there: a timeout naming the address, exit 1, quickly.
    let o = sim.at("9", &["--timeout", "10", "--retries", "0", "read", "P000"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("SBus address 9"), "{}", stderr(&o));
}

#[test]
fn a_wrong_bit_rate_is_named() {
    let sim = Sim::start(&["--bitrate", "250k"]);
    // The adapter is opened at 500k (the default) on a 250k bus.
    let o = sim.run(&["--timeout", "20", "--retries", "0", "read", "P000"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let ok = sim.drivectl(&[
        "sbus",
        "--iface",
        &format!("slcan:{}@250k", sim.path),
        "--addr",
        "1",
        "read",
        "P000",
    ]);
    assert!(ok.status.success(), "{}", stderr(&ok));
}

#[test]
fn watch_polls_and_capture_logs_every_frame() {
    let sim = Sim::start(&[]);
    let v = ok_json(&sim.run(&[
        "watch",
        "P000",
        "P130",
        "--interval",
        "50",
        "--count",
        "3",
        "--json",
    ]));
    assert_eq!(v.len(), 3, "{v:?}");
    let dir = std::env::temp_dir().join(format!("sbus-capture-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("session.log");
    let log_s = log.to_str().unwrap();
    let o = sim.run(&["--capture", log_s, "read", "P000", "P130"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&log).unwrap();
    // Two requests (8a+515 = 523 = 20Bh) and two answers (524 = 20Ch).
    assert_eq!(text.lines().count(), 4, "{text}");
    assert!(text.lines().all(|l| l.contains(" slcan0 ")), "{text}");
    assert_eq!(text.matches("20B#31").count(), 2);
    assert_eq!(text.matches("20C#31").count(), 2);
    // The log decodes, and is not replaced unasked.
    let d = sim.drivectl(&["decode", "sbus", "--log", log_s, "--json"]);
    assert_eq!(ok_json(&d).len(), 4);
    let again = sim.run(&["--capture", log_s, "read", "P000"]);
    assert_eq!(again.status.code(), Some(2), "{}", stderr(&again));
    assert_eq!(std::fs::read_to_string(&log).unwrap(), text);
    // A failed session is captured too: the retries to a missing drive.
    let missing = dir.join("missing.log");
    let o = sim.at(
        "9",
        &[
            "--timeout",
            "5",
            "--retries",
            "1",
            "--capture",
            missing.to_str().unwrap(),
            "read",
            "P000",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(&missing).unwrap().lines().count(),
        2
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A long session's capture is streamed to its temporary file as the frames come (memory stays
/// bounded), and Ctrl-C still ends it with the stop sent and the log in place.
#[test]
fn a_capture_is_streamed_and_kept_after_ctrl_c() {
    let sim = Sim::start(&[]);
    let dir = std::env::temp_dir().join(format!("sbus-stream-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("long.log");
    let iface = format!("slcan:{}", sim.path);
    let child = sim
        .command()
        .args(["sbus", "--iface", &iface, "--addr", "1", "--capture"])
        .arg(&log)
        .args([
            "pd",
            "--out",
            "0x0006,1000,0",
            "--count",
            "0",
            "--interval",
            "10",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The temporary file next to the log fills while the session runs.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let streamed = loop {
        let tmp: u64 = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .map(|e| e.metadata().unwrap().len())
            .sum();
        if tmp > 2000 || std::time::Instant::now() > deadline {
            break tmp;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert!(
        streamed > 2000,
        "the capture is not written as it goes: {streamed} bytes"
    );
    assert!(!log.exists(), "the log takes its name only at the end");
    let status = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("sent stop"), "{err}");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.lines().count() > 20, "{}", text.lines().count());
    // No temporary file left behind.
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
