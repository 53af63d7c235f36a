//! The master shell with a toy protocol on a line (length-prefixed frames `0xA5 n data…`, the
//! first data byte the answering address) and on CAN (identifier = address).

use super::*;
use crate::can::CanExchangeConfig;
use crate::exchange::ExchangeConfig;
use crate::framing::{FrameTiming, LineError, Progress, Start};

const CHAR: Duration = Duration::from_micros(1_000);
const PAUSE: Duration = Duration::from_micros(3_000);

#[derive(Debug, Clone, Copy)]
struct Lp;

impl Framing for Lp {
    type Frame = [u8; 2];
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
    fn decode(&self, frame: &[u8]) -> Result<[u8; 2], LineError> {
        Ok([
            frame.get(2).copied().unwrap_or(0),
            frame.get(3).copied().unwrap_or(0),
        ])
    }
}

/// Why the toy protocol did not take a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Why {
    Line(LineError),
    OtherAddress(u8),
    Late,
    Broken,
}

impl From<LineError> for Why {
    fn from(e: LineError) -> Self {
        Why::Line(e)
    }
}

/// The toy protocol: a request is an address (0 = broadcast); the answer `[address, value]`.
/// Value 0xEE is corrupt, 0xDD is an earlier request's answer, 0xCC asks for another exchange
/// (twice, then the protocol abandons the request).
#[derive(Debug, Clone, Copy, Default)]
struct Toy {
    cycles: u8,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct NotDone;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SendError {
    Busy,
    Zero,
}

impl From<Busy> for SendError {
    fn from(_: Busy) -> Self {
        SendError::Busy
    }
}

type Event = MasterEvent<u8, Why, NotDone>;

impl Protocol for Toy {
    type Input = u8;
    type Request = u8;
    type Frame = [u8; 2];
    type Answer = u8;
    type Reason = Why;
    type Failure = NotDone;
    type Event = Event;
    type SendError = SendError;

    fn prepare(&mut self, input: u8) -> Result<u8, SendError> {
        if input == 0xFF {
            return Err(SendError::Zero);
        }
        Ok(input)
    }

    fn answered(&self, request: &u8) -> bool {
        *request != 0
    }

    fn judge(
        &mut self,
        request: &mut u8,
        [address, value]: [u8; 2],
    ) -> Judgement<u8, Why, NotDone> {
        if address != *request {
            return Judgement::Foreign(Why::OtherAddress(address));
        }
        match value {
            0xEE => Judgement::Corrupt(Why::Broken),
            0xDD => Judgement::Stale(Why::Late),
            0xCC if self.cycles >= 2 => Judgement::Abandon(value, None, NotDone),
            0xCC => {
                self.cycles += 1;
                Judgement::Again(value, Some(Why::Late))
            }
            v => Judgement::Ours(v),
        }
    }

    fn report(&mut self, _: &u8, event: Event, events: &mut Queue<Event, EVENTS>) {
        events.push(event);
    }
}

impl CharProtocol for Toy {
    type Framing = Lp;

    fn encode(&mut self, request: &u8, buf: &mut [u8], _: &mut Lp) -> Option<usize> {
        let frame = [0xA5, 1, *request];
        buf.get_mut(..3)?.copy_from_slice(&frame);
        Some(3)
    }
}

impl FrameProtocol for Toy {
    fn encode(&mut self, request: &u8) -> CanFrame {
        CanFrame::standard(u16::from(*request), &[]).unwrap()
    }
}

fn us(n: u64) -> Instant {
    Instant::from_micros(n)
}

fn line(retries: u8) -> Master<Toy, Exchange<Lp, 8>> {
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(50),
        retries,
        retry_pause: PAUSE * 2,
        unanswered_hold: Duration::from_millis(25),
        min_idle_gap: Duration::ZERO,
    };
    Master::from_parts(Toy::default(), Exchange::new(Lp, config))
}

