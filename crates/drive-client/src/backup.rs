//! The `drivebus-backup` version 1 file and the backup of a drive, for every family, over a
//! [`ParamClient`].
//!
//! A backup file is a JSON object: the drive's identification as [`ParamClient::identify`]
//! gives it (`device_type`, `firmware`, `variant`, `address`, …), then `format`
//! ([`FORMAT`]), `version` ([`VERSION`]), `family` (the family's name) and `parameters`, one
//! object per value: `index` (bus index), `sub` (sub-index: data set, IND word; 0 where there is
//! none), `number` (its label), `name` (English), `raw` and `writable`. [`backup`] reads it,
//! [`Backup::text`] gives the file's bytes, so that every front end offers the same file.
//!
//! [`BackupFile::parse`] reads such a file from the bytes a front end read (a UTF-8 byte order
//! mark, as Notepad writes it, and CR LF line ends are fine) and checks the whole of it before a
//! restore writes anything ([`FileError`]): the format and version, the family, a `parameters`
//! list that is not empty, and every entry: a parameter of the family's table, named once, whose
//! value fits its bus width. Entries no restore writes are kept aside with their reason
//! ([`Skip`]): read-only ones and those of the client's
//! [`not_restored`](ParamClient::not_restored). The first MOVILINK-only backups
//! ([`LEGACY_MOVILINK`], sign-extended 32-bit values) are still read, as MOVIDRIVE backups.

use std::collections::{BTreeMap, BTreeSet};

use drive_profile::family::{self, AnyParam};
use drive_profile::{Access, Family};
use serde_json::{Map, Value, json};

use crate::client::{ClientError, DeviceError, DeviceErrorKind, ParamClient};
use crate::front::{FrontEnd, Setting};
use crate::interrupt::{Cause, Interrupt};
use crate::meaning::target_json;
use crate::progress::{Phase, Progress};
use crate::target::{Target, ValueError, nord_subs};

/// The format name in a file's `format` field.
pub const FORMAT: &str = "drivebus-backup";
/// The version of the file layout.
pub const VERSION: u64 = 1;
/// The format of the first MOVILINK-only backups (still restored, as MOVIDRIVE backups).
pub const LEGACY_MOVILINK: &str = "drivebus-movilink-backup";
/// The most a backup file can be: a backup of the largest table is about 60 KB; 16 MiB is no
/// backup (a front end reads at most this much).
pub const MAX_LEN: u64 = 16 << 20;

/// NORD P560 "save to EEPROM" (PNU 230h): 0 keeps every later parameter write in RAM only.
const NORD_SAVE_TO_EEPROM: u16 = 0x230;

/// The parameters a backup covers: numbered rows (SEW's fault-memory sub-entries share the
/// index of their parent), one per bus index and sub-index; a data-set parameter
/// ([`Access::DATA_SET`], Bonfiglioli) once per data set 1–4 (its sub-index is the data set;
/// data set 0 addresses all four and is never saved or restored); a NORD parameter once per
/// array element and parameter set (its sub-index is the IND word), with P560 "save to EEPROM"
/// last, so that a restore that turns it off does not send the values after it to RAM only.
pub fn rows(family: Family) -> Vec<Target> {
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

/// The sub-indices a backup holds of `p`: the data sets 1–4 of a data-set parameter, every
/// IND word of a NORD parameter (array elements × parameter sets), else its own sub-index.
fn subs(p: AnyParam) -> Vec<u16> {
    if p.family() == Family::Nord {
        return nord_subs(p.bus_index());
    }
    if p.access().contains(Access::DATA_SET) {
        vec![1, 2, 3, 4]
    } else {
        vec![p.sub_index().unwrap_or(0)]
    }
}

/// One value of a drive or of a file, checked against the table.
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    /// The parameter (with its sub-index).
    pub target: Target,
    /// Its raw value.
    pub raw: i64,
}

