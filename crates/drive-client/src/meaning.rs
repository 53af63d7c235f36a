//! What a raw value means beyond its number: a value name from the table, or a decoded status
//! or fault word. One function of the table entry and the raw value, so every family's `read`,
//! `watch` and JSON output show the same; each family adds its words here.
//!
//! Some words mean different things on different devices of one family: the Bonfiglioli status
//! word 411 differs between the ACTIVE (ACT) and the ACTIVE Cube (ACU), which the table does not
//! tell apart. [`Device`] carries what a front end knows of the drive ([`meaning_in`]); without
//! it the decoding says the device is not known and keeps to what both share.
//!
//! MOVIDRIVE (serial communication manual, parameter list ch. 7): P010 drive status, P011
//! operating state, P012 fault status and P013 active parameter set are one index, 8310,
//! whose low word is "coded like status word 1"; the operating state rows of the fault memory
//! (8391–8395) are coded the same way. The manual gives no fault-code table: a fault is shown
//! by its number.

use drive_profile::bonfiglioli::Variant;
use drive_profile::family::AnyParam;
use drive_profile::sew::{StatusWord1, index};
use drive_profile::{Access, Family};
use serde_json::{Map, Value, json};

use crate::target::Target;

/// The meaning of one raw value.
#[derive(Debug, Clone, PartialEq)]
pub struct Meaning {
    /// For a person, in English, e.g. `ready, PO data enabled, unit status 2 = no enable`.
    pub text: String,
    /// The decoded word for scripts (bits, unit status, fault number, …); `None` for a plain
    /// value name.
    pub decoded: Option<Value>,
}

/// What a front end knows of the drive beyond its family's table, where a value's meaning
/// depends on it. The default knows nothing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Device {
    /// A Bonfiglioli drive's variant: the status word 411 is decoded for it.
    pub bonfiglioli: Option<KnownVariant>,
}

/// A Bonfiglioli drive's variant and how it is known.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KnownVariant {
    /// ACT or ACU.
    pub variant: Variant,
    /// How it is known, for scripts (`variant_from` in the decoded status word): `given` (the
    /// user or a configuration said so) or what the drive showed (`484 readable`, `484 not
    /// readable`, `status word bit 4`).
    pub from: &'static str,
}

impl Device {
    /// A Bonfiglioli drive of `variant`, known `from` (see [`KnownVariant::from`]).
    pub const fn bonfiglioli(variant: Variant, from: &'static str) -> Self {
        Self {
            bonfiglioli: Some(KnownVariant { variant, from }),
        }
    }
}

/// What `raw` of parameter `p` means: a decoded status or fault word, else the name of the
/// value in the table's value list, else nothing. Nothing is known of the device
/// ([`meaning_with`]).
#[cfg(test)]
pub fn meaning(p: AnyParam, raw: i64) -> Option<Meaning> {
    meaning_with(p, raw, &Device::default())
}

/// What `raw` of parameter `p` means on the drive `device` describes: a decoded status or fault
/// word, else the name of the value in the table's value list, else nothing.
pub fn meaning_with(p: AnyParam, raw: i64, device: &Device) -> Option<Meaning> {
    let word = match p.family() {
        Family::Movidrive => movidrive(p, raw),
        Family::Bonfiglioli => bonfiglioli(p.bus_index(), raw, device.bonfiglioli),
        _ => None,
    };
    word.or_else(|| {
        p.value_name(raw).map(|v| Meaning {
            text: v.en.to_owned(),
            decoded: None,
        })
    })
}

/// What `raw` of `t` means: [`meaning_with`] of its table entry, with what only the whole target
/// knows (a NORD array element: P700 [-02] is a warning, [-03] a reason for switch-on
/// disabled).
pub fn meaning_of(t: &crate::target::Target, raw: i64) -> Option<Meaning> {
    meaning_in(t, raw, &Device::default())
}

