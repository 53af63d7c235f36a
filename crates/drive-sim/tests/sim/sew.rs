//! A MOVIDRIVE sim built from the generated SEW table.

use drive_profile::sew;
use drive_sim::{
    DriveState, Instant, ParamStore, Persistence, SimDrive, SimError, SpeedMapping, StoreOptions,
};

/// P000 speed, 0.001 1/min per bit.
const SPEED: u16 = 8318;
/// P130 ramp t11 up CW, ms.
const RAMP_UP: u16 = 8470;
/// P803 parameter lock.
const LOCK: u16 = 8595;

fn movidrive() -> SimDrive {
    let store = ParamStore::with_options(
        sew::params(),
        StoreOptions {
            lock_index: Some(LOCK),
            ..StoreOptions::default()
        },
    );
    let mut d = SimDrive::new(store);
    d.set_speed_actual_mapping(Some(SpeedMapping {
        index: SPEED,
        sub: 0,
        to_raw: |rpm| (rpm * 1000.0).round() as i64,
    }))
    .unwrap();
    d.tick(Instant::ZERO);
    d
}

#[test]
fn movidrive_sim_reads_speed_at_index_8318() {
    let mut d = movidrive();
    assert_eq!(d.read(SPEED, 0), Ok(0));
    assert_eq!(
        d.write(SPEED, 0, 1, Persistence::Volatile, Instant::ZERO),
        Err(SimError::ReadOnly { index: SPEED })
    );
    d.set_setpoint(1500.0, Instant::ZERO).unwrap();
    assert_eq!(d.enable(Instant::ZERO), Ok(DriveState::Enabled));
    d.tick(Instant::from_secs(1));
    // the manual: "1000000 … represents the speed (3 decimal places)"
    assert_eq!(d.read(SPEED, 0), Ok(1_500_000));
    let meta = d.store().meta(SPEED, 0).unwrap();
    assert_eq!(meta.name_de(), "Drehzahl [1/min]");
}

#[test]
fn movidrive_ramp_parameter_and_lock() {
    let mut d = movidrive();
    let t = Instant::ZERO;
    assert_eq!(d.read(RAMP_UP, 0), Ok(2000));
    assert_eq!(d.store().has_eeprom(RAMP_UP, 0), Ok(true));
    d.write(RAMP_UP, 0, 1000, Persistence::NonVolatile, t)
        .unwrap();
    assert_eq!(d.store().nv_writes(RAMP_UP, 0), Ok(1));
    d.write(LOCK, 0, 1, Persistence::NonVolatile, t).unwrap();
    assert_eq!(
        d.write(RAMP_UP, 0, 500, Persistence::Volatile, t),
        Err(SimError::Locked { index: RAMP_UP })
    );
    d.restart(t);
    assert_eq!(d.read(RAMP_UP, 0), Ok(1000));
    assert!(d.store().is_locked());
    // P010…P013 share index 8310
    assert!(sew::all_by_index(8310).count() > 1);
    assert_eq!(d.store().keys().filter(|k| k.0 == 8310).count(), 1);
}
