//! Generator for the Bonfiglioli ACTIVE (ACT) / ACTIVE Cube (ACU) tables.
//!
//! Inputs (in `crates/drive-profile/data/bonfiglioli/`):
//!
//! * `parameters.csv`: one row per parameter, raw ranges, data type and its source, flags;
//! * `values.csv`: value lists of parameters (P11 takes its values from `vabus_errors.csv`);
//! * `warnings.csv`: the bits of P270;
//! * `faults.csv`: the fault keys of P260 (`FXXYY`, group in the high byte);
//! * `vabus_errors.csv`: the VABus SST error register P11;
//! * `exceptions.csv`: the Modbus exception codes of ch. 6.6.
//!
//! Every rule is checked before anything is rendered; every error names `file:line`.
//!
//! Each submodule reads, validates and renders one generated file: [`params`] (with the value
//! lists), [`warnings`], [`faults`], [`vabus_errors`] and [`exceptions`].

pub mod exceptions;
pub mod faults;
pub mod params;
pub mod vabus_errors;
pub mod warnings;

use crate::table::Row;
use crate::{Output, Result};
use std::path::Path;

/// The parameter whose value list is the VABus error register.
const VABUS_PARAM: u16 = 11;

/// One named value of a parameter (a value list entry or a VABus error).
#[derive(Debug, Clone)]
struct Value {
    value: i64,
    name_de: String,
    name_en: String,
}

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let params = params::read_params(&dir.join("parameters.csv"))?;
    let vabus = vabus_errors::read_vabus(&dir.join("vabus_errors.csv"), &params)?;
    let mut values = params::read_values(&dir.join("values.csv"), &params)?;
    values.insert(VABUS_PARAM, vabus.clone());
    let warnings = warnings::read_warnings(&dir.join("warnings.csv"))?;
    let faults = faults::read_faults(&dir.join("faults.csv"))?;
    let exceptions = exceptions::read_exceptions(&dir.join("exceptions.csv"))?;
    Ok(vec![
        Output {
            name: "bonfiglioli_params.rs".into(),
            text: params::render_params(&params, &values),
        },
        Output {
            name: "bonfiglioli_warnings.rs".into(),
            text: warnings::render_warnings(&warnings),
        },
        Output {
            name: "bonfiglioli_faults.rs".into(),
            text: faults::render_faults(&faults),
        },
        Output {
            name: "bonfiglioli_vabus_errors.rs".into(),
            text: vabus_errors::render_vabus(&vabus),
        },
        Output {
            name: "bonfiglioli_exceptions.rs".into(),
            text: exceptions::render_exceptions(&exceptions),
        },
    ])
}

/// `v` of row `row` must lie in `lo…hi`; `what` names it in the error.
fn check_in(row: &Row, what: &str, v: i64, lo: i64, hi: i64) -> Result<()> {
    if v < lo || v > hi {
        return Err(row.err(format!("{what} {v} is outside {lo}…{hi}")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codegen::test_util::{self, EditedData};

    pub(super) use crate::codegen::test_util::{expect_err, replace_line};

    /// The generator's result on a copy of the real inputs with `file` edited by `edit`.
    pub(super) fn with_edit(
        name: &str,
        file: &str,
        edit: impl FnOnce(&str) -> String,
    ) -> Result<Vec<Output>> {
        generate(EditedData::new("bonfiglioli", name, file, edit).dir())
    }

    /// The 1-based number of the first line of the real `file` starting with `prefix`.
    pub(super) fn line_of(file: &str, prefix: &str) -> usize {
        test_util::line_of("bonfiglioli", file, prefix)
    }

    #[test]
    fn real_tables_generate() {
        let out = generate(&test_util::data("bonfiglioli")).unwrap();
        assert_eq!(out.len(), 5);
        let params = &out[0].text;
        assert!(params.contains("number: 1376,"));
    }
}
