//! Issue 22 item 5, end to end over pseudo-terminals: an RS-485 adapter that echoes what it
//! sends (a two-wire converter whose receiver stays on), played by a relay between drivectl's
//! pty and a simulator's. Every byte drivectl writes comes back to it at once (the echo) and
//! goes on to the simulator; the simulator's answers come back after it.
//!
//! * Modbus FC 6, FC 8 and FC 101 and a USS read to a silent echoing bus: the echo is the
//!   request byte for byte, and the answer to it would (or could) be the same bytes. Without
//!   `--echo` the driver does not take it: it reads the parameter (an answer that never repeats
//!   the request) to find out, sees its echo too, and fails saying the adapter echoes, naming
//!   `--echo`; with `--echo` it is a timeout. Never a success.
//! * Without `--echo` through an echoing adapter to a simulator, every Modbus and USS call fails
//!   the same way (no answer can be told from the echo); MOVILINK, whose answers never look like
//!   its requests, works. Without an echoing adapter the same writes work (the read that finds
//!   out shows the line does not echo).
//! * With `--echo`, every serial family works through the echoing relay (MOVILINK, USS,
//!   Modbus RTU).
//! * A corrupted echo (the relay flips a bit of what it echoes) is a collision: the frame is
//!   not taken, the command fails after its retries and says so.
//! * `--rs485` on a pty (no kernel RS-485 support) is refused naming the option.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::process::{Command, Output};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{PtySim, stderr};
use drive_transport::pty::PtyPair;
use drive_transport::serial::{self, LineSettings, Parity, SerialConfig};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// The echoing adapter: a pty for drivectl whose every written byte is echoed back (with bit 0
/// of the `garble`-th byte flipped, if given) and forwarded to `peer` (a simulator's pty),
/// whose bytes come back to drivectl. Runs until the test process ends.
struct Relay {
    path: String,
}

impl Relay {
    fn start(peer: Option<&str>, garble: Option<usize>) -> Relay {
        let (tx, rx) = mpsc::channel();
        let peer = peer.map(str::to_owned);
        std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async move {
                let mut pair = PtyPair::open().unwrap();
                tx.send(pair.slave_path().to_string_lossy().into_owned())
                    .unwrap();
                let mut peer = peer.map(|p| {
                    serial::open(&SerialConfig::with_line(
                        p,
                        LineSettings::new(9600).with_parity(Parity::None),
                    ))
                    .unwrap()
                });
                let mut a = [0u8; 256];
                let mut b = [0u8; 256];
                let mut echoed = 0usize;
                loop {
                    tokio::select! {
                        r = pair.master().read(&mut a) => {
                            let n = match r {
                                // drivectl closed its end; the next one opens it again.
                                Ok(0) | Err(_) => {
                                    tokio::time::sleep(Duration::from_millis(5)).await;
                                    continue;
                                }
                                Ok(n) => n,
                            };
                            let mut echo = a[..n].to_vec();
                            if let Some(k) = garble {
                                for byte in echo.iter_mut() {
                                    if echoed % 8 == k {
                                        *byte ^= 0x01;
                                    }
                                    echoed += 1;
                                }
                            }
                            let _ = pair.master().write_all(&echo).await;
                            if let Some(p) = peer.as_mut() {
                                let _ = p.write_all(&a[..n]).await;
                            }
                        }
                        r = async {
                            match peer.as_mut() {
                                Some(p) => p.read(&mut b).await,
                                None => std::future::pending().await,
                            }
                        } => {
                            if let Ok(n) = r
                                && n > 0
                            {
                                let _ = pair.master().write_all(&b[..n]).await;
                            }
                        }
                    }
                }
            });
        });
        Relay {
            path: rx.recv_timeout(Duration::from_secs(10)).unwrap(),
        }
    }
}

fn drivectl(args: &[&str]) -> Output {
    let state = std::env::temp_dir().join(format!("drivectl-echo-{}", std::process::id()));
    Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
        .env("DRIVECTL_STATE_DIR", &state)
        .output()
        .unwrap()
}

/// The stderr of a command that failed because the adapter echoes while `--echo` is not given.
fn assert_echo_refused(o: &Output, what: &str) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{what}: {e}");
    assert!(
        e.contains("the adapter echoes what it sends") && e.contains("--echo"),
        "{what}: {e}"
    );
}

