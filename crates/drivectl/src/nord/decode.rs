//! `drivectl decode ctt2|uss <HEX...>`: explain captured NORD telegrams field by field.
//!
//! Both carry the same USS data (BU 0255 section 4.6: the parameter channel PKW with PKE, IND,
//! PWE1, PWE2; section 4.5: process data, control/status word and up to three setpoints/actual
//! values), which is explained with the parameter table (P102 1000 = 10.00 s, IND 0200h =
//! parameter set 3, P543 IND 0100h = element [-02]).
//!
//! * CTT2 (section 4.3): the first byte is the message code, so requests (16, 18, 19, 29) and
//!   answers (80, 82, 83, 93; 144, 146, 147, 157 and the misprinted 177) split a stream by
//!   their lengths. An answer's data are read as the request before it in the capture asked
//!   (ID object, diagnosis object, PZD channel or PKW channel).
//! * USS: STX 02h, LGE, ADR, the net data and the BCC (XOR of all bytes before it). A telegram
//!   does not say whether the master or the drive sent it: telegrams alternate, the first is
//!   the master's (`--start drive` turns that round), and a broadcast gets no answer. The
//!   net data are `--pkw` PKW words and the rest PZD words (`--pzd` checks the number).
//!
//! The walk does not stop at the first error: a message is explained as far as its bytes go,
//! with the problem named.

use drive_profile::nord::{self, ControlWord, StatusWord};
use serde_json::{Value, json};

use crate::decode::{Capture, parse_hex, read_capture};
use crate::error::{CliError, Result};
use crate::tool::client::{Target, nord_sub_parts};
use crate::tool::output::{physical_text, trim_float};

pub use crate::decode::Field;

/// One explained message (CTT2) or telegram (USS).
#[derive(Debug, Clone, Default)]
pub struct Message {
    /// Offset of the first byte in the capture.
    pub offset: usize,
    /// Bytes.
    pub len: usize,
    /// `request`/`response` (CTT2), `master`/`drive` (USS), or `unrecognised`.
    pub direction: &'static str,
    /// What it is (`NORD write request`, `USS telegram`).
    pub kind: String,
    /// CTT2: the message code.
    pub code: Option<u8>,
    /// CTT2: the index (object or channel).
    pub index: Option<u8>,
    /// USS: the ADR byte's address.
    pub address: Option<u8>,
    /// The parameter (PNU) of a PKW part.
    pub parameter: Option<u16>,
    /// The IND word of a PKW part.
    pub ind: Option<u16>,
    /// The AK of a PKW part.
    pub ak: Option<u8>,
    /// The parameter value a PKW part carries (written, or read back).
    pub raw: Option<i64>,
    /// The number of array elements an AK 6 answer carries.
    pub count: Option<u16>,
    /// The error number (PWE2) of an AK 7 answer.
    pub pwe_error: Option<u16>,
    /// A CTT2 negative answer's error code.
    pub ctt2_error: Option<u8>,
    /// The drive's negative answer in words (AK 7 with its error, a CTT2 error code).
    pub refusal: Option<String>,
    /// The message's bytes.
    pub bytes: Vec<u8>,
    /// The parameter value in the table's unit, where the PKW part carries one (a write order,
    /// a value answer).
    pub value: Option<f64>,
    /// The process data words (control/status word first).
    pub words: Vec<u16>,
    /// The fields in order.
    pub fields: Vec<Field>,
    /// The first problem, if any.
    pub error: Option<String>,
    /// Notes that are not errors (an erratum of the manual recognised, bits that carry no
    /// information but are set).
    pub notes: Vec<String>,
}

impl Message {
    fn push(&mut self, bytes: &[u8], at: usize, len: usize, name: &str, meaning: String) {
        let b = bytes.get(at..(at + len).min(bytes.len())).unwrap_or(&[]);
        self.fields
            .push(Field::new(self.offset + at, b, name, meaning));
    }

    fn fail(&mut self, why: String) {
        if self.error.is_none() {
            self.error = Some(why);
        }
    }
}

fn be16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

/// The table's name of a PNU, or that the table does not have it.
fn param_name(pnu: u16) -> String {
    match nord::by_index(pnu) {
        Some(p) => format!("P{:03} {}", p.number, p.name_en),
        None => format!("P{pnu} (not in the NORD table)"),
    }
}

