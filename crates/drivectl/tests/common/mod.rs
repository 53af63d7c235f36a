//! What the end-to-end tests over a pseudo-terminal share: a `drivectl sim … --pty` process
//! whose pty path is the first line it prints, `drivectl` runs with their own EEPROM-wear state
//! directory, and reading their output.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    dead_code
)]

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};

/// A running `drivectl sim … --pty`; killed (and its state directory removed) when dropped.
pub struct PtySim {
    child: Child,
    /// The pseudo-terminal the simulator serves.
    pub path: String,
    /// The EEPROM-wear state directory of the `drivectl` runs against it.
    pub state: PathBuf,
}

impl PtySim {
    /// Start `drivectl <args>` (e.g. `sim movilink --pty --parity none`) and wait for the pty
    /// path it prints first.
    pub fn start(args: &[&str]) -> PtySim {
        let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(args)
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
        let protocol = args.get(1).copied().unwrap_or("sim");
        let state = std::env::temp_dir().join(format!(
            "drivectl-state-{protocol}-{}",
            path.replace('/', "_")
        ));
        let _ = std::fs::remove_dir_all(&state);
        PtySim { child, path, state }
    }

    /// The simulator's process id (to stop and continue it).
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `drivectl <args>` with this simulator's state directory.
    pub fn drivectl(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(args)
            .env("DRIVECTL_STATE_DIR", &self.state)
            .output()
            .expect("drivectl runs")
    }

    /// A `drivectl` command with this simulator's state directory, to be completed by the
    /// caller (arguments, pipes).
    pub fn command(&self) -> Command {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_drivectl"));
        cmd.env("DRIVECTL_STATE_DIR", &self.state);
        cmd
    }
}

impl Drop for PtySim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.state);
    }
}

/// Every line of standard output as a JSON object; the command must have succeeded.
pub fn ok_json(o: &Output) -> Vec<serde_json::Value> {
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

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every line of standard error as a JSON object.
pub fn stderr_json(o: &Output) -> Vec<serde_json::Value> {
    stderr(o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("stderr not JSON: {l}: {e}")))
        .collect()
}

/// Send `sig` (`TERM`, `HUP`, `STOP`, …) to `pid`; panics if `kill` fails.
pub fn signal(pid: u32, sig: &str) {
    let ok = Command::new("kill")
        .arg(format!("-{sig}"))
        .arg(pid.to_string())
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{sig} {pid}");
}
