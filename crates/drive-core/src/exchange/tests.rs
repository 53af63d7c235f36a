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
