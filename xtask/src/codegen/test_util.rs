//! Test helpers shared by the family generators: edited copies of the real data folders and
//! checks that an error names `file:line`.

use crate::Result;
use std::path::{Path, PathBuf};

/// The real data folder of `family` (`sew`, `nord`, `bonfiglioli`).
pub(crate) fn data(family: &str) -> PathBuf {
    crate::data_dir(&crate::workspace_root()).join(family)
}

/// A temporary copy of a family's data folder with one file edited; removed on drop.
#[derive(Debug)]
pub(crate) struct EditedData {
    dir: PathBuf,
}

impl EditedData {
    /// Copy every file of `family`'s data folder into a fresh folder named after `test`, then
    /// replace the text of `file` by `edit(text)`, which must change it.
    pub(crate) fn new(
        family: &str,
        test: &str,
        file: &str,
        edit: impl FnOnce(&str) -> String,
    ) -> EditedData {
        let dir = std::env::temp_dir().join(format!(
            "drivebus-xtask-{family}-{}-{test}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(data(family)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
        }
        let path = dir.join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let edited = edit(&text);
        assert_ne!(text, edited, "edit changed nothing");
        std::fs::write(&path, edited).unwrap();
        EditedData { dir }
    }

    /// The folder holding the copy.
    pub(crate) fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of `file` in the copy.
    pub(crate) fn file(&self, file: &str) -> PathBuf {
        self.dir.join(file)
    }
}

impl Drop for EditedData {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// `text` with its first line starting with `prefix` replaced by `line`.
pub(crate) fn replace_line(text: &str, prefix: &str, line: &str) -> String {
    let mut found = false;
    let out: Vec<&str> = text
        .lines()
        .map(|l| {
            if !found && l.starts_with(prefix) {
                found = true;
                line
            } else {
                l
            }
        })
        .collect();
    assert!(found, "no line starts with {prefix:?}");
    out.join("\n") + "\n"
}

/// The 1-based number of the first line starting with `prefix` in the real `file` of `family`.
pub(crate) fn line_of(family: &str, file: &str, prefix: &str) -> usize {
    let text = std::fs::read_to_string(data(family).join(file)).unwrap();
    text.lines().position(|l| l.starts_with(prefix)).unwrap() + 1
}

/// `r` must be an error that names `file:line:` and mentions `needle`.
pub(crate) fn expect_err<T: std::fmt::Debug>(r: Result<T>, file: &str, line: usize, needle: &str) {
    let e = r.expect_err("the edit must be rejected").0;
    let at = format!("{file}:{line}:");
    assert!(e.contains(&at), "error `{e}` does not name {at}");
    assert!(
        e.contains(needle),
        "error `{e}` does not mention `{needle}`"
    );
}
