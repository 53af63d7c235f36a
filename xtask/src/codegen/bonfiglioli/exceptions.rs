//! The Modbus exception codes of ch. 6.6: `exceptions.csv`, rendered into
//! `bonfiglioli_exceptions.rs`.

use super::check_in;
use crate::Result;
use crate::render::{header, lit};
use crate::table::Table;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `exceptions.csv`.
const EXCEPTION_COLUMNS: &[&str] = &[
    "code",
    "modbus_name",
    "name_de",
    "name_en",
    "cause_de",
    "cause_en",
];

/// One Modbus exception code.
#[derive(Debug)]
pub(super) struct Exception {
    code: u8,
    modbus_name: String,
    name_de: String,
    name_en: String,
    cause_de: String,
    cause_en: String,
}

/// Read the exception codes: 1…127, each once; sorted.
pub(super) fn read_exceptions(path: &Path) -> Result<Vec<Exception>> {
    let table = Table::read(path, EXCEPTION_COLUMNS)?;
    let mut out: Vec<Exception> = Vec::new();
    for row in table.rows() {
        let code = row.int("code")?;
        check_in(row, "exception code", code, 1, 127)?;
        let code = code as u8;
        if out.iter().any(|e| e.code == code) {
            return Err(row.err(format!("duplicate exception code {code}")));
        }
        out.push(Exception {
            code,
            modbus_name: row.req("modbus_name")?.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            cause_de: row.req("cause_de")?.to_owned(),
            cause_en: row.req("cause_en")?.to_owned(),
        });
    }
    out.sort_by_key(|e| e.code);
    Ok(out)
}

/// Render `bonfiglioli_exceptions.rs`.
pub(super) fn render_exceptions(exceptions: &[Exception]) -> String {
    let mut s = header("bonfiglioli/exceptions.csv");
    s.push_str("use crate::bonfiglioli::ModbusException;\n\n");
    let _ = writeln!(
        s,
        "/// The Modbus exception codes the drive sends (ch. 6.6), sorted."
    );
    let _ = writeln!(s, "pub static EXCEPTIONS: &[ModbusException] = &[");
    for e in exceptions {
        let _ = writeln!(
            s,
            "    ModbusException {{ code: {}, modbus_name: {}, name_de: {}, name_en: {}, cause_de: {}, cause_en: {} }},",
            e.code,
            lit(&e.modbus_name),
            lit(&e.name_de),
            lit(&e.name_en),
            lit(&e.cause_de),
            lit(&e.cause_en)
        );
    }
    s.push_str("];\n");
    s
}
