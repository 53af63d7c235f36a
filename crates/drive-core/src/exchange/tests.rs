//! The transaction skeleton with a small length-prefixed framing: `0xA5`, length n, n bytes.

use super::*;
use crate::framing::{FrameTiming, LineError, Progress, Start};

const CHAR: Duration = Duration::from_micros(1_000);
const PAUSE: Duration = Duration::from_micros(3_000);

#[derive(Debug, Clone, Copy)]
struct Lp;

impl Framing for Lp {
    type Frame = u8;
    type Error = LineError;
    fn timing(&self) -> FrameTiming {
        FrameTiming::uniform(CHAR, PAUSE)
    }
    fn start(&self, byte: u8) -> Start<LineError> {
        if byte == 0xA5 {
            Start::Begin
        } else {
            Start::Ignore
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<LineError> {
        match frame.get(1) {
            Some(&n) if frame.len() == usize::from(n) + 2 => Progress::Complete,
            _ => Progress::More,
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<u8, LineError> {
        Ok(frame.get(2).copied().unwrap_or(0))
    }
}

fn config(retries: u8) -> ExchangeConfig {
    ExchangeConfig {
        response_timeout: Duration::from_millis(50),
        retries,
        retry_pause: PAUSE * 2,
        unanswered_hold: Duration::from_millis(25),
        min_idle_gap: Duration::ZERO,
    }
}

fn us(n: u64) -> Instant {
    Instant::from_micros(n)
}

/// Feed `bytes` as an answer whose first character starts at `start` (µs); return the events.
fn answer(x: &mut Exchange<Lp, 8>, bytes: &[u8], start: u64) -> Vec<ExchangeEvent<u8, LineError>> {
    let mut out = Vec::new();
    for (i, &b) in bytes.iter().enumerate() {
        let c = RxChar::new(b, us(start + 1_000 * (i as u64 + 1)));
        out.extend(x.handle_char(c));
    }
    if let Some(t) = x.poll_timeout() {
        out.extend(x.handle_timeout(t));
    }
    out
}

#[test]
fn answered_request_completes_after_confirmation() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(2));
    x.begin(Instant::ZERO).unwrap();
    assert_eq!(x.begin(Instant::ZERO), Err(Busy));
    assert!(x.may_transmit(Instant::ZERO));
    let end = x.transmitted(4, true);
    assert_eq!(end, us(4_000));
    assert!(x.is_awaiting_response());
    assert_eq!(x.response_deadline(), Some(us(4_000 + 50_000 + 1_000)));
    let ev = answer(&mut x, &[0xA5, 1, 42], 10_000);
    assert_eq!(ev, [ExchangeEvent::Frame(42)]);
    x.complete();
    assert!(x.is_idle());
    // The next request waits for the idle gap after the answer's last character (13 ms).
    assert_eq!(x.gate().earliest_start(), us(13_000 + 3_000));
    x.begin(us(15_000)).unwrap();
    assert!(x.may_transmit(us(16_000)));
}

#[test]
fn retries_then_gives_up_even_with_255_retries() {
    for retries in [0u8, 2, 255] {
        let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(retries));
        x.begin(Instant::ZERO).unwrap();
        let mut attempts = 0u32;
        let verdict = loop {
            let now = x.poll_timeout().unwrap();
            assert!(x.may_transmit(now));
            x.transmitted(4, true);
            attempts += 1;
            let give_up = x.poll_timeout().unwrap();
            match x.handle_timeout(give_up) {
                Some(ExchangeEvent::NoAnswer(Verdict::Retry)) => {
                    // The retry waits the retry pause after the last activity.
                    assert!(x.poll_timeout().unwrap() >= give_up);
                }
                Some(ExchangeEvent::NoAnswer(v)) => break v,
                other => panic!("{other:?}"),
            }
            assert!(attempts <= 300, "never gives up");
        };
        assert_eq!(
            verdict,
            Verdict::GiveUp {
                attempts: u16::from(retries) + 1
            }
        );
        assert_eq!(attempts, u32::from(retries) + 1);
        assert!(x.is_idle());
    }
}

#[test]
fn late_answers_are_never_matched_to_the_next_request() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    x.begin(Instant::ZERO).unwrap();
    x.may_transmit(Instant::ZERO);
    x.transmitted(4, true);
    let give_up = us(4_000 + 50_000 + 1_000);
    assert_eq!(
        x.handle_timeout(give_up),
        Some(ExchangeEvent::NoAnswer(Verdict::GiveUp { attempts: 1 }))
    );
    // The late answer arrives while nothing waits: only bus activity.
    let ev = answer(&mut x, &[0xA5, 1, 99], 60_000);
    assert!(ev.is_empty());
    // The next request waits until the line was quiet after the late answer.
    x.begin(us(63_000)).unwrap();
    assert!(!x.may_transmit(us(63_000)));
    assert_eq!(x.poll_timeout(), Some(us(63_000 + 3_000)));
    // A late answer that starts after the give-up time while the next request waits fails
    // that attempt instead of answering it.
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(1));
    x.begin(Instant::ZERO).unwrap();
    x.may_transmit(Instant::ZERO);
    x.transmitted(4, true);
    let ev = answer(&mut x, &[0xA5, 1, 7], 56_000);
    assert_eq!(ev.first(), Some(&ExchangeEvent::NoAnswer(Verdict::Retry)));
    assert!(!ev.contains(&ExchangeEvent::Frame(7)));
}

