//! The simulated Bonfiglioli ACT / ACU (manual `bonfiglioli-active-modbus-de.txt`), on a manual
//! clock.

use std::time::Duration;

use drive_profile::bonfiglioli::{self, DataType, State};
use drive_profile::state::StateMachine;
use drive_sim::Instant;
use drive_sim::bonfiglioli::{
    CHOSEN_WIDTHS, FAULT_WATCHDOG, Input, Refusal, SIM_DEFAULTS, SimulatedBonfiglioli, VabusCause,
    Variant, Width, width_of,
};

use Width::{Long, Word};

fn ms(n: u64) -> Instant {
    Instant::ZERO + Duration::from_millis(n)
}

/// Exception code and register value of a refusal.
fn refusal<T: std::fmt::Debug>(r: Result<T, Refusal>) -> (u8, Option<u16>) {
    let e = r.unwrap_err();
    (e.exception(), e.vabus())
}

/// A drive in *Local/Remote* 412 = 1 (state machine), data set 0 (all four), at t = 0.
fn bus_drive(variant: Variant) -> SimulatedBonfiglioli {
    let mut d = SimulatedBonfiglioli::new(variant);
    d.write(412, 0, Word, 1, ms(0)).unwrap();
    d
}

fn status(d: &mut SimulatedBonfiglioli, t: Instant) -> u16 {
    d.read(411, 0, Word, t).unwrap() as u16
}

fn cw(d: &mut SimulatedBonfiglioli, word: u16, t: Instant) {
    d.write(410, 0, Word, u32::from(word), t).unwrap();
}

/// Bits 0…3, 5, 6 of the status word (the state pattern of ch. 9.1.2 / 10.2).
fn pattern(d: &mut SimulatedBonfiglioli, t: Instant) -> u16 {
    status(d, t) & 0x6F
}

// ----- widths, defaults -----

#[test]
fn every_parameter_without_a_stated_type_has_a_chosen_width() {
    for p in bonfiglioli::params() {
        let listed = CHOSEN_WIDTHS.iter().any(|(n, _)| *n == p.number);
        assert_eq!(
            listed,
            p.data_type == DataType::Unknown,
            "P{}: listed in CHOSEN_WIDTHS exactly when the manual gives no type",
            p.number
        );
        let expected = match p.data_type {
            DataType::Long => Some(Long),
            DataType::UInt | DataType::Int => Some(Word),
            _ => CHOSEN_WIDTHS
                .iter()
                .find(|(n, _)| *n == p.number)
                .map(|e| e.1),
        };
        assert_eq!(width_of(p.number), expected, "P{}", p.number);
        // A chosen word must hold the whole range.
        if let (Some(Word), Some((lo, hi))) = (width_of(p.number), p.range()) {
            assert!(lo >= i64::from(i16::MIN) && hi <= 0xFFFF, "P{}", p.number);
        }
    }
    assert_eq!(width_of(1600), None);
}

trait Range {
    fn range(&self) -> Option<(i64, i64)>;
}
impl Range for bonfiglioli::Param {
    fn range(&self) -> Option<(i64, i64)> {
        drive_profile::ParamMeta::raw_range(self)
    }
}

#[test]
fn simulator_defaults_are_in_the_table_and_in_range() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    for (n, raw) in SIM_DEFAULTS {
        let p = bonfiglioli::by_number(*n).unwrap_or_else(|| panic!("P{n} not in the table"));
        if let Some((lo, hi)) = p.range() {
            assert!((lo..=hi).contains(raw), "P{n} = {raw} outside {lo}…{hi}");
        }
        let w = width_of(*n).unwrap();
        let got = d.read(*n, 0, w, ms(0)).unwrap();
        let got = if w == Word {
            i64::from(got as u16)
        } else {
            i64::from(got as i32)
        };
        assert_eq!(got, *raw, "P{n}");
    }
    assert_eq!(d.eeprom_writes(), 0, "defaults are not writes");
}

// ----- the manual's examples (ch. 8.1) -----