#[test]
fn issue22_a_silent_echoing_bus_never_answers_a_write_a_diag_or_a_read_without_echo() {
    let relay = Relay::start(None, None);
    let line = [
        "--port",
        &relay.path,
        "--parity",
        "none",
        "--addr",
        "1",
        "--timeout",
        "100",
        "--retries",
        "1",
    ];
    fn cmd<'a>(line: &[&'a str], family: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
        let mut v = vec![family];
        v.extend(line);
        v.extend(rest);
        v
    }
    // FC 8 (diag): it printed the counters of a drive that is not there (exit 0).
    assert_echo_refused(&drivectl(&cmd(&line, "bonfiglioli", &["diag"])), "FC 8");
    // FC 6: a write reported done that no drive answered (only its read-back failed).
    let o = drivectl(&cmd(&line, "bonfiglioli", &["write", "372", "1400"]));
    assert_echo_refused(&o, "FC 6");
    assert!(!stderr(&o).contains("was written"), "{}", stderr(&o));
    // FC 101 (481, fixed frequency 2, a 32-bit parameter): its answer repeats it too.
    let o = drivectl(&cmd(&line, "bonfiglioli", &["write", "481", "12.5"]));
    assert_echo_refused(&o, "FC 101");
    assert!(!stderr(&o).contains("was written"), "{}", stderr(&o));
    // A USS read printed 0.00 s, a value no drive sent.
    let mut uss = cmd(&line, "uss", &["read", "P102"]);
    let at = uss.iter().position(|a| *a == "1").unwrap();
    uss[at] = "0";
    assert_echo_refused(&drivectl(&uss), "USS read");
    // With --echo: no answer, never a success.
    let started = Instant::now();
    let mut args = cmd(&line, "bonfiglioli", &["diag"]);
    args.push("--echo");
    let o = drivectl(&args);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no answer"), "{}", stderr(&o));
    assert!(started.elapsed() < Duration::from_secs(5));
}

#[test]
fn issue22_without_echo_an_echoing_adapter_is_refused_by_modbus_and_uss_and_movilink_works() {
    for (sim, family, works) in [
        (
            vec!["sim", "bonfiglioli", "--pty", "--parity", "none"],
            vec!["bonfiglioli", "--addr", "1", "read", "372", "--json"],
            false,
        ),
        (
            vec!["sim", "bonfiglioli", "--pty", "--parity", "none"],
            vec!["bonfiglioli", "--addr", "1", "write", "372", "1400"],
            false,
        ),
        (
            vec!["sim", "uss", "--pty", "--parity", "none"],
            vec!["uss", "--addr", "0", "read", "P102", "--json"],
            false,
        ),
        (
            vec!["sim", "movilink", "--pty", "--parity", "none"],
            vec!["movilink", "--addr", "0", "read", "P000", "--json"],
            true,
        ),
    ] {
        let s = PtySim::start(&sim);
        let relay = Relay::start(Some(&s.path), None);
        let mut args = family.clone();
        args.extend(["--port", &relay.path, "--parity", "none"]);
        let o = s.drivectl(&args);
        if works {
            assert!(o.status.success(), "{family:?}: {}", stderr(&o));
        } else {
            assert_echo_refused(&o, &format!("{family:?}"));
        }
        // The same command on the simulator's own pty (no echo) works: a write first of all
        // (its answer repeats it: the read that finds out shows the line does not echo).
        let own = PtySim::start(&sim);
        let mut direct = family.clone();
        direct.extend(["--port", &own.path, "--parity", "none"]);
        let o = own.drivectl(&direct);
        assert!(
            o.status.success(),
            "{family:?} without an echo: {}",
            stderr(&o)
        );
    }
}

#[test]
fn with_echo_every_serial_family_works_through_an_echoing_adapter() {
    for (sim, family) in [
        (
            vec!["sim", "bonfiglioli", "--pty", "--parity", "none"],
            vec!["bonfiglioli", "--addr", "1", "read", "372", "--json"],
        ),
        (
            vec!["sim", "movilink", "--pty", "--parity", "none"],
            vec!["movilink", "--addr", "0", "read", "P000", "--json"],
        ),
        (
            vec!["sim", "uss", "--pty", "--parity", "none"],
            vec!["uss", "--addr", "0", "read", "P102", "--json"],
        ),
    ] {
        let s = PtySim::start(&sim);
        let relay = Relay::start(Some(&s.path), None);
        let mut args = family.clone();
        args.extend(["--port", &relay.path, "--parity", "none", "--echo"]);
        let o = s.drivectl(&args);
        assert!(
            o.status.success(),
            "{family:?} through the echoing adapter: {}",
            stderr(&o)
        );
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains("\"raw\""), "{family:?}: {out}");
    }
}

#[test]
fn a_corrupted_echo_is_a_collision_and_nothing_is_taken() {
    let s = PtySim::start(&["sim", "bonfiglioli", "--pty", "--parity", "none"]);
    let relay = Relay::start(Some(&s.path), Some(3));
    let o = s.drivectl(&[
        "bonfiglioli",
        "--port",
        &relay.path,
        "--parity",
        "none",
        "--echo",
        "--addr",
        "1",
        "--timeout",
        "200",
        "read",
        "372",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("collision"), "{}", stderr(&o));
}

#[test]
fn rs485_mode_on_a_port_without_it_is_refused_naming_the_option() {
    let relay = Relay::start(None, None);
    let o = drivectl(&[
        "movilink",
        "--port",
        &relay.path,
        "--parity",
        "none",
        "--rs485",
        "read",
        "P000",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("RS-485") && e.contains("--rs485"), "{e}");
}
