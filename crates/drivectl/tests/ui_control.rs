//! The page's control of a drive over process data in a real browser (headless Chromium
//! through chromedriver): the example plant on simulated drives with its MOVILINK conveyor
//! given to the page (`page_control = true`). The page enables it at a setpoint and its speed
//! (P000, a polled point) follows; leaving the view and ending the browser session each stop
//! it; a POST without the CSRF token and a drive the config does not give the page are
//! refused. Screenshots go to `target/ui-screenshots/`.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "common/web.rs"]
mod web;

use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;
use web::{Reaped, Scratch, Session, browser_tools, free_port, request};

/// The example plant, without broker and metrics, its first drive (the MOVILINK conveyor)
/// driven from the page, served on 127.0.0.1:`port`.
fn gateway(port: u16) -> (Reaped, Scratch) {
    let dir = Scratch::new("ui-control");
    let drivectl = env!("CARGO_BIN_EXE_drivectl");
    let example = Command::new(drivectl)
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    assert!(example.status.success());
    let text = String::from_utf8(example.stdout).unwrap();
    assert!(
        text.contains("out = [0x0002, 0, 0]\n"),
        "the example's conveyor"
    );
    let config = text
        .replacen("broker = \"mqtt://127.0.0.1:1883\"", "broker = \"off\"", 1)
        .replacen("metrics = \"127.0.0.1:9464\"", "metrics = \"off\"", 1)
        .replacen(
            "out = [0x0002, 0, 0]\n",
            "out = [0x0002, 0, 0]\npage_control = true\n",
            1,
        )
        + &format!("\n[ui]\nlisten = \"127.0.0.1:{port}\"\n");
    let path = dir.0.join("plant.toml");
    std::fs::write(&path, config).unwrap();
    let child = Command::new(drivectl)
        .args(["gateway", "--simulate", "--config"])
        .arg(&path)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let gateway = Reaped(child);
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let until = Instant::now() + Duration::from_secs(30);
    while std::net::TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not listen");
        std::thread::sleep(Duration::from_millis(50));
    }
    (gateway, dir)
}

/// The conveyor's latest speed (P000, point 0 of drive 0) in 1/min, and its process input
/// words.
fn conveyor(addr: SocketAddr) -> (Option<f64>, Value) {
    let a = request(addr, "GET", "/api/plant", None);
    assert_eq!(a.code, 200, "{}", a.body);
    let p: Value = serde_json::from_str(&a.body).unwrap();
    let d = &p["buses"][0]["drives"][0];
    (
        d["points"][0]["latest"]["value"].as_f64(),
        d["process_data"]["in"].clone(),
    )
}

