//! The simulated MOVIDRIVE device: parameter services, process data, control and status words,
//! RS-485 timeout.

use std::time::Duration;

use drive_profile::sew;
use drive_profile::sew::{ControlWord1, Management, ParamChannel, ReturnCode, Service};
use drive_sim::movidrive::{
    BusSource, FAULT_RS485_TIMEOUT, FIRMWARE, Movidrive, PiFunction, TimeoutReaction, UNIT_TYPE,
    index,
};
use drive_sim::{DriveState, Instant};
use proptest::prelude::*;

fn ms(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

fn us(us: u64) -> Instant {
    Instant::from_micros(us)
}

/// Address 1, P100/P101 = RS-485, everything else at the table defaults.
fn bus_drive() -> Movidrive {
    let mut d = Movidrive::new(1);
    d.set_bus_control(BusSource::Rs485, Instant::ZERO);
    d
}

/// A parameter channel with service code `code` (also undefined ones), 4 data bytes.
fn request(code: u8, index: u16, data: u32) -> ParamChannel {
    ParamChannel {
        management: Management::from_raw(0x30 | code),
        subindex: 0,
        index,
        data,
    }
}

fn read(d: &mut Movidrive, index: u16, now: Instant) -> Result<u32, ReturnCode> {
    d.param_service(Service::Read, index, 0, now)
}

fn write(d: &mut Movidrive, index: u16, value: i64, now: Instant) -> Result<u32, ReturnCode> {
    d.param_service(Service::Write, index, value as u32, now)
}

fn write_volatile(
    d: &mut Movidrive,
    index: u16,
    value: i64,
    now: Instant,
) -> Result<u32, ReturnCode> {
    d.param_service(Service::WriteVolatile, index, value as u32, now)
}

fn pi(d: &Movidrive) -> [u16; 3] {
    let mut pi = [0; 3];
    d.process_input(&mut pi);
    pi
}

fn assert_rpm(d: &Movidrive, expected: f64) {
    let got = d.actual_speed_rpm();
    assert!(
        (got - expected).abs() < 0.01,
        "actual speed {got} 1/min, expected {expected} 1/min"
    );
}

/// Enabled at 0 ms with 1000 1/min (PO 0006 / 5000), at speed from 667 ms on.
fn running_drive() -> Movidrive {
    let mut d = bus_drive();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 1000.0);
    d
}

// ----- identity and settings -----

#[test]
fn new_takes_the_address_and_table_defaults() {
    let mut d = Movidrive::new(7);
    assert_eq!(d.address(), 7);
    assert_eq!(d.group_address(), 100);
    assert_eq!(d.rs485_timeout(), None);
    assert_eq!(
        d.rs485_timeout_reaction(),
        TimeoutReaction::RapidStopWarning
    );
    let t = Instant::ZERO;
    assert_eq!(read(&mut d, index::RS485_ADDRESS, t), Ok(7));
    assert_eq!(read(&mut d, index::PO1_DESCRIPTION, t), Ok(9));
    assert_eq!(read(&mut d, index::PO1_DESCRIPTION + 1, t), Ok(1));
    assert_eq!(read(&mut d, index::PO1_DESCRIPTION + 2, t), Ok(0));
    assert_eq!(read(&mut d, index::PI1_DESCRIPTION, t), Ok(6));
    assert_eq!(read(&mut d, index::PI1_DESCRIPTION + 1, t), Ok(1));
    assert_eq!(read(&mut d, index::PI1_DESCRIPTION + 2, t), Ok(2));
    assert_eq!(read(&mut d, index::PO_DATA_ENABLE, t), Ok(1));
    // an address beyond P810's range is clamped
    assert_eq!(Movidrive::new(200).address(), 99);
}

#[test]
fn identity_reads_back_nonzero() {
    let mut d = Movidrive::new(1);
    let t = Instant::ZERO;
    let unit_type = read(&mut d, index::UNIT_TYPE, t).unwrap();
    assert_ne!(unit_type, 0);
    assert_eq!(unit_type, UNIT_TYPE);
    // The manual's format "822609711 = 822 609 7.11": part number 822 609, version 7.11.
    let firmware = read(&mut d, index::FIRMWARE, t).unwrap();
    assert_eq!((firmware / 1000, firmware % 1000), (822_609, 711));
    assert_eq!(read(&mut d, index::RATED_CURRENT, t), Ok(4000));
    // identity survives a power cycle
    d.restart(ms(10));
    assert_eq!(read(&mut d, index::FIRMWARE, ms(10)), Ok(FIRMWARE));
}

#[test]
fn group_address_and_timeout_follow_their_parameters() {
    let mut d = Movidrive::new(3);
    write(&mut d, index::RS485_GROUP_ADDRESS, 105, ms(0)).unwrap();
    assert_eq!(d.group_address(), 105);
    // P812 counts in ms (size index 4, conversion index −3), step 10
    write(&mut d, index::RS485_TIMEOUT, 1500, ms(0)).unwrap();
    assert_eq!(d.rs485_timeout(), Some(Duration::from_millis(1500)));
    let p812 = sew::by_index(index::RS485_TIMEOUT).unwrap();
    assert_eq!((p812.size_index, p812.conversion_index), (4, -3));
}

