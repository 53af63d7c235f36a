//! The examples run and print what the simulated drive holds.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(clippy::expect_used)]

use drive_core::Instant;
use drive_profile::{ParamMeta, sew};
use movilink::{ParamChannel, SimulatedMovidrive};

#[path = "../../../tests/support/run_example.rs"]
mod support;
use support::run_example;

#[test]
fn movilink_read_param_prints_p130_of_the_simulated_drive() {
    let p130 = sew::lookup("P130").expect("P130 in the table");
    let mut drive = SimulatedMovidrive::new(1);
    let raw = drive
        .movidrive_mut()
        .param(&ParamChannel::read(p130.bus_index()), Instant::ZERO)
        .expect("the simulated drive holds P130");
    let value = p130.to_physical(raw.into());
    assert_eq!(
        run_example("movilink_read_param"),
        format!(
            "P130 {}: {value} {} (raw {raw})\n",
            p130.name_en(),
            p130.unit()
        )
    );
}

/// README.md's "Use it as a library" shows this example as it is (without its doc comment).
/// Skipped where the README is not there (the packaged crate).
#[test]
fn readme_shows_movilink_read_param_as_it_is() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let Ok(readme) = std::fs::read_to_string(root.join("../../README.md")) else {
        return;
    };
    let example = std::fs::read_to_string(root.join("examples/movilink_read_param.rs"))
        .expect("the example's source");
    let code: String = example
        .lines()
        .filter(|l| !l.starts_with("//!"))
        .skip_while(|l| l.is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    let section = readme
        .split("## Use it as a library")
        .nth(1)
        .expect("README.md has a section \"Use it as a library\"");
    let shown = section
        .split("```rust\n")
        .nth(1)
        .and_then(|s| s.split("```\n").next())
        .expect("the section shows a Rust program");
    assert_eq!(
        shown, code,
        "README.md shows another program than examples/movilink_read_param.rs"
    );
}
