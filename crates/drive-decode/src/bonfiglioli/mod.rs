//! Bonfiglioli Modbus RTU and ASCII: explain captured frames field by field.
//!
//! * RTU has no start character: a stream is split where a CRC-16 closes a frame (the shortest
//!   CRC-valid run from the current byte, within the input line when the capture has lines;
//!   longer than a line only when the CRC proves a wrapped frame). A run with no valid CRC is
//!   explained as one frame with the CRC it should have.
//! * ASCII frames run from `:` to CR LF. The capture is the text itself (`:010321740001 66`
//!   … one frame per line), or the characters as hex bytes (`3A 30 31 …`, as the manual's `Hex`
//!   rows print them).
//!
//! Request or response is told by the length where the function codes differ (FC 3, FC 100);
//! FC 6, 8 and 101 answers echo the request. A read answer is paired with the last read request
//! to the same address in the capture, so its value is scaled by that parameter.

use bonfiglioli_modbus::ascii;
use bonfiglioli_modbus::rtu;
use serde_json::json;

use crate::input::{Capture, InputError, parse_hex, parse_text};
use crate::shape::{Telegram, escape, escape_bytes, target};
use crate::{Decoded, Entry};

mod explain;

pub use explain::Frame;
use explain::{Pending, explain_ascii, explain_rtu};

/// Split an RTU capture at CRC-valid boundaries (see the [module docs](self)).
pub fn split_rtu(capture: &Capture) -> Vec<Frame> {
    let bytes = capture.bytes.as_slice();
    let line_end = |p: usize| {
        let line = capture.lines.get(p);
        capture
            .lines
            .iter()
            .enumerate()
            .skip(p)
            .find(|(_, l)| Some(*l) != line)
            .map_or(bytes.len(), |(i, _)| i)
    };
    let valid = |from: usize, to: usize| {
        bytes
            .get(from..to)
            .is_some_and(|f| f.len() >= rtu::MIN_FRAME && rtu::decode(f).is_ok())
    };
    let mut pending = Pending::new();
    let mut out = Vec::new();
    let mut p = 0;
    while p < bytes.len() {
        let limit = if capture.lines.is_empty() {
            bytes.len()
        } else {
            line_end(p)
        };
        let wide = (p + rtu::MAX_FRAME).min(bytes.len());
        let end = (p + rtu::MIN_FRAME..=limit)
            .find(|&e| valid(p, e))
            .or_else(|| (limit + 1..=wide).find(|&e| valid(p, e)))
            .unwrap_or(limit.max(p + 1));
        out.push(explain_rtu(
            bytes.get(p..end).unwrap_or(&[]),
            p,
            &mut pending,
        ));
        p = end;
    }
    out
}

/// Why text is no Modbus ASCII capture.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AsciiError {
    /// Hex bytes of the characters that are no hex bytes.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A character that is not ASCII.
    #[error("`{ch}` is not a Modbus ASCII character")]
    NotAscii {
        /// The character, escaped.
        ch: String,
    },
    /// Nothing but blank lines and comments.
    #[error("no frames given")]
    NoFrames,
    /// No `:` anywhere: a Modbus ASCII frame starts with one.
    #[error("no `:` in the capture: a Modbus ASCII frame starts with `:` and ends with CR LF")]
    NoColon,
}

/// The characters of an ASCII capture: the text itself when it has a `:`, else hex bytes of
/// the characters, with the input line of every character (none for arguments,
/// `from_args`). Line ends in text input are CR LF of the frames (a lone LF counts as CR LF).
///
/// # Errors
///
/// [`AsciiError`]: no ASCII, no frames, no `:`.
pub fn ascii_input(text: &str, from_args: bool) -> Result<Capture, AsciiError> {
    let chars = ascii_capture(text, from_args)?;
    if chars.bytes.is_empty() {
        return Err(AsciiError::NoFrames);
    }
    if !chars.bytes.contains(&ascii::START) {
        return Err(AsciiError::NoColon);
    }
    Ok(chars)
}

fn ascii_capture(text: &str, from_args: bool) -> Result<Capture, AsciiError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if !text.contains(':') {
        return Ok(if from_args {
            Capture::from_bytes(parse_hex(&text.split('\n').collect::<Vec<_>>())?)
        } else {
            parse_text(text, "the capture")?
        });
    }
    let mut out = Capture::default();
    for (n, line) in text.split('\n').enumerate() {
        let line = line.strip_suffix('\r').unwrap_or(line);
        let content = line.split_once('#').map_or(line, |(a, _)| a);
        let content: String = content.chars().filter(|c| !c.is_whitespace()).collect();
        if content.is_empty() {
            continue;
        }
        if let Some(bad) = content.chars().find(|c| !c.is_ascii()) {
            return Err(AsciiError::NotAscii {
                ch: escape(&bad.to_string()),
            });
        }
        out.bytes.extend_from_slice(content.as_bytes());
        out.bytes.extend_from_slice(b"\r\n");
        if !from_args {
            out.lines
                .extend(std::iter::repeat_n(n + 1, content.len() + 2));
        }
    }
    Ok(out)
}

