//! Restore a [backup file](crate::backup::BackupFile) onto a drive, for every family, over a
//! [`ParamClient`], in three steps a front end runs one after the other, saying what it likes
//! in between:
//!
//! 1. [`plan`] writes nothing. It compares the drive's identification with the file's: every
//!    field both know with a known (non-null) value must match (device type, variant,
//!    configuration, …) except the drive's place on the bus ([`PLACE_FIELDS`]: cloning a drive
//!    is what a backup is for), unless [`Options::any_device`]; another firmware is a
//!    [`Notice`]. It reads every entry from the drive: an absent or unreadable one is skipped
//!    ([`Skip`]), a link failure ends the plan. A setting of the link the restore talks over
//!    ([`ParamClient::link_settings`]: a timeout, a group address) that differs is written only
//!    with [`Options::confirm_link_settings`]. Every value that differs passes the one write
//!    path's checks ([`crate::write::check`]: access, range, value list, the EEPROM-wear rule;
//!    [`Options::force`] skips all but the width) before anything is written, and every refusal
//!    is listed ([`Plan::refusals`]). A dry run stops here.
//! 2. [`apply`] refuses a plan with refusals, then writes the changes non-volatilely, enters them
//!    in the EEPROM-wear log and follows a link setting it wrote. A write the drive refuses is
//!    listed and the rest still written; a link failure or an interrupt ends the writing, and
//!    the error says what was and was not written ([`Halted`]): running the same restore again
//!    finishes it, since values the drive already holds are not written.
//! 3. [`verify`] reads back every entry compared and lists the values that differ
//!    ([`Mismatch`]).
//!
//! [`Interrupt`] is checked before every exchange: the exchange in flight is finished.

use drive_profile::Persistence;
use serde_json::{Map, Value, json};

use crate::backup::{BackupFile, Entry, FileError, Skip, skipped_json};
use crate::client::{ClientError, DeviceError, DeviceErrorKind, ParamClient};
use crate::front::FrontEnd;
use crate::interrupt::{Cause, Interrupt};
use crate::meaning::target_json;
use crate::progress::{FieldDiff, Notice, Phase, Progress};
use crate::target::Target;
use crate::wear::WearLog;
use crate::write::{self, WriteError, WriteRequest};

/// Identity fields that say where the drive is, not what it is: a backup may be restored onto
/// a drive at another address.
pub const PLACE_FIELDS: &[&str] = &["address", "asi_address"];

/// How a restore was asked to run.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// Write values the table check refuses (never a value that does not fit).
    pub force: bool,
    /// Restore onto a drive whose identification differs from the file's.
    pub any_device: bool,
    /// Write the drive's settings of the link the restore talks over too.
    pub confirm_link_settings: bool,
}

/// The identification fields that differ between the file (`saved`) and the drive: every field
/// both name with a known (non-null) value, except the drive's place ([`PLACE_FIELDS`]) and
/// its firmware ([`firmware_difference`]).
pub fn identity_differences(
    saved: &Map<String, Value>,
    drive: &Map<String, Value>,
) -> Vec<FieldDiff> {
    saved
        .iter()
        .filter(|(key, _)| !PLACE_FIELDS.contains(&key.as_str()) && key.as_str() != "firmware")
        .filter_map(|(key, sv)| {
            let dv = drive.get(key)?;
            (!sv.is_null() && !dv.is_null() && sv != dv).then(|| FieldDiff {
                key: key.clone(),
                saved: sv.clone(),
                drive: dv.clone(),
            })
        })
        .collect()
}

/// An identification value for a person: a string as it is, anything else as JSON.
pub fn identity_text(v: &Value) -> String {
    v.as_str().map_or_else(|| v.to_string(), str::to_owned)
}

/// How the file's drive differs from this one, for a person: `was saved from a drive of device
/// type 7, variant act; this drive is device type 8, variant acu`.
pub fn other_device_text(differ: &[FieldDiff]) -> String {
    let side = |pick: fn(&FieldDiff) -> &Value| {
        differ
            .iter()
            .map(|d| format!("{} {}", d.key.replace('_', " "), identity_text(pick(d))))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "was saved from a drive of {}; this drive is {}",
        side(|d| &d.saved),
        side(|d| &d.drive)
    )
}

/// The firmware of the file (`saved`) and of the drive, when both are known and differ.
pub fn firmware_difference(
    saved: &Map<String, Value>,
    drive: &Map<String, Value>,
) -> Option<FieldDiff> {
    let (sf, df) = (saved.get("firmware")?, drive.get("firmware")?);
    (!sf.is_null() && !df.is_null() && sf != df).then(|| FieldDiff {
        key: "firmware".into(),
        saved: sf.clone(),
        drive: df.clone(),
    })
}