#[test]
fn manual_examples_8_1() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    // 8.1.1 example 1: FC 3, 0x2174 = data set 2, P372 → 0x056E = 1390 1/min.
    assert_eq!(d.read(372, 2, Word, ms(0)), Ok(0x056E));
    // 8.1.2 example 1: FC 6, 0x4178 = data set 4, P376 ← 0x000F (1.5 kW) is echoed.
    assert_eq!(d.write(376, 4, Word, 0x000F, ms(0)), Ok(()));
    // 8.1.2 example 2: FC 6, 0x2178 = data set 2, P376 ← 0 → exception 4 (value out of range).
    assert_eq!(refusal(d.write(376, 2, Word, 0, ms(0))), (4, Some(1)));
    // 8.1.3 example 1: FC 100, 0x01E1 = data set 0, P481 → 0x000003E8 = 10.00 Hz.
    assert_eq!(d.read(481, 0, Long, ms(0)), Ok(0x0000_03E8));
    // 8.1.3 example 2: FC 100, 0x2640 = data set 2, P1600 (unknown) → exception 4; P11 = 11.
    assert_eq!(refusal(d.read(1600, 2, Long, ms(0))), (4, Some(11)));
    assert_eq!(d.read(11, 0, Word, ms(0)), Ok(11));
    // 8.1.4 example 1: FC 101, 0x2177 = data set 2, P375 ← 0x000003E8 (10.00 Hz) is echoed.
    assert_eq!(d.write(375, 2, Long, 0x0000_03E8, ms(0)), Ok(()));
    // 8.1.4 example 2: FC 101, 0x2177, P375 ← 0x00000384 (9.00 Hz) → exception 4.
    assert_eq!(
        refusal(d.write(375, 2, Long, 0x0000_0384, ms(0))),
        (4, Some(1))
    );
    assert_eq!(
        d.read(375, 2, Long, ms(0)),
        Ok(1000),
        "the refused write changed nothing"
    );
}

// ----- refusals and register 11 -----

#[test]
fn wrong_width_is_exception_2_and_leaves_register_11() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    d.write(411, 0, Word, 0, ms(0)).unwrap_err(); // read-only: register = 4
    assert_eq!(d.error_register(), 4);
    let e = d.read(241, 0, Word, ms(0)).unwrap_err(); // Long read with FC 3
    assert_eq!(
        e,
        Refusal::WrongWidth {
            param: 241,
            requested: Word,
            actual: Long
        }
    );
    assert_eq!((e.exception(), e.vabus()), (2, None));
    assert_eq!(refusal(d.write(372, 0, Long, 1390, ms(0))), (2, None)); // uInt written with FC 101
    assert_eq!(refusal(d.read(413, 0, Long, ms(0))), (2, None)); // chosen width: Word
    assert_eq!(
        d.error_register(),
        4,
        "exception 2 does not touch parameter 11"
    );
    assert_eq!(refusal(d.read(11, 0, Long, ms(0))), (2, None));
    assert_eq!(
        d.error_register(),
        4,
        "a refused read of 11 does not clear it"
    );
}

#[test]
fn register_11_holds_the_last_cause_and_reading_clears_it() {
    let mut d = SimulatedBonfiglioli::new(Variant::Acu);
    let t = ms(0);
    assert_eq!(d.read(11, 0, Word, t), Ok(0));
    type Access = fn(&mut SimulatedBonfiglioli) -> Result<(), Refusal>;
    let cases: [(Access, VabusCause); 6] = [
        (
            |d| d.write(376, 1, Word, 0, ms(0)),
            VabusCause::ValueOutOfRange,
        ), // 1
        (
            |d| d.write(413, 1, Word, 5, ms(0)),
            VabusCause::InvalidDataSet,
        ), // 2: 413 exists once
        (
            |d| d.read(484, 0, Long, ms(0)).map(drop),
            VabusCause::WriteOnly,
        ), // 3: ACU 484
        (|d| d.write(260, 0, Word, 0, ms(0)), VabusCause::ReadOnly), // 4
        (
            |d| d.write(1599, 0, Word, 0, ms(0)),
            VabusCause::UnknownParameter,
        ), // 11
        (
            |d| d.read(372, 12, Word, ms(0)).map(drop),
            VabusCause::InvalidDataSet,
        ), // data set 12
    ];
    for (access, cause) in cases {
        assert_eq!(access(&mut d), Err(Refusal::Device(cause)));
        assert_eq!(d.error_register(), cause.code());
        assert_eq!(
            d.read(11, 0, Word, t),
            Ok(u32::from(cause.code())),
            "{cause}"
        );
        assert_eq!(d.read(11, 0, Word, t), Ok(0), "cleared after {cause}");
    }
    // Each cause has its meaning in the profile's table.
    assert_eq!(
        VabusCause::NotWhileRunning.meaning().map(|m| m.value),
        Some(8)
    );
    // A later refusal overwrites an earlier one.
    d.write(411, 0, Word, 0, t).unwrap_err();
    d.read(1600, 0, Word, t).unwrap_err();
    assert_eq!(d.read(11, 0, Word, t), Ok(11));
}