// ----- parameter services -----

#[test]
fn write_counts_eeprom_writes_and_write_volatile_does_not() {
    let mut d = Movidrive::new(1);
    assert_eq!(d.nv_writes(index::RAMP_T11_UP_CW), Some(0));
    assert_eq!(write(&mut d, index::RAMP_T11_UP_CW, 1000, ms(5)), Ok(0));
    assert_eq!(d.nv_writes(index::RAMP_T11_UP_CW), Some(1));
    assert_eq!(d.last_nv_write(index::RAMP_T11_UP_CW), Some(ms(5)));
    assert_eq!(
        write_volatile(&mut d, index::RAMP_T11_UP_CW, 500, ms(6)),
        Ok(0)
    );
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(7)), Ok(500));
    assert_eq!(d.nv_writes(index::RAMP_T11_UP_CW), Some(1));
    assert_eq!(d.last_nv_write(index::RAMP_T11_UP_CW), Some(ms(5)));
    assert_eq!(d.nv_writes(1234), None);
    // power cycle: the volatile value is lost, the non-volatile one restored
    d.restart(ms(8));
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(8)), Ok(1000));
}

#[test]
fn writes_are_rounded_onto_the_step_grid() {
    let mut d = Movidrive::new(1);
    write_volatile(&mut d, index::RAMP_T11_UP_CW, 1005, ms(0)).unwrap();
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(0)), Ok(1000));
    write_volatile(&mut d, index::RAMP_T11_UP_CW, 15, ms(0)).unwrap();
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(0)), Ok(20));
}

#[test]
fn read_minimum_maximum_default() {
    let mut d = Movidrive::new(1);
    let t = Instant::ZERO;
    let svc = |d: &mut Movidrive, s, i| d.param_service(s, i, 0, t);
    assert_eq!(svc(&mut d, Service::ReadMinimum, 8470), Ok(0));
    assert_eq!(svc(&mut d, Service::ReadMaximum, 8470), Ok(2_000_000));
    assert_eq!(svc(&mut d, Service::ReadDefault, 8470), Ok(2000));
    assert_eq!(svc(&mut d, Service::ReadMaximum, 8304), Ok(12));
    assert_eq!(svc(&mut d, Service::ReadMinimum, 8598), Ok(100));
    assert_eq!(svc(&mut d, Service::ReadDefault, 8598), Ok(100));
    // no printed range: the 32-bit signed limits
    assert_eq!(svc(&mut d, Service::ReadMinimum, 8318), Ok(0x8000_0000));
    assert_eq!(svc(&mut d, Service::ReadMaximum, 8318), Ok(0x7fff_ffff));
    // the default is the table's, not the current value
    write_volatile(&mut d, 8470, 500, t).unwrap();
    assert_eq!(svc(&mut d, Service::ReadDefault, 8470), Ok(2000));
}

#[test]
fn read_scale_gives_size_and_conversion_index() {
    let mut d = Movidrive::new(1);
    let t = Instant::ZERO;
    // the manual's example: P131 → size index 4 (time), conversion index −3
    let p131 = d.param_service(Service::ReadScale, 8471, 0, t).unwrap();
    assert_eq!(p131.to_be_bytes(), [0, 0, 4, 0xfd]);
    assert_eq!(p131.to_be_bytes()[3] as i8, -3);
    // P000 speed: size index 11, conversion index 66 (1/min)
    let p000 = d.param_service(Service::ReadScale, 8318, 0, t).unwrap();
    assert_eq!(p000.to_be_bytes(), [0, 0, 11, 66]);
}

#[test]
fn read_attribute_gives_next_index_and_access_byte() {
    let mut d = Movidrive::new(1);
    let t = Instant::ZERO;
    let attr = |d: &mut Movidrive, i| d.param_service(Service::ReadAttribute, i, 0, t);
    // P130 N/RW → N (0x10) | RW (0x08); next index 8471
    assert_eq!(attr(&mut d, 8470), Ok(8471 << 16 | 0x18));
    // P000 RO (0x02); next 8319
    assert_eq!(attr(&mut d, 8318), Ok(8319 << 16 | 0x02));
    // P803 N/S/RW
    assert_eq!(attr(&mut d, 8595), Ok(8596 << 16 | 0x19));
    // P802 R/RW
    assert_eq!(attr(&mut d, 8594), Ok(8595 << 16 | 0x0c));
    // P852: its second index is the next one
    assert_eq!(attr(&mut d, 8772).map(|v| v >> 16), Ok(8773));
    // walking the chain from the first index visits every parameter and ends with 0
    let mut index = d.drive().store().keys().next().unwrap().0;
    let mut visited = 1;
    loop {
        let next = (attr(&mut d, index).unwrap() >> 16) as u16;
        if next == 0 {
            break;
        }
        assert!(next > index);
        index = next;
        visited += 1;
    }
    let distinct = {
        let mut keys: Vec<u16> = d.drive().store().keys().map(|k| k.0).collect();
        keys.dedup();
        keys.len()
    };
    assert_eq!(visited, distinct);
}

