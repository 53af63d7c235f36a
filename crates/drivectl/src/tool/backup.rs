//! Backup and restore of a drive's parameters, for every family, over a [`ParamClient`].
//!
//! The backup is a JSON document with every readable parameter of the family's table (one value
//! per bus index and sub-index) and the drive's identification. Restore checks the whole file
//! before it writes anything: every entry must name a parameter of the table once and fit its
//! width, and every value that differs from the drive's passes the one write path's checks
//! (access, range, value list, EEPROM wear; `--force` skips all but the width). It then writes
//! those values non-volatilely, logs them in the EEPROM-wear log, and reads every entry back. The file is written to a temporary name and renamed,
//! so an interrupted backup never leaves a truncated file behind.

use std::collections::BTreeSet;
use std::path::Path;

use drive_profile::family::{self, AnyParam};
use drive_profile::guard::GuardError;
use drive_profile::{Family, Persistence};
use serde_json::{Value, json};

use super::client::{ClientError, DeviceErrorKind, ParamClient, Target};
use super::output::print_value;
use super::write::{self, WriteRequest};
use crate::error::{CliError, Result};

/// Format name in the file's `format` field.
pub const FORMAT: &str = "drivebus-backup";
/// Version of the file layout.
pub const VERSION: u64 = 1;
/// The format of the first MOVILINK-only backups (still restored, as MOVIDRIVE backups).
const LEGACY_MOVILINK: &str = "drivebus-movilink-backup";

/// The parameters a backup covers: numbered rows (SEW's fault-memory sub-entries share the
/// index of their parent), one per bus index and sub-index.
fn rows(family: Family) -> Vec<AnyParam> {
    let mut seen = BTreeSet::new();
    family::params(family)
        .filter(|p| p.number().is_some())
        .filter(|p| seen.insert((p.bus_index(), p.sub_index().unwrap_or(0))))
        .collect()
}

/// A progress bar for `len` steps.
pub fn progress(len: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{what} {{pos}}/{{len}} {{bar:30}} {{msg}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Write `text` to `out` through a temporary file and a rename.
pub fn write_atomic(out: &Path, text: &str) -> Result<()> {
    let tmp = out.with_extension("tmp-drivectl");
    std::fs::write(&tmp, text.as_bytes())
        .and_then(|()| std::fs::rename(&tmp, out))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            CliError::failed(format!("cannot write {}: {e}", out.display()))
        })
}

