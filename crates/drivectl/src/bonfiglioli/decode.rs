//! `drivectl decode modbus-rtu|modbus-ascii`: explain captured Bonfiglioli Modbus frames field
//! by field.
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

use bonfiglioli_modbus::ascii::{self, lrc};
use bonfiglioli_modbus::frame::{DiagSubFunction, StartAddress};
use bonfiglioli_modbus::rtu::{self, crc};
use drive_profile::{ParamMeta, bonfiglioli};
use serde_json::{Value, json};

use crate::error::{CliError, Result};
use crate::movilink::decode::{Capture, parse_hex, read_capture};
use crate::tool::output::physical_text;

/// One explained field.
#[derive(Debug, Clone)]
pub struct Field {
    /// Offset of the field's first byte (RTU) or character (ASCII) in the capture.
    pub offset: usize,
    /// The bytes as hex (RTU) or the characters (ASCII).
    pub text: String,
    /// Field name.
    pub name: &'static str,
    /// What it means.
    pub meaning: String,
}

/// One explained frame.
#[derive(Debug, Clone, Default)]
pub struct Frame {
    /// Offset of the first byte or character.
    pub offset: usize,
    /// Length in bytes or characters.
    pub len: usize,
    /// `request`, `response` or `request or echoed response`.
    pub direction: Option<&'static str>,
    /// The address.
    pub address: Option<u8>,
    /// The function code.
    pub function: Option<u8>,
    /// Data set and parameter.
    pub data_set: Option<u8>,
    /// Parameter number.
    pub parameter: Option<u16>,
    /// The raw value, if the frame carries one.
    pub raw: Option<i64>,
    /// Exception code.
    pub exception: Option<u8>,
    /// The fields.
    pub fields: Vec<Field>,
    /// The first problem, if any.
    pub error: Option<String>,
}

/// The last read request per address: (function, start address).
type Pending = std::collections::HashMap<u8, (u8, StartAddress)>;

/// How spans of the binary frame map to the capture.
trait Span {
    fn span(&self, start: usize, len: usize) -> (usize, String);
}

struct RtuSpan<'a> {
    base: usize,
    bytes: &'a [u8],
}

impl Span for RtuSpan<'_> {
    fn span(&self, start: usize, len: usize) -> (usize, String) {
        let text = self
            .bytes
            .iter()
            .skip(start)
            .take(len)
            .map(|b| format!("{b:02X}"))
            .collect::<Vec<_>>()
            .join(" ");
        (self.base + start, text)
    }
}

struct AsciiSpan<'a> {
    base: usize,
    chars: &'a [u8],
}

impl Span for AsciiSpan<'_> {
    fn span(&self, start: usize, len: usize) -> (usize, String) {
        // Binary byte i is characters 1 + 2i and 2 + 2i after the `:`.
        let from = 1 + 2 * start;
        let text: String = self
            .chars
            .iter()
            .skip(from)
            .take(2 * len)
            .map(|&c| char::from(c))
            .collect();
        (self.base + from, text)
    }
}

fn push(
    f: &mut Frame,
    s: &dyn Span,
    start: usize,
    len: usize,
    name: &'static str,
    meaning: String,
) {
    let (offset, text) = s.span(start, len);
    f.fields.push(Field {
        offset,
        text,
        name,
        meaning,
    });
}

fn be16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

fn be32(b: &[u8], at: usize) -> Option<u32> {
    Some((u32::from(be16(b, at)?) << 16) | u32::from(be16(b, at + 2)?))
}