#[test]
fn unknown_index_answers_0x0010_for_every_service() {
    let mut d = Movidrive::new(1);
    for id in 1..=8 {
        let service = Service::from_code(id).unwrap();
        assert_eq!(service.code(), id);
        assert_eq!(
            d.param_service(service, 1234, 0, ms(0)),
            Err(ReturnCode::ILLEGAL_INDEX),
            "{service:?}"
        );
    }
    assert_eq!(ReturnCode::ILLEGAL_INDEX.to_bytes(), [8, 0, 0x00, 0x10]);
}

#[test]
fn unknown_service_answers_class_5_code_5() {
    let mut d = Movidrive::new(1);
    for id in [9u8, 10, 15, 0xff] {
        assert_eq!(
            d.param(&request(id, 8470, 0), ms(0)),
            Err(ReturnCode::ILLEGAL_SERVICE_CODING)
        );
    }
    assert_eq!(ReturnCode::ILLEGAL_SERVICE_CODING.to_bytes(), [5, 5, 0, 0]);
    assert_eq!(d.param(&request(0, 8470, 0), ms(0)), Ok(0));
    assert_eq!(d.param(&request(1, 8470, 0), ms(0)), Ok(2000));
}

#[test]
fn read_only_answers_0x0012() {
    let mut d = Movidrive::new(1);
    assert_eq!(write(&mut d, 8318, 1, ms(0)), Err(ReturnCode::READ_ONLY));
    assert_eq!(
        write_volatile(&mut d, 8301, 1, ms(0)),
        Err(ReturnCode::READ_ONLY)
    );
}

#[test]
fn parameter_lock_answers_0x0013() {
    let mut d = Movidrive::new(1);
    write(&mut d, index::PARAMETER_LOCK, 1, ms(0)).unwrap();
    assert_eq!(
        write(&mut d, index::RAMP_T11_UP_CW, 1000, ms(0)),
        Err(ReturnCode::PARAMETER_LOCK)
    );
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(0)), Ok(2000));
    // P803 and P876 carry S: writable under the lock
    write(&mut d, index::PO_DATA_ENABLE, 1, ms(0)).unwrap();
    write(&mut d, index::PARAMETER_LOCK, 0, ms(0)).unwrap();
    write(&mut d, index::RAMP_T11_UP_CW, 1000, ms(0)).unwrap();
}

#[test]
fn range_violations_answer_0x0015_and_0x0016() {
    let mut d = Movidrive::new(1);
    assert_eq!(
        write(&mut d, index::RAMP_T11_UP_CW, 2_000_001, ms(0)),
        Err(ReturnCode::VALUE_TOO_LARGE)
    );
    // P850 scaling factor numerator: 1…65535
    assert_eq!(
        write(&mut d, 8747, 0, ms(0)),
        Err(ReturnCode::VALUE_TOO_SMALL)
    );
    assert_eq!(
        write(&mut d, 8747, 65536, ms(0)),
        Err(ReturnCode::VALUE_TOO_LARGE)
    );
    assert_eq!(d.nv_writes(8747), Some(0));
}

#[test]
fn value_outside_the_value_list_answers_0x001d() {
    let mut d = Movidrive::new(1);
    assert_eq!(
        write(&mut d, index::PO1_DESCRIPTION, 13, ms(0)),
        Err(ReturnCode::INVALID_VALUE)
    );
    assert_eq!(
        write(&mut d, index::RS485_TIMEOUT_REACTION, 8, ms(0)),
        Err(ReturnCode::INVALID_VALUE)
    );
    assert_eq!(
        write(&mut d, index::PO1_DESCRIPTION, -1, ms(0)),
        Err(ReturnCode::INVALID_VALUE)
    );
    assert_eq!(read(&mut d, index::PO1_DESCRIPTION, ms(0)), Ok(9));
}

#[test]
fn r_parameter_needs_controller_inhibit_0x001c() {
    let mut d = running_drive();
    assert_eq!(
        write_volatile(&mut d, index::FACTORY_SETTING, 0, ms(1000)),
        Err(ReturnCode::CONTROLLER_INHIBIT_REQUIRED)
    );
    d.process_output(&[ControlWord1::INHIBIT.bits(), 5000], ms(1100));
    assert_eq!(
        write_volatile(&mut d, index::FACTORY_SETTING, 0, ms(1100)),
        Ok(0)
    );
}

