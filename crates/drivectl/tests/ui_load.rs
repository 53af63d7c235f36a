//! Watching pages cost the buses nothing: with 20 clients on the page's event stream, a busy
//! simulated bus keeps its wire bound. The cheap guard of the figures `scripts/ui-measure`
//! measures in full (docs/ui.md, "Figures"): no browser, plain SSE clients over TCP.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "common/web.rs"]
mod web;

use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::Value;
use web::{Reaped, Scratch, free_port, request};

/// How many clients watch in the loaded window.
const VIEWERS: usize = 20;

/// One MOVILINK bus at 9600 baud with three drives polled fast: the polls ask for about half
/// of the wire, so a bus task held up by the page would show it.
fn plant(port: u16) -> String {
    let mut s = format!(
        "[gateway]\nname = \"load\"\nbroker = \"off\"\nmetrics = \"off\"\n\n\
         [ui]\nlisten = \"127.0.0.1:{port}\"\n\n\
         [[bus]]\nname = \"line\"\nprotocol = \"movilink\"\nport = \"/dev/null\"\nsimulate = true\n"
    );
    for address in 1..=3 {
        s += &format!("\n[[bus.drive]]\nname = \"d{address}\"\naddress = {address}\n");
        for (param, name) in [("P000", "speed"), ("P004", "current")] {
            s += &format!(
                "\n[[bus.drive.param]]\nparam = \"{param}\"\nname = \"{name}\"\nperiod = \"300ms\"\n"
            );
        }
    }
    s
}

/// One open `GET /api/events`: each `data:` line sent on `lines` (until the receiver is gone),
/// counted in `count`; it reads until `stop` is set.
fn watch(
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    count: Arc<AtomicU64>,
    lines: Option<mpsc::Sender<Value>>,
) -> std::thread::JoinHandle<()> {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    write!(
        s,
        "GET /api/events HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nAccept: text/event-stream\r\n\r\n",
        addr.port()
    )
    .unwrap();
    std::thread::spawn(move || {
        let mut r = BufReader::new(s);
        let mut line = String::new();
        while !stop.load(Ordering::Relaxed) {
            match r.read_line(&mut line) {
                Ok(0) => break,
                Ok(_) => {
                    // Chunked framing puts a size line between events; only data lines count.
                    if let Some(data) = line.trim_end().strip_prefix("data: ") {
                        count.fetch_add(1, Ordering::Relaxed);
                        if let (Some(tx), Ok(v)) = (&lines, serde_json::from_str::<Value>(data)) {
                            let _ = tx.send(v);
                        }
                    }
                    line.clear();
                }
                // A read timeout keeps what it read so far in `line`: go on reading.
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(_) => break,
            }
        }
    })
}

/// The next figures of bus 0 from the observer's events: (utilisation, transactions,
/// late polls, ts in ms).
fn next_figures(rx: &mpsc::Receiver<Value>) -> (f64, u64, u64, u64) {
    let until = Instant::now() + Duration::from_secs(15);
    loop {
        let left = until.saturating_duration_since(Instant::now());
        let v = rx.recv_timeout(left).expect("no bus figures within 15 s");
        if v["type"] == "figures" && v["bus"] == 0 {
            let f = &v["payload"];
            return (
                f["utilisation"].as_f64().unwrap(),
                f["transactions"].as_u64().unwrap(),
                f["late_polls"].as_u64().unwrap(),
                f["ts"].as_u64().unwrap(),
            );
        }
    }
}

#[test]
fn twenty_event_stream_clients_leave_a_busy_bus_its_wire_bound() {
    let port = free_port();
    let dir = Scratch::new("ui-load");
    let config = dir.0.join("plant.toml");
    std::fs::write(&config, plant(port)).unwrap();
    let drivectl = env!("CARGO_BIN_EXE_drivectl");
    let check = Command::new(drivectl)
        .args(["gateway", "--check", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    let child = Command::new(drivectl)
        .args(["gateway", "--config"])
        .arg(&config)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _gateway = Reaped(child);
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let until = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not listen");
        std::thread::sleep(Duration::from_millis(20));
    }

    // One observer all along, for the bus figures (every 5 s, counted from the bus's start).
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let observer = watch(addr, stop.clone(), Arc::new(AtomicU64::new(0)), Some(tx));
    // Nothing reported yet: the first figures the observer sees are the first the bus sent.
    let plant: Value =
        serde_json::from_str(&request(addr, "GET", "/api/plant", None).body).unwrap();
    assert!(
        plant["buses"][0]["figures"].is_null(),
        "figures came before the observer watched: {plant}"
    );

    let first = next_figures(&rx);
    let second = next_figures(&rx);
    let counts: Vec<Arc<AtomicU64>> = (0..VIEWERS).map(|_| Arc::new(AtomicU64::new(0))).collect();
    let viewers: Vec<_> = counts
        .iter()
        .map(|c| watch(addr, stop.clone(), c.clone(), None))
        .collect();
    let third = next_figures(&rx);
    stop.store(true, Ordering::Relaxed);
    for v in viewers {
        v.join().unwrap();
    }
    observer.join().unwrap();

    // Each figure's utilisation is the busy share since the bus's start, 5 s before the first.
    let elapsed = |f: (f64, u64, u64, u64)| 5.0 + (f.3 - first.3) as f64 / 1000.0;
    let busy = |f: (f64, u64, u64, u64)| f.0 * elapsed(f);
    let window = |a, b| (busy(b) - busy(a)) / (elapsed(b) - elapsed(a));
    let without = window(first, second);
    let with = window(second, third);
    eprintln!(
        "utilisation {without:.4} without, {with:.4} with {VIEWERS} clients; transactions {} / {}; \
         late polls {} / {}",
        second.1 - first.1,
        third.1 - second.1,
        second.2 - first.2,
        third.2 - second.2
    );
    assert!(
        without > 0.3,
        "the bus is not busy enough to tell: {without}"
    );
    assert!(
        (with / without - 1.0).abs() < 0.05,
        "utilisation {with:.4} with {VIEWERS} clients, {without:.4} without"
    );
    assert_eq!(
        third.2, second.2,
        "late polls while {VIEWERS} clients watched"
    );
    assert_eq!(second.2, first.2, "late polls before the clients came");
    for (i, c) in counts.iter().enumerate() {
        // 20 values a second on the bus: every client got its share of the 5 s.
        let n = c.load(Ordering::Relaxed);
        assert!(n >= 50, "client {i} got only {n} events");
    }
}
