//! Output files (a backup, a capture log, a state file) that are never a device node, never
//! replaced unasked, and never half-written.
//!
//! [`OutputFile::prepare`] checks the path before any work is done (a backup reads hundreds of
//! parameters first): it must be a regular file or not exist yet; a symlink is followed to the
//! regular file it names (the link stays a link); an existing file is replaced only with
//! `overwrite`. It creates the temporary file in the target's directory right away, so an
//! unwritable or missing directory is reported at once. [`OutputFile::commit`] writes the text,
//! gives the file the mode (and, where the process may, the owner and group) of the file it
//! replaces, checks the path again (it may have changed during the work) and renames the
//! temporary file into place. A prepared file that is dropped uncommitted (an error, an
//! interrupt) removes its temporary file; an exit that skips the drops (a second signal) calls
//! [`remove_temporary_files`] first.

use std::fs::{File, OpenOptions};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What a path names instead of a regular file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FileKind {
    /// A directory.
    Directory,
    /// A character or block device (a serial port, `/dev/null`).
    Device,
    /// A named pipe.
    Fifo,
    /// A socket.
    Socket,
    /// Anything else that is no regular file.
    Other,
}

impl std::fmt::Display for FileKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileKind::Directory => "a directory",
            FileKind::Device => "a device node",
            FileKind::Fifo => "a named pipe",
            FileKind::Socket => "a socket",
            FileKind::Other => "not a regular file",
        })
    }
}

/// Why the directory of an output file cannot take it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DirProblem {
    /// It does not exist.
    Missing,
    /// It is not a directory.
    NotADirectory,
    /// It is not writable.
    NotWritable,
    /// It is on a read-only file system.
    ReadOnly,
}

/// `the directory /x does not exist`, `/x is not a directory`, …
fn dir_text(dir: &Path, problem: DirProblem) -> String {
    let dir = dir.display();
    match problem {
        DirProblem::Missing => format!("the directory {dir} does not exist"),
        DirProblem::NotADirectory => format!("{dir} is not a directory"),
        DirProblem::NotWritable => format!("the directory {dir} is not writable"),
        DirProblem::ReadOnly => format!("the directory {dir} is on a read-only file system"),
    }
}

