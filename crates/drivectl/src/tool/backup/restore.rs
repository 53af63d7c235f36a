//! `restore`: a backup file planned against the drive, written and verified by drive-client's
//! engine, what it did and what it refused said on the command line.

use super::*;

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

/// Print every change, old → new, by its label.
fn print_changes(changes: &[Change], json: bool) -> Result<()> {
    for c in changes {
        if json {
            outln!("{}", c.to_json())?;
        } else {
            outln!("{}", change_text(&c.target, c.from, c.to))?;
        }
    }
    Ok(())
}

/// `<file> was saved from a drive of device type 7, variant act; this drive is device type 8,
/// variant acu`.
fn other_device(file: &Path, differ: &[FieldDiff]) -> String {
    format!(
        "{} {}",
        file.display(),
        restoring::other_device_text(differ)
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
            restoring::identity_text(&f.saved),
            restoring::identity_text(&f.drive)
        ),
        Notice::Warning(w) => errln!("drivectl: warning: {w}"),
        Notice::NotRecorded(e) => errln!("drivectl: warning: {e}"),
        Notice::LinkFollowed { target, note } => {
            errln!("drivectl: note: {}: {note}", target.label());
        }
        other => errln!("drivectl: note: {other:?}"),
    }
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
        RestoreError::Verify { target, error } => CliError::failed(format!(
            "{} change(s) were written, but verifying failed: {}; run the restore again to check",
            written.len(),
            target.error(error)
        )),
        // `Read`: the parameter, the failure, `nothing was written`.
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
    let shown = file.display().to_string();
    let mut bar = Bar::new(|n: &Notice| say(file, n));
    let stop = stop.inner();
    let plan = restoring::plan(client, &loaded, &opts.rules, &log, &mut bar, stop)
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
            outln!("{}", plan.dry_run_json(&shown, &refusals, &Cli))?;
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
            if json {
                outln!("{}", h.report_json(&plan, &shown, &Cli))?;
            }
            let why = match &h.why {
                Halt::Interrupted(cause) => format!("interrupted{}", by(cause)),
                Halt::Link { target, error } => target.error(error.clone()).to_string(),
                other => format!("{other:?}"),
            };
            let message = format!("restore stopped ({why}): {}", h.state_text());
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
            outln!("{}", m.to_json())?;
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
    let refused = restoring::answered(&skipped, false);
    let unreadable = restoring::answered(&skipped, true);
    let compared = plan.compared.len();
    if json {
        outln!("{}", plan.report_json(&applied, &mismatches, &shown, &Cli))?;
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
    let failures = plan.shortfalls(&applied, &mismatches);
    if !failures.is_empty() {
        return Err(CliError::failed(failures.join("; ")));
    }
    Ok(())
}
