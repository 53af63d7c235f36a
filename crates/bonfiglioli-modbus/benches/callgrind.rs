//! Instruction-count harness for `valgrind --tool=callgrind`: runs one operation `n` times, so
//! that (count(n) − count(0)) / n is the cost of one operation, exactly and repeatably on a
//! noisy machine (docs/benchmarks.md).
//!
//! ```text
//! cargo bench -p bonfiglioli-modbus --bench callgrind --no-run
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null target/release/deps/callgrind-* OP N
//! ```
//!
//! OP is one of [`OPS`]. Run without an operation (as `cargo bench` does) it does nothing.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    missing_docs
)]

use std::hint::black_box;

use bonfiglioli_modbus::frame::{Address, Request, Response, StartAddress};
use bonfiglioli_modbus::framing::{self, MAX_FRAME, Mode};
use bonfiglioli_modbus::master::{MasterConfig, MasterEvent, ModbusMaster};
use bonfiglioli_modbus::pdu::MAX_PDU;
use bonfiglioli_modbus::rtu;
use bonfiglioli_modbus::slave::{Slave, SlaveConfig};
use drive_core::LineSettings;

#[path = "common/bus.rs"]
mod bus;

const OPS: &[&str] = &[
    "encode",
    "encode_modbus_core",
    "encode_rmodbus",
    "decode",
    "decode_rtu",
    "decode_modbus_core",
    "decode_rmodbus",
    "crc256",
    "crc256_modbus_core",
    "exchange",
];

const START: u16 = 0x2174;

fn main() {
    let mut args = std::env::args().skip(1);
    let op = args.next().unwrap_or_default();
    let Some(n) = args.next().and_then(|s| s.parse::<u64>().ok()) else {
        // `cargo bench` runs every bench binary with `--bench`: nothing to do.
        if !op.starts_with("--") {
            eprintln!("usage: callgrind OP N, OP one of {OPS:?}");
        }
        return;
    };
    let a = Address::new(1).unwrap();
    let req = Request::ReadWord {
        start: StartAddress::from_raw(START),
        count: 1,
    };
    let mut resp = [0u8; MAX_FRAME];
    let rn = framing::encode_response(Mode::Rtu, a, &Response::ReadWord { value: 1390 }, &mut resp)
        .unwrap();
    let resp = &resp[..rn];
    let mut data = [0u8; 256];
    for (i, b) in data.iter_mut().enumerate() {
        *b = (i as u8).wrapping_mul(151).wrapping_add(7);
    }
    let mut acc = 0u64;
    let mut out = [0u8; MAX_FRAME];
    match op.as_str() {
        "encode" => {
            for _ in 0..n {
                acc += framing::encode_request(Mode::Rtu, black_box(a), black_box(&req), &mut out)
                    .unwrap_or(0) as u64;
            }
        }
        "encode_modbus_core" => {
            for _ in 0..n {
                let adu = modbus_core::rtu::RequestAdu {
                    hdr: modbus_core::rtu::Header {
                        slave: black_box(1),
                    },
                    pdu: modbus_core::RequestPdu(modbus_core::Request::ReadHoldingRegisters(
                        black_box(START),
                        1,
                    )),
                };
                acc += modbus_core::rtu::client::encode_request(adu, &mut out).unwrap_or(0) as u64;
            }
        }
        "encode_rmodbus" => {
            let mut v = Vec::with_capacity(MAX_FRAME);
            for _ in 0..n {
                v.clear();
                let mut r =
                    rmodbus::client::ModbusRequest::new(black_box(1), rmodbus::ModbusProto::Rtu);
                let _ = r.generate_get_holdings(black_box(START), 1, &mut v);
                acc += v.len() as u64;
            }
        }
        "decode" => {
            for _ in 0..n {
                let mut pdu = [0u8; MAX_PDU];
                if let Ok((_, len)) = framing::decode_frame(Mode::Rtu, black_box(resp), &mut pdu)
                    && let Ok(Response::ReadWord { value }) = Response::decode(&pdu[..len])
                {
                    acc += u64::from(value);
                }
            }
        }
        "decode_rtu" => {
            for _ in 0..n {
                if let Ok((_, pdu)) = rtu::decode(black_box(resp))
                    && let Ok(Response::ReadWord { value }) = Response::decode(pdu)
                {
                    acc += u64::from(value);
                }
            }
        }
        "decode_modbus_core" => {
            for _ in 0..n {
                if let Ok(Some(adu)) = modbus_core::rtu::client::decode_response(black_box(resp))
                    && let Ok(modbus_core::Response::ReadHoldingRegisters(d)) = adu.pdu.0
                {
                    acc += u64::from(d.get(0).unwrap_or(0));
                }
            }
        }
        "decode_rmodbus" => {
            let mut r = rmodbus::client::ModbusRequest::new(1, rmodbus::ModbusProto::Rtu);
            let mut v = Vec::new();
            r.generate_get_holdings(START, 1, &mut v).unwrap();
            let mut vals: Vec<u16> = Vec::with_capacity(8);
            for _ in 0..n {
                vals.clear();
                let _ = r.parse_u16(black_box(resp), &mut vals);
                acc += u64::from(vals.first().copied().unwrap_or(0));
            }
        }
        "crc256" => {
            for _ in 0..n {
                acc += u64::from(rtu::crc(black_box(&data)));
            }
        }
        "crc256_modbus_core" => {
            for _ in 0..n {
                acc += u64::from(modbus_core::rtu::crc16(black_box(&data)));
            }
        }
        "exchange" => {
            let line = LineSettings::new(19200);
            let mut bus = bus::Bus::new(
                ModbusMaster::new(MasterConfig::new(Mode::Rtu, line)),
                Slave::new(
                    SlaveConfig::new(a, Mode::Rtu, line),
                    bus::Trivial::default(),
                ),
            );
            for _ in 0..n {
                let now = bus.now;
                let _ = bus.master.send((a, black_box(req)), now);
                bus.run(|e| {
                    if let MasterEvent::Response(Response::ReadWord { value }) = e {
                        acc += u64::from(value);
                    }
                });
                while bus.slave.poll_event().is_some() {}
            }
        }
        _ => panic!("unknown operation {op:?}: one of {OPS:?}"),
    }
    println!("{acc}");
}
