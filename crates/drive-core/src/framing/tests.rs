//! The receiver with the four shapes of framing drivebus needs, written here as small test
//! framings: length from a header byte (MOVILINK), end by silence (Modbus RTU), start and end
//! characters (Modbus ASCII), length byte with immediate acceptance (USS).

use super::*;
use proptest::prelude::*;

const CHAR: Duration = Duration::from_micros(1_000);

fn us(n: u64) -> Instant {
    Instant::from_micros(n)
}

/// Characters back to back starting to arrive at `t0` (first one complete at `t0 + CHAR`).
fn chars(bytes: &[u8], t0: u64) -> impl Iterator<Item = RxChar> + '_ {
    bytes
        .iter()
        .enumerate()
        .map(move |(i, &b)| RxChar::new(b, us(t0 + 1_000 * (i as u64 + 1))))
}

fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |a, b| a ^ b)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TestError {
    Line(LineError),
    BadStart(u8),
    BadCheck,
    WrongAddress(u8),
}

impl From<LineError> for TestError {
    fn from(e: LineError) -> Self {
        TestError::Line(e)
    }
}

/// MOVILINK's shape: `0x02`, address, type (length = type + 4), data, XOR; start pause 3 chars.
#[derive(Debug, Clone, Copy)]
struct Headered {
    address: u8,
}

