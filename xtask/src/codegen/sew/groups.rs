//! The section headings of the parameter list: `movidrive_groups.csv`, rendered into
//! `sew_parameters.rs` together with the parameters.

use crate::Result;
use crate::render::lit;
use crate::table::Table;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `movidrive_groups.csv`.
pub const GROUP_COLUMNS: &[&str] = &["group", "name_de", "name_en"];

/// One section heading of the parameter list.
#[derive(Debug, Clone)]
pub(super) struct Group {
    /// The group code, `N..` or `NN.`.
    pub(super) code: String,
    name_de: String,
    name_en: String,
}

/// Read the section headings: codes `N..` or `NN.`, each once.
pub(super) fn read_groups(dir: &Path) -> Result<Vec<Group>> {
    let t = Table::read(&dir.join("movidrive_groups.csv"), GROUP_COLUMNS)?;
    let mut out: Vec<Group> = Vec::new();
    for row in t.rows() {
        let code = row.req("group")?;
        let b = code.as_bytes();
        let ok = match b {
            [d, b'.', b'.'] => d.is_ascii_digit(),
            [d, e, b'.'] => d.is_ascii_digit() && e.is_ascii_digit(),
            _ => false,
        };
        if !ok {
            return Err(row.err(format!("group `{code}` is not `N..` or `NN.`")));
        }
        if out.iter().any(|g| g.code == code) {
            return Err(row.err(format!("duplicate group `{code}`")));
        }
        out.push(Group {
            code: code.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    Ok(out)
}

/// Append the `GROUPS` table to the text of `sew_parameters.rs`.
pub(super) fn render(s: &mut String, groups: &[Group]) {
    s.push_str("/// The section headings of the parameter list, in manual order.\npub static GROUPS: &[Group] = &[\n");
    for g in groups {
        let _ = writeln!(
            s,
            "    Group {{ code: {}, name_de: {}, name_en: {} }},",
            lit(&g.code),
            lit(&g.name_de),
            lit(&g.name_en)
        );
    }
    s.push_str("];\n\n");
}
