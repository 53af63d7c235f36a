//! `drivectl decode movilink <HEX...>`: explain a captured telegram field by field.
//!
//! The walk does not stop at the first error: a telegram with a wrong BCC or an unknown PDU type
//! is still explained as far as its bytes go, with the error named where it occurs.

use crate::error::{CliError, Result};
use crate::tool::output::{physical_text, trim_float};
use drive_profile::sew::{ControlWord1, StatusWord1};
use drive_profile::{ParamMeta, sew};
use movilink::codec::bcc;
use movilink::{Address, ParamChannel, PduType, ReturnCode, SD1, SD2, Service};
use serde_json::{Value, json};

/// One explained field of a telegram.
#[derive(Debug, Clone)]
pub struct Field {
    /// Offset of the first byte in the telegram.
    pub offset: usize,
    /// The bytes, as hex.
    pub bytes: String,
    /// Field name (SD1, ADR, TYP, management, …).
    pub name: String,
    /// What the bytes mean.
    pub meaning: String,
}

/// The explanation of one telegram of a capture.
#[derive(Debug, Clone)]
pub struct Explained {
    /// Request (SD1) or response (SD2), if the start character says so.
    pub direction: Option<&'static str>,
    /// The fields in order.
    pub fields: Vec<Field>,
    /// The first problem found, if any.
    pub error: Option<String>,
    /// Bytes consumed from the capture.
    pub len: usize,
}

/// Parse hex arguments: `02 01 85`, `020185`, `0x02,0x01` and mixtures.
pub fn parse_hex(args: &[String]) -> Result<Vec<u8>> {
    let mut digits = String::new();
    for a in args {
        for part in a.split([',', ' ', ':', '-']) {
            let p = part.trim();
            let p = p
                .strip_prefix("0x")
                .or_else(|| p.strip_prefix("0X"))
                .unwrap_or(p);
            if p.len() % 2 == 1 {
                digits.push('0');
            }
            digits.push_str(p);
        }
    }
    if let Some(bad) = digits.chars().find(|c| !c.is_ascii_hexdigit()) {
        return Err(CliError::usage(format!(
            "`{bad}` is not a hex digit; give bytes like `02 01 86` or `020186`"
        )));
    }
    let bytes: Vec<u8> = digits
        .as_bytes()
        .chunks(2)
        .filter_map(|pair| std::str::from_utf8(pair).ok())
        .filter_map(|s| u8::from_str_radix(s, 16).ok())
        .collect();
    if bytes.is_empty() {
        return Err(CliError::usage(
            "no bytes given; give a telegram like `02 01 86 …`",
        ));
    }
    Ok(bytes)
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Explain every telegram in `capture`.
pub fn explain_all(capture: &[u8]) -> Vec<Explained> {
    let mut out = Vec::new();
    let mut rest = capture;
    let mut offset = 0;
    while !rest.is_empty() {
        let e = explain(rest);
        let used = e.len.max(1);
        let mut e = e;
        for f in &mut e.fields {
            f.offset += offset;
        }
        out.push(e);
        offset += used;
        rest = rest.get(used..).unwrap_or(&[]);
    }
    out
}

/// Explain the telegram at the start of `bytes`.
pub fn explain(bytes: &[u8]) -> Explained {
    let mut fields = Vec::new();
    let mut push = |offset: usize, b: &[u8], name: &str, meaning: String| {
        fields.push(Field {
            offset,
            bytes: hex(b),
            name: name.to_owned(),
            meaning,
        });
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
            };
        }
    }
    let Some(&adr) = bytes.get(1) else {
        return Explained {
            direction,
            fields,
            error: Some("truncated after the start character".into()),
            len: bytes.len(),
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
        };
    };
    let Some(pdu) = PduType::new(typ) else {
        push(2, &[typ], "TYP", "unknown PDU type".into());
        return Explained {
            direction,
            fields,
            error: Some(format!("unknown PDU type 0x{typ:02X}")),
            len: 3,
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
        };
    }
    let mut at = 3;
    if pdu.has_param() {
        let mut raw = [0u8; 8];
        if let Some(src) = bytes.get(at..at + 8) {
            raw.copy_from_slice(src);
        }
        let p = ParamChannel::from_bytes(raw);
        explain_param(&p, direction == Some("response"), at, &raw, &mut push);
        at += 8;
    }
    let is_request = direction == Some("request");
    for w in 0..words {
        let b = bytes.get(at..at + 2).unwrap_or(&[0, 0]);
        let v = u16::from_be_bytes([
            b.first().copied().unwrap_or(0),
            b.get(1).copied().unwrap_or(0),
        ]);
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
        fields,
        error,
        len,
    }
}

/// The default process-data meaning of P870–P875 (factory settings), as a hint.
fn pd_hint(request: bool, word: usize, v: u16) -> String {
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

fn explain_param(
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
        let rc = ReturnCode::from_data(p.data);
        format!(
            "return code: error class {}, error code {}, additional code 0x{:04X}: {}",
            rc.error_class,
            rc.error_code,
            rc.additional_code,
            rc.describe()
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

/// JSON of one explained telegram.
pub fn to_json(e: &Explained) -> Value {
    json!({
        "direction": e.direction,
        "valid": e.error.is_none(),
        "error": e.error,
        "length": e.len,
        "fields": e.fields.iter().map(|f| json!({
            "offset": f.offset, "bytes": f.bytes, "field": f.name, "meaning": f.meaning,
        })).collect::<Vec<_>>(),
    })
}

/// Run `drivectl decode movilink`.
pub fn run(hex_args: &[String], json: bool) -> Result<()> {
    let capture = parse_hex(hex_args)?;
    let all = explain_all(&capture);
    let mut out = String::new();
    for e in &all {
        if json {
            out.push_str(&to_json(e).to_string());
            out.push('\n');
            continue;
        }
        out.push_str(&format!(
            "{} telegram, {} bytes: {}\n",
            e.direction.unwrap_or("unrecognised"),
            e.len,
            e.error
                .as_deref()
                .map_or_else(|| "valid".to_owned(), |er| format!("INVALID ({er})"))
        ));
        for f in &e.fields {
            out.push_str(&format!(
                "  {:>3}  {:<12} {:<11} {}\n",
                f.offset, f.bytes, f.name, f.meaning
            ));
        }
    }
    out!("{out}")?;
    if all.iter().any(|e| e.error.is_some()) {
        return Err(CliError::failed(
            "the capture holds an invalid telegram (see above)",
        ));
    }
    Ok(())
}
