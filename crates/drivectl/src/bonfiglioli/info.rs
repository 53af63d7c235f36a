//! `info`: what the table knows of a parameter and the drive's value in each data set it has.

use super::*;
use drive_client::info::{FromDrive, Reading, width_text};

/// `info`: what the table knows of one parameter (range, default, unit, decimals, data type
/// and width, data sets, access, RAM-only) and the drive's value in each data set it has (1–4
/// for a data-set parameter, else 0; only `--dataset N` when given). The JSON keys are those of
/// `drivectl movilink info --json` where they mean the same (`index`, `number`, `name_de`,
/// `name_en`, `unit`, `range`, `default`, `default_value`, `access`), the table's columns as
/// `drivectl params bonfiglioli --json` names them, and `current`: one value object per data
/// set as `read --json` prints it, or `{label, selector, error}` for a refused one. A width the
/// manual does not give is found by trying (FC 3, then FC 100) unless --word/--long gives it.
pub async fn info<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    args: &BonfiglioliArgs,
    key: &str,
    access: Access,
    json: bool,
) -> Result<()> {
    let t = resolve(key, access.dataset)?;
    check_data_set(&t)?;
    let table = t.param.and(bonfiglioli::by_index(t.index));
    let subs: Vec<u16> = match table {
        _ if access.dataset != 0 => vec![u16::from(access.dataset)],
        Some(p) if p.is_data_set() => vec![1, 2, 3, 4],
        _ => vec![0],
    };
    let mut c =
        client(m, address(args.addr)?, &args.port, access.width()).given(given_variant(args));
    let probing = table_width(&t, access.width()).is_none();
    if probing {
        c = c.probing();
    }
    find_variant_for(&mut c, &[t]).await?;
    let info = drive_client::info::bonfiglioli(&mut c, t, &subs)
        .await
        .map_err(|f| f.target.error(f.error))?;
    // Refusals other than the write-only parameter's "not readable" (484/524 on the ACU, as
    // the table says): the command fails at the end, after showing what it has.
    let outcome = || {
        let refused: Vec<String> = info.refused().iter().map(|t| t.label()).collect();
        if refused.is_empty() {
            Ok(())
        } else {
            Err(CliError::failed(format!(
                "the drive refused to read {} (its answer is above)",
                refused.join(", ")
            )))
        }
    };
    if json {
        outln!("{}", info.json())?;
        return outcome();
    }
    let FromDrive::Bonfiglioli { width, device } = &info.drive else {
        return outcome();
    };
    let width_text = width.map(width_text);
    let current = &info.current;
    let Some(p) = table else {
        outln!(
            "{} is not in the table (raw access){}",
            t.label(),
            width_text.map_or_else(String::new, |w| format!(", read as {w}"))
        )?;
        print_current(current, device)?;
        return outcome();
    };
    outln!(
        "{} {} / {} (index {})",
        p.number,
        p.name_de,
        p.name_en,
        p.number
    )?;
    if let Some((lo, hi)) = ParamMeta::raw_range(p) {
        outln!(
            "  range      {} … {} (raw {lo} … {hi})",
            physical_text(p, lo),
            physical_text(p, hi)
        )?;
    }
    match p.default {
        Some(d) => outln!("  default    {} (raw {d})", physical_text(p, d))?,
        None => outln!("  default    not given in the manual")?,
    }
    outln!(
        "  unit       {}, {} decimal(s)",
        if p.unit.is_empty() { "-" } else { p.unit },
        p.decimals
    )?;
    outln!(
        "  data type  {}{}",
        match p.data_type.bits() {
            Some(bits) => format!(
                "{} ({bits} bit; {})",
                p.data_type.name(),
                match p.type_source {
                    bonfiglioli::TypeSource::Stated => "stated in the manual",
                    bonfiglioli::TypeSource::Example => "from an example of the manual",
                    bonfiglioli::TypeSource::Range => "from its range",
                    bonfiglioli::TypeSource::Layout => "from its bit layout in the manual",
                    bonfiglioli::TypeSource::Analogy => "by analogy with a stated type",
                    bonfiglioli::TypeSource::Unknown => "source not known",
                }
            ),
            None => "not given in the manual".to_owned(),
        },
        width_text.map_or_else(
            || " (give --word or --long)".to_owned(),
            |w| format!("; read as {w}")
        )
    )?;
    outln!(
        "  data sets  {}",
        match p.data_set {
            Some(true) => "four (1–4; 0 addresses all four; 5–9 their RAM-only twins)",
            Some(false) => "none: exists once (data set 0; 5 for a RAM-only write)",
            None => "not stated in the manual",
        }
    )?;
    let mut notes = Vec::new();
    if p.ram_only {
        notes.push("kept in RAM only, never written to EEPROM");
    } else if p.is_writable() {
        notes.push("a write goes to EEPROM (--volatile: RAM only)");
    }
    if matches!(p.access, bonfiglioli::ParamAccess::WriteOnly) {
        notes.push("write-only on the ACTIVE Cube (ch. 10.2.3)");
    }
    if p.not_in_operation {
        notes.push("not writable while the drive runs");
    }
    if p.bus_only {
        notes.push("only over the bus, not from KP500/VPlus");
    }
    outln!(
        "  access     {} ({}){}",
        ParamMeta::access(p),
        match p.access {
            bonfiglioli::ParamAccess::ReadOnly => "read-only",
            bonfiglioli::ParamAccess::ReadWrite => "read/write",
            bonfiglioli::ParamAccess::WriteOnly => "write-only",
        },
        if notes.is_empty() {
            String::new()
        } else {
            format!("; {}", notes.join("; "))
        }
    )?;
    if !p.values.is_empty() {
        outln!("  values")?;
        for v in p.values {
            outln!("    {:>6} = {} ({})", v.value, v.en, v.de)?;
        }
    }
    print_current(current, device)?;
    outcome()
}

/// The drive's values of `info`, one line per data set.
pub fn print_current(current: &[Reading], device: &Device) -> Result<()> {
    for (
        i,
        Reading {
            target: at,
            value: r,
        },
    ) in current.iter().enumerate()
    {
        let head = if i == 0 {
            "  drive     "
        } else {
            "            "
        };
        let place = if at.sub == 0 && at.selector_json().is_null() {
            "value".to_owned()
        } else {
            format!("data set {}", at.sub)
        };
        match r {
            Ok(raw) => outln!(
                "{head} {place}: {} (raw {raw})",
                crate::tool::output::value_text_in(at, *raw, device)
            )?,
            Err(e) => outln!("{head} {place}: refused: {}", e.message)?,
        }
    }
    Ok(())
}
