//! The write path on the command line: `drive_client::write` (the width check always, then,
//! unless forced, the write guard with the EEPROM-wear rule of the file log, the link settings
//! only with `--yes`, the write and the read-back), its refusals said with the options that are
//! the way out (`--force`, `--volatile`, `--yes`), and what a write did printed as `read` prints
//! a value, with `sent` and `differs` in JSON.

use drive_client::write as path;
use drive_profile::guard::GuardError;
use serde_json::Value;

pub use drive_client::write::{WriteError, WriteRequest, Written};
pub use drive_client::{FileWearLog, WearLogError};

use super::client::{ParamClient, Target};
use super::meaning::Device;
use super::output::{print_value, value_json_in};
use crate::error::{CliError, Result};

/// How a refusal for an unusable wear log ends on the command line (the gateway, which has no
/// such options, says its own way out instead).
pub const CLI_WAY_OUT: &str = "; set DRIVECTL_STATE_DIR to a writable directory, write with \
                               --volatile, or --force to write without the rule";

impl From<WriteError> for CliError {
    fn from(e: WriteError) -> Self {
        match e {
            WriteError::Width(v) => v.into(),
            WriteError::NotInTable { label, family } => CliError::usage(format!(
                "{label} is not in the {family} parameter table; check the index (`drivectl \
                 params {family} --search NAME`) or use --force to send it anyway"
            )),
            WriteError::Guard { error, message } => {
                CliError::usage(message + &hint_of(&error).unwrap_or_default())
            }
            WriteError::LinkSetting { .. } => {
                CliError::usage(format!("{e}; add --yes to write it"))
            }
            WriteError::WearLog(w) => CliError::failed(format!("{w}{CLI_WAY_OUT}")),
            WriteError::Key(c) => c.into(),
            WriteError::Client { ref error, .. } | WriteError::ReadBack { ref error, .. } => {
                let hint = super::client::echo_hint(error);
                CliError::failed(format!("{e}{hint}"))
            }
            other => CliError::failed(other.to_string()),
        }
    }
}

/// Check `req` as the user asked without sending anything; returns the guard's warning to show,
/// if any. A refusal carries the hints of the `write` command.
pub async fn check<C: ParamClient>(client: &mut C, req: &WriteRequest) -> Result<Option<String>> {
    let drive = client.drive_key().await?;
    Ok(path::check(&drive, req, &FileWearLog::from_env())?)
}

/// [`check`] for the drive named `drive` (its [`ParamClient::drive_key`]), before anything is
/// opened (a command that knows no drive key yet checks the table with `""`).
pub fn check_drive(drive: &str, req: &WriteRequest) -> Result<Option<String>> {
    Ok(path::check(drive, req, &FileWearLog::from_env())?)
}

/// Refuse a write of the drive's own link settings unless the user confirmed it with `--yes`.
pub fn check_link_setting<C: ParamClient>(client: &C, req: &WriteRequest, yes: bool) -> Result<()> {
    Ok(path::check_link_setting(client, req, yes)?)
}

/// The value the drive holds after a write, as JSON (`read --json`'s keys) with `sent` (the raw
/// value sent) and `differs` (whether the drive holds another one).
pub fn written_json(target: &Target, done: &Written) -> Value {
    let mut v = value_json_in(target, done.back, &Device::default());
    if let Value::Object(m) = &mut v {
        m.insert("sent".into(), done.sent.into());
        m.insert("differs".into(), done.differs.is_some().into());
    }
    v
}

/// Print what a write did: where the drive answers now (a link setting) on standard error, then
/// the value it holds, as `read` prints one (text), or [`written_json`].
pub fn print_written(target: &Target, done: &Written, json: bool) -> Result<()> {
    if let Some(note) = &done.link_note {
        errln!("drivectl: note: {note}");
    }
    if json {
        outln!("{}", written_json(target, done))
    } else {
        print_value(target, done.back, false)
    }
}

