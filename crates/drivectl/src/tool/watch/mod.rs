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

use std::fmt::Write as _;
use std::future::Future;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde_json::{Value, json};
use tokio::time::MissedTickBehavior;

use super::client::{ClientError, ParamClient, Target};
use super::meaning::Device;
use super::output::{target_json, value_json_in, value_text_in};
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
    let mut ticker = tokio::time::interval(options.interval);
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

/// The value of one cell as text.
fn cell_text(t: &Target, cell: &std::result::Result<i64, String>, device: &Device) -> String {
    match cell {
        Ok(raw) => value_text_in(t, *raw, device),
        Err(m) => format!("refused: {m}"),
    }
}

fn table(
    time: &str,
    interval: Duration,
    targets: &[Target],
    cells: &[std::result::Result<i64, String>],
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

fn line(
    time: &str,
    targets: &[Target],
    cells: &[std::result::Result<i64, String>],
    device: &Device,
) -> String {
    let parts: Vec<String> = targets
        .iter()
        .zip(cells)
        .map(|(t, c)| format!("{} {}", t.label(), cell_text(t, c, device)))
        .collect();
    format!("{time}  {}\n", parts.join(" | "))
}

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// The CSV header: `time`, then per target its title with the unit the values are in
/// (`372 data set 2 Rated speed [1/min]`, `P700 [-02] present warning`, `index 9999 (raw)`);
/// a name that came before gets ` (2)`, ` (3)`, … so that every column has its own.
fn csv_header(targets: &[Target]) -> String {
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
fn csv_row(time: &str, targets: &[Target], cells: &[std::result::Result<i64, String>]) -> String {
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

/// `{"type": "sample", "time": …, "values": [the read's object, or the target's keys
/// (`index`, `number`, `label`, names, `selector`, `unit`) with the drive's `error`]}`.
fn sample_json(
    time: &str,
    targets: &[Target],
    cells: &[std::result::Result<i64, String>],
    device: &Device,
) -> Value {
    let values: Vec<Value> = targets
        .iter()
        .zip(cells)
        .map(|(t, cell)| match cell {
            Ok(raw) => value_json_in(t, *raw, device),
            Err(m) => {
                let mut o = target_json(t);
                o.insert("error".into(), m.as_str().into());
                Value::Object(o)
            }
        })
        .collect();
    json!({"type": "sample", "time": time, "values": values})
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::client::DeviceErrorKind;
    use crate::tool::fake::{FakeClient, refusal};
    use drive_profile::Family;
    use std::cell::RefCell;
    use tokio::time::Instant;

    const MS: Duration = Duration::from_millis(1);

    fn at(secs: i64, millis: u64) -> SystemTime {
        let base = if secs >= 0 {
            UNIX_EPOCH + Duration::from_secs(secs.unsigned_abs())
        } else {
            UNIX_EPOCH - Duration::from_secs(secs.unsigned_abs())
        };
        base + Duration::from_millis(millis)
    }

    #[test]
    fn timestamps_are_rfc3339_utc_with_milliseconds() {
        assert_eq!(timestamp(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
        assert_eq!(timestamp(at(951_782_400, 0)), "2000-02-29T00:00:00.000Z");
        assert_eq!(
            timestamp(at(1_709_210_096, 789)),
            "2024-02-29T12:34:56.789Z"
        );
        assert_eq!(timestamp(at(4_107_542_400, 1)), "2100-03-01T00:00:00.001Z");
        assert_eq!(
            timestamp(at(253_402_300_799, 999)),
            "9999-12-31T23:59:59.999Z"
        );
        // Before 1970: 1900 was not a leap year.
        assert_eq!(timestamp(at(-2_203_891_200, 0)), "1900-03-01T00:00:00.000Z");
        assert_eq!(
            timestamp(UNIX_EPOCH - Duration::from_millis(1)),
            "1969-12-31T23:59:59.999Z"
        );
        // Every day of 400 years follows the one before it.
        let mut prev = civil_from_days(-1);
        for day in 0..146_097 {
            let (y, m, d) = civil_from_days(day);
            let next_day = (y, m, d) > prev && (d == prev.2 + 1 || d == 1);
            assert!(next_day, "day {day}: {prev:?} -> {:?}", (y, m, d));
            prev = (y, m, d);
        }
        assert_eq!(prev, (2369, 12, 31));
    }

    thread_local! {
        /// When the fake drive was asked, on tokio's (paused) clock.
        static ASKED: RefCell<Vec<Instant>> = const { RefCell::new(Vec::new()) };
    }

    /// P000 answers 1500 1/min and notes the time; P130 is refused; index 9999 reads -5.
    fn drive(index: u16) -> std::result::Result<i64, ClientError> {
        match index {
            8318 => {
                ASKED.with(|a| a.borrow_mut().push(Instant::now()));
                Ok(1_500_000)
            }
            8470 => Err(refusal(DeviceErrorKind::Refused, "parameter lock")),
            9999 => Ok(-5),
            _ => Err(ClientError::Link("no answer from drive 1".into())),
        }
    }

    fn targets(keys: &[&str]) -> Vec<Target> {
        keys.iter()
            .map(|k| Target::resolve(Family::Movidrive, k, 1000..=0xFFFF).unwrap())
            .collect()
    }

    async fn run(
        keys: &[&str],
        format: Format,
        count: u64,
        stop: impl Future<Output = ()>,
    ) -> (Result<u64>, String) {
        let mut client = FakeClient::new(drive);
        let mut text = String::new();
        let options = Options {
            interval: 200 * MS,
            count,
            format,
        };
        let r = watch(
            &mut client,
            &targets(keys),
            options,
            &mut |s| {
                text.push_str(s);
                Ok(())
            },
            stop,
        )
        .await;
        (r, text)
    }

    #[tokio::test(start_paused = true)]
    async fn polls_keep_their_rhythm_and_json_samples_carry_the_time() {
        ASKED.with(|a| a.borrow_mut().clear());
        let start = Instant::now();
        let (r, text) = run(
            &["P000", "P130", "9999"],
            Format::Json,
            3,
            std::future::pending(),
        )
        .await;
        // P130 is refused in every poll: shown in its cells, and the watch fails at the end.
        assert!(
            r.unwrap_err()
                .to_string()
                .starts_with("1 of 3 parameter(s) could not be read in any of the 3 poll(s): P130"),
        );
        let asked = ASKED.with(|a| a.borrow().clone());
        let offsets: Vec<Duration> = asked.iter().map(|t| *t - start).collect();
        assert_eq!(offsets, [Duration::ZERO, 200 * MS, 400 * MS]);
        let samples: Vec<Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(samples.len(), 3);
        for s in &samples {
            assert_eq!(s["type"], "sample");
            let time = s["time"].as_str().unwrap();
            assert_eq!((time.len(), &time[10..11], &time[23..]), (24, "T", "Z"));
            assert_eq!(s["values"][0]["number"], "P000");
            assert_eq!(s["values"][0]["value"], 1500.0);
            assert_eq!(s["values"][1]["error"], "parameter lock");
            assert_eq!(s["values"][2]["raw"], -5);
        }
    }

    #[tokio::test(start_paused = true)]
    async fn csv_has_a_header_and_one_row_per_poll() {
        let (r, text) = run(
            &["P000", "P130", "9999"],
            Format::Csv,
            2,
            std::future::pending(),
        )
        .await;
        // P130 is refused in every poll: shown in its cells, and the watch fails at the end.
        assert!(
            r.unwrap_err()
                .to_string()
                .starts_with("1 of 3 parameter(s) could not be read in any of the 2 poll(s): P130"),
        );
        let rows: Vec<&str> = text.lines().collect();
        assert_eq!(
            rows[0],
            "time,P000 Speed [1/min],P130 Ramp t11 up CW [s],index 9999 (raw)"
        );
        assert_eq!(rows.len(), 3);
        let fields: Vec<&str> = rows[1].split(',').collect();
        assert_eq!(&fields[1..], ["1500.000", "", "-5"]);
        assert_eq!(csv_field("a, \"b\""), "\"a, \"\"b\"\"\"");
    }

    #[tokio::test(start_paused = true)]
    async fn stop_ends_an_endless_watch_cleanly() {
        let (r, text) = run(&["P000"], Format::Lines, 0, tokio::time::sleep(700 * MS)).await;
        // Polls at 0, 200, 400 and 600 ms; the stop at 700 ms ends it without an error.
        assert_eq!(r.unwrap(), 4);
        assert_eq!(text.lines().count(), 4);
        assert!(
            text.lines().all(|l| l.ends_with("  P000 1500.000 1/min")),
            "{text}"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_link_failure_ends_the_watch_with_an_error() {
        let (r, text) = run(&["P000", "P001"], Format::Lines, 3, std::future::pending()).await;
        let e = r.unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert!(
            e.to_string()
                .contains("P001: no answer from drive 1; the watch stopped after 0 poll(s)"),
            "{e}"
        );
        assert_eq!(text, "");
    }

    #[tokio::test(start_paused = true)]
    async fn the_table_is_redrawn_in_place() {
        let (r, text) = run(&["P000", "P130"], Format::Table, 2, std::future::pending()).await;
        // P130 is refused in every poll: shown in its cells, and the watch fails at the end.
        assert!(
            r.unwrap_err()
                .to_string()
                .starts_with("1 of 2 parameter(s) could not be read in any of the 2 poll(s): P130"),
        );
        // The second table moves the cursor up over the three lines of the first and clears.
        let (first, second) = text.split_once("\x1b[3F\x1b[J").unwrap();
        assert_eq!(first.lines().count(), 3);
        assert!(
            first.contains("P000 Speed") && first.contains("1500.000 1/min"),
            "{first}"
        );
        assert!(first.contains("refused: parameter lock"), "{first}");
        assert_eq!(second.lines().count(), 3);
    }

    #[tokio::test(start_paused = true)]
    async fn issue18_a_watch_that_read_nothing_fails_naming_what_failed() {
        let (r, text) = run(&["P130"], Format::Lines, 2, std::future::pending()).await;
        let e = r.unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert_eq!(
            e.to_string(),
            "no parameter could be read in 2 poll(s): P130 (parameter lock)"
        );
        // The refusals were shown as they came.
        assert_eq!(text.lines().count(), 2);
        // One parameter never read beside one read: the others' values are shown, and the
        // watch fails naming the one.
        let (r, _) = run(&["P000", "P130"], Format::Json, 2, std::future::pending()).await;
        assert_eq!(
            r.unwrap_err().to_string(),
            "1 of 2 parameter(s) could not be read in any of the 2 poll(s): P130 (parameter \
             lock); the values of the others are above"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn issue18_csv_headers_are_unique_and_json_refusals_carry_the_label() {
        let (_, text) = run(
            &["P000", "P000", "9999"],
            Format::Csv,
            1,
            std::future::pending(),
        )
        .await;
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        assert_eq!(
            header,
            [
                "time",
                "P000 Speed [1/min]",
                "P000 Speed [1/min] (2)",
                "index 9999 (raw)"
            ]
        );
        let (_, text) = run(&["P000", "P130"], Format::Json, 1, std::future::pending()).await;
        let sample: Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
        let refused = &sample["values"][1];
        assert_eq!(refused["label"], "P130");
        assert_eq!(refused["name_en"], "Ramp t11 up CW [s]");
        assert!(refused["selector"].is_null());
        assert_eq!(refused["error"], "parameter lock");
    }

    #[test]
    fn csv_and_json_exclude_each_other() {
        assert_eq!(
            Format::choose(true, true, false).unwrap_err().exit_code(),
            2
        );
        assert_eq!(Format::choose(false, false, true).unwrap(), Format::Table);
        assert_eq!(Format::choose(false, false, false).unwrap(), Format::Lines);
        assert_eq!(Format::choose(true, false, true).unwrap(), Format::Csv);
    }
}
