//! Backup and restore of a drive's parameters, for every family, over a [`ParamClient`].
//!
//! The backup is a JSON document with every readable parameter of the family's table (one value
//! per bus index and sub-index) and the drive's identification (`device_type`, `firmware`). Its
//! path is checked before the first read ([`OutputFile`]: regular files only, a symlink is
//! followed, an existing file is replaced only with `--overwrite`) and the file is written to a
//! temporary name and renamed, so an interrupted backup never leaves a truncated file behind.
//!
//! Restore checks the whole file before it writes anything: it must hold parameters, every
//! entry must name a parameter of the table once and fit its width (a UTF-8 byte order mark, as
//! Notepad writes it, is skipped), and every identification field the file and the drive both
//! know (device type, variant, configuration; `null` is unknown) must match, except the
//! drive's place on the bus (its address): `--any-device` overrides; another firmware is a
//! warning. Every value that differs from the drive's passes the one write path's checks
//! (access, range, value list, EEPROM wear; `--force` skips all but the width); every refusal
//! is listed at once. A value of the drive's settings of the link the restore talks over
//! ([`ParamClient::link_settings`]: a timeout, a group address) is written only with `--yes`.
//! `--dry-run` stops there and shows the changes as old → new. Otherwise the changed values are
//! written non-volatilely and logged in the EEPROM-wear log, shown as old → new, and every
//! entry compared is read back; a mismatch shows the expected and the read value.
//!
//! Everything shown names its value by [`Target::title`] (the label with its data set,
//! parameter set or array element: `372 data set 2 Rated speed`, `P102 set 2 acceleration
//! time`); the JSON objects (`change`, `mismatch`, the `skipped` list of the `restore` summary)
//! carry the keys of [`target_json`]. The backup file's own layout is unchanged.
//!
//! A restore lists every entry it does not write and why ([`Skip`]): not restored by rule
//! ([`ParamClient::not_restored`]: a link setting whose change would cut the connection, a
//! command or lock, a RAM-only value), read-only, absent on this drive, unreadable (the drive
//! refused the read: the restore fails at the end), a link setting without `--yes`, refused by
//! the drive (the restore fails at the end); values the drive already holds are counted.
//!
//! A restore that stops halfway (a signal: exit 128 + its number; the drive gone) lists what was
//! written and what was not: running it again finishes it, since values the drive already holds
//! are not written.

use std::collections::BTreeSet;
use std::path::Path;

use drive_profile::family::{self, AnyParam};
use drive_profile::guard::GuardError;
use drive_profile::{Access, Family, Persistence};
use serde_json::{Map, Value, json};

use super::client::{ClientError, DeviceErrorKind, ParamClient, Target};
use super::interrupt::Interrupt;
use super::outfile::OutputFile;
use super::output::{physical_text, target_json};
use super::write::{self, WriteRequest};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;

/// Format name in the file's `format` field.
pub const FORMAT: &str = "drivebus-backup";
/// Version of the file layout.
pub const VERSION: u64 = 1;
/// The format of the first MOVILINK-only backups (still restored, as MOVIDRIVE backups).
const LEGACY_MOVILINK: &str = "drivebus-movilink-backup";

/// The parameters a backup covers: numbered rows (SEW's fault-memory sub-entries share the
/// index of their parent), one per bus index and sub-index; a data-set parameter
/// ([`Access::DATA_SET`], Bonfiglioli) once per data set 1–4 (its sub-index is the data set;
/// data set 0 addresses all four and is never saved or restored); a NORD parameter once per
/// array element and parameter set (its sub-index is the IND word), with P560 "save to EEPROM"
/// last, so that a restore that turns it off does not send the values after it to RAM only.
fn rows(family: Family) -> Vec<Target> {
    let mut seen = BTreeSet::new();
    let mut rows: Vec<Target> = family::params(family)
        .filter(|p| p.number().is_some())
        .filter(|p| seen.insert((p.bus_index(), p.sub_index().unwrap_or(0))))
        .flat_map(|p| {
            subs(p).into_iter().map(move |sub| Target {
                sub,
                ..Target::of(p)
            })
        })
        .collect();
    if family == Family::Nord {
        rows.sort_by_key(|t| t.index == NORD_SAVE_TO_EEPROM);
    }
    rows
}

/// NORD P560 "save to EEPROM" (PNU 230h): 0 keeps every later parameter write in RAM only.
const NORD_SAVE_TO_EEPROM: u16 = 0x230;