/// Explain a parameter channel of 3 or 4 words at `at`: an order (`order`) or an answer.
fn explain_pkw(m: &mut Message, bytes: &[u8], at: usize, words: u8, order: bool) {
    let (Some(pke), Some(ind)) = (be16(bytes, at), be16(bytes, at + 2)) else {
        m.fail("the parameter channel is cut short".to_owned());
        return;
    };
    let ak = (pke >> 12) as u8;
    let pnu = pke & 0x07FF;
    let (pwe1, pwe2) = if words == 3 {
        let w = be16(bytes, at + 4);
        // The 3-word PKW has no PWE1: the sign of the value word.
        (w.map(|v| if v & 0x8000 != 0 { 0xFFFF } else { 0 }), w)
    } else {
        (be16(bytes, at + 4), be16(bytes, at + 6))
    };
    m.parameter = Some(pnu);
    m.ind = Some(ind);
    m.ak = Some(ak);
    let ak_text = if order {
        nord::ak_request(ak)
            .map_or_else(|| format!("order ID {ak}: not defined"), |r| r.to_string())
    } else {
        nord::ak_response(ak).map_or_else(
            || format!("response ID {ak}: not defined"),
            |r| r.to_string(),
        )
    };
    let spm = if pke & 0x0800 != 0 {
        ", SPM set (spontaneous messages: not supported by the drive)"
    } else {
        ""
    };
    m.push(
        bytes,
        at,
        2,
        "PKE",
        format!("{ak_text}; PNU {pnu} = {}{spm}", param_name(pnu)),
    );
    let sub = ind & 0xFF00;
    let (element, set) = nord_sub_parts(pnu, sub);
    let mut ind_text = match (element, set) {
        (Some(e), Some(s)) => format!("element [-{e:02}], parameter set {s}"),
        (Some(e), None) => format!("element [-{e:02}] (sub-index {}, bits 8-15)", e - 1),
        (None, Some(s)) => format!("parameter set {s} (bits 8-9)"),
        (None, None) if sub == 0 => "no element or set".to_owned(),
        (None, None) => format!("sub-index {} in bits 8-15", sub >> 8),
    };
    let array_order = nord::ak_request(ak).is_some_and(|r| r.array);
    if order && element.is_some() && !array_order && matches!(ak, 1..=3 | 13 | 14) {
        ind_text.push_str(
            " — the element takes effect only with AK 6, 7, 8, 11 or 12 (section 4.6.1.2)",
        );
    }
    if ind & 0x00FF != 0 {
        ind_text.push_str(&format!(
            "; bits 0-7 = {:02X}h carry no information and should be 0",
            ind & 0xFF
        ));
        m.notes.push(format!(
            "IND {ind:04X}h has bits 0-7 set: the manual's example 5.1.3 prints IND as 00h 02h for \
             parameter set 3, which is 02h 00h (erratum E4 in docs/errata-nord.md)"
        ));
    }
    m.push(bytes, at + 2, 2, "IND", format!("{ind:04X}h: {ind_text}"));
    let target = nord::by_index(pnu).map(|p| Target {
        family: drive_profile::Family::Nord,
        index: pnu,
        sub,
        param: drive_profile::family::lookup(drive_profile::Family::Nord, &p.number.to_string()),
    });
    let word_value = |hi: u16, lo: u16| i64::from((((hi as u32) << 16) | lo as u32) as i32);
    let physical = |raw: i64| {
        target
            .and_then(|t| t.param)
            .map_or_else(String::new, |p| format!(" = {}", physical_text(p, raw)))
    };
    let (Some(pwe1), Some(pwe2)) = (pwe1, pwe2) else {
        m.fail("the parameter value is cut short".to_owned());
        return;
    };
    let value_text = if order {
        match nord::ak_request(ak).map(|r| r.kind) {
            Some(nord::AkRequestKind::Write) => {
                let raw = word_value(pwe1, pwe2);
                m.raw = Some(raw);
                m.value = target.and_then(|t| t.param).map(|p| p.to_physical(raw));
                let high_ok = matches!(pwe1, 0 | 0xFFFF)
                    || nord::ak_request(ak).and_then(|r| r.width) == Some(nord::Width::DoubleWord);
                if !high_ok {
                    m.fail(format!(
                        "a word write with PWE1 = {pwe1:04X}h (must be 0000h, or FFFFh for a \
                         negative value, section 4.6.1.3)"
                    ));
                }
                format!("value to write {raw}{}", physical(raw))
            }
            _ => "no value in this order (0)".to_owned(),
        }
    } else {
        match ak {
            0 => "no answer".to_owned(),
            1 | 4 => {
                let raw = word_value(pwe1, pwe2);
                // A word of a parameter whose range does not go below zero is unsigned.
                let raw = match target.and_then(|t| t.param).and_then(|p| p.raw_range()) {
                    Some((lo, _)) if lo >= 0 => i64::from(pwe2),
                    _ => raw,
                };
                m.raw = Some(raw);
                m.value = target.and_then(|t| t.param).map(|p| p.to_physical(raw));
                format!("value {raw}{}", physical(raw))
            }
            2 | 5 => {
                let raw = word_value(pwe1, pwe2);
                m.raw = Some(raw);
                format!("double word {raw}")
            }
            6 => {
                m.count = Some(pwe2);
                format!("{pwe2} array elements")
            }
            7 => {
                m.pwe_error = Some(pwe2);
                let text = nord::pwe_error(pwe2).map_or_else(
                    || format!("error {pwe2} (not in the manual's table)"),
                    |e| e.to_string(),
                );
                m.refusal = Some(format!("order not executable (AK 7): {text}"));
                text
            }
            _ => "undefined response".to_owned(),
        }
    };
    if words == 4 {
        m.push(bytes, at + 4, 2, "PWE1", format!("{pwe1:04X}h: high word"));
        m.push(
            bytes,
            at + 6,
            2,
            "PWE2",
            format!("{pwe2:04X}h: {value_text}"),
        );
    } else {
        m.push(
            bytes,
            at + 4,
            2,
            "PWE",
            format!("{pwe2:04X}h: {value_text} (3-word PKW: no PWE1)"),
        );
    }
}

