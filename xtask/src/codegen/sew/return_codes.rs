//! MOVILINK return codes (manual ch. 6.2 and 5.2): `movilink_error_classes.csv` and
//! `movilink_return_codes.csv`, rendered into `sew_return_codes.rs`.

use crate::Result;
use crate::render::{header, lit};
use crate::table::Table;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `movilink_error_classes.csv`.
pub const CLASS_COLUMNS: &[&str] = &["class", "name", "meaning_de", "meaning_en"];
/// Columns of `movilink_return_codes.csv`.
pub const RETURN_CODE_COLUMNS: &[&str] = &[
    "class", "code", "add_high", "add_low", "name_de", "name_en", "source", "retry",
];

/// One error class.
#[derive(Debug, Clone)]
pub(super) struct Class {
    class: i64,
    name: String,
    de: String,
    en: String,
}

/// One return code with its meaning.
#[derive(Debug, Clone)]
pub(super) struct Code {
    class: i64,
    code: i64,
    add: i64,
    de: String,
    en: String,
    source: String,
    retry: bool,
}

/// Read the error classes and the return codes: bytes, each once, of a known class.
pub(super) fn read_return_codes(dir: &Path) -> Result<(Vec<Class>, Vec<Code>)> {
    let t = Table::read(&dir.join("movilink_error_classes.csv"), CLASS_COLUMNS)?;
    let mut classes: Vec<Class> = Vec::new();
    for row in t.rows() {
        let class = i64::from(row.byte("class")?);
        if classes.iter().any(|c| c.class == class) {
            return Err(row.err(format!("duplicate error class {class}")));
        }
        classes.push(Class {
            class,
            name: row.req("name")?.to_owned(),
            de: row.req("meaning_de")?.to_owned(),
            en: row.req("meaning_en")?.to_owned(),
        });
    }
    let t = Table::read(&dir.join("movilink_return_codes.csv"), RETURN_CODE_COLUMNS)?;
    let mut codes: Vec<Code> = Vec::new();
    for row in t.rows() {
        let class = row.int("class")?;
        if !classes.iter().any(|c| c.class == class) {
            return Err(row.err(format!("unknown error class {class}")));
        }
        let code = i64::from(row.byte("code")?);
        let add = (row.hex("add_high", 2)? << 8) | row.hex("add_low", 2)?;
        if codes
            .iter()
            .any(|c| (c.class, c.code, c.add) == (class, code, add))
        {
            return Err(row.err(format!("duplicate return code {class}/{code}/{add:04X}")));
        }
        let source = row.req("source")?.to_owned();
        if !["5.2", "6.2"].contains(&source.as_str()) {
            return Err(row.err(format!(
                "source `{source}` is not a manual section (5.2 or 6.2)"
            )));
        }
        codes.push(Code {
            class,
            code,
            add,
            de: row.req("name_de")?.to_owned(),
            en: row.req("name_en")?.to_owned(),
            source,
            retry: row.flag("retry")?,
        });
    }
    classes.sort_by_key(|c| c.class);
    codes.sort_by_key(|c| (c.class, c.code, c.add));
    Ok((classes, codes))
}

/// Render `sew_return_codes.rs`.
pub(super) fn render_return_codes(classes: &[Class], codes: &[Code]) -> String {
    let mut s = header(
        "MOVILINK return codes, sew/movilink_error_classes.csv and movilink_return_codes.csv",
    );
    s.push_str("use crate::sew::{ErrorClassInfo, ReturnCodeInfo};\n\n");
    s.push_str(
        "/// The error classes (EN 50170), sorted.\npub static ERROR_CLASSES: &[ErrorClassInfo] = &[\n",
    );
    for c in classes {
        let _ = writeln!(
            s,
            "    ErrorClassInfo {{ class: {}, name: {}, de: {}, en: {} }},",
            c.class,
            lit(&c.name),
            lit(&c.de),
            lit(&c.en)
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// The return codes with a meaning, sorted by (class, code, additional code).\npub static RETURN_CODES: &[ReturnCodeInfo] = &[\n");
    for c in codes {
        let _ = writeln!(
            s,
            "    ReturnCodeInfo {{ class: {}, code: {}, additional: 0x{:04X}, de: {}, en: {}, section: {}, retry: {} }},",
            c.class,
            c.code,
            c.add,
            lit(&c.de),
            lit(&c.en),
            lit(&c.source),
            c.retry
        );
    }
    s.push_str("];\n");
    s
}
