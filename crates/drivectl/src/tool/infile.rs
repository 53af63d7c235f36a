//! Input files read whole (a backup to restore, a capture to decode): never a device node, and
//! never more than a limit, so `restore /dev/zero` or `decode - < /dev/zero` ends with an error
//! instead of reading forever.

use std::path::Path;

use drive_client::infile::InputError;

use crate::error::{CliError, Result};

/// The whole of `path` (`-`: standard input when `stdin_dash`), at most `limit` bytes
/// (`drive_client::infile::read_limited`), its refusals in the command line's words.
pub fn read_limited(path: &Path, stdin_dash: bool, limit: u64) -> Result<Vec<u8>> {
    drive_client::infile::read_limited(path, stdin_dash, limit).map_err(|e| match e {
        InputError::TooLarge { .. } => CliError::usage(format!(
            "{e}: not a file drivectl reads whole; check the path, or split the input"
        )),
        InputError::NotAFile { .. } => CliError::usage(format!("{e}; give a file")),
        InputError::Open { .. } => CliError::failed(format!(
            "{e}; check the path and that it is a readable file"
        )),
        other => CliError::failed(other.to_string()),
    })
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
