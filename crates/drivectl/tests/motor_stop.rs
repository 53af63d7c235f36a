//! Issue 18 A3: no motor left running, silently or against the user's interrupt — the one rule
//! run through all four families over real pseudo-terminals against their simulators.
//!
//! Every command that drives a motor (`movilink pd`, `sbus pd`, `uss control enable`,
//! `bonfiglioli control enable`) is ended by every signal that ends a command (SIGINT,
//! SIGTERM, SIGHUP, SIGQUIT) at times spread over its run, and by a closed output pipe. After
//! it, the drive is never running unless standard error says that it keeps running: `pd` always
//! stops it; `control enable` stops it when interrupted before it was done, and otherwise says
//! that it keeps running and how to stop it.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::io::Read;
use std::process::{Command, Output, Stdio};

use common::{PtySim, ok_json, stderr};

/// One family's motor command against its simulator.
struct Family {
    name: &'static str,
    sim: PtySim,
    /// The arguments that reach the drive (`movilink --port P --parity none --addr 1`).
    prefix: Vec<String>,
    /// The command that drives the motor.
    drive: Vec<&'static str>,
    /// `pd`: the motor is stopped at the end in every case.
    always_stops: bool,
}

impl Family {
    fn start(name: &'static str) -> Family {
        let (sim_args, drive, always_stops): (&[&str], Vec<&str>, bool) = match name {
            "movilink" => (
                &[
                    "sim", "movilink", "--pty", "--addr", "1", "--parity", "none",
                ],
                vec![
                    "pd",
                    "--type",
                    "0x05",
                    "--out",
                    "0x0006,5000,0",
                    "--count",
                    "12",
                    "--interval",
                    "50",
                ],
                true,
            ),
            "sbus" => (
                &["sim", "sbus", "--pty", "--addr", "1"],
                vec![
                    "pd",
                    "--out",
                    "0x0006,5000,0",
                    "--count",
                    "12",
                    "--interval",
                    "50",
                ],
                true,
            ),
            "uss" => (
                &["sim", "uss", "--pty", "--addr", "1", "--parity", "none"],
                vec!["control", "enable", "--setpoint", "50"],
                false,
            ),
            "bonfiglioli" => (
                &[
                    "sim",
                    "bonfiglioli",
                    "--pty",
                    "--parity",
                    "none",
                    "--mode",
                    "rtu",
                ],
                vec!["control", "enable", "--freq", "5"],
                false,
            ),
            other => panic!("{other}"),
        };
        let sim = PtySim::start(sim_args);
        let prefix: Vec<String> = match name {
            "sbus" => vec![
                "sbus".into(),
                "--iface".into(),
                format!("slcan:{}@500k", sim.path),
                "--addr".into(),
                "1".into(),
            ],
            "bonfiglioli" => vec![
                "bonfiglioli".into(),
                "--port".into(),
                sim.path.clone(),
                "--parity".into(),
                "none".into(),
            ],
            _ => vec![
                name.into(),
                "--port".into(),
                sim.path.clone(),
                "--parity".into(),
                "none".into(),
                "--addr".into(),
                "1".into(),
            ],
        };
        Family {
            name,
            sim,
            prefix,
            drive,
            always_stops,
        }
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut c = self.sim.command();
        c.args(&self.prefix).args(args);
        c
    }

    fn run(&self, args: &[&str]) -> Output {
        self.command(args).output().unwrap()
    }

    /// Whether the drive runs: its state says enabled (SEW: unit status 4 "enable"; NORD: E
    /// operation enabled; Bonfiglioli: operation enabled).
    fn running(&self) -> bool {
        match self.name {
            "movilink" | "sbus" => {
                let v = ok_json(&self.run(&["--json", "read", "P010"]));
                v[0]["decoded"]["unit_status"]["code"] == 4
            }
            "uss" => ok_json(&self.run(&["--json", "status"]))[0]["state"] == "E",
            _ => ok_json(&self.run(&["--json", "status"]))[0]["state"] == "operation enabled",
        }
    }

