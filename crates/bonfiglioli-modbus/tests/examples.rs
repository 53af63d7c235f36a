//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use bonfiglioli_modbus::Mode;
use bonfiglioli_modbus::sim::{SimulatedDrive, Variant};
use drive_core::{Instant, LineSettings};
use drive_profile::{ParamMeta, bonfiglioli};

#[path = "../../../tests/support/run_example.rs"]
mod support;
use support::run_example;

#[test]
fn bonfiglioli_read_param_prints_372_of_the_simulated_drive() {
    let p372 = bonfiglioli::lookup("372").expect("372 in the table");
    let mut drive = SimulatedDrive::new(1, Variant::Acu, Mode::Rtu, LineSettings::new(19200));
    let raw = drive
        .drive_mut()
        .read(372, 1, drive_sim::bonfiglioli::Width::Word, Instant::ZERO)
        .expect("the simulated drive holds 372 in data set 1");
    let value = p372.to_physical(raw.into());
    assert_eq!(
        run_example("bonfiglioli_read_param"),
        format!(
            "372 {}, data set 1: {value} {} (raw {raw})\n",
            p372.name_en, p372.unit
        )
    );
}
