//! The drive view in a real browser (headless Chromium through chromedriver) against a MOVILINK
//! simulator on a pseudo-terminal, served by `drivectl ui movilink --port PTY`: a write through
//! the form, writes the guard refuses (range, read-only, EEPROM wear) and one without the CSRF
//! token, the fault memory, a restore of a changed file with its plan, and a backup. Afterwards
//! the page is stopped and the simulator is asked directly, by `drivectl movilink read` and
//! `backup`: the values are the ones the page wrote, nothing refused arrived, and the page's
//! backup is the file `drivectl backup` writes. Screenshots go to `target/ui-screenshots/`.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common;
#[path = "common/web.rs"]
mod web;

use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{PtySim, ok_json};
use serde_json::{Value, json};
use web::{Reaped, Scratch, Session, browser_tools, free_port, request};

/// `drivectl movilink --port PTY --parity none --addr 1 --json ARGS`, straight to the simulator.
fn direct(sim: &PtySim, args: &[&str]) -> Vec<Value> {
    let mut all = vec![
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--json",
    ];
    all.extend_from_slice(args);
    ok_json(&sim.drivectl(&all))
}

fn value_of(sim: &PtySim, param: &str) -> f64 {
    let v = direct(sim, &["read", param]);
    v[0]["value"]
        .as_f64()
        .unwrap_or_else(|| panic!("{param}: {v:?}"))
}

/// The note under a row's editor once it says something other than "checking…"/"writing…".
fn note(s: &Session, number: &str) -> String {
    let script = format!(
        "const n = document.querySelector('tr[data-number={number}] .note'); \
         return n ? n.textContent : null;"
    );
    s.wait_for(20, &script, |v| {
        v.as_str()
            .is_some_and(|t| !t.is_empty() && !t.ends_with('…'))
    })
    .as_str()
    .unwrap()
    .to_owned()
}

/// Type `value` into the editor of `number`, set its EEPROM box, press check.
fn check(s: &Session, number: &str, value: &str, eeprom: bool) -> String {
    s.run(&format!(
        "const r = document.querySelector('tr[data-number={number}]'); \
         const i = r.querySelector('td.edit input:not([type=checkbox])'); i.value = {value:?}; \
         i.dispatchEvent(new Event('input')); \
         const e = r.querySelector('td.edit input[type=checkbox]'); e.checked = {eeprom}; \
         e.dispatchEvent(new Event('change')); \
         r.querySelector('.note').textContent = ''; \
         r.querySelectorAll('td.edit button')[0].click();"
    ));
    note(s, number)
}

/// Press write in the row of `number` (after a check that passed); the note it leaves.
fn write(s: &Session, number: &str) -> String {
    let enabled = s.run(&format!(
        "const r = document.querySelector('tr[data-number={number}]'); \
         const w = r.querySelectorAll('td.edit button')[1]; const on = !w.disabled; \
         r.querySelector('.note').textContent = ''; w.click(); return on;"
    ));
    assert_eq!(enabled, json!(true), "write is enabled after a good check");
    note(s, number)
}

/// Show the parameters whose names hold `term`; wait until `number` is listed.
fn search(s: &Session, term: &str, number: &str) {
    s.run(&format!(
        "const i = document.getElementById('search'); i.value = {term:?}; \
         i.dispatchEvent(new Event('input'));"
    ));
    s.wait_for(
        20,
        &format!(
            "const c = document.querySelector('#drive .figures'); \
             return !!document.querySelector('tr[data-number={number}]') && !!c && c.textContent.includes({term:?});"
        ),
        |v| v == &json!(true),
    );
}

/// `POST path` from inside the page with `headers`, its status and body.
fn page_post(s: &Session, path: &str, headers: &str, body: &Value) -> (u64, Value) {
    let v = s.run(&format!(
        "return fetch({path:?}, {{method: 'POST', headers: {headers}, body: {:?}}})\
           .then(async r => [r.status, await r.text()]);",
        body.to_string()
    ));
    let text = v[1].as_str().unwrap();
    (
        v[0].as_u64().unwrap(),
        serde_json::from_str(text).unwrap_or(json!(text)),
    )
}

