//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use std::process::Command;

use ctt2_uss::{Layout, SimulatedDoubleSlave, SimulatedDrive, UssAddress};
use drive_core::LineSettings;
use drive_profile::{ParamMeta, nord};

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

/// Runs example `name` and returns what it printed. `cargo test` builds the examples next to
/// the test binaries (`target/<profile>/examples/`); one that is not there (`cargo test --test
/// examples` alone, on a fresh target directory) is built first.
fn run_example(name: &str) -> String {
    let exe = std::env::current_exe().expect("the test binary's path");
    // target/<profile>/deps/examples-<hash> → target/<profile>/examples/<name>
    let profile = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("the test binary lies in target/<profile>/deps");
    let bin = profile
        .join("examples")
        .join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    if !bin.exists() {
        let mut build = Command::new(env!("CARGO"));
        build.args([
            "build",
            "--quiet",
            "-p",
            env!("CARGO_PKG_NAME"),
            "--example",
            name,
        ]);
        if profile.ends_with("release") {
            build.arg("--release");
        }
        let status = build.status().expect("cargo runs");
        assert!(status.success(), "cargo build --example {name} failed");
    }
    let out = Command::new(&bin).output().expect("the example runs");
    assert!(
        out.status.success(),
        "{name} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("the example prints UTF-8")
}
