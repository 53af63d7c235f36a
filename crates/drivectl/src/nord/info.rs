//! `info`: what the table knows of a parameter and the drive's value in every set and
//! element.

use ctt2_uss::client::{NordClient, ParameterChannel};
use drive_profile::nord::{self};
use serde_json::{Value, json};

use super::{Session, Sub, param_client, resolve};
use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ClientError, ParamClient, Target};
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
    let mut current = Vec::new();
    for t in targets {
        match pc.read(t).await {
            Ok(raw) => current.push((*t, Ok(raw))),
            Err(ClientError::Device(d)) => current.push((*t, Err(d.message))),
            Err(e) => return Err(t.error(e)),
        }
    }
    // AK 9: the drive's own number of elements, for an array (or a raw PNU read as one).
    let count = if p.map_or(sub.array.is_some(), |p| p.array_len.is_some()) {
        match pc.element_count(first.index).await {
            Ok(n) => Some(Ok(n)),
            Err(ClientError::Device(d)) => Some(Err(d.message)),
            Err(e) => return Err(first.error(e)),
        }
    } else {
        None
    };
    let physical = |raw: i64| first.param.map_or(raw as f64, |q| q.to_physical(raw));
    let text_of = |raw: i64| {
        first
            .param
            .map_or_else(|| raw.to_string(), |q| physical_text(q, raw))
    };
    if s.json {
        let values: Vec<Value> = current
            .iter()
            .map(|(t, r)| {
                let mut v = crate::decode::param_json(t, r.as_ref().ok().copied());
                if let (Value::Object(m), Err(e)) = (&mut v, r) {
                    m.insert("error".into(), e.clone().into());
                }
                v
            })
            .collect();
        outln!(
            "{}",
            json!({
                // The keys of `movilink info --json` and `params --json` where they mean the
                // same: raw values plain, physical ones as `*_value` in the table's unit.
                "index": first.index,
                "number": p.map(|q| q.label().to_string()),
                // One target: its label and selector; several (every set or element): the
                // parameter, each one's in `current`.
                "label": if targets.len() == 1 { first.label() } else {
                    p.map_or_else(|| first.label(), |q| q.label().to_string())
                },
                "selector": if targets.len() == 1 { first.selector_json() } else { Value::Null },
                "name_de": p.map(|q| q.name_de), "name_en": p.map(|q| q.name_en),
                "unit": p.map(|q| q.unit),
                "range": p.and_then(|q| q.raw_range).map(|(lo, hi)| json!({
                    "min": lo, "max": hi, "min_value": physical(lo), "max_value": physical(hi),
                })),
                "default": p.and_then(|q| q.default_raw),
                "default_value": p.and_then(|q| q.default_raw).map(physical),
                "resolution": p.and_then(|q| q.resolution).map(|r| json!({
                    "step": r.step, "decimals": r.decimals, "text": r.text,
                })),
                "access": p.map(|q| q.access.to_string()),
                "parameter_set": p.map(|q| q.parameter_set),
                "array_len": p.and_then(|q| q.array_len),
                "array_len_drive": count.as_ref().and_then(|c| c.as_ref().ok().copied()),
                "limits_from": p.map(|_| "table"),
                // The drive's values (every set/element asked for), as `read --json` shows
                // them; `values` is the value list in `params --json`.
                "current": values,
                "values": p.map(|q| q.values.iter().map(|v| json!({
                    "value": v.value, "de": v.de, "en": v.en,
                })).collect::<Vec<_>>()),
            })
        )?;
        return info_outcome(&current);
    }
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
        outln!(
            "  access      {}",
            if q.access.is_writable() {
                "read-write"
            } else {
                "read-only"
            }
        )?;
        outln!(
            "  sets        {}",
            if q.parameter_set {
                "one value per parameter set 1–4 (IND bits 8–9; --set)"
            } else {
                "none (one value for every parameter set)"
            }
        )?;
        let drive = match &count {
            Some(Ok(n)) => format!("; the drive counts {n} (AK 9)"),
            Some(Err(e)) => format!("; the drive's count (AK 9): {e}"),
            None => String::new(),
        };
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
    } else if let Some(c) = &count {
        outln!(
            "  elements    {}",
            match c {
                Ok(n) => format!("the drive counts {n} (AK 9)"),
                Err(e) => format!("the drive's count (AK 9): {e}"),
            }
        )?;
    }
    for (t, r) in &current {
        match r {
            Ok(raw) => outln!(
                "  {:<11} {} (raw {raw})",
                t.label(),
                crate::tool::output::value_text(t, *raw)
            )?,
            Err(e) => outln!("  {:<11} refused: {e}", t.label())?,
        }
    }
    info_outcome(&current)
}

/// The end of `info`: as `read` of several, a value the drive refused fails the command (the
/// drive's answers are shown above).
pub fn info_outcome(current: &[(Target, std::result::Result<i64, String>)]) -> Result<()> {
    let refused: Vec<String> = current
        .iter()
        .filter(|(_, r)| r.is_err())
        .map(|(t, _)| t.label())
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(CliError::failed(format!(
        "{} of {} values could not be read: {} (the drive's answers are above)",
        refused.len(),
        current.len(),
        refused.join(", ")
    )))
}
