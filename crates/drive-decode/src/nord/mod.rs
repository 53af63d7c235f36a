//! NORD CTT2 (AS-i) and USS (RS-485): explain captured telegrams field by field.
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
//!   the master's unless [`UssLayout::drive_first`], and a broadcast gets no answer. The
//!   net data are [`UssLayout::pkw`] PKW words and the rest PZD words ([`UssLayout::pzd`]
//!   checks the number).
//!
//! The walk does not stop at the first error: a message is explained as far as its bytes go,
//! with the problem named.

use drive_profile::nord;
use serde_json::json;

use crate::input::Capture;
use crate::shape::{Field, Telegram, target};
use crate::{Decoded, Entry};

mod ctt2;
mod pkw;
mod uss;

pub use ctt2::split_ctt2;
pub use pkw::state_text;
pub use uss::split_uss;

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

/// How a USS capture is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UssLayout {
    /// PKW words (0, 3 or 4).
    pub pkw: u8,
    /// PZD words, if given (else the rest of the net data).
    pub pzd: Option<u8>,
    /// The first telegram is the drive's (else the master's).
    pub drive_first: bool,
    /// How a front end names the PKW and PZD settings in a telegram's error (the command
    /// line's `--pkw`), or nothing.
    pub names: SettingNames,
}

/// A front end's names of a USS layout's settings, for the errors that point at them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SettingNames {
    /// The number of PKW words.
    pub pkw: Option<&'static str>,
    /// The number of PZD words.
    pub pzd: Option<&'static str>,
}

impl SettingNames {
    /// ` (NAME)`, or nothing.
    fn named(name: Option<&'static str>) -> String {
        name.map_or_else(String::new, |n| format!(" ({n})"))
    }
}

/// One message in the common shape of every decoder ([`crate::shape`]): the PKW part's
/// parameter with its IND word as `read --json` names it (`label` `P102 set 3`, `selector`
/// `{"set": 3, "ind": "0x0200"}`), `direction` `request` for the master's telegrams and
/// `response` for the drive's, `address` the USS address or a CTT2 channel's drive address.
/// NORD's own keys: `ak` (order or response ID), `ind` (the whole IND word, bits 0–7 too),
/// `elements` (an AK 6 answer's count), `pwe_error` (an AK 7 answer's number); CTT2 also
/// `code` (the message code), `ctt2_index` (the object or channel) and `ctt2_error`.
pub fn telegram(m: &Message, protocol: &'static str, line: Option<usize>) -> Telegram {
    if m.direction == "unrecognised" {
        let why = m.error.clone().unwrap_or_else(|| m.kind.clone());
        let mut t = Telegram::skipped(protocol, Some(m.offset), &m.bytes, why);
        t.line = line;
        return t;
    }
    let mut t = Telegram::new(protocol);
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
        (target(drive_profile::Family::Nord, pnu, ind), m.raw)
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
    t
}

/// The text lines of one message.
pub fn message_text(m: &Message) -> String {
    let mut out = format!(
        "{} {} at offset {}, {} bytes: {}\n",
        m.direction,
        m.kind,
        m.offset,
        m.len,
        m.error
            .as_deref()
            .map_or_else(|| "valid".to_owned(), |e| format!("INVALID ({e})"))
    );
    for f in &m.fields {
        out.push_str(&format!(
            "  {:>4}  {:<24} {:<12} {}\n",
            f.offset, f.bytes, f.name, f.text
        ));
    }
    for n in &m.notes {
        out.push_str(&format!("  note: {n}\n"));
    }
    out
}

fn decoded(messages: &[Message], capture: &Capture, protocol: &'static str) -> Decoded {
    Decoded::of(messages.iter().map(|m| Entry {
        telegram: telegram(m, protocol, capture.line_of(m.offset)),
        text: message_text(m),
    }))
}

/// A CTT2 capture split into messages ([`split_ctt2`]) and explained.
pub fn decode_ctt2(capture: &Capture) -> Decoded {
    decoded(&split_ctt2(capture), capture, "ctt2")
}

/// A USS capture split into telegrams ([`split_uss`]) with `layout` and explained.
pub fn decode_uss(capture: &Capture, layout: UssLayout) -> Decoded {
    decoded(&split_uss(capture, layout), capture, "uss")
}

#[cfg(test)]
mod tests;