/// [`meaning_of`] on the drive `device` describes (the gateway and the CLI pass what they know,
/// e.g. a Bonfiglioli drive's variant).
pub fn meaning_in(t: &crate::target::Target, raw: i64, device: &Device) -> Option<Meaning> {
    let p = t.param?;
    if p.family() == Family::Nord {
        let (element, _) = crate::target::nord_sub_parts(t.index, t.sub);
        if let Some(m) = nord(p.bus_index(), element, raw) {
            return Some(m);
        }
    }
    meaning_with(p, raw, device)
}

/// NORD's information parameters (BU 0255 section 6): P700 present fault [-01], warning [-02]
/// and reason for switch-on disabled [-03]; P701 the fault memory; P740/P741 the process data
/// bus in/out, whose first word is the control/status word. The manual has no table of fault
/// numbers: they are shown as numbers.
fn nord(pnu: u16, element: Option<u8>, raw: i64) -> Option<Meaning> {
    use drive_profile::nord::{ControlWord, StatusWord, state_info};
    let word = u16::try_from(raw)
        .ok()
        .or_else(|| i16::try_from(raw).ok().map(|w| w as u16))?;
    let text = match (pnu, element) {
        (0x2BC, Some(1)) | (0x2BD, Some(_)) if word == 0 => "no fault".to_owned(),
        (0x2BC, Some(1)) | (0x2BD, Some(_)) => format!("fault {word}"),
        (0x2BC, Some(2)) if word == 0 => "no warning".to_owned(),
        (0x2BC, Some(2)) => format!("warning {word}"),
        (0x2BC, Some(3)) if word == 0 => "no reason (switch-on not disabled)".to_owned(),
        (0x2BC, Some(3)) => format!("reason {word}"),
        (0x2E4, _) => {
            let bits: Vec<&str> = ControlWord(word).set_bits().map(|b| b.name_en).collect();
            return Some(Meaning {
                text: format!("control word: {}", bits.join(", ")),
                decoded: Some(json!({"control_word": format!("0x{word:04X}"), "bits": bits})),
            });
        }
        (0x2E5, _) => {
            let sw = StatusWord(word);
            let state = sw.state();
            let info = state_info(state);
            let bits: Vec<&str> = sw.set_bits().map(|b| b.name_en).collect();
            return Some(Meaning {
                text: format!(
                    "status word: {} {} ({})",
                    info.map_or('?', |i| i.letter),
                    state.name_en(),
                    bits.join(", ")
                ),
                decoded: Some(json!({
                    "status_word": format!("0x{word:04X}"),
                    "state": info.map(|i| i.letter.to_string()),
                    "state_en": state.name_en(),
                    "state_de": state.name_de(),
                    "bits": bits,
                })),
            });
        }
        _ => return None,
    };
    Some(Meaning {
        text,
        decoded: None,
    })
}

