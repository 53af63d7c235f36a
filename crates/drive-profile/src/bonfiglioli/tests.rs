//! Tests of the Bonfiglioli tables, words and state machines, with the manual's numbers.

use super::state::{ACT_PATTERNS, ACU_PATTERNS, Pattern, command};
use super::words::ContactState;
use super::*;
use crate::state::StateMachine;
use proptest::prelude::*;

fn p(n: u16) -> &'static Param {
    by_number(n).unwrap_or_else(|| panic!("P{n} missing"))
}

fn scaling_text(p: &Param) -> String {
    let mut s = String::new();
    p.describe_scaling(&mut s).unwrap();
    s
}

// ---------------------------------------------------------------- parameter table

#[test]
fn spot_check_1376_modbus_address() {
    // Ch. 5.2.2 / 5.3.2: Modbus address, 1 … 247, factory setting 1.
    let a = lookup("1376").unwrap();
    assert_eq!(a.name_de, "Modbus Adresse");
    assert_eq!(a.name_en, "Modbus address");
    assert_eq!((a.min, a.max, a.default), (Some(1), Some(247), Some(1)));
    assert_eq!(a.raw_range(), Some((1, 247)));
    assert_eq!(a.default_raw(), Some(1));
    assert!(!a.in_range(0) && a.in_range(247) && !a.in_range(248));
    assert_eq!(a.family(), Family::Bonfiglioli);
    assert_eq!(a.bus_index(), 1376);
    assert_eq!(a.range_en, "1 … 247");
}

#[test]
fn lookups_accept_number_and_p_prefix() {
    assert_eq!(lookup("P1376").map(|p| p.number), Some(1376));
    assert_eq!(lookup(" p10 ").map(|p| p.number), Some(10));
    assert!(lookup("P").is_none());
    assert!(lookup("P-1").is_none());
    assert!(lookup("1600").is_none()); // ch. 8.1.3: unknown parameter
    assert!(lookup("x10").is_none());
    assert!(lookup("99999").is_none());
    assert_eq!(by_index(410).map(|p| p.name_en), Some("Control word"));
    assert!(by_number(0).is_none());
}

#[test]
fn every_number_the_manual_names_is_present() {
    let required = [
        10u16, 11, 30, 34, 68, 69, 210, 217, 218, 228, 229, 241, 249, 250, 260, 270, 282, 283, 372,
        375, 376, 392, 394, 395, 410, 411, 412, 413, 414, 415, 419, 424, 425, 434, 475, 476, 481,
        484, 506, 507, 524, 549, 632, 637, 638, 680, 1375, 1376,
    ];
    for n in required {
        assert!(by_number(n).is_some(), "P{n} missing");
    }
    assert_eq!(params().len(), required.len());
    assert!(params().windows(2).all(|w| w[0].number < w[1].number));
}

#[test]
fn table_is_consistent() {
    for p in params() {
        if let (Some(lo), Some(hi)) = (p.min, p.max) {
            assert!(lo <= hi, "P{}", p.number);
        }
        if let Some(d) = p.default {
            assert!(p.in_range(d), "P{} default", p.number);
        }
        if let Some((lo, hi)) = p.data_type.bounds() {
            let (rlo, rhi) = p.raw_range().unwrap();
            assert!(
                rlo >= lo && rhi <= hi,
                "P{} range outside its type",
                p.number
            );
        }
        for v in p.values {
            assert!(p.in_range(v.value), "P{} value {}", p.number, v.value);
        }
        if p.menu == Menu::Val {
            assert_eq!(p.access, ParamAccess::ReadOnly, "P{}", p.number);
        }
        assert!(!p.name_de.is_empty() && !p.name_en.is_empty());
        assert!(p.number <= 1599);
    }
}