/// The sub-indices a backup holds of `p`: the data sets 1–4 of a data-set parameter, every
/// IND word of a NORD parameter (array elements × parameter sets), else its own sub-index.
fn subs(p: AnyParam) -> Vec<u16> {
    if p.family() == Family::Nord {
        // Every array element in every parameter set: the IND word is the sub-index.
        return super::client::nord_subs(p.bus_index());
    }
    if p.access().contains(Access::DATA_SET) {
        vec![1, 2, 3, 4]
    } else {
        vec![p.sub_index().unwrap_or(0)]
    }
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
    let family = client.family();
    let mut doc = client.identify().await?;
    let rows = rows(family);
    let bar = progress(rows.len(), "reading");
    let mut entries = Vec::new();
    let mut skipped = 0;
    let mut unreadable: Vec<(Target, String)> = Vec::new();
    for t in &rows {
        if stop.requested() {
            bar.abandon();
            return Err(interrupted(
                stop,
                format!(
                    "the backup was interrupted{} after {} of {} parameters; {} was not written",
                    by(stop),
                    entries.len(),
                    rows.len(),
                    out.display()
                ),
            ));
        }
        bar.set_message(t.label());
        match client.read(t).await {
            Ok(raw) => entries.push(json!({
                "index": t.index, "sub": t.sub, "number": t.label(),
                "name": t.param.map(|p| p.name_en()),
                "raw": raw, "writable": t.param.is_some_and(|p| p.access().is_writable()),
            })),
            // A drive without an option card answers "not implemented" or "option card
            // missing" for its parameters: they are not part of this drive's backup.
            Err(ClientError::Device(d)) if d.kind == DeviceErrorKind::Absent => skipped += 1,
            // Any other refusal is a gap in the backup: saved without it, and said.
            Err(ClientError::Device(d)) => unreadable.push((*t, d.message)),
            Err(e) => {
                bar.abandon();
                return Err(CliError::failed(format!(
                    "{}; {} was not written",
                    t.error(e),
                    out.display()
                )));
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
    file.commit(&text)?;
    if json {
        let unreadable: Vec<Value> = unreadable
            .iter()
            .map(|(t, why)| {
                let mut o = target_json(t);
                o.insert("error".into(), why.as_str().into());
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
    if !unreadable.is_empty() {
        let list: Vec<String> = unreadable
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

/// ` by SIGTERM` (the signal that interrupted the work), or nothing.
fn by(stop: &Interrupt) -> String {
    stop.signal()
        .map_or_else(String::new, |s| format!(" by {}", s.name()))
}

/// The error of work ended by a signal: its exit code is the shell's for that signal (128 + its
/// number; 1 when no signal is known).
fn interrupted(stop: &Interrupt, message: String) -> CliError {
    match stop.signal() {
        Some(s) => CliError::with_code(message, s.exit_code()),
        None => CliError::failed(message),
    }
}

/// One entry of a backup file, checked against the table.
#[derive(Debug)]
struct Entry {
    target: Target,
    raw: i64,
}

/// Why a restore did not write an entry of its file. Every one is listed (text and JSON).
#[derive(Debug, Clone, PartialEq, Eq)]
enum Skip {
    /// Not restored by rule: a setting of the link the restore talks over whose change would
    /// cut the connection (address, baud rate, …).
    LinkSetting,
    /// Not restored by rule: a command or lock, which acts on the drive (factory setting,
    /// parameter lock, reset, program).
    Command,
    /// Not restored by rule: a RAM-only value (a bus control word or setpoint).
    RamOnly,
    /// Read-only in the table.
    ReadOnly,
    /// This drive does not have it (the drive's answer).
    Absent(String),
    /// The drive refused to read it (its answer): it could not be compared.
    Unreadable(String),
    /// A setting of the link the restore talks over (a timeout, a group address) that differs:
    /// written only with `--yes`. What the write would do to the link.
    NeedsYes(String),
    /// The drive refused the write (its answer).
    Refused(String),
}

impl Skip {
    /// The reason as JSON's `reason`.
    fn code(&self) -> &'static str {
        match self {
            Skip::LinkSetting => "link_setting",
            Skip::Command => "command",
            Skip::RamOnly => "ram_only",
            Skip::ReadOnly => "read_only",
            Skip::Absent(_) => "absent",
            Skip::Unreadable(_) => "unreadable",
            Skip::NeedsYes(_) => "needs_yes",
            Skip::Refused(_) => "refused",
        }
    }

    /// The reason for a person (the heading of its group in the text).
    fn reason(&self) -> &'static str {
        match self {
            Skip::LinkSetting => {
                "not restored by rule: settings of the link the restore talks over, whose \
                 change would cut the connection"
            }
            Skip::Command => "not restored by rule: commands and locks, which act on the drive",
            Skip::RamOnly => {
                "not restored by rule: RAM-only values (bus control words and setpoints)"
            }
            Skip::ReadOnly => "read-only",
            Skip::Absent(_) => "absent on this drive",
            Skip::Unreadable(_) => "the drive refused to read them, so they were not compared",
            Skip::NeedsYes(_) => {
                "settings of the link the restore talks over; add --yes to write them"
            }
            Skip::Refused(_) => "refused by the drive",
        }
    }

    /// The drive's answer or what a write would do, where there is one.
    fn detail(&self) -> Option<&str> {
        match self {
            Skip::Absent(d) | Skip::Unreadable(d) | Skip::NeedsYes(d) | Skip::Refused(d) => Some(d),
            _ => None,
        }
    }

    /// The order of the groups in the text.
    fn rank(&self) -> u8 {
        match self {
            Skip::LinkSetting => 0,
            Skip::Command => 1,
            Skip::RamOnly => 2,
            Skip::ReadOnly => 3,
            Skip::Absent(_) => 4,
            Skip::NeedsYes(_) => 5,
            Skip::Unreadable(_) => 6,
            Skip::Refused(_) => 7,
        }
    }
}

/// Why the rules keep `t` (one of the client's `not_restored`) out of every restore: a link
/// setting (one of `link_settings`), a RAM-only value, or else a command.
fn by_rule(t: &Target, link_settings: &[u16]) -> Skip {
    if link_settings.contains(&t.index) {
        Skip::LinkSetting
    } else if t.family == Family::Bonfiglioli
        && drive_profile::bonfiglioli::by_index(t.index).is_some_and(|p| p.ram_only)
    {
        Skip::RamOnly
    } else {
        Skip::Command
    }
}

/// The skipped entries as text: one line per reason, `skipped (reason): P813, P816` (a drive's
/// answer or a link change in brackets after its entry); read-only entries as a count (a backup
/// holds every readable value; `--json` lists them).
fn skipped_lines(skipped: &[(Target, Skip)]) -> Vec<String> {
    let mut sorted: Vec<&(Target, Skip)> = skipped.iter().collect();
    sorted.sort_by_key(|(_, s)| s.rank());
    let mut lines = Vec::new();
    for group in sorted.chunk_by(|a, b| a.1.rank() == b.1.rank()) {
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
        lines.push(format!("skipped ({}): {list}", first.reason()));
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
                o.insert("reason".into(), s.code().into());
                let message = match s.detail() {
                    Some(d) => format!("{}: {d}", s.reason()),
                    None => s.reason().to_owned(),
                };
                o.insert("message".into(), message.into());
                if matches!(s, Skip::NeedsYes(_)) {
                    o.insert("hint".into(), "--yes".into());
                }
                Value::Object(o)
            })
            .collect(),
    )
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
        GuardError::DoesNotFit { .. } => return write::hint_of(e).unwrap_or_default(),
        _ => "fix the file, or use --force to let the drive decide",
    };
    format!("; {hint}")
}

/// A backup file, checked against the table.
#[derive(Debug)]
struct Loaded {
    /// The entries a restore compares with the drive and writes where they differ.
    entries: Vec<Entry>,
    /// The entries no restore writes (read-only, not restored by rule).
    skipped: Vec<(Target, Skip)>,
    /// The file's identification of the drive it was saved from (every top-level field but
    /// the format's own and the list).
    identity: Map<String, Value>,
}

/// Parse and check a backup file; every problem is reported with its entry. Each value must
/// fit its parameter's width; the table's other rules are the write path's, for the values
/// that differ from the drive's. Entries of read-only parameters and of `not_restored` ones
/// (classified with `link_settings`) are kept aside, to be listed.
fn load(
    file: &Path,
    family: Family,
    not_restored: &[u16],
    link_settings: &[u16],
) -> Result<Loaded> {
    // A backup of the largest table is about 60 KB; 16 MiB is no backup.
    let bytes = super::infile::read_limited(file, false, 16 << 20)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        CliError::usage(format!(
            "{} is not a drivectl backup (not UTF-8 text at byte {})",
            file.display(),
            e.utf8_error().valid_up_to()
        ))
    })?;
    // Notepad saves UTF-8 with a byte order mark.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let doc: Value = serde_json::from_str(text).map_err(|e| {
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
    let list = field(&doc, "parameters").as_array().ok_or_else(|| {
        CliError::usage(format!(
            "{} has no `parameters` list; it is not a drivectl backup",
            file.display()
        ))
    })?;
    if list.is_empty() {
        return Err(CliError::usage(format!(
            "{} holds no parameters; there is nothing to restore",
            file.display()
        )));
    }
    let mut entries: Vec<Entry> = Vec::new();
    let mut skipped = Vec::new();
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
            .find(|p| p.bus_index() == index && subs(*p).contains(&sub))
            .ok_or_else(|| bad(format!("index {index} is not in the {family} table")))?;
        let raw = if legacy {
            legacy_raw(raw, param.wire_range())
        } else {
            raw
        };
        let target = Target {
            sub,
            ..Target::of(param)
        };
        if !param.access().is_writable() {
            skipped.push((target, Skip::ReadOnly));
            continue;
        }
        if not_restored.contains(&index) {
            skipped.push((target, by_rule(&target, link_settings)));
            continue;
        }
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
    let identity = doc
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(k, _)| {
                    !["format", "version", "family", "parameters"].contains(&k.as_str())
                })
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        })
        .unwrap_or_default();
    Ok(Loaded {
        entries,
        skipped,
        identity,
    })
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