/// A value to change: what the drive holds and what the file says.
#[derive(Debug, Clone, Copy)]
pub struct Change {
    /// The parameter.
    pub target: Target,
    /// The raw value the drive holds.
    pub from: i64,
    /// The raw value of the file.
    pub to: i64,
}

/// What a restore would do, found without writing anything.
#[derive(Debug, Clone)]
pub struct Plan {
    /// How many entries the file holds.
    pub in_file: usize,
    /// How many of them a restore compares with the drive (the file's others are skipped).
    pub entries: usize,
    /// The entries compared with the drive, verified at the end (the changes among them).
    pub compared: Vec<Entry>,
    /// The values that differ from the drive's, to be written in this order.
    pub changes: Vec<Change>,
    /// Every entry not written, with the reason.
    pub skipped: Vec<(Target, Skip)>,
    /// The write guard's warnings for the changes.
    pub warnings: Vec<String>,
    /// The changes the write path refuses: [`apply`] writes nothing while there are any.
    pub refusals: Vec<WriteError>,
    force: bool,
    drive_key: String,
}

impl Plan {
    /// How many entries compared already hold the file's value.
    pub fn unchanged(&self) -> usize {
        self.compared.len().saturating_sub(self.changes.len())
    }

    /// The write of `change`: non-volatile, forced as the restore was asked.
    pub fn request(&self, change: &Change) -> WriteRequest {
        WriteRequest {
            target: change.target,
            raw: change.to,
            persistence: Persistence::NonVolatile,
            force: self.force,
        }
    }

    /// The entries not written after `applied`'s writes: the plan's, then the writes the drive
    /// refused ([`Skip::Refused`]).
    pub fn skipped_after(&self, refused: &[(Target, DeviceError)]) -> Vec<(Target, Skip)> {
        let mut all = self.skipped.clone();
        all.extend(refused.iter().map(|(t, d)| (*t, Skip::Refused(d.clone()))));
        all
    }
}

/// What [`apply`] wrote.
#[derive(Debug, Clone, Default)]
pub struct Applied {
    /// The changes written, in order.
    pub written: Vec<Change>,
    /// The writes the drive refused, with its answer (the rest were still written).
    pub refused: Vec<(Target, DeviceError)>,
}

/// Why the writing stopped halfway.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Halt {
    /// The work was asked to stop (before the next write: nothing is in doubt).
    Interrupted(Cause),
    /// The link failed while `target` was written: it may or may not have arrived.
    Link {
        /// The value being written.
        target: Target,
        /// What failed.
        error: ClientError,
    },
}

/// A restore that stopped halfway: what was and was not written.
#[derive(Debug, Clone)]
pub struct Halted {
    /// What was written, and what the drive refused.
    pub applied: Applied,
    /// The changes not written (the first one in doubt after a link failure).
    pub not_written: Vec<Change>,
    /// Why it stopped.
    pub why: Halt,
}

impl Halted {
    /// The change that was being written when the link failed, which may or may not have
    /// arrived.
    pub fn uncertain(&self) -> Option<&Target> {
        match &self.why {
            Halt::Link { target, .. } => Some(target),
            Halt::Interrupted(_) => None,
        }
    }
}

/// A value read back that is not the file's.
#[derive(Debug, Clone, Copy)]
pub struct Mismatch {
    /// The parameter.
    pub target: Target,
    /// The raw value of the file.
    pub expected: i64,
    /// The raw value the drive holds.
    pub back: i64,
}

