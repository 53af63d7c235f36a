//! `info` of every family: drive-client's [`Info`] as its JSON object or as text, and the end
//! of the command (a value the drive refused fails it, after everything is shown).

use drive_client::DeviceError;
use drive_client::info::{FromDrive, Info, Reading, width_text};
use drive_client::sew::{Description, raw_of};
use drive_profile::bonfiglioli::{self, ParamAccess, TypeSource};
use drive_profile::{Access, ParamMeta, nord, sew};

use super::meaning::Device;
use super::output::{physical_text, value_text, value_text_in};
use crate::error::{CliError, Result};

/// Print `info` (JSON or text), then fail if the drive refused a value.
pub fn print(info: &Info, json: bool) -> Result<()> {
    if json {
        outln!("{}", info.json())?;
    } else {
        match &info.drive {
            FromDrive::Sew(d) => sew_text(info, d)?,
            FromDrive::Nord { count } => nord_text(info, count.as_ref())?,
            FromDrive::Bonfiglioli { width, device } => bonfiglioli_text(info, *width, device)?,
            _ => {}
        }
    }
    let refused: Vec<String> = info.refused().iter().map(|t| t.label()).collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(CliError::failed(match info.drive {
        FromDrive::Bonfiglioli { .. } => format!(
            "the drive refused to read {} (its answer is above)",
            refused.join(", ")
        ),
        // As `read` of several.
        _ => format!(
            "{} of {} values could not be read: {} (the drive's answers are above)",
            refused.len(),
            info.current.len(),
            refused.join(", ")
        ),
    }))
}

/// Rows of `key value`, the keys padded to `width`.
fn rows(width: usize, rows: &[(&str, String)]) -> Result<()> {
    for (k, v) in rows {
        outln!("  {k:<width$} {v}")?;
    }
    Ok(())
}

/// `lo … hi (raw lo … hi)`.
fn range_text(p: &dyn ParamMeta, (lo, hi): (i64, i64)) -> String {
    format!(
        "{} … {} (raw {lo} … {hi})",
        physical_text(p, lo),
        physical_text(p, hi)
    )
}

fn sew_text(info: &Info, d: &Description) -> Result<()> {
    let t = &info.target;
    let show = |data: u32| {
        let v = raw_of(t, data);
        t.param
            .map_or_else(|| v.to_string(), |p| physical_text(p, v))
    };
    let (scale, attr) = (d.scale, d.attribute);
    let name = t
        .param
        .map_or_else(String::new, |p| format!("{} {} ", p.label(), p.name_en()));
    outln!("{name}(index {})", t.index)?;
    rows(
        10,
        &[
            ("value", value_text(t, raw_of(t, d.current))),
            ("minimum", show(d.minimum)),
            ("maximum", show(d.maximum)),
            ("default", show(d.default)),
            (
                "scale",
                format!(
                    "size index {} ({}), conversion index {}",
                    scale.size_index,
                    sew::size_name(scale.size_index).unwrap_or("unknown quantity"),
                    scale.conversion_index
                ),
            ),
            (
                "attributes",
                format!(
                    "0x{:04X} ({}), next index {}",
                    attr.attributes,
                    Access::from_bits_truncate(attr.attributes as u8),
                    attr.next_index
                ),
            ),
        ],
    )
}

fn nord_text(info: &Info, count: Option<&std::result::Result<u16, DeviceError>>) -> Result<()> {
    let first = &info.target;
    let p = first.param.and_then(|_| nord::by_index(first.index));
    let count_text = |c: &std::result::Result<u16, DeviceError>| match c {
        Ok(n) => format!("the drive counts {n} (AK 9)"),
        Err(e) => format!("the drive's count (AK 9): {}", e.message),
    };
    let mut all = Vec::new();
    match p {
        Some(q) => {
            outln!(
                "{} {} ({}), PNU {} (0x{:03X})",
                q.label(),
                q.name_en,
                q.name_de,
                first.index,
                first.index
            )?;
            let drive = count.map_or_else(String::new, |c| format!("; {}", count_text(c)));
            all.extend([
                (
                    "range",
                    q.raw_range.map_or_else(
                        || "not in the table (a 16-bit word)".to_owned(),
                        |r| range_text(q, r),
                    ),
                ),
                (
                    "default",
                    q.default_raw.map_or_else(
                        || "not in the table".to_owned(),
                        |d| format!("{} (raw {d})", physical_text(q, d)),
                    ),
                ),
                (
                    "resolution",
                    q.resolution.map_or_else(
                        || "1 (an integer)".to_owned(),
                        |r| format!("{} {}", r.text, q.unit).trim_end().to_owned(),
                    ),
                ),
                (
                    "access",
                    if q.access.is_writable() {
                        "read-write"
                    } else {
                        "read-only"
                    }
                    .to_owned(),
                ),
                (
                    "sets",
                    if q.parameter_set {
                        "one value per parameter set 1–4 (IND bits 8–9; --set)"
                    } else {
                        "none (one value for every parameter set)"
                    }
                    .to_owned(),
                ),
                (
                    "elements",
                    q.array_len.map_or_else(
                        || "none (no array)".to_owned(),
                        |n| format!("{n}: [-01] … [-{n:02}] (--array 1…{n})"),
                    ) + &drive,
                ),
            ]);
        }
        None => {
            outln!(
                "PNU {} (0x{:03X}): not in the NORD table; only the drive's value is known",
                first.index,
                first.index
            )?;
            all.extend(count.map(|c| ("elements", count_text(c))));
        }
    }
    rows(11, &all)?;
    if p.is_some() {
        outln!(
            "  (range and default from the NORD table: USS and CTT2 have no order that reads \
             them from the drive)"
        )?;
    }
    let current: Vec<(String, String)> = info
        .current
        .iter()
        .map(|r| {
            let v = match &r.value {
                Ok(raw) => format!("{} (raw {raw})", value_text(&r.target, *raw)),
                Err(e) => format!("refused: {}", e.message),
            };
            (r.target.label(), v)
        })
        .collect();
    for (k, v) in current {
        outln!("  {k:<11} {v}")?;
    }
    Ok(())
}

