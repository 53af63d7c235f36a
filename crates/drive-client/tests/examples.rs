//! The example runs and prints what the simulated drive holds before and after the write.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use drive_core::Instant;
use drive_profile::{ParamMeta, sew};
use movilink::{ParamChannel, SimulatedMovidrive};

#[path = "../../../tests/support/run_example.rs"]
mod support;
use support::run_example;

#[test]
fn drive_client_read_write_reads_p130_then_writes_and_reads_back_1_5_s() {
    let p130 = sew::lookup("P130").expect("P130 in the table");
    let raw = SimulatedMovidrive::new(1)
        .movidrive_mut()
        .param(&ParamChannel::read(p130.bus_index()), Instant::ZERO)
        .expect("the simulated drive holds P130");
    let before = drive_client::text::physical_text(p130, raw.into());
    assert_ne!(before, "1.50 s", "the write would not show");
    assert_eq!(
        run_example("drive_client_read_write"),
        format!("P130: {before}\nP130 = 1.50 s (read back)\n")
    );
}
