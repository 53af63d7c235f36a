//! CTT2 codec and double-slave benchmarks:
//!
//! * `ctt2_codec/encode_pkw_write` and `decode_pkw_write`: the NORD write of example 5.1.3's
//!   order on the PKW channel without address (`19 47 8` + 8 PKW bytes), including building
//!   the channel data from the `Pkw` and reading it back (target ≤ 25 ns each);
//! * `ctt2_codec/encode_pzd_answer` and `decode_pzd_answer`: a NORD read answer of the PZD
//!   channel (`82`, address, ZSW, IW1–IW3) to and from `PzdIn` (target ≤ 25 ns each);
//! * `ctt2_loop/pkw_read`: one PKW read as a master does it over the sans-IO double slave with
//!   an instant backend: request encode, `handle_request`, `poll_answer`, answer encode, answer
//!   decode, PKW out of the data (target ≥ 1 000 000 reads/s, i.e. ≤ 1 µs each).
//!
//! On a busy machine the times jitter; the instruction counts do not. With `CTT2_CALLGRIND=OP,N`
//! the binary runs operation OP (a benchmark name without the group, or `noop` for the loop
//! itself) N times and exits, for
//! `valgrind --tool=callgrind` ((count(N) − count(0)) / N is one operation):
//!
//! ```text
//! cargo bench -p ctt2-uss --bench ctt2 --no-run
//! CTT2_CALLGRIND=decode_pzd_answer,100000 valgrind --tool=callgrind \
//!     --callgrind-out-file=/dev/null target/release/deps/ctt2-*
//! ```

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    missing_docs
)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group};
use ctt2_uss::ctt2::link::SimulatedDoubleSlave;
use ctt2_uss::ctt2::{
    Backend, Channel, Data, DiagnosisCode, DiagnosisObject, DoubleSlave, IdObject, MAX_REQUEST,
    MAX_RESPONSE, Request, Response, SlaveConfig,
};
use ctt2_uss::uss::{Ind, Order, Pkw, Plausibility, PzdIn, PzdOut, Reply, Storage};
use drive_core::Instant;
use drive_profile::nord::{Ctt2MessageType, StatusWord, Width};
use drive_sim::nord::SimulatedNord;

/// A drive that answers at once.
struct Instantly;

impl Backend for Instantly {
    fn id_object(&mut self, _now: Instant) -> IdObject {
        IdObject::default()
    }

    fn diagnosis(&mut self, _now: Instant) -> DiagnosisObject {
        DiagnosisObject::new(DiagnosisCode::NoFault, 0, 45)
    }

    fn process(&mut self, _out: PzdOut, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B37), &[0x2000, 0, 0])
    }

    fn process_data(&mut self, _now: Instant) -> PzdIn {
        PzdIn::new(StatusWord(0x0B37), &[0x2000, 0, 0])
    }

    fn execute(&mut self, order: Order, _now: Instant) -> Reply {
        Reply::Value {
            width: Width::Word,
            array: true,
            value: i32::from(order.ind().0),
        }
    }
}

fn order() -> Pkw {
    Order::write(
        0x66,
        Ind::new(0, 2).unwrap(),
        Width::Word,
        true,
        Storage::Eeprom,
        1000,
    )
    .unwrap()
    .to_pkw()
}

