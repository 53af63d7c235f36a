//! The Sparkplug B edge node under the load model: BUSESxDRIVES simulated MOVILINK buses
//! (`load::sparkplug_plant`: every drive's P130 polled every PERIOD, each bus at most as often
//! as its wire allows, its figures every 5 s) for SECONDS of virtual time, fed to the session
//! (`sparkplug::node::Node`) as the gateway's Sparkplug task feeds it: each update, then a
//! flush (FLUSH `each`: the task keeps up with the buses), or every update of a window, then
//! one flush (FLUSH `100ms`: a task that is behind by that much). Two cases: every poll reads
//! a new value (the worst case) and one poll in ten does (the other nine read the value
//! already published).
//!
//! ```text
//! cargo run --release -p drivebus-gateway --example sparkplug_load -- [64x31 [SECONDS [PERIOD [FLUSH [RUNS [CASE]]]]]]
//! ```
//!
//! Per case: the messages, metrics and bytes the plant asks for per (virtual) second, and what
//! the node can publish per second of processor time, with the processor time per published
//! metric; the medians of RUNS runs (default 5). CASE: `all` (every read a new value),
//! `tenth` (one in ten) or `both` (the default).
//!
//! It measures the node's side only, without a broker: the session's bookkeeping and the
//! protobuf encoding of every DDATA and NDATA. The MQTT client's queue and its socket writes
//! are not included, nor the bus tasks that read the values (`examples/load.rs` measures
//! those). Processor time is `getrusage(RUSAGE_SELF)` (user + system) of this single-threaded
//! process, so other processes on the machine do not count; the wall clock is printed beside
//! it. Before the timed runs one run is decoded message by message: every DDATA carries
//! exactly the values that changed, and `seq` counts every message.
//!
//! Callgrind's instruction count of the timed loop alone (the function `timed_feed`), one
//! case at a time:
//!
//! ```text
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null --toggle-collect='*timed_feed*' \
//!     target/release/examples/sparkplug_load 64x31 10 1s each 1 all
//! ```

use std::io::Write;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use drivebus_gateway::config::Plant;
use drivebus_gateway::model::{BusFigures, DriveStatus, Update};
use drivebus_gateway::sparkplug::node::{Node, Out};
use drivebus_gateway::{families, load, task};

/// A line of the report; a closed pipe (`… | head`) ends the program quietly.
macro_rules! say {
    ($out:expr, $($t:tt)*) => {
        match writeln!($out, $($t)*) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
            Err(e) => return Err(format!("cannot write the report: {e}")),
        }
    };
}

/// Virtual time of the run's start (ms since the epoch).
const START_MS: u64 = 1_767_000_000_000;

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sparkplug_load: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

/// The command line.
struct Args {
    buses: usize,
    drives: usize,
    seconds: u64,
    period: String,
    /// The flush window (µs); `None`: a flush after each update.
    window_us: Option<u64>,
    runs: usize,
    /// The cases' steps (a new value every `step` reads).
    steps: Vec<u64>,
}

fn parse(args: &[String]) -> Result<Args, String> {
    let arg = |i: usize| args.get(i).map(String::as_str);
    let spec = arg(0).unwrap_or("64x31");
    let bad = || format!("{spec}: give BUSESxDRIVES, e.g. 64x31 (1–256 buses, 1–31 drives)");
    let (b, d) = spec.split_once(['x', 'X']).ok_or_else(bad)?;
    let buses: usize = b.trim().parse().map_err(|_| bad())?;
    let drives: usize = d.trim().parse().map_err(|_| bad())?;
    if !(1..=256).contains(&buses) || !(1..=31).contains(&drives) {
        return Err(bad());
    }
    let seconds = match arg(1) {
        None => 60,
        Some(s) => s
            .parse::<u64>()
            .ok()
            .filter(|s| (1..=3600).contains(s))
            .ok_or_else(|| {
                format!("SECONDS {s}: give a whole number of virtual seconds, 1–3600")
            })?,
    };
    let period = arg(2).unwrap_or("1s").to_owned();
    let window_us = match arg(3).unwrap_or("each") {
        "each" => None,
        w => {
            let ms = w
                .strip_suffix("ms")
                .and_then(|n| n.parse::<u64>().ok())
                .filter(|n| (1..=10_000).contains(n))
                .ok_or_else(|| format!("FLUSH {w}: give each, or a window of 1ms–10000ms"))?;
            Some(ms * 1000)
        }
    };
    let runs = match arg(4) {
        None => 5,
        Some(r) => r
            .parse::<usize>()
            .ok()
            .filter(|r| (1..=99).contains(r))
            .ok_or_else(|| format!("RUNS {r}: give 1–99"))?,
    };
    let steps = match arg(5).unwrap_or("both") {
        "all" => vec![1],
        "tenth" => vec![10],
        "both" => vec![1, 10],
        c => return Err(format!("CASE {c}: give all, tenth or both")),
    };
    Ok(Args {
        steps,
        buses,
        drives,
        seconds,
        period,
        window_us,
        runs,
    })
}