#[test]
fn rejected_answers_and_unanswered_requests_and_abort() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(1));
    x.begin(Instant::ZERO).unwrap();
    x.may_transmit(Instant::ZERO);
    x.transmitted(4, true);
    let c = RxChar::with_error(0xA5, us(6_000), crate::CharError::Parity);
    assert_eq!(
        x.handle_char(c),
        Some(ExchangeEvent::Rejected(
            LineError::Char(crate::CharError::Parity),
            Verdict::Retry
        ))
    );
    assert_eq!(x.attempts(), 1);
    // The protocol refuses a well-formed frame (it answers another request): retry, then give
    // up.
    let t = x.poll_timeout().unwrap();
    assert!(x.may_transmit(t));
    x.transmitted(4, true);
    assert_eq!(x.fail(), Verdict::GiveUp { attempts: 2 });
    // A broadcast completes on transmission and holds the bus.
    x.begin(us(100_000)).unwrap();
    x.may_transmit(us(100_000));
    let end = x.transmitted(4, false);
    assert!(x.is_idle());
    assert_eq!(x.gate().earliest_start(), end + Duration::from_millis(25));
    // Requeue keeps the job with fresh attempts; abort drops it and holds the bus.
    x.begin(us(200_000)).unwrap();
    x.may_transmit(us(200_000));
    x.transmitted(4, true);
    x.requeue();
    assert_eq!(x.attempts(), 0);
    assert!(!x.is_awaiting_response());
    x.abort(us(205_000));
    assert!(x.is_idle());
    assert_eq!(x.gate().earliest_start(), us(211_000));
}

#[test]
fn the_retry_pause_follows_the_last_attempt_too() {
    // One attempt only: a garbage answer gives up, and the next request still waits the
    // retry pause after it (what failed may still be on the line).
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    x.begin(Instant::ZERO).unwrap();
    assert!(x.may_transmit(Instant::ZERO));
    x.transmitted(4, true);
    let c = RxChar::with_error(0xA5, us(6_000), crate::CharError::Parity);
    assert!(matches!(
        x.handle_char(c),
        Some(ExchangeEvent::Rejected(_, Verdict::GiveUp { attempts: 1 }))
    ));
    x.begin(us(6_000)).unwrap();
    assert_eq!(x.poll_timeout(), Some(us(6_000 + 6_000)));
    assert!(!x.may_transmit(us(11_999)));
    assert!(x.may_transmit(us(12_000)));

    // The same after a response timeout on the last attempt.
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    x.begin(Instant::ZERO).unwrap();
    assert!(x.may_transmit(Instant::ZERO));
    let end = x.transmitted(4, true);
    let give_up = x.response_deadline().unwrap();
    assert_eq!(
        x.handle_timeout(give_up),
        Some(ExchangeEvent::NoAnswer(Verdict::GiveUp { attempts: 1 }))
    );
    x.begin(give_up).unwrap();
    // The last activity was the request's end; the pause from there has long passed.
    assert!(x.may_transmit(give_up));
    assert!(end.add_nanos(6_000_000) < give_up);
}

/// `Lp` on a line whose speed can change.
#[derive(Debug, Clone, Copy)]
struct Scaled {
    factor: u32,
}

impl Framing for Scaled {
    type Frame = u8;
    type Error = LineError;
    fn timing(&self) -> FrameTiming {
        FrameTiming::uniform(CHAR * self.factor, PAUSE * self.factor)
    }
    fn start(&self, byte: u8) -> Start<LineError> {
        Lp.start(byte)
    }
    fn progress(&self, frame: &[u8]) -> Progress<LineError> {
        Lp.progress(frame)
    }
    fn decode(&self, frame: &[u8]) -> Result<u8, LineError> {
        Lp.decode(frame)
    }
}

