//! The warning bits of P270: `warnings.csv`, rendered into `bonfiglioli_warnings.rs`.

use super::check_in;
use crate::Result;
use crate::render::{header, lit, opt_display};
use crate::table::Table;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `warnings.csv`.
const WARNING_COLUMNS: &[&str] = &[
    "bit", "code", "name_de", "name_en", "implies", "note_de", "note_en",
];

/// One warning bit.
#[derive(Debug)]
pub(super) struct Warning {
    bit: u8,
    name_de: String,
    name_en: String,
    implies: Option<u8>,
    note_de: String,
    note_en: String,
}

/// Read the warning bits: each of 0…15 once, code `1 << bit`, implied bits other than itself.
pub(super) fn read_warnings(path: &Path) -> Result<Vec<Warning>> {
    let table = Table::read(path, WARNING_COLUMNS)?;
    let mut out: Vec<Warning> = Vec::new();
    for row in table.rows() {
        let bit = row.int("bit")?;
        check_in(row, "warning bit", bit, 0, 15)?;
        let bit = bit as u8;
        if out.iter().any(|w| w.bit == bit) {
            return Err(row.err(format!("duplicate warning bit {bit}")));
        }
        let code = row.int("code")?;
        if code != 1i64 << bit {
            return Err(row.err(format!(
                "warning code {code:#06X} of bit {bit} must be {:#06X} (1 << bit)",
                1u32 << bit
            )));
        }
        let implies = match row.opt_int("implies")? {
            None => None,
            Some(b) => {
                check_in(row, "implied bit", b, 0, 15)?;
                if b == i64::from(bit) {
                    return Err(row.err("a warning bit cannot imply itself"));
                }
                Some(b as u8)
            }
        };
        out.push(Warning {
            bit,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            implies,
            note_de: row.str("note_de")?.to_owned(),
            note_en: row.str("note_en")?.to_owned(),
        });
    }
    out.sort_by_key(|w| w.bit);
    if out.len() != 16 {
        let have: BTreeSet<u8> = out.iter().map(|w| w.bit).collect();
        let missing: Vec<String> = (0..16u8)
            .filter(|b| !have.contains(b))
            .map(|b| b.to_string())
            .collect();
        return Err(table.err(format!("warning bits missing: {}", missing.join(", "))));
    }
    Ok(out)
}

/// Render `bonfiglioli_warnings.rs`.
pub(super) fn render_warnings(warnings: &[Warning]) -> String {
    let mut s = header("bonfiglioli/warnings.csv");
    s.push_str("use crate::bonfiglioli::Warning;\n\n");
    let _ = writeln!(
        s,
        "/// The warning bits of parameter 270, indexed by bit number."
    );
    let _ = writeln!(s, "pub static WARNINGS: [Warning; 16] = [");
    for w in warnings {
        let _ = writeln!(
            s,
            "    Warning {{ bit: {}, code: {:#06X}, name_de: {}, name_en: {}, implies: {}, note_de: {}, note_en: {} }},",
            w.bit,
            1u16 << w.bit,
            lit(&w.name_de),
            lit(&w.name_en),
            opt_display(w.implies),
            lit(&w.note_de),
            lit(&w.note_en)
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{expect_err, line_of, replace_line, with_edit};

    #[test]
    fn warning_code_must_be_its_bit() {
        let line = line_of("warnings.csv", "5,");
        let out = with_edit("warn", "warnings.csv", |t| {
            replace_line(t, "5,", "5,0x0040,Warnung I-Limit,Warning current limit,,,")
        });
        expect_err(out, "warnings.csv", line, "must be 0x0020");
    }

    #[test]
    fn duplicate_warning_bit_is_rejected() {
        let line = line_of("warnings.csv", "15,");
        let out = with_edit("warndup", "warnings.csv", |t| {
            replace_line(t, "15,", "14,0x4000,Warnung Udc,Warning DC link voltage,,,")
        });
        expect_err(out, "warnings.csv", line, "duplicate warning bit 14");
    }
}