/// Send the request (due at `at`) and feed `answer` starting 5 ms after its end; the events.
fn exchange(m: &mut Master<Toy, Exchange<Lp, 8>>, at: u64, answer: &[u8]) -> Vec<Event> {
    let mut buf = [0; 8];
    let t = m.poll_timeout().unwrap_or(us(at)).later(us(at));
    m.handle_timeout(t);
    assert_eq!(m.poll_transmit(t, &mut buf), Some(3));
    let start = t.as_micros() + 3_000 + 5_000;
    for (i, &b) in answer.iter().enumerate() {
        m.handle_char(RxChar::new(b, us(start + 1_000 * (i as u64 + 1))));
    }
    if let Some(t) = m.poll_timeout() {
        m.handle_timeout(t);
    }
    core::iter::from_fn(|| m.poll_event()).collect()
}

#[test]
fn the_answer_is_taken_and_the_master_is_idle() {
    let mut m = line(2);
    m.send(7, Instant::ZERO).unwrap();
    assert_eq!(m.send(8, Instant::ZERO), Err(SendError::Busy));
    assert_eq!(
        exchange(&mut m, 0, &[0xA5, 2, 7, 42]),
        [MasterEvent::Response(42)]
    );
    assert!(m.is_idle());
    assert_eq!(m.send(0xFF, us(50_000)), Err(SendError::Zero));
}

#[test]
fn on_a_line_what_is_not_the_answer_fails_the_attempt() {
    let mut m = line(1);
    m.send(7, Instant::ZERO).unwrap();
    // Another address, then a corrupt answer: both fail an attempt; the second is the last.
    let ev = exchange(&mut m, 0, &[0xA5, 2, 9, 1]);
    assert_eq!(ev, [MasterEvent::Rejected(Why::OtherAddress(9))]);
    assert_eq!(m.attempts(), 1);
    let ev = exchange(&mut m, 0, &[0xA5, 2, 7, 0xEE]);
    assert_eq!(
        ev,
        [
            MasterEvent::Rejected(Why::Broken),
            MasterEvent::Timeout { attempts: 2 }
        ]
    );
    assert!(m.is_idle());
    // A stale judgement fails the attempt the same way on a line.
    m.send(7, us(100_000)).unwrap();
    let ev = exchange(&mut m, 100_000, &[0xA5, 2, 7, 0xDD]);
    assert_eq!(ev, [MasterEvent::Rejected(Why::Late)]);
}

#[test]
fn again_requeues_with_fresh_attempts_and_abandon_ends_the_request() {
    let mut m = line(0);
    m.send(7, Instant::ZERO).unwrap();
    let ev = exchange(&mut m, 0, &[0xA5, 2, 7, 0xCC]);
    assert_eq!(
        ev,
        [MasterEvent::Answer(0xCC), MasterEvent::Rejected(Why::Late)]
    );
    // With 0 retries a second exchange is still allowed: the attempts started again.
    assert_eq!(m.attempts(), 0);
    let ev = exchange(&mut m, 0, &[0xA5, 2, 7, 0xCC]);
    assert_eq!(ev.len(), 2);
    let ev = exchange(&mut m, 0, &[0xA5, 2, 7, 0xCC]);
    assert_eq!(
        ev,
        [MasterEvent::Answer(0xCC), MasterEvent::Failed(NotDone)]
    );
    assert!(m.is_idle());
}

#[test]
fn an_unanswered_request_is_complete_when_handed_out() {
    let mut m = line(2);
    m.send(0, Instant::ZERO).unwrap();
    let mut buf = [0; 8];
    assert_eq!(m.poll_transmit(Instant::ZERO, &mut buf), Some(3));
    assert_eq!(m.poll_event(), Some(MasterEvent::Sent));
    assert!(m.is_idle());
    // The next request waits for the hold after the broadcast (3 ms + 25 ms).
    m.send(7, us(1_000)).unwrap();
    assert_eq!(m.poll_timeout(), Some(us(28_000)));
}