/// The command a control word gives, where it is one of the manual's.
fn command_name(w: u16) -> Option<&'static str> {
    use nord::command::*;
    [
        (SHUTDOWN, "shutdown (Stillsetzen)"),
        (ENABLE_OPERATION, "enable operation (Betrieb freigeben)"),
        (
            SWITCH_ON,
            "switch on / disable operation (Einschalten / Betrieb sperren)",
        ),
        (DISABLE_VOLTAGE, "disable voltage (Spannung sperren)"),
        (QUICK_STOP, "quick stop (Schnellhalt)"),
        (
            FAULT_RESET,
            "fault reset, on a rising edge (Fehler quittieren)",
        ),
    ]
    .iter()
    .find(|(c, _)| c.0 == w & !ControlWord::PARAMETER_SET_MASK)
    .map(|(_, n)| *n)
}

/// Explain process data words at `at`: to the drive (control word, setpoints) or from it
/// (status word, actual values).
fn explain_pzd(m: &mut Message, bytes: &[u8], at: usize, words: usize, to_drive: bool) {
    for i in 0..words {
        let Some(w) = be16(bytes, at + 2 * i) else {
            m.fail("the process data are cut short".to_owned());
            return;
        };
        m.words.push(w);
        let (name, meaning) = match (i, to_drive) {
            (0, true) => {
                let bits: Vec<&str> = ControlWord(w).set_bits().map(|b| b.name_en).collect();
                let mut t = format!("control word {w:04X}h");
                if let Some(c) = command_name(w) {
                    t.push_str(&format!(": {c}"));
                }
                t.push_str(&format!(
                    "; parameter set {}; bits: {}",
                    ControlWord(w).parameter_set(),
                    if bits.is_empty() {
                        "none".to_owned()
                    } else {
                        bits.join(", ")
                    }
                ));
                if w & ControlWord::CONTROL_DATA_VALID.0 == 0 {
                    t.push_str(" — bit 10 clear: the drive does not evaluate these process data");
                }
                ("STW".to_owned(), t)
            }
            (0, false) => {
                let sw = StatusWord(w);
                let state = sw.state();
                let bits: Vec<&str> = sw.set_bits().map(|b| b.name_en).collect();
                (
                    "ZSW".to_owned(),
                    format!(
                        "status word {w:04X}h: {}; parameter set {}; bits: {}",
                        super::state_text(state),
                        sw.parameter_set(),
                        bits.join(", ")
                    ),
                )
            }
            (n, true) => (
                format!("SW{n}"),
                format!(
                    "setpoint {n} {w:04X}h = {} % (4000h = 100 %; P546 [-{n:02}] says what it \
                     sets)",
                    trim_float(nord::percent_from_word(w), 2)
                ),
            ),
            (n, false) => (
                format!("IW{n}"),
                format!(
                    "actual value {n} {w:04X}h = {} % (4000h = 100 %; P543 [-{n:02}] says what it \
                     is)",
                    trim_float(nord::percent_from_word(w), 2)
                ),
            ),
        };
        m.push(bytes, at + 2 * i, 2, &name, meaning);
    }
}

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

/// Split a CTT2 capture into messages (see the [module docs](self)).
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

/// How a USS capture is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UssLayout {
    /// PKW words (0, 3 or 4).
    pub pkw: u8,
    /// PZD words, if given (else the rest of the net data).
    pub pzd: Option<u8>,
    /// The first telegram is the drive's (else the master's).
    pub drive_first: bool,
}

