//! MOVILINK (SEW, RS-485/RS-232): split a capture into telegrams and explain each field by
//! field.
//!
//! The walk does not stop at the first error: a telegram with a wrong BCC or an unknown PDU type
//! is still explained as far as its bytes go, with the error named where it occurs.

use drive_client::text::{physical_text, trim_float};
use drive_profile::sew::{ControlWord1, StatusWord1};
use drive_profile::{ParamMeta, sew};
use movilink::DecodeError;
use movilink::codec::{self, bcc};
use movilink::{Address, ParamChannel, PduType, ReturnCode, SD1, SD2, Service};
use serde_json::{Value, json};

use crate::input::Capture;
use crate::shape::{Field, Telegram, hex, target};
use crate::{Decoded, Entry};

/// The explanation of one telegram of a capture.
#[derive(Debug, Clone, Default)]
pub struct Explained {
    /// Offset of the telegram's first byte in the capture.
    pub offset: usize,
    /// Request (SD1) or response (SD2), if the start character says so.
    pub direction: Option<&'static str>,
    /// The address byte, if present.
    pub address: Option<u8>,
    /// The PDU type, if present and known.
    pub pdu_type: Option<PduType>,
    /// The parameter channel's index, if the PDU type has one.
    pub index: Option<u16>,
    /// The parameter channel's service, if the PDU type has one and the code is defined.
    pub service: Option<&'static str>,
    /// The parameter channel's data as the parameter's raw value (signed where its range goes
    /// below zero or the index is not in the table), unless the status bit marks an error.
    pub raw: Option<i64>,
    /// The process data words.
    pub words: Vec<u16>,
    /// The parameter channel's return code, when its status bit marks an error.
    pub return_code: Option<ReturnCode>,
    /// The fields in order.
    pub fields: Vec<Field>,
    /// The first problem found, if any.
    pub error: Option<String>,
    /// Bytes consumed from the capture.
    pub len: usize,
    /// The telegram's bytes.
    pub bytes: Vec<u8>,
}

/// One item of a split capture: a telegram (valid or not), or bytes that start none.
#[derive(Debug, Clone)]
pub enum Item {
    /// A telegram framed by its start character and PDU type.
    Telegram(Explained),
    /// Bytes that do not start a telegram, skipped up to the next start character or line.
    Unrecognised {
        /// Offset of the first byte in the capture.
        offset: usize,
        /// The skipped bytes.
        bytes: Vec<u8>,
        /// Why they start no telegram.
        reason: String,
    },
}

impl Item {
    /// Offset of the item's first byte.
    pub fn offset(&self) -> usize {
        match self {
            Self::Telegram(e) => e.offset,
            Self::Unrecognised { offset, .. } => *offset,
        }
    }
}

