//! Tests of the simulated NORD drive: the manual's examples (BU 0255 ch. 5.1) as vectors, every
//! transition of ch. 4.5.3, the PKW refusals, P560, parameter sets, arrays, BusIO bits, ramps,
//! positions, and a property test.

use std::collections::BTreeSet;
use std::time::Duration;

use drive_profile::nord::{NordStateMachine, State, Trigger, Width, states, transitions};
use drive_profile::state::StateMachine;
use proptest::prelude::*;

use super::{
    PkwRefusal, SimulatedNord, input_function, output_function, switch_on_disabled_reason,
};
use drive_core::Instant;

const T0: Instant = Instant::ZERO;

fn ms(n: u64) -> Instant {
    T0 + Duration::from_millis(n)
}

/// A drive running at 25 Hz (50 % of P105 = 50.0 Hz) clockwise at `ms(1000)`, started at T0.
fn running() -> SimulatedNord {
    let mut d = SimulatedNord::new();
    d.process(0x047E, &[0], T0);
    d.process(0x047F, &[0x2000], T0);
    d.tick(ms(1000));
    assert_eq!(d.state(), State::OperationEnabled);
    assert_eq!(d.actual_frequency(), 25.0);
    d
}

// ---- the manual's examples (ch. 5.1) ----

/// 5.1.1: after power-on the drive is in switch-on disabled with 0B70h; 047Eh takes it to
/// ready to switch on, 0B31h (errata E7, E8).
#[test]
fn manual_5_1_1_switch_on_disabled_to_ready() {
    let mut d = SimulatedNord::new();
    assert_eq!(d.state(), State::SwitchOnDisabled);
    // 0B70h: bit 11 rotation right, bit 9 bus control, bit 8 setpoint reached, bit 6 switch-on
    // disabled, bit 5 no quick stop, bit 4 voltage enabled; bits 0..3 and 7 = 0.
    assert_eq!(d.status_word(), 0x0B70);
    assert_eq!(d.actual_values()[0], 0x0000); // IW1: 0 %
    // STW 047Eh: bit 10 control data valid, bits 6..1 set, bit 0 = 0 ("Stillsetzen").
    d.process(0x047E, &[0x0000], T0);
    assert_eq!(d.state(), State::ReadyToSwitchOn);
    // 0B31h: bits 11, 9, 8, 5, 4 as above, bit 0 ready to switch on.
    assert_eq!(d.status_word(), 0x0B31);
    assert_eq!(d.actual_values()[0], 0x0000);
}

/// 5.1.2: from ready to switch on, 047Fh with SW1 2000h (50 %) runs up on the ramp; once 50 %
/// is reached the drive answers ZSW 0B37h, IW1 2000h.
#[test]
fn manual_5_1_2_enable_with_50_percent() {
    let mut d = SimulatedNord::new();
    d.process(0x047E, &[0], T0);
    assert_eq!(d.status_word(), 0x0B31);
    // STW 047Fh: bits 10, 6..0 ("Betrieb freigeben"); SW1 2000h = 50 % of P105 (50.0 Hz).
    d.process(0x047F, &[0x2000], T0);
    assert_eq!(d.state(), State::OperationEnabled);
    // On the ramp: bit 8 (setpoint reached) clear: 0A37h.
    assert_eq!(d.status_word(), 0x0A37);
    // P102 = 2.00 s for 0 → 50 Hz: 12.5 Hz (25 %, 1000h) after 0.5 s.
    d.tick(ms(500));
    assert_eq!(d.actual_frequency(), 12.5);
    assert_eq!(d.status_word(), 0x0A37);
    assert_eq!(d.actual_values()[0], 0x1000);
    d.tick(ms(999));
    assert_eq!(d.status_word() & 0x0100, 0, "not yet reached at 0.999 s");
    // 25 Hz after 1 s: 0B37h = bits 11, 9, 8 + operation enabled 37h; IW1 2000h.
    d.tick(ms(1000));
    assert_eq!(d.actual_frequency(), 25.0);
    assert_eq!(d.status_word(), 0x0B37);
    assert_eq!(d.actual_values()[0], 0x2000);
    // IW3 (P543 [-03] default: setpoint frequency) shows the target from the start.
    assert_eq!(d.actual_values()[2], 0x2000);
}

