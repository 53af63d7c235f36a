//! SBus codec benchmarks (criterion), target ≤ 10 ns each (issue 10):
//!
//! * `sbus_codec/encode_param_request`, `decode_param_request`: the manual's read of index
//!   8318 to address 1 (ch. 5.3) as a parameter request frame (identifier 523, 8 bytes);
//! * `sbus_codec/encode_process_output`, `decode_process_output`: PO 0006h 1388h 0000h to
//!   address 33 (identifier 267, 6 bytes);
//! * `sbus_codec/encode_variable`, `decode_variable`: the manual's INTEL variable telegram
//!   (object 1024, DataLow 11223344h, DataHigh 55667788h, `Len` 108h);
//! * `sbus_busload/result_of_15_objects`: the bus load and free capacity of a device's 15
//!   cyclic objects (what setting up one more computes).
//!
//! With `SBUS_CALLGRIND=OP,N` the binary runs operation OP (a benchmark name without its
//! group, or `noop` for the loop itself) N times and exits, for `valgrind --tool=callgrind`
//! ((count(N) − count(0)) / N is one operation):
//!
//! ```text
//! cargo bench -p sbus-can --bench codec --no-run
//! SBUS_CALLGRIND=decode_variable,100000 valgrind --tool=callgrind \
//!     --callgrind-out-file=/dev/null target/release/deps/codec-*
//! ```

// Benchmark setup: a failing fixture means a broken benchmark, so panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    missing_docs
)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group};
use drive_core::can::{Bitrate, CanFrame};
use drive_profile::sew::ParamChannel;
use sbus_can::busload::BusLoad;
use sbus_can::ids::Address;
use sbus_can::telegram::{ProcessData, Telegram};
use sbus_can::variable::{self, Len, ObjectNo, Variables};

fn param_request() -> Telegram {
    Telegram::ParamRequest {
        address: Address::new(1).unwrap(),
        channel: ParamChannel::read(8318),
    }
}

fn process_output() -> Telegram {
    Telegram::ProcessOutput {
        address: Address::new(33).unwrap(),
        synchronised: false,
        data: ProcessData([0x0006, 5000, 0]),
    }
}

const VARS: Variables = Variables {
    low: 0x1122_3344,
    high: 0x5566_7788,
};

fn object() -> ObjectNo {
    ObjectNo::new(1024).unwrap()
}

/// 5 objects every 5 ms and 10 every 100 ms, 8 bytes each, at 500 kbit/s.
fn fifteen_objects(extra: u32) -> BusLoad {
    let mut load = BusLoad::ZERO;
    for i in 0..15u32 {
        let cycle = if i < 5 { 5 } else { 100 + (extra & 1) * 10 };
        load += BusLoad::cyclic_ms(8, cycle, Bitrate::K500);
    }
    load
}

fn codec(c: &mut Criterion) {
    let mut g = c.benchmark_group("sbus_codec");
    let req = param_request();
    let req_frame = req.encode(0);
    let po = process_output();
    let po_frame = po.encode(0);
    let var_frame = variable::encode(object(), Len::INTEL_8, VARS);
    g.bench_function("encode_param_request", |b| {
        b.iter(|| black_box(black_box(&req).encode(black_box(0))))
    });
    g.bench_function("decode_param_request", |b| {
        b.iter(|| black_box(Telegram::decode(black_box(&req_frame), black_box(0))))
    });
    g.bench_function("encode_process_output", |b| {
        b.iter(|| black_box(black_box(&po).encode(black_box(0))))
    });
    g.bench_function("decode_process_output", |b| {
        b.iter(|| black_box(Telegram::decode(black_box(&po_frame), black_box(0))))
    });
    g.bench_function("encode_variable", |b| {
        b.iter(|| {
            black_box(variable::encode(
                black_box(object()),
                black_box(Len::INTEL_8),
                black_box(VARS),
            ))
        })
    });
    g.bench_function("decode_variable", |b| {
        b.iter(|| {
            black_box(variable::decode(
                black_box(&var_frame),
                black_box(Len::INTEL_8),
            ))
        })
    });
    g.finish();

    let mut g = c.benchmark_group("sbus_busload");
    g.bench_function("result_of_15_objects", |b| {
        b.iter(|| black_box(fifteen_objects(black_box(0)).free_capacity()))
    });
    g.finish();
}

fn callgrind(op: &str, n: u64) {
    let req = param_request();
    let req_frame = req.encode(0);
    let po = process_output();
    let po_frame = po.encode(0);
    let var_frame: CanFrame = variable::encode(object(), Len::INTEL_8, VARS);
    let run: Box<dyn Fn(u64)> = match op {
        "encode_param_request" => Box::new(|i| {
            black_box(black_box(&req).encode(black_box(i as u16 & 1)));
        }),
        "decode_param_request" => Box::new(|i| {
            black_box(Telegram::decode(
                black_box(&req_frame),
                black_box(i as u16 & 1),
            ))
            .unwrap();
        }),
        "encode_process_output" => Box::new(|i| {
            black_box(black_box(&po).encode(black_box(i as u16 & 1)));
        }),
        "decode_process_output" => Box::new(|i| {
            black_box(Telegram::decode(
                black_box(&po_frame),
                black_box(i as u16 & 1),
            ))
            .unwrap();
        }),
        "encode_variable" => Box::new(|i| {
            black_box(variable::encode(
                black_box(object()),
                black_box(Len::INTEL_8),
                black_box(Variables {
                    low: i as u32,
                    high: 0,
                }),
            ));
        }),
        "decode_variable" => Box::new(|i| {
            black_box(i);
            black_box(variable::decode(
                black_box(&var_frame),
                black_box(Len::INTEL_8),
            ))
            .unwrap();
        }),
        "result_of_15_objects" => Box::new(|i| {
            black_box(fifteen_objects(black_box(i as u32)).free_capacity());
        }),
        "noop" => Box::new(|i| {
            black_box(i);
        }),
        other => panic!("unknown operation {other}"),
    };
    for i in 0..n {
        run(i);
    }
}

criterion_group!(benches, codec);

fn main() {
    if let Ok(spec) = std::env::var("SBUS_CALLGRIND") {
        let (op, n) = spec.split_once(',').unwrap_or((&spec, "1"));
        callgrind(op, n.parse().unwrap());
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