/// The physical value of `raw` as JSON (raw outside the table).
fn physical_json(t: &Target, raw: i64) -> Value {
    t.param
        .map_or(Value::from(raw), |p| json!(p.to_physical(raw)))
}

/// Identity fields that say where the drive is, not what it is: a backup may be restored onto
/// a drive at another address (cloning a drive is what a backup is for).
const PLACE_FIELDS: &[&str] = &["address", "asi_address"];

/// An identity value for a person: a string as it is, anything else as JSON.
fn identity_text(v: &Value) -> String {
    v.as_str().map_or_else(|| v.to_string(), str::to_owned)
}

/// Compare the drive's identification with the file's: every field both name with a known
/// (non-null) value must match (device type, variant, configuration, …) unless `any_device`,
/// except the drive's place on the bus ([`PLACE_FIELDS`]); another firmware is a warning.
fn check_identity(
    file: &Path,
    saved: &Map<String, Value>,
    drive: &Map<String, Value>,
    any_device: bool,
) -> Result<()> {
    let mut differ: Vec<(&str, &Value, &Value)> = Vec::new();
    for (key, sv) in saved {
        if PLACE_FIELDS.contains(&key.as_str()) || key == "firmware" {
            continue;
        }
        if let Some(dv) = drive.get(key)
            && !sv.is_null()
            && !dv.is_null()
            && sv != dv
        {
            differ.push((key, sv, dv));
        }
    }
    if !differ.is_empty() {
        let side = |pick: fn(&(&str, &Value, &Value)) -> String| {
            differ.iter().map(pick).collect::<Vec<_>>().join(", ")
        };
        let msg = format!(
            "{} was saved from a drive of {}; this drive is {}",
            file.display(),
            side(|(k, s, _)| format!("{} {}", k.replace('_', " "), identity_text(s))),
            side(|(k, _, d)| format!("{} {}", k.replace('_', " "), identity_text(d)))
        );
        if !any_device {
            return Err(CliError::usage(format!(
                "{msg}: nothing was written; add --any-device to restore it anyway"
            )));
        }
        errln!("drivectl: warning: {msg}");
    }
    let (sf, df) = (
        saved.get("firmware").unwrap_or(&Value::Null),
        drive.get("firmware").unwrap_or(&Value::Null),
    );
    if !sf.is_null() && !df.is_null() && sf != df {
        errln!(
            "drivectl: warning: {} was saved from firmware {}; this drive runs firmware {}: \
             parameters may differ between firmware versions",
            file.display(),
            identity_text(sf),
            identity_text(df)
        );
    }
    Ok(())
}

