//! The fault keys of P260 (`FXXYY`, group in the high byte): `faults.csv`, rendered into
//! `bonfiglioli_faults.rs`.

use super::check_in;
use crate::Result;
use crate::render::{header, lit};
use crate::table::Table;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `faults.csv`.
const FAULT_COLUMNS: &[&str] = &["value", "key", "group_de", "group_en", "text_de", "text_en"];

/// One fault key.
#[derive(Debug)]
pub(super) struct Fault {
    value: u16,
    key: String,
    group_de: String,
    group_en: String,
    text_de: String,
    text_en: String,
}

/// Read the fault keys: sorted, unique, key matching the value, one name per group.
pub(super) fn read_faults(path: &Path) -> Result<Vec<Fault>> {
    let table = Table::read(path, FAULT_COLUMNS)?;
    let mut out: Vec<Fault> = Vec::new();
    let mut groups: BTreeMap<u8, (String, u64)> = BTreeMap::new();
    for row in table.rows() {
        let value = row.int("value")?;
        check_in(row, "fault value", value, 0, i64::from(u16::MAX))?;
        let value = value as u16;
        let key = row.req("key")?;
        let expected = format!("F{value:04X}");
        if key != expected {
            return Err(row.err(format!(
                "fault key `{key}` does not match value {value:#06X}: group {:02X} in the high \
                 byte and code {:02X} in the low byte give `{expected}`",
                value >> 8,
                value & 0xFF
            )));
        }
        if let Some(prev) = out.last()
            && prev.value >= value
        {
            return Err(row.err(format!(
                "fault {key} duplicate or out of order (after {}); keep the file sorted",
                prev.key
            )));
        }
        let group_de = row.req("group_de")?.to_owned();
        let group_en = row.req("group_en")?.to_owned();
        let group = (value >> 8) as u8;
        if let Some((name, line)) = groups.get(&group)
            && *name != group_en
        {
            return Err(row.err(format!(
                "group F{group:02X} is named `{group_en}` here but `{name}` on line {line}"
            )));
        }
        groups
            .entry(group)
            .or_insert((group_en.clone(), row.line()));
        out.push(Fault {
            value,
            key: key.to_owned(),
            group_de,
            group_en,
            text_de: row.req("text_de")?.to_owned(),
            text_en: row.req("text_en")?.to_owned(),
        });
    }
    Ok(out)
}

/// Render `bonfiglioli_faults.rs`.
pub(super) fn render_faults(faults: &[Fault]) -> String {
    let mut s = header("bonfiglioli/faults.csv");
    s.push_str("use crate::bonfiglioli::Fault;\n\n");
    let _ = writeln!(s, "/// The fault keys of parameter 260, sorted by value.");
    let _ = writeln!(s, "pub static FAULTS: &[Fault] = &[");
    for f in faults {
        let _ = writeln!(
            s,
            "    Fault {{ value: {:#06X}, key: {}, group_de: {}, group_en: {}, text_de: {}, text_en: {} }},",
            f.value,
            lit(&f.key),
            lit(&f.group_de),
            lit(&f.group_en),
            lit(&f.text_de),
            lit(&f.text_en)
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{expect_err, line_of, replace_line, with_edit};

    #[test]
    fn fault_key_must_match_value() {
        let line = line_of("faults.csv", "0x2010,");
        let out = with_edit("fault", "faults.csv", |t| {
            replace_line(t, "0x2010,", "0x2010,F2016,Kommunikation,Communication,x,y")
        });
        expect_err(out, "faults.csv", line, "give `F2010`");
    }
}
