//! The one write path of every family: the width check always, then (unless forced) the write
//! guard with the EEPROM-wear log, the write, and the value read back.

use drive_profile::Persistence;
use drive_profile::guard::{GuardError, WriteGuard};

use super::client::{ParamClient, Target};
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
pub fn check<C: ParamClient>(client: &C, req: &WriteRequest) -> Result<Option<String>> {
    check_with(client, req, with_hint)
}

/// [`check`] with the caller's way out in a refusal (`hint` turns the guard's error into the
/// message), for commands with other options than `write`.
pub fn check_with<C: ParamClient>(
    client: &C,
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
    wear::prime(&mut guard, &client.drive_key(), param);
    guard
        .check(param, req.raw, req.persistence, wear::now())
        .map_err(|e| CliError::usage(hint(&e)))?;
    Ok(WriteGuard::warning(param).map(|w| w.to_string()))
}

/// Check, write and read back: the value the drive holds afterwards.
pub async fn write_checked<C: ParamClient>(client: &mut C, req: &WriteRequest) -> Result<i64> {
    if let Some(warning) = check(client, req)? {
        errln!("drivectl: warning: {warning}");
    }
    client.write(&req.target, req.raw, req.persistence).await?;
    record(&client.drive_key(), req);
    // The write is done: a failing read-back must not look like a failed write.
    client.read(&req.target).await.map_err(|e| {
        CliError::failed(format!(
            "{} was written, but reading it back failed: {}",
            req.target.label(),
            CliError::from(e)
        ))
    })
}

/// Enter a sent write into the EEPROM-wear log of drive `drive_key` (non-volatile writes of
/// table parameters only).
pub fn record(drive_key: &str, req: &WriteRequest) {
    if req.persistence == Persistence::NonVolatile {
        if let Some(param) = req.target.param {
            wear::record(drive_key, param);
        }
    }
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
        _ => "or --force to send it anyway",
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
            .block_on(write_checked(&mut client, &req))
            .unwrap_err()
            .to_string();
        assert_eq!(client.written, [(8470, 1500, Persistence::Volatile)]);
        assert_eq!(
            err,
            "P130 was written, but reading it back failed: no answer from drive 1"
        );
    }
}