/// Write a backup back and verify it (see the [module docs](self)).
pub async fn restore<C: ParamClient>(
    client: &mut C,
    file: &Path,
    opts: RestoreOptions,
    json: bool,
    stop: &Interrupt,
) -> Result<()> {
    let Loaded {
        entries,
        mut skipped,
        identity: saved_identity,
    } = load(
        file,
        client.family(),
        client.not_restored(),
        client.link_settings(),
    )?;
    let in_file = entries.len() + skipped.len();
    let identity = client.identify().await?;
    check_identity(file, &saved_identity, &identity, opts.any_device)?;
    let bar = progress(entries.len(), "reading");
    // The entries compared with the drive (the ones verified at the end) and the changes.
    let mut compared: Vec<&Entry> = Vec::new();
    let mut changes = Vec::new();
    for e in &entries {
        if stop.requested() {
            bar.abandon();
            return Err(interrupted(
                stop,
                format!(
                    "the restore was interrupted{} while reading the drive; nothing was written",
                    by(stop)
                ),
            ));
        }
        bar.set_message(e.target.label());
        let current = match client.read(&e.target).await {
            Ok(v) => v,
            Err(ClientError::Device(d)) if d.kind == DeviceErrorKind::Absent => {
                skipped.push((e.target, Skip::Absent(d.message)));
                bar.inc(1);
                continue;
            }
            Err(ClientError::Device(d)) => {
                skipped.push((e.target, Skip::Unreadable(d.message)));
                bar.inc(1);
                continue;
            }
            Err(err) => {
                bar.abandon();
                return Err(CliError::failed(format!(
                    "{}; nothing was written",
                    e.target.error(err)
                )));
            }
        };
        bar.inc(1);
        if current == e.raw {
            compared.push(e);
            continue;
        }
        // A setting of the link the restore runs over moves the drive away from it (a
        // timeout that ends the connection): only when confirmed.
        if !opts.yes && client.link_settings().contains(&e.target.index) {
            skipped.push((
                e.target,
                Skip::NeedsYes(client.link_change(&e.target, e.raw)),
            ));
            continue;
        }
        compared.push(e);
        changes.push((
            WriteRequest {
                target: e.target,
                raw: e.raw,
                persistence: Persistence::NonVolatile,
                force: opts.force,
            },
            current,
        ));
    }
    bar.finish_and_clear();
    let unchanged = compared.len() - changes.len();
    // Every write is checked before the first one is sent: a file that would be refused
    // halfway leaves the drive as it was. Every refusal is listed, not just the first.
    let drive_key = client.drive_key().await?;
    let mut warnings = Vec::new();
    let mut refusals = Vec::new();
    for (req, _) in &changes {
        match drive_client::write::check(&drive_key, req, &write::FileWearLog::from_env()) {
            Ok(w) => warnings.extend(w),
            Err(write::WriteError::Guard { error, message }) => {
                refusals.push(message + &restore_hint(&error));
            }
            Err(e) => refusals.push(CliError::from(e).to_string()),
        }
    }
    if opts.dry_run {
        for (req, old) in &changes {
            if json {
                outln!("{}", change_json(&req.target, *old, req.raw))?;
            } else {
                outln!("{}", change_text(&req.target, *old, req.raw))?;
            }
        }
        for r in &refusals {
            errln!("drivectl: would be refused: {r}");
        }
        if json {
            outln!(
                "{}",
                json!({"type": "restore", "dry_run": true, "file": file.display().to_string(),
                       "entries": entries.len(), "changes": changes.len(),
                       "unchanged": unchanged, "refused": refusals,
                       "skipped": skipped_json(&skipped)})
            )?;
        } else {
            for l in skipped_lines(&skipped) {
                outln!("{l}")?;
            }
            outln!(
                "dry run: {} of {in_file} parameter(s) in {} differ from the drive and would be \
                 written, {unchanged} already hold the saved value, {} skipped{}; nothing was \
                 written",
                changes.len(),
                file.display(),
                skipped.len(),
                listed(&skipped)
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
    for w in &warnings {
        errln!("drivectl: warning: {w}");
    }
    let bar = progress(changes.len(), "writing");
    let mut written: Vec<&(WriteRequest, i64)> = Vec::new();
    // Where the writing stopped, why, and whether the write in flight may have arrived.
    let mut halted: Option<(usize, String, bool)> = None;
    for (i, change) in changes.iter().enumerate() {
        let req = &change.0;
        if stop.requested() {
            halted = Some((i, format!("interrupted{}", by(stop)), false));
            break;
        }
        bar.set_message(req.target.label());
        match client.write(&req.target, req.raw, req.persistence).await {
            Ok(()) => {
                if let Err(e) = write::record(&drive_key, req) {
                    bar.suspend(|| errln!("drivectl: warning: {e}"));
                }
                if client.link_settings().contains(&req.target.index) {
                    let note = client.follow_link_change(&req.target, req.raw);
                    bar.suspend(|| errln!("drivectl: note: {}: {note}", req.target.label()));
                }
                written.push(change);
            }
            Err(ClientError::Device(why)) => {
                skipped.push((req.target, Skip::Refused(why.message)));
            }
            Err(err) => {
                halted = Some((i, req.target.error(err).to_string(), true));
                break;
            }
        }
        bar.inc(1);
    }
    // What was written, old → new, by its label.
    for (req, old) in &written {
        if json {
            outln!("{}", change_json(&req.target, *old, req.raw))?;
        } else {
            outln!("{}", change_text(&req.target, *old, req.raw))?;
        }
    }
    let written_labels: Vec<String> = written.iter().map(|(r, _)| r.target.label()).collect();
    let refused: Vec<String> = skipped
        .iter()
        .filter_map(|(t, s)| match s {
            Skip::Refused(why) => Some(format!("{} ({why})", t.label())),
            _ => None,
        })
        .collect();
    if let Some((at, why, in_flight)) = halted {
        bar.abandon();
        let rest = changes.get(at..).unwrap_or_default();
        let missing: Vec<String> = rest.iter().map(|(r, _)| r.target.label()).collect();
        let uncertain = in_flight.then(|| missing.first().cloned()).flatten();
        if json {
            outln!(
                "{}",
                json!({"type": "restore", "file": file.display().to_string(), "complete": false,
                       "entries": entries.len(), "written": written_labels, "refused": refused,
                       "not_written": missing, "uncertain": uncertain,
                       "skipped": skipped_json(&skipped)})
            )?;
        }
        let message = format!(
            "restore stopped ({why}): the drive is half restored: {} of {} change(s) written ({}), \
             {} not written ({}){}; run the same restore again to finish it (values the drive \
             already holds are not written again)",
            written.len(),
            changes.len(),
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
        return Err(if in_flight {
            CliError::failed(message)
        } else {
            interrupted(stop, message)
        });
    }
    bar.finish_and_clear();
    let bar = progress(compared.len(), "verifying");
    let mut mismatches = Vec::new();
    for e in &compared {
        if stop.requested() {
            bar.abandon();
            return Err(interrupted(
                stop,
                format!(
                    "the restore was interrupted{} while verifying: {} change(s) were written \
                     ({}), not all were read back; run the restore again to check",
                    by(stop),
                    written.len(),
                    written_labels.join(", ")
                ),
            ));
        }
        let back = client.read(&e.target).await.map_err(|err| {
            bar.abandon();
            CliError::failed(format!(
                "{} change(s) were written, but verifying failed: {}; run the restore again to check",
                written.len(),
                e.target.error(err)
            ))
        })?;
        if back != e.raw {
            mismatches.push((*e, back));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for (e, back) in &mismatches {
        let t = &e.target;
        if json {
            let mut o = target_json(t);
            o.insert("type".into(), "mismatch".into());
            o.insert("expected_raw".into(), e.raw.into());
            o.insert("expected".into(), physical_json(t, e.raw));
            o.insert("raw".into(), (*back).into());
            o.insert("value".into(), physical_json(t, *back));
            outln!("{}", Value::Object(o))?;
        } else {
            outln!(
                "{}: expected {}, the drive holds {}",
                t.title(),
                value_text(t, e.raw),
                value_text(t, *back)
            )?;
        }
    }
    let unreadable: Vec<String> = skipped
        .iter()
        .filter_map(|(t, s)| match s {
            Skip::Unreadable(why) => Some(format!("{} ({why})", t.label())),
            _ => None,
        })
        .collect();
    if json {
        outln!(
            "{}",
            json!({"type": "restore", "file": file.display().to_string(), "complete": true,
                   "entries": entries.len(), "written": written.len(), "unchanged": unchanged,
                   "refused": refused, "mismatches": mismatches.len(),
                   "skipped": skipped_json(&skipped)})
        )?;
    } else {
        for l in skipped_lines(&skipped) {
            outln!("{l}")?;
        }
        if written.is_empty() && refused.is_empty() && unreadable.is_empty() {
            outln!(
                "{}: all {} parameter(s) compared already held the saved values; nothing was \
                 written ({} skipped{})",
                file.display(),
                compared.len(),
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
                compared.len() - mismatches.len()
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
