//! The one shape of every decoder's output (`docs/decode-json.md` in the drivebus sources): a [`Telegram`] with its
//! [`Field`]s, the parameter a telegram names in the keys of `read --json`, and text from the
//! input shown without its control characters.
//!
//! Every object has every common key ([`COMMON_KEYS`]; `null` where the telegram has nothing
//! for it); a protocol adds only its own keys beside them (MOVILINK `pdu_type`, CTT2 `code`,
//! Modbus `function`, …).

use drive_client::Target;
use drive_profile::Family;
use serde_json::{Map, Value, json};

/// The keys every decode object has, in the order `docs/decode-json.md` explains them.
pub const COMMON_KEYS: [&str; 26] = [
    "type",
    "protocol",
    "offset",
    "line",
    "length",
    "bytes",
    "valid",
    "error",
    "notes",
    "direction",
    "kind",
    "address",
    "index",
    "number",
    "label",
    "name_de",
    "name_en",
    "selector",
    "raw",
    "value",
    "unit",
    "meaning",
    "decoded",
    "refusal",
    "process_data",
    "fields",
];

/// The target a telegram names: bus index `index` (SEW index, NORD PNU, Bonfiglioli
/// parameter number) with sub-index `sub` (NORD IND word, Bonfiglioli data set), the table's
/// entry where it has one.
pub fn target(family: Family, index: u16, sub: u16) -> Target {
    let param = drive_profile::family::lookup(family, &index.to_string())
        .filter(|p| p.bus_index() == index);
    Target {
        family,
        index,
        sub,
        param,
    }
}

/// The parameter keys of `read --json` for `t`; without a value
/// (`raw` = `None`: a read request, a refusal) `raw`, `value`, `meaning` and `decoded` are
/// `null`.
pub fn param_json(t: &Target, raw: Option<i64>) -> Value {
    let mut v = value_json(t, raw.unwrap_or(0));
    if raw.is_none()
        && let Value::Object(m) = &mut v
    {
        for k in ["raw", "value", "meaning", "decoded"] {
            m.insert(k.into(), Value::Null);
        }
    }
    v
}

/// The parameter keys with every value `null`: the telegram names no parameter.
fn no_param() -> Map<String, Value> {
    let mut m = Map::new();
    for k in [
        "index", "number", "label", "name_de", "name_en", "selector", "raw", "value", "unit",
        "meaning", "decoded",
    ] {
        m.insert(k.into(), Value::Null);
    }
    m
}

/// One field of a telegram: where it is, its bytes, its name, the number it carries and what
/// that means.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Offset of the field's first byte (Modbus ASCII: character) in the capture; SBus: in
    /// the frame's data.
    pub offset: usize,
    /// The bytes as hex (`70 66`); Modbus ASCII: the characters' codes.
    pub bytes: String,
    /// The characters of a Modbus ASCII field (`01`), escaped; `None` elsewhere.
    pub chars: Option<String>,
    /// The field's name in the protocol's words (`PKE`, `ADR`, `management`, `CRC`).
    pub name: String,
    /// The number the field carries as the protocol reads it (big-endian words, Modbus's CRC
    /// low byte first); `None` for a field of more than 8 bytes or text.
    pub value: Option<u64>,
    /// What it means.
    pub text: String,
}

impl Field {
    /// A field of `bytes` at `offset`, its value the bytes read big-endian.
    pub fn new(offset: usize, bytes: &[u8], name: &str, text: String) -> Self {
        Self {
            offset,
            bytes: hex(bytes),
            chars: None,
            name: name.to_owned(),
            value: big_endian(bytes),
            text,
        }
    }

    /// The field as JSON: `{offset, bytes, name, value, text}` (and `chars` for Modbus
    /// ASCII).
    pub fn to_json(&self) -> Value {
        let mut m = Map::new();
        m.insert("offset".into(), self.offset.into());
        m.insert("bytes".into(), self.bytes.clone().into());
        if let Some(c) = &self.chars {
            m.insert("chars".into(), c.clone().into());
        }
        m.insert("name".into(), self.name.clone().into());
        m.insert("value".into(), json!(self.value));
        m.insert("text".into(), self.text.clone().into());
        Value::Object(m)
    }
}

/// `bytes` as one big-endian number; `None` for none or more than 8.
pub fn big_endian(bytes: &[u8]) -> Option<u64> {
    if bytes.is_empty() || bytes.len() > 8 {
        return None;
    }
    Some(bytes.iter().fold(0u64, |a, b| (a << 8) | u64::from(*b)))
}

