//! The SBus part of the simulated MOVIDRIVE: the P815 monitor (held "t", lapse when not
//! enabled, warning reaction, 650 s = off) without a front-end.

use std::time::Duration;

use drive_profile::sew::{ControlWord1, ParamChannel, index};
use drive_sim::Instant;
use drive_sim::movidrive::{BusSource, FAULT_SBUS_TIMEOUT, Movidrive, TimeoutReaction};

fn ms(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

fn sbus_drive() -> Movidrive {
    let mut d = Movidrive::new(0);
    d.set_bus_control(BusSource::SBus, Instant::ZERO);
    d
}

fn set(d: &mut Movidrive, i: u16, v: u32, t: Instant) {
    d.param(&ParamChannel::write_volatile(i, v), t).unwrap();
}

fn pd(d: &mut Movidrive, words: [u16; 3], t: Instant) {
    d.sbus_process_data_received(t);
    d.process_output(&words, t);
}

#[test]
fn held_until_first_sbus_process_data_ch_6_1() {
    let mut d = sbus_drive();
    assert!(d.sbus_held());
    d.process_output(&[ControlWord1::ENABLE.bits(), 5000, 0], ms(0));
    d.tick(ms(10));
    assert_eq!(d.status_word_1() >> 8, 2, "no enable while held ('t')");
    pd(&mut d, [ControlWord1::ENABLE.bits(), 5000, 0], ms(10));
    assert!(!d.sbus_held());
    assert_eq!(d.status_word_1() >> 8, 4);
    // A MOVILINK drive (P100/P101 = RS485) is not monitored by P815.
    let mut m = Movidrive::new(1);
    m.set_bus_control(BusSource::Rs485, ms(0));
    assert!(!m.sbus_held() && m.sbus_deadline().is_none());
}

#[test]
fn not_enabled_the_monitor_lapses_without_fault() {
    let mut d = sbus_drive();
    pd(&mut d, [ControlWord1::STOP.bits(), 0, 0], ms(0));
    assert_eq!(d.sbus_deadline(), Some(ms(100) + Duration::from_nanos(1)));
    d.tick(ms(1000));
    assert_eq!(d.fault_number(), None);
    assert_eq!(
        d.sbus_deadline(),
        None,
        "re-armed by the next process data only"
    );
}

#[test]
fn warning_reaction_ends_with_the_next_process_data() {
    let mut d = sbus_drive();
    set(&mut d, index::SBUS_TIMEOUT_REACTION, 7, ms(0)); // rapid stop / warning
    pd(&mut d, [ControlWord1::ENABLE.bits(), 5000, 0], ms(0));
    d.tick(ms(100));
    assert_eq!(d.timeout_warning(), None);
    d.tick(ms(101));
    assert_eq!(d.timeout_warning(), Some(TimeoutReaction::RapidStopWarning));
    assert_eq!(d.fault_number(), Some(FAULT_SBUS_TIMEOUT));
    pd(&mut d, [ControlWord1::ENABLE.bits(), 5000, 0], ms(200));
    assert_eq!(d.timeout_warning(), None);
    assert_eq!(d.status_word_1() >> 8, 4);
}

#[test]
fn p815_650_s_is_off() {
    let mut d = sbus_drive();
    set(&mut d, index::SBUS_TIMEOUT, 650_000, ms(0));
    assert_eq!(d.sbus_timeout(), None);
    set(&mut d, index::SBUS_TIMEOUT, 649_990, ms(0));
    assert_eq!(d.sbus_timeout(), Some(Duration::from_millis(649_990)));
}