fn codec(c: &mut Criterion) {
    let mut g = c.benchmark_group("ctt2_codec");
    g.throughput(Throughput::Elements(1));
    let pkw = order();
    let mut buf = [0u8; MAX_REQUEST];
    g.bench_function("encode_pkw_write", |b| {
        b.iter(|| {
            let r = Request::NordWrite {
                index: Channel::Pkw,
                data: Data::from_pkw(Channel::Pkw, black_box(&pkw)).unwrap(),
            };
            black_box(r.encode(&mut buf).unwrap())
        })
    });
    let n = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &pkw).unwrap(),
    }
    .encode(&mut buf)
    .unwrap();
    let wire = buf;
    g.bench_function("decode_pkw_write", |b| {
        b.iter(|| {
            let Request::NordWrite { index, data } =
                Request::decode(black_box(&wire[..n])).unwrap()
            else {
                panic!()
            };
            black_box(data.to_pkw(index).unwrap())
        })
    });
    let pzd = PzdIn::new(StatusWord(0x0B37), &[0x2000, 0x1234, 0xFFFF]);
    let mut out = [0u8; MAX_RESPONSE];
    g.bench_function("encode_pzd_answer", |b| {
        b.iter(|| {
            let r = Response::Ok {
                kind: Ctt2MessageType::NordRead,
                data: Data::from_pzd_in(black_box(&pzd)),
            };
            black_box(r.encode(&mut out).unwrap())
        })
    });
    let m = Response::Ok {
        kind: Ctt2MessageType::NordRead,
        data: Data::from_pzd_in(&pzd),
    }
    .encode(&mut out)
    .unwrap();
    let answer = out;
    g.bench_function("decode_pzd_answer", |b| {
        b.iter(|| {
            let Response::Ok { data, .. } = Response::decode(black_box(&answer[..m])).unwrap()
            else {
                panic!()
            };
            black_box(data.to_pzd_in().unwrap())
        })
    });
    g.finish();
}

fn exchange(c: &mut Criterion) {
    let mut g = c.benchmark_group("ctt2_loop");
    g.throughput(Throughput::Elements(1));
    let mut slave = DoubleSlave::new(Instantly, SlaveConfig::default());
    // One order first, so that reads return a value.
    let mut req = [0u8; MAX_REQUEST];
    let n = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &order()).unwrap(),
    }
    .encode(&mut req)
    .unwrap();
    slave.handle_request(&req[..n], Instant::ZERO);
    assert!(slave.poll_answer(Instant::ZERO).is_some());
    let read = Request::NordRead {
        index: Channel::Pkw,
        len: 8,
    };
    let mut t = 0u64;
    g.bench_function("pkw_read", |b| {
        b.iter(|| {
            t += 1_000_000;
            let now = Instant::from_nanos(t);
            let mut req = [0u8; MAX_REQUEST];
            let n = black_box(&read).encode(&mut req).unwrap();
            slave.handle_request(&req[..n], now);
            let a = slave.poll_answer(now).unwrap();
            let mut wire = [0u8; MAX_RESPONSE];
            let m = a.encode(&mut wire).unwrap();
            let Response::Ok { data, .. } = Response::decode(&wire[..m]).unwrap() else {
                panic!()
            };
            black_box(data.to_pkw(Channel::Pkw).unwrap())
        })
    });

    // A whole PKW read against the simulated NORDAC LINK (the model of `drivectl ctt2 --sim`,
    // no PKW processing time): the order (AK 1, P102 set 3) as a NORD write, then a NORD read
    // of the parameter channel, its answer decoded and checked as the master does.
    let mut model = SimulatedDoubleSlave::new(SimulatedNord::new());
    model.set_pkw_time(core::time::Duration::ZERO);
    let mut slave = DoubleSlave::new(model, SlaveConfig::default());
    let read_order = Order::read(102, Ind::new(0, 2).unwrap()).unwrap();
    let mut write = [0u8; MAX_REQUEST];
    let wn = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &read_order.to_pkw()).unwrap(),
    }
    .encode(&mut write)
    .unwrap();
    let mut t = 0u64;
    let mut order_and_read = |slave: &mut DoubleSlave<SimulatedDoubleSlave>| {
        t += 1_000_000;
        let now = Instant::from_nanos(t);
        slave.handle_request(black_box(&write[..wn]), now);
        slave.poll_answer(now).unwrap();
        let mut req = [0u8; MAX_REQUEST];
        let n = black_box(&read).encode(&mut req).unwrap();
        slave.handle_request(&req[..n], now);
        let a = slave.poll_answer(now).unwrap();
        let mut wire = [0u8; MAX_RESPONSE];
        let m = a.encode(&mut wire).unwrap();
        let Response::Ok { data, .. } = Response::decode(&wire[..m]).unwrap() else {
            panic!()
        };
        read_order.check(&data.to_pkw(Channel::Pkw).unwrap())
    };
    assert_eq!(
        order_and_read(&mut slave),
        Plausibility::Answer(Reply::Value {
            width: Width::Word,
            array: false,
            value: 200
        })
    );
    g.bench_function("pkw_order_and_read_simulated_nord", |b| {
        b.iter(|| black_box(order_and_read(&mut slave)))
    });
    g.finish();
}

