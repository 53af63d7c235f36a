//! Backup and restore on the command line, for every family: `drive_client`'s
//! [backup](drive_client::backup) and [restore](drive_client::restore) engines with the file
//! read and written here, what they did printed as text or JSON, the progress bar, and their
//! refusals said with the options that are the way out (`--overwrite`, `--force`, `--yes`,
//! `--any-device`).
//!
//! The backup file's path is checked before the first read ([`OutputFile`]: regular files only,
//! a symlink is followed, an existing file is replaced only with `--overwrite`) and the file is
//! written to a temporary name and renamed, so an interrupted backup never leaves a truncated
//! file behind; its bytes are the library's ([`drive_client::backup::Backup::text`]).
//!
//! Restore reads the file (never a device node, at most [`MAX_LEN`]) and checks the whole of it
//! before it writes anything ([`BackupFile::parse`]). Every identification field the file and
//! the drive both know must match except the address: `--any-device` overrides; another
//! firmware is a warning. Every value that differs passes the one write path's checks (access,
//! range, value list, EEPROM wear; `--force` skips all but the width); every refusal is listed
//! at once. A setting of the link the restore talks over is written only with `--yes`.
//! `--dry-run` stops there and shows the changes as old → new. Otherwise the changed values are
//! written non-volatilely and logged in the EEPROM-wear log, shown as old → new, and every
//! entry compared is read back; a mismatch shows the expected and the read value.
//!
//! Everything shown names its value by [`Target::title`]; the JSON objects (`change`,
//! `mismatch`, the `skipped` list of the `restore` summary) carry the keys of [`target_json`].
//! A restore lists every entry it does not write and why ([`Skip`]: `reason` in JSON); values
//! the drive already holds are counted. A restore that stops halfway (a signal: exit 128 + its
//! number; the drive gone) lists what was written and what was not: running it again finishes
//! it.

use std::path::Path;

use drive_client::backup::{self as engine, BackupFile, FileError, MAX_LEN, Skip};
use drive_client::progress::FieldDiff;
use drive_client::restore::{self as restoring, Change, Halt, RestoreError};
use drive_client::{Cause, Notice};
use drive_profile::Family;
use drive_profile::guard::GuardError;
use serde_json::{Value, json};

pub use drive_client::backup::{FORMAT, VERSION};

use super::client::{ParamClient, Target};
// The tests' scripted drive answers with these.
#[cfg(test)]
use super::client::{ClientError, DeviceErrorKind};
use super::interrupt::{Interrupt, Stop};
use super::outfile::OutputFile;
use super::output::{physical_text, target_json};
use super::progress::Bar;
pub use super::progress::progress;
use super::write::{self, FileWearLog, WriteError};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;

/// ` by SIGTERM` (the signal that interrupted the work), or nothing.
fn by(cause: &Cause) -> String {
    Stop::of(cause.code).map_or_else(String::new, |s| format!(" by {}", s.name()))
}

/// The error of work ended by a signal: its exit code is the shell's for that signal (128 + its
/// number; 1 when no signal is known).
fn interrupted(cause: &Cause, message: String) -> CliError {
    match Stop::of(cause.code) {
        Some(s) => CliError::with_code(message, s.exit_code()),
        None => CliError::failed(message),
    }
}

/// Read every parameter and write the backup file `out` (checked before the first read; an
/// existing file only with `overwrite`).
pub async fn backup<C: ParamClient>(
    client: &mut C,
    out: &Path,
    overwrite: bool,
    json: bool,
    stop: &Interrupt,
) -> Result<()> {
    let file = OutputFile::prepare(out, overwrite)?;
    let not_written = |what: String| format!("{what}; {} was not written", out.display());
    let done = engine::backup(client, &mut Bar::new(|_| {}), stop.inner())
        .await
        .map_err(|e| match e {
            engine::BackupError::Identify(e) => e.into(),
            engine::BackupError::Interrupted {
                cause,
                saved,
                total,
            } => interrupted(
                &cause,
                not_written(format!(
                    "the backup was interrupted{} after {saved} of {total} parameters",
                    by(&cause)
                )),
            ),
            engine::BackupError::Read { target, error } => {
                CliError::failed(not_written(target.error(error).to_string()))
            }
            other => CliError::failed(not_written(other.to_string())),
        })?;
    let text = done
        .text()
        .map_err(|e| CliError::failed(format!("cannot encode the backup: {e}")))?;
    file.commit(&text)?;
    let (saved, skipped) = (done.saved.len(), done.absent);
    if json {
        let unreadable: Vec<Value> = done
            .unreadable
            .iter()
            .map(|(t, why)| {
                let mut o = target_json(t);
                o.insert("error".into(), why.message.as_str().into());
                Value::Object(o)
            })
            .collect();
        outln!(
            "{}",
            json!({"type": "backup", "file": out.display().to_string(), "parameters": saved,
                   "skipped": skipped, "unreadable": unreadable})
        )?;
    } else {
        outln!(
            "saved {saved} parameters to {} ({skipped} not present on this drive)",
            out.display()
        )?;
    }
    if !done.unreadable.is_empty() {
        let list: Vec<String> = done
            .unreadable
            .iter()
            .map(|(t, why)| format!("{} ({why})", t.label()))
            .collect();
        return Err(CliError::failed(format!(
            "the backup is incomplete: the drive refused to read {} parameter(s): {}",
            list.len(),
            list.join(", ")
        )));
    }
    Ok(())
}

