//! What the browser tests share: a headless Chromium driven through chromedriver (W3C
//! WebDriver over plain HTTP/1.1), the example plant served by `drivectl gateway --simulate`
//! with `broker = "off"`, plain HTTP requests and screenshots under `target/ui-screenshots/`.
//!
//! Chromium and chromedriver come from `scripts/setup-browser`; where they are missing a test
//! fails under CI (`CI` set) and skips with one line elsewhere ([`browser_tools`]).

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    dead_code
)]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

/// The paths of chromium and chromedriver, or `None` after saying why (a failure under CI).
pub fn browser_tools() -> Option<(PathBuf, PathBuf)> {
    let on_path = |name: &str| {
        let paths = std::env::var_os("PATH")?;
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    };
    let mut missing = Vec::new();
    let chromium = on_path("chromium");
    let driver = on_path("chromedriver");
    if chromium.is_none() {
        missing.push("chromium");
    }
    if driver.is_none() {
        missing.push("chromedriver");
    }
    if missing.is_empty() {
        return chromium.zip(driver);
    }
    let why = format!(
        "{} not installed (bash scripts/setup-browser installs them)",
        missing.join(" and ")
    );
    let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
    assert!(
        !ci,
        "{why}; CI is set, so a browser test that cannot run fails"
    );
    eprintln!("SKIPPED: {why}");
    None
}

/// A loopback port free a moment ago.
pub fn free_port() -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

/// An answer: status code, lower-cased head, body (de-chunked).
pub struct Answer {
    /// The status code.
    pub code: u16,
    /// The head, lower-cased.
    pub head: String,
    /// The body.
    pub body: String,
}

/// One request on a fresh connection, `body` sent as JSON; the answer read by its
/// `Content-Length` (chromedriver keeps connections open), chunks or to the close.
pub fn request(addr: SocketAddr, method: &str, path: &str, body: Option<&Value>) -> Answer {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let body = body.map(Value::to_string).unwrap_or_default();
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n\
         Content-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        addr.port(),
        body.len()
    );
    s.write_all(head.as_bytes()).unwrap();
    s.write_all(body.as_bytes()).unwrap();
    let mut got: Vec<u8> = Vec::new();
    let mut chunk = vec![0u8; 64 * 1024];
    let split = loop {
        if let Some(i) = got.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
        let n = s.read(&mut chunk).unwrap();
        assert!(n > 0, "closed before the head's end");
        got.extend_from_slice(&chunk[..n]);
    };
    let head = String::from_utf8_lossy(&got[..split]).to_ascii_lowercase();
    let length = head.lines().find_map(|l| {
        l.strip_prefix("content-length:")
            .and_then(|n| n.trim().parse::<usize>().ok())
    });
    if let Some(n) = length {
        while got.len() < split + n {
            let k = s.read(&mut chunk).unwrap();
            assert!(k > 0, "closed inside the body");
            got.extend_from_slice(&chunk[..k]);
        }
        got.truncate(split + n);
    } else {
        s.read_to_end(&mut got).unwrap();
    }
    let code = head
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let raw = String::from_utf8_lossy(&got[split..]).into_owned();
    let body = if head.contains("transfer-encoding: chunked") {
        unchunk(&raw)
    } else {
        raw
    };
    Answer { code, head, body }
}

/// The body of a chunked answer.
fn unchunk(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some((size, after)) = rest.split_once("\r\n") {
        let n = usize::from_str_radix(size.split(';').next().unwrap_or("").trim(), 16).unwrap_or(0);
        if n == 0 || after.len() < n {
            break;
        }
        out.push_str(&after[..n]);
        rest = after[n..].strip_prefix("\r\n").unwrap_or(&after[n..]);
    }
    out
}

/// Standard base64 (with or without padding) to bytes.
pub fn from_base64(text: &str) -> Vec<u8> {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let mut bits = 0u32;
    let mut have = 0u32;
    for c in text.bytes() {
        let Some(v) = ALPHABET.iter().position(|&a| a == c) else {
            continue;
        };
        bits = (bits << 6) | v as u32;
        have += 6;
        if have >= 8 {
            have -= 8;
            out.push((bits >> have) as u8);
            bits &= (1 << have) - 1;
        }
    }
    out
}

/// `ms` since the Unix epoch as JavaScript's `Date.toISOString()` writes it.
pub fn iso_time(ms: u64) -> String {
    let days = (ms / 86_400_000) as i64;
    let in_day = ms % 86_400_000;
    // Days since 1970-01-01 to a civil date (the proleptic Gregorian calendar).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        in_day / 3_600_000,
        in_day / 60_000 % 60,
        in_day / 1000 % 60,
        in_day % 1000
    )
}

