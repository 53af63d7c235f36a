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

use crate::decode::{Capture, parse_hex, read_capture};
use crate::error::{CliError, Result};
use crate::tool::output::physical_text;

pub use crate::decode::Field;

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
    /// The exception in words.
    pub refusal: Option<String>,
    /// The fields.
    pub fields: Vec<Field>,
    /// The first problem, if any.
    pub error: Option<String>,
    /// The frame's bytes (RTU) or characters (ASCII).
    pub bytes: Vec<u8>,
    /// Bytes or characters outside any frame, skipped.
    pub skipped: bool,
}

/// The last read request per address: (function, start address).
type Pending = std::collections::HashMap<u8, (u8, StartAddress)>;

/// How spans of the binary frame map to the capture.
trait Span {
    /// The field of binary bytes `start .. start + len`: its offset in the capture, its bytes
    /// (ASCII: the characters' codes), its characters (ASCII) and the value of the binary bytes.
    fn field(&self, start: usize, len: usize, name: &str, text: String) -> Field;
}

struct RtuSpan<'a> {
    base: usize,
    bytes: &'a [u8],
}

impl Span for RtuSpan<'_> {
    fn field(&self, start: usize, len: usize, name: &str, text: String) -> Field {
        let b = self.bytes.get(start..).unwrap_or(&[]);
        Field::new(self.base + start, b.get(..len).unwrap_or(b), name, text)
    }
}

struct AsciiSpan<'a> {
    base: usize,
    chars: &'a [u8],
}

impl Span for AsciiSpan<'_> {
    fn field(&self, start: usize, len: usize, name: &str, text: String) -> Field {
        // Binary byte i is characters 1 + 2i and 2 + 2i after the `:`.
        let from = 1 + 2 * start;
        let c = self.chars.get(from..).unwrap_or(&[]);
        let c = c.get(..2 * len).unwrap_or(c);
        let binary: Option<Vec<u8>> = c
            .chunks(2)
            .map(|p| {
                let hi = ascii::hex_value(*p.first()?)?;
                let lo = ascii::hex_value(*p.get(1)?)?;
                Some((hi << 4) | lo)
            })
            .collect();
        Field {
            offset: self.base + from,
            bytes: crate::decode::hex(c),
            chars: Some(crate::decode::escape_bytes(c)),
            name: name.to_owned(),
            value: binary.as_deref().and_then(crate::decode::big_endian),
            text,
        }
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
    f.fields.push(s.field(start, len, name, meaning));
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
                f.refusal = Some(meaning.clone());
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
            let asked = pending.remove(&address).map(|(_, st)| st);
            let param = asked.and_then(StartAddress::param);
            f.parameter = param;
            f.data_set = asked.and_then(|st| st.data_set()).map(|d| d.get());
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
            let asked = pending.remove(&address).map(|(_, st)| st);
            let param = asked.and_then(StartAddress::param);
            f.parameter = param;
            f.data_set = asked.and_then(|st| st.data_set()).map(|d| d.get());
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
        bytes: bytes.to_vec(),
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
    // The CRC travels low byte first: its value is the CRC-16 it carries.
    if let Some(crc_field) = f.fields.last_mut() {
        crc_field.value = Some(u64::from(got));
    }
    f
}

