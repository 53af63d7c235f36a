//! Ramp timing.

use std::time::Duration;

use drive_sim::{Instant, Ramp, RampConfig, RampMode, SimError};

fn ms(n: u64) -> Instant {
    Instant::from_millis(n)
}

/// 1 s per 3000 1/min both ways, 100 ms quick stop, instant coast.
fn ramp() -> Ramp {
    let mut r = Ramp::new(RampConfig::default());
    r.advance(ms(0), RampMode::Follow);
    r
}

#[test]
fn zero_to_1500_takes_half_a_second() {
    let mut r = ramp();
    r.set_setpoint(1500.0).unwrap();
    assert_eq!(r.advance(ms(100), RampMode::Follow), 300.0);
    assert_eq!(r.advance(ms(250), RampMode::Follow), 750.0);
    assert_eq!(r.advance(ms(499), RampMode::Follow), 1497.0);
    assert_eq!(r.advance(ms(500), RampMode::Follow), 1500.0);
    assert_eq!(r.advance(ms(10_000), RampMode::Follow), 1500.0);
}

#[test]
fn one_large_step_reaches_the_setpoint_exactly() {
    let mut r = ramp();
    r.set_setpoint(1500.0).unwrap();
    assert_eq!(
        r.advance(Instant::from_secs(3600), RampMode::Follow),
        1500.0
    );
}

#[test]
fn deceleration_uses_its_own_ramp() {
    let mut r = Ramp::new(RampConfig {
        acceleration: Duration::from_secs(1),
        deceleration: Duration::from_secs(2),
        ..RampConfig::default()
    });
    r.advance(ms(0), RampMode::Follow);
    r.set_setpoint(3000.0).unwrap();
    assert_eq!(r.advance(ms(1000), RampMode::Follow), 3000.0);
    r.set_setpoint(1500.0).unwrap();
    // 1500 1/min down at 3000 1/min per 2 s: 1 s
    assert_eq!(r.advance(ms(1500), RampMode::Follow), 2250.0);
    assert_eq!(r.advance(ms(2000), RampMode::Follow), 1500.0);
}

#[test]
fn sign_change_decelerates_to_zero_then_accelerates_in_one_tick() {
    let mut r = Ramp::new(RampConfig {
        acceleration: Duration::from_secs(1),
        deceleration: Duration::from_secs(2),
        ..RampConfig::default()
    });
    r.advance(ms(0), RampMode::Follow);
    r.set_setpoint(1500.0).unwrap();
    r.advance(ms(500), RampMode::Follow);
    r.set_setpoint(-1500.0).unwrap();
    // 1500 → 0 takes 1 s (deceleration), then 0 → -750 takes 0.25 s (acceleration)
    assert_eq!(r.advance(ms(1750), RampMode::Follow), -750.0);
    assert_eq!(r.advance(ms(2000), RampMode::Follow), -1500.0);
    // midpoint of the deceleration phase, in small steps
    r.set_setpoint(1500.0).unwrap();
    assert_eq!(r.advance(ms(2500), RampMode::Follow), -750.0);
    assert_eq!(r.advance(ms(3000), RampMode::Follow), 0.0);
    assert_eq!(r.advance(ms(3250), RampMode::Follow), 750.0);
}

#[test]
fn negative_setpoints_mirror_positive_ones() {
    let mut r = ramp();
    r.set_setpoint(-3000.0).unwrap();
    assert_eq!(r.advance(ms(500), RampMode::Follow), -1500.0);
    assert_eq!(r.advance(ms(1000), RampMode::Follow), -3000.0);
    r.set_setpoint(-1000.0).unwrap();
    assert_eq!(r.advance(ms(1500), RampMode::Follow), -1500.0);
    assert_eq!(r.advance(ms(5000), RampMode::Follow), -1000.0);
}

#[test]
fn stop_quick_stop_and_coast_head_for_zero() {
    let mut r = ramp();
    r.set_setpoint(3000.0).unwrap();
    r.advance(ms(1000), RampMode::Follow);
    // stop: deceleration ramp, 1 s per 3000
    assert_eq!(r.advance(ms(1500), RampMode::Stop), 1500.0);
    // quick stop: 100 ms per 3000 → 1500 takes 50 ms
    assert_eq!(r.advance(ms(1525), RampMode::QuickStop), 750.0);
    assert_eq!(r.advance(ms(1550), RampMode::QuickStop), 0.0);
    r.advance(ms(3000), RampMode::Follow);
    assert_eq!(r.actual(), 3000.0);
    // coast with zero coast time: at once
    assert_eq!(r.advance(ms(3000), RampMode::Coast), 0.0);
    assert_eq!(r.setpoint(), 3000.0);
}

#[test]
fn coast_time_is_a_ramp_too() {
    let mut r = Ramp::new(RampConfig {
        coast: Duration::from_secs(10),
        ..RampConfig::default()
    });
    r.advance(ms(0), RampMode::Follow);
    r.set_setpoint(3000.0).unwrap();
    r.advance(ms(1000), RampMode::Follow);
    assert_eq!(r.advance(ms(6000), RampMode::Coast), 1500.0);
}

#[test]
fn zero_ramp_time_is_instant() {
    let mut r = Ramp::new(RampConfig {
        acceleration: Duration::ZERO,
        deceleration: Duration::ZERO,
        ..RampConfig::default()
    });
    r.set_setpoint(-1234.5).unwrap();
    // even the first call, which only sets the time base
    assert_eq!(r.advance(ms(7), RampMode::Follow), -1234.5);
    r.set_setpoint(99.0).unwrap();
    assert_eq!(r.advance(ms(7), RampMode::Follow), 99.0);
}

#[test]
fn first_call_sets_the_time_base_and_time_never_runs_backwards() {
    let mut r = Ramp::default();
    r.set_setpoint(3000.0).unwrap();
    assert_eq!(r.advance(Instant::from_secs(100), RampMode::Follow), 0.0);
    assert_eq!(r.last_update(), Some(Instant::from_secs(100)));
    assert_eq!(r.advance(Instant::from_secs(50), RampMode::Follow), 0.0);
    assert_eq!(r.last_update(), Some(Instant::from_secs(100)));
    assert_eq!(
        r.advance(Instant::from_millis(100_100), RampMode::Follow),
        300.0
    );
}

#[test]
fn setpoints_are_validated_and_clamped() {
    let mut r = Ramp::new(RampConfig {
        speed_limit: 2000.0,
        ..RampConfig::default()
    });
    assert_eq!(r.set_setpoint(f64::NAN), Err(SimError::InvalidSetpoint));
    assert_eq!(
        r.set_setpoint(f64::INFINITY),
        Err(SimError::InvalidSetpoint)
    );
    r.set_setpoint(5000.0).unwrap();
    assert_eq!(r.setpoint(), 2000.0);
    r.set_setpoint(-5000.0).unwrap();
    assert_eq!(r.setpoint(), -2000.0);
    r.set_config(RampConfig {
        speed_limit: 1000.0,
        ..RampConfig::default()
    });
    assert_eq!(r.setpoint(), -1000.0);
}

#[test]
fn reset_stops_at_once() {
    let mut r = ramp();
    r.set_setpoint(3000.0).unwrap();
    r.advance(ms(500), RampMode::Follow);
    r.reset(ms(600));
    assert_eq!(r.actual(), 0.0);
    assert_eq!(r.setpoint(), 0.0);
    assert_eq!(r.last_update(), Some(ms(600)));
}
