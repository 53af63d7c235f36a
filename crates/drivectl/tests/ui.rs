//! The browser page of `drivectl gateway` (`[ui]`), in a real browser: a headless Chromium
//! driven through chromedriver (WebDriver) against the example plant on simulated drives,
//! with `broker = "off"`. Screenshots go to `target/ui-screenshots/`.
//!
//! Chromium and chromedriver come from `scripts/setup-browser` (run by `scripts/test` and CI).
//! Where they are missing the tests fail under CI (the `CI` variable set) and skip with one
//! line elsewhere.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "common/web.rs"]
mod web;

use std::io::Read;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use web::{Reaped, Scratch, Session, browser_tools, free_port, request};

/// The example plant on simulated drives, with no broker and the page on `port`; its standard
/// error is kept (the test reads what the gateway logged).
fn gateway(port: u16) -> (Reaped, Scratch) {
    let dir = Scratch::new("ui-plant");
    let example = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    let text = String::from_utf8(example.stdout)
        .unwrap()
        .replacen("broker = \"mqtt://127.0.0.1:1883\"", "broker = \"off\"", 1)
        .replacen("metrics = \"127.0.0.1:9464\"", "metrics = \"off\"", 1);
    let config = dir.0.join("plant.toml");
    std::fs::write(
        &config,
        format!("{text}\n[ui]\nlisten = \"127.0.0.1:{port}\"\n"),
    )
    .unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["gateway", "--simulate", "--config"])
        .arg(&config)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let addr: SocketAddr = ([127, 0, 0, 1], port).into();
    let until = Instant::now() + Duration::from_secs(20);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not come up");
        std::thread::sleep(Duration::from_millis(50));
    }
    (Reaped(child), dir)
}

