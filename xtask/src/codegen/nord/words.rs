//! Control and status word bits (BU 0255 section 4.5): `nord_control_word.csv` and
//! `nord_status_word.csv`, rendered into `nord_words.rs`.

use crate::Result;
use crate::render::{header, lit, opt_display};
use crate::table::{Row, Table};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

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
        let name_de = row.req("name_de")?.to_owned();
        let name_en = row.req("name_en")?.to_owned();
        let (meaning0_de, meaning0_en) = row.text_pair("meaning0_de", "meaning0_en")?;
        let (meaning1_de, meaning1_en) = row.text_pair("meaning1_de", "meaning1_en")?;
        out.push(Bit {
            bit,
            key: key.to_owned(),
            name_de,
            name_en,
            meaning0_de: meaning0_de.to_owned(),
            meaning0_en: meaning0_en.to_owned(),
            meaning1_de: meaning1_de.to_owned(),
            meaning1_en: meaning1_en.to_owned(),
            priority0,
            priority1,
        });
    }
    if out.len() != 16 {
        let missing: Vec<String> = (0..16u8)
            .filter(|i| !out.iter().any(|b| b.bit == *i))
            .map(|i| i.to_string())
            .collect();
        return Err(table.err(format!(
            "the word needs all 16 bits; missing {}",
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

/// Column `col` holds `s`, which must be `snake_case`.
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

/// Render `nord_words.rs`.
pub(super) fn render_words(cw: &[Bit], sw: &[Bit]) -> String {
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
                opt_display(b.priority0),
                opt_display(b.priority1),
            );
        }
        s.push_str("];\n\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{edited, expect_err, line_of};
    use super::*;

    #[test]
    fn duplicate_bit_names_file_and_line() {
        let f = "nord_control_word.csv";
        let n = line_of(f, "5,");
        let d = edited("dupbit", f, "5,", "4,enable_x,A,a,,,,,,");
        let r = read_bits(&d.file(f), true);
        expect_err(r, f, n, "bit 4 appears twice");
    }

    #[test]
    fn bit_outside_word_is_rejected() {
        let f = "nord_status_word.csv";
        let n = line_of(f, "15,");
        let d = edited("bit16", f, "15,", "16,parameter_set_bit1,A,a,,,,");
        expect_err(read_bits(&d.file(f), false), f, n, "outside 0..15");
    }

    #[test]
    fn missing_bit_is_reported() {
        let f = "nord_status_word.csv";
        let d = edited("missing", f, "15,", "# removed");
        let e = read_bits(&d.file(f), false).unwrap_err().0;
        assert!(e.contains("missing 15"), "{e}");
        assert!(e.contains(&format!("{f}:")), "{e}");
    }
}
