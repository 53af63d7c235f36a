//! The load example runs the gateway's bus tasks on simulated MOVILINK buses and its figures
//! agree with each other: every bus keeps the wire busy (the polls ask 128 % of it), and the
//! transactions per second are what the wire time of a read allows.

// A test helper that fails the test by panicking, as a `#[test]` may.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "../../../tests/support/run_example.rs"]
#[allow(dead_code)] // `run_example` (no arguments) is the other crates'
mod support;
use support::run_example_with;

/// The number after `key` on the line that starts with `line`.
fn figure(out: &str, line: &str, key: &str) -> f64 {
    let l = out
        .lines()
        .find(|l| l.starts_with(line))
        .unwrap_or_else(|| panic!("no line {line:?} in:\n{out}"));
    let rest = &l[l.find(key).unwrap_or_else(|| panic!("no {key:?} in {l:?}")) + key.len()..];
    let number: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    number
        .parse()
        .unwrap_or_else(|_| panic!("no number after {key:?} in {l:?}"))
}

#[test]
fn load_keeps_every_bus_at_its_wire_bound() {
    // 8 s: the figures are the report at 5 s (the rate was divided by 8 − 5 = 3 s before).
    let out = run_example_with("load", &["3x31", "8"]);
    assert!(out.starts_with("3 buses x 31 drives, 8 s virtual"), "{out}");
    let bound = figure(&out, "wire time of a read", "bound per bus");
    let per_bus = figure(&out, "transactions:", "(");
    // The figures from the 6th second on (the first 5 s start the buses): within 5 % below
    // the wire's bound and not above it (+1 % for the formula's rounding).
    assert!(
        per_bus >= 0.95 * bound && per_bus <= 1.01 * bound,
        "{per_bus}/s per bus against a bound of {bound}/s:\n{out}"
    );
    let min = figure(&out, "utilisation of the wire bound", "min");
    assert!((0.95..=1.0).contains(&min), "{out}");
}

/// The Sparkplug load example, both cases, both flushes: one DDATA metric per value that
/// changed, one DDATA per change when every update is flushed on its own, and one in ten reads
/// a change in the realistic case.
#[test]
fn sparkplug_load_publishes_one_ddata_metric_per_changed_value() {
    for flush in ["each", "100ms"] {
        let out = run_example_with("sparkplug_load", &["3x31", "6", "1s", flush, "1"]);
        assert!(out.starts_with("3 buses x 31 drives"), "{out}");
        let cases: Vec<&str> = out
            .split("\n\n")
            .filter(|c| c.contains("values changed"))
            .collect();
        assert_eq!(cases.len(), 2, "{out}");
        let mut changed = Vec::new();
        for case in cases {
            let head = case.lines().next().unwrap();
            let name = head.split(':').next().unwrap();
            let fed = figure(head, name, ":");
            let values = figure(head, name, "fed,");
            let ddata = figure(case, "  published:", "published:");
            let metrics = figure(case, "  published:", "DDATA (");
            assert_eq!(metrics, values, "{case}");
            if flush == "each" {
                assert_eq!(ddata, values, "{case}");
            } else {
                assert!(ddata <= values, "{case}");
            }
            assert!(fed > values, "{case}");
            changed.push(values);
        }
        // 3 × 31 drives read about every 1.28 s for 6 s: some 450 reads, one in ten new.
        assert!((400.0..500.0).contains(&changed[0]), "{out}");
        assert!((changed[0] / changed[1] - 10.0).abs() < 1.0, "{out}");
    }
}
