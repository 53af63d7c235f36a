//! Property tests: random command sequences never panic, never overshoot, and refused writes
//! never change a value.

use std::time::Duration;

use drive_sim::{
    Command, FaultReaction, Instant, ParamStore, Persistence, RampConfig, SimDrive, SimError,
    SpeedMapping, StoreOptions,
};
use proptest::prelude::*;

use crate::table::*;

#[derive(Debug, Clone)]
enum Op {
    Tick(u32),
    Cmd(Command),
    Setpoint(f64),
    Fault(u16),
    Reaction(bool),
    Write(u16, u16, i64, bool),
    Restart,
    Ramps(u32, u32, u32, u32),
}

fn op() -> impl Strategy<Value = Op> {
    let command = prop_oneof![
        Just(Command::Enable),
        Just(Command::Inhibit),
        Just(Command::Stop),
        Just(Command::QuickStop),
        Just(Command::FaultReset),
    ];
    let index = prop::sample::select(vec![
        ACTUAL_SPEED,
        STATUS,
        RAMP_UP,
        MOTOR_DATA,
        LOCK,
        ADDRESS,
        SETTING,
        FACTORY,
        ARRAY,
        DATA_SET,
        NO_RUN,
        NO_DEFAULT,
        1,
    ]);
    prop_oneof![
        4 => (0u32..3_000_000).prop_map(Op::Tick),
        3 => command.prop_map(Op::Cmd),
        2 => prop_oneof![
            -10_000.0f64..10_000.0,
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(1e300),
        ]
        .prop_map(Op::Setpoint),
        1 => any::<u16>().prop_map(Op::Fault),
        1 => any::<bool>().prop_map(Op::Reaction),
        2 => (index, 0u16..6, any::<i64>(), any::<bool>())
            .prop_map(|(i, s, v, nv)| Op::Write(i, s, v, nv)),
        1 => Just(Op::Restart),
        1 => (0u32..3_000_000, 0u32..3_000_000, 0u32..300_000, 0u32..5_000_000)
            .prop_map(|(a, d, q, c)| Op::Ramps(a, d, q, c)),
    ]
}