/// Explain one USS telegram (`bytes` from STX on, as long as LGE says or the capture has).
fn explain_uss(bytes: &[u8], offset: usize, layout: UssLayout, from_master: bool) -> Message {
    let mut m = Message {
        offset,
        len: bytes.len(),
        bytes: bytes.to_vec(),
        direction: if from_master { "master" } else { "drive" },
        kind: "USS telegram".to_owned(),
        ..Message::default()
    };
    m.push(bytes, 0, 1, "STX", "02h: start of text".to_owned());
    let Some(&lge) = bytes.get(1) else {
        m.fail("no LGE".to_owned());
        return m;
    };
    let total = usize::from(lge) + 2;
    m.push(
        bytes,
        1,
        1,
        "LGE",
        format!("{lge}: ADR, net data and BCC; the telegram is {total} bytes"),
    );
    if lge < 2 {
        m.fail(format!("LGE {lge} is less than ADR + BCC"));
        return m;
    }
    if bytes.len() < total {
        m.fail(format!(
            "the telegram is cut short: LGE announces {total} bytes, the capture has {}",
            bytes.len()
        ));
    }
    let Some(&adr) = bytes.get(2) else {
        return m;
    };
    m.address = Some(adr & 0x1F);
    let mut flags = Vec::new();
    if adr & 0x20 != 0 {
        flags.push("broadcast (bit 5: every drive executes it, none answers)");
    }
    if adr & 0x40 != 0 {
        flags.push("mirror (bit 6: the drive sends it back unchanged)");
    }
    if adr & 0x80 != 0 {
        flags.push("special (bit 7)");
    }
    m.push(
        bytes,
        2,
        1,
        "ADR",
        format!(
            "{adr:02X}h: address {}{}",
            adr & 0x1F,
            if flags.is_empty() {
                String::new()
            } else {
                format!(", {}", flags.join(", "))
            }
        ),
    );
    let net = total.saturating_sub(4);
    let pkw_bytes = 2 * usize::from(layout.pkw);
    if net < pkw_bytes || (net - pkw_bytes) % 2 != 0 {
        m.fail(format!(
            "{net} bytes of net data do not hold {} PKW words and whole PZD words (--pkw)",
            layout.pkw
        ));
    } else {
        let pzd = (net - pkw_bytes) / 2;
        if let Some(want) = layout.pzd.filter(|w| usize::from(*w) != pzd) {
            m.fail(format!(
                "{pzd} PZD words where the layout has {want} (--pzd): LGE should be {}",
                2 * (usize::from(layout.pkw) + usize::from(want)) + 2
            ));
        }
        if layout.pkw > 0 {
            explain_pkw(&mut m, bytes, 3, layout.pkw, from_master);
        }
        explain_pzd(&mut m, bytes, 3 + pkw_bytes, pzd, from_master);
    }
    if bytes.len() >= total {
        let body = bytes.get(..total - 1).unwrap_or(&[]);
        let expected = body.iter().fold(0u8, |a, b| a ^ b);
        let got = bytes.get(total - 1).copied().unwrap_or(0);
        if got == expected {
            m.push(
                bytes,
                total - 1,
                1,
                "BCC",
                format!("{got:02X}h: correct (XOR of all bytes before it)"),
            );
        } else {
            m.push(
                bytes,
                total - 1,
                1,
                "BCC",
                format!("{got:02X}h: WRONG, the XOR of the bytes before it is {expected:02X}h"),
            );
            m.fail(format!("BCC {got:02X}h, expected {expected:02X}h"));
        }
    }
    m
}

/// Split a USS capture at its STX characters and LGE lengths (see the [module docs](self)).
pub fn split_uss(capture: &Capture, layout: UssLayout) -> Vec<Message> {
    let bytes = &capture.bytes;
    let mut out = Vec::new();
    let mut master = !layout.drive_first;
    let mut at = 0;
    while at < bytes.len() {
        let rest = bytes.get(at..).unwrap_or(&[]);
        if rest.first() != Some(&0x02) {
            let skip = rest.iter().position(|b| *b == 0x02).unwrap_or(rest.len());
            let mut m = Message {
                offset: at,
                len: skip,
                bytes: rest.get(..skip).unwrap_or(rest).to_vec(),
                direction: "unrecognised",
                kind: "bytes before an STX".to_owned(),
                ..Message::default()
            };
            m.push(
                rest,
                0,
                skip,
                "bytes",
                "no STX (02h): no telegram starts here".to_owned(),
            );
            m.fail("bytes that start no telegram (a USS telegram starts with STX 02h)".to_owned());
            out.push(m);
            at += skip;
            continue;
        }
        let total = rest.get(1).map_or(rest.len(), |l| usize::from(*l) + 2);
        let len = total.clamp(1, rest.len());
        let m = explain_uss(rest.get(..len).unwrap_or(rest), at, layout, master);
        // A broadcast gets no answer: the next telegram is the master's again.
        let broadcast = master && m.address.is_some() && rest.get(2).is_some_and(|a| a & 0x20 != 0);
        if !broadcast {
            master = !master;
        }
        out.push(m);
        at += len;
    }
    out
}