/// Bytes as spaced hex: `02 0E 01`.
pub fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Text from the input as it may be shown on a terminal: control characters (C0, DEL, C1)
/// escaped as `\r`, `\n`, `\t` or `\xNN`/`\u{NNNN}`, a backslash doubled; everything else as
/// it is.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\r' => out.push_str("\\r"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => {
                let n = u32::from(c);
                if n < 0x100 {
                    out.push_str(&format!("\\x{n:02X}"));
                } else {
                    out.push_str(&format!("\\u{{{n:04X}}}"));
                }
            }
            c => out.push(c),
        }
    }
    out
}

/// Bytes from the input shown as characters ([`escape`]d; bytes that are no UTF-8 as `\xNN`).
pub fn escape_bytes(bytes: &[u8]) -> String {
    let mut out = String::new();
    for chunk in bytes.utf8_chunks() {
        out.push_str(&escape(chunk.valid()));
        for b in chunk.invalid() {
            out.push_str(&format!("\\x{b:02X}"));
        }
    }
    out
}

/// One decoded unit of a capture in the common shape, built by a decoder and printed with
/// [`Telegram::to_json`].
#[derive(Debug, Clone)]
pub struct Telegram {
    /// `telegram` (a telegram, frame or message) or `skipped` (bytes that start none, or an
    /// input line that is no record).
    pub type_: &'static str,
    /// `movilink`, `sbus`, `uss`, `ctt2`, `modbus-rtu`, `modbus-ascii`.
    pub protocol: &'static str,
    /// Offset of the first byte (Modbus ASCII: character) in the capture; `None` for SBus.
    pub offset: Option<usize>,
    /// The input line it starts on, where the capture came from lines.
    pub line: Option<usize>,
    /// Bytes (Modbus ASCII: characters) it takes.
    pub length: usize,
    /// Its bytes (Modbus ASCII: the characters' codes; SBus: the data bytes).
    pub bytes: Vec<u8>,
    /// The first problem, if any (`valid` is its absence).
    pub error: Option<String>,
    /// Remarks that are no error (an erratum recognised).
    pub notes: Vec<String>,
    /// `request` (master → drive), `response` (drive → master), `request or response`
    /// (Modbus echoes), or `None` where it is not known.
    pub direction: Option<&'static str>,
    /// What the protocol calls it (`parameter request`, `NORD write request`, `read 16-bit
    /// parameter`, `PARAM+0PD acyclic`).
    pub kind: Option<String>,
    /// The drive's (or group's) address on the bus.
    pub address: Option<i64>,
    /// The parameter it names, and the raw value it carries for it (a write, a read answer).
    pub param: Option<(Target, Option<i64>)>,
    /// The drive's negative answer in words (SEW return code, USS AK 7 error, CTT2 error code,
    /// Modbus exception).
    pub refusal: Option<String>,
    /// Process data words (control/status word first).
    pub process_data: Vec<u16>,
    /// The fields in order.
    pub fields: Vec<Field>,
    /// The protocol's own keys (`pdu_type`, `code`, `function`, …).
    pub extra: Map<String, Value>,
}

impl Telegram {
    /// An empty telegram of `protocol`.
    pub fn new(protocol: &'static str) -> Self {
        Self {
            type_: "telegram",
            protocol,
            offset: None,
            line: None,
            length: 0,
            bytes: Vec::new(),
            error: None,
            notes: Vec::new(),
            direction: None,
            kind: None,
            address: None,
            param: None,
            refusal: None,
            process_data: Vec::new(),
            fields: Vec::new(),
            extra: Map::new(),
        }
    }

    /// Bytes that start no telegram, skipped with `why`.
    pub fn skipped(
        protocol: &'static str,
        offset: Option<usize>,
        bytes: &[u8],
        why: String,
    ) -> Self {
        Self {
            type_: "skipped",
            offset,
            length: bytes.len(),
            bytes: bytes.to_vec(),
            error: Some(why),
            ..Self::new(protocol)
        }
    }

    /// Whether it is a run of bytes skipped, not a telegram.
    pub fn is_skipped(&self) -> bool {
        self.type_ == "skipped"
    }

    /// A protocol key.
    pub fn extra(mut self, key: &str, value: Value) -> Self {
        self.extra.insert(key.into(), value);
        self
    }

