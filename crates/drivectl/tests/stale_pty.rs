//! Issue 18 A1, end to end over real pseudo-terminals: an answer another program left in the
//! port (a master killed after its request, a script that wrote a request and closed the port)
//! is never taken as the answer to drivectl's request, for every serial family, whether the
//! stale answer already sits in the port when drivectl opens it or arrives just after.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::process::{Command, Output, Stdio};
use std::time::Duration;

use common::{PtySim, ok_json, signal, stderr};

/// A program that is not drivectl: it opens the pty (without drivectl's exclusive mode, so
/// drivectl can open it meanwhile), writes `frame` and closes it without reading, so the
/// simulator's answer stays in the pty for the next program. The simulator made the pty raw.
struct Writer(std::fs::File);

impl Writer {
    fn open(path: &str) -> Writer {
        Writer(
            std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(path)
                .unwrap(),
        )
    }

    fn write(&mut self, frame: &[u8]) {
        use std::io::Write;
        self.0.write_all(frame).unwrap();
    }

    /// Close the port without reading.
    fn close(self) {
        drop(self.0);
    }
}

/// Leave `frame` in the pty at `path` and wait `settle` for the simulator's answer to sit in
/// the port's input.
fn leave(path: &str, frame: &[u8], settle: Duration) {
    let mut w = Writer::open(path);
    w.write(frame);
    w.close();
    std::thread::sleep(settle);
}

/// The notes drivectl printed about stale bytes (text, or the message of a JSON note).
fn stale_notes(o: &Output) -> Vec<String> {
    stderr(o)
        .lines()
        .filter_map(|l| match serde_json::from_str::<serde_json::Value>(l) {
            Ok(v) if v["type"] == "note" => {
                Some(format!("drivectl: note: {}", v["message"].as_str()?))
            }
            Ok(_) => None,
            Err(_) => Some(l.to_owned()),
        })
        .filter(|l| l.starts_with("drivectl: note: discarded"))
        .collect()
}

/// The number of bytes the notes say were discarded.
fn discarded(o: &Output) -> u64 {
    stale_notes(o)
        .iter()
        .filter_map(|l| {
            l.strip_prefix("drivectl: note: discarded ")?
                .split(' ')
                .next()?
                .parse::<u64>()
                .ok()
        })
        .sum()
}

// ---------------------------------------------------------------------------------------------
// Bonfiglioli Modbus RTU: an FC 3 answer carries only a byte count and the value.