fn bonfiglioli_text(
    info: &Info,
    width: Option<bonfiglioli_modbus::slave::Width>,
    device: &Device,
) -> Result<()> {
    let t = &info.target;
    let width_text = width.map(width_text);
    let Some(p) = t.param.and(bonfiglioli::by_index(t.index)) else {
        outln!(
            "{} is not in the table (raw access){}",
            t.label(),
            width_text.map_or_else(String::new, |w| format!(", read as {w}"))
        )?;
        return bonfiglioli_current(&info.current, device);
    };
    outln!(
        "{} {} / {} (index {})",
        p.number,
        p.name_de,
        p.name_en,
        p.number
    )?;
    let mut all = Vec::new();
    all.extend(ParamMeta::raw_range(p).map(|r| ("range", range_text(p, r))));
    all.push((
        "default",
        p.default.map_or_else(
            || "not given in the manual".to_owned(),
            |d| format!("{} (raw {d})", physical_text(p, d)),
        ),
    ));
    let unit = if p.unit.is_empty() { "-" } else { p.unit };
    all.push(("unit", format!("{unit}, {} decimal(s)", p.decimals)));
    let source = match p.type_source {
        TypeSource::Stated => "stated in the manual",
        TypeSource::Example => "from an example of the manual",
        TypeSource::Range => "from its range",
        TypeSource::Layout => "from its bit layout in the manual",
        TypeSource::Analogy => "by analogy with a stated type",
        TypeSource::Unknown => "source not known",
    };
    let data_type = p.data_type.bits().map_or_else(
        || "not given in the manual".to_owned(),
        |bits| format!("{} ({bits} bit; {source})", p.data_type.name()),
    );
    let read_as = width_text.map_or_else(
        || " (give --word or --long)".to_owned(),
        |w| format!("; read as {w}"),
    );
    all.push(("data type", data_type + &read_as));
    let sets = match p.data_set {
        Some(true) => "four (1–4; 0 addresses all four; 5–9 their RAM-only twins)",
        Some(false) => "none: exists once (data set 0; 5 for a RAM-only write)",
        None => "not stated in the manual",
    };
    all.push(("data sets", sets.to_owned()));
    let mut notes = Vec::new();
    if p.ram_only {
        notes.push("kept in RAM only, never written to EEPROM");
    } else if p.is_writable() {
        notes.push("a write goes to EEPROM (--volatile: RAM only)");
    }
    if matches!(p.access, ParamAccess::WriteOnly) {
        notes.push("write-only on the ACTIVE Cube (ch. 10.2.3)");
    }
    if p.not_in_operation {
        notes.push("not writable while the drive runs");
    }
    if p.bus_only {
        notes.push("only over the bus, not from KP500/VPlus");
    }
    let rw = match p.access {
        ParamAccess::ReadOnly => "read-only",
        ParamAccess::ReadWrite => "read/write",
        ParamAccess::WriteOnly => "write-only",
    };
    let notes: String = notes.iter().map(|n| format!("; {n}")).collect();
    all.push(("access", format!("{} ({rw}){notes}", ParamMeta::access(p))));
    rows(10, &all)?;
    if !p.values.is_empty() {
        outln!("  values")?;
        for v in p.values {
            outln!("    {:>6} = {} ({})", v.value, v.en, v.de)?;
        }
    }
    bonfiglioli_current(&info.current, device)
}

/// The drive's values of a Bonfiglioli `info`, one line per data set.
fn bonfiglioli_current(current: &[Reading], device: &Device) -> Result<()> {
    for (i, r) in current.iter().enumerate() {
        let at = &r.target;
        let place = if at.sub == 0 && at.selector_json().is_null() {
            "value".to_owned()
        } else {
            format!("data set {}", at.sub)
        };
        let v = match &r.value {
            Ok(raw) => format!("{} (raw {raw})", value_text_in(at, *raw, device)),
            Err(e) => format!("refused: {}", e.message),
        };
        outln!("  {:<10} {place}: {v}", if i == 0 { "drive" } else { "" })?;
    }
    Ok(())
}
