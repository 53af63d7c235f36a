//! The one address scan of every family: range check, progress bar, a line or JSON object per
//! drive found ([`drive_client::scan::Found`]), the summary.

use std::ops::RangeInclusive;

use drive_client::scan::{Found, Scan, ScanError, firmware_text};
use drive_profile::sew;

use crate::error::{CliError, Result};
use crate::tool::meaning::nord_state_text;
use crate::tool::output::trim_float;

/// How a family's scan is shown.
pub struct Shown<'a> {
    /// The addresses a scan may ask.
    pub range: RangeInclusive<u8>,
    /// The progress bar's message at each address (given the drives found so far), `None`
    /// for no bar (a bus asked at once).
    pub message: Option<&'a dyn Fn(u8, usize) -> String>,
    /// `--json`.
    pub json: bool,
}

/// Scan `from..=to` on `bus`, link failures said by `link`.
pub async fn scan<S: Scan<Error = ScanError<E>>, E: std::fmt::Display>(
    bus: &mut S,
    from: u8,
    to: u8,
    shown: Shown<'_>,
    link: impl Fn(E) -> CliError,
) -> Result<()> {
    let (lo, hi) = (*shown.range.start(), *shown.range.end());
    if from < lo || from > to || to > hi {
        return Err(CliError::usage(format!(
            "scan range must satisfy {lo} ≤ --from ≤ --to ≤ {hi}"
        )));
    }
    let bar = shown
        .message
        .map(|_| super::backup::progress(usize::from(to - from) + 1, "scanning"));
    let mut found = 0;
    for a in from..=to {
        if let (Some(bar), Some(message)) = (&bar, shown.message) {
            bar.set_message(message(a, found));
        }
        let probe = bus.probe(a).await.map_err(|e| match e {
            ScanError::Link(e) => link(e),
            e => CliError::usage(e.to_string()),
        })?;
        if let Some(bar) = &bar {
            bar.inc(1);
        }
        let Some(f) = probe else { continue };
        found += 1;
        let line = || {
            if shown.json {
                outln!("{}", f.json(a))
            } else {
                outln!("{}", text(a, &f))
            }
        };
        match &bar {
            Some(bar) => bar.suspend(line)?,
            None => line()?,
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    super::stale::note_stale(bus.stale_bytes());
    if !shown.json {
        outln!("{found} drive(s) answered between {from} and {to}")?;
    }
    Ok(())
}

/// One drive found, as a line.
pub fn text(a: u8, found: &Found) -> String {
    let unreadable = || "unreadable".to_owned();
    match found {
        Found::Movilink {
            device_type,
            rated_current_a,
            firmware,
        } => format!(
            "address {a:>2}: device type {}, rated current {}, firmware {}",
            // P070 named where a manual codes it, never a designation guessed from the digits.
            sew::device::designation(*device_type).map_or_else(
                || format!("{device_type} (no designation: the manual does not code P070)"),
                |name| format!("{name} ({device_type})"),
            ),
            rated_current_a.map_or_else(unreadable, |c| format!("{} A", trim_float(c, 3))),
            firmware_text(*firmware)
        ),
        Found::Sbus {
            device_type: Ok(device_type),
            firmware,
        } => format!(
            "address {a:>2}: device type {device_type}, firmware {}",
            firmware.map_or_else(unreadable, firmware_text)
        ),
        Found::Sbus {
            device_type: Err(code),
            ..
        } => format!("address {a:>2}: answers, refuses P070 ({code})"),
        Found::Nord {
            status,
            configuration_level,
        } => format!(
            "address {a:>2}: {}, P744 configuration level {}",
            status.map_or_else(
                || "status word unknown (no PZD)".to_owned(),
                |s| format!("status word 0x{:04X} = {}", s.0, nord_state_text(s.state()))
            ),
            configuration_level.map_or_else(unreadable, |v| v.to_string())
        ),
        Found::Bonfiglioli {
            variant,
            configuration,
            status_word,
        } => format!(
            "address {a:>3}: {}, configuration {}, status word {} (the manual defines no device \
             type or firmware parameter)",
            variant.map_or("ACT or ACU (not told apart)", |k| k.variant.name()),
            configuration.map_or_else(unreadable, |v| v.to_string()),
            status_word.map_or_else(unreadable, |v| format!("0x{v:04X}"))
        ),
        _ => format!("address {a:>2}: answers"),
    }
}