fn start_text(start: StartAddress) -> String {
    let ds = start.data_set().map_or(0, |d| d.get());
    let ds_text = match ds {
        0 => "data set 0 (all four)".to_owned(),
        1..=4 => format!("data set {ds}"),
        5..=9 => format!("data set {ds} (RAM only, of data set {})", ds - 5),
        _ => format!("data set {ds} (none: 0-9 exist)"),
    };
    match start.param() {
        Some(p) => match bonfiglioli::by_number(p) {
            Some(q) => format!("{ds_text}, parameter {p} {} ({})", q.name_en, q.name_de),
            None => format!("{ds_text}, parameter {p} (not in the table)"),
        },
        None => format!(
            "{ds_text}, parameter {} (none: 0-1599 exist)",
            start.param_bits()
        ),
    }
}

fn value_text(param: Option<u16>, raw_data: u32, long: bool) -> (i64, String) {
    let p = param.and_then(bonfiglioli::by_number);
    let signed = p.and_then(|p| p.raw_range()).is_none_or(|(lo, _)| lo < 0);
    let raw = match (long, signed) {
        (false, true) => i64::from(raw_data as u16 as i16),
        (false, false) => i64::from(raw_data as u16),
        (true, true) => i64::from(raw_data as i32),
        (true, false) => i64::from(raw_data),
    };
    let text = match p {
        Some(p) => format!(
            "{raw} = {} ({} {})",
            physical_text(p, raw),
            p.label(),
            p.name_en
        ),
        None => format!("{raw} (0x{raw_data:X}; parameter unknown, not scaled)"),
    };
    (raw, text)
}