/// Split `capture` into telegrams with the MOVILINK framing (start character SD1 0x02 or SD2
/// 0x1D, length from the PDU type) and explain each. Bytes that start no telegram are reported
/// and skipped up to the next start character. A telegram that would cross a line of the input
/// is taken only if its check character is right (a wrapped dump); otherwise the line's part is
/// explained as truncated and the next line starts afresh. Never panics.
pub fn split(capture: &Capture) -> Vec<Item> {
    let bytes = capture.bytes.as_slice();
    let starts = capture.line_starts();
    // Sorted, so a binary search keeps long captures linear-ish.
    let next_line = |p: usize| starts.get(starts.partition_point(|&b| b <= p)).copied();
    let mut out = Vec::new();
    let mut p = 0;
    while let Some(rest) = bytes.get(p..).filter(|r| !r.is_empty()) {
        let framed = match codec::telegram_len(rest) {
            Ok(n) => Some(n.min(rest.len())),
            // A start character with fewer than three bytes after it: a truncated telegram.
            Err(DecodeError::Truncated { .. }) => Some(rest.len()),
            Err(_) => None,
        };
        if let Some(n) = framed {
            let mut e = explain(rest.get(..n).unwrap_or(rest));
            let mut n = n;
            if let Some(b) = next_line(p).filter(|&b| b < p + n)
                && e.error.is_some()
            {
                n = b - p;
                e = explain(rest.get(..n).unwrap_or(rest));
            }
            e.offset = p;
            for f in &mut e.fields {
                f.offset += p;
            }
            e.len = n;
            e.bytes = rest.get(..n).unwrap_or(rest).to_vec();
            out.push(Item::Telegram(e));
            p += n.max(1);
            continue;
        }
        let reason = match rest.first() {
            Some(&b) if b == SD1 || b == SD2 => format!(
                "unknown PDU type 0x{:02X} after a start character",
                rest.get(2).copied().unwrap_or(0)
            ),
            _ => "no start character (SD1 = 02, SD2 = 1D)".to_owned(),
        };
        let limit = next_line(p).map_or(rest.len(), |b| b - p);
        let skip = rest
            .iter()
            .enumerate()
            .skip(1)
            .take_while(|(i, _)| *i < limit)
            .find(|(_, b)| **b == SD1 || **b == SD2)
            .map_or(limit, |(i, _)| i);
        out.push(Item::Unrecognised {
            offset: p,
            bytes: rest.get(..skip).unwrap_or(rest).to_vec(),
            reason,
        });
        p += skip.max(1);
    }
    out
}

