//! Fault injection (the generator itself is tested in drive-core).

use std::time::Duration;

use drive_sim::{FaultInjector, Instant, Response};

#[test]
fn drop_probability_is_roughly_honoured_and_reproducible() {
    let run = |seed| {
        let mut inj = FaultInjector::new(seed);
        inj.set_drop_probability(0.25);
        (0..10_000)
            .map(|_| inj.should_respond(Instant::ZERO))
            .collect::<Vec<_>>()
    };
    let a = run(7);
    assert_eq!(a, run(7));
    assert_ne!(a, run(8));
    let drops = a.iter().filter(|r| **r == Response::Drop).count();
    assert!((2200..2800).contains(&drops), "{drops} drops");
}

#[test]
fn probabilities_are_clamped() {
    let mut inj = FaultInjector::default();
    inj.set_drop_probability(f64::NAN);
    assert_eq!(inj.drop_probability(), 0.0);
    inj.set_drop_probability(7.0);
    assert_eq!(inj.drop_probability(), 1.0);
    inj.set_drop_probability(-1.0);
    assert_eq!(inj.drop_probability(), 0.0);
}

#[test]
fn drop_next_counts_down_before_anything_else() {
    let mut inj = FaultInjector::new(1);
    inj.set_response_delay(Duration::from_millis(5));
    inj.drop_next(3);
    assert_eq!(inj.pending_drops(), 3);
    for _ in 0..3 {
        assert_eq!(inj.should_respond(Instant::ZERO), Response::Drop);
    }
    assert_eq!(inj.pending_drops(), 0);
    assert_eq!(
        inj.should_respond(Instant::ZERO),
        Response::After(Duration::from_millis(5))
    );
    inj.reseed(3);
    inj.clear();
    assert_eq!(inj.should_respond(Instant::ZERO), Response::Now);
}
