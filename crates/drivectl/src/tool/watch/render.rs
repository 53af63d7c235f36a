//! The shapes of a watch's output: a table redrawn in place, a line per poll, CSV rows with
//! their header (a JSON sample is drive-client's [`Sample::to_json`]).
//!
//! [`Sample::to_json`]: drive_client::watch::Sample::to_json

use std::fmt::Write as _;
use std::time::Duration;

use drive_client::DeviceError;

use super::super::client::Target;
use super::super::meaning::Device;
use super::super::output::value_text_in;

/// One value of a sample: its raw value or the drive's refusal.
type Cell = std::result::Result<i64, DeviceError>;

/// The value of one cell as text.
pub fn cell_text(t: &Target, cell: &Cell, device: &Device) -> String {
    match cell {
        Ok(raw) => value_text_in(t, *raw, device),
        Err(d) => format!("refused: {}", d.message),
    }
}

pub fn table(
    time: &str,
    interval: Duration,
    targets: &[Target],
    cells: &[Cell],
    device: &Device,
) -> String {
    let mut s = format!("{time}  every {} ms, Ctrl-C ends\n", interval.as_millis());
    let names: Vec<String> = targets.iter().map(Target::title).collect();
    let width = names.iter().map(|n| n.chars().count()).max().unwrap_or(0);
    for ((t, name), cell) in targets.iter().zip(&names).zip(cells) {
        let _ = writeln!(s, "  {name:<width$}  {}", cell_text(t, cell, device));
    }
    s
}

pub fn line(time: &str, targets: &[Target], cells: &[Cell], device: &Device) -> String {
    let parts: Vec<String> = targets
        .iter()
        .zip(cells)
        .map(|(t, c)| format!("{} {}", t.label(), cell_text(t, c, device)))
        .collect();
    format!("{time}  {}\n", parts.join(" | "))
}

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// The CSV header: `time`, then per target its title with the unit the values are in
/// (`372 data set 2 Rated speed [1/min]`, `P700 [-02] present warning`, `index 9999 (raw)`);
/// a name that came before gets ` (2)`, ` (3)`, … so that every column has its own.
pub fn csv_header(targets: &[Target]) -> String {
    let mut fields = vec!["time".to_owned()];
    let mut seen: Vec<String> = Vec::new();
    for t in targets {
        let title = t.title();
        let name = match t.param {
            // Table names carry their unit in brackets ("Speed [1/min]"); add it where not.
            Some(p) if p.unit().is_empty() || title.contains(&format!("[{}]", p.unit())) => title,
            Some(p) => format!("{title} [{}]", p.unit()),
            None => format!("{title} (raw)"),
        };
        let before = seen.iter().filter(|n| **n == name).count();
        let unique = if before == 0 {
            name.clone()
        } else {
            format!("{name} ({})", before + 1)
        };
        seen.push(name);
        fields.push(csv_field(&unique));
    }
    format!("{}\n", fields.join(","))
}

/// A CSV row: the physical value in the header's unit (raw outside the table); an empty field
/// for a refused read.
pub fn csv_row(time: &str, targets: &[Target], cells: &[Cell]) -> String {
    let mut row = time.to_owned();
    for (t, cell) in targets.iter().zip(cells) {
        row.push(',');
        if let Ok(raw) = cell {
            match t.param {
                Some(p) => {
                    let d = usize::from(p.decimals());
                    let _ = write!(row, "{:.d$}", p.to_physical(*raw));
                }
                None => {
                    let _ = write!(row, "{raw}");
                }
            }
        }
    }
    row.push('\n');
    row
}
