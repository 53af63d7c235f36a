//! The receiver with Modbus framing: RTU's silences (t1.5 ends a frame, t3.5 confirms it and
//! separates frames), ASCII's `:` … CR LF with the one-second gap, errors and
//! resynchronisation. Times are nanoseconds on a manual clock.

use bonfiglioli_modbus::frame::{Address, ExceptionCode, Request, Response, StartAddress};
use bonfiglioli_modbus::framing::{
    FrameError, MAX_FRAME, ModbusFraming, Mode, Received, Receiver, RxEvent, Side, encode_request,
};
use bonfiglioli_modbus::pdu::PduError;
use bonfiglioli_modbus::rtu;
use drive_core::{CharError, Instant, LineError, LineSettings, RxChar};

use crate::{drain, line, receive};

/// Ch. 8.1.1, example 1, request.
const READ: [u8; 8] = [0x01, 0x03, 0x21, 0x74, 0x00, 0x01, 0xCE, 0x2C];

fn read_request() -> RxEvent {
    RxEvent::Frame(Received::Request(
        Address::new(1).unwrap(),
        Ok(Request::ReadWord {
            start: StartAddress::from_raw(0x2174),
            count: 1,
        }),
    ))
}

/// Feed `chars` as (byte, idle gap before it in ns) on `line`; every event, then drained.
fn feed(mode: Mode, side: Side, line: &LineSettings, chars: &[(u8, u64)]) -> Vec<RxEvent> {
    let mut rx = Receiver::new(ModbusFraming::new(mode, side, line));
    let ct = line.char_time().as_nanos() as u64;
    let mut t = 10_000_000_000; // a long idle line before
    let mut events = Vec::new();
    for &(b, gap) in chars {
        t += gap + ct;
        events.extend(rx.handle_char(RxChar::new(b, Instant::from_nanos(t))));
    }
    drain(&mut rx, &mut events);
    events
}

/// `bytes` back to back, with `gap` before byte `at`.
fn with_gap(bytes: &[u8], at: usize, gap: u64) -> Vec<(u8, u64)> {
    bytes
        .iter()
        .enumerate()
        .map(|(i, b)| (*b, if i == at { gap } else { 0 }))
        .collect()
}

fn nanos(d: core::time::Duration) -> u64 {
    d.as_nanos() as u64
}

#[test]
fn rtu_a_gap_of_up_to_1_5_characters_stays_inside_the_frame() {
    let l = line(Mode::Rtu);
    let t15 = nanos(rtu::t15(&l));
    let ev = feed(Mode::Rtu, Side::Slave, &l, &with_gap(&READ, 4, t15));
    assert_eq!(ev, [read_request()]);
}

#[test]
fn rtu_a_gap_of_more_than_1_5_characters_discards_the_frame() {
    let l = line(Mode::Rtu);
    let t15 = nanos(rtu::t15(&l));
    // The first four bytes end by the silence (a bad CRC), the rest is ignored: it does not
    // follow t3.5 of idle line.
    let ev = feed(Mode::Rtu, Side::Slave, &l, &with_gap(&READ, 4, t15 + 1));
    assert_eq!(
        ev,
        [RxEvent::Rejected(FrameError::Checksum {
            expected: rtu::crc(&READ[..2]),
            got: 0x7421
        })]
    );
}

#[test]
fn rtu_a_character_within_t3_5_after_a_complete_frame_discards_it() {
    // A valid frame and one more character after a gap of 2 characters (more than t1.5, so
    // the frame ended, less than t3.5): the Modbus rule "more than 1.5 characters inside a
    // frame" discards it; drive-core reports the trailing character.
    let l = line(Mode::Rtu);
    let ct = nanos(l.char_time());
    let mut chars = with_gap(&READ, usize::MAX, 0);
    chars.push((0x00, 2 * ct));
    let ev = feed(Mode::Rtu, Side::Slave, &l, &chars);
    assert_eq!(
        ev,
        [RxEvent::Rejected(FrameError::Line(
            LineError::TrailingCharacter { byte: 0 }
        ))]
    );
    // Up to just below 2.5 characters (the character completes before the t3.5 timer runs
    // out) the same.
    let mut chars = with_gap(&READ, usize::MAX, 0);
    chars.push((0x00, nanos(rtu::t35(&l)) - ct - 1));
    assert!(matches!(
        feed(Mode::Rtu, Side::Slave, &l, &chars)[..],
        [RxEvent::Rejected(FrameError::Line(
            LineError::TrailingCharacter { .. }
        ))]
    ));
}

#[test]
fn rtu_a_character_completing_after_t3_5_leaves_the_frame_standing_but_starts_nothing() {
    // Gap 2.5 to 3.5 characters: the t3.5 timer ran out before the character was complete,
    // so the frame stands; the character had less than t3.5 of idle line before it, so it
    // does not start a frame, nor does the rest of a frame it begins.
    let l = line(Mode::Rtu);
    let ct = nanos(l.char_time());
    let mut chars = with_gap(&READ, usize::MAX, 0);
    chars.extend(with_gap(&READ, 0, nanos(rtu::t35(&l)) - ct));
    assert_eq!(feed(Mode::Rtu, Side::Slave, &l, &chars), [read_request()]);
}