#[test]
fn data_types_from_the_manual() {
    // Stated in ch. 9 / 10.
    assert_eq!(p(410).data_type, DataType::UInt);
    assert_eq!(p(411).data_type, DataType::UInt);
    assert_eq!(p(484).data_type, DataType::Long);
    assert_eq!(p(524).data_type, DataType::Long);
    assert_eq!(p(210).data_type, DataType::Long);
    assert_eq!(p(217).data_type, DataType::Long);
    assert_eq!(p(218).data_type, DataType::Int);
    // Ch. 8 examples: FC 3/6 for 372/376, FC 100/101 for 375/481.
    assert_eq!(p(372).data_type.is_32_bit(), Some(false));
    assert_eq!(p(376).data_type.is_32_bit(), Some(false));
    assert_eq!(p(375).data_type.is_32_bit(), Some(true));
    assert_eq!(p(481).data_type.is_32_bit(), Some(true));
    assert_eq!(p(372).type_source, TypeSource::Example);
    // The manual gives no type for 1376.
    assert_eq!(p(1376).data_type, DataType::Unknown);
    assert_eq!(p(1376).data_type.is_32_bit(), None);
}

#[test]
fn describe_scaling_names_decimals_and_type() {
    assert_eq!(scaling_text(p(218)), "0 decimals, Int (16 bit)");
    assert_eq!(scaling_text(p(376)), "1 decimal, uInt (16 bit)");
    assert_eq!(scaling_text(p(484)), "2 decimals, Long (32 bit)");
    assert_eq!(
        scaling_text(p(1376)),
        "0 decimals, data type not given in the manual"
    );
}

#[test]
fn manual_scaling_examples() {
    // Ch. 8.1.2: 1.5 kW in P376 (one decimal) is sent as 15 = 0x000F.
    assert_eq!(p(376).from_physical(1.5), Ok(0x000F));
    assert_eq!(p(376).to_physical(15), 1.5);
    // Ch. 8.1.3: P481 reads 0x000003E8 = 1000 = 10.00 Hz (two decimals).
    assert_eq!(p(481).to_physical(0x3E8), 10.0);
    // Ch. 8.1.4: 10.00 Hz in P375 is 1000 = 0x03E8; 9.00 Hz (900) is rejected by the drive.
    assert_eq!(p(375).from_physical(10.0), Ok(0x03E8));
    assert!(p(375).in_range(1000));
    assert!(!p(375).in_range(900));
    assert!(p(375).from_physical(9.0).is_err());
    // Ch. 8.1.2 example 2: 0 is an illegal value of P376.
    assert!(!p(376).in_range(0));
    // Ch. 8.1.1: P372 has no decimals: 0x056E = 1390 1/min.
    assert_eq!(p(372).to_physical(0x056E), 1390.0);
    // Ch. 6.4.3: 100.25 Hz is sent as 10025 = 0x2729.
    assert_eq!(p(484).from_physical(100.25), Ok(0x2729));
    assert_eq!(p(484).from_physical(-999.99), Ok(-99999));
    assert!(p(484).from_physical(1000.0).is_err());
    // Ch. 11: P424 0.01 … 9999.99 Hz/s.
    assert_eq!(p(424).from_physical(9999.99), Ok(999_999));
}

#[test]
fn flags_and_access() {
    // Data-set parameters (ch. 11 pictogram, ch. 9/10 text, ch. 8 examples).
    for n in [372, 375, 376, 392, 412, 424, 425, 434, 632, 637, 638] {
        assert!(p(n).is_data_set(), "P{n}");
        assert!(p(n).access().contains(Access::DATA_SET));
    }
    // RAM only, always data set 0 (ch. 7).
    for n in [410, 484, 524] {
        assert!(p(n).ram_only && !p(n).is_data_set());
        assert!(!p(n).access().contains(Access::NON_VOLATILE));
    }
    assert!(p(1376).access().contains(Access::NON_VOLATILE));
    // ACU: P484 and P524 can only be written (ch. 10.2.3).
    assert!(!p(484).is_readable() && p(484).is_writable());
    assert!(p(484).bus_only && p(524).bus_only);
    assert!(p(34).access().contains(Access::NOT_IN_OPERATION));
    assert!(!p(260).access().is_writable());
    assert!(p(1376).access().is_writable());
    assert_eq!(p(11).access, ParamAccess::ReadOnly);
    assert_eq!(p(10).sub_index(), Some(0));
}

