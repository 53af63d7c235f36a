//! Codec and state machine benchmarks.
//!
//! * `movilink_codec`: encode / decode of an 18-byte PARAM + 3PD telegram (target ≤ 25 ns each),
//! * `movilink_exchange`: a master and a drive exchanging the bytes of an acyclic parameter
//!   read in memory, character by character (target ≥ 1 000 000 reads/s).

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use movilink::{
    Address, MasterConfig, MasterEvent, MovilinkMaster, ParamChannel, PduType, Slave, SlaveConfig,
    Telegram,
};

#[path = "../tests/protocol/bus.rs"]
mod bus;

fn telegram() -> Telegram {
    Telegram::request(
        Address::new(1).unwrap_or(Address::BROADCAST),
        PduType::PARAM_3PD,
    )
    .with_param(ParamChannel::write(8471, 3000).with_handshake(true))
    .with_process_data(&[0x0006, 0x2000, 0x0BB8])
}

fn codec(c: &mut Criterion) {
    let mut g = c.benchmark_group("movilink_codec");
    let t = telegram();
    let mut buf = [0u8; 18];
    let n = movilink::encode(&t, &mut buf).unwrap_or(0);
    assert_eq!(n, 18);
    g.throughput(Throughput::Elements(1));
    g.bench_function("encode_param_3pd", |b| {
        let mut out = [0u8; 18];
        b.iter(|| movilink::encode(black_box(&t), black_box(&mut out)))
    });
    g.bench_function("decode_param_3pd", |b| {
        b.iter(|| movilink::decode(black_box(&buf)))
    });
    g.finish();
}

fn exchange(c: &mut Criterion) {
    let mut g = c.benchmark_group("movilink_exchange");
    g.throughput(Throughput::Elements(1));
    let drive = Address::new(1).unwrap_or(Address::BROADCAST);
    let mut bus = bus::Bus::new(
        MovilinkMaster::new(MasterConfig::default()),
        Slave::new(SlaveConfig::new(drive), bus::TestDrive::default()),
    );
    let req =
        Telegram::request(drive, PduType::PARAM_0PD_ACYCLIC).with_param(ParamChannel::read(8318));
    g.bench_function("param_read_master_slave", |b| {
        b.iter(|| {
            let now = bus.now;
            let _ = bus.master.send(black_box(req), now);
            let mut value = None;
            bus.run(|e| {
                if let MasterEvent::ParamDone(r) = e {
                    value = Some(r);
                }
            });
            while bus.slave.poll_event().is_some() {}
            black_box(value)
        })
    });
    g.finish();
}

criterion_group!(benches, codec, exchange);
criterion_main!(benches);