/// Bonfiglioli's status word (411), current fault (260, "FXXYY" with its text) and warnings
/// (270, bit-coded, several at once), as the manual's ch. 9, 10 and 12 name them. The status
/// word is decoded for `variant`; without one, for what the ACT and the ACU share (the states
/// and bits 0–3, 5–7, 9–11, 15), saying that the device is not known, unless bit 4 is set,
/// which only an ACU sets (ch. 9.1.3).
fn bonfiglioli(index: u16, raw: i64, variant: Option<KnownVariant>) -> Option<Meaning> {
    use drive_profile::bonfiglioli as b;
    let word = u16::try_from(raw).ok()?;
    match index {
        260 => {
            let code = b::FaultCode(word);
            let listed = code.meaning();
            let text = match listed {
                _ if word == 0 => "no fault".to_owned(),
                Some(f) => format!("{}: {}", f.key, f.text_en),
                None => format!("{code} (not in the manual's list)"),
            };
            Some(Meaning {
                text,
                decoded: Some(json!({
                    "fault": code.to_string(),
                    "group": code.group(),
                    "code": code.code(),
                    "listed": listed.is_some(),
                    "group_en": listed.map(|f| f.group_en),
                    "text_en": listed.map(|f| f.text_en),
                    "text_de": listed.map(|f| f.text_de),
                })),
            })
        }
        270 => {
            let bits: Vec<&b::Warning> = b::warning_bits(word).collect();
            let text = if bits.is_empty() {
                "no warning".to_owned()
            } else {
                bits.iter()
                    .map(|w| w.name_en)
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            Some(Meaning {
                text,
                decoded: Some(json!({
                    "warning_word": format!("0x{word:04X}"),
                    "warnings": bits.iter().map(|w| json!({
                        "bit": w.bit, "code": format!("0x{:04X}", w.code),
                        "name_en": w.name_en, "name_de": w.name_de,
                    })).collect::<Vec<_>>(),
                    "consistent": b::warnings_consistent(word),
                })),
            })
        }
        411 => Some(bonfiglioli_status(word, variant)),
        _ => None,
    }
}

/// The status word 411 of a Bonfiglioli drive of `known` variant (see [`bonfiglioli`]).
fn bonfiglioli_status(word: u16, known: Option<KnownVariant>) -> Meaning {
    let from_word = Variant::of_status_word(word);
    let variant = known.map(|k| k.variant).or(from_word);
    // Said to be an ACT, the drive shows what only an ACU shows: decoded as said, and said.
    let contradiction = known.is_some_and(|k| k.variant == Variant::Act) && from_word.is_some();
    // Unknown device: the states and bit names both share; the ACT's table has them all but
    // 0x00, which only the ACT calls "not ready to switch on".
    let decoding = variant.unwrap_or(Variant::Act);
    let mut state = decoding.state(word);
    if variant.is_none() && state == drive_profile::bonfiglioli::State::NotReadyToSwitchOn {
        state = drive_profile::bonfiglioli::State::Unknown;
    }
    let mut bits: Vec<&str> = decoding.set_bits(word).collect();
    if variant.is_none() {
        // Bit 4 is clear here: "voltage disabled" is an ACT name only.
        bits.retain(|b| *b != "voltage disabled");
    }
    let unnamed = decoding.unnamed_bits(word);
    let mains = variant.and_then(|v| v.mains_voltage(word));
    let mut text = state.name_en().to_owned();
    match variant {
        Some(v) => text.push_str(&format!(" ({})", v.key().to_uppercase())),
        None => text.push_str(" (ACT or ACU: the device is not known)"),
    }
    if !bits.is_empty() {
        text.push_str(": ");
        text.push_str(&bits.join(", "));
    }
    if mains == Some(false) {
        text.push_str("; no mains voltage (bit 4 = 0): the drive cannot start");
    }
    if unnamed != 0 {
        text.push_str(&format!("; other bits 0x{unnamed:04X}"));
    }
    if contradiction {
        text.push_str("; bit 4 is set, which an ACT never sets (ch. 9.1.3): is it an ACU?");
    }
    Meaning {
        text,
        decoded: Some(json!({
            "status_word": format!("0x{word:04X}"),
            "variant": variant.map(Variant::key),
            "variant_from": match (known, variant) {
                (Some(k), _) => Some(k.from),
                (None, Some(_)) => Some("status word bit 4"),
                (None, None) => None,
            },
            "variant_contradicted": contradiction,
            "state": state.name_en(),
            "state_de": state.name_de(),
            "bits": bits,
            "mains_voltage": mains,
            "other_bits": (unnamed != 0).then(|| format!("0x{unnamed:04X}")),
        })),
    }
}

/// Which part of a MOVIDRIVE status index a table row shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StatusPart {
    /// The whole status word (P010, the operating state rows of the fault memory).
    Word,
    /// P011: the unit status (high byte while no fault is shown).
    OperatingState,
    /// P012: the fault number (high byte while bit 5 is set).
    Fault,
    /// P013 and the parameter set rows of the fault memory: bit 4.
    ParameterSet,
}

/// The fault memory's operating state rows (P080–P084, "Betriebszustand"): 8391–8395.
const FAULT_MEMORY_STATES: std::ops::RangeInclusive<u16> = 8391..=8395;