/// Why an output file was not written; the file at its path is as it was.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The path names something that is no regular file.
    #[error("{}: is {kind}", .path.display())]
    NotAFile {
        /// The path as given.
        path: PathBuf,
        /// What it names.
        kind: FileKind,
    },
    /// A file exists at the path and replacing it was not asked for.
    #[error("{}: exists", .path.display())]
    Exists {
        /// The path as given.
        path: PathBuf,
    },
    /// The path is a symlink to nothing.
    #[error("{}: is a symlink to a file that does not exist", .path.display())]
    DanglingLink {
        /// The path as given.
        path: PathBuf,
    },
    /// The path could not be looked at.
    #[error("{}: cannot be checked ({source})", .path.display())]
    Check {
        /// The path as given.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The path names no file (`/`, `..`).
    #[error("{}: names no file", .path.display())]
    NoFileName {
        /// The path as given.
        path: PathBuf,
    },
    /// The directory cannot take the file.
    #[error("{}: cannot be written: {}", .path.display(), dir_text(dir, *problem))]
    Directory {
        /// The path as given.
        path: PathBuf,
        /// The directory.
        dir: PathBuf,
        /// What is wrong with it.
        problem: DirProblem,
    },
    /// The temporary file could not be created for another reason.
    #[error("cannot write {} ({source})", .path.display())]
    Create {
        /// The path as given.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// Writing, syncing or renaming failed.
    #[error("cannot write {}: {source}", .path.display())]
    Write {
        /// The path as given.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The path now names another file than when it was prepared: nothing was replaced.
    #[error("cannot write {}: the path changed during the work; nothing was replaced", .path.display())]
    Changed {
        /// The path as given.
        path: PathBuf,
    },
}

/// The temporary files of the prepared, uncommitted output files of this process.
static TEMPORARY: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn forget(tmp: &Path) {
    if let Ok(mut list) = TEMPORARY.lock() {
        list.retain(|p| p != tmp);
    }
}

/// Remove the temporary files of every output file not committed yet: for an exit that skips
/// their drops (a second signal, `signals`).
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

fn kind_of(meta: &std::fs::Metadata) -> FileKind {
    use std::os::unix::fs::FileTypeExt as _;
    let t = meta.file_type();
    if t.is_dir() {
        FileKind::Directory
    } else if t.is_char_device() || t.is_block_device() {
        FileKind::Device
    } else if t.is_fifo() {
        FileKind::Fifo
    } else if t.is_socket() {
        FileKind::Socket
    } else {
        FileKind::Other
    }
}

/// The regular file `shown` stands for, or why it cannot be written.
fn resolve(shown: &Path, overwrite: bool) -> Result<PathBuf, OutputError> {
    let path = || shown.to_path_buf();
    let target = match std::fs::symlink_metadata(shown) {
        Ok(m) if m.file_type().is_symlink() => {
            std::fs::canonicalize(shown).map_err(|_| OutputError::DanglingLink { path: path() })?
        }
        Ok(_) => path(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(path()),
        Err(source) => {
            return Err(OutputError::Check {
                path: path(),
                source,
            });
        }
    };
    let meta = std::fs::metadata(&target).map_err(|source| OutputError::Check {
        path: path(),
        source,
    })?;
    if !meta.is_file() {
        return Err(OutputError::NotAFile {
            path: path(),
            kind: kind_of(&meta),
        });
    }
    if !overwrite {
        return Err(OutputError::Exists { path: path() });
    }
    Ok(target)
}

/// Why the temporary file for `path` could not be created in `dir`.
fn unusable(path: &Path, dir: &Path, source: std::io::Error) -> OutputError {
    use std::io::ErrorKind;
    let problem = match source.kind() {
        ErrorKind::NotFound => DirProblem::Missing,
        ErrorKind::NotADirectory => DirProblem::NotADirectory,
        ErrorKind::PermissionDenied => DirProblem::NotWritable,
        ErrorKind::ReadOnlyFilesystem => DirProblem::ReadOnly,
        _ => {
            return OutputError::Create {
                path: path.to_path_buf(),
                source,
            };
        }
    };
    OutputError::Directory {
        path: path.to_path_buf(),
        dir: dir.to_path_buf(),
        problem,
    }
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

fn already_written() -> std::io::Error {
    std::io::Error::other("already written")
}

impl OutputFile {
    /// Check `path` and create the temporary file (see the [module docs](self)).
    pub fn prepare(path: &Path, overwrite: bool) -> Result<Self, OutputError> {
        let target = resolve(path, overwrite)?;
        let name = target
            .file_name()
            .ok_or_else(|| OutputError::NoFileName {
                path: path.to_path_buf(),
            })?
            .to_string_lossy()
            .into_owned();
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let tmp = dir.join(format!(".{name}.drivebus-{}.tmp", std::process::id()));
        // create_new: never through something planted at the temporary name.
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| unusable(path, &dir, e))?;
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

    /// The path as given.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    /// A handle on the temporary file, for output written as the work goes (a capture log);
    /// [`OutputFile::commit`] with no more text then moves it into place.
    pub fn writer(&self) -> Result<File, OutputError> {
        let write = |source| OutputError::Write {
            path: self.shown.clone(),
            source,
        };
        self.file
            .as_ref()
            .ok_or_else(|| write(already_written()))?
            .try_clone()
            .map_err(write)
    }

    /// Write `text` and move the file into place.
    pub fn commit(mut self, text: &str) -> Result<(), OutputError> {
        let shown = self.shown.clone();
        let write = |source| OutputError::Write {
            path: shown.clone(),
            source,
        };
        let mut file = self.file.take().ok_or_else(|| write(already_written()))?;
        if let Ok(replaced) = std::fs::metadata(&self.target) {
            keep_mode_and_owner(&file, &replaced).map_err(write)?;
        }
        file.write_all(text.as_bytes())
            .and_then(|()| file.sync_all())
            .map_err(write)?;
        drop(file);
        // The path may have changed while the work ran.
        if resolve(&self.shown, self.overwrite)? != self.target {
            return Err(OutputError::Changed { path: shown });
        }
        std::fs::rename(&self.tmp, &self.target).map_err(write)?;
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

    fn fresh(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("drive-client-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn issue7_output_goes_only_to_regular_files() {
        let dir = fresh("outfile");
        let err = |p: &Path, o| OutputFile::prepare(p, o).unwrap_err();
        assert!(matches!(
            err(Path::new("/dev/full"), true),
            OutputError::NotAFile {
                kind: FileKind::Device,
                ..
            }
        ));
        assert!(matches!(
            err(&dir, true),
            OutputError::NotAFile {
                kind: FileKind::Directory,
                ..
            }
        ));
        // A new file: written; then it exists and needs `overwrite`.
        let f = dir.join("b.json");
        OutputFile::prepare(&f, false)
            .unwrap()
            .commit("one")
            .unwrap();
        assert!(matches!(err(&f, false), OutputError::Exists { .. }));
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
        let meta = std::fs::symlink_metadata(&link).unwrap();
        assert!(meta.file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "three");
        // A dangling link is refused.
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
        assert!(matches!(
            err(&dangling, true),
            OutputError::DanglingLink { .. }
        ));
        // A dropped file leaves nothing.
        drop(OutputFile::prepare(&dir.join("c.json"), false).unwrap());
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 3, "{left:?}");
        // The path turned into a directory while the work ran: nothing replaced.
        let g = dir.join("g.json");
        let pending = OutputFile::prepare(&g, false).unwrap();
        std::fs::create_dir(&g).unwrap();
        assert!(matches!(
            pending.commit("x").unwrap_err(),
            OutputError::NotAFile {
                kind: FileKind::Directory,
                ..
            }
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn issue18_a_replaced_file_keeps_its_mode_and_a_missing_directory_is_named() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = fresh("outfile18");
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
        assert!(
            matches!(&e, OutputError::Directory { dir, problem: DirProblem::Missing, .. }
                if dir == Path::new("/nonexistent")),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