/// A child process killed and reaped when dropped, however the test ends.
pub struct Reaped(pub Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A headless Chromium session through its own chromedriver.
pub struct Session {
    driver: SocketAddr,
    id: String,
    _chromedriver: Reaped,
}

impl Session {
    /// Start chromedriver on a free port and open a session of a `width` × `height` window.
    pub fn start(chromium: &Path, chromedriver: &Path, width: u32, height: u32) -> Session {
        Session::start_with(chromium, chromedriver, width, height, &[])
    }

    /// [`Session::start`] with further Chromium arguments (`--ignore-certificate-errors` for a
    /// test's self-signed certificate).
    pub fn start_with(
        chromium: &Path,
        chromedriver: &Path,
        width: u32,
        height: u32,
        extra: &[&str],
    ) -> Session {
        let port = free_port();
        let child = Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let chromedriver = Reaped(child);
        let driver = SocketAddr::from(([127, 0, 0, 1], port));
        wait_for_listener(driver, "chromedriver");
        let args: Vec<String> = [
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
        ]
        .iter()
        .map(|a| (*a).to_owned())
        .chain([format!("--window-size={width},{height}")])
        .chain(extra.iter().map(|a| (*a).to_owned()))
        .collect();
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": chromium,
                "args": args,
            },
        }}});
        let a = request(driver, "POST", "/session", Some(&caps));
        assert_eq!(a.code, 200, "{}", a.body);
        let v: Value = serde_json::from_str(&a.body).unwrap();
        let id = v["value"]["sessionId"].as_str().unwrap().to_owned();
        Session {
            driver,
            id,
            _chromedriver: chromedriver,
        }
    }

    /// One WebDriver command of this session; its `value`.
    pub fn command(&self, method: &str, what: &str, body: Option<&Value>) -> Value {
        let a = request(
            self.driver,
            method,
            &format!("/session/{}/{what}", self.id),
            body,
        );
        assert_eq!(a.code, 200, "{what}: {}", a.body);
        let mut v: Value = serde_json::from_str(&a.body).unwrap();
        v["value"].take()
    }

    /// Load `url`.
    pub fn open(&self, url: &str) {
        self.command("POST", "url", Some(&json!({"url": url})));
    }

    /// Run `script` in the page (its `return` value; a promise it returns is awaited).
    pub fn run(&self, script: &str) -> Value {
        self.command(
            "POST",
            "execute/sync",
            Some(&json!({"script": script, "args": []})),
        )
    }

    /// Run `script` until `done` holds for its value (at most `secs` seconds).
    pub fn wait_for(&self, secs: u64, script: &str, done: impl Fn(&Value) -> bool) -> Value {
        let until = Instant::now() + Duration::from_secs(secs);
        loop {
            let v = self.run(script);
            if done(&v) {
                return v;
            }
            assert!(
                Instant::now() < until,
                "not within {secs} s: {script} gave {v}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// A finger (a touch pointer) put down at (`x0`, `y`), moved to (`x1`, `y`) and lifted;
    /// viewport coordinates in CSS pixels.
    pub fn swipe(&self, x0: i64, x1: i64, y: i64) {
        let actions = json!({"actions": [{
            "type": "pointer", "id": "finger", "parameters": {"pointerType": "touch"},
            "actions": [
                {"type": "pointerMove", "duration": 0, "origin": "viewport", "x": x0, "y": y},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerMove", "duration": 150, "origin": "viewport", "x": (x0 + x1) / 2, "y": y},
                {"type": "pointerMove", "duration": 150, "origin": "viewport", "x": x1, "y": y},
                {"type": "pointerUp", "button": 0},
            ],
        }]});
        self.command("POST", "actions", Some(&actions));
        self.command("DELETE", "actions", None);
    }

    /// The page as `target/ui-screenshots/NAME.png`; its path.
    pub fn screenshot(&self, name: &str) -> PathBuf {
        let png = from_base64(self.command("GET", "screenshot", None).as_str().unwrap());
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
        save_artifact(&format!("{name}.png"), &png)
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        let _ = request(
            self.driver,
            "DELETE",
            &format!("/session/{}", self.id),
            None,
        );
    }
}

/// Write `bytes` to `target/ui-screenshots/NAME`; its path.
pub fn save_artifact(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/ui-screenshots");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn wait_for_listener(addr: SocketAddr, what: &str) {
    let until = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "{what} did not listen on {addr}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A directory of its own under the system's temporary one, removed when dropped.
pub struct Scratch(pub PathBuf);

impl Scratch {
    /// A new, empty one named after `what`, this process and thread.
    pub fn new(what: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!(
            "drivebus-{what}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `drivectl gateway --simulate` on the example plant, without broker and metrics, its page
/// on 127.0.0.1:`port`; returned once the page listens.
pub fn example_gateway(port: u16) -> (Reaped, Scratch) {
    let dir = Scratch::new("ui");
    let drivectl = env!("CARGO_BIN_EXE_drivectl");
    let example = Command::new(drivectl)
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    assert!(example.status.success());
    let config = String::from_utf8(example.stdout)
        .unwrap()
        .replacen("broker = \"mqtt://127.0.0.1:1883\"", "broker = \"off\"", 1)
        .replacen("metrics = \"127.0.0.1:9464\"", "metrics = \"off\"", 1)
        + &format!("\n[ui]\nlisten = \"127.0.0.1:{port}\"\n");
    let path = dir.0.join("plant.toml");
    std::fs::write(&path, config).unwrap();
    let child = Command::new(drivectl)
        .args(["gateway", "--simulate", "--config"])
        .arg(&path)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let gateway = Reaped(child);
    wait_for_listener(SocketAddr::from(([127, 0, 0, 1], port)), "the page");
    (gateway, dir)
}
