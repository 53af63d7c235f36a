//! The trend's memory: rings, the window, the cap, the times and the answer.

use std::sync::Arc;
use std::time::{Duration, SystemTime};

use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use super::*;
use crate::model::Update;
use crate::ui::Hub;

/// A plant of `buses` simulated MOVILINK buses of `drives` drives, each with the points
/// `periods` gives (`None`: read after writes only).
fn plant(buses: usize, drives: usize, periods: &[Option<&str>]) -> Plant {
    let mut t = String::from("[gateway]\nname = \"gw\"\nbroker = \"off\"\n");
    t += "[ui]\nlisten = \"127.0.0.1:0\"\n";
    for b in 0..buses {
        t += &format!("[[bus]]\nname = \"line{b}\"\nprotocol = \"movilink\"\nsimulate = true\n");
        for d in 0..drives {
            t += &format!("[[bus.drive]]\nname = \"d{d}\"\naddress = {}\n", d + 1);
            for (i, p) in periods.iter().enumerate() {
                let param = match p {
                    Some(_) => ["P000", "P004", "P130", "P131"][i % 4],
                    None => "P130",
                };
                t += &format!("[[bus.drive.param]]\nparam = \"{param}\"\nname = \"p{i}\"\n");
                match p {
                    Some(p) => t += &format!("period = \"{p}\"\n"),
                    None => t += "writable = true\n",
                }
            }
        }
    }
    Plant::parse(&t, "test").unwrap()
}

const T0: u64 = 1_700_000_000_000;

#[test]
fn a_sample_is_12_bytes_and_keeps_its_raw_value_whole() {
    assert_eq!(SAMPLE_BYTES, 12);
    assert_eq!(bound(), 48 * 1024 * 1024);
    for raw in [
        0,
        1,
        -1,
        0xFFFF_FFFF,
        -0x8000_0000,
        i64::MIN,
        i64::MAX,
        1 << 40,
    ] {
        assert_eq!(Sample::new(T0, raw).raw(), raw, "{raw}");
    }
}

#[test]
fn rings_are_sized_from_the_period_and_read_after_writes_gets_a_few() {
    let p = plant(1, 1, &[Some("500ms"), Some("1s"), Some("7s"), None]);
    let h = History::new(&p);
    // 600 s / period + 1, and a sixteenth more.
    assert_eq!(h.size(0, 0, 0), Some(1201 + 75));
    assert_eq!(h.size(0, 0, 1), Some(601 + 37));
    assert_eq!(h.size(0, 0, 2), Some(86 + 5));
    assert_eq!(h.size(0, 0, 3), Some(UNPOLLED));
    assert_eq!(h.size(0, 0, 4), None);
    assert_eq!(h.size(1, 0, 0), None);
    // Nothing is allocated before samples arrive.
    assert_eq!((h.len(), h.bytes()), (0, 0));
}

#[test]
fn a_full_ring_wraps_keeping_the_newest_in_order() {
    let p = plant(1, 1, &[Some("1s")]);
    let mut h = History::with_cap(&p, 5);
    assert_eq!(h.size(0, 0, 0), Some(5));
    for i in 0..8u64 {
        h.push(0, 0, 0, T0 + i * 1000, i as i64 * 10);
    }
    let got = h.samples(0, 0, 0, T0 + 8000).unwrap();
    let want: Vec<(u64, i64)> = (3..8u64).map(|i| (T0 + i * 1000, i as i64 * 10)).collect();
    assert_eq!(got, want);
    assert_eq!(h.len(), 5);
    // The buffer never grows past the ring's size.
    assert!(h.bytes() <= 16 * SAMPLE_BYTES, "{}", h.bytes());
    // A point the plant does not have is ignored.
    h.push(0, 0, 9, T0, 1);
    h.push(3, 0, 0, T0, 1);
    assert!(h.samples(0, 1, 0, T0).is_none());
    assert_eq!(h.len(), 5);
}