#[test]
fn rtu_frames_separated_by_t3_5_are_both_received() {
    let l = line(Mode::Rtu);
    let mut chars = with_gap(&READ, usize::MAX, 0);
    chars.extend(with_gap(&READ, 0, nanos(rtu::t35(&l))));
    assert_eq!(
        feed(Mode::Rtu, Side::Slave, &l, &chars),
        [read_request(), read_request()]
    );
}

#[test]
fn rtu_above_19200_baud_the_fixed_times_apply() {
    // 115200 8E1: a character is 95.5 µs, 1.5 characters 143 µs; the gap limit is 750 µs.
    let l = Mode::Rtu.line_settings(115_200, drive_core::Parity::Even);
    let ev = feed(Mode::Rtu, Side::Slave, &l, &with_gap(&READ, 4, 750_000));
    assert_eq!(ev, [read_request()]);
    let ev = feed(Mode::Rtu, Side::Slave, &l, &with_gap(&READ, 4, 750_001));
    assert!(matches!(
        ev[..],
        [RxEvent::Rejected(FrameError::Checksum { .. })]
    ));
    // The frame is confirmed 1.75 ms after its last character.
    let mut rx = Receiver::new(ModbusFraming::new(Mode::Rtu, Side::Slave, &l));
    let ct = nanos(l.char_time());
    for (i, b) in READ.iter().enumerate() {
        assert_eq!(
            rx.handle_char(RxChar::new(*b, Instant::from_nanos(ct * (i as u64 + 1)))),
            None
        );
    }
    let last = Instant::from_nanos(ct * 8);
    assert_eq!(rx.poll_timeout(), Some(last.add_nanos(ct + 750_001)));
    assert_eq!(rx.handle_timeout(last.add_nanos(ct + 750_001)), None);
    assert_eq!(rx.poll_timeout(), Some(last.add_nanos(1_750_000)));
    assert_eq!(rx.handle_timeout(last.add_nanos(1_749_999)), None);
    assert_eq!(
        rx.handle_timeout(last.add_nanos(1_750_000)),
        Some(read_request())
    );
}

#[test]
fn rtu_uart_errors_short_long_and_reserved_frames_are_rejected() {
    let l = line(Mode::Rtu);
    let mut rx = Receiver::new(ModbusFraming::new(Mode::Rtu, Side::Slave, &l));
    let ct = nanos(l.char_time());
    let mut events = Vec::new();
    for (i, b) in READ.iter().enumerate() {
        let t = Instant::from_nanos(ct * (i as u64 + 1));
        let c = if i == 3 {
            RxChar::with_error(*b, t, CharError::Parity)
        } else {
            RxChar::new(*b, t)
        };
        events.extend(rx.handle_char(c));
    }
    drain(&mut rx, &mut events);
    assert_eq!(
        events,
        [RxEvent::Rejected(FrameError::Line(LineError::Char(
            CharError::Parity
        )))]
    );
    assert_eq!(
        receive(Mode::Rtu, Side::Slave, &[0x01, 0x03, 0x21]),
        [RxEvent::Rejected(FrameError::TooShort(3))]
    );
    assert_eq!(
        receive(Mode::Rtu, Side::Slave, &[0x55; 300]),
        [RxEvent::Rejected(FrameError::Line(LineError::TooLong {
            capacity: 256
        }))]
    );
    let mut reserved = [0xF8, 0x03, 0, 0];
    let c = rtu::crc(&reserved[..2]).to_le_bytes();
    reserved[2..].copy_from_slice(&c);
    assert_eq!(
        receive(Mode::Rtu, Side::Master, &reserved),
        [RxEvent::Rejected(FrameError::ReservedAddress(0xF8))]
    );
}

#[test]
fn pdus_that_do_not_decode_go_to_the_drive_but_not_to_the_master() {
    // An unknown function code 0x10 to drive 1, correctly framed.
    let a = Address::new(1).unwrap();
    for mode in [Mode::Rtu, Mode::Ascii] {
        let mut out = [0u8; MAX_FRAME];
        let n = match mode {
            Mode::Rtu => rtu::encode(a, &[0x10, 0, 0], &mut out).unwrap(),
            Mode::Ascii => bonfiglioli_modbus::ascii::encode(a, &[0x10, 0, 0], &mut out).unwrap(),
        };
        assert_eq!(
            receive(mode, Side::Slave, &out[..n]),
            [RxEvent::Frame(Received::Request(
                a,
                Err(PduError::UnknownFunction(0x10))
            ))]
        );
        assert_eq!(
            receive(mode, Side::Master, &out[..n]),
            [RxEvent::Rejected(FrameError::Pdu(
                PduError::UnknownFunction(0x10)
            ))]
        );
        // The master sees a request as a response that does not decode (byte count 0x21).
        let n = encode_request(
            mode,
            a,
            &Request::ReadWord {
                start: StartAddress::from_raw(0x2174),
                count: 1,
            },
            &mut out,
        )
        .unwrap();
        assert_eq!(
            receive(mode, Side::Master, &out[..n]),
            [RxEvent::Rejected(FrameError::Pdu(PduError::ByteCount(
                0x21
            )))]
        );
    }
}

