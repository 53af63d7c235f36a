//! Benchmarks of the async master driver with a simulated drive on the other end.
//!
//! 1. `driver/read_untimed_duplex`: parameter reads through the tokio driver over an in-memory
//!    `tokio::io::duplex` (wrapped in `Stream`), `Clock::Virtual`: software overhead only
//!    (driver, sans-IO master and slave, simulated drive, two tokio tasks). Throughput in
//!    reads/s = 1 / median.
//! 2. `driver/cyclic_param_3pd_9600_virtual`: one cyclic PARAM+3PD exchange on the 9600-baud
//!    wire model on tokio's paused clock, `Clock::Real`. `iter_custom` returns *virtual*
//!    durations: the leading start pause + request start → response end (exact wire times),
//!    to compare with the bound (18 + 18) × 11 / 9600 s + 2 × 3.44 ms = 48.13 ms.

use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use drive_transport::link::{self, LinkConfig};
use movilink::driver::{Clock, DriverConfig, MovilinkDriver, ParamServices, Stream};
use movilink::sim::SimulatedMovidrive;
use movilink::{Address, ParamChannel, PduType, Telegram};

fn untimed_reads(c: &mut Criterion) {
    let Ok(rt) = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
    else {
        return;
    };
    let (a, b) = tokio::io::duplex(4096);
    let mut sim = SimulatedMovidrive::new(1);
    sim.set_clock(Clock::Virtual);
    rt.spawn(async move { sim.serve(Stream(b)).await });
    let config = DriverConfig {
        clock: Clock::Virtual,
        ..DriverConfig::default()
    };
    let mut driver = MovilinkDriver::new(Stream(a), config);
    let Some(drive) = Address::new(1) else { return };
    let mut g = c.benchmark_group("driver");
    g.bench_function("read_untimed_duplex", |bench| {
        bench.iter_custom(|iters| {
            rt.block_on(async {
                let start = Instant::now();
                for _ in 0..iters {
                    let v = driver.read(drive, 8470).await;
                    assert_eq!(v.ok(), Some(2000));
                }
                start.elapsed()
            })
        });
    });
    let s = driver.stats();
    println!(
        "driver/read_untimed_duplex: {} transactions, {} retries, {} timeouts",
        s.transactions, s.retries, s.timeouts
    );
    g.finish();
}

fn cyclic_virtual(c: &mut Criterion) {
    let Ok(rt) = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
    else {
        return;
    };
    let Some(drive) = Address::new(1) else { return };
    let mut driver = rt.block_on(async {
        let (port, wire) = link::pair(LinkConfig::new(9600));
        let mut sim = SimulatedMovidrive::new(1);
        tokio::spawn(async move { sim.serve(wire).await });
        MovilinkDriver::new(port, DriverConfig::default())
    });
    let request = Telegram::request(drive, PduType::PARAM_3PD)
        .with_param(ParamChannel::no_service())
        .with_process_data(&[0x0006, 0, 0]);
    let start_pause = movilink::timing::START_PAUSE;
    let bound = Duration::from_secs_f64(36.0 * 11.0 / 9600.0) + start_pause * 2;
    let mut last = Duration::ZERO;
    let mut g = c.benchmark_group("driver");
    g.bench_function("cyclic_param_3pd_9600_virtual", |bench| {
        bench.iter_custom(|iters| {
            rt.block_on(async {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let ok = driver.exchange(request).await.is_ok();
                    assert!(ok);
                    let t = driver
                        .last_timing()
                        .map_or(Duration::ZERO, |t| t.duration());
                    last = start_pause + t;
                    total += last;
                }
                total
            })
        });
    });
    g.finish();
    println!(
        "driver/cyclic_param_3pd_9600_virtual: {:.3} ms virtual per exchange, bound {:.3} ms, {:+.2} %",
        last.as_secs_f64() * 1e3,
        bound.as_secs_f64() * 1e3,
        (last.as_secs_f64() / bound.as_secs_f64() - 1.0) * 100.0
    );
}

criterion_group!(benches, untimed_reads, cyclic_virtual);
criterion_main!(benches);