fn micros(n: u32) -> Duration {
    Duration::from_micros(u64::from(n))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_sequences_never_panic_or_overshoot(ops in prop::collection::vec(op(), 1..120)) {
        let mut d = SimDrive::new(ParamStore::with_options(&TABLE, StoreOptions {
            lock_index: Some(LOCK),
            eeprom_endurance: Some(50),
            value_lists_exhaustive: true,
            ..StoreOptions::default()
        }));
        d.set_speed_actual_mapping(Some(SpeedMapping {
            index: ACTUAL_SPEED,
            sub: 0,
            to_raw: |rpm| (rpm * 1000.0).round() as i64,
        })).unwrap();
        let mut now = Instant::ZERO;
        d.set_ramp_config(RampConfig { speed_limit: 10_000.0, ..RampConfig::default() }, now);
        d.tick(now);
        for op in ops {
            let before = d.actual_speed();
            let target_before = d.effective_target();
            match op {
                Op::Tick(us) => {
                    now += micros(us);
                    d.tick(now);
                    let after = d.actual_speed();
                    let lo = before.min(target_before);
                    let hi = before.max(target_before);
                    prop_assert!(after >= lo && after <= hi,
                        "{before} → {after} overshoots target {target_before}");
                }
                Op::Cmd(c) => {
                    let state = d.state();
                    match d.command(c, now) {
                        Ok(s) => prop_assert_eq!(s, d.state()),
                        Err(SimError::Faulted { code }) => {
                            prop_assert_eq!(state.fault_code(), Some(code));
                            prop_assert_eq!(d.state(), state);
                        }
                        Err(e) => prop_assert!(false, "unexpected {e:?}"),
                    }
                }
                Op::Setpoint(rpm) => {
                    let old = d.setpoint();
                    match d.set_setpoint(rpm, now) {
                        Ok(()) => prop_assert!(d.setpoint().is_finite()),
                        Err(e) => {
                            prop_assert_eq!(e, SimError::InvalidSetpoint);
                            prop_assert_eq!(d.setpoint(), old);
                        }
                    }
                }
                Op::Fault(code) => {
                    let s = d.raise_fault(code, now);
                    prop_assert!(s.fault_code().is_some());
                }
                Op::Reaction(q) => d.set_fault_reaction(if q {
                    FaultReaction::QuickStop
                } else {
                    FaultReaction::Coast
                }),
                Op::Write(index, sub, raw, nv) => {
                    let persistence = if nv {
                        Persistence::NonVolatile
                    } else {
                        Persistence::Volatile
                    };
                    let keys: Vec<(u16, u16)> = d.store().keys().collect();
                    let snapshot: Vec<_> = keys
                        .iter()
                        .map(|&(i, s)| {
                            (d.store().read(i, s), d.store().read_eeprom(i, s),
                             d.store().nv_writes(i, s))
                        })
                        .collect();
                    let result = d.write(index, sub, raw, persistence, now);
                    if let Ok(Some(max)) = d.store().max_raw(index, sub)
                        && raw > max {
                            prop_assert!(result.is_err());
                        }
                    if let Ok(Some(min)) = d.store().min_raw(index, sub)
                        && raw < min {
                            prop_assert!(result.is_err());
                        }
                    if result.is_err() {
                        // the write itself may advance the ramp (actual speed cell), nothing else
                        for (k, old) in keys.iter().zip(&snapshot) {
                            if k.0 == ACTUAL_SPEED {
                                continue;
                            }
                            let new = (d.store().read(k.0, k.1), d.store().read_eeprom(k.0, k.1),
                                       d.store().nv_writes(k.0, k.1));
                            prop_assert_eq!(&new, old, "refused write changed {:?}", k);
                        }
                    } else {
                        prop_assert_eq!(d.store().read(index, sub), Ok(raw));
                    }
                }
                Op::Restart => {
                    d.restart(now);
                    prop_assert_eq!(d.actual_speed(), 0.0);
                }
                Op::Ramps(a, dd, q, c) => d.set_ramp_config(RampConfig {
                    acceleration: micros(a),
                    deceleration: micros(dd),
                    quick_stop: micros(q),
                    coast: micros(c),
                    speed_limit: 10_000.0,
                    ..RampConfig::default()
                }, now),
            }
            prop_assert!(d.actual_speed().is_finite());
            prop_assert!(d.actual_speed().abs() <= 10_000.0);
            let mirrored = d.read(ACTUAL_SPEED, 0);
            prop_assert_eq!(mirrored, Ok((d.actual_speed() * 1000.0).round() as i64));
        }
    }

    #[test]
    fn out_of_range_writes_never_change_the_value(
        raw in prop_oneof![any::<i64>(), -10i64..10, 1_999_990i64..2_000_010],
        nv in any::<bool>(),
    ) {
        let mut s = ParamStore::new(&TABLE);
        let persistence = if nv { Persistence::NonVolatile } else { Persistence::Volatile };
        let result = s.write(RAMP_UP, 0, raw, persistence, Instant::ZERO);
        if (0..=2_000_000).contains(&raw) {
            prop_assert_eq!(result, Ok(()));
            prop_assert_eq!(s.read(RAMP_UP, 0), Ok(raw));
        } else {
            let refused = matches!(
                result,
                Err(SimError::TooLarge { .. } | SimError::TooSmall { .. })
            );
            prop_assert!(refused, "{:?}", result);
            prop_assert_eq!(s.read(RAMP_UP, 0), Ok(2000));
            prop_assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(2000));
            prop_assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(0));
        }
    }

    #[test]
    fn ramp_reaches_any_setpoint_in_the_computed_time(
        setpoint in -6000.0f64..6000.0,
        up_ms in 1u64..5000,
    ) {
        let mut d = SimDrive::new(ParamStore::new(&TABLE));
        d.set_ramp_config(RampConfig {
            acceleration: Duration::from_millis(up_ms),
            ..RampConfig::default()
        }, Instant::ZERO);
        d.set_setpoint(setpoint, Instant::ZERO).unwrap();
        d.enable(Instant::ZERO).unwrap();
        // time to reach: |setpoint| / 3000 * up
        let needed_us = (setpoint.abs() / 3000.0 * up_ms as f64 * 1000.0).ceil() as u64;
        d.tick(Instant::from_micros(needed_us));
        prop_assert_eq!(d.actual_speed(), setpoint);
        if needed_us > 2 {
            d.restart(Instant::ZERO);
            d.set_setpoint(setpoint, Instant::ZERO).unwrap();
            d.enable(Instant::ZERO).unwrap();
            d.tick(Instant::from_micros(needed_us / 2));
            prop_assert!(d.actual_speed().abs() < setpoint.abs());
        }
    }
}
