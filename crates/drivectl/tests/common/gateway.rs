//! `drivectl gateway` as a process for the end-to-end tests: its config file and log in a
//! directory of its own, its state directory, the signals it is sent.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    dead_code
)]

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Every test that runs a gateway has `mod common;` too.
pub use crate::common::signal;

/// A running `drivectl gateway`; killed when dropped.
pub struct Gateway {
    child: Option<Child>,
    /// Its directory: `plant.toml`, `gateway.log`.
    pub dir: PathBuf,
    /// Its `DRIVECTL_STATE_DIR` (default: `state` in its directory).
    state: Option<PathBuf>,
}

static SEQ: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

impl Gateway {
    /// Write `config` and start `drivectl gateway --config … <extra>`; its log goes to a file.
    pub fn start(config: &str, extra: &[&str]) -> Gateway {
        Gateway::launch(config, extra, None)
    }

    /// [`Gateway::start`] with `state` as its `DRIVECTL_STATE_DIR`.
    pub fn start_with_state(config: &str, state: PathBuf) -> Gateway {
        Gateway::launch(config, &[], Some(state))
    }

    fn launch(config: &str, extra: &[&str], state: Option<PathBuf>) -> Gateway {
        let dir = std::env::temp_dir().join(format!(
            "drivebus-gw-{}-{}",
            std::process::id(),
            SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut gw = Gateway {
            child: None,
            dir,
            state,
        };
        gw.write_config(config);
        gw.spawn(extra);
        gw
    }

    pub fn write_config(&self, config: &str) {
        std::fs::write(self.dir.join("plant.toml"), config).unwrap();
    }

    /// Start the process (again): its log is appended to, so that a restart keeps the
    /// earlier run's lines above the new ones.
    pub fn spawn(&mut self, extra: &[&str]) {
        assert!(self.child.is_none(), "the gateway runs already");
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(self.dir.join("gateway.log"))
            .unwrap();
        let state = self.state.clone().unwrap_or_else(|| self.dir.join("state"));
        let child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .arg("gateway")
            .arg("--config")
            .arg(self.dir.join("plant.toml"))
            .args(extra)
            .env("DRIVECTL_STATE_DIR", state)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("drivectl gateway starts");
        self.child = Some(child);
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("gateway.log")).unwrap_or_default()
    }

    /// SIGTERM (systemd's stop) and wait for the exit (10 s at most); the exit status.
    pub fn terminate(&mut self) -> std::process::ExitStatus {
        self.stop_with("TERM")
    }

    /// Send `sig` and wait for the exit (10 s at most: the drives' stop may take that); the
    /// exit status.
    pub fn stop_with(&mut self, sig: &str) -> std::process::ExitStatus {
        let mut child = self.child.take().expect("running");
        signal(child.id(), sig);
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(s) = child.try_wait().unwrap() {
                return s;
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                let _ = child.wait();
                panic!(
                    "the gateway did not stop within 10 s of SIG{sig}:\n{}",
                    self.log()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        } else {
            eprintln!("gateway log ({}):\n{}", self.dir.display(), self.log());
        }
    }
}

/// The `state` of the gateway's status payload (`{"state":"online","config":…}`).
pub fn gw_state(p: &[u8]) -> String {
    serde_json::from_slice::<serde_json::Value>(p)
        .ok()
        .and_then(|v| v["state"].as_str().map(str::to_owned))
        .unwrap_or_default()
}

impl Gateway {
    /// Its process id, while it runs.
    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    /// Send `sig` (`HUP`, …) without waiting for anything.
    pub fn signal(&self, sig: &str) {
        signal(self.pid().expect("running"), sig);
    }

    /// Panics with the log if the gateway has exited (`what`: what it should have done first).
    pub fn assert_running(&mut self, what: &str) {
        if let Some(child) = self.child.as_mut()
            && let Some(status) = child.try_wait().unwrap()
        {
            self.child = None;
            panic!(
                "the gateway exited ({status}) before {what}:\n{}",
                self.log()
            );
        }
    }

    /// Whether it still runs.
    pub fn running(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| c.try_wait().ok().flatten().is_none())
    }
}

/// A free port on 127.0.0.1.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `N` distinct free ports on 127.0.0.1: each listener is held until all are chosen (`N`
/// calls of [`free_port`] in a row may be given one port twice).
pub fn free_ports<const N: usize>() -> [u16; N] {
    let held: [std::net::TcpListener; N] =
        std::array::from_fn(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap());
    held.map(|l| l.local_addr().unwrap().port())
}

/// `GET /metrics` on 127.0.0.1:`port`.
pub fn scrape(port: u16) -> String {
    use std::io::{Read as _, Write as _};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(b"GET /metrics HTTP/1.1\r\nHost: localhost\r\n\r\n")
        .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    assert!(out.starts_with("HTTP/1.1 200"), "{out}");
    out
}

/// The value of the metric line starting with `prefix` (labels included), 0 when absent.
pub fn metric(text: &str, prefix: &str) -> f64 {
    text.lines()
        .find(|l| l.starts_with(prefix))
        .and_then(|l| l.rsplit(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0)
}