/// The page's backup of the drive (the backup button, the file it offers).
fn page_backup(s: &Session) -> String {
    s.run("window.lastBackup = undefined; document.querySelectorAll('.tools button')[2].click();");
    let file = s.wait_for(
        120,
        "return window.lastBackup === undefined ? 'waiting' : window.lastBackup;",
        |v| v != "waiting",
    );
    let status = s.run("return document.getElementById('tool-status').textContent;");
    file.as_str()
        .unwrap_or_else(|| panic!("no backup: {status}"))
        .to_owned()
}

/// Choose `file` in the file input `selector`, as a person picking it would.
fn upload(s: &Session, selector: &str, file: &std::path::Path) {
    let input = s.command(
        "POST",
        "element",
        Some(&json!({"using": "css selector", "value": selector})),
    );
    let id = input
        .as_object()
        .and_then(|o| o.values().next())
        .and_then(Value::as_str)
        .unwrap()
        .to_owned();
    s.command(
        "POST",
        &format!("element/{id}/value"),
        Some(&json!({"text": file.to_str().unwrap()})),
    );
}

#[test]
fn the_drive_view_writes_refuses_restores_and_backs_up_as_drivectl_does() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1", "--addr", "2",
    ]);
    let port = free_port();
    let page = SocketAddr::from(([127, 0, 0, 1], port));
    let ui = sim
        .command()
        .args([
            "ui", "movilink", "--port", &sim.path, "--parity", "none", "--addr", "1", "--addr", "2",
        ])
        // A machine loaded by other tests is slow on the pty: more time and attempts per read
        // (the page's work, not the line's timing, is under test).
        .args(["--timeout", "300", "--retries", "4"])
        .args(["--listen", &page.to_string(), "--no-open"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut ui = Reaped(ui);
    let until = Instant::now() + Duration::from_secs(30);
    while std::net::TcpStream::connect(page).is_err() {
        assert!(Instant::now() < until, "the page did not listen");
        std::thread::sleep(Duration::from_millis(50));
    }
    let s = Session::start(&chromium, &chromedriver, 1280, 1000);
    s.open(&format!("http://{page}/#drive/0/0"));
    s.wait_for(
        30,
        "return document.querySelectorAll('table.params tr').length;",
        |v| v.as_u64().is_some_and(|n| n > 100),
    );

    // German and English find the ramps.
    search(&s, "Rampe", "P130");
    search(&s, "ramp", "P131");

    // A write through the form: the check says what will be written, the write what the drive
    // holds.
    let c = check(&s, "P130", "3.3", false);
    assert!(
        c.starts_with("will write 3.3 s (raw 3300) to RAM only"),
        "{c}"
    );
    let w = write(&s, "P130");
    assert_eq!(w, "written; the drive holds 3.3 s", "{w}");
    s.screenshot("drive-write");

    // Refusals: shown with their reason, the write button stays off, nothing is sent.
    let c = check(&s, "P131", "99999", false);
    assert!(c.starts_with("range: P131"), "{c}");
    let c = check(&s, "P131", "2.5555", false);
    assert!(c.starts_with("resolution:") && c.contains("use "), "{c}");
    s.screenshot("drive-refused");
    let enabled = s.run(
        "return !document.querySelector('tr[data-number=P131]').querySelectorAll('td.edit button')[1].disabled;",
    );
    assert_eq!(enabled, json!(false), "no write after a refused check");
    search(&s, "Drehzahl", "P000");
    let c = check(&s, "P000", "5", false);
    assert!(c.starts_with("access:") && c.contains("read-only"), "{c}");
    // The guard holds for a request that skips the form too.
    let token = "{'Content-Type': 'application/json', 'X-CSRF-Token': csrfToken}";
    let (code, v) = page_post(
        &s,
        "/api/drive/0/0/write",
        token,
        &json!({"key": "8321.0", "value": "5"}),
    );
    assert_eq!(
        (code, v["outcome"].as_str(), v["reason"].as_str()),
        (200, Some("refused"), Some("access")),
        "{v}"
    );
    // Without the CSRF token nothing is even checked.
    let (code, v) = page_post(
        &s,
        "/api/drive/0/0/write",
        "{'Content-Type': 'application/json'}",
        &json!({"key": "8471.0", "value": "4"}),
    );
    assert_eq!((code, v["error"].as_str()), (403, Some("csrf")), "{v}");
    // The EEPROM-wear rule: a second EEPROM write of P132 right after the first is refused.
    search(&s, "Rampe", "P132");
    check(&s, "P132", "4", true);
    assert_eq!(write(&s, "P132"), "written; the drive holds 4 s");
    let c = check(&s, "P132", "5", true);
    assert!(c.starts_with("wear:"), "{c}");

    // The fault memory.
    s.run("document.querySelectorAll('.tools button')[1].click();");
    let rows = s.wait_for(
        30,
        "return document.querySelectorAll('table.faults tr').length;",
        |v| v.as_u64().is_some_and(|n| n >= 6),
    );
    let first = s.run("return document.querySelector('table.faults tr').textContent;");
    assert!(
        first.as_str().unwrap().contains("no fault"),
        "{first} ({rows} rows)"
    );
    s.screenshot("drive-faults");

    // A restore of a changed file: the plan (old → new), then the change on the drive.
    let before = page_backup(&s);
    let mut doc: Value = serde_json::from_str(&before).unwrap();
    for p in doc["parameters"].as_array_mut().unwrap() {
        if p["number"] == "P131" {
            p["raw"] = json!(7000);
        }
    }
    let dir = Scratch::new("ui-drive");
    let changed = dir.0.join("changed.json");
    std::fs::write(&changed, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    upload(&s, "#restore-file", &changed);
    let plan = s.wait_for(
        60,
        "const r = document.querySelectorAll('table.plan tr'); return r.length;",
        |v| v.as_u64().is_some_and(|n| n >= 2),
    );
    assert_eq!(plan, json!(2), "one change besides the head");
    let row = s.run("return document.querySelector('table.plan tr[data-label=P131]').textContent;");
    assert!(
        row.as_str().unwrap().contains("2 s") && row.as_str().unwrap().contains("7 s"),
        "{row}"
    );
    s.screenshot("restore-plan");
    s.run("document.getElementById('restore-apply').click();");
    s.wait_for(
        60,
        "const r = document.querySelector('.report'); return r ? r.dataset.done || null : null;",
        |v| !v.is_null(),
    );
    let report = s.run("return document.querySelector('.report').dataset.done;");
    assert_eq!(report, json!("restored"));
    s.screenshot("restore-done");
    let after = page_backup(&s);
    // Compare the drive with the file saved before the restore: P131 differs, nothing else.
    let saved = dir.0.join("before.json");
    std::fs::write(&saved, &before).unwrap();
    upload(&s, "#compare-file", &saved);
    let rows = s.wait_for(60, "return [...document.querySelectorAll('table.compare tr[data-key]')].map(r => r.dataset.key);", |v| {
        v.as_array().is_some_and(|a| !a.is_empty())
    });
    assert_eq!(rows, json!(["8471.0"]), "only P131 differs");
    s.screenshot("compare");
    // Compare with the other drive, untouched: the ramps the page changed and the address.
    s.run(
        "const c = document.getElementById('compare-with'); c.value = '0/1'; \
         c.dispatchEvent(new Event('change'));",
    );
    let rows = s.wait_for(
        120,
        "return [...document.querySelectorAll('table.compare tr[data-key]')].map(r => r.dataset.key);",
        |v| v.as_array().is_some_and(|a| a.len() > 1),
    );
    assert_eq!(
        rows,
        json!(["8470.0", "8471.0", "8472.0", "8597.0"]),
        "P130, P131, P132 and P810 differ"
    );
    s.screenshot("compare-drives");
    drop(s);

    // The page stops; the simulator is asked directly.
    let _ = Command::new("kill").arg(ui.0.id().to_string()).status();
    let until = Instant::now() + Duration::from_secs(20);
    while ui.0.try_wait().unwrap().is_none() {
        assert!(Instant::now() < until, "drivectl ui stops on SIGTERM");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!((value_of(&sim, "P130") - 3.3).abs() < 1e-9);
    assert!(
        (value_of(&sim, "P131") - 7.0).abs() < 1e-9,
        "the restore's change arrived"
    );
    assert!(
        (value_of(&sim, "P132") - 4.0).abs() < 1e-9,
        "the wear-refused 5 never arrived"
    );
    let file = dir.0.join("direct.json");
    direct(&sim, &["backup", "--out", file.to_str().unwrap()]);
    let written = std::fs::read_to_string(&file).unwrap();
    assert_eq!(
        written.trim_end(),
        after.trim_end(),
        "the page's backup is the file drivectl backup writes"
    );
}

#[test]
fn the_page_refuses_requests_for_drives_it_does_not_have() {
    // No browser needed: the routes answer for themselves.
    let port = free_port();
    let (_gateway, _dir) = web::example_gateway(port);
    let page = SocketAddr::from(([127, 0, 0, 1], port));
    let a = request(page, "GET", "/api/drive/9/0/read?keys=8470.0", None);
    assert_eq!(a.code, 404, "{}", a.body);
    let a = request(page, "GET", "/api/drive/0/0/read?keys=99999.0", None);
    assert_eq!(a.code, 400, "{}", a.body);
    assert!(a.body.contains("no parameter 99999.0"), "{}", a.body);
}

/// `drivectl ui --scan` serves the drives that answer on the line: a MOVILINK and a Bonfiglioli
/// simulator on pseudo-terminals, with drives at addresses the command line does not name.
#[test]
fn drivectl_ui_scan_serves_the_drives_that_answer() {
    for (sim_args, ui_args, want) in [
        (
            vec![
                "sim", "movilink", "--pty", "--parity", "none", "--addr", "2", "--addr", "5",
            ],
            vec!["ui", "movilink", "--parity", "none", "--scan", "--to", "8"],
            vec![2, 5],
        ),
        (
            vec![
                "sim",
                "bonfiglioli",
                "--pty",
                "--parity",
                "none",
                "--addr",
                "4",
            ],
            vec![
                "ui",
                "bonfiglioli",
                "--parity",
                "none",
                "--scan",
                "--to",
                "6",
            ],
            vec![4],
        ),
    ] {
        let sim = PtySim::start(&sim_args);
        let port = free_port();
        let page = SocketAddr::from(([127, 0, 0, 1], port));
        let child = sim
            .command()
            .args(&ui_args)
            .args([
                "--port",
                &sim.path,
                "--listen",
                &page.to_string(),
                "--no-open",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let _ui = Reaped(child);
        let until = Instant::now() + Duration::from_secs(60);
        while std::net::TcpStream::connect(page).is_err() {
            assert!(
                Instant::now() < until,
                "{ui_args:?}: the page did not listen"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        let a = request(page, "GET", "/api/plant", None);
        let plant: Value = serde_json::from_str(&a.body).unwrap();
        let found: Vec<u64> = plant["buses"][0]["drives"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|d| d["address"].as_u64())
            .collect();
        assert_eq!(found, want, "{ui_args:?}");
    }
}

/// `POST path` with the page's CSRF token (from `GET /api/session`), its status and JSON body.
fn post_with_token(page: SocketAddr, path: &str, body: &Value) -> (u16, Value) {
    use std::io::{Read as _, Write as _};
    let session: Value =
        serde_json::from_str(&request(page, "GET", "/api/session", None).body).unwrap();
    let token = session["csrf"].as_str().unwrap().to_owned();
    let body = body.to_string();
    let mut s = std::net::TcpStream::connect(page).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    write!(
        s,
        "POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n\
         Content-Type: application/json\r\nX-CSRF-Token: {token}\r\nContent-Length: {}\r\n\r\n{body}",
        page.port(),
        body.len()
    )
    .unwrap();
    let mut got = String::new();
    s.read_to_string(&mut got).unwrap();
    let (head, rest) = got.split_once("\r\n\r\n").unwrap();
    let code = head.split(' ').nth(1).unwrap().parse().unwrap();
    // A chunked body: its chunks' data are between the size lines.
    let text = if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        let mut out = String::new();
        let mut r = rest;
        while let Some((size, tail)) = r.split_once("\r\n") {
            let n = usize::from_str_radix(size.trim(), 16).unwrap_or(0);
            if n == 0 {
                break;
            }
            out.push_str(&tail[..n]);
            r = &tail[n + 2..];
        }
        out
    } else {
        rest.to_owned()
    };
    (code, serde_json::from_str(&text).unwrap_or(json!(text)))
}

/// `drivectl ui ctt2 --sim` serves NORDAC LINKs on the simulated AS-i link: the plant shows
/// them at their double slaves' numbers, a drive reads its parameters, and a guarded write is
/// read back while one out of range is refused and leaves the value. `ctt2` without `--sim`
/// and a port for it are refused with what to do.
#[test]
fn drivectl_ui_ctt2_sim_serves_the_simulated_as_i_drives() {
    let refused = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["ui", "ctt2", "--no-open"])
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(2));
    let e = String::from_utf8_lossy(&refused.stderr);
    assert!(e.contains("--sim") && e.contains("AS-i"), "{e}");
    let refused = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["ui", "ctt2", "--sim", "--port", "/dev/ttyUSB0", "--no-open"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && e.contains("no real AS-i master"),
        "{e}"
    );

    let port = free_port();
    let page = SocketAddr::from(([127, 0, 0, 1], port));
    let child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["ui", "ctt2", "--sim", "--addr", "1", "--addr", "5"])
        .args(["--listen", &page.to_string(), "--no-open"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _ui = Reaped(child);
    let until = Instant::now() + Duration::from_secs(60);
    while std::net::TcpStream::connect(page).is_err() {
        assert!(Instant::now() < until, "the page did not listen");
        std::thread::sleep(Duration::from_millis(100));
    }
    let plant: Value =
        serde_json::from_str(&request(page, "GET", "/api/plant", None).body).unwrap();
    let found: Vec<u64> = plant["buses"][0]["drives"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|d| d["address"].as_u64())
        .collect();
    assert_eq!(found, vec![1, 5], "{plant}");
    let params: Value =
        serde_json::from_str(&request(page, "GET", "/api/drive/0/1/params", None).body).unwrap();
    assert_eq!(params["family"], "nord", "{params}");
    let key_of = |number: &str| {
        params["params"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["number"] == number)
            .unwrap_or_else(|| panic!("no {number}"))["key"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    let (p102, p105) = (key_of("P102"), key_of("P105"));
    // Reads on the AS-i link: a value line per key, then the end line.
    let read = |key: &str| -> Value {
        let a = request(
            page,
            "GET",
            &format!("/api/drive/0/1/read?keys={key}"),
            None,
        );
        assert_eq!(a.code, 200, "{}", a.body);
        let lines: Vec<Value> = a
            .body
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        let v = lines
            .iter()
            .find(|l| l["type"] == "value" && l["key"] == key)
            .unwrap_or_else(|| panic!("{key}: {}", a.body))
            .clone();
        assert!(
            lines.iter().any(|l| l["type"] == "end" && l["failed"] == 0),
            "{}",
            a.body
        );
        v["payload"].clone()
    };
    let max = read(&p105);
    assert!(max["value"].as_f64().is_some_and(|v| v > 0.0), "{max}");
    let before = read(&p102);
    let (code, v) = post_with_token(
        page,
        "/api/drive/0/1/write",
        &json!({"key": p102, "value": "3.5"}),
    );
    assert_eq!((code, v["outcome"].as_str()), (200, Some("written")), "{v}");
    assert_eq!(read(&p102)["value"].as_f64(), Some(3.5), "before: {before}");
    let (code, v) = post_with_token(
        page,
        "/api/drive/0/1/write",
        &json!({"key": p102, "value": "99999"}),
    );
    // The guard's refusal: the value does not fit the parameter's 16 bits.
    assert_eq!(
        (code, v["outcome"].as_str(), v["reason"].as_str()),
        (200, Some("refused"), Some("width")),
        "{v}"
    );
    assert_eq!(read(&p102)["value"].as_f64(), Some(3.5));
}