/// Why a restore did not finish.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum RestoreError {
    /// The file is not one for this drive's family: nothing was written.
    #[error("{0}")]
    File(FileError),
    /// Asking the drive for its identification failed: nothing was written.
    #[error("{0}")]
    Identify(ClientError),
    /// The file was saved from another kind of drive (these fields differ) and
    /// [`Options::any_device`] was not given: nothing was written.
    #[error("the file was saved from another kind of drive: nothing was written")]
    OtherDevice(Vec<FieldDiff>),
    /// The work was asked to stop while reading the drive (nothing was written) or while
    /// verifying (everything was written, not all of it read back).
    #[error("the restore was interrupted by {} while {}", .cause.name, while_text(*.phase))]
    Interrupted {
        /// The phase.
        phase: Phase,
        /// Who asked.
        cause: Cause,
    },
    /// Reading a value from the drive failed on the link: nothing was written.
    #[error("{}: {error}; nothing was written", .target.label())]
    Read {
        /// The parameter being read.
        target: Target,
        /// What failed.
        error: ClientError,
    },
    /// The drive's key for the wear log could not be found: nothing was written.
    #[error("{0}")]
    Key(ClientError),
    /// The plan has refusals ([`Plan::refusals`]): nothing was written.
    #[error("{count} change(s) refused, nothing was written")]
    Refused {
        /// How many.
        count: usize,
    },
    /// The writing stopped halfway.
    #[error(
        "the restore stopped: {} change(s) written, {} not written",
        .0.applied.written.len(),
        .0.not_written.len()
    )]
    Halted(Box<Halted>),
    /// Reading a value back failed on the link: everything was written, not all of it read
    /// back.
    #[error("verifying failed: {}: {error}", .target.label())]
    Verify {
        /// The parameter being read back.
        target: Target,
        /// What failed.
        error: ClientError,
    },
}

/// What an interrupt in `phase` leaves, for [`RestoreError::Interrupted`]'s message.
fn while_text(phase: Phase) -> &'static str {
    match phase {
        Phase::Verifying => "verifying: not every value was read back",
        _ => "reading the drive: nothing was written",
    }
}

/// Find what restoring `file` onto the drive would do, writing nothing (see the
/// [module docs](self)); the wear rule is `log`'s.
pub async fn plan<C: ParamClient>(
    client: &mut C,
    file: &BackupFile,
    opts: &Options,
    log: &dyn WearLog,
    progress: &mut dyn Progress,
    stop: &Interrupt,
) -> Result<Plan, RestoreError> {
    if file.family != client.family() {
        return Err(RestoreError::File(FileError::OtherFamily {
            saved: file.family.name().to_owned(),
            family: client.family(),
        }));
    }
    let identity = client.identify().await.map_err(RestoreError::Identify)?;
    let differ = identity_differences(&file.identity, &identity);
    if !differ.is_empty() {
        if !opts.any_device {
            return Err(RestoreError::OtherDevice(differ));
        }
        progress.notice(&Notice::OtherDevice(differ));
    }
    if let Some(firmware) = firmware_difference(&file.identity, &identity) {
        progress.notice(&Notice::OtherFirmware(firmware));
    }
    let mut skipped = file.skipped.clone();
    let mut compared = Vec::new();
    let mut changes = Vec::new();
    progress.start(Phase::Reading, file.entries.len());
    for e in &file.entries {
        if let Some(cause) = stop.cause() {
            progress.abandon();
            return Err(RestoreError::Interrupted {
                phase: Phase::Reading,
                cause,
            });
        }
        progress.step(&e.target);
        let current = match client.read(&e.target).await {
            Ok(v) => v,
            Err(ClientError::Device(d)) => {
                let skip = if d.kind == DeviceErrorKind::Absent {
                    Skip::Absent(d)
                } else {
                    Skip::Unreadable(d)
                };
                skipped.push((e.target, skip));
                progress.done();
                continue;
            }
            Err(error) => {
                progress.abandon();
                return Err(RestoreError::Read {
                    target: e.target,
                    error,
                });
            }
        };
        progress.done();
        if current == e.raw {
            compared.push(*e);
            continue;
        }
        // A setting of the link the restore runs over moves the drive away from it (a
        // timeout that ends the connection): only when confirmed.
        if !opts.confirm_link_settings && client.link_settings().contains(&e.target.index) {
            let change = client.link_change(&e.target, e.raw);
            skipped.push((e.target, Skip::Unconfirmed(change)));
            continue;
        }
        compared.push(*e);
        changes.push(Change {
            target: e.target,
            from: current,
            to: e.raw,
        });
    }
    progress.finish();
    let drive_key = client.drive_key().await.map_err(RestoreError::Key)?;
    let mut plan = Plan {
        in_file: file.len(),
        entries: file.entries.len(),
        compared,
        changes,
        skipped,
        warnings: Vec::new(),
        refusals: Vec::new(),
        force: opts.force,
        drive_key,
    };
    // Every write is checked before the first one is sent: a file that would be refused
    // halfway leaves the drive as it was. Every refusal is listed, not just the first.
    for change in &plan.changes {
        match write::check(&plan.drive_key, &plan.request(change), log) {
            Ok(w) => plan.warnings.extend(w),
            Err(e) => plan.refusals.push(e),
        }
    }
    Ok(plan)
}

