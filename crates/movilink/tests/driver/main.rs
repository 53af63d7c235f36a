//! Tests of the async master driver, the simulated drives and the write guard (feature `sim`).
//! Everything runs on tokio's paused clock over the 9600-baud 8E1 wire model of
//! `drive-transport`, so times are exact and the tests deterministic.

mod common;
mod cyclic;
mod retries;
mod scan;
mod services;
mod timing;
