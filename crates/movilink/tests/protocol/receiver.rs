//! Receiver framing: every rejection of ch. 4.2, resynchronisation, timing of start pauses.

use movilink::timing::Instant;
use movilink::{Address, AddressFilter, CharError, Receiver, RejectReason, RxChar, RxEvent};

const CT: u64 = 1146;
const PAUSE: u64 = 3440;

/// Bild 20's request to drive 1.
const REQ: [u8; 10] = [0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57];

fn slave_rx() -> Receiver {
    Receiver::new(movilink::TelegramFraming::slave(
        Address::new(1).unwrap(),
        Address::group(150).unwrap(),
    ))
}

/// Feed `bytes` back to back starting at `t0` (first character complete at t0 + CT); if they
/// completed a telegram, let the line stay quiet until its end is confirmed (a start pause
/// after the last character). Returns the events and the time of the last character.
fn feed(rx: &mut Receiver, bytes: &[u8], t0: u64) -> (Vec<RxEvent>, u64) {
    let mut events = Vec::new();
    let mut t = t0;
    for b in bytes {
        t += CT;
        if let Some(e) = rx.handle_char(RxChar::new(*b, Instant::from_micros(t))) {
            events.push(e);
        }
    }
    let confirm = Instant::from_micros(t + PAUSE);
    if rx.poll_timeout() == Some(confirm) {
        events.extend(rx.handle_timeout(confirm));
    }
    (events, t)
}

fn with_addr(adr: u8) -> Vec<u8> {
    let mut v = REQ.to_vec();
    v[1] = adr;
    v[9] = movilink::codec::bcc(&v[..9]);
    v
}

#[test]
fn accepts_valid_request_and_resynchronises_after_idle() {
    let mut rx = slave_rx();
    let (ev, t) = feed(&mut rx, &REQ, 0);
    assert!(
        matches!(ev.as_slice(), [RxEvent::Frame(t)] if t.process_data() == [6, 0x3A98, 0x01F4])
    );
    // Exactly one start pause of idle: accepted again.
    let (ev, _) = feed(&mut rx, &REQ, t + PAUSE);
    assert_eq!(ev.len(), 1);
    assert!(matches!(ev[0], RxEvent::Frame(_)));
}

#[test]
fn start_character_without_idle_gap_is_not_a_start() {
    let mut rx = slave_rx();
    let (_, t) = feed(&mut rx, &REQ, 0);
    // Next telegram after 3.439 ms idle: too early, ignored entirely (and it keeps the line busy).
    let (ev, t) = feed(&mut rx, &REQ, t + PAUSE - 1);
    assert!(ev.is_empty());
    let (ev, _) = feed(&mut rx, &REQ, t + PAUSE);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]));
}

#[test]
fn parity_and_framing_errors_reject() {
    for (err, reason) in [
        (CharError::Parity, RejectReason::Char(CharError::Parity)),
        (CharError::Framing, RejectReason::Char(CharError::Framing)),
        (CharError::Overrun, RejectReason::Char(CharError::Overrun)),
    ] {
        let mut rx = slave_rx();
        let mut events = Vec::new();
        for (i, b) in REQ.iter().enumerate() {
            let t = Instant::from_micros(CT * (i as u64 + 1));
            let c = if i == 5 {
                RxChar::with_error(*b, t, err)
            } else {
                RxChar::new(*b, t)
            };
            events.extend(rx.handle_char(c));
        }
        assert_eq!(events, vec![RxEvent::Rejected(reason)], "{err:?}");
        // An erroneous start character is rejected too.
        let mut rx = slave_rx();
        let ev = rx.handle_char(RxChar::with_error(0x02, Instant::from_micros(CT), err));
        assert_eq!(ev, Some(RxEvent::Rejected(reason)));
    }
}

#[test]
fn inter_character_gap_rejects_and_next_char_may_start() {
    let mut rx = slave_rx();
    let (ev, t) = feed(&mut rx, &REQ[..4], 0);
    assert!(ev.is_empty());
    // A gap just below the start pause is fine.
    let (ev, t) = feed(&mut rx, &REQ[4..5], t + PAUSE - 1);
    assert!(ev.is_empty());
    // A gap of a start pause: rejected; the SD1 after the gap starts a new telegram.
    let (ev, t) = feed(&mut rx, &REQ[..1], t + PAUSE);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::InterCharacterGap {
            received: 5
        })]
    );
    let (ev, _) = feed(&mut rx, &REQ[1..], t);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]));
}

#[test]
fn inter_character_gap_by_timeout() {
    let mut rx = slave_rx();
    let (_, t) = feed(&mut rx, &REQ[..3], 0);
    let due = rx.poll_timeout().unwrap();
    // The telegram breaks off when a character ending now would have followed a gap of a start
    // pause: one character time (11 bits at 9600 baud) plus the pause after the last one.
    assert_eq!(
        due,
        Instant::from_micros(t + PAUSE) + movilink::timing::CHAR_TIME
    );
    assert_eq!(
        rx.handle_timeout(due.saturating_sub(std::time::Duration::from_nanos(1))),
        None
    );
    assert_eq!(
        rx.handle_timeout(due),
        Some(RxEvent::Rejected(RejectReason::InterCharacterGap {
            received: 3
        }))
    );
    assert_eq!(rx.poll_timeout(), None);
    assert!(!rx.is_receiving());
}