/// Write the changes of `plan` (see the [module docs](self)): the guard's warnings are handed
/// to `progress` first, a write the wear log `log` cannot record and where the drive answers
/// after a link setting as they happen.
pub async fn apply<C: ParamClient>(
    client: &mut C,
    plan: &Plan,
    log: &dyn WearLog,
    progress: &mut dyn Progress,
    stop: &Interrupt,
) -> Result<Applied, RestoreError> {
    if !plan.refusals.is_empty() {
        return Err(RestoreError::Refused {
            count: plan.refusals.len(),
        });
    }
    for w in &plan.warnings {
        progress.notice(&Notice::Warning(w.clone()));
    }
    progress.start(Phase::Writing, plan.changes.len());
    let mut applied = Applied::default();
    for (i, change) in plan.changes.iter().enumerate() {
        let why = match stop.cause() {
            Some(cause) => Some(Halt::Interrupted(cause)),
            None => {
                progress.step(&change.target);
                let req = plan.request(change);
                match client.write(&req.target, req.raw, req.persistence).await {
                    Ok(()) => {
                        if let Err(e) = write::record(&plan.drive_key, &req, log) {
                            progress.notice(&Notice::NotRecorded(e));
                        }
                        if client.link_settings().contains(&req.target.index) {
                            let note = client.follow_link_change(&req.target, req.raw);
                            progress.notice(&Notice::LinkFollowed {
                                target: req.target,
                                note,
                            });
                        }
                        applied.written.push(*change);
                        None
                    }
                    Err(ClientError::Device(d)) => {
                        applied.refused.push((req.target, d));
                        None
                    }
                    Err(error) => Some(Halt::Link {
                        target: req.target,
                        error,
                    }),
                }
            }
        };
        if let Some(why) = why {
            progress.abandon();
            return Err(RestoreError::Halted(Box::new(Halted {
                applied,
                not_written: plan.changes.get(i..).unwrap_or_default().to_vec(),
                why,
            })));
        }
        progress.done();
    }
    progress.finish();
    Ok(applied)
}

/// Read back every entry `plan` compared: the values the drive holds that are not the file's.
pub async fn verify<C: ParamClient>(
    client: &mut C,
    plan: &Plan,
    progress: &mut dyn Progress,
    stop: &Interrupt,
) -> Result<Vec<Mismatch>, RestoreError> {
    progress.start(Phase::Verifying, plan.compared.len());
    let mut mismatches = Vec::new();
    for e in &plan.compared {
        if let Some(cause) = stop.cause() {
            progress.abandon();
            return Err(RestoreError::Interrupted {
                phase: Phase::Verifying,
                cause,
            });
        }
        progress.step(&e.target);
        let back = match client.read(&e.target).await {
            Ok(back) => back,
            Err(error) => {
                progress.abandon();
                return Err(RestoreError::Verify {
                    target: e.target,
                    error,
                });
            }
        };
        if back != e.raw {
            mismatches.push(Mismatch {
                target: e.target,
                expected: e.raw,
                back,
            });
        }
        progress.done();
    }
    progress.finish();
    Ok(mismatches)
}

/// The physical value of `raw` as JSON (raw outside the table).
fn physical_json(t: &Target, raw: i64) -> Value {
    t.param
        .map_or(Value::from(raw), |p| json!(p.to_physical(raw)))
}

impl Change {
    /// The change as JSON: the target's keys ([`target_json`]) with `"type": "change"`,
    /// `from_raw`, `from`, `to_raw`, `to` (raw and physical values).
    pub fn to_json(&self) -> Value {
        let t = &self.target;
        let mut o = target_json(t);
        o.insert("type".into(), "change".into());
        o.insert("from_raw".into(), self.from.into());
        o.insert("from".into(), physical_json(t, self.from));
        o.insert("to_raw".into(), self.to.into());
        o.insert("to".into(), physical_json(t, self.to));
        Value::Object(o)
    }
}

impl Mismatch {
    /// The mismatch as JSON: the target's keys with `"type": "mismatch"`, `expected_raw`,
    /// `expected`, `raw`, `value` (what the drive holds).
    pub fn to_json(&self) -> Value {
        let t = &self.target;
        let mut o = target_json(t);
        o.insert("type".into(), "mismatch".into());
        o.insert("expected_raw".into(), self.expected.into());
        o.insert("expected".into(), physical_json(t, self.expected));
        o.insert("raw".into(), self.back.into());
        o.insert("value".into(), physical_json(t, self.back));
        Value::Object(o)
    }
}

