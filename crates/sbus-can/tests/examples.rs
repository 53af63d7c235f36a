//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use drive_core::Instant;
use drive_profile::sew::ParamChannel;
use drive_profile::{ParamMeta, sew};
use sbus_can::SimulatedSbusBus;

#[path = "../../../tests/support/run_example.rs"]
mod support;
use support::run_example;

#[test]
fn sbus_read_param_prints_p130_of_the_simulated_drive() {
    let p130 = sew::lookup("P130").expect("P130 in the table");
    let mut bus = SimulatedSbusBus::new(&[1]);
    let drive = bus.drive_mut(1).expect("drive 1 on the bus");
    let raw = drive
        .movidrive_mut()
        .param(&ParamChannel::read(p130.bus_index()), Instant::ZERO)
        .expect("the simulated drive holds P130");
    let value = p130.to_physical(raw.into());
    assert_eq!(
        run_example("sbus_read_param"),
        format!(
            "P130 {}: {value} {} (raw {raw})\n",
            p130.name_en(),
            p130.unit()
        )
    );
}
