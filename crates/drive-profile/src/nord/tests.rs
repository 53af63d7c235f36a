//! Tests of the NORD profile: table consistency, every status word, the manual's example
//! telegrams (BU 0255 chapters 4 and 5) as test vectors, and state-machine paths.
//!
//! Where the manual prints a wrong value the test asserts the right one and names the erratum
//! in `docs/errata-nord.md` (E1, E2, ...).

use super::*;
use crate::ParamMeta;
use crate::param::Family;
use crate::scaling::{ScaleError, join_i32, split_i32};
use crate::state::StateMachine;
use proptest::prelude::*;

// --- small USS PKW helpers for the test vectors (the real codec lives in ctt2-uss) ----------

/// PKE: AK in bits 12..15, SPM (bit 11) = 0, PNU in bits 0..10.
fn pke(ak: u8, pnu: u16) -> u16 {
    (u16::from(ak) << 12) | (pnu & 0x07FF)
}

/// IND for parameter-set parameters: array element raw value in bits 10..15, parameter set
/// (1..4) in bits 8..9, bits 0..7 zero (section 4.6.1.2).
fn ind(array_raw: u8, set: u8) -> u16 {
    (u16::from(array_raw) << 10) | (u16::from(set - 1) << 8)
}

/// The 8 PKW bytes, high byte first: PKE, IND, PWE1 (high word), PWE2 (low word).
fn pkw(pke: u16, ind: u16, pwe: u32) -> [u8; 8] {
    let (pwe1, pwe2) = crate::scaling::split_u32(pwe);
    let mut b = [0u8; 8];
    b[0..2].copy_from_slice(&pke.to_be_bytes());
    b[2..4].copy_from_slice(&ind.to_be_bytes());
    b[4..6].copy_from_slice(&pwe1.to_be_bytes());
    b[6..8].copy_from_slice(&pwe2.to_be_bytes());
    b
}

fn word(hi: u8, lo: u8) -> u16 {
    u16::from_be_bytes([hi, lo])
}

// --- tables ---------------------------------------------------------------------------------

#[test]
fn every_state_is_in_the_table_once() {
    for s in State::ALL {
        assert_eq!(states().iter().filter(|i| i.state == s).count(), 1, "{s:?}");
    }
    assert!(crate::nord::state_info(State::Unknown).is_none());
    // E12: the manual prints "Einschaltsperr"; the table uses the correct spelling.
    assert_eq!(State::SwitchOnDisabled.name_de(), "Einschaltsperre");
    assert_eq!(
        State::FaultReactionActive.to_string(),
        "fault reaction active"
    );
    assert_eq!(State::Unknown.to_string(), "unknown state");
}

#[test]
fn bit_tables_are_indexed_by_bit() {
    for (i, b) in control_bits().iter().enumerate() {
        assert_eq!(usize::from(b.bit), i);
    }
    for (i, b) in status_bits().iter().enumerate() {
        assert_eq!(usize::from(b.bit), i);
    }
    assert_eq!(ControlWord::bit_info(7).map(|b| b.key), Some("fault_reset"));
    assert_eq!(
        StatusWord::bit_info(6).map(|b| b.name_de),
        Some("Einschaltsperre")
    );
    assert!(ControlWord::bit_info(16).is_none());
    // Named constants agree with the table.
    let consts = [
        (ControlWord::SWITCH_ON, "switch_on"),
        (ControlWord::ENABLE_VOLTAGE, "enable_voltage"),
        (ControlWord::NO_QUICK_STOP, "no_quick_stop"),
        (ControlWord::ENABLE_OPERATION, "enable_operation"),
        (ControlWord::FAULT_RESET, "fault_reset"),
        (ControlWord::CONTROL_DATA_VALID, "control_data_valid"),
        (ControlWord::ROTATION_LEFT, "rotation_left"),
    ];
    for (c, key) in consts {
        assert_eq!(c.set_bits().map(|b| b.key).collect::<Vec<_>>(), [key]);
    }
    let consts = [
        (StatusWord::READY_TO_SWITCH_ON, "ready_to_switch_on"),
        (StatusWord::FAULT, "fault"),
        (StatusWord::SWITCH_ON_DISABLED, "switch_on_disabled"),
        (StatusWord::WARNING, "warning"),
        (StatusWord::FUNCTION_481_10, "function_481_10"),
    ];
    for (c, key) in consts {
        assert_eq!(c.set_bits().map(|b| b.key).collect::<Vec<_>>(), [key]);
    }
}

#[test]
fn status_patterns_reproduce_the_manual_table() {
    // "Auscodierte Zustände": bits 6..0 as printed.
    let printed = [
        (State::NotReadyToSwitchOn, "0XX0000"),
        (State::SwitchOnDisabled, "1XX0000"),
        (State::ReadyToSwitchOn, "0110001"),
        (State::SwitchedOn, "0110011"),
        (State::OperationEnabled, "0110111"),
        (State::Fault, "0XX1000"),
        (State::FaultReactionActive, "0XX1111"),
        (State::QuickStopActive, "0010111"),
    ];
    for (s, p) in printed {
        let info = crate::nord::state_info(s).unwrap();
        let mut text = String::new();
        for bit in (0..7).rev() {
            let m = 1u16 << bit;
            text.push(match (info.mask & m != 0, info.value & m != 0) {
                (false, _) => 'X',
                (true, false) => '0',
                (true, true) => '1',
            });
        }
        assert_eq!(text, p, "{s:?}");
    }
}