/// Read every parameter and write the backup file.
pub async fn backup<C: ParamClient>(client: &mut C, out: &Path, json: bool) -> Result<()> {
    let family = client.family();
    let mut doc = client.identify().await?;
    let rows = rows(family);
    let bar = progress(rows.len(), "reading");
    let mut entries = Vec::new();
    let mut skipped = 0;
    let mut unreadable = Vec::new();
    for p in &rows {
        let t = Target::of(*p);
        bar.set_message(t.label());
        match client.read(&t).await {
            Ok(raw) => entries.push(json!({
                "index": t.index, "sub": t.sub, "number": t.label(), "name": p.name_en(),
                "raw": raw, "writable": p.access().is_writable(),
            })),
            // A drive without an option card answers "not implemented" or "option card
            // missing" for its parameters: they are not part of this drive's backup.
            Err(ClientError::Device(d)) if d.kind == DeviceErrorKind::Absent => skipped += 1,
            // Any other refusal is a gap in the backup: saved without it, and said.
            Err(ClientError::Device(d)) => unreadable.push(format!("{} ({d})", t.label())),
            Err(e) => {
                bar.abandon();
                return Err(e.into());
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let saved = entries.len();
    doc.insert("format".into(), FORMAT.into());
    doc.insert("version".into(), VERSION.into());
    doc.insert("family".into(), family.name().into());
    doc.insert("parameters".into(), Value::Array(entries));
    let text = serde_json::to_string_pretty(&Value::Object(doc))
        .map_err(|e| CliError::failed(format!("cannot encode the backup: {e}")))?;
    write_atomic(out, &text)?;
    if json {
        outln!(
            "{}",
            json!({"file": out.display().to_string(), "parameters": saved, "skipped": skipped,
                   "unreadable": unreadable})
        )?;
    } else {
        outln!(
            "saved {saved} parameters to {} ({skipped} not present on this drive)",
            out.display()
        )?;
    }
    if !unreadable.is_empty() {
        return Err(CliError::failed(format!(
            "the backup is incomplete: the drive refused to read {} parameter(s): {}",
            unreadable.len(),
            unreadable.join(", ")
        )));
    }
    Ok(())
}

/// One entry of a backup file, checked against the table.
#[derive(Debug)]
struct Entry {
    target: Target,
    raw: i64,
}

/// `value[key]` without the `Index` operator: the field, or `Null` when it is missing or `value`
/// is not an object (a backup file is user input; nothing here may panic on it).
fn field<'a>(value: &'a Value, key: &str) -> &'a Value {
    value.get(key).unwrap_or(&Value::Null)
}

/// A value of the legacy MOVILINK format, which stored every 32-bit value sign-extended
/// (`i64::from(raw as i32)`): for a parameter that carries no negative values, a negative
/// 32-bit value is the unsigned one it stood for (P221 = 3 000 000 000 was saved as
/// −1 294 967 296). Anything else is left as it is for the width check to judge.
fn legacy_raw(raw: i64, (lo, _): (i64, i64)) -> i64 {
    match i32::try_from(raw) {
        Ok(v) if v < 0 && lo >= 0 => i64::from(v as u32),
        _ => raw,
    }
}

/// The guard's message with what `restore` offers as a way out.
fn restore_hint(e: &GuardError) -> String {
    let hint = match e {
        GuardError::TooFrequent { .. } => "restore again in a second, or use --force",
        GuardError::DoesNotFit { .. } => return write::with_hint(e),
        _ => "fix the file, or use --force to let the drive decide",
    };
    format!("{e}; {hint}")
}

/// Parse and check a backup file; every problem is reported with its entry. Each value must
/// fit its parameter's width; the table's other rules are the write path's, for the values
/// that differ from the drive's.
fn load(file: &Path, family: Family, not_restored: &[u16]) -> Result<Vec<Entry>> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| CliError::failed(format!("cannot read {}: {e}", file.display())))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| {
        CliError::usage(format!(
            "{} is not a drivectl backup (invalid JSON: {e})",
            file.display()
        ))
    })?;
    let legacy = field(&doc, "format") == LEGACY_MOVILINK && family == Family::Movidrive;
    if !(field(&doc, "format") == FORMAT || legacy) || field(&doc, "version") != VERSION {
        return Err(CliError::usage(format!(
            "{} is not a {FORMAT} version {VERSION} file",
            file.display()
        )));
    }
    if !legacy && field(&doc, "family") != family.name() {
        return Err(CliError::usage(match field(&doc, "family").as_str() {
            Some(other) => format!(
                "{} is a backup of a {other} drive, not of a {family} drive",
                file.display()
            ),
            None => format!(
                "{} names no drive family (`family`); it is not a {family} backup",
                file.display()
            ),
        }));
    }
    let list = field(&doc, "parameters")
        .as_array()
        .ok_or_else(|| CliError::usage("backup file has no `parameters` list"))?;
    let mut entries: Vec<Entry> = Vec::new();
    let mut seen = std::collections::BTreeMap::new();
    for (i, e) in list.iter().enumerate() {
        let bad =
            |why: String| CliError::usage(format!("{}: entry {}: {why}", file.display(), i + 1));
        let index = field(e, "index")
            .as_u64()
            .and_then(|v| u16::try_from(v).ok())
            .ok_or_else(|| bad("no valid `index`".into()))?;
        let sub = match field(e, "sub") {
            Value::Null => 0,
            v => v
                .as_u64()
                .and_then(|v| u16::try_from(v).ok())
                .ok_or_else(|| bad("no valid `sub`".into()))?,
        };
        let raw = field(e, "raw")
            .as_i64()
            .ok_or_else(|| bad("no integer `raw` value".into()))?;
        let param = family::params(family)
            .find(|p| p.bus_index() == index && p.sub_index().unwrap_or(0) == sub)
            .ok_or_else(|| bad(format!("index {index} is not in the {family} table")))?;
        let raw = if legacy {
            legacy_raw(raw, param.wire_range())
        } else {
            raw
        };
        if !param.access().is_writable() || not_restored.contains(&index) {
            continue;
        }
        let target = Target::of(param);
        target.check_width(raw).map_err(|e| bad(e.to_string()))?;
        // One parameter twice would be written twice (and its EEPROM with it), the last one
        // winning: a file like that was not made by drivectl.
        if let Some(first) = seen.insert((index, sub), i + 1) {
            return Err(bad(format!(
                "{} appears twice (entries {first} and {})",
                target.label(),
                i + 1
            )));
        }
        entries.push(Entry { target, raw });
    }
    Ok(entries)
}