/// What a backup read from a drive.
#[derive(Debug, Clone)]
pub struct Backup {
    /// The family.
    pub family: Family,
    /// The drive's identification ([`ParamClient::identify`]).
    pub identity: Map<String, Value>,
    /// Every value read, in the order of [`rows`].
    pub saved: Vec<Entry>,
    /// How many parameters this drive does not have (left out: not part of its backup).
    pub absent: usize,
    /// The parameters the drive refused to read, with its answer: a gap in the backup, which is
    /// complete only without them.
    pub unreadable: Vec<(Target, DeviceError)>,
}

impl Backup {
    /// Whether every parameter the drive has was read.
    pub fn is_complete(&self) -> bool {
        self.unreadable.is_empty()
    }

    /// The backup as the file's JSON document (see the [module docs](self)).
    pub fn to_json(&self) -> Value {
        let mut doc = self.identity.clone();
        let entries: Vec<Value> = self
            .saved
            .iter()
            .map(|Entry { target: t, raw }| {
                json!({
                    "index": t.index, "sub": t.sub, "number": t.label(),
                    "name": t.param.map(|p| p.name_en()),
                    "raw": raw, "writable": t.param.is_some_and(|p| p.access().is_writable()),
                })
            })
            .collect();
        doc.insert("format".into(), FORMAT.into());
        doc.insert("version".into(), VERSION.into());
        doc.insert("family".into(), self.family.name().into());
        doc.insert("parameters".into(), Value::Array(entries));
        Value::Object(doc)
    }

    /// The file's text: [`Backup::to_json`], pretty-printed.
    pub fn text(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(&self.to_json())
    }
}

/// Why a backup was not made: no file should be written for any of them.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum BackupError {
    /// Asking the drive for its identification failed.
    #[error("{0}")]
    Identify(ClientError),
    /// The work was asked to stop.
    #[error("the backup was interrupted by {} after {saved} of {total} parameters", .cause.name)]
    Interrupted {
        /// Who asked.
        cause: Cause,
        /// How many values had been read.
        saved: usize,
        /// How many parameters the backup covers.
        total: usize,
    },
    /// Reading a value failed on the link (a drive's refusal is [`Backup::unreadable`]).
    #[error("{}: {error}", .target.label())]
    Read {
        /// The parameter being read.
        target: Target,
        /// What failed.
        error: ClientError,
    },
}

/// Read every parameter of the family's table ([`rows`]) from the drive: parameters the drive
/// does not have ([`DeviceErrorKind::Absent`]) are left out, any other refusal is listed
/// ([`Backup::unreadable`]); a link failure or `stop` ends the backup. `stop` is checked before
/// each read.
pub async fn backup<C: ParamClient>(
    client: &mut C,
    progress: &mut dyn Progress,
    stop: &Interrupt,
) -> Result<Backup, BackupError> {
    let family = client.family();
    let identity = client.identify().await.map_err(BackupError::Identify)?;
    let rows = rows(family);
    progress.start(Phase::Reading, rows.len());
    let mut saved = Vec::new();
    let mut absent = 0;
    let mut unreadable = Vec::new();
    for t in &rows {
        if let Some(cause) = stop.cause() {
            progress.abandon();
            return Err(BackupError::Interrupted {
                cause,
                saved: saved.len(),
                total: rows.len(),
            });
        }
        progress.step(t);
        match client.read(t).await {
            Ok(raw) => saved.push(Entry { target: *t, raw }),
            // A drive without an option card answers "not implemented" or "option card
            // missing" for its parameters: they are not part of this drive's backup.
            Err(ClientError::Device(d)) if d.kind == DeviceErrorKind::Absent => absent += 1,
            // Any other refusal is a gap in the backup: saved without it, and said.
            Err(ClientError::Device(d)) => unreadable.push((*t, d)),
            Err(error) => {
                progress.abandon();
                return Err(BackupError::Read { target: *t, error });
            }
        }
        progress.done();
    }
    progress.finish();
    Ok(Backup {
        family,
        identity,
        saved,
        absent,
        unreadable,
    })
}

