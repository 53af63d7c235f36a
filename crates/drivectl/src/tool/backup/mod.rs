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
//! `mismatch`, the `skipped` list of the `restore` summary) carry the keys of [`drive_client::meaning::target_json`]; drive-client builds them.
//! A restore lists every entry it does not write and why ([`Skip`]: `reason` in JSON); values
//! the drive already holds are counted. A restore that stops halfway (a signal: exit 128 + its
//! number; the drive gone) lists what was written and what was not: running it again finishes
//! it.

mod restore;
#[cfg(test)]
mod tests;

use std::path::Path;

use drive_client::backup::{self as engine, BackupFile, FileError, MAX_LEN, Skip};
use drive_client::progress::FieldDiff;
use drive_client::restore::{self as restoring, Change, Halt, RestoreError};
use drive_client::{Cause, Notice};
use drive_profile::Family;
use drive_profile::guard::GuardError;

pub use drive_client::backup::{FORMAT, VERSION};

use super::client::{ParamClient, Target};
// The tests' scripted drive answers with these.
#[cfg(test)]
use super::client::{ClientError, DeviceErrorKind};
use super::front::Cli;
use super::interrupt::{Interrupt, Stop};
use super::outfile::OutputFile;
use super::output::physical_text;
use super::progress::Bar;
pub use super::progress::progress;
use super::write::{self, FileWearLog, WriteError};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
pub use restore::restore;

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
            // `Read`: the parameter and the failure.
            other => CliError::failed(not_written(other.to_string())),
        })?;
    let text = done
        .text()
        .map_err(|e| CliError::failed(format!("cannot encode the backup: {e}")))?;
    file.commit(&text)?;
    let (saved, skipped) = (done.saved.len(), done.absent);
    if json {
        outln!("{}", done.summary_json(&out.display().to_string()))?;
    } else {
        outln!(
            "saved {saved} parameters to {} ({skipped} not present on this drive)",
            out.display()
        )?;
    }
    if let Some(gaps) = done.gaps_text() {
        return Err(CliError::failed(gaps));
    }
    Ok(())
}

/// The skipped entries as text: one line per reason, `skipped (reason): P813, P816` (a drive's
/// answer or a link change in brackets after its entry); read-only entries as a count (a backup
/// holds every readable value; `--json` lists them).
fn skipped_lines(skipped: &[(Target, Skip)]) -> Vec<String> {
    let mut sorted: Vec<&(Target, Skip)> = skipped.iter().collect();
    sorted.sort_by_key(|(_, s)| s.order());
    let mut lines = Vec::new();
    for group in sorted.chunk_by(|a, b| a.1.order() == b.1.order()) {
        let Some((_, first)) = group.first() else {
            continue;
        };
        let list = if *first == Skip::ReadOnly {
            format!("{} parameter(s) (--json lists them)", group.len())
        } else {
            group
                .iter()
                .map(|(t, s)| match s.detail() {
                    Some(d) => format!("{} ({d})", t.label()),
                    None => t.label(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        lines.push(format!("skipped ({}): {list}", first.reason(&Cli)));
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
        let rules = restoring::Options {
            force: self.force,
            any_device: self.any_device,
            confirm_link_settings: self.yes,
        };
        RestoreOptions {
            rules,
            dry_run: self.dry_run,
        }
    }
}

/// How `restore` was asked to run.
#[derive(Debug, Clone, Copy, Default)]
pub struct RestoreOptions {
    /// The engine's rules (`--force`, `--any-device`, `--yes`).
    pub rules: restoring::Options,
    /// Show the changes, write nothing.
    pub dry_run: bool,
}