fn crc16(bytes: &[u8]) -> [u8; 2] {
    let mut crc: u16 = 0xFFFF;
    for &b in bytes {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc.to_le_bytes()
}

/// An RTU FC 3 request for one register of parameter `param` (data set 0) from drive 1.
fn fc3(param: u16) -> Vec<u8> {
    let [hi, lo] = param.to_be_bytes();
    let mut f = vec![0x01, 0x03, hi, lo, 0x00, 0x01];
    let crc = crc16(&f);
    f.extend_from_slice(&crc);
    f
}

fn bonfiglioli_sim() -> PtySim {
    PtySim::start(&[
        "sim",
        "bonfiglioli",
        "--pty",
        "--parity",
        "none",
        "--mode",
        "rtu",
        "--variant",
        "act",
    ])
}

fn bonfiglioli(sim: &PtySim, args: &[&str]) -> Command {
    let mut c = sim.command();
    c.args(["bonfiglioli", "--port", &sim.path, "--parity", "none"])
        .args(args);
    c
}

fn bonfiglioli_raw(sim: &PtySim, param: &str, extra: &[&str]) -> (Output, Option<i64>) {
    let o = bonfiglioli(sim, &["--json", "read", param])
        .args(extra)
        .output()
        .unwrap();
    let raw = o
        .status
        .success()
        .then(|| ok_json(&o)[0]["raw"].as_i64())
        .flatten();
    (o, raw)
}

/// The technician's report: an FC 3 answer for 372 left in the port was printed as 411's
/// value, exit 0.
#[test]
fn issue18_a_stale_modbus_answer_in_the_port_is_not_taken_as_the_value() {
    let sim = bonfiglioli_sim();
    let (_, v372) = bonfiglioli_raw(&sim, "372", &[]);
    let (_, v411) = bonfiglioli_raw(&sim, "411", &[]);
    let (v372, v411) = (v372.unwrap(), v411.unwrap());
    assert_ne!(v372, v411, "the test needs two different values");
    for retries in ["2", "0"] {
        leave(&sim.path, &fc3(372), Duration::from_millis(100));
        let (o, raw) = bonfiglioli_raw(&sim, "411", &["--retries", retries]);
        assert_eq!(raw, Some(v411), "--retries {retries}: {}", stderr(&o));
        // The FC 3 answer: address, function, byte count, two data bytes, CRC.
        assert_eq!(discarded(&o), 7, "{}", stderr(&o));
    }
    // The text output too: the note on stderr, the value on stdout.
    leave(&sim.path, &fc3(372), Duration::from_millis(100));
    let o = bonfiglioli(&sim, &["read", "411"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains(&format!("raw {v411})")), "{out}");
    assert_eq!(
        stale_notes(&o),
        [
            "drivectl: note: discarded 7 bytes an earlier program left in the port when it was \
          opened; they were not taken as an answer"
        ],
        "{}",
        stderr(&o)
    );
}

/// The other master's request was sent a moment before drivectl started: its answer arrives
/// while drivectl starts, opens the port or sends its own request. Whenever it comes, drivectl
/// prints 411's value: the answer was in the port when it was opened (discarded then), or
/// arrived before drivectl's request had left (discarded then), or the drive heard drivectl's
/// request before it answered the other one (and dropped that answer, as a drive does).
#[test]
fn issue18_a_modbus_answer_arriving_just_after_the_port_was_opened_is_not_taken() {
    let sim = bonfiglioli_sim();
    let (_, v372) = bonfiglioli_raw(&sim, "372", &[]);
    let (_, v411) = bonfiglioli_raw(&sim, "411", &[]);
    let (v372, v411) = (v372.unwrap(), v411.unwrap());
    assert_ne!(v372, v411);
    let (mut at_open, mut later) = (0, 0);
    for delay_ms in [0u64, 1, 2, 3, 4, 5, 6, 8, 10, 12, 14, 16, 20] {
        let mut w = Writer::open(&sim.path);
        w.write(&fc3(372));
        std::thread::sleep(Duration::from_millis(delay_ms));
        let o = bonfiglioli(&sim, &["--json", "read", "411"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        w.close();
        let raw = ok_json(&o)[0]["raw"].as_i64();
        assert_eq!(raw, Some(v411), "delay {delay_ms} ms: {}", stderr(&o));
        let notes = stale_notes(&o);
        if notes.iter().any(|n| n.contains("when it was opened")) {
            at_open += 1;
        }
        if notes
            .iter()
            .any(|n| n.contains("before the request had left"))
        {
            later += 1;
        }
    }
    eprintln!("the stale answer was discarded at the open {at_open} times, later {later} times");
}

/// A master that gives up at once (`--retries 0`) and waits the shortest time (`--timeout 1`)
/// with a stale answer in the port, the one answer that is there at once: never the stale
/// value. The drive answers 10 ms after the request's last character, which on a pty (no wire
/// time) falls about where the request's 9.2 ms of wire time plus 1 ms end: either its answer
/// or a timeout, never 1390.
#[test]
fn issue18_timeout_extremes_with_a_stale_modbus_answer() {
    let sim = bonfiglioli_sim();
    let (_, v372) = bonfiglioli_raw(&sim, "372", &[]);
    let (_, v411) = bonfiglioli_raw(&sim, "411", &[]);
    for _ in 0..5 {
        leave(&sim.path, &fc3(372), Duration::from_millis(100));
        // The least timeout drivectl takes at 9600 baud (33 ms: both frames and the 10 ms
        // answer delay; 1 ms is refused before the port opens).
        let (o, raw) = bonfiglioli_raw(&sim, "411", &["--timeout", "33", "--retries", "0"]);
        assert_ne!(raw, v372, "{}", stderr(&o));
        match o.status.code() {
            Some(0) => assert_eq!(raw, v411),
            _ => assert!(stderr(&o).contains("no answer"), "{}", stderr(&o)),
        }
        assert_eq!(discarded(&o), 7, "{}", stderr(&o));
    }
    leave(&sim.path, &fc3(372), Duration::from_millis(100));
    let (o, raw) = bonfiglioli_raw(&sim, "411", &["--timeout", "60000"]);
    assert_eq!(raw, v411, "{}", stderr(&o));
    assert_eq!(discarded(&o), 7);
}

/// Another program is stopped in the middle of a transaction (SIGKILL while it waits for the
/// answer; the simulator is held with SIGSTOP meanwhile so that the answer comes after the
/// kill): the answer stays in the port and the next program does not take it.
fn kill_mid_poll(sim: &PtySim, watch: &mut Command) {
    let mut child = watch
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(400));
    signal(sim.pid(), "STOP");
    // The next poll's request goes into the pty; the simulator does not read it yet.
    std::thread::sleep(Duration::from_millis(150));
    child.kill().unwrap();
    child.wait().unwrap();
    signal(sim.pid(), "CONT");
    // The simulator answers the orphaned request into the port.
    std::thread::sleep(Duration::from_millis(150));
}

#[test]
fn issue18_a_modbus_watch_killed_mid_poll_leaves_nothing_the_next_read_takes() {
    let sim = bonfiglioli_sim();
    let (_, v411) = bonfiglioli_raw(&sim, "411", &[]);
    kill_mid_poll(
        &sim,
        bonfiglioli(
            &sim,
            &["--timeout", "5000", "watch", "372", "--interval", "50"],
        )
        .env("DRIVECTL_STATE_DIR", &sim.state),
    );
    let (o, raw) = bonfiglioli_raw(&sim, "411", &["--retries", "0"]);
    assert_eq!(raw, v411, "{}", stderr(&o));
    assert_eq!(discarded(&o), 7, "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// MOVILINK: parameter responses echo the service, subindex and index (the master checks them);
// process-data responses name nothing but the drive and the PDU type.

fn movilink_sim() -> PtySim {
    PtySim::start(&[
        "sim", "movilink", "--pty", "--addr", "1", "--parity", "none",
    ])
}

fn movilink(sim: &PtySim, args: &[&str]) -> Command {
    let mut c = sim.command();
    c.args([
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1",
    ])
    .args(args);
    c
}

/// A MOVILINK request with its BCC.
fn telegram(body: &[u8]) -> Vec<u8> {
    let mut t = body.to_vec();
    t.push(body.iter().fold(0, |a, b| a ^ b));
    t
}

/// Read `index` from drive 1, acyclic PARAM + 0PD.
fn movilink_read(index: u16) -> Vec<u8> {
    let [hi, lo] = index.to_be_bytes();
    telegram(&[0x02, 0x01, 0x86, 0x31, 0x00, hi, lo, 0, 0, 0, 0])
}

fn movilink_raw(sim: &PtySim, param: &str, extra: &[&str]) -> (Output, Option<i64>) {
    let o = movilink(sim, &["--json", "read", param])
        .args(extra)
        .output()
        .unwrap();
    let raw = o
        .status
        .success()
        .then(|| ok_json(&o)[0]["raw"].as_i64())
        .flatten();
    (o, raw)
}

/// A parameter response left in the port: for another parameter it failed the index check
/// (with `--retries 0` the read failed); for the same parameter it passed every check. Now it
/// is discarded either way and the drive's own answer is taken in one attempt.
#[test]
fn issue18_a_stale_movilink_parameter_response_is_not_taken() {
    let sim = movilink_sim();
    let (_, p130) = movilink_raw(&sim, "P130", &[]);
    assert_eq!(p130, Some(2000));
    // P000 (8318), then P130 (8470) itself.
    for index in [8318u16, 8470] {
        leave(&sim.path, &movilink_read(index), Duration::from_millis(100));
        let (o, raw) = movilink_raw(&sim, "P130", &["--retries", "0"]);
        assert_eq!(raw, p130, "index {index}: {}", stderr(&o));
        // SD2, address, PDU type, 8 bytes of parameter channel, BCC.
        assert_eq!(discarded(&o), 12, "index {index}: {}", stderr(&o));
    }
}

/// A process-data response left in the port names nothing a master could check: only when it
/// came tells it apart.
#[test]
fn issue18_a_stale_movilink_process_data_response_is_not_taken() {
    let sim = movilink_sim();
    // 3PD acyclic with PO1 = 0x0002 (stop), the stale request of an earlier `pd`.
    leave(
        &sim.path,
        &telegram(&[0x02, 0x01, 0x85, 0x00, 0x02, 0, 0, 0, 0]),
        Duration::from_millis(100),
    );
    let o = movilink(
        &sim,
        &["--json", "--retries", "0", "pd", "--out", "0x0002,0,0"],
    )
    .output()
    .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // SD2, address, PDU type, three PI words, BCC.
    assert_eq!(discarded(&o), 10, "{}", stderr(&o));
}

#[test]
fn issue18_a_movilink_watch_killed_mid_poll_leaves_nothing_the_next_read_takes() {
    let sim = movilink_sim();
    kill_mid_poll(
        &sim,
        &mut movilink(
            &sim,
            &["--timeout", "5000", "watch", "P000", "--interval", "50"],
        ),
    );
    let (o, raw) = movilink_raw(&sim, "P130", &["--retries", "0"]);
    assert_eq!(raw, Some(2000), "{}", stderr(&o));
    assert_eq!(discarded(&o), 12, "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// USS: PKW answers echo PNU and IND (but a drive repeats its previous answer, erratum E21); the
// PZD part names nothing.

fn uss_sim() -> PtySim {
    PtySim::start(&["sim", "uss", "--pty", "--addr", "1", "--parity", "none"])
}

fn uss(sim: &PtySim, args: &[&str]) -> Command {
    let mut c = sim.command();
    c.args([
        "uss", "--port", &sim.path, "--parity", "none", "--addr", "1",
    ])
    .args(args);
    c
}

/// Read `pnu` (set 1) from USS address 1 in the PKW 4 + PZD 4 layout, process data all zero.
fn uss_read(pnu: u16) -> Vec<u8> {
    let [hi, lo] = (0x1000 | pnu).to_be_bytes();
    // STX, LGE (ADR + 16 data bytes + BCC), ADR, PKE, IND, PWE1, PWE2, four PZD words.
    let mut t = vec![0x02, 18, 0x01, hi, lo];
    t.resize(19, 0);
    telegram(&t)
}

#[test]
fn issue18_a_stale_uss_answer_is_not_taken() {
    let sim = uss_sim();
    let read = |param: &str| {
        let o = uss(&sim, &["--json", "--retries", "0", "read", param])
            .output()
            .unwrap();
        let raw = o
            .status
            .success()
            .then(|| ok_json(&o)[0]["raw"].as_i64())
            .flatten();
        (o, raw)
    };
    let (_, p102) = read("P102");
    let (_, p105) = read("P105");
    assert_ne!(p102, p105);
    // An answer for P105, then one for P102 itself (the order a killed program left).
    for pnu in [105u16, 102] {
        let frame = uss_read(pnu);
        assert_eq!(frame.len(), 20);
        leave(&sim.path, &frame, Duration::from_millis(100));
        let (o, raw) = read("P102");
        assert_eq!(raw, p102, "P{pnu}: {}", stderr(&o));
        assert_eq!(discarded(&o), 20, "P{pnu}: {}", stderr(&o));
    }
    // The status word comes in the PZD part, which names nothing.
    leave(&sim.path, &uss_read(105), Duration::from_millis(100));
    let o = uss(&sim, &["--json", "--retries", "0", "status"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(discarded(&o), 20, "{}", stderr(&o));
}

#[test]
fn issue18_a_uss_watch_killed_mid_poll_leaves_nothing_the_next_read_takes() {
    let sim = uss_sim();
    kill_mid_poll(
        &sim,
        &mut uss(
            &sim,
            &["--timeout", "5000", "watch", "P105", "--interval", "50"],
        ),
    );
    let o = uss(&sim, &["--json", "--retries", "0", "read", "P102"])
        .output()
        .unwrap();
    assert_eq!(ok_json(&o)[0]["raw"], 200, "{}", stderr(&o));
    assert_eq!(discarded(&o), 20, "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// SBus through the simulated slcan adapter: the adapter's lines an earlier program left unread.

#[test]
fn issue18_an_sbus_answer_a_killed_program_left_in_the_slcan_port_is_not_taken() {
    let sim = PtySim::start(&["sim", "sbus", "--pty", "--addr", "1"]);
    let iface = format!("slcan:{}", sim.path);
    let sbus = |args: &[&str]| {
        let mut c = sim.command();
        c.args(["sbus", "--iface", &iface, "--addr", "1"])
            .args(args);
        c
    };
    kill_mid_poll(
        &sim,
        &mut sbus(&["--timeout", "5000", "watch", "P000", "--interval", "50"]),
    );
    let o = sbus(&["--json", "--retries", "0", "read", "P130"])
        .output()
        .unwrap();
    assert_eq!(ok_json(&o)[0]["raw"], 2000, "{}", stderr(&o));
    // The adapter's acknowledgement of the request (`z` CR) and the answer's line (`t`, three
    // identifier digits, the length, 16 data digits, CR).
    assert_eq!(discarded(&o), 2 + 22, "{}", stderr(&o));
}