#[test]
fn value_lists() {
    let baud = p(10);
    assert_eq!(baud.default, Some(4));
    assert_eq!(baud.value_name(4).map(|v| v.en), Some("19200 baud"));
    assert_eq!(baud.values.len(), 6);
    assert_eq!(p(395).value_name(2).map(|v| v.de), Some("Modbus RTU"));
    assert_eq!(p(395).value_name(3).map(|v| v.en), Some("Modbus ASCII"));
    assert_eq!(
        p(412).value_name(1).map(|v| v.en),
        Some("Control via state machine control word")
    );
    assert_eq!(p(1375).value_name(0).map(|v| v.de), Some("Gerade"));
    assert_eq!(p(1375).value_name(2).map(|v| v.en), Some("None"));
    assert_eq!(p(392).value_name(2).map(|v| v.en), Some("Ramp"));
    assert_eq!(p(434).values.len(), 3);
    // P11 takes its values from the VABus error table.
    assert_eq!(p(11).values.len(), 16);
    assert_eq!(
        p(11).value_name(9).map(|v| v.en),
        Some("Values of the data sets differ")
    );
}

#[test]
fn search_finds_german_english_and_aliases() {
    let hits: Vec<u16> = search("modbus").map(|p| p.number).collect();
    assert_eq!(hits, [1375, 1376]);
    assert!(search("SOLLFREQUENZ").any(|p| p.number == 283));
    assert!(search("watchdog").any(|p| p.number == 413));
    // Ch. 9/10 call P414 "Datensatzanzahl"; ch. 11 "Datensatzanwahl".
    assert_eq!(
        search("Datensatzanzahl")
            .map(|p| p.number)
            .collect::<Vec<_>>(),
        [414]
    );
    assert_eq!(
        search("data set selection")
            .map(|p| p.number)
            .collect::<Vec<_>>(),
        [414]
    );
    assert!(search("Übergang").any(|p| p.number == 392));
    assert!(search("zzzz").next().is_none());
}

#[test]
fn errata_375_has_two_decimals_376_one() {
    // Ch. 8.1.4 / 8.2.4 example 2 call the rated frequency "376"; it is 375 (two decimals).
    assert_eq!(p(375).decimals, 2);
    assert_eq!(p(375).name_de, "Bemessungsfrequenz");
    assert_eq!(p(376).decimals, 1);
    assert_eq!(p(376).name_de, "Mech. Bemessungsleistung");
}

proptest! {
    #[test]
    fn every_parameter_round_trips_over_its_range(i in 0usize..64, frac in 0.0f64..=1.0) {
        let n = params().len();
        let p = &params()[i % n];
        if let Some((lo, hi)) = p.raw_range() {
            let raw = lo + ((hi - lo) as f64 * frac) as i64;
            let raw = raw.clamp(lo, hi);
            prop_assert_eq!(p.from_physical(p.to_physical(raw)), Ok(raw));
            prop_assert_eq!(p.from_physical(p.to_physical(lo)), Ok(lo));
            prop_assert_eq!(p.from_physical(p.to_physical(hi)), Ok(hi));
        }
    }
}

// ---------------------------------------------------------------- warnings, faults, errors

#[test]
fn warning_example_of_ch_12_1() {
    // Ixt + short-term Ixt + heat sink + motor temperature = 0x008B.
    let bits: Vec<u8> = warning_bits(0x008B).map(|w| w.bit).collect();
    assert_eq!(bits, [0, 1, 3, 7]);
    let names: Vec<&str> = warning_bits(0x008B).map(|w| w.name_de).collect();
    assert_eq!(
        names,
        [
            "Warnung Ixt",
            "Warnung Kurzzeit Ixt",
            "Warnung Kühlkörpertemperatur Tk",
            "Warnung Motortemperatur"
        ]
    );
    assert!(warnings_consistent(0x008B));
    // Bit 1 without bit 0 contradicts footnote 1.
    assert!(!warnings_consistent(0x0002));
    assert_eq!(warning_bits(0).count(), 0);
    assert_eq!(warning_bits(0xFFFF).count(), 16);
    for (i, w) in warnings().iter().enumerate() {
        assert_eq!(usize::from(w.bit), i);
        assert_eq!(w.code, 1 << i);
    }
}

