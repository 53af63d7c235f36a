//! The VABus SST error register P11: `vabus_errors.csv`, rendered into
//! `bonfiglioli_vabus_errors.rs` (and into the value list of P11).

use super::params::Param;
use super::{VABUS_PARAM, Value, check_in};
use crate::Result;
use crate::render::{header, lit};
use crate::table::Table;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `vabus_errors.csv`.
const VABUS_COLUMNS: &[&str] = &["value", "name_de", "name_en"];

/// Read the VABus error numbers: unique, inside the range of P11; sorted.
pub(super) fn read_vabus(path: &Path, params: &[Param]) -> Result<Vec<Value>> {
    let table = Table::read(path, VABUS_COLUMNS)?;
    let p11 = params.iter().find(|p| p.number == VABUS_PARAM);
    let mut out: Vec<Value> = Vec::new();
    for row in table.rows() {
        let value = row.int("value")?;
        let (lo, hi) = p11.map_or((0, 255), |p| (p.min.unwrap_or(0), p.max.unwrap_or(255)));
        check_in(row, "VABus error number", value, lo, hi)?;
        if out.iter().any(|v| v.value == value) {
            return Err(row.err(format!("duplicate VABus error number {value}")));
        }
        out.push(Value {
            value,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    out.sort_by_key(|v| v.value);
    Ok(out)
}

/// Render `bonfiglioli_vabus_errors.rs`.
pub(super) fn render_vabus(errors: &[Value]) -> String {
    let mut s = header("bonfiglioli/vabus_errors.csv");
    s.push_str("use crate::bonfiglioli::VabusError;\n\n");
    let _ = writeln!(
        s,
        "/// The values of the VABus SST error register (parameter 11), sorted."
    );
    let _ = writeln!(s, "pub static VABUS_ERRORS: &[VabusError] = &[");
    for e in errors {
        let _ = writeln!(
            s,
            "    VabusError {{ value: {}, name_de: {}, name_en: {} }},",
            e.value,
            lit(&e.name_de),
            lit(&e.name_en)
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{expect_err, line_of, replace_line, with_edit};

    #[test]
    fn duplicate_vabus_error_is_rejected() {
        let line = line_of("vabus_errors.csv", "15,");
        let out = with_edit("vabus", "vabus_errors.csv", |t| {
            replace_line(t, "15,", "14,Unbekannter Fehler,Unknown error")
        });
        expect_err(
            out,
            "vabus_errors.csv",
            line,
            "duplicate VABus error number 14",
        );
    }
}