#[test]
fn characters_before_the_request_left_are_stale() {
    let mut m = line(2);
    m.send(7, Instant::ZERO).unwrap();
    // Waiting in the port before the request goes out.
    for (i, b) in [0xA5, 2, 7, 1].into_iter().enumerate() {
        m.handle_char(RxChar::new(b, us(i as u64 * 100)));
    }
    assert_eq!(m.stale_chars(), 4);
    assert_eq!(m.stale(), 4);
    assert_eq!(m.poll_event(), None);
}

fn can(retries: u8) -> Master<Toy, CanExchange> {
    let config = CanExchangeConfig {
        response_timeout: Duration::from_millis(10),
        retries,
        late_guard: Duration::from_millis(10),
    };
    Master::from_parts(Toy::default(), CanExchange::new(config))
}

#[test]
fn on_can_a_frame_before_the_first_transmission_is_stale() {
    let mut m = can(2);
    m.send(7, us(1_000)).unwrap();
    assert_eq!(m.handle_frame([7, 1], us(1_500)), Heard::Stale);
    let f = m.poll_transmit(us(2_000)).unwrap();
    assert_eq!(f.raw_id(), 7);
    // Received before the transmission, handled after it: still stale.
    assert_eq!(m.handle_frame([7, 1], us(1_900)), Heard::Stale);
    assert_eq!(m.stale(), 2);
    // Another address and a corrupt answer are counted; the attempt keeps waiting.
    assert_eq!(
        m.handle_frame([9, 1], us(2_100)),
        Heard::Rejected(Why::OtherAddress(9))
    );
    assert_eq!(
        m.handle_frame([7, 0xEE], us(2_200)),
        Heard::Rejected(Why::Broken)
    );
    assert_eq!(m.poll_event(), None);
    assert_eq!(m.handle_frame([7, 5], us(2_300)), Heard::Taken);
    assert_eq!(m.poll_event(), Some(MasterEvent::Response(5)));
    assert_eq!(m.handle_frame([7, 5], us(2_400)), Heard::Unsolicited);
}

#[test]
fn on_can_a_request_is_retried_given_up_and_guarded() {
    let mut m = can(1);
    m.send(7, Instant::ZERO).unwrap();
    assert!(m.poll_transmit(Instant::ZERO).is_some());
    assert_eq!(m.poll_timeout(), Some(us(10_000)));
    assert_eq!(m.handle_timeout(us(9_999)), None);
    assert_eq!(m.handle_timeout(us(10_000)), Some(Verdict::Retry));
    assert!(m.poll_transmit(us(10_000)).is_some());
    assert_eq!(
        m.handle_timeout(us(20_000)),
        Some(Verdict::GiveUp { attempts: 2 })
    );
    assert_eq!(m.poll_event(), Some(MasterEvent::Timeout { attempts: 2 }));
    let tally = m.carrier().tally();
    assert_eq!(
        (tally.first_transmissions, tally.retries, tally.give_ups),
        (1, 1, 1)
    );
    // The late guard holds the next request for 10 ms after the give-up.
    m.send(7, us(20_000)).unwrap();
    assert_eq!(m.poll_transmit(us(29_999)), None);
    assert_eq!(m.poll_timeout(), Some(us(30_000)));
    assert!(m.poll_transmit(us(30_000)).is_some());
    // Dropped while on the bus: the guard holds again.
    m.abort(us(31_000));
    m.send(7, us(31_000)).unwrap();
    assert_eq!(m.poll_timeout(), Some(us(41_000)));
}

#[test]
fn on_can_an_unanswered_request_is_sent_at_once() {
    let mut m = can(0);
    m.send(0, Instant::ZERO).unwrap();
    assert!(m.poll_transmit(Instant::ZERO).is_some());
    assert_eq!(m.poll_event(), Some(MasterEvent::Sent));
    assert!(m.is_idle());
    assert_eq!(m.carrier().tally().first_transmissions, 1);
}
