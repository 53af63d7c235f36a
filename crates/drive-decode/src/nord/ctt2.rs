//! CTT2 messages (section 4.3): split by their codes' lengths, an answer read as the request
//! before it asked.

use drive_profile::nord;

use super::pkw::{explain_pkw, explain_pzd};
use super::{Capture, Message};

/// What a CTT2 answer's data are: the request before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Pending {
    code: u8,
    index: u8,
    /// Bytes the answer carries (the read length, at most what the object has).
    len: u8,
}

/// The data length of an object or channel.
fn max_len(index: u8, standard: bool) -> u8 {
    if standard {
        match index {
            0 => 14,
            1 => 3,
            _ => 0,
        }
    } else {
        nord::ctt2_index(index).map_or(0, |i| i.max_len)
    }
}

/// How many bytes the CTT2 message at the start of `rest` takes; `None` when its code is no
/// CTT2 code.
fn ctt2_len(rest: &[u8], pending: Option<Pending>) -> Option<usize> {
    let code = *rest.first()?;
    let at = |i: usize| rest.get(i).copied().map(usize::from);
    Some(match code {
        16 | 18 => 3,
        19 => 3 + at(2).unwrap_or(0),
        29 => 4 + at(3).unwrap_or(0),
        83 => 1,
        144 | 146 | 147 | 157 | 177 => 2,
        80 | 82 | 93 => match pending {
            Some(p) if p.code + 0x40 == code => 1 + usize::from(p.len),
            // No request before it: the rest of the capture (or line).
            _ => rest.len(),
        },
        _ => return None,
    })
}

/// Explain one CTT2 message.
fn explain_ctt2(bytes: &[u8], offset: usize, pending: &mut Option<Pending>) -> Message {
    let mut m = Message {
        offset,
        len: bytes.len(),
        bytes: bytes.to_vec(),
        ..Message::default()
    };
    let Some(&code) = bytes.first() else {
        m.fail("empty message".to_owned());
        return m;
    };
    m.code = Some(code);
    let info = nord::ctt2_message(code);
    let printed = (code == 177).then_some(
        "177 is the manual's misprint of 157 (erratum E3): taken as the negative write/read \
         answer",
    );
    m.kind = info.map_or_else(
        || {
            if code == 177 {
                "NORD write/read response not OK (printed code 177)".to_owned()
            } else {
                format!("unknown code {code}")
            }
        },
        |i| i.name_en.to_owned(),
    );
    let role = info.map(|i| i.role);
    m.direction = match (role, code) {
        (Some(nord::Ctt2Role::Request), _) => "request",
        (Some(_), _) | (None, 177) => "response",
        _ => "unrecognised",
    };
    m.push(
        bytes,
        0,
        1,
        "code",
        format!("{code} ({code:02X}h): {}", m.kind),
    );
    if let Some(p) = printed {
        m.notes.push(p.to_owned());
    }
    match m.direction {
        "request" => {
            if let Err(e) = ctt2_uss::ctt2::Request::decode(bytes) {
                m.fail(format!(
                    "{e} (the double slave answers {})",
                    e.answer().code()
                ));
            }
            explain_ctt2_request(&mut m, bytes, code, pending);
        }
        "response" => {
            if let Err(e) = ctt2_uss::ctt2::Response::decode(bytes) {
                m.fail(e.to_string());
            }
            explain_ctt2_response(&mut m, bytes, code, pending);
        }
        _ => m.fail(format!("{code} ({code:02X}h) is no CTT2 message code")),
    }
    m
}

fn explain_ctt2_request(m: &mut Message, bytes: &[u8], code: u8, pending: &mut Option<Pending>) {
    let standard = code == 16;
    let Some(&index) = bytes.get(1) else {
        m.fail("no index".to_owned());
        return;
    };
    m.index = Some(index);
    let object = nord::ctt2_index(index)
        .filter(|i| i.standard == standard)
        .map_or_else(
            || "not implemented (error 1)".to_owned(),
            |i| i.object_en.to_owned(),
        );
    m.push(bytes, 1, 1, "index", format!("{index}: {object}"));
    let max = max_len(index, standard);
    match code {
        16 | 18 => {
            let len = bytes.get(2).copied().unwrap_or(0);
            m.push(
                bytes,
                2,
                1,
                "read length",
                format!("{len} bytes (the object has {max}; a longer read returns {max})"),
            );
            *pending = Some(Pending {
                code,
                index,
                len: len.min(max),
            });
        }
        19 => {
            let len = bytes.get(2).copied().unwrap_or(0);
            m.push(bytes, 2, 1, "write length", format!("{len} bytes"));
            explain_channel(m, bytes, 3, index, true);
            *pending = Some(Pending {
                code,
                index,
                len: 0,
            });
        }
        _ => {
            let read = bytes.get(2).copied().unwrap_or(0);
            let write = bytes.get(3).copied().unwrap_or(0);
            m.push(
                bytes,
                2,
                1,
                "read length",
                format!("{read} bytes (the channel has {max})"),
            );
            m.push(bytes, 3, 1, "write length", format!("{write} bytes"));
            explain_channel(m, bytes, 4, index, true);
            *pending = Some(Pending {
                code,
                index,
                len: read.min(max),
            });
        }
    }
}

