//! The candump log format (`candump -L`): `(seconds.micros) iface ID#DATA`, one frame a line.
//!
//! ```text
//! (1735270496.916858) can0 10B#0006138800000000
//! (1735270496.917120) can0 10C#0007138900000000
//! (1735270497.000000) vcan1 12345678#R2
//! ```
//!
//! * Reading: each line goes through `socketcan`'s parser ([`socketcan::dump::Reader`]; there
//!   is no second parser here). What this module adds: line numbers in every error, a UTF-8
//!   byte-order mark before the first line and CR LF line ends accepted (a file saved by
//!   Notepad), blank lines skipped, and the frames drivebus has no type for refused by name
//!   (CAN FD frames, error frames).
//! * Writing: [`write_record`] writes the same format with [`CanFrame`]'s `Display`, which is
//!   the candump spelling; what it writes, [`LogReader`] reads back unchanged.
//! * [`Capture`]: a [`CanIo`] wrapper that writes every frame it receives or sends to a log.
//! * [`replay`]: sends a log's frames onto a [`CanIo`] with their relative timing.

use std::fmt;
use std::io::{self, BufRead, Write};
use std::path::Path;
use std::task::{Context, Poll};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::can::{CanFrame, Frame};
use drive_core::rt::{CanIo, ReceivedFrame, send_frame};
use socketcan::CanAnyFrame;
use socketcan::dump::{ParseError, Reader};
use tokio::time::Instant;

/// One line of a candump log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogRecord {
    /// The time stamp in microseconds (since the Unix epoch in logs written by candump).
    pub t_us: u64,
    /// The interface name (`can0`, `vcan1`, `slcan0`, …).
    pub interface: String,
    /// The frame.
    pub frame: CanFrame,
}

impl fmt::Display for LogRecord {
    /// The log line without its line end: `(1735270496.916858) can0 10B#00061388`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({}.{:06}) {} {}",
            self.t_us / 1_000_000,
            self.t_us % 1_000_000,
            self.interface,
            self.frame
        )
    }
}