/// Every one of the 65 536 status words matches at most one state pattern; `decode` returns
/// that state, or `Unknown` when none matches.
#[test]
fn every_status_word_decodes_to_exactly_one_state_or_unknown() {
    let mut per_state = [0u32; 8];
    let mut unknown = 0u32;
    for sw in 0..=u16::MAX {
        let matching: Vec<State> = states()
            .iter()
            .filter(|s| sw & s.mask == s.value)
            .map(|s| s.state)
            .collect();
        assert!(matching.len() <= 1, "{sw:#06X} matches {matching:?}");
        let decoded = NordStateMachine::decode(sw);
        match matching.first() {
            Some(s) => {
                assert_eq!(decoded, *s, "{sw:#06X}");
                let i = State::ALL.iter().position(|x| x == s).unwrap();
                per_state[i] += 1;
            }
            None => {
                assert_eq!(decoded, State::Unknown, "{sw:#06X}");
                unknown += 1;
            }
        }
        assert_eq!(StatusWord(sw).state(), decoded);
    }
    // Every state is reachable, and fully specified patterns (7 bits) match 2^9 words.
    assert!(per_state.iter().all(|n| *n > 0), "{per_state:?}");
    assert_eq!(per_state[2], 512);
    assert_eq!(per_state.iter().sum::<u32>() + unknown, 65_536);
}

// --- section 4.5: process data ------------------------------------------------------------

/// E1: section 4.5.1 prints 047Eh as "1000111110b"; that is 23Eh. The right binary is
/// 10001111110b. Section 4.5.2's 0B31h = "101100110001b" is right.
#[test]
fn manual_4_5_binary_notations() {
    assert_eq!(format!("{:b}", 0x047Eu16), "10001111110");
    assert_eq!(u16::from_str_radix("1000111110", 2), Ok(0x023E)); // as printed: wrong
    assert_eq!(u16::from_str_radix("101100110001", 2), Ok(0x0B31));
}

#[test]
fn manual_4_5_4_percent_and_physical_values() {
    // 4000h = 100 %, C000h = -100 %, range 8000h..7FFFh.
    assert_eq!(setpoint_from_percent(100.0), Ok(0x4000));
    assert_eq!(setpoint_from_percent(-100.0), Ok(0xC000));
    assert_eq!(percent_from_word(0x4000), 100.0);
    assert_eq!(percent_from_word(0xC000), -100.0);
    assert_eq!(setpoint_from_percent(50.0), Ok(0x2000));
    assert!(setpoint_from_percent(200.0).is_err());
    // Frequency = value × P105 / 16384 with P105 = 50 Hz.
    assert_eq!(word_to_physical(0x2000, 50.0), 25.0);
    assert_eq!(word_to_physical(0xC000, 50.0), -50.0);
    assert_eq!(physical_to_word(25.0, 50.0), Ok(0x2000));
    assert_eq!(physical_to_word(1.0, 0.0), Err(ScaleError::NotFinite));
    // Positions: ±50000.00 revolutions × 1000 increments fit 32 bits, split in two words.
    let (hi, lo) = split_i32(-50_000_000);
    assert_eq!(join_i32(hi, lo), -50_000_000);
    // Low word only: 32.767 … -32.768 revolutions at 1000 increments.
    assert_eq!(f64::from(i16::MAX) / 1000.0, 32.767);
    assert_eq!(f64::from(i16::MIN) / 1000.0, -32.768);
}

#[test]
fn words_debug_by_english_name_and_parameter_sets() {
    assert_eq!(
        format!("{:?}", ControlWord(0x047E)),
        "ControlWord(0x047E: enable_voltage | no_quick_stop | enable_operation | \
         enable_pulses | enable_ramp | enable_setpoint | control_data_valid)"
    );
    assert_eq!(
        format!("{:?}", StatusWord(0x0B31)),
        "StatusWord(0x0B31: ready_to_switch_on | voltage_enabled | no_quick_stop | \
         setpoint_reached | bus_control | rotation_right)"
    );
    assert_eq!(format!("{:?}", StatusWord(0)), "StatusWord(0x0000)");
    let cw = command::ENABLE_OPERATION.with_parameter_set(3).unwrap();
    assert_eq!(cw.bits(), 0x847F);
    assert_eq!(cw.parameter_set(), 3);
    assert!(cw.with_parameter_set(0).is_none());
    assert!(cw.with_parameter_set(5).is_none());
    assert_eq!(StatusWord(0xC000).parameter_set(), 4);
    assert_eq!(StatusWord(0x4000).parameter_set(), 2);
    assert!(StatusWord(0x0008).is_fault());
    assert!(StatusWord(0x0080).is_warning());
    assert!(ControlWord(0x047F).contains(ControlWord::SWITCH_ON));
    assert_eq!(
        ControlWord(0x047F).without(ControlWord::SWITCH_ON),
        command::SHUTDOWN
    );
    assert_eq!(
        ControlWord(0x0400).union(ControlWord::FAULT_RESET),
        command::FAULT_RESET
    );
    assert_eq!(u16::from(ControlWord::from(0x1234)), 0x1234);
    assert_eq!(u16::from(StatusWord::from(0x4321)), 0x4321);
}

