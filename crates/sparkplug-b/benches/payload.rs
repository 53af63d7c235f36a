//! Encode and decode of the gateway's DDATA messages (1 and 8 metrics: alias, timestamp, Int16
//! or Double value), one criterion group. `cargo bench -p sparkplug-b`.
#![allow(clippy::expect_used)]

#[path = "../tests/support/ddata.rs"]
mod support;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sparkplug_b::{decode, encode_into};
use std::hint::black_box;

fn payload(c: &mut Criterion) {
    let mut group = c.benchmark_group("payload");
    for n in [1usize, 8] {
        let p = support::ddata(n, 17);
        let mut buf = Vec::new();
        encode_into(&p, &mut buf);
        group.throughput(Throughput::Elements(n as u64));
        let mut out = Vec::with_capacity(buf.len());
        group.bench_with_input(BenchmarkId::new("encode_ddata", n), &p, |b, p| {
            b.iter(|| {
                encode_into(black_box(p), &mut out);
                black_box(out.len())
            })
        });
        group.bench_with_input(BenchmarkId::new("decode_ddata", n), &buf, |b, bytes| {
            b.iter(|| decode(black_box(bytes)).map(|p| p.metrics.len()))
        });
    }
    group.finish();
}

criterion_group!(benches, payload);
criterion_main!(benches);