/// The data of a channel at `at`: the drive address where the channel has one, then PZD or
/// PKW.
fn explain_channel(m: &mut Message, bytes: &[u8], at: usize, index: u8, to_drive: bool) {
    let data = bytes.get(at..).unwrap_or(&[]);
    let mut at = at;
    if matches!(index, 3 | 4) {
        match data.first() {
            Some(&a) => {
                m.address = Some(a);
                let t = if a == 1 {
                    "drive address 1 (always 1, section 4.3)".to_owned()
                } else {
                    m.fail(format!("drive address {a} (the drive is always address 1)"));
                    format!("drive address {a}: must be 1")
                };
                m.push(bytes, at, 1, "address", t);
            }
            None => {
                m.fail("no drive address".to_owned());
                return;
            }
        }
        at += 1;
    }
    let rest = bytes.len().saturating_sub(at);
    if index == 3 {
        explain_pzd(m, bytes, at, rest / 2, to_drive);
        if !rest.is_multiple_of(2) {
            m.fail("process data of half a word".to_owned());
        }
    } else if rest >= 8 {
        explain_pkw(m, bytes, at, 4, to_drive);
    } else if rest > 0 {
        m.push(
            bytes,
            at,
            rest,
            "PKW",
            "incomplete parameter channel".to_owned(),
        );
        m.fail(format!("a parameter channel of {rest} bytes (must be 8)"));
    }
}

fn explain_ctt2_response(m: &mut Message, bytes: &[u8], code: u8, pending: &mut Option<Pending>) {
    let asked = pending.take();
    if matches!(code, 144 | 146 | 147 | 157 | 177) {
        let e = bytes.get(1).copied().unwrap_or(0);
        let t = nord::ctt2_error(e).map_or_else(
            || format!("{e}: not in the manual's table"),
            |x| x.to_string(),
        );
        m.ctt2_error = Some(e);
        m.refusal = Some(format!("the double slave's error code {t}"));
        m.push(bytes, 1, 1, "error code", t);
        return;
    }
    if code == 83 {
        m.notes.push(
            "a write's OK says nothing about the parameter order: read the PKW channel back \
             (section 4.3.3)"
                .to_owned(),
        );
        return;
    }
    let data_len = bytes.len().saturating_sub(1);
    let Some(p) = asked.filter(|p| p.code + 0x40 == code) else {
        m.push(
            bytes,
            1,
            data_len,
            "data",
            "no request before it in the capture: what the data are is not known".to_owned(),
        );
        return;
    };
    m.index = Some(p.index);
    match (code, p.index) {
        (80, 0) => {
            let names = [
                "manufacturer ID, high byte",
                "manufacturer ID, low byte",
                "device ID, high byte",
                "device ID, low byte",
                "I/O configuration of the cyclic data",
                "AS-i mode",
                "AS-i interface firmware version",
                "drive firmware version",
                "drive firmware revision",
                "drive power, high byte",
                "drive power, low byte",
                "drive voltage range",
                "configuration level, high byte",
                "configuration level, low byte",
            ];
            for (i, n) in names.iter().enumerate().take(data_len) {
                let v = bytes.get(1 + i).copied().unwrap_or(0);
                m.push(
                    bytes,
                    1 + i,
                    1,
                    &format!("ID byte {}", i + 1),
                    format!("{v}: {n}"),
                );
            }
        }
        (80, _) => {
            let v = |i: usize| bytes.get(i).copied();
            if let Some(c) = v(1) {
                let t = match c {
                    0 => "0: no fault".to_owned(),
                    255 => "255: fault".to_owned(),
                    x => format!("{x}: not a code of the manual (0 or 255)"),
                };
                m.push(bytes, 1, 1, "diagnosis code", t);
            }
            if let Some(f) = v(2) {
                m.push(
                    bytes,
                    2,
                    1,
                    "fault number",
                    format!("{f}: the drive's fault number"),
                );
            }
            if let Some(t) = v(3) {
                m.push(
                    bytes,
                    3,
                    1,
                    "temperature",
                    format!("{t} °C: microcontroller"),
                );
            }
        }
        (_, 3) => explain_channel(m, bytes, 1, 3, false),
        (_, index) => explain_channel(m, bytes, 1, index, false),
    }
}

/// Split a CTT2 capture into messages (see the [module docs](super)).
pub fn split_ctt2(capture: &Capture) -> Vec<Message> {
    let bytes = &capture.bytes;
    let mut out = Vec::new();
    let mut pending = None;
    let mut at = 0;
    while at < bytes.len() {
        let rest = bytes.get(at..).unwrap_or(&[]);
        // A message ends at its input line's end at the latest.
        let line_end = capture.lines.get(at).map_or(bytes.len(), |l| {
            at + capture
                .lines
                .iter()
                .skip(at)
                .take_while(|x| *x == l)
                .count()
        }) - at;
        let Some(len) = ctt2_len(rest, pending) else {
            // Bytes that start no message: up to the next code or the line's end.
            let skip = rest
                .iter()
                .skip(1)
                .take(line_end.saturating_sub(1))
                .position(|b| nord::ctt2_message(*b).is_some() || *b == 177)
                .map_or(line_end.max(1), |p| p + 1);
            let mut m = Message {
                offset: at,
                len: skip,
                bytes: rest.get(..skip).unwrap_or(rest).to_vec(),
                direction: "unrecognised",
                kind: "bytes that start no CTT2 message".to_owned(),
                ..Message::default()
            };
            m.push(rest, 0, skip, "bytes", "no CTT2 message code".to_owned());
            m.fail(format!(
                "{:02X}h is no CTT2 message code (16, 18, 19, 29 or an answer code)",
                rest.first().copied().unwrap_or(0)
            ));
            out.push(m);
            at += skip;
            continue;
        };
        let len = len.clamp(1, line_end.max(1));
        let m = explain_ctt2(rest.get(..len).unwrap_or(rest), at, &mut pending);
        out.push(m);
        at += len;
    }
    out
}