/// The reason of a skip as JSON's `reason`.
fn code(s: &Skip) -> &'static str {
    match s {
        Skip::LinkSetting => "link_setting",
        Skip::Command => "command",
        Skip::RamOnly => "ram_only",
        Skip::ReadOnly => "read_only",
        Skip::Absent(_) => "absent",
        Skip::Unreadable(_) => "unreadable",
        Skip::Unconfirmed(_) => "needs_yes",
        Skip::Refused(_) => "refused",
        _ => "other",
    }
}

/// The reason for a person (the heading of its group in the text).
fn reason(s: &Skip) -> &'static str {
    match s {
        Skip::LinkSetting => {
            "not restored by rule: settings of the link the restore talks over, whose change \
             would cut the connection"
        }
        Skip::Command => "not restored by rule: commands and locks, which act on the drive",
        Skip::RamOnly => "not restored by rule: RAM-only values (bus control words and setpoints)",
        Skip::ReadOnly => "read-only",
        Skip::Absent(_) => "absent on this drive",
        Skip::Unreadable(_) => "the drive refused to read them, so they were not compared",
        Skip::Unconfirmed(_) => {
            "settings of the link the restore talks over; add --yes to write them"
        }
        Skip::Refused(_) => "refused by the drive",
        _ => "not restored",
    }
}

/// The drive's answer or what a write would do, where there is one.
fn detail(s: &Skip) -> Option<&str> {
    match s {
        Skip::Absent(d) | Skip::Unreadable(d) | Skip::Refused(d) => Some(&d.message),
        Skip::Unconfirmed(change) => Some(change),
        _ => None,
    }
}

/// The order of the groups in the text.
fn rank(s: &Skip) -> u8 {
    match s {
        Skip::LinkSetting => 0,
        Skip::Command => 1,
        Skip::RamOnly => 2,
        Skip::ReadOnly => 3,
        Skip::Absent(_) => 4,
        Skip::Unconfirmed(_) => 5,
        Skip::Unreadable(_) => 6,
        Skip::Refused(_) => 7,
        _ => 8,
    }
}

