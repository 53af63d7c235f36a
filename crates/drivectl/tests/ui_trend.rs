//! The page's trend in a real browser (headless Chromium through chromedriver) against the
//! example plant on simulated drives: the history the gateway kept, the join with the live
//! values, the CSV, the PNG picture, zoom by the buttons and by a finger's drag, and the
//! rates. Screenshots and the exported PNG go to `target/ui-screenshots/`.

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
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde_json::Value;
use web::{Session, browser_tools, example_gateway, free_port, iso_time, request, save_artifact};

fn now_ms() -> u64 {
    u64::try_from(
        SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap()
            .as_millis(),
    )
    .unwrap()
}

fn history(addr: SocketAddr, path: &str) -> Value {
    let a = request(addr, "GET", path, None);
    assert_eq!(a.code, 200, "{path}: {}", a.body);
    serde_json::from_str(&a.body).unwrap()
}

/// `[(ts, value, raw)]` of a history answer.
fn samples(h: &Value) -> Vec<(u64, f64, i64)> {
    h["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["ts"].as_u64().unwrap(),
                s["value"].as_f64().unwrap(),
                s["raw"].as_i64().unwrap(),
            )
        })
        .collect()
}

/// The CSV's rows of one point: (time, value, unit, raw).
fn csv_rows(csv: &str, point: &str) -> Vec<(String, f64, String, i64)> {
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("time,point,value,unit,raw"));
    let quoted = format!("\"{point}\"");
    lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|r| r[1] == quoted)
        .map(|r| {
            (
                r[0].to_owned(),
                r[2].parse().unwrap(),
                r[3].trim_matches('"').to_owned(),
                r[4].parse().unwrap(),
            )
        })
        .collect()
}

const SPEED: &str = "/api/history/1/0/0";
const VIEW: &str = "return trendView()";
const COUNTS: &str = "return [...document.querySelectorAll('#trend-plot polyline')].map(l => \
    l.getAttribute('points').trim().split(' ').filter(Boolean).length)";

