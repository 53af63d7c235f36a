//! `docs/ARCHITECTURE.md` names every crate and every top-level module, and stays short.
//!
//! The rule:
//!
//! * The crates are the workspace members of the root `Cargo.toml` (a `dir/*` member is every
//!   directory under `dir` with a `Cargo.toml`), plus `fuzz/`, which is a crate outside the
//!   workspace.
//! * A crate's top-level modules are the `mod` declarations at column 0 of its `src/lib.rs` and
//!   `src/main.rs` (`pub`, `pub(crate)` and inline ones too, and those under `#[cfg(...)]`),
//!   except a module gated by exactly `#[cfg(test)]` (a crate's own unit tests). The fuzz crate
//!   has no `src/`: its top-level units are its `[[bin]]` targets.
//! * A crate is named by a heading (outside code blocks) with its directory (`crates/movilink`,
//!   `xtask`) or its package name in backticks; its section runs to the next heading of the same
//!   or a higher level. One heading may name several crates, which then share the section.
//! * A module is named when, in its crate's section and outside code blocks, a code span is the
//!   module's name or a path starting with it (`rt`, `rt::Port`), or holds the path from the
//!   crate (`drive_core::rt`, `crate::rt`). Prose does not count: `client` must be in backticks.
//! * The file is under 15 KiB (15 360 bytes).
//!
//! Only what the code has is required, not the reverse: a module the document names before it
//! lands (or after it moved) is no failure.

use std::fs;
use std::path::{Path, PathBuf};

const LIMIT: usize = 15 * 1024;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace root")
        .to_path_buf()
}

fn architecture() -> String {
    let path = root().join("docs/ARCHITECTURE.md");
    fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A crate: its directory relative to the root, its package name, its top-level modules.
#[derive(Debug)]
struct Crate {
    dir: String,
    name: String,
    modules: Vec<String>,
}

/// The quoted strings of the `members = [...]` array in the root manifest.
fn members(manifest: &str) -> Vec<String> {
    let start = manifest
        .lines()
        .position(|l| l.trim_start().starts_with("members"))
        .expect("the root Cargo.toml lists its members");
    let mut array = String::new();
    for line in manifest.lines().skip(start) {
        array.push_str(line.split('#').next().unwrap_or(""));
        if line.contains(']') {
            break;
        }
    }
    array
        .split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

/// Every value of `key = "..."` under a `section` header of a manifest (every `[[bin]]`
/// table has one).
fn values(manifest: &str, section: &str, key: &str) -> Vec<String> {
    let mut inside = false;
    let mut found = Vec::new();
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            inside = line == section;
            continue;
        }
        let Some((k, v)) = line.split_once('=') else {
            continue;
        };
        if inside && k.trim() == key {
            found.push(v.trim().trim_matches('"').to_owned());
        }
    }
    found
}

/// The column-0 `mod` declarations of a crate root, without those under `#[cfg(test)]`.
fn modules(source: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut test_only = false;
    for line in source.lines() {
        if line.starts_with("#[") {
            test_only |= line.trim_end() == "#[cfg(test)]";
            continue;
        }
        if line.starts_with("//") {
            continue;
        }
        let mut rest = line;
        if let Some(r) = rest.strip_prefix("pub") {
            rest = match r.strip_prefix('(') {
                Some(r) => r.split_once(')').map_or("", |(_, r)| r),
                None => r,
            }
            .trim_start();
        }
        if let Some(r) = rest.strip_prefix("mod ") {
            let name: String = r
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && !test_only {
                found.push(name);
            }
        }
        test_only = false;
    }
    found
}

fn read_crate(dir: &str) -> Crate {
    let manifest = fs::read_to_string(root().join(dir).join("Cargo.toml")).unwrap();
    let name = values(&manifest, "[package]", "name")
        .pop()
        .unwrap_or_else(|| panic!("{dir}/Cargo.toml has no package name"));
    let mut modules_found = Vec::new();
    for file in ["src/lib.rs", "src/main.rs"] {
        if let Ok(source) = fs::read_to_string(root().join(dir).join(file)) {
            for module in modules(&source) {
                if !modules_found.contains(&module) {
                    modules_found.push(module);
                }
            }
        }
    }
    if modules_found.is_empty() {
        // A crate of targets only (fuzz): its binaries.
        modules_found = values(&manifest, "[[bin]]", "name");
    }
    Crate {
        dir: dir.to_owned(),
        name,
        modules: modules_found,
    }
}

