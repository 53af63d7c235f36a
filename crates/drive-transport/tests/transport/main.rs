//! Integration tests of drive-transport (one test binary).

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[cfg(target_os = "linux")]
mod can_candump;
#[cfg(target_os = "linux")]
mod can_slcan;
#[cfg(target_os = "linux")]
mod can_socketcan;
mod can_virtual;
mod link;
#[cfg(target_os = "linux")]
mod pty_serial;
