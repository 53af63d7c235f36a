//! No allocation per frame: encode, decode, the receiver and whole master ↔ drive exchanges in
//! memory (RTU and ASCII, every function code) run while a counting global allocator sees
//! nothing (it counts the test thread's allocations only).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use bonfiglioli_modbus::frame::{
    Address, DataSet, DiagSubFunction, Request, Response, StartAddress,
};
use bonfiglioli_modbus::framing::{
    self, MAX_FRAME, ModbusFraming, Mode, Received, Receiver, RxEvent, Side,
};
use bonfiglioli_modbus::master::{MasterConfig, MasterEvent, ModbusMaster};
use bonfiglioli_modbus::pdu::MAX_PDU;
use bonfiglioli_modbus::slave::{Slave, SlaveConfig, Width};
use drive_core::alloc_count::CountingAllocator;
use drive_core::{Instant, LineSettings, RxChar};

#[path = "../benches/common/bus.rs"]
mod bus;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn allocations() -> usize {
    CountingAllocator::count()
}

#[test]
fn encode_decode_receiver_and_exchanges_allocate_nothing() {
    let a = Address::new(1).unwrap();
    let line = LineSettings::new(19200);
    let start = StartAddress::new(DataSet::new(2).unwrap(), 372).unwrap();
    let requests = [
        Request::ReadWord { start, count: 1 },
        Request::WriteWord { start, value: 1390 },
        Request::ReadLong { start },
        Request::WriteLong {
            start,
            value: 0x0102_0304,
        },
        Request::Diagnostics {
            sub: DiagSubFunction::BUS_MESSAGES,
            data: 0,
        },
    ];
    // Everything is set up (and the buses built) before counting starts.
    let mut buses = [Mode::Rtu, Mode::Ascii].map(|mode| {
        bus::Bus::new(
            ModbusMaster::new(MasterConfig::new(mode, line)),
            Slave::new(SlaveConfig::new(a, mode, line), bus::Trivial::default()),
        )
    });
    let mut receivers =
        [Mode::Rtu, Mode::Ascii].map(|m| Receiver::new(ModbusFraming::new(m, Side::Slave, &line)));
    let char_ns = line.char_time().as_nanos() as u64;

    // The allocator counts (else the assertion below could not fail).
    let probe = allocations();
    drop(std::hint::black_box(Box::new(1u64)));
    assert!(allocations() > probe);

    let before = allocations();
    let mut frames = 0usize;
    let mut answers = 0usize;
    for (mode, rx) in [Mode::Rtu, Mode::Ascii].into_iter().zip(&mut receivers) {
        for (i, req) in requests.iter().enumerate() {
            // Whole-frame encode and decode.
            let mut wire = [0u8; MAX_FRAME];
            let n = framing::encode_request(mode, a, req, &mut wire).unwrap();
            let mut pdu = [0u8; MAX_PDU];
            let (addr, len) = framing::decode_frame(mode, &wire[..n], &mut pdu).unwrap();
            assert_eq!((addr, Request::decode(&pdu[..len])), (a, Ok(*req)));
            let resp = Response::ReadLong { value: i as u32 };
            let m = framing::encode_response(mode, a, &resp, &mut wire[n..]).unwrap();
            let (_, len) = framing::decode_frame(mode, &wire[n..n + m], &mut pdu).unwrap();
            assert_eq!(Response::decode(&pdu[..len]), Ok(resp));

            // The character receiver, one frame a second.
            let t0 = Instant::from_secs(i as u64 + 1);
            let mut got = None;
            for (k, b) in wire[..n].iter().enumerate() {
                let at = t0.add_nanos(char_ns * (k as u64 + 1));
                if let Some(ev) = rx.handle_char(RxChar::new(*b, at)) {
                    got = Some(ev);
                }
            }
            while got.is_none() {
                let Some(at) = rx.poll_timeout() else { break };
                got = rx.handle_timeout(at);
            }
            assert_eq!(got, Some(RxEvent::Frame(Received::Request(a, Ok(*req)))));
            frames += 1;
        }
    }

    // Whole exchanges, master ↔ drive, in both modes.
    for bus in &mut buses {
        for _ in 0..20 {
            for req in requests {
                let now = bus.now;
                bus.master.send((a, req), now).unwrap();
                let mut response = None;
                assert!(bus.run(|e| {
                    if let MasterEvent::Response(r) = e {
                        response = Some(r);
                    }
                }));
                while bus.slave.poll_event().is_some() {}
                let ok = match (req, response) {
                    (Request::ReadWord { .. }, Some(Response::ReadWord { value })) => {
                        u32::from(value) == bus.slave.backend().value(start, Width::Word)
                    }
                    (Request::ReadLong { .. }, Some(Response::ReadLong { value })) => {
                        value == bus.slave.backend().value(start, Width::Long)
                    }
                    (Request::WriteWord { .. }, Some(Response::WriteWord { .. }))
                    | (Request::WriteLong { .. }, Some(Response::WriteLong { .. }))
                    | (Request::Diagnostics { .. }, Some(Response::Diagnostics { .. })) => true,
                    _ => false,
                };
                assert!(ok, "{req:?} answered {response:?}");
                answers += 1;
            }
        }
    }
    let after = allocations();

    assert_eq!((frames, answers), (10, 200));
    assert_eq!(
        after - before,
        0,
        "allocations during encode/decode/receiver/exchanges"
    );
}