/// Write a backup back and verify it: read what the drive holds, check every value that
/// differs on the one write path (width always; access, range, value list and the EEPROM-wear
/// rule unless forced) before anything is written, write those non-volatilely and log them in
/// the wear log, then read every entry back.
pub async fn restore<C: ParamClient>(
    client: &mut C,
    file: &Path,
    force: bool,
    json: bool,
) -> Result<()> {
    let entries = load(file, client.family(), client.not_restored())?;
    let bar = progress(entries.len(), "reading");
    let mut changes = Vec::new();
    for e in &entries {
        bar.set_message(e.target.label());
        let current = client
            .read(&e.target)
            .await
            .inspect_err(|_| bar.abandon())?;
        if current != e.raw {
            changes.push(WriteRequest {
                target: e.target,
                raw: e.raw,
                persistence: Persistence::NonVolatile,
                force,
            });
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Every write is checked before the first one is sent: a file that would be refused
    // halfway leaves the drive as it was.
    let drive_key = client.drive_key().await?;
    let mut warnings = Vec::new();
    for req in &changes {
        let warning = write::check_with(&drive_key, req, restore_hint).map_err(|e| {
            CliError::usage(format!("{}: {e}; nothing was written", file.display()))
        })?;
        warnings.extend(warning);
    }
    for w in &warnings {
        errln!("drivectl: warning: {w}");
    }
    let bar = progress(changes.len(), "writing");
    let mut refused = Vec::new();
    let mut written = 0;
    for req in &changes {
        bar.set_message(req.target.label());
        match client.write(&req.target, req.raw, req.persistence).await {
            Ok(()) => {
                if let Err(e) = write::record(&drive_key, req) {
                    bar.suspend(|| errln!("drivectl: warning: {e}"));
                }
                written += 1;
            }
            Err(ClientError::Device(why)) => {
                refused.push(format!("{} ({why})", req.target.label()))
            }
            Err(err) => {
                bar.abandon();
                return Err(err.into());
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let bar = progress(entries.len(), "verifying");
    let mut mismatches = Vec::new();
    for e in &entries {
        let back = client
            .read(&e.target)
            .await
            .inspect_err(|_| bar.abandon())?;
        if back != e.raw {
            mismatches.push((e, back));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for (e, back) in &mismatches {
        print_value(&e.target, *back, json)?;
    }
    if json {
        outln!(
            "{}",
            json!({"file": file.display().to_string(), "entries": entries.len(),
                   "written": written, "refused": refused, "mismatches": mismatches.len()})
        )?;
    } else {
        outln!(
            "restored {} parameter(s) from {}: {written} written, {} already held the saved value",
            entries.len(),
            file.display(),
            entries.len() - changes.len()
        )?;
    }
    if !mismatches.is_empty() || !refused.is_empty() {
        return Err(CliError::failed(format!(
            "verify failed: {} value(s) differ after restore, {} write(s) refused by the drive ({}); \
             check controller inhibit and the parameter lock",
            mismatches.len(),
            refused.len(),
            refused.join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::fake::{FakeClient, refusal};
    use drive_profile::sew::index;

    /// Every read answers the index as value, except: P000 "speed" (8318) is absent, P001
    /// "user display" (8501) refuses reading.
    fn answers(i: u16) -> std::result::Result<i64, ClientError> {
        match i {
            8318 => Err(refusal(DeviceErrorKind::Absent, "not implemented")),
            8501 => Err(refusal(DeviceErrorKind::Refused, "access denied")),
            i => Ok(i64::from(i)),
        }
    }

    #[test]
    fn absent_parameters_are_skipped_and_refused_ones_make_the_backup_fail_loudly() {
        let dir = std::env::temp_dir().join(format!("drivectl-backup-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("b.json");
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let r = rt.block_on(backup(&mut FakeClient::new(answers), &out, true));
        let err = r.unwrap_err().to_string();
        assert!(err.contains("incomplete"), "{err}");
        assert!(err.contains("P001 (access denied)"), "{err}");
        assert!(!err.contains("P000"), "{err}");
        // The file holds everything else.
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        let list = doc["parameters"].as_array().unwrap();
        assert!(list.iter().any(|e| e["index"] == index::RAMP_T11_UP_CW));
        assert!(
            !list
                .iter()
                .any(|e| e["index"] == 8318 || e["index"] == 8501)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[cfg(test)]
mod load_tests {
    use super::*;
    use crate::movilink::NOT_RESTORED;

    #[test]
    fn commands_and_link_settings_in_a_file_are_not_restored() {
        let dir = std::env::temp_dir().join(format!("drivectl-load-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("b.json");
        let doc = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "parameters": [
                {"index": 8470, "raw": 1200},
                // P804 = 1 would clear the fault memory; P810 would move the drive.
                {"index": 8596, "raw": 1},
                {"index": 8597, "raw": 7},
            ],
        });
        std::fs::write(&file, doc.to_string()).unwrap();
        let entries = load(&file, Family::Movidrive, NOT_RESTORED).unwrap();
        let indices: Vec<u16> = entries.iter().map(|e| e.target.index).collect();
        assert_eq!(indices, [8470]);
        // A file of another family, and one that names none.
        let err = load(&file, Family::Nord, &[]).unwrap_err().to_string();
        assert!(
            err.ends_with("is a backup of a movidrive drive, not of a nord drive"),
            "{err}"
        );
        // One parameter twice.
        let twice = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "parameters": [
                {"index": 8470, "raw": 1200}, {"index": 8471, "raw": 1}, {"index": 8470, "raw": 1300},
            ],
        });
        std::fs::write(&file, twice.to_string()).unwrap();
        let err = load(&file, Family::Movidrive, &[]).unwrap_err().to_string();
        assert!(
            err.ends_with("entry 3: P130 appears twice (entries 1 and 3)"),
            "{err}"
        );
        std::fs::write(&file, doc.to_string()).unwrap();
        let mut doc = doc;
        doc.as_object_mut().unwrap().remove("family");
        std::fs::write(&file, doc.to_string()).unwrap();
        let err = load(&file, Family::Movidrive, &[]).unwrap_err().to_string();
        assert!(
            err.ends_with("names no drive family (`family`); it is not a movidrive backup"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