/// Explain one ASCII frame: the characters from `:` up to and with CR LF (or as far as they go).
pub fn explain_ascii(chars: &[u8], base: usize, pending: &mut Pending) -> Frame {
    let mut f = Frame {
        offset: base,
        len: chars.len(),
        bytes: chars.to_vec(),
        ..Frame::default()
    };
    let s = AsciiSpan { base, chars };
    f.fields.push(Field {
        chars: Some(":".to_owned()),
        value: None,
        ..Field::new(base, &[ascii::START], "start", "start of frame".to_owned())
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
                    crate::decode::escape_bytes(pair),
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
            chars: Some("\\r\\n".to_owned()),
            value: None,
            ..Field::new(
                base + chars.len() - 2,
                &[ascii::CR, ascii::LF],
                "end",
                "end of frame (CR LF)".to_owned(),
            )
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
#[cfg(test)]
fn ascii_chars(text: &str, from_args: bool) -> Result<Vec<u8>> {
    ascii_capture(text, from_args).map(|c| c.bytes)
}

/// The characters of an ASCII capture (the text itself when it has a `:`, else hex bytes of
/// the characters) with the input line of every character (none for arguments).
fn ascii_capture(text: &str, from_args: bool) -> Result<Capture> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if !text.contains(':') {
        return if from_args {
            Ok(Capture {
                bytes: parse_hex(&text.split('\n').map(str::to_owned).collect::<Vec<_>>())?,
                lines: Vec::new(),
            })
        } else {
            crate::decode::parse_text(text, "the capture")
        };
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
            return Err(CliError::usage(format!(
                "`{}` is not a Modbus ASCII character; give frames like `:010321740001 66`",
                crate::decode::escape(&bad.to_string())
            )));
        }
        out.bytes.extend_from_slice(content.as_bytes());
        out.bytes.extend_from_slice(b"\r\n");
        let number = if from_args { None } else { Some(n + 1) };
        if let Some(number) = number {
            out.lines
                .extend(std::iter::repeat_n(number, content.len() + 2));
        }
    }
    Ok(out)
}

/// The usage error for ASCII input without any `:`: a Modbus ASCII frame starts with one. For
/// arguments that look like frames without it (hex digits), the command with it.
fn missing_colon(args: &[String], from_args: bool) -> CliError {
    let looks_like_frames = from_args
        && !args.is_empty()
        && args.iter().all(|a| {
            let t = a.trim();
            !t.is_empty() && t.chars().all(|c| c.is_ascii_hexdigit() || c == ' ')
        });
    let hint = if looks_like_frames {
        let with: Vec<String> = args
            .iter()
            .map(|a| format!(":{}", a.trim().replace(' ', "")))
            .collect();
        format!(
            "; with it: `drivectl decode modbus-ascii {}`",
            with.join(" ")
        )
    } else {
        String::new()
    };
    CliError::usage(format!(
        "no `:` in the capture: a Modbus ASCII frame starts with `:` and ends with CR LF \
         (`:01032174000166`), or give its characters as hex bytes with the `:` as 3A \
         (`3A 30 31 …`){hint}"
    ))
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
            let shown = crate::decode::escape_bytes(junk.trim_ascii());
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

/// One frame in the common shape of every decoder ([`crate::decode`]): the parameter of the
/// start address (a read answer: of the read request before it) with its data set, as `read
/// --json` names it (`label` `372 data set 2`, `selector` `{"dataset": 2}`). Modbus's own
/// keys: `function` (without the exception bit), `exception` (an exception answer's code),
/// and for ASCII `chars` (the frame's characters, control characters escaped: `\r\n`);
/// `bytes`, `offset` and `length` of an ASCII frame count its characters.
pub fn to_json(f: &Frame, protocol: &'static str) -> Value {
    let mut t = if f.skipped {
        crate::decode::Telegram::skipped(
            protocol,
            Some(f.offset),
            &f.bytes,
            f.error.clone().unwrap_or_default(),
        )
    } else {
        let mut t = crate::decode::Telegram::new(protocol);
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
                crate::decode::target(
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
        t = t.extra("chars", crate::decode::escape_bytes(&f.bytes).into());
    }
    t.to_json()
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

/// Run `drivectl decode modbus-rtu` (`ascii` false) or `modbus-ascii`.
pub fn run(ascii_mode: bool, args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let from_stdin = file.is_some() || matches!(args, [only] if only == "-");
    let (frames, lines) = if ascii_mode {
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
        let chars = ascii_capture(&text, !from_stdin)?;
        if chars.bytes.is_empty() {
            return Err(CliError::usage(
                "no frames given; give ASCII frames like `:010321740001 66`",
            ));
        }
        if !chars.bytes.contains(&ascii::START) {
            return Err(missing_colon(args, !from_stdin));
        }
        (split_ascii(&chars.bytes), chars.lines)
    } else {
        let capture = if from_stdin {
            read_capture(file.unwrap_or("-"))?
        } else {
            Capture {
                bytes: parse_hex(args)?,
                lines: Vec::new(),
            }
        };
        (split_rtu(&capture), capture.lines)
    };
    let protocol = if ascii_mode {
        "modbus-ascii"
    } else {
        "modbus-rtu"
    };
    let mut out = String::new();
    for f in &frames {
        let line = lines.get(f.offset).copied();
        if json {
            let mut v = to_json(f, protocol);
            if let Value::Object(m) = &mut v {
                m.insert("line".into(), json!(line));
            }
            out.push_str(&v.to_string());
            out.push('\n');
            continue;
        }
        let at = line.map_or_else(
            || format!("offset {}", f.offset),
            |l| format!("offset {} (line {l})", f.offset),
        );
        if f.skipped {
            out.push_str(&format!(
                "skipped {} {} at {at}: {}\n",
                f.len,
                if ascii_mode { "characters" } else { "bytes" },
                f.error.as_deref().unwrap_or("")
            ));
            continue;
        }
        out.push_str(&format!(
            "{} frame at {at}, {} {}: {}\n",
            f.direction.unwrap_or("unrecognised"),
            f.len,
            if ascii_mode { "characters" } else { "bytes" },
            f.error
                .as_deref()
                .map_or_else(|| "valid".to_owned(), |e| format!("INVALID ({e})"))
        ));
        for x in &f.fields {
            let shown = x.chars.as_deref().unwrap_or(&x.bytes);
            out.push_str(&format!(
                "  {:>4}  {:<14} {:<18} {}\n",
                x.offset, shown, x.name, x.text
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
        assert!(f[0].fields.iter().any(|x| x.text.contains("1.5 kW")));
        // 8.1.3 example 1: read 481 (FC 100) → 1000 = 10.00 Hz.
        let f = rtu("01 64 01 E1 81 DF 01 64 00 00 03 E8 70 BC");
        assert_eq!((f[1].parameter, f[1].raw), (Some(481), Some(1000)));
        assert!(
            f[1].fields.iter().any(|x| x.text.contains("10.00 Hz")),
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