/// Explain the telegram at the start of `bytes`.
pub fn explain(bytes: &[u8]) -> Explained {
    let mut fields = Vec::new();
    let mut push = |offset: usize, b: &[u8], name: &str, meaning: String| {
        fields.push(Field::new(offset, b, name, meaning));
    };
    let mut error = None;
    let sd = bytes.first().copied().unwrap_or(0);
    let direction = match sd {
        SD1 => Some("request"),
        SD2 => Some("response"),
        _ => None,
    };
    match direction {
        Some("request") => push(
            0,
            &[sd],
            "SD1",
            "start character: request, master → drive".into(),
        ),
        Some(_) => push(
            0,
            &[sd],
            "SD2",
            "start character: response, drive → master".into(),
        ),
        None => {
            push(
                0,
                &[sd],
                "??",
                "not a start character (SD1 = 02, SD2 = 1D)".into(),
            );
            return Explained {
                direction,
                fields,
                error: Some(format!("byte 0x{sd:02X} is not SD1 or SD2")),
                len: 1,
                ..Explained::default()
            };
        }
    }
    let Some(&adr) = bytes.get(1) else {
        return Explained {
            direction,
            fields,
            error: Some("truncated after the start character".into()),
            len: bytes.len(),
            ..Explained::default()
        };
    };
    let adr_text = match Address::new(adr) {
        Some(a) if a.is_unicast() => format!("address {adr} (single drive)"),
        Some(a) if a.get() == 100 => "group address 100 (no group: not effective)".to_owned(),
        Some(a) if a.is_group() => format!("group address {adr} (multicast, never answered)"),
        Some(a) if a.is_point_to_point() => "254: point-to-point (any drive answers)".to_owned(),
        Some(a) if a.is_broadcast() => "255: broadcast (never answered)".to_owned(),
        Some(_) => "253: local address (IPOS internal)".to_owned(),
        None => {
            error.get_or_insert(format!("address {adr} is reserved (200…252)"));
            format!("{adr}: reserved, invalid")
        }
    };
    push(1, &[adr], "ADR", adr_text);
    let Some(&typ) = bytes.get(2) else {
        return Explained {
            direction,
            fields,
            error: Some("truncated after the address".into()),
            len: bytes.len(),
            address: Some(adr),
            ..Explained::default()
        };
    };
    let Some(pdu) = PduType::new(typ) else {
        push(2, &[typ], "TYP", "unknown PDU type".into());
        return Explained {
            direction,
            fields,
            error: Some(format!("unknown PDU type 0x{typ:02X}")),
            len: 3,
            address: Some(adr),
            ..Explained::default()
        };
    };
    let words = pdu.pd_words();
    push(
        2,
        &[typ],
        "TYP",
        format!(
            "{}{}PD {} ({} bytes PDU, {} bytes telegram)",
            if pdu.has_param() { "PARAM + " } else { "" },
            words,
            if pdu.is_cyclic() { "cyclic" } else { "acyclic" },
            pdu.pdu_len(),
            pdu.telegram_len()
        ),
    );
    let len = pdu.telegram_len();
    if bytes.len() < len {
        return Explained {
            direction,
            fields,
            error: Some(format!(
                "truncated: PDU type needs {len} bytes, {} given",
                bytes.len()
            )),
            len: bytes.len(),
            address: Some(adr),
            pdu_type: Some(pdu),
            ..Explained::default()
        };
    }
    let mut at = 3;
    let mut channel = None;
    if pdu.has_param() {
        let mut raw = [0u8; 8];
        if let Some(src) = bytes.get(at..at + 8) {
            raw.copy_from_slice(src);
        }
        let p = ParamChannel::from_bytes(raw);
        explain_param(&p, direction == Some("response"), at, &raw, &mut push);
        channel = Some(p);
        at += 8;
    }
    let mut pd = Vec::with_capacity(words);
    let is_request = direction == Some("request");
    for w in 0..words {
        let b = bytes.get(at..at + 2).unwrap_or(&[0, 0]);
        let v = u16::from_be_bytes([
            b.first().copied().unwrap_or(0),
            b.get(1).copied().unwrap_or(0),
        ]);
        pd.push(v);
        let name = format!("{}{}", if is_request { "PO" } else { "PI" }, w + 1);
        push(
            at,
            b,
            &name,
            format!("0x{v:04X} = {v} ({})", pd_hint(is_request, w, v)),
        );
        at += 2;
    }
    let got = bytes.get(at).copied().unwrap_or(0);
    let expected = bcc(bytes.get(..at).unwrap_or(&[]));
    if got == expected {
        push(
            at,
            &[got],
            "BCC",
            "block check character: correct (XOR of all bytes before it)".into(),
        );
    } else {
        push(
            at,
            &[got],
            "BCC",
            format!("block check character: WRONG, expected 0x{expected:02X}"),
        );
        error.get_or_insert(format!(
            "BCC mismatch: expected 0x{expected:02X}, got 0x{got:02X}"
        ));
    }
    Explained {
        direction,
        address: Some(adr),
        pdu_type: Some(pdu),
        index: channel.map(|p| p.index),
        service: channel
            .and_then(|p| p.management.service())
            .map(Service::name),
        raw: channel
            .filter(|p| carries_value(p, direction == Some("response")))
            .map(|p| raw_value(p.index, p.data)),
        return_code: channel
            .filter(|p| p.management.is_error())
            .map(|p| ReturnCode::from_data(p.data)),
        words: pd,
        fields,
        error,
        len,
        ..Explained::default()
    }
}

/// Whether the parameter channel's data are a value of its parameter: a write (request and
/// answer), the answer to a read or to a read of the minimum, maximum or default; not a read
/// request (its data are 0), a scale or attribute answer, or an error (a return code).
pub(crate) fn carries_value(p: &ParamChannel, response: bool) -> bool {
    if p.management.is_error() {
        return false;
    }
    match p.management.service() {
        Some(Service::Write | Service::WriteVolatile) => true,
        Some(
            Service::Read | Service::ReadMinimum | Service::ReadMaximum | Service::ReadDefault,
        ) => response,
        _ => false,
    }
}

/// A return code as JSON: `{error_class, error_code, additional_code}`.
pub(crate) fn return_code_json(rc: &ReturnCode) -> Value {
    json!({"error_class": rc.error_class, "error_code": rc.error_code,
           "additional_code": rc.additional_code})
}

/// A return code in words: `error class 8, error code 0, additional code 0x0010: …`.
pub(crate) fn return_code_text(rc: &ReturnCode) -> String {
    format!(
        "error class {}, error code {}, additional code 0x{:04X}: {}",
        rc.error_class,
        rc.error_code,
        rc.additional_code,
        rc.describe()
    )
}

