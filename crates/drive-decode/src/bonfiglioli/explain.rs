//! One Modbus frame explained field by field: the PDU of the drive's function codes, the
//! address, the CRC (RTU) or LRC (ASCII).

use bonfiglioli_modbus::ascii::{self, lrc};
use bonfiglioli_modbus::frame::{DiagSubFunction, StartAddress};
use bonfiglioli_modbus::rtu::{self, crc};
use drive_client::text::physical_text;
use drive_profile::{ParamMeta, bonfiglioli};

use crate::shape::{Field, big_endian, escape_bytes, hex};

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
pub(super) type Pending = std::collections::HashMap<u8, (u8, StartAddress)>;

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
            bytes: hex(c),
            chars: Some(escape_bytes(c)),
            name: name.to_owned(),
            value: binary.as_deref().and_then(big_endian),
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
pub(super) fn explain_rtu(bytes: &[u8], base: usize, pending: &mut Pending) -> Frame {
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
pub(super) fn explain_ascii(chars: &[u8], base: usize, pending: &mut Pending) -> Frame {
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
                    escape_bytes(pair),
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