#[test]
fn fault_keys_encode_group_and_code() {
    // Ch. 6.9 / 12.2: the watchdog fault F2010 is group 0x20, code 0x10.
    let f = fault(0x2010).unwrap();
    assert_eq!(f.key, "F2010");
    assert_eq!((f.group(), f.code()), (0x20, 0x10));
    assert_eq!(f.text_en, "Communication watchdog RS232/RS485");
    assert_eq!(FaultCode(0x2010).to_string(), "F2010");
    assert_eq!(FaultCode(0x0101).to_string(), "F0101");
    assert!(FaultCode(0x0101).meaning().is_none()); // not listed in ch. 12.2
    assert_eq!(fault_by_key("F0102").map(|f| f.value), Some(0x0102));
    assert_eq!(
        fault_by_key("f1431").map(|f| f.group_en),
        Some("Control connection")
    );
    assert!(fault_by_key("F99").is_none());
    assert!(!fault(0).unwrap().is_fault());
    for f in faults() {
        assert_eq!(FaultCode(f.value).to_string(), f.key);
    }
}

#[test]
fn vabus_errors_and_exceptions() {
    assert_eq!(vabus_error(0).map(|e| e.name_en), Some("No error"));
    assert_eq!(
        vabus_error(9).map(|e| e.name_de),
        Some("Werte der Datensätze unterscheiden sich voneinander")
    );
    assert_eq!(vabus_error(15).map(|e| e.name_en), Some("Unknown error"));
    assert!(vabus_error(16).is_none());
    assert_eq!(vabus_errors().len(), 16);
    assert_eq!(
        modbus_exception(2).map(|e| e.modbus_name),
        Some("ILLEGAL DATA ADDRESS")
    );
    assert_eq!(
        modbus_exception(4).map(|e| e.name_de),
        Some("FEHLER SLAVE GERÄT")
    );
    assert!(modbus_exception(5).is_none());
    assert_eq!(modbus_exceptions().len(), 4);
}

// ---------------------------------------------------------------- words

#[test]
fn words_debug_by_english_name() {
    assert_eq!(
        format!("{:?}", ActControlWord::from_bits(0x0F)),
        "ActControlWord(switch on | enable voltage | no quick stop | enable operation)"
    );
    assert_eq!(
        format!("{:?}", ActControlWord::from_bits(0x80)),
        "ActControlWord(fault reset)"
    );
    assert_eq!(
        format!("{:?}", ActControlWord::from_bits(0x0110)),
        "ActControlWord(0x0110)"
    );
    assert_eq!(
        format!("{:?}", AcuControlWord::from_bits(0x0100)),
        "AcuControlWord(halt)"
    );
    assert_eq!(
        format!(
            "{:?}",
            RemoteContacts::S1IND | RemoteContacts::S2IND | RemoteContacts::EM_S3IND
        ),
        "RemoteContacts(S1IND | S2IND | EM-S3IND)"
    );
    assert_eq!(
        format!("{:?}", ActStatusWord::from_bits(0x8627)),
        "ActStatusWord(ready to switch on | switched on | operation enabled | no quick stop | \
         remote | setpoint reached | warning 2)"
    );
    assert_eq!(
        format!("{:?}", AcuStatusWord::from_bits(0x0437)),
        "AcuStatusWord(ready to switch on | switched on | operation enabled | voltage enabled | \
         no quick stop | target reached)"
    );
    assert_eq!(format!("{:?}", AcuStatusWord::empty()), "AcuStatusWord()");
}

#[test]
fn word_bits_match_the_manual_tables() {
    // Commands of ch. 9.1.2.
    let on =
        ActControlWord::SWITCH_ON | ActControlWord::ENABLE_VOLTAGE | ActControlWord::NO_QUICK_STOP;
    assert_eq!(on.bits(), command::SWITCH_ON);
    assert_eq!(
        (on | ActControlWord::ENABLE_OPERATION).bits(),
        command::ENABLE_OPERATION
    );
    assert_eq!(
        on.difference(ActControlWord::SWITCH_ON).bits(),
        command::SHUTDOWN
    );
    assert_eq!(ActControlWord::ENABLE_VOLTAGE.bits(), command::QUICK_STOP);
    assert_eq!(ActControlWord::FAULT_RESET.bits(), command::FAULT_RESET);
    assert_eq!(u16::from(RemoteContacts::EM_S3IND), 1 << 9);
    assert_eq!(ActStatusWord::WARNING_2.bits(), 0x8000);
    assert!(AcuStatusWord::from_bits(0x10).mains_on());
    assert_eq!(
        ActStatusWord::from_bits(0x0027).state(),
        State::OperationEnabled
    );
    assert_eq!(
        AcuStatusWord::from_bits(0x0037).state(),
        State::OperationEnabled
    );
}