fn status_part(p: AnyParam) -> Option<StatusPart> {
    let i = p.bus_index();
    if i == index::DRIVE_STATUS {
        return match p.number() {
            Some(10) => Some(StatusPart::Word),
            Some(11) => Some(StatusPart::OperatingState),
            Some(12) => Some(StatusPart::Fault),
            Some(13) => Some(StatusPart::ParameterSet),
            _ => None,
        };
    }
    if FAULT_MEMORY_STATES.contains(&i) {
        return match p.name_de() {
            "Betriebszustand" => Some(StatusPart::Word),
            "Parametersatz" => Some(StatusPart::ParameterSet),
            _ => None,
        };
    }
    None
}

fn movidrive(p: AnyParam, raw: i64) -> Option<Meaning> {
    let part = status_part(p)?;
    // The low word is status word 1; the manual says nothing of the high word (it is shown in
    // `decoded` so nothing the drive sends is hidden).
    let low = (raw & 0xFFFF) as u16;
    let high = ((raw >> 16) & 0xFFFF) as u16;
    let sw = StatusWord1::from_bits(low);
    let set = if sw.contains(StatusWord1::PARAMETER_SET_2) {
        2
    } else {
        1
    };
    let text = match part {
        StatusPart::Word => {
            let t = sw.to_string();
            if t.is_empty() {
                format!("unit status {}", sw.high_byte())
            } else {
                t
            }
        }
        StatusPart::OperatingState => match sw.unit_status() {
            Some(s) if !s.name().is_empty() => format!("{} = {}", s.code(), s.name()),
            Some(s) => format!("unit status {}", s.code()),
            None => format!(
                "fault/warning {} shown instead of the operating state",
                sw.high_byte()
            ),
        },
        StatusPart::Fault => match sw.fault_number() {
            Some(n) => format!("fault/warning {n}"),
            None => "no fault".to_owned(),
        },
        StatusPart::ParameterSet => format!("parameter set {set}"),
    };
    let flags: Vec<&str> = StatusWord1::NAMED
        .iter()
        .filter(|(flag, _)| sw.contains(*flag))
        .map(|(_, name)| *name)
        .collect();
    let unit_status = sw
        .unit_status()
        .map(|s| json!({"code": s.code(), "name": (!s.name().is_empty()).then_some(s.name())}));
    let decoded = json!({
        "status_word": format!("0x{low:04X}"),
        "flags": flags,
        "unit_status": unit_status,
        "fault": sw.fault_number(),
        "parameter_set": set,
        "high_word": format!("0x{high:04X}"),
    });
    Some(Meaning {
        text,
        decoded: Some(decoded),
    })
}

/// What names a target in every JSON object that shows one of its values (`read --json` and
/// every decoder): `index` (the bus index: SEW index, NORD PNU, Bonfiglioli parameter number),
/// `number` (the table's number, `P130`, `P102`, `372`), `label` (the number with its selector,
/// as the family's manual writes it: `P102 set 2`, `P543 [-02]`, `372 data set 2`), `name_de`,
/// `name_en` (a NORD array element's own names where the table has them), `selector`
/// ([`Target::selector_json`]: `null`, or `{"set": …}`, `{"array": …}`, `{"dataset": …}`) and
/// `unit`; outside the table `number`, the names and `unit` are `null`.
pub fn target_json(t: &Target) -> Map<String, Value> {
    let names = t.names();
    let mut m = Map::new();
    m.insert("index".into(), t.index.into());
    m.insert(
        "number".into(),
        t.param
            .map_or(Value::Null, |p| p.label().to_string().into()),
    );
    m.insert("label".into(), t.label().into());
    m.insert("name_de".into(), names.map_or(Value::Null, |n| n.0.into()));
    m.insert("name_en".into(), names.map_or(Value::Null, |n| n.1.into()));
    m.insert("selector".into(), t.selector_json());
    m.insert(
        "unit".into(),
        t.param.map_or(Value::Null, |p| p.unit().into()),
    );
    m
}