/// Explain the PDU `pdu` (after the address byte at binary index 0) into `f`.
fn explain_pdu(f: &mut Frame, s: &dyn Span, address: u8, pdu: &[u8], pending: &mut Pending) {
    let Some(&fc) = pdu.first() else {
        f.error.get_or_insert("no function code".to_owned());
        return;
    };
    f.function = Some(fc & 0x7F);
    let n = pdu.len();
    if fc & 0x80 != 0 {
        f.direction = Some("response");
        push(
            f,
            s,
            1,
            1,
            "function",
            format!("0x{fc:02X}: exception answer to function {}", fc & 0x7F),
        );
        match pdu.get(1) {
            Some(&code) => {
                f.exception = Some(code);
                let meaning = bonfiglioli::modbus_exception(code).map_or_else(
                    || format!("exception {code} (not one the drive sends)"),
                    |e| {
                        format!(
                            "exception {code} {}: {}; causes: {}",
                            e.modbus_name, e.name_en, e.cause_en
                        )
                    },
                );
                push(f, s, 2, 1, "exception", meaning);
            }
            None => {
                f.error
                    .get_or_insert("exception answer without its code".to_owned());
            }
        }
        if n > 2 {
            f.error
                .get_or_insert(format!("exception answer of {n} bytes, expected 2"));
        }
        pending.remove(&address);
        return;
    }
    let name = match fc {
        3 => "read 16-bit parameter",
        6 => "write 16-bit parameter",
        8 => "diagnostics",
        100 => "read 32-bit parameter",
        101 => "write 32-bit parameter",
        _ => {
            push(
                f,
                s,
                1,
                1,
                "function",
                format!("{fc}: not a function code of the drive (3, 6, 8, 100, 101)"),
            );
            f.error.get_or_insert(format!("unknown function code {fc}"));
            return;
        }
    };
    push(f, s, 1, 1, "function", format!("{fc} (0x{fc:02X}): {name}"));
    let start = be16(pdu, 1).map(StartAddress::from_raw);
    let start_field = |f: &mut Frame, st: StartAddress| {
        f.data_set = st.data_set().map(|d| d.get());
        f.parameter = st.param();
        push(
            f,
            s,
            2,
            2,
            "data set/parameter",
            format!("0x{:04X}: {}", st.raw(), start_text(st)),
        );
    };
    let expected = match (fc, n) {
        (3, 5) => {
            f.direction = Some("request");
            if let Some(st) = start {
                start_field(f, st);
                pending.insert(address, (fc, st));
            }
            let count = be16(pdu, 3).unwrap_or(0);
            push(
                f,
                s,
                4,
                2,
                "register count",
                if count == 1 {
                    "1 (the only count the drive takes)".to_owned()
                } else {
                    format!("{count}: the drive answers exception 2 (only 1 is allowed)")
                },
            );
            None
        }
        (3, 4) => {
            f.direction = Some("response");
            let bc = pdu.get(1).copied().unwrap_or(0);
            push(
                f,
                s,
                2,
                1,
                "byte count",
                format!("{bc}{}", if bc == 2 { "" } else { " (expected 2)" }),
            );
            let param = pending.remove(&address).and_then(|(_, st)| st.param());
            f.parameter = param;
            let (raw, text) = value_text(param, u32::from(be16(pdu, 2).unwrap_or(0)), false);
            f.raw = Some(raw);
            push(f, s, 3, 2, "value", text);
            None
        }
        (100, 3) => {
            f.direction = Some("request");
            if let Some(st) = start {
                start_field(f, st);
                pending.insert(address, (fc, st));
            }
            None
        }
        (100, 5) => {
            f.direction = Some("response");
            let param = pending.remove(&address).and_then(|(_, st)| st.param());
            f.parameter = param;
            let (raw, text) = value_text(param, be32(pdu, 1).unwrap_or(0), true);
            f.raw = Some(raw);
            push(f, s, 2, 4, "value", text);
            None
        }
        (6, 5) | (101, 7) => {
            f.direction = Some("request or echoed response");
            if let Some(st) = start {
                start_field(f, st);
            }
            let long = fc == 101;
            let data = if long {
                be32(pdu, 3).unwrap_or(0)
            } else {
                u32::from(be16(pdu, 3).unwrap_or(0))
            };
            let (raw, text) = value_text(start.and_then(StartAddress::param), data, long);
            f.raw = Some(raw);
            push(f, s, 4, if long { 4 } else { 2 }, "value", text);
            None
        }
        (8, 5) => {
            f.direction = Some("request or echoed response");
            let sub = DiagSubFunction(be16(pdu, 1).unwrap_or(0));
            push(
                f,
                s,
                2,
                2,
                "sub-function",
                sub.name().map_or_else(
                    || format!("0x{:04X}: not supported (exception 1)", sub.0),
                    |n| format!("0x{:04X}: {n}", sub.0),
                ),
            );
            let data = be16(pdu, 3).unwrap_or(0);
            f.raw = Some(i64::from(data));
            push(
                f,
                s,
                4,
                2,
                "data",
                format!("{data} (0 in a request; the counter in an answer)"),
            );
            None
        }
        (3, _) => Some("5 (request) or 4 (response)"),
        (100, _) => Some("3 (request) or 5 (response)"),
        (6 | 8, _) => Some("5"),
        _ => Some("7"),
    };
    if let Some(e) = expected {
        f.error
            .get_or_insert(format!("function {fc} with {n} PDU bytes; it has {e}"));
    }
}

fn address_field(f: &mut Frame, s: &dyn Span, a: u8) {
    f.address = Some(a);
    let meaning = match a {
        0 => "0: broadcast (writes only, never answered)".to_owned(),
        1..=247 => format!("{a}"),
        _ => {
            f.error
                .get_or_insert(format!("address {a} is reserved (248-255)"));
            format!("{a}: reserved")
        }
    };
    push(f, s, 0, 1, "address", meaning);
}

