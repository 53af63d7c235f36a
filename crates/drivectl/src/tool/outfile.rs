//! Output files that are never a device node, never replaced unasked, and never half-written.
//!
//! [`OutputFile::prepare`] checks the path before any work is done (a backup reads hundreds of
//! parameters first): it must be a regular file or not exist yet; a symlink is followed to the
//! regular file it names (the link stays a link); an existing file is replaced only with
//! `overwrite`. It creates the temporary file in the target's directory right away, so an
//! unwritable or missing directory is reported at once. A path that cannot be used is a usage
//! error (exit 2), like every other refusal of a path. [`OutputFile::commit`] writes the text,
//! gives the file the mode (and, where the process may, the owner and group) of the file it
//! replaces, checks the path again (it may have changed during the work) and renames the
//! temporary file into place;
//! a prepared file that is dropped uncommitted (an error, Ctrl-C) removes its temporary file,
//! and so does a second Ctrl-C, which ends the process at once ([`remove_temporary_files`]).

use std::fs::{File, OpenOptions};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{CliError, Result};

/// The temporary files of the prepared, uncommitted output files of this process: a second
/// Ctrl-C ends the process at once, without the drops that would remove them
/// ([`remove_temporary_files`]).
static TEMPORARY: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn forget(tmp: &Path) {
    if let Ok(mut list) = TEMPORARY.lock() {
        list.retain(|p| p != tmp);
    }
}

