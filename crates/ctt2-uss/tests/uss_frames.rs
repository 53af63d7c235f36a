//! USS serial telegrams: vectors built by hand from the USS specification (a comment per
//! byte), the examples of BU 0255 section 5.1 carried in USS telegrams, decode errors, the
//! receiver's timing rules on manual instants, and property tests (round trips; decoding and
//! the receiver never panic).

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::time::Duration;

use ctt2_uss::serial::framing::{Side, UssFraming, UssReceiver, UssTiming};
use ctt2_uss::serial::telegram::{
    Adr, FrameError, Layout, LayoutError, MAX_TELEGRAM, Telegram, TelegramError, UssAddress, bcc,
};
use ctt2_uss::uss::pkw::{Ind, Order, Pke, Pkw, Reply, Storage};
use drive_core::{CharError, Instant, LineError, LineSettings, RxChar, RxEvent};
use drive_profile::nord::{ControlWord, StatusWord, Width};
use drive_profile::state::StateMachine;
use proptest::prelude::*;

fn addr(a: u8) -> UssAddress {
    UssAddress::new(a).unwrap()
}

fn layout(pkw: u8, pzd: u8) -> Layout {
    Layout::new(pkw, pzd).unwrap()
}

fn encode(t: &Telegram) -> Vec<u8> {
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = t.encode(&mut buf).unwrap();
    buf[..n].to_vec()
}

/// `t` encodes to `wire` and `wire` decodes to `t`.
fn vector(t: Telegram, wire: &[u8]) {
    assert_eq!(encode(&t), wire, "{t:?}");
    assert_eq!(Telegram::decode(wire, t.layout()), Ok(t));
    assert_eq!(bcc(&wire[..wire.len() - 1]), wire[wire.len() - 1]);
}

// ---- hand-built vectors ----

