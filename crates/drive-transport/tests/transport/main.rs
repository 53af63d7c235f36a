//! Integration tests of drive-transport (one test binary).

mod link;
#[cfg(target_os = "linux")]
mod pty_serial;
