//! Protocol tests of the movilink crate (one test binary).

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod bus;
mod faults;
mod master_slave;
mod props;
mod receiver;
mod timing;
mod vectors;