#[test]
fn r_parameter_while_the_output_stage_is_still_on_answers_0x0020() {
    let mut d = running_drive();
    d.process_output(&[ControlWord1::STOP.bits(), 5000], ms(1000));
    d.tick(ms(1100));
    assert!(d.actual_speed_rpm() > 0.0);
    assert_eq!(
        write_volatile(&mut d, index::FACTORY_SETTING, 0, ms(1100)),
        Err(ReturnCode::OUTPUT_STAGE_ENABLED)
    );
    // at standstill the output stage is off, but controller inhibit is still required
    d.tick(ms(3000));
    assert_eq!(
        write_volatile(&mut d, index::FACTORY_SETTING, 0, ms(3000)),
        Err(ReturnCode::CONTROLLER_INHIBIT_REQUIRED)
    );
}

#[test]
fn every_return_code_is_in_the_manuals_table() {
    for rc in [
        ReturnCode::ILLEGAL_INDEX,
        ReturnCode::NOT_IMPLEMENTED,
        ReturnCode::READ_ONLY,
        ReturnCode::PARAMETER_LOCK,
        ReturnCode::VALUE_TOO_LARGE,
        ReturnCode::VALUE_TOO_SMALL,
        ReturnCode::SYSTEM_SOFTWARE_ERROR,
        ReturnCode::CONTROLLER_INHIBIT_REQUIRED,
        ReturnCode::INVALID_VALUE,
        ReturnCode::NOT_STORED_IN_EEPROM,
        ReturnCode::OUTPUT_STAGE_ENABLED,
        ReturnCode::ILLEGAL_SERVICE_CODING,
    ] {
        assert!(rc.describe().known.is_some(), "{rc:?}");
        assert!(!rc.to_string().is_empty());
        assert_eq!(rc.to_data().to_be_bytes(), rc.to_bytes());
    }
}

#[test]
fn shared_and_second_indices_are_readable() {
    let mut d = Movidrive::new(1);
    // P010…P013 all live at 8310; its low word is status word 1
    assert!(sew::all_by_index(8310).count() >= 4);
    let status = read(&mut d, index::DRIVE_STATUS, ms(0)).unwrap();
    assert_eq!(status, u32::from(d.status_word_1()));
    // P852 user unit: 8772 holds "1/mi", 8773 the rest
    assert_eq!(read(&mut d, index::USER_UNIT, ms(0)), Ok(1_768_763_185));
    assert_eq!(read(&mut d, index::USER_UNIT_2, ms(0)), Ok(0));
    assert_eq!(write(&mut d, index::USER_UNIT_2, 0x6e, ms(0)), Ok(0));
    assert_eq!(read(&mut d, index::USER_UNIT_2, ms(0)), Ok(0x6e));
    assert_eq!(d.nv_writes(index::USER_UNIT_2), Some(1));
    let scale = d.param_service(Service::ReadScale, index::USER_UNIT_2, 0, ms(0));
    assert_eq!(scale, Ok(0));
}

#[test]
fn factory_setting_restores_defaults_but_keeps_the_address() {
    let mut d = Movidrive::new(12);
    write(&mut d, index::RAMP_T11_UP_CW, 1000, ms(0)).unwrap();
    write(&mut d, index::FACTORY_SETTING, 1, ms(1)).unwrap();
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(2)), Ok(2000));
    assert_eq!(read(&mut d, index::FACTORY_SETTING, ms(2)), Ok(0));
    assert_eq!(d.address(), 12);
    d.restart(ms(3));
    assert_eq!(read(&mut d, index::RAMP_T11_UP_CW, ms(3)), Ok(2000));
}

// ----- process data, control and status words -----

#[test]
fn enable_ramps_to_1000_rpm_in_the_time_p130_says() {
    let mut d = bus_drive();
    // PO1 = control word 1 = enable, PO2 = speed 5000 × 0.2 = 1000 1/min
    d.process_output(&[0x0006, 5000], ms(0));
    assert_eq!(d.drive().state(), DriveState::Enabled);
    // P130 = 2 s per 3000 1/min: 1000 1/min take 666.7 ms, the midpoint is at 333.3 ms
    d.tick(us(333_333));
    assert_rpm(&d, 500.0);
    d.tick(us(666_667));
    assert_rpm(&d, 1000.0);
    d.tick(ms(1000));
    assert_rpm(&d, 1000.0);
    let [pi1, pi2, pi3] = pi(&d);
    // status word 1: output stage enabled, ready, PO data enabled; unit status 4 "enable"
    assert_eq!(pi1, 0x0407);
    assert_eq!(pi1, d.status_word_1());
    assert_eq!(pi2, 5000);
    // output current model: 20 % + 60 % × 1000/1500 = 60 %, 0.1 % per digit
    assert_eq!(pi3, 600);
    assert_eq!(read(&mut d, index::SPEED, ms(1000)), Ok(1_000_000));
    assert_eq!(
        read(&mut d, index::OUTPUT_CURRENT_PERCENT, ms(1000)),
        Ok(60_000)
    );
    assert_eq!(
        read(&mut d, index::OUTPUT_CURRENT_AMPERE, ms(1000)),
        Ok(2_400)
    );
    assert_eq!(read(&mut d, index::DRIVE_STATUS, ms(1000)), Ok(0x0407));
}

