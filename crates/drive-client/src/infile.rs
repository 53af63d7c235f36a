//! Input files read whole (a backup to restore, a capture to decode, a plant's config): never a
//! device node, and never more than a limit, so a path to `/dev/zero` or a serial port given
//! by mistake ends with an error instead of reading (or blocking) forever.

use std::io::Read as _;
use std::path::Path;

/// What a path named instead of a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotAFile {
    /// A directory.
    Directory,
    /// A character or block device (a serial port, `/dev/zero`).
    Device,
    /// A socket or anything else that is no regular file or pipe.
    Other,
}

impl std::fmt::Display for NotAFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NotAFile::Directory => "a directory",
            NotAFile::Device => "a device node",
            NotAFile::Other => "not a regular file",
        })
    }
}

/// Why an input was not read; nothing of it is used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// Longer than the limit.
    #[error("{what} is larger than {} MiB", limit >> 20)]
    TooLarge {
        /// The path, or `standard input`.
        what: String,
        /// The limit in bytes.
        limit: u64,
    },
    /// The path names no file.
    #[error("{path} is {kind}")]
    NotAFile {
        /// The path.
        path: String,
        /// What it is.
        kind: NotAFile,
    },
    /// The path cannot be opened or looked at (missing, no permission).
    #[error("cannot read {path}: {source}")]
    Open {
        /// The path.
        path: String,
        /// The system's error.
        source: std::io::Error,
    },
    /// Reading failed part-way (or standard input could not be read).
    #[error("cannot read {what}: {source}")]
    Read {
        /// The path, or `standard input`.
        what: String,
        /// The system's error.
        source: std::io::Error,
    },
}

/// The whole of `path` (`-`: standard input when `stdin_dash`), at most `limit` bytes. A
/// regular file, a pipe (`<(…)`, standard input) or a symlink to one is read; a directory or a
/// device node is refused.
pub fn read_limited(path: &Path, stdin_dash: bool, limit: u64) -> Result<Vec<u8>, InputError> {
    let mut buf = Vec::new();
    if stdin_dash && path == Path::new("-") {
        let what = "standard input".to_owned();
        std::io::stdin()
            .lock()
            .take(limit.saturating_add(1))
            .read_to_end(&mut buf)
            .map_err(|source| InputError::Read {
                what: what.clone(),
                source,
            })?;
        if buf.len() as u64 > limit {
            return Err(InputError::TooLarge { what, limit });
        }
        return Ok(buf);
    }
    let shown = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|source| InputError::Open {
        path: shown.clone(),
        source,
    })?;
    use std::os::unix::fs::FileTypeExt as _;
    let t = meta.file_type();
    if !(t.is_file() || t.is_fifo()) {
        let kind = if t.is_dir() {
            NotAFile::Directory
        } else if t.is_char_device() || t.is_block_device() {
            NotAFile::Device
        } else {
            NotAFile::Other
        };
        return Err(InputError::NotAFile { path: shown, kind });
    }
    std::fs::File::open(path)
        .and_then(|f| f.take(limit.saturating_add(1)).read_to_end(&mut buf))
        .map_err(|source| InputError::Read {
            what: shown.clone(),
            source,
        })?;
    if buf.len() as u64 > limit {
        return Err(InputError::TooLarge { what: shown, limit });
    }
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_nodes_directories_and_endless_input_are_refused() {
        let e = read_limited(Path::new("/dev/zero"), true, 1 << 20).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::NotAFile {
                    kind: NotAFile::Device,
                    ..
                }
            ),
            "{e}"
        );
        let e = read_limited(Path::new("/tmp"), true, 1 << 20).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::NotAFile {
                    kind: NotAFile::Directory,
                    ..
                }
            ),
            "{e}"
        );
        let dir = std::env::temp_dir().join(format!("drive-client-infile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("big");
        std::fs::write(&f, vec![b'0'; 2048]).unwrap();
        let e = read_limited(&f, true, 1024).unwrap_err();
        assert!(matches!(e, InputError::TooLarge { limit: 1024, .. }), "{e}");
        assert_eq!(read_limited(&f, true, 4096).unwrap().len(), 2048);
        let e = read_limited(&dir.join("missing"), true, 4096).unwrap_err();
        assert!(matches!(e, InputError::Open { .. }), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