/// Every command word has bit 10 "control data valid" set (4.5.3, "Steuerbit 10").
#[test]
fn commands_keep_control_data_valid() {
    for c in [
        command::SHUTDOWN,
        command::SWITCH_ON,
        command::DISABLE_OPERATION,
        command::ENABLE_OPERATION,
        command::DISABLE_VOLTAGE,
        command::QUICK_STOP,
        command::FAULT_RESET,
    ] {
        assert!(c.contains(ControlWord::CONTROL_DATA_VALID), "{c:?}");
        assert_eq!(c.parameter_set(), 1);
    }
}

// --- chapter 5: example telegrams ---------------------------------------------------------

/// 5.1.1 switch-on disabled → ready to switch on. E7: the manual's "(Steuerbit 0 = 0/1)"
/// describes status bit 0; the control word 047Eh that reaches the state has control bit 0 = 0.
#[test]
fn manual_5_1_1_switch_on_disabled_to_ready() {
    // Step 1: ZSW 0Bh 70h, IW1 00h 00h.
    let zsw = word(0x0B, 0x70);
    assert_eq!(zsw, 0x0B70);
    assert_eq!(NordStateMachine::decode(zsw), State::SwitchOnDisabled);
    // The bit breakdown printed next to it: bits 11, 9, 8, 6, 5, 4 set (E8: its labels for
    // bits 10 and 13 differ from section 4.5.2; the values agree).
    let set: Vec<u8> = StatusWord(zsw).set_bits().map(|b| b.bit).collect();
    assert_eq!(set, [4, 5, 6, 8, 9, 11]);
    // Step 2: STW 04h 7Eh, SW1 00h 00h.
    let stw = word(0x04, 0x7E);
    assert_eq!(stw, command::SHUTDOWN.bits());
    assert_eq!(
        NordStateMachine::control_toward(State::SwitchOnDisabled, State::ReadyToSwitchOn),
        Some(stw)
    );
    assert_eq!(stw.to_be_bytes(), [0x04, 0x7E]);
    // Transition 2 of the table fires on it.
    assert!(
        NordStateMachine::transitions_from(State::SwitchOnDisabled)
            .any(|t| t.id == "2" && t.triggered_by(0, stw) && t.to == State::ReadyToSwitchOn)
    );
    // Step 3: ZSW 0Bh 31h.
    let zsw = word(0x0B, 0x31);
    assert_eq!(NordStateMachine::decode(zsw), State::ReadyToSwitchOn);
    // E7: status bit 0 goes 0 → 1; control bit 0 stays 0.
    assert!(!StatusWord(0x0B70).contains(StatusWord::READY_TO_SWITCH_ON));
    assert!(StatusWord(0x0B31).contains(StatusWord::READY_TO_SWITCH_ON));
    assert!(!ControlWord(stw).contains(ControlWord::SWITCH_ON));
}

/// 5.1.2 enable with a 50 % setpoint, clockwise.
#[test]
fn manual_5_1_2_enable_with_half_setpoint() {
    assert_eq!(
        NordStateMachine::decode(word(0x0B, 0x31)),
        State::ReadyToSwitchOn
    );
    // STW 04h 7Fh, SW1 20h 00h.
    let stw = word(0x04, 0x7F);
    assert_eq!(stw, command::ENABLE_OPERATION.bits());
    assert_eq!(
        setpoint_from_percent(50.0).map(u16::to_be_bytes),
        Ok([0x20, 0x00])
    );
    // From ready to switch on, 047Fh satisfies transition 3 and then transition 4.
    let t3 = transitions().iter().find(|t| t.id == "3").unwrap();
    let t4 = transitions().iter().find(|t| t.id == "4").unwrap();
    assert!(t3.triggered_by(0x047E, stw) && t4.triggered_by(0x047E, stw));
    // Bit 12 = 0: clockwise applies (footnote 3).
    assert!(!ControlWord(stw).contains(ControlWord::ROTATION_LEFT));
    // Response ZSW 0Bh 37h, IW1 20h 00h.
    let zsw = StatusWord(word(0x0B, 0x37));
    assert_eq!(zsw.state(), State::OperationEnabled);
    assert!(zsw.contains(StatusWord::SETPOINT_REACHED));
    assert!(zsw.contains(StatusWord::ROTATION_RIGHT));
    assert_eq!(percent_from_word(word(0x20, 0x00)), 50.0);
}