const ASCII_EXC: &[u8] = b":0183027A\r\n";

fn ascii_exception() -> RxEvent {
    RxEvent::Frame(Received::Response(
        Address::new(1).unwrap(),
        Response::Exception {
            function: 3,
            code: ExceptionCode::ILLEGAL_DATA_ADDRESS,
        },
    ))
}

#[test]
fn ascii_up_to_one_second_between_characters() {
    let l = line(Mode::Ascii);
    let ev = feed(
        Mode::Ascii,
        Side::Master,
        &l,
        &with_gap(ASCII_EXC, 5, 1_000_000_000),
    );
    assert_eq!(ev, [ascii_exception()]);
    let ev = feed(
        Mode::Ascii,
        Side::Master,
        &l,
        &with_gap(ASCII_EXC, 5, 1_000_000_001),
    );
    assert_eq!(
        ev,
        [RxEvent::Rejected(FrameError::Line(
            LineError::InterCharacterGap { received: 5 }
        ))]
    );
    // A longer time-out can be set.
    let framing = ModbusFraming::new(Mode::Ascii, Side::Master, &l)
        .with_ascii_max_gap(core::time::Duration::from_secs(5));
    let mut rx = Receiver::new(framing);
    let mut t = 0;
    let mut events = Vec::new();
    for b in ASCII_EXC {
        t += 2_000_000_000;
        events.extend(rx.handle_char(RxChar::new(*b, Instant::from_nanos(t))));
    }
    assert_eq!(events, [ascii_exception()]);
}

#[test]
fn ascii_a_colon_restarts_and_noise_between_frames_is_ignored() {
    // Noise, a partial frame, a new ':' inside it, a whole frame, more noise.
    let mut wire = b"xy\r\n:0103".to_vec();
    wire.extend_from_slice(ASCII_EXC);
    wire.extend_from_slice(b"zz");
    assert_eq!(
        receive(Mode::Ascii, Side::Master, &wire),
        [
            RxEvent::Rejected(FrameError::Line(LineError::InterCharacterGap {
                received: 5
            })),
            ascii_exception()
        ]
    );
    // Lower case is accepted; the frame is complete at its LF, with no silence after it.
    let mut rx = Receiver::new(ModbusFraming::new(
        Mode::Ascii,
        Side::Master,
        &line(Mode::Ascii),
    ));
    let mut last = None;
    for (i, b) in b":0183027a\r\n".iter().enumerate() {
        last = rx.handle_char(RxChar::new(*b, Instant::from_micros(1000 * (i as u64 + 1))));
    }
    assert_eq!(last, Some(ascii_exception()));
    assert_eq!(rx.poll_timeout(), None);
}

#[test]
fn ascii_bad_characters_and_bad_ends_drop_the_frame_until_the_next_colon() {
    let cases: [(&[u8], FrameError); 5] = [
        (b":01G3", FrameError::BadHex),
        (b":0183 027A\r\n", FrameError::BadHex),
        (b":0183027A\rX", FrameError::NoEnd),
        (b":0183027A\n", FrameError::NoEnd),
        (b":0183027A\r\r", FrameError::NoEnd),
    ];
    for (bad, err) in cases {
        let mut wire = bad.to_vec();
        wire.extend_from_slice(b"0183027A\r\n"); // no ':' here: ignored
        wire.extend_from_slice(ASCII_EXC);
        assert_eq!(
            receive(Mode::Ascii, Side::Master, &wire),
            [RxEvent::Rejected(err), ascii_exception()],
            "{:?}",
            String::from_utf8_lossy(bad)
        );
    }
    assert_eq!(
        receive(Mode::Ascii, Side::Master, b":0183027B\r\n"),
        [RxEvent::Rejected(FrameError::Checksum {
            expected: 0x7A,
            got: 0x7B
        })]
    );
    assert_eq!(
        receive(Mode::Ascii, Side::Master, b":01\r\n"),
        [RxEvent::Rejected(FrameError::TooShort(5))]
    );
    let mut long = vec![b':'];
    long.extend(std::iter::repeat_n(b'0', 600));
    assert_eq!(
        receive(Mode::Ascii, Side::Master, &long),
        [RxEvent::Rejected(FrameError::Line(LineError::TooLong {
            capacity: 513
        })),]
    );
}
