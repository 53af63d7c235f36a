//! Codec and state machine benchmarks, with the peers in the same group so that the ratios
//! come from one run (docs/benchmarks.md):
//!
//! * `modbus_rtu_encode_fc3`: the RTU frame of an FC 3 read request (address 1, start 0x2174,
//!   one register: `01 03 21 74 00 01 CE 2C`, the manual's ch. 8.1.1) by bonfiglioli-modbus,
//!   `modbus-core` and `rmodbus`;
//! * `modbus_rtu_decode_fc3`: its answer (`01 03 02 05 6E` + CRC: the value 1390) checked and
//!   decoded to the value by each;
//! * `crc16_256`: CRC-16/MODBUS over 256 bytes: ours (`rtu::crc`), the crc crate's three table
//!   variants, modbus-core's (bitwise); throughput in bytes;
//! * `modbus_ascii`: the same request encoded and the answer decoded in ASCII;
//! * `modbus_exchange`: the sans-IO master and a drive exchanging an FC 3 read character by
//!   character in memory, with wire timestamps (`benches/bus.rs`; target ≥ 1 000 000 reads/s).

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
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
use bonfiglioli_modbus::slave::{Slave, SlaveConfig};
use bonfiglioli_modbus::{ascii, rtu};
use crc::{CRC_16_MODBUS, Crc, Table};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use drive_core::LineSettings;

#[path = "common/bus.rs"]
mod bus;

const START: u16 = 0x2174;
const VALUE: u16 = 1390;

fn addr() -> Address {
    Address::new(1).unwrap()
}

fn request() -> Request {
    Request::ReadWord {
        start: StartAddress::from_raw(START),
        count: 1,
    }
}

/// The RTU answer frame of the FC 3 read.
fn rtu_response() -> ([u8; MAX_FRAME], usize) {
    let mut frame = [0u8; MAX_FRAME];
    let n = framing::encode_response(
        Mode::Rtu,
        addr(),
        &Response::ReadWord { value: VALUE },
        &mut frame,
    )
    .unwrap();
    assert_eq!((n, &frame[..5]), (7, &[0x01, 0x03, 0x02, 0x05, 0x6E][..]));
    (frame, n)
}

fn rtu_encode(c: &mut Criterion) {
    let mut g = c.benchmark_group("modbus_rtu_encode_fc3");
    g.throughput(Throughput::Elements(1));
    let req = request();
    let expected = [0x01, 0x03, 0x21, 0x74, 0x00, 0x01, 0xCE, 0x2C];

    let mut out = [0u8; MAX_FRAME];
    let n = framing::encode_request(Mode::Rtu, addr(), &req, &mut out).unwrap();
    assert_eq!(out[..n], expected);
    g.bench_function("bonfiglioli_modbus", |b| {
        let mut out = [0u8; MAX_FRAME];
        b.iter(|| {
            framing::encode_request(Mode::Rtu, black_box(addr()), black_box(&req), &mut out)
                .unwrap_or(0)
        })
    });

    let mc = |slave: u8, start: u16| modbus_core::rtu::RequestAdu {
        hdr: modbus_core::rtu::Header { slave },
        pdu: modbus_core::RequestPdu(modbus_core::Request::ReadHoldingRegisters(start, 1)),
    };
    let n = modbus_core::rtu::client::encode_request(mc(1, START), &mut out).unwrap();
    assert_eq!(out[..n], expected);
    g.bench_function("modbus_core", |b| {
        let mut out = [0u8; MAX_FRAME];
        b.iter(|| {
            modbus_core::rtu::client::encode_request(mc(black_box(1), black_box(START)), &mut out)
                .unwrap_or(0)
        })
    });

    // rmodbus writes into a `Vec` it is handed (cleared and reused: no allocation per frame
    // once it has grown).
    let mut v = Vec::with_capacity(MAX_FRAME);
    let mut r = rmodbus::client::ModbusRequest::new(1, rmodbus::ModbusProto::Rtu);
    r.generate_get_holdings(START, 1, &mut v).unwrap();
    assert_eq!(v[..], expected);
    g.bench_function("rmodbus", |b| {
        b.iter(|| {
            v.clear();
            let mut r =
                rmodbus::client::ModbusRequest::new(black_box(1), rmodbus::ModbusProto::Rtu);
            let _ = r.generate_get_holdings(black_box(START), 1, &mut v);
            v.len()
        })
    });
    g.finish();
}

fn rtu_decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("modbus_rtu_decode_fc3");
    g.throughput(Throughput::Elements(1));
    let (frame, n) = rtu_response();
    let frame = &frame[..n];

    // The whole-frame API (copies the PDU out, as the receiver does).
    let ours = |f: &[u8]| -> Option<u16> {
        let mut pdu = [0u8; MAX_PDU];
        let (_, len) = framing::decode_frame(Mode::Rtu, f, &mut pdu).ok()?;
        match Response::decode(pdu.get(..len)?) {
            Ok(Response::ReadWord { value }) => Some(value),
            _ => None,
        }
    };
    assert_eq!(ours(frame), Some(VALUE));
    g.bench_function("bonfiglioli_modbus", |b| b.iter(|| ours(black_box(frame))));

    // The RTU layer's zero-copy split, then the PDU.
    let ours_rtu = |f: &[u8]| -> Option<u16> {
        let (_, pdu) = rtu::decode(f).ok()?;
        match Response::decode(pdu) {
            Ok(Response::ReadWord { value }) => Some(value),
            _ => None,
        }
    };
    assert_eq!(ours_rtu(frame), Some(VALUE));
    g.bench_function("bonfiglioli_modbus_rtu", |b| {
        b.iter(|| ours_rtu(black_box(frame)))
    });

    let mc = |f: &[u8]| -> Option<u16> {
        let adu = modbus_core::rtu::client::decode_response(f).ok()??;
        match adu.pdu.0 {
            Ok(modbus_core::Response::ReadHoldingRegisters(data)) => data.get(0),
            _ => None,
        }
    };
    assert_eq!(mc(frame), Some(VALUE));
    g.bench_function("modbus_core", |b| b.iter(|| mc(black_box(frame))));

    let mut req = rmodbus::client::ModbusRequest::new(1, rmodbus::ModbusProto::Rtu);
    let mut v = Vec::new();
    req.generate_get_holdings(START, 1, &mut v).unwrap();
    let mut out: Vec<u16> = Vec::with_capacity(8);
    req.parse_u16(frame, &mut out).unwrap();
    assert_eq!(out, [VALUE]);
    g.bench_function("rmodbus", |b| {
        b.iter(|| {
            out.clear();
            let _ = req.parse_u16(black_box(frame), &mut out);
            out.first().copied()
        })
    });
    g.finish();
}