/// 5.1.3 P102 = 10 s in parameter set 3. E4: the manual prints IND as 00h 02h (request and
/// response); parameter set 3 lives in IND bits 8..9, so the bytes are 02h 00h.
#[test]
fn manual_5_1_3_change_p102_in_parameter_set_3() {
    let p102 = lookup("P102").unwrap();
    assert_eq!(p102.pnu, 0x66);
    assert!(p102.parameter_set);
    let raw = p102.from_physical(10.0).unwrap();
    assert_eq!(raw, 0x3E8);
    // AK 7: change parameter value (array, word), as printed (E13: P102 is no array; 5.1.5
    // uses AK 2 for the same parameter).
    let ak = ak_request(7).unwrap();
    assert_eq!(ak.kind, AkRequestKind::Write);
    assert_eq!(ak.width, Some(Width::Word));
    let request = pkw(pke(7, p102.pnu), ind(0, 3), raw as u32);
    assert_eq!(request, [0x70, 0x66, 0x02, 0x00, 0x00, 0x00, 0x03, 0xE8]);
    // As printed, IND = 0002h: bits 8..9 = 0 (parameter set 1), low byte not "all 0".
    let printed_ind = word(0x00, 0x02);
    assert_eq!((printed_ind >> 8) & 3, 0);
    assert_ne!(printed_ind & 0xFF, 0);
    // Response: AK 4 (array, word), the positive answer to AK 7.
    assert!(ak.responses.contains(&4));
    let response = pkw(pke(4, p102.pnu), ind(0, 3), 0x3E8);
    assert_eq!(response, [0x40, 0x66, 0x02, 0x00, 0x00, 0x00, 0x03, 0xE8]);
    assert_eq!(ak_response(4).unwrap().kind, AkResponseKind::ArrayValue);
    // Sent in a CTT2 NORD write over the parameter channel without address (4.3.3):
    // code 19, index 47, length 8, then the 8 PKW bytes (bytes 4..11).
    let ix = ctt2_index(47).unwrap();
    let mut msg = Vec::from([ctt2_code(Ctt2MessageType::NordWrite, Ctt2Role::Request).unwrap()]);
    msg.extend([ix.index, ix.max_len]);
    msg.extend(request);
    assert_eq!(
        msg,
        [19, 47, 8, 0x70, 0x66, 0x02, 0x00, 0x00, 0x00, 0x03, 0xE8]
    );
    assert!(ix.write_lengths.contains(&8) && !ix.address);
}

