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
/// show, if any. Nothing is sent.
pub fn check<C: ParamClient>(client: &C, req: &WriteRequest) -> Result<Option<String>> {
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
        .map_err(|e| CliError::usage(with_hint(&e)))?;
    Ok(WriteGuard::warning(param).map(|w| w.to_string()))
}

/// Check, write and read back: the value the drive holds afterwards.
pub async fn write_checked<C: ParamClient>(client: &mut C, req: &WriteRequest) -> Result<i64> {
    if let Some(warning) = check(client, req)? {
        eprintln!("drivectl: warning: {warning}");
    }
    client.write(&req.target, req.raw, req.persistence).await?;
    if req.persistence == Persistence::NonVolatile {
        if let Some(param) = req.target.param {
            wear::record(&client.drive_key(), param);
        }
    }
    Ok(client.read(&req.target).await?)
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
