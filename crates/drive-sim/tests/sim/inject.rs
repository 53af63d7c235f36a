//! Fault injection and the seeded RNG.

use std::time::Duration;

use drive_sim::{FaultInjector, Response, SimTime, SplitMix64};

#[test]
fn splitmix_matches_the_reference_sequence() {
    // Reference values of SplitMix64 for seed 1234567 (from the algorithm's published C code).
    let mut r = SplitMix64::new(1234567);
    let expected: [u64; 5] = [
        6457827717110365317,
        3203168211198807973,
        9817491932198370423,
        4593380528125082431,
        16408922859458223821,
    ];
    for e in expected {
        assert_eq!(r.next_u64(), e);
    }
    assert_eq!(SplitMix64::new(0).next_u64(), 0xE220_A839_7B1D_CDAF);
}

#[test]
fn splitmix_is_deterministic_and_f64_is_in_unit_interval() {
    let mut a = SplitMix64::new(42);
    let mut b = SplitMix64::new(42);
    for _ in 0..1000 {
        let x = a.next_f64();
        assert_eq!(x, b.next_f64());
        assert!((0.0..1.0).contains(&x));
    }
}

#[test]
fn drop_probability_is_roughly_honoured_and_reproducible() {
    let run = |seed| {
        let mut inj = FaultInjector::new(seed);
        inj.set_drop_probability(0.25);
        (0..10_000)
            .map(|_| inj.should_respond(SimTime::ZERO))
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
        assert_eq!(inj.should_respond(SimTime::ZERO), Response::Drop);
    }
    assert_eq!(inj.pending_drops(), 0);
    assert_eq!(
        inj.should_respond(SimTime::ZERO),
        Response::After(Duration::from_millis(5))
    );
    inj.reseed(3);
    inj.clear();
    assert_eq!(inj.should_respond(SimTime::ZERO), Response::Now);
}