/// What is wrong with a line of a log.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LogErrorKind {
    /// The line is not a candump record (`socketcan`'s parser says what is wrong).
    #[error("{} (expected `(seconds.micros) iface ID#DATA`)", lowercase_first(.0))]
    Parse(#[source] ParseError),
    /// A CAN FD frame (`ID##…`): drivebus speaks classical CAN only.
    #[error("a CAN FD frame; only classical CAN frames are supported")]
    FdFrame,
    /// An error frame (identifier with the error flag 20000000h).
    #[error("an error frame, not a frame on the bus")]
    ErrorFrame,
    /// The line is longer than a candump record can be.
    #[error("line longer than {MAX_LINE} bytes")]
    Overlong,
    /// The line is not UTF-8.
    #[error("the line is not text (not UTF-8)")]
    NotText,
    /// Reading failed.
    #[error("{0}")]
    Io(#[source] io::Error),
}

/// `socketcan`'s messages start with a capital; ours do not.
fn lowercase_first(e: &ParseError) -> String {
    let text = e.to_string();
    let mut chars = text.chars();
    match chars.next() {
        Some(first) => first.to_lowercase().chain(chars).collect(),
        None => text,
    }
}

/// A line of a log that could not be read, with its number (1-based).
#[derive(Debug, thiserror::Error)]
#[error("line {line}: {kind}")]
pub struct LogError {
    /// The line number, counting from 1.
    pub line: u64,
    /// What is wrong with it.
    #[source]
    pub kind: LogErrorKind,
}

/// The longest line accepted (a real record is about 50 characters).
pub const MAX_LINE: usize = 1024;

/// Reads a candump log record by record (an iterator of `Result<LogRecord, LogError>`).
///
/// After an error the reader goes on with the next line, so a caller may report a bad line and
/// continue, or stop at the first error.
#[derive(Debug)]
pub struct LogReader<R> {
    input: R,
    line: u64,
    buf: Vec<u8>,
    done: bool,
}

impl<R: BufRead> LogReader<R> {
    /// Reads from `input`.
    pub fn new(input: R) -> Self {
        LogReader {
            input,
            line: 0,
            buf: Vec::with_capacity(128),
            done: false,
        }
    }

    /// Lines read so far.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The next record, `Ok(None)` at the end.
    ///
    /// # Errors
    ///
    /// [`LogError`] with the line number.
    pub fn next_record(&mut self) -> Result<Option<LogRecord>, LogError> {
        loop {
            if self.done {
                return Ok(None);
            }
            self.buf.clear();
            let n = io::Read::take(&mut self.input, MAX_LINE as u64 + 1)
                .read_until(b'\n', &mut self.buf)
                .map_err(|e| self.error(LogErrorKind::Io(e)))?;
            if n == 0 {
                self.done = true;
                return Ok(None);
            }
            self.line += 1;
            if self.buf.len() > MAX_LINE && self.buf.last() != Some(&b'\n') {
                // Skip the rest of the over-long line.
                self.skip_line();
                return Err(self.error(LogErrorKind::Overlong));
            }
            let mut text: &[u8] = &self.buf;
            if self.line == 1 {
                text = text.strip_prefix("\u{feff}".as_bytes()).unwrap_or(text);
            }
            let Ok(text) = std::str::from_utf8(text) else {
                return Err(self.error(LogErrorKind::NotText));
            };
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            let record = Reader::from_reader(text.as_bytes())
                .next_record()
                .map_err(|e| self.error(LogErrorKind::Parse(e)))?;
            let Some(record) = record else {
                continue;
            };
            let frame = match record.frame {
                CanAnyFrame::Normal(d) => CanFrame::data_frame(d.id(), d.data()),
                CanAnyFrame::Remote(r) => CanFrame::remote_frame(r.id(), r.dlc() as u8),
                CanAnyFrame::Error(_) => return Err(self.error(LogErrorKind::ErrorFrame)),
                CanAnyFrame::Fd(_) => return Err(self.error(LogErrorKind::FdFrame)),
            };
            let Some(frame) = frame else {
                return Err(self.error(LogErrorKind::FdFrame));
            };
            return Ok(Some(LogRecord {
                t_us: record.t_us,
                interface: record.device,
                frame,
            }));
        }
    }

    fn error(&self, kind: LogErrorKind) -> LogError {
        LogError {
            line: self.line,
            kind,
        }
    }

    fn skip_line(&mut self) {
        loop {
            self.buf.clear();
            match io::Read::take(&mut self.input, MAX_LINE as u64).read_until(b'\n', &mut self.buf)
            {
                Ok(0) | Err(_) => {
                    self.done = true;
                    return;
                }
                Ok(_) if self.buf.last() == Some(&b'\n') => return,
                Ok(_) => {}
            }
        }
    }
}

impl<R: BufRead> Iterator for LogReader<R> {
    type Item = Result<LogRecord, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_record().transpose()
    }
}

/// Reads a whole log file.
///
/// # Errors
///
/// The first bad line as a [`LogError`]; a file that cannot be opened as line 0 with
/// [`LogErrorKind::Io`].
pub fn read_file(path: impl AsRef<Path>) -> Result<Vec<LogRecord>, LogError> {
    let file = std::fs::File::open(path).map_err(|e| LogError {
        line: 0,
        kind: LogErrorKind::Io(e),
    })?;
    LogReader::new(io::BufReader::new(file)).collect()
}

/// Writes `record` as one log line ending in `\n`.
///
/// # Errors
///
/// [`io::ErrorKind::InvalidInput`] for an interface name that is empty or contains white
/// space (the line could not be read back); write errors.
pub fn write_record(out: &mut impl Write, record: &LogRecord) -> io::Result<()> {
    if record.interface.is_empty() || record.interface.chars().any(char::is_whitespace) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "interface name {:?} cannot be written to a candump log (empty or with white \
                 space)",
                record.interface
            ),
        ));
    }
    writeln!(out, "{record}")
}