/// [`value_json_in`] of a drive nothing is known of (a decoded capture, a backup file).
pub fn value_json(t: &Target, raw: i64) -> Value {
    value_json_in(t, raw, &Device::default())
}

/// One value of a parameter as a JSON object, the same keys for every family: those of
/// [`target_json`], then `raw`, `value`, `meaning` (a value name or a decoded word, else
/// `null`) and `decoded` (the decoded status/fault word, else `null`); outside the table
/// `meaning` and `decoded` are `null` and `value` is the raw value. The meaning takes what is
/// known of the drive, `device` ([`meaning_in`]).
pub fn value_json_in(t: &Target, raw: i64, device: &Device) -> Value {
    let mut m = target_json(t);
    m.insert("raw".into(), raw.into());
    match t.param {
        Some(p) => {
            let meaning = meaning_in(t, raw, device);
            m.insert("value".into(), json!(p.to_physical(raw)));
            m.insert(
                "meaning".into(),
                json!(meaning.as_ref().map(|m| m.text.clone())),
            );
            m.insert("decoded".into(), json!(meaning.and_then(|m| m.decoded)));
        }
        // The same keys outside the table, null where only the table knows.
        None => {
            m.insert("value".into(), raw.into());
            m.insert("meaning".into(), Value::Null);
            m.insert("decoded".into(), Value::Null);
        }
    }
    Value::Object(m)
}

/// A NORD state with the manual's letter and both names: `E operation enabled (Betrieb
/// freigegeben)` (BU 0250 ch. 5.1.5); a state outside the manual's table says so.
pub fn nord_state_text(state: drive_profile::nord::State) -> String {
    match drive_profile::nord::state_info(state) {
        Some(i) => format!("{} {} ({})", i.letter, i.name_en, i.name_de),
        None => format!("? {} (no state of the manual)", state.name_en()),
    }
}

/// A column value as JSON: numbers stay numbers (non-finite floats become null), lists and
/// records become arrays and objects.
fn column_json(c: drive_profile::Column<'_>) -> Value {
    match c {
        drive_profile::Column::Null => Value::Null,
        drive_profile::Column::Bool(b) => Value::Bool(b),
        drive_profile::Column::Int(n) => Value::from(n),
        drive_profile::Column::Float(x) => {
            serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
        }
        drive_profile::Column::Text(s) => Value::from(s),
        drive_profile::Column::Formatted(d) => Value::from(d.to_string()),
        drive_profile::Column::List(items) => {
            let mut list = Vec::new();
            items(&mut |c| list.push(column_json(c)));
            Value::Array(list)
        }
        drive_profile::Column::Record(fields) => {
            let mut map = Map::new();
            fields(&mut |k, c| {
                map.insert(k.to_owned(), column_json(c));
            });
            Value::Object(map)
        }
    }
}

/// The JSON object describing a parameter of a table (`drivectl params --json`, a front end's
/// table view): every key of [`drive_profile::COLUMN_KEYS`], whatever the family,
/// null where the family has no such column (`docs/params-json.md`).
pub fn param_json(p: &dyn drive_profile::ParamMeta) -> Value {
    let mut map: Map<String, Value> = drive_profile::COLUMN_KEYS
        .iter()
        .map(|k| ((*k).to_owned(), Value::Null))
        .collect();
    p.columns(&mut |k, c| {
        debug_assert!(
            drive_profile::COLUMN_KEYS.contains(&k),
            "column key {k} not in COLUMN_KEYS"
        );
        if let Some(slot) = map.get_mut(k) {
            *slot = column_json(c);
        }
    });
    Value::Object(map)
}

/// The fault a MOVIDRIVE's status word 1 shows: `F47 TIMEOUT SBUS` where the manuals name the
/// fault, else its number alone (`F43`); `None` while bit 5 is clear.
pub fn sew_fault_text(sw: StatusWord1) -> Option<String> {
    sw.fault_number().map(|n| {
        drive_profile::sew::device::fault_name(n)
            .map_or_else(|| format!("F{n:02}"), |name| format!("F{n:02} {name}"))
    })
}

