//! `drivectl movilink backup --out FILE` and `restore FILE`.
//!
//! The backup is a JSON document with every readable parameter of the MOVIDRIVE table (one
//! value per index). Restore checks the whole file against the table before it writes anything,
//! writes the writable parameters non-volatilely, then reads every one back and compares.
//! The file is written to a temporary name and renamed, so an interrupted backup never leaves
//! a truncated file behind.

use super::{Target, driver_error, print_value};
use crate::error::{CliError, Result};
use crate::params::label;
use drive_profile::{ParamMeta, sew};
use movilink::Address;
use movilink::driver::{CharIo, DriverError, MasterDriver};
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::path::Path;

/// Format name in the file's `format` field.
pub const FORMAT: &str = "drivebus-movilink-backup";
/// Version of the file layout.
pub const VERSION: u64 = 1;

/// Parameters a restore never writes: commands and the bus settings of the link in use.
/// P802 factory setting, P803 parameter lock, P810/P811 RS-485 address and group address
/// (writing them would cut the connection the restore runs on), P840 manual reset.
const NOT_RESTORED: [u16; 5] = [8594, 8595, 8597, 8598, 8617];

/// The rows a backup covers: first row of each index, readable, not a fault-memory sub-entry.
fn rows() -> Vec<&'static sew::Param> {
    let mut seen = BTreeSet::new();
    sew::params()
        .iter()
        .filter(|p| p.number().is_some())
        .filter(|p| seen.insert(p.bus_index()))
        .collect()
}

fn progress(len: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{what} {{pos}}/{{len}} {{bar:30}} {{msg}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Read every parameter and write the backup file.
pub async fn backup<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    out: &Path,
    json: bool,
) -> Result<()> {
    let device_type = m.read(addr, 8301).await.map_err(driver_error)?;
    let firmware = m.read(addr, 8300).await.map_err(driver_error)?;
    let rows = rows();
    let bar = progress(rows.len(), "reading");
    let mut entries = Vec::new();
    let mut skipped = 0;
    for p in &rows {
        bar.set_message(label(*p));
        match m.read(addr, p.bus_index()).await {
            Ok(raw) => entries.push(json!({
                "index": p.bus_index(), "number": label(*p), "name": p.name_en(),
                "raw": i64::from(raw as i32), "writable": p.access().is_writable(),
            })),
            // A drive without an option card answers "not implemented" or "option card
            // missing" for its parameters: they are not part of this drive's backup.
            Err(DriverError::Device(_)) => skipped += 1,
            Err(e) => {
                bar.abandon();
                return Err(driver_error(e));
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let doc = json!({
        "format": FORMAT, "version": VERSION, "address": addr.get(),
        "device_type": device_type, "firmware": firmware, "parameters": entries,
    });
    let text = serde_json::to_string_pretty(&doc)
        .map_err(|e| CliError::failed(format!("cannot encode the backup: {e}")))?;
    let tmp = out.with_extension("tmp-drivectl");
    std::fs::write(&tmp, text.as_bytes())
        .and_then(|()| std::fs::rename(&tmp, out))
        .map_err(|e| CliError::failed(format!("cannot write {}: {e}", out.display())))?;
    let saved = doc["parameters"].as_array().map_or(0, Vec::len);
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
    param: &'static sew::Param,
    raw: i64,
}

/// Parse and check a backup file; every problem is reported with its entry.
fn load(file: &Path, force: bool) -> Result<Vec<Entry>> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| CliError::failed(format!("cannot read {}: {e}", file.display())))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| {
        CliError::usage(format!(
            "{} is not a drivectl backup (invalid JSON: {e})",
            file.display()
        ))
    })?;
    if doc["format"] != FORMAT || doc["version"] != VERSION {
        return Err(CliError::usage(format!(
            "{} is not a {FORMAT} version {VERSION} file",
            file.display()
        )));
    }
    let list = doc["parameters"]
        .as_array()
        .ok_or_else(|| CliError::usage("backup file has no `parameters` list"))?;
    let mut entries = Vec::new();
    for (i, e) in list.iter().enumerate() {
        let bad =
            |why: String| CliError::usage(format!("{}: entry {}: {why}", file.display(), i + 1));
        let index = e["index"]
            .as_u64()
            .and_then(|v| u16::try_from(v).ok())
            .ok_or_else(|| bad("no valid `index`".into()))?;
        let raw = e["raw"]
            .as_i64()
            .ok_or_else(|| bad("no integer `raw` value".into()))?;
        let param = sew::by_index(index)
            .ok_or_else(|| bad(format!("index {index} is not in the MOVIDRIVE table")))?;
        if !param.access().is_writable() || NOT_RESTORED.contains(&index) {
            continue;
        }
        if !force && !param.in_range(raw) {
            let (lo, hi) = param.raw_range().unwrap_or((raw, raw));
            return Err(bad(format!(
                "{} {}: raw {raw} is outside {lo} … {hi}; fix the file or use --force",
                label(param),
                param.name_en()
            )));
        }
        entries.push(Entry { param, raw });
    }
    Ok(entries)
}

/// Write a backup back and verify it.
pub async fn restore<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    file: &Path,
    force: bool,
    json: bool,
) -> Result<()> {
    let entries = load(file, force)?;
    let bar = progress(entries.len(), "writing");
    let mut refused = Vec::new();
    for e in &entries {
        bar.set_message(label(e.param));
        let current = m
            .read(addr, e.param.bus_index())
            .await
            .map_err(driver_error)?;
        if i64::from(current as i32) != e.raw {
            match m
                .write(addr, e.param.bus_index(), e.raw as i32 as u32)
                .await
            {
                Ok(()) => {}
                Err(DriverError::Device(rc)) => {
                    refused.push(format!("{} ({rc:?})", label(e.param)))
                }
                Err(err) => {
                    bar.abandon();
                    return Err(driver_error(err));
                }
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let bar = progress(entries.len(), "verifying");
    let mut mismatches = Vec::new();
    for e in &entries {
        let back = m
            .read(addr, e.param.bus_index())
            .await
            .map_err(driver_error)?;
        if i64::from(back as i32) != e.raw {
            mismatches.push((e, back));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for (e, back) in &mismatches {
        print_value(
            Target {
                index: e.param.bus_index(),
                param: Some(e.param),
            },
            *back,
            json,
        );
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
             check controller inhibit and the parameter lock (P803)",
            mismatches.len(),
            refused.len(),
            refused.join(", ")
        )));
    }
    Ok(())
}