/// One message in the common shape of every decoder ([`crate::decode`]): the PKW part's
/// parameter with its IND word as `read --json` names it (`label` `P102 set 3`, `selector`
/// `{"set": 3, "ind": "0x0200"}`), `direction` `request` for the master's telegrams and
/// `response` for the drive's, `address` the USS address or a CTT2 channel's drive address.
/// NORD's own keys: `ak` (order or response ID), `ind` (the whole IND word, bits 0–7 too),
/// `elements` (an AK 6 answer's count), `pwe_error` (an AK 7 answer's number); CTT2 also
/// `code` (the message code), `ctt2_index` (the object or channel) and `ctt2_error`.
pub fn to_json(m: &Message, protocol: &'static str, line: Option<usize>) -> Value {
    if m.direction == "unrecognised" {
        let why = m.error.clone().unwrap_or_else(|| m.kind.clone());
        let mut t = crate::decode::Telegram::skipped(protocol, Some(m.offset), &m.bytes, why);
        t.line = line;
        return t.to_json();
    }
    let mut t = crate::decode::Telegram::new(protocol);
    t.offset = Some(m.offset);
    t.line = line;
    t.length = m.len;
    t.bytes = m.bytes.clone();
    t.error = m.error.clone();
    t.notes = m.notes.clone();
    t.direction = match m.direction {
        "master" | "request" => Some("request"),
        "drive" | "response" => Some("response"),
        _ => None,
    };
    t.kind = Some(m.kind.clone());
    t.address = m.address.map(i64::from);
    t.param = m.parameter.map(|pnu| {
        let ind = m.ind.unwrap_or(0) & 0xFF00;
        (
            crate::decode::target(drive_profile::Family::Nord, pnu, ind),
            m.raw,
        )
    });
    t.refusal = m.refusal.clone();
    t.process_data = m.words.clone();
    t.fields = m.fields.clone();
    let mut t = t
        .extra("ak", json!(m.ak))
        .extra("ind", json!(m.ind.map(|i| format!("0x{i:04X}"))))
        .extra("elements", json!(m.count))
        .extra("pwe_error", json!(m.pwe_error));
    if protocol == "ctt2" {
        t = t
            .extra("code", json!(m.code))
            .extra("ctt2_index", json!(m.index))
            .extra("ctt2_error", json!(m.ctt2_error));
    }
    t.to_json()
}

/// Run `drivectl decode ctt2` (`uss` None) or `decode uss` with its layout.
pub fn run(uss: Option<UssLayout>, args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let from_stdin = file.is_some() || matches!(args, [only] if only == "-");
    let capture = if from_stdin {
        read_capture(file.unwrap_or("-"))?
    } else {
        Capture {
            bytes: parse_hex(args)?,
            lines: Vec::new(),
        }
    };
    let (messages, protocol) = match uss {
        Some(layout) => (split_uss(&capture, layout), "uss"),
        None => (split_ctt2(&capture), "ctt2"),
    };
    let mut out = String::new();
    for m in &messages {
        if json {
            out.push_str(&to_json(m, protocol, capture.lines.get(m.offset).copied()).to_string());
            out.push('\n');
            continue;
        }
        out.push_str(&format!(
            "{} {} at offset {}, {} bytes: {}\n",
            m.direction,
            m.kind,
            m.offset,
            m.len,
            m.error
                .as_deref()
                .map_or_else(|| "valid".to_owned(), |e| format!("INVALID ({e})"))
        ));
        for f in &m.fields {
            out.push_str(&format!(
                "  {:>4}  {:<24} {:<12} {}\n",
                f.offset, f.bytes, f.name, f.text
            ));
        }
        for n in &m.notes {
            out.push_str(&format!("  note: {n}\n"));
        }
    }
    out!("{out}")?;
    let invalid = messages.iter().filter(|m| m.error.is_some()).count();
    if invalid > 0 {
        return Err(CliError::failed(format!(
            "{invalid} of {} message(s) are invalid (see above)",
            messages.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
