//! Code generation from the tables extracted from the vendor manuals, and of sparkplug-b's
//! payload types from the Sparkplug B schema ([`codegen::sparkplug`]).
//!
//! Every CSV file is read with [`table::Table`], which names `file:line` in every error.
//! Each drive family has its own folder under [`codegen`](mod@codegen) that validates its files
//! and renders Rust source.

pub mod codegen;
pub mod interop;
pub mod render;
pub mod table;

use codegen::{bonfiglioli, nord, sew, sparkplug};

use std::fmt;
use std::path::{Path, PathBuf};

/// An error of the generator: a bad CSV row (`file:line: reason`), an I/O failure or stale output.
#[derive(Debug)]
pub struct Error(pub String);

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

/// Result alias of the generator.
pub type Result<T> = std::result::Result<T, Error>;

/// One generated file: its name inside `src/generated/` and its full text.
#[derive(Debug)]
pub struct Output {
    /// File name, e.g. `sew_parameters.rs`.
    pub name: String,
    /// Complete file contents including the header.
    pub text: String,
}

/// The workspace root (the parent of this crate's manifest directory).
pub fn workspace_root() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| here.to_path_buf())
}

/// The folder holding the CSV inputs.
pub fn data_dir(root: &Path) -> PathBuf {
    root.join("crates/drive-profile/data")
}

/// The folder receiving the generated Rust files.
pub fn generated_dir(root: &Path) -> PathBuf {
    root.join("crates/drive-profile/src/generated")
}

/// Render every generated file in memory.
pub fn generate_all(root: &Path) -> Result<Vec<Output>> {
    let data = data_dir(root);
    let mut out = Vec::new();
    out.extend(sew::generate(&data.join("sew"))?);
    out.extend(nord::generate(&data.join("nord"))?);
    out.extend(bonfiglioli::generate(&data.join("bonfiglioli"))?);
    let mut names: Vec<&str> = out.iter().map(|o| o.name.as_str()).collect();
    names.sort_unstable();
    let mut modrs = render::header("the list of generated modules");
    for n in &names {
        let m = n.trim_end_matches(".rs");
        modrs.push_str(&format!("pub mod {m};\n"));
    }
    out.push(Output {
        name: "mod.rs".into(),
        text: modrs,
    });
    Ok(out)
}

/// Validate, generate and write (or, with `check`, compare) every generated file.
pub fn codegen(root: &Path, check: bool) -> Result<String> {
    let outputs = generate_all(root)?;
    let dir = generated_dir(root);
    let mut stale = Vec::new();
    for o in &outputs {
        let path = dir.join(&o.name);
        let current = std::fs::read_to_string(&path).ok();
        if current.as_deref() != Some(o.text.as_str()) {
            stale.push(o.name.clone());
            if !check {
                std::fs::create_dir_all(&dir)
                    .map_err(|e| Error(format!("{}: {e}", dir.display())))?;
                std::fs::write(&path, &o.text)
                    .map_err(|e| Error(format!("{}: {e}", path.display())))?;
            }
        }
    }
    // Files in the folder that the generator no longer produces are stale too.
    if let Ok(rd) = std::fs::read_dir(&dir) {
        for entry in rd.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.ends_with(".rs") && !outputs.iter().any(|o| o.name == name) {
                stale.push(name.clone());
                if !check {
                    std::fs::remove_file(entry.path())
                        .map_err(|e| Error(format!("{}: {e}", entry.path().display())))?;
                }
            }
        }
    }
    // sparkplug-b's payload types, from its `.proto`.
    let proto = sparkplug::generate(root)?;
    let path = sparkplug::output_path(root);
    if std::fs::read_to_string(&path).ok().as_deref() != Some(proto.as_str()) {
        stale.push(sparkplug::OUTPUT.to_owned());
        if !check {
            std::fs::write(&path, &proto).map_err(|e| Error(format!("{}: {e}", path.display())))?;
        }
    }
    let total = outputs.len() + 1;
    if check && !stale.is_empty() {
        return Err(Error(format!(
            "generated tables are stale ({}); run `cargo xtask codegen` and commit the result",
            stale.join(", ")
        )));
    }
    Ok(if stale.is_empty() {
        format!("{total} generated files up to date")
    } else {
        format!(
            "wrote {} of {} generated files: {}",
            stale.len(),
            total,
            stale.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn committed_tables_are_fresh() {
        let root = super::workspace_root();
        if let Err(e) = super::codegen(&root, true) {
            panic!("{e}");
        }
    }
}