#[test]
fn zero_setpoint_does_not_move_the_drive() {
    let mut d = bus_drive();
    d.process_output(&[ControlWord1::ENABLE.bits(), 0], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x0407);
}

#[test]
fn p130_changes_the_ramp() {
    let mut d = bus_drive();
    write_volatile(&mut d, index::RAMP_T11_UP_CW, 1000, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(us(166_667));
    assert_rpm(&d, 500.0);
}

#[test]
fn negative_speed_uses_the_ccw_ramps() {
    let mut d = bus_drive();
    write_volatile(&mut d, index::RAMP_T11_UP_CCW, 1000, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), (-5000i16) as u16], ms(0));
    d.tick(us(166_667));
    assert_rpm(&d, -500.0);
    d.tick(ms(1000));
    assert_eq!(pi(&d)[1], (-5000i16) as u16);
}

#[test]
fn stop_decelerates_on_the_p131_ramp() {
    let mut d = running_drive();
    d.process_output(&[ControlWord1::STOP.bits(), 5000], ms(1000));
    assert_eq!(d.drive().state(), DriveState::Ready);
    d.tick(us(1_333_333));
    assert_rpm(&d, 500.0);
    assert_eq!(d.status_word_1() & 0x0001, 0x0001);
    d.tick(ms(1700));
    assert_rpm(&d, 0.0);
    // standstill without enable: output stage off, unit status 2 "no enable"
    assert_eq!(d.status_word_1(), 0x0206);
}

#[test]
fn rapid_stop_uses_the_stop_ramp_t13() {
    let mut d = running_drive();
    write_volatile(&mut d, index::STOP_RAMP_T13, 500, ms(1000)).unwrap();
    d.process_output(&[ControlWord1::RAPID_STOP.bits(), 5000], ms(1000));
    assert_eq!(d.drive().state(), DriveState::QuickStop);
    // 3000 1/min per 0.5 s: 600 1/min in 100 ms
    d.tick(ms(1100));
    assert_rpm(&d, 400.0);
    d.tick(ms(1200));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x0206);
}

#[test]
fn controller_inhibit_switches_the_output_stage_off() {
    let mut d = running_drive();
    d.process_output(&[ControlWord1::INHIBIT.bits(), 5000], ms(1000));
    assert_eq!(d.drive().state(), DriveState::Inhibited);
    d.tick(ms(1001));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x0106);
    assert_eq!(pi(&d)[2], 0);
}

#[test]
fn integrator_and_parameter_set_bits_select_ramps_and_show_in_the_status() {
    let mut d = bus_drive();
    // integrator 2: t12 (P134, 10 s per 3000 1/min)
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::INTEGRATOR_2.bits(),
            5000,
        ],
        ms(0),
    );
    d.tick(ms(1000));
    assert_rpm(&d, 300.0);
    assert_eq!(d.status_word_1() & 0x18, 0x08);
    // parameter set 2: t21 (P140 = 2 s), status bit 4
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::PARAMETER_SET_2.bits(),
            5000,
        ],
        ms(1000),
    );
    d.tick(ms(1100));
    assert_rpm(&d, 450.0);
    assert_eq!(d.status_word_1() & 0x18, 0x10);
}

#[test]
fn p870_mapping_changes_what_po1_means() {
    // default mapping: PO1 = control word → 5000 = 0x1388 has bit 1 clear = rapid stop
    let mut d = bus_drive();
    d.process_output(&[5000, ControlWord1::ENABLE.bits()], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 0.0);
    assert_eq!(d.drive().state(), DriveState::Inhibited);

    // PO1 = speed, PO2 = control word 1
    let mut d = bus_drive();
    write(&mut d, index::PO1_DESCRIPTION, 1, ms(0)).unwrap();
    write(&mut d, index::PO1_DESCRIPTION + 1, 9, ms(0)).unwrap();
    d.process_output(&[5000, ControlWord1::ENABLE.bits()], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 1000.0);

    // PO2 = speed [%]: 0x2000 = 50 % of P302 (1500 1/min)
    let mut d = bus_drive();
    write(&mut d, index::PO1_DESCRIPTION + 1, 11, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 0x2000], ms(0));
    d.tick(ms(2000));
    assert_rpm(&d, 750.0);
    assert_eq!(d.pi_word(PiFunction::SpeedPercent), 0x2000);
    assert_eq!(d.pi_word(PiFunction::Speed), 3750);

    // PO3 = ramp: 500 ms per 3000 1/min for up and down
    let mut d = bus_drive();
    write(&mut d, index::PO1_DESCRIPTION + 2, 8, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000, 500], ms(0));
    d.tick(ms(100));
    assert_rpm(&d, 600.0);

    // PO3 = maximum speed: 2500 × 0.2 = 500 1/min limit
    let mut d = bus_drive();
    write(&mut d, index::PO1_DESCRIPTION + 2, 5, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000, 2500], ms(0));
    d.tick(ms(2000));
    assert_rpm(&d, 500.0);
}