/// Run one operation `n` times (for callgrind).
fn callgrind(op: &str, n: u64) {
    let pkw = order();
    let mut buf = [0u8; MAX_REQUEST];
    let write = Request::NordWrite {
        index: Channel::Pkw,
        data: Data::from_pkw(Channel::Pkw, &pkw).unwrap(),
    };
    let wn = write.encode(&mut buf).unwrap();
    let wire = buf;
    let pzd = PzdIn::new(StatusWord(0x0B37), &[0x2000, 0x1234, 0xFFFF]);
    let mut out = [0u8; MAX_RESPONSE];
    let answer = Response::Ok {
        kind: Ctt2MessageType::NordRead,
        data: Data::from_pzd_in(&pzd),
    };
    let an = answer.encode(&mut out).unwrap();
    let ans = out;
    let mut slave = DoubleSlave::new(Instantly, SlaveConfig::default());
    slave.handle_request(&wire[..wn], Instant::ZERO);
    assert!(slave.poll_answer(Instant::ZERO).is_some());
    let mut run: Box<dyn FnMut(u64)> = match op {
        "encode_pkw_write" => Box::new(move |_| {
            let r = Request::NordWrite {
                index: Channel::Pkw,
                data: Data::from_pkw(Channel::Pkw, black_box(&pkw)).unwrap(),
            };
            black_box(r.encode(&mut buf).unwrap());
        }),
        "decode_pkw_write" => Box::new(move |_| {
            let Request::NordWrite { index, data } =
                Request::decode(black_box(&wire[..wn])).unwrap()
            else {
                panic!()
            };
            black_box(data.to_pkw(index).unwrap());
        }),
        "encode_pzd_answer" => Box::new(move |_| {
            let r = Response::Ok {
                kind: Ctt2MessageType::NordRead,
                data: Data::from_pzd_in(black_box(&pzd)),
            };
            black_box(r.encode(&mut out).unwrap());
        }),
        "decode_pzd_answer" => Box::new(move |_| {
            let Response::Ok { data, .. } = Response::decode(black_box(&ans[..an])).unwrap() else {
                panic!()
            };
            black_box(data.to_pzd_in().unwrap());
        }),
        "pkw_read" => Box::new(move |i| {
            let now = Instant::from_nanos((i + 1) * 1_000_000);
            let n = Request::NordRead {
                index: Channel::Pkw,
                len: 8,
            }
            .encode(&mut buf)
            .unwrap();
            slave.handle_request(&buf[..n], now);
            let a = slave.poll_answer(now).unwrap();
            let m = a.encode(&mut out).unwrap();
            let Response::Ok { data, .. } = Response::decode(&out[..m]).unwrap() else {
                panic!()
            };
            black_box(data.to_pkw(Channel::Pkw).unwrap());
        }),
        "noop" => Box::new(|i| {
            black_box(i);
        }),
        other => panic!("unknown operation {other}"),
    };
    for i in 0..n {
        run(i);
    }
}

criterion_group!(benches, codec, exchange);

fn main() {
    if let Ok(spec) = std::env::var("CTT2_CALLGRIND") {
        let (op, n) = spec.split_once(',').unwrap_or((&spec, "1"));
        callgrind(op, n.parse().unwrap());
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
