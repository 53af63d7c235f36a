//! The sans-IO SBus master against the minimal sans-IO responder of the tests, in a loop
//! without tokio or a bus: one parameter read = request encoded and handed out, decoded and
//! answered by the responder, the answer decoded, matched and reported. Reads per second =
//! 1 / median. (At integration the same loop runs against the simulated MOVIDRIVE.)

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
use sbus_can::master::{Answer, Handshake, Master, MasterConfig, MasterEvent};

fn reads(c: &mut Criterion) {
    let mut g = c.benchmark_group("master");
    let address = Address::new(1).unwrap();
    for hs in [Handshake::Async, Handshake::Sync] {
        let name = match hs {
            Handshake::Async => "param_read_async",
            Handshake::Sync => "param_read_sync_mode",
        };
        let mut m = Master::new(MasterConfig::default());
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

criterion_group!(benches, reads);
criterion_main!(benches);