/// 5.1.3 (erratum E4): P102 = 10 s (3E8h) in parameter set 3; 5.1.5 (E6): P102 = 2.5 s (FAh)
/// in parameter set 2. The four sets are independent.
#[test]
fn manual_5_1_3_and_5_1_5_parameter_sets_are_independent() {
    let mut d = SimulatedNord::new();
    d.write(102, 0, 2, 0x3E8, true, T0).unwrap(); // IND 0200h: set 3
    d.write(102, 0, 1, 0xFA, true, T0).unwrap(); // IND 0100h: set 2
    assert_eq!(d.read(102, 0, 0, T0), Ok(200)); // set 1: simulator default 2.00 s
    assert_eq!(d.read(102, 0, 1, T0), Ok(250));
    assert_eq!(d.read(102, 0, 2, T0), Ok(1000));
    assert_eq!(d.read(102, 0, 3, T0), Ok(200));
    for set in 0..4 {
        assert_eq!(
            d.eeprom_writes_of(102, 0, set),
            Some(u64::from(set == 1 || set == 2))
        );
    }
    // The ramp uses the set selected by control bits 14/15: set 2 (bit 14) → 2.5 s for 50 Hz,
    // so 50 % is reached after 1.25 s; status bits 14/15 report set 2.
    d.process(0x447E, &[0], T0);
    d.process(0x447F, &[0x2000], T0);
    d.tick(ms(1000));
    assert_eq!(d.actual_frequency(), 20.0);
    d.tick(ms(1250));
    assert_eq!(d.status_word(), 0x4B37);
    assert_eq!(d.active_parameter_set(), 2);
    // P105 per set: 100.0 Hz in set 4 makes 2000h = 50.0 Hz there.
    d.write(105, 0, 3, 1000, true, ms(1250)).unwrap();
    assert_eq!(d.read(105, 0, 0, ms(1250)), Ok(500));
}

/// 5.1.4 (erratum E5): P701 [-01] is the most recent fault.
#[test]
fn manual_5_1_4_read_p701() {
    let mut d = SimulatedNord::new();
    assert_eq!(d.read(701, 0, 0, T0), Ok(0));
    d.raise_fault(42, T0);
    assert_eq!(d.read(701, 0, 0, T0), Ok(42));
}

// ---- state machine (ch. 4.5.3) ----

/// Every transition of the table (1…15 and erratum E14's 12F) is taken in one run, each with
/// the state it leads to.
#[test]
fn every_transition_is_reachable() {
    let mut d = SimulatedNord::new();
    let mut t = 0;
    let step = |d: &mut SimulatedNord, t: &mut u64, word: u16, sw: &[u16], dt: u64, want: State| {
        *t += dt;
        d.process(word, sw, ms(*t));
        assert_eq!(d.state(), want, "after {word:04X} at {t} ms");
        NordStateMachine::decode(d.status_word())
    };
    use State::*;
    step(&mut d, &mut t, 0x047E, &[0], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x0400, &[], 0, SwitchOnDisabled); // 7a disable voltage
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x0402, &[], 0, SwitchOnDisabled); // 7b quick stop
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x0477, &[], 0, SwitchedOn); // 3 switch on
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 6 shutdown (f = 0 already)
    step(&mut d, &mut t, 0x0477, &[], 0, SwitchedOn); // 3
    step(&mut d, &mut t, 0x0400, &[], 0, SwitchOnDisabled); // 10a
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x0477, &[], 0, SwitchedOn); // 3
    step(&mut d, &mut t, 0x0402, &[], 0, SwitchOnDisabled); // 10b
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x047F, &[0x2000], 0, OperationEnabled); // 3, 4
    step(&mut d, &mut t, 0x047F, &[], 1000, OperationEnabled);
    assert_eq!(d.actual_frequency(), 25.0);
    step(&mut d, &mut t, 0x0477, &[], 0, SwitchedOn); // 5: output off at once
    assert_eq!(d.actual_frequency(), 0.0);
    step(&mut d, &mut t, 0x047F, &[], 0, OperationEnabled); // 4
    step(&mut d, &mut t, 0x047F, &[], 1000, OperationEnabled);
    // 8: "Stillsetzen" ramps down with the braking time (= P102: 25 Hz → 0 in 1 s) first.
    step(&mut d, &mut t, 0x047E, &[], 0, OperationEnabled);
    step(&mut d, &mut t, 0x047E, &[], 500, OperationEnabled);
    assert_eq!(d.actual_frequency(), 12.5);
    step(&mut d, &mut t, 0x047E, &[], 500, ReadyToSwitchOn); // 8 at 0 Hz
    step(&mut d, &mut t, 0x047F, &[], 0, OperationEnabled); // 3, 4
    step(&mut d, &mut t, 0x047F, &[], 1000, OperationEnabled);
    step(&mut d, &mut t, 0x0400, &[], 0, SwitchOnDisabled); // 9: output off at once
    assert_eq!(d.actual_frequency(), 0.0);
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x047F, &[], 0, OperationEnabled); // 3, 4
    step(&mut d, &mut t, 0x047F, &[], 1000, OperationEnabled);
    // 11: quick stop, 0.1 s for 50 Hz → 0: 25 Hz → 12.5 Hz in 25 ms, 0 Hz (12F) in 50 ms.
    assert_eq!(
        step(&mut d, &mut t, 0x0402, &[], 0, QuickStopActive),
        QuickStopActive
    );
    assert_eq!(d.status_word(), 0x0A17); // bit 5 = 0: quick stop; not at the setpoint
    step(&mut d, &mut t, 0x0402, &[], 25, QuickStopActive);
    assert_eq!(d.actual_frequency(), 12.5);
    step(&mut d, &mut t, 0x0402, &[], 25, SwitchOnDisabled); // 12F (erratum E14)
    step(&mut d, &mut t, 0x047E, &[], 0, ReadyToSwitchOn); // 2
    step(&mut d, &mut t, 0x047F, &[], 0, OperationEnabled); // 3, 4
    step(&mut d, &mut t, 0x047F, &[], 1000, OperationEnabled);
    step(&mut d, &mut t, 0x0402, &[], 0, QuickStopActive); // 11
    step(&mut d, &mut t, 0x0400, &[], 10, SwitchOnDisabled); // 12: voltage off at once
    assert_eq!(d.actual_frequency(), 0.0);
    t += 10;
    d.raise_fault(7, ms(t)); // 13
    assert_eq!(d.state(), FaultReactionActive);
    assert_eq!(d.status_word(), 0x0B0F); // bits 0..3; bits 4/5 = 0 (0400h commands both)
    d.tick(ms(t + 49));
    assert_eq!(d.state(), FaultReactionActive);
    d.tick(ms(t + 50)); // 14
    assert_eq!(d.state(), Fault);
    assert_eq!(d.status_word(), 0x0B08);
    t += 50;
    step(&mut d, &mut t, 0x0480, &[], 0, SwitchOnDisabled); // 15: rising edge of bit 7

    let taken: BTreeSet<&str> = d.transition_log().collect();
    let all: BTreeSet<&str> = transitions().iter().map(|t| t.id).collect();
    assert_eq!(
        taken, all,
        "every transition of the table is taken, and no other"
    );
}