/// Explain one RTU frame (`bytes` at capture offset `base`).
pub fn explain_rtu(bytes: &[u8], base: usize, pending: &mut Pending) -> Frame {
    let mut f = Frame {
        offset: base,
        len: bytes.len(),
        ..Frame::default()
    };
    let s = RtuSpan { base, bytes };
    if bytes.len() < rtu::MIN_FRAME {
        f.error = Some(format!(
            "{} byte(s): an RTU frame has at least 4 (address, function, CRC)",
            bytes.len()
        ));
        push(
            &mut f,
            &s,
            0,
            bytes.len(),
            "bytes",
            "too short to be a frame".to_owned(),
        );
        return f;
    }
    let body = bytes.get(..bytes.len() - 2).unwrap_or(&[]);
    let Some(&a) = body.first() else { return f };
    address_field(&mut f, &s, a);
    explain_pdu(&mut f, &s, a, body.get(1..).unwrap_or(&[]), pending);
    let got = u16::from_le_bytes([
        bytes.get(bytes.len() - 2).copied().unwrap_or(0),
        bytes.last().copied().unwrap_or(0),
    ]);
    let expected = crc(body);
    let [lo, hi] = expected.to_le_bytes();
    let meaning = if got == expected {
        format!("CRC-16 0x{expected:04X} (sent low byte first): right")
    } else {
        f.error = Some(format!(
            "CRC wrong: the frame carries {:02X} {:02X}, the bytes give {lo:02X} {hi:02X}",
            got & 0xFF,
            got >> 8
        ));
        format!("WRONG: expected {lo:02X} {hi:02X} (CRC-16 0x{expected:04X})")
    };
    push(&mut f, &s, body.len(), 2, "CRC", meaning);
    f
}

/// Explain one ASCII frame: the characters from `:` up to and with CR LF (or as far as they go).
pub fn explain_ascii(chars: &[u8], base: usize, pending: &mut Pending) -> Frame {
    let mut f = Frame {
        offset: base,
        len: chars.len(),
        ..Frame::default()
    };
    let s = AsciiSpan { base, chars };
    f.fields.push(Field {
        offset: base,
        text: ":".to_owned(),
        name: "start",
        meaning: "start of frame".to_owned(),
    });
    let (digits, ended) = match chars.get(1..).unwrap_or(&[]) {
        [d @ .., ascii::CR, ascii::LF] => (d, true),
        d => (d, false),
    };
    let mut bin = Vec::new();
    for pair in digits.chunks(2) {
        match (
            pair.first().copied().and_then(ascii::hex_value),
            pair.get(1).copied().and_then(ascii::hex_value),
        ) {
            (Some(h), Some(l)) => bin.push((h << 4) | l),
            _ => {
                f.error = Some(format!(
                    "`{}` at offset {} is not a pair of hex digits",
                    String::from_utf8_lossy(pair),
                    base + 1 + 2 * bin.len()
                ));
                break;
            }
        }
    }
    if bin.len() < 3 {
        f.error.get_or_insert(format!(
            "{} byte(s) between `:` and CR LF: a frame has at least 3 (address, function, LRC)",
            bin.len()
        ));
        return f;
    }
    let body = bin.get(..bin.len() - 1).unwrap_or(&[]);
    if let Some(&a) = body.first() {
        address_field(&mut f, &s, a);
        explain_pdu(&mut f, &s, a, body.get(1..).unwrap_or(&[]), pending);
    }
    let got = bin.last().copied().unwrap_or(0);
    let expected = lrc(body);
    let meaning = if got == expected {
        format!("LRC 0x{expected:02X}: right")
    } else {
        f.error = Some(format!(
            "LRC wrong: the frame carries {got:02X}, the bytes give {expected:02X}"
        ));
        format!("WRONG: expected {expected:02X}")
    };
    push(&mut f, &s, body.len(), 1, "LRC", meaning);
    if ended {
        f.fields.push(Field {
            offset: base + chars.len() - 2,
            text: "CR LF".to_owned(),
            name: "end",
            meaning: "end of frame".to_owned(),
        });
    } else {
        f.error.get_or_insert("no CR LF at the end".to_owned());
    }
    f
}

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

