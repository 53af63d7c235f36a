//! The sans-IO SBus master against the minimal sans-IO responder of the tests, in a loop
//! without tokio or a bus: one parameter read = request encoded and handed out, decoded and
//! answered by the responder, the answer decoded, matched and reported. Reads per second =
//! 1 / median. The same loop runs against the simulated MOVIDRIVE (`sbus_can::sim`: the
//! drive-sim model with its parameter table, the SBus slave front-end), the figure the issue
//! asks for (≥ 1 000 000 reads/s of the state machines).

// Bench code: setup failures panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "../tests/common/responder.rs"]
mod responder;

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use drive_core::Instant;
use drive_core::can::CanEndpoint;
use drive_profile::sew::ParamChannel;
use sbus_can::Address;
use sbus_can::master::{Answer, Handshake, MasterConfig, MasterEvent, SbusMaster};
use sbus_can::sim::SimulatedSbusDrive;

/// One parameter read of `m` from `d` at `t`, through both state machines.
fn read_once(
    m: &mut SbusMaster,
    d: &mut impl CanEndpoint,
    address: Address,
    hs: Handshake,
    t: &mut Instant,
) -> u32 {
    *t = t.add_nanos(1000);
    m.param(address, black_box(ParamChannel::read(8318)), hs, *t)
        .unwrap();
    loop {
        while let Some(f) = m.poll_transmit(*t) {
            d.handle_frame(&f, *t);
        }
        d.handle_timeout(*t);
        while let Some(f) = d.poll_transmit(*t) {
            m.handle_frame(&f, *t);
        }
        if let Some(MasterEvent::Done(r)) = m.poll_event() {
            match r {
                Ok(Answer::Param(ch)) => break black_box(ch.data),
                other => panic!("{other:?}"),
            }
        }
        // Sync mode: on to the SYNC (1 ms after the request), or the drive's own deadline.
        let next = [m.poll_timeout(), d.poll_timeout()]
            .into_iter()
            .flatten()
            .min()
            .unwrap();
        *t = next.later(*t);
        m.handle_timeout(*t);
    }
}

fn reads(c: &mut Criterion) {
    let mut g = c.benchmark_group("master");
    let address = Address::new(1).unwrap();
    for hs in [Handshake::Async, Handshake::Sync] {
        let name = match hs {
            Handshake::Async => "param_read_async",
            Handshake::Sync => "param_read_sync_mode",
        };
        let mut m = SbusMaster::new(MasterConfig::default());
        let mut d = responder::Responder::new(1);
        let mut t = Instant::ZERO;
        g.bench_function(name, |b| {
            b.iter(|| {
                t = t.add_nanos(1000);
                m.param(address, black_box(ParamChannel::read(8318)), hs, t)
                    .unwrap();
                loop {
                    while let Some(f) = m.poll_transmit(t) {
                        d.handle_frame(&f, t);
                    }
                    while let Some(f) = d.poll_transmit(t) {
                        m.handle_frame(&f, t);
                    }
                    if let Some(MasterEvent::Done(Ok(Answer::Param(ch)))) = m.poll_event() {
                        break black_box(ch.data);
                    }
                    // Sync mode: on to the SYNC (1 ms after the request).
                    t = m.poll_timeout().unwrap();
                    m.handle_timeout(t);
                }
            });
        });
    }
    g.finish();
}

fn reads_from_the_simulated_movidrive(c: &mut Criterion) {
    let mut g = c.benchmark_group("master_sim");
    let address = Address::new(1).unwrap();
    for (name, hs) in [
        ("param_read_async", Handshake::Async),
        ("param_read_sync_mode", Handshake::Sync),
    ] {
        let mut m = SbusMaster::new(MasterConfig::default());
        let mut d = SimulatedSbusDrive::new(1);
        let mut t = Instant::ZERO;
        // The answer is the drive's P000 speed, 0 at standstill: check it once.
        assert_eq!(read_once(&mut m, &mut d, address, hs, &mut t), 0);
        g.bench_function(name, |b| {
            b.iter(|| read_once(&mut m, &mut d, address, hs, &mut t));
        });
    }
    g.finish();
}

criterion_group!(benches, reads, reads_from_the_simulated_movidrive);
criterion_main!(benches);