#[test]
fn not_writable_while_running_is_vabus_8() {
    let mut d = bus_drive(Variant::Act);
    cw(&mut d, 0x0F, ms(0));
    assert_eq!(d.state(), State::OperationEnabled);
    assert_eq!(refusal(d.write(34, 0, Word, 123, ms(10))), (4, Some(8)));
    cw(&mut d, 0x00, ms(20)); // disable voltage: coasts, output stage off
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.write(34, 0, Word, 123, ms(30)), Ok(()));
}

#[test]
fn write_only_on_the_acu_readable_on_the_act() {
    let mut acu = SimulatedBonfiglioli::new(Variant::Acu);
    acu.write(484, 0, Long, 2500, ms(0)).unwrap();
    acu.write(524, 0, Long, (-1000i32) as u32, ms(0)).unwrap();
    assert_eq!(refusal(acu.read(484, 0, Long, ms(0))), (4, Some(3)));
    assert_eq!(refusal(acu.read(524, 0, Long, ms(0))), (4, Some(3)));
    // …but their read-backs are there: 282 bus reference, 229 percentage reference.
    assert_eq!(acu.read(282, 0, Long, ms(0)), Ok(2500));
    assert_eq!(acu.read(229, 0, Long, ms(0)), Ok((-1000i32) as u32));

    let mut act = SimulatedBonfiglioli::new(Variant::Act);
    act.write(484, 0, Long, (-500i32) as u32, ms(0)).unwrap();
    assert_eq!(act.read(484, 0, Long, ms(0)), Ok(0xFFFF_FE0C)); // −5.00 Hz
    assert_eq!(
        refusal(act.write(484, 0, Long, 100_000, ms(0))),
        (4, Some(1))
    ); // > 999.99 Hz
}

// ----- data sets and EEPROM -----

#[test]
fn data_set_0_writes_all_four_and_reads_only_while_equal() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    let t = ms(0);
    d.write(372, 0, Word, 1400, t).unwrap();
    for ds in 1..=4 {
        assert_eq!(d.read(372, ds, Word, t), Ok(1400));
        assert_eq!(d.eeprom_writes_of(372, ds), Some(1));
    }
    assert_eq!(d.eeprom_writes(), 4, "data set 0 is four EEPROM writes");
    assert_eq!(d.read(372, 0, Word, t), Ok(1400));
    d.write(372, 3, Word, 1450, t).unwrap();
    assert_eq!(d.eeprom_writes(), 5);
    assert_eq!(refusal(d.read(372, 0, Word, t)), (4, Some(9)));
    assert_eq!(d.read(11, 0, Word, t), Ok(9));
    assert_eq!(d.read(372, 3, Word, t), Ok(1450));
    assert_eq!(d.read(372, 2, Word, t), Ok(1400));
    d.write(372, 0, Word, 1390, t).unwrap();
    assert_eq!(d.read(372, 0, Word, t), Ok(1390));
}

