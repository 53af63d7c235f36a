//! Remembers non-volatile writes across `drivectl` runs, so that a script calling `drivectl …
//! write` in a loop is stopped by the EEPROM-wear rule of the write guard just like a program
//! that keeps one guard alive. The same log serves every family.
//!
//! The log is a small JSON object `{"<drive> <family> <index> <sub>": unix-milliseconds}` (`<sub>`
//! the target's sub-index: a Bonfiglioli data set, a NORD IND word with its parameter set and
//! array element, each its own EEPROM cell) named
//! [`FILE`] in `$DRIVECTL_STATE_DIR`, else `$XDG_STATE_HOME/drivectl`, else
//! `~/.local/state/drivectl`. `<drive>` is the client's [`drive_key`](super::client::ParamClient::drive_key):
//! the canonical port path (symlinks and `//` resolved) and the address the drive really has,
//! so a second path to the same port or a point-to-point address does not start a fresh log.
//!
//! The rule must not switch itself off: a log that cannot be read (damaged) or a state
//! directory that cannot be written refuses non-volatile writes with a message that names the
//! path and the ways out (another `DRIVECTL_STATE_DIR`, `--volatile`, `--force`). The log is
//! rewritten through a temporary file and a rename, so it is never half-written. An entry in
//! the future (a clock set back) counts as a write made now.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::Instant;
use drive_profile::ParamMeta;
use drive_profile::guard::WriteGuard;
use serde_json::{Map, Value};

use crate::error::{CliError, Result};

/// The log's file name inside the state directory.
pub const FILE: &str = "eeprom-writes.json";

/// How long entries are kept.
const KEEP: Duration = Duration::from_secs(60);

/// Where the state directory is, and why (for messages and `--help`).
pub fn dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("DRIVECTL_STATE_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_STATE_HOME") {
        return Some(PathBuf::from(d).join("drivectl"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state/drivectl"))
}

fn key(drive: &str, param: &dyn ParamMeta, sub: u16) -> String {
    format!("{drive} {} {} {sub}", param.family(), param.bus_index())
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

/// How a refusal for an unusable log ends on the command line (the gateway, which has no
/// such options, says its own way out instead).
pub const CLI_WAY_OUT: &str = "; set DRIVECTL_STATE_DIR to a writable directory, write with \
                               --volatile, or --force to write without the rule";

/// The refusal when the log cannot be kept: the rule would be off.
fn unusable(what: &str, path: &Path, e: &dyn std::fmt::Display) -> CliError {
    CliError::failed(format!(
        "the EEPROM-wear log {} {what} ({e}), so non-volatile writes cannot be counted: nothing \
         was sent{CLI_WAY_OUT}",
        path.display()
    ))
}

/// The state directory, or a refusal when none can be found.
fn state_dir() -> Result<PathBuf> {
    dir().ok_or_else(|| {
        CliError::failed(format!(
            "no place for the EEPROM-wear log (neither DRIVECTL_STATE_DIR, XDG_STATE_HOME nor \
             HOME is set): nothing was sent{CLI_WAY_OUT}"
        ))
    })
}

/// The log as it is on disk (empty when there is none yet).
fn load(d: &Path) -> Result<Map<String, Value>> {
    let path = d.join(FILE);
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice::<Value>(&bytes)
            .ok()
            .and_then(|v| v.as_object().cloned())
            .ok_or_else(|| {
                unusable(
                    "is damaged",
                    &path,
                    &"not a JSON object; delete it to start a new log",
                )
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Map::new()),
        Err(e) => Err(unusable("cannot be read", &path, &e)),
    }
}

/// Make sure the log can be read and written before a non-volatile write is sent: the
/// directory is created if needed and a probe file is written and removed.
pub fn ensure_usable() -> Result<()> {
    let d = state_dir()?;
    load(&d)?;
    // The directory's writability is probed once per process (a restore checks many writes).
    static WRITABLE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    if WRITABLE.load(std::sync::atomic::Ordering::Relaxed) {
        return Ok(());
    }
    let probe = d.join(format!("{FILE}.probe.{}", std::process::id()));
    std::fs::create_dir_all(&d)
        .and_then(|()| std::fs::write(&probe, b"{}"))
        .and_then(|()| std::fs::remove_file(&probe))
        .map_err(|e| unusable("cannot be written", &d.join(FILE), &e))?;
    WRITABLE.store(true, std::sync::atomic::Ordering::Relaxed);
    Ok(())
}

/// Tell `guard` about the last non-volatile write of `param` at sub-index `sub` (the target's:
/// data set, IND word) on `drive`, if the log has one.
pub fn prime(guard: &mut WriteGuard, drive: &str, param: &dyn ParamMeta, sub: u16) -> Result<()> {
    let log = load(&state_dir()?)?;
    if let Some(ms) = log.get(&key(drive, param, sub)).and_then(Value::as_u64) {
        // A write "in the future" (the clock was set back) is taken as one made now.
        let at = Instant::from_millis(ms).min(now());
        guard.remember(param, at);
    }
    Ok(())
}

/// Record a non-volatile write of `param` at sub-index `sub` on `drive` that just happened
/// (entries older than a minute are dropped). The write is done: a failure here is returned
/// for the caller to report, not to undo anything.
pub fn record(drive: &str, param: &dyn ParamMeta, sub: u16) -> Result<()> {
    let d = state_dir()?;
    let now_ms = now().as_nanos() / 1_000_000;
    let keep_ms = KEEP.as_millis() as u64;
    let mut log = load(&d)?;
    log.retain(|_, v| {
        v.as_u64()
            .is_some_and(|t| now_ms.saturating_sub(t) < keep_ms)
    });
    log.insert(key(drive, param, sub), Value::from(now_ms));
    let text = Value::Object(log).to_string();
    let tmp = d.join(format!("{FILE}.{}", std::process::id()));
    std::fs::create_dir_all(&d)
        .and_then(|()| std::fs::write(&tmp, text))
        .and_then(|()| std::fs::rename(&tmp, d.join(FILE)))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            CliError::failed(format!(
                "the write was sent, but the EEPROM-wear log {} cannot be written ({e}); the \
                 next write of this parameter is not held back by it",
                d.join(FILE).display()
            ))
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_profile::Family;

    #[test]
    fn issue18_every_data_set_and_parameter_set_has_its_own_entry() {
        let p372 = drive_profile::family::lookup(Family::Bonfiglioli, "372").unwrap();
        assert_ne!(key("d", p372, 2), key("d", p372, 3));
        assert_eq!(
            key("/dev/ttyUSB0 1", p372, 2),
            "/dev/ttyUSB0 1 bonfiglioli 372 2"
        );
    }
}
