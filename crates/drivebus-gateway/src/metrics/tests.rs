//! Tests of the metrics registry and the `/metrics` endpoint (real sockets on 127.0.0.1).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

use super::*;
use crate::config::Plant;

// ---- a per-thread counting allocator: tests run in parallel threads, so the count of one
// test is not disturbed by the others.

struct ThreadCounting;

thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<u64> = const { Cell::new(0) };
    static FREED: Cell<u64> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
    let _ = BYTES.try_with(|c| c.set(c.get() + size as u64));
}

// SAFETY: every call is forwarded unchanged to the system allocator; the thread-local
// counters are `const`-initialised `Cell`s without destructors, so touching them allocates
// nothing and cannot fail.
unsafe impl GlobalAlloc for ThreadCounting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: the caller's contract is passed on unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        let _ = FREED.try_with(|c| c.set(c.get() + layout.size() as u64));
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let _ = FREED.try_with(|c| c.set(c.get() + layout.size() as u64));
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: ThreadCounting = ThreadCounting;

/// Allocations this thread made while running `f`, and the bytes still held at its end.
fn counted<R>(f: impl FnOnce() -> R) -> (R, u64, i64) {
    let live = || BYTES.with(Cell::get) as i64 - FREED.with(Cell::get) as i64;
    let (a0, l0) = (ALLOCS.with(Cell::get), live());
    let r = f();
    (r, ALLOCS.with(Cell::get) - a0, live() - l0)
}

/// A plant of `buses` simulated MOVILINK buses with `drives` drives each; the first drive of
/// each bus has a writable parameter and process data.
fn plant(buses: usize, drives: usize) -> Plant {
    let mut t = String::from("[gateway]\nname = \"gw1\"\nbroker = \"mqtt://127.0.0.1:1883\"\n");
    for b in 0..buses {
        t += &format!("[[bus]]\nname = \"line{b}\"\nprotocol = \"movilink\"\nsimulate = true\n");
        for d in 0..drives {
            t += &format!("[[bus.drive]]\nname = \"d{d}\"\naddress = {}\n", d + 1);
            t += "[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n";
            if d == 0 {
                t += "writable = true\n[bus.drive.process_data]\nperiod = \"50ms\"\nout = [6, 0]\n";
            }
        }
    }
    Plant::parse(&t, "test").unwrap()
}

fn lines_with<'a>(text: &'a str, prefix: &str) -> Vec<&'a str> {
    text.lines().filter(|l| l.starts_with(prefix)).collect()
}

/// The value of the one sample line that starts with `series` followed by a space.
fn sample(text: &str, series: &str) -> f64 {
    let found: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix(series)?.strip_prefix(' '))
        .collect();
    assert_eq!(found.len(), 1, "{series}: {found:?}\n{text}");
    found[0].parse().unwrap()
}