/// The table's command patterns leave no choice: for every state and every low byte of the
/// control word at most one command transition applies, in the priority order of ch. 4.5.1.
#[test]
fn no_control_word_matches_two_transitions() {
    for s in states() {
        for low in 0..=0xFFu16 {
            let word = 0x0400 | low;
            let n = transitions()
                .iter()
                .filter(|t| t.from == Some(s.state) && matches!(t.trigger, Trigger::Command { .. }))
                .filter(|t| t.triggered_by(0, word))
                .count();
            assert!(n <= 1, "{:?} with {word:04X}: {n} transitions", s.state);
        }
    }
    // Priorities: disable voltage (1) beats quick stop (2) beats the rest.
    let mut d = running();
    d.process(0x04F9, &[], ms(1000)); // bits 1 and 2 = 0, all others set
    assert_eq!(d.state(), State::SwitchOnDisabled);
    let mut d = running();
    d.process(0x04FB, &[], ms(1000)); // bit 2 = 0, bits 0, 1, 3..7 set
    assert_eq!(d.state(), State::QuickStopActive);
}

/// Only telegrams with control bit 10 are acted on; the status word is still answered and P740
/// shows what arrived.
#[test]
fn control_bit_10_must_be_set() {
    let mut d = SimulatedNord::new();
    d.process(0x007E, &[0x2000], T0); // "Stillsetzen" without bit 10
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.status_word(), 0x0B70);
    assert_eq!(d.setpoints(), [0, 0, 0]);
    assert_eq!(d.control_word(), None);
    assert_eq!(d.read(740, 0, 0, T0), Ok(0x007E));
    assert_eq!(d.read(741, 0, 0, T0), Ok(0x0B70));
    // Running: a telegram without bit 10 neither stops nor changes the setpoint.
    let mut d = running();
    d.process(0x0000, &[0x4000], ms(1000));
    d.tick(ms(2000));
    assert_eq!(d.state(), State::OperationEnabled);
    assert_eq!(d.actual_frequency(), 25.0);
}

/// A fault is reset only by a 0 → 1 edge of bit 7, and not during the fault reaction.
#[test]
fn fault_reset_needs_a_rising_edge() {
    let mut d = running();
    d.raise_fault(3, ms(1000));
    assert_eq!(d.actual_frequency(), 0.0);
    d.process(0x0480, &[], ms(1010)); // edge during the fault reaction: ignored
    assert_eq!(d.state(), State::FaultReactionActive);
    d.tick(ms(1100));
    assert_eq!(d.state(), State::Fault);
    d.process(0x0480, &[], ms(1110)); // bit 7 still 1: no edge
    assert_eq!(d.state(), State::Fault);
    assert_eq!(d.fault(), 3);
    d.process(0x0400, &[], ms(1120));
    d.process(0x0480, &[], ms(1130));
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.fault(), 0);
    assert_eq!(d.fault_memory(), [3, 0, 0, 0, 0]);
    // A fault while a fault is active is ignored; 0 is no fault.
    d.raise_fault(0, ms(1140));
    assert_eq!(d.state(), State::SwitchOnDisabled);
    d.raise_fault(4, ms(1150));
    d.raise_fault(5, ms(1160));
    assert_eq!(d.fault(), 4);
    assert_eq!(d.fault_memory(), [4, 3, 0, 0, 0]);
}

/// "Stillsetzen" during the ramp-down is undone by a word that asks for operation again.
#[test]
fn shutdown_ramp_can_be_resumed() {
    let mut d = running();
    d.process(0x047E, &[], ms(1000));
    d.tick(ms(1500));
    assert_eq!(d.actual_frequency(), 12.5);
    d.process(0x047F, &[], ms(1500));
    d.tick(ms(2000));
    assert_eq!(d.state(), State::OperationEnabled);
    assert_eq!(d.actual_frequency(), 25.0);
}

