//! What a raw value means beyond its number: a value name from the table, or a decoded status
//! or fault word. One function of the table entry and the raw value, so every family's `read`,
//! `watch` and JSON output show the same; each family adds its words here.
//!
//! MOVIDRIVE (serial communication manual, parameter list ch. 7): P010 drive status, P011
//! operating state, P012 fault status and P013 active parameter set are one index, 8310,
//! whose low word is "coded like status word 1"; the operating state rows of the fault memory
//! (8391–8395) are coded the same way. The manual gives no fault-code table: a fault is shown
//! by its number.

use drive_profile::Family;
use drive_profile::family::AnyParam;
use drive_profile::sew::{StatusWord1, index};
use serde_json::{Value, json};

/// The meaning of one raw value.
#[derive(Debug, Clone, PartialEq)]
pub struct Meaning {
    /// For a person, in English, e.g. `ready, PO data enabled, unit status 2 = no enable`.
    pub text: String,
    /// The decoded word for scripts (bits, unit status, fault number, …); `None` for a plain
    /// value name.
    pub decoded: Option<Value>,
}

/// What `raw` of parameter `p` means: a decoded status or fault word, else the name of the
/// value in the table's value list, else nothing.
pub fn meaning(p: AnyParam, raw: i64) -> Option<Meaning> {
    let word = match p.family() {
        Family::Movidrive => movidrive(p, raw),
        Family::Bonfiglioli => bonfiglioli(p.bus_index(), raw),
        _ => None,
    };
    word.or_else(|| {
        p.value_name(raw).map(|v| Meaning {
            text: v.en.to_owned(),
            decoded: None,
        })
    })
}

/// What `raw` of `t` means: [`meaning`] of its table entry, with what only the whole target
/// knows (a NORD array element: P700 [-02] is a warning, [-03] a reason for switch-on
/// disabled).
pub fn meaning_of(t: &super::client::Target, raw: i64) -> Option<Meaning> {
    let p = t.param?;
    if p.family() == Family::Nord {
        let (element, _) = super::client::nord_sub_parts(t.index, t.sub);
        if let Some(m) = nord(p.bus_index(), element, raw) {
            return Some(m);
        }
    }
    meaning(p, raw)
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

/// Bonfiglioli's current fault (260, "FXX YY" with its text) and warnings (270, bit-coded,
/// several at once), as the manual's ch. 12 names them. The status word 411 differs between ACT
/// and ACU, which the table does not tell apart: `drivectl bonfiglioli status` decodes it.
fn bonfiglioli(index: u16, raw: i64) -> Option<Meaning> {
    use drive_profile::bonfiglioli as b;
    let word = u16::try_from(raw).ok()?;
    let text = match index {
        260 if word == 0 => "no fault".to_owned(),
        260 => match b::fault(word) {
            Some(f) => format!("{}: {}", f.key, f.text_en),
            None => format!("fault 0x{word:04X} (not in the manual's list)"),
        },
        270 if word == 0 => "no warning".to_owned(),
        270 => b::warning_bits(word)
            .map(|w| w.name_en)
            .collect::<Vec<_>>()
            .join(", "),
        _ => return None,
    };
    Some(Meaning {
        text,
        decoded: None,
    })
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

#[cfg(test)]
mod tests {
    use super::*;
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
}
