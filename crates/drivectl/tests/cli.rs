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
    // The count, then the legend of the access codes shown (issue 7 #18).
    let tail: Vec<_> = out.lines().rev().take(4).collect();
    assert_eq!(
        tail,
        [
            "  RW   read/write",
            "  RO   read-only",
            "access:",
            "17 parameters"
        ]
    );
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
    // The NORD CTT2 session reaches the manual's 5.1.2 answer and stops.
    assert!(out.contains("ZSW 0x0B37, IW1 0x2000"), "{out}");
    assert!(out.contains("C ready to switch on"), "{out}");
}

/// The keys of every object `params <family> --json` prints.
fn json_key_sets(family: &str) -> Vec<std::collections::BTreeSet<String>> {
    let o = drivectl(&["params", family, "--json"]);
    assert!(o.status.success(), "{family}: {}", stderr(&o));
    let rows = json_lines(&o);
    assert!(!rows.is_empty(), "{family}: no rows");
    rows.iter()
        .map(|p| p.as_object().expect("an object").keys().cloned().collect())
        .collect()
}

#[test]
fn every_family_lists_the_same_json_keys() {
    let expected: std::collections::BTreeSet<String> = drive_profile::COLUMN_KEYS
        .iter()
        .map(|k| k.to_string())
        .collect();
    for family in ["movidrive", "nord", "bonfiglioli"] {
        for keys in json_key_sets(family) {
            assert_eq!(keys, expected, "{family}");
        }
    }
    // The shared keys the earlier output had are still there.
    for key in [
        "family",
        "number",
        "index",
        "sub_index",
        "name_de",
        "name_en",
        "unit",
        "access",
        "default",
        "default_value",
        "range",
        "range_de",
        "range_en",
        "scaling",
        "values",
    ] {
        assert!(expected.contains(key), "{key}");
    }
}

#[test]
fn json_columns_are_typed() {
    let sew = &json_lines(&drivectl(&[
        "params",
        "movidrive",
        "show",
        "P000",
        "--json",
    ]))[0];
    assert_eq!(sew["index"].as_u64(), Some(8318));
    assert_eq!(sew["size_index"].as_u64(), Some(11));
    assert_eq!(sew["conversion_index"].as_u64(), Some(66));
    assert_eq!(sew["display_conversion_index"].as_u64(), Some(67));
    assert_eq!(sew["index_hex"], "207E");
    assert_eq!(sew["access_flags"]["read_only"], true);
    assert!(sew["range_segments"].is_array());
    assert!(sew["errata"].is_array());
    // Another family's columns are null, not missing.
    assert!(sew["resolution"].is_null() && sew["data_type"].is_null());

    let nord = &json_lines(&drivectl(&["params", "nord", "show", "P102", "--json"]))[0];
    assert_eq!(nord["resolution"]["step"].as_f64(), Some(0.01));
    assert_eq!(nord["resolution"]["decimals"].as_u64(), Some(2));
    assert_eq!(nord["pnu"].as_u64(), Some(0x66));
    assert_eq!(nord["parameter_set"], true);
    assert!(nord["size_index"].is_null());

    let bonfi = &json_lines(&drivectl(&[
        "params",
        "bonfiglioli",
        "show",
        "1376",
        "--json",
    ]))[0];
    assert_eq!(bonfi["range"]["min"].as_i64(), Some(1));
    assert_eq!(bonfi["range"]["max"].as_i64(), Some(247));
    assert_eq!(bonfi["table_min"].as_i64(), Some(1));
    assert_eq!(bonfi["table_max"].as_i64(), Some(247));
    assert_eq!(bonfi["data_type"], "unknown");
    assert_eq!(bonfi["menu"], "PARA");
    assert_eq!(
        bonfi["chapters"],
        serde_json::json!(["5", "5.2.2", "5.3.2"])
    );
    let p210 = &json_lines(&drivectl(&[
        "params",
        "bonfiglioli",
        "show",
        "210",
        "--json",
    ]))[0];
    assert_eq!(p210["data_type"], "Long");
}