    /// The object: every common key (`docs/decode-json.md`), then the protocol's own.
    pub fn to_json(&self) -> Value {
        let mut m = Map::new();
        m.insert("type".into(), self.type_.into());
        m.insert("protocol".into(), self.protocol.into());
        m.insert("offset".into(), json!(self.offset));
        m.insert("line".into(), json!(self.line));
        m.insert("length".into(), self.length.into());
        m.insert("bytes".into(), hex(&self.bytes).into());
        m.insert("valid".into(), self.error.is_none().into());
        m.insert("error".into(), json!(self.error));
        m.insert("notes".into(), json!(self.notes));
        m.insert("direction".into(), json!(self.direction));
        m.insert("kind".into(), json!(self.kind));
        m.insert("address".into(), json!(self.address));
        let param = match &self.param {
            Some((t, raw)) => match param_json(t, *raw) {
                Value::Object(p) => p,
                _ => no_param(),
            },
            None => no_param(),
        };
        m.extend(param);
        m.insert("refusal".into(), json!(self.refusal));
        m.insert("process_data".into(), json!(self.process_data));
        m.insert(
            "fields".into(),
            Value::Array(self.fields.iter().map(Field::to_json).collect()),
        );
        for (k, v) in &self.extra {
            m.entry(k.clone()).or_insert_with(|| v.clone());
        }
        Value::Object(m)
    }
}

// The keys that name a target and its value are the client layer's (`read --json`, every
// decoder, the gateway's front ends alike).
pub use drive_client::meaning::{target_json, value_json, value_json_in};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_from_the_input_are_escaped() {
        assert_eq!(escape("\u{1}\u{3}!t\u{0}\u{1}f"), "\\x01\\x03!t\\x00\\x01f");
        assert_eq!(
            escape(":01\r\n\u{1b}[2J\u{9b}ü\\"),
            ":01\\r\\n\\x1B[2J\\x9Bü\\\\"
        );
        assert_eq!(escape_bytes(&[0x3A, 0xFF, 0x0D]), ":\\xFF\\r");
    }

    #[test]
    fn every_object_has_every_common_key_once() {
        let t = Telegram::new("uss").to_json();
        let keys: Vec<&str> = t.as_object().unwrap().keys().map(String::as_str).collect();
        let mut want = COMMON_KEYS.to_vec();
        want.sort_unstable();
        let mut got = keys.clone();
        got.sort_unstable();
        assert_eq!(got, want);
        let s = Telegram::skipped("movilink", Some(3), &[0x55], "no start".into()).to_json();
        assert_eq!(
            (&s["type"], &s["valid"], &s["bytes"]),
            (&json!("skipped"), &json!(false), &json!("55"))
        );
        assert_eq!(s.as_object().unwrap().len(), COMMON_KEYS.len());
    }

    #[test]
    fn a_parameter_without_a_value_has_its_names_and_no_value() {
        // P130 (index 8470) of the MOVIDRIVE table.
        let t = target(Family::Movidrive, 8470, 0);
        let v = param_json(&t, None);
        assert_eq!(
            (&v["index"], &v["number"], &v["raw"], &v["value"]),
            (&json!(8470), &json!("P130"), &Value::Null, &Value::Null)
        );
        assert_eq!(v["name_en"], json!(t.names().unwrap().1));
        let v = param_json(&t, Some(1500));
        assert_eq!(v["raw"], 1500);
        // Outside the table: the raw value is the value.
        let v = param_json(&target(Family::Movidrive, 1, 0), Some(7));
        assert_eq!((&v["number"], &v["value"]), (&Value::Null, &json!(7)));
    }

    /// docs/decode-json.md lists every common key in its first table and the parameter's
    /// table, and no other. Skipped where the docs are not there (the packaged crate).
    #[test]
    fn the_docs_list_the_common_keys() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let Ok(doc) = std::fs::read_to_string(root.join("../../docs/decode-json.md")) else {
            return;
        };
        let tables = doc
            .split("## Keys every object has")
            .nth(1)
            .and_then(|d| d.split("### A field").next())
            .unwrap();
        let mut listed: Vec<&str> = tables
            .lines()
            .filter_map(|l| l.strip_prefix("| "))
            .filter_map(|l| l.split(" |").next())
            .filter(|cell| cell.starts_with('`') && !cell.contains('…'))
            .flat_map(|cell| cell.split(", "))
            .map(|k| k.trim_matches('`'))
            .collect();
        listed.sort_unstable();
        let mut want = COMMON_KEYS.to_vec();
        want.sort_unstable();
        assert_eq!(listed, want);
    }
}
