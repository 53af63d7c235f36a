//! The tokio master driver against a sans-IO drive served by `drive_core::rt::serve`.
//!
//! `modbus_driver/fc3_read_untimed_virtual`: FC 3 reads through [`ModbusDriver`] over the
//! untimed in-memory link of drive-transport (characters delivered at once), both sides on
//! `Clock::Virtual`: software overhead only (driver, sans-IO master and slave, the serve loop,
//! two tokio tasks). Throughput in reads/s = 1 / median; target ≥ 50 000 reads/s.
//!
//! The wire timing of a read cycle on the 19200-baud line is measured exactly on tokio's paused
//! clock by a test (`tests/faults.rs`, `fc3_read_cycle_against_the_manuals_bound`),
//! not here.

#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::Instant;

use bonfiglioli_modbus::driver::{Clock, DriverConfig, ModbusDriver};
use bonfiglioli_modbus::frame::{Address, DataSet};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::{Slave, SlaveConfig, Width};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use drive_core::LineSettings;
use drive_core::rt::{Timebase, serve};
use drive_transport::link::{self, LinkConfig};

#[path = "common/bus.rs"]
mod bus;

fn untimed_reads(c: &mut Criterion) {
    let Ok(rt) = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
    else {
        return;
    };
    let line = LineSettings::new(19200);
    let drive = Address::new(1).unwrap();
    let mut driver = rt.block_on(async {
        let (port, wire) = link::pair(LinkConfig {
            timing: false,
            ..LinkConfig::from_line(line)
        });
        let mut drives = [Slave::new(
            SlaveConfig::new(drive, Mode::Rtu, line),
            bus::Trivial::default(),
        )];
        tokio::spawn(async move {
            let mut time = Timebase::new(Clock::Virtual, line.char_time());
            let _ = serve(&mut drives, &mut time, wire).await;
        });
        ModbusDriver::new(
            port,
            DriverConfig {
                clock: Clock::Virtual,
                ..DriverConfig::new(Mode::Rtu, line)
            },
        )
    });
    let expected = u32::from(0x0174u16) * 3 + 1;
    let mut g = c.benchmark_group("modbus_driver");
    g.throughput(Throughput::Elements(1));
    g.bench_function("fc3_read_untimed_virtual", |bench| {
        bench.iter_custom(|iters| {
            rt.block_on(async {
                let start = Instant::now();
                for _ in 0..iters {
                    let v = driver.read(drive, 372, DataSet::ALL, Width::Word).await;
                    assert_eq!(v.ok(), Some(expected));
                }
                start.elapsed()
            })
        });
    });
    g.finish();
    let s = driver.stats();
    println!(
        "modbus_driver/fc3_read_untimed_virtual: {} transactions, {} retries, {} timeouts",
        s.transactions, s.retries, s.timeouts
    );
}

criterion_group!(benches, untimed_reads);
criterion_main!(benches);
