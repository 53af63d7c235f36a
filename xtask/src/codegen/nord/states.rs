//! The state machine (BU 0255 section 4.5.3): `nord_states.csv` and `nord_transitions.csv`,
//! rendered into `nord_states.rs`.

use crate::Result;
use crate::render::{header, lit, opt};
use crate::table::{Row, Table};
use std::fmt::Write as _;
use std::path::Path;

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

/// Column `col` holds `s`, which must be `CamelCase`.
fn check_camel(row: &Row, col: &str, s: &str) -> Result<()> {
    let ok = s.starts_with(|c: char| c.is_ascii_uppercase())
        && s.chars().all(|c| c.is_ascii_alphanumeric());
    if ok {
        Ok(())
    } else {
        Err(row.err(format!("column `{col}`: `{s}` is not CamelCase")))
    }
}

/// Render `nord_states.rs`.
pub(super) fn render_states(states: &[StateRow], transitions: &[TransitionRow]) -> String {
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

#[cfg(test)]
mod tests {
    use super::super::tests::{edited, expect_err, line_of, real};
    use super::*;

    #[test]
    fn overlapping_state_patterns_are_rejected() {
        let f = "nord_states.csv";
        let n = line_of(f, "D,");
        // Switched on with bit 1 as X would also match ready to switch on.
        let d = edited(
            "overlap",
            f,
            "D,",
            "D,SwitchedOn,Eingeschaltet,switched on,01100X1,x,x",
        );
        expect_err(read_states(&d.file(f)), f, n, "overlaps `ReadyToSwitchOn`");
    }

    #[test]
    fn bad_pattern_character_is_rejected() {
        let f = "nord_states.csv";
        let n = line_of(f, "C,");
        let d = edited(
            "badchar",
            f,
            "C,",
            "C,ReadyToSwitchOn,Einschaltbereit,ready,01100?1,x,x",
        );
        expect_err(read_states(&d.file(f)), f, n, "not 0, 1 or X");
    }

    #[test]
    fn transitions_need_known_states_and_disjoint_commands() {
        let states = read_states(&real("nord_states.csv")).unwrap();
        let f = "nord_transitions.csv";
        let n = line_of(f, "3,");
        let d = edited(
            "unknownstate",
            f,
            "3,",
            "3,ReadyToSwitchOn,Running,command,E,e,XXXXX111,,s",
        );
        let r = read_transitions(&d.file(f), &states);
        expect_err(r, f, n, "unknown state `Running`");
        // Shutdown (110) out of ready to switch on toward switched on clashes with nothing,
        // but 1X1 clashes with 7a (X0X) toward switch-on disabled.
        let n7a = line_of(f, "7a,");
        let d = edited(
            "clash",
            f,
            "3,",
            "3,ReadyToSwitchOn,SwitchedOn,command,E,e,XXXXX1X1,,s",
        );
        let r = read_transitions(&d.file(f), &states);
        expect_err(r, f, n7a, "overlaps transition `3`");
    }
}