    /// Back to a drive that does not run, between trials.
    fn reset(&self) {
        match self.name {
            "movilink" | "sbus" => {
                // `pd` itself stops at its end; a trial that left it running is the failure
                // this test looks for, so make sure of the start state.
                let o = self.run(&["pd", "--out", "0x0002,0,0", "--count", "1"]);
                assert!(o.status.success(), "{}", stderr(&o));
            }
            _ => {
                let o = self.run(&["control", "disable"]);
                assert!(o.status.success(), "{}", stderr(&o));
            }
        }
        assert!(
            !self.running(),
            "{}: the reset left the drive running",
            self.name
        );
    }
}

/// The rule, checked after one run that ended with `out` (`signalled`: a signal was sent).
fn check(f: &Family, out: &Output, what: &str) {
    let err = stderr(out);
    let running = f.running();
    let says_running = err.contains("keeps running after drivectl ends");
    if f.always_stops {
        assert!(
            !running,
            "{} {what}: pd left the drive running\n{err}",
            f.name
        );
    }
    // Never running without saying so; never said running when it was stopped.
    assert_eq!(
        running, says_running,
        "{} {what}: running {running}, exit {:?}\n{err}",
        f.name, out.status
    );
    if let Some(code) = out.status.code()
        && code >= 128
        && code != 141
    {
        // Ended by a signal before it was done: the stop was sent and said.
        assert!(
            err.contains("interrupted by")
                && (err.contains("note: sent ")
                    || err.contains("before anything that moves the motor was sent")),
            "{} {what}: exit {code} without a stop\n{err}",
            f.name
        );
    }
}

/// Send `sig` to `pid`; the command may have ended already, which makes the trial one of its
/// normal end (`kill` then fails, and that is fine).
fn signal(pid: u32, sig: &str) {
    let _ = Command::new("kill")
        .args([&format!("-{sig}"), &pid.to_string()])
        .stderr(Stdio::null())
        .status();
}

fn every_signal_at_every_time(name: &'static str) {
    let f = Family::start(name);
    f.reset();
    // A normal run first: how long the command takes, and its end checked too.
    let started = std::time::Instant::now();
    let out = f.command(&f.drive).output().unwrap();
    let took = started.elapsed();
    assert!(out.status.success(), "{name}: {}", stderr(&out));
    check(&f, &out, "at its normal end");
    f.reset();
    // Then every signal at times spread over such a run (its start is ~20 ms of process
    // start and preflight reads: a signal that early may end the process before any word is
    // sent, which must leave the drive as it was).
    let signals = ["INT", "TERM", "HUP", "QUIT"];
    let mut interrupted = 0;
    for k in 1..=10u32 {
        let delay = took * k / 10;
        let sig = signals[k as usize % signals.len()];
        let child = f
            .command(&f.drive)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(delay);
        signal(child.id(), sig);
        let out = child.wait_with_output().unwrap();
        if stderr(&out).contains("interrupted by") {
            interrupted += 1;
        }
        check(
            &f,
            &out,
            &format!("SIG{sig} after {} ms", delay.as_millis()),
        );
        f.reset();
    }
    // The trials must really have interrupted the command, most of them mid-way.
    assert!(
        interrupted >= 3,
        "{name}: only {interrupted} trials were interrupted"
    );
    // A closed output pipe (`… | head -0`): the reader is gone before the first line.
    let mut child = f
        .command(&f.drive)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    let out = Output {
        status,
        stdout: Vec::new(),
        stderr: err.into_bytes(),
    };
    assert_eq!(out.status.code(), Some(141), "{name}\n{}", stderr(&out));
    check(&f, &out, "with a closed pipe");
    f.reset();
}

#[test]
fn issue18_movilink_pd_stops_on_every_signal_and_a_closed_pipe() {
    every_signal_at_every_time("movilink");
}

#[test]
fn issue18_sbus_pd_stops_on_every_signal_and_a_closed_pipe() {
    every_signal_at_every_time("sbus");
}

#[test]
fn issue18_uss_control_enable_stops_on_every_signal_and_says_when_it_keeps_running() {
    every_signal_at_every_time("uss");
}

#[test]
fn issue18_bonfiglioli_control_enable_stops_on_every_signal_and_says_when_it_keeps_running() {
    every_signal_at_every_time("bonfiglioli");
}