#[test]
fn ram_data_sets_5_to_9_write_no_eeprom_and_are_lost_at_restart() {
    let mut d = SimulatedBonfiglioli::new(Variant::Acu);
    let t = ms(0);
    d.write(372, 2, Word, 1400, t).unwrap(); // EEPROM
    for i in 0..1000 {
        d.write(372, 7, Word, 1000 + i, t).unwrap(); // data set 2 + 5: RAM only
    }
    d.write(372, 5, Word, 1200, t).unwrap(); // all four, RAM only
    assert_eq!(d.eeprom_writes(), 1);
    assert_eq!(d.read(372, 0, Word, t), Ok(1200));
    assert_eq!(
        d.read(372, 7, Word, t),
        Ok(1200),
        "a read of 5…9 reads the same RAM"
    );
    d.restart(ms(1));
    assert_eq!(d.read(372, 2, Word, ms(1)), Ok(1400));
    assert_eq!(d.read(372, 1, Word, ms(1)), Ok(1390));
}

#[test]
fn ram_only_parameters_never_write_eeprom() {
    let mut d = bus_drive(Variant::Act);
    let before = d.eeprom_writes();
    assert_eq!(before, 4, "412 in data set 0 went to EEPROM four times");
    for i in 0..100u32 {
        d.write(410, 0, Word, 0x06, ms(u64::from(i))).unwrap();
        d.write(484, 0, Long, i * 10, ms(u64::from(i))).unwrap();
        d.write(524, 5, Long, i, ms(u64::from(i))).unwrap();
    }
    assert_eq!(d.eeprom_writes(), before);
    d.write(413, 0, Word, 30, ms(200)).unwrap();
    assert_eq!(
        d.eeprom_writes(),
        before + 1,
        "413 exists once: one EEPROM write"
    );
}

#[test]
fn parameters_that_exist_once_take_only_data_set_0_and_5() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    let t = ms(0);
    for ds in [1, 2, 3, 4, 6, 7, 8, 9, 10, 15] {
        assert_eq!(
            refusal(d.write(410, ds, Word, 0x06, t)),
            (4, Some(2)),
            "410 ds {ds}"
        );
        assert_eq!(
            refusal(d.read(1376, ds, Word, t)),
            (4, Some(2)),
            "1376 ds {ds}"
        );
    }
    assert_eq!(d.write(1376, 5, Word, 7, t), Ok(()));
    assert_eq!(d.read(1376, 0, Word, t), Ok(7));
    assert_eq!(d.eeprom_writes(), 0);
}

// ----- control: state machine -----

#[test]
fn act_state_walk_to_operation_enabled_and_back() {
    let mut d = bus_drive(Variant::Act);
    let mut t = 0;
    let mut step = |d: &mut SimulatedBonfiglioli, word: u16| {
        t += 10;
        cw(d, word, ms(t));
        pattern(d, ms(t))
    };
    assert_eq!(
        pattern(&mut d, ms(0)),
        0x40,
        "switch-on disabled after power-on"
    );
    assert_eq!(step(&mut d, 0x06), 0x21, "2: ready to switch on");
    assert_eq!(step(&mut d, 0x07), 0x23, "3: switched on");
    assert_eq!(step(&mut d, 0x0F), 0x27, "4: operation enabled");
    assert_eq!(status(&mut d, ms(100)) & 0x10, 0, "ACT bit 4 is always 0");
    assert_ne!(status(&mut d, ms(100)) & 0x200, 0, "remote");
    d.write(392, 0, Word, 0, ms(100)).unwrap(); // transition 5: free coast
    assert_eq!(step(&mut d, 0x07), 0x23, "5: switched on");
    assert_eq!(step(&mut d, 0x06), 0x21, "6: ready to switch on");
    assert_eq!(step(&mut d, 0x00), 0x40, "7: switch-on disabled");
    assert_eq!(
        step(&mut d, 0x0F),
        0x27,
        "shortcut 4 from switch-on disabled"
    );
    assert_eq!(step(&mut d, 0x06), 0x21, "8");
    assert_eq!(
        step(&mut d, 0x0F),
        0x27,
        "0x0F from ready: 3 then 4 (a level)"
    );
    assert_eq!(step(&mut d, 0x00), 0x40, "9");
    assert_eq!(
        step(&mut d, 0x07),
        0x40,
        "0x07 does nothing in switch-on disabled"
    );
}

