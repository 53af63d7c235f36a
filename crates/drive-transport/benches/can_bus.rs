//! Software overhead of the virtual CAN bus: frames per second between two nodes in untimed
//! mode (frames are delivered when sent: no frame times, no arbitration waits), one sender
//! task and one receiver task on a current-thread runtime.
//!
//! Run with `cargo bench -p drive-transport --bench can_bus`.

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use drive_core::can::CanFrame;
use drive_core::rt::{recv_frame, send_frame};
use drive_transport::can::{BusConfig, BusFaults, VirtualBus};

const FRAMES: u64 = 100_000;

async fn transfer(config: BusConfig) -> u64 {
    let bus = VirtualBus::with_config(BusConfig {
        // Room for every frame: the sender never waits for the reader.
        rx_capacity: 1024,
        ..config
    });
    let (mut a, mut b) = (bus.node(), bus.node());
    drop(bus);
    let frame = CanFrame::standard(0x10B, &[0, 6, 0x13, 0x88, 0, 0, 0, 0]).unwrap();
    let sender = tokio::spawn(async move {
        for i in 0..FRAMES {
            send_frame(&mut a, &frame).await.unwrap();
            if i % 512 == 511 {
                tokio::task::yield_now().await;
            }
        }
        // Dropping the sender (the bus handle is gone already) ends the bus for the reader.
        drop(a);
    });
    let mut received = 0;
    while let Ok(f) = recv_frame(&mut b).await {
        black_box(f);
        received += 1;
    }
    sender.await.unwrap();
    received
}

fn virtual_bus(c: &mut Criterion) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .expect("runtime");
    let mut g = c.benchmark_group("can_virtual_bus");
    g.throughput(Throughput::Elements(FRAMES));
    g.sample_size(20);
    let cases = [
        ("untimed_two_nodes", BusConfig::untimed()),
        (
            "untimed_two_nodes_1pct_drop_corrupt",
            BusConfig::untimed().with_faults(BusFaults {
                drop: 0.01,
                corrupt: 0.01,
                ..BusFaults::none()
            }),
        ),
    ];
    for (name, config) in cases {
        g.bench_function(name, |b| {
            b.iter(|| {
                let n = rt.block_on(transfer(config));
                assert!(n > FRAMES / 2);
                n
            })
        });
    }
    g.finish();
}

criterion_group!(benches, virtual_bus);
criterion_main!(benches);