/// Wait until the conveyor's speed satisfies `done` (at most `secs` seconds).
fn wait_speed(addr: SocketAddr, secs: u64, what: &str, done: impl Fn(f64) -> bool) -> f64 {
    let until = Instant::now() + Duration::from_secs(secs);
    loop {
        if let (Some(v), _) = conveyor(addr)
            && done(v)
        {
            return v;
        }
        assert!(
            Instant::now() < until,
            "{what}: not within {secs} s (speed {:?})",
            conveyor(addr)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn actions(addr: SocketAddr) -> Vec<Value> {
    let a = request(addr, "GET", "/api/actions", None);
    assert_eq!(a.code, 200, "{}", a.body);
    serde_json::from_str::<Vec<Value>>(&a.body).unwrap()
}

fn lost_stops(addr: SocketAddr) -> usize {
    actions(addr)
        .iter()
        .filter(|a| {
            a["action"]
                .as_str()
                .is_some_and(|s| s.starts_with("page lost: stop drive conveyor"))
                && a["outcome"]
                    .as_str()
                    .is_some_and(|s| s.starts_with("stopped"))
        })
        .count()
}

/// Open the conveyor's view, wait for its control, type `setpoint`, enable.
fn enable(s: &Session, port: u16, setpoint: &str) {
    s.open(&format!("http://127.0.0.1:{port}/#drive/0/0"));
    s.wait_for(
        20,
        "return !!document.getElementById('control-enable')",
        |v| v == &Value::Bool(true),
    );
    s.run(&format!(
        "const i = document.getElementById('control-setpoint'); i.value = '{setpoint}'; \
         document.getElementById('control-enable').click(); return true;"
    ));
}

#[test]
fn the_page_enables_a_page_control_drive_at_a_setpoint_and_leaving_or_closing_it_stops_the_drive() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let port = free_port();
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let (_gateway, _dir) = gateway(port);

    // Without the CSRF token the lease is refused, and nothing moves.
    let a = request(addr, "POST", "/api/drive/0/0/control/lease", None);
    assert_eq!(a.code, 403, "{}", a.body);
    assert!(a.body.contains("\"csrf\""), "{}", a.body);
    let a = request(
        addr,
        "POST",
        "/api/drive/0/0/control",
        Some(&serde_json::json!({"lease": 1, "action": "enable", "setpoint": "300"})),
    );
    assert_eq!(a.code, 403, "{}", a.body);
    wait_speed(addr, 20, "the conveyor stands at the start", |v| v == 0.0);

    let s = Session::start(&chromium, &chromedriver, 1100, 900);
    enable(&s, port, "300");
    let note = s.run("return document.querySelector('#control .control-note').textContent");
    assert!(
        note.as_str().is_some_and(|t| t.contains("stops the drive")),
        "the note before enabling: {note}"
    );
    s.wait_for(
        20,
        "return document.getElementById('control-state').textContent",
        |v| {
            v.as_str()
                .is_some_and(|t| t.contains("enabled at 300.0 1/min"))
        },
    );
    let speed = wait_speed(addr, 30, "the speed follows the setpoint", |v| {
        (v - 300.0).abs() < 0.5
    });
    assert!((speed - 300.0).abs() < 0.5);
    let message = s.run("return document.getElementById('control-message').textContent");
    assert!(
        message
            .as_str()
            .is_some_and(|t| t.contains("enable at 300.0 1/min")),
        "{message}"
    );
    // While it drives, the page asks before it is left (beforeunload is armed).
    assert_eq!(
        s.run("return controlLease !== null && controlLease.driving"),
        Value::Bool(true)
    );
    s.screenshot("control-enabled");

    // A drive the config does not give the page is refused with what the config needs, also
    // with the token.
    let refused = s.run(
        "return fetch('/api/drive/0/1/control/lease', {method: 'POST', headers: {'X-CSRF-Token': csrfToken}})\
         .then(async (r) => [r.status, (await r.json()).message])",
    );
    assert_eq!(refused[0], 403, "{refused}");
    assert!(
        refused[1]
            .as_str()
            .is_some_and(|m| m.contains("page_control = true")),
        "{refused}"
    );
    // A second page (another lease) is refused and told who drives it.
    let second = s.run(
        "return fetch('/api/drive/0/0/control/lease', {method: 'POST', headers: {'X-CSRF-Token': csrfToken}})\
         .then(async (r) => [r.status, (await r.json()).message])",
    );
    assert_eq!(second[0], 409, "{second}");
    assert!(
        second[1]
            .as_str()
            .is_some_and(|m| m.contains("driven from another page by local")),
        "{second}"
    );

    // Leaving the drive's view ends the lease: the drive stops.
    s.run("location.hash = ''; return true;");
    wait_speed(addr, 30, "leaving the view stops the drive", |v| v == 0.0);
    assert_eq!(lost_stops(addr), 1, "{:?}", actions(addr));
    s.screenshot("control-left");

    // Enabled again, then the browser session ends: the drive stops.
    enable(&s, port, "150");
    wait_speed(addr, 30, "enabled again at 150", |v| {
        (v - 150.0).abs() < 0.5
    });
    drop(s);
    let stopped_at = Instant::now();
    wait_speed(addr, 30, "closing the browser stops the drive", |v| {
        v == 0.0
    });
    let (_, inputs) = conveyor(addr);
    // PI1 is status word 1: bit 0 "output stage enabled" clear once stopped on the ramp.
    let until = Instant::now() + Duration::from_secs(10);
    loop {
        let (_, inputs) = conveyor(addr);
        if inputs[0].as_u64().is_some_and(|w| w & 1 == 0) {
            break;
        }
        assert!(Instant::now() < until, "status word {inputs}");
        std::thread::sleep(Duration::from_millis(200));
    }
    assert_eq!(lost_stops(addr), 2, "{:?} (inputs {inputs})", actions(addr));
    eprintln!(
        "the speed was 0 {:.1} s after the session ended",
        stopped_at.elapsed().as_secs_f64()
    );
}