/// 5.1.4 read P701, index 0. E5: the byte column prints "1h" and "2BDh"; PKE 12BDh is sent as
/// the bytes 12h BDh.
#[test]
fn manual_5_1_4_read_p701() {
    let p701 = lookup("701").unwrap();
    assert_eq!(p701.pnu, 0x2BD);
    assert_eq!(by_index(0x2BD).map(|p| p.number), Some(701));
    let request = pkw(pke(1, p701.pnu), 0x0000, 0);
    assert_eq!(u16::from_be_bytes([request[0], request[1]]), 0x12BD);
    assert_eq!(request, [0x12, 0xBD, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(ak_request(1).unwrap().responses, &[1, 2]);
    // Index 0 is element [-01], the most recent fault.
    let e = p701.element(1).unwrap();
    assert_eq!(e.sub_index(), Some(0));
    assert_eq!(e.name_de(), "Letzte Störung");
    assert_eq!(e.label().as_str(), "P701[-01]");
    // Elements the manual names only by number fall back to the parameter's name.
    assert_eq!(p701.element(5).unwrap().name_en(), "last fault");
    assert!(p701.element(6).is_none() && p701.element(0).is_none());
}

/// 5.1.5 write P102 = 2.5 s, index 1. E6: the explanation "Parameterwert anfordern (lesen)"
/// is wrong for AK 2, which changes a word; IND 0100h selects parameter set 2.
#[test]
fn manual_5_1_5_write_p102_index_1() {
    let p102 = by_number(102).unwrap();
    let raw = p102.from_physical(2.5).unwrap();
    assert_eq!(raw, 250);
    assert_eq!(raw, 0xFA);
    let request = pkw(pke(2, 0x66), word(0x01, 0x00), raw as u32);
    assert_eq!(u16::from_be_bytes([request[0], request[1]]), 0x2066);
    assert_eq!(request, [0x20, 0x66, 0x01, 0x00, 0x00, 0x00, 0x00, 0xFA]);
    assert_eq!(word(0x01, 0x00), ind(0, 2));
    let ak = ak_request(2).unwrap();
    assert_eq!(ak.function_en, "change parameter value (word)");
    assert_eq!(ak.kind, AkRequestKind::Write);
    assert_eq!(ak.to_string(), "AK 2: change parameter value (word)");
}

/// 4.6.1.2 address examples. E9: "5 (000101b)" and "21 (010101b)" are raw array values
/// (elements [-06] and [-22]) while "2 (01b)" and "4 (11b)" are set numbers (raw 1 and 3).
#[test]
fn manual_4_6_1_2_index_examples() {
    assert_eq!(ind(5, 2), 0x1500);
    assert_eq!(ind(0b01_0101, 4), 0x5700);
    assert_eq!(0x1500u16.to_be_bytes(), [0b0001_0101, 0]);
    assert_eq!(0x5700u16.to_be_bytes(), [0b0101_0111, 0]);
}

/// 4.6.1.3: 99.99 s at 0.01 s is 9999 (270Fh).
#[test]
fn manual_4_6_1_3_resolution() {
    let p = lookup("p102").unwrap();
    assert_eq!(p.from_physical(99.99), Ok(9999));
    assert_eq!(9999, 0x270F);
    assert!((p.to_physical(9999) - 99.99).abs() < 1e-9);
    let mut s = String::new();
    p.describe_scaling(&mut s).unwrap();
    assert_eq!(s, "resolution 0.01 s");
    assert_eq!(p.decimals(), 2);
    // Outside 0…320.00 s.
    assert!(matches!(
        p.from_physical(400.0),
        Err(ScaleError::OutOfRange { .. })
    ));
    assert!(matches!(
        p.from_physical(-0.01),
        Err(ScaleError::OutOfRange { .. })
    ));
    assert_eq!(p.range_en, "0.00 … 320.00 s");
    assert_eq!(p.range_de, "0,00 … 320,00 s");
}

// --- section 4.3: CTT2 --------------------------------------------------------------------

#[test]
fn manual_4_3_1_standard_read_examples() {
    // ID object: request 16, 0, 14; response 80, 1, 137, … (15 bytes).
    let req = ctt2_message(16).unwrap();
    assert_eq!(
        (req.message_type, req.role),
        (Ctt2MessageType::StandardRead, Ctt2Role::Request)
    );
    let id = ctt2_index(0).unwrap();
    assert_eq!((id.standard, id.max_len), (true, 14));
    assert_eq!(ctt2_object_bytes(0).count(), 14);
    assert_eq!(ctt2_message(80).unwrap().role, Ctt2Role::ResponseOk);
    assert_eq!(word(1, 137), 0x0189); // manufacturer ID
    // Error response 144, 4: busy.
    assert_eq!(ctt2_message(144).unwrap().role, Ctt2Role::ResponseError);
    assert_eq!(
        ctt2_error(4).unwrap().to_string(),
        "CTT2 error 4: busy (request not completed within the time window of 200 ms)"
    );
    // Diagnostic object: 16, 1, 3 → 80, 0 (no fault), 0, 45 (°C).
    let diag = ctt2_index(1).unwrap();
    assert_eq!(diag.max_len, 3);
    let names: Vec<&str> = ctt2_object_bytes(1).map(|b| b.name_en).collect();
    assert_eq!(names.len(), 3);
    assert!(names[2].contains("temperature"));
}

#[test]
fn manual_4_3_2_to_4_3_4_nord_messages() {
    // 4.3.2: read process data 18, 3, 9 → 82, address 1, ZSW, IW1..IW3 (10 bytes).
    assert_eq!(
        ctt2_code(Ctt2MessageType::NordRead, Ctt2Role::Request),
        Some(18)
    );
    assert_eq!(
        ctt2_code(Ctt2MessageType::NordRead, Ctt2Role::ResponseOk),
        Some(82)
    );
    let pzd = ctt2_index(3).unwrap();
    assert_eq!((pzd.max_len, pzd.address), (9, true));
    assert_eq!(pzd.write_lengths, &[3, 5, 7, 9]);
    // 4.3.3: write response 83 carries no data.
    assert_eq!(
        ctt2_code(Ctt2MessageType::NordWrite, Ctt2Role::ResponseOk),
        Some(83)
    );
    assert_eq!(ctt2_message(83).unwrap().contents_en, "");
    // 4.3.4: 29, 3, read length 7, write length 9, address 1, STW, SW1..SW3 (13 bytes).
    // E11: byte 3 is the read length and byte 4 the write length, data last.
    let stw = command::ENABLE_OPERATION.bits().to_be_bytes();
    let sw1 = setpoint_from_percent(50.0).unwrap().to_be_bytes();
    let mut msg = Vec::from([29u8, 3, 7, 9, 1]);
    msg.extend(stw);
    msg.extend(sw1);
    msg.extend([0, 0, 0, 0]);
    assert_eq!(msg.len(), 13);
    assert_eq!(usize::from(msg[3]), msg.len() - 4); // write length counts address + words
    assert!(pzd.write_lengths.contains(&msg[3]) && msg[2] <= pzd.max_len);
    // Response: 93, address, ZSW, IW1, IW2 = 1 + 7 bytes.
    assert_eq!(
        ctt2_code(Ctt2MessageType::NordWriteRead, Ctt2Role::ResponseOk),
        Some(93)
    );
    // E3: "Schreib-/Leseantwort nicht OK" is printed as 177; the code is 29 + 80h = 157.
    assert_eq!(
        ctt2_code(Ctt2MessageType::NordWriteRead, Ctt2Role::ResponseError),
        Some(157)
    );
    assert!(ctt2_message(177).is_none());
    assert_eq!(ctt2_message(157).unwrap().printed, Some(177));
    // The rule holds for every message type.
    for t in [
        Ctt2MessageType::StandardRead,
        Ctt2MessageType::NordRead,
        Ctt2MessageType::NordWrite,
        Ctt2MessageType::NordWriteRead,
    ] {
        let req = ctt2_code(t, Ctt2Role::Request).unwrap();
        assert_eq!(ctt2_code(t, Ctt2Role::ResponseOk), Some(req + 0x40));
        assert_eq!(ctt2_code(t, Ctt2Role::ResponseError), Some(req + 0x80));
    }
    // 4.3.5: only indices 0, 1, 3, 4 and 47 exist.
    let known: Vec<u8> = (0..=255).filter(|i| ctt2_index(*i).is_some()).collect();
    assert_eq!(known, [0, 1, 3, 4, 47]);
    assert!(ctt2_error(0).is_none() && ctt2_error(6).is_none());
    assert_eq!(
        ctt2_message(19).unwrap().to_string(),
        "CTT2 code 19: NORD write request"
    );
}

/// 4.4: 16 × 154 µs × (2 + slaves), against the printed table (ms, rounded).
#[test]
fn manual_4_4_transfer_times() {
    // (slaves, printed ms, decimals printed)
    let printed = [
        (1, 7.4, 1),
        (2, 9.86, 2),
        (3, 12.32, 2),
        (30, 78.85, 2),
        (31, 81.31, 2),
        (32, 83.78, 2),
        (60, 152.77, 2),
        (61, 155.23, 2),
        (62, 157.7, 1),
    ];
    for (n, ms, decimals) in printed {
        let scale = crate::scaling::pow10(decimals);
        let us = f64::from(ctt2_byte_time_us(n));
        let rounded = crate::scaling::round(us / 1000.0 * scale) / scale;
        assert_eq!(rounded, ms, "{n} slaves: {us} µs");
    }
    assert_eq!(ctt2_byte_time_us(31), 81_312);
}

// --- section 4.6.1.1: AK and PWE2 error numbers --------------------------------------------

#[test]
fn ak_and_error_tables() {
    assert_eq!(
        ak_response(7).unwrap().to_string(),
        "AK 7: order cannot be executed (error number in PWE2)"
    );
    assert_eq!(ak_response(7).unwrap().kind, AkResponseKind::Error);
    assert!(ak_response(3).is_none());
    assert!(ak_request(15).is_none());
    assert_eq!(ak_request(4).unwrap().kind, AkRequestKind::Reserved);
    // RAM-only writes 11..14 mirror 8, 7, 3, 2.
    for (ram, eeprom) in [(11, 8), (12, 7), (13, 3), (14, 2)] {
        let (r, e) = (ak_request(ram).unwrap(), ak_request(eeprom).unwrap());
        assert!(!r.eeprom && e.eeprom);
        assert_eq!(
            (r.width, r.array, r.responses),
            (e.width, e.array, e.responses)
        );
    }
    assert_eq!(
        pwe_error(2).unwrap().to_string(),
        "error 2: lower or upper value limit exceeded"
    );
    assert_eq!(
        pwe_error(102).unwrap().to_string(),
        "error 102 (no meaning given in the manual)"
    );
    assert!(pwe_error(8).is_none());
    // E10: 102 is listed without a meaning.
    assert_eq!(pwe_error(102).unwrap().meaning_de, "");
    assert_eq!(
        pwe_error(0).unwrap().meaning_de,
        "Unzulässige Parameternummer"
    );
}

// --- parameters ---------------------------------------------------------------------------

#[test]
fn parameter_lookups() {
    assert_eq!(params().len(), 17);
    assert!(params().windows(2).all(|w| w[0].number < w[1].number));
    assert!(
        params()
            .iter()
            .all(|p| p.pnu == p.number && p.family() == Family::Nord)
    );
    for s in ["P102", "p102", "102", " P102 "] {
        assert_eq!(lookup(s).map(|p| p.number), Some(102), "{s}");
    }
    for s in ["P", "", "Px", "P-1", "P99999", "P103", "PP102"] {
        assert!(lookup(s).is_none(), "{s}");
    }
    assert_eq!(by_index(0x66).map(|p| p.name_de), Some("Hochlaufzeit"));
    assert!(by_index(0x67).is_none());
    let hits: Vec<u16> = search("hochlauf").map(|p| p.number).collect();
    assert_eq!(hits, [102]);
    let hits: Vec<u16> = search("ACCELERATION").map(|p| p.number).collect();
    assert_eq!(hits, [102]);
    // Element names are searched too: "Warnung" is P700 [-02].
    let hits: Vec<u16> = search("warnung").map(|p| p.number).collect();
    assert_eq!(hits, [700]);
    let hits: Vec<u16> = search("bus").map(|p| p.number).collect();
    assert_eq!(hits, [480, 481, 543, 546, 740, 741]);
    assert_eq!(by_number(102).unwrap().label().as_str(), "P102");
}

#[test]
fn parameter_metadata() {
    let p105 = lookup("P105").unwrap();
    assert_eq!(p105.from_physical(50.0), Ok(500));
    assert_eq!(p105.default_raw(), Some(500));
    assert_eq!(p105.raw_range(), Some((1, 4000)));
    let p700 = lookup("P700").unwrap();
    assert!(!p700.access().is_writable());
    assert_eq!(
        p700.element(3).unwrap().name_en(),
        "reason for switch-on disabled"
    );
    assert!(p700.element(4).is_none());
    assert!(lookup("P102").unwrap().access().is_writable());
    let p509 = lookup("P509").unwrap();
    assert_eq!(p509.value_name(5).map(|v| v.de), Some("AS-i"));
    let mut s = String::new();
    p509.describe_scaling(&mut s).unwrap();
    assert_eq!(s, "integer");
    assert_eq!(p509.from_physical(5.0), Ok(5));
    let p112 = lookup("P112").unwrap();
    assert_eq!(p112.value_name(401).map(|v| v.en), Some("off (no limit)"));
    assert!(p112.in_range(401) && !p112.in_range(24));
    let e = lookup("P546").unwrap().element(2).unwrap();
    assert_eq!(
        (e.number(), e.bus_index(), e.sub_index()),
        (Some(546), 0x222, Some(1))
    );
    assert_eq!(e.name_de(), "Fkt. Bus-Sollwert 2");
    // Every value list entry lies in range, every element within the array.
    for p in params() {
        assert!(
            p.values.iter().all(|v| p.in_range(v.value)),
            "P{}",
            p.number
        );
        let len = p.array_len.unwrap_or(0);
        assert!(
            p.elements
                .iter()
                .all(|e| e.element >= 1 && e.element <= len),
            "P{}",
            p.number
        );
    }
}

// --- state machine paths ------------------------------------------------------------------

/// A drive that follows the manual's transition table: a command or edge transition out of
/// the current state if the word triggers one, otherwise an automatic one, otherwise stay.
fn model_step(current: State, previous: u16, word: u16) -> State {
    let by_command = NordStateMachine::transitions_from(current)
        .find(|t| t.from.is_some() && t.triggered_by(previous, word));
    let automatic = || {
        NordStateMachine::transitions_from(current)
            .find(|t| t.from.is_some() && t.trigger == Trigger::Automatic)
    };
    by_command.or_else(automatic).map_or(current, |t| t.to)
}

/// A status word the model drive reports for `state`: the pattern plus bit 9 (bus control).
fn status_of(state: State) -> u16 {
    crate::nord::state_info(state).map_or(0xFFFF, |i| i.value | 0x0200)
}

/// Drive from `start` to `target`, returning the number of control words sent.
fn drive(start: State, target: State, mut last: u16) -> (State, u16, usize) {
    let mut state = start;
    for sent in 0..12 {
        let seen = NordStateMachine::decode(status_of(state));
        assert_eq!(seen, state);
        let Some(word) = NordStateMachine::next_control(last, seen, target) else {
            return (state, last, sent);
        };
        assert!(ControlWord(word).contains(ControlWord::CONTROL_DATA_VALID));
        state = model_step(state, last, word);
        last = word;
    }
    panic!("{start:?} did not reach {target:?}; stuck in {state:?}");
}

#[test]
fn every_state_reaches_operation_enabled_and_back() {
    for start in State::ALL {
        for last in [0x0000, 0x0480] {
            let (s, last, up) = drive(start, State::OperationEnabled, last);
            assert_eq!(s, State::OperationEnabled, "from {start:?}");
            assert!(up <= 6, "from {start:?}: {up} steps");
            let (s, _, down) = drive(s, State::SwitchOnDisabled, last);
            assert_eq!(s, State::SwitchOnDisabled);
            assert_eq!(down, 2); // shutdown (braking ramp), then disable voltage
        }
    }
}

#[test]
fn every_commandable_target_is_reached_from_every_state() {
    let targets = [
        State::SwitchOnDisabled,
        State::ReadyToSwitchOn,
        State::SwitchedOn,
        State::OperationEnabled,
    ];
    for start in State::ALL {
        for target in targets {
            let (s, _, _) = drive(start, target, 0);
            assert_eq!(s, target, "{start:?} → {target:?}");
        }
    }
}

#[test]
fn control_toward_edge_cases() {
    let ct = NordStateMachine::control_toward;
    assert_eq!(ct(State::OperationEnabled, State::OperationEnabled), None);
    assert_eq!(ct(State::Unknown, State::OperationEnabled), None);
    for s in State::ALL {
        // Targets no control word leads to.
        for t in [
            State::Fault,
            State::FaultReactionActive,
            State::NotReadyToSwitchOn,
        ] {
            assert_eq!(ct(s, t), None, "{s:?} → {t:?}");
        }
        assert_eq!(ct(s, State::Unknown), None);
    }
    assert_eq!(
        ct(State::SwitchOnDisabled, State::OperationEnabled),
        Some(0x047E)
    );
    assert_eq!(
        ct(State::ReadyToSwitchOn, State::OperationEnabled),
        Some(0x0477)
    );
    assert_eq!(ct(State::SwitchedOn, State::OperationEnabled), Some(0x047F));
    assert_eq!(ct(State::OperationEnabled, State::SwitchedOn), Some(0x0477));
    assert_eq!(
        ct(State::OperationEnabled, State::SwitchOnDisabled),
        Some(0x047E)
    );
    assert_eq!(
        ct(State::QuickStopActive, State::OperationEnabled),
        Some(0x0402)
    );
    assert_eq!(
        ct(State::NotReadyToSwitchOn, State::SwitchOnDisabled),
        Some(0x0400)
    );
    assert_eq!(
        ct(State::NotReadyToSwitchOn, State::ReadyToSwitchOn),
        Some(0x047E)
    );
    assert_eq!(
        ct(State::FaultReactionActive, State::SwitchOnDisabled),
        Some(0x0400)
    );
    assert_eq!(ct(State::Fault, State::SwitchOnDisabled), Some(0x0480));
}

/// A fault is reset only by a 0 → 1 change of bit 7: holding 0480h does nothing, and
/// `next_control` inserts the 0 half of the edge.
#[test]
fn fault_reset_needs_a_rising_edge() {
    let reset = command::FAULT_RESET.bits();
    assert_eq!(model_step(State::Fault, reset, reset), State::Fault);
    assert_eq!(
        model_step(State::Fault, 0x0400, reset),
        State::SwitchOnDisabled
    );
    assert_eq!(
        NordStateMachine::next_control(reset, State::Fault, State::SwitchOnDisabled),
        Some(0x0400)
    );
    assert_eq!(
        NordStateMachine::next_control(0x0400, State::Fault, State::SwitchOnDisabled),
        Some(reset)
    );
    // A fault from every state leads to fault reaction active (transition 13).
    let t13: Vec<&Transition> = transitions()
        .iter()
        .filter(|t| t.trigger == Trigger::FaultEvent)
        .collect();
    assert_eq!(t13.len(), 1);
    assert_eq!((t13[0].from, t13[0].to), (None, State::FaultReactionActive));
}

/// Out of one state, no control word triggers two transitions toward different states.
#[test]
fn command_transitions_are_unambiguous() {
    for s in State::ALL {
        for w in 0..=0xFFu16 {
            let mut targets: Vec<State> = NordStateMachine::transitions_from(s)
                .filter(|t| t.from.is_some() && t.triggered_by(0, w))
                .map(|t| t.to)
                .collect();
            targets.dedup();
            assert!(targets.len() <= 1, "{s:?} with {w:#04X}: {targets:?}");
        }
    }
}

proptest! {
    /// Whatever status word arrives, planning never panics and every planned word keeps
    /// bit 10 set and selects parameter set 1.
    #[test]
    fn planning_from_any_status_word(sw in any::<u16>(), t in 0usize..8, last in any::<u16>()) {
        let current = NordStateMachine::decode(sw);
        let target = State::ALL[t];
        if let Some(w) = NordStateMachine::next_control(last, current, target) {
            prop_assert!(ControlWord(w).contains(ControlWord::CONTROL_DATA_VALID));
            prop_assert_eq!(ControlWord(w).parameter_set(), 1);
        }
    }
}

/// E2: section 4.5.1 says control bit 3 = 0 takes the drive to "Einschaltbereit"; the
/// transition table (transition 5, "Betrieb sperren" xxxx0111) leads to switched on.
#[test]
fn e2_disable_operation_leads_to_switched_on() {
    let word = command::DISABLE_OPERATION.bits();
    assert_eq!(word & 0x000F, 0x0007);
    assert_eq!(
        model_step(
            State::OperationEnabled,
            command::ENABLE_OPERATION.bits(),
            word
        ),
        State::SwitchedOn
    );
    // No transition leads from operation enabled to ready to switch on with bits 0..2 = 111.
    assert!(
        !NordStateMachine::transitions_from(State::OperationEnabled)
            .any(|t| t.to == State::ReadyToSwitchOn && t.triggered_by(0, 0x0477))
    );
}

/// E14: the transition table has no automatic step out of quick stop active, but state F's
/// description and control bit 2 say the drive ends in switch-on disabled at 0 Hz.
#[test]
fn e14_quick_stop_ends_in_switch_on_disabled() {
    let auto: Vec<&Transition> = NordStateMachine::transitions_from(State::QuickStopActive)
        .filter(|t| t.trigger == Trigger::Automatic)
        .collect();
    assert_eq!(auto.len(), 1);
    assert_eq!(auto[0].to, State::SwitchOnDisabled);
    assert_eq!(
        model_step(State::QuickStopActive, 0x0402, 0x0402),
        State::SwitchOnDisabled
    );
}

/// Every erratum this file names (E1, E2, ...) is documented in docs/errata-nord.md, and the
/// document names the test that proves each one.
#[test]
fn every_erratum_is_documented() {
    let doc = include_str!("../../../../docs/errata-nord.md");
    let me = include_str!("tests.rs");
    let mut ids: Vec<u32> = Vec::new();
    let bytes = me.as_bytes();
    for (i, w) in bytes.windows(2).enumerate() {
        if w[0] == b'E'
            && w[1].is_ascii_digit()
            && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric())
        {
            let digits: String = me[i + 1..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            ids.push(digits.parse().unwrap());
        }
    }
    ids.sort_unstable();
    ids.dedup();
    assert!(ids.len() >= 10, "{ids:?}");
    for id in ids {
        assert!(
            doc.contains(&format!("## E{id}:")),
            "E{id} is not in docs/errata-nord.md"
        );
    }
}