#[test]
fn a_response_timeout_shorter_than_the_start_pause_is_refused_before_opening_the_port() {
    // At 300 baud a drive waits 110 ms before answering: the default 50 ms can never be met.
    let o = drivectl(&[
        "movilink",
        "--port",
        "/nonexistent",
        "--baud",
        "300",
        "read",
        "P000",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("start pause"), "{err}");
    assert!(err.contains("300 baud (110.00 ms)"), "{err}");
    assert!(err.contains("--timeout 110 or more"), "{err}");
    // With that timeout the port is what fails.
    let o = drivectl(&[
        "movilink",
        "--port",
        "/nonexistent",
        "--baud",
        "300",
        "--timeout",
        "110",
        "read",
        "P000",
    ]);
    assert!(
        stderr(&o).contains("/nonexistent not found"),
        "{}",
        stderr(&o)
    );
}

/// `drivectl … | head` where the reader is already gone: the read end is closed right after the
/// start, long before the new process gets to its first write, which meets a closed pipe.
///
/// Other tests of this binary spawn processes in parallel, and a child forked by another thread
/// holds a copy of the read end until its exec closes it; a write landing in that window
/// succeeds and the run exits 0. Such a run proves nothing either way, so it is repeated (a
/// panic or a message shows on every run).
fn into_closed_pipe(args: &[&str]) -> Output {
    let run = || {
        let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        child.wait_with_output().unwrap()
    };
    let mut o = run();
    for _ in 0..20 {
        if o.status.code() != Some(0) {
            break;
        }
        o = run();
    }
    o
}

#[test]
fn issue7_a_closed_pipe_ends_a_command_quietly() {
    for args in [
        &["params", "movidrive", "--json"][..],
        &["params", "nord", "show", "P102"],
        &["demo"],
        &["decode", "movilink", "02 01 85 00 06 20 00 0B B8 13"],
        &["completions", "bash"],
        &["man"],
    ] {
        let o = into_closed_pipe(args);
        // No panic, no message: the exit code a shell shows for SIGPIPE.
        assert_eq!(stderr(&o), "", "{args:?}");
        assert_eq!(o.status.code(), Some(141), "{args:?}");
    }
}

/// Issue 7 #19: `watch --interval` is validated with its limits, which `--help` states.
#[test]
fn watch_interval_has_limits_in_help() {
    let o = drivectl(&[
        "movilink",
        "--port",
        "/dev/null",
        "watch",
        "P000",
        "--interval",
        "10",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("50..=3600000"), "{}", stderr(&o));
    let o = drivectl(&["movilink", "--port", "/dev/null", "watch", "--help"]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("50–3600000"), "{}", stdout(&o));
    let o = drivectl(&[
        "movilink",
        "--port",
        "/dev/null",
        "watch",
        "P000",
        "--csv",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

// ---- issue 7 #14: `decode movilink` input ----

/// A read request of P070 (index 8301) to address 1 and the simulator's answer, BCCs correct.
const READ_8301: &str = "02 01 86 31 00 20 6D 00 00 00 00 F9";
const ANSWER_8301: &str = "1D 01 86 31 00 20 6D 03 93 8D 11 EA";

fn drivectl_stdin(args: &[&str], input: &[u8]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("drivectl runs");
    // A command that refuses its arguments exits without reading: a closed pipe is its answer.
    match child.stdin.take().unwrap().write_all(input) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other.unwrap(),
    }
    child.wait_with_output().unwrap()
}

#[test]
fn issue7_14_decode_refuses_odd_digits_and_signs_naming_the_token() {
    // An odd digit count used to be padded, shifting every byte after it.
    let o = drivectl(&["decode", "movilink", "02 1 86 31 00 20 6D 00 00 00 00 F9"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert_eq!(stdout(&o), "");
    let e = stderr(&o);
    assert!(
        e.contains("`1`") && e.contains("column 4") && e.contains("odd"),
        "{e}"
    );
    // `-02` used to be read as 02.
    let o = drivectl(&["decode", "movilink", "--", "-02", "01", "86"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let e = stderr(&o);
    assert!(
        e.contains("argument 1") && e.contains("`-02` is not hex"),
        "{e}"
    );
}

#[test]
fn issue7_14_decode_reads_a_notepad_file_one_telegram_per_line() {
    let dir = std::env::temp_dir().join(format!("drivectl-decode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("capture.txt");
    let text = format!("\u{feff}# P070 read\r\n{READ_8301}\r\n\r\n{ANSWER_8301}  # answer\r\n");
    std::fs::write(&path, text).unwrap();
    let o = drivectl(&[
        "decode",
        "movilink",
        "--file",
        path.to_str().unwrap(),
        "--json",
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), 2);
    assert_eq!(v[0]["type"], "telegram");
    assert_eq!(v[0]["direction"], "request");
    assert_eq!(v[0]["line"], 2);
    assert_eq!(v[0]["pdu_type"], "0x86");
    assert_eq!(v[0]["kind"], "PARAM+0PD acyclic");
    assert_eq!(v[0]["address"], 1);
    assert_eq!(v[0]["index"], 8301);
    // The parameter as `read --json` names it; a read request carries no value.
    assert_eq!(
        (&v[0]["number"], &v[0]["raw"]),
        (&serde_json::json!("P070"), &serde_json::Value::Null)
    );
    assert_eq!(v[1]["direction"], "response");
    assert_eq!(v[1]["line"], 4);
    assert_eq!(v[1]["raw"], 60_001_553);
    assert_eq!(v[1]["valid"], true);
}

#[test]
fn issue7_14_decode_splits_a_stream_from_stdin_and_reports_stray_bytes() {
    let input = format!("55 AA {READ_8301} {ANSWER_8301} 02 01");
    let o = drivectl_stdin(&["decode", "movilink", "-", "--json"], input.as_bytes());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v = json_lines(&o);
    let kinds: Vec<_> = v
        .iter()
        .map(|j| (j["type"].as_str().unwrap(), j["offset"].as_u64().unwrap()))
        .collect();
    assert_eq!(
        kinds,
        [
            ("skipped", 0),
            ("telegram", 2),
            ("telegram", 14),
            ("telegram", 26)
        ]
    );
    assert_eq!(v[0]["bytes"], "55 AA");
    assert_eq!(v[1]["valid"], true);
    assert_eq!(v[2]["valid"], true);
    assert_eq!(v[3]["valid"], false);
    let e = stderr(&o);
    assert!(e.contains("1 of 3 telegram(s) are invalid"), "{e}");
    assert!(e.contains("2 byte(s) start no telegram"), "{e}");
}

#[test]
fn issue7_14_decode_says_when_a_file_cannot_be_read() {
    let o = drivectl(&["decode", "movilink", "--file", "/nonexistent/capture.txt"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("cannot read /nonexistent/capture.txt"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
}

// ---- issue 7 #15: `sim movilink` refuses what it cannot serve ----

/// Run drivectl, killing it if it still runs after `secs` (a simulator that accepted its
/// arguments serves until stopped): the exit status is `None` then.
fn drivectl_within(args: &[&str], secs: u64) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("drivectl runs");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(secs);
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    (code, err)
}

#[test]
fn issue7_15_sim_refuses_a_duplicate_address_naming_it() {
    let (code, err) = drivectl_within(
        &[
            "sim", "movilink", "--pty", "--parity", "none", "--addr", "1", "--addr", "5", "--addr",
            "1",
        ],
        5,
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--addr 1 is given twice"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}

#[test]
fn issue7_15_baud_0_is_refused_by_the_simulator_and_the_master() {
    let (code, err) = drivectl_within(
        &[
            "sim", "movilink", "--pty", "--parity", "none", "--baud", "0",
        ],
        5,
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("'0' for '--baud <BAUD>'"), "{err}");
    assert!(err.contains("1..=4000000"), "{err}");
    let o = drivectl(&["movilink", "--port", "/dev/null", "--baud", "0", "line"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("1..=4000000"), "{}", stderr(&o));
}

/// The master refuses parity on a pty (tests/movilink_pty.rs `a_refused_parity_names_the_option`);
/// the simulator used to switch to 8N1 by itself. Now both refuse, naming the setting and the way
/// out, and the default (even) says it is the default.
#[test]
fn issue7_15_sim_on_a_pty_refuses_parity_as_the_master_does() {
    for (extra, named) in [
        (&[][..], "parity even (the default"),
        (&["--parity", "even"][..], "parity even"),
        (&["--parity", "odd"][..], "parity odd"),
    ] {
        let mut args = vec!["sim", "movilink", "--pty", "--addr", "1"];
        args.extend_from_slice(extra);
        let (code, err) = drivectl_within(&args, 5);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(named), "{args:?}: {err}");
        assert!(
            err.contains("pseudo-terminals accept only no parity"),
            "{err}"
        );
        assert!(err.contains("--parity none"), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
}

#[test]
fn issue7_search_folds_umlauts_and_sharp_s() {
    // "Drehzahl-Überwachung 1" (P500) and "Drehzahlüberwachung 2" (P502), however the term
    // spells the umlaut.
    for term in ["ueberwachung", "uberwachung", "ÜBERWACHUNG", "Ueberwachung"] {
        let o = drivectl(&["params", "movidrive", "--search", term, "--json"]);
        assert!(o.status.success(), "{term}: {}", stderr(&o));
        let numbers: Vec<_> = json_lines(&o)
            .iter()
            .map(|p| p["number"].as_str().unwrap().to_owned())
            .collect();
        assert!(
            numbers.contains(&"P500".to_owned()) && numbers.contains(&"P502".to_owned()),
            "{term}: {numbers:?}"
        );
    }
}

#[test]
fn issue7_access_codes_are_explained() {
    // `show` says what each code of the parameter means.
    let o = drivectl(&["params", "movidrive", "show", "P813"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("access     N/RW"), "{out}");
    assert!(out.contains("N    non-volatile"), "{out}");
    assert!(out.contains("RW   read/write"), "{out}");

    // The listing ends with a legend of the codes it shows.
    let o = drivectl(&["params", "movidrive"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let legend = out.rsplit_once(" parameters\n").map(|(_, l)| l).unwrap();
    for code in ["N ", "S ", "R ", "RO ", "RW "] {
        assert!(
            legend.lines().any(|l| l.trim_start().starts_with(code)),
            "{code}: {legend}"
        );
    }
    assert!(
        legend.contains("controller inhibit"),
        "R explained: {legend}"
    );

    // `params --help` explains every code.
    let o = drivectl(&["params", "--help"]);
    let help = stdout(&o);
    for explained in [
        "N    non-volatile",
        "S    SEW: may be stored",
        "R    SEW: writing needs controller inhibit",
        "RO   read-only",
        "RW   read/write",
        "NOP  ",
        "DS   ",
    ] {
        assert!(help.contains(explained), "{explained}: {help}");
    }
}

/// The top-level commands whose `--help` must show examples. `movilink` joins once its
/// examples are in (issue 7 #21).
const COMMANDS_WITH_EXAMPLES: &[&[&str]] = &[
    &[],
    &["params"],
    &["params", "movidrive", "show"],
    &["sim"],
    &["decode"],
    &["demo"],
    &["ports"],
    &["completions"],
    &["man"],
    &["movilink"],
    &["movilink", "read"],
    &["movilink", "watch"],
    &["movilink", "write"],
    &["movilink", "info"],
    &["movilink", "scan"],
    &["movilink", "pd"],
    &["movilink", "line"],
    &["movilink", "backup"],
    &["movilink", "restore"],
    &["bonfiglioli"],
    &["bonfiglioli", "read"],
    &["bonfiglioli", "write"],
    &["bonfiglioli", "diag"],
    &["bonfiglioli", "scan"],
    &["bonfiglioli", "status"],
    &["bonfiglioli", "control"],
    &["bonfiglioli", "backup"],
    &["bonfiglioli", "restore"],
    &["bonfiglioli", "watch"],
    &["bonfiglioli", "info"],
    &["bonfiglioli", "line"],
    &["sim", "bonfiglioli"],
    &["decode", "modbus-rtu"],
    &["decode", "modbus-ascii"],
    &["uss"],
    &["uss", "read"],
    &["uss", "write"],
    &["uss", "watch"],
    &["uss", "status"],
    &["uss", "control"],
    &["uss", "backup"],
    &["uss", "restore"],
    &["uss", "scan"],
    &["uss", "line"],
    &["ctt2"],
    &["ctt2", "read"],
    &["ctt2", "write"],
    &["ctt2", "watch"],
    &["ctt2", "status"],
    &["ctt2", "control"],
    &["ctt2", "backup"],
    &["ctt2", "restore"],
    &["ctt2", "id"],
    &["ctt2", "diag"],
    &["sim", "uss"],
    &["decode", "ctt2"],
    &["decode", "uss"],
    &["sbus"],
    &["sbus", "read"],
    &["sbus", "watch"],
    &["sbus", "write"],
    &["sbus", "info"],
    &["sbus", "scan"],
    &["sbus", "pd"],
    &["sbus", "sync"],
    &["sbus", "backup"],
    &["sbus", "restore"],
    &["sbus", "ids"],
    &["sbus", "plan"],
    &["sim", "sbus"],
    &["decode", "sbus"],
];

#[test]
fn issue7_every_command_help_has_examples() {
    for cmd in COMMANDS_WITH_EXAMPLES {
        for flag in ["--help", "-h"] {
            let args: Vec<&str> = cmd.iter().copied().chain([flag]).collect();
            let o = drivectl(&args);
            assert!(o.status.success(), "{args:?}: {}", stderr(&o));
            let help = stdout(&o);
            let examples = help
                .split_once("\nExamples:\n")
                .map(|(_, e)| e)
                .unwrap_or_else(|| panic!("{args:?}: no Examples: block in {help}"));
            // Real command lines: the first example calls drivectl with the command.
            let first = examples.lines().next().unwrap_or("").trim_start();
            let expected = ["drivectl"]
                .into_iter()
                .chain(cmd.iter().copied().take(1))
                .collect::<Vec<_>>()
                .join(" ");
            assert!(first.starts_with(&expected), "{args:?}: {first}");
        }
    }
}

#[test]
fn issue7_ports_lists_or_says_none() {
    let o = drivectl(&["ports"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let first = out.lines().next().unwrap_or("");
    assert!(
        first.starts_with("port ") || first.starts_with("no serial ports found"),
        "{out}"
    );
    let o = drivectl(&["ports", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for p in json_lines(&o) {
        assert!(p["path"].is_string(), "{p}");
        assert!(
            ["usb", "pci", "bluetooth", "unknown"].contains(&p["type"].as_str().unwrap()),
            "{p}"
        );
        for key in ["vid", "pid", "serial_number", "manufacturer", "product"] {
            assert!(p.get(key).is_some(), "{key}: {p}");
        }
    }
}

#[test]
fn issue7_completions_name_the_subcommands() {
    let o = drivectl(&["completions", "bash"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let script = stdout(&o);
    assert!(script.contains("complete -F _drivectl"), "{script}");
    for sub in ["params", "movilink", "ports", "completions", "--search"] {
        assert!(script.contains(sub), "{sub}");
    }
    for shell in ["zsh", "fish", "powershell", "elvish"] {
        let o = drivectl(&["completions", shell]);
        assert!(o.status.success(), "{shell}: {}", stderr(&o));
        assert!(stdout(&o).contains("params"), "{shell}");
    }
    let o = drivectl(&["completions", "tcsh"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn issue7_man_pages_render_as_roff() {
    let o = drivectl(&["man"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = stdout(&o);
    assert!(page.contains(".TH drivectl 1"), "{page}");
    for section in [".SH NAME", ".SH SYNOPSIS", ".SH SUBCOMMANDS"] {
        assert!(page.contains(section), "{section}: {page}");
    }
    assert!(page.contains("drivectl\\-ports(1)"), "{page}");
    // The NAME line says what the tool does, not its name twice (`drivectl - drivectl: …`).
    assert!(
        page.contains(".SH NAME\ndrivectl \\- Talk to SEW, NORD and Bonfiglioli"),
        "{page}"
    );

    // One command's page, named after its path, with its options and examples.
    let o = drivectl(&["man", "params"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = stdout(&o);
    assert!(page.contains(".TH drivectl-params 1"), "{page}");
    assert!(page.contains("\\-\\-search"), "{page}");
    assert!(page.contains("Examples:"), "{page}");
    let o = drivectl(&["man", "movilink", "read"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("\\fBdrivectl movilink read\\fR"));

    let o = drivectl(&["man", "nope"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("use one of: params"), "{}", stderr(&o));
}

#[test]
fn issue22_man_list_names_every_page_the_package_installs() {
    let o = drivectl(&["man", "--list"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let list = stdout(&o);
    let paths: Vec<&str> = list.lines().collect();
    assert_eq!(paths.first(), Some(&"drivectl"), "{list}");
    for path in [
        "drivectl params",
        "drivectl movilink read",
        "drivectl gateway",
    ] {
        assert!(paths.contains(&path), "{path}: {list}");
    }
    assert!(!paths.iter().any(|p| p.ends_with(" help")), "{list}");
    // Every listed path has its page, named after the path (scripts/package installs each).
    for path in &paths {
        let mut args = vec!["man"];
        args.extend(path.split(' ').skip(1));
        let o = drivectl(&args);
        assert!(o.status.success(), "{path}: {}", stderr(&o));
        let title = format!(".TH {} 1", path.replace(' ', "-"));
        assert!(stdout(&o).contains(&title), "{path}: {}", stdout(&o));
    }
    let o = drivectl(&["man", "--list", "params"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn issue7_help_says_where_the_eeprom_wear_log_lives_and_how_to_move_it() {
    for args in [
        &["movilink", "--help"][..],
        &["movilink", "write", "--help"],
    ] {
        let help = stdout(&drivectl(args));
        assert!(help.contains("eeprom-writes.json"), "{args:?}: {help}");
        assert!(
            help.contains("set\nDRIVECTL_STATE_DIR to move it")
                || help.contains("DRIVECTL_STATE_DIR to move it"),
            "{args:?}"
        );
    }
}

#[test]
fn issue7_names_and_values_are_checked_before_the_port_is_opened() {
    for (args, what) in [
        (
            &["read", "P000", "P9999"][..],
            "no movidrive parameter `P9999`",
        ),
        (&["watch", "P9999"], "no movidrive parameter"),
        (&["info", "P9999"], "no movidrive parameter"),
        (&["write", "P130", "--5", "--raw"], "`--5`"),
        (&["write", "P700", "2.5"], "it takes one of"),
    ] {
        let mut all = vec!["movilink", "--port", "/dev/drivectl-no-such-port"];
        all.extend_from_slice(args);
        let o = drivectl(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(what), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn issue7_device_nodes_and_endless_input_are_refused_not_read_forever() {
    let started = std::time::Instant::now();
    let o = drivectl(&["decode", "movilink", "--file", "/dev/zero"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is a device node"), "{}", stderr(&o));
    let o = drivectl(&[
        "movilink",
        "--port",
        "/dev/drivectl-none",
        "restore",
        "/dev/zero",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is a device node"), "{}", stderr(&o));
    // Standard input that never ends: cut off at the limit.
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["decode", "movilink", "-"])
        .stdin(std::fs::File::open("/dev/zero").unwrap())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("larger than 64 MiB"), "{}", stderr(&o));
    assert!(started.elapsed() < std::time::Duration::from_secs(20));
    let o = drivectl(&[
        "movilink",
        "--port",
        "/dev/drivectl-none",
        "write",
        "9999",
        "99999999999999999999",
        "--raw",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("too large"), "{}", stderr(&o));
}

/// The manual's ch. 8.1 RTU examples, every one, as one stream: split at CRC boundaries and
/// explained; each frame's CRC is right (bytes: address, function, data set/parameter or byte
/// count, value or count, CRC low then high).
#[test]
fn decode_modbus_rtu_the_manuals_examples() {
    let stream = [
        "01 03 21 74 00 01 CE 2C",       // 8.1.1 ex. 1: read 372 in data set 2
        "01 03 02 05 6E 3A F8",          // its answer: 0x056E = 1390
        "01 03 01 74 00 02 85 ED",       // 8.1.1 ex. 2: register count 2
        "01 83 02 C0 F1",                // exception 2
        "03 06 41 78 00 0F 5C 09",       // 8.1.2 ex. 1: 376 in data set 4 = 15 (1.5 kW)
        "03 06 21 78 00 00 02 0D",       // 8.1.2 ex. 2: 376 = 0
        "03 86 04 E2 63",                // exception 4
        "01 64 01 E1 81 DF",             // 8.1.3 ex. 1: read 481 (FC 100)
        "01 64 00 00 03 E8 70 BC",       // its answer: 1000 = 10.00 Hz
        "01 64 26 40 5B 97",             // 8.1.3 ex. 2: unknown parameter 1600
        "01 E4 04 6A C3",                // exception 4
        "01 65 21 77 00 00 03 E8 46 C5", // 8.1.4 ex. 1: 375 in data set 2 = 10.00 Hz
        "01 65 21 77 00 00 03 84 46 E8", // 8.1.4 ex. 2: 9.00 Hz
        "01 E5 04 6B 53",                // exception 4
        "01 08 00 0A 00 00 C0 09",       // 8.1.5 ex. 1a: clear counters
        "01 08 00 0E 00 00 81 C8",       // 8.1.5 ex. 1b: slave messages
        "01 08 00 0E 00 01 40 08",       // its answer: 1
        "01 08 00 13 00 00 11 CE",       // 8.1.5 ex. 2: unknown sub-function 0x13
        "01 88 01 87 C0",                // exception 1
    ];
    let o = drivectl(&["decode", "modbus-rtu", "--json", &stream.join(" ")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), stream.len());
    assert!(v.iter().all(|f| f["valid"] == true), "{v:?}");
    assert_eq!(
        (v[1]["index"].as_u64(), v[1]["raw"].as_i64()),
        (Some(372), Some(1390))
    );
    // The answer's data set is the request's (372 is read in data set 2).
    assert_eq!(v[1]["label"], "372 data set 2");
    assert_eq!(v[3]["exception"], 2);
    assert!(
        v[3]["refusal"].as_str().unwrap().contains("exception 2"),
        "{}",
        v[3]
    );
    assert_eq!(
        (&v[4]["selector"], v[4]["raw"].as_i64()),
        (&serde_json::json!({"dataset": 4}), Some(15))
    );
    assert_eq!(v[4]["value"].as_f64(), Some(1.5));
    assert_eq!(
        (v[8]["index"].as_u64(), v[8]["raw"].as_i64()),
        (Some(481), Some(1000))
    );
    // The CRC field's value is the CRC-16 it carries (sent low byte first: CE 2C = 0x2CCE).
    let crc = v[0]["fields"].as_array().unwrap().last().unwrap().clone();
    assert_eq!(
        (&crc["name"], &crc["bytes"], &crc["value"]),
        (
            &serde_json::json!("CRC"),
            &serde_json::json!("CE 2C"),
            &serde_json::json!(0x2CCE)
        )
    );
    // 1600 is past the last parameter number (1599): named as such.
    assert!(
        v[9]["fields"].to_string().contains("data set 2"),
        "{}",
        v[9]
    );
    assert!(
        v[9]["fields"].to_string().contains("parameter 1600 (none"),
        "{}",
        v[9]
    );
    // An FC 8 answer names no parameter: its counter is the data field's value.
    assert_eq!(v[16]["raw"], serde_json::Value::Null);
    assert_eq!(
        (&v[16]["fields"][3]["name"], &v[16]["fields"][3]["value"]),
        (&serde_json::json!("data"), &serde_json::json!(1))
    );
    // Text: names and scaled values.
    let o = drivectl(&[
        "decode",
        "modbus-rtu",
        "01 03 21 74 00 01 CE 2C 01 03 02 05 6E 3A F8",
    ]);
    let text = stdout(&o);
    assert!(
        text.contains("Rated speed") && text.contains("1390 1/min"),
        "{text}"
    );
    // A wrong CRC names the right one; exit 1.
    let o = drivectl(&["decode", "modbus-rtu", "01 03 21 74 00 01 CE 2D"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("expected CE 2C"), "{}", stdout(&o));
    // Strict hex.
    let o = drivectl(&["decode", "modbus-rtu", "01 0g"]);
    assert_eq!(o.status.code(), Some(2));
}

/// The manual's ch. 8.2 ASCII examples as text, one frame per line (CR LF, a BOM and comments
/// allowed), through standard input.
#[test]
fn decode_modbus_ascii_the_manuals_examples() {
    let capture = "\u{feff}# ch. 8.2\r\n\
        :01032174000166\r\n\
        :010302056E87\r\n\
        :03064178000F2F\r\n\
        :0164 01E1 B9\r\n\
        :0164000003E8B0\r\n\
        :01E40417\r\n\
        :0165217700 0003E817\r\n\
        :0108000A0000ED\r\n\
        :0108000E0001E8\r\n";
    let o = drivectl_stdin(
        &["decode", "modbus-ascii", "--json", "-"],
        capture.as_bytes(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), 9);
    assert!(v.iter().all(|f| f["valid"] == true), "{v:?}");
    assert_eq!(
        (v[1]["index"].as_u64(), v[1]["raw"].as_i64()),
        (Some(372), Some(1390))
    );
    assert_eq!(
        (&v[2]["selector"], v[2]["raw"].as_i64()),
        (&serde_json::json!({"dataset": 4}), Some(15))
    );
    assert_eq!(v[4]["raw"], 1000);
    assert_eq!(v[5]["exception"], 4);
    // ASCII: the characters, their line, a field's characters and the binary value.
    assert_eq!(
        (&v[0]["chars"], &v[0]["line"]),
        (
            &serde_json::json!(":01032174000166\\r\\n"),
            &serde_json::json!(2)
        )
    );
    let adr = &v[0]["fields"][1];
    assert_eq!(
        (&adr["name"], &adr["chars"], &adr["bytes"], &adr["value"]),
        (
            &serde_json::json!("address"),
            &serde_json::json!("01"),
            &serde_json::json!("30 31"),
            &serde_json::json!(1)
        )
    );
    // Erratum E4: the ASC row of ch. 8.2.3 example 2 (`:01E40219`) carries code 02; the hex
    // row (04, LRC 17) is right. As hex bytes of the characters, the manual's Hex row.
    let o = drivectl(&["decode", "modbus-ascii", "3A 30 31 45 34 30 34 31 37 0D 0A"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = drivectl(&["decode", "modbus-ascii", ":01E40219"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("exception 2"), "{}", stdout(&o));
    // A wrong LRC names the right one.
    let o = drivectl(&["decode", "modbus-ascii", ":01E40418"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("expected 17"), "{}", stdout(&o));
}

/// The decode examples in `--help` decode without complaint (a wrong check byte in an example
/// would teach the wrong thing).
#[test]
fn the_decode_examples_in_help_are_valid_captures() {
    let mut ran = 0;
    for cmd in [
        &["decode"][..],
        &["decode", "modbus-rtu"],
        &["decode", "modbus-ascii"],
        &["decode", "ctt2"],
        &["decode", "uss"],
    ] {
        let help = stdout(&drivectl(&[cmd, &["--help"]].concat()));
        for line in help.lines().map(str::trim) {
            let Some(rest) = line.strip_prefix("drivectl ") else {
                continue;
            };
            if !rest.starts_with("decode ")
                || rest.contains("--file")
                || rest.contains(" - ")
                || rest.ends_with(" -")
            {
                continue;
            }
            let args: Vec<&str> = rest
                .split_whitespace()
                .take_while(|w| !w.starts_with('<'))
                .collect();
            let o = drivectl(&args);
            assert!(o.status.success(), "{rest}: {}{}", stdout(&o), stderr(&o));
            assert!(!stdout(&o).contains("INVALID"), "{rest}: {}", stdout(&o));
            ran += 1;
        }
    }
    assert!(ran >= 8, "only {ran} examples found");
}

/// NORD BU 0255 5.1.3 (P102 := 10 s in parameter set 3) and 5.1.1/5.1.2 (the control
/// sequence) carried in CTT2 messages and USS telegrams, explained by the binary.
#[test]
fn nord_decode_ctt2_and_uss_the_manuals_5_1_telegrams() {
    let o = drivectl(&[
        "decode",
        "ctt2",
        "--json",
        // NORD write on index 47 (2Fh), 8 bytes: PKE 70 66 (AK 7, P102), IND 02 00 (set 3,
        // erratum E4), PWE 00 00 03 E8 (1000 = 10.00 s).
        "13 2F 08 70 66 02 00 00 00 03 E8",
        // Write answer OK, then NORD read of index 47 and its answer (AK 4, the value).
        "53 12 2F 08 52 40 66 02 00 00 00 03 E8",
        // 5.1.1/5.1.2 through write/read of the PZD channel (index 3): address 1, STW, SW1;
        // answer address 1, ZSW, IW1.
        "1D 03 05 05 01 04 7E 00 00 5D 01 0B 31 00 00",
        "1D 03 05 05 01 04 7F 20 00 5D 01 0B 37 20 00",
    ]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), 8);
    assert_eq!(
        (
            &v[0]["index"],
            &v[0]["selector"]["set"],
            &v[0]["raw"],
            &v[0]["value"]
        ),
        (
            &serde_json::json!(102),
            &serde_json::json!(3),
            &serde_json::json!(1000),
            &serde_json::json!(10.0)
        )
    );
    assert_eq!(
        (&v[3]["ak"], &v[3]["raw"]),
        (&serde_json::json!(4), &serde_json::json!(1000))
    );
    assert_eq!(v[5]["process_data"], serde_json::json!([0x0B31, 0]));
    assert_eq!(v[6]["process_data"], serde_json::json!([0x047F, 0x2000]));
    assert_eq!(v[7]["process_data"], serde_json::json!([0x0B37, 0x2000]));
    // The same order in a USS telegram (STX, LGE 0Eh, ADR 1, PKW, STW 047E, SW1 0, BCC 88),
    // then the drive's answer (BCC F8).
    let o = drivectl(&[
        "decode",
        "uss",
        "--json",
        "02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88",
        "02 0E 01 40 66 02 00 00 00 03 E8 0B 31 00 00 F8",
    ]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let v = json_lines(&o);
    assert_eq!(
        (&v[0]["direction"], &v[1]["direction"]),
        (
            &serde_json::json!("request"),
            &serde_json::json!("response")
        )
    );
    assert_eq!(
        (&v[0]["address"], &v[0]["raw"]),
        (&serde_json::json!(1), &serde_json::json!(1000))
    );
    // A wrong BCC: invalid, exit 1, the right one named.
    let o = drivectl(&[
        "decode",
        "uss",
        "02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 89",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("expected 88h"), "{}", stdout(&o));
}

#[test]
fn nord_bad_input_is_refused_before_anything_is_opened() {
    for (args, code, what) in [
        (&["uss", "read", "P102"][..], 2, "no serial port given"),
        (&["ctt2", "read", "P102"], 2, "add --sim"),
        (
            &["uss", "--port", "/dev/x", "--addr", "32", "read", "P102"],
            2,
            "32",
        ),
        (
            &["uss", "--port", "/dev/x", "--pkw", "2", "read", "P102"],
            2,
            "2",
        ),
        (
            &["uss", "--port", "/dev/x", "write", "P102", "1e3"],
            2,
            "not a number",
        ),
        (
            &["uss", "--port", "/dev/x", "write", "P102", "0x10"],
            2,
            "not a number",
        ),
        (
            &[
                "uss", "--port", "/dev/x", "write", "P102", "2.555", "--set", "1",
            ],
            2,
            "cannot hold 2.555 exactly",
        ),
        (
            &[
                "uss",
                "--port",
                "/dev/x",
                "control",
                "enable",
                "--setpoint",
                "200",
            ],
            2,
            "setpoint",
        ),
        (
            &["uss", "--port", "/dev/x", "--pzd", "0", "status"],
            2,
            "--pzd 0",
        ),
        (
            &[
                "uss",
                "--port",
                "/dev/x",
                "--timeout",
                "1",
                "--baud",
                "4800",
                "read",
                "P102",
            ],
            2,
            "start delay",
        ),
        (&["ctt2", "--sim", "--asi-address", "5B", "id"], 2, "1A…31A"),
        (&["ctt2", "--sim", "--slaves", "63", "id"], 2, "63"),
        (
            &["sim", "uss", "--pty", "--addr", "32", "--parity", "none"],
            2,
            "0…31",
        ),
        (&["sim", "uss", "--pty"], 2, "parity even (the default)"),
        (&["decode", "ctt2", "13 2F 0"], 2, "`0`"),
        (&["ctt2", "--sim", "restore", "/dev/zero"], 2, "device node"),
    ] {
        let o = drivectl(args);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(what), "{args:?}: {}", stderr(&o));
    }
    // With --json the error is one JSON object.
    let o = drivectl(&["uss", "--json", "read", "P102"]);
    let e: serde_json::Value = serde_json::from_str(stderr(&o).trim()).unwrap();
    assert_eq!(
        (&e["type"], &e["exit_code"]),
        (&serde_json::json!("error"), &serde_json::json!(2))
    );
    // The write help names the EEPROM-wear log and the RAM-only way.
    let help = stdout(&drivectl(&["uss", "write", "--help"]));
    assert!(
        help.contains("eeprom-writes.json")
            && help.contains("--volatile")
            && help.contains("--no-eeprom"),
        "{help}"
    );
}

#[test]
fn nord_ctt2_sim_runs_the_commands_on_the_simulated_as_i_link() {
    // The ID object (manufacturer 1, 137 as in 4.3.1) and the diagnosis object (45 °C).
    let o = drivectl(&["ctt2", "--sim", "--fast", "--json", "id"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_lines(&o)[0]["manufacturer_id"], 0x0189);
    let o = drivectl(&["ctt2", "--sim", "--fast", "--json", "diag"]);
    assert_eq!(json_lines(&o)[0]["temperature_c"], 45);
    // A parameter in a set, an array element, the state machine: within one run each.
    let o = drivectl(&[
        "ctt2", "--sim", "--fast", "--json", "read", "P102", "--set", "3",
    ]);
    assert_eq!(json_lines(&o)[0]["selector"]["set"], 3);
    let o = drivectl(&[
        "ctt2", "--sim", "--fast", "--json", "read", "P543", "--array", "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_lines(&o)[0]["selector"]["array"], 2);
    let o = drivectl(&[
        "ctt2",
        "--sim",
        "--fast",
        "--json",
        "control",
        "enable",
        "--setpoint",
        "50",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_lines(&o)[0]["state"], "E");
    // The simulated drive ends with the command: no advice to stop a motor that is gone.
    assert!(
        stderr(&o).contains("until the simulation ended with the command"),
        "{}",
        stderr(&o)
    );
    assert!(!stderr(&o).contains("control stop"), "{}", stderr(&o));
    // A backup holds every array element and parameter set (the IND word as the manual's
    // 4.6.1.2 forms it: sets in bits 8-9, a set parameter's element in bits 10-15, any other
    // parameter's element in bits 8-15), P560 last; a restore writes a changed one back.
    let dir = std::env::temp_dir().join(format!("drivectl-ctt2-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("nord.json");
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "ctt2",
            "--sim",
            "--fast",
            "backup",
            "--out",
            file.to_str().unwrap(),
        ])
        .env("DRIVECTL_STATE_DIR", &dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let numbers: Vec<String> = doc["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["number"].as_str().unwrap().to_owned())
        .collect();
    assert_eq!(numbers.len(), 57, "{numbers:?}");
    for label in ["P102 set 4", "P480 [-12]", "P543 [-03]", "P701 [-05]"] {
        assert!(numbers.iter().any(|n| n == label), "{label}: {numbers:?}");
    }
    assert_eq!(numbers.last().map(String::as_str), Some("P560"));
    for p in doc["parameters"].as_array_mut().unwrap() {
        if p["number"] == "P102 set 3" {
            p["raw"] = serde_json::json!(1000);
        }
    }
    std::fs::write(&file, doc.to_string()).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args([
            "ctt2",
            "--sim",
            "--fast",
            "--json",
            "restore",
            file.to_str().unwrap(),
        ])
        .env("DRIVECTL_STATE_DIR", &dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.last().unwrap()["written"], 1, "{v:?}");
    let _ = std::fs::remove_dir_all(&dir);
    // 31 AS-i slaves: 81.312 ms per byte (section 4.4), counted on the virtual clock.
    let o = drivectl(&["ctt2", "--sim", "--fast", "--slaves", "31", "diag"]);
    assert!(stderr(&o).contains("81.312 ms per byte"), "{}", stderr(&o));
}

/// Manual ch. 5.6: the identifiers of the drive at SBus address 33.
#[test]
fn issue10_sbus_ids_reproduce_the_manual_table() {
    let o = drivectl(&["sbus", "ids", "--addr", "33", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ids: Vec<i64> = json_lines(&o)
        .iter()
        .map(|v| v["id"].as_i64().unwrap())
        .collect();
    assert_eq!(ids, [779, 780, 267, 268, 269, 518, 6, 0]);
    let o = drivectl(&["sbus", "ids", "--addr", "64"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn issue10_decode_sbus_frames_and_logs() {
    let o = drivectl(&[
        "decode", "sbus", "--id", "524", "31", "00", "20", "7E", "00", "0F", "42", "40", "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = &json_lines(&o)[0];
    assert_eq!(v["index"], 8318);
    assert_eq!(v["raw"], 1_000_000);
    assert_eq!(v["address"], 1);
    // Nine bytes, an identifier past 11 bits: usage errors.
    let o = drivectl(&[
        "decode", "sbus", "--id", "1", "0", "1", "2", "3", "4", "5", "6", "7", "8",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let o = drivectl(&["decode", "sbus", "--id", "2048"]);
    assert_eq!(o.status.code(), Some(2));
    // A candump log saved by Notepad: BOM and CR LF.
    let dir = std::env::temp_dir().join(format!("drivectl-sbus-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("capture.log");
    std::fs::write(
        &log,
        "\u{feff}(1735270496.916858) can0 20B#3100207E00000000\r\n(1735270496.917100) can0 20C#3100207E000F4240\r\n",
    )
    .unwrap();
    let o = drivectl(&["decode", "sbus", "--log", log.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v.len(), 2);
    assert_eq!(v[1]["raw"], 1_000_000);
    assert_eq!(v[1]["time"], "1735270496.917100");
    // A line that is no record: named with its number, exit 1.
    std::fs::write(&log, "(1.000000) can0 000#\ngarbage\n").unwrap();
    let o = drivectl(&["decode", "sbus", "--log", log.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("line 2"), "{}", stdout(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn issue10_sbus_plan_checks_the_manual_example() {
    let dir = std::env::temp_dir().join(format!("drivectl-sbus-plan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plan = dir.join("bus.toml");
    let manual = "bitrate = \"500k\"\n[[device]]\nname = \"device 1\"\naddress = 0\nmaster_of = [\"address 1\", \"group 2\"]\n[[device]]\nname = \"device 2\"\naddress = 1\ngroup = 2\n";
    std::fs::write(&plan, manual).unwrap();
    let o = drivectl(&[
        "sbus",
        "plan",
        plan.to_str().unwrap(),
        "--forbidden",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_lines(&o);
    assert_eq!(v[1]["device"], "device 2");
    assert_eq!(
        v[1]["transmit"],
        serde_json::json!([523, 524, 11, 12, 13, 534, 22, 0, 516, 4])
    );
    // Device 2 sends a variable telegram on 515, device 1's parameter request identifier.
    let bad =
        format!("{manual}[[device.object]]\nid = 515\nkind = \"cyclic\"\ncycle_ms = 10\nlen = 8\n");
    std::fs::write(&plan, bad).unwrap();
    let o = drivectl(&["sbus", "plan", plan.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stdout(&o).contains("515"), "{}", stdout(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn issue10_sbus_read_json_on_the_virtual_bus() {
    let o = drivectl(&[
        "sbus", "--iface", "virtual", "--addr", "1", "read", "8318", "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = &json_lines(&o)[0];
    assert_eq!(v["index"], 8318);
    assert_eq!(v["raw"], 0);
    // No interface: a usage error saying what to give, before anything is opened.
    let o = drivectl(&["sbus", "read", "P000"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--iface"), "{}", stderr(&o));
}

/// Issue 18: `control enable --setpoint` sent 100.0001 % as 4000h without a word; now a
/// setpoint SW1 cannot hold is refused (USS before the port opens, CTT2 alike) naming the
/// nearest, and `--round` sends the nearest and says so.
#[test]
fn issue18_a_setpoint_sw1_cannot_hold_is_refused_or_rounded_with_a_note() {
    for prefix in [
        &["uss", "--port", "/dev/drivectl-no-such-port"][..],
        &["ctt2", "--sim", "--fast"],
    ] {
        let o = drivectl(&[prefix, &["control", "enable", "--setpoint", "100.0001"]].concat());
        assert_eq!(o.status.code(), Some(2), "{prefix:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("100 % (0x4000)") && e.contains("--round"), "{e}");
        assert!(!e.contains("no-such-port"), "{e}");
        let o = drivectl(
            &[
                prefix,
                &["control", "enable", "--setpoint", "200", "--round"],
            ]
            .concat(),
        );
        assert_eq!(o.status.code(), Some(2), "{prefix:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("0x7FFF"), "{}", stderr(&o));
    }
    let o = drivectl(&[
        "ctt2",
        "--sim",
        "--fast",
        "--json",
        "control",
        "enable",
        "--setpoint",
        "100.0001",
        "--round",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_lines(&o)[0]["setpoint"], 0x4000);
    assert!(
        stderr(&o).contains("cannot hold 100.0001 %"),
        "{}",
        stderr(&o)
    );
    // The word's lower end, 8000h, is a setpoint (BU 0255 4.5.4: −32768…32767).
    let o = drivectl(&[
        "ctt2",
        "--sim",
        "--fast",
        "--json",
        "control",
        "enable",
        "--setpoint",
        "-200",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_lines(&o)[0]["setpoint"], 0x8000);
}

/// Issue 18: `info` and `line` exist for CTT2 as for every family: `info` as over USS, `line`
/// what the simulated AS-i link uses (double slave, addresses, the cycle and byte time of BU
/// 0255 4.4); the defaults of --addr, --timeout and --asi-address say where they come from.
#[test]
fn issue18_ctt2_info_and_line() {
    let o = drivectl(&["ctt2", "--sim", "--fast", "--json", "info", "P543"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = &json_lines(&o)[0];
    assert_eq!(
        (&v["array_len"], &v["array_len_drive"]),
        (&serde_json::json!(3), &serde_json::json!(3))
    );
    assert_eq!(v["current"].as_array().map(Vec::len), Some(3));
    let o = drivectl(&[
        "ctt2",
        "--sim",
        "--slaves",
        "31",
        "--asi-address",
        "5A",
        "--json",
        "line",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = &json_lines(&o)[0];
    assert_eq!(
        (&v["asi_address"], &v["second_slave"]),
        (&serde_json::json!("5A"), &serde_json::json!("5B"))
    );
    // 31 slaves: 81.312 ms per byte, 16 AS-i cycles of 154 µs × 33.
    assert_eq!(v["byte_time_us"].as_f64(), Some(81_312.0));
    assert_eq!(v["asi_cycle_us"].as_f64(), Some(5_082.0));
    assert_eq!(v["answer_window_ms"], 200);
    let o = drivectl(&["ctt2", "--sim", "line"]);
    assert!(
        stdout(&o).contains("a CTT2 byte takes 16 cycles: 9.856 ms"),
        "{}",
        stdout(&o)
    );
    let help = stdout(&drivectl(&["uss", "--help"]));
    assert!(
        help.contains("Default 0: the address") && help.contains("Default 50: the 20 ms"),
        "{help}"
    );
    let help = stdout(&drivectl(&["ctt2", "--help"]));
    assert!(
        help.contains("Default 1A") && help.contains("200 ms"),
        "{help}"
    );
}

/// The keys every `decode --json` object has, whatever the protocol (docs/decode-json.md,
/// which the library's tests check against the list).
use drive_decode::COMMON_KEYS as DECODE_KEYS;

/// Issue 18: the decoders had their own JSON words for the same things (`field`/`name`,
/// `meaning`, `text`/`bytes`, `parameter`, `set`, `data_set`, `words`); every object of every
/// decoder now has the common keys, fields are `{offset, bytes, name, value, text}`, a
/// parameter is named with the keys of `read --json`, and bytes that start no telegram are
/// `"type": "skipped"`.
#[test]
fn issue18_every_decoder_emits_one_shape() {
    let runs: [(&[&str], &str, usize); 6] = [
        (
            &["movilink", "55", "02 01 86 31 00 20 6D 00 00 00 00 F9"],
            "movilink",
            1,
        ),
        (
            &["sbus", "--id", "524", "31 00 20 7E 00 0F 42 40"],
            "sbus",
            0,
        ),
        (
            &[
                "uss",
                "55",
                "02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88",
            ],
            "uss",
            1,
        ),
        (
            &["ctt2", "FF", "13 2F 08 70 66 02 00 00 00 03 E8"],
            "ctt2",
            1,
        ),
        (&["modbus-rtu", "01 03 21 74 00 01 CE 2C"], "modbus-rtu", 0),
        (&["modbus-ascii", "x:01032174000166"], "modbus-ascii", 1),
    ];
    for (args, protocol, telegram) in runs {
        let mut all = vec!["decode"];
        all.extend_from_slice(args);
        all.push("--json");
        let o = drivectl(&all);
        let v = json_lines(&o);
        assert!(!v.is_empty(), "{args:?}: {}", stderr(&o));
        for obj in &v {
            let m = obj.as_object().unwrap();
            for k in DECODE_KEYS {
                assert!(m.contains_key(k), "{protocol}: no `{k}` in {obj}");
            }
            assert_eq!(obj["protocol"], protocol);
            for f in obj["fields"].as_array().unwrap() {
                let keys: Vec<&String> = f.as_object().unwrap().keys().collect();
                for k in ["offset", "bytes", "name", "value", "text"] {
                    assert!(f.get(k).is_some(), "{protocol}: field without `{k}`: {f}");
                }
                assert!(keys.len() <= 6, "{protocol}: {f}");
            }
        }
        let t = &v[telegram];
        assert_eq!(t["type"], "telegram", "{t}");
        if telegram == 1 {
            assert_eq!(
                (&v[0]["type"], &v[0]["valid"]),
                (&serde_json::json!("skipped"), &serde_json::json!(false)),
                "{}",
                v[0]
            );
        }
        // Every one of these names a parameter, in the keys of `read --json`.
        assert!(
            t["index"].is_u64() && t["label"].is_string() && t["name_en"].is_string(),
            "{t}"
        );
    }
}

/// Issue 18: `decode modbus-ascii` given a frame without its `:` printed the characters the
/// hex digits stand for, control characters and all, to the terminal; now the missing `:` is
/// said with the command that has it, and no control character from the input is printed.
#[test]
fn issue18_modbus_ascii_without_its_colon_says_so_and_prints_no_control_characters() {
    let o = drivectl(&["decode", "modbus-ascii", "01032174000166"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let e = stderr(&o);
    assert!(e.contains("no `:`"), "{e}");
    assert!(
        e.contains("drivectl decode modbus-ascii :01032174000166"),
        "{e}"
    );
    let printed = [stdout(&o), e].concat();
    assert!(
        !printed.chars().any(|c| c.is_control() && c != '\n'),
        "{printed:?}"
    );
    // Control characters between frames of a capture are shown escaped.
    let o = drivectl_stdin(
        &["decode", "modbus-ascii", "-"],
        b"\x1b[2J\x07:01032174000166\r\n",
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        !text.chars().any(|c| c.is_control() && c != '\n'),
        "{text:?}"
    );
    assert!(text.contains("\\x1B[2J\\x07"), "{text}");
    assert!(text.contains("no `:` before it"), "{text}");
}

/// Issue 18: a candump log line with a time stamp candump does not write (`(1.0)`) was refused
/// without saying what one looks like; now the message shows it, six digits after the point.
#[test]
fn issue18_decode_sbus_log_says_what_a_candump_time_stamp_looks_like() {
    let dir = std::env::temp_dir().join(format!("drivectl-sbus-stamp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("capture.log");
    std::fs::write(&log, "(1.0) slcan0 20B#3100207E00000000\n").unwrap();
    let o = drivectl(&["decode", "sbus", "--log", log.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let text = stdout(&o);
    assert!(
        text.contains("`(1.0)`") && text.contains("(1700000000.123456)"),
        "{text}"
    );
    assert!(text.contains("six digits"), "{text}");
    let o = drivectl(&["decode", "sbus", "--log", log.to_str().unwrap(), "--json"]);
    let v = json_lines(&o);
    assert_eq!(
        (&v[0]["type"], &v[0]["line"]),
        (&serde_json::json!("skipped"), &serde_json::json!(1))
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 18 D: `--port /dev/pts/ptmx` was accepted (it opens a new pty master nobody listens
/// to, so every request timed out); the multiplexer, also through a symbolic link, is refused
/// as no port in every family, a usage error.
#[test]
fn issue18_the_pty_multiplexer_is_no_port_in_any_family() {
    let link = std::env::temp_dir().join(format!("drivectl-ptmx-{}", std::process::id()));
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink("/dev/ptmx", &link).unwrap();
    let link = link.to_str().unwrap().to_owned();
    for port in ["/dev/ptmx", "/dev/pts/ptmx", link.as_str()] {
        let slcan = format!("slcan:{port}");
        for args in [
            vec![
                "movilink", "--port", port, "--parity", "none", "read", "P130",
            ],
            vec!["uss", "--port", port, "--parity", "none", "read", "P102"],
            vec![
                "bonfiglioli",
                "--port",
                port,
                "--parity",
                "none",
                "read",
                "372",
            ],
            vec!["sbus", "--iface", &slcan, "read", "P130"],
        ] {
            let o = drivectl(&args);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
            assert!(
                stderr(&o).contains("is not a serial port")
                    && stderr(&o).contains("pseudo-terminal multiplexer"),
                "{args:?}: {}",
                stderr(&o)
            );
        }
    }
    let _ = std::fs::remove_file(&link);
}
