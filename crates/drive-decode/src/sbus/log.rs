//! A candump log explained record by record (feature `candump`).

use drive_transport::can::candump::{LogErrorKind, LogReader};

use super::{explain, telegram, to_text};
use crate::Entry;
use crate::shape::{Telegram, escape};

/// Whether `token` is a candump time stamp: seconds, a point and exactly six digits (the
/// microseconds), in brackets.
fn is_candump_stamp(token: &str) -> bool {
    token
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .and_then(|t| t.split_once('.'))
        .is_some_and(|(s, us)| {
            !s.is_empty()
                && s.bytes().all(|b| b.is_ascii_digit())
                && us.len() == 6
                && us.bytes().all(|b| b.is_ascii_digit())
        })
}

/// What is wrong with a line of a candump log, in words that say what the line must look
/// like. `text` is the line (to quote its time stamp).
fn log_error_text(kind: &LogErrorKind, text: Option<&str>) -> String {
    let stamp = text.and_then(|t| t.split_whitespace().next());
    match (kind, stamp) {
        (LogErrorKind::Parse(_), Some(s)) if !is_candump_stamp(s) => format!(
            "`{}` is no candump time stamp: candump writes the seconds since 1970 with exactly \
             six digits after the point, in brackets, then the interface and the frame: \
             `(1700000000.123456) can0 20B#3100207E00000000`",
            escape(s)
        ),
        (other, _) => escape(&other.to_string()),
    }
}

/// Every record of a candump log explained, an [`Entry`] each; a line that is no record is an
/// entry of `type` `skipped` with its line number and why, and the rest is read on.
#[derive(Debug)]
pub struct LogDecoder<'a> {
    reader: LogReader<&'a [u8]>,
    /// The lines as read, to quote a bad one.
    lines: Vec<&'a [u8]>,
    /// The log's name in the text of a bad line.
    input: String,
    sync_id: u16,
    frames: usize,
    invalid: usize,
    unreadable: usize,
}

impl<'a> LogDecoder<'a> {
    /// Decode `log` (named `input` in the text of a bad line) with `sync_id` as the
    /// synchronisation identifier (P817).
    pub fn new(log: &'a [u8], input: &str, sync_id: u16) -> Self {
        Self {
            reader: LogReader::new(log),
            lines: log.split(|b| *b == b'\n').collect(),
            input: escape(input),
            sync_id,
            frames: 0,
            invalid: 0,
            unreadable: 0,
        }
    }

    /// Records read so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Records read so far that are no valid SBus telegram.
    pub fn invalid(&self) -> usize {
        self.invalid
    }

    /// Lines read so far that are no record.
    pub fn unreadable(&self) -> usize {
        self.unreadable
    }

    /// The counts in words: `2 frame(s), 0 not valid SBus, 1 unreadable line(s)`.
    pub fn tally(&self) -> String {
        format!(
            "{} frame(s), {} not valid SBus, {} unreadable line(s)",
            self.frames, self.invalid, self.unreadable
        )
    }

    /// Line `n` (1-based) as text, without a BOM and surrounding white space.
    fn line_text(&self, n: u64) -> Option<&'a str> {
        usize::try_from(n)
            .ok()
            .and_then(|n| self.lines.get(n.checked_sub(1)?))
            .and_then(|l| std::str::from_utf8(l).ok())
            .map(|l| l.trim_start_matches('\u{feff}').trim())
    }
}

impl Iterator for LogDecoder<'_> {
    type Item = Entry;

    fn next(&mut self) -> Option<Entry> {
        let item = self.reader.next_record();
        let line = usize::try_from(self.reader.line()).ok();
        match item {
            Ok(None) => None,
            Ok(Some(r)) => {
                self.frames += 1;
                let e = explain(&r.frame, self.sync_id);
                if e.error.is_some() {
                    self.invalid += 1;
                }
                let place = format!(
                    "({}.{:06}) {} ",
                    r.t_us / 1_000_000,
                    r.t_us % 1_000_000,
                    escape(&r.interface)
                );
                Some(Entry {
                    telegram: telegram(&e, line, Some((r.t_us, r.interface.as_str()))),
                    text: to_text(&e, &place),
                })
            }
            Err(e) => {
                self.unreadable += 1;
                let why = log_error_text(&e.kind, self.line_text(e.line));
                let text = format!("{}: line {}: {why}\n", self.input, e.line);
                let mut t = Telegram::skipped("sbus", None, &[], why);
                t.line = usize::try_from(e.line).ok();
                Some(Entry { telegram: t, text })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_and_bad_lines_of_a_log() {
        let log = b"\xef\xbb\xbf(1735270496.916858) can0 20B#3100207E00000000\r\n\
                    (1.0) slcan0 20B#31\r\n(1735270496.917100) can0 20C#3100207E000F4240\r\n";
        let mut d = LogDecoder::new(log, "capture.log", 0);
        let entries: Vec<Entry> = d.by_ref().collect();
        assert_eq!(
            d.tally(),
            "2 frame(s), 0 not valid SBus, 1 unreadable line(s)"
        );
        assert_eq!(entries.len(), 3);
        let read = entries[0].telegram.to_json();
        assert_eq!(
            (&read["index"], &read["time"], &read["interface"]),
            (
                &serde_json::json!(8318),
                &serde_json::json!("1735270496.916858"),
                &serde_json::json!("can0")
            )
        );
        assert!(
            entries[1]
                .text
                .starts_with("capture.log: line 2: `(1.0)` is no candump time stamp"),
            "{}",
            entries[1].text
        );
        assert_eq!(entries[1].telegram.line, Some(2));
        assert_eq!(entries[2].telegram.to_json()["raw"], 1_000_000);
    }
}
