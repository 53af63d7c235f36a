//! Software overhead of the in-memory link (timing off): bytes per second through a pair of
//! ends, plain bytes and parity-flagged characters, with and without fault injection.
//!
//! Run with `cargo bench -p drive-transport`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use drive_transport::link::{self, FaultConfig, LinkConfig, WireChar};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const TOTAL: usize = 4 << 20;
const CHUNK: usize = 256;

async fn transfer(config: LinkConfig, chars: bool) -> usize {
    let (mut a, mut b) = link::pair(config);
    let writer = tokio::spawn(async move {
        let chunk = [0x5Au8; CHUNK];
        for _ in 0..TOTAL / CHUNK {
            a.write_all(&chunk).await.expect("write");
        }
    });
    let mut received = 0;
    let mut bytes = [0u8; CHUNK];
    let mut wire = [WireChar::new(0); CHUNK];
    loop {
        let n = if chars {
            b.read_chars(&mut wire).await.expect("read")
        } else {
            b.read(&mut bytes).await.expect("read")
        };
        if n == 0 {
            break;
        }
        received += n;
        black_box((&bytes, &wire));
    }
    writer.await.expect("writer task");
    received
}

fn main() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .expect("runtime");
    let cases = [
        ("untimed, AsyncRead", LinkConfig::untimed(), false),
        ("untimed, read_chars", LinkConfig::untimed(), true),
        (
            "untimed, 1 % drop/insert/flip",
            LinkConfig::untimed().with_faults(FaultConfig {
                drop: 0.01,
                insert: 0.01,
                flip: 0.01,
                ..FaultConfig::none()
            }),
            true,
        ),
    ];
    println!("link group: {} MiB per case, best of 5", TOTAL >> 20);
    for (name, config, chars) in cases {
        let mut best = Duration::MAX;
        for _ in 0..5 {
            let start = Instant::now();
            let n = rt.block_on(transfer(config, chars));
            best = best.min(start.elapsed());
            assert!(n > TOTAL / 2);
        }
        let ns_per_byte = best.as_nanos() as f64 / TOTAL as f64;
        let mib_s = TOTAL as f64 / best.as_secs_f64() / (1 << 20) as f64;
        println!("  {name:<32} {ns_per_byte:>7.2} ns/byte {mib_s:>9.1} MiB/s");
    }
}