impl Framing for Headered {
    type Frame = (u8, u8);
    type Error = TestError;
    fn timing(&self) -> FrameTiming {
        FrameTiming::uniform(CHAR, CHAR * 3)
    }
    fn start(&self, byte: u8) -> Start<TestError> {
        match byte {
            0x02 => Start::Begin,
            0x1D => Start::Ignore,
            b => Start::Reject(TestError::BadStart(b)),
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<TestError> {
        match frame {
            [_, a, ..] if *a != self.address => Progress::Reject(TestError::WrongAddress(*a)),
            [_, _, t, ..] if frame.len() == usize::from(*t) + 4 => Progress::Complete,
            _ => Progress::More,
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<(u8, u8), TestError> {
        let (last, body) = frame.split_last().ok_or(TestError::BadCheck)?;
        if xor(body) != *last {
            return Err(TestError::BadCheck);
        }
        Ok((body.len() as u8, body.get(3).copied().unwrap_or(0)))
    }
}

fn headered(data: &[u8]) -> Vec<u8> {
    let mut f = vec![0x02, 7, data.len() as u8];
    f.extend_from_slice(data);
    f.push(xor(&f));
    f
}

#[test]
fn headered_frame_is_accepted_after_the_silence() {
    let mut rx: Receiver<Headered, 16> = Receiver::new(Headered { address: 7 });
    let f = headered(&[0xAB, 0xCD]);
    for c in chars(&f, 0) {
        assert_eq!(rx.handle_char(c), None);
    }
    assert!(rx.is_receiving());
    let confirm = rx.poll_timeout().unwrap();
    assert_eq!(confirm, us(6_000 + 3_000));
    assert_eq!(rx.handle_timeout(us(8_999)), None);
    assert_eq!(rx.handle_timeout(confirm), Some(RxEvent::Frame((5, 0xAB))));
    assert!(!rx.is_receiving());
    assert_eq!(rx.poll_timeout(), None);
}

#[test]
fn trailing_character_rejects_and_missed_confirmation_is_caught_up() {
    let mut rx: Receiver<Headered, 16> = Receiver::new(Headered { address: 7 });
    let f = headered(&[1]);
    for c in chars(&f, 0) {
        rx.handle_char(c);
    }
    // A character right after the check byte: the frame was longer than it said.
    let trailing = RxChar::new(0x55, us(6_000));
    assert_eq!(
        rx.handle_char(trailing),
        Some(RxEvent::Rejected(TestError::Line(
            LineError::TrailingCharacter { byte: 0x55 }
        )))
    );
    // The same frame again, its confirmation not polled: the next frame after a start pause
    // delivers it and starts itself.
    let mut rx: Receiver<Headered, 16> = Receiver::new(Headered { address: 7 });
    for c in chars(&f, 0) {
        rx.handle_char(c);
    }
    let next = RxChar::new(0x02, us(5_000 + 3_000 + 1_000));
    assert_eq!(rx.handle_char(next), Some(RxEvent::Frame((4, 1))));
    assert!(rx.is_receiving());
}

#[test]
fn gap_breaks_off_and_the_next_start_resynchronises() {
    let mut rx: Receiver<Headered, 16> = Receiver::new(Headered { address: 7 });
    let f = headered(&[1, 2, 3]);
    rx.handle_char(RxChar::new(f[0], us(1_000)));
    rx.handle_char(RxChar::new(f[1], us(2_000)));
    assert_eq!(rx.poll_timeout(), Some(us(2_000 + 1_000 + 3_000)));
    assert_eq!(
        rx.handle_timeout(us(6_000)),
        Some(RxEvent::Rejected(TestError::Line(
            LineError::InterCharacterGap { received: 2 }
        )))
    );
    // Garbage after a gap is a bad start, garbage without a gap is ignored, then a frame.
    assert_eq!(
        rx.handle_char(RxChar::new(0x77, us(7_000))),
        Some(RxEvent::Rejected(TestError::BadStart(0x77)))
    );
    assert_eq!(rx.handle_char(RxChar::new(0x77, us(8_000))), None);
    assert_eq!(
        rx.handle_char(RxChar::new(0x77, us(12_000))),
        Some(RxEvent::Rejected(TestError::BadStart(0x77)))
    );
    for c in chars(&f, 20_000) {
        assert_eq!(rx.handle_char(c), None);
    }
    assert_eq!(rx.handle_timeout(us(40_000)), Some(RxEvent::Frame((6, 1))));
}

#[test]
fn uart_errors_wrong_address_bad_check_and_overflow() {
    let mut rx: Receiver<Headered, 16> = Receiver::new(Headered { address: 7 });
    let mut f = headered(&[9]);
    rx.handle_char(RxChar::new(f[0], us(1_000)));
    assert_eq!(
        rx.handle_char(RxChar::with_error(f[1], us(2_000), CharError::Parity)),
        Some(RxEvent::Rejected(TestError::Line(LineError::Char(
            CharError::Parity
        ))))
    );
    rx.reset();
    let other = [0x02, 8, 0];
    let mut events = Vec::new();
    rx.handle_chars(&chars(&other, 10_000).collect::<Vec<_>>(), |e| {
        events.push(e)
    });
    assert_eq!(events, [RxEvent::Rejected(TestError::WrongAddress(8))]);
    rx.reset();
    *f.last_mut().unwrap() ^= 1;
    let mut last = None;
    for c in chars(&f, 30_000) {
        last = rx.handle_char(c).or(last);
    }
    assert_eq!(last, Some(RxEvent::Rejected(TestError::BadCheck)));
    // A frame announcing more than the buffer holds.
    let mut small: Receiver<Headered, 4> = Receiver::new(Headered { address: 7 });
    let mut last = None;
    for c in chars(&headered(&[1, 2, 3]), 0) {
        last = small.handle_char(c).or(last);
    }
    assert_eq!(
        last,
        Some(RxEvent::Rejected(TestError::Line(LineError::TooLong {
            capacity: 4
        })))
    );
}

/// Modbus RTU's shape: any byte after 3.5 characters of silence starts a frame; a gap above
/// 1.5 characters ends it; 3.5 characters of silence confirm it; the last byte is an XOR.
#[derive(Debug, Clone, Copy)]
struct Rtu;

impl Framing for Rtu {
    type Frame = usize;
    type Error = TestError;
    fn timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: CHAR,
            start_gap: CHAR * 7 / 2,
            max_gap: CHAR * 3 / 2,
            end_silence: CHAR * 7 / 2,
            ends_by_silence: true,
        }
    }
    fn start(&self, _: u8) -> Start<TestError> {
        Start::Begin
    }
    fn progress(&self, _: &[u8]) -> Progress<TestError> {
        Progress::More
    }
    fn decode(&self, frame: &[u8]) -> Result<usize, TestError> {
        match frame.split_last() {
            Some((last, body)) if body.len() >= 2 && xor(body) == *last => Ok(frame.len()),
            _ => Err(TestError::BadCheck),
        }
    }
}

fn rtu(data: &[u8]) -> Vec<u8> {
    let mut f = data.to_vec();
    f.push(xor(data));
    f
}

#[test]
fn rtu_frames_end_by_silence() {
    let mut rx: Receiver<Rtu, 256> = Receiver::new(Rtu);
    let f = rtu(&[1, 3, 0, 10]);
    for c in chars(&f, 0) {
        assert_eq!(rx.handle_char(c), None);
    }
    // The 1.5-character gap ends the frame, 3.5 characters confirm it.
    assert_eq!(rx.poll_timeout(), Some(us(5_000 + 1_000 + 1_500)));
    assert_eq!(rx.handle_timeout(us(7_500)), None);
    assert_eq!(rx.poll_timeout(), Some(us(5_000 + 3_500)));
    assert_eq!(rx.handle_timeout(us(8_500)), Some(RxEvent::Frame(5)));

    // A character 2 characters after the end (between t1.5 and t3.5): the frame is rejected,
    // and that character starts nothing (it came without the 3.5-character gap).
    let mut rx: Receiver<Rtu, 256> = Receiver::new(Rtu);
    for c in chars(&f, 0) {
        rx.handle_char(c);
    }
    assert_eq!(
        rx.handle_char(RxChar::new(0x11, us(5_000 + 2_000 + 1_000))),
        Some(RxEvent::Rejected(TestError::Line(
            LineError::TrailingCharacter { byte: 0x11 }
        )))
    );
    assert!(!rx.is_receiving());

    // Missed timeouts: the next frame after 3.5 characters delivers the previous one.
    let mut rx: Receiver<Rtu, 256> = Receiver::new(Rtu);
    for c in chars(&f, 0) {
        rx.handle_char(c);
    }
    assert_eq!(
        rx.handle_char(RxChar::new(0x01, us(5_000 + 4_000 + 1_000))),
        Some(RxEvent::Frame(5))
    );
    assert!(rx.is_receiving());

    // A bad check is rejected when the silence ends the frame.
    let mut rx: Receiver<Rtu, 256> = Receiver::new(Rtu);
    let mut bad = f.clone();
    bad[1] ^= 0x40;
    for c in chars(&bad, 0) {
        rx.handle_char(c);
    }
    assert_eq!(
        rx.handle_timeout(us(20_000)),
        Some(RxEvent::Rejected(TestError::BadCheck))
    );
}

/// Modbus ASCII's shape: `:` at any time (also inside a frame) starts one, CR LF ends it, no
/// silence needed, up to 1 s between characters.
#[derive(Debug, Clone, Copy)]
struct Ascii;

impl Framing for Ascii {
    type Frame = usize;
    type Error = TestError;
    fn timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: CHAR,
            start_gap: Duration::ZERO,
            max_gap: Duration::from_secs(1),
            end_silence: Duration::ZERO,
            ends_by_silence: false,
        }
    }
    fn start(&self, byte: u8) -> Start<TestError> {
        if byte == b':' {
            Start::Begin
        } else {
            Start::Ignore
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<TestError> {
        if frame.ends_with(b"\r\n") {
            Progress::Complete
        } else {
            Progress::More
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<usize, TestError> {
        Ok(frame.len())
    }
    fn restarts(&self, byte: u8) -> bool {
        byte == b':'
    }
}

#[test]
fn ascii_frames_restart_on_colon_and_end_at_crlf() {
    let mut rx: Receiver<Ascii, 513> = Receiver::new(Ascii);
    let mut events = Vec::new();
    let line = b"junk:0103:01030000000AF2\r\n";
    rx.handle_chars(&chars(line, 0).collect::<Vec<_>>(), |e| events.push(e));
    assert_eq!(
        events,
        [
            RxEvent::Rejected(TestError::Line(LineError::InterCharacterGap {
                received: 5
            })),
            RxEvent::Frame(17),
        ]
    );
    assert_eq!(rx.poll_timeout(), None, "accepted at once, nothing pending");
    // Characters 0.9 s apart are fine, 1 s breaks off.
    let mut rx: Receiver<Ascii, 513> = Receiver::new(Ascii);
    rx.handle_char(RxChar::new(b':', us(1_000)));
    assert_eq!(rx.handle_char(RxChar::new(b'0', us(901_000))), None);
    assert_eq!(
        rx.handle_timeout(us(901_000 + 1_000 + 1_000_000)),
        Some(RxEvent::Rejected(TestError::Line(
            LineError::InterCharacterGap { received: 2 }
        )))
    );
}

/// USS's shape: STX after 2 characters of silence, LGE = bytes after it, XOR check, accepted at
/// once.
#[derive(Debug, Clone, Copy)]
struct Uss;

impl Framing for Uss {
    type Frame = u8;
    type Error = TestError;
    fn timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: CHAR,
            start_gap: CHAR * 2,
            max_gap: CHAR * 2,
            end_silence: Duration::ZERO,
            ends_by_silence: false,
        }
    }
    fn start(&self, byte: u8) -> Start<TestError> {
        if byte == 0x02 {
            Start::Begin
        } else {
            Start::Reject(TestError::BadStart(byte))
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<TestError> {
        match frame.get(1) {
            Some(&lge) => Progress::Length(usize::from(lge) + 2),
            None => Progress::More,
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<u8, TestError> {
        match frame.split_last() {
            Some((bcc, body)) if xor(body) == *bcc => Ok(frame.get(2).copied().unwrap_or(0)),
            _ => Err(TestError::BadCheck),
        }
    }
}

#[test]
fn uss_length_byte_and_immediate_acceptance() {
    let mut rx: Receiver<Uss, 258> = Receiver::new(Uss);
    let mut f = vec![0x02, 4, 0x05, 0xAA, 0xBB];
    f.push(xor(&f));
    let mut events = Vec::new();
    rx.handle_chars(&chars(&f, 0).collect::<Vec<_>>(), |e| events.push(e));
    assert_eq!(events, [RxEvent::Frame(0x05)]);
    // The next STX needs two characters of silence: right after, it is ignored.
    assert_eq!(rx.handle_char(RxChar::new(0x02, us(7_000))), None);
    assert!(!rx.is_receiving());
}

fn arb_chars() -> impl Strategy<Value = Vec<(u8, u16, u8)>> {
    proptest::collection::vec((any::<u8>(), any::<u16>(), any::<u8>()), 0..200)
}

fn feed<F: Framing, const N: usize>(rx: &mut Receiver<F, N>, input: &[(u8, u16, u8)]) {
    let mut t = 0u64;
    for &(byte, gap, err) in input {
        t += 1_000 + u64::from(gap);
        let time = us(t);
        let c = match err {
            0 => RxChar::with_error(byte, time, CharError::Parity),
            1 => RxChar::with_error(byte, time, CharError::Framing),
            _ => RxChar::new(byte, time),
        };
        let _ = rx.handle_char(c);
        if let Some(at) = rx.poll_timeout() {
            assert!(at >= c.time);
            if gap % 7 == 0 {
                let _ = rx.handle_timeout(at);
            }
        }
    }
    let _ = rx.handle_timeout(Instant::MAX);
    assert!(!rx.is_receiving() || rx.poll_timeout().is_some());
}

proptest! {
    #[test]
    fn no_input_makes_any_receiver_panic(input in arb_chars()) {
        feed(&mut Receiver::<Headered, 16>::new(Headered { address: 7 }), &input);
        feed(&mut Receiver::<Rtu, 256>::new(Rtu), &input);
        feed(&mut Receiver::<Ascii, 513>::new(Ascii), &input);
        feed(&mut Receiver::<Uss, 258>::new(Uss), &input);
        feed(&mut Receiver::<Uss, 0>::new(Uss), &input);
    }
}

/// The events of `chars`, with every timeout due before a character handled first (as a
/// caller polling in time would) or with no timeouts at all until the end.
fn events_of<F: Framing, const N: usize>(
    rx: &mut Receiver<F, N>,
    chars: &[RxChar],
    poll_timeouts: bool,
) -> Vec<RxEvent<F::Frame, F::Error>> {
    let mut out = Vec::new();
    for c in chars {
        if poll_timeouts {
            while let Some(t) = rx.poll_timeout().filter(|t| *t <= c.time) {
                out.extend(rx.handle_timeout(t));
            }
        }
        out.extend(rx.handle_char(*c));
    }
    while let Some(t) = rx.poll_timeout() {
        out.extend(rx.handle_timeout(t));
    }
    out
}

#[test]
fn the_end_is_confirmed_the_same_with_or_without_polled_timeouts() {
    // Headered: last character complete at 5 ms, end silence 3 ms: the end is confirmed at
    // 8 ms. A character completing before that instant makes the frame too long; one
    // completing at or after it comes after the frame (and, after a full start pause from the
    // frame's end, is judged as a start character: 0x55 is not one).
    let trailing = RxEvent::Rejected(TestError::Line(LineError::TrailingCharacter { byte: 0x55 }));
    let frame = RxEvent::Frame((4, 1));
    let f = headered(&[1]);
    for (t, expected) in [
        (7_999, vec![trailing]),
        (8_000, vec![frame]),
        (8_500, vec![frame]),
        (
            9_000,
            vec![frame, RxEvent::Rejected(TestError::BadStart(0x55))],
        ),
    ] {
        let mut all: Vec<RxChar> = chars(&f, 0).collect();
        all.push(RxChar::new(0x55, us(t)));
        let new = || Receiver::<Headered, 16>::new(Headered { address: 7 });
        assert_eq!(
            events_of(&mut new(), &all, true),
            expected,
            "{t} µs, polled"
        );
        assert_eq!(
            events_of(&mut new(), &all, false),
            expected,
            "{t} µs, unpolled"
        );
    }
    // The same with a UART error on that character: the frame stands, then the error.
    let mut all: Vec<RxChar> = chars(&f, 0).collect();
    all.push(RxChar::with_error(0x02, us(9_000), CharError::Framing));
    let expected = vec![
        frame,
        RxEvent::Rejected(TestError::Line(LineError::Char(CharError::Framing))),
    ];
    let new = || Receiver::<Headered, 16>::new(Headered { address: 7 });
    assert_eq!(events_of(&mut new(), &all, true), expected);
    assert_eq!(events_of(&mut new(), &all, false), expected);

    // RTU: last character at 5 ms, confirmed 3.5 characters later (8.5 ms).
    let f = rtu(&[1, 3, 0, 10]);
    for (t, trailing) in [(8_499, true), (8_500, false), (8_700, false)] {
        let mut all: Vec<RxChar> = chars(&f, 0).collect();
        all.push(RxChar::new(0x11, us(t)));
        let expected = if trailing {
            RxEvent::Rejected(TestError::Line(LineError::TrailingCharacter { byte: 0x11 }))
        } else {
            RxEvent::Frame(5)
        };
        let new = || Receiver::<Rtu, 256>::new(Rtu);
        assert_eq!(
            events_of(&mut new(), &all, true),
            [expected],
            "{t} µs, polled"
        );
        assert_eq!(
            events_of(&mut new(), &all, false),
            [expected],
            "{t} µs, unpolled"
        );
    }
}
