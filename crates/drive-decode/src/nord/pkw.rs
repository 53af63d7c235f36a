//! The USS data both transports carry: the parameter channel (PKW) and the process data (PZD).

use drive_client::target::{Target, nord_sub_parts};
use drive_client::text::{physical_text, trim_float};
use drive_profile::nord::{self, ControlWord, StatusWord};

use super::{Message, be16, param_name};

// A NORD state's text is the client layer's (drivectl's `control` and `status` say it too).
pub use drive_client::meaning::nord_state_text as state_text;

/// Explain a parameter channel of 3 or 4 words at `at`: an order (`order`) or an answer.
pub(super) fn explain_pkw(m: &mut Message, bytes: &[u8], at: usize, words: u8, order: bool) {
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
pub(super) fn explain_pzd(m: &mut Message, bytes: &[u8], at: usize, words: usize, to_drive: bool) {
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
                        state_text(state),
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