#[test]
fn only_the_last_10_minutes_are_kept_and_answered() {
    let p = plant(1, 1, &[Some("1s")]);
    let mut h = History::new(&p);
    // Every 100 s for 20 minutes: at most 601 s back from the newest stay.
    for i in 0..=12u64 {
        h.push(0, 0, 0, T0 + i * 100_000, i as i64);
    }
    let now = T0 + 1_200_000;
    let got = h.samples(0, 0, 0, now).unwrap();
    assert_eq!(got.first(), Some(&(T0 + 600_000, 6)));
    assert_eq!(got.last(), Some(&(T0 + 1_200_000, 12)));
    assert_eq!(h.len(), 7);
    // A point that stopped being read: what it kept ages out of the answer too.
    let later = now + 450_000;
    let got = h.samples(0, 0, 0, later).unwrap();
    assert_eq!(got.first().map(|s| s.0), Some(T0 + 1_100_000));
    assert!(h.samples(0, 0, 0, now + 601_000).unwrap().is_empty());
}

#[test]
fn times_are_whole_milliseconds_across_the_low_bits_wrap_and_a_clock_set_back_clears() {
    let p = plant(1, 1, &[Some("100ms")]);
    let mut h = History::new(&p);
    // Straddle a multiple of 2^32 ms: the low 32 bits wrap inside the ring.
    let wrap = (T0 >> 32 << 32) + (1 << 32);
    let times: Vec<u64> = (0..50u64).map(|i| wrap - 2_500 + i * 100).collect();
    for (i, t) in times.iter().enumerate() {
        h.push(0, 0, 0, *t, -(i as i64));
    }
    let got = h.samples(0, 0, 0, wrap + 3_000).unwrap();
    let want: Vec<(u64, i64)> = times
        .iter()
        .enumerate()
        .map(|(i, t)| (*t, -(i as i64)))
        .collect();
    assert_eq!(got, want);
    // Set back by a minute: what was kept is not older than the new sample any more.
    h.push(0, 0, 0, wrap - 60_000, 7);
    assert_eq!(h.samples(0, 0, 0, wrap).unwrap(), vec![(wrap - 60_000, 7)]);
}

#[test]
#[allow(clippy::print_stdout)] // the figures docs/ui.md quotes, for `--nocapture`
fn a_plant_of_64_buses_of_31_drives_stays_under_the_cap() {
    // 64 × 31 drives × 4 points at 500 ms would ask for 10 million samples.
    let p = plant(
        64,
        31,
        &[Some("500ms"), Some("500ms"), Some("1s"), Some("1s")],
    );
    let mut h = History::new(&p);
    let total = h.total_size();
    assert!(total <= MAX_SAMPLES, "{total}");
    assert!(total > MAX_SAMPLES - 4 * 64 * 31, "{total}");
    // The same share each: the 500 ms points keep about 2 minutes, the 1 s points as long.
    let fast = h.size(0, 0, 0).unwrap();
    let slow = h.size(0, 0, 2).unwrap();
    assert!(
        (fast as f64 / slow as f64 - 2.0).abs() < 0.01,
        "{fast} {slow}"
    );
    assert!(fast < 1201, "{fast}");
    // Fill every ring for more than 10 minutes of polls: the memory stays at the bound.
    let start = std::time::Instant::now();
    for i in 0..1300u64 {
        for b in 0..64 {
            for d in 0..31 {
                for pt in 0..4 {
                    if pt < 2 || i % 2 == 0 {
                        h.push(b, d, pt, T0 + i * 500, i as i64);
                    }
                }
            }
        }
    }
    let took = start.elapsed();
    let (len, bytes) = (h.len(), h.bytes());
    assert_eq!(len, total, "every ring full");
    assert!(bytes <= bound(), "{bytes}");
    println!(
        "64 x 31 drives x 4 points: {total} samples at most, {len} kept, {} MiB of samples \
         ({} bytes each), filled in {took:?}",
        bytes / (1024 * 1024),
        SAMPLE_BYTES
    );
    // A small plant is not shrunk.
    let p = plant(2, 31, &[Some("500ms"), Some("1s")]);
    assert_eq!(History::new(&p).size(1, 30, 0), Some(1201 + 75));
}

