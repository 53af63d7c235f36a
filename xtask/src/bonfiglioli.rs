//! Generator for the bonfiglioli tables (owned by the bonfiglioli data work).

use crate::{Output, Result};
use std::path::Path;

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let _ = dir;
    Ok(Vec::new())
}
