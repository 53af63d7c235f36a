//! End-to-end tests of the `drivectl` binary: real process, real output, real exit codes.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::process::{Command, Output};

fn drivectl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
        .output()
        .expect("drivectl runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn json_lines(o: &Output) -> Vec<serde_json::Value> {
    stdout(o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("every line is one JSON object"))
        .collect()
}

#[test]
fn show_p000_by_index_as_json() {
    let o = drivectl(&["params", "movidrive", "show", "8318", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), 1);
    let p = &v[0];
    assert_eq!(p["number"], "P000");
    assert_eq!(p["index"], 8318);
    assert_eq!(p["unit"], "1/min");
    assert_eq!(p["access"], "RO");
    let scaling = p["scaling"].as_str().unwrap();
    assert!(
        scaling.contains("11") && scaling.contains("66"),
        "{scaling}"
    );
}

#[test]
fn show_p813_by_menu_number() {
    for key in ["P813", "p813", "813"] {
        let o = drivectl(&["params", "sew", "show", key, "--json"]);
        assert!(o.status.success(), "{key}: {}", stderr(&o));
        let p = &json_lines(&o)[0];
        assert_eq!(p["index"], 8600, "{key}");
        assert_eq!(p["range"]["min"], 0, "{key}");
        assert_eq!(p["range"]["max"], 63, "{key}");
    }
}

#[test]
fn bonfiglioli_modbus_address_spot_check() {
    let o = drivectl(&["params", "bonfiglioli", "show", "1376", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = &json_lines(&o)[0];
    assert_eq!(p["range"]["min"], 1);
    assert_eq!(p["range"]["max"], 247);
    assert_eq!(p["default"], 1);
}

#[test]
fn search_finds_german_and_english_names() {
    let de = drivectl(&["params", "movidrive", "--search", "DREHZAHL", "--json"]);
    assert!(de.status.success(), "{}", stderr(&de));
    let hits = json_lines(&de);
    assert!(
        hits.iter().any(|p| p["index"] == 8318),
        "P000 is a Drehzahl"
    );
    assert!(hits.iter().all(|p| {
        let n = format!("{} {}", p["name_de"], p["name_en"]).to_lowercase();
        n.contains("drehzahl")
    }));
    let en = drivectl(&["params", "movidrive", "--search", "speed", "--json"]);
    assert!(
        json_lines(&en).iter().any(|p| p["index"] == 8318),
        "P000 is a speed"
    );
}

#[test]
fn human_listing_has_a_header_and_count() {
    let o = drivectl(&["params", "nord"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.lines().next().unwrap().starts_with("number"));
    assert!(out.contains("P102"));
    assert!(out.trim_end().ends_with("parameters"));
}

#[test]
fn unknown_family_is_one_line_and_nonzero() {
    let o = drivectl(&["params", "siemens"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("unknown drive family `siemens`"), "{err}");
    assert!(stdout(&o).is_empty());
}

#[test]
fn unknown_parameter_is_one_line_and_nonzero() {
    let o = drivectl(&["params", "movidrive", "show", "P999"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("P999"), "{err}");
}

#[test]
fn demo_runs() {
    let o = drivectl(&["demo"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("1000 1/min"), "{out}");
}