/// Bits 4, 5 and 6 (ramp generator to 0, hold, setpoint to 0) keep the drive enabled.
#[test]
fn ramp_generator_bits() {
    let mut d = SimulatedNord::new();
    d.process(0x047E, &[], T0);
    d.process(0x047F, &[0x4000], T0); // 100 % = 50 Hz, 2 s
    d.tick(ms(500));
    assert_eq!(d.actual_frequency(), 12.5);
    d.process(0x045F, &[], ms(500)); // bit 5 = 0: hold
    d.tick(ms(1000));
    assert_eq!(d.actual_frequency(), 12.5);
    assert_eq!(
        d.status_word() & 0x0100,
        0x0100,
        "held frequency counts as reached"
    );
    d.process(0x043F, &[], ms(1000)); // bit 6 = 0: setpoint 0, braking ramp
    d.tick(ms(1250));
    assert_eq!(d.actual_frequency(), 6.25);
    d.process(0x047F, &[], ms(1250));
    d.tick(ms(1500));
    assert_eq!(d.actual_frequency(), 12.5);
    d.process(0x046F, &[], ms(1500)); // bit 4 = 0: ramp generator to 0 at once
    assert_eq!(d.actual_frequency(), 0.0);
    assert_eq!(d.state(), State::OperationEnabled);
    // Bit 4 wins over bits 5 and 6.
    d.process(0x040F, &[], ms(1600));
    d.tick(ms(2000));
    assert_eq!(d.actual_frequency(), 0.0);
}

/// Direction: bit 12 counter-clockwise (wins over bit 11), otherwise clockwise; the status word
/// shows the output's rotating field.
#[test]
fn direction_bits() {
    let mut d = SimulatedNord::new();
    d.process(0x147E, &[], T0); // bit 12
    assert_eq!(
        d.status_word(),
        0x1331,
        "bit 12 instead of 11 at standstill"
    );
    d.process(0x1C7F, &[0x2000], T0); // bits 11 and 12: left
    d.tick(ms(1000));
    assert_eq!(d.actual_frequency(), -25.0);
    assert_eq!(d.status_word(), 0x1337);
    assert_eq!(d.actual_values()[0], 0xE000); // −50 %
    d.process(0x0C7F, &[0x2000], ms(1000)); // bit 11 only: right, through 0 Hz
    d.tick(ms(2000));
    assert_eq!(d.actual_frequency(), 0.0);
    assert_eq!(d.status_word() & 0x1800, 0x0800);
    d.tick(ms(3000));
    assert_eq!(d.actual_frequency(), 25.0);
    // A negative setpoint with bit 12 = 0 turns counter-clockwise; setpoints above 100 % are
    // limited to P105.
    d.process(0x047F, &[0x8000], ms(3000)); // −200 %
    d.tick(ms(6000));
    assert_eq!(d.actual_frequency(), -50.0);
}

// ---- parameters (ch. 4.6, 6) ----

/// Each PWE2 error number 0…6 of ch. 4.6.1.1, provoked; a refused write changes nothing.
#[test]
fn every_refusal_is_provoked() {
    let mut d = SimulatedNord::new();
    let cases = [
        (
            d.read(999, 0, 0, T0).map(|_| ()),
            PkwRefusal::InvalidParameter,
            0,
        ),
        (
            d.write(700, 0, 0, 1, true, T0),
            PkwRefusal::NotChangeable,
            1,
        ),
        (
            d.write(105, 0, 0, 4001, true, T0),
            PkwRefusal::LimitExceeded,
            2,
        ),
        (
            d.write(102, 0, 0, -1, true, T0),
            PkwRefusal::LimitExceeded,
            2,
        ),
        (
            d.write(560, 0, 0, 2, true, T0),
            PkwRefusal::LimitExceeded,
            2,
        ),
        (
            d.write(509, 0, 0, 40_000, true, T0),
            PkwRefusal::LimitExceeded,
            2,
        ),
        (
            d.read(102, 0, 4, T0).map(|_| ()),
            PkwRefusal::WrongSubindex,
            3,
        ),
        (
            d.read(105, 1, 0, T0).map(|_| ()),
            PkwRefusal::WrongSubindex,
            3,
        ),
        (
            d.read(480, 12, 0, T0).map(|_| ()),
            PkwRefusal::WrongSubindex,
            3,
        ),
        (
            d.write(509, 0, 1, 5, true, T0),
            PkwRefusal::WrongSubindex,
            3,
        ),
        (d.array_len(102).map(|_| ()), PkwRefusal::NotArray, 4),
        (
            d.write_width(105, 0, 0, Width::DoubleWord, 500, true, T0),
            PkwRefusal::InvalidDataType,
            5,
        ),
        (
            d.write(701, 0, 0, 3, true, T0),
            PkwRefusal::OnlyResettable,
            6,
        ),
    ];
    for (got, want, number) in cases {
        assert_eq!(got, Err(want));
        assert_eq!(want.number(), number);
        let meaning = want.meaning().unwrap();
        assert_eq!(meaning.number, number);
    }
    assert_eq!(d.array_len(999), Err(PkwRefusal::InvalidParameter));
    assert_eq!(d.eeprom_writes(), 0);
    assert_eq!(d.read(105, 0, 0, T0), Ok(500));
    assert_eq!(d.read(560, 0, 0, T0), Ok(1));
    assert_eq!(d.is_double_word(102), Some(false));
    assert_eq!(d.is_double_word(999), None);
    // Edges of the ranges are accepted.
    d.write(105, 0, 0, 4000, true, T0).unwrap();
    d.write(105, 0, 0, 1, true, T0).unwrap();
    d.write(509, 0, 0, -32768, false, T0).unwrap();
}