#[test]
fn p873_mapping_changes_what_the_pi_words_carry() {
    let mut d = running_drive();
    write(&mut d, index::PI1_DESCRIPTION, 7, ms(1000)).unwrap(); // status word 2
    write(&mut d, index::PI1_DESCRIPTION + 1, 3, ms(1000)).unwrap(); // active current
    write(&mut d, index::PI1_DESCRIPTION + 2, 0, ms(1000)).unwrap(); // none
    let [pi1, pi2, pi3] = pi(&d);
    // brake released, DO01 ready, DO02 /fault; low byte as status word 1
    assert_eq!(pi1, 0x0707);
    assert_eq!(pi2, 400);
    assert_eq!(pi3, 0);
    // a longer buffer gets zeros beyond PI3
    let mut long = [0xffffu16; 5];
    d.process_input(&mut long);
    assert_eq!(long, [0x0707, 400, 0, 0, 0]);
}

#[test]
fn position_is_integrated_from_the_speed() {
    let mut d = bus_drive();
    write(&mut d, index::PI1_DESCRIPTION + 1, 4, ms(0)).unwrap();
    write(&mut d, index::PI1_DESCRIPTION + 2, 5, ms(0)).unwrap();
    write_volatile(&mut d, index::RAMP_T11_UP_CW, 0, ms(0)).unwrap();
    // 1500 1/min = 25 rev/s for 2 s = 50 rev = 204800 increments
    d.process_output(&[ControlWord1::ENABLE.bits(), 7500], ms(0));
    d.tick(ms(2000));
    assert_eq!(d.position_increments(), 204_800);
    let [_, lo, hi] = pi(&d);
    assert_eq!((u32::from(hi) << 16) | u32::from(lo), 204_800);
    assert_eq!(read(&mut d, index::POSITION, ms(2000)), Ok(204_800));
}

#[test]
fn po_data_are_ignored_while_p876_is_off() {
    let mut d = bus_drive();
    write(&mut d, index::PO_DATA_ENABLE, 0, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 0.0);
    assert_eq!(d.process_output_words(), [0, 0, 0]);
    assert_eq!(d.status_word_1() & 0x0004, 0);
}

#[test]
fn terminal_control_keeps_the_drive_inhibited() {
    // factory setting: P100/P101 = terminals; no binary inputs are simulated
    let mut d = Movidrive::new(1);
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 0.0);
    assert!(!d.po_data_enabled());
    assert_eq!(d.status_word_1(), 0x0102);
    // P101 = RS485 but P100 still terminals: enabled, setpoint 0
    write(&mut d, index::CONTROL_SOURCE, 1, ms(1000)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(1000));
    d.tick(ms(2000));
    assert_eq!(d.status_word_1(), 0x0407);
    assert_rpm(&d, 0.0);
    // SBus as source works the same, with the SBus monitor off (P815 = 0; its factory
    // setting, 100 ms, would hold the drive until SBus process data and then fault it, F47)
    let mut d = Movidrive::new(1);
    d.set_bus_control(BusSource::SBus, ms(0));
    write(&mut d, index::SBUS_TIMEOUT, 0, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(ms(1000));
    assert_rpm(&d, 1000.0);
}

// ----- RS-485 timeout -----

/// Monitor on (P812 = 100 ms), enabled at 1000 1/min by cyclic telegrams every 50 ms until
/// 1000 ms.
fn monitored_drive(reaction: i64) -> Movidrive {
    let mut d = bus_drive();
    write(&mut d, index::RS485_TIMEOUT, 100, ms(0)).unwrap();
    write(&mut d, index::RS485_TIMEOUT_REACTION, reaction, ms(0)).unwrap();
    write_volatile(&mut d, index::STOP_RAMP_T13, 500, ms(0)).unwrap();
    write_volatile(&mut d, index::EMERGENCY_RAMP_T14, 300, ms(0)).unwrap();
    for t in (0..=1000).step_by(50) {
        d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(t));
        d.cyclic_telegram_received(ms(t));
    }
    assert_rpm(&d, 1000.0);
    d
}

