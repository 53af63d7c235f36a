//! Issue 22, item 2: the browser page across a reload of the gateway's config, in a real
//! browser (headless Chromium through chromedriver, `scripts/setup-browser`): the plant is drawn
//! again with the new numbers, the trend keeps its point under its new number, and a drive view
//! opened before the reload still reaches its drive by its old numbers (the page sends the
//! generation it read them from).

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "common/web.rs"]
mod web;

use std::net::{SocketAddr, TcpStream};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use web::{Reaped, Scratch, Session, browser_tools, free_port};

const A: &str = "[[bus]]\nname = \"a\"\nprotocol = \"movilink\"\nsimulate = true\n\
                 [[bus.drive]]\nname = \"a1\"\naddress = 1\n\
                 [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\n";
const B: &str = "[[bus]]\nname = \"b\"\nprotocol = \"modbus-rtu\"\nsimulate = true\n\
                 [[bus.drive]]\nname = \"b1\"\naddress = 1\n\
                 [[bus.drive.param]]\nparam = \"241\"\nname = \"frequency\"\nperiod = \"200ms\"\n";
const C: &str = "[[bus]]\nname = \"c\"\nprotocol = \"sbus\"\nsimulate = true\n\
                 [[bus.drive]]\nname = \"c1\"\naddress = 3\n\
                 [[bus.drive.param]]\nparam = \"P000\"\nname = \"speed\"\nperiod = \"200ms\"\n";

fn config(port: u16, buses: &[&str]) -> String {
    format!(
        "[gateway]\nname = \"gw\"\nbroker = \"off\"\nmetrics = \"off\"\n\
         [ui]\nlisten = \"127.0.0.1:{port}\"\n{}",
        buses.concat()
    )
}

#[test]
fn issue22_the_page_follows_a_reload_and_old_numbers_reach_their_drive() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let port = free_port();
    let dir = Scratch::new("ui-reload");
    let file = dir.0.join("plant.toml");
    std::fs::write(&file, config(port, &[A, B])).unwrap();
    let gw = Reaped(
        Command::new(env!("CARGO_BIN_EXE_drivectl"))
            .args(["gateway", "--config"])
            .arg(&file)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let addr: SocketAddr = ([127, 0, 0, 1], port).into();
    let until = Instant::now() + Duration::from_secs(20);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not come up");
        std::thread::sleep(Duration::from_millis(50));
    }
    let browser = Session::start(&chromium, &chromedriver, 1280, 900);
    browser.open(&format!("http://127.0.0.1:{port}/"));
    let drives = "return [...document.querySelectorAll('article.drive')].map(a => a.dataset.drive)";
    browser.wait_for(15, drives, |v| v == &serde_json::json!(["a1", "b1"]));
    // b1's frequency in the trend: its key is bus 1, drive 0, point 0.
    browser.wait_for(
        10,
        "return document.querySelector('input[data-key=\"1.0.0\"]') !== null",
        |v| v == true,
    );
    browser.run("document.querySelector('input[data-key=\"1.0.0\"]').click(); return true");
    browser.wait_for(10, "return [...trend.keys()]", |v| {
        v == &serde_json::json!(["1.0.0"])
    });
    // The drive view of b1, opened on the plant of generation 1.
    browser.run("location.hash = '#drive/1/0'; return true");
    browser.wait_for(15, "return document.querySelector('#drive h2') && document.querySelector('#drive h2').textContent", |v| {
        v.as_str().is_some_and(|t| t.contains("b1"))
    });

    // The reload: a goes, c comes after b, so b1 moves from bus 1 to bus 0.
    std::fs::write(&file, config(port, &[B, C])).unwrap();
    let ok = Command::new("kill")
        .args(["-HUP", &gw.0.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok);
    // The drive view says so, and still reaches b1 by its old numbers.
    browser.wait_for(15, "return document.getElementById('reloaded') && document.getElementById('reloaded').textContent", |v| {
        v.as_str().is_some_and(|t| t.contains("generation 2"))
    });
    let bus = browser.run(
        "return fetch('/api/drive/1/0/params').then(r => r.json()).then(j => j.drive + ' on ' + j.bus)",
    );
    assert_eq!(bus, "b1 on b", "the old numbers reach the drive they meant");
    // A drive view of a removed bus (a1, bus 0 of generation 1) is refused, never another.
    let gone = browser.run(
        "driveGeneration = 1; return fetch('/api/drive/0/0/params').then(r => r.status + ' ' + r.statusText)",
    );
    assert!(gone.as_str().unwrap().starts_with("409"), "{gone}");
    browser.run("driveGeneration = plantGeneration; return true");
    // The plant view: drawn again with the new buses, the trend's point under its new number,
    // its box checked, values still arriving.
    browser.run("location.hash = ''; return true");
    browser.wait_for(15, drives, |v| v == &serde_json::json!(["b1", "c1"]));
    let keys = browser.wait_for(10, "return [...trend.keys()]", |v| {
        v == &serde_json::json!(["0.0.0"])
    });
    assert_eq!(keys, serde_json::json!(["0.0.0"]));
    assert_eq!(
        browser.run("return document.querySelector('input[data-key=\"0.0.0\"]').checked"),
        true
    );
    assert_eq!(browser.run("return plantGeneration"), 2);
    let shown =
        "return document.querySelector('article.drive[data-drive=\"c1\"] td.value div').title";
    browser.wait_for(15, shown, |v| {
        v.as_str().is_some_and(|t| t.starts_with("raw "))
    });
    let samples = "return trend.get('0.0.0').samples.length";
    let before = browser.run(samples).as_u64().unwrap();
    browser.wait_for(10, samples, |v| v.as_u64().is_some_and(|n| n > before));
    browser.screenshot("ui-after-reload");
    drop(gw);
}