/// The text of a fault parameter's value (NORD P700, Bonfiglioli 260): `None` for 0 (no
/// fault), else the table's name for it or the number.
pub fn fault_text(t: &Target, raw: i64) -> Option<String> {
    (raw != 0).then(|| meaning_of(t, raw).map_or_else(|| format!("fault {raw}"), |m| m.text))
}

/// Each access code set in `access`, in the order `Access` prints them, with what it means for
/// `family` (the legend of SEW's table, and what the other families' columns map onto).
pub fn access_codes(family: Family, access: Access) -> Vec<(&'static str, &'static str)> {
    let non_volatile = match family {
        Family::Bonfiglioli => {
            "non-volatile: a written value goes to EEPROM automatically (writes to the RAM \
             data sets 5-9 spare the EEPROM)"
        }
        _ => "non-volatile: at restart the value is copied from EEPROM into RAM",
    };
    [
        (Access::NON_VOLATILE, "N", non_volatile),
        (
            Access::STORE_LOCKED,
            "S",
            "may be stored even while the parameter lock (P803) is on",
        ),
        (
            Access::NEEDS_INHIBIT,
            "R",
            "writing needs controller inhibit (the drive must not be enabled)",
        ),
        (Access::READ_ONLY, "RO", "read-only"),
        (Access::READ_WRITE, "RW", "read/write"),
        (
            Access::NOT_IN_OPERATION,
            "NOP",
            "not writable while the drive is in operation",
        ),
        (
            Access::DATA_SET,
            "DS",
            "exists once per data set 1-4; data set 0 addresses all four",
        ),
    ]
    .into_iter()
    .filter(|(flag, _, _)| access.contains(*flag))
    .map(|(_, code, meaning)| (code, meaning))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_row_has_every_column_key_in_every_family() {
        for (family, key) in [
            (Family::Movidrive, "P130"),
            (Family::Nord, "P102"),
            (Family::Bonfiglioli, "372"),
        ] {
            let p = drive_profile::family::lookup(family, key).unwrap();
            let Value::Object(row) = param_json(p) else {
                panic!("{key}: not an object");
            };
            let keys: Vec<&str> = row.keys().map(String::as_str).collect();
            let mut want: Vec<&str> = drive_profile::COLUMN_KEYS.to_vec();
            want.sort_unstable();
            assert_eq!(keys, want, "{key}");
            // A column the family has is filled from the table, not left null.
            assert!(
                row.values().any(|v| v == &Value::from(p.bus_index())),
                "{key}: {row:?}"
            );
        }
    }

    #[test]
    fn nord_states_carry_the_manuals_letter_and_both_names() {
        use drive_profile::nord::{State, state_info};
        let i = state_info(State::OperationEnabled).unwrap();
        let text = nord_state_text(State::OperationEnabled);
        assert_eq!(text, format!("{} {} ({})", i.letter, i.name_en, i.name_de));
        assert!(text.starts_with("E "), "{text}");
        assert!(text.contains("Betrieb freigegeben"), "{text}");
    }
    use drive_profile::family::lookup;

    fn of(key: &str, raw: i64) -> Option<Meaning> {
        meaning(lookup(Family::Movidrive, key).unwrap(), raw)
    }

    #[test]
    fn drive_status_rows_decode_the_status_word() {
        // The manual's example status word 1 (ch. 4.3): 0206h.
        let m = of("P010", 0x0206).unwrap();
        assert_eq!(m.text, "ready, PO data enabled, unit status 2 = no enable");
        let d = m.decoded.unwrap();
        assert_eq!(d["status_word"], "0x0206");
        assert_eq!(d["flags"], json!(["ready", "PO data enabled"]));
        assert_eq!(d["unit_status"], json!({"code": 2, "name": "no enable"}));
        assert_eq!(d["fault"], Value::Null);
        assert_eq!(d["parameter_set"], 1);
        assert_eq!(of("P011", 0x0206).unwrap().text, "2 = no enable");
        assert_eq!(of("P012", 0x0206).unwrap().text, "no fault");
        assert_eq!(of("P013", 0x0206).unwrap().text, "parameter set 1");

        // Fault 43 (RS-485 timeout) shown with bit 5, parameter set 2 (bit 4).
        let fault = 0x2B00 | 0x20 | 0x10 | 0x02;
        assert_eq!(of("P010", fault).unwrap().text, "ready, fault/warning 43");
        assert_eq!(
            of("P011", fault).unwrap().text,
            "fault/warning 43 shown instead of the operating state"
        );
        assert_eq!(of("P012", fault).unwrap().text, "fault/warning 43");
        assert_eq!(of("P013", fault).unwrap().text, "parameter set 2");
        let d = of("P012", fault).unwrap().decoded.unwrap();
        assert_eq!(
            (d["fault"].clone(), d["unit_status"].clone()),
            (json!(43), Value::Null)
        );

        // Unnamed unit status codes and the high word are not lost.
        assert_eq!(of("P010", 0x0900).unwrap().text, "unit status 9");
        let d = of("P010", 0x1234_0000).unwrap().decoded.unwrap();
        assert_eq!(d["high_word"], "0x1234");
    }

    #[test]
    fn fault_memory_operating_states_decode_too() {
        let m = of("8391", 0x0407).unwrap();
        assert_eq!(
            m.text,
            "output stage enabled, ready, PO data enabled, unit status 4 = enable"
        );
    }

    #[test]
    fn other_parameters_keep_their_value_names_or_nothing() {
        // P870 setpoint description PO1: value 9 = control word 1.
        let m = of("P870", 9).unwrap();
        assert_eq!((m.text.as_str(), m.decoded), ("control word 1", None));
        assert_eq!(of("P130", 2000), None);
    }
}