/// The characters of an ASCII capture: the text itself when it has a `:`, else hex bytes of
/// the characters. Line ends in text input are CR LF of the frames (a lone LF counts as CR LF).
fn ascii_chars(text: &str, from_args: bool) -> Result<Vec<u8>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if !text.contains(':') {
        let bytes = if from_args {
            parse_hex(&text.split('\n').map(str::to_owned).collect::<Vec<_>>())?
        } else {
            crate::movilink::decode::parse_text(text, "the capture")?.bytes
        };
        return Ok(bytes);
    }
    let mut out = Vec::new();
    for line in text.split('\n') {
        let line = line.strip_suffix('\r').unwrap_or(line);
        let content = line.split_once('#').map_or(line, |(a, _)| a);
        let content: String = content.chars().filter(|c| !c.is_whitespace()).collect();
        if content.is_empty() {
            continue;
        }
        if let Some(bad) = content.chars().find(|c| !c.is_ascii()) {
            return Err(CliError::usage(format!(
                "`{bad}` is not a Modbus ASCII character; give frames like `:010321740001 66`"
            )));
        }
        out.extend_from_slice(content.as_bytes());
        out.extend_from_slice(b"\r\n");
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
            out.push(Frame {
                offset: p,
                len: skip,
                error: Some(format!(
                    "`{}` is outside a frame (no `:` before it)",
                    String::from_utf8_lossy(junk).trim()
                )),
                ..Frame::default()
            });
        }
        p += skip.max(1);
    }
    out
}

/// One frame as JSON.
pub fn to_json(f: &Frame, mode: &str) -> Value {
    json!({
        "type": "frame", "mode": mode, "offset": f.offset, "length": f.len,
        "direction": f.direction, "valid": f.error.is_none(), "error": f.error,
        "address": f.address, "function": f.function, "data_set": f.data_set,
        "parameter": f.parameter,
        "name_en": f.parameter.and_then(bonfiglioli::by_number).map(|p| p.name_en),
        "raw": f.raw, "exception": f.exception,
        "fields": f.fields.iter().map(|x| json!({
            "offset": x.offset, "text": x.text, "field": x.name, "meaning": x.meaning,
        })).collect::<Vec<_>>(),
    })
}

