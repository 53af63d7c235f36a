//! The EEPROM-wear rule across runs: the write guard holds back a non-volatile write of a
//! parameter that was written less than a second ago, and a [`WearLog`] remembers those writes
//! beyond one guard's life, so that a script calling `drivectl … write` in a loop is stopped just
//! like a program that keeps one guard alive. The same log serves every family and front end.
//!
//! [`FileWearLog`] is the log of the command line and the gateway: a small JSON object `{"<drive>
//! <family> <index> <sub>": unix-milliseconds}` (`<sub>` the target's sub-index: a Bonfiglioli
//! data set, a NORD IND word, each its own EEPROM cell) named [`FILE`] in `$DRIVECTL_STATE_DIR`,
//! else `$XDG_STATE_HOME/drivectl`, else `~/.local/state/drivectl`. `<drive>` is the client's
//! [`drive_key`](crate::ParamClient::drive_key). [`MemoryWearLog`] keeps the same in memory (a
//! program that owns its process, tests).
//!
//! The rule must not switch itself off: a log that cannot be read (damaged) or a state
//! directory that cannot be written refuses non-volatile writes ([`WearLogError`]). The file is
//! rewritten through a temporary file and a rename, so it is never half-written. An entry in
//! the future (a clock set back) counts as a write made now.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::Instant;
use drive_profile::ParamMeta;
use serde_json::{Map, Value};

/// The log's file name inside the state directory.
pub const FILE: &str = "eeprom-writes.json";

/// How long entries are kept.
const KEEP: Duration = Duration::from_secs(60);

/// Why the rule cannot be kept: nothing was sent.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WearLogError {
    /// No state directory can be found.
    #[error(
        "no place for the EEPROM-wear log (neither DRIVECTL_STATE_DIR, XDG_STATE_HOME nor HOME \
         is set): nothing was sent"
    )]
    NoPlace,
    /// The log cannot be read, is damaged, or cannot be written.
    #[error(
        "the EEPROM-wear log {} {what} ({reason}), so non-volatile writes cannot be counted: \
         nothing was sent",
        .path.display()
    )]
    Unusable {
        /// The log file.
        path: PathBuf,
        /// `is damaged`, `cannot be read`, `cannot be written`.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A write was sent, but recording it failed (the next write is not held back by it).
    #[error(
        "the write was sent, but the EEPROM-wear log {} cannot be written ({reason}); the next \
         write of this parameter is not held back by it",
        .path.display()
    )]
    NotRecorded {
        /// The log file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// Where non-volatile writes are remembered.
pub trait WearLog {
    /// Make sure the log can be read and written before a non-volatile write is sent.
    fn ensure_usable(&self) -> Result<(), WearLogError>;

    /// The last non-volatile write of `param` at sub-index `sub` on `drive`, if the log has one.
    fn last_write(
        &self,
        drive: &str,
        param: &dyn ParamMeta,
        sub: u16,
    ) -> Result<Option<Instant>, WearLogError>;

    /// Record a non-volatile write of `param` at `sub` on `drive` that just happened.
    fn record(&self, drive: &str, param: &dyn ParamMeta, sub: u16) -> Result<(), WearLogError>;
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

/// The log in a file of the state directory (see the [module docs](self)).
#[derive(Debug, Clone, Default)]
pub struct FileWearLog {
    /// The directory; `None`: found from the environment at each call.
    dir: Option<PathBuf>,
    /// The directory this log (and its clones) found writable, so that a restore that checks
    /// many writes probes it once; another directory is probed again.
    writable: std::sync::Arc<Mutex<Option<PathBuf>>>,
}

impl FileWearLog {
    /// The log in the directory the environment names (`$DRIVECTL_STATE_DIR`, else
    /// `$XDG_STATE_HOME/drivectl`, else `~/.local/state/drivectl`).
    pub fn from_env() -> Self {
        Self::default()
    }

    /// The log in `dir`.
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: Some(dir.into()),
            writable: std::sync::Arc::default(),
        }
    }

    /// Where the state directory is, if anywhere.
    pub fn dir(&self) -> Option<PathBuf> {
        self.dir.clone().or_else(env_dir)
    }

    fn state_dir(&self) -> Result<PathBuf, WearLogError> {
        self.dir().ok_or(WearLogError::NoPlace)
    }
}