fn value(point: usize, raw: i64, ms: u64) -> Update {
    Update::Value {
        bus: 0,
        drive: 0,
        point,
        raw,
        at: SystemTime::UNIX_EPOCH + Duration::from_millis(ms),
    }
}

#[test]
fn the_answer_has_each_sample_as_a_live_event_carries_it() {
    let hub = Hub::new(Arc::new(plant(1, 1, &[Some("500ms"), None])));
    // P000 (speed) in 0.001 1/min: raw 1500000 is 1500 1/min.
    hub.apply(&value(0, 1_500_000, T0));
    hub.apply(&value(0, -250_000, T0 + 500));
    let v = hub.history_json((0, 0, 0), T0 + 1000).unwrap();
    assert_eq!(v["name"], "p0");
    assert_eq!(v["period_ms"], 500);
    assert_eq!(v["window_ms"], 600_000);
    assert_eq!(v["capacity"], 1276);
    assert_eq!(v["now"], T0 + 1000);
    let samples = v["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 2);
    // Exactly the live payload of the same read.
    let latest = hub.plant_json()["buses"][0]["drives"][0]["points"][0]["latest"].clone();
    assert_eq!(samples[1], latest);
    assert_eq!(samples[0]["raw"], 1_500_000);
    assert_eq!(samples[0]["ts"], T0);
    assert_eq!(samples[0]["unit"], "1/min");
    assert_eq!(samples[0]["value"], json!(1500.0));
    assert_eq!(samples[1]["value"], json!(-250.0));
    // The point read only after writes has none yet; a point the plant lacks has no answer.
    let none = hub.history_json((0, 0, 1), T0).unwrap();
    assert_eq!(
        (none["samples"].clone(), none["period_ms"].clone()),
        (json!([]), Value::Null)
    );
    assert!(hub.history_json((0, 0, 2), T0).is_none());
    assert!(hub.history_json((0, 1, 0), T0).is_none());
}

/// `GET path` on a fresh connection: the status code and the body.
async fn get(addr: std::net::SocketAddr, path: &str) -> (u16, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(
        format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n").as_bytes(),
    )
    .await
    .unwrap();
    let mut got = Vec::new();
    tokio::time::timeout(Duration::from_secs(10), s.read_to_end(&mut got))
        .await
        .unwrap()
        .unwrap();
    let text = String::from_utf8(got).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    (head[9..12].parse().unwrap(), body.to_owned())
}

#[tokio::test]
async fn the_route_answers_a_points_history_and_404_for_one_the_plant_lacks() {
    let hub = Hub::new(Arc::new(plant(1, 2, &[Some("1s")])));
    let now = crate::mqtt::payload::millis(SystemTime::now());
    for i in 0..3u64 {
        hub.apply(&value(0, 1000 * i as i64, now - 3000 + i * 1000));
    }
    let listener = crate::ui::bind("127.0.0.1:0".parse().unwrap())
        .await
        .unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(crate::ui::serve(
        listener,
        hub.clone(),
        std::future::pending(),
    ));
    let (code, body) = get(addr, "/api/history/0/0/0").await;
    assert_eq!(code, 200, "{body}");
    let v: Value = serde_json::from_str(&body).unwrap();
    let ts: Vec<u64> = v["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["ts"].as_u64().unwrap())
        .collect();
    assert_eq!(ts, vec![now - 3000, now - 2000, now - 1000]);
    assert_eq!(v["samples"][2]["raw"], 2000);
    let (code, body) = get(addr, "/api/history/0/1/0").await;
    assert_eq!(
        (code, body.contains("\"samples\":[]")),
        (200, true),
        "{body}"
    );
    assert_eq!(get(addr, "/api/history/0/0/1").await.0, 404);
    assert_eq!(get(addr, "/api/history/0/2/0").await.0, 404);
    assert_eq!(get(addr, "/api/history/0/0/x").await.0, 400);
}
