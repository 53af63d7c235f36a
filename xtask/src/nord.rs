//! Generator for the NORD tables (NORDAC LINK, BU 0255: CTT2 over AS-i carrying USS PKW/PZD).
//!
//! Inputs in `crates/drive-profile/data/nord/`:
//!
//! | file | contents |
//! |---|---|
//! | `nord_control_word.csv`, `nord_status_word.csv` | the 16 bits of each word |
//! | `nord_states.csv`, `nord_transitions.csv` | the state machine (section 4.5.3) |
//! | `nord_ak_requests.csv`, `nord_ak_responses.csv`, `nord_pwe_errors.csv` | USS PKW codes |
//! | `nord_ctt2_messages.csv`, `nord_ctt2_indices.csv`, `nord_ctt2_errors.csv`, `nord_ctt2_objects.csv` | CTT2 |
//! | `nord_parameters.csv`, `nord_param_arrays.csv`, `nord_param_values.csv` | parameters |
//!
//! Every check reports `file:line: reason` through [`Row::err`].

use crate::render::{header, lit, opt};
use crate::table::{Row, Table};
use crate::{Error, Output, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let cw = read_bits(&dir.join("nord_control_word.csv"), true)?;
    let sw = read_bits(&dir.join("nord_status_word.csv"), false)?;
    let states = read_states(&dir.join("nord_states.csv"))?;
    let transitions = read_transitions(&dir.join("nord_transitions.csv"), &states)?;
    let responses = read_ak_responses(&dir.join("nord_ak_responses.csv"))?;
    let requests = read_ak_requests(&dir.join("nord_ak_requests.csv"), &responses)?;
    let pwe = read_pwe_errors(&dir.join("nord_pwe_errors.csv"))?;
    let messages = read_ctt2_messages(&dir.join("nord_ctt2_messages.csv"))?;
    let indices = read_ctt2_indices(&dir.join("nord_ctt2_indices.csv"))?;
    let ctt2_errors = read_ctt2_errors(&dir.join("nord_ctt2_errors.csv"))?;
    let objects = read_ctt2_objects(&dir.join("nord_ctt2_objects.csv"), &indices)?;
    let mut params = read_params(&dir.join("nord_parameters.csv"))?;
    read_param_arrays(&dir.join("nord_param_arrays.csv"), &mut params)?;
    read_param_values(&dir.join("nord_param_values.csv"), &mut params)?;

    Ok(vec![
        Output {
            name: "nord_words.rs".into(),
            text: render_words(&cw, &sw),
        },
        Output {
            name: "nord_states.rs".into(),
            text: render_states(&states, &transitions),
        },
        Output {
            name: "nord_uss.rs".into(),
            text: render_uss(&requests, &responses, &pwe),
        },
        Output {
            name: "nord_ctt2.rs".into(),
            text: render_ctt2(&messages, &indices, &ctt2_errors, &objects),
        },
        Output {
            name: "nord_params.rs".into(),
            text: render_params(&params),
        },
    ])
}

// ---------------------------------------------------------------------------------------------
// Control and status word bits

/// One bit of the control or status word.
#[derive(Debug, Clone)]
pub struct Bit {
    bit: u8,
    key: String,
    name_de: String,
    name_en: String,
    meaning0_de: String,
    meaning0_en: String,
    meaning1_de: String,
    meaning1_en: String,
    priority0: Option<u8>,
    priority1: Option<u8>,
}

const BIT_COLS: [&str; 8] = [
    "bit",
    "key",
    "name_de",
    "name_en",
    "meaning0_de",
    "meaning0_en",
    "meaning1_de",
    "meaning1_en",
];

/// Read a control-word (`with_priority`) or status-word bit table: bits 0..15, each exactly once.
pub fn read_bits(path: &Path, with_priority: bool) -> Result<Vec<Bit>> {
    let mut cols: Vec<&str> = BIT_COLS.to_vec();
    if with_priority {
        cols.extend(["priority0", "priority1"]);
    }
    let table = Table::read(path, &cols)?;
    let mut out: Vec<Bit> = Vec::new();
    let mut keys = BTreeSet::new();
    let mut last: Option<&Row> = None;
    for row in table.rows() {
        let bit = row.int("bit")?;
        if !(0..=15).contains(&bit) {
            return Err(row.err(format!("bit {bit} is outside 0..15")));
        }
        let bit = bit as u8;
        if out.iter().any(|b| b.bit == bit) {
            return Err(row.err(format!("bit {bit} appears twice")));
        }
        let key = row.req("key")?;
        check_snake(row, "key", key)?;
        if !keys.insert(key.to_owned()) {
            return Err(row.err(format!("key `{key}` appears twice")));
        }
        let (priority0, priority1) = if with_priority {
            (priority(row, "priority0")?, priority(row, "priority1")?)
        } else {
            (None, None)
        };
        let b = Bit {
            bit,
            key: key.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            meaning0_de: row.str("meaning0_de")?.to_owned(),
            meaning0_en: row.str("meaning0_en")?.to_owned(),
            meaning1_de: row.str("meaning1_de")?.to_owned(),
            meaning1_en: row.str("meaning1_en")?.to_owned(),
            priority0,
            priority1,
        };
        pair(
            row,
            "meaning0_de",
            &b.meaning0_de,
            "meaning0_en",
            &b.meaning0_en,
        )?;
        pair(
            row,
            "meaning1_de",
            &b.meaning1_de,
            "meaning1_en",
            &b.meaning1_en,
        )?;
        out.push(b);
        last = Some(row);
    }
    if out.len() != 16 {
        let missing: Vec<String> = (0..16u8)
            .filter(|i| !out.iter().any(|b| b.bit == *i))
            .map(|i| i.to_string())
            .collect();
        let at = last.map(|r| r.err("")).map(|e| e.0).unwrap_or_default();
        return Err(Error(format!(
            "{at}the word needs all 16 bits; missing {}",
            missing.join(", ")
        )));
    }
    // Priorities of one word are ranks: each used once.
    let mut seen = BTreeMap::new();
    for (row, b) in table.rows().iter().zip(&out) {
        for p in [b.priority0, b.priority1].into_iter().flatten() {
            if let Some(other) = seen.insert(p, b.bit) {
                return Err(row.err(format!("priority {p} is used by bit {other} too")));
            }
        }
    }
    out.sort_by_key(|b| b.bit);
    Ok(out)
}

fn priority(row: &Row, col: &str) -> Result<Option<u8>> {
    match row.opt_int(col)? {
        None => Ok(None),
        Some(p) if (1..=16).contains(&p) => Ok(Some(p as u8)),
        Some(p) => Err(row.err(format!("column `{col}`: priority {p} is outside 1..16"))),
    }
}

// ---------------------------------------------------------------------------------------------
// States and transitions

/// A state with its status-word pattern.
#[derive(Debug, Clone)]
pub struct StateRow {
    letter: char,
    id: String,
    name_de: String,
    name_en: String,
    description_de: String,
    description_en: String,
    mask: u16,
    value: u16,
}

