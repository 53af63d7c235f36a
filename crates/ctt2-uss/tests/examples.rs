//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use ctt2_uss::{Layout, SimulatedDoubleSlave, SimulatedDrive, UssAddress};
use drive_core::LineSettings;
use drive_profile::{ParamMeta, nord};

#[path = "../../../tests/support/run_example.rs"]
mod support;
use support::run_example;

/// The line the example prints for P102 (element 0, parameter set 1) of a drive holding `raw`.
fn p102_line(raw: Option<i32>) -> String {
    let p102 = nord::lookup("P102").expect("P102 in the table");
    let raw = raw.expect("the simulated drive holds P102");
    let value = p102.to_physical(raw.into());
    format!(
        "P102 {}: {value} {} (raw {raw})\n",
        p102.name_en(),
        p102.unit()
    )
}

#[test]
fn uss_read_param_prints_p102_of_the_simulated_drive() {
    let address = UssAddress::new(1).expect("address 1");
    let drive = SimulatedDrive::new(address, Layout::PKW4_PZD4, LineSettings::new(9600));
    let held = drive.drive().ram_value(102, 0, 0);
    assert_eq!(run_example("uss_read_param"), p102_line(held));
}

#[test]
fn ctt2_read_param_prints_p102_of_the_simulated_drive() {
    let drive = SimulatedDoubleSlave::default();
    let held = drive.drive().ram_value(102, 0, 0);
    assert_eq!(run_example("ctt2_read_param"), p102_line(held));
}
