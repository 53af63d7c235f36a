//! Generator for the NORD tables (NORDAC LINK, BU 0255: CTT2 over AS-i carrying USS PKW/PZD).
//!
//! Inputs in `crates/drive-profile/data/nord/`:
//!
//! | file | contents |
//! |---|---|
//! | `nord_control_word.csv`, `nord_status_word.csv` | the 16 bits of each word |
//! | `nord_states.csv`, `nord_transitions.csv` | the state machine (section 4.5.3) |
//! | `nord_ak_requests.csv`, `nord_ak_responses.csv`, `nord_pwe_errors.csv` | USS PKW codes |
//! | `nord_ctt2_messages.csv`, `nord_ctt2_indices.csv`, `nord_ctt2_errors.csv`, `nord_ctt2_objects.csv` | CTT2 |
//! | `nord_parameters.csv`, `nord_param_arrays.csv`, `nord_param_values.csv` | parameters |
//!
//! Each submodule reads, validates and renders one generated file: [`words`], [`states`],
//! [`uss`], [`ctt2`] and [`params`]. Every check reports `file:line: reason` through
//! [`Row::err`](crate::table::Row::err).

pub mod ctt2;
pub mod params;
pub mod states;
pub mod uss;
pub mod words;

use crate::{Output, Result};
use std::path::Path;

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let cw = words::read_bits(&dir.join("nord_control_word.csv"), true)?;
    let sw = words::read_bits(&dir.join("nord_status_word.csv"), false)?;
    let states = states::read_states(&dir.join("nord_states.csv"))?;
    let transitions = states::read_transitions(&dir.join("nord_transitions.csv"), &states)?;
    let responses = uss::read_ak_responses(&dir.join("nord_ak_responses.csv"))?;
    let requests = uss::read_ak_requests(&dir.join("nord_ak_requests.csv"), &responses)?;
    let pwe = uss::read_pwe_errors(&dir.join("nord_pwe_errors.csv"))?;
    let messages = ctt2::read_ctt2_messages(&dir.join("nord_ctt2_messages.csv"))?;
    let indices = ctt2::read_ctt2_indices(&dir.join("nord_ctt2_indices.csv"))?;
    let ctt2_errors = ctt2::read_ctt2_errors(&dir.join("nord_ctt2_errors.csv"))?;
    let objects = ctt2::read_ctt2_objects(&dir.join("nord_ctt2_objects.csv"), &indices)?;
    let mut params = params::read_params(&dir.join("nord_parameters.csv"))?;
    params::read_param_arrays(&dir.join("nord_param_arrays.csv"), &mut params)?;
    params::read_param_values(&dir.join("nord_param_values.csv"), &mut params)?;

    Ok(vec![
        Output {
            name: "nord_words.rs".into(),
            text: words::render_words(&cw, &sw),
        },
        Output {
            name: "nord_states.rs".into(),
            text: states::render_states(&states, &transitions),
        },
        Output {
            name: "nord_uss.rs".into(),
            text: uss::render_uss(&requests, &responses, &pwe),
        },
        Output {
            name: "nord_ctt2.rs".into(),
            text: ctt2::render_ctt2(&messages, &indices, &ctt2_errors, &objects),
        },
        Output {
            name: "nord_params.rs".into(),
            text: params::render_params(&params),
        },
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codegen::test_util::{self, EditedData, replace_line};
    use std::path::PathBuf;

    pub(super) use crate::codegen::test_util::expect_err;

    /// The real file `file` of the NORD data folder.
    pub(super) fn real(file: &str) -> PathBuf {
        test_util::data("nord").join(file)
    }

    /// A copy of the real data folder in which the line of `file` starting with `prefix` is
    /// replaced by `line`.
    pub(super) fn edited(test: &str, file: &str, prefix: &str, line: &str) -> EditedData {
        EditedData::new("nord", test, file, |t| replace_line(t, prefix, line))
    }

    /// The 1-based number of the first line of the real `file` starting with `prefix`.
    pub(super) fn line_of(file: &str, prefix: &str) -> usize {
        test_util::line_of("nord", file, prefix)
    }

    #[test]
    fn real_tables_generate() {
        let out = generate(&real("")).unwrap();
        assert_eq!(out.len(), 5);
        assert!(out.iter().all(|o| o.text.starts_with("// @generated")));
    }
}