#[test]
fn a_page_opened_late_shows_the_gateways_history_then_follows_zooms_and_exports() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let port = free_port();
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let (_gateway, _dir) = example_gateway(port);
    let browser = Session::start(&chromium, &chromedriver, 1280, 1000);

    // The gateway runs for over a minute before the page opens (the 1-minute zoom then has
    // something to cut).
    let until = Instant::now() + Duration::from_secs(120);
    loop {
        let s = samples(&history(addr, SPEED));
        if let (Some(first), Some(last)) = (s.first(), s.last())
            && last.0 - first.0 > 65_000
        {
            break;
        }
        assert!(Instant::now() < until, "the gateway kept no minute: {s:?}");
        std::thread::sleep(Duration::from_millis(500));
    }
    let opened = now_ms();
    browser.open(&format!("http://127.0.0.1:{port}/"));
    browser.wait_for(
        20,
        "return document.getElementById('link').textContent",
        |v| v == "live",
    );
    browser.run(
        "for (const p of ['speed', 'current']) document.querySelector(\
         `article[data-drive=press] tr[data-point=${p}] td.pick input`).click(); return 0",
    );
    let picked = now_ms();

    // At once: what the gateway kept from before the page opened.
    let loaded = browser.wait_for(5, "return [...trend.values()].map(t => [t.loading, t.samples.length, t.samples.length ? t.samples[0].ts : null])", |v| {
        v.as_array().is_some_and(|a| a.len() == 2 && a.iter().all(|t| t[0] == false))
    });
    for t in loaded.as_array().unwrap() {
        assert!(t[1].as_u64() > Some(100), "{loaded}");
        assert!(t[2].as_u64() < Some(opened - 60_000), "{loaded}");
    }
    browser.screenshot("trend-history");

    // Then the live values: a few read after the point was added.
    browser.wait_for(15, "return trend.get('1.0.0').samples.at(-1).ts", |v| {
        v.as_u64() > Some(picked + 1500)
    });
    let view = browser.run(VIEW);
    assert_eq!(view["window"], 600_000);
    let full = view["end"].as_u64().unwrap() - view["start"].as_u64().unwrap();
    assert!(full > 65_000, "{view}");

    // The rates: what the point gets and what the wire allows (its 500 ms period, the SBus
    // bus's demand far below 1).
    let legend = browser
        .run("return document.querySelector('#trend-legend li[data-key=\"1.0.0\"]').textContent");
    let legend = legend.as_str().unwrap();
    assert!(
        legend.contains("the wire allows 2.00/s (every 500 ms)"),
        "{legend}"
    );
    let got: f64 = legend
        .split("gets ")
        .nth(1)
        .and_then(|r| r.split("/s").next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no rate: {legend}"));
    assert!((1.6..2.4).contains(&got), "{legend}");
    // A bus whose polls ask more than its wire carries: every period is stretched by the
    // demand, and the legend says so (the figures set and read in one script, before the bus's
    // next figures arrive).
    let stretched = browser.run(
        "trendFigures(1, {demand: 1.5}); drawTrend(); \
         return document.querySelector('#trend-legend li[data-key=\"1.0.0\"]').textContent",
    );
    assert!(
        stretched.as_str().unwrap().contains(
            "the wire allows 1.33/s (every 500 ms × 1.50 = 750 ms: the bus's polls ask 150 % of the wire)"
        ),
        "{stretched}"
    );

    // Paused: the CSV holds what the gateway answered, up to the last live sample shown.
    browser.run("document.getElementById('trend-pause').click(); return 0");
    let view = browser.run(VIEW);
    let csv = browser.run("return trendCsv()");
    let csv = csv.as_str().unwrap();
    let drawn = browser.run(COUNTS);
    let (start, end) = (
        view["start"].as_u64().unwrap(),
        view["end"].as_u64().unwrap(),
    );
    let h = history(addr, SPEED);
    let want: Vec<(String, f64, String, i64)> = samples(&h)
        .into_iter()
        .filter(|s| s.0 >= start && s.0 <= end)
        .map(|(ts, v, raw)| (iso_time(ts), v, "1/min".to_owned(), raw))
        .collect();
    let rows = csv_rows(csv, "press speed");
    assert_eq!(rows, want, "the CSV differs from the gateway's history");
    // It has samples from before the page opened and live ones after the point was added.
    assert!(
        rows.first().unwrap().0 < iso_time(opened - 60_000),
        "{rows:?}"
    );
    assert!(rows.last().unwrap().0 > iso_time(picked + 1000), "{rows:?}");
    let current = csv_rows(csv, "press current");
    assert_eq!(drawn, serde_json::json!([rows.len(), current.len()]));

    // The picture as a PNG: its signature, its header's size (twice the 1000-pixel SVG) and
    // a body worth a plot.
    let data = browser.run(
        "return trendPng().then(b => new Promise(ok => { const r = new FileReader(); \
         r.onload = () => ok(r.result); r.readAsDataURL(b); }))",
    );
    let data = data.as_str().unwrap();
    let png = web::from_base64(data.strip_prefix("data:image/png;base64,").unwrap());
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert_eq!(&png[12..16], b"IHDR");
    let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert_eq!(width, 2000);
    assert_eq!(height, 2 * (262 + 18 * 2));
    assert!(png.len() > 20_000, "{} bytes", png.len());
    save_artifact("trend-export.png", &png);
    let svg = browser.run("return trendSvg()");
    assert_eq!(svg.as_str().unwrap().matches("<polyline").count(), 2);
    browser.run("document.getElementById('trend-pause').click(); return 0");

    // Zoom by the buttons: the last minute of the one-minute-plus the page holds.
    browser
        .run("document.querySelector('#trend-zoom button[data-minutes=\"1\"]').click(); return 0");
    let view = browser.run(VIEW);
    assert_eq!(view["window"], 60_000);
    assert_eq!(
        view["end"].as_u64().unwrap() - view["start"].as_u64().unwrap(),
        60_000,
        "{view}"
    );
    let one_minute = csv_rows(
        browser.run("return trendCsv()").as_str().unwrap(),
        "press speed",
    );
    assert!(
        (100..=125).contains(&one_minute.len()),
        "{}",
        one_minute.len()
    );
    browser.screenshot("trend-1-minute");

    // Zoom by a finger drawn across the middle half of the plot (a tablet's touch).
    let r = browser.run(
        "const r = document.getElementById('trend-plot').getBoundingClientRect(); \
         return [r.left, r.width, r.top, r.height]",
    );
    let (left, width, top, height) = (
        r[0].as_f64().unwrap(),
        r[1].as_f64().unwrap(),
        r[2].as_f64().unwrap(),
        r[3].as_f64().unwrap(),
    );
    let before = browser.run(VIEW);
    browser.swipe(
        (left + width * 0.25) as i64,
        (left + width * 0.75) as i64,
        (top + height / 2.0) as i64,
    );
    let view = browser.wait_for(5, VIEW, |v| v["picked"] == true);
    let span = view["end"].as_u64().unwrap() - view["start"].as_u64().unwrap();
    assert!((27_000..33_000).contains(&span), "{view} after {before}");
    let b0 = before["start"].as_u64().unwrap();
    assert!(
        view["start"].as_u64().unwrap() >= b0 + 13_000,
        "{view} after {before}"
    );
    let rows = csv_rows(
        browser.run("return trendCsv()").as_str().unwrap(),
        "press speed",
    );
    assert!(
        rows.len() < one_minute.len() * 2 / 3 && rows.len() > 40,
        "{} rows",
        rows.len()
    );
    let (lo, hi) = (
        iso_time(view["start"].as_u64().unwrap()),
        iso_time(view["end"].as_u64().unwrap()),
    );
    assert!(rows.iter().all(|r| r.0 >= lo && r.0 <= hi), "{rows:?}");
    browser.screenshot("trend-picked");
    // The 10-minute button follows the live values again, from the oldest sample kept.
    browser
        .run("document.querySelector('#trend-zoom button[data-minutes=\"10\"]').click(); return 0");
    let view = browser.run(VIEW);
    assert_eq!(
        (view["picked"].clone(), view["window"].clone()),
        (Value::Bool(false), 600_000.into())
    );
    assert!(
        view["end"].as_u64().unwrap() - view["start"].as_u64().unwrap() > full,
        "{view}"
    );
}