/// Why a restore does not write an entry of its file (or of its plan).
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Skip {
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
    Absent(DeviceError),
    /// The drive refused to read it (its answer): it could not be compared.
    Unreadable(DeviceError),
    /// A setting of the link the restore talks over (a timeout, a group address) that differs
    /// and was not confirmed ([`crate::restore::Options::confirm_link_settings`]): what the write
    /// would do to the link.
    Unconfirmed(String),
    /// The drive refused the write (its answer).
    Refused(DeviceError),
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Skip::LinkSetting => f.write_str("not restored by rule: a setting of the link in use"),
            Skip::Command => f.write_str("not restored by rule: a command or lock"),
            Skip::RamOnly => f.write_str("not restored by rule: a RAM-only value"),
            Skip::ReadOnly => f.write_str("read-only"),
            Skip::Absent(d) => write!(f, "absent on this drive: {d}"),
            Skip::Unreadable(d) => write!(f, "the drive refused to read it: {d}"),
            Skip::Unconfirmed(c) => write!(f, "a setting of the link in use, not confirmed: {c}"),
            Skip::Refused(d) => write!(f, "refused by the drive: {d}"),
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

/// Why a backup file cannot be restored: nothing was written for any of them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// The bytes are not UTF-8 text.
    #[error("not UTF-8 text (at byte {at})")]
    NotUtf8 {
        /// Where the text stops being UTF-8.
        at: usize,
    },
    /// The text is not JSON.
    #[error("invalid JSON: {0}")]
    Json(String),
    /// Another format or version.
    #[error("not a {FORMAT} version {VERSION} file")]
    Format,
    /// A backup of another family's drive.
    #[error("a backup of a {saved} drive, not of a {family} drive")]
    OtherFamily {
        /// The file's family.
        saved: String,
        /// The family it was to be restored as.
        family: Family,
    },
    /// The file names no family.
    #[error("names no drive family (`family`); it is not a {family} backup")]
    NoFamily {
        /// The family it was to be restored as.
        family: Family,
    },
    /// No `parameters` list.
    #[error("has no `parameters` list")]
    NoList,
    /// An empty `parameters` list.
    #[error("holds no parameters; there is nothing to restore")]
    Empty,
    /// An entry of the list is wrong.
    #[error("entry {entry}: {problem}")]
    Entry {
        /// Which entry (1-based).
        entry: usize,
        /// What is wrong with it.
        problem: EntryError,
    },
}

/// What is wrong with an entry of a backup file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EntryError {
    /// `index` is missing or not a bus index.
    #[error("no valid `index`")]
    Index,
    /// `sub` is not a sub-index.
    #[error("no valid `sub`")]
    Sub,
    /// `raw` is missing or not an integer.
    #[error("no integer `raw` value")]
    Raw,
    /// The family's table has no such parameter (or not with this sub-index).
    #[error("index {index} is not in the {family} table")]
    NotInTable {
        /// The bus index.
        index: u16,
        /// The family.
        family: Family,
    },
    /// The value does not fit the parameter's bus width.
    #[error("{0}")]
    Width(ValueError),
    /// The same parameter twice: it would be written twice, the last one winning.
    #[error("{label} appears twice (entries {first} and {second})")]
    Twice {
        /// The parameter's label.
        label: String,
        /// The first entry (1-based).
        first: usize,
        /// This entry.
        second: usize,
    },
}

