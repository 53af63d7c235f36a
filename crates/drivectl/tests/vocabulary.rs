//! Issue 18 C: one vocabulary across the four families. The same jobs — read, write to RAM,
//! info, line, watch, backup and a dry-run restore — are run through every family against its
//! simulator over a real pseudo-terminal (CTT2 in-process), and the shapes of what they print
//! are compared: the same options work, the same JSON keys come back, the same refusals are
//! made.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;

use std::collections::BTreeSet;
use std::process::Output;

use common::{PtySim, ok_json, stderr};
use serde_json::Value;

/// The keys of every value object (`read --json`, `watch`, `info`'s `current`, `write`).
const VALUE_KEYS: [&str; 11] = [
    "decoded", "index", "label", "meaning", "name_de", "name_en", "number", "raw", "selector",
    "unit", "value",
];

/// What every family's `info --json` has.
const INFO_KEYS: [&str; 12] = [
    "access",
    "current",
    "default",
    "default_value",
    "index",
    "label",
    "name_de",
    "name_en",
    "number",
    "range",
    "selector",
    "unit",
];

/// What every family's `line --json` has.
const LINE_KEYS: [&str; 3] = ["address", "response_timeout_ms", "retries"];

/// One family: how to reach its simulated drive, and the parameter the jobs use (with its
/// selector where the family has one).
struct Family {
    name: &'static str,
    _sim: Option<PtySim>,
    state: std::path::PathBuf,
    prefix: Vec<String>,
    param: Vec<&'static str>,
    /// A value to write to RAM, in the parameter's unit.
    value: &'static str,
    /// The selector `read --json` must show.
    selector: Value,
}

impl Family {
    fn start(name: &'static str) -> Family {
        let sim = match name {
            "movilink" => Some(PtySim::start(&[
                "sim", "movilink", "--pty", "--addr", "1", "--parity", "none",
            ])),
            "sbus" => Some(PtySim::start(&["sim", "sbus", "--pty", "--addr", "1"])),
            "uss" => Some(PtySim::start(&[
                "sim", "uss", "--pty", "--addr", "1", "--parity", "none",
            ])),
            "bonfiglioli" => Some(PtySim::start(&[
                "sim",
                "bonfiglioli",
                "--pty",
                "--parity",
                "none",
                "--mode",
                "rtu",
            ])),
            _ => None,
        };
        let path = sim.as_ref().map(|s| s.path.clone()).unwrap_or_default();
        let state = sim.as_ref().map_or_else(
            || std::env::temp_dir().join(format!("drivectl-vocabulary-{}", std::process::id())),
            |s| s.state.clone(),
        );
        let (prefix, param, value, selector): (Vec<String>, Vec<&str>, &str, Value) = match name {
            "movilink" => (
                strings(&[
                    "movilink", "--port", &path, "--parity", "none", "--addr", "1",
                ]),
                vec!["P130"],
                "2.5",
                Value::Null,
            ),
            "sbus" => (
                strings(&[
                    "sbus",
                    "--iface",
                    &format!("slcan:{path}@500k"),
                    "--addr",
                    "1",
                ]),
                vec!["P130"],
                "2.5",
                Value::Null,
            ),
            "uss" => (
                strings(&["uss", "--port", &path, "--parity", "none", "--addr", "1"]),
                vec!["P102", "--set", "2"],
                "2.5",
                serde_json::json!({"set": 2, "ind": "0x0100"}),
            ),
            "ctt2" => (
                strings(&["ctt2", "--sim", "--fast"]),
                vec!["P102", "--set", "2"],
                "2.5",
                serde_json::json!({"set": 2, "ind": "0x0100"}),
            ),
            _ => (
                strings(&[
                    "bonfiglioli",
                    "--port",
                    &path,
                    "--parity",
                    "none",
                    "--addr",
                    "1",
                ]),
                vec!["376", "--dataset", "2"],
                "1.5",
                serde_json::json!({"dataset": 2}),
            ),
        };
        Family {
            name,
            _sim: sim,
            state,
            prefix,
            param,
            value,
            selector,
        }
    }

    fn run(&self, args: &[&str]) -> Output {
        std::process::Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(&self.prefix)
            .args(args)
            .env("DRIVECTL_STATE_DIR", &self.state)
            .output()
            .unwrap()
    }

    /// `job` with the family's parameter (and selector) in place of `{}`.
    fn job(&self, job: &[&str]) -> Vec<String> {
        let mut v = Vec::new();
        for w in job {
            if *w == "{}" {
                v.extend(self.param.iter().map(|s| (*s).to_owned()));
            } else {
                v.push((*w).to_owned());
            }
        }
        v
    }

