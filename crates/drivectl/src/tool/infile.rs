//! Input files read whole (a backup to restore, a capture to decode): never a device node, and
//! never more than a limit, so `restore /dev/zero` or `decode - < /dev/zero` ends with an error
//! instead of reading forever.

use std::io::Read as _;
use std::path::Path;

use crate::error::{CliError, Result};

/// The whole of `path` (`-`: standard input when `stdin_dash`), at most `limit` bytes. A
/// regular file, a pipe (`<(…)`, standard input) or a symlink to one is read; a directory or a
/// device node is refused (a serial port given by mistake would block forever).
pub fn read_limited(path: &Path, stdin_dash: bool, limit: u64) -> Result<Vec<u8>> {
    let too_big = |what: &str| {
        CliError::usage(format!(
            "{what} is larger than {} MiB: not a file drivectl reads whole; check the path, or \
             split the input",
            limit >> 20
        ))
    };
    let mut buf = Vec::new();
    if stdin_dash && path == Path::new("-") {
        std::io::stdin()
            .lock()
            .take(limit + 1)
            .read_to_end(&mut buf)
            .map_err(|e| CliError::failed(format!("cannot read standard input: {e}")))?;
        if buf.len() as u64 > limit {
            return Err(too_big("standard input"));
        }
        return Ok(buf);
    }
    let shown = path.display();
    let meta = std::fs::metadata(path).map_err(|e| {
        CliError::failed(format!(
            "cannot read {shown}: {e}; check the path and that it is a readable file"
        ))
    })?;
    use std::os::unix::fs::FileTypeExt as _;
    let t = meta.file_type();
    if !(t.is_file() || t.is_fifo()) {
        let what = if t.is_dir() {
            "a directory"
        } else if t.is_char_device() || t.is_block_device() {
            "a device node"
        } else {
            "not a regular file"
        };
        return Err(CliError::usage(format!("{shown} is {what}; give a file")));
    }
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut buf))
        .map_err(|e| CliError::failed(format!("cannot read {shown}: {e}")))?;
    if buf.len() as u64 > limit {
        return Err(too_big(&shown.to_string()));
    }
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issue7_device_nodes_directories_and_endless_input_are_refused() {
        let e = read_limited(Path::new("/dev/zero"), true, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("is a device node"), "{e}");
        let e = read_limited(Path::new("/tmp"), true, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
        let dir = std::env::temp_dir().join(format!("drivectl-infile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("big");
        std::fs::write(&f, vec![b'0'; 2048]).unwrap();
        let e = read_limited(&f, true, 1024).unwrap_err();
        assert!(e.to_string().contains("larger than"), "{e}");
        assert_eq!(read_limited(&f, true, 4096).unwrap().len(), 2048);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
