//! The helper every crate's `tests/examples.rs` includes (`#[path]`): run one of the crate's
//! examples and return what it printed.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use std::process::Command;

/// Runs example `name` and returns what it printed. `cargo test` builds the examples next to
/// the test binaries (`target/<profile>/examples/`); one that is not there (`cargo test --test
/// examples` alone, on a fresh target directory) is built first.
pub fn run_example(name: &str) -> String {
    run_example_with(name, &[])
}

/// [`run_example`] with command-line arguments.
pub fn run_example_with(name: &str, args: &[&str]) -> String {
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
    let out = Command::new(&bin)
        .args(args)
        .output()
        .expect("the example runs");
    assert!(
        out.status.success(),
        "{name} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("the example prints UTF-8")
}