/// The skipped entries as text: one line per reason, `skipped (reason): P813, P816` (a drive's
/// answer or a link change in brackets after its entry); read-only entries as a count (a backup
/// holds every readable value; `--json` lists them).
fn skipped_lines(skipped: &[(Target, Skip)]) -> Vec<String> {
    let mut sorted: Vec<&(Target, Skip)> = skipped.iter().collect();
    sorted.sort_by_key(|(_, s)| rank(s));
    let mut lines = Vec::new();
    for group in sorted.chunk_by(|a, b| rank(&a.1) == rank(&b.1)) {
        let Some((_, first)) = group.first() else {
            continue;
        };
        let list = if *first == Skip::ReadOnly {
            format!("{} parameter(s) (--json lists them)", group.len())
        } else {
            group
                .iter()
                .map(|(t, s)| match detail(s) {
                    Some(d) => format!("{} ({d})", t.label()),
                    None => t.label(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        lines.push(format!("skipped ({}): {list}", reason(first)));
    }
    lines
}

/// ` (listed above)` after the count of skipped entries, when there are any.
fn listed(skipped: &[(Target, Skip)]) -> &'static str {
    if skipped.is_empty() {
        ""
    } else {
        " (listed above)"
    }
}

/// The skipped entries as JSON: the target's keys ([`target_json`]) with `reason` (a code:
/// `link_setting`, `command`, `ram_only`, `read_only`, `absent`, `unreadable`, `needs_yes`,
/// `refused`), `message` (the reason for a person, with the drive's answer) and, where an
/// option writes it, `hint`.
fn skipped_json(skipped: &[(Target, Skip)]) -> Value {
    Value::Array(
        skipped
            .iter()
            .map(|(t, s)| {
                let mut o = target_json(t);
                o.insert("reason".into(), code(s).into());
                let message = match detail(s) {
                    Some(d) => format!("{}: {d}", reason(s)),
                    None => reason(s).to_owned(),
                };
                o.insert("message".into(), message.into());
                if matches!(s, Skip::Unconfirmed(_)) {
                    o.insert("hint".into(), "--yes".into());
                }
                Value::Object(o)
            })
            .collect(),
    )
}

/// The guard's message with what `restore` offers as a way out.
fn restore_hint(e: &GuardError) -> String {
    let hint = match e {
        GuardError::TooFrequent { .. } => "restore again in a second, or use --force",
        GuardError::DoesNotFit { .. } => return write::hint_of(e).unwrap_or_default(),
        _ => "fix the file, or use --force to let the drive decide",
    };
    format!("; {hint}")
}

/// A refusal of the write path for a change, as `restore` says it.
fn refusal_text(e: &WriteError) -> String {
    match e {
        WriteError::Guard { error, message } => message.clone() + &restore_hint(error),
        e => CliError::from(e.clone()).to_string(),
    }
}

/// A backup file's problem, said with its path: a usage error.
fn file_error(file: &Path, e: &FileError) -> CliError {
    let f = file.display();
    CliError::usage(match e {
        FileError::NotUtf8 { at } => {
            format!("{f} is not a drivectl backup (not UTF-8 text at byte {at})")
        }
        FileError::Json(e) => format!("{f} is not a drivectl backup (invalid JSON: {e})"),
        FileError::Format => format!("{f} is not a {FORMAT} version {VERSION} file"),
        FileError::OtherFamily { saved, family } => {
            format!("{f} is a backup of a {saved} drive, not of a {family} drive")
        }
        FileError::NoFamily { family } => {
            format!("{f} names no drive family (`family`); it is not a {family} backup")
        }
        FileError::NoList => format!("{f} has no `parameters` list; it is not a drivectl backup"),
        FileError::Empty => format!("{f} holds no parameters; there is nothing to restore"),
        FileError::Entry { entry, problem } => format!("{f}: entry {entry}: {problem}"),
        other => format!("{f}: {other}"),
    })
}

/// Read and check a backup file (see [`BackupFile::parse`]); every problem is reported with
/// its entry.
fn load(
    file: &Path,
    family: Family,
    not_restored: &[u16],
    link_settings: &[u16],
) -> Result<BackupFile> {
    let bytes = super::infile::read_limited(file, false, MAX_LEN)?;
    BackupFile::parse(&bytes, family, not_restored, link_settings).map_err(|e| file_error(file, &e))
}

/// Check a restore file without a drive (before a port is opened): it must be a backup of
/// `family` that holds parameters, each named once and fitting its width.
pub fn check_file(file: &Path, family: Family, not_restored: &[u16]) -> Result<()> {
    load(file, family, not_restored, &[]).map(|_| ())
}

/// The arguments of every family's `backup` command.
#[derive(Debug, Clone, clap::Args)]
pub struct BackupArgs {
    /// Output file: a new regular file (a symlink is followed to one); checked before the
    /// first read. A file replaced with --overwrite keeps its mode and, where possible, its
    /// owner.
    #[arg(long)]
    pub out: std::path::PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

/// The arguments of every family's `restore` command.
#[derive(Debug, Clone, clap::Args)]
pub struct RestoreArgs {
    /// Backup file written by `backup`.
    pub file: std::path::PathBuf,
    /// Write even values the table check refuses (values that do not fit are refused).
    #[arg(long)]
    pub force: bool,
    /// Show what would change (old → new) and what would be skipped, and write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Restore onto a drive whose identification differs from the file's (device type,
    /// variant, configuration: every field both know, except the address; another firmware is
    /// only a warning).
    #[arg(long)]
    pub any_device: bool,
    /// Also write the drive's settings of the link the restore talks over (timeouts, group
    /// address) where the file's differ; without it they are skipped and listed.
    #[arg(long)]
    pub yes: bool,
}

impl RestoreArgs {
    /// How `restore` runs.
    pub fn options(&self) -> RestoreOptions {
        RestoreOptions {
            force: self.force,
            dry_run: self.dry_run,
            any_device: self.any_device,
            yes: self.yes,
        }
    }
}

/// How `restore` was asked to run.
#[derive(Debug, Clone, Copy, Default)]
pub struct RestoreOptions {
    /// Write values the table check refuses (never a value that does not fit).
    pub force: bool,
    /// Show the changes, write nothing.
    pub dry_run: bool,
    /// Restore onto a drive whose identification differs from the file's.
    pub any_device: bool,
    /// Write the settings of the link the restore talks over too.
    pub yes: bool,
}

/// A value as text: physical with unit where the table knows the parameter.
fn value_text(t: &Target, raw: i64) -> String {
    t.param.map_or_else(
        || format!("raw {raw}"),
        |p| format!("{} (raw {raw})", physical_text(p, raw)),
    )
}

/// A change as text: `372 data set 2 Rated speed: 1400 1/min (raw 1400) → 1390 1/min (raw
/// 1390)`.
fn change_text(t: &Target, old: i64, new: i64) -> String {
    format!(
        "{}: {} → {}",
        t.title(),
        value_text(t, old),
        value_text(t, new)
    )
}

/// A change as JSON: the target's keys ([`target_json`]) with `from_raw`, `from`, `to_raw`,
/// `to` (raw and physical values).
fn change_json(t: &Target, old: i64, new: i64) -> Value {
    let mut o = target_json(t);
    o.insert("type".into(), "change".into());
    o.insert("from_raw".into(), old.into());
    o.insert("from".into(), physical_json(t, old));
    o.insert("to_raw".into(), new.into());
    o.insert("to".into(), physical_json(t, new));
    Value::Object(o)
}

/// Print every change, old → new, by its label.
fn print_changes(changes: &[Change], json: bool) -> Result<()> {
    for c in changes {
        if json {
            outln!("{}", change_json(&c.target, c.from, c.to))?;
        } else {
            outln!("{}", change_text(&c.target, c.from, c.to))?;
        }
    }
    Ok(())
}

/// The physical value of `raw` as JSON (raw outside the table).
fn physical_json(t: &Target, raw: i64) -> Value {
    t.param
        .map_or(Value::from(raw), |p| json!(p.to_physical(raw)))
}

/// An identity value for a person: a string as it is, anything else as JSON.
fn identity_text(v: &Value) -> String {
    v.as_str().map_or_else(|| v.to_string(), str::to_owned)
}

/// `<file> was saved from a drive of device type 7, variant act; this drive is device type 8,
/// variant acu`.
fn other_device(file: &Path, differ: &[FieldDiff]) -> String {
    let side = |pick: fn(&FieldDiff) -> &Value| {
        differ
            .iter()
            .map(|d| format!("{} {}", d.key.replace('_', " "), identity_text(pick(d))))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "{} was saved from a drive of {}; this drive is {}",
        file.display(),
        side(|d| &d.saved),
        side(|d| &d.drive)
    )
}

/// What a restore of `file` says while it runs, on standard error.
fn say(file: &Path, notice: &Notice) {
    match notice {
        Notice::OtherDevice(differ) => {
            errln!("drivectl: warning: {}", other_device(file, differ));
        }
        Notice::OtherFirmware(f) => errln!(
            "drivectl: warning: {} was saved from firmware {}; this drive runs firmware {}: \
             parameters may differ between firmware versions",
            file.display(),
            identity_text(&f.saved),
            identity_text(&f.drive)
        ),
        Notice::Warning(w) => errln!("drivectl: warning: {w}"),
        Notice::NotRecorded(e) => errln!("drivectl: warning: {e}"),
        Notice::LinkFollowed { target, note } => {
            errln!("drivectl: note: {}: {note}", target.label());
        }
        other => errln!("drivectl: note: {other:?}"),
    }
}

/// The entries of `skipped` refused or unreadable by the drive: `P130 (its answer)`.
fn answered(skipped: &[(Target, Skip)], unreadable: bool) -> Vec<String> {
    skipped
        .iter()
        .filter_map(|(t, s)| match s {
            Skip::Refused(why) if !unreadable => Some(format!("{} ({why})", t.label())),
            Skip::Unreadable(why) if unreadable => Some(format!("{} ({why})", t.label())),
            _ => None,
        })
        .collect()
}

/// A restore's error before anything was written, or while verifying (`written`: the labels of
/// what was written).
fn restore_error(file: &Path, e: RestoreError, written: &[String]) -> CliError {
    match e {
        RestoreError::File(e) => file_error(file, &e),
        RestoreError::Identify(e) | RestoreError::Key(e) => e.into(),
        RestoreError::OtherDevice(differ) => CliError::usage(format!(
            "{}: nothing was written; add --any-device to restore it anyway",
            other_device(file, &differ)
        )),
        RestoreError::Interrupted {
            phase: drive_client::Phase::Verifying,
            cause,
        } => interrupted(
            &cause,
            format!(
                "the restore was interrupted{} while verifying: {} change(s) were written ({}), \
                 not all were read back; run the restore again to check",
                by(&cause),
                written.len(),
                written.join(", ")
            ),
        ),
        RestoreError::Interrupted { cause, .. } => interrupted(
            &cause,
            format!(
                "the restore was interrupted{} while reading the drive; nothing was written",
                by(&cause)
            ),
        ),
        RestoreError::Read { target, error } => {
            CliError::failed(format!("{}; nothing was written", target.error(error)))
        }
        RestoreError::Verify { target, error } => CliError::failed(format!(
            "{} change(s) were written, but verifying failed: {}; run the restore again to check",
            written.len(),
            target.error(error)
        )),
        other => CliError::failed(other.to_string()),
    }
}

/// Write a backup back and verify it (see the [module docs](self)).
pub async fn restore<C: ParamClient>(
    client: &mut C,
    file: &Path,
    opts: RestoreOptions,
    json: bool,
    stop: &Interrupt,
) -> Result<()> {
    let loaded = load(
        file,
        client.family(),
        client.not_restored(),
        client.link_settings(),
    )?;
    let log = FileWearLog::from_env();
    let rules = restoring::Options {
        force: opts.force,
        any_device: opts.any_device,
        confirm_link_settings: opts.yes,
    };
    let mut bar = Bar::new(|n: &Notice| say(file, n));
    let stop = stop.inner();
    let plan = restoring::plan(client, &loaded, &rules, &log, &mut bar, stop)
        .await
        .map_err(|e| restore_error(file, e, &[]))?;
    let refusals: Vec<String> = plan.refusals.iter().map(refusal_text).collect();
    let (changes, unchanged) = (plan.changes.len(), plan.unchanged());
    if opts.dry_run {
        print_changes(&plan.changes, json)?;
        for r in &refusals {
            errln!("drivectl: would be refused: {r}");
        }
        if json {
            outln!(
                "{}",
                json!({"type": "restore", "dry_run": true, "file": file.display().to_string(),
                       "entries": plan.entries, "changes": changes,
                       "unchanged": unchanged, "refused": refusals,
                       "skipped": skipped_json(&plan.skipped)})
            )?;
        } else {
            for l in skipped_lines(&plan.skipped) {
                outln!("{l}")?;
            }
            outln!(
                "dry run: {changes} of {} parameter(s) in {} differ from the drive and would be \
                 written, {unchanged} already hold the saved value, {} skipped{}; nothing was \
                 written",
                plan.in_file,
                file.display(),
                plan.skipped.len(),
                listed(&plan.skipped)
            )?;
        }
        if !refusals.is_empty() {
            return Err(CliError::usage(format!(
                "{} of the changes would be refused",
                refusals.len()
            )));
        }
        return Ok(());
    }
    if let Some(first) = refusals.first() {
        return Err(CliError::usage(format!(
            "{}: {} change(s) refused, nothing was written: {first}{}",
            file.display(),
            refusals.len(),
            if refusals.len() > 1 {
                format!(
                    " (and {} more; `restore --dry-run` lists them)",
                    refusals.len() - 1
                )
            } else {
                String::new()
            }
        )));
    }
    let applied = match restoring::apply(client, &plan, &log, &mut bar, stop).await {
        Ok(applied) => applied,
        Err(RestoreError::Halted(h)) => {
            let written = &h.applied.written;
            print_changes(written, json)?;
            let written_labels: Vec<String> = written.iter().map(|c| c.target.label()).collect();
            let skipped = plan.skipped_after(&h.applied.refused);
            let missing: Vec<String> = h.not_written.iter().map(|c| c.target.label()).collect();
            let uncertain = h.uncertain().map(Target::label);
            if json {
                outln!(
                    "{}",
                    json!({"type": "restore", "file": file.display().to_string(),
                           "complete": false, "entries": plan.entries,
                           "written": written_labels, "refused": answered(&skipped, false),
                           "not_written": missing, "uncertain": uncertain,
                           "skipped": skipped_json(&skipped)})
                )?;
            }
            let why = match &h.why {
                Halt::Interrupted(cause) => format!("interrupted{}", by(cause)),
                Halt::Link { target, error } => target.error(error.clone()).to_string(),
                other => format!("{other:?}"),
            };
            let message = format!(
                "restore stopped ({why}): the drive is half restored: {} of {changes} change(s) \
                 written ({}), {} not written ({}){}; run the same restore again to finish it \
                 (values the drive already holds are not written again)",
                written.len(),
                if written.is_empty() {
                    "none".to_owned()
                } else {
                    written_labels.join(", ")
                },
                missing.len(),
                missing.join(", "),
                uncertain.map_or_else(String::new, |u| format!(
                    "; {u} was being written when the link failed and may or may not have arrived"
                )),
            );
            return Err(match &h.why {
                Halt::Interrupted(cause) => interrupted(cause, message),
                _ => CliError::failed(message),
            });
        }
        Err(e) => return Err(restore_error(file, e, &[])),
    };
    print_changes(&applied.written, json)?;
    let written: Vec<String> = applied.written.iter().map(|c| c.target.label()).collect();
    let mismatches = restoring::verify(client, &plan, &mut bar, stop)
        .await
        .map_err(|e| restore_error(file, e, &written))?;
    for m in &mismatches {
        let t = &m.target;
        if json {
            let mut o = target_json(t);
            o.insert("type".into(), "mismatch".into());
            o.insert("expected_raw".into(), m.expected.into());
            o.insert("expected".into(), physical_json(t, m.expected));
            o.insert("raw".into(), m.back.into());
            o.insert("value".into(), physical_json(t, m.back));
            outln!("{}", Value::Object(o))?;
        } else {
            outln!(
                "{}: expected {}, the drive holds {}",
                t.title(),
                value_text(t, m.expected),
                value_text(t, m.back)
            )?;
        }
    }
    let skipped = plan.skipped_after(&applied.refused);
    let refused = answered(&skipped, false);
    let unreadable = answered(&skipped, true);
    let compared = plan.compared.len();
    if json {
        outln!(
            "{}",
            json!({"type": "restore", "file": file.display().to_string(), "complete": true,
                   "entries": plan.entries, "written": written.len(), "unchanged": unchanged,
                   "refused": refused, "mismatches": mismatches.len(),
                   "skipped": skipped_json(&skipped)})
        )?;
    } else {
        for l in skipped_lines(&skipped) {
            outln!("{l}")?;
        }
        if written.is_empty() && refused.is_empty() && unreadable.is_empty() {
            outln!(
                "{}: all {compared} parameter(s) compared already held the saved values; nothing \
                 was written ({} skipped{})",
                file.display(),
                skipped.len(),
                if skipped.is_empty() {
                    ""
                } else {
                    ", listed above"
                }
            )?;
        } else {
            outln!(
                "{}: {} parameter(s) written, {unchanged} already held the saved value, {} \
                 skipped{}; {} verified",
                file.display(),
                written.len(),
                skipped.len(),
                listed(&skipped),
                compared - mismatches.len()
            )?;
        }
    }
    let mut failures = Vec::new();
    if !mismatches.is_empty() || !refused.is_empty() {
        failures.push(format!(
            "verify failed: {} value(s) differ after restore, {} write(s) refused by the drive{}; \
             check controller inhibit and the parameter lock",
            mismatches.len(),
            refused.len(),
            if refused.is_empty() {
                String::new()
            } else {
                format!(" ({})", refused.join(", "))
            }
        ));
    }
    if !unreadable.is_empty() {
        failures.push(format!(
            "the restore is incomplete: the drive refused to read {} parameter(s), which were \
             not compared or written: {}",
            unreadable.len(),
            unreadable.join(", ")
        ));
    }
    if !failures.is_empty() {
        return Err(CliError::failed(failures.join("; ")));
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
        let r = rt.block_on(backup(
            &mut FakeClient::new(answers),
            &out,
            false,
            true,
            &Interrupt::never(),
        ));
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
    use crate::movilink::{LINK_SETTINGS, NOT_RESTORED};

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
        let loaded = load(&file, Family::Movidrive, NOT_RESTORED, LINK_SETTINGS).unwrap();
        let indices: Vec<u16> = loaded.entries.iter().map(|e| e.target.index).collect();
        assert_eq!(indices, [8470]);
        // Kept aside, each with its reason.
        let skipped: Vec<(String, Skip)> = loaded
            .skipped
            .iter()
            .map(|(t, s)| (t.label(), s.clone()))
            .collect();
        assert_eq!(
            skipped,
            [
                ("P804".to_owned(), Skip::Command),
                ("P810".to_owned(), Skip::LinkSetting)
            ]
        );
        // A file of another family, and one that names none.
        let err = load(&file, Family::Nord, &[], &[]).unwrap_err().to_string();
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
        let err = load(&file, Family::Movidrive, &[], &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.ends_with("entry 3: P130 appears twice (entries 1 and 3)"),
            "{err}"
        );
        std::fs::write(&file, doc.to_string()).unwrap();
        let mut doc = doc;
        doc.as_object_mut().unwrap().remove("family");
        std::fs::write(&file, doc.to_string()).unwrap();
        let err = load(&file, Family::Movidrive, &[], &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.ends_with("names no drive family (`family`); it is not a movidrive backup"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[cfg(test)]
mod restore_tests {
    use super::*;
    use crate::tool::fake::FakeClient;

    /// Every read answers the index as value (writes do not change it).
    fn index_as_value(i: u16) -> std::result::Result<i64, ClientError> {
        Ok(i64::from(i))
    }

    /// A backup file in a fresh directory with P130…P133 (8470…8473) set to 1000 and the
    /// device type `device_type`; the directory is removed by the caller.
    fn file_with(name: &str, device_type: u64) -> (std::path::PathBuf, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("drivectl-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("b.json");
        let doc = json!({
            "format": FORMAT, "version": VERSION, "family": "movidrive",
            "device_type": device_type, "firmware": 822_609_711,
            "parameters": [
                {"index": 8470, "raw": 1000}, {"index": 8471, "raw": 1000},
                {"index": 8472, "raw": 1000}, {"index": 8473, "raw": 8473},
            ],
        });
        // As Notepad saves it: a byte order mark and CRLF line ends.
        let text = format!("\u{feff}{}", serde_json::to_string_pretty(&doc).unwrap())
            .replace('\n', "\r\n");
        std::fs::write(&file, text).unwrap();
        (dir, file)
    }

    fn drive(device_type: u64) -> FakeClient {
        let mut c = FakeClient::new(index_as_value);
        c.identity.insert("device_type".into(), device_type.into());
        c.identity.insert("firmware".into(), 822_609_711.into());
        c
    }

    fn run(c: &mut FakeClient, file: &Path, opts: RestoreOptions, stop: &Interrupt) -> Result<()> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        // The wear log of these tests lives in their own directory.
        rt.block_on(restore(
            c,
            file,
            RestoreOptions {
                force: true,
                ..opts
            },
            true,
            stop,
        ))
    }

    #[test]
    fn issue7_a_restore_cut_short_by_the_link_says_what_was_written_and_how_to_finish() {
        let (dir, file) = file_with("restore-link", 7);
        let mut c = drive(7);
        c.link_dies_after = Some(1);
        let e = run(
            &mut c,
            &file,
            RestoreOptions::default(),
            &Interrupt::never(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(c.written.len(), 1);
        assert!(
            e.contains("half restored: 1 of 3 change(s) written (P130)"),
            "{e}"
        );
        assert!(e.contains("2 not written (P131, P132)"), "{e}");
        assert!(
            e.contains("P131 was being written when the link failed"),
            "{e}"
        );
        assert!(e.contains("run the same restore again"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_ctrl_c_during_a_restore_finishes_the_write_in_flight_and_reports() {
        let (dir, file) = file_with("restore-int", 7);
        let stop = Interrupt::never();
        let mut c = drive(7);
        c.interrupt_after = Some((2, stop.clone()));
        let e = run(&mut c, &file, RestoreOptions::default(), &stop).unwrap_err();
        // The exit code a shell reports for the signal.
        assert_eq!(e.exit_code(), 130);
        let e = e.to_string();
        assert_eq!(c.written.len(), 2);
        assert!(
            e.contains("restore stopped (interrupted by Ctrl-C (SIGINT))"),
            "{e}"
        );
        assert!(
            e.contains("2 of 3 change(s) written (P130, P131), 1 not written (P132)"),
            "{e}"
        );
        assert!(!e.contains("may or may not"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_restore_checks_the_device_type_and_dry_run_writes_nothing() {
        let (dir, file) = file_with("restore-type", 7);
        let mut c = drive(8);
        let e = run(
            &mut c,
            &file,
            RestoreOptions::default(),
            &Interrupt::never(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("device type 7; this drive is device type 8"),
            "{e}"
        );
        assert!(e.contains("--any-device"), "{e}");
        assert!(c.written.is_empty());
        let dry = RestoreOptions {
            dry_run: true,
            any_device: true,
            ..RestoreOptions::default()
        };
        run(&mut c, &file, dry, &Interrupt::never()).unwrap();
        assert!(c.written.is_empty());
        // Written, and every value read back differs (this drive ignores writes): a mismatch
        // names what was expected.
        let any = RestoreOptions {
            any_device: true,
            ..RestoreOptions::default()
        };
        let e = run(&mut c, &file, any, &Interrupt::never())
            .unwrap_err()
            .to_string();
        assert_eq!(c.written.len(), 3);
        assert!(e.contains("3 value(s) differ"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A file with P130…P133 and the identity fields `identity`, in a fresh directory.
    fn file_identified(name: &str, identity: Value) -> (std::path::PathBuf, std::path::PathBuf) {
        let (dir, file) = file_with(name, 7);
        let text = std::fs::read_to_string(&file).unwrap();
        let mut doc: Value = serde_json::from_str(text.trim_start_matches('\u{feff}')).unwrap();
        for (k, v) in identity.as_object().unwrap() {
            doc[k] = v.clone();
        }
        std::fs::write(&file, doc.to_string()).unwrap();
        (dir, file)
    }

    #[test]
    fn issue18_every_identity_field_both_sides_know_must_match_but_the_address() {
        let (dir, file) =
            file_identified("restore-variant", json!({"variant": "act", "address": 1}));
        let opts = RestoreOptions::default();
        // Another variant: refused, named, with the way out.
        let mut c = drive(7);
        c.identity.insert("variant".into(), "acu".into());
        c.identity.insert("address".into(), 2.into());
        let e = run(&mut c, &file, opts, &Interrupt::never()).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let e = e.to_string();
        assert!(
            e.contains("saved from a drive of variant act; this drive is variant acu"),
            "{e}"
        );
        assert!(e.contains("--any-device"), "{e}");
        assert!(c.written.is_empty());
        // The same variant at another address: restored (a backup clones a drive).
        let mut c = drive(7);
        c.identity.insert("variant".into(), "act".into());
        c.identity.insert("address".into(), 2.into());
        run(&mut c, &file, opts, &Interrupt::never()).unwrap_err();
        assert_eq!(c.written.len(), 3);
        // A drive that does not say its variant (null): not compared.
        let mut c = drive(7);
        c.identity.insert("variant".into(), Value::Null);
        run(&mut c, &file, opts, &Interrupt::never()).unwrap_err();
        assert_eq!(c.written.len(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue18_a_link_setting_is_restored_only_with_yes() {
        let (dir, file) = file_with("restore-yes", 7);
        // P131 (8471) is a setting of the link.
        let mut c = drive(7);
        c.link_settings = &[8471];
        let _ = run(
            &mut c,
            &file,
            RestoreOptions::default(),
            &Interrupt::never(),
        );
        let indices: Vec<u16> = c.written.iter().map(|w| w.0).collect();
        assert_eq!(indices, [8470, 8472]);
        let mut c = drive(7);
        c.link_settings = &[8471];
        let yes = RestoreOptions {
            yes: true,
            ..RestoreOptions::default()
        };
        let _ = run(&mut c, &file, yes, &Interrupt::never());
        let indices: Vec<u16> = c.written.iter().map(|w| w.0).collect();
        assert_eq!(indices, [8470, 8471, 8472]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue18_a_file_without_parameters_says_so() {
        let (dir, file) = file_with("restore-empty", 7);
        let doc = json!({"format": FORMAT, "version": VERSION, "family": "movidrive",
                         "parameters": []});
        std::fs::write(&file, doc.to_string()).unwrap();
        let e = check_file(&file, Family::Movidrive, &[]).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(
            e.to_string()
                .ends_with("holds no parameters; there is nothing to restore"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue7_a_value_wider_than_the_parameter_in_a_file_is_refused_before_any_write() {
        let (dir, file) = file_with("restore-wide", 7);
        let text = std::fs::read_to_string(&file).unwrap();
        std::fs::write(&file, text.replacen("1000", "1099511627776", 1)).unwrap();
        let mut c = drive(7);
        let e = run(
            &mut c,
            &file,
            RestoreOptions::default(),
            &Interrupt::never(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("entry 1") && e.contains("1099511627776"), "{e}");
        assert!(c.written.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