/// Check, write and read back (`drive_client::write::write_checked` with the file wear log):
/// the value the drive holds afterwards; the guard's warning, a wear-log problem and a
/// read-back that differs are shown on standard error.
pub async fn write_checked<C: ParamClient>(
    client: &mut C,
    req: &WriteRequest,
    yes: bool,
) -> Result<Written> {
    let log = FileWearLog::from_env();
    Ok(path::write_checked(client, req, yes, &log, &mut |w: &str| {
        errln!("drivectl: warning: {w}")
    })
    .await?)
}

/// A write no drive answers (a group, a broadcast): the same checks as an answered write (the
/// link settings with `yes`, the table, the EEPROM-wear rule; the guard's warning shown), then
/// `send` puts it on the bus, and the wear log records it under `client`'s drive key. Nothing
/// is read back.
pub async fn unanswered<C: ParamClient>(
    client: &mut C,
    req: &WriteRequest,
    yes: bool,
    send: impl AsyncFnOnce(&mut C) -> Result<()>,
) -> Result<()> {
    check_link_setting(client, req, yes)?;
    let drive_key = client.drive_key().await?;
    if let Some(warning) = check(client, req).await? {
        errln!("drivectl: warning: {warning}");
    }
    send(client).await?;
    if let Err(e) = record(&drive_key, req) {
        errln!("drivectl: warning: {e}");
    }
    Ok(())
}

/// Enter a sent write into the EEPROM-wear log of drive `drive_key` (non-volatile writes of
/// table parameters only); a failure is for the caller to report.
pub fn record(drive_key: &str, req: &WriteRequest) -> std::result::Result<(), WearLogError> {
    path::record(drive_key, req, &FileWearLog::from_env())
}

/// What drivectl offers as a way out of a guard's refusal (`; use --volatile …`), if anything.
pub fn hint_of(e: &GuardError) -> Option<String> {
    let hint = match e {
        GuardError::DoesNotFit { .. } => "not even --force sends a value that would be cut",
        GuardError::ReadOnly { .. } => return None,
        GuardError::OutOfRange { .. } | GuardError::NotInValueList { .. } => {
            "use a value in range, or --force to let the drive decide"
        }
        GuardError::TooFrequent { .. } => "use --volatile for values that change often, or --force",
        _ => "--force sends it anyway",
    };
    Some(format!("; {hint}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::client::ClientError;
    use crate::tool::fake::FakeClient;
    use drive_profile::Persistence;

    #[test]
    fn issue18_a_write_the_drive_holds_differently_is_said() {
        // The drive rounds P130 to its 1 s steps above 10 s.
        let mut client = FakeClient::new(|_| Ok(66_000));
        let target = crate::movilink::resolve("P130").unwrap();
        let req = WriteRequest {
            target,
            raw: 65_536,
            persistence: Persistence::Volatile,
            force: false,
        };
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let mut warnings = Vec::new();
        let done = rt
            .block_on(path::write_checked(
                &mut client,
                &req,
                false,
                &drive_client::MemoryWearLog::default(),
                &mut |w: &str| warnings.push(w.to_owned()),
            ))
            .unwrap();
        assert_eq!((done.sent, done.back), (65_536, 66_000));
        assert_eq!(written_json(&target, &done)["sent"], 65_536);
        assert_eq!(written_json(&target, &done)["differs"], true);
        assert_eq!(
            done.differs.as_deref(),
            warnings.first().map(String::as_str)
        );
        assert_eq!(
            warnings,
            [
                "P130 was written with raw 65536 (65.54 s), but the drive holds 66000 (66.00 s): \
              it rounded the value to its step"
            ]
        );
    }

    #[test]
    fn a_failed_read_back_says_the_value_was_written() {
        // A drive that takes every write and then stops answering.
        let mut client = FakeClient::new(|_| {
            Err(ClientError::link(
                drive_client::LinkFault::NoAnswer,
                "no answer from drive 1",
            ))
        });
        let target = crate::movilink::resolve("P130").unwrap();
        let req = WriteRequest {
            target,
            raw: 1500,
            persistence: Persistence::Volatile,
            force: true,
        };
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let err = rt
            .block_on(write_checked(&mut client, &req, false))
            .unwrap_err()
            .to_string();
        assert_eq!(client.written, [(8470, 1500, Persistence::Volatile)]);
        assert_eq!(
            err,
            "P130 was written, but reading it back failed: no answer from drive 1"
        );
    }
}
