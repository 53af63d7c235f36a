//! Backup and restore of a drive's parameters, for every family, over a [`ParamClient`].
//!
//! The backup is a JSON document with every readable parameter of the family's table (one value
//! per bus index and sub-index) and the drive's identification. Restore checks the whole file
//! against the table before it writes anything (every value must fit its parameter's width, and
//! unless forced lie in its range), writes the writable parameters that differ non-volatilely,
//! then reads every one back and compares. The file is written to a temporary name and renamed,
//! so an interrupted backup never leaves a truncated file behind.

use std::collections::BTreeSet;
use std::path::Path;

use drive_profile::family::{self, AnyParam};
use drive_profile::{Family, Persistence};
use serde_json::{Value, json};

use super::client::{ClientError, ParamClient, Target};
use super::output::print_value;
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
            Err(ClientError::Device(_)) => skipped += 1,
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
        println!(
            "{}",
            json!({"file": out.display().to_string(), "parameters": saved, "skipped": skipped})
        );
    } else {
        println!(
            "saved {saved} parameters to {} ({skipped} not present on this drive)",
            out.display()
        );
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

/// Parse and check a backup file; every problem is reported with its entry.
fn load(file: &Path, family: Family, not_restored: &[u16], force: bool) -> Result<Vec<Entry>> {
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
        return Err(CliError::usage(format!(
            "{} is a backup of a {} drive, not of a {family} drive",
            file.display(),
            field(&doc, "family").as_str().unwrap_or("unknown")
        )));
    }
    let list = field(&doc, "parameters")
        .as_array()
        .ok_or_else(|| CliError::usage("backup file has no `parameters` list"))?;
    let mut entries = Vec::new();
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
        if !param.access().is_writable() || not_restored.contains(&index) {
            continue;
        }
        let target = Target::of(param);
        target
            .check_width(raw)
            .map_err(|e| bad(format!("{}: {e}", target.label())))?;
        if !force && !param.in_range(raw) {
            let (lo, hi) = param.raw_range().unwrap_or((raw, raw));
            return Err(bad(format!(
                "{} {}: raw {raw} is outside {lo} … {hi}; fix the file or use --force",
                target.label(),
                param.name_en()
            )));
        }
        entries.push(Entry { target, raw });
    }
    Ok(entries)
}

/// Write a backup back and verify it.
pub async fn restore<C: ParamClient>(
    client: &mut C,
    file: &Path,
    force: bool,
    json: bool,
) -> Result<()> {
    let entries = load(file, client.family(), client.not_restored(), force)?;
    let bar = progress(entries.len(), "writing");
    let mut refused = Vec::new();
    for e in &entries {
        bar.set_message(e.target.label());
        let current = client.read(&e.target).await?;
        if current != e.raw {
            match client
                .write(&e.target, e.raw, Persistence::NonVolatile)
                .await
            {
                Ok(()) => {}
                Err(ClientError::Device(why)) => {
                    refused.push(format!("{} ({why})", e.target.label()))
                }
                Err(err) => {
                    bar.abandon();
                    return Err(err.into());
                }
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let bar = progress(entries.len(), "verifying");
    let mut mismatches = Vec::new();
    for e in &entries {
        let back = client.read(&e.target).await?;
        if back != e.raw {
            mismatches.push((e, back));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for (e, back) in &mismatches {
        print_value(&e.target, *back, json);
    }
    if json {
        println!(
            "{}",
            json!({"file": file.display().to_string(), "written": entries.len(),
                   "refused": refused, "mismatches": mismatches.len()})
        );
    } else {
        println!(
            "restored {} parameters from {}",
            entries.len(),
            file.display()
        );
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