/// P560: 1 = RAM and EEPROM (counted per cell), 0 = RAM only; AK 11…14 never write EEPROM;
/// a restart reloads RAM from EEPROM; P560 itself is written through.
#[test]
fn p560_ram_versus_eeprom_and_restart() {
    let mut d = SimulatedNord::new();
    d.write(105, 0, 0, 600, true, T0).unwrap(); // AK 2 with P560 = 1
    assert_eq!(
        (d.ram_value(105, 0, 0), d.eeprom_value(105, 0, 0)),
        (Some(600), Some(600))
    );
    assert_eq!(d.eeprom_writes_of(105, 0, 0), Some(1));
    d.write(105, 0, 0, 700, false, T0).unwrap(); // AK 14: RAM only
    assert_eq!(
        (d.ram_value(105, 0, 0), d.eeprom_value(105, 0, 0)),
        (Some(700), Some(600))
    );
    assert_eq!(d.eeprom_writes(), 1);
    d.write(560, 0, 0, 0, true, T0).unwrap(); // P560 = 0, written through
    assert_eq!(d.eeprom_writes_of(560, 0, 0), Some(1));
    assert_eq!(d.eeprom_value(560, 0, 0), Some(0));
    d.write(105, 0, 0, 800, true, T0).unwrap(); // AK 2, but P560 = 0: RAM only
    assert_eq!(
        (d.ram_value(105, 0, 0), d.eeprom_value(105, 0, 0)),
        (Some(800), Some(600))
    );
    assert_eq!(d.eeprom_writes(), 2);
    d.restart(ms(10));
    assert_eq!(d.read(105, 0, 0, ms(10)), Ok(600));
    assert_eq!(
        d.read(560, 0, 0, ms(10)),
        Ok(0),
        "RAM-only mode survives the power cycle"
    );
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.status_word(), 0x0B70);
    assert_eq!(d.transition_log().filter(|id| *id == "1").count(), 2);
    d.write(560, 0, 0, 1, true, ms(10)).unwrap();
    d.write(105, 0, 0, 900, true, ms(10)).unwrap();
    assert_eq!(d.eeprom_value(105, 0, 0), Some(900));
    assert_eq!(d.eeprom_writes_of(105, 0, 0), Some(2));
    assert_eq!(d.eeprom_writes(), 4);
    // The information parameters have no EEPROM value.
    assert_eq!(d.eeprom_value(700, 0, 0), None);
    assert_eq!(d.eeprom_value(105, 0, 1), Some(500));
    assert_eq!(d.eeprom_writes_of(105, 0, 4), None);
}