#[test]
fn refresh_timing_reaches_the_gate_and_the_transmission_times() {
    let mut x: Exchange<Scaled, 8> = Exchange::new(Scaled { factor: 1 }, config(0));
    x.receiver_mut().framing_mut().factor = 2;
    x.refresh_timing();
    assert_eq!(x.gate().idle_gap(), PAUSE * 2);
    assert_eq!(x.receiver().timing().char_time, CHAR * 2);
    x.begin(Instant::ZERO).unwrap();
    assert!(x.may_transmit(Instant::ZERO));
    // Four characters of 2 ms each.
    assert_eq!(x.transmitted(4, true), us(8_000));
    // Give up after the response timeout plus one (new) character time.
    assert_eq!(x.response_deadline(), Some(us(8_000 + 50_000 + 2_000)));
}

#[test]
fn min_idle_gap_holds_the_next_request_beyond_the_framings_start_gap() {
    // Modbus: 2 ms after an answer even where the framing needs less (ASCII needs none).
    let cfg = ExchangeConfig {
        min_idle_gap: Duration::from_millis(5),
        ..config(2)
    };
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, cfg);
    x.begin(Instant::ZERO).unwrap();
    assert!(x.may_transmit(Instant::ZERO));
    x.transmitted(4, true);
    assert_eq!(
        answer(&mut x, &[0xA5, 1, 42], 10_000),
        [ExchangeEvent::Frame(42)]
    );
    x.complete();
    // The answer's last character ended at 13 ms: 5 ms, not the framing's 3 ms.
    assert_eq!(x.gate().earliest_start(), us(13_000 + 5_000));
    // A shorter minimum leaves the framing's gap in force; refreshing keeps the rule.
    x.refresh_timing();
    assert_eq!(x.gate().earliest_start(), us(18_000));
    let mut y: Exchange<Lp, 8> = Exchange::new(
        Lp,
        ExchangeConfig {
            min_idle_gap: Duration::from_millis(1),
            ..config(2)
        },
    );
    y.begin(Instant::ZERO).unwrap();
    y.may_transmit(Instant::ZERO);
    y.transmitted(4, true);
    answer(&mut y, &[0xA5, 1, 42], 10_000);
    y.complete();
    assert_eq!(y.gate().earliest_start(), us(16_000));
}

// ----- Issue 18: stale characters are never an answer -----

/// Feed `bytes` as characters 1 ms apart from `start` µs on, without polling the timeout;
/// the events.
fn feed(x: &mut Exchange<Lp, 8>, bytes: &[u8], start: u64) -> Vec<ExchangeEvent<u8, LineError>> {
    let mut out = Vec::new();
    for (i, &b) in bytes.iter().enumerate() {
        out.extend(x.handle_char(RxChar::new(b, us(start + 1_000 * (i as u64 + 1)))));
    }
    out
}

/// A request of four characters (4 ms) transmitted at `start` µs; its end.
fn sent(x: &mut Exchange<Lp, 8>, start: u64) -> Instant {
    x.begin(us(start)).unwrap();
    assert!(x.may_transmit(us(start)));
    x.transmitted(4, true)
}

#[test]
fn issue18_an_answer_completing_before_the_request_has_left_is_stale() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    let end = sent(&mut x, 0);
    assert_eq!(end, us(4_000));
    assert_eq!(x.request_left(), Some(end));
    // A complete, valid frame whose characters complete at 1, 2 and 3 ms, while the request
    // is still on the wire: an earlier program's answer that was waiting in the port.
    assert!(feed(&mut x, &[0xA5, 1, 99], 0).is_empty());
    assert_eq!(x.stale_chars(), 3);
    assert!(x.is_awaiting_response());
    // A character completing exactly when the request has left started while it was still on
    // the wire: stale too.
    assert_eq!(x.handle_char(RxChar::new(0xA5, end)), None);
    assert_eq!(x.stale_chars(), 4);
    // The real answer after the request: taken, even with no retries left.
    assert_eq!(
        answer(&mut x, &[0xA5, 1, 42], 8_000),
        [ExchangeEvent::Frame(42)]
    );
    assert_eq!(x.stale_chars(), 4);
}