/// Parse a printed bit pattern (`0`, `1`, `X`), most significant bit first, into (mask, value).
fn pattern(row: &Row, col: &str, bits: usize) -> Result<(u16, u16)> {
    let s = row.req(col)?;
    if s.chars().count() != bits {
        return Err(row.err(format!(
            "column `{col}`: `{s}` must have {bits} characters 0, 1 or X"
        )));
    }
    let (mut mask, mut value) = (0u16, 0u16);
    for (i, c) in s.chars().enumerate() {
        let bit = 1u16 << (bits - 1 - i);
        match c {
            '0' => mask |= bit,
            '1' => {
                mask |= bit;
                value |= bit;
            }
            'X' | 'x' => {}
            other => {
                return Err(row.err(format!("column `{col}`: `{other}` is not 0, 1 or X")));
            }
        }
    }
    Ok((mask, value))
}

/// Whether two (mask, value) patterns accept a common word.
fn overlap(a: (u16, u16), b: (u16, u16)) -> bool {
    (a.1 ^ b.1) & a.0 & b.0 == 0
}

/// Read the states: unique ids and letters, status-word patterns that no word matches twice.
pub fn read_states(path: &Path) -> Result<Vec<StateRow>> {
    let table = Table::read(
        path,
        &[
            "letter",
            "id",
            "name_de",
            "name_en",
            "pattern_6_0",
            "description_de",
            "description_en",
        ],
    )?;
    let mut out: Vec<StateRow> = Vec::new();
    for row in table.rows() {
        let letter = row.req("letter")?;
        let mut chars = letter.chars();
        let letter = match (chars.next(), chars.next()) {
            (Some(c), None) if c.is_ascii_uppercase() => c,
            _ => return Err(row.err(format!("letter `{letter}` must be one capital letter"))),
        };
        let id = row.req("id")?;
        check_camel(row, "id", id)?;
        if id == "Unknown" {
            return Err(row.err("id `Unknown` is reserved for words that match no state"));
        }
        let (mask, value) = pattern(row, "pattern_6_0", 7)?;
        for other in &out {
            if other.id == id {
                return Err(row.err(format!("state `{id}` appears twice")));
            }
            if other.letter == letter {
                return Err(row.err(format!("letter {letter} appears twice")));
            }
            if overlap((mask, value), (other.mask, other.value)) {
                return Err(row.err(format!(
                    "status pattern of `{id}` overlaps `{}`: some status words would match both",
                    other.id
                )));
            }
        }
        out.push(StateRow {
            letter,
            id: id.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            description_de: row.req("description_de")?.to_owned(),
            description_en: row.req("description_en")?.to_owned(),
            mask,
            value,
        });
    }
    Ok(out)
}

/// One state transition.
#[derive(Debug, Clone)]
pub struct TransitionRow {
    id: String,
    from: Option<String>,
    to: String,
    trigger: &'static str,
    command_de: String,
    command_en: String,
    mask: u16,
    value: u16,
    edge_bit: Option<u8>,
    source: String,
}

