//! Software overhead of the in-memory link (timing off): bytes per second through a pair of
//! ends, plain bytes and parity-flagged characters, with and without fault injection.
//!
//! Run with `cargo bench -p drive-transport`.

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

use drive_transport::link::{self, FaultConfig, LinkConfig, WireChar};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const TOTAL: usize = 256 << 10;
const CHUNK: usize = 256;

async fn transfer(config: LinkConfig, chars: bool) -> usize {
    let (mut a, mut b) = link::pair(config);
    let writer = tokio::spawn(async move {
        let chunk = [0x5Au8; CHUNK];
        for _ in 0..TOTAL / CHUNK {
            a.write_all(&chunk).await.expect("write");
        }
    });
    let mut received = 0;
    let mut bytes = [0u8; CHUNK];
    let mut wire = [WireChar::new(0); CHUNK];
    loop {
        let n = if chars {
            b.read_chars(&mut wire).await.expect("read")
        } else {
            b.read(&mut bytes).await.expect("read")
        };
        if n == 0 {
            break;
        }
        received += n;
        black_box((&bytes, &wire));
    }
    writer.await.expect("writer task");
    received
}

fn link(c: &mut Criterion) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .expect("runtime");
    let cases = [
        ("untimed_async_read", LinkConfig::untimed(), false),
        ("untimed_read_chars", LinkConfig::untimed(), true),
        (
            "untimed_1pct_drop_insert_flip",
            LinkConfig::untimed().with_faults(FaultConfig {
                drop: 0.01,
                insert: 0.01,
                flip: 0.01,
                ..FaultConfig::none()
            }),
            true,
        ),
    ];
    let mut g = c.benchmark_group("link");
    g.throughput(Throughput::Bytes(TOTAL as u64));
    for (name, config, chars) in cases {
        g.bench_function(name, |b| {
            b.iter(|| {
                let n = rt.block_on(transfer(config, chars));
                assert!(n > TOTAL / 2);
                n
            })
        });
    }
    g.finish();
}

criterion_group!(benches, link);
criterion_main!(benches);