#[test]
fn contact_mode_states() {
    // Ch. 9.1.1 / 9.1.3 (ACT) and 10.1 (ACU).
    assert_eq!(
        ActStatusWord::from_bits(0x23).contact_state(),
        ContactState::SwitchedOn
    );
    assert_eq!(
        ActStatusWord::from_bits(0x0227).contact_state(),
        ContactState::OperationEnabled
    );
    assert_eq!(
        ActStatusWord::from_bits(0x28).contact_state(),
        ContactState::Fault
    );
    assert_eq!(
        ActStatusWord::from_bits(0x40).contact_state(),
        ContactState::Other
    );
    // ACU: bit 4 reports the mains only (the table prints 0 for switched on, 1 for enabled).
    assert_eq!(
        AcuStatusWord::from_bits(0x23).contact_state(),
        ContactState::SwitchedOn
    );
    assert_eq!(
        AcuStatusWord::from_bits(0x33).contact_state(),
        ContactState::SwitchedOn
    );
    assert_eq!(
        AcuStatusWord::from_bits(0x37).contact_state(),
        ContactState::OperationEnabled
    );
    assert_eq!(
        AcuStatusWord::from_bits(0x0F).contact_state(),
        ContactState::Fault
    );
}

// ---------------------------------------------------------------- state machine

fn count_matches(patterns: &[Pattern], w: u16) -> usize {
    patterns.iter().filter(|p| w & p.mask == p.value).count()
}

#[test]
fn every_status_word_decodes_to_one_state_act() {
    let mut unknown = 0u32;
    for w in 0..=u16::MAX {
        let n = count_matches(&ACT_PATTERNS, w);
        assert!(n <= 1, "{w:#06x} matches {n} states");
        let s = ActStateMachine::decode(w);
        if n == 0 {
            assert_eq!(s, State::Unknown, "{w:#06x}");
            unknown += 1;
        } else {
            assert_ne!(s, State::Unknown);
            let p = ACT_PATTERNS.iter().find(|p| p.state == s).unwrap();
            assert_eq!(w & p.mask, p.value);
        }
    }
    // Bits 0…3, 5, 6 take part: 64 combinations, of which the table covers
    // 2 (not ready) + 2 (disabled) + 1 + 1 + 1 + 1 + 2 (fault) + 2 (fault reaction) = 12;
    // the other 10 bits are free.
    assert_eq!(unknown, (64 - 12) * 1024);
}

#[test]
fn every_status_word_decodes_to_one_state_acu() {
    let mut unknown = 0u32;
    for w in 0..=u16::MAX {
        let n = count_matches(&ACU_PATTERNS, w);
        assert!(n <= 1, "{w:#06x}");
        let s = AcuStateMachine::decode(w);
        assert_eq!(s == State::Unknown, n == 0, "{w:#06x}");
        assert_eq!(AcuPositioningStateMachine::decode(w), s);
    }
    for w in 0..=u16::MAX {
        if AcuStateMachine::decode(w) == State::Unknown {
            unknown += 1;
        }
    }
    assert_eq!(unknown, (64 - 10) * 1024);
}

#[test]
fn manual_status_words_decode() {
    use State::*;
    // Ch. 9.1.2 table (bits 7…15 ignored).
    for (w, s) in [
        (0x00, NotReadyToSwitchOn),
        (0x40, SwitchOnDisabled),
        (0x21, ReadyToSwitchOn),
        (0x07, QuickStopActive),
        (0x23, SwitchedOn),
        (0x27, OperationEnabled),
        (0x08, Fault),
        (0x0F, FaultReactionActive),
        (0x8627, OperationEnabled),
        (0x0260, SwitchOnDisabled),
        (0x28, Fault),
    ] {
        assert_eq!(ActStateMachine::decode(w), s, "{w:#06x}");
    }
    assert_eq!(AcuStateMachine::decode(0x00), Unknown);
    assert_eq!(AcuStateMachine::decode(0x50), SwitchOnDisabled);
    assert_eq!(AcuStateMachine::decode(0x31), ReadyToSwitchOn);
    assert_eq!(AcuStateMachine::decode(0x17), QuickStopActive);
}