#[test]
fn the_plant_page_shows_every_drive_live_in_a_real_browser_and_the_gateway_stops_under_it() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let port = free_port();
    let (mut gw, _dir) = gateway(port);
    let page = format!("http://127.0.0.1:{port}/");
    let browser = Session::start(&chromium, &chromedriver, 1280, 1100);
    browser.open(&page);
    // Every drive of the example plant, each with its state, the event stream open.
    let drives = browser.wait_for(
        15,
        "return [...document.querySelectorAll('article.drive')].map(a => a.dataset.drive)",
        |v| v.as_array().is_some_and(|a| a.len() == 10),
    );
    let names: Vec<&str> = drives
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .collect();
    for name in [
        "conveyor",
        "lift",
        "press",
        "feeder",
        "mixer",
        "pump",
        "fan",
        "extractor",
        "dosing",
        "agitator",
    ] {
        assert!(names.contains(&name), "{name} missing: {names:?}");
    }
    browser.wait_for(
        15,
        "return document.getElementById('link').textContent",
        |v| v == "live",
    );
    // Every drive online, every polled value shown with its unit.
    let states = browser.wait_for(
        15,
        "return [...document.querySelectorAll('.state')].map(s => s.textContent)",
        |v| {
            v.as_array()
                .is_some_and(|a| a.iter().all(|s| s.as_str() == Some("online")))
        },
    );
    assert_eq!(states.as_array().map(Vec::len), Some(10));
    let conveyor_speed = "return (() => { const r = document.querySelector(\
        'article[data-drive=conveyor] tr[data-point=speed] td.value div'); \
        return [r.textContent, r.title]; })()";
    let first = browser.wait_for(15, conveyor_speed, |v| v[0] != "–");
    assert!(
        first[0].as_str().unwrap().ends_with(" 1/min"),
        "speed without its unit: {first}"
    );
    assert!(first[1].as_str().unwrap().starts_with("raw "), "{first}");
    // Live: the next read of the same value arrives without a reload (its read time moves).
    let next = browser.wait_for(15, conveyor_speed, |v| v[1] != first[1]);
    assert_ne!(next[1], first[1]);
    // The bus figures arrive too.
    browser.wait_for(
        15,
        "return document.querySelector('section.bus .figures').textContent",
        |v| v.as_str().is_some_and(|t| t.starts_with("utilisation ")),
    );
    let shot = browser.screenshot("plant");
    assert!(std::fs::metadata(&shot).unwrap().len() > 10_000, "{shot:?}");

    // The trend: two points picked, drawn as the bus reads them, and the CSV holds what was
    // drawn, the value shown last among it.
    browser.run(
        "for (const p of ['speed', 'current']) document.querySelector(\
         `article[data-drive=conveyor] tr[data-point=${p}] td.pick input`).click(); return 0",
    );
    let counts = "return [...document.querySelectorAll('#trend-plot polyline')].map(l => \
        l.getAttribute('points').trim().split(' ').filter(Boolean).length)";
    browser.wait_for(15, counts, |v| {
        v.as_array()
            .is_some_and(|a| a.len() == 2 && a.iter().all(|n| n.as_u64() >= Some(3)))
    });
    browser.run("document.getElementById('trend-pause').click(); return 0");
    let drawn = browser.run(counts);
    let csv = browser.run("return trendCsv()");
    let csv = csv.as_str().unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("time,point,value,unit,raw"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let speed: Vec<&Vec<&str>> = rows
        .iter()
        .filter(|r| r[1] == "\"conveyor speed\"")
        .collect();
    let current = rows
        .iter()
        .filter(|r| r[1] == "\"conveyor current\"")
        .count();
    assert_eq!(
        json!([speed.len(), current]),
        drawn,
        "the CSV and the plot differ: {csv}"
    );
    for r in &rows {
        assert!(
            r[2].parse::<f64>().is_ok() && r[4].parse::<i64>().is_ok(),
            "{r:?}"
        );
    }
    assert_eq!(speed.last().unwrap()[3], "\"1/min\"");
    let shown = browser.run(
        "return document.querySelector('article[data-drive=conveyor] tr[data-point=speed] td.value div').textContent",
    );
    let last = speed.last().unwrap()[2].parse::<f64>().unwrap();
    assert_eq!(shown, format!("{last} 1/min"), "{csv}");
    // From a value's read on the bus (its `ts`) to the page: the target is 50 ms beyond
    // the wire time; a debug build on a loaded machine gets a wider bound here, and the
    // figures are printed.
    let l = browser.wait_for(15, "return latency()", |v| v["count"].as_u64() >= Some(20));
    eprintln!("bus read → page: {l}");
    assert!(
        l["median"]
            .as_f64()
            .is_some_and(|m| (0.0..50.0).contains(&m)),
        "{l}"
    );
    assert!(l["p99"].as_f64().is_some_and(|p| p < 250.0), "{l}");
    let shot = browser.screenshot("trend");
    assert!(std::fs::metadata(&shot).unwrap().len() > 10_000, "{shot:?}");

    // The drive's parameter table, searched in German and in English.
    browser.run("document.querySelector('article[data-drive=conveyor] h3 a').click(); return 0");
    let search = |term: &str| {
        browser.run(&format!(
            "const i = document.getElementById('search'); i.value = {}; \
             i.dispatchEvent(new Event('input')); return 0",
            json!(term)
        ));
        // The list shown is the answer to this search (the count names the term).
        let shown = format!("matching “{term}”");
        browser.wait_for(
            15,
            "return document.querySelector('#drive .figures').textContent",
            |v| v.as_str().is_some_and(|t| t.ends_with(&shown)),
        );
        browser.run(
            "return [...document.querySelectorAll('table.params tr[data-number]')].map(r => r.dataset.number)",
        )
    };
    browser.wait_for(
        15,
        "return document.getElementById('search') !== null",
        |v| v == true,
    );
    for term in ["Rampe", "ramp"] {
        let rows = search(term);
        let rows = rows.as_array().unwrap();
        assert!(rows.iter().any(|n| n == "P130"), "{term}: {rows:?}");
        assert!(rows.len() < 100, "{term}: not narrowed: {}", rows.len());
    }
    let shot = browser.screenshot("drive-search");
    assert!(std::fs::metadata(&shot).unwrap().len() > 10_000, "{shot:?}");
    browser.run("location.hash = ''; return 0");
    browser.wait_for(15, "return document.getElementById('plant').hidden", |v| {
        v == false
    });

    // A stop signal with the page still connected: the gateway ends promptly and cleanly.
    let pid = gw.0.id();
    let killed = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let until = Instant::now() + Duration::from_secs(15);
    let status = loop {
        if let Some(s) = gw.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            Instant::now() < until,
            "the gateway did not stop with a page connected"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    if let Some(mut e) = gw.0.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    assert!(status.success(), "{status:?}: {err}");
    assert!(err.contains("the page is served"), "{err}");
    // The page says the link is gone.
    browser.wait_for(
        15,
        "return document.getElementById('link').textContent",
        |v| v.as_str().is_some_and(|t| t.starts_with("connection lost")),
    );
}

#[test]
fn drivectl_ui_serves_one_bus_from_the_command_line_and_stops_on_ctrl_c() {
    use std::io::BufRead;
    let drivectl = env!("CARGO_BIN_EXE_drivectl");
    // Refused before anything opens: no port, a listener for other hosts.
    let o = Command::new(drivectl).args(["ui", "uss"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("needs --port"));
    let o = Command::new(drivectl)
        .args(["ui", "uss", "--simulate", "--listen", "0.0.0.0:8080"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("loopback address only"));
    // A port in use is named by the option the user gave.
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let at = taken.local_addr().unwrap().to_string();
    let o = Command::new(drivectl)
        .args(["ui", "uss", "--simulate", "--no-open", "--listen", &at])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains(&format!("--listen {at}: cannot listen")), "{e}");

    let mut child = Command::new(drivectl)
        .args([
            "ui",
            "uss",
            "--simulate",
            "--addr",
            "1",
            "--addr",
            "2",
            "--no-open",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let mut gw = Reaped(child);
    let url = line.trim();
    let addr: SocketAddr = url
        .strip_prefix("http://")
        .and_then(|r| r.strip_suffix('/'))
        .unwrap_or_else(|| panic!("not the page's address: {line:?}"))
        .parse()
        .unwrap();
    assert!(addr.ip().is_loopback() && addr.port() != 0, "{addr}");
    let until = Instant::now() + Duration::from_secs(20);
    let plant: Value = loop {
        if TcpStream::connect(addr).is_ok() {
            let a = request(addr, "GET", "/api/plant", None);
            assert_eq!(a.code, 200, "{}", a.body);
            let v: Value = serde_json::from_str(&a.body).unwrap();
            let read = v["buses"][0]["drives"][1]["points"][0]["latest"].is_object();
            if read {
                break v;
            }
        }
        assert!(Instant::now() < until, "the page did not show a value");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(plant["buses"][0]["protocol"], "uss");
    assert_eq!(plant["buses"][0]["name"], "simulated");
    let drive = &plant["buses"][0]["drives"][1];
    assert_eq!(drive["address"], 2);
    assert_eq!(drive["points"][0]["label"], "P700 [-01]");
    assert_eq!(drive["points"][0]["latest"]["text"], "no fault");
    // Ctrl-C: the gateway stops cleanly.
    let sent = Command::new("kill")
        .args(["-INT", &gw.0.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let until = Instant::now() + Duration::from_secs(15);
    let status = loop {
        if let Some(s) = gw.0.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < until, "drivectl ui did not stop on Ctrl-C");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "{status:?}");
}

/// Ten tabs of the page in one browser all follow the plant live: the browser's tabs share one
/// event stream (a browser opens at most six HTTP/1.1 connections to a host; with a stream per
/// tab the seventh tab never loaded).
#[test]
fn ten_tabs_of_the_page_in_one_browser_all_follow_live() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let port = free_port();
    let (_gw, _dir) = web::example_gateway(port);
    let page = format!("http://127.0.0.1:{port}/");
    let browser = Session::start(&chromium, &chromedriver, 1000, 800);
    browser.open(&page);
    let mut tabs = vec![browser.command("GET", "window", None)];
    for _ in 1..10 {
        let t = browser.command("POST", "window/new", Some(&json!({"type": "tab"})));
        let handle = t["handle"].clone();
        browser.command("POST", "window", Some(&json!({"handle": handle})));
        browser.open(&page);
        tabs.push(handle);
    }
    for (i, handle) in tabs.iter().enumerate() {
        browser.command("POST", "window", Some(&json!({"handle": handle})));
        let l = browser.wait_for(30, "return latency().count;", |v| {
            v.as_u64().is_some_and(|n| n >= 3)
        });
        let link = browser.run("return document.getElementById('link').textContent;");
        assert_eq!(link, json!("live"), "tab {i}: {l} values");
    }
}