#[test]
fn every_family_with_its_labels() {
    let m = Metrics::new(&plant(2, 2));
    m.transaction("line0", "d1", "read", "ok", Duration::from_millis(3));
    m.transaction("line0", "d1", "read", "timeout", Duration::from_millis(300));
    m.retries("line1", 2);
    m.rejected("line1", "checksum", 3);
    m.utilisation("line0", 0.42, 0.4);
    m.drive_status("line0", "d0", "fault");
    m.broker_connected(true);
    m.published("value");
    m.set_outcome("range");
    let t = m.encode();
    assert_eq!(
        sample(
            &t,
            r#"drivebus_transactions_total{bus="line0",drive="d1",op="read",outcome="ok"}"#
        ),
        1.0
    );
    assert_eq!(
        sample(
            &t,
            r#"drivebus_transactions_total{bus="line0",drive="d1",op="read",outcome="timeout"}"#
        ),
        1.0
    );
    // 3 ms lies in the 5 ms bucket, not in the 2 ms one; 300 ms in the 0.3 s one.
    let b = |le: &str| {
        sample(
            &t,
            &format!(
                r#"drivebus_transaction_seconds_bucket{{le="{le}",bus="line0",drive="d1",op="read"}}"#
            ),
        )
    };
    assert_eq!(
        (b("0.002"), b("0.005"), b("0.2"), b("0.3"), b("+Inf")),
        (0.0, 1.0, 1.0, 2.0, 2.0)
    );
    assert_eq!(
        sample(
            &t,
            r#"drivebus_transaction_seconds_count{bus="line0",drive="d1",op="read"}"#
        ),
        2.0
    );
    assert_eq!(sample(&t, r#"drivebus_retries_total{bus="line1"}"#), 2.0);
    assert_eq!(sample(&t, r#"drivebus_retries_total{bus="line0"}"#), 0.0);
    assert_eq!(
        sample(
            &t,
            r#"drivebus_rejected_frames_total{bus="line1",reason="checksum"}"#
        ),
        3.0
    );
    assert_eq!(sample(&t, r#"drivebus_bus_utilisation{bus="line0"}"#), 0.42);
    assert_eq!(sample(&t, r#"drivebus_bus_demand{bus="line0"}"#), 0.4);
    for (state, v) in [("online", 0.0), ("timeout", 0.0), ("fault", 1.0)] {
        assert_eq!(
            sample(
                &t,
                &format!(r#"drivebus_drive_up{{bus="line0",drive="d0",state="{state}"}}"#)
            ),
            v
        );
    }
    assert_eq!(sample(&t, "drivebus_broker_connected"), 1.0);
    assert_eq!(
        sample(&t, r#"drivebus_mqtt_published_total{kind="value"}"#),
        1.0
    );
    assert_eq!(sample(&t, r#"drivebus_sets_total{outcome="range"}"#), 1.0);
    assert_eq!(sample(&t, r#"drivebus_sets_total{outcome="written"}"#), 0.0);
    assert_eq!(
        sample(
            &t,
            &format!(
                r#"drivebus_build_info{{version="{}"}}"#,
                env!("CARGO_PKG_VERSION")
            )
        ),
        1.0
    );
    assert!(t.ends_with("# EOF\n"), "OpenMetrics ends with # EOF");
    assert!(t.contains("# TYPE drivebus_transaction_seconds histogram"));
    assert!(t.contains("# UNIT drivebus_transaction_seconds seconds"));
}

#[test]
fn series_are_prebuilt_for_what_each_drive_does() {
    let m = Metrics::new(&plant(1, 2));
    let t = m.encode();
    // d0 reads, writes and exchanges process data; d1 only reads: one series per outcome.
    let n = crate::metrics::OUTCOMES.len();
    let series = |drive: &str, op: &str| {
        lines_with(
            &t,
            &format!(r#"drivebus_transactions_total{{bus="line0",drive="{drive}",op="{op}""#),
        )
        .len()
    };
    assert_eq!(
        (
            series("d0", "read"),
            series("d0", "write"),
            series("d0", "process_data")
        ),
        (n, n, n)
    );
    assert_eq!(
        (
            series("d1", "read"),
            series("d1", "write"),
            series("d1", "process_data")
        ),
        (n, 0, 0)
    );
    // An op first used later gets its series then.
    m.transaction("line0", "d1", "write", "ok", Duration::from_millis(20));
    let t = m.encode();
    assert_eq!(
        sample(
            &t,
            r#"drivebus_transactions_total{bus="line0",drive="d1",op="write",outcome="ok"}"#
        ),
        1.0
    );
}

#[test]
fn nothing_from_outside_grows_the_label_sets() {
    let m = Metrics::new(&plant(1, 1));
    let before = m.encode();
    // Names the plant does not have, and reasons and outcomes outside the lists.
    m.transaction("nobus", "d0", "read", "ok", Duration::from_millis(1));
    m.transaction("line0", "nodrive", "read", "ok", Duration::from_millis(1));
    m.transaction_at(7, 0, "read", "ok", Duration::from_millis(1));
    m.transaction_at(0, 7, "read", "ok", Duration::from_millis(1));
    m.retries("nobus", 1);
    m.utilisation("nobus", 0.5, 0.5);
    m.drive_status("line0", "nodrive", "online");
    m.drive_status("line0", "d0", "exploded");
    for i in 0..100 {
        m.rejected("line0", &format!("reason {i} from the wire"), 1);
        m.set_outcome(&format!("outcome {i} from a payload"));
    }
    let after = m.encode();
    let series = |t: &str| t.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(series(&before), series(&after));
    assert_eq!(
        sample(
            &after,
            r#"drivebus_rejected_frames_total{bus="line0",reason="other"}"#
        ),
        100.0
    );
    assert_eq!(
        sample(&after, r#"drivebus_sets_total{outcome="other"}"#),
        100.0
    );
    for state in STATES {
        assert_eq!(
            sample(
                &after,
                &format!(r#"drivebus_drive_up{{bus="line0",drive="d0",state="{state}"}}"#)
            ),
            0.0,
            "an unknown state changes nothing"
        );
    }
}

#[test]
fn gauges_take_no_nan_and_stay_in_range() {
    let m = Metrics::new(&plant(1, 1));
    m.utilisation("line0", 0.5, 1.5);
    m.utilisation("line0", f64::NAN, f64::INFINITY);
    let t = m.encode();
    assert_eq!(sample(&t, r#"drivebus_bus_utilisation{bus="line0"}"#), 0.5);
    assert_eq!(sample(&t, r#"drivebus_bus_demand{bus="line0"}"#), 1.5);
    m.utilisation("line0", 1.7, -0.2);
    let t = m.encode();
    assert_eq!(sample(&t, r#"drivebus_bus_utilisation{bus="line0"}"#), 1.0);
    assert_eq!(sample(&t, r#"drivebus_bus_demand{bus="line0"}"#), 0.0);
    m.drive_status("line0", "d0", "online");
    m.drive_status("line0", "d0", "timeout");
    let t = m.encode();
    let up: f64 = STATES
        .iter()
        .map(|s| {
            sample(
                &t,
                &format!(r#"drivebus_drive_up{{bus="line0",drive="d0",state="{s}"}}"#),
            )
        })
        .sum();
    assert_eq!(up, 1.0);
    assert_eq!(
        sample(
            &t,
            r#"drivebus_drive_up{bus="line0",drive="d0",state="timeout"}"#
        ),
        1.0
    );
}

#[test]
fn a_name_with_quotes_and_backslashes_is_escaped() {
    // Topic levels may hold `"` and `\`; the exposition must stay parseable.
    let t = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h:1883\"\n[[bus]]\nname = 'a\"b\\c'\n\
             protocol = \"movilink\"\nsimulate = true\n[[bus.drive]]\nname = \"d\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n";
    let m = Metrics::new(&Plant::parse(t, "test").unwrap());
    m.retries("a\"b\\c", 1);
    assert_eq!(
        sample(&m.encode(), r#"drivebus_retries_total{bus="a\"b\\c"}"#),
        1.0
    );
}

#[test]
fn a_transaction_allocates_nothing() {
    let m = Metrics::new(&plant(4, 31));
    // The counter counts (this test would pass without it otherwise).
    assert_eq!(counted(|| String::from("x")).1, 1);
    // The first observation of a histogram may settle its storage; count from the second.
    m.transaction("line3", "d30", "read", "ok", Duration::from_millis(4));
    m.transaction_at(3, 30, "read", "ok", Duration::from_millis(4));
    let ((), allocs, _) = counted(|| {
        for i in 0..1000u64 {
            m.transaction("line3", "d30", "read", "ok", Duration::from_micros(i * 37));
            m.transaction(
                "line0",
                "d0",
                "process_data",
                "timeout",
                Duration::from_millis(50),
            );
            m.transaction_at(2, 17, "read", "device_error", Duration::from_millis(25));
            m.retries("line1", 1);
            m.rejected("line1", "checksum", 1);
            m.utilisation("line2", 0.3, 0.35);
            m.drive_status("line2", "d5", "online");
            m.published("value");
            m.set_outcome("written");
        }
    });
    assert_eq!(allocs, 0, "the hot path allocated");
}

#[test]
#[allow(clippy::print_stdout)] // the figures, for `--nocapture`
fn figures_of_a_plant_of_64_buses_of_31_drives() {
    // The figures the report quotes (debug build; `--nocapture` prints them). The bounds are
    // loose: they catch a per-call allocation or a quadratic lookup, not a slow machine.
    let p = plant(64, 31);
    let (m, allocs, bytes) = counted(|| Metrics::new(&p));
    let n = 100_000u32;
    let start = std::time::Instant::now();
    for i in 0..n {
        let bus = (i % 64) as usize;
        let drive = (i % 31) as usize;
        m.transaction_at(bus, drive, "read", "ok", Duration::from_millis(25));
    }
    let per_at = start.elapsed() / n;
    let names: Vec<(String, String)> = (0..64)
        .flat_map(|b| (0..31).map(move |d| (format!("line{b}"), format!("d{d}"))))
        .collect();
    let start = std::time::Instant::now();
    for i in 0..n as usize {
        let (b, d) = &names[i % names.len()];
        m.transaction(b, d, "read", "ok", Duration::from_millis(25));
    }
    let per_named = start.elapsed() / n;
    let start = std::time::Instant::now();
    let text = m.encode();
    let encode = start.elapsed();
    println!(
        "64 x 31 drives: Metrics::new {allocs} allocations, {} KiB held; transaction_at {per_at:?}, \
         transaction by name {per_named:?}; exposition {} KiB, {} lines, encoded in {encode:?}",
        bytes / 1024,
        text.len() / 1024,
        text.lines().count()
    );
    assert_eq!(
        sample(
            &text,
            r#"drivebus_transactions_total{bus="line5",drive="d7",op="read",outcome="ok"}"#
        ),
        // i % 64 == 5 and i % 31 == 7: every 1984th i from the first, twice over.
        2.0 * (0..n).filter(|i| i % 64 == 5 && i % 31 == 7).count() as f64
    );
    assert!(per_at < Duration::from_micros(50), "{per_at:?}");
    assert!(per_named < Duration::from_micros(50), "{per_named:?}");
    assert!(encode < Duration::from_secs(5), "{encode:?}");
}

/// `drivebus_runtime_tasks` is the runtime's alive tasks and the gateway's own on its
/// `LocalSet` (started by `crate::tasks::spawn_local`, counted while they live, aborted ones
/// too), read at each scrape, also when the exposition is written on a blocking thread as the
/// endpoint does. (Tokio's count alone misses the `LocalSet`'s tasks: the soak found the gauge
/// at 1 all the time.)
#[test]
fn runtime_tasks_are_read_at_each_scrape_the_gateways_own_included() {
    let m = Arc::new(Metrics::new(&plant(1, 1)));
    // Outside a runtime the gauge keeps its value.
    assert_eq!(sample(&m.encode(), "drivebus_runtime_tasks"), 0.0);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let local = tokio::task::LocalSet::new();
    crate::tasks::count_on_this_thread(m.local_task_count());
    local.block_on(&rt, async {
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        let parked = |mut rx: tokio::sync::watch::Receiver<bool>| async move {
            let _ = rx.wait_for(|s| *s).await;
        };
        let a = tokio::spawn(parked(stop_rx.clone()));
        let b = tokio::spawn(parked(stop_rx.clone()));
        let c = crate::tasks::spawn_local(parked(stop_rx.clone()));
        let d = crate::tasks::spawn_local(parked(stop_rx.clone()));
        // A task of the LocalSet not started through the gateway's spawn is not seen.
        let e = tokio::task::spawn_local(parked(stop_rx.clone()));
        assert_eq!(sample(&m.encode(), "drivebus_runtime_tasks"), 4.0);
        let on_blocking = m.clone();
        let body = tokio::task::spawn_blocking(move || on_blocking.encode())
            .await
            .unwrap();
        assert_eq!(sample(&body, "drivebus_runtime_tasks"), 4.0);
        // Aborted: no longer alive once its future is dropped.
        d.abort();
        assert!(d.await.unwrap_err().is_cancelled());
        assert_eq!(sample(&m.encode(), "drivebus_runtime_tasks"), 3.0);
        stop_tx.send(true).unwrap();
        for t in [a, b, c, e] {
            t.await.unwrap();
        }
        assert_eq!(sample(&m.encode(), "drivebus_runtime_tasks"), 0.0);
    });
}

// ---- the endpoint

async fn endpoint(limits: Limits) -> (std::net::SocketAddr, Arc<Metrics>) {
    let m = Arc::new(Metrics::new(&plant(1, 2)));
    let listener = bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(serve_with(listener, m.clone(), limits));
    (addr, m)
}

/// Send `request`, read the answer to the end: (status code, head, body).
async fn ask(addr: std::net::SocketAddr, request: &[u8]) -> (u16, String, String) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(request).await.unwrap();
    read_answer(&mut s).await
}

async fn read_answer(s: &mut TcpStream) -> (u16, String, String) {
    let mut all = Vec::new();
    s.read_to_end(&mut all).await.unwrap();
    let all = String::from_utf8(all).unwrap();
    let (head, body) = all.split_once("\r\n\r\n").unwrap();
    let status = head[9..12].parse().unwrap();
    let len: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(len, body.len(), "Content-Length matches the body");
    assert!(head.contains("\r\nConnection: close"), "{head}");
    (status, head.to_owned(), body.to_owned())
}

#[tokio::test]
async fn get_metrics_answers_the_exposition() {
    let (addr, m) = endpoint(Limits::default()).await;
    m.transaction("line0", "d1", "read", "ok", Duration::from_millis(3));
    let (status, head, body) = ask(
        addr,
        b"GET /metrics HTTP/1.1\r\nHost: x\r\nAccept: */*\r\n\r\n",
    )
    .await;
    assert_eq!(status, 200);
    assert!(
        head.contains(&format!("\r\nContent-Type: {CONTENT_TYPE}")),
        "{head}"
    );
    assert_eq!(
        sample(
            &body,
            r#"drivebus_transactions_total{bus="line0",drive="d1",op="read",outcome="ok"}"#
        ),
        1.0
    );
    // A query string is ignored; HTTP/1.0 is served too.
    let (status, _, body) = ask(addr, b"GET /metrics?x=1 HTTP/1.0\r\n\r\n").await;
    assert_eq!(status, 200);
    assert!(body.ends_with("# EOF\n"));
    let (status, _, body) = ask(addr, b"GET / HTTP/1.1\r\n\r\n").await;
    assert_eq!(status, 200);
    assert!(
        body.contains("/metrics") && body.lines().count() == 1,
        "{body}"
    );
}

#[tokio::test]
async fn a_head_in_pieces_is_read_to_its_end() {
    let (addr, _) = endpoint(Limits::default()).await;
    let mut s = TcpStream::connect(addr).await.unwrap();
    // The blank line is split between two writes.
    for piece in [&b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r"[..], b"\n"] {
        s.write_all(piece).await.unwrap();
        s.flush().await.unwrap();
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    assert_eq!(read_answer(&mut s).await.0, 200);
}

#[tokio::test]
async fn other_paths_methods_and_garbage() {
    let (addr, _) = endpoint(Limits::default()).await;
    assert_eq!(ask(addr, b"GET /metricsx HTTP/1.1\r\n\r\n").await.0, 404);
    assert_eq!(ask(addr, b"GET /favicon.ico HTTP/1.1\r\n\r\n").await.0, 404);
    let (status, head, _) = ask(addr, b"POST /metrics HTTP/1.1\r\nContent-Length: 0\r\n\r\n").await;
    assert_eq!(status, 405);
    assert!(head.contains("\r\nAllow: GET"), "{head}");
    assert_eq!(ask(addr, b"DELETE / HTTP/1.1\r\n\r\n").await.0, 405);
    assert_eq!(ask(addr, b"GET /metrics\r\n\r\n").await.0, 400);
    assert_eq!(ask(addr, b"GET /metrics HTTP/2.0\r\n\r\n").await.0, 400);
    assert_eq!(ask(addr, b"\xff\xfe / HTTP/1.1\r\n\r\n").await.0, 400);
    // Blank lines before the request line are ignored (RFC 9112, 2.2); blank lines alone get
    // 408 once the head's time is up (a_client_that_sends_nothing_gets_408_after_5_s).
    assert_eq!(
        ask(addr, b"\r\n\r\nGET /metrics HTTP/1.1\r\n\r\n").await.0,
        200
    );
}

#[tokio::test]
async fn an_oversized_head_gets_431() {
    let (addr, _) = endpoint(Limits::default()).await;
    let mut req = b"GET /metrics HTTP/1.1\r\n".to_vec();
    while req.len() < 9000 {
        req.extend_from_slice(b"X-Filler: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\r\n");
    }
    req.extend_from_slice(b"\r\n");
    let (status, _, body) = ask(addr, &req).await;
    assert_eq!(status, 431, "{body}");
    // Just under the limit is served.
    let mut req = b"GET /metrics HTTP/1.1\r\n".to_vec();
    while req.len() < 8000 {
        req.extend_from_slice(b"X-Filler: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\r\n");
    }
    req.extend_from_slice(b"\r\n");
    assert!(req.len() < 8192);
    assert_eq!(ask(addr, &req).await.0, 200);
    // Another limit is kept to the byte, below hyper's 8 KiB buffer too.
    let (addr, _) = endpoint(Limits {
        max_head: 1024,
        ..Limits::default()
    })
    .await;
    let mut req = b"GET /metrics HTTP/1.1\r\n".to_vec();
    while req.len() < 1000 {
        req.extend_from_slice(b"X-Filler: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\r\n");
    }
    let under = [&req[..], b"\r\n"].concat();
    assert!(under.len() <= 1024, "{}", under.len());
    assert_eq!(ask(addr, &under).await.0, 200);
    req.extend_from_slice(b"X-Filler: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\r\n\r\n");
    assert_eq!(ask(addr, &req).await.0, 431);
}

#[tokio::test(start_paused = true)]
async fn a_client_that_sends_nothing_gets_408_after_5_s() {
    let (addr, _) = endpoint(Limits::default()).await;
    let start = tokio::time::Instant::now();
    let mut s = TcpStream::connect(addr).await.unwrap();
    let (status, _, _) = read_answer(&mut s).await;
    assert_eq!(status, 408);
    assert!(
        start.elapsed() >= Duration::from_secs(5),
        "{:?}",
        start.elapsed()
    );
    // Blank lines are no request.
    let start = tokio::time::Instant::now();
    let (status, _, _) = ask(addr, b"\r\n\r\n").await;
    assert_eq!(status, 408);
    assert!(start.elapsed() >= Duration::from_secs(5));
    // A slow client that trickles bytes has 5 s for the whole head, not 5 s per byte.
    let start = tokio::time::Instant::now();
    let (mut r, mut w) = TcpStream::connect(addr).await.unwrap().into_split();
    tokio::spawn(async move {
        for b in b"GET /metrics HTTP/1.1\r\nHost: x" {
            if w.write_all(&[*b]).await.is_err() {
                break;
            }
            tokio::time::sleep(Duration::from_secs(1)).await;
        }
    });
    let mut all = Vec::new();
    r.read_to_end(&mut all).await.unwrap();
    assert!(
        all.starts_with(b"HTTP/1.1 408 "),
        "{}",
        String::from_utf8_lossy(&all)
    );
    let took = start.elapsed();
    assert!(
        took >= Duration::from_secs(5) && took < Duration::from_secs(6),
        "{took:?}"
    );
}

#[tokio::test]
async fn the_17th_connection_gets_503_and_is_served_when_one_ends() {
    // The default 16 places; a long head timeout, so that a slow machine cannot free a place
    // by timing a held connection out during the test.
    let limits = Limits {
        head_timeout: Duration::from_secs(120),
        ..Limits::default()
    };
    assert_eq!(limits.max_connections, 16);
    let (addr, _) = endpoint(limits).await;
    let mut held = Vec::new();
    for _ in 0..16 {
        held.push(TcpStream::connect(addr).await.unwrap());
    }
    // The 17th is answered at once, although the 16 have sent nothing yet.
    let mut s = TcpStream::connect(addr).await.unwrap();
    let (status, head, _) = tokio::time::timeout(Duration::from_secs(2), read_answer(&mut s))
        .await
        .expect("503 at once, not after the others' 5 s");
    assert_eq!(status, 503);
    assert!(head.contains("\r\nRetry-After: 1"), "{head}");
    // One of the 16 asks and is answered: its place is free again.
    let mut first = held.remove(0);
    first
        .write_all(b"GET /metrics HTTP/1.1\r\n\r\n")
        .await
        .unwrap();
    assert_eq!(read_answer(&mut first).await.0, 200);
    drop(first);
    // The server ends that connection once the client has closed its side; until then a
    // new one may still be turned away.
    let mut served = false;
    for _ in 0..100 {
        let (status, _, _) = ask(addr, b"GET /metrics HTTP/1.1\r\n\r\n").await;
        if status == 200 {
            served = true;
            break;
        }
        assert_eq!(status, 503);
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(served, "a freed place is served again");
    drop(held);
}

#[test]
fn busy_answer_is_well_formed() {
    let text = std::str::from_utf8(BUSY).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    let len: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(len, body.len());
}

#[test]
fn the_deployment_pages_config_is_accepted() {
    // docs/deploying.md shows a cabinet's config: it must pass the same checks as a real one.
    let page = include_str!("../../../../docs/deploying.md");
    let block = page
        .split("```toml\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .unwrap();
    assert!(block.contains("[gateway]"), "{block}");
    let plant = Plant::parse(block, "docs/deploying.md").unwrap();
    assert_eq!(plant.gateway.name, "cabinet-12");
    assert_eq!(plant.buses[0].drives[0].points.len(), 2);
}

/// Issue 22, item 2: a reload's metrics: the series of a bus or drive the new config no longer
/// has are gone from the exposition, those that stay keep counting, new ones start at 0.
#[test]
fn a_reload_removes_the_series_that_went_and_keeps_the_counts_that_stay() {
    let m = Metrics::new(&plant(2, 2));
    m.transaction("line0", "d1", "read", "ok", Duration::from_millis(3));
    m.transaction("line1", "d0", "read", "ok", Duration::from_millis(3));
    m.retries("line1", 4);
    m.drive_status("line1", "d1", "online");
    // line1 goes, line0 keeps only d1.
    let mut t = String::from("[gateway]\nname = \"gw1\"\nbroker = \"mqtt://127.0.0.1:1883\"\n");
    t += "[[bus]]\nname = \"line0\"\nprotocol = \"movilink\"\nsimulate = true\n";
    t += "[[bus.drive]]\nname = \"d1\"\naddress = 2\n[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n";
    t += "[[bus]]\nname = \"line9\"\nprotocol = \"movilink\"\nsimulate = true\n";
    t += "[[bus.drive]]\nname = \"n\"\naddress = 1\n[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n";
    let reloaded = Plant::parse(&t, "test").unwrap();
    m.reconfigure(&reloaded);
    let text = m.encode();
    assert!(!text.contains("line1"), "{text}");
    assert!(!text.contains("drive=\"d0\""), "{text}");
    assert_eq!(
        sample(
            &text,
            "drivebus_transactions_total{bus=\"line0\",drive=\"d1\",op=\"read\",outcome=\"ok\"}"
        ),
        1.0
    );
    assert_eq!(
        sample(
            &text,
            "drivebus_transactions_total{bus=\"line9\",drive=\"n\",op=\"read\",outcome=\"ok\"}"
        ),
        0.0
    );
    // Metric calls by the names of what went are dropped; by the new names, counted.
    m.retries("line1", 1);
    m.transaction("line9", "n", "read", "ok", Duration::from_millis(1));
    m.transaction("line0", "d1", "read", "ok", Duration::from_millis(1));
    let text = m.encode();
    assert!(!text.contains("line1"), "{text}");
    assert_eq!(
        sample(
            &text,
            "drivebus_transactions_total{bus=\"line0\",drive=\"d1\",op=\"read\",outcome=\"ok\"}"
        ),
        2.0
    );
    assert_eq!(sample(&text, "drivebus_retries_total{bus=\"line9\"}"), 0.0);
}