    fn json(&self, job: &[&str]) -> Vec<Value> {
        let args = self.job(job);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = self.run(&args);
        assert!(o.status.success(), "{} {args:?}: {}", self.name, stderr(&o));
        ok_json(&o)
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| (*s).to_owned()).collect()
}

fn keys(v: &Value) -> BTreeSet<String> {
    v.as_object()
        .unwrap_or_else(|| panic!("not an object: {v}"))
        .keys()
        .cloned()
        .collect()
}

fn set(k: &[&str]) -> BTreeSet<String> {
    k.iter().map(|s| (*s).to_owned()).collect()
}

#[test]
fn issue18_the_same_jobs_have_the_same_shape_in_every_family() {
    let families: Vec<Family> = ["movilink", "sbus", "uss", "ctt2", "bonfiglioli"]
        .into_iter()
        .map(Family::start)
        .collect();
    for f in &families {
        let n = f.name;
        // read: the value keys, the selector as the family has one, the label naming it.
        let v = f.json(&["--json", "read", "{}"]);
        assert_eq!(keys(&v[0]), set(&VALUE_KEYS), "{n} read");
        assert_eq!(v[0]["selector"], f.selector, "{n} read");
        // write to RAM: --volatile in every family; the value keys and what was sent.
        let mut job = vec!["--json", "write", "{}"];
        job.push(f.value);
        job.push("--volatile");
        let w = f.json(&job);
        let mut expected = set(&VALUE_KEYS);
        expected.extend(set(&["sent", "differs"]));
        assert_eq!(keys(&w[0]), expected, "{n} write");
        assert_eq!(w[0]["differs"], false, "{n} write");
        assert_eq!(w[0]["label"], v[0]["label"], "{n} write");
        // info: the keys of movilink's, the drive's value as a value object.
        let i = f.json(&["--json", "info", "{}"]);
        assert!(
            keys(&i[0]).is_superset(&set(&INFO_KEYS)),
            "{n} info lacks {:?}",
            set(&INFO_KEYS).difference(&keys(&i[0])).collect::<Vec<_>>()
        );
        assert_eq!(keys(&i[0]["current"][0]), set(&VALUE_KEYS), "{n} info");
        if n != "ctt2" {
            // (`ctt2 --sim` runs every command against a new simulated drive.)
            assert_eq!(i[0]["current"][0]["raw"], w[0]["raw"], "{n} info");
        }
        // line: the master's timing, with the same keys where they mean the same.
        let l = f.json(&["--json", "line"]);
        assert!(
            keys(&l[0]).is_superset(&set(&LINE_KEYS)),
            "{n} line lacks {:?}",
            set(&LINE_KEYS).difference(&keys(&l[0])).collect::<Vec<_>>()
        );
        if n == "ctt2" {
            continue;
        }
        // watch: one sample object of value objects.
        let s = f.json(&["--json", "watch", "{}", "--count", "1", "--interval", "100"]);
        assert_eq!(keys(&s[0]), set(&["type", "time", "values"]), "{n} watch");
        assert_eq!(keys(&s[0]["values"][0]), set(&VALUE_KEYS), "{n} watch");
        // A response timeout no answer can meet is refused before anything is sent.
        let o = f.run(&["--timeout", "1", "read", f.param[0]]);
        assert_eq!(o.status.code(), Some(2), "{n} --timeout 1: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--timeout") && stderr(&o).contains("or more"),
            "{n}: {}",
            stderr(&o)
        );
    }
    // The same refusal of an unknown option spelling of the RAM-only write is nowhere: the
    // family's own word is an alias where it has one.
    for (f, alias) in [(&families[2], "--no-eeprom"), (&families[4], "--ram")] {
        let mut job = vec!["--json", "write", "{}"];
        job.push(f.value);
        job.push(alias);
        f.json(&job);
    }
}

#[test]
fn issue18_backup_and_a_dry_run_restore_look_the_same_in_every_family() {
    let dir = std::env::temp_dir().join(format!("drivectl-vocab-backup-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut summaries = Vec::new();
    for name in ["movilink", "sbus", "uss", "bonfiglioli"] {
        let f = Family::start(name);
        let file = dir.join(format!("{name}.json"));
        let file = file.to_str().unwrap();
        let o = f.run(&["backup", "--out", file]);
        assert!(o.status.success(), "{name} backup: {}", stderr(&o));
        let o = f.run(&["--json", "restore", file, "--dry-run"]);
        assert!(o.status.success(), "{name} restore: {}", stderr(&o));
        let lines = ok_json(&o);
        let last = lines.last().unwrap().clone();
        summaries.push((name, keys(&last)));
    }
    let (first, k) = &summaries[0];
    for (name, other) in &summaries[1..] {
        assert_eq!(other, k, "{name}'s restore summary differs from {first}'s");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