#[test]
fn acu_needs_mains_for_3_and_4_prime_and_shows_it_in_bit_4() {
    let mut d = bus_drive(Variant::Acu);
    assert_eq!(status(&mut d, ms(0)) & 0x10, 0x10);
    d.set_input(Input::Mains, false);
    assert_eq!(status(&mut d, ms(1)) & 0x10, 0);
    cw(&mut d, 0x0F, ms(10));
    assert_eq!(pattern(&mut d, ms(10)), 0x40, "4' refused without mains");
    cw(&mut d, 0x06, ms(20));
    cw(&mut d, 0x07, ms(30));
    assert_eq!(pattern(&mut d, ms(30)), 0x21, "3 refused without mains");
    d.set_input(Input::Mains, true);
    assert_eq!(
        pattern(&mut d, ms(40)),
        0x23,
        "the held word acts once mains is back"
    );
    cw(&mut d, 0x0F, ms(50));
    assert_eq!(pattern(&mut d, ms(50)), 0x27);
    // With positioning (30 = x40) there is no 4'.
    cw(&mut d, 0x00, ms(60));
    d.write(30, 0, Word, 140, ms(70)).unwrap();
    cw(&mut d, 0x0F, ms(80));
    assert_eq!(pattern(&mut d, ms(80)), 0x40);
}

#[test]
fn hardware_enable_is_needed_and_its_loss_coasts_to_switched_on() {
    for (variant, inputs) in [
        (Variant::Act, &[Input::S1ind][..]),
        (Variant::Acu, &[Input::Stoa, Input::Stob][..]),
    ] {
        for input in inputs {
            let mut d = bus_drive(variant);
            d.write(484, 0, Long, 1000, ms(0)).unwrap();
            d.set_input(*input, false);
            cw(&mut d, 0x0F, ms(10));
            assert_eq!(
                pattern(&mut d, ms(10)),
                0x40,
                "{variant:?} without {input:?}"
            );
            assert_eq!(status(&mut d, ms(10)) & 0x200, 0, "not remote");
            d.set_input(*input, true);
            assert_eq!(pattern(&mut d, ms(20)), 0x27, "{variant:?} with {input:?}");
            d.tick(ms(2020));
            assert!((d.actual_frequency() - 10.0).abs() < 1e-9);
            d.set_input(*input, false);
            d.tick(ms(2030));
            assert_eq!(pattern(&mut d, ms(2030)), 0x23);
            assert_eq!(d.actual_frequency(), 0.0, "coasts");
        }
    }
    // ACT: the start command S2IND or S3IND is needed too.
    let mut d = bus_drive(Variant::Act);
    d.set_input(Input::S2ind, false);
    cw(&mut d, 0x0F, ms(10));
    assert_eq!(pattern(&mut d, ms(10)), 0x40);
    d.set_input(Input::S3ind, true);
    assert_eq!(pattern(&mut d, ms(20)), 0x27);
}

// ----- ramp, quick stop, transition 5 -----

/// A bus drive running at 10.00 Hz at t = 2 s.
fn running(variant: Variant) -> SimulatedBonfiglioli {
    let mut d = bus_drive(variant);
    d.write(484, 0, Long, 1000, ms(0)).unwrap();
    cw(&mut d, 0x0F, ms(0));
    d.tick(ms(2000));
    d
}

