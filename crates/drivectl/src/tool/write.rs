//! The one write path of every family: the width check always, then (unless forced) the write
//! guard with the EEPROM-wear log, the write, and the value read back. A read-back that differs
//! from what was sent (a drive that rounds to its steps or limits a value) is a warning and a
//! field of [`Written`], never a plain success.

use drive_profile::Persistence;
use drive_profile::guard::{GuardError, WriteGuard};

use serde_json::Value;

use super::client::{ParamClient, Target};
use super::meaning::Device;
use super::output::{physical_text, print_value, value_json_in};
use super::wear;
use crate::error::{CliError, Result};

/// One write as the user asked for it.
#[derive(Debug, Clone, Copy)]
pub struct WriteRequest {
    /// The parameter.
    pub target: Target,
    /// The raw value.
    pub raw: i64,
    /// RAM only, or RAM and EEPROM.
    pub persistence: Persistence,
    /// Skip the table checks (access, range, value list, EEPROM wear); the width check stays.
    pub force: bool,
}

/// Check `req` as the user asked (see the [module docs](self)); returns the guard's warning to
/// show, if any. Nothing is sent. A refusal carries the hints of the `write` command.
pub async fn check<C: ParamClient>(client: &mut C, req: &WriteRequest) -> Result<Option<String>> {
    let drive = client.drive_key().await?;
    check_with(&drive, req, with_hint)
}

/// [`check`] for the drive named `drive` (its [`ParamClient::drive_key`]), with the caller's way
/// out in a refusal (`hint` turns the guard's error into the message), for commands with other
/// options than `write`.
pub fn check_with(
    drive: &str,
    req: &WriteRequest,
    hint: fn(&GuardError) -> String,
) -> Result<Option<String>> {
    req.target.check_width(req.raw)?;
    if req.force {
        return Ok(None);
    }
    let Some(param) = req.target.param else {
        return Err(CliError::usage(format!(
            "{} is not in the {} parameter table; check the index (`drivectl params {} --search NAME`) or use --force to send it anyway",
            req.target.label(),
            req.target.family,
            req.target.family
        )));
    };
    let mut guard = WriteGuard::new();
    if req.persistence == Persistence::NonVolatile {
        // The rule must not switch itself off: no log, no non-volatile write.
        wear::ensure_usable()?;
        wear::prime(&mut guard, drive, param, req.target.sub)?;
    }
    guard
        .check(param, req.raw, req.persistence, wear::now())
        .map_err(|e| CliError::usage(req.target.relabel(&hint(&e))))?;
    Ok(WriteGuard::warning(param).map(|w| req.target.relabel(&w.to_string())))
}

/// Refuse a write of the drive's own link settings (address, baud rate, timeouts of the link
/// in use) unless the user confirmed it with `--yes`: such a write moves the drive away from
/// the link it was written over.
pub fn check_link_setting<C: ParamClient>(client: &C, req: &WriteRequest, yes: bool) -> Result<()> {
    if yes || !client.link_settings().contains(&req.target.index) {
        return Ok(());
    }
    Err(CliError::usage(format!(
        "{} is a setting of the link this command talks over: {}; add --yes to write it",
        req.target.label(),
        client.link_change(&req.target, req.raw)
    )))
}

/// What a checked write did: the raw value sent, the value the drive holds afterwards, and
/// where the drive answers now when a link setting was written.
#[derive(Debug, Clone)]
pub struct Written {
    /// The raw value sent.
    pub sent: i64,
    /// The value read back.
    pub back: i64,
    /// When the value read back is not the one sent: what happened, for a person (`P130 was
    /// written with raw 65536 (65.54 s), but the drive holds 66000 (66.00 s): it rounded the
    /// value to its step`); the write path has handed it to its `warn` already.
    pub differs: Option<String>,
    /// For a link setting: what changed for the link (`P810`: the drive answers at address 5).
    pub link_note: Option<String>,
}

impl Written {
    /// The value the drive holds, as JSON ([`value_json_in`]) with `sent` (the raw value sent) and
    /// `differs` (whether the drive holds another one).
    pub fn json(&self, target: &Target) -> Value {
        let mut v = value_json_in(target, self.back, &Device::default());
        if let Value::Object(m) = &mut v {
            m.insert("sent".into(), self.sent.into());
            m.insert("differs".into(), self.differs.is_some().into());
        }
        v
    }
}

