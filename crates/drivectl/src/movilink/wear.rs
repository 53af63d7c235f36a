//! Remembers non-volatile writes across `drivectl` runs, so that a script calling
//! `drivectl movilink write` in a loop is stopped by the EEPROM-wear rule of the write guard
//! just like a program that keeps one `WriteGuard` alive.
//!
//! The log is a small JSON object `{"<port> <address> <index>": unix-milliseconds}` in
//! `$DRIVECTL_STATE_DIR`, else `$XDG_STATE_HOME/drivectl`, else `~/.local/state/drivectl`.
//! It is rewritten through a temporary file and a rename, so it is never half-written; a log
//! that cannot be read is treated as empty (the guard then knows only this run's writes).

use movilink::guard::{MIN_NV_INTERVAL, WriteGuard};
use serde_json::{Map, Value};
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

const FILE: &str = "eeprom-writes.json";

fn dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("DRIVECTL_STATE_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_STATE_HOME") {
        return Some(PathBuf::from(d).join("drivectl"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state/drivectl"))
}

fn key(port: &str, address: u8, index: u16) -> String {
    format!("{port} {address} {index}")
}

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

fn load() -> Map<String, Value> {
    dir()
        .and_then(|d| std::fs::read_to_string(d.join(FILE)).ok())
        .and_then(|t| serde_json::from_str::<Value>(&t).ok())
        .and_then(|v| v.as_object().cloned())
        .unwrap_or_default()
}

/// Tell `guard` about the last non-volatile write of `index` on this port and address, if it
/// was recent enough to matter.
pub fn prime(guard: &mut WriteGuard, port: &str, address: u8, index: u16) {
    let log = load();
    let Some(at) = log.get(&key(port, address, index)).and_then(Value::as_u64) else {
        return;
    };
    let ago = Duration::from_millis(now_ms().saturating_sub(at));
    if ago < MIN_NV_INTERVAL {
        if let Some(then) = Instant::now().checked_sub(ago) {
            guard.record(index, false, then);
        }
    }
}

/// Record a non-volatile write that just happened (entries older than a minute are dropped).
pub fn record(port: &str, address: u8, index: u16) {
    let Some(d) = dir() else { return };
    let now = now_ms();
    let mut log = load();
    log.retain(|_, v| v.as_u64().is_some_and(|t| now.saturating_sub(t) < 60_000));
    log.insert(key(port, address, index), Value::from(now));
    let text = Value::Object(log).to_string();
    let tmp = d.join(format!("{FILE}.{}", std::process::id()));
    let _ = std::fs::create_dir_all(&d)
        .and_then(|()| std::fs::write(&tmp, text))
        .and_then(|()| std::fs::rename(&tmp, d.join(FILE)));
}