/// One update of the run, at its virtual time.
struct Feed {
    at_us: u64,
    update: Update,
}

/// The updates of a case: every drive's P130 at the bus's read interval, the drives of a bus
/// spread over it and the buses interleaved; a bus's figures every `FIGURES_EVERY`. A read
/// gives a new value when its count is a multiple of `step` (1: every read). Returns the
/// initial values (before the births), the updates in time order, and how many reads gave a
/// new value.
fn schedule(plant: &Plant, seconds: u64, step: u64) -> (Vec<Update>, Vec<Feed>, u64) {
    let end_us = seconds * 1_000_000;
    let buses = plant.buses.len() as u64;
    let figures_us = u64::try_from(task::FIGURES_EVERY.as_micros()).unwrap_or(u64::MAX);
    let mut initial = Vec::new();
    let mut feeds = Vec::new();
    let mut changes = 0;
    // A raw value of P130 (ms) for the n-th read: it changes when n is a multiple of `step`.
    let raw = |n: u64| 1000 + 10 * i64::try_from((n / step) % 100).unwrap_or(0);
    for (b, bus) in plant.buses.iter().enumerate() {
        let demand = families::wire::demand(bus);
        let drives = bus.drives.len().max(1) as u64;
        for (d, drive) in bus.drives.iter().enumerate() {
            initial.push(Update::Status {
                bus: b,
                drive: d,
                status: DriveStatus::Online,
                at: at(0),
            });
            for (p, point) in drive.points.iter().enumerate() {
                let Some(period) = point.period else {
                    continue;
                };
                // Polls asking for more than the wire carries are stretched alike.
                let interval_us = (period.as_secs_f64() * demand.max(1.0) * 1e6) as u64;
                let offset =
                    interval_us * d as u64 / drives + interval_us * b as u64 / drives / buses;
                let first = (b + d) as u64;
                initial.push(Update::Value {
                    bus: b,
                    drive: d,
                    point: p,
                    raw: raw(first),
                    at: at(0),
                });
                let mut k = 0;
                while offset + k * interval_us < end_us {
                    let n = first + k + 1;
                    let t = offset + k * interval_us;
                    if raw(n) != raw(n - 1) {
                        changes += 1;
                    }
                    feeds.push(Feed {
                        at_us: t,
                        update: Update::Value {
                            bus: b,
                            drive: d,
                            point: p,
                            raw: raw(n),
                            at: at(t),
                        },
                    });
                    k += 1;
                }
            }
        }
        // The figures: the transactions so far (the value reads and each drive's status read
        // every status period), the utilisation of the wire's share.
        let reads_per_s: f64 = bus
            .drives
            .iter()
            .flat_map(|d| &d.points)
            .filter_map(|p| p.period)
            .map(|p| 1.0 / p.as_secs_f64())
            .sum::<f64>()
            + bus.drives.len() as f64 / bus.status_period.as_secs_f64();
        let mut t = figures_us + figures_us * b as u64 / buses;
        while t < end_us {
            feeds.push(Feed {
                at_us: t,
                update: Update::Figures {
                    bus: b,
                    figures: BusFigures {
                        utilisation: demand.min(1.0),
                        demand,
                        transactions: (reads_per_s / demand.max(1.0) * t as f64 / 1e6) as u64,
                        ..BusFigures::default()
                    },
                },
            });
            t += figures_us;
        }
    }
    feeds.sort_by_key(|f| f.at_us);
    (initial, feeds, changes)
}

fn at(us: u64) -> SystemTime {
    UNIX_EPOCH + Duration::from_millis(START_MS) + Duration::from_micros(us)
}

fn now_ms(us: u64) -> u64 {
    START_MS + us / 1000
}

/// What the node published.
#[derive(Debug, Default, Clone, PartialEq)]
struct Tally {
    ddata: u64,
    ndata: u64,
    other: u64,
    payload_bytes: u64,
    /// The MQTT 3.1.1 PUBLISH packets with QoS 0: fixed header (1 byte and the remaining
    /// length), topic length (2) and topic, payload.
    wire_bytes: u64,
    /// Decoded runs only: the metrics of the DDATA and NDATA messages.
    ddata_metrics: u64,
    ndata_metrics: u64,
    /// Decoded runs only: the last `seq`, and whether every message's followed it.
    last_seq: Option<u64>,
    seq_broken: bool,
    decode_failed: bool,
}

