//! `info`: what the table knows of a parameter and the drive's value in every set and
//! element.

use ctt2_uss::client::{NordClient, ParameterChannel};
use drive_client::DeviceError;
use drive_client::info::{FromDrive, Info};
use drive_profile::nord::{self};

use super::{Session, Sub, param_client, resolve};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
use crate::tool::client::Target;
use crate::tool::output::physical_text;

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

/// `info`: see [`NordCommand::Info`](super::NordCommand::Info). A refusal of one set or element is shown for it; a link
/// failure stops.
pub async fn info<C: ParameterChannel>(
    c: &mut NordClient<C>,
    s: &Session,
    targets: &[Target],
    sub: Sub,
) -> Result<()> {
    let Some(first) = targets.first().copied() else {
        return Err(CliError::failed("no parameter to show"));
    };
    let p = first.param.and_then(|_| nord::by_index(first.index));
    let mut pc = param_client(c, s).raw_array(sub.array.is_some());
    // AK 9: the drive's own number of elements, for an array (or a raw PNU read as one).
    let count = p.map_or(sub.array.is_some(), |p| p.array_len.is_some());
    let info = drive_client::info::nord(&mut pc, first, targets, count)
        .await
        .map_err(|f| f.target.error(f.error))?;
    if s.json {
        outln!("{}", info.json())?;
        return info_outcome(&info);
    }
    let text_of = |raw: i64| {
        first
            .param
            .map_or_else(|| raw.to_string(), |q| physical_text(q, raw))
    };
    let FromDrive::Nord { count } = &info.drive else {
        return info_outcome(&info);
    };
    match p {
        Some(q) => outln!(
            "{} {} ({}), PNU {} (0x{:03X})",
            q.label(),
            q.name_en,
            q.name_de,
            first.index,
            first.index
        )?,
        None => outln!(
            "PNU {} (0x{:03X}): not in the NORD table; only the drive's value is known",
            first.index,
            first.index
        )?,
    }
    let count_text = |c: &std::result::Result<u16, DeviceError>| match c {
        Ok(n) => format!("the drive counts {n} (AK 9)"),
        Err(e) => format!("the drive's count (AK 9): {}", e.message),
    };
    if let Some(q) = p {
        let range = q.raw_range.map_or_else(
            || "not in the table (a 16-bit word)".to_owned(),
            |(lo, hi)| format!("{} … {} (raw {lo} … {hi})", text_of(lo), text_of(hi)),
        );
        outln!("  range       {range}")?;
        outln!(
            "  default     {}",
            q.default_raw.map_or_else(
                || "not in the table".to_owned(),
                |d| format!("{} (raw {d})", text_of(d))
            )
        )?;
        outln!(
            "  resolution  {}",
            q.resolution.map_or_else(
                || "1 (an integer)".to_owned(),
                |r| format!("{} {}", r.text, q.unit).trim_end().to_owned()
            )
        )?;
        let rw = if q.access.is_writable() {
            "read-write"
        } else {
            "read-only"
        };
        outln!("  access      {rw}")?;
        outln!(
            "  sets        {}",
            if q.parameter_set {
                "one value per parameter set 1–4 (IND bits 8–9; --set)"
            } else {
                "none (one value for every parameter set)"
            }
        )?;
        let drive = count
            .as_ref()
            .map_or_else(String::new, |c| format!("; {}", count_text(c)));
        outln!(
            "  elements    {}{drive}",
            q.array_len.map_or_else(
                || "none (no array)".to_owned(),
                |n| format!("{n}: [-01] … [-{n:02}] (--array 1…{n})")
            )
        )?;
        outln!(
            "  (range and default from the NORD table: USS and CTT2 have no order that reads \
             them from the drive)"
        )?;
    } else if let Some(c) = count {
        outln!("  elements    {}", count_text(c))?;
    }
    for r in &info.current {
        let t = &r.target;
        match &r.value {
            Ok(raw) => outln!(
                "  {:<11} {} (raw {raw})",
                t.label(),
                crate::tool::output::value_text(t, *raw)
            )?,
            Err(e) => outln!("  {:<11} refused: {}", t.label(), e.message)?,
        }
    }
    info_outcome(&info)
}

/// The end of `info`: as `read` of several, a value the drive refused fails the command (the
/// drive's answers are shown above).
pub fn info_outcome(info: &Info) -> Result<()> {
    let refused: Vec<String> = info.refused().iter().map(|t| t.label()).collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(CliError::failed(format!(
        "{} of {} values could not be read: {} (the drive's answers are above)",
        refused.len(),
        info.current.len(),
        refused.join(", ")
    )))
}
