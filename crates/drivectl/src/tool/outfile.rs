//! Output files on the command line: `drive_client`'s [`outfile`](drive_client::outfile)
//! (regular files only, a symlink followed, replaced only with `--overwrite`, written to a
//! temporary file and renamed, mode and owner kept) with its refusals in the command line's
//! words. A path that cannot be used is a usage error (exit 2), like every other refusal of a
//! path; a failure to write is exit 1.

use drive_client::outfile::OutputError;

use crate::error::CliError;

pub use drive_client::outfile::OutputFile;

/// An output file's refusal in the command line's words.
impl From<OutputError> for CliError {
    fn from(e: OutputError) -> Self {
        match e {
            OutputError::NotAFile { .. } => {
                CliError::usage(format!("{e}; output goes only to regular files"))
            }
            OutputError::Exists { .. } => CliError::usage(format!(
                "{e}; add --overwrite to replace it, or choose another name"
            )),
            OutputError::DanglingLink { .. } => {
                CliError::usage(format!("{e}; give the file's own path"))
            }
            OutputError::Check { .. } | OutputError::NoFileName { .. } => {
                CliError::usage(e.to_string())
            }
            OutputError::Directory { .. } => {
                CliError::usage(format!("{e}; nothing was read from the drive"))
            }
            OutputError::Create { .. } => {
                CliError::failed(format!("{e}; nothing was read from the drive"))
            }
            OutputError::Changed { path } => CliError::failed(format!(
                "cannot write {}: the path changed while the backup was made; nothing was replaced",
                path.display()
            )),
            other => CliError::failed(other.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn issue7_issue18_refusals_say_the_way_out_with_their_exit_codes() {
        let dir = std::env::temp_dir().join(format!("drivectl-outfile-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let err = |p: &Path, o| CliError::from(OutputFile::prepare(p, o).unwrap_err());
        let e = err(Path::new("/dev/full"), true);
        assert_eq!(e.exit_code(), 2);
        assert_eq!(
            e.to_string(),
            "/dev/full: is a device node; output goes only to regular files"
        );
        let f = dir.join("b.json");
        OutputFile::prepare(&f, false)
            .unwrap()
            .commit("one")
            .unwrap();
        assert!(
            err(&f, false)
                .to_string()
                .ends_with("b.json: exists; add --overwrite to replace it, or choose another name")
        );
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
        assert!(
            err(&dangling, true)
                .to_string()
                .ends_with("is a symlink to a file that does not exist; give the file's own path")
        );
        let e = err(Path::new("/nonexistent/x.json"), false);
        assert_eq!(e.exit_code(), 2);
        assert_eq!(
            e.to_string(),
            "/nonexistent/x.json: cannot be written: the directory /nonexistent does not exist; \
             nothing was read from the drive"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