impl Tally {
    /// Count what a flush gave (and drop it, as the task hands it to the client).
    fn add(&mut self, outs: Vec<Out>, decode: bool) {
        for o in outs {
            let Out::Publish(m) = o else {
                continue;
            };
            if m.topic.contains("/DDATA/") {
                self.ddata += 1;
            } else if m.topic.contains("/NDATA/") {
                self.ndata += 1;
            } else {
                self.other += 1;
            }
            self.payload_bytes += m.payload.len() as u64;
            let rest = 2 + m.topic.len() + m.payload.len();
            let length_bytes = match rest {
                0..=127 => 1,
                128..=16_383 => 2,
                16_384..=2_097_151 => 3,
                _ => 4,
            };
            self.wire_bytes += (1 + length_bytes + rest) as u64;
            if decode {
                self.check(&m.topic, &m.payload);
            }
        }
    }

    fn check(&mut self, topic: &str, payload: &[u8]) {
        let Ok(p) = sparkplug_b::decode(payload) else {
            self.decode_failed = true;
            return;
        };
        let n = p.metrics.len() as u64;
        if topic.contains("/DDATA/") {
            self.ddata_metrics += n;
        } else {
            self.ndata_metrics += n;
        }
        if let (Some(last), Some(seq)) = (self.last_seq, p.seq)
            && seq != (last + 1) % 256
        {
            self.seq_broken = true;
        }
        self.last_seq = p.seq;
    }
}

/// A node of `plant` past its births: the drives online with their initial values; the
/// births' tally.
fn born(plant: &Plant, initial: &[Update], decode: bool) -> Result<(Node, Tally), String> {
    let sp = plant
        .sparkplug
        .as_ref()
        .ok_or("the load plant has no [sparkplug]")?;
    let mut node = Node::new(plant, sp);
    let t0 = now_ms(0);
    for u in initial {
        let _ = node.update(u, t0);
    }
    let subs = node.connected(0);
    let mut outs = Vec::new();
    for _ in &subs {
        outs.extend(node.subscribed(t0));
    }
    let mut tally = Tally::default();
    tally.add(outs, decode);
    let want = 1 + plant
        .buses
        .iter()
        .map(|b| b.drives.len() as u64)
        .sum::<u64>();
    if tally.other != want {
        return Err(format!(
            "{} births, not NBIRTH and one DBIRTH per drive ({want})",
            tally.other
        ));
    }
    Ok((node, tally))
}

/// The timed loop (not inlined: callgrind counts it alone).
#[inline(never)]
fn timed_feed(node: &mut Node, feeds: &[Feed], window_us: Option<u64>, tally: &mut Tally) {
    feed(node, feeds, window_us, tally, false);
}

/// Every update to the node, each followed by a flush (`window_us` `None`), or every update
/// of a window, then one flush; `decode`: every message decoded and checked.
fn feed(node: &mut Node, feeds: &[Feed], window_us: Option<u64>, tally: &mut Tally, decode: bool) {
    match window_us {
        None => {
            for f in feeds {
                let now = now_ms(f.at_us);
                let mut outs = node.update(&f.update, now);
                outs.extend(node.flush(now));
                tally.add(outs, decode);
            }
        }
        Some(w) => {
            let mut end = w;
            for f in feeds {
                while f.at_us >= end {
                    tally.add(node.flush(now_ms(end)), decode);
                    end += w;
                }
                let outs = node.update(&f.update, now_ms(f.at_us));
                tally.add(outs, decode);
            }
            tally.add(node.flush(now_ms(end)), decode);
        }
    }
}

/// Processor time of this process (user + system).
fn cpu_time() -> Option<Duration> {
    let mut ru = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: `getrusage` writes one `rusage` through the pointer, which points to one.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, ru.as_mut_ptr()) };
    if rc != 0 {
        return None;
    }
    // SAFETY: zeroed is a valid `rusage` (integers only), and `getrusage` succeeded.
    let ru = unsafe { ru.assume_init() };
    let tv = |t: libc::timeval| {
        Duration::from_secs(u64::try_from(t.tv_sec).unwrap_or(0))
            + Duration::from_micros(u64::try_from(t.tv_usec).unwrap_or(0))
    };
    Some(tv(ru.ru_utime) + tv(ru.ru_stime))
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort_unstable();
    v.get(v.len() / 2).copied().unwrap_or_default()
}

fn ms(d: Duration) -> String {
    format!("{:.1}", d.as_secs_f64() * 1e3)
}

