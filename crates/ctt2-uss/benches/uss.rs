//! USS serial benchmarks (docs/benchmarks.md):
//!
//! * `uss_codec`: encode and decode (STX, LGE against the layout, BCC, words) of the typical
//!   telegram, 4 PKW words and 2 PZD words (16 bytes); target ≤ 25 ns each;
//! * `uss_exchange`: the sans-IO master and one slave exchanging a PKW read character by
//!   character in memory, through both receivers, with wire timestamps and an instant backend
//!   (`tests/uss_common/bus.rs`); target ≥ 1 000 000 reads/s.
//!
//! Instruction counts under callgrind: the same binary runs one operation `n` times when given
//! `callgrind OP N`, so that (count(N) − count(0)) / N is the cost of one operation, exactly
//! and repeatably on a noisy machine:
//!
//! ```text
//! cargo bench -p ctt2-uss --bench uss --no-run
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null target/release/deps/uss-* callgrind OP N
//! ```
//!
//! with OP one of `encode`, `decode`, `exchange`.

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    missing_docs
)]

use std::hint::black_box;

use criterion::{Criterion, Throughput};
use ctt2_uss::serial::master::{MasterConfig, MasterEvent, UssMaster};
use ctt2_uss::serial::slave::{Backend, Slave, SlaveConfig};
use ctt2_uss::serial::telegram::{Adr, Layout, MAX_TELEGRAM, Telegram, UssAddress};
use ctt2_uss::uss::DriveError;
use ctt2_uss::uss::pkw::{Ind, Order, Pkw, Reply};
use drive_core::LineSettings;

#[path = "../tests/uss_common/bus.rs"]
mod bus;

/// The simulated NORDAC LINK (`drive_sim::nord::SimulatedNord`) as the slave's backend: the
/// same model and order mapping (`ctt2_uss::sim::execute`) as `drivectl sim uss`, without its
/// PKW processing time.
#[derive(Debug)]
struct Model(drive_sim::nord::SimulatedNord);

impl Backend for Model {
    fn execute(&mut self, order: &Pkw, now: drive_core::Instant) -> Pkw {
        let reply = match Order::from_pkw(order) {
            Ok(o) => ctt2_uss::sim::execute(&mut self.0, &o, now),
            Err(_) => Reply::Error(DriveError(201)),
        };
        reply.to_pkw(order.pke.pnu(), order.ind)
    }

    fn process(&mut self, request: &[u16], answer: &mut [u16], now: drive_core::Instant) {
        if let Some((&control, setpoints)) = request.split_first() {
            self.0.process(control, setpoints, now);
        }
        let words = core::iter::once(self.0.status_word()).chain(self.0.actual_values());
        for (a, w) in answer.iter_mut().zip(words) {
            *a = w;
        }
    }
}

impl drive_core::Timers for Model {}

fn model_bus() -> bus::Bus<Model> {
    let line = LineSettings::new(19200);
    let a = UssAddress::new(7).unwrap();
    bus::Bus::new(
        UssMaster::new(MasterConfig::new(line)),
        vec![Slave::new(
            SlaveConfig::new(a, Layout::PKW4_PZD2, line),
            Model(drive_sim::nord::SimulatedNord::new()),
        )],
    )
}

fn telegram() -> Telegram {
    let order = Order::read(102, Ind::new(0, 2).unwrap()).unwrap().to_pkw();
    Telegram::new(
        Adr::new(UssAddress::new(7).unwrap()),
        Layout::PKW4_PZD2,
        order,
        &[0x047F, 0x2000],
    )
    .unwrap()
}

fn new_bus() -> bus::Bus<bus::Store> {
    let line = LineSettings::new(19200);
    let a = UssAddress::new(7).unwrap();
    bus::Bus::new(
        UssMaster::new(MasterConfig::new(line)),
        vec![Slave::new(
            SlaveConfig::new(a, Layout::PKW4_PZD2, line),
            bus::Store::default(),
        )],
    )
}

/// One read through master and slave; the value read.
#[inline]
fn read<B: Backend>(bus: &mut bus::Bus<B>, t: Telegram) -> Option<u16> {
    let now = bus.now;
    let _ = bus.master.send(black_box(t), now);
    let mut value = None;
    let settled = bus.run(|e| {
        if let MasterEvent::Response(a) = e {
            value = a.pkw().map(|p| p.pwe2);
        }
    });
    settled.then_some(value).flatten()
}

fn codec(c: &mut Criterion) {
    let t = telegram();
    let mut wire = [0u8; MAX_TELEGRAM];
    let n = t.encode(&mut wire).unwrap();
    assert_eq!(n, 16);
    assert_eq!(Telegram::decode(&wire[..n], Layout::PKW4_PZD2), Ok(t));
    let mut g = c.benchmark_group("uss_codec");
    g.bench_function("encode_pkw4_pzd2", |b| {
        let mut out = [0u8; MAX_TELEGRAM];
        b.iter(|| black_box(t).encode(black_box(&mut out)))
    });
    g.bench_function("decode_pkw4_pzd2", |b| {
        b.iter(|| Telegram::decode(black_box(&wire[..n]), black_box(Layout::PKW4_PZD2)))
    });
    g.finish();
}

fn exchange(c: &mut Criterion) {
    let mut bus = new_bus();
    let t = telegram();
    // P102 in parameter set 3 (IND 0200h) of the test store: 102 × 3 + 512.
    assert_eq!(read(&mut bus, t), Some(818));
    let mut g = c.benchmark_group("uss_exchange");
    g.throughput(Throughput::Elements(1));
    g.bench_function("pkw_read_master_slave", |b| b.iter(|| read(&mut bus, t)));
    // The same against the simulated drive: P102 in parameter set 3 reads 200 (2.00 s).
    let mut model = model_bus();
    assert_eq!(read(&mut model, t), Some(200));
    g.bench_function("pkw_read_master_simulated_nord", |b| {
        b.iter(|| read(&mut model, t))
    });
    g.finish();
}

fn callgrind(op: &str, n: u64) {
    let t = telegram();
    let mut wire = [0u8; MAX_TELEGRAM];
    let len = t.encode(&mut wire).unwrap();
    let mut acc = 0u64;
    match op {
        "encode" => {
            let mut out = [0u8; MAX_TELEGRAM];
            for _ in 0..n {
                acc += black_box(t).encode(&mut out).unwrap_or(0) as u64;
            }
        }
        "decode" => {
            for _ in 0..n {
                acc += Telegram::decode(black_box(&wire[..len]), Layout::PKW4_PZD2)
                    .map_or(0, |t| u64::from(t.pzd()[0]));
            }
        }
        "exchange" => {
            let mut bus = new_bus();
            for _ in 0..n {
                acc += u64::from(read(&mut bus, t).unwrap_or(0));
            }
        }
        _ => {
            eprintln!("usage: uss callgrind OP N, OP one of encode, decode, exchange");
            return;
        }
    }
    black_box(acc);
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("callgrind") {
        let op = args.get(1).cloned().unwrap_or_default();
        let n = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
        callgrind(&op, n);
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    codec(&mut c);
    exchange(&mut c);
    c.final_summary();
}
