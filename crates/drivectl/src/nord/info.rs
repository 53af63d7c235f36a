//! `info`: what the table knows of a parameter and the drive's value in every set and
//! element.

use ctt2_uss::client::{NordClient, ParameterChannel};
use drive_client::info::Info;
use drive_profile::nord::{self};

use super::{Session, Sub, param_client, resolve};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
use crate::tool::client::Target;

/// The targets `info` reads: what `--array`/`--set` name, else every array element in every
/// parameter set.
pub fn info_targets(key: &str, sub: Sub) -> Result<Vec<Target>> {
    let first = resolve(key, sub, true)?;
    let sets = first
        .first()
        .filter(|t| t.param.is_some())
        .and_then(|t| nord::by_index(t.index))
        .is_some_and(|p| p.parameter_set);
    if !sets || sub.set.is_some() {
        return Ok(first);
    }
    let mut all = Vec::new();
    for set in 1..=4 {
        all.extend(resolve(
            key,
            Sub {
                set: Some(set),
                ..sub
            },
            true,
        )?);
    }
    Ok(all)
}

/// `info`: see [`NordCommand::Info`](super::NordCommand::Info). A refusal of one set or
/// element is kept for it; a link failure stops.
pub async fn info<C: ParameterChannel>(
    c: &mut NordClient<C>,
    s: &Session,
    targets: &[Target],
    sub: Sub,
) -> Result<Info> {
    let Some(first) = targets.first().copied() else {
        return Err(CliError::failed("no parameter to show"));
    };
    let p = first.param.and_then(|_| nord::by_index(first.index));
    let mut pc = param_client(c, s).raw_array(sub.array.is_some());
    // AK 9: the drive's own number of elements, for an array (or a raw PNU read as one).
    let count = p.map_or(sub.array.is_some(), |p| p.array_len.is_some());
    drive_client::info::nord(&mut pc, first, targets, count)
        .await
        .map_err(|f| f.target.error(f.error))
}