fn crates() -> Vec<Crate> {
    let root = root();
    let manifest = fs::read_to_string(root.join("Cargo.toml")).unwrap();
    let mut dirs = Vec::new();
    for member in members(&manifest) {
        match member.strip_suffix("/*") {
            Some(parent) => {
                let mut found: Vec<String> = fs::read_dir(root.join(parent))
                    .unwrap()
                    .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                    .filter(|d| root.join(parent).join(d).join("Cargo.toml").is_file())
                    .map(|d| format!("{parent}/{d}"))
                    .collect();
                found.sort();
                dirs.extend(found);
            }
            None => dirs.push(member),
        }
    }
    if root.join("fuzz/Cargo.toml").is_file() {
        dirs.push("fuzz".to_owned());
    }
    dirs.iter().map(|d| read_crate(d)).collect()
}

/// The document's lines outside fenced code blocks.
fn prose(doc: &str) -> Vec<&str> {
    let mut fenced = false;
    doc.lines()
        .filter(|l| {
            if l.trim_start().starts_with("```") {
                fenced = !fenced;
                return false;
            }
            !fenced
        })
        .collect()
}

/// The inline code spans of some lines.
fn spans<'a>(lines: &[&'a str]) -> Vec<&'a str> {
    lines
        .iter()
        .flat_map(|l| l.split('`').skip(1).step_by(2))
        .collect()
}

fn level(line: &str) -> Option<usize> {
    let hashes = line.chars().take_while(|c| *c == '#').count();
    (hashes > 0 && line[hashes..].starts_with(' ')).then_some(hashes)
}

/// The section of the heading that names `krate`, if one does.
fn section<'a>(lines: &[&'a str], krate: &Crate) -> Option<Vec<&'a str>> {
    let start = lines.iter().position(|l| {
        level(l).is_some()
            && spans(&[l])
                .iter()
                .any(|s| *s == krate.dir || *s == krate.name)
    })?;
    let own = level(lines[start])?;
    let end = lines[start + 1..]
        .iter()
        .position(|l| level(l).is_some_and(|n| n <= own))
        .map_or(lines.len(), |i| start + 1 + i);
    Some(lines[start + 1..end].to_vec())
}

/// Whether a code span holds `prefix::module` as whole path segments.
fn holds_path(span: &str, prefix: &str, module: &str) -> bool {
    let needle = format!("{prefix}::{module}");
    span.match_indices(&needle).any(|(i, _)| {
        let before = span[..i].chars().next_back();
        let after = span[i + needle.len()..].chars().next();
        !before.is_some_and(|c| c.is_alphanumeric() || c == '_')
            && !after.is_some_and(|c| c.is_alphanumeric() || c == '_')
    })
}

fn names_module(section: &[&str], krate: &Crate, module: &str) -> bool {
    let ident = krate.name.replace('-', "_");
    spans(section).iter().any(|s| {
        *s == module
            || s.strip_prefix(module).is_some_and(|r| r.starts_with("::"))
            || holds_path(s, &ident, module)
            || holds_path(s, "crate", module)
    })
}

#[test]
fn architecture_names_every_crate_and_every_top_level_module() {
    let doc = architecture();
    let lines = prose(&doc);
    let crates = crates();
    assert!(crates.len() >= 12, "too few crates found: {crates:?}");
    let mut missing = Vec::new();
    for krate in &crates {
        let Some(section) = section(&lines, krate) else {
            missing.push(format!(
                "crate {} ({}): no heading names `{}` or `{}`; its modules: {}",
                krate.name,
                krate.dir,
                krate.dir,
                krate.name,
                krate.modules.join(", ")
            ));
            continue;
        };
        for module in &krate.modules {
            if !names_module(&section, krate, module) {
                missing.push(format!(
                    "crate {}: module `{module}` is not named in its section",
                    krate.name
                ));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "docs/ARCHITECTURE.md misses {} name(s):\n  {}",
        missing.len(),
        missing.join("\n  ")
    );
}

#[test]
fn architecture_is_under_15_kib() {
    let size = architecture().len();
    assert!(
        size < LIMIT,
        "docs/ARCHITECTURE.md has {size} bytes, it must stay under {LIMIT}: say less, and move \
         detail to the page it belongs on"
    );
}

#[test]
fn the_module_rule_reads_attributes_visibility_and_test_gates() {
    let source = "//! doc\n#[macro_use]\nmod tool;\npub mod a;\n#[cfg(feature = \"x\")]\n\
                  pub mod b;\n#[cfg(any(test, feature = \"testing\"))]\npub mod testing;\n\
                  #[cfg(test)]\nmod tests {\n    mod inner;\n}\npub(crate) mod c;\nmod d {}\n";
    assert_eq!(modules(source), ["tool", "a", "b", "testing", "c", "d"]);
    let krate = Crate {
        dir: "crates/drive-core".into(),
        name: "drive-core".into(),
        modules: vec![],
    };
    let section = ["`rt::Port`, `drive_core::can`, `crate::time`, `master` and `rng(x)`"];
    for module in ["rt", "can", "time", "master"] {
        assert!(names_module(&section, &krate, module), "{module}");
    }
    for module in ["rng", "port", "core"] {
        assert!(!names_module(&section, &krate, module), "{module}");
    }
}