#[test]
fn manual_control_words() {
    use State::*;
    type A = ActStateMachine;
    assert_eq!(
        A::control_toward(SwitchOnDisabled, ReadyToSwitchOn),
        Some(0x06)
    ); // 2
    assert_eq!(A::control_toward(ReadyToSwitchOn, SwitchedOn), Some(0x07)); // 3
    assert_eq!(A::control_toward(SwitchedOn, OperationEnabled), Some(0x0F)); // 4
    assert_eq!(A::control_toward(OperationEnabled, SwitchedOn), Some(0x07)); // 5
    assert_eq!(A::control_toward(SwitchedOn, ReadyToSwitchOn), Some(0x06)); // 6
    assert_eq!(
        A::control_toward(ReadyToSwitchOn, SwitchOnDisabled),
        Some(0x00)
    ); // 7
    assert_eq!(
        A::control_toward(OperationEnabled, ReadyToSwitchOn),
        Some(0x06)
    ); // 8
    assert_eq!(
        A::control_toward(OperationEnabled, SwitchOnDisabled),
        Some(0x00)
    ); // 9
    assert_eq!(A::control_toward(SwitchedOn, SwitchOnDisabled), Some(0x00)); // 10
    assert_eq!(
        A::control_toward(OperationEnabled, QuickStopActive),
        Some(0x02)
    ); // 11
    assert_eq!(
        A::control_toward(QuickStopActive, SwitchOnDisabled),
        Some(0x00)
    ); // 12
    assert_eq!(A::control_toward(Fault, SwitchOnDisabled), Some(0x80)); // 15
    // The shortcut 4 (0x0F) from switch-on disabled straight to operation enabled.
    assert_eq!(
        A::control_toward(SwitchOnDisabled, OperationEnabled),
        Some(0x0F)
    );
    assert_eq!(
        AcuStateMachine::control_toward(SwitchOnDisabled, OperationEnabled),
        Some(0x0F)
    );
    // Not with positioning control (P30 = x40): the regular way 2, 3, 4.
    assert_eq!(
        AcuPositioningStateMachine::control_toward(SwitchOnDisabled, OperationEnabled),
        Some(0x06)
    );
    // Fault → operation enabled starts with the reset.
    assert_eq!(A::control_toward(Fault, OperationEnabled), Some(0x80));
    // None: already there, not a target, or the drive moves by itself.
    assert_eq!(A::control_toward(OperationEnabled, OperationEnabled), None);
    assert_eq!(A::control_toward(SwitchedOn, Fault), None);
    assert_eq!(
        A::control_toward(NotReadyToSwitchOn, OperationEnabled),
        None
    );
    assert_eq!(
        A::control_toward(FaultReactionActive, SwitchOnDisabled),
        None
    );
    assert_eq!(A::control_toward(Unknown, OperationEnabled), None);
    assert_eq!(A::control_toward(SwitchedOn, Unknown), None);
}

#[test]
fn transition_5_from_parameter_392() {
    assert_eq!(
        p(392).default.and_then(Transition5::from_raw),
        Some(Transition5::Ramp)
    );
    for v in p(392).values {
        let t = Transition5::from_raw(v.value).unwrap();
        assert_eq!(i64::from(t.raw()), v.value);
    }
    assert!(Transition5::from_raw(3).is_none());
    assert!(Transition5::FreeCoast.is_immediate());
    assert!(!Transition5::DcBrake.accepts_control_word_while_stopping());
    assert!(Transition5::Ramp.can_resume() && !Transition5::DcBrake.can_resume());
}

