//! `SimDrive`: state, ramp, store and injection together.

use std::time::Duration;

use drive_sim::{
    DriveState, FaultReaction, Instant, ParamStore, Persistence, RampConfig, Response, SimDrive,
    SimError, SpeedMapping,
};

use crate::table::*;

fn ms(n: u64) -> Instant {
    Instant::from_millis(n)
}

fn drive() -> SimDrive {
    let mut d = SimDrive::new(ParamStore::new(&TABLE));
    d.set_speed_actual_mapping(Some(SpeedMapping {
        index: ACTUAL_SPEED,
        sub: 0,
        to_raw: |rpm| (rpm * 1000.0).round() as i64,
    }))
    .unwrap();
    d.tick(ms(0));
    d
}

#[test]
fn enable_ramps_to_the_setpoint_and_mirrors_actual_speed() {
    let mut d = drive();
    d.set_setpoint(1500.0, ms(0)).unwrap();
    d.tick(ms(100));
    assert_eq!(d.actual_speed(), 0.0, "not enabled yet");
    assert_eq!(d.enable(ms(100)), Ok(DriveState::Enabled));
    d.tick(ms(350));
    assert_eq!(d.actual_speed(), 750.0);
    assert_eq!(d.read(ACTUAL_SPEED, 0), Ok(750_000));
    assert!(d.motor_turning());
    assert!(!d.target_reached());
    d.tick(ms(600));
    assert_eq!(d.actual_speed(), 1500.0);
    assert!(d.target_reached());
    assert_eq!(d.effective_target(), 1500.0);
}

