//! Framing tests of `bonfiglioli-modbus`: the manual's vectors, the receiver's timing and
//! resynchronisation rules, the manual's errata, property tests. One test binary.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod errata;
mod props;
mod receiver;
mod vectors;

use bonfiglioli_modbus::frame::{Address, Request, Response};
use bonfiglioli_modbus::framing::{
    MAX_FRAME, ModbusFraming, Mode, Received, Receiver, RxEvent, Side, decode_frame,
    encode_request, encode_response,
};
use bonfiglioli_modbus::pdu::MAX_PDU;
use drive_core::{Instant, LineSettings, Parity, RxChar};

/// The line of the tests: the drive's default 19200 baud, even parity, in the mode's format.
pub fn line(mode: Mode) -> LineSettings {
    mode.line_settings(19200, Parity::Even)
}

/// Feed `wire` back to back (one character time apart) into a receiver of `mode` and `side`
/// from time `t0`, then let the line go quiet; every event.
pub fn receive(mode: Mode, side: Side, wire: &[u8]) -> Vec<RxEvent> {
    let line = line(mode);
    let mut rx = Receiver::new(ModbusFraming::new(mode, side, &line));
    let ct = line.char_time().as_nanos() as u64;
    let mut events = Vec::new();
    let mut t = 0;
    for b in wire {
        t += ct;
        events.extend(rx.handle_char(RxChar::new(*b, Instant::from_nanos(t))));
    }
    drain(&mut rx, &mut events);
    events
}

/// Let the line go quiet: handle every timeout the receiver asks for.
pub fn drain(rx: &mut Receiver, events: &mut Vec<RxEvent>) {
    for _ in 0..8 {
        let Some(at) = rx.poll_timeout() else { return };
        events.extend(rx.handle_timeout(at));
    }
    panic!("the receiver keeps asking for timeouts");
}

fn check_whole_frame(mode: Mode, wire: &[u8], address: Address) -> ([u8; MAX_PDU], usize) {
    let mut pdu = [0u8; MAX_PDU];
    let (a, n) = decode_frame(mode, wire, &mut pdu).expect("the vector decodes");
    assert_eq!(a, address, "address");
    if mode == Mode::Ascii {
        // Lower-case digits are accepted too.
        let lower: Vec<u8> = wire.iter().map(u8::to_ascii_lowercase).collect();
        let mut pdu2 = [0u8; MAX_PDU];
        assert_eq!(decode_frame(mode, &lower, &mut pdu2), Ok((a, n)));
        assert_eq!(pdu2[..n], pdu[..n]);
    }
    (pdu, n)
}

/// A request vector: encodes to `wire`, decodes whole, and the drive's receiver hands it out.
pub fn request(mode: Mode, wire: &[u8], address: u8, req: Request) {
    let a = Address::new(address).unwrap();
    let mut out = [0u8; MAX_FRAME];
    let n = encode_request(mode, a, &req, &mut out).unwrap();
    assert_eq!(&out[..n], wire, "encode");
    let (pdu, len) = check_whole_frame(mode, wire, a);
    assert_eq!(Request::decode(&pdu[..len]), Ok(req));
    assert_eq!(
        receive(mode, Side::Slave, wire),
        [RxEvent::Frame(Received::Request(a, Ok(req)))]
    );
}

/// A response vector: encodes to `wire`, decodes whole, and the master's receiver hands it out.
pub fn response(mode: Mode, wire: &[u8], address: u8, resp: Response) {
    let a = Address::new(address).unwrap();
    let mut out = [0u8; MAX_FRAME];
    let n = encode_response(mode, a, &resp, &mut out).unwrap();
    assert_eq!(&out[..n], wire, "encode");
    let (pdu, len) = check_whole_frame(mode, wire, a);
    assert_eq!(Response::decode(&pdu[..len]), Ok(resp));
    assert_eq!(
        receive(mode, Side::Master, wire),
        [RxEvent::Frame(Received::Response(a, resp))]
    );
}