#[test]
fn frequency_ramp_and_actual_values() {
    let mut d = bus_drive(Variant::Acu);
    d.write(484, 0, Long, 1000, ms(0)).unwrap();
    cw(&mut d, 0x0F, ms(0));
    assert_eq!(
        d.read(241, 0, Long, ms(1000)),
        Ok(500),
        "5.00 Hz/s: 5.00 Hz after 1 s"
    );
    assert_eq!(d.read(210, 0, Long, ms(1000)), Ok(500));
    assert_eq!(status(&mut d, ms(1000)) & 0x400, 0, "setpoint not reached");
    assert_eq!(d.read(241, 0, Long, ms(2000)), Ok(1000));
    assert_ne!(status(&mut d, ms(2000)) & 0x400, 0, "setpoint reached");
    assert_eq!(d.read(283, 0, Long, ms(2000)), Ok(1000));
    // Reversing passes through 0.
    d.write(484, 0, Long, (-1000i32) as u32, ms(2000)).unwrap();
    assert_eq!(d.read(241, 0, Long, ms(4000)), Ok(0));
    assert_eq!(d.read(241, 0, Long, ms(5000)), Ok((-500i32) as u32));
    // Limited to the maximum frequency 419 (50.00 Hz).
    d.write(484, 0, Long, 90_000, ms(5000)).unwrap();
    assert_eq!(d.read(283, 0, Long, ms(5000)), Ok(5000));
    // Ramp setpoint 434 = 1 (internal only): the line setpoint is not used.
    d.write(434, 0, Word, 1, ms(5000)).unwrap();
    assert_eq!(d.read(283, 0, Long, ms(5000)), Ok(0));
    assert_eq!(d.read(241, 0, Long, ms(6000)), Ok(0));
}

#[test]
fn quick_stop_ramps_on_424_then_holds_then_switch_on_disabled() {
    let mut d = running(Variant::Act);
    cw(&mut d, 0x0B, ms(2000)); // bit 2 = 0: quick stop
    assert_eq!(pattern(&mut d, ms(2000)), 0x07);
    assert_eq!(status(&mut d, ms(2000)) & 0x20, 0, "bit 5 active low");
    // 424 = 10.00 Hz/s: 10 Hz → 0.5 Hz (threshold 1 % of 50 Hz) in 0.95 s.
    let mut t = 2000;
    while t < 2900 {
        t += 50;
        d.tick(ms(t));
    }
    assert!((d.actual_frequency() - 1.0).abs() < 1e-9);
    assert_eq!(d.state(), State::QuickStopActive);
    t = 2950;
    d.tick(ms(t)); // 0.5 Hz: holding starts
    while t < 3900 {
        t += 50;
        d.tick(ms(t));
        assert_eq!(
            d.state(),
            State::QuickStopActive,
            "holding 638 = 1.0 s, t = {t}"
        );
    }
    d.tick(ms(3950));
    assert_eq!(pattern(&mut d, ms(3950)), 0x40);
    assert_eq!(d.actual_frequency(), 0.0);
    // Quick stop (0x02) from switched on: 10 → switch-on disabled.
    cw(&mut d, 0x06, ms(4000));
    cw(&mut d, 0x07, ms(4010));
    cw(&mut d, 0x02, ms(4020));
    assert_eq!(pattern(&mut d, ms(4020)), 0x40);
}

#[test]
fn transition_5_ramp_resumes_on_0x0f_and_ends_in_switched_on() {
    let mut d = running(Variant::Acu); // 392 default 2: ramp
    cw(&mut d, 0x07, ms(2000));
    d.tick(ms(3000));
    assert_eq!(d.state(), State::OperationEnabled, "still ramping");
    assert!((d.actual_frequency() - 5.0).abs() < 1e-9);
    cw(&mut d, 0x0F, ms(3000));
    d.tick(ms(4000));
    assert!((d.actual_frequency() - 10.0).abs() < 1e-9, "resumed");
    cw(&mut d, 0x07, ms(4000));
    let mut t = 4000;
    while d.state() == State::OperationEnabled && t < 10_000 {
        t += 50;
        d.tick(ms(t));
    }
    // 10 Hz → 0.5 Hz at 5 Hz/s: 1.9 s, then holding 1.0 s.
    assert!((6900..=7000).contains(&t), "switched on at {t} ms");
    assert_eq!(pattern(&mut d, ms(t)), 0x23);
}