/// A backup file, checked against the family's table.
#[derive(Debug, Clone)]
pub struct BackupFile {
    /// The family it is a backup of.
    pub family: Family,
    /// The entries a restore compares with the drive and writes where they differ.
    pub entries: Vec<Entry>,
    /// The entries no restore writes (read-only, not restored by rule), with the reason.
    pub skipped: Vec<(Target, Skip)>,
    /// The file's identification of the drive it was saved from (every top-level field but
    /// the format's own and the list).
    pub identity: Map<String, Value>,
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

impl BackupFile {
    /// Parse and check the bytes of a backup file for a restore to a `family` drive; the first
    /// problem found is the error, with its entry. Each value must fit its parameter's width;
    /// the table's other rules are the write path's, for the values that differ from the
    /// drive's. Entries of read-only parameters and of `not_restored` ones (sorted with
    /// `link_settings`) are kept aside, to be listed.
    pub fn parse(
        bytes: &[u8],
        family: Family,
        not_restored: &[u16],
        link_settings: &[u16],
    ) -> Result<Self, FileError> {
        let text = std::str::from_utf8(bytes).map_err(|e| FileError::NotUtf8 {
            at: e.valid_up_to(),
        })?;
        // Notepad saves UTF-8 with a byte order mark.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let doc: Value = serde_json::from_str(text).map_err(|e| FileError::Json(e.to_string()))?;
        let legacy = field(&doc, "format") == LEGACY_MOVILINK && family == Family::Movidrive;
        if !(field(&doc, "format") == FORMAT || legacy) || field(&doc, "version") != VERSION {
            return Err(FileError::Format);
        }
        if !legacy && field(&doc, "family") != family.name() {
            return Err(match field(&doc, "family").as_str() {
                Some(other) => FileError::OtherFamily {
                    saved: other.to_owned(),
                    family,
                },
                None => FileError::NoFamily { family },
            });
        }
        let list = field(&doc, "parameters")
            .as_array()
            .ok_or(FileError::NoList)?;
        if list.is_empty() {
            return Err(FileError::Empty);
        }
        let mut entries: Vec<Entry> = Vec::new();
        let mut skipped = Vec::new();
        let mut seen = BTreeMap::new();
        for (i, e) in list.iter().enumerate() {
            let bad = |problem| FileError::Entry {
                entry: i + 1,
                problem,
            };
            let index = field(e, "index")
                .as_u64()
                .and_then(|v| u16::try_from(v).ok())
                .ok_or_else(|| bad(EntryError::Index))?;
            let sub = match field(e, "sub") {
                Value::Null => 0,
                v => v
                    .as_u64()
                    .and_then(|v| u16::try_from(v).ok())
                    .ok_or_else(|| bad(EntryError::Sub))?,
            };
            let raw = field(e, "raw")
                .as_i64()
                .ok_or_else(|| bad(EntryError::Raw))?;
            let param = family::params(family)
                .find(|p| p.bus_index() == index && subs(*p).contains(&sub))
                .ok_or_else(|| bad(EntryError::NotInTable { index, family }))?;
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
            target
                .check_width(raw)
                .map_err(|e| bad(EntryError::Width(e)))?;
            // One parameter twice would be written twice (and its EEPROM with it), the last
            // one winning: a file like that was not made by a backup.
            if let Some(first) = seen.insert((index, sub), i + 1) {
                return Err(bad(EntryError::Twice {
                    label: target.label(),
                    first,
                    second: i + 1,
                }));
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
        Ok(Self {
            family,
            entries,
            skipped,
            identity,
        })
    }

    /// [`BackupFile::parse`] for a restore through `client` (its family, the parameters it
    /// never restores and its link settings).
    pub fn parse_for<C: ParamClient>(bytes: &[u8], client: &C) -> Result<Self, FileError> {
        Self::parse(
            bytes,
            client.family(),
            client.not_restored(),
            client.link_settings(),
        )
    }

    /// How many entries the file holds.
    pub fn len(&self) -> usize {
        self.entries.len() + self.skipped.len()
    }

    /// Whether the file holds no entries (never, for a parsed file).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Skip {
    /// The reason as a code, JSON's `reason`: `link_setting`, `command`, `ram_only`,
    /// `read_only`, `absent`, `unreadable`, `needs_yes` (not confirmed), `refused`.
    pub fn code(&self) -> &'static str {
        match self {
            Skip::LinkSetting => "link_setting",
            Skip::Command => "command",
            Skip::RamOnly => "ram_only",
            Skip::ReadOnly => "read_only",
            Skip::Absent(_) => "absent",
            Skip::Unreadable(_) => "unreadable",
            Skip::Unconfirmed(_) => "needs_yes",
            Skip::Refused(_) => "refused",
        }
    }

    /// The reason for a person, as the heading of the entries skipped for it; a setting of the
    /// link that was not confirmed names the front end's way to confirm it
    /// ([`Setting::ConfirmLinkSettings`]).
    pub fn reason(&self, front: &dyn FrontEnd) -> String {
        match self {
            Skip::LinkSetting => "not restored by rule: settings of the link the restore talks \
                                  over, whose change would cut the connection"
                .into(),
            Skip::Command => {
                "not restored by rule: commands and locks, which act on the drive".into()
            }
            Skip::RamOnly => {
                "not restored by rule: RAM-only values (bus control words and setpoints)".into()
            }
            Skip::ReadOnly => "read-only".into(),
            Skip::Absent(_) => "absent on this drive".into(),
            Skip::Unreadable(_) => {
                "the drive refused to read them, so they were not compared".into()
            }
            Skip::Unconfirmed(_) => match front.name(Setting::ConfirmLinkSettings) {
                Some(yes) => {
                    format!("settings of the link the restore talks over; add {yes} to write them")
                }
                None => "settings of the link the restore talks over, not confirmed".into(),
            },
            Skip::Refused(_) => "refused by the drive".into(),
        }
    }

    /// The drive's answer, or what a write would do to the link, where there is one.
    pub fn detail(&self) -> Option<&str> {
        match self {
            Skip::Absent(d) | Skip::Unreadable(d) | Skip::Refused(d) => Some(&d.message),
            Skip::Unconfirmed(change) => Some(change),
            _ => None,
        }
    }

    /// The place of this reason when skipped entries are listed by reason: the rules first,
    /// then read-only, absent, not confirmed, unreadable, refused.
    pub fn order(&self) -> u8 {
        match self {
            Skip::LinkSetting => 0,
            Skip::Command => 1,
            Skip::RamOnly => 2,
            Skip::ReadOnly => 3,
            Skip::Absent(_) => 4,
            Skip::Unconfirmed(_) => 5,
            Skip::Unreadable(_) => 6,
            Skip::Refused(_) => 7,
        }
    }
}

/// The skipped entries as JSON, one object each: the target's keys ([`target_json`]) with
/// `reason` ([`Skip::code`]), `message` (the reason for a person with the drive's answer) and,
/// where the front end names the way to write it, `hint`.
pub fn skipped_json(skipped: &[(Target, Skip)], front: &dyn FrontEnd) -> Value {
    Value::Array(
        skipped
            .iter()
            .map(|(t, s)| {
                let mut o = target_json(t);
                o.insert("reason".into(), s.code().into());
                let message = match s.detail() {
                    Some(d) => format!("{}: {d}", s.reason(front)),
                    None => s.reason(front),
                };
                o.insert("message".into(), message.into());
                if let (Skip::Unconfirmed(_), Some(yes)) =
                    (s, front.name(Setting::ConfirmLinkSettings))
                {
                    o.insert("hint".into(), yes.into());
                }
                Value::Object(o)
            })
            .collect(),
    )
}

impl Backup {
    /// The gap in an incomplete backup, for a person: `the backup is incomplete: the drive
    /// refused to read 1 parameter(s): P001 (its answer)`; `None` when it is complete.
    pub fn gaps_text(&self) -> Option<String> {
        let list: Vec<String> = self
            .unreadable
            .iter()
            .map(|(t, why)| format!("{} ({why})", t.label()))
            .collect();
        (!list.is_empty()).then(|| {
            format!(
                "the backup is incomplete: the drive refused to read {} parameter(s): {}",
                list.len(),
                list.join(", ")
            )
        })
    }

    /// The backup's summary as JSON, written to `file`: `{"type": "backup", "file",
    /// "parameters" (how many saved), "skipped" (how many absent), "unreadable": [the target's
    /// keys with the drive's `error`]}`.
    pub fn summary_json(&self, file: &str) -> Value {
        let unreadable: Vec<Value> = self
            .unreadable
            .iter()
            .map(|(t, why)| {
                let mut o = target_json(t);
                o.insert("error".into(), why.message.as_str().into());
                Value::Object(o)
            })
            .collect();
        json!({"type": "backup", "file": file, "parameters": self.saved.len(),
               "skipped": self.absent, "unreadable": unreadable})
    }
}

#[cfg(test)]
#[path = "backup_tests.rs"]
mod tests;