/// Remove the temporary files of every output file not committed yet: for an exit that skips
/// their drops (a second Ctrl-C).
pub fn remove_temporary_files() {
    if let Ok(mut list) = TEMPORARY.lock() {
        for p in list.drain(..) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// A file being written: a temporary file next to its final path.
#[derive(Debug)]
pub struct OutputFile {
    /// The path as the user gave it (for messages).
    shown: PathBuf,
    /// The regular file that is written (a symlink's target).
    target: PathBuf,
    overwrite: bool,
    tmp: PathBuf,
    file: Option<File>,
}

/// What is at `path` now, for the checks.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt as _;
    let t = meta.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_char_device() || t.is_block_device() {
        "a device node"
    } else if t.is_fifo() {
        "a named pipe"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// The regular file `shown` stands for, or why it cannot be written.
fn resolve(shown: &Path, overwrite: bool) -> Result<PathBuf> {
    let refuse = |why: String| CliError::usage(format!("{}: {why}", shown.display()));
    let target = match std::fs::symlink_metadata(shown) {
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(shown).map_err(|_| {
            refuse("is a symlink to a file that does not exist; give the file's own path".into())
        })?,
        Ok(_) => shown.to_path_buf(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(shown.to_path_buf()),
        Err(e) => return Err(refuse(format!("cannot be checked ({e})"))),
    };
    let meta =
        std::fs::metadata(&target).map_err(|e| refuse(format!("cannot be checked ({e})")))?;
    if !meta.is_file() {
        return Err(refuse(format!(
            "is {}; output goes only to regular files",
            kind_of(&meta)
        )));
    }
    if !overwrite {
        return Err(refuse(
            "exists; add --overwrite to replace it, or choose another name".into(),
        ));
    }
    Ok(target)
}

/// Why the temporary file for `path` could not be created in `dir`: a directory that is
/// missing, not a directory, not writable or on a read-only file system is a path the user
/// gave that cannot be used (a usage error); anything else is a failure.
fn unusable(path: &Path, dir: &Path, e: &std::io::Error) -> CliError {
    use std::io::ErrorKind;
    let why = match e.kind() {
        ErrorKind::NotFound => format!("the directory {} does not exist", dir.display()),
        ErrorKind::NotADirectory => format!("{} is not a directory", dir.display()),
        ErrorKind::PermissionDenied => format!("the directory {} is not writable", dir.display()),
        ErrorKind::ReadOnlyFilesystem => {
            format!(
                "the directory {} is on a read-only file system",
                dir.display()
            )
        }
        _ => {
            return CliError::failed(format!(
                "cannot write {} ({e}); nothing was read from the drive",
                path.display()
            ));
        }
    };
    CliError::usage(format!(
        "{}: cannot be written: {why}; nothing was read from the drive",
        path.display()
    ))
}

/// Give `file` the permission bits of the file it replaces, `replaced`, and its owner and group
/// where the process may (a user may give a file only a group they are in; root any owner);
/// an owner that cannot be kept leaves the file the user's, as any new file is.
fn keep_mode_and_owner(file: &File, replaced: &std::fs::Metadata) -> std::io::Result<()> {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
    let _ = std::os::unix::fs::fchown(file, Some(replaced.uid()), Some(replaced.gid()))
        .or_else(|_| std::os::unix::fs::fchown(file, None, Some(replaced.gid())));
    // After the owner: a change of owner may clear the set-ID bits, which are not kept anyway.
    file.set_permissions(std::fs::Permissions::from_mode(replaced.mode() & 0o777))
}

impl OutputFile {
    /// Check `path` and create the temporary file (see the [module docs](self)).
    pub fn prepare(path: &Path, overwrite: bool) -> Result<Self> {
        let target = resolve(path, overwrite)?;
        let name = target
            .file_name()
            .ok_or_else(|| CliError::usage(format!("{}: names no file", path.display())))?
            .to_string_lossy()
            .into_owned();
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let tmp = dir.join(format!(".{name}.drivectl-{}.tmp", std::process::id()));
        // create_new: never through something planted at the temporary name.
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| unusable(path, &dir, &e))?;
        if let Ok(mut list) = TEMPORARY.lock() {
            list.push(tmp.clone());
        }
        Ok(Self {
            shown: path.to_path_buf(),
            target,
            overwrite,
            tmp,
            file: Some(file),
        })
    }

    /// A handle on the temporary file, for output written as the work goes (a capture log);
    /// [`OutputFile::commit`] with no more text then moves it into place.
    pub fn writer(&self) -> Result<File> {
        self.file
            .as_ref()
            .ok_or_else(|| CliError::failed(format!("{}: already written", self.shown.display())))?
            .try_clone()
            .map_err(|e| CliError::failed(format!("cannot write {}: {e}", self.shown.display())))
    }

    /// Write `text` and move the file into place.
    pub fn commit(mut self, text: &str) -> Result<()> {
        let fail = |e: &dyn std::fmt::Display| {
            CliError::failed(format!("cannot write {}: {e}", self.shown.display()))
        };
        let mut file = self.file.take().ok_or_else(|| fail(&"already written"))?;
        if let Ok(replaced) = std::fs::metadata(&self.target) {
            keep_mode_and_owner(&file, &replaced).map_err(|e| fail(&e))?;
        }
        file.write_all(text.as_bytes())
            .and_then(|()| file.sync_all())
            .map_err(|e| fail(&e))?;
        drop(file);
        // The path may have changed while the drive was read.
        let now = resolve(&self.shown, self.overwrite)?;
        if now != self.target {
            return Err(fail(
                &"the path changed while the backup was made; nothing was replaced",
            ));
        }
        std::fs::rename(&self.tmp, &self.target).map_err(|e| fail(&e))?;
        forget(&self.tmp);
        self.tmp = PathBuf::new();
        Ok(())
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
            forget(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issue7_output_goes_only_to_regular_files() {
        let dir = std::env::temp_dir().join(format!("drivectl-outfile-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let err = |p: &Path, o| OutputFile::prepare(p, o).unwrap_err().to_string();
        assert!(err(Path::new("/dev/full"), true).contains("is a device node"));
        assert!(err(&dir, true).contains("is a directory"));
        // A new file: written; then it exists and needs --overwrite.
        let f = dir.join("b.json");
        OutputFile::prepare(&f, false)
            .unwrap()
            .commit("one")
            .unwrap();
        assert!(err(&f, false).contains("--overwrite"));
        OutputFile::prepare(&f, true)
            .unwrap()
            .commit("two")
            .unwrap();
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "two");
        // A symlink is followed: the target gets the text, the link stays a link.
        let link = dir.join("link.json");
        std::os::unix::fs::symlink(&f, &link).unwrap();
        OutputFile::prepare(&link, true)
            .unwrap()
            .commit("three")
            .unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "three");
        // A dangling link is refused.
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
        assert!(err(&dangling, true).contains("does not exist"));
        // An unwritable directory is reported before any work; a dropped file leaves nothing.
        assert!(err(Path::new("/proc/drivectl/b.json"), false).contains("nothing was read"));
        let pending = OutputFile::prepare(&dir.join("c.json"), false).unwrap();
        drop(pending);
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 3, "{left:?}");
        // The path turned into a directory while the work ran: nothing replaced.
        let g = dir.join("g.json");
        let pending = OutputFile::prepare(&g, false).unwrap();
        std::fs::create_dir(&g).unwrap();
        assert!(
            pending
                .commit("x")
                .unwrap_err()
                .to_string()
                .contains("is a directory")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue18_a_replaced_file_keeps_its_mode_and_an_unusable_directory_is_a_usage_error() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = std::env::temp_dir().join(format!("drivectl-outfile18-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("b.json");
        std::fs::write(&f, "old").unwrap();
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o600)).unwrap();
        OutputFile::prepare(&f, true)
            .unwrap()
            .commit("new")
            .unwrap();
        let mode = std::fs::metadata(&f).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "new");
        let e = OutputFile::prepare(Path::new("/nonexistent/x.json"), false).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert_eq!(
            e.to_string(),
            "/nonexistent/x.json: cannot be written: the directory /nonexistent does not exist; \
             nothing was read from the drive"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
