//! Tests of the async master driver, the simulated drives and the write guard (feature `sim`).
//! Everything runs on tokio's paused clock over the 9600-baud 8E1 wire model of
//! `drive-transport`, so times are exact and the tests deterministic.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;
mod cyclic;
mod retries;
mod scan;
mod services;
mod timing;