/// A tiny drive that follows the manual's command table (independent of `control_toward`).
#[derive(Debug)]
struct Drive {
    state: State,
    shortcut: bool,
    last_word: u16,
    t5: Transition5,
    stopping: u8,
    quick_stopping: u8,
    noise: u16,
}

impl Drive {
    fn new(state: State, shortcut: bool, t5: Transition5) -> Drive {
        Drive {
            state,
            shortcut,
            last_word: 0,
            t5,
            stopping: 0,
            quick_stopping: 0,
            noise: 0,
        }
    }

    /// Status word of the state, with changing don't-care bits (4, 7…15 and X columns).
    fn status(&mut self) -> u16 {
        self.noise = self.noise.wrapping_mul(25173).wrapping_add(13849);
        let junk = self.noise & 0xFF90;
        let x5 = self.noise & 0x20;
        junk | match self.state {
            State::NotReadyToSwitchOn => x5,
            State::SwitchOnDisabled => 0x40 | x5,
            State::ReadyToSwitchOn => 0x21,
            State::SwitchedOn => 0x23,
            State::OperationEnabled => 0x27,
            State::QuickStopActive => 0x07,
            State::FaultReactionActive => 0x0F | x5,
            State::Fault => 0x08 | x5,
            State::Unknown => 0x01,
        }
    }

    fn apply(&mut self, w: u16) {
        use State::*;
        let edge = w & 0x80 != 0 && self.last_word & 0x80 == 0;
        self.last_word = w;
        if self.stopping > 0 && !self.t5.accepts_control_word_while_stopping() {
            return;
        }
        let low = w & 0x0F;
        let disable_voltage = low & 0b0010 == 0;
        let quick_stop = !disable_voltage && low & 0b0100 == 0;
        let shutdown = low & 0b0111 == 0b0110;
        let switch_on = low & 0b0111 == 0b0111;
        let enable = low == 0x0F;
        self.state = match self.state {
            Fault if edge => SwitchOnDisabled,
            s @ (Fault | FaultReactionActive | NotReadyToSwitchOn | Unknown) => s,
            ReadyToSwitchOn | SwitchedOn if disable_voltage || quick_stop => SwitchOnDisabled,
            OperationEnabled | QuickStopActive if disable_voltage => SwitchOnDisabled,
            OperationEnabled if quick_stop => {
                self.quick_stopping = 2;
                QuickStopActive
            }
            SwitchOnDisabled | SwitchedOn | OperationEnabled if shutdown => ReadyToSwitchOn,
            ReadyToSwitchOn if switch_on => SwitchedOn,
            SwitchedOn if enable => OperationEnabled,
            SwitchOnDisabled if enable && self.shortcut => OperationEnabled,
            OperationEnabled if enable => {
                if self.t5.can_resume() {
                    self.stopping = 0;
                }
                OperationEnabled
            }
            OperationEnabled if switch_on => {
                if self.t5.is_immediate() {
                    SwitchedOn
                } else {
                    if self.stopping == 0 {
                        self.stopping = 3;
                    }
                    OperationEnabled
                }
            }
            s => s,
        };
    }

    fn tick(&mut self) {
        match self.state {
            State::NotReadyToSwitchOn => self.state = State::SwitchOnDisabled,
            State::FaultReactionActive => self.state = State::Fault,
            State::QuickStopActive if self.quick_stopping > 0 => {
                self.quick_stopping -= 1;
                if self.quick_stopping == 0 {
                    self.state = State::SwitchOnDisabled;
                }
            }
            State::OperationEnabled if self.stopping > 0 => {
                self.stopping -= 1;
                if self.stopping == 0 {
                    self.state = State::SwitchedOn;
                }
            }
            _ => {}
        }
    }
}

const STARTS: [State; 8] = [
    State::NotReadyToSwitchOn,
    State::SwitchOnDisabled,
    State::ReadyToSwitchOn,
    State::SwitchedOn,
    State::OperationEnabled,
    State::QuickStopActive,
    State::FaultReactionActive,
    State::Fault,
];

fn drive_to<M: StateMachine<State = State>>(d: &mut Drive, target: State) -> usize {
    let mut seq = ControlSequencer::<M>::with_last(d.last_word);
    for step in 0..30 {
        let sw = d.status();
        let s = M::decode(sw);
        if s == target {
            return step;
        }
        if let Some(w) = seq.next(sw, target) {
            d.apply(w);
        }
        d.tick();
    }
    panic!("{target:?} not reached: {d:?}");
}