/// The state directory the environment names.
pub fn env_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("DRIVECTL_STATE_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_STATE_HOME") {
        return Some(PathBuf::from(d).join("drivectl"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state/drivectl"))
}

/// The log as it is on disk (empty when there is none yet).
fn load(d: &Path) -> Result<Map<String, Value>, WearLogError> {
    let path = d.join(FILE);
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice::<Value>(&bytes)
            .ok()
            .and_then(|v| v.as_object().cloned())
            .ok_or_else(|| WearLogError::Unusable {
                path,
                what: "is damaged",
                reason: "not a JSON object; delete it to start a new log".into(),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Map::new()),
        Err(e) => Err(WearLogError::Unusable {
            path,
            what: "cannot be read",
            reason: e.to_string(),
        }),
    }
}

impl WearLog for FileWearLog {
    fn ensure_usable(&self) -> Result<(), WearLogError> {
        let d = self.state_dir()?;
        load(&d)?;
        let mut writable = self
            .writable
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if writable.as_ref() == Some(&d) {
            return Ok(());
        }
        let probe = d.join(format!("{FILE}.probe.{}", std::process::id()));
        std::fs::create_dir_all(&d)
            .and_then(|()| std::fs::write(&probe, b"{}"))
            .and_then(|()| std::fs::remove_file(&probe))
            .map_err(|e| WearLogError::Unusable {
                path: d.join(FILE),
                what: "cannot be written",
                reason: e.to_string(),
            })?;
        *writable = Some(d);
        Ok(())
    }

    fn last_write(
        &self,
        drive: &str,
        param: &dyn ParamMeta,
        sub: u16,
    ) -> Result<Option<Instant>, WearLogError> {
        let log = load(&self.state_dir()?)?;
        // A write "in the future" (the clock was set back) is taken as one made now.
        Ok(log
            .get(&key(drive, param, sub))
            .and_then(Value::as_u64)
            .map(|ms| Instant::from_millis(ms).min(now())))
    }

    fn record(&self, drive: &str, param: &dyn ParamMeta, sub: u16) -> Result<(), WearLogError> {
        let d = self.state_dir()?;
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
                WearLogError::NotRecorded {
                    path: d.join(FILE),
                    reason: e.to_string(),
                }
            })
    }
}

/// The log in memory: for a program that owns its process (one guard alive is enough there)
/// and for tests.
#[derive(Debug, Default)]
pub struct MemoryWearLog {
    writes: Mutex<HashMap<String, Instant>>,
}

impl WearLog for MemoryWearLog {
    fn ensure_usable(&self) -> Result<(), WearLogError> {
        Ok(())
    }

    fn last_write(
        &self,
        drive: &str,
        param: &dyn ParamMeta,
        sub: u16,
    ) -> Result<Option<Instant>, WearLogError> {
        let writes = self
            .writes
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        Ok(writes.get(&key(drive, param, sub)).copied())
    }

    fn record(&self, drive: &str, param: &dyn ParamMeta, sub: u16) -> Result<(), WearLogError> {
        let mut writes = self
            .writes
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        writes.insert(key(drive, param, sub), now());
        Ok(())
    }
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

    #[test]
    fn a_damaged_file_refuses_and_a_memory_log_remembers() {
        let dir = std::env::temp_dir().join(format!("drive-client-wear-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(FILE), b"[1, 2]").unwrap();
        let p130 = drive_profile::family::lookup(Family::Movidrive, "P130").unwrap();
        let log = FileWearLog::in_dir(&dir);
        match log.last_write("d", p130, 0) {
            Err(WearLogError::Unusable { what, .. }) => assert_eq!(what, "is damaged"),
            other => panic!("{other:?}"),
        }
        std::fs::remove_file(dir.join(FILE)).unwrap();
        log.record("d", p130, 0).unwrap();
        assert!(log.last_write("d", p130, 0).unwrap().is_some());
        assert!(log.last_write("d", p130, 1).unwrap().is_none());
        let _ = std::fs::remove_dir_all(&dir);
        let m = MemoryWearLog::default();
        assert!(m.last_write("d", p130, 0).unwrap().is_none());
        m.record("d", p130, 0).unwrap();
        assert!(m.last_write("d", p130, 0).unwrap().is_some());
    }

    /// A directory found writable once does not vouch for another: in one process (a gateway,
    /// a program with two logs) each log probes its own directory.
    #[test]
    fn a_writable_directory_does_not_make_another_usable() {
        let base = std::env::temp_dir().join(format!("wear-two-{}", std::process::id()));
        std::fs::create_dir_all(&base).unwrap();
        let good = FileWearLog::in_dir(base.join("state"));
        good.ensure_usable().unwrap();
        good.ensure_usable().unwrap();
        // No log to read there yet, and no directory can be made there, not even by root.
        let bad = FileWearLog::in_dir("/proc/self/drivebus-wear-test");
        match bad.ensure_usable() {
            Err(WearLogError::Unusable { what, .. }) => assert_eq!(what, "cannot be written"),
            other => panic!("an unusable directory passed: {other:?}"),
        }
        let _ = std::fs::remove_dir_all(&base);
    }
}
