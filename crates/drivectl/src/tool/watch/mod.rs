//! `watch`: several parameters polled at a steady rhythm by `drive_client`'s
//! [`Sampler`], every row with a wall-clock timestamp, for every family.
//!
//! Four shapes of output ([`Format`]): a table redrawn in place on a terminal, one line per
//! poll when standard output is a pipe or a file, CSV with a header row, or one JSON object per
//! poll (`"type": "sample"`).
//!
//! The rhythm is the sampler's: polls start on a fixed grid (0, T, 2T, …) and a poll that
//! overruns its slot lets the slots it overran pass, so the timestamps stay evenly spaced.
//!
//! Every value is named by its label with its selector, as the family's manual writes it
//! (`372 data set 2`, `P700 [-02]`, `P102 set 3`), and a NORD array element by its own name;
//! every CSV column has a header of its own (a parameter given twice gets ` (2)`).
//!
//! A drive's refusal for one parameter is shown in its cell and the polls go on; a link failure
//! (no answer) ends the watch with an error. The caller's `stop` future (Ctrl-C in the
//! command) ends it cleanly at any point, also in the middle of a poll. When the watch ends
//! (its count done, or stopped), a parameter that could not be read in any poll makes it fail
//! (exit 1) with a message naming each such parameter and the drive's last answer: "no
//! parameter could be read" when none was, else "k of n parameter(s) could not be read"; a
//! parameter read in at least one poll is a success, its refusals in other polls were shown in
//! their cells. A watch stopped before its first poll has nothing to report.

use std::future::Future;
use std::time::Duration;

use drive_client::watch::{Sampler, WatchError};

mod render;
#[cfg(test)]
mod tests;

#[cfg(test)]
use render::csv_field;
use render::{csv_header, csv_row, line, table};

pub use drive_client::watch::{MAX_INTERVAL_MS, MIN_INTERVAL_MS, timestamp};

use super::client::{ParamClient, Target};
use crate::error::{CliError, Result};

/// The options of every family's `watch` command.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct WatchArgs {
    /// Milliseconds between the starts of two polls, 50–3600000.
    #[arg(long, default_value_t = 1000, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(MIN_INTERVAL_MS..=MAX_INTERVAL_MS))]
    pub interval: u64,
    /// Number of polls; 0 = until Ctrl-C.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub count: u64,
    /// CSV: a header row, then one row of physical values per poll (not with --json).
    #[arg(long, conflicts_with = "json")]
    pub csv: bool,
}

impl WatchArgs {
    /// The watch options these arguments ask for (the format from `--csv`, `--json` and whether
    /// standard output is a terminal).
    pub fn options(&self, json: bool) -> Result<Options> {
        Ok(Options {
            interval: Duration::from_millis(self.interval),
            count: self.count,
            format: Format::choose(
                self.csv,
                json,
                std::io::IsTerminal::is_terminal(&std::io::stdout()),
            )?,
        })
    }
}

/// How the samples are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// A table redrawn in place with ANSI cursor codes (standard output is a terminal).
    Table,
    /// One line of text per poll.
    Lines,
    /// CSV: a header row, then one row per poll.
    Csv,
    /// One JSON object per poll, `"type": "sample"`.
    Json,
}

impl Format {
    /// The format of the options: `--csv`, `--json`, else a table on a terminal and lines
    /// otherwise.
    pub fn choose(csv: bool, json: bool, terminal: bool) -> Result<Format> {
        match (csv, json) {
            (true, true) => Err(CliError::usage(
                "--csv and --json cannot be combined; choose one",
            )),
            (true, false) => Ok(Format::Csv),
            (false, true) => Ok(Format::Json),
            (false, false) if terminal => Ok(Format::Table),
            (false, false) => Ok(Format::Lines),
        }
    }
}

/// What to watch and how.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Time between the starts of two polls.
    pub interval: Duration,
    /// Number of polls; 0 = until `stop`.
    pub count: u64,
    /// The output shape.
    pub format: Format,
}

/// Completes on Ctrl-C (SIGINT), SIGTERM, SIGHUP or SIGQUIT: the `stop` of a watch on the
/// command line. The handlers are in place when it returns, so a signal a moment later ends the
/// watch through its normal path (exit 0, the output complete up to its last row, a CSV file
/// not cut in a row).
pub use drive_client::signals::first as ctrl_c;

/// Poll `targets` through `client` as `options` say, writing through `out`, until `count`
/// polls are done, `stop` completes (Ctrl-C: a clean end) or the link fails (an error).
/// Returns the number of complete polls; fails when a parameter could not be read in any of
/// them (see the [module docs](self)).
pub async fn watch<C: ParamClient>(
    client: &mut C,
    targets: &[Target],
    options: Options,
    out: &mut dyn FnMut(&str) -> Result<()>,
    stop: impl Future,
) -> Result<u64> {
    let mut sampler = Sampler::new(client, targets, options.interval, options.count);
    let polls = poll_loop(&mut sampler, options.format, options.interval, out);
    tokio::select! {
        r = polls => r?,
        _ = stop => {}
    }
    // The end: an error naming every parameter that no poll could read.
    sampler.verdict().map_err(|u| {
        CliError::failed(if u.none_read() {
            u.to_string()
        } else {
            format!("{u}; the values of the others are above")
        })
    })?;
    Ok(sampler.polls())
}

async fn poll_loop<C: ParamClient>(
    sampler: &mut Sampler<'_, C>,
    format: Format,
    interval: Duration,
    out: &mut dyn FnMut(&str) -> Result<()>,
) -> Result<()> {
    let targets = sampler.targets();
    if format == Format::Csv {
        out(&csv_header(targets))?;
    }
    let mut drawn = 0;
    while let Some(s) = sampler.next().await.map_err(|e| match e {
        WatchError::Link { polls, .. } => {
            CliError::failed(format!("{e}; the watch stopped after {polls} poll(s)"))
        }
        other => CliError::failed(other.to_string()),
    })? {
        crate::tool::stale::note_stale(s.stale_bytes);
        let time = timestamp(s.time);
        let (cells, device) = (&s.values, &s.device);
        let text = match format {
            Format::Table => {
                let table = table(&time, interval, targets, cells, device);
                // Back to the first line of the previous table, clear to the end, redraw.
                let up = if drawn > 0 {
                    format!("\x1b[{drawn}F\x1b[J")
                } else {
                    String::new()
                };
                drawn = table.lines().count();
                format!("{up}{table}")
            }
            Format::Lines => line(&time, targets, cells, device),
            Format::Csv => csv_row(&time, targets, cells),
            Format::Json => format!("{}\n", s.to_json(targets)),
        };
        out(&text)?;
    }
    Ok(())
}