#[test]
fn wrong_address_slave_side() {
    // Own 1, group 150: 1, 150, 254, 255 accepted; 2, 100, 151, 253 rejected.
    for (adr, ok) in [
        (1, true),
        (150, true),
        (254, true),
        (255, true),
        (2, false),
        (100, false),
        (151, false),
        (253, false),
        (200, false),
    ] {
        let mut rx = slave_rx();
        let (ev, _) = feed(&mut rx, &with_addr(adr), 0);
        if ok {
            assert!(
                matches!(ev.as_slice(), [RxEvent::Frame(t)] if t.address().get() == adr),
                "{adr}"
            );
        } else {
            assert_eq!(
                ev,
                vec![RxEvent::Rejected(RejectReason::WrongAddress {
                    address: adr
                })],
                "{adr}"
            );
        }
    }
    // Group 100 means "no group": address 100 is never accepted.
    let mut rx = Receiver::new(movilink::TelegramFraming::slave(
        Address::new(1).unwrap(),
        Address::NO_GROUP,
    ));
    let (ev, _) = feed(&mut rx, &with_addr(100), 0);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::WrongAddress {
            address: 100
        })]
    );
}

#[test]
fn wrong_address_master_side() {
    let mut resp = REQ.to_vec();
    resp[0] = 0x1D;
    resp[9] = movilink::codec::bcc(&resp[..9]);
    let mut rx = Receiver::new(movilink::TelegramFraming::master(Address::new(2).unwrap()));
    let (ev, _) = feed(&mut rx, &resp, 0);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::WrongAddress { address: 1 })]
    );
    // Point-to-point request: any unicast answer is accepted.
    rx.framing_mut().filter = AddressFilter::Master {
        expected: Address::POINT_TO_POINT,
    };
    let (ev, _) = feed(&mut rx, &resp, 100_000);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]));
}

#[test]
fn unknown_pdu_type_and_bad_bcc() {
    let mut rx = slave_rx();
    let mut bad = REQ;
    bad[2] = 0x07;
    let (ev, t) = feed(&mut rx, &bad, 0);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::UnknownPduType {
            pdu_type: 0x07
        })]
    );
    let mut bad = REQ;
    bad[9] = 0x56;
    let (ev, _) = feed(&mut rx, &bad, t + PAUSE);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::BadBcc {
            expected: 0x57,
            got: 0x56
        })]
    );
}

#[test]
fn start_characters() {
    let mut rx = slave_rx();
    // A response (SD2) on the bus is not for the drive: silently skipped with its bytes.
    let mut resp = REQ;
    resp[0] = 0x1D;
    let (ev, t) = feed(&mut rx, &resp, 0);
    assert!(ev.is_empty());
    // Noise after an idle gap.
    let (ev, t) = feed(&mut rx, &[0x55, 0x02, 0x01], t + PAUSE);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::BadStartCharacter {
            byte: 0x55
        })]
    );
    let (ev, _) = feed(&mut rx, &REQ, t + PAUSE);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]));
}

#[test]
fn trailing_characters_reject_and_are_ignored_until_idle() {
    let mut rx = slave_rx();
    let mut stream = REQ.to_vec();
    stream.extend_from_slice(&REQ);
    // A second telegram right after the first (no idle gap) makes the first one too long:
    // one rejection, and the rest is ignored until the line was idle for a start pause.
    let (ev, t) = feed(&mut rx, &stream, 0);
    assert_eq!(
        ev,
        vec![RxEvent::Rejected(RejectReason::TrailingCharacter {
            byte: 0x02
        })]
    );
    let (ev, _) = feed(&mut rx, &REQ, t + PAUSE);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]));
}

/// A response delivered in two bursts 10 ms apart (as a USB serial adapter hands characters
/// over): rejected under the manual's gap rule, accepted with a wider `LineTiming::max_gap`,
/// and a gap beyond that wider limit still breaks the telegram off.
#[test]
fn bursty_delivery_needs_a_wider_gap_limit() {
    use movilink::{Direction, LineTiming, TelegramFraming};
    use std::time::Duration;
    let mut resp = REQ.to_vec();
    resp[0] = 0x1D;
    resp[9] = movilink::codec::bcc(&resp[..9]);
    let burst = |rx: &mut Receiver, split_gap: u64| {
        let mut events = Vec::new();
        let mut t = 100_000;
        for (i, b) in resp.iter().enumerate() {
            t += if i == 5 { split_gap } else { 0 };
            events.extend(rx.handle_char(RxChar::new(*b, Instant::from_micros(t))));
        }
        let confirm = Instant::from_micros(t + 20_000 + PAUSE);
        events.extend(rx.handle_timeout(confirm));
        events
    };
    let strict = LineTiming::MOVILINK;
    let lenient = LineTiming::MOVILINK.with_max_gap(Duration::from_millis(20));
    assert_eq!(lenient.max_gap, Duration::from_millis(20));
    // Never narrower than the start pause.
    assert_eq!(
        LineTiming::MOVILINK.with_max_gap(Duration::ZERO).max_gap,
        strict.start_pause
    );

    let mut rx = Receiver::new(TelegramFraming::new(
        Direction::Response,
        AddressFilter::Any,
        strict,
    ));
    let ev = burst(&mut rx, 10_000);
    assert!(
        matches!(
            ev.first(),
            Some(RxEvent::Rejected(RejectReason::InterCharacterGap {
                received: 5
            }))
        ),
        "{ev:?}"
    );

    let mut rx = Receiver::new(TelegramFraming::new(
        Direction::Response,
        AddressFilter::Any,
        lenient,
    ));
    let ev = burst(&mut rx, 10_000);
    assert!(matches!(ev.as_slice(), [RxEvent::Frame(_)]), "{ev:?}");

    let mut rx = Receiver::new(TelegramFraming::new(
        Direction::Response,
        AddressFilter::Any,
        lenient,
    ));
    let ev = burst(&mut rx, 25_000);
    assert!(
        matches!(
            ev.first(),
            Some(RxEvent::Rejected(RejectReason::InterCharacterGap { .. }))
        ),
        "{ev:?}"
    );
}