/// A [`CanIo`] that writes every frame it receives or sends to a candump log.
///
/// Received frames are logged with their [`ReceivedFrame::at`], sent frames when their send
/// completes. Time stamps are wall-clock microseconds: the system time when the capture
/// started plus the time on tokio's clock since then, so on the paused clock the log's times
/// are exact. A failed write to the log fails the receive or send that caused it (the capture
/// is never silently incomplete).
#[derive(Debug)]
pub struct Capture<C, W> {
    io: C,
    log: W,
    interface: String,
    epoch: Instant,
    epoch_us: u64,
    records: u64,
}

impl<C: CanIo, W: Write + Send> Capture<C, W> {
    /// Captures what `io` sees into `log` under the interface name `interface`.
    pub fn new(io: C, log: W, interface: impl Into<String>) -> Self {
        let epoch_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX));
        Self::with_epoch(io, log, interface, Instant::now(), epoch_us)
    }

    /// Like [`Capture::new`], with the time stamp `epoch_us` at tokio instant `epoch`.
    pub fn with_epoch(
        io: C,
        log: W,
        interface: impl Into<String>,
        epoch: Instant,
        epoch_us: u64,
    ) -> Self {
        Capture {
            io,
            log,
            interface: interface.into(),
            epoch,
            epoch_us,
            records: 0,
        }
    }

    /// Records written so far.
    pub fn records(&self) -> u64 {
        self.records
    }

    /// Flushes the log and returns the transport and the log.
    ///
    /// # Errors
    ///
    /// The log's flush error.
    pub fn finish(mut self) -> io::Result<(C, W)> {
        self.log.flush()?;
        Ok((self.io, self.log))
    }

    fn record(&mut self, frame: CanFrame, at: Instant) -> io::Result<()> {
        let since = at.saturating_duration_since(self.epoch);
        let t_us = self
            .epoch_us
            .saturating_add(u64::try_from(since.as_micros()).unwrap_or(u64::MAX));
        let record = LogRecord {
            t_us,
            interface: self.interface.clone(),
            frame,
        };
        write_record(&mut self.log, &record).map_err(|e| {
            io::Error::new(e.kind(), format!("writing the capture log failed: {e}"))
        })?;
        self.records += 1;
        Ok(())
    }
}

impl<C: CanIo, W: Write + Send> CanIo for Capture<C, W> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        let received = std::task::ready!(self.io.poll_recv(cx))?;
        self.record(received.frame, received.at)?;
        Poll::Ready(Ok(received))
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        std::task::ready!(self.io.poll_send(cx, frame))?;
        self.record(*frame, Instant::now())?;
        Poll::Ready(Ok(()))
    }

    // Forwarded, not left to the default: the transport underneath may place the frame at its
    // intended start (the virtual bus does).
    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: Instant,
    ) -> Poll<io::Result<()>> {
        std::task::ready!(self.io.poll_send_at(cx, frame, start))?;
        self.record(*frame, Instant::now())?;
        Poll::Ready(Ok(()))
    }
}

/// What [`replay`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplayStats {
    /// Frames sent.
    pub sent: u64,
    /// Records whose time stamp was earlier than the one before (sent at once, not reordered).
    pub out_of_order: u64,
}

/// Sends `records`' frames onto `io` with their relative timing: the first at once, each
/// other one at start + (its time stamp − the first one's), on tokio's clock. A record older
/// than its predecessor is sent right after it (counted). Records of every interface are sent;
/// filter the iterator to pick one.
///
/// # Errors
///
/// The first send error.
pub async fn replay<C, I>(io: &mut C, records: I) -> io::Result<ReplayStats>
where
    C: CanIo + ?Sized,
    I: IntoIterator<Item = LogRecord>,
{
    let start = Instant::now();
    let mut first: Option<u64> = None;
    let mut last = 0u64;
    let mut stats = ReplayStats::default();
    for record in records {
        let t0 = *first.get_or_insert(record.t_us);
        if record.t_us < last {
            stats.out_of_order += 1;
        } else {
            last = record.t_us;
        }
        let offset = Duration::from_micros(last.saturating_sub(t0));
        tokio::time::sleep_until(start + offset).await;
        send_frame(io, &record.frame).await?;
        stats.sent += 1;
    }
    Ok(stats)
}