/// What a read-back `back` that differs from the raw value `sent` says, or `None` when they are
/// the same.
pub fn difference(target: &Target, sent: i64, back: i64) -> Option<String> {
    if sent == back {
        return None;
    }
    let Some(p) = target.param else {
        return Some(format!(
            "{} was written with raw {sent}, but the drive holds {back}",
            target.label()
        ));
    };
    let why = if p.from_physical(p.to_physical(sent)).ok() == Some(back) {
        ": it rounded the value to its step"
    } else if p
        .raw_range()
        .is_some_and(|(lo, hi)| back == lo || back == hi)
    {
        ": it limited the value to its range"
    } else {
        ""
    };
    Some(format!(
        "{} was written with raw {sent} ({}), but the drive holds {back} ({}){why}",
        target.label(),
        physical_text(p, sent),
        physical_text(p, back)
    ))
}

/// Print what a write did: where the drive answers now (a link setting) on standard error, then
/// the value it holds, as `read` prints one (text), or [`Written::json`].
pub fn print_written(target: &Target, done: &Written, json: bool) -> Result<()> {
    if let Some(note) = &done.link_note {
        errln!("drivectl: note: {note}");
    }
    if json {
        outln!("{}", done.json(target))
    } else {
        print_value(target, done.back, false)
    }
}

/// Check, write and read back: the value the drive holds afterwards. A write of a link setting
/// needs `yes`; the client follows the change (a new address) before reading back. The guard's
/// warning and a wear-log problem are shown on standard error.
pub async fn write_checked<C: ParamClient>(
    client: &mut C,
    req: &WriteRequest,
    yes: bool,
) -> Result<Written> {
    write_checked_with(client, req, yes, &mut |w: &str| {
        errln!("drivectl: warning: {w}")
    })
    .await
}

/// [`write_checked`] with the warnings handed to `warn` as they come (the gateway logs them;
/// its standard error may be a JSON log).
pub async fn write_checked_with<C: ParamClient>(
    client: &mut C,
    req: &WriteRequest,
    yes: bool,
    warn: &mut dyn FnMut(&str),
) -> Result<Written> {
    check_link_setting(client, req, yes)?;
    if let Some(warning) = check(client, req).await? {
        warn(&warning);
    }
    let drive = client.drive_key().await?;
    client
        .write(&req.target, req.raw, req.persistence)
        .await
        .map_err(|e| req.target.error(e))?;
    if let Err(e) = record(&drive, req) {
        warn(&e.to_string());
    }
    let link_note = client
        .link_settings()
        .contains(&req.target.index)
        .then(|| client.follow_link_change(&req.target, req.raw));
    // The write is done: a failing read-back must not look like a failed write.
    let back = client.read(&req.target).await.map_err(|e| {
        CliError::failed(format!(
            "{} was written{}, but reading it back failed: {}",
            req.target.label(),
            link_note
                .as_ref()
                .map_or_else(String::new, |n| format!(" ({n})")),
            CliError::from(e)
        ))
    })?;
    let differs = difference(&req.target, req.raw, back);
    if let Some(d) = &differs {
        warn(d);
    }
    Ok(Written {
        sent: req.raw,
        back,
        differs,
        link_note,
    })
}

/// Enter a sent write into the EEPROM-wear log of drive `drive_key` (non-volatile writes of
/// table parameters only).
pub fn record(drive_key: &str, req: &WriteRequest) -> Result<()> {
    if req.persistence == Persistence::NonVolatile
        && let Some(param) = req.target.param
    {
        wear::record(drive_key, param, req.target.sub)?;
    }
    Ok(())
}

/// The guard's message with what drivectl offers as a way out.
pub fn with_hint(e: &GuardError) -> String {
    let hint = match e {
        GuardError::DoesNotFit { .. } => "not even --force sends a value that would be cut",
        GuardError::ReadOnly { .. } => "",
        GuardError::OutOfRange { .. } | GuardError::NotInValueList { .. } => {
            "use a value in range, or --force to let the drive decide"
        }
        GuardError::TooFrequent { .. } => "use --volatile for values that change often, or --force",
        _ => "--force sends it anyway",
    };
    if hint.is_empty() {
        e.to_string()
    } else {
        format!("{e}; {hint}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::client::ClientError;
    use crate::tool::fake::FakeClient;

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
            .block_on(write_checked_with(
                &mut client,
                &req,
                false,
                &mut |w: &str| warnings.push(w.to_owned()),
            ))
            .unwrap();
        assert_eq!((done.sent, done.back), (65_536, 66_000));
        assert_eq!(done.json(&target)["sent"], 65_536);
        assert_eq!(done.json(&target)["differs"], true);
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
        let mut client =
            FakeClient::new(|_| Err(ClientError::Link("no answer from drive 1".into())));
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