#[test]
fn timeout_with_rapid_stop_warning_stops_and_resumes() {
    let mut d = monitored_drive(7);
    // deadline 1100 ms: not yet at 1100
    d.tick(ms(1100));
    assert_eq!(d.timeout_warning(), None);
    assert_rpm(&d, 1000.0);
    // fired at 1100 ms, rapid stop on t13 = 500 ms per 3000 1/min
    d.tick(ms(1150));
    assert_eq!(d.timeout_warning(), Some(TimeoutReaction::RapidStopWarning));
    assert_rpm(&d, 700.0);
    let sw1 = d.status_word_1();
    assert_eq!(sw1 >> 8, FAULT_RS485_TIMEOUT);
    // warning: fault/warning bit, still ready
    assert_eq!(sw1 & 0x00ff, 0x0027);
    d.tick(ms(2000));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x2B26);
    // communication resumes: the last process data are effective again
    d.cyclic_telegram_received(ms(2000));
    assert_eq!(d.timeout_warning(), None);
    assert_eq!(d.drive().state(), DriveState::Enabled);
    for t in (2050..=3000).step_by(50) {
        d.cyclic_telegram_received(ms(t));
    }
    assert_rpm(&d, 1000.0);
    assert_eq!(d.status_word_1(), 0x0407);
}

#[test]
fn timeout_with_emergency_stop_warning_uses_t14() {
    let mut d = monitored_drive(6);
    d.tick(ms(1150));
    // 3000 1/min per 0.3 s: 500 1/min in 50 ms
    assert_rpm(&d, 500.0);
}

#[test]
fn timeout_with_immediate_stop_warning_coasts() {
    let mut d = monitored_drive(5);
    d.tick(ms(1101));
    assert_rpm(&d, 0.0);
    assert_eq!(d.drive().state(), DriveState::Inhibited);
    assert_eq!(d.status_word_1() >> 8, FAULT_RS485_TIMEOUT);
}

#[test]
fn timeout_with_rapid_stop_fault_latches_until_reset() {
    let mut d = monitored_drive(4);
    d.tick(ms(1150));
    assert_eq!(d.drive().state(), DriveState::Fault(FAULT_RS485_TIMEOUT));
    assert_rpm(&d, 700.0);
    // decelerating: output stage still on; fault, not ready
    assert_eq!(d.status_word_1(), 0x2B25);
    d.tick(ms(2000));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x2B24);
    assert_eq!(read(&mut d, index::FAULT_T0, ms(2000)), Ok(43));
    // communication resumes: the fault stays
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(2000));
    d.cyclic_telegram_received(ms(2000));
    d.tick(ms(2500));
    assert_eq!(d.drive().state(), DriveState::Fault(FAULT_RS485_TIMEOUT));
    // fault reset on the rising edge of bit 6
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::FAULT_RESET.bits(),
            5000,
        ],
        ms(2500),
    );
    assert_eq!(d.fault_number(), None);
    // after the reset the drive is held until the next cyclic telegram
    assert!(d.held_until_first_telegram());
    d.tick(ms(2520));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x0206);
    d.cyclic_telegram_received(ms(2520));
    assert_eq!(d.drive().state(), DriveState::Enabled);
    for t in (2550..=3600).step_by(50) {
        d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(t));
        d.cyclic_telegram_received(ms(t));
    }
    assert_rpm(&d, 1000.0);
}

#[test]
fn fault_reset_acts_on_the_edge_only() {
    let mut d = monitored_drive(2);
    d.tick(ms(1101));
    assert_eq!(d.drive().state(), DriveState::Fault(43));
    assert_rpm(&d, 0.0);
    // immediate stop: output stage off at once
    assert_eq!(d.status_word_1(), 0x2B24);
    // bit 6 already set before the fault: holding it does nothing, a new edge resets
    let mut d = monitored_drive(2);
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::FAULT_RESET.bits(),
            5000,
        ],
        ms(1000),
    );
    d.tick(ms(1200));
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::FAULT_RESET.bits(),
            5000,
        ],
        ms(1200),
    );
    assert_eq!(d.drive().state(), DriveState::Fault(43));
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(1210));
    d.process_output(
        &[
            ControlWord1::ENABLE.bits() | ControlWord1::FAULT_RESET.bits(),
            5000,
        ],
        ms(1220),
    );
    assert_eq!(d.fault_number(), None);
    // held until the next cyclic telegram: enable acts as stop
    assert_eq!(d.drive().state(), DriveState::Ready);
}

#[test]
fn timeout_is_off_with_p812_zero_and_with_acyclic_traffic_only() {
    let mut d = bus_drive();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.cyclic_telegram_received(ms(0));
    d.tick(ms(60_000));
    assert_rpm(&d, 1000.0);
    assert_eq!(d.fault_number(), None);
    // monitor on but only acyclic telegrams: never armed
    let mut d = bus_drive();
    write(&mut d, index::RS485_TIMEOUT, 100, ms(0)).unwrap();
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(0));
    d.tick(ms(10_000));
    assert_eq!(d.fault_number(), None);
    assert_rpm(&d, 1000.0);
}

#[test]
fn no_response_reaction_does_nothing() {
    let mut d = monitored_drive(0);
    d.tick(ms(5000));
    assert_eq!(d.fault_number(), None);
    assert_rpm(&d, 1000.0);
}