#[test]
fn typical_telegram_pkw4_pzd2() {
    // Read P102 ramp time (AK 1, PNU 66h) in parameter set 1 from drive 7, with control word
    // 047Eh (shut down) and setpoint 0.
    let order = Order::read(102, Ind::ZERO).unwrap().to_pkw();
    let t = Telegram::new(Adr::new(addr(7)), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    let wire = [
        0x02,       // STX
        0x0E,       // LGE: ADR + 12 net bytes + BCC = 14
        0x07,       // ADR: address 7, no broadcast, mirror or special bit
        0x10, 0x66, // PKE: AK 1 (read), PNU 066h = 102
        0x00, 0x00, // IND: element [-01], parameter set 1
        0x00, 0x00, // PWE1
        0x00, 0x00, // PWE2
        0x04, 0x7E, // PZD1: control word 047Eh
        0x00, 0x00, // PZD2: setpoint 1
        0x07,       // BCC: XOR of the 15 bytes before
    ];
    assert_eq!(t.len(), 16, "the typical USS telegram is 16 bytes");
    vector(t, &wire);
}

#[test]
fn smallest_telegram_without_net_data() {
    let t = Telegram::new(Adr::new(addr(3)), layout(0, 0), Pkw::default(), &[]).unwrap();
    // STX, LGE 2 (ADR + BCC), ADR 3, BCC = 02h ^ 02h ^ 03h.
    vector(t, &[0x02, 0x02, 0x03, 0x03]);
    assert_eq!(t.pkw(), None);
    assert_eq!(t.pzd(), &[] as &[u16]);
}

#[test]
fn three_word_pkw_carries_one_value_word() {
    // Example 5.1.5 (P102, IND 0100h = parameter set 2, 2.5 s = FAh) in the 3-word PKW form.
    let pkw = Pkw {
        pke: Pke(0x2066),
        ind: Ind(0x0100),
        pwe1: 0,
        pwe2: 0x00FA,
    };
    let t = Telegram::new(Adr::new(addr(7)), layout(3, 2), pkw, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    let wire = [
        0x02,       // STX
        0x0C,       // LGE: ADR + 10 net bytes + BCC = 12
        0x07,       // ADR 7
        0x20, 0x66, // PKE: AK 2 (change word), PNU 102
        0x01, 0x00, // IND: parameter set 2
        0x00, 0xFA, // PWE: 250 = 2.5 s (no PWE1 in this form)
        0x04, 0x7E, // control word
        0x00, 0x00, // setpoint 1
        0xCE,       // BCC
    ];
    vector(t, &wire);
    // A negative word arrives with PWE1 = FFFFh: the sign of its one word.
    let neg = Pkw {
        pwe1: 0xFFFF,
        pwe2: 0xFFFE,
        ..pkw
    };
    let t = Telegram::new(Adr::new(addr(7)), layout(3, 0), neg, &[]).unwrap();
    let back = Telegram::decode(&encode(&t), t.layout()).unwrap();
    assert_eq!(back.pkw().unwrap().value32(), -2);
    // A double word does not fit: refused, not cut.
    let wide = Pkw {
        pwe1: 0x0001,
        pwe2: 0x0000,
        ..pkw
    };
    assert_eq!(
        Telegram::new(Adr::new(addr(7)), layout(3, 0), wide, &[]),
        Err(TelegramError::PkwValueTooWide { pwe1: 1, pwe2: 0 })
    );
}

#[test]
fn broadcast_and_mirror_address_bytes() {
    // Broadcast: write P102 in parameter set 3 to 10.00 s in RAM only (AK 14) on every drive.
    let order = Order::write(
        102,
        Ind::new(0, 2).unwrap(),
        Width::Word,
        false,
        Storage::Ram,
        1000,
    )
    .unwrap()
    .to_pkw();
    let t = Telegram::new(Adr::broadcast(), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    let wire = [
        0x02,       // STX
        0x0E,       // LGE 14
        0x20,       // ADR: bit 5 broadcast, address bits 0
        0xE0, 0x66, // PKE: AK 14 (change word without EEPROM), PNU 102
        0x02, 0x00, // IND: parameter set 3
        0x00, 0x00, // PWE1
        0x03, 0xE8, // PWE2: 1000 = 10.00 s
        0x04, 0x7E, // control word
        0x00, 0x00, // setpoint 1
        0x39,       // BCC
    ];
    vector(t, &wire);
    assert!(t.adr().is_broadcast() && !t.adr().is_mirror());

    // Mirror telegram to drive 5: bit 6 set, address 5.
    let order = Order::read(102, Ind::ZERO).unwrap().to_pkw();
    let t = Telegram::new(Adr::mirror(addr(5)), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    let wire = encode(&t);
    assert_eq!(wire[2], 0x45, "ADR: bit 6 mirror + address 5");
    assert_eq!(wire[15], 0x45, "BCC");
    assert_eq!(t.adr().address(), addr(5));
    assert!(t.adr().is_mirror() && !t.adr().is_broadcast() && !t.adr().is_special());
    assert!(Adr(0x85).is_special());
    assert_eq!(
        format!("{:?}", Adr(0xE5)),
        "Adr(0xE5: address 5, broadcast, mirror, special)"
    );
}

// ---- the manual's examples (BU 0255 section 5.1) in USS telegrams ----

/// 5.1.1: switch-on disabled (status word 0B70h) → ready to switch on with control word 047Eh
/// (status word 0B31h). "Es wird nur der PZD-Kanal abgebildet": a telegram without PKW part,
/// control/status word and setpoint/actual value 1, drive 1.
#[test]
fn manual_5_1_1_in_uss_telegrams() {
    let pzd = layout(0, 2);
    let request = Telegram::new(Adr::new(addr(1)), pzd, Pkw::default(), &[0x047E, 0x0000]).unwrap();
    #[rustfmt::skip]
    vector(request, &[
        0x02,       // STX
        0x06,       // LGE: ADR + 4 + BCC
        0x01,       // ADR 1
        0x04, 0x7E, // STW 047Eh (manual: "04h 7Eh")
        0x00, 0x00, // SW1 0 (manual: "00h 00h")
        0x7F,       // BCC
    ]);
    #[rustfmt::skip]
    let before = [
        0x02, 0x06, 0x01,
        0x0B, 0x70, // ZSW 0B70h: switch-on disabled (manual: "0Bh 70h")
        0x00, 0x00, // IW1 0
        0x7E,       // BCC
    ];
    #[rustfmt::skip]
    let after = [
        0x02, 0x06, 0x01,
        0x0B, 0x31, // ZSW 0B31h: ready to switch on (manual: "0Bh 31h")
        0x00, 0x00, // IW1 0
        0x3F,       // BCC
    ];
    for (wire, state) in [
        (before, drive_profile::nord::State::SwitchOnDisabled),
        (after, drive_profile::nord::State::ReadyToSwitchOn),
    ] {
        let t = Telegram::decode(&wire, pzd).unwrap();
        let zsw = StatusWord(t.pzd()[0]);
        assert_eq!(drive_profile::nord::NordStateMachine::decode(zsw.0), state);
    }
    assert_eq!(
        ControlWord(request.pzd()[0]),
        drive_profile::nord::command::SHUTDOWN
    );
}

/// 5.1.2: enable with 50 % setpoint: control word 047Fh, SW1 2000h; once there, status word
/// 0B37h (operation enabled) and IW1 2000h.
#[test]
fn manual_5_1_2_in_uss_telegrams() {
    let pzd = layout(0, 2);
    let request = Telegram::new(Adr::new(addr(1)), pzd, Pkw::default(), &[0x047F, 0x2000]).unwrap();
    #[rustfmt::skip]
    vector(request, &[
        0x02, 0x06, 0x01,
        0x04, 0x7F, // STW 047Fh: enable operation
        0x20, 0x00, // SW1 2000h = 50 % of P105
        0x5E,       // BCC
    ]);
    #[rustfmt::skip]
    let answer = Telegram::decode(&[
        0x02, 0x06, 0x01,
        0x0B, 0x37, // ZSW 0B37h: operation enabled
        0x20, 0x00, // IW1 2000h = 50 %
        0x19,       // BCC
    ], pzd).unwrap();
    assert_eq!(
        drive_profile::nord::NordStateMachine::decode(answer.pzd()[0]),
        drive_profile::nord::State::OperationEnabled
    );
    assert_eq!(answer.pzd()[1], 0x2000);
}

/// 5.1.3 with erratum E4: change P102 in parameter set 3 to 10 s (3E8h) with AK 7; the answer
/// AK 4 repeats PNU, IND and value. IND is 0200h, high byte first (the manual prints 00h 02h).
#[test]
fn manual_5_1_3_in_uss_telegrams() {
    let order = Pkw::from_words([0x7066, 0x0200, 0x0000, 0x03E8]);
    let t = Telegram::new(Adr::new(addr(1)), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    vector(t, &[
        0x02,       // STX
        0x0E,       // LGE 14
        0x01,       // ADR 1
        0x70, 0x66, // PKE: AK 7 (change array word), PNU 102
        0x02, 0x00, // IND: parameter set 3 (E4: the manual prints 00h 02h)
        0x00, 0x00, // PWE1
        0x03, 0xE8, // PWE2: 1000 = 10.00 s
        0x04, 0x7E, // STW
        0x00, 0x00, // SW1
        0x88,       // BCC
    ]);
    #[rustfmt::skip]
    let answer = Telegram::decode(&[
        0x02, 0x0E, 0x01,
        0x40, 0x66, // PKE: AK 4 (array word value), PNU 102
        0x02, 0x00, // IND 0200h
        0x00, 0x00, 0x03, 0xE8, // PWE 1000
        0x0B, 0x31, // ZSW ready to switch on
        0x00, 0x00, // IW1
        0xF8,       // BCC
    ], Layout::PKW4_PZD2).unwrap();
    let order = Order::from_pkw(&order).unwrap();
    assert!(matches!(
        order.check(&answer.pkw().unwrap()),
        ctt2_uss::uss::Plausibility::Answer(Reply::Value { value: 1000, .. })
    ));
}

/// 5.1.4 with erratum E5: read P701 (PKE 12BDh, sent 12h BDh), IND 0.
#[test]
fn manual_5_1_4_in_a_uss_telegram() {
    let order = Order::read(701, Ind::ZERO).unwrap().to_pkw();
    let t = Telegram::new(Adr::new(addr(7)), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    vector(t, &[
        0x02, 0x0E, 0x07,
        0x12, 0xBD, // PKE 12BDh: AK 1, PNU 2BDh = 701
        0x00, 0x00, // IND 0
        0x00, 0x00, 0x00, 0x00, // PWE: not set for a read
        0x04, 0x7E, 0x00, 0x00, // STW, SW1
        0xDE,       // BCC
    ]);
}

/// 5.1.5 with erratum E6: write P102 "Index 1" (IND 0100h: parameter set 2) = 2.5 s with AK 2.
#[test]
fn manual_5_1_5_in_a_uss_telegram() {
    let order = Order::write(
        102,
        Ind::new(0, 1).unwrap(),
        Width::Word,
        false,
        Storage::Eeprom,
        250,
    )
    .unwrap()
    .to_pkw();
    assert_eq!(order.words(), [0x2066, 0x0100, 0x0000, 0x00FA]);
    let t = Telegram::new(Adr::new(addr(7)), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    #[rustfmt::skip]
    vector(t, &[
        0x02, 0x0E, 0x07,
        0x20, 0x66, // PKE: AK 2 (change word), PNU 102
        0x01, 0x00, // IND 0100h
        0x00, 0x00, // PWE1
        0x00, 0xFA, // PWE2 250 = 2.5 s
        0x04, 0x7E, 0x00, 0x00, // STW, SW1
        0xCC,       // BCC
    ]);
}

// ---- decode errors ----

#[test]
fn decode_reports_what_is_wrong() {
    let l = Layout::PKW4_PZD2;
    let t = Telegram::new(Adr::new(addr(7)), l, Pkw::default(), &[1, 2]).unwrap();
    let good = encode(&t);
    assert_eq!(
        Telegram::decode(&[], l),
        Err(FrameError::Truncated { needed: 4, got: 0 })
    );
    let mut b = good.clone();
    b[0] = 0x03;
    assert_eq!(Telegram::decode(&b, l), Err(FrameError::BadStx(0x03)));
    let mut b = good.clone();
    b[1] = 0x0C;
    assert_eq!(
        Telegram::decode(&b, l),
        Err(FrameError::BadLength {
            expected: 14,
            got: 12
        })
    );
    assert_eq!(
        Telegram::decode(&good[..10], l),
        Err(FrameError::Truncated {
            needed: 16,
            got: 10
        })
    );
    let mut b = good.clone();
    b.push(0);
    assert_eq!(
        Telegram::decode(&b, l),
        Err(FrameError::TrailingBytes { extra: 1 })
    );
    let mut b = good.clone();
    b[5] ^= 0x10;
    let expected = bcc(&b[..15]);
    assert_eq!(
        Telegram::decode(&b, l),
        Err(FrameError::BadBcc {
            expected,
            got: good[15]
        })
    );
    assert_eq!(Telegram::announced_len(&good), Some(16));
    assert_eq!(Telegram::announced_len(&[0x02]), None);
    assert_eq!(Layout::new(2, 0), Err(LayoutError::PkwWords(2)));
    assert_eq!(Layout::new(4, 17), Err(LayoutError::PzdWords(17)));
    assert_eq!(
        Telegram::new(Adr::new(addr(7)), l, Pkw::default(), &[1]),
        Err(TelegramError::PzdWords {
            expected: 2,
            got: 1
        })
    );
    assert_eq!(
        t.encode(&mut [0u8; 15]),
        Err(FrameError::BufferTooSmall { needed: 16 })
    );
    assert_eq!(UssAddress::new(32), None);
    assert_eq!(
        FrameError::BadBcc {
            expected: 0x12,
            got: 0x13
        }
        .to_string(),
        "BCC error: computed 0x12, received 0x13"
    );
}

// ---- the receiver's rules on manual instants ----

fn line(baud: u32) -> LineSettings {
    LineSettings::new(baud)
}

/// Characters of `bytes` back to back from `start` (a character's time is the end of its stop
/// bit).
fn chars(bytes: &[u8], start: Instant, ct: u64) -> Vec<RxChar> {
    bytes
        .iter()
        .enumerate()
        .map(|(i, b)| RxChar::new(*b, start.add_nanos(ct * (i as u64 + 1))))
        .collect()
}

/// Feed `cs` and then the time until the receiver has nothing due; every event.
fn run(rx: &mut UssReceiver, cs: &[RxChar]) -> Vec<RxEvent<Telegram, FrameError>> {
    let mut out = Vec::new();
    for c in cs {
        out.extend(rx.handle_char(*c));
    }
    while let Some(at) = rx.poll_timeout() {
        match rx.handle_timeout(at) {
            Some(e) => out.push(e),
            None => break,
        }
    }
    out
}

#[test]
fn start_delay_is_two_characters_at_every_baud_rate() {
    // 11-bit characters (8E1): the published minimum start delays.
    for (baud, min_us) in [
        (9600, 2291),
        (19200, 1145),
        (38400, 572),
        (57600, 381),
        (115200, 190),
        (187500, 117),
    ] {
        let t = UssTiming::from_line(&line(baud));
        assert_eq!(t.start_delay, line(baud).char_times(2, 1));
        assert_eq!(t.start_delay.as_micros() as u64, min_us, "{baud}");
        assert_eq!(t.max_char_gap, t.start_delay);
    }
    assert_eq!(
        UssTiming::from_line(&line(9600)).char_time,
        Duration::from_nanos(1_145_833)
    );
}

#[test]
fn stx_needs_the_start_delay_before_it() {
    for baud in [9600, 19200, 38400] {
        let l = line(baud);
        let ct = l.char_time().as_nanos() as u64;
        let delay = l.char_times(2, 1).as_nanos() as u64;
        let framing = UssFraming::new(Side::Slave(addr(7)), Layout::PKW4_PZD2, &l);
        let t = Telegram::new(
            Adr::new(addr(7)),
            Layout::PKW4_PZD2,
            Pkw::default(),
            &[1, 2],
        )
        .unwrap();
        let wire = encode(&t);
        // A character, then the telegram after the start delay minus 1 ns: the
        // STX is ignored (the line was not quiet long enough) and so is the rest.
        let mut rx = UssReceiver::new(framing);
        let first = RxChar::new(0x55, Instant::from_nanos(ct));
        let _ = rx.handle_char(first); // garbage on an unknown line: rejected, ignored
        let start = first.time.add_nanos(delay - 1);
        let evs = run(&mut rx, &chars(&wire, start, ct));
        assert!(
            !evs.iter().any(|e| matches!(e, RxEvent::Frame(_))),
            "{baud}: {evs:?}"
        );
        // With exactly the start delay it is received.
        let mut rx = UssReceiver::new(framing);
        let _ = rx.handle_char(first);
        let start = first.time.add_nanos(delay);
        let evs = run(&mut rx, &chars(&wire, start, ct));
        assert_eq!(evs, vec![RxEvent::Frame(t)], "{baud}");
    }
}

#[test]
fn a_gap_of_the_start_delay_breaks_the_telegram_off() {
    let l = line(19200);
    let ct = l.char_time().as_nanos() as u64;
    let framing = UssFraming::new(Side::Master, Layout::PKW4_PZD2, &l);
    let t = Telegram::new(
        Adr::new(addr(7)),
        Layout::PKW4_PZD2,
        Pkw::default(),
        &[1, 2],
    )
    .unwrap();
    let wire = encode(&t);
    // 1.9 character times of silence after the 5th character: still one telegram (and within
    // the residual run time: 1.9 of 22.5 allowed extra characters).
    let mut cs = chars(&wire, Instant::ZERO, ct);
    for c in cs.iter_mut().skip(5) {
        c.time = c.time.add_nanos(ct * 19 / 10);
    }
    let mut rx = UssReceiver::new(framing);
    assert_eq!(run(&mut rx, &cs), vec![RxEvent::Frame(t)]);
    // Two character times: broken off after 5 bytes.
    let mut cs = chars(&wire, Instant::ZERO, ct);
    for c in cs.iter_mut().skip(5) {
        c.time = c.time.add_nanos(ct * 2);
    }
    let mut rx = UssReceiver::new(framing);
    let evs = run(&mut rx, &cs);
    assert_eq!(
        evs[0],
        RxEvent::Rejected(FrameError::Line(LineError::InterCharacterGap {
            received: 5
        }))
    );
    assert!(!evs.iter().any(|e| matches!(e, RxEvent::Frame(_))));
}

#[test]
fn a_telegram_is_accepted_only_after_the_start_delay_of_silence() {
    let l = line(9600);
    let ct = l.char_time().as_nanos() as u64;
    let framing = UssFraming::new(Side::Master, Layout::PKW4_PZD2, &l);
    let t = Telegram::new(
        Adr::new(addr(7)),
        Layout::PKW4_PZD2,
        Pkw::default(),
        &[1, 2],
    )
    .unwrap();
    let wire = encode(&t);
    let mut rx = UssReceiver::new(framing);
    for c in chars(&wire, Instant::ZERO, ct) {
        assert_eq!(rx.handle_char(c), None);
    }
    let end = Instant::from_nanos(16 * ct);
    let delay = l.char_times(2, 1).as_nanos() as u64;
    assert_eq!(rx.poll_timeout(), Some(end.add_nanos(delay)));
    assert_eq!(rx.handle_timeout(end.add_nanos(delay - 1)), None);
    assert_eq!(
        rx.handle_timeout(end.add_nanos(delay)),
        Some(RxEvent::Frame(t))
    );
    // An inserted character right after the BCC (the real telegram was longer than it said):
    // rejected, never accepted.
    let mut rx = UssReceiver::new(framing);
    let mut cs = chars(&wire, Instant::ZERO, ct);
    cs.push(RxChar::new(0x00, end.add_nanos(ct)));
    assert_eq!(
        run(&mut rx, &cs),
        vec![RxEvent::Rejected(FrameError::Line(
            LineError::TrailingCharacter { byte: 0 }
        ))]
    );
}

#[test]
fn residual_run_time_is_checked() {
    use ctt2_uss::serial::master::{MasterConfig, MasterEvent, RejectReason, UssMaster};
    let l = line(9600);
    let ct = l.char_time().as_nanos() as u64;
    let timing = UssTiming::from_line(&l);
    // 16-byte telegram: LGE 14, residual run time 15 characters, at most 22.5 characters.
    assert_eq!(
        timing.max_runtime(Layout::PKW4_PZD2),
        Some(Duration::from_nanos(ct * 45 / 2))
    );
    assert_eq!(
        timing
            .with_runtime_percent(None)
            .max_runtime(Layout::PKW4_PZD2),
        None
    );
    assert_eq!(
        timing
            .with_max_char_gap(Duration::from_secs(1))
            .max_char_gap,
        timing.start_delay
    );
    let request = Telegram::new(
        Adr::new(addr(7)),
        Layout::PKW4_PZD2,
        Pkw::default(),
        &[1, 2],
    )
    .unwrap();
    // The answer trickles in: 1.5 character times of gap before each of the 15 characters
    // after STX, each below the gap limit, 22.5 characters of gaps in all (+ 15 characters):
    // over the limit.
    for (gap_tenths, ok) in [(5u64, true), (15, false)] {
        let mut m = UssMaster::new(MasterConfig::new(l));
        m.send(request, Instant::ZERO).unwrap();
        let mut buf = [0u8; MAX_TELEGRAM];
        let n = m.poll_transmit(Instant::ZERO, &mut buf).unwrap();
        let mut t = Instant::from_nanos(ct * n as u64 + 2 * ct);
        for b in encode(&request) {
            t = t.add_nanos(ct);
            m.handle_char(RxChar::new(b, t));
            t = t.add_nanos(ct * gap_tenths / 10);
        }
        m.handle_timeout(t.add_nanos(3 * ct));
        let ev = m.poll_event();
        if ok {
            assert_eq!(ev, Some(MasterEvent::Response(request)));
        } else {
            assert!(
                matches!(
                    ev,
                    Some(MasterEvent::Rejected(RejectReason::Frame(
                        FrameError::RuntimeExceeded { .. }
                    )))
                ),
                "{ev:?}"
            );
        }
    }
}

#[test]
fn a_slave_drops_other_addresses_at_adr_and_takes_broadcasts() {
    let l = line(19200);
    let ct = l.char_time().as_nanos() as u64;
    let framing = UssFraming::new(Side::Slave(addr(3)), Layout::PKW4_PZD2, &l);
    let to = |adr| Telegram::new(adr, Layout::PKW4_PZD2, Pkw::default(), &[1, 2]).unwrap();
    let mut rx = UssReceiver::new(framing);
    assert_eq!(
        run(
            &mut rx,
            &chars(&encode(&to(Adr::new(addr(4)))), Instant::ZERO, ct)
        ),
        vec![RxEvent::Rejected(FrameError::NotAddressed(Adr(4)))]
    );
    for adr in [Adr::new(addr(3)), Adr::broadcast(), Adr::mirror(addr(3))] {
        let mut rx = UssReceiver::new(framing);
        assert_eq!(
            run(&mut rx, &chars(&encode(&to(adr)), Instant::ZERO, ct)),
            vec![RxEvent::Frame(to(adr))]
        );
    }
    // Another layout for this slave: rejected at ADR with the lengths.
    let other = Telegram::new(Adr::new(addr(3)), layout(4, 4), Pkw::default(), &[0; 4]).unwrap();
    let mut rx = UssReceiver::new(framing);
    assert_eq!(
        run(&mut rx, &chars(&encode(&other), Instant::ZERO, ct)),
        vec![RxEvent::Rejected(FrameError::BadLength {
            expected: 14,
            got: 18
        })]
    );
    // A parity error in a character rejects the telegram.
    let mut cs = chars(&encode(&to(Adr::new(addr(3)))), Instant::ZERO, ct);
    cs[6].error = Some(CharError::Parity);
    let mut rx = UssReceiver::new(framing);
    assert_eq!(
        run(&mut rx, &cs)[0],
        RxEvent::Rejected(FrameError::Line(LineError::Char(CharError::Parity)))
    );
}

// ---- properties ----

fn layout_strategy() -> impl Strategy<Value = Layout> {
    (prop_oneof![Just(0u8), Just(3), Just(4)], 0u8..=16).prop_map(|(k, z)| layout(k, z))
}

fn telegram_strategy() -> impl Strategy<Value = Telegram> {
    (
        layout_strategy(),
        any::<u8>(),
        any::<[u16; 4]>(),
        proptest::collection::vec(any::<u16>(), 16),
    )
        .prop_map(|(l, adr, w, pzd)| {
            let mut pkw = Pkw::from_words(w);
            if l.pkw_words() == 3 {
                pkw.pwe1 = if pkw.pwe2 & 0x8000 != 0 { 0xFFFF } else { 0 };
            }
            Telegram::new(Adr(adr), l, pkw, &pzd[..usize::from(l.pzd_words())]).unwrap()
        })
}

proptest! {
    #[test]
    fn encode_decode_round_trip(t in telegram_strategy()) {
        let wire = encode(&t);
        prop_assert_eq!(wire.len(), t.len());
        prop_assert_eq!(wire[1], t.layout().lge());
        prop_assert_eq!(Telegram::decode(&wire, t.layout()), Ok(t));
    }

    #[test]
    fn receiver_round_trip(t in telegram_strategy(), baud in prop_oneof![Just(9600u32), Just(38400), Just(187500)]) {
        let l = line(baud);
        let ct = l.char_time().as_nanos() as u64;
        let side = Side::Slave(t.adr().address());
        let mut rx = UssReceiver::new(UssFraming::new(side, t.layout(), &l));
        prop_assert_eq!(run(&mut rx, &chars(&encode(&t), Instant::ZERO, ct)), vec![RxEvent::Frame(t)]);
    }

    #[test]
    fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..64), l in layout_strategy()) {
        let _ = Telegram::decode(&bytes, l);
        let _ = Telegram::announced_len(&bytes);
    }

    /// Characters with random gaps and UART errors: the receiver never panics and hands out
    /// only telegrams that re-encode to bytes it was given.
    #[test]
    fn receiver_never_panics(input in proptest::collection::vec((any::<u8>(), 0u64..40, 0u8..20), 0..200), l in layout_strategy(), master in any::<bool>()) {
        let line = line(19200);
        let ct = line.char_time().as_nanos() as u64;
        let side = if master { Side::Master } else { Side::Slave(addr(1)) };
        let mut rx = UssReceiver::new(UssFraming::new(side, l, &line));
        let mut t = Instant::ZERO;
        let mut seen = Vec::new();
        for (b, gap, status) in input {
            t = t.add_nanos(ct + ct * gap / 8);
            let c = match status {
                0 => RxChar::with_error(b, t, CharError::Parity),
                1 => RxChar::with_error(b, t, CharError::Framing),
                _ => RxChar::new(b, t),
            };
            seen.push(b);
            if let Some(RxEvent::Frame(f)) = rx.handle_char(c) {
                prop_assert_eq!(f.layout(), l);
                let wire = encode(&f);
                prop_assert!(seen.windows(wire.len()).any(|w| w == wire.as_slice()));
            }
            if let Some(at) = rx.poll_timeout()
                && at <= t {
                    let _ = rx.handle_timeout(t);
                }
        }
    }
}
