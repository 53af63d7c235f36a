//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use std::process::Command;

use drive_core::Instant;
use drive_profile::sew::ParamChannel;
use drive_profile::{ParamMeta, sew};
use sbus_can::SimulatedSbusBus;

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
