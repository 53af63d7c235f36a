//! Parameter store: access errors, EEPROM vs RAM, write counters, restart.

use drive_sim::{
    Instant, Meta, OperatingCondition, ParamStore, Persistence, SimError, StoreOptions,
};

use crate::table::*;

const T0: Instant = Instant::ZERO;
const V: Persistence = Persistence::Volatile;
const NV: Persistence = Persistence::NonVolatile;

fn store() -> ParamStore {
    ParamStore::new(&TABLE)
}

fn running() -> OperatingCondition {
    OperatingCondition {
        controller_inhibited: false,
        in_operation: true,
    }
}

#[test]
fn initial_values_come_from_defaults_or_zero() {
    let s = store();
    assert_eq!(s.read(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.read(NO_DEFAULT, 0), Ok(0));
    assert_eq!(s.default_raw(NO_DEFAULT, 0), Ok(0));
    assert_eq!(s.default_raw(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.min_raw(RAMP_UP, 0), Ok(Some(0)));
    assert_eq!(s.max_raw(RAMP_UP, 0), Ok(Some(2_000_000)));
    assert_eq!(s.min_raw(NO_DEFAULT, 0), Ok(None));
    assert_eq!(s.max_raw(NO_DEFAULT, 0), Ok(None));
    assert!(!s.is_locked());
    assert!(s.contains(RAMP_UP));
    assert!(!s.is_empty());
}

#[test]
fn rows_sharing_an_index_share_one_value() {
    let mut s = store();
    // first row has no default, the second supplies 7
    assert_eq!(s.read(STATUS, 0), Ok(7));
    assert_eq!(s.keys().filter(|k| k.0 == STATUS).count(), 1);
    s.set_internal(STATUS, 42).unwrap();
    assert_eq!(s.read(STATUS, 0), Ok(42));
}

#[test]
fn cell_count_and_keys() {
    let s = store();
    // 12 non-data-set cells (8310 counted once, 700 twice) + 4 data sets
    let keys: Vec<_> = s.keys().collect();
    assert_eq!(keys.len(), s.len());
    assert_eq!(s.len(), 12 + 4);
    assert!(keys.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn unknown_index_and_sub_index() {
    let mut s = store();
    assert_eq!(s.read(1, 0), Err(SimError::UnknownIndex { index: 1 }));
    assert_eq!(
        s.write(1, 0, 0, V, T0),
        Err(SimError::UnknownIndex { index: 1 })
    );
    assert_eq!(s.min_raw(1, 0), Err(SimError::UnknownIndex { index: 1 }));
    assert_eq!(s.max_raw(1, 0), Err(SimError::UnknownIndex { index: 1 }));
    assert_eq!(
        s.default_raw(1, 0),
        Err(SimError::UnknownIndex { index: 1 })
    );
    assert_eq!(
        s.set_internal(1, 0),
        Err(SimError::UnknownIndex { index: 1 })
    );
    assert_eq!(
        s.read(RAMP_UP, 3),
        Err(SimError::UnknownSubIndex {
            index: RAMP_UP,
            sub: 3
        })
    );
    assert_eq!(
        s.write(ARRAY, 2, 1, V, T0),
        Err(SimError::UnknownSubIndex {
            index: ARRAY,
            sub: 2
        })
    );
}

#[test]
fn read_only_is_refused() {
    let mut s = store();
    assert_eq!(
        s.write(ACTUAL_SPEED, 0, 5, V, T0),
        Err(SimError::ReadOnly {
            index: ACTUAL_SPEED
        })
    );
    assert_eq!(
        s.write(STATUS, 0, 5, NV, T0),
        Err(SimError::ReadOnly { index: STATUS })
    );
    assert_eq!(s.read(ACTUAL_SPEED, 0), Ok(0));
}

#[test]
fn range_errors_name_the_limit_and_change_nothing() {
    let mut s = store();
    assert_eq!(
        s.write(RAMP_UP, 0, 2_000_001, NV, T0),
        Err(SimError::TooLarge {
            index: RAMP_UP,
            max: 2_000_000
        })
    );
    assert_eq!(
        s.write(RAMP_UP, 0, -1, NV, T0),
        Err(SimError::TooSmall {
            index: RAMP_UP,
            min: 0
        })
    );
    assert_eq!(s.read(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(0));
    // the limits themselves are fine
    s.write(RAMP_UP, 0, 2_000_000, V, T0).unwrap();
    s.write(RAMP_UP, 0, 0, V, T0).unwrap();
    // no range: anything goes
    s.write(NO_DEFAULT, 0, i64::MIN, V, T0).unwrap();
    assert_eq!(s.read(NO_DEFAULT, 0), Ok(i64::MIN));
}

#[test]
fn needs_inhibit_and_not_in_operation() {
    let mut s = store();
    s.set_condition(running());
    assert_eq!(
        s.write(MOTOR_DATA, 0, 5, V, T0),
        Err(SimError::NeedsInhibit { index: MOTOR_DATA })
    );
    assert_eq!(
        s.write(NO_RUN, 0, 5, V, T0),
        Err(SimError::NotInOperation { index: NO_RUN })
    );
    // unflagged parameters are fine while running
    s.write(RAMP_UP, 0, 5, V, T0).unwrap();
    // inhibited but the motor still turns: R allowed, not-in-operation still refused
    s.set_condition(OperatingCondition {
        controller_inhibited: true,
        in_operation: true,
    });
    s.write(MOTOR_DATA, 0, 5, V, T0).unwrap();
    assert_eq!(
        s.write(NO_RUN, 0, 5, V, T0),
        Err(SimError::NotInOperation { index: NO_RUN })
    );
    s.set_condition(OperatingCondition::default());
    s.write(NO_RUN, 0, 5, V, T0).unwrap();
    assert_eq!(s.read(MOTOR_DATA, 0), Ok(5));
    assert_eq!(s.read(NO_RUN, 0), Ok(5));
}

#[test]
fn parameter_lock_by_switch_and_by_parameter() {
    let mut s = store();
    s.set_param_lock(true);
    assert!(s.is_locked());
    assert_eq!(
        s.write(RAMP_UP, 0, 5, V, T0),
        Err(SimError::Locked { index: RAMP_UP })
    );
    // S parameters may still be written
    s.write(ADDRESS, 0, 5, NV, T0).unwrap();
    s.set_param_lock(false);
    s.write(RAMP_UP, 0, 5, V, T0).unwrap();

    let mut s = ParamStore::with_options(
        &TABLE,
        StoreOptions {
            lock_index: Some(LOCK),
            ..StoreOptions::default()
        },
    );
    assert!(!s.is_locked());
    s.write(LOCK, 0, 1, NV, T0).unwrap();
    assert!(s.is_locked());
    assert_eq!(
        s.write(RAMP_UP, 0, 5, V, T0),
        Err(SimError::Locked { index: RAMP_UP })
    );
    // the lock persists over restart (N) and can be released (S)
    s.restart();
    assert!(s.is_locked());
    s.write(LOCK, 0, 0, V, T0).unwrap();
    s.write(RAMP_UP, 0, 5, V, T0).unwrap();
}

#[test]
fn value_lists_are_checked_only_when_exhaustive() {
    let mut s = store();
    // the range allows 0…5, the value list names 0 and 1; not exhaustive by default
    s.write(SETTING, 0, 3, V, T0).unwrap();
    s.set_value_list_exhaustive(SETTING, true);
    assert_eq!(
        s.write(SETTING, 0, 4, V, T0),
        Err(SimError::ValueNotAllowed {
            index: SETTING,
            value: 4
        })
    );
    assert_eq!(s.read(SETTING, 0), Ok(3));
    s.write(SETTING, 0, 1, V, T0).unwrap();
    // range is checked first
    assert_eq!(
        s.write(SETTING, 0, 6, V, T0),
        Err(SimError::TooLarge {
            index: SETTING,
            max: 5
        })
    );

    let mut s = ParamStore::with_options(
        &TABLE,
        StoreOptions {
            value_lists_exhaustive: true,
            ..StoreOptions::default()
        },
    );
    assert_eq!(
        s.write(SETTING, 0, 2, V, T0),
        Err(SimError::ValueNotAllowed {
            index: SETTING,
            value: 2
        })
    );
    // parameters without a list are unaffected
    s.write(RAMP_UP, 0, 7, V, T0).unwrap();
    s.set_value_list_exhaustive(SETTING, false);
    s.write(SETTING, 0, 2, V, T0).unwrap();
}

#[test]
fn check_order_read_only_before_lock_before_range() {
    let mut s = store();
    s.set_param_lock(true);
    s.set_condition(running());
    assert_eq!(
        s.write(ACTUAL_SPEED, 0, -1, V, T0),
        Err(SimError::ReadOnly {
            index: ACTUAL_SPEED
        })
    );
    assert_eq!(
        s.write(MOTOR_DATA, 0, -1, V, T0),
        Err(SimError::Locked { index: MOTOR_DATA })
    );
    s.set_param_lock(false);
    assert_eq!(
        s.write(MOTOR_DATA, 0, -1, V, T0),
        Err(SimError::NeedsInhibit { index: MOTOR_DATA })
    );
}

#[test]
fn volatile_writes_touch_ram_only() {
    let mut s = store();
    s.write(RAMP_UP, 0, 500, V, Instant::from_secs(1)).unwrap();
    assert_eq!(s.read(RAMP_UP, 0), Ok(500));
    assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(0));
    assert_eq!(s.last_nv_write(RAMP_UP, 0), Ok(None));
    assert_eq!(s.total_nv_writes(), 0);
}

#[test]
fn non_volatile_writes_count_and_record_time() {
    let mut s = store();
    for i in 0..5u64 {
        s.write(RAMP_UP, 0, 100 + i as i64, NV, Instant::from_secs(i))
            .unwrap();
    }
    assert_eq!(s.read(RAMP_UP, 0), Ok(104));
    assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(104));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(5));
    assert_eq!(s.last_nv_write(RAMP_UP, 0), Ok(Some(Instant::from_secs(4))));
    assert_eq!(s.has_eeprom(RAMP_UP, 0), Ok(true));
    // failed writes are not counted
    let _ = s.write(RAMP_UP, 0, -5, NV, Instant::from_secs(9));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(5));
    s.write(ADDRESS, 0, 3, NV, T0).unwrap();
    assert_eq!(s.total_nv_writes(), 6);
}

#[test]
fn non_volatile_write_to_parameter_without_n_changes_ram_only() {
    let mut s = store();
    assert_eq!(s.has_eeprom(FACTORY, 0), Ok(false));
    s.write(FACTORY, 0, 1, NV, T0).unwrap();
    assert_eq!(s.read(FACTORY, 0), Ok(1));
    assert_eq!(s.read_eeprom(FACTORY, 0), Ok(0));
    assert_eq!(s.nv_writes(FACTORY, 0), Ok(0));
    s.restart();
    assert_eq!(s.read(FACTORY, 0), Ok(0));
}

#[test]
fn eeprom_for_unflagged_gives_writable_parameters_backing() {
    let mut s = ParamStore::with_options(
        &TABLE,
        StoreOptions {
            eeprom_for_unflagged: true,
            ..StoreOptions::default()
        },
    );
    assert_eq!(s.has_eeprom(FACTORY, 0), Ok(true));
    // read-only values stay without backing
    assert_eq!(s.has_eeprom(ACTUAL_SPEED, 0), Ok(false));
    s.write(FACTORY, 0, 1, NV, T0).unwrap();
    s.restart();
    assert_eq!(s.read(FACTORY, 0), Ok(1));
    assert_eq!(s.nv_writes(FACTORY, 0), Ok(1));
}

#[test]
fn restart_restores_eeprom_and_drops_volatile_values() {
    let mut s = store();
    s.write(RAMP_UP, 0, 300, NV, T0).unwrap();
    s.write(RAMP_UP, 0, 400, V, T0).unwrap();
    assert_eq!(
        s.write(VOLATILE_RW, 0, 0, V, T0),
        Err(SimError::UnknownIndex { index: VOLATILE_RW })
    );
    s.write(NO_DEFAULT, 0, 77, NV, T0).unwrap();
    s.set_internal(ACTUAL_SPEED, 1234).unwrap();
    s.set_internal(STATUS, 55).unwrap();
    assert_eq!(s.read(RAMP_UP, 0), Ok(400));
    s.restart();
    // N: RAM ← EEPROM (last non-volatile value)
    assert_eq!(s.read(RAMP_UP, 0), Ok(300));
    // not N: back to the default
    assert_eq!(s.read(NO_DEFAULT, 0), Ok(0));
    assert_eq!(s.read(ACTUAL_SPEED, 0), Ok(0));
    // N/RO values set by the drive itself survive
    assert_eq!(s.read(STATUS, 0), Ok(55));
    // counters survive a restart
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(1));
}

