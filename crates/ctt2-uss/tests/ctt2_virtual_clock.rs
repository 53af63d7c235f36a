//! A CTT2 session over the simulated AS-i link counts the same transfer times on
//! `drive_core::rt::time::VirtualClock` as on tokio's paused clock, for a session beginning on
//! a timer tick and one beginning part-way into it (as `drivectl`'s do).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use ctt2_uss::ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
use ctt2_uss::ctt2::master::{Ctt2Driver, DriverConfig};
use drive_core::rt::time::{self, PAUSE_PHASE, VirtualClock};

/// The time since the session began after each request, in µs.
async fn session(slaves: u8) -> Vec<u128> {
    let t0 = time::now();
    let link = SimulatedLink::new(SimulatedDoubleSlave::default(), slaves).unwrap();
    let mut master = Ctt2Driver::new(link, DriverConfig::default());
    let mut seen = Vec::new();
    master.read_id_object().await.unwrap();
    seen.push(time::elapsed(t0).as_micros());
    master.read_diagnosis().await.unwrap();
    seen.push(time::elapsed(t0).as_micros());
    master.read_id(4).await.unwrap();
    seen.push(time::elapsed(t0).as_micros());
    seen
}

fn on_tokio(phase: Duration, slaves: u8) -> Vec<u128> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    rt.block_on(async {
        tokio::time::advance(phase).await;
        session(slaves).await
    })
}

#[test]
fn a_ctt2_session_counts_the_same_times_on_the_virtual_clock_as_on_tokios_paused_one() {
    for phase in [Duration::ZERO, PAUSE_PHASE] {
        for slaves in [2, 31] {
            let tokio = on_tokio(phase, slaves);
            let virt = VirtualClock::with_phase(phase)
                .run(session(slaves))
                .unwrap();
            assert_eq!(virt, tokio, "phase {phase:?}, {slaves} slaves");
        }
    }
}
