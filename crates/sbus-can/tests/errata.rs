//! The SBus errata page and the tests agree: every test named after an erratum (`…_sb_eN`) has
//! its entry in `docs/errata-sbus.md`, and every entry that names a test names one that exists
//! (SB-E14, about names only, has none).

// Test code: panics are the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::collections::BTreeSet;
use std::path::Path;

fn sources(dir: &Path, out: &mut String) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push_str(&std::fs::read_to_string(&path).unwrap());
        }
    }
}

/// The numbers N of every `sb_eN` / `SB-EN` in `text` (`marker` is the prefix).
fn numbers(text: &str, marker: &str) -> BTreeSet<u32> {
    text.match_indices(marker)
        .filter_map(|(i, m)| {
            let digits: String = text[i + m.len()..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            digits.parse().ok()
        })
        .collect()
}

#[test]
fn every_erratum_test_is_documented_and_every_entry_has_its_test() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let page = std::fs::read_to_string(root.join("../../docs/errata-sbus.md")).unwrap();
    let mut code = String::new();
    sources(&root.join("src"), &mut code);
    sources(&root.join("tests"), &mut code);
    // Test function names only (`fn …_sb_eN`), not this file's own text.
    let named: BTreeSet<u32> = code
        .lines()
        .filter(|l| l.trim_start().starts_with("fn ") || l.contains(" fn "))
        .flat_map(|l| numbers(l, "_sb_e"))
        .collect();
    let entries = numbers(&page, "## SB-E");
    let missing: Vec<_> = named.difference(&entries).collect();
    assert!(
        missing.is_empty(),
        "tests name errata without an entry: {missing:?}"
    );
    let untested: Vec<_> = entries.difference(&named).filter(|n| **n != 14).collect();
    assert!(
        untested.is_empty(),
        "entries without a test named after them: {untested:?}"
    );
    assert!(entries.len() >= 13, "{entries:?}");
}