/// The channel's data as the parameter's raw value: unsigned where the parameter's range
/// starts at zero or above, else signed (as `read` reports it).
pub(crate) fn raw_value(index: u16, data: u32) -> i64 {
    match sew::by_index(index).map(|q| q.wire_range()) {
        Some((lo, _)) if lo >= 0 => i64::from(data),
        _ => i64::from(data as i32),
    }
}

/// The default process-data meaning of P870–P875 (factory settings), as a hint.
pub(crate) fn pd_hint(request: bool, word: usize, v: u16) -> String {
    match (request, word) {
        (true, 0) => format!("control word 1 by default (P870){}", control_word_hint(v)),
        (true, 1) => format!(
            "speed setpoint by default (P871): {} 1/min",
            trim_float(sew::speed_from_word(v), 1)
        ),
        (true, 2) => "no function by default (P872)".to_owned(),
        (false, 0) => format!("status word 1 by default (P873){}", status_word_hint(v)),
        (false, 1) => format!(
            "actual speed by default (P874): {} 1/min",
            trim_float(sew::speed_from_word(v), 1)
        ),
        (false, 2) => format!(
            "output current by default (P875): {} % In",
            trim_float(f64::from(v as i16) * 0.1, 1)
        ),
        _ => String::new(),
    }
}

fn control_word_hint(v: u16) -> String {
    format!(": {}", ControlWord1::from_bits(v).command().name())
}

fn status_word_hint(v: u16) -> String {
    let s = StatusWord1::from_bits(v).to_string();
    if s.is_empty() { s } else { format!(": {s}") }
}

pub(crate) fn explain_param(
    p: &ParamChannel,
    response: bool,
    at: usize,
    raw: &[u8; 8],
    push: &mut impl FnMut(usize, &[u8], &str, String),
) {
    let m = p.management;
    let service = m.service().map_or_else(
        || format!("undefined service {}", m.service_code()),
        |s| s.name().to_owned(),
    );
    push(
        at,
        &raw[..1],
        "management",
        format!(
            "service {service}, data length {} byte{}, handshake {}, status {}",
            m.data_length().bytes(),
            if m.data_length().bytes() == 1 {
                ""
            } else {
                "s"
            },
            u8::from(m.handshake()),
            if m.is_error() { "ERROR" } else { "ok" }
        ),
    );
    push(
        at + 1,
        &raw[1..2],
        "subindex",
        format!("{} (reserved)", p.subindex),
    );
    let param = sew::by_index(p.index);
    let name = param.map_or_else(
        || "not in the MOVIDRIVE table".to_owned(),
        |q| format!("{} {} / {}", q.menu_label(), q.name_de(), q.name_en()),
    );
    push(at + 2, &raw[2..4], "index", format!("{} = {name}", p.index));
    let data_meaning = if m.is_error() {
        format!(
            "return code: {}",
            return_code_text(&ReturnCode::from_data(p.data))
        )
    } else {
        match (m.service(), param) {
            (Some(Service::ReadScale), _) if response => {
                let s = p.scale().ok();
                s.map_or_else(String::new, |s| {
                    format!(
                        "size index {}, conversion index {}",
                        s.size_index, s.conversion_index
                    )
                })
            }
            (Some(Service::ReadAttribute), _) if response => {
                let a = p.attribute().ok();
                a.map_or_else(String::new, |a| {
                    format!(
                        "next index {}, attributes 0x{:04X}",
                        a.next_index, a.attributes
                    )
                })
            }
            (
                Some(
                    Service::Read
                    | Service::ReadMinimum
                    | Service::ReadMaximum
                    | Service::ReadDefault,
                ),
                Some(q),
            ) if response => {
                format!(
                    "{} = {}",
                    p.data as i32,
                    physical_text(q, i64::from(p.data as i32))
                )
            }
            (Some(Service::Write | Service::WriteVolatile), Some(q)) => {
                format!(
                    "{} = {}",
                    p.data as i32,
                    physical_text(q, i64::from(p.data as i32))
                )
            }
            _ => format!("{} (0x{:08X})", p.data, p.data),
        }
    };
    push(at + 4, &raw[4..8], "data", data_meaning);
}