fn paths_for<M: StateMachine<State = State>>(shortcut: bool, acu: bool) {
    let targets = [
        State::OperationEnabled,
        State::SwitchOnDisabled,
        State::ReadyToSwitchOn,
        State::SwitchedOn,
        State::QuickStopActive,
    ];
    for start in STARTS {
        if acu && start == State::NotReadyToSwitchOn {
            continue; // the ACU table has no such state
        }
        for t5 in [
            Transition5::FreeCoast,
            Transition5::DcBrake,
            Transition5::Ramp,
        ] {
            for target in targets {
                let mut d = Drive::new(start, shortcut, t5);
                d.last_word = 0x80; // worst case for the fault reset edge
                drive_to::<M>(&mut d, target);
                // And back to operation enabled, and again to the target.
                drive_to::<M>(&mut d, State::OperationEnabled);
                drive_to::<M>(&mut d, target);
            }
        }
    }
}

#[test]
fn every_state_reaches_every_target_act() {
    paths_for::<ActStateMachine>(true, false);
}

#[test]
fn every_state_reaches_every_target_acu() {
    paths_for::<AcuStateMachine>(true, true);
    paths_for::<AcuPositioningStateMachine>(false, true);
}

#[test]
fn shortcut_takes_one_step() {
    let mut d = Drive::new(State::SwitchOnDisabled, true, Transition5::Ramp);
    assert_eq!(
        drive_to::<ActStateMachine>(&mut d, State::OperationEnabled),
        1
    );
    let mut d = Drive::new(State::SwitchOnDisabled, false, Transition5::Ramp);
    assert_eq!(
        drive_to::<AcuPositioningStateMachine>(&mut d, State::OperationEnabled),
        3
    );
}

#[test]
fn transition_5_ramp_can_resume_and_dc_brake_cannot() {
    // Ramp: 0x07 starts the stop; 0x0F during the ramp keeps operation enabled.
    let mut d = Drive::new(State::OperationEnabled, true, Transition5::Ramp);
    d.apply(command::DISABLE_OPERATION);
    d.tick();
    assert_eq!(d.state, State::OperationEnabled);
    d.apply(command::ENABLE_OPERATION);
    for _ in 0..5 {
        d.tick();
    }
    assert_eq!(d.state, State::OperationEnabled);
    // DC brake: the control word is ignored until the braking time is over.
    let mut d = Drive::new(State::OperationEnabled, true, Transition5::DcBrake);
    d.apply(command::DISABLE_OPERATION);
    d.tick();
    d.apply(command::ENABLE_OPERATION);
    for _ in 0..5 {
        d.tick();
    }
    assert_eq!(d.state, State::SwitchedOn);
    // Free coast: at once.
    let mut d = Drive::new(State::OperationEnabled, true, Transition5::FreeCoast);
    d.apply(command::DISABLE_OPERATION);
    assert_eq!(d.state, State::SwitchedOn);
}

#[test]
fn sequencer_makes_the_fault_reset_an_edge() {
    let mut seq = ControlSequencer::<ActStateMachine>::with_last(0x80);
    assert_eq!(seq.next(0x08, State::SwitchOnDisabled), Some(0x00));
    assert_eq!(seq.next(0x08, State::SwitchOnDisabled), Some(0x80));
    // The 15 s lock keeps the fault: the next attempt clears bit 7 first again.
    assert_eq!(seq.next(0x08, State::SwitchOnDisabled), Some(0x00));
    assert_eq!(seq.next(0x08, State::SwitchOnDisabled), Some(0x80));
    let mut seq = ControlSequencer::<ActStateMachine>::new();
    assert_eq!(seq.next(0x08, State::OperationEnabled), Some(0x00));
    seq.sent(0x0F);
    assert_eq!(seq.last(), Some(0x0F));
    assert_eq!(seq.next(0x08, State::OperationEnabled), Some(0x80));
    assert_eq!(seq.next(0x40, State::OperationEnabled), Some(0x0F));
}