/// The entries of `skipped` the drive answered for, `P130 (its answer)`: those whose write it
/// refused, or (`unreadable`) those it refused to read.
pub fn answered(skipped: &[(Target, Skip)], unreadable: bool) -> Vec<String> {
    skipped
        .iter()
        .filter_map(|(t, s)| match s {
            Skip::Refused(why) if !unreadable => Some(format!("{} ({why})", t.label())),
            Skip::Unreadable(why) if unreadable => Some(format!("{} ({why})", t.label())),
            _ => None,
        })
        .collect()
}

impl Plan {
    /// A dry run's summary of restoring `file`: `{"type": "restore", "dry_run": true, "file",
    /// "entries", "changes", "unchanged", "refused" (the front end's text of each of
    /// [`Plan::refusals`]), "skipped"}` ([`skipped_json`]).
    pub fn dry_run_json(&self, file: &str, refused: &[String], front: &dyn FrontEnd) -> Value {
        json!({"type": "restore", "dry_run": true, "file": file, "entries": self.entries,
               "changes": self.changes.len(), "unchanged": self.unchanged(),
               "refused": refused, "skipped": skipped_json(&self.skipped, front)})
    }

    /// What a finished restore did not achieve, one sentence each for a person (empty when it
    /// did everything): values that differ after the restore or writes the drive refused, and
    /// entries the drive refused to read.
    pub fn shortfalls(&self, applied: &Applied, mismatches: &[Mismatch]) -> Vec<String> {
        let skipped = self.skipped_after(&applied.refused);
        let (refused, unreadable) = (answered(&skipped, false), answered(&skipped, true));
        let mut failures = Vec::new();
        if !mismatches.is_empty() || !refused.is_empty() {
            failures.push(format!(
                "verify failed: {} value(s) differ after restore, {} write(s) refused by the \
                 drive{}; check controller inhibit and the parameter lock",
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
        failures
    }

    /// A finished restore's summary: `{"type": "restore", "file", "complete": true,
    /// "entries", "written" (how many), "unchanged", "refused" ([`answered`]), "mismatches"
    /// (how many), "skipped"}`.
    pub fn report_json(
        &self,
        applied: &Applied,
        mismatches: &[Mismatch],
        file: &str,
        front: &dyn FrontEnd,
    ) -> Value {
        let skipped = self.skipped_after(&applied.refused);
        json!({"type": "restore", "file": file, "complete": true, "entries": self.entries,
               "written": applied.written.len(), "unchanged": self.unchanged(),
               "refused": answered(&skipped, false), "mismatches": mismatches.len(),
               "skipped": skipped_json(&skipped, front)})
    }
}

impl Halted {
    /// What the drive holds now, for a person: `the drive is half restored: 1 of 3 change(s)
    /// written (P130), 2 not written (P131, P132)`, the write in doubt, and how to finish it.
    pub fn state_text(&self) -> String {
        let labels = |c: &[Change]| -> Vec<String> { c.iter().map(|c| c.target.label()).collect() };
        let (written, missing) = (labels(&self.applied.written), labels(&self.not_written));
        let changes = written.len() + self.applied.refused.len() + missing.len();
        format!(
            "the drive is half restored: {} of {changes} change(s) written ({}), {} not written \
             ({}){}; run the same restore again to finish it (values the drive already holds are \
             not written again)",
            written.len(),
            if written.is_empty() {
                "none".to_owned()
            } else {
                written.join(", ")
            },
            missing.len(),
            missing.join(", "),
            self.uncertain().map_or_else(String::new, |u| format!(
                "; {} was being written when the link failed and may or may not have arrived",
                u.label()
            )),
        )
    }

    /// A half-finished restore's summary: `{"type": "restore", "file", "complete": false,
    /// "entries", "written", "not_written" (labels), "uncertain" (the label of the write in
    /// doubt, or null), "refused", "skipped"}`.
    pub fn report_json(&self, plan: &Plan, file: &str, front: &dyn FrontEnd) -> Value {
        let labels = |c: &[Change]| -> Vec<String> { c.iter().map(|c| c.target.label()).collect() };
        let skipped = plan.skipped_after(&self.applied.refused);
        json!({"type": "restore", "file": file, "complete": false, "entries": plan.entries,
               "written": labels(&self.applied.written), "refused": answered(&skipped, false),
               "not_written": labels(&self.not_written),
               "uncertain": self.uncertain().map(Target::label),
               "skipped": skipped_json(&skipped, front)})
    }
}

#[cfg(test)]
#[path = "restore_tests.rs"]
mod tests;