/// The name of a PDU type: `PARAM+0PD acyclic`, `3PD cyclic`.
pub fn pdu_name(pdu: PduType) -> String {
    format!(
        "{}{}PD {}",
        if pdu.has_param() { "PARAM+" } else { "" },
        pdu.pd_words(),
        if pdu.is_cyclic() { "cyclic" } else { "acyclic" }
    )
}

/// One explained telegram in the common shape of every decoder ([`crate::shape`]); `line` is
/// its first byte's input line, if it came from a file or stdin. MOVILINK's own keys:
/// `pdu_type` (`0x86`), `service` (`read`, …) and `return_code` (`{error_class, error_code,
/// additional_code}` of an error answer).
pub fn telegram(e: &Explained, line: Option<usize>) -> Telegram {
    let mut t = Telegram::new("movilink");
    t.offset = Some(e.offset);
    t.line = line;
    t.length = e.len;
    t.bytes = e.bytes.clone();
    t.error = e.error.clone();
    t.direction = e.direction;
    t.kind = e.pdu_type.map(pdu_name);
    t.address = e.address.map(i64::from);
    t.param = e
        .index
        .map(|i| (target(drive_profile::Family::Movidrive, i, 0), e.raw));
    t.refusal = e.return_code.as_ref().map(return_code_text);
    t.process_data = e.words.clone();
    t.fields = e.fields.clone();
    t.extra(
        "pdu_type",
        json!(e.pdu_type.map(|t| format!("0x{:02X}", t.raw()))),
    )
    .extra("service", json!(e.service))
    .extra(
        "return_code",
        json!(e.return_code.as_ref().map(return_code_json)),
    )
}

/// One item of a split capture in the common shape: a telegram, or `"type": "skipped"` for
/// bytes that start none.
pub fn item_telegram(item: &Item, capture: &Capture) -> Telegram {
    let line = capture.line_of(item.offset());
    match item {
        Item::Telegram(e) => telegram(e, line),
        Item::Unrecognised {
            offset,
            bytes,
            reason,
        } => {
            let mut t = Telegram::skipped("movilink", Some(*offset), bytes, reason.clone());
            t.line = line;
            t
        }
    }
}

/// Where an item starts, for the text output: `offset 12` or `offset 12 (line 3)`.
fn place(offset: usize, line: Option<usize>) -> String {
    match line {
        Some(l) => format!("offset {offset} (line {l})"),
        None => format!("offset {offset}"),
    }
}

/// The text lines of one item of a split capture.
pub fn item_text(item: &Item, capture: &Capture) -> String {
    let at = place(item.offset(), capture.line_of(item.offset()));
    match item {
        Item::Telegram(e) => {
            let mut out = format!(
                "{} telegram at {at}, {} bytes: {}\n",
                e.direction.unwrap_or("unrecognised"),
                e.len,
                e.error
                    .as_deref()
                    .map_or_else(|| "valid".to_owned(), |er| format!("INVALID ({er})"))
            );
            for f in &e.fields {
                out.push_str(&format!(
                    "  {:>3}  {:<12} {:<11} {}\n",
                    f.offset, f.bytes, f.name, f.text
                ));
            }
            out
        }
        Item::Unrecognised { bytes, reason, .. } => format!(
            "skipped {} byte{} at {at}: {} ({reason})\n",
            bytes.len(),
            if bytes.len() == 1 { "" } else { "s" },
            hex(bytes)
        ),
    }
}

/// Split `capture` ([`split`]) and explain every item as text and in the common shape.
pub fn decode(capture: &Capture) -> Decoded {
    Decoded::of(split(capture).iter().map(|item| Entry {
        telegram: item_telegram(item, capture),
        text: item_text(item, capture),
    }))
}

#[cfg(test)]
mod tests;