/// Read the transitions: known states, triggers that fit their columns, and command patterns
/// that never let one control word trigger two transitions out of the same state.
pub fn read_transitions(path: &Path, states: &[StateRow]) -> Result<Vec<TransitionRow>> {
    let table = Table::read(
        path,
        &[
            "id",
            "from",
            "to",
            "trigger",
            "command_de",
            "command_en",
            "pattern_7_0",
            "edge_bit",
            "source",
        ],
    )?;
    let known = |row: &Row, col: &str| -> Result<String> {
        let s = row.req(col)?;
        if states.iter().any(|st| st.id == s) {
            Ok(s.to_owned())
        } else {
            Err(row.err(format!("column `{col}`: unknown state `{s}`")))
        }
    };
    let mut out: Vec<TransitionRow> = Vec::new();
    for row in table.rows() {
        let id = row.req("id")?;
        if out.iter().any(|t| t.id == id) {
            return Err(row.err(format!("transition `{id}` appears twice")));
        }
        let from = if row.req("from")? == "*" {
            None
        } else {
            Some(known(row, "from")?)
        };
        let to = known(row, "to")?;
        let trigger = match row.req("trigger")? {
            "command" => "Command",
            "rising_edge" => "RisingEdge",
            "automatic" => "Automatic",
            "fault_event" => "FaultEvent",
            other => {
                return Err(row.err(format!(
                    "trigger `{other}` is not command, rising_edge, automatic or fault_event"
                )));
            }
        };
        let has_pattern = !row.str("pattern_7_0")?.is_empty();
        let edge_bit = row.opt_int("edge_bit")?;
        let (mask, value) = if has_pattern {
            pattern(row, "pattern_7_0", 8)?
        } else {
            (0, 0)
        };
        match trigger {
            "Command" => {
                if !has_pattern || mask == 0 {
                    return Err(row.err("a command transition needs a control-word pattern"));
                }
                if edge_bit.is_some() {
                    return Err(row.err("a command transition has no edge_bit"));
                }
            }
            "RisingEdge" => {
                if has_pattern {
                    return Err(row.err("a rising_edge transition has no pattern"));
                }
                if !edge_bit.is_some_and(|b| (0..=15).contains(&b)) {
                    return Err(row.err("a rising_edge transition needs edge_bit 0..15"));
                }
            }
            _ => {
                if has_pattern || edge_bit.is_some() {
                    return Err(row.err("automatic and fault_event transitions have no pattern"));
                }
            }
        }
        if from.is_none() && trigger != "FaultEvent" {
            return Err(row.err("only a fault_event transition may start from every state (*)"));
        }
        if from.as_deref() == Some(to.as_str()) {
            return Err(row.err(format!("transition `{id}` leads from `{to}` to itself")));
        }
        if trigger == "Command" {
            for other in out
                .iter()
                .filter(|t| t.trigger == "Command" && t.from == from)
            {
                if overlap((mask, value), (other.mask, other.value)) && other.to != to {
                    return Err(row.err(format!(
                        "control-word pattern overlaps transition `{}` out of the same state \
                         toward another state",
                        other.id
                    )));
                }
            }
        }
        out.push(TransitionRow {
            id: id.to_owned(),
            from,
            to,
            trigger,
            command_de: row.req("command_de")?.to_owned(),
            command_en: row.req("command_en")?.to_owned(),
            mask,
            value,
            edge_bit: edge_bit.map(|b| b as u8),
            source: row.req("source")?.to_owned(),
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// USS PKW: order IDs, response IDs, error numbers

/// One response ID.
#[derive(Debug, Clone)]
pub struct AkResponseRow {
    ak: u8,
    meaning_de: String,
    meaning_en: String,
    kind: &'static str,
    width: Option<&'static str>,
}

fn width(row: &Row) -> Result<Option<&'static str>> {
    match row.str("width")? {
        "" => Ok(None),
        "word" => Ok(Some("Word")),
        "dword" => Ok(Some("DoubleWord")),
        other => Err(row.err(format!("width `{other}` is not word, dword or empty"))),
    }
}

fn ak(row: &Row) -> Result<u8> {
    let v = row.int("ak")?;
    if (0..=15).contains(&v) {
        Ok(v as u8)
    } else {
        Err(row.err(format!("AK {v} does not fit PKE bits 12..15 (0..15)")))
    }
}

/// Read the response IDs: unique, 0..15, exactly one error response.
pub fn read_ak_responses(path: &Path) -> Result<Vec<AkResponseRow>> {
    let table = Table::read(path, &["ak", "meaning_de", "meaning_en", "kind", "width"])?;
    let mut out: Vec<AkResponseRow> = Vec::new();
    for row in table.rows() {
        let code = ak(row)?;
        if out.iter().any(|r| r.ak == code) {
            return Err(row.err(format!("AK {code} appears twice")));
        }
        let kind = match row.req("kind")? {
            "none" => "None",
            "value" => "Value",
            "array_value" => "ArrayValue",
            "count" => "Count",
            "error" => "Error",
            other => return Err(row.err(format!("kind `{other}` is not a response kind"))),
        };
        let width = width(row)?;
        if matches!(kind, "Value" | "ArrayValue") != width.is_some() {
            return Err(row.err("value responses, and only they, need a width"));
        }
        if kind == "Error" && out.iter().any(|r| r.kind == "Error") {
            return Err(row.err("only one response ID may be the error response"));
        }
        out.push(AkResponseRow {
            ak: code,
            meaning_de: row.req("meaning_de")?.to_owned(),
            meaning_en: row.req("meaning_en")?.to_owned(),
            kind,
            width,
        });
    }
    if !out.iter().any(|r| r.kind == "Error") {
        return Err(Error(format!(
            "{}: no error response ID (kind error)",
            table.path().display()
        )));
    }
    Ok(out)
}

/// One order ID.
#[derive(Debug, Clone)]
pub struct AkRequestRow {
    ak: u8,
    function_de: String,
    function_en: String,
    kind: &'static str,
    width: Option<&'static str>,
    array: bool,
    eeprom: bool,
    responses: Vec<u8>,
}

/// Read the order IDs and check each positive response against the response table: it must
/// exist, not be the error response, and fit the order's kind, width and array flag.
pub fn read_ak_requests(path: &Path, responses: &[AkResponseRow]) -> Result<Vec<AkRequestRow>> {
    let table = Table::read(
        path,
        &[
            "ak",
            "function_de",
            "function_en",
            "kind",
            "width",
            "array",
            "eeprom",
            "responses",
        ],
    )?;
    let mut out: Vec<AkRequestRow> = Vec::new();
    for row in table.rows() {
        let code = ak(row)?;
        if out.iter().any(|r| r.ak == code) {
            return Err(row.err(format!("AK {code} appears twice")));
        }
        let kind = match row.req("kind")? {
            "none" => "None",
            "read" => "Read",
            "write" => "Write",
            "count" => "Count",
            "reserved" => "Reserved",
            other => return Err(row.err(format!("kind `{other}` is not an order kind"))),
        };
        let width = width(row)?;
        if (kind == "Write") != width.is_some() {
            return Err(row.err("write orders, and only they, need a width"));
        }
        let array = row.flag("array")?;
        let eeprom = row.flag("eeprom")?;
        if eeprom && kind != "Write" {
            return Err(row.err("only a write order can write to EEPROM"));
        }
        let mut list = Vec::new();
        for part in row
            .str("responses")?
            .split('|')
            .map(str::trim)
            .filter(|s| !s.is_empty())
        {
            let n: u8 = part
                .parse()
                .map_err(|_| row.err(format!("responses: `{part}` is not a number")))?;
            let resp = responses
                .iter()
                .find(|r| r.ak == n)
                .ok_or_else(|| row.err(format!("response AK {n} is not in the response table")))?;
            let fits = match kind {
                "None" => resp.kind == "None",
                "Read" => {
                    resp.kind == if array { "ArrayValue" } else { "Value" } && resp.width.is_some()
                }
                "Write" => {
                    resp.kind == if array { "ArrayValue" } else { "Value" } && resp.width == width
                }
                "Count" => resp.kind == "Count",
                _ => false,
            };
            if !fits {
                return Err(row.err(format!(
                    "response AK {n} ({}) does not answer this order",
                    resp.meaning_en
                )));
            }
            list.push(n);
        }
        if (kind == "Reserved") != list.is_empty() {
            return Err(row.err("reserved orders, and only they, have no positive response"));
        }
        out.push(AkRequestRow {
            ak: code,
            function_de: row.req("function_de")?.to_owned(),
            function_en: row.req("function_en")?.to_owned(),
            kind,
            width,
            array,
            eeprom,
            responses: list,
        });
    }
    Ok(out)
}

/// One PWE2 error number.
#[derive(Debug, Clone)]
pub struct PweRow {
    number: u16,
    meaning_de: String,
    meaning_en: String,
}

/// Read the PWE2 error numbers: unique; a meaning in both languages or in neither.
pub fn read_pwe_errors(path: &Path) -> Result<Vec<PweRow>> {
    let table = Table::read(path, &["number", "meaning_de", "meaning_en"])?;
    let mut out: Vec<PweRow> = Vec::new();
    for row in table.rows() {
        let n = row.int("number")?;
        let number =
            u16::try_from(n).map_err(|_| row.err(format!("error number {n} is not 0..65535")))?;
        if out.iter().any(|r| r.number == number) {
            return Err(row.err(format!("error number {number} appears twice")));
        }
        let (de, en) = (row.str("meaning_de")?, row.str("meaning_en")?);
        pair(row, "meaning_de", de, "meaning_en", en)?;
        out.push(PweRow {
            number,
            meaning_de: de.to_owned(),
            meaning_en: en.to_owned(),
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// CTT2

/// One CTT2 message code.
#[derive(Debug, Clone)]
pub struct MessageRow {
    code: u8,
    message_type: &'static str,
    role: &'static str,
    name_de: String,
    name_en: String,
    contents_de: String,
    contents_en: String,
    printed: Option<u8>,
}

fn byte(row: &Row, col: &str) -> Result<u8> {
    let v = row.int(col)?;
    u8::try_from(v).map_err(|_| row.err(format!("column `{col}`: {v} is not a byte (0..255)")))
}

/// Read the CTT2 message codes: unique; per message type one request, one OK and one not-OK
/// response, with OK = request + 40h and not OK = request + 80h.
pub fn read_ctt2_messages(path: &Path) -> Result<Vec<MessageRow>> {
    let table = Table::read(
        path,
        &[
            "code",
            "message_type",
            "role",
            "name_de",
            "name_en",
            "contents_de",
            "contents_en",
            "printed",
        ],
    )?;
    let mut out: Vec<MessageRow> = Vec::new();
    for row in table.rows() {
        let code = byte(row, "code")?;
        if out.iter().any(|m| m.code == code) {
            return Err(row.err(format!("code {code} appears twice")));
        }
        let message_type = match row.req("message_type")? {
            "standard_read" => "StandardRead",
            "nord_read" => "NordRead",
            "nord_write" => "NordWrite",
            "nord_write_read" => "NordWriteRead",
            other => return Err(row.err(format!("message_type `{other}` is unknown"))),
        };
        let role = match row.req("role")? {
            "request" => "Request",
            "ok" => "ResponseOk",
            "error" => "ResponseError",
            other => return Err(row.err(format!("role `{other}` is not request, ok or error"))),
        };
        if out
            .iter()
            .any(|m| m.message_type == message_type && m.role == role)
        {
            return Err(row.err(format!("{message_type} has a second {role} code")));
        }
        let printed = match row.opt_int("printed")? {
            None => None,
            Some(p) => Some(
                u8::try_from(p)
                    .ok()
                    .filter(|p| *p != code)
                    .ok_or_else(|| row.err("printed must be a byte that differs from code"))?,
            ),
        };
        let (contents_de, contents_en) = (row.str("contents_de")?, row.str("contents_en")?);
        pair(row, "contents_de", contents_de, "contents_en", contents_en)?;
        out.push(MessageRow {
            code,
            message_type,
            role,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            contents_de: contents_de.to_owned(),
            contents_en: contents_en.to_owned(),
            printed,
        });
    }
    for (row, m) in table.rows().iter().zip(&out) {
        if m.role == "Request" {
            if m.code & 0xC0 != 0 {
                return Err(row.err(format!("request code {} has bit 6 or 7 set", m.code)));
            }
            continue;
        }
        let request = out
            .iter()
            .find(|r| r.message_type == m.message_type && r.role == "Request")
            .ok_or_else(|| row.err(format!("{} has no request code", m.message_type)))?;
        let expected = request.code | if m.role == "ResponseOk" { 0x40 } else { 0x80 };
        if m.code != expected {
            return Err(row.err(format!(
                "response code {} (0x{:02X}) must be request {} + 0x{:02X} = {expected} (0x{expected:02X})",
                m.code,
                m.code,
                request.code,
                if m.role == "ResponseOk" { 0x40 } else { 0x80 }
            )));
        }
    }
    for t in ["StandardRead", "NordRead", "NordWrite", "NordWriteRead"] {
        for r in ["Request", "ResponseOk", "ResponseError"] {
            if !out.iter().any(|m| m.message_type == t && m.role == r) {
                return Err(Error(format!(
                    "{}: message type {t} has no {r} code",
                    table.path().display()
                )));
            }
        }
    }
    Ok(out)
}

/// One CTT2 index (object).
#[derive(Debug, Clone)]
pub struct IndexRow {
    index: u8,
    standard: bool,
    object_de: String,
    object_en: String,
    max_len: u8,
    write_lengths: Vec<u8>,
    address: bool,
}

/// Read the CTT2 indices: unique; write lengths within the maximum length.
pub fn read_ctt2_indices(path: &Path) -> Result<Vec<IndexRow>> {
    let table = Table::read(
        path,
        &[
            "index",
            "scope",
            "object_de",
            "object_en",
            "max_len",
            "write_lengths",
            "address",
        ],
    )?;
    let mut out: Vec<IndexRow> = Vec::new();
    for row in table.rows() {
        let index = byte(row, "index")?;
        if out.iter().any(|i| i.index == index) {
            return Err(row.err(format!("index {index} appears twice")));
        }
        let standard = match row.req("scope")? {
            "standard" => true,
            "nord" => false,
            other => return Err(row.err(format!("scope `{other}` is not standard or nord"))),
        };
        let max_len = byte(row, "max_len")?;
        if max_len == 0 {
            return Err(row.err("max_len must be at least 1"));
        }
        let mut write_lengths = Vec::new();
        for part in row
            .str("write_lengths")?
            .split('|')
            .map(str::trim)
            .filter(|s| !s.is_empty())
        {
            let n: u8 = part
                .parse()
                .map_err(|_| row.err(format!("write_lengths: `{part}` is not a number")))?;
            if n == 0 || n > max_len {
                return Err(row.err(format!("write length {n} is outside 1..{max_len}")));
            }
            write_lengths.push(n);
        }
        if standard && !write_lengths.is_empty() {
            return Err(row.err("standard-read objects cannot be written"));
        }
        out.push(IndexRow {
            index,
            standard,
            object_de: row.req("object_de")?.to_owned(),
            object_en: row.req("object_en")?.to_owned(),
            max_len,
            write_lengths,
            address: row.flag("address")?,
        });
    }
    Ok(out)
}

/// One CTT2 error code.
#[derive(Debug, Clone)]
pub struct Ctt2ErrorRow {
    code: u8,
    meaning_de: String,
    meaning_en: String,
}

/// Read the CTT2 error codes: unique, non-zero.
pub fn read_ctt2_errors(path: &Path) -> Result<Vec<Ctt2ErrorRow>> {
    let table = Table::read(path, &["code", "meaning_de", "meaning_en"])?;
    let mut out: Vec<Ctt2ErrorRow> = Vec::new();
    for row in table.rows() {
        let code = byte(row, "code")?;
        if code == 0 || out.iter().any(|e| e.code == code) {
            return Err(row.err(format!("error code {code} is zero or appears twice")));
        }
        out.push(Ctt2ErrorRow {
            code,
            meaning_de: row.req("meaning_de")?.to_owned(),
            meaning_en: row.req("meaning_en")?.to_owned(),
        });
    }
    Ok(out)
}

/// One byte of a standard-read object.
#[derive(Debug, Clone)]
pub struct ObjectByteRow {
    index: u8,
    byte: u8,
    name_de: String,
    name_en: String,
}

/// Read the object layouts: every byte 1..max_len of each described standard object, once.
pub fn read_ctt2_objects(path: &Path, indices: &[IndexRow]) -> Result<Vec<ObjectByteRow>> {
    let table = Table::read(path, &["index", "byte", "name_de", "name_en"])?;
    let mut out: Vec<ObjectByteRow> = Vec::new();
    for row in table.rows() {
        let index = byte(row, "index")?;
        let ix = indices
            .iter()
            .find(|i| i.index == index && i.standard)
            .ok_or_else(|| row.err(format!("index {index} is not a standard-read object")))?;
        let b = byte(row, "byte")?;
        if b == 0 || b > ix.max_len {
            return Err(row.err(format!("byte {b} is outside 1..{}", ix.max_len)));
        }
        if out.iter().any(|o| o.index == index && o.byte == b) {
            return Err(row.err(format!("byte {b} of index {index} appears twice")));
        }
        out.push(ObjectByteRow {
            index,
            byte: b,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    for ix in indices
        .iter()
        .filter(|i| out.iter().any(|o| o.index == i.index))
    {
        let n = out.iter().filter(|o| o.index == ix.index).count();
        if n != usize::from(ix.max_len) {
            return Err(Error(format!(
                "{}: index {} describes {n} of its {} bytes",
                table.path().display(),
                ix.index,
                ix.max_len
            )));
        }
    }
    out.sort_by_key(|o| (o.index, o.byte));
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Parameters

/// One parameter with its array elements and value list.
#[derive(Debug, Clone)]
pub struct ParamRow {
    number: u16,
    pnu: u16,
    name_de: String,
    name_en: String,
    unit: String,
    /// Resolution text and its (mantissa, scale).
    resolution: Option<(String, Decimal)>,
    raw_range: Option<(i64, i64)>,
    default_raw: Option<i64>,
    range_de: String,
    range_en: String,
    read_only: bool,
    param_set: bool,
    array_len: Option<u8>,
    description_de: String,
    description_en: String,
    source: String,
    elements: Vec<(u8, String, String)>,
    values: Vec<(i64, String, String)>,
}

/// A decimal number as (mantissa, number of fractional digits): `320.00` = (32000, 2).
type Decimal = (i128, u32);

/// Parse `-12.345` style decimals (a dot, no exponent).
fn decimal(s: &str) -> Option<Decimal> {
    let (neg, body) = match s.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, s),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    if int.is_empty() || !int.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if !frac.bytes().all(|b| b.is_ascii_digit()) || body.ends_with('.') || frac.len() > 9 {
        return None;
    }
    let digits = format!("{int}{frac}");
    let m: i128 = digits.parse().ok()?;
    Some((if neg { -m } else { m }, frac.len() as u32))
}

/// `value / step` when it is a whole number.
fn steps(value: Decimal, step: Decimal) -> Option<i64> {
    let scale = value.1.max(step.1);
    let v = value.0 * 10i128.pow(scale - value.1);
    let s = step.0 * 10i128.pow(scale - step.1);
    if s <= 0 || v % s != 0 {
        return None;
    }
    i64::try_from(v / s).ok()
}

/// Format `raw` steps of `step` with the step's decimals, using `sep` as decimal separator.
fn format_steps(raw: i64, step: Decimal, sep: char) -> String {
    let v = i128::from(raw) * step.0;
    let d = step.1 as usize;
    let sign = if v < 0 { "-" } else { "" };
    let digits = format!("{:0>width$}", v.abs(), width = d + 1);
    if d == 0 {
        format!("{sign}{digits}")
    } else {
        let (int, frac) = digits.split_at(digits.len() - d);
        format!("{sign}{int}{sep}{frac}")
    }
}

/// Read the parameters: unique numbers, PNU equal to the number and within PKE bits 0..10,
/// min/max/default whole multiples of the resolution, within a 16-bit word, default in range.
pub fn read_params(path: &Path) -> Result<Vec<ParamRow>> {
    let table = Table::read(
        path,
        &[
            "number",
            "pnu",
            "name_de",
            "name_en",
            "unit",
            "resolution",
            "min",
            "max",
            "default",
            "access",
            "param_set",
            "array_len",
            "description_de",
            "description_en",
            "source",
        ],
    )?;
    let mut out: Vec<ParamRow> = Vec::new();
    for row in table.rows() {
        let number = row.int("number")?;
        let number = u16::try_from(number)
            .ok()
            .filter(|n| *n <= 999)
            .ok_or_else(|| row.err(format!("parameter number {number} is outside 0..999")))?;
        let pnu = row.int("pnu")?;
        if pnu != i64::from(number) {
            return Err(row.err(format!(
                "PNU {pnu:#X} differs from the parameter number P{number} ({:#X}); the manual \
                 sends the parameter number as PNU (P102 = 66h, P701 = 2BDh)",
                number
            )));
        }
        if pnu > 0x7FF {
            return Err(row.err(format!("PNU {pnu:#X} does not fit PKE bits 0..10")));
        }
        if out.iter().any(|p| p.number == number) {
            return Err(row.err(format!("P{number} appears twice")));
        }
        let resolution = match row.str("resolution")? {
            "" => None,
            s => {
                let d = decimal(s).filter(|d| d.0 > 0).ok_or_else(|| {
                    row.err(format!("resolution `{s}` is not a positive decimal"))
                })?;
                Some((s.to_owned(), d))
            }
        };
        let step = resolution.as_ref().map_or((1, 0), |r| r.1);
        let raw = |col: &str| -> Result<Option<i64>> {
            let s = row.str(col)?;
            if s.is_empty() {
                return Ok(None);
            }
            let d = decimal(s)
                .ok_or_else(|| row.err(format!("column `{col}`: `{s}` is not a decimal")))?;
            let r = steps(d, step).ok_or_else(|| {
                row.err(format!(
                    "column `{col}`: {s} is not a whole multiple of the resolution"
                ))
            })?;
            if !(-32768..=65535).contains(&r) {
                return Err(row.err(format!(
                    "column `{col}`: raw value {r} does not fit a 16-bit word (section 6)"
                )));
            }
            Ok(Some(r))
        };
        let (min, max, default) = (raw("min")?, raw("max")?, raw("default")?);
        let raw_range = match (min, max) {
            (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
            (Some(lo), Some(hi)) => {
                return Err(row.err(format!("min (raw {lo}) is above max (raw {hi})")));
            }
            (None, None) => None,
            _ => return Err(row.err("give both min and max, or neither")),
        };
        if let (Some(d), Some((lo, hi))) = (default, raw_range) {
            if !(lo..=hi).contains(&d) {
                return Err(row.err(format!("default (raw {d}) is outside raw {lo}..{hi}")));
            }
        }
        let read_only = match row.req("access")? {
            "RO" => true,
            "RW" => false,
            other => return Err(row.err(format!("access `{other}` is not RO or RW"))),
        };
        let array_len = match row.opt_int("array_len")? {
            None => None,
            Some(n) if (1..=64).contains(&n) => Some(n as u8),
            Some(n) => {
                return Err(row.err(format!("array_len {n} is outside 1..64 (IND bits 10..15)")));
            }
        };
        let unit = row.str("unit")?.to_owned();
        let (range_de, range_en) = match raw_range {
            Some((lo, hi)) => {
                let u = if unit.is_empty() {
                    String::new()
                } else {
                    format!(" {unit}")
                };
                (
                    format!(
                        "{} … {}{u}",
                        format_steps(lo, step, ','),
                        format_steps(hi, step, ',')
                    ),
                    format!(
                        "{} … {}{u}",
                        format_steps(lo, step, '.'),
                        format_steps(hi, step, '.')
                    ),
                )
            }
            None => (String::new(), String::new()),
        };
        out.push(ParamRow {
            number,
            pnu: pnu as u16,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            unit,
            resolution,
            raw_range,
            default_raw: default,
            range_de,
            range_en,
            read_only,
            param_set: row.flag("param_set")?,
            array_len,
            description_de: row.req("description_de")?.to_owned(),
            description_en: row.req("description_en")?.to_owned(),
            source: row.req("source")?.to_owned(),
            elements: Vec::new(),
            values: Vec::new(),
        });
    }
    out.sort_by_key(|p| p.number);
    Ok(out)
}

fn param_of<'a>(row: &Row, params: &'a mut [ParamRow]) -> Result<&'a mut ParamRow> {
    let n = row.int("number")?;
    params
        .iter_mut()
        .find(|p| i64::from(p.number) == n)
        .ok_or_else(|| row.err(format!("P{n} is not in nord_parameters.csv")))
}

/// Read the named array elements: of an array parameter, within its length, once each.
pub fn read_param_arrays(path: &Path, params: &mut [ParamRow]) -> Result<()> {
    let table = Table::read(path, &["number", "element", "name_de", "name_en", "source"])?;
    for row in table.rows() {
        let p = param_of(row, params)?;
        let len = p
            .array_len
            .ok_or_else(|| row.err(format!("P{} is not an array (array_len empty)", p.number)))?;
        let e = row.int("element")?;
        if !(1..=i64::from(len)).contains(&e) {
            return Err(row.err(format!("element {e} is outside [-01]..[-{len:02}]")));
        }
        let e = e as u8;
        if p.elements.iter().any(|x| x.0 == e) {
            return Err(row.err(format!("P{} [-{e:02}] appears twice", p.number)));
        }
        let (de, en) = (row.str("name_de")?, row.str("name_en")?);
        pair(row, "name_de", de, "name_en", en)?;
        row.req("source")?;
        p.elements.push((e, de.to_owned(), en.to_owned()));
    }
    for p in params.iter_mut() {
        p.elements.sort_by_key(|e| e.0);
    }
    Ok(())
}

/// Read the value lists: of a known parameter, once per value, inside the parameter's range.
pub fn read_param_values(path: &Path, params: &mut [ParamRow]) -> Result<()> {
    let table = Table::read(path, &["number", "value", "de", "en", "source"])?;
    for row in table.rows() {
        let p = param_of(row, params)?;
        let v = row.int("value")?;
        if p.values.iter().any(|x| x.0 == v) {
            return Err(row.err(format!("value {v} of P{} appears twice", p.number)));
        }
        if let Some((lo, hi)) = p.raw_range {
            if !(lo..=hi).contains(&v) {
                return Err(row.err(format!("value {v} is outside the raw range {lo}..{hi}")));
            }
        }
        row.req("source")?;
        p.values
            .push((v, row.req("de")?.to_owned(), row.req("en")?.to_owned()));
    }
    for p in params.iter_mut() {
        p.values.sort_by_key(|v| v.0);
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Shared checks

fn check_snake(row: &Row, col: &str, s: &str) -> Result<()> {
    let ok = s.starts_with(|c: char| c.is_ascii_lowercase())
        && s.chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(row.err(format!("column `{col}`: `{s}` is not snake_case")))
    }
}

fn check_camel(row: &Row, col: &str, s: &str) -> Result<()> {
    let ok = s.starts_with(|c: char| c.is_ascii_uppercase())
        && s.chars().all(|c| c.is_ascii_alphanumeric());
    if ok {
        Ok(())
    } else {
        Err(row.err(format!("column `{col}`: `{s}` is not CamelCase")))
    }
}

/// A German text needs its English translation and vice versa.
fn pair(row: &Row, de_col: &str, de: &str, en_col: &str, en: &str) -> Result<()> {
    if de.is_empty() != en.is_empty() {
        Err(row.err(format!(
            "`{de_col}` and `{en_col}` must both be given or both be empty"
        )))
    } else {
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Rendering

fn render_words(cw: &[Bit], sw: &[Bit]) -> String {
    let mut s = header("nord/nord_control_word.csv, nord/nord_status_word.csv");
    s.push_str("use crate::nord::BitInfo;\n\n");
    for (name, what, bits) in [
        ("CONTROL_BITS", "control word (STW)", cw),
        ("STATUS_BITS", "status word (ZSW)", sw),
    ] {
        let _ = writeln!(
            s,
            "/// The 16 bits of the {what}, BU 0255 section 4.5, by bit number."
        );
        let _ = writeln!(s, "pub static {name}: [BitInfo; 16] = [");
        for b in bits {
            let _ = writeln!(
                s,
                "    BitInfo {{ bit: {}, key: {}, name_de: {}, name_en: {}, meaning0_de: {}, \
                 meaning0_en: {}, meaning1_de: {}, meaning1_en: {}, priority0: {}, priority1: {} }},",
                b.bit,
                lit(&b.key),
                lit(&b.name_de),
                lit(&b.name_en),
                lit(&b.meaning0_de),
                lit(&b.meaning0_en),
                lit(&b.meaning1_de),
                lit(&b.meaning1_en),
                opt(b.priority0, |p| p.to_string()),
                opt(b.priority1, |p| p.to_string()),
            );
        }
        s.push_str("];\n\n");
    }
    s
}

fn render_states(states: &[StateRow], transitions: &[TransitionRow]) -> String {
    let mut s = header("nord/nord_states.csv, nord/nord_transitions.csv");
    s.push_str("use crate::nord::{State, StateInfo, Transition, Trigger};\n\n");
    s.push_str("/// The drive states with their status-word patterns, BU 0255 section 4.5.3.\n");
    let _ = writeln!(s, "pub static STATES: [StateInfo; {}] = [", states.len());
    for st in states {
        let _ = writeln!(
            s,
            "    StateInfo {{ state: State::{}, letter: {:?}, name_de: {}, name_en: {}, \
             mask: 0x{:04X}, value: 0x{:04X}, description_de: {}, description_en: {} }},",
            st.id,
            st.letter,
            lit(&st.name_de),
            lit(&st.name_en),
            st.mask,
            st.value,
            lit(&st.description_de),
            lit(&st.description_en),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// The state transitions, BU 0255 section 4.5.3, table \"Zustandsübergänge\".\n");
    let _ = writeln!(
        s,
        "pub static TRANSITIONS: [Transition; {}] = [",
        transitions.len()
    );
    for t in transitions {
        let trigger = match (t.trigger, t.edge_bit) {
            ("Command", _) => format!(
                "Trigger::Command {{ mask: 0x{:04X}, value: 0x{:04X} }}",
                t.mask, t.value
            ),
            ("RisingEdge", Some(b)) => format!("Trigger::RisingEdge {{ bit: {b} }}"),
            (other, _) => format!("Trigger::{other}"),
        };
        let _ = writeln!(
            s,
            "    Transition {{ id: {}, from: {}, to: State::{}, trigger: {trigger}, command_de: {}, \
             command_en: {}, source: {} }},",
            lit(&t.id),
            opt(t.from.as_deref(), |f| format!("State::{f}")),
            t.to,
            lit(&t.command_de),
            lit(&t.command_en),
            lit(&t.source),
        );
    }
    s.push_str("];\n");
    s
}

fn render_uss(requests: &[AkRequestRow], responses: &[AkResponseRow], pwe: &[PweRow]) -> String {
    let mut s =
        header("nord/nord_ak_requests.csv, nord/nord_ak_responses.csv, nord/nord_pwe_errors.csv");
    s.push_str(
        "use crate::nord::{AkInfo, AkRequest, AkRequestKind, AkResponseKind, PweError, Width};\n\n",
    );
    s.push_str("/// USS order IDs (AK in PKE bits 12..15), BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(
        s,
        "pub static AK_REQUESTS: [AkRequest; {}] = [",
        requests.len()
    );
    for r in requests {
        let list: Vec<String> = r.responses.iter().map(u8::to_string).collect();
        let _ = writeln!(
            s,
            "    AkRequest {{ ak: {}, function_de: {}, function_en: {}, kind: AkRequestKind::{}, \
             width: {}, array: {}, eeprom: {}, responses: &[{}] }},",
            r.ak,
            lit(&r.function_de),
            lit(&r.function_en),
            r.kind,
            opt(r.width, |w| format!("Width::{w}")),
            r.array,
            r.eeprom,
            list.join(", "),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// USS response IDs, BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(
        s,
        "pub static AK_RESPONSES: [AkInfo; {}] = [",
        responses.len()
    );
    for r in responses {
        let _ = writeln!(
            s,
            "    AkInfo {{ ak: {}, meaning_de: {}, meaning_en: {}, kind: AkResponseKind::{}, \
             width: {} }},",
            r.ak,
            lit(&r.meaning_de),
            lit(&r.meaning_en),
            r.kind,
            opt(r.width, |w| format!("Width::{w}")),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// Error numbers in PWE2 of a response with AK 7, BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(s, "pub static PWE_ERRORS: [PweError; {}] = [", pwe.len());
    for e in pwe {
        let _ = writeln!(
            s,
            "    PweError {{ number: {}, meaning_de: {}, meaning_en: {} }},",
            e.number,
            lit(&e.meaning_de),
            lit(&e.meaning_en),
        );
    }
    s.push_str("];\n");
    s
}

fn render_ctt2(
    messages: &[MessageRow],
    indices: &[IndexRow],
    errors: &[Ctt2ErrorRow],
    objects: &[ObjectByteRow],
) -> String {
    let mut s = header(
        "nord/nord_ctt2_messages.csv, nord/nord_ctt2_indices.csv, nord/nord_ctt2_errors.csv, \
         nord/nord_ctt2_objects.csv",
    );
    s.push_str(
        "use crate::nord::{Ctt2Error, Ctt2Index, Ctt2Message, Ctt2MessageType, Ctt2ObjectByte, \
         Ctt2Role};\n\n",
    );
    s.push_str("/// CTT2 message codes, BU 0255 sections 4.3.1 to 4.3.4.\n");
    let _ = writeln!(
        s,
        "pub static MESSAGES: [Ctt2Message; {}] = [",
        messages.len()
    );
    for m in messages {
        let _ = writeln!(
            s,
            "    Ctt2Message {{ code: {}, message_type: Ctt2MessageType::{}, role: Ctt2Role::{}, \
             name_de: {}, name_en: {}, contents_de: {}, contents_en: {}, printed: {} }},",
            m.code,
            m.message_type,
            m.role,
            lit(&m.name_de),
            lit(&m.name_en),
            lit(&m.contents_de),
            lit(&m.contents_en),
            opt(m.printed, |p| p.to_string()),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// CTT2 indices (objects), BU 0255 sections 4.3.1 to 4.3.4.\n");
    let _ = writeln!(s, "pub static INDICES: [Ctt2Index; {}] = [", indices.len());
    for i in indices {
        let list: Vec<String> = i.write_lengths.iter().map(u8::to_string).collect();
        let _ = writeln!(
            s,
            "    Ctt2Index {{ index: {}, standard: {}, object_de: {}, object_en: {}, max_len: {}, \
             write_lengths: &[{}], address: {} }},",
            i.index,
            i.standard,
            lit(&i.object_de),
            lit(&i.object_en),
            i.max_len,
            list.join(", "),
            i.address,
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// CTT2 error codes, BU 0255 section 4.3.5.\n");
    let _ = writeln!(s, "pub static ERRORS: [Ctt2Error; {}] = [", errors.len());
    for e in errors {
        let _ = writeln!(
            s,
            "    Ctt2Error {{ code: {}, meaning_de: {}, meaning_en: {} }},",
            e.code,
            lit(&e.meaning_de),
            lit(&e.meaning_en),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// Byte layout of the standard-read objects, BU 0255 section 4.3.1.\n");
    let _ = writeln!(
        s,
        "pub static OBJECT_BYTES: [Ctt2ObjectByte; {}] = [",
        objects.len()
    );
    for o in objects {
        let _ = writeln!(
            s,
            "    Ctt2ObjectByte {{ index: {}, byte: {}, name_de: {}, name_en: {} }},",
            o.index,
            o.byte,
            lit(&o.name_de),
            lit(&o.name_en),
        );
    }
    s.push_str("];\n");
    s
}

fn render_params(params: &[ParamRow]) -> String {
    let mut s =
        header("nord/nord_parameters.csv, nord/nord_param_arrays.csv, nord/nord_param_values.csv");
    s.push_str("use crate::nord::{ArrayElement, Param, Resolution};\n");
    s.push_str("use crate::param::{Access, ValueName};\n\n");
    s.push_str("/// The parameters BU 0255 names, sorted by number (= PNU).\n");
    let _ = writeln!(s, "pub static PARAMS: [Param; {}] = [", params.len());
    for p in params {
        let resolution = opt(p.resolution.as_ref(), |(text, d)| {
            let step = if text.contains('.') {
                text.clone()
            } else {
                format!("{text}.0")
            };
            format!(
                "Resolution {{ step: {step}, decimals: {}, text: {} }}",
                d.1,
                lit(text)
            )
        });
        let elements: Vec<String> = p
            .elements
            .iter()
            .map(|(e, de, en)| {
                format!(
                    "ArrayElement {{ element: {e}, name_de: {}, name_en: {} }}",
                    lit(de),
                    lit(en)
                )
            })
            .collect();
        let values: Vec<String> = p
            .values
            .iter()
            .map(|(v, de, en)| {
                format!(
                    "ValueName {{ value: {v}, de: {}, en: {} }}",
                    lit(de),
                    lit(en)
                )
            })
            .collect();
        let _ = writeln!(s, "    Param {{");
        let _ = writeln!(s, "        number: {},", p.number);
        let _ = writeln!(s, "        pnu: 0x{:03X},", p.pnu);
        let _ = writeln!(s, "        name_de: {},", lit(&p.name_de));
        let _ = writeln!(s, "        name_en: {},", lit(&p.name_en));
        let _ = writeln!(s, "        unit: {},", lit(&p.unit));
        let _ = writeln!(s, "        resolution: {resolution},");
        let _ = writeln!(
            s,
            "        raw_range: {},",
            opt(p.raw_range, |(a, b)| format!("({a}, {b})"))
        );
        let _ = writeln!(
            s,
            "        default_raw: {},",
            opt(p.default_raw, |d| d.to_string())
        );
        let _ = writeln!(s, "        range_de: {},", lit(&p.range_de));
        let _ = writeln!(s, "        range_en: {},", lit(&p.range_en));
        let _ = writeln!(
            s,
            "        access: Access::{},",
            if p.read_only {
                "READ_ONLY"
            } else {
                "READ_WRITE"
            }
        );
        let _ = writeln!(s, "        parameter_set: {},", p.param_set);
        let _ = writeln!(
            s,
            "        array_len: {},",
            opt(p.array_len, |n| n.to_string())
        );
        let _ = writeln!(s, "        elements: &[{}],", elements.join(", "));
        let _ = writeln!(s, "        values: &[{}],", values.join(", "));
        let _ = writeln!(s, "        description_de: {},", lit(&p.description_de));
        let _ = writeln!(s, "        description_en: {},", lit(&p.description_en));
        let _ = writeln!(s, "        source: {},", lit(&p.source));
        let _ = writeln!(s, "    }},");
    }
    s.push_str("];\n");
    s
}

// ---------------------------------------------------------------------------------------------

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// A scratch folder with one CSV file; returns the file's path.
    fn scratch(test: &str, file: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-nord-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(file);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn real(file: &str) -> PathBuf {
        crate::data_dir(&crate::workspace_root())
            .join("nord")
            .join(file)
    }

    /// The real file with line `line` (1-based) replaced by `new`.
    fn edited(file: &str, line: usize, new: &str) -> String {
        let text = std::fs::read_to_string(real(file)).unwrap();
        let mut lines: Vec<&str> = text.lines().collect();
        lines[line - 1] = new;
        lines.join("\n") + "\n"
    }

    fn line_of(file: &str, starts: &str) -> usize {
        let text = std::fs::read_to_string(real(file)).unwrap();
        text.lines().position(|l| l.starts_with(starts)).unwrap() + 1
    }

    fn expect_err(r: Result<impl std::fmt::Debug>, file: &str, line: usize, what: &str) {
        let e = r.expect_err("must fail").0;
        let at = format!("{file}:{line}:");
        assert!(e.contains(&at), "`{e}` does not name {at}");
        assert!(e.contains(what), "`{e}` does not say `{what}`");
    }

    #[test]
    fn real_tables_generate() {
        let out = generate(&real("")).unwrap();
        assert_eq!(out.len(), 5);
        assert!(out.iter().all(|o| o.text.starts_with("// @generated")));
    }

    #[test]
    fn duplicate_bit_names_file_and_line() {
        let f = "nord_control_word.csv";
        let n = line_of(f, "5,");
        let text = edited(f, n, "4,enable_x,A,a,,,,,,");
        let r = read_bits(&scratch("dupbit", f, &text), true);
        expect_err(r, f, n, "bit 4 appears twice");
    }

    #[test]
    fn bit_outside_word_is_rejected() {
        let f = "nord_status_word.csv";
        let n = line_of(f, "15,");
        let text = edited(f, n, "16,parameter_set_bit1,A,a,,,,");
        expect_err(
            read_bits(&scratch("bit16", f, &text), false),
            f,
            n,
            "outside 0..15",
        );
    }

    #[test]
    fn missing_bit_is_reported() {
        let f = "nord_status_word.csv";
        let n = line_of(f, "15,");
        let text = edited(f, n, "# removed");
        let e = read_bits(&scratch("missing", f, &text), false)
            .unwrap_err()
            .0;
        assert!(e.contains("missing 15"), "{e}");
        assert!(e.contains(&format!("{f}:")), "{e}");
    }

    #[test]
    fn overlapping_state_patterns_are_rejected() {
        let f = "nord_states.csv";
        let n = line_of(f, "D,");
        // Switched on with bit 1 as X would also match ready to switch on.
        let text = edited(f, n, "D,SwitchedOn,Eingeschaltet,switched on,01100X1,x,x");
        expect_err(
            read_states(&scratch("overlap", f, &text)),
            f,
            n,
            "overlaps `ReadyToSwitchOn`",
        );
    }

    #[test]
    fn bad_pattern_character_is_rejected() {
        let f = "nord_states.csv";
        let n = line_of(f, "C,");
        let text = edited(f, n, "C,ReadyToSwitchOn,Einschaltbereit,ready,01100?1,x,x");
        expect_err(
            read_states(&scratch("badchar", f, &text)),
            f,
            n,
            "not 0, 1 or X",
        );
    }

    #[test]
    fn transitions_need_known_states_and_disjoint_commands() {
        let states = read_states(&real("nord_states.csv")).unwrap();
        let f = "nord_transitions.csv";
        let n = line_of(f, "3,");
        let text = edited(f, n, "3,ReadyToSwitchOn,Running,command,E,e,XXXXX111,,s");
        let r = read_transitions(&scratch("unknownstate", f, &text), &states);
        expect_err(r, f, n, "unknown state `Running`");
        // Shutdown (110) out of ready to switch on toward switched on clashes with nothing,
        // but 1X1 clashes with 7a (X0X) toward switch-on disabled.
        let text = edited(f, n, "3,ReadyToSwitchOn,SwitchedOn,command,E,e,XXXXX1X1,,s");
        let n7a = line_of(f, "7a,");
        let r = read_transitions(&scratch("clash", f, &text), &states);
        expect_err(r, f, n7a, "overlaps transition `3`");
    }

    #[test]
    fn duplicate_ak_is_rejected() {
        let f = "nord_ak_responses.csv";
        let n = line_of(f, "2,");
        let text = edited(f, n, "1,x,x,value,dword");
        expect_err(
            read_ak_responses(&scratch("dupak", f, &text)),
            f,
            n,
            "AK 1 appears twice",
        );
    }

    #[test]
    fn request_response_mismatch_is_rejected() {
        let responses = read_ak_responses(&real("nord_ak_responses.csv")).unwrap();
        let f = "nord_ak_requests.csv";
        let n = line_of(f, "7,");
        // A word array write answered with a double-word response.
        let text = edited(f, n, "7,x,x,write,word,1,1,5");
        let r = read_ak_requests(&scratch("akmismatch", f, &text), &responses);
        expect_err(r, f, n, "response AK 5");
    }

    #[test]
    fn ctt2_response_code_rule_catches_the_manual_misprint() {
        let f = "nord_ctt2_messages.csv";
        let n = line_of(f, "157,");
        // What the manual prints in section 4.3.4.
        let text = edited(
            f,
            n,
            "177,nord_write_read,error,Schreib-/Leseantwort nicht OK,x,Fehlercode,error code,",
        );
        let r = read_ctt2_messages(&scratch("ctt2code", f, &text));
        expect_err(r, f, n, "must be request 29 + 0x80 = 157");
    }

    #[test]
    fn pnu_must_equal_the_number() {
        let f = "nord_parameters.csv";
        let n = line_of(f, "102,");
        let text = edited(
            f,
            n,
            "102,0x67,Hochlaufzeit,acc,s,0.01,0,320.00,,RW,1,,d,d,s",
        );
        expect_err(
            read_params(&scratch("pnu", f, &text)),
            f,
            n,
            "differs from the parameter number",
        );
    }

    #[test]
    fn values_must_be_multiples_of_the_resolution() {
        let f = "nord_parameters.csv";
        let n = line_of(f, "102,");
        let text = edited(
            f,
            n,
            "102,0x66,Hochlaufzeit,acc,s,0.01,0,320.005,,RW,1,,d,d,s",
        );
        expect_err(
            read_params(&scratch("res", f, &text)),
            f,
            n,
            "whole multiple",
        );
        let text = edited(
            f,
            n,
            "102,0x66,Hochlaufzeit,acc,s,0.01,0,700.00,,RW,1,,d,d,s",
        );
        expect_err(read_params(&scratch("word", f, &text)), f, n, "16-bit word");
    }

    #[test]
    fn array_elements_must_fit_the_array() {
        let mut params = read_params(&real("nord_parameters.csv")).unwrap();
        let f = "nord_param_arrays.csv";
        let n = line_of(f, "700,3,");
        let text = edited(f, n, "700,4,x,x,manual");
        let r = read_param_arrays(&scratch("elem", f, &text), &mut params);
        expect_err(r, f, n, "outside [-01]..[-03]");
    }

    #[test]
    fn decimals_parse_and_format() {
        assert_eq!(decimal("320.00"), Some((32000, 2)));
        assert_eq!(decimal("-0.5"), Some((-5, 1)));
        assert_eq!(decimal("1."), None);
        assert_eq!(decimal(".5"), None);
        assert_eq!(steps((32000, 2), (1, 2)), Some(32000));
        assert_eq!(steps((4000, 1), (1, 1)), Some(4000));
        assert_eq!(steps((5, 1), (1, 0)), None);
        assert_eq!(format_steps(32000, (1, 2), ','), "320,00");
        assert_eq!(format_steps(1, (1, 1), '.'), "0.1");
        assert_eq!(format_steps(-5, (1, 2), '.'), "-0.05");
    }
}