#[cfg(test)]
mod bonfiglioli_tests {
    use super::*;

    #[test]
    fn bonfiglioli_faults_and_warnings_are_named() {
        let p260 = drive_profile::family::lookup(Family::Bonfiglioli, "260").unwrap();
        let p270 = drive_profile::family::lookup(Family::Bonfiglioli, "270").unwrap();
        assert_eq!(meaning(p260, 0).unwrap().text, "no fault");
        let f = meaning(p260, 0x2010).unwrap().text;
        assert!(f.starts_with("F2010: "), "{f}");
        assert_eq!(meaning(p270, 0).unwrap().text, "no warning");
        // Several warnings at once, each named.
        let w = meaning(p270, 0b11).unwrap().text;
        assert_eq!(w.matches(", ").count(), 1, "{w}");
    }

    fn p(key: &str) -> AnyParam {
        drive_profile::family::lookup(Family::Bonfiglioli, key).unwrap()
    }

    #[test]
    fn issue18_b8_the_status_word_is_decoded_for_its_variant() {
        let act = Device::bonfiglioli(Variant::Act, "given");
        let acu = Device::bonfiglioli(Variant::Acu, "484 not readable");
        // ACT 0x0023: switched on (ch. 9.1.2).
        let m = meaning_with(p("411"), 0x0023, &act).unwrap();
        assert_eq!(
            m.text,
            "switched on (ACT): ready to switch on, switched on, no quick stop"
        );
        let d = m.decoded.unwrap();
        assert_eq!(
            (
                &d["state"],
                &d["variant"],
                &d["variant_from"],
                &d["mains_voltage"]
            ),
            (
                &json!("switched on"),
                &json!("act"),
                &json!("given"),
                &Value::Null
            )
        );
        // ACU 0x0023: switched on without mains voltage; 0x0037 operation enabled with it.
        let m = meaning_with(p("411"), 0x0023, &acu).unwrap();
        assert!(m.text.contains("no mains voltage"), "{}", m.text);
        let d = meaning_with(p("411"), 0x0437, &acu)
            .unwrap()
            .decoded
            .unwrap();
        assert_eq!(d["state"], "operation enabled");
        assert_eq!(d["mains_voltage"], true);
        assert_eq!(d["variant_from"], "484 not readable");
        assert!(
            d["bits"]
                .as_array()
                .unwrap()
                .contains(&json!("target reached"))
        );
        // 0x00: not ready to switch on on the ACT only.
        let state = |w: i64, dev: &Device| {
            meaning_with(p("411"), w, dev).unwrap().decoded.unwrap()["state"].clone()
        };
        assert_eq!(state(0, &act), "not ready to switch on");
        assert_eq!(state(0, &acu), "unknown state");
        // Unknown device: what both share, and said; bit 4 set makes it an ACU.
        let none = Device::default();
        let m = meaning_with(p("411"), 0x0023, &none).unwrap();
        assert!(m.text.contains("the device is not known"), "{}", m.text);
        assert_eq!(m.decoded.unwrap()["variant"], Value::Null);
        assert_eq!(state(0, &none), "unknown state");
        let d = meaning_with(p("411"), 0x0033, &none)
            .unwrap()
            .decoded
            .unwrap();
        assert_eq!(
            (&d["variant"], &d["variant_from"]),
            (&json!("acu"), &json!("status word bit 4"))
        );
        // Said to be an ACT with bit 4 set: decoded as said, the contradiction named.
        let m = meaning_with(p("411"), 0x0033, &act).unwrap();
        assert!(m.text.contains("bit 4 is set"), "{}", m.text);
        assert_eq!(m.decoded.unwrap()["variant_contradicted"], true);
        // Bits no variant names are shown, not dropped.
        let m = meaning_with(p("411"), 0x4023, &act).unwrap();
        assert!(m.text.ends_with("other bits 0x4000"), "{}", m.text);
    }