static CRC_TABLE0: Crc<u16, Table<0>> = Crc::<u16, Table<0>>::new(&CRC_16_MODBUS);
static CRC_TABLE1: Crc<u16, Table<1>> = Crc::<u16, Table<1>>::new(&CRC_16_MODBUS);
static CRC_TABLE16: Crc<u16, Table<16>> = Crc::<u16, Table<16>>::new(&CRC_16_MODBUS);

fn crc16(c: &mut Criterion) {
    let mut g = c.benchmark_group("crc16_256");
    let mut data = [0u8; 256];
    let mut x = 0x1234_5678u32;
    for b in &mut data {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
        *b = (x >> 24) as u8;
    }
    let want = rtu::crc(&data);
    assert_eq!(CRC_TABLE0.checksum(&data), want);
    assert_eq!(CRC_TABLE1.checksum(&data), want);
    assert_eq!(CRC_TABLE16.checksum(&data), want);
    assert_eq!(modbus_core::rtu::crc16(&data).swap_bytes(), want);
    g.throughput(Throughput::Bytes(data.len() as u64));
    g.bench_function("bonfiglioli_modbus", |b| {
        b.iter(|| rtu::crc(black_box(&data)))
    });
    g.bench_function("crc_table16", |b| {
        b.iter(|| CRC_TABLE16.checksum(black_box(&data)))
    });
    g.bench_function("crc_table1", |b| {
        b.iter(|| CRC_TABLE1.checksum(black_box(&data)))
    });
    g.bench_function("crc_notable", |b| {
        b.iter(|| CRC_TABLE0.checksum(black_box(&data)))
    });
    g.bench_function("modbus_core", |b| {
        b.iter(|| modbus_core::rtu::crc16(black_box(&data)))
    });
    g.finish();
}

fn ascii_codec(c: &mut Criterion) {
    let mut g = c.benchmark_group("modbus_ascii");
    g.throughput(Throughput::Elements(1));
    let req = request();
    let mut out = [0u8; MAX_FRAME];
    let n = framing::encode_request(Mode::Ascii, addr(), &req, &mut out).unwrap();
    assert_eq!(&out[..n], b":01032174000166\r\n");
    g.bench_function("encode_fc3_request", |b| {
        let mut out = [0u8; MAX_FRAME];
        b.iter(|| {
            framing::encode_request(Mode::Ascii, black_box(addr()), black_box(&req), &mut out)
                .unwrap_or(0)
        })
    });
    let n = framing::encode_response(
        Mode::Ascii,
        addr(),
        &Response::ReadWord { value: VALUE },
        &mut out,
    )
    .unwrap();
    let frame = &out[..n];
    let decode = |f: &[u8]| -> Option<u16> {
        let mut pdu = [0u8; MAX_PDU];
        let (_, len) = ascii::decode(f, &mut pdu).ok()?;
        match Response::decode(pdu.get(..len)?) {
            Ok(Response::ReadWord { value }) => Some(value),
            _ => None,
        }
    };
    assert_eq!(decode(frame), Some(VALUE));
    g.bench_function("decode_fc3_response", |b| {
        b.iter(|| decode(black_box(frame)))
    });
    g.finish();
}

fn exchange(c: &mut Criterion) {
    let mut g = c.benchmark_group("modbus_exchange");
    g.throughput(Throughput::Elements(1));
    let line = LineSettings::new(19200);
    let mut bus = bus::Bus::new(
        ModbusMaster::new(MasterConfig::new(Mode::Rtu, line)),
        Slave::new(
            SlaveConfig::new(addr(), Mode::Rtu, line),
            bus::Trivial::default(),
        ),
    );
    let req = request();
    let mut check = || {
        let now = bus.now;
        let _ = bus.master.send((addr(), black_box(req)), now);
        let mut value = None;
        let settled = bus.run(|e| {
            if let MasterEvent::Response(Response::ReadWord { value: v }) = e {
                value = Some(v);
            }
        });
        while bus.slave.poll_event().is_some() {}
        (settled, value)
    };
    let expected = bus::Trivial::default().value(
        StartAddress::from_raw(START),
        bonfiglioli_modbus::slave::Width::Word,
    ) as u16;
    assert_eq!(check(), (true, Some(expected)));
    g.bench_function("fc3_read_master_slave", |b| b.iter(&mut check));
    g.finish();
}

criterion_group!(
    benches,
    rtu_encode,
    rtu_decode,
    crc16,
    ascii_codec,
    exchange
);
criterion_main!(benches);