fn run(args: &[String]) -> Result<(), String> {
    let mut out = std::io::stdout().lock();
    let a = parse(args)?;
    let plant = load::sparkplug_plant(a.buses, a.drives, &a.period).map_err(|e| e.to_string())?;
    let first = plant.buses.first().ok_or("no bus")?;
    let demand = families::wire::demand(first);
    let period = first
        .drives
        .first()
        .and_then(|d| d.points.first())
        .and_then(|p| p.period)
        .ok_or("no polled point")?;
    say!(
        out,
        "{} buses x {} drives, P130 every {} per drive: demand {:.2} of each wire, a read every {:.3} s per drive; {} s virtual; {}",
        a.buses,
        a.drives,
        a.period,
        demand,
        period.as_secs_f64() * demand.max(1.0),
        a.seconds,
        match a.window_us {
            None => "a flush after each update (the task keeping up)".to_owned(),
            Some(w) => format!("one flush per {} ms window", w / 1000),
        }
    );
    for &step in &a.steps {
        let name = if step == 1 {
            "every read a new value"
        } else {
            "one read in ten a new value"
        };
        let (initial, feeds, changes) = schedule(&plant, a.seconds, step);
        // The decoded run: what is counted is what the node publishes.
        let (mut node, births) = born(&plant, &initial, true)?;
        let mut checked = Tally {
            last_seq: births.last_seq,
            ..Tally::default()
        };
        feed(&mut node, &feeds, a.window_us, &mut checked, true);
        if checked.decode_failed || checked.seq_broken || checked.other != 0 {
            return Err(format!(
                "{name}: the node's messages do not decode in sequence: {checked:?}"
            ));
        }
        if checked.ddata_metrics != changes {
            return Err(format!(
                "{name}: {} DDATA metrics for {changes} values changed",
                checked.ddata_metrics
            ));
        }
        let mut cpu = Vec::new();
        let mut wall = Vec::new();
        let mut birth_cpu = Vec::new();
        for _ in 0..a.runs {
            let c0 = cpu_time().ok_or("getrusage failed")?;
            let (mut node, _) = born(&plant, &initial, false)?;
            let c1 = cpu_time().ok_or("getrusage failed")?;
            let w0 = Instant::now();
            let mut tally = Tally::default();
            timed_feed(&mut node, &feeds, a.window_us, &mut tally);
            let w = w0.elapsed();
            let c2 = cpu_time().ok_or("getrusage failed")?;
            let counted = Tally {
                ddata: checked.ddata,
                ndata: checked.ndata,
                payload_bytes: checked.payload_bytes,
                wire_bytes: checked.wire_bytes,
                ..Tally::default()
            };
            if tally != counted {
                return Err(format!("{name}: a run published other messages: {tally:?}"));
            }
            birth_cpu.push(c1.saturating_sub(c0));
            cpu.push(c2.saturating_sub(c1));
            wall.push(w);
        }
        let c = median(cpu.clone()).as_secs_f64().max(1e-9);
        let messages = (checked.ddata + checked.ndata) as f64;
        let metrics = (checked.ddata_metrics + checked.ndata_metrics) as f64;
        let secs = a.seconds as f64;
        say!(
            out,
            "\n{name}: {} updates fed, {changes} values changed",
            feeds.len()
        );
        say!(
            out,
            "  published: {} DDATA ({} metrics) + {} NDATA ({} metrics); {:.2} MB of payload, {:.2} MB on the wire (MQTT 3.1.1 PUBLISH, QoS 0)",
            checked.ddata,
            checked.ddata_metrics,
            checked.ndata,
            checked.ndata_metrics,
            checked.payload_bytes as f64 / 1e6,
            checked.wire_bytes as f64 / 1e6
        );
        say!(
            out,
            "  the plant asks for: {:.0} messages/s, {:.0} metrics/s, {:.1} kB/s on the wire",
            messages / secs,
            metrics / secs,
            checked.wire_bytes as f64 / secs / 1e3
        );
        say!(
            out,
            "  the node publishes per second of processor time: {:.0} messages/s, {:.0} metrics/s, {:.1} MB/s on the wire",
            messages / c,
            metrics / c,
            checked.wire_bytes as f64 / c / 1e6
        );
        say!(
            out,
            "  processor time: {:.0} ns per published metric, {:.0} ns per update fed; {:.2} % of one core at the plant's rate",
            c * 1e9 / metrics.max(1.0),
            c * 1e9 / (feeds.len().max(1) as f64),
            c / secs * 100.0
        );
        say!(
            out,
            "  median of {} runs: processor {} ms, wall {} ms (runs, processor ms: {})",
            a.runs,
            ms(median(cpu.clone())),
            ms(median(wall)),
            cpu.iter().map(|d| ms(*d)).collect::<Vec<_>>().join(" ")
        );
        say!(
            out,
            "  births (NBIRTH and {} DBIRTH): {:.2} MB of payload; the node made and born in {} ms of processor time (median)",
            births.other.saturating_sub(1),
            births.payload_bytes as f64 / 1e6,
            ms(median(birth_cpu))
        );
    }
    say!(
        out,
        "\n(the node's side only: the MQTT client's queue and socket writes and the bus tasks are not included)"
    );
    Ok(())
}