    #[test]
    fn issue18_b8_faults_and_warnings_are_decoded_for_scripts() {
        let d = meaning(p("260"), 0x2010).unwrap().decoded.unwrap();
        assert_eq!(
            (&d["fault"], &d["group"], &d["code"], &d["listed"]),
            (&json!("F2010"), &json!(0x20), &json!(0x10), &json!(true))
        );
        // A key the manual does not list is shown as a key, not dropped.
        let m = meaning(p("260"), 0x2099).unwrap();
        assert_eq!(m.text, "F2099 (not in the manual's list)");
        assert_eq!(m.decoded.unwrap()["listed"], false);
        // ch. 12.1 example: 0x008B = Ixt, short-term Ixt, heat sink, motor temperature.
        let d = meaning(p("270"), 0x008B).unwrap().decoded.unwrap();
        let bits: Vec<u64> = d["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w["bit"].as_u64().unwrap())
            .collect();
        assert_eq!(bits, [0, 1, 3, 7]);
        assert_eq!(d["consistent"], true);
        // Bit 1 without bit 0 breaks the manual's footnote.
        assert_eq!(
            meaning(p("270"), 0x0002).unwrap().decoded.unwrap()["consistent"],
            false
        );
    }
}

#[cfg(test)]
mod access_tests {
    use super::*;

    #[test]
    fn every_access_code_is_explained() {
        // Each flag `Access` can print, for every family, has a meaning under the same code.
        for bit in 0..8 {
            let flag = Access::from_bits_truncate(1 << bit);
            if flag == Access::NONE {
                continue;
            }
            for family in Family::ALL {
                let codes = access_codes(family, flag);
                assert_eq!(codes.len(), 1, "{flag:?}");
                assert_eq!(codes[0].0, flag.to_string(), "{flag:?}");
                assert!(!codes[0].1.is_empty());
            }
        }
        let codes = access_codes(Family::Movidrive, Access::parse("N/R/RW").unwrap());
        let names: Vec<_> = codes.iter().map(|c| c.0).collect();
        assert_eq!(names, ["N", "R", "RW"]);
    }
}