#[test]
fn commands_take_effect_at_their_own_time() {
    let mut d = drive();
    d.set_setpoint(3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    // no tick in between: stop at 500 ms must first accelerate up to 1500
    assert_eq!(d.stop(ms(500)), Ok(DriveState::Ready));
    assert_eq!(d.actual_speed(), 1500.0);
    d.tick(ms(750));
    assert_eq!(d.actual_speed(), 750.0);
    d.tick(ms(2000));
    assert_eq!(d.actual_speed(), 0.0);
    assert_eq!(d.effective_target(), 0.0);
    assert_eq!(d.setpoint(), 3000.0, "stop keeps the setpoint");
}

#[test]
fn quick_stop_uses_the_short_ramp_and_holds() {
    let mut d = drive();
    d.set_setpoint(3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    d.tick(ms(1000));
    assert_eq!(d.quick_stop(ms(1000)), Ok(DriveState::QuickStop));
    d.tick(ms(1050));
    assert_eq!(d.actual_speed(), 1500.0);
    d.tick(ms(1100));
    assert_eq!(d.actual_speed(), 0.0);
    d.tick(ms(5000));
    assert_eq!(d.actual_speed(), 0.0);
    assert_eq!(d.state(), DriveState::QuickStop);
    // enabling again resumes the setpoint
    d.enable(ms(5000)).unwrap();
    d.tick(ms(5500));
    assert_eq!(d.actual_speed(), 1500.0);
}

#[test]
fn inhibit_coasts() {
    let mut d = drive();
    d.set_ramp_config(
        RampConfig {
            coast: Duration::from_secs(3),
            ..RampConfig::default()
        },
        ms(0),
    );
    d.set_setpoint(3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    d.inhibit(ms(1000)).unwrap();
    d.tick(ms(2000));
    assert_eq!(d.actual_speed(), 2000.0);
    assert_eq!(d.state(), DriveState::Inhibited);
}

#[test]
fn fault_with_coast_reaction() {
    let mut d = drive();
    d.set_setpoint(3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    assert_eq!(d.raise_fault(84, ms(1000)), DriveState::Fault(84));
    assert_eq!(d.actual_speed(), 3000.0, "speed at the moment of the fault");
    d.tick(ms(1000));
    assert_eq!(d.actual_speed(), 0.0, "coast time zero: stops at once");
    assert_eq!(d.enable(ms(1000)), Err(SimError::Faulted { code: 84 }));
    assert_eq!(d.stop(ms(1000)), Err(SimError::Faulted { code: 84 }));
    assert_eq!(d.quick_stop(ms(1000)), Err(SimError::Faulted { code: 84 }));
    assert_eq!(d.inhibit(ms(1000)), Ok(DriveState::Fault(84)));
    assert_eq!(d.fault_reset(ms(1100)), Ok(DriveState::Inhibited));
    assert_eq!(d.enable(ms(1100)), Ok(DriveState::Enabled));
}

#[test]
fn fault_with_quick_stop_reaction() {
    let mut d = drive();
    d.set_fault_reaction(FaultReaction::QuickStop);
    assert_eq!(d.fault_reaction(), FaultReaction::QuickStop);
    d.set_setpoint(-3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    d.raise_fault(7, ms(1000));
    d.tick(ms(1025));
    assert_eq!(d.actual_speed(), -2250.0);
    d.tick(ms(1100));
    assert_eq!(d.actual_speed(), 0.0);
    assert_eq!(d.state(), DriveState::Fault(7));
}

#[test]
fn access_checks_follow_the_drive_state() {
    let mut d = drive();
    // inhibited: R parameters can be written
    d.write(MOTOR_DATA, 0, 1, Persistence::Volatile, ms(0))
        .unwrap();
    d.stop(ms(0)).unwrap();
    assert_eq!(
        d.write(MOTOR_DATA, 0, 2, Persistence::Volatile, ms(0)),
        Err(SimError::NeedsInhibit { index: MOTOR_DATA })
    );
    assert_eq!(
        d.write(NO_RUN, 0, 2, Persistence::Volatile, ms(0)),
        Err(SimError::NotInOperation { index: NO_RUN })
    );
    // with a coast time, the motor still turns after inhibit: not in operation until it stops
    d.set_ramp_config(
        RampConfig {
            coast: Duration::from_secs(1),
            ..RampConfig::default()
        },
        ms(0),
    );
    d.set_setpoint(3000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    d.inhibit(ms(1000)).unwrap();
    d.write(MOTOR_DATA, 0, 3, Persistence::Volatile, ms(1000))
        .unwrap();
    assert_eq!(
        d.write(NO_RUN, 0, 2, Persistence::Volatile, ms(1500)),
        Err(SimError::NotInOperation { index: NO_RUN })
    );
    d.write(NO_RUN, 0, 2, Persistence::Volatile, ms(2000))
        .unwrap();
    // faulted: no controller inhibit, so R parameters are refused
    d.raise_fault(1, ms(2000));
    assert_eq!(
        d.write(MOTOR_DATA, 0, 4, Persistence::Volatile, ms(2000)),
        Err(SimError::NeedsInhibit { index: MOTOR_DATA })
    );
}

#[test]
fn restart_returns_to_inhibited_standstill_with_eeprom_values() {
    let mut d = drive();
    d.write(RAMP_UP, 0, 500, Persistence::NonVolatile, ms(0))
        .unwrap();
    d.write(RAMP_UP, 0, 700, Persistence::Volatile, ms(0))
        .unwrap();
    d.set_setpoint(1000.0, ms(0)).unwrap();
    d.enable(ms(0)).unwrap();
    d.tick(ms(200));
    assert_eq!(d.read(ACTUAL_SPEED, 0), Ok(600_000));
    d.drop_next(1);
    d.restart(ms(300));
    assert_eq!(d.state(), DriveState::Inhibited);
    assert_eq!(d.actual_speed(), 0.0);
    assert_eq!(d.setpoint(), 0.0);
    assert_eq!(d.read(ACTUAL_SPEED, 0), Ok(0));
    assert_eq!(d.read(RAMP_UP, 0), Ok(500));
    assert_eq!(d.store().nv_writes(RAMP_UP, 0), Ok(1));
    assert_eq!(
        d.should_respond(ms(300)),
        Response::Drop,
        "injection survives"
    );
}

#[test]
fn speed_mapping_must_name_a_known_cell() {
    let mut d = drive();
    let bad = SpeedMapping {
        index: 1,
        sub: 0,
        to_raw: |rpm| rpm as i64,
    };
    assert_eq!(
        d.set_speed_actual_mapping(Some(bad)),
        Err(SimError::UnknownIndex { index: 1 })
    );
    assert_eq!(
        d.speed_actual_mapping().map(|m| m.index),
        Some(ACTUAL_SPEED)
    );
    d.set_speed_actual_mapping(None).unwrap();
    assert!(d.speed_actual_mapping().is_none());
}

#[test]
fn tick_hook_maps_internal_values_and_reads_ramp_parameters() {
    let mut d = drive();
    d.set_tick_hook(Some(Box::new(|drive: &mut SimDrive, _now: Instant| {
        let state_code = match drive.state() {
            DriveState::Inhibited => 1,
            DriveState::Enabled => 4,
            _ => 0,
        };
        let _ = drive.store_mut().set_internal(STATUS, state_code);
    })));
    d.tick(ms(1));
    assert_eq!(d.read(STATUS, 0), Ok(1));
    d.enable(ms(2)).unwrap();
    assert_eq!(d.read(STATUS, 0), Ok(1), "hook runs on tick only");
    d.tick(ms(3));
    assert_eq!(d.read(STATUS, 0), Ok(4));
    d.set_tick_hook(None);
    d.inhibit(ms(4)).unwrap();
    d.tick(ms(5));
    assert_eq!(d.read(STATUS, 0), Ok(4));
}

#[test]
fn injection_knobs_through_the_drive() {
    let mut d = drive();
    assert_eq!(d.should_respond(ms(0)), Response::Now);
    d.set_response_delay(Duration::from_millis(30));
    assert_eq!(
        d.should_respond(ms(0)),
        Response::After(Duration::from_millis(30))
    );
    d.drop_next(2);
    assert_eq!(d.should_respond(ms(0)), Response::Drop);
    assert_eq!(d.should_respond(ms(0)), Response::Drop);
    assert_eq!(
        d.should_respond(ms(0)),
        Response::After(Duration::from_millis(30))
    );
    d.set_drop_probability(1.0);
    assert_eq!(d.should_respond(ms(0)), Response::Drop);
    d.clear_injection();
    assert_eq!(d.should_respond(ms(0)), Response::Now);
    assert_eq!(d.injector().response_delay(), Duration::ZERO);
    d.injector_mut().set_offline_until(Some(ms(10)));
    assert_eq!(d.should_respond(ms(9)), Response::Drop);
    assert_eq!(d.should_respond(ms(10)), Response::Now);
}

#[test]
fn debug_output_does_not_panic() {
    let d = drive();
    let text = format!("{d:?}");
    assert!(text.contains("SimDrive"));
}