#[test]
fn issue18_characters_while_the_request_waits_for_the_bus_are_stale_and_hold_it_back() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    // Nothing in flight: bus activity only, not counted.
    assert_eq!(x.handle_char(RxChar::new(0x11, us(1_000))), None);
    assert_eq!(x.stale_chars(), 0);
    // The request is queued; a whole answer arrives before it could go out.
    x.begin(us(5_000)).unwrap();
    assert!(feed(&mut x, &[0xA5, 1, 99], 5_000).is_empty());
    assert_eq!(x.stale_chars(), 3);
    // Listen before talking: the request waits until the line was quiet for the idle gap.
    assert!(!x.may_transmit(us(8_000)));
    assert_eq!(x.poll_timeout(), Some(us(8_000 + 3_000)));
    assert!(x.may_transmit(us(11_000)));
    x.transmitted(4, true);
    assert_eq!(
        answer(&mut x, &[0xA5, 1, 42], 18_000),
        [ExchangeEvent::Frame(42)]
    );
}

#[test]
fn issue18_left_at_moves_the_end_for_a_port_without_wire_time() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
    let end = sent(&mut x, 0);
    // A pseudo-terminal delivered the request when the write returned, 100 µs after its
    // start; the other side answers long before the request's wire time is over.
    x.left_at(us(100));
    assert_eq!(x.request_left(), Some(us(100)));
    assert_eq!(x.handle_char(RxChar::new(0x55, us(100))), None);
    assert_eq!(x.stale_chars(), 1);
    assert_eq!(
        answer(&mut x, &[0xA5, 1, 42], 500),
        [ExchangeEvent::Frame(42)]
    );
    assert!(us(3_500) < end);
    x.complete();
    // The response timeout still counts from the end of the wire time.
    let end = sent(&mut x, 20_000);
    x.left_at(us(20_100));
    assert_eq!(
        x.response_deadline(),
        Some(end + Duration::from_millis(50) + CHAR)
    );
    // No effect while nothing is awaited.
    x.complete();
    x.left_at(us(90_000));
    assert_eq!(x.request_left(), None);
}

#[test]
fn issue18_a_retry_judges_characters_against_its_own_transmission() {
    let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(1));
    sent(&mut x, 0);
    let give_up = x.response_deadline().unwrap();
    assert_eq!(
        x.handle_timeout(give_up),
        Some(ExchangeEvent::NoAnswer(Verdict::Retry))
    );
    // The retry goes out at once (the retry pause after the last activity, the request's
    // end, has long passed); the late answer to the first attempt arrives while the retry is
    // still on the wire.
    let t = x.poll_timeout().unwrap();
    assert!(x.may_transmit(t));
    let end = x.transmitted(4, true);
    let late = t.as_micros();
    assert!(feed(&mut x, &[0xA5, 1, 99], late).is_empty());
    assert_eq!(x.stale_chars(), 3);
    assert_eq!(
        answer(&mut x, &[0xA5, 1, 42], end.as_micros() + 4_000),
        [ExchangeEvent::Frame(42)]
    );
}

mod stale_props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Whatever arrives while the request waits for the bus or is still on the wire —
        /// any bytes, valid frames or garbage, with or without UART errors — is counted as
        /// stale and never decides the request: the answer after it is taken as it is.
        #[test]
        fn stale_characters_never_decide_the_request(
            queued in proptest::collection::vec((any::<u8>(), any::<bool>()), 0..20),
            on_wire in proptest::collection::vec((any::<u8>(), 0u64..=4_000, any::<bool>()), 0..20),
            value in any::<u8>(),
            gap in 0u64..40_000,
        ) {
            let mut x: Exchange<Lp, 8> = Exchange::new(Lp, config(0));
            x.begin(Instant::ZERO).unwrap();
            // Queued characters, 1 ms apart, before the request may go out.
            let mut t = 0;
            for &(b, bad) in &queued {
                t += 1_000;
                let c = if bad {
                    RxChar::with_error(b, us(t), crate::CharError::Parity)
                } else {
                    RxChar::new(b, us(t))
                };
                prop_assert_eq!(x.handle_char(c), None);
            }
            let start = x.poll_timeout().unwrap();
            prop_assert!(x.may_transmit(start));
            let end = x.transmitted(4, true);
            let mut times: Vec<u64> = on_wire.iter().map(|&(_, dt, _)| dt).collect();
            times.sort_unstable();
            for (&(b, _, bad), dt) in on_wire.iter().zip(times) {
                let at = start.add_nanos(dt * 1_000);
                let c = if bad {
                    RxChar::with_error(b, at, crate::CharError::Parity)
                } else {
                    RxChar::new(b, at)
                };
                prop_assert_eq!(x.handle_char(c), None);
            }
            prop_assert_eq!(x.stale_chars(), (queued.len() + on_wire.len()) as u64);
                    prop_assert!(x.is_awaiting_response());
            let ev = answer(&mut x, &[0xA5, 1, value], end.as_micros() + gap);
            prop_assert_eq!(ev, vec![ExchangeEvent::Frame(value)]);
        }
    }
}
