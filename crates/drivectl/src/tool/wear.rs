//! Remembers non-volatile writes across `drivectl` runs, so that a script calling `drivectl …
//! write` in a loop is stopped by the EEPROM-wear rule of the write guard just like a program
//! that keeps one guard alive. The same log serves every family.
//!
//! The log is a small JSON object `{"<drive> <family> <index> <sub>": unix-milliseconds}` in
//! `$DRIVECTL_STATE_DIR`, else `$XDG_STATE_HOME/drivectl`, else `~/.local/state/drivectl`.
//! It is rewritten through a temporary file and a rename, so it is never half-written; a log
//! that cannot be read is treated as empty (the guard then knows only this run's writes).

use std::path::PathBuf;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::Instant;
use drive_profile::ParamMeta;
use drive_profile::guard::WriteGuard;
use serde_json::{Map, Value};

const FILE: &str = "eeprom-writes.json";

/// How long entries are kept.
const KEEP: Duration = Duration::from_secs(60);

fn dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("DRIVECTL_STATE_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_STATE_HOME") {
        return Some(PathBuf::from(d).join("drivectl"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state/drivectl"))
}

fn key(drive: &str, param: &dyn ParamMeta) -> String {
    format!(
        "{drive} {} {} {}",
        param.family(),
        param.bus_index(),
        param.sub_index().unwrap_or(0)
    )
}

/// Wall-clock time as the guard's [`Instant`] (since the Unix epoch), so that times from the
/// log and from this run compare.
pub fn now() -> Instant {
    Instant::from_duration(
        SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default(),
    )
}

fn load() -> Map<String, Value> {
    dir()
        .and_then(|d| std::fs::read_to_string(d.join(FILE)).ok())
        .and_then(|t| serde_json::from_str::<Value>(&t).ok())
        .and_then(|v| v.as_object().cloned())
        .unwrap_or_default()
}

/// Tell `guard` about the last non-volatile write of `param` on `drive`, if the log has one.
pub fn prime(guard: &mut WriteGuard, drive: &str, param: &dyn ParamMeta) {
    let log = load();
    if let Some(ms) = log.get(&key(drive, param)).and_then(Value::as_u64) {
        guard.remember(param, Instant::from_millis(ms));
    }
}

/// Record a non-volatile write of `param` on `drive` that just happened (entries older than a
/// minute are dropped).
pub fn record(drive: &str, param: &dyn ParamMeta) {
    let Some(d) = dir() else { return };
    let now_ms = now().as_nanos() / 1_000_000;
    let keep_ms = KEEP.as_millis() as u64;
    let mut log = load();
    log.retain(|_, v| {
        v.as_u64()
            .is_some_and(|t| now_ms.saturating_sub(t) < keep_ms)
    });
    log.insert(key(drive, param), Value::from(now_ms));
    let text = Value::Object(log).to_string();
    let tmp = d.join(format!("{FILE}.{}", std::process::id()));
    let _ = std::fs::create_dir_all(&d)
        .and_then(|()| std::fs::write(&tmp, text))
        .and_then(|()| std::fs::rename(&tmp, d.join(FILE)));
}
