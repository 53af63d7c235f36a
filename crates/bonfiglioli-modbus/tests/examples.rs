//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use std::process::Command;

use bonfiglioli_modbus::Mode;
use bonfiglioli_modbus::sim::{SimulatedDrive, Variant};
use drive_core::{Instant, LineSettings};
use drive_profile::{ParamMeta, bonfiglioli};

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
