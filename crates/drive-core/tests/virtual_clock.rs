//! `rt::time::VirtualClock` advances as tokio's paused clock does: the same timers (sleeps of
//! whole and part ticks, a deadline in the past, a reset, two tasks, timeouts, an interval
//! with a late tick) end at the same times on both, for sessions beginning on a tick and
//! part-way into one.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use std::pin::Pin;
use std::time::Duration;

use drive_core::rt::time::{self, MissedTickBehavior, PAUSE_PHASE, VirtualClock};

const US: Duration = Duration::from_micros(1);

/// When each timer ended, in µs since the probe began.
async fn probe() -> Vec<u128> {
    let t0 = time::now();
    let mut seen = Vec::new();
    let at = |seen: &mut Vec<u128>| seen.push(time::elapsed(t0).as_micros());
    for us in [300, 1000, 1500, 2000, 9856, 0, 999, 1001] {
        time::sleep(US * us).await;
        at(&mut seen);
    }
    time::sleep_until(t0).await;
    at(&mut seen);
    let mut s = time::sleep(Duration::from_millis(10));
    Pin::new(&mut s).reset(time::now() + US * 2500);
    s.await;
    at(&mut seen);
    let task = tokio::spawn(async move {
        time::sleep(US * 3700).await;
        time::elapsed(t0).as_micros()
    });
    time::sleep(US * 1200).await;
    at(&mut seen);
    seen.push(task.await.unwrap());
    at(&mut seen);
    let late = time::timeout(US * 4200, time::sleep(Duration::from_millis(50))).await;
    assert!(late.is_err());
    at(&mut seen);
    let early = time::timeout(Duration::from_millis(50), time::sleep(US * 700)).await;
    assert!(early.is_ok());
    at(&mut seen);
    let mut ticker = time::interval(US * 2300);
    ticker.set_missed_tick_behavior(MissedTickBehavior::Skip);
    for i in 0..6 {
        ticker.tick().await;
        at(&mut seen);
        if i == 2 {
            time::sleep(Duration::from_millis(12)).await;
        }
    }
    seen
}

/// `probe` on tokio's paused clock, the session beginning `phase` after the first tick.
fn on_tokio(phase: Duration) -> Vec<u128> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    rt.block_on(async {
        tokio::time::advance(phase).await;
        probe().await
    })
}

#[test]
fn the_virtual_clock_ends_timers_where_tokios_paused_clock_does() {
    for phase in [Duration::ZERO, PAUSE_PHASE, US * 500, US * 999] {
        let tokio = on_tokio(phase);
        let virt = VirtualClock::with_phase(phase).run(probe()).unwrap();
        assert_eq!(virt, tokio, "phase {phase:?}");
    }
    assert_eq!(
        VirtualClock::new().run(probe()).unwrap(),
        on_tokio(Duration::ZERO)
    );
}

#[test]
fn outside_a_virtual_clock_the_timers_are_tokios() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    rt.block_on(async {
        let t0 = tokio::time::Instant::now();
        time::sleep(Duration::from_millis(7)).await;
        assert_eq!(time::now(), tokio::time::Instant::now());
        assert!(t0.elapsed() >= Duration::from_millis(7));
    });
}

#[test]
fn a_virtual_session_takes_no_real_time() {
    let real = std::time::Instant::now();
    let virt = VirtualClock::new()
        .run(async {
            let t0 = time::now();
            time::sleep(Duration::from_secs(3600)).await;
            time::elapsed(t0)
        })
        .unwrap();
    assert_eq!(virt, Duration::from_secs(3600));
    assert!(real.elapsed() < Duration::from_secs(60));
}
