//! `watch`: several parameters polled at a steady rhythm, every row with a wall-clock
//! timestamp, for every family (it needs only a [`ParamClient`]).
//!
//! Four shapes of output ([`Format`]): a table redrawn in place on a terminal, one line per
//! poll when standard output is a pipe or a file, CSV with a header row, or one JSON object per
//! poll (`"type": "sample"`).
//!
//! The rhythm is a tokio interval with [`MissedTickBehavior::Skip`]: polls start on a fixed
//! grid (0, T, 2T, …); a poll that overruns its slot (a slow line, many parameters) lets the
//! slots it overran pass instead of firing them back to back, so polls never bunch up and the
//! timestamps stay evenly spaced.
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
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::rt::time::MissedTickBehavior;

mod render;
#[cfg(test)]
mod tests;

#[cfg(test)]
use render::csv_field;
use render::{csv_header, csv_row, line, sample_json, table};

use super::client::{ClientError, ParamClient, Target};
use crate::error::{CliError, Result};

/// The shortest interval between polls, in milliseconds: a MOVILINK parameter read at 9600
/// baud takes about 25 ms, and a watch is for people and logs, not for control loops.
pub const MIN_INTERVAL_MS: u64 = 50;
/// The longest interval between polls, in milliseconds (one hour).
pub const MAX_INTERVAL_MS: u64 = 3_600_000;

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
/// command line. The handlers are in place when this returns (not when the future is first
/// polled), so a signal a moment later no longer kills the process: the watch ends through its
/// normal path (exit 0, the output complete up to its last row, a CSV file not cut in a row).
/// A handler that does not install leaves that signal's default.
pub fn ctrl_c() -> impl Future<Output = ()> {
    use tokio::signal::unix::{SignalKind, signal};
    let mut streams: Vec<_> = [
        SignalKind::interrupt(),
        SignalKind::terminate(),
        SignalKind::hangup(),
        SignalKind::quit(),
    ]
    .into_iter()
    .filter_map(|k| signal(k).ok())
    .collect();
    async move {
        std::future::poll_fn(|cx| {
            for s in &mut streams {
                if let std::task::Poll::Ready(Some(())) = s.poll_recv(cx) {
                    return std::task::Poll::Ready(());
                }
            }
            std::task::Poll::Pending
        })
        .await;
    }
}

/// A point in time as RFC 3339 in UTC with milliseconds, e.g. `2024-02-29T12:34:56.789Z`
/// (times before 1970 too). The periodic outputs of drivectl stamp their rows with it.
pub fn timestamp(t: SystemTime) -> String {
    let ms: i128 = match t.duration_since(UNIX_EPOCH) {
        Ok(d) => i128::try_from(d.as_millis()).unwrap_or(i128::MAX),
        Err(e) => -i128::try_from(e.duration().as_millis()).unwrap_or(i128::MAX),
    };
    let secs = ms.div_euclid(1000);
    let milli = ms.rem_euclid(1000);
    let (days, sod) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{milli:03}Z",
        sod / 3600,
        sod / 60 % 60,
        sod % 60
    )
}

/// Year, month and day of the `days`-th day after 1970-01-01 in the proleptic Gregorian
/// calendar (Howard Hinnant's `civil_from_days`: eras of 400 years, years starting in March).
fn civil_from_days(days: i128) -> (i128, i128, i128) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097; // day of the era, 0..=146096
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // 0..=399
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of the year from March 1st
    let mp = (5 * doy + 2) / 153; // month from March, 0..=11
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i128::from(m <= 2);
    (y, m, d)
}

/// Poll `targets` through `client` as `options` say, writing through `out`, until `count`
/// polls are done, `stop` completes (Ctrl-C: a clean end) or the link fails (an error).
/// Returns the number of complete polls; fails when a parameter could not be read in any of
/// them (see the [module docs](self)).
pub async fn watch<C: ParamClient>(
    client: &mut C,
    targets: &[Target],
    options: Options,
    out: &mut dyn FnMut(&str) -> Result<()>,
    stop: impl Future<Output = ()>,
) -> Result<u64> {
    let mut tally = Tally {
        done: 0,
        never_read: targets.iter().map(|_| Some(String::new())).collect(),
    };
    let polls = poll_loop(client, targets, options, out, &mut tally);
    tokio::select! {
        r = polls => r?,
        () = stop => {}
    }
    tally.verdict(targets)?;
    Ok(tally.done)
}

/// What the polls so far have read.
struct Tally {
    /// Complete polls.
    done: u64,
    /// Per target: `None` once it was read, else the drive's last refusal (empty before the
    /// first poll).
    never_read: Vec<Option<String>>,
}

impl Tally {
    /// The watch's end: an error naming every parameter that no poll could read.
    fn verdict(&self, targets: &[Target]) -> Result<()> {
        let failed: Vec<String> = targets
            .iter()
            .zip(&self.never_read)
            .filter_map(|(t, never)| never.as_ref().map(|why| format!("{} ({why})", t.label())))
            .collect();
        if self.done == 0 || failed.is_empty() {
            return Ok(());
        }
        Err(CliError::failed(if failed.len() == targets.len() {
            format!(
                "no parameter could be read in {} poll(s): {}",
                self.done,
                failed.join(", ")
            )
        } else {
            format!(
                "{} of {} parameter(s) could not be read in any of the {} poll(s): {}; the \
                 values of the others are above",
                failed.len(),
                targets.len(),
                self.done,
                failed.join(", ")
            )
        }))
    }
}

async fn poll_loop<C: ParamClient>(
    client: &mut C,
    targets: &[Target],
    options: Options,
    out: &mut dyn FnMut(&str) -> Result<()>,
    tally: &mut Tally,
) -> Result<()> {
    let mut ticker = drive_core::rt::time::interval(options.interval);
    ticker.set_missed_tick_behavior(MissedTickBehavior::Skip);
    if options.format == Format::Csv {
        out(&csv_header(targets))?;
    }
    let mut drawn = 0;
    while options.count == 0 || tally.done < options.count {
        ticker.tick().await;
        let time = timestamp(SystemTime::now());
        let mut cells = Vec::with_capacity(targets.len());
        for (t, never) in targets.iter().zip(tally.never_read.iter_mut()) {
            match client.read(t).await {
                Ok(raw) => {
                    *never = None;
                    cells.push(Ok(raw));
                }
                Err(ClientError::Device(d)) => {
                    if let Some(why) = never {
                        why.clone_from(&d.message);
                    }
                    cells.push(Err(d.message));
                }
                // The link failed (or a failure this drivectl does not know yet).
                Err(m) => {
                    return Err(CliError::failed(format!(
                        "{}: {m}; the watch stopped after {} poll(s)",
                        t.label(),
                        tally.done
                    )));
                }
            }
        }
        let device = client.device();
        crate::tool::stale::note_stale(client.stale_bytes());
        let text = match options.format {
            Format::Table => {
                let table = table(&time, options.interval, targets, &cells, &device);
                // Back to the first line of the previous table, clear to the end, redraw.
                let up = if drawn > 0 {
                    format!("\x1b[{drawn}F\x1b[J")
                } else {
                    String::new()
                };
                drawn = table.lines().count();
                format!("{up}{table}")
            }
            Format::Lines => line(&time, targets, &cells, &device),
            Format::Csv => csv_row(&time, targets, &cells),
            Format::Json => format!("{}\n", sample_json(&time, targets, &cells, &device)),
        };
        out(&text)?;
        tally.done += 1;
    }
    Ok(())
}