#[test]
fn display_fault_shows_43_and_keeps_running() {
    let mut d = monitored_drive(1);
    d.tick(ms(5000));
    assert_eq!(d.fault_number(), Some(43));
    assert_rpm(&d, 1000.0);
    assert_eq!(d.status_word_1(), 0x2B27);
    d.cyclic_telegram_received(ms(5000));
    assert_eq!(d.fault_number(), None);
}

#[test]
fn held_safe_after_power_on_until_the_first_cyclic_telegram() {
    let mut d = bus_drive();
    write(&mut d, index::RS485_TIMEOUT, 100, ms(0)).unwrap();
    d.restart(ms(0));
    assert!(d.held_until_first_telegram());
    // acyclic telegrams do not release the hold
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(10));
    d.tick(ms(500));
    assert_rpm(&d, 0.0);
    assert_eq!(d.status_word_1(), 0x0206);
    d.cyclic_telegram_received(ms(500));
    assert!(!d.held_until_first_telegram());
    assert_eq!(d.drive().state(), DriveState::Enabled);
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000], ms(550));
    d.cyclic_telegram_received(ms(550));
    d.tick(ms(600));
    assert!(d.actual_speed_rpm() > 0.0);
}

#[test]
fn manual_example_ch_4_3_is_reproduced() {
    // PO1 control word 1, PO2 speed [%], PO3 ramp; PI1 status word 1, PI2 speed [%],
    // PI3 status word 2
    let mut d = bus_drive();
    let t = ms(0);
    write(&mut d, index::PO1_DESCRIPTION + 1, 11, t).unwrap();
    write(&mut d, index::PO1_DESCRIPTION + 2, 8, t).unwrap();
    write(&mut d, index::PI1_DESCRIPTION + 1, 8, t).unwrap();
    write(&mut d, index::PI1_DESCRIPTION + 2, 7, t).unwrap();
    write(&mut d, index::RS485_TIMEOUT, 1000, t).unwrap();
    d.restart(t);
    // the example's telegram is acyclic (PDU type 85h): the enable is not yet effective
    d.process_output(&[0x0006, 0x2000, 0x0bb8], ms(10));
    assert_eq!(pi(&d), [0x0206, 0x0000, 0x0606]);
    // with the first cyclic telegram it is: 50 % of 1500 1/min on a 3 s ramp
    d.cyclic_telegram_received(ms(10));
    d.tick(ms(385));
    assert_rpm(&d, 375.0);
    d.process_output(&[0x0006, 0x2000, 0x0bb8], ms(760));
    d.cyclic_telegram_received(ms(760));
    assert_rpm(&d, 750.0);
    assert_eq!(pi(&d), [0x0407, 0x2000, 0x0707]);
}

// ----- robustness -----

fn interesting_index() -> impl Strategy<Value = u16> {
    prop_oneof![
        any::<u16>(),
        8290u16..8800,
        prop::sample::select(vec![
            8304u16, 8305, 8306, 8307, 8308, 8309, 8310, 8318, 8461, 8462, 8470, 8476, 8594, 8595,
            8596, 8597, 8599, 8612, 8622, 8772, 8773,
        ]),
    ]
}

#[derive(Debug, Clone)]
enum Op {
    Service(u8, u16, u32),
    Po(Vec<u16>),
    Cyclic,
    Tick,
    Restart,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (0u8..16, interesting_index(), any::<u32>()).prop_map(|(s, i, d)| Op::Service(s, i, d)),
        (0u8..16, interesting_index(), 0u32..20).prop_map(|(s, i, d)| Op::Service(s, i, d)),
        prop::collection::vec(any::<u16>(), 0..5).prop_map(Op::Po),
        Just(Op::Cyclic),
        Just(Op::Tick),
        Just(Op::Restart),
    ]
}

proptest! {
    #[test]
    fn arbitrary_services_and_process_data_never_panic(
        ops in prop::collection::vec((op(), 0u64..500), 1..60),
    ) {
        let mut d = bus_drive();
        let mut now = Instant::ZERO;
        for (op, step) in ops {
            now += Duration::from_millis(step);
            match op {
                Op::Service(s, i, data) => {
                    let _ = d.param(&request(s, i, data), now);
                }
                Op::Po(words) => d.process_output(&words, now),
                Op::Cyclic => d.cyclic_telegram_received(now),
                Op::Tick => d.tick(now),
                Op::Restart => d.restart(now),
            }
            let mut pi = [0u16; 4];
            d.process_input(&mut pi);
            prop_assert!(d.actual_speed_rpm().is_finite());
            let sw1 = d.status_word_1();
            // bit 5 set exactly when the high byte is a fault number
            prop_assert_eq!(sw1 & 0x20 != 0, d.fault_number().is_some());
            prop_assert_eq!(pi[3], 0);
        }
    }
}
