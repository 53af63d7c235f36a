//! Encode, decode and the receiver with Modbus framing do not allocate: a counting global
//! allocator sees no allocation while they run (it counts the test thread's allocations only).

use bonfiglioli_modbus::frame::{Address, ExceptionCode, Request, Response, StartAddress};
use bonfiglioli_modbus::framing::{
    MAX_FRAME, ModbusFraming, Mode, Receiver, RxEvent, Side, decode_frame, encode_request,
    encode_response,
};
use bonfiglioli_modbus::pdu::MAX_PDU;
use drive_core::alloc_count::CountingAllocator;
use drive_core::{Instant, LineSettings, RxChar};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn nothing_allocates() {
    let a = Address::new(1).unwrap();
    let line = LineSettings::new(19200);
    let req = Request::WriteLong {
        start: StartAddress::from_raw(0x2177),
        value: 1000,
    };
    let resp = Response::Exception {
        function: 101,
        code: ExceptionCode::SLAVE_DEVICE_FAILURE,
    };
    let mut slave = [
        Receiver::new(ModbusFraming::new(Mode::Rtu, Side::Slave, &line)),
        Receiver::new(ModbusFraming::new(Mode::Ascii, Side::Slave, &line)),
    ];
    let mut master = [
        Receiver::new(ModbusFraming::new(Mode::Rtu, Side::Master, &line)),
        Receiver::new(ModbusFraming::new(Mode::Ascii, Side::Master, &line)),
    ];
    let before = CountingAllocator::count();

    let mut frames = 0usize;
    let mut t = 0u64;
    for (i, mode) in [Mode::Rtu, Mode::Ascii].into_iter().enumerate() {
        let mut wire = [0u8; MAX_FRAME];
        let mut pdu = [0u8; MAX_PDU];
        for (rx, is_request) in [(&mut slave[i], true), (&mut master[i], false)] {
            let n = if is_request {
                encode_request(mode, a, &req, &mut wire).unwrap()
            } else {
                encode_response(mode, a, &resp, &mut wire).unwrap()
            };
            assert_eq!(
                decode_frame(mode, &wire[..n], &mut pdu).map(|(a, _)| a),
                Ok(a)
            );
            for b in &wire[..n] {
                t += 600_000;
                if let Some(RxEvent::Frame(_)) =
                    rx.handle_char(RxChar::new(*b, Instant::from_nanos(t)))
                {
                    frames += 1;
                }
            }
            t += 10_000_000;
            while let Some(at) = rx.poll_timeout() {
                if let Some(RxEvent::Frame(_)) = rx.handle_timeout(at) {
                    frames += 1;
                }
            }
        }
    }

    let after = CountingAllocator::count();
    assert_eq!(frames, 4, "every frame received");
    assert_eq!(
        after - before,
        0,
        "allocations during encode/decode/receive"
    );
}