/// Arrays: element counts (AK 9), elements addressed 0-based, independent values.
#[test]
fn arrays() {
    let mut d = SimulatedNord::new();
    let lens: Vec<_> = [480, 481, 510, 543, 546, 700, 701]
        .iter()
        .map(|p| d.array_len(*p).unwrap())
        .collect();
    assert_eq!(lens, [12, 10, 2, 3, 3, 3, 5]);
    // Simulator defaults of the BusIO and bus value functions.
    let p480: Vec<_> = (0..12).map(|e| d.read(480, e, 0, T0).unwrap()).collect();
    assert_eq!(p480, [1, 2, 12, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    let p481: Vec<_> = (0..10).map(|e| d.read(481, e, 0, T0).unwrap()).collect();
    assert_eq!(p481, [18, 7, 2, 8, 0, 0, 0, 0, 0, 0]);
    d.write(543, 2, 0, 9, true, T0).unwrap(); // [-03]: fault number
    assert_eq!(d.read(543, 2, 0, T0), Ok(9));
    assert_eq!(d.read(543, 1, 0, T0), Ok(3));
    assert_eq!(d.eeprom_writes_of(543, 2, 0), Some(1));
    assert_eq!(d.eeprom_writes_of(543, 1, 0), Some(0));
    d.raise_fault(77, T0);
    assert_eq!(d.actual_values()[2], 77);
}

/// P700 present fault / warning / reason for switch-on disabled, P701 fault memory (newest
/// first, five entries, cleared by writing 0), P740/P741 process data, P744.
#[test]
fn information_parameters_show_live_data() {
    let mut d = SimulatedNord::new();
    let p700 = |d: &mut SimulatedNord| [0, 1, 2].map(|e| d.read(700, e, 0, T0).unwrap());
    assert_eq!(
        p700(&mut d),
        [0, 0, switch_on_disabled_reason::AWAITING_SHUTDOWN]
    );
    d.process(0x0400, &[], T0);
    assert_eq!(
        p700(&mut d),
        [0, 0, switch_on_disabled_reason::DISABLE_VOLTAGE]
    );
    d.process(0x0402, &[], T0);
    assert_eq!(p700(&mut d), [0, 0, switch_on_disabled_reason::QUICK_STOP]);
    d.process(0x047E, &[], T0);
    d.set_warning(21);
    assert_eq!(p700(&mut d), [0, 21, switch_on_disabled_reason::NONE]);
    assert_eq!(d.status_word(), 0x0BB1, "bit 7 warning");
    d.set_warning(0);
    let mut t = 0;
    for fault in 1..=6 {
        d.raise_fault(fault, ms(t));
        assert_eq!(d.read(700, 0, 0, ms(t)), Ok(i32::from(fault)));
        d.process(0x0400, &[], ms(t + 60));
        d.process(0x0480, &[], ms(t + 70));
        t += 100;
    }
    let p701: Vec<_> = (0..5).map(|e| d.read(701, e, 0, ms(t)).unwrap()).collect();
    assert_eq!(p701, [6, 5, 4, 3, 2]);
    assert_eq!(d.read(700, 0, 0, ms(t)), Ok(0));
    d.restart(ms(t));
    assert_eq!(
        d.read(701, 0, 0, ms(t)),
        Ok(6),
        "the fault memory survives a power cycle"
    );
    d.write(701, 3, 0, 0, true, ms(t)).unwrap();
    assert_eq!(d.fault_memory(), [0; 5]);
    assert_eq!(d.eeprom_writes(), 0);
    // P740/P741 show the words; nothing while P509 = 0.
    d.process(0x047E, &[], ms(t));
    assert_eq!(d.read(740, 0, 0, ms(t)), Ok(0x047E));
    assert_eq!(d.read(741, 0, 0, ms(t)), Ok(0x0B31));
    d.write(509, 0, 0, 0, true, ms(t)).unwrap();
    assert_eq!(d.read(740, 0, 0, ms(t)), Ok(0));
    assert_eq!(d.read(741, 0, 0, ms(t)), Ok(0));
    assert_eq!(d.read(744, 0, 0, ms(t)), Ok(super::CONFIGURATION_LEVEL));
    assert_eq!(
        d.write(744, 0, 0, 0, true, ms(t)),
        Err(PkwRefusal::NotChangeable)
    );
}

// ---- BusIO bits (ch. 3.2, 3.3) ----

/// With P509 = 0 the drive runs from a BusIO enable bit (P480 [-01] enable right, [-02] left);
/// the setpoint still comes from valid telegrams. BusIO Out shows ready, no fault, running.
#[test]
fn enable_through_busio_bit() {
    let mut d = SimulatedNord::new();
    d.write(509, 0, 0, 0, true, T0).unwrap();
    // Without an enable the drive applies "Stillsetzen": ready to switch on, no bus control.
    assert_eq!(d.state(), State::ReadyToSwitchOn);
    assert_eq!(d.status_word(), 0x0931);
    // Out bits: 0 ready (18), 1 fault active low (7) = no fault, 2 running (2), 3 warning (8).
    assert_eq!(d.busio_out(), 0b0011);
    d.process(0x0400, &[0x2000], T0); // the control word itself does not act (P509 = 0)
    assert_eq!(d.state(), State::ReadyToSwitchOn);
    d.set_busio_in(0b0_0001, T0); // In bit 1: enable right
    assert_eq!(d.state(), State::OperationEnabled);
    assert_eq!(d.busio_out(), 0b0111);
    d.tick(ms(1000));
    assert_eq!(d.actual_frequency(), 25.0);
    assert_eq!(d.status_word(), 0x0937);
    d.set_busio_in(0b0_0010, ms(1000)); // In bit 2: enable left (through 0 Hz)
    d.tick(ms(3000));
    assert_eq!(d.actual_frequency(), -25.0);
    assert_eq!(d.status_word(), 0x1137);
    d.set_busio_in(0b0_0011, ms(3000)); // both: stop with the braking ramp
    assert_eq!(d.state(), State::OperationEnabled);
    d.tick(ms(4000));
    assert_eq!(d.state(), State::ReadyToSwitchOn);
    // Under bus control (P509 = 5) the last valid control word acts (0400h: disable voltage)
    // and the enable bits do nothing.
    d.write(509, 0, 0, 5, true, ms(4000)).unwrap();
    assert_eq!(d.state(), State::SwitchOnDisabled);
    d.set_busio_in(0b0_0000, ms(4000));
    d.set_busio_in(0b0_0001, ms(4000));
    assert_eq!(d.state(), State::SwitchOnDisabled);
}

/// An active-low quick stop on In bit 4 (P480 [-04] = 11) and disable voltage on In bit 5
/// ([-05] = 10) act on top of the control word.
#[test]
fn quick_stop_and_disable_voltage_through_busio_bits() {
    let mut d = running();
    d.set_busio_in(0b1_1000, ms(1000)); // bits 4 and 5 high before their functions are set
    d.write(
        480,
        3,
        0,
        input_function::QUICK_STOP as i32,
        false,
        ms(1000),
    )
    .unwrap();
    d.write(
        480,
        4,
        0,
        input_function::DISABLE_VOLTAGE as i32,
        false,
        ms(1000),
    )
    .unwrap();
    assert_eq!(d.state(), State::OperationEnabled);
    d.set_busio_in(0b1_0000, ms(1000)); // bit 4 low: quick stop
    assert_eq!(d.state(), State::QuickStopActive);
    assert_eq!(
        d.status_word() & 0x0020,
        0,
        "status bit 5: quick stop commanded"
    );
    d.tick(ms(1050));
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(
        d.read(700, 2, 0, ms(1050)),
        Ok(switch_on_disabled_reason::QUICK_STOP)
    );
    d.set_busio_in(0b1_1000, ms(1050)); // released: the control word 047Fh is still present
    d.process(0x047E, &[], ms(1050));
    d.process(0x047F, &[], ms(1050));
    d.tick(ms(2050));
    assert_eq!(d.actual_frequency(), 25.0);
    d.set_busio_in(0b0_1000, ms(2050)); // bit 5 low: disable voltage at once
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.actual_frequency(), 0.0);
    assert_eq!(
        d.status_word() & 0x0030,
        0x0020,
        "bit 4 = 0: disable voltage commanded"
    );
}

/// Fault acknowledgement through In bit 3 (default P480 [-03] = 12) and through control bit 8
/// (P480 [-11] = 12); status bits 10 and 13 through P481 [-09] / [-10].
#[test]
fn fault_ack_and_status_bits_through_busio_functions() {
    let mut d = running();
    d.write(481, 8, 0, output_function::FAULT as i32, true, ms(1000))
        .unwrap(); // ZSW bit 10
    d.write(481, 9, 0, output_function::WARNING as i32, true, ms(1000))
        .unwrap(); // bit 13
    assert_eq!(d.status_word(), 0x0F37, "bit 10: no fault (active low)");
    d.set_warning(1);
    assert_eq!(d.status_word(), 0x2FB7, "bits 13 and 7: warning");
    assert_eq!(d.busio_out(), 0b1111);
    d.set_warning(0);
    d.raise_fault(9, ms(1000));
    d.tick(ms(1100));
    assert_eq!(d.status_word() & 0x0400, 0);
    assert_eq!(
        d.busio_out(),
        0b0000,
        "not ready, fault (active low), not running"
    );
    d.set_busio_in(0b0_0100, ms(1100)); // In bit 3 rises: acknowledged
    assert_eq!(d.state(), State::SwitchOnDisabled);
    d.raise_fault(10, ms(1200));
    d.tick(ms(1300));
    d.set_busio_in(0b0_0100, ms(1300)); // still high: no edge
    assert_eq!(d.state(), State::Fault);
    d.write(480, 10, 0, input_function::FAULT_ACK as i32, true, ms(1300))
        .unwrap();
    d.process(0x047F, &[], ms(1300));
    d.process(0x057F, &[], ms(1310)); // control bit 8 rises (In bit 3 is still high)
    assert_eq!(d.state(), State::SwitchOnDisabled);
    assert_eq!(d.transition_log().last(), Some("15"));
}

// ---- actual values (ch. 4.5.4) ----

/// A 32-bit position across IW2 (low word) and IW3 (high word).
#[test]
fn position_across_two_actual_values() {
    let mut d = SimulatedNord::new();
    d.write(543, 1, 0, 10, true, T0).unwrap(); // IW2: position low word
    d.write(543, 2, 0, 15, true, T0).unwrap(); // IW3: position high word
    d.set_position(0x0001_2345);
    assert_eq!(d.actual_values()[1..], [0x2345, 0x0001]);
    d.set_position(-2);
    assert_eq!(d.actual_values()[1..], [0xFFFE, 0xFFFF]);
    d.set_position(0);
    // 50 Hz with P102 = 0 (no ramp): 2 pole pairs → 25 rev/s → 100 revolutions in 4 s =
    // 100000 increments = 0001_86A0h.
    d.write(102, 0, 0, 0, false, T0).unwrap();
    d.process(0x047E, &[], T0);
    d.process(0x047F, &[0x4000], T0);
    d.tick(ms(2000));
    d.tick(ms(4000));
    assert_eq!(d.position(), 100_000);
    assert_eq!(d.actual_values(), [0x4000, 0x86A0, 0x0001]);
    // P607/P608 = 1/2 halves the value sent.
    d.write(608, 0, 0, 2, false, ms(4000)).unwrap();
    assert_eq!(d.actual_values()[1..], [0xC350, 0x0000]); // 50000
    assert_eq!(
        d.write(608, 0, 0, 0, false, ms(4000)),
        Err(PkwRefusal::LimitExceeded)
    );
    // Counter-clockwise counts down.
    d.write(608, 0, 0, 1, false, ms(4000)).unwrap();
    d.process(0x147F, &[0x4000], ms(4000));
    d.tick(ms(12_000));
    assert_eq!(d.position(), -100_000);
    assert_eq!(d.actual_values()[1..], [0x7960, 0xFFFE]);
}

/// The current: 30 % of the rated current at constant frequency, 60 % while ramping, in percent
/// of P112 (401 "off" counts as 400 %).
#[test]
fn current_actual_value() {
    let mut d = SimulatedNord::new();
    d.write(543, 1, 0, 3, true, T0).unwrap();
    assert_eq!(d.actual_values()[1], 0);
    d.process(0x047E, &[], T0);
    d.process(0x047F, &[0x2000], T0);
    assert_eq!(d.actual_values()[1], 2458); // 60 / 400 × 16384, rounded
    d.tick(ms(1000));
    assert_eq!(d.actual_values()[1], 1229); // 30 / 400 × 16384
    d.write(112, 0, 0, 100, true, ms(1000)).unwrap();
    assert_eq!(d.actual_values()[1], 4915); // 30 % of 100 %
}

// ---- properties ----

#[derive(Debug, Clone)]
enum Op {
    Process(u16, Vec<u16>),
    BusIo(u8),
    Write(u16, u8, u8, i32, bool),
    Read(u16, u8, u8),
    Fault(u16),
    Warning(u16),
    Restart,
    Tick,
}

fn op() -> impl Strategy<Value = Op> {
    let pnu = prop::sample::select(vec![
        102u16, 105, 112, 480, 481, 509, 543, 546, 560, 607, 608, 700, 701, 740, 999,
    ]);
    prop_oneof![
        4 => (any::<u16>(), prop::collection::vec(any::<u16>(), 0..4)).prop_map(|(w, s)| Op::Process(w, s)),
        // Control words near the manual's commands, so that the states are visited.
        4 => (prop::sample::select(vec![0x047Eu16, 0x047F, 0x0477, 0x0400, 0x0402, 0x0480, 0x147F, 0x445F, 0x046F]),
              prop::collection::vec(any::<u16>(), 0..2)).prop_map(|(w, s)| Op::Process(w, s)),
        2 => any::<u8>().prop_map(Op::BusIo),
        2 => (pnu.clone(), 0u8..14, 0u8..5, any::<i32>(), any::<bool>()).prop_map(|(p, e, s, v, ee)| Op::Write(p, e, s, v, ee)),
        1 => (pnu, 0u8..14, 0u8..5).prop_map(|(p, e, s)| Op::Read(p, e, s)),
        1 => any::<u16>().prop_map(Op::Fault),
        1 => any::<u16>().prop_map(Op::Warning),
        1 => Just(Op::Restart),
        2 => Just(Op::Tick),
    ]
}

proptest! {
    /// No input sequence panics, and every status word decodes to exactly one state: the
    /// drive's own.
    #[test]
    fn no_sequence_panics_and_status_decodes_to_one_state(
        ops in prop::collection::vec((op(), 0u64..300), 1..60),
    ) {
        let mut d = SimulatedNord::new();
        let mut t = T0;
        for (op, dt) in ops {
            t += Duration::from_millis(dt);
            match op {
                Op::Process(w, s) => d.process(w, &s, t),
                Op::BusIo(b) => d.set_busio_in(b, t),
                Op::Write(p, e, s, v, ee) => { let _ = d.write(p, e, s, v, ee, t); }
                Op::Read(p, e, s) => { let _ = d.read(p, e, s, t); }
                Op::Fault(n) => d.raise_fault(n, t),
                Op::Warning(n) => d.set_warning(n),
                Op::Restart => d.restart(t),
                Op::Tick => d.tick(t),
            }
            let zsw = d.status_word();
            let matching = states().iter().filter(|s| s.matches(zsw)).count();
            prop_assert_eq!(matching, 1, "ZSW {:04X}", zsw);
            prop_assert_eq!(NordStateMachine::decode(zsw), d.state());
            prop_assert!(d.actual_frequency().is_finite());
            let _ = (d.actual_values(), d.busio_out());
        }
    }
}

/// The cached settings of the process-data path always equal the store: after writes to RAM
/// and EEPROM, refused writes, RAM-only writes lost by a restart.
#[test]
fn cached_settings_follow_every_write_and_restart() {
    let mut d = SimulatedNord::new();
    let same = |d: &SimulatedNord| {
        for (number, len) in [
            (480u16, 12u8),
            (481, 10),
            (543, 3),
            (546, 3),
            (509, 1),
            (560, 1),
        ] {
            for e in 0..len {
                assert_eq!(
                    d.settings.element(number, e),
                    Some(d.store.read(number, super::params::sub(e, 0)).unwrap_or(0)),
                    "P{number} [{e}]"
                );
            }
        }
        for number in [102u16, 105, 112] {
            for set in 0..4 {
                assert_eq!(
                    d.settings.in_set(number, set),
                    Some(
                        d.store
                            .read(number, super::params::sub(0, set))
                            .unwrap_or(0)
                    ),
                    "P{number} set {set}"
                );
            }
        }
    };
    same(&d);
    let t = Instant::from_millis(1);
    d.write(480, 3, 0, 11, true, t).unwrap();
    d.write(105, 0, 2, 400, false, t).unwrap(); // RAM only: lost at restart
    d.write(102, 0, 1, 150, true, t).unwrap();
    assert!(d.write(105, 0, 0, 100_000, true, t).is_err()); // refused: nothing changes
    same(&d);
    assert_eq!(d.settings.in_set(105, 2), Some(400));
    d.restart(Instant::from_millis(2));
    same(&d);
    assert_eq!(
        d.settings.in_set(105, 2),
        d.eeprom_value(105, 0, 2).map(i64::from)
    );
    assert_eq!(d.settings.in_set(102, 1), Some(150));
}
