//! The one workspace-level integration-test binary: checks that cross crate boundaries.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod architecture;
mod movilink_faults;
mod tables_and_sim;