/// Split ASCII characters into frames: from `:` to CR LF; characters outside a frame are
/// reported as an error item.
pub fn split_ascii(chars: &[u8]) -> Vec<Frame> {
    let mut pending = Pending::new();
    let mut out = Vec::new();
    let mut p = 0;
    while p < chars.len() {
        let rest = chars.get(p..).unwrap_or(&[]);
        if rest.first() == Some(&ascii::START) {
            // Up to CR LF, or the next `:` (a frame cut short).
            let end = (1..rest.len())
                .find(|&i| {
                    rest.get(i) == Some(&ascii::START)
                        || (rest.get(i - 1) == Some(&ascii::CR) && rest.get(i) == Some(&ascii::LF))
                })
                .map_or(rest.len(), |i| {
                    if rest.get(i) == Some(&ascii::START) {
                        i
                    } else {
                        i + 1
                    }
                });
            out.push(explain_ascii(
                rest.get(..end).unwrap_or(rest),
                p,
                &mut pending,
            ));
            p += end.max(1);
            continue;
        }
        let skip = rest
            .iter()
            .position(|&c| c == ascii::START)
            .unwrap_or(rest.len());
        let junk = rest.get(..skip).unwrap_or(rest);
        if junk.iter().any(|c| !matches!(c, b'\r' | b'\n')) {
            let shown = escape_bytes(junk.trim_ascii());
            out.push(Frame {
                offset: p,
                len: skip,
                bytes: junk.to_vec(),
                skipped: true,
                error: Some(format!(
                    "`{shown}` is outside a frame: no `:` before it (a Modbus ASCII frame starts \
                     with `:`)"
                )),
                ..Frame::default()
            });
        }
        p += skip.max(1);
    }
    out
}

/// One frame in the common shape of every decoder ([`crate::shape`]): the parameter of the
/// start address (a read answer: of the read request before it) with its data set, as `read
/// --json` names it (`label` `372 data set 2`, `selector` `{"dataset": 2}`). Modbus's own
/// keys: `function` (without the exception bit), `exception` (an exception answer's code),
/// and for ASCII `chars` (the frame's characters, control characters escaped: `\r\n`);
/// `bytes`, `offset` and `length` of an ASCII frame count its characters.
pub fn telegram(f: &Frame, protocol: &'static str, line: Option<usize>) -> Telegram {
    let mut t = if f.skipped {
        Telegram::skipped(
            protocol,
            Some(f.offset),
            &f.bytes,
            f.error.clone().unwrap_or_default(),
        )
    } else {
        let mut t = Telegram::new(protocol);
        t.offset = Some(f.offset);
        t.length = f.len;
        t.bytes = f.bytes.clone();
        t.error = f.error.clone();
        t.direction = f.direction;
        t.kind = f.function.map(|fc| {
            let name = function_name(fc);
            if f.exception.is_some() {
                format!("exception answer to {name}")
            } else {
                name.to_owned()
            }
        });
        t.address = f.address.map(i64::from);
        t.param = f.parameter.map(|p| {
            (
                target(
                    drive_profile::Family::Bonfiglioli,
                    p,
                    u16::from(f.data_set.unwrap_or(0)),
                ),
                f.raw.filter(|_| f.function != Some(8)),
            )
        });
        t.refusal = f.refusal.clone();
        t.fields = f.fields.clone();
        t.extra("function", json!(f.function))
            .extra("exception", json!(f.exception))
    };
    if protocol == "modbus-ascii" {
        t = t.extra("chars", escape_bytes(&f.bytes).into());
    }
    t.line = line;
    t
}

/// The name of a function code the drive knows.
fn function_name(fc: u8) -> &'static str {
    match fc {
        3 => "read 16-bit parameter",
        6 => "write 16-bit parameter",
        8 => "diagnostics",
        100 => "read 32-bit parameter",
        101 => "write 32-bit parameter",
        _ => "unknown function",
    }
}

/// The text lines of one frame; `ascii` counts characters, not bytes.
pub fn frame_text(f: &Frame, line: Option<usize>, ascii: bool) -> String {
    let unit = if ascii { "characters" } else { "bytes" };
    let at = line.map_or_else(
        || format!("offset {}", f.offset),
        |l| format!("offset {} (line {l})", f.offset),
    );
    if f.skipped {
        return format!(
            "skipped {} {unit} at {at}: {}\n",
            f.len,
            f.error.as_deref().unwrap_or("")
        );
    }
    let mut out = format!(
        "{} frame at {at}, {} {unit}: {}\n",
        f.direction.unwrap_or("unrecognised"),
        f.len,
        f.error
            .as_deref()
            .map_or_else(|| "valid".to_owned(), |e| format!("INVALID ({e})"))
    );
    for x in &f.fields {
        let shown = x.chars.as_deref().unwrap_or(&x.bytes);
        out.push_str(&format!(
            "  {:>4}  {:<14} {:<18} {}\n",
            x.offset, shown, x.name, x.text
        ));
    }
    out
}

fn decoded(frames: &[Frame], capture: &Capture, ascii: bool) -> Decoded {
    let protocol = if ascii { "modbus-ascii" } else { "modbus-rtu" };
    Decoded::of(frames.iter().map(|f| {
        let line = capture.line_of(f.offset);
        Entry {
            telegram: telegram(f, protocol, line),
            text: frame_text(f, line, ascii),
        }
    }))
}

/// An RTU capture split at CRC-valid boundaries ([`split_rtu`]) and explained.
pub fn decode_rtu(capture: &Capture) -> Decoded {
    decoded(&split_rtu(capture), capture, false)
}

/// An ASCII capture's characters ([`ascii_input`]) split into frames ([`split_ascii`]) and
/// explained; offsets and lengths count characters.
pub fn decode_ascii(chars: &Capture) -> Decoded {
    decoded(&split_ascii(&chars.bytes), chars, true)
}

#[cfg(test)]
mod tests;
