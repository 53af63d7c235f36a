//! The ramp model of actual speed.
//!
//! Speeds are signed `f64` in 1/min (positive = clockwise / "right"). Ramp times are given the
//! way SEW's P130/P131 give them: the time a change of [`RampConfig::reference_speed`] takes
//! (3000 1/min by default), so the rate is `reference_speed / ramp_time`.
//!
//! Actual speed moves linearly toward the target:
//!
//! * with the **acceleration** ramp while the magnitude grows (same sign, or from 0);
//! * with the **deceleration** ramp while the magnitude shrinks; on a sign change the speed first
//!   decelerates to 0 and then accelerates in the new direction;
//! * in one call, however large the time step, passing through each phase in turn, and never
//!   beyond the target (it ends exactly on it);
//! * a zero ramp time means an instantaneous change.

use std::time::Duration;

use crate::error::SimError;
use drive_core::Instant;

/// Ramp times and limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampConfig {
    /// The speed change, in 1/min, that each ramp time refers to (SEW: 3000 1/min).
    pub reference_speed: f64,
    /// Time for the magnitude to grow by `reference_speed` (SEW P130 "ramp up").
    pub acceleration: Duration,
    /// Time for the magnitude to shrink by `reference_speed` (SEW P131 "ramp down"); also used
    /// by [`crate::Command::Stop`].
    pub deceleration: Duration,
    /// Deceleration time of quick stop and of [`crate::FaultReaction::QuickStop`] (SEW P136).
    pub quick_stop: Duration,
    /// Deceleration time while the output stage is off (coasting); zero: the speed drops to 0
    /// at once.
    pub coast: Duration,
    /// Setpoints are clamped to ±`speed_limit` 1/min.
    pub speed_limit: f64,
}

impl Default for RampConfig {
    /// 3000 1/min reference, 1 s acceleration and deceleration, 100 ms quick stop, instant
    /// coast-down, no speed limit.
    fn default() -> RampConfig {
        RampConfig {
            reference_speed: 3000.0,
            acceleration: Duration::from_secs(1),
            deceleration: Duration::from_secs(1),
            quick_stop: Duration::from_millis(100),
            coast: Duration::ZERO,
            speed_limit: f64::INFINITY,
        }
    }
}

/// What the ramp drives the actual speed toward.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RampMode {
    /// Toward the setpoint with the acceleration / deceleration ramps (enabled).
    Follow,
    /// Toward 0 with the deceleration ramp (stop).
    Stop,
    /// Toward 0 with the quick-stop ramp.
    QuickStop,
    /// Toward 0 with the coast time (output stage off).
    Coast,
}

/// Setpoint and actual speed with their ramps.
#[derive(Debug, Clone, PartialEq)]
pub struct Ramp {
    config: RampConfig,
    setpoint: f64,
    actual: f64,
    last: Option<Instant>,
}

impl Default for Ramp {
    fn default() -> Ramp {
        Ramp::new(RampConfig::default())
    }
}

impl Ramp {
    /// Standstill, setpoint 0, no time base yet.
    pub const fn new(config: RampConfig) -> Ramp {
        Ramp {
            config,
            setpoint: 0.0,
            actual: 0.0,
            last: None,
        }
    }

    /// The ramp configuration.
    pub const fn config(&self) -> &RampConfig {
        &self.config
    }

    /// Replace the ramp configuration (the setpoint is clamped to the new limit).
    pub fn set_config(&mut self, config: RampConfig) {
        self.config = config;
        self.setpoint = self.clamp(self.setpoint);
    }

    /// The setpoint in 1/min.
    pub const fn setpoint(&self) -> f64 {
        self.setpoint
    }

    /// Set the setpoint in 1/min (clamped to ±[`RampConfig::speed_limit`]).
    pub fn set_setpoint(&mut self, rpm: f64) -> Result<(), SimError> {
        if !rpm.is_finite() {
            return Err(SimError::InvalidSetpoint);
        }
        self.setpoint = self.clamp(rpm);
        Ok(())
    }

    /// The actual speed in 1/min.
    pub const fn actual(&self) -> f64 {
        self.actual
    }

    /// The time of the last [`Ramp::advance`], if any.
    pub const fn last_update(&self) -> Option<Instant> {
        self.last
    }

    /// Where `mode` drives the actual speed.
    pub fn target(&self, mode: RampMode) -> f64 {
        match mode {
            RampMode::Follow => self.setpoint,
            RampMode::Stop | RampMode::QuickStop | RampMode::Coast => 0.0,
        }
    }

    /// Move the actual speed toward the target of `mode` by the time elapsed since the last
    /// call (the first call only sets the time base; time going backwards counts as none).
    /// Returns the new actual speed.
    pub fn advance(&mut self, now: Instant, mode: RampMode) -> f64 {
        let elapsed = match self.last {
            Some(last) => now.saturating_duration_since(last),
            None => Duration::ZERO,
        };
        self.last = Some(self.last.map_or(now, |last| last.max(now)));
        let c = &self.config;
        let (up, down) = match mode {
            RampMode::Follow => (c.acceleration, c.deceleration),
            RampMode::Stop => (c.acceleration, c.deceleration),
            RampMode::QuickStop => (c.acceleration, c.quick_stop),
            RampMode::Coast => (c.acceleration, c.coast),
        };
        self.actual = approach(
            self.actual,
            self.target(mode),
            elapsed.as_micros() as f64,
            up.as_micros() as f64,
            down.as_micros() as f64,
            c.reference_speed,
        );
        self.actual
    }

    /// Standstill, setpoint 0, time base `now`.
    pub fn reset(&mut self, now: Instant) {
        self.setpoint = 0.0;
        self.actual = 0.0;
        self.last = Some(now);
    }

    fn clamp(&self, rpm: f64) -> f64 {
        let limit = self.config.speed_limit.abs();
        if limit.is_nan() {
            rpm
        } else {
            rpm.clamp(-limit, limit)
        }
    }
}

/// Move `actual` toward `target` within `remaining_us` microseconds; `up_us` / `down_us` are the
/// times for a change of `reference` while the magnitude grows / shrinks.
fn approach(
    mut actual: f64,
    target: f64,
    mut remaining_us: f64,
    up_us: f64,
    down_us: f64,
    reference: f64,
) -> f64 {
    // At most two phases: decelerate to 0 on a sign change, then accelerate.
    for _ in 0..3 {
        if actual == target {
            break;
        }
        let crosses = (actual > 0.0 && target < 0.0) || (actual < 0.0 && target > 0.0);
        let (goal, ramp_us) = if crosses {
            (0.0, down_us)
        } else if target.abs() < actual.abs() {
            (target, down_us)
        } else {
            (target, up_us)
        };
        let distance = (goal - actual).abs();
        let usable = reference.is_finite() && reference > 0.0;
        if ramp_us <= 0.0 || !usable {
            actual = goal;
            continue;
        }
        let needed_us = distance * ramp_us / reference;
        if needed_us <= remaining_us {
            actual = goal;
            remaining_us -= needed_us;
        } else {
            let step = reference * remaining_us / ramp_us;
            if step >= distance {
                actual = goal;
            } else if goal > actual {
                actual = (actual + step).min(goal);
            } else {
                actual = (actual - step).max(goal);
            }
            break;
        }
    }
    actual
}
