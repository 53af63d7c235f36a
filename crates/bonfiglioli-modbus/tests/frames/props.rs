//! Property tests: encode → receiver → the same frame, for both modes and sides; whole-frame
//! decoding and the receiver never panic, whatever arrives.

use bonfiglioli_modbus::frame::{
    Address, DiagSubFunction, ExceptionCode, Request, Response, StartAddress,
};
use bonfiglioli_modbus::framing::{
    MAX_FRAME, ModbusFraming, Mode, Received, Receiver, RxEvent, Side, decode_frame,
    encode_request, encode_response,
};
use bonfiglioli_modbus::pdu::MAX_PDU;
use bonfiglioli_modbus::rtu;
use drive_core::{CharError, Instant, RxChar};
use proptest::prelude::*;

use crate::{line, receive};

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![Just(Mode::Rtu), Just(Mode::Ascii)]
}

fn address() -> impl Strategy<Value = Address> {
    (0u8..=247).prop_map(|a| Address::new(a).unwrap())
}

fn request() -> impl Strategy<Value = Request> {
    let s = any::<u16>().prop_map(StartAddress::from_raw);
    prop_oneof![
        (s.clone(), any::<u16>()).prop_map(|(start, count)| Request::ReadWord { start, count }),
        (s.clone(), any::<u16>()).prop_map(|(start, value)| Request::WriteWord { start, value }),
        s.clone().prop_map(|start| Request::ReadLong { start }),
        (s, any::<u32>()).prop_map(|(start, value)| Request::WriteLong { start, value }),
        (any::<u16>(), any::<u16>()).prop_map(|(sub, data)| Request::Diagnostics {
            sub: DiagSubFunction(sub),
            data
        }),
    ]
}

fn response() -> impl Strategy<Value = Response> {
    let s = any::<u16>().prop_map(StartAddress::from_raw);
    prop_oneof![
        any::<u16>().prop_map(|value| Response::ReadWord { value }),
        (s.clone(), any::<u16>()).prop_map(|(start, value)| Response::WriteWord { start, value }),
        any::<u32>().prop_map(|value| Response::ReadLong { value }),
        (s, any::<u32>()).prop_map(|(start, value)| Response::WriteLong { start, value }),
        (any::<u16>(), any::<u16>()).prop_map(|(sub, data)| Response::Diagnostics {
            sub: DiagSubFunction(sub),
            data
        }),
        (0u8..0x80, any::<u8>()).prop_map(|(function, code)| Response::Exception {
            function,
            code: ExceptionCode(code)
        }),
    ]
}

/// Characters as (byte, gap code, UART status): gap code × 1/8 character time of idle line
/// before the character (0 to 32 characters), status 0 = parity error, 1 = framing error,
/// else none.
fn arb_chars() -> impl Strategy<Value = Vec<(u8, u8, u8)>> {
    proptest::collection::vec((any::<u8>(), any::<u8>(), 0u8..16), 0..600)
}

proptest! {
    #[test]
    fn requests_round_trip(mode in mode(), a in address(), req in request()) {
        let mut wire = [0u8; MAX_FRAME];
        let n = encode_request(mode, a, &req, &mut wire).unwrap();
        let mut pdu = [0u8; MAX_PDU];
        let (back, len) = decode_frame(mode, &wire[..n], &mut pdu).unwrap();
        prop_assert_eq!(back, a);
        prop_assert_eq!(Request::decode(&pdu[..len]), Ok(req));
        prop_assert_eq!(
            receive(mode, Side::Slave, &wire[..n]),
            vec![RxEvent::Frame(Received::Request(a, Ok(req)))]
        );
    }

    #[test]
    fn responses_round_trip(mode in mode(), a in address(), resp in response()) {
        let mut wire = [0u8; MAX_FRAME];
        let n = encode_response(mode, a, &resp, &mut wire).unwrap();
        let mut pdu = [0u8; MAX_PDU];
        let (back, len) = decode_frame(mode, &wire[..n], &mut pdu).unwrap();
        prop_assert_eq!(back, a);
        prop_assert_eq!(Response::decode(&pdu[..len]), Ok(resp));
        prop_assert_eq!(
            receive(mode, Side::Master, &wire[..n]),
            vec![RxEvent::Frame(Received::Response(a, resp))]
        );
    }

    #[test]
    fn any_pdu_round_trips_through_both_modes(
        a in address(),
        pdu in proptest::collection::vec(any::<u8>(), 1..=MAX_PDU),
    ) {
        for mode in [Mode::Rtu, Mode::Ascii] {
            let mut wire = [0u8; MAX_FRAME];
            let n = match mode {
                Mode::Rtu => rtu::encode(a, &pdu, &mut wire).unwrap(),
                Mode::Ascii => bonfiglioli_modbus::ascii::encode(a, &pdu, &mut wire).unwrap(),
            };
            prop_assert!(n <= mode.max_frame());
            let mut out = [0u8; MAX_PDU];
            prop_assert_eq!(decode_frame(mode, &wire[..n], &mut out), Ok((a, pdu.len())));
            prop_assert_eq!(&out[..pdu.len()], &pdu[..]);
        }
    }

    #[test]
    fn decode_frame_never_panics_and_what_it_accepts_is_a_frame(
        bytes in proptest::collection::vec(any::<u8>(), 0..700),
    ) {
        let mut pdu = [0u8; MAX_PDU];
        if let Ok((a, n)) = decode_frame(Mode::Rtu, &bytes, &mut pdu) {
            let mut wire = [0u8; MAX_FRAME];
            let m = rtu::encode(a, &pdu[..n], &mut wire).unwrap();
            prop_assert_eq!(&wire[..m], &bytes[..]);
        }
        let _ = decode_frame(Mode::Ascii, &bytes, &mut pdu);
        // As an ASCII frame made of hex digits.
        let mut text = vec![b':'];
        text.extend(bytes.iter().map(|b| b"0123456789ABCDEFabcdef\r\n:"[usize::from(*b) % 25]));
        let _ = decode_frame(Mode::Ascii, &text, &mut pdu);
    }

    #[test]
    fn no_input_makes_the_receiver_panic(chars in arb_chars(), hexish in any::<bool>()) {
        for mode in [Mode::Rtu, Mode::Ascii] {
            for side in [Side::Master, Side::Slave] {
                let l = line(mode);
                let mut rx = Receiver::new(ModbusFraming::new(mode, side, &l));
                let ct = l.char_time().as_nanos() as u64;
                let mut t = 0u64;
                for &(b, gap, status) in &chars {
                    let b = if hexish { b":0123456789ABCDEF\r\n"[usize::from(b) % 19] } else { b };
                    t += ct + u64::from(gap) * ct / 8;
                    let time = Instant::from_nanos(t);
                    let c = match status {
                        0 => RxChar::with_error(b, time, CharError::Parity),
                        1 => RxChar::with_error(b, time, CharError::Framing),
                        _ => RxChar::new(b, time),
                    };
                    let _ = rx.handle_char(c);
                    if let Some(at) = rx.poll_timeout().filter(|at| *at <= time) {
                        let _ = rx.handle_timeout(at);
                    }
                }
                let _ = rx.handle_timeout(Instant::MAX);
            }
        }
    }
}