#[test]
fn transition_5_dc_brake_ignores_control_words_for_632() {
    let mut d = running(Variant::Act);
    d.write(392, 0, Word, 1, ms(2000)).unwrap();
    cw(&mut d, 0x07, ms(2000));
    cw(&mut d, 0x00, ms(2100)); // not acted on during the DC brake
    assert_eq!(d.state(), State::OperationEnabled);
    cw(&mut d, 0x07, ms(2200));
    d.tick(ms(2999));
    assert_eq!(d.state(), State::OperationEnabled);
    d.tick(ms(3000)); // 632 = 1.0 s
    assert_eq!(pattern(&mut d, ms(3000)), 0x23);
    assert_eq!(d.actual_frequency(), 0.0);
}

// ----- faults, reset lockout, watchdog, warnings -----

#[test]
fn fault_reset_needs_a_rising_edge_15_s_after_the_fault() {
    let mut d = running(Variant::Act);
    d.raise_fault(0x0100, ms(2000));
    assert_eq!(pattern(&mut d, ms(2000)), 0x08);
    assert_eq!(d.read(260, 0, Word, ms(2000)), Ok(0x0100));
    assert_eq!(d.actual_frequency(), 0.0);
    cw(&mut d, 0x80, ms(12_000)); // 10 s after: locked out
    assert_eq!(d.state(), State::Fault);
    cw(&mut d, 0x80, ms(17_000)); // 15 s after, but no new edge
    assert_eq!(d.state(), State::Fault);
    cw(&mut d, 0x00, ms(17_000));
    cw(&mut d, 0x80, ms(16_999)); // an edge 14.999 s after
    assert_eq!(d.state(), State::Fault);
    cw(&mut d, 0x00, ms(17_000));
    cw(&mut d, 0x80, ms(17_000)); // an edge 15 s after
    assert_eq!(pattern(&mut d, ms(17_000)), 0x40, "15: switch-on disabled");
    assert_eq!(d.read(260, 0, Word, ms(17_000)), Ok(0));
    // Other commands do not leave the fault.
    d.raise_fault(0x0500, ms(20_000));
    cw(&mut d, 0x0F, ms(40_000));
    assert_eq!(d.state(), State::Fault);
    assert_eq!(d.fault(), 0x0500);
    // Keypad reset, locked out as well.
    assert!(!d.keypad_reset(ms(34_999)));
    assert!(d.keypad_reset(ms(35_000)));
}

#[test]
fn watchdog_413_trips_f2010() {
    let mut d = running(Variant::Acu);
    d.write(413, 0, Word, 2, ms(2000)).unwrap();
    for t in (3000..=10_000).step_by(1000) {
        d.valid_exchange(ms(t));
        d.tick(ms(t));
        assert_eq!(d.state(), State::OperationEnabled, "fed at {t} ms");
    }
    d.tick(ms(11_999));
    assert_eq!(d.state(), State::OperationEnabled);
    d.tick(ms(12_000));
    assert_eq!(pattern(&mut d, ms(12_000)), 0x08);
    assert_eq!(
        d.read(260, 0, Word, ms(12_000)),
        Ok(u32::from(FAULT_WATCHDOG))
    );
    assert_eq!(
        bonfiglioli::fault(FAULT_WATCHDOG).map(|f| f.key),
        Some("F2010")
    );
    assert_eq!(d.actual_frequency(), 0.0);
    // 413 = 0 switches it off.
    let mut d = running(Variant::Act);
    d.tick(ms(1_000_000));
    assert_eq!(d.state(), State::OperationEnabled);
}

#[test]
fn warnings_270_and_status_bit_7() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    assert_eq!(d.read(270, 0, Word, ms(0)), Ok(0));
    assert_eq!(status(&mut d, ms(0)) & 0x80, 0);
    d.set_warnings(0x008B); // the example of ch. 12.1
    assert_eq!(d.read(270, 0, Word, ms(0)), Ok(0x008B));
    assert_ne!(status(&mut d, ms(0)) & 0x80, 0);
    assert_eq!(refusal(d.write(270, 0, Word, 0, ms(0))), (4, Some(4)));
}

// ----- contact modes -----

#[test]
fn factory_412_44_is_local_and_ignores_the_control_word() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    assert_eq!(d.read(412, 0, Word, ms(0)), Ok(44));
    cw(&mut d, 0x0F, ms(0));
    assert_eq!(pattern(&mut d, ms(0)), 0x23);
    assert_eq!(status(&mut d, ms(0)) & 0x200, 0, "not remote");
}

