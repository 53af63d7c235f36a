//! Integration tests of the drive-sim crate (one test binary).

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod bonfiglioli;
mod drive;
mod inject;
mod movidrive;
mod movidrive_sbus;
mod props;
mod ramp;
mod sew;
mod state;
mod store;
mod table;
