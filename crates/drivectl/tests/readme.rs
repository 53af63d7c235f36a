//! Issue 18: every command of README.md is run, in order, as a new user would run it.
//!
//! The test reads README.md's `sh` blocks line by line and runs each command with bash in one
//! scratch directory (its own `HOME` and EEPROM-wear state directory), `drivectl` being this
//! build's binary. Each command must succeed. The only changes made to a line are the ones a
//! user without the hardware makes:
//!
//! * `drivectl sim … --pty …` runs in the background, and the pty path it prints replaces the
//!   example path `/dev/pts/3` in the commands of its family that follow (a Bonfiglioli
//!   command with `--mode ascii` takes the simulator started with `--mode ascii`);
//! * a real port (`/dev/ttyUSB0`) is the family's simulated drive's pty, with `--parity none`
//!   (a pty takes no parity); a CAN interface (`can0`) is the simulated slcan adapter's pty;
//! * `cargo run --release -p drivectl --` is the binary (the same build);
//! * commands that run until stopped (a simulator, the gateway, a broker) run in the
//!   background and are stopped at the end;
//! * a command that runs until Ctrl-C (`watch` without `--count`, `pd --count 0`, `sync`
//!   without `--count`) gets Ctrl-C after two seconds, as a user ends it, and must end with
//!   exit 0;
//! * `scripts/test` is not run: it is what runs this test;
//! * a library crate's example (`cargo run -p movilink --example …`) is not run here: it needs
//!   the workspace, and that crate's `tests/examples.rs` runs it and checks its output.
//!
//! Blocks that need hardware or root (SocketCAN's `vcan` module) are `console` blocks in the
//! README, not `sh`, and say so there.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The README's commands, in order, each with its line number.
fn commands(readme: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut in_sh = false;
    for (i, line) in readme.lines().enumerate() {
        let t = line.trim();
        if let Some(lang) = t.strip_prefix("```") {
            in_sh = !in_sh && lang.trim() == "sh";
            continue;
        }
        if !in_sh || t.is_empty() || t.starts_with('#') {
            continue;
        }
        out.push((i + 1, strip_comment(t)));
    }
    out
}

/// Whether `line` runs a library crate's example (`cargo run -p CRATE --example NAME`).
fn is_crate_example(line: &str) -> bool {
    line.starts_with("cargo run -p ") && line.contains(" --example ")
}

/// The line without its trailing comment (a `#` after white space, outside quotes).
fn strip_comment(line: &str) -> String {
    let (mut single, mut double) = (false, false);
    let mut prev_space = true;
    for (i, c) in line.char_indices() {
        match c {
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && prev_space => return line[..i].trim_end().to_owned(),
            _ => {}
        }
        prev_space = c.is_whitespace();
    }
    line.trim_end().to_owned()
}

/// Which simulator a command talks to: the family, and for Bonfiglioli the mode.
fn family_of(line: &str) -> Option<String> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let pos = words.iter().position(|w| *w == "drivectl")?;
    let mut family = *words.get(pos + 1)?;
    if family == "sim" {
        family = words.get(pos + 2)?;
    }
    let family = match family {
        "movilink" | "sbus" | "uss" => family.to_owned(),
        "bonfiglioli" if line.contains("--mode ascii") => "bonfiglioli-ascii".to_owned(),
        "bonfiglioli" => "bonfiglioli".to_owned(),
        _ => return None,
    };
    Some(family)
}

/// A command a user ends with Ctrl-C.
fn runs_until_ctrl_c(line: &str) -> bool {
    let words: Vec<&str> = line.split_whitespace().collect();
    let has = |w: &str| words.contains(&w);
    let count_zero = words.windows(2).any(|p| p == ["--count", "0"]);
    (has("watch") && !has("--count"))
        || (has("pd") && count_zero)
        || (has("sync") && (!has("--count") || count_zero))
}