#[test]
fn remote_contacts_need_bit_0_and_the_hardware_enable() {
    let mut d = SimulatedBonfiglioli::new(Variant::Acu);
    d.write(412, 0, Word, 2, ms(0)).unwrap();
    d.write(484, 0, Long, 1000, ms(0)).unwrap();
    cw(&mut d, 0x02, ms(0)); // S2IND without S1IND
    assert_eq!(pattern(&mut d, ms(0)), 0x23);
    assert_eq!(
        d.read(250, 0, Word, ms(0)),
        Ok(0),
        "not shown without bit 0"
    );
    cw(&mut d, 0x03, ms(0)); // S1IND + S2IND: start clockwise
    assert_eq!(pattern(&mut d, ms(0)), 0x27);
    assert_ne!(status(&mut d, ms(0)) & 0x200, 0, "remote");
    assert_eq!(d.read(250, 0, Word, ms(0)), Ok(0x03));
    assert_eq!(d.read(241, 0, Long, ms(2000)), Ok(1000));
    cw(&mut d, 0x05, ms(2000)); // S1IND + S3IND: anticlockwise
    assert_eq!(d.read(241, 0, Long, ms(6000)), Ok((-1000i32) as u32));
    d.set_input(Input::Stob, false);
    assert_eq!(pattern(&mut d, ms(6000)), 0x23);
    assert_eq!(d.read(250, 0, Word, ms(6000)), Ok(0));
}

#[test]
fn local_remote_follows_the_active_data_set() {
    let mut d = SimulatedBonfiglioli::new(Variant::Act);
    d.write(412, 2, Word, 1, ms(0)).unwrap(); // data set 2: state machine
    cw(&mut d, 0x0F, ms(0));
    assert_eq!(pattern(&mut d, ms(0)), 0x23, "data set 1 active: local");
    d.write(414, 0, Word, 2, ms(10)).unwrap();
    assert_eq!(d.read(249, 0, Word, ms(10)), Ok(2));
    assert_eq!(
        pattern(&mut d, ms(10)),
        0x27,
        "data set 2: the held 0x0F acts"
    );
}

// ----- arbitrary requests -----

proptest::proptest! {
    /// Whatever a front-end passes on: no panic, exception 2 or 4 only, and parameter 11 holds
    /// the cause of the last exception 4 (exception 2 leaves it).
    #[test]
    fn arbitrary_requests_are_answered_or_refused_consistently(
        ops in proptest::collection::vec(
            (0u16..1700, 0u8..16, proptest::bool::ANY, proptest::bool::ANY, proptest::num::u32::ANY, 0u64..50),
            1..40,
        ),
        acu in proptest::bool::ANY,
    ) {
        let mut d = SimulatedBonfiglioli::new(if acu { Variant::Acu } else { Variant::Act });
        let mut t = 0;
        for (param, ds, long, write, value, dt) in ops {
            t += dt;
            let width = if long { Long } else { Word };
            let before = d.error_register();
            let result = if write {
                d.write(param, ds, width, value, ms(t))
            } else {
                d.read(param, ds, width, ms(t)).map(drop)
            };
            match result {
                Ok(()) => {}
                Err(e @ Refusal::WrongWidth { .. }) => {
                    proptest::prop_assert_eq!(e.exception(), 2);
                    proptest::prop_assert_eq!(d.error_register(), before);
                }
                Err(e) => {
                    proptest::prop_assert_eq!(e.exception(), 4);
                    proptest::prop_assert_eq!(Some(d.error_register()), e.vabus());
                }
            }
            let s = d.read(411, 0, Word, ms(t)).unwrap() as u16;
            let state = if acu {
                bonfiglioli::AcuStateMachine::decode(s)
            } else {
                bonfiglioli::ActStateMachine::decode(s)
            };
            proptest::prop_assert_eq!(state, d.state(), "status word {:#06x}", s);
        }
    }
}
