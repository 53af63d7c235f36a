//! The one write path of every family and front end: the width check always, then (unless
//! forced) the write guard with the EEPROM-wear rule ([`WearLog`]), the link settings only when
//! confirmed, the write, and the value read back. A read-back that differs from what was sent (a
//! drive that rounds to its steps or limits a value) is a warning and a field of [`Written`],
//! never a plain success. Refusals are typed ([`WriteError`]): nothing was sent for any of them
//! but [`WriteError::ReadBack`].

use drive_profile::guard::{GuardError, WriteGuard};
use drive_profile::{Family, Persistence};

use crate::client::{ClientError, ParamClient};
use crate::target::{Target, ValueError};
use crate::text::physical_text;
use crate::wear::{self, WearLog, WearLogError};

/// One write as it was asked for.
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

/// Why a write was not made, or not confirmed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    /// The value does not fit the parameter's bus width: never sent, not even forced.
    #[error("{0}")]
    Width(ValueError),
    /// The parameter is not in the family's table and the write was not forced.
    #[error("{label} is not in the {family} parameter table; check the index")]
    NotInTable {
        /// The target's label.
        label: String,
        /// The family.
        family: Family,
    },
    /// The write guard refused: read-only, out of range, not in the value list, too frequent.
    #[error("{message}")]
    Guard {
        /// The guard's refusal.
        error: GuardError,
        /// Its message, naming the target by its label (selector included).
        message: String,
    },
    /// A setting of the link the client talks over, not confirmed: writing it moves the drive
    /// away from the link.
    #[error("{label} is a setting of the link this command talks over: {change}")]
    LinkSetting {
        /// The target's label.
        label: String,
        /// What the write would change, for a person.
        change: String,
    },
    /// The EEPROM-wear log cannot be used, so the rule cannot be kept.
    #[error("{0}")]
    WearLog(WearLogError),
    /// The drive's key for the wear log could not be found (asking the drive failed).
    #[error("{0}")]
    Key(ClientError),
    /// The write itself failed: refused by the drive, or the link.
    #[error("{label}: {error}")]
    Client {
        /// The target's label.
        label: String,
        /// What failed.
        error: ClientError,
    },
    /// The write was sent, but reading the value back failed.
    #[error(
        "{label} was written{}, but reading it back failed: {error}",
        .note.as_ref().map_or_else(String::new, |n| format!(" ({n})"))
    )]
    ReadBack {
        /// The target's label.
        label: String,
        /// For a link setting: where the drive answers now.
        note: Option<String>,
        /// What failed.
        error: ClientError,
    },
}

/// Check `req` for the drive named `drive` (its [`ParamClient::drive_key`]) without sending
/// anything: the width always, then unless forced the table (the parameter must be in it) and
/// the guard, with the wear rule from `log` for a non-volatile write. Returns the guard's warning
/// to show, if any.
pub fn check(
    drive: &str,
    req: &WriteRequest,
    log: &dyn WearLog,
) -> Result<Option<String>, WriteError> {
    req.target.check_width(req.raw).map_err(WriteError::Width)?;
    if req.force {
        return Ok(None);
    }
    let Some(param) = req.target.param else {
        return Err(WriteError::NotInTable {
            label: req.target.label(),
            family: req.target.family,
        });
    };
    let mut guard = WriteGuard::new();
    if req.persistence == Persistence::NonVolatile {
        // The rule must not switch itself off: no log, no non-volatile write.
        log.ensure_usable().map_err(WriteError::WearLog)?;
        if let Some(at) = log
            .last_write(drive, param, req.target.sub)
            .map_err(WriteError::WearLog)?
        {
            guard.remember(param, at);
        }
    }
    guard
        .check(param, req.raw, req.persistence, wear::now())
        .map_err(|error| WriteError::Guard {
            message: req.target.relabel(&error.to_string()),
            error,
        })?;
    Ok(WriteGuard::warning(param).map(|w| req.target.relabel(&w.to_string())))
}

/// Refuse a write of the drive's own link settings (address, baud rate, timeouts of the link in
/// use) unless `confirmed`: such a write moves the drive away from the link it was written over.
pub fn check_link_setting<C: ParamClient>(
    client: &C,
    req: &WriteRequest,
    confirmed: bool,
) -> Result<(), WriteError> {
    if confirmed || !client.link_settings().contains(&req.target.index) {
        return Ok(());
    }
    Err(WriteError::LinkSetting {
        label: req.target.label(),
        change: client.link_change(&req.target, req.raw),
    })
}

/// What a checked write did: the raw value sent, the value the drive holds afterwards, and
/// where the drive answers now when a link setting was written.
#[derive(Debug, Clone, PartialEq, Eq)]
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

/// Check, write and read back: the value the drive holds afterwards. A write of a link setting
/// needs `confirmed`; the client follows the change (a new address) before reading back. The
/// guard's warning, a write the wear log could not record and a read-back that differs are
/// handed to `warn` as they come.
pub async fn write_checked<C: ParamClient>(
    client: &mut C,
    req: &WriteRequest,
    confirmed: bool,
    log: &dyn WearLog,
    warn: &mut dyn FnMut(&str),
) -> Result<Written, WriteError> {
    check_link_setting(client, req, confirmed)?;
    let drive = client.drive_key().await.map_err(WriteError::Key)?;
    if let Some(warning) = check(&drive, req, log)? {
        warn(&warning);
    }
    client
        .write(&req.target, req.raw, req.persistence)
        .await
        .map_err(|error| WriteError::Client {
            label: req.target.label(),
            error,
        })?;
    if let Err(e) = record(&drive, req, log) {
        warn(&e.to_string());
    }
    let link_note = client
        .link_settings()
        .contains(&req.target.index)
        .then(|| client.follow_link_change(&req.target, req.raw));
    // The write is done: a failing read-back must not look like a failed write.
    let back = match client.read(&req.target).await {
        Ok(back) => back,
        Err(error) => {
            return Err(WriteError::ReadBack {
                label: req.target.label(),
                note: link_note,
                error,
            });
        }
    };
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

/// Enter a sent write into the wear log of drive `drive_key` (non-volatile writes of table
/// parameters only).
pub fn record(drive_key: &str, req: &WriteRequest, log: &dyn WearLog) -> Result<(), WearLogError> {
    if req.persistence == Persistence::NonVolatile
        && let Some(param) = req.target.param
    {
        log.record(drive_key, param, req.target.sub)?;
    }
    Ok(())
}