/// Run `cmd` (a bash command in its own process group) to its end, with Ctrl-C (SIGINT to the
/// group) after `interrupt_after` if given, and killed after two minutes.
fn run_to_end(mut cmd: Command, interrupt_after: Option<Duration>) -> std::process::Output {
    use std::os::unix::process::CommandExt;
    let child = cmd
        .process_group(0)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pgid = child.id();
    let signal = move |sig: &str| {
        let _ = Command::new("kill")
            .args([sig, "--", &format!("-{pgid}")])
            .stderr(Stdio::null())
            .status();
    };
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watcher = {
        let done = done.clone();
        std::thread::spawn(move || {
            let started = Instant::now();
            let mut interrupted = false;
            while !done.load(std::sync::atomic::Ordering::SeqCst) {
                if let Some(after) = interrupt_after
                    && !interrupted
                    && started.elapsed() >= after
                {
                    signal("-INT");
                    interrupted = true;
                }
                if started.elapsed() >= Duration::from_secs(120) {
                    signal("-KILL");
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    let out = child.wait_with_output().unwrap();
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    let _ = watcher.join();
    out
}

/// A command that runs until it is stopped.
fn runs_until_stopped(line: &str) -> bool {
    line.starts_with("mosquitto ")
        || line.starts_with("drivectl sim ")
        || line.starts_with("drivectl ui ")
        || (line.starts_with("drivectl gateway ")
            && !line.contains("--check")
            && !line.contains("--example-config"))
}

struct Background {
    line: usize,
    child: Child,
}

#[test]
fn issue18_every_readme_command_runs_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let dir = std::env::temp_dir().join(format!("drivebus-readme-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_drivectl"), bin.join("drivectl")).unwrap();
    let home = dir.join("home");
    std::fs::create_dir_all(&home).unwrap();
    let work = dir.join("work");
    std::fs::create_dir_all(&work).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ptys: HashMap<String, String> = HashMap::new();
    let mut background: Vec<Background> = Vec::new();
    let mut ran = 0;
    let shell = |cmd: &str| {
        let mut c = Command::new("bash");
        c.args(["-o", "pipefail", "-c", cmd])
            .current_dir(&work)
            .env("PATH", &path)
            .env("HOME", &home)
            .env("DRIVECTL_STATE_DIR", dir.join("state"))
            .env_remove("XDG_STATE_HOME");
        c
    };
    let mut failures = {
        let mut failures = Vec::new();
        for (number, original) in commands(&readme) {
            // The library crates' examples need the workspace, not the scratch directory: each
            // crate's tests/examples.rs runs them and checks what they print.
            if original == "scripts/test" || is_crate_example(&original) {
                continue;
            }
            let line = adapt(&original, &ptys);
            if runs_until_stopped(&line) {
                let mut child = shell(&format!("exec {line}"))
                    .stdout(Stdio::piped())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap();
                if line.starts_with("drivectl sim ") {
                    let mut first = String::new();
                    BufReader::new(child.stdout.take().unwrap())
                        .read_line(&mut first)
                        .unwrap();
                    let pty = first.trim().to_owned();
                    assert!(
                        pty.starts_with("/dev/"),
                        "README.md:{number}: `{original}` printed {first:?}"
                    );
                    ptys.insert(family_of(&line).unwrap(), pty);
                } else {
                    // A server: give it a moment to listen (the next command talks to it).
                    wait_ready(&line);
                }
                background.push(Background {
                    line: number,
                    child,
                });
                ran += 1;
                continue;
            }
            let started = Instant::now();
            let ctrl_c = runs_until_ctrl_c(&line).then_some(Duration::from_secs(2));
            let out = run_to_end(shell(&line), ctrl_c);
            ran += 1;
            if !out.status.success() {
                failures.push(format!(
                    "README.md:{number}: `{original}`\n  ran `{line}`: {:?} after {:.1} s\n  stdout: {}\n  stderr: {}",
                    out.status,
                    started.elapsed().as_secs_f64(),
                    String::from_utf8_lossy(&out.stdout).trim(),
                    String::from_utf8_lossy(&out.stderr).trim()
                ));
            }
        }
        failures
    };
    for mut b in background {
        if let Some(status) = b.child.try_wait().unwrap() {
            failures.push(format!(
                "README.md:{}: the background command ended early: {status:?}",
                b.line
            ));
        }
        let _ = b.child.kill();
        let _ = b.child.wait();
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(ran > 50, "only {ran} commands found in README.md");
    assert!(
        failures.is_empty(),
        "{} of {ran} README commands failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Wait until the server `line` starts listens on its port (a broker, the gateway's metrics),
/// at most 5 s.
fn wait_ready(line: &str) {
    let port = line
        .split_whitespace()
        .skip_while(|w| *w != "-p")
        .nth(1)
        .and_then(|p| p.parse::<u16>().ok());
    let deadline = Instant::now() + Duration::from_secs(5);
    match port {
        Some(p) => {
            while std::net::TcpStream::connect(("127.0.0.1", p)).is_err()
                && Instant::now() < deadline
            {
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        None => std::thread::sleep(Duration::from_secs(2)),
    }
}

/// `line` as a user without the hardware runs it (see the module docs).
fn adapt(line: &str, ptys: &HashMap<String, String>) -> String {
    let mut l = line.replace("cargo run --release -p drivectl --", "drivectl");
    let family = family_of(&l);
    let pty = family.as_ref().and_then(|f| ptys.get(f));
    if let Some(pty) = pty {
        if l.contains("/dev/ttyUSB0") || l.contains("/dev/ttyACM0") {
            l = l.replace("/dev/ttyUSB0", pty).replace("/dev/ttyACM0", pty);
            if !l.contains("--parity") && family.as_deref() != Some("sbus") {
                l = l.replacen(
                    &format!("--port {pty}"),
                    &format!("--port {pty} --parity none"),
                    1,
                );
            }
        }
        l = l.replace("/dev/pts/3", pty);
        if family.as_deref() == Some("sbus") {
            l = l.replace("--iface can0", &format!("--iface slcan:{pty}@500k"));
        }
    }
    l
}

#[test]
fn comments_are_stripped_outside_quotes_only() {
    assert_eq!(
        strip_comment("mosquitto_sub -t 'drivebus/cabinet-1/#' -v   # values"),
        "mosquitto_sub -t 'drivebus/cabinet-1/#' -v"
    );
    assert_eq!(strip_comment("drivectl a#b"), "drivectl a#b");
    let ptys = HashMap::from([("uss".to_owned(), "/dev/pts/9".to_owned())]);
    assert_eq!(
        adapt("drivectl uss --port /dev/ttyUSB0 --addr 1 status", &ptys),
        "drivectl uss --port /dev/pts/9 --parity none --addr 1 status"
    );
}
