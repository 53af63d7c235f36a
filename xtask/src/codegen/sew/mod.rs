//! Generator for the SEW MOVIDRIVE tables.
//!
//! Inputs (in `crates/drive-profile/data/sew/`), all extracted from the SEW manuals:
//!
//! * `movidrive_parameters.csv`: the parameter list (serial communication manual ch. 7.2), one
//!   row per printed table row, in manual order ([`params`]);
//! * `movidrive_groups.csv`: the section headings of the parameter list ([`groups`]);
//! * `movidrive_pno_units.csv` and `movidrive_pno_conversions.csv`: PNO size and conversion
//!   indices (ch. 7.3, [`pno`]);
//! * `movilink_error_classes.csv` and `movilink_return_codes.csv`: MOVILINK return codes
//!   (ch. 6.2 and 5.2, [`return_codes`]).
//!
//! Every row is validated; a bad row fails with `file:line: reason`. Outputs:
//! `sew_parameters.rs`, `sew_pno.rs` and `sew_return_codes.rs`.

pub mod groups;
pub mod params;
pub mod pno;
pub mod return_codes;

pub use groups::GROUP_COLUMNS;
pub use params::PARAM_COLUMNS;
pub use pno::{CONVERSION_COLUMNS, UNIT_COLUMNS};
pub use return_codes::{CLASS_COLUMNS, RETURN_CODE_COLUMNS};

use crate::table::{Row, Table};
use crate::{Output, Result};
use std::collections::BTreeSet;
use std::path::Path;

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let conversions = pno::read_conversions(dir)?;
    let units = pno::read_units(dir, &conversions)?;
    let groups = groups::read_groups(dir)?;
    let params = params::read_params(dir, &units, &conversions, &groups)?;
    let (classes, codes) = return_codes::read_return_codes(dir)?;
    Ok(vec![
        Output {
            name: "sew_parameters.rs".into(),
            text: params::render_params(&params, &groups),
        },
        Output {
            name: "sew_pno.rs".into(),
            text: pno::render_pno(&units, &conversions),
        },
        Output {
            name: "sew_return_codes.rs".into(),
            text: return_codes::render_return_codes(&classes, &codes),
        },
    ])
}

/// Every errata id (`SEW-Enn`) used by the CSV files in `dir`, for the cross-check with
/// `docs/errata-sew.md`.
pub fn errata_ids(dir: &Path) -> Result<BTreeSet<String>> {
    let mut ids = BTreeSet::new();
    for (file, cols) in [
        ("movidrive_parameters.csv", PARAM_COLUMNS),
        ("movidrive_pno_units.csv", UNIT_COLUMNS),
        ("movidrive_pno_conversions.csv", CONVERSION_COLUMNS),
    ] {
        let t = Table::read(&dir.join(file), cols)?;
        for row in t.rows() {
            for id in row.str("errata")?.split_whitespace() {
                ids.insert(id.to_owned());
            }
        }
    }
    Ok(ids)
}

/// Check the `errata` column: whitespace-separated ids `SEW-Enn`.
fn check_errata(row: &Row) -> Result<()> {
    for id in row.str("errata")?.split_whitespace() {
        let ok = id
            .strip_prefix("SEW-E")
            .is_some_and(|n| n.len() == 2 && n.bytes().all(|b| b.is_ascii_digit()));
        if !ok {
            return Err(row.err(format!("errata id `{id}` is not `SEW-Enn`")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codegen::test_util::{self, EditedData};
    use std::path::PathBuf;

    /// The real SEW data folder.
    pub(super) fn data() -> PathBuf {
        test_util::data("sew")
    }

    /// A copy of the real data folder with `file` edited by `edit`.
    pub(super) fn with_edit(
        name: &str,
        file: &str,
        edit: impl FnOnce(&str) -> String,
    ) -> EditedData {
        EditedData::new("sew", name, file, edit)
    }

    /// The error of generating from the edited copy `d`, which must fail.
    pub(super) fn err_of(d: &EditedData) -> String {
        generate(d.dir()).expect_err("must fail").0
    }

    #[test]
    fn real_tables_validate() {
        let out = generate(&data()).unwrap();
        assert_eq!(out.len(), 3);
        assert!(out.iter().all(|o| o.text.starts_with("// @generated")));
    }

    #[test]
    fn every_errata_id_is_documented() {
        let ids = errata_ids(&data()).unwrap();
        let doc =
            std::fs::read_to_string(crate::workspace_root().join("docs/errata-sew.md")).unwrap();
        for id in &ids {
            assert!(
                doc.contains(&format!("## {id}")),
                "{id} is used in the CSV files but has no section in docs/errata-sew.md"
            );
        }
        assert!(ids.len() >= 10);
    }
}