#[test]
fn reset_to_defaults_volatile_and_non_volatile() {
    let mut s = store();
    s.write(RAMP_UP, 0, 300, NV, T0).unwrap();
    s.write(ADDRESS, 0, 5, NV, T0).unwrap();
    s.set_internal(STATUS, 55).unwrap();
    s.reset_to_defaults(V, Instant::from_secs(1));
    assert_eq!(s.read(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(300));
    assert_eq!(s.read(STATUS, 0), Ok(55)); // read-only: untouched
    s.restart();
    assert_eq!(s.read(RAMP_UP, 0), Ok(300));

    s.reset_to_defaults(NV, Instant::from_secs(2));
    assert_eq!(s.read_eeprom(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.read_eeprom(ADDRESS, 0), Ok(0));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(2));
    assert_eq!(s.last_nv_write(RAMP_UP, 0), Ok(Some(Instant::from_secs(2))));
    // cells already at their default are not rewritten
    assert_eq!(s.nv_writes(MOTOR_DATA, 0), Ok(0));
}

#[test]
fn eeprom_endurance_refuses_further_non_volatile_writes() {
    let mut s = ParamStore::with_options(
        &TABLE,
        StoreOptions {
            eeprom_endurance: Some(3),
            ..StoreOptions::default()
        },
    );
    for v in 1..=3 {
        s.write(RAMP_UP, 0, v, NV, T0).unwrap();
    }
    assert_eq!(
        s.write(RAMP_UP, 0, 9, NV, T0),
        Err(SimError::EepromWornOut {
            index: RAMP_UP,
            writes: 3
        })
    );
    assert_eq!(s.read(RAMP_UP, 0), Ok(3));
    // volatile writes still work, and cells without backing are not limited
    s.write(RAMP_UP, 0, 9, V, T0).unwrap();
    for _ in 0..5 {
        s.write(FACTORY, 0, 1, NV, T0).unwrap();
    }
}

#[test]
fn arrays_keep_one_value_per_sub_index() {
    let mut s = store();
    assert_eq!(s.read(ARRAY, 0), Ok(10));
    assert_eq!(s.read(ARRAY, 1), Ok(11));
    s.write(ARRAY, 1, 50, NV, T0).unwrap();
    assert_eq!(s.read(ARRAY, 0), Ok(10));
    assert_eq!(s.read(ARRAY, 1), Ok(50));
    assert_eq!(s.nv_writes(ARRAY, 0), Ok(0));
    assert_eq!(s.nv_writes(ARRAY, 1), Ok(1));
}

#[test]
fn data_sets_zero_addresses_all_four() {
    let mut s = store();
    for ds in 0..=4 {
        assert_eq!(s.read(DATA_SET, ds), Ok(1500));
    }
    assert_eq!(
        s.read(DATA_SET, 5),
        Err(SimError::UnknownSubIndex {
            index: DATA_SET,
            sub: 5
        })
    );
    s.write(DATA_SET, 2, 1000, NV, T0).unwrap();
    assert_eq!(s.read(DATA_SET, 2), Ok(1000));
    assert_eq!(s.read(DATA_SET, 1), Ok(1500));
    assert_eq!(
        s.read(DATA_SET, 0),
        Err(SimError::DataSetsDiffer { index: DATA_SET })
    );
    s.write(DATA_SET, 0, 900, NV, T0).unwrap();
    for ds in 0..=4 {
        assert_eq!(s.read(DATA_SET, ds), Ok(900));
    }
    assert_eq!(s.nv_writes(DATA_SET, 2), Ok(2));
    assert_eq!(s.nv_writes(DATA_SET, 3), Ok(1));
    assert_eq!(
        s.write(DATA_SET, 0, 60001, NV, T0),
        Err(SimError::TooLarge {
            index: DATA_SET,
            max: 60000
        })
    );
}

#[test]
fn set_internal_bypasses_checks() {
    let mut s = store();
    s.set_param_lock(true);
    s.set_condition(running());
    s.set_internal(ACTUAL_SPEED, -1_500_000).unwrap();
    s.set_internal(RAMP_UP, -5).unwrap(); // even outside the range
    assert_eq!(s.read(ACTUAL_SPEED, 0), Ok(-1_500_000));
    assert_eq!(s.read(RAMP_UP, 0), Ok(-5));
    s.set_internal_sub(ARRAY, 1, 99).unwrap();
    assert_eq!(s.read(ARRAY, 1), Ok(99));
    assert_eq!(s.total_nv_writes(), 0);
}

#[test]
fn stores_can_combine_tables() {
    let rows = TABLE.iter().chain(EXTRA.iter()).map(|r| r as Meta);
    let s = ParamStore::from_rows(rows, StoreOptions::default());
    assert_eq!(s.read(VOLATILE_RW, 0), Ok(3));
    assert_eq!(s.meta(VOLATILE_RW, 0).unwrap().bus_index(), VOLATILE_RW);
}

#[test]
fn indices_outside_and_between_the_table_are_unknown() {
    // The store finds an index through a table of slots from its lowest to its highest index
    // (372 … 9000 here): below, above and in the gaps nothing may be found.
    let s = store();
    for index in [
        0,
        1,
        DATA_SET - 1,
        ARRAY + 1,
        8319,
        NO_DEFAULT + 1,
        u16::MAX,
    ] {
        assert_eq!(s.read(index, 0), Err(SimError::UnknownIndex { index }));
        assert!(!s.contains(index));
    }
    assert_eq!(s.read(DATA_SET, 1), Ok(1500));
    assert_eq!(s.read(NO_DEFAULT, 0), Ok(0));
}

#[test]
fn a_second_index_below_between_and_above_the_table_keeps_every_value() {
    let mut s = store();
    s.write(RAMP_UP, 0, 1234, NV, T0).unwrap();
    s.write(DATA_SET, 3, 700, NV, T0).unwrap();
    s.write(ARRAY, 1, 55, V, T0).unwrap();
    let before: Vec<_> = s.keys().map(|(i, sub)| (i, sub, s.read(i, sub))).collect();
    let meta = s.meta(RAMP_UP, 0).unwrap();
    // Below the lowest index, between two indices, above the highest.
    for (index, default) in [(0, Some(1)), (8311, None), (u16::MAX, Some(3))] {
        s.add_second_index(index, meta, default).unwrap();
    }
    assert_eq!(s.read(0, 0), Ok(1));
    assert_eq!(s.read(8311, 0), Ok(0));
    assert_eq!(s.read(u16::MAX, 0), Ok(3));
    for (i, sub, value) in &before {
        assert_eq!(s.read(*i, *sub), *value, "{i}.{sub}");
    }
    assert_eq!(s.len(), before.len() + 3);
    let keys: Vec<_> = s.keys().collect();
    assert!(keys.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(keys.first(), Some(&(0, 0)));
    assert_eq!(keys.last(), Some(&(u16::MAX, 0)));
    // Writes reach the right cell after the cells moved.
    s.write(8311, 0, 2500, NV, T0).unwrap();
    assert_eq!(s.read(8311, 0), Ok(2500));
    assert_eq!(s.nv_writes(8311, 0), Ok(1));
    assert_eq!(s.read(RAMP_UP, 0), Ok(1234));
    assert_eq!(s.nv_writes(RAMP_UP, 0), Ok(1));
    assert_eq!(s.read(DATA_SET, 3), Ok(700));
    // An index in use is refused and changes nothing.
    assert_eq!(
        s.add_second_index(8311, meta, None),
        Err(SimError::ValueNotAllowed {
            index: 8311,
            value: 8311
        })
    );
    assert_eq!(s.read(8311, 0), Ok(2500));
    assert_eq!(s.len(), before.len() + 3);
}

#[test]
fn set_internal_of_an_unknown_sub_index_is_refused_and_changes_nothing() {
    let mut s = store();
    assert_eq!(
        s.set_internal_sub(RAMP_UP, 3, 1),
        Err(SimError::UnknownSubIndex {
            index: RAMP_UP,
            sub: 3
        })
    );
    assert_eq!(
        s.set_internal_sub(DATA_SET, 5, 1),
        Err(SimError::UnknownSubIndex {
            index: DATA_SET,
            sub: 5
        })
    );
    assert_eq!(s.read(RAMP_UP, 0), Ok(2000));
    assert_eq!(s.read(DATA_SET, 0), Ok(1500));
    // Sub-index 0 of a data-set parameter sets every data set.
    s.set_internal_sub(DATA_SET, 0, 7).unwrap();
    for ds in 1..=4 {
        assert_eq!(s.read(DATA_SET, ds), Ok(7));
    }
}