/// Run `drivectl decode modbus-rtu` (`ascii` false) or `modbus-ascii`.
pub fn run(ascii_mode: bool, args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let from_stdin = file.is_some() || matches!(args, [only] if only == "-");
    let frames = if ascii_mode {
        let text = if from_stdin {
            let path = file.unwrap_or("-");
            let raw =
                crate::tool::infile::read_limited(std::path::Path::new(path), true, 64 << 20)?;
            String::from_utf8(raw).map_err(|e| {
                CliError::usage(format!(
                    "the capture is not text (byte {} is not UTF-8)",
                    e.utf8_error().valid_up_to()
                ))
            })?
        } else {
            args.join("\n")
        };
        let chars = ascii_chars(&text, !from_stdin)?;
        if chars.is_empty() {
            return Err(CliError::usage(
                "no frames given; give ASCII frames like `:010321740001 66`",
            ));
        }
        split_ascii(&chars)
    } else {
        let capture = if from_stdin {
            read_capture(file.unwrap_or("-"))?
        } else {
            Capture {
                bytes: parse_hex(args)?,
                lines: Vec::new(),
            }
        };
        split_rtu(&capture)
    };
    let mode = if ascii_mode { "ascii" } else { "rtu" };
    let mut out = String::new();
    for f in &frames {
        if json {
            out.push_str(&to_json(f, mode).to_string());
            out.push('\n');
            continue;
        }
        out.push_str(&format!(
            "{} frame at offset {}, {} {}: {}\n",
            f.direction.unwrap_or("unrecognised"),
            f.offset,
            f.len,
            if ascii_mode { "characters" } else { "bytes" },
            f.error
                .as_deref()
                .map_or_else(|| "valid".to_owned(), |e| format!("INVALID ({e})"))
        ));
        for x in &f.fields {
            out.push_str(&format!(
                "  {:>4}  {:<14} {:<18} {}\n",
                x.offset, x.text, x.name, x.meaning
            ));
        }
    }
    out!("{out}")?;
    let invalid = frames.iter().filter(|f| f.error.is_some()).count();
    if invalid > 0 {
        return Err(CliError::failed(format!(
            "{invalid} of {} frame(s) are invalid (see above)",
            frames.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rtu(hex: &str) -> Vec<Frame> {
        split_rtu(&Capture {
            bytes: parse_hex(&[hex.to_owned()]).unwrap(),
            lines: Vec::new(),
        })
    }

    #[test]
    fn manual_8_1_1_read_372_in_data_set_2_and_its_answer() {
        // Request: 01 address, 03 FC, 21 74 data set 2 | 372, 00 01 count, CE 2C CRC; answer:
        // 01 address, 03 FC, 02 byte count, 05 6E = 1390, 3A F8 CRC. One stream, split by CRC.
        let f = rtu("01 03 21 74 00 01 CE 2C 01 03 02 05 6E 3A F8");
        assert_eq!(f.len(), 2);
        assert_eq!((f[0].data_set, f[0].parameter), (Some(2), Some(372)));
        assert_eq!(f[0].direction, Some("request"));
        assert_eq!((f[1].parameter, f[1].raw), (Some(372), Some(1390)));
        assert!(f.iter().all(|x| x.error.is_none()));
    }

    #[test]
    fn manual_8_1_exceptions_and_writes() {
        // 8.1.2 example 2: 03 86 04 E2 63: exception 4 to FC 6.
        let f = rtu("03 86 04 E2 63");
        assert_eq!((f[0].function, f[0].exception), (Some(6), Some(4)));
        // 8.1.2 example 1: write 376 in data set 4 = 15 (1.5 kW).
        let f = rtu("03 06 41 78 00 0F 5C 09");
        assert_eq!(
            (f[0].data_set, f[0].parameter, f[0].raw),
            (Some(4), Some(376), Some(15))
        );
        assert!(f[0].fields.iter().any(|x| x.meaning.contains("1.5 kW")));
        // 8.1.3 example 1: read 481 (FC 100) → 1000 = 10.00 Hz.
        let f = rtu("01 64 01 E1 81 DF 01 64 00 00 03 E8 70 BC");
        assert_eq!((f[1].parameter, f[1].raw), (Some(481), Some(1000)));
        assert!(
            f[1].fields.iter().any(|x| x.meaning.contains("10.00 Hz")),
            "{:?}",
            f[1].fields
        );
    }

    #[test]
    fn a_wrong_crc_names_the_expected_one() {
        let f = rtu("01 03 21 74 00 01 2C CE");
        assert_eq!(f.len(), 1);
        let e = f[0].error.as_deref().unwrap();
        assert!(e.contains("CE 2C"), "{e}");
    }

    #[test]
    fn manual_8_2_ascii_frames() {
        // 8.2.1 example 1, request and answer, as text.
        let chars = ascii_chars(":010321740001 66\n:01030205 6E 87\n", false).unwrap();
        let f = split_ascii(&chars);
        assert_eq!(f.len(), 2);
        assert_eq!((f[0].data_set, f[0].parameter), (Some(2), Some(372)));
        assert_eq!(f[1].raw, Some(1390));
        assert!(f.iter().all(|x| x.error.is_none()), "{f:?}");
        // 8.2.3 example 2 as the manual's ASC row prints it (erratum E4): LRC 19 belongs to
        // exception code 02; as the Hex row, code 04 with LRC 17 is right.
        let f = split_ascii(&ascii_chars(":01E40217\r\n", false).unwrap());
        assert!(f[0].error.as_deref().unwrap().contains("19"), "{f:?}");
        let f = split_ascii(&ascii_chars("3A 30 31 45 34 30 34 31 37 0D 0A", false).unwrap());
        assert_eq!((f[0].exception, f[0].error.as_deref()), (Some(4), None));
    }
}
