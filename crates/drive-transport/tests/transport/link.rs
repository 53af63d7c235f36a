//! The in-memory link: wire timing on tokio's paused clock, parity flags, fault injection.

use std::time::Duration;

use drive_transport::link::{
    self, Fault, FaultConfig, FaultStats, LinkConfig, LinkEnd, TimedChar, WireChar,
};
use drive_transport::serial::{LineSettings, Parity};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::time::Instant;

const CHAR_8E1_9600: Duration = Duration::from_nanos(1_145_833);

fn blank() -> TimedChar {
    TimedChar {
        ch: WireChar::new(0),
        at: Instant::now(),
    }
}

/// Reads exactly `n` characters with timestamps.
async fn read_timed_n(end: &mut LinkEnd, n: usize) -> Vec<TimedChar> {
    let mut out = Vec::with_capacity(n);
    let mut buf = vec![blank(); n];
    while out.len() < n {
        let got = end.read_timed(&mut buf[..n - out.len()]).await.unwrap();
        assert!(got > 0, "unexpected end of file after {} chars", out.len());
        out.extend_from_slice(&buf[..got]);
    }
    out
}

async fn read_chars_n(end: &mut LinkEnd, n: usize) -> Vec<WireChar> {
    read_timed_n(end, n)
        .await
        .into_iter()
        .map(|c| c.ch)
        .collect()
}

fn assert_close(actual: Duration, expected: Duration, tolerance: Duration) {
    let diff = actual.abs_diff(expected);
    assert!(
        diff <= tolerance,
        "{actual:?} differs from {expected:?} by more than {tolerance:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn telegram_of_18_bytes_takes_20_625_ms_at_9600_8e1() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let telegram: Vec<u8> = (0..18).collect();
    let t0 = Instant::now();
    a.write_all(&telegram).await.unwrap();
    // Writing itself takes no time: the characters are queued on the line.
    assert_eq!(Instant::now(), t0);

    let chars = read_timed_n(&mut b, 18).await;
    let bytes: Vec<u8> = chars.iter().map(|c| c.ch.byte).collect();
    assert_eq!(bytes, telegram);
    assert!(chars.iter().all(|c| c.ch.parity_ok));
    // Exact arrival of the last bit: 18 × 11 / 9600 s.
    assert_close(
        chars[17].at - t0,
        Duration::from_micros(20_625),
        Duration::from_micros(1),
    );
    // The reader is woken by a tokio timer (1 ms resolution), at or after the arrival.
    let woke = Instant::now() - t0;
    assert!(woke >= Duration::from_micros(20_625), "{woke:?}");
    assert!(woke < Duration::from_micros(21_625), "{woke:?}");
}

#[tokio::test(start_paused = true)]
async fn flush_waits_until_the_last_bit_has_left_the_line() {
    let (mut a, _b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.write_all(&[0x55; 18]).await.unwrap();
    a.flush().await.unwrap();
    let elapsed = Instant::now() - t0;
    assert!(elapsed >= Duration::from_micros(20_625), "{elapsed:?}");
    assert!(elapsed < Duration::from_micros(21_625), "{elapsed:?}");
    // Idle line: flushing again returns at once.
    let t1 = Instant::now();
    a.flush().await.unwrap();
    assert_eq!(Instant::now(), t1);
}

#[tokio::test(start_paused = true)]
async fn characters_are_serialised_back_to_back() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    // Two separate writes while the line is busy: the second queues behind the first.
    a.write_all(&[1, 2, 3]).await.unwrap();
    a.write_all(&[4, 5]).await.unwrap();
    let chars = read_timed_n(&mut b, 5).await;
    for (i, c) in chars.iter().enumerate() {
        assert_eq!(c.ch.byte, i as u8 + 1);
        assert_close(
            c.at - t0,
            CHAR_8E1_9600 * (i as u32 + 1),
            Duration::from_nanos(5),
        );
    }
    for pair in chars.windows(2) {
        assert_close(
            pair[1].at - pair[0].at,
            CHAR_8E1_9600,
            Duration::from_nanos(1),
        );
    }

    // After the line went idle, a new character starts when it is written.
    tokio::time::sleep(Duration::from_millis(10)).await;
    let t1 = Instant::now();
    a.write_all(&[6]).await.unwrap();
    let c = read_timed_n(&mut b, 1).await;
    assert_close(c[0].at - t1, CHAR_8E1_9600, Duration::from_nanos(1));
}

#[tokio::test(start_paused = true)]
async fn reader_sees_bytes_arrive_progressively() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.write_all(&[0xAA; 18]).await.unwrap();
    let mut buf = [0u8; 64];
    let mut reads = Vec::new();
    let mut total = 0;
    while total < 18 {
        let n = b.read(&mut buf).await.unwrap();
        assert!(n > 0);
        total += n;
        reads.push((Instant::now() - t0, total));
    }
    assert_eq!(total, 18);
    // About one character per millisecond tick at 9600 baud, never all at once.
    assert!(reads.len() >= 15, "{reads:?}");
    for &(at, count) in &reads {
        // Never earlier than the modelled arrival of the last character received so far.
        assert!(at >= CHAR_8E1_9600 * count as u32, "{reads:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn timing_off_delivers_immediately() {
    let (mut a, mut b) = link::pair(LinkConfig::untimed());
    let t0 = Instant::now();
    let data: Vec<u8> = (0..=255).collect();
    a.write_all(&data).await.unwrap();
    a.flush().await.unwrap();
    let mut got = vec![0u8; 256];
    b.read_exact(&mut got).await.unwrap();
    assert_eq!(got, data);
    assert_eq!(Instant::now(), t0, "no time may pass with timing off");
}

#[tokio::test(start_paused = true)]
async fn both_directions_run_in_parallel() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.write_all(&[1; 18]).await.unwrap();
    b.write_all(&[2; 18]).await.unwrap();
    let at_b = read_timed_n(&mut b, 18).await;
    let at_a = read_timed_n(&mut a, 18).await;
    assert!(at_b.iter().all(|c| c.ch.byte == 1));
    assert!(at_a.iter().all(|c| c.ch.byte == 2));
    assert_close(
        at_b[17].at - t0,
        Duration::from_micros(20_625),
        Duration::from_micros(1),
    );
    assert_close(
        at_a[17].at - t0,
        Duration::from_micros(20_625),
        Duration::from_micros(1),
    );
}

#[tokio::test(start_paused = true)]
async fn other_baud_rates_and_formats() {
    // 19200 baud 8N1: 10 bits per character.
    let cfg = LinkConfig::from_line(LineSettings::new(19200).with_parity(Parity::None));
    let (mut a, mut b) = link::pair(cfg);
    let t0 = Instant::now();
    a.write_all(&[0; 8]).await.unwrap();
    let chars = read_timed_n(&mut b, 8).await;
    // 8 × 10 / 19200 s = 4.1667 ms
    assert_close(
        chars[7].at - t0,
        Duration::from_nanos(4_166_667),
        Duration::from_micros(1),
    );
}

#[tokio::test(start_paused = true)]
async fn one_shot_flip_sets_parity_flags() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    a.inject(Fault::Flip(1 << 9)); // parity bit only
    a.inject(Fault::Flip(1 << 1)); // data bit 0
    a.inject(Fault::Flip((1 << 1) | (1 << 2))); // two data bits: parity passes
    a.inject(Fault::Flip(1 << 0)); // start bit: framing error
    a.inject(Fault::Flip(1 << 10)); // stop bit: framing error
    a.write_all(&[0x10, 0x10, 0x10, 0x10, 0x10, 0x10])
        .await
        .unwrap();
    let chars = read_chars_n(&mut b, 6).await;
    assert_eq!(
        chars,
        [
            WireChar {
                byte: 0x10,
                parity_ok: false
            },
            WireChar {
                byte: 0x11,
                parity_ok: false
            },
            WireChar {
                byte: 0x13,
                parity_ok: true
            },
            WireChar {
                byte: 0x10,
                parity_ok: false
            },
            WireChar {
                byte: 0x10,
                parity_ok: false
            },
            WireChar {
                byte: 0x10,
                parity_ok: true
            },
        ]
    );
    let stats = a.fault_stats();
    assert_eq!(stats.written, 6);
    assert_eq!(stats.flipped, 5);
    assert_eq!(stats.flagged, 4);
    assert_eq!(b.rx_fault_stats(), stats);
}

#[tokio::test(start_paused = true)]
async fn plain_read_returns_flagged_bytes_too() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    a.inject(Fault::Flip(1 << 9));
    a.write_all(&[0x42, 0x43]).await.unwrap();
    let mut got = [0u8; 2];
    b.read_exact(&mut got).await.unwrap();
    assert_eq!(got, [0x42, 0x43]);
}

#[tokio::test(start_paused = true)]
async fn one_shot_drop_keeps_its_wire_time() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.inject(Fault::Drop);
    a.write_all(&[1, 2, 3]).await.unwrap();
    let chars = read_timed_n(&mut b, 2).await;
    assert_eq!(chars[0].ch.byte, 2);
    assert_eq!(chars[1].ch.byte, 3);
    assert_close(chars[0].at - t0, CHAR_8E1_9600 * 2, Duration::from_nanos(5));
    assert_eq!(a.fault_stats().dropped, 1);
}

#[tokio::test(start_paused = true)]
async fn one_shot_insert_adds_a_character_after_the_next() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.inject(Fault::Insert(0xEE));
    a.write_all(&[1, 2]).await.unwrap();
    let chars = read_timed_n(&mut b, 3).await;
    let bytes: Vec<u8> = chars.iter().map(|c| c.ch.byte).collect();
    assert_eq!(bytes, [1, 0xEE, 2]);
    assert!(chars.iter().all(|c| c.ch.parity_ok));
    assert_close(chars[2].at - t0, CHAR_8E1_9600 * 3, Duration::from_nanos(5));
    assert_eq!(a.fault_stats().inserted, 1);
}

#[tokio::test(start_paused = true)]
async fn one_shot_delay_opens_a_gap_and_shifts_the_rest() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    let t0 = Instant::now();
    a.write_all(&[1]).await.unwrap();
    a.inject(Fault::Delay(Duration::from_millis(4)));
    a.write_all(&[2, 3]).await.unwrap();
    let chars = read_timed_n(&mut b, 3).await;
    assert_close(chars[0].at - t0, CHAR_8E1_9600, Duration::from_nanos(5));
    // Gap between end of char 1 and end of char 2: idle 4 ms + one char time.
    assert_close(
        chars[1].at - chars[0].at,
        Duration::from_millis(4) + CHAR_8E1_9600,
        Duration::from_nanos(5),
    );
    assert_close(
        chars[2].at - chars[1].at,
        CHAR_8E1_9600,
        Duration::from_nanos(5),
    );
    assert_eq!(a.fault_stats().delayed, 1);
}

#[tokio::test(start_paused = true)]
async fn delay_applies_with_timing_off_too() {
    let (mut a, mut b) = link::pair(LinkConfig::untimed());
    let t0 = Instant::now();
    a.inject(Fault::Delay(Duration::from_millis(3)));
    a.write_all(&[7, 8]).await.unwrap();
    let chars = read_timed_n(&mut b, 2).await;
    assert_eq!(chars[0].at - t0, Duration::from_millis(3));
    assert_eq!(chars[1].at - t0, Duration::from_millis(3));
    assert_eq!(chars[1].ch.byte, 8);
}

/// Sends `n` bytes (a counter pattern) through a faulty untimed link, returns what arrived.
async fn run_faulty(faults: FaultConfig, n: usize) -> (Vec<WireChar>, FaultStats) {
    let (mut a, mut b) = link::pair(LinkConfig::untimed().with_faults(faults));
    let writer = tokio::spawn(async move {
        let data: Vec<u8> = (0..n).map(|i| i as u8).collect();
        for chunk in data.chunks(1000) {
            a.write_all(chunk).await.unwrap();
        }
        a.shutdown().await.unwrap();
        a.fault_stats()
    });
    let mut got = Vec::new();
    let mut buf = [WireChar::new(0); 512];
    loop {
        let k = b.read_chars(&mut buf).await.unwrap();
        if k == 0 {
            break;
        }
        got.extend_from_slice(&buf[..k]);
    }
    let stats = writer.await.unwrap();
    (got, stats)
}

#[tokio::test(start_paused = true)]
async fn seeded_one_percent_faults_have_expected_counts() {
    const N: usize = 100_000;
    let faults = FaultConfig::uniform(42, 0.01);
    let (got, stats) = run_faulty(faults, N).await;

    assert_eq!(stats.written, N as u64);
    // Expected 1000 each (σ ≈ 31); flips skip dropped characters (990).
    for (name, count) in [
        ("dropped", stats.dropped),
        ("inserted", stats.inserted),
        ("flipped", stats.flipped),
        ("delayed", stats.delayed),
    ] {
        assert!((850..=1150).contains(&count), "{name}: {count} ({stats:?})");
    }
    // One flipped bit of an 8E1 frame is always detected (data, parity, start or stop bit).
    assert_eq!(stats.flagged, stats.flipped);
    assert_eq!(
        got.len() as u64,
        stats.written - stats.dropped + stats.inserted
    );
    let flagged = got.iter().filter(|c| !c.parity_ok).count() as u64;
    assert_eq!(flagged, stats.flagged);

    // Deterministic: the same seed gives the same result, another seed a different one.
    let (again, stats_again) = run_faulty(faults, N).await;
    assert_eq!(stats_again, stats);
    assert_eq!(again, got);
    let (_, other) = run_faulty(FaultConfig::uniform(43, 0.01), N).await;
    assert_ne!(other, stats);
}

#[tokio::test(start_paused = true)]
async fn each_random_fault_type_shows_up_as_described() {
    const N: usize = 20_000;
    let base = FaultConfig::none();

    // Drops only: the output is the input with characters missing.
    let (got, stats) = run_faulty(FaultConfig { drop: 0.01, ..base }, N).await;
    assert!(stats.dropped > 100 && stats.flipped + stats.inserted + stats.delayed == 0);
    assert_eq!(got.len() as u64, N as u64 - stats.dropped);
    let sent: Vec<u8> = (0..N).map(|i| i as u8).collect();
    let mut it = sent.iter();
    assert!(
        got.iter().all(|c| c.parity_ok && it.any(|&s| s == c.byte)),
        "received characters must be a subsequence of the sent ones"
    );

    // Inserts only: every original character arrives, in order, plus extras.
    let (got, stats) = run_faulty(
        FaultConfig {
            insert: 0.01,
            ..base
        },
        N,
    )
    .await;
    assert!(stats.inserted > 100);
    assert_eq!(got.len() as u64, N as u64 + stats.inserted);
    assert!(got.iter().all(|c| c.parity_ok));

    // Flips of two bits: some pass parity unnoticed (two data bits), length unchanged.
    let (got, stats) = run_faulty(
        FaultConfig {
            flip: 0.05,
            flip_bits: 2,
            ..base
        },
        N,
    )
    .await;
    assert_eq!(got.len(), N);
    let changed = got.iter().zip(&sent).filter(|(c, s)| c.byte != **s).count() as u64;
    assert!(stats.flipped > 500);
    assert!(stats.flagged < stats.flipped, "{stats:?}");
    assert!(changed > 0 && changed <= stats.flipped);
    let unflagged_changes = got
        .iter()
        .zip(&sent)
        .filter(|(c, s)| c.byte != **s && c.parity_ok)
        .count();
    assert!(unflagged_changes > 0, "two flipped data bits pass parity");

    // Delays only: nothing lost or changed, but virtual time passes.
    let t0 = Instant::now();
    let (got, stats) = run_faulty(
        FaultConfig {
            delay: 0.01,
            delay_by: Duration::from_millis(2),
            ..base
        },
        N,
    )
    .await;
    assert_eq!(got.len(), N);
    assert!(
        got.iter()
            .zip(&sent)
            .all(|(c, s)| c.byte == *s && c.parity_ok)
    );
    assert!(stats.delayed > 100);
    assert!(Instant::now() - t0 >= Duration::from_millis(2));
}

#[tokio::test(start_paused = true)]
async fn dropping_an_end_gives_eof_and_broken_pipe() {
    let (mut a, mut b) = link::pair(LinkConfig::new(9600));
    a.write_all(b"bye").await.unwrap();
    drop(a);
    let mut got = Vec::new();
    b.read_to_end(&mut got).await.unwrap();
    assert_eq!(got, b"bye");
    let err = b.write_all(b"x").await.unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::BrokenPipe);
}

#[tokio::test(start_paused = true)]
async fn writes_wait_when_the_line_is_full() {
    let cfg = LinkConfig {
        capacity: 4,
        ..LinkConfig::untimed()
    };
    let (mut a, mut b) = link::pair(cfg);
    let n = a.write(&[1, 2, 3, 4, 5, 6]).await.unwrap();
    assert_eq!(n, 4);
    let writer = tokio::spawn(async move {
        a.write_all(&[5, 6]).await.unwrap();
        a
    });
    let mut got = [0u8; 6];
    b.read_exact(&mut got).await.unwrap();
    assert_eq!(got, [1, 2, 3, 4, 5, 6]);
    drop(writer.await.unwrap());
}

/// A frame written with its intended start (`CharIo::poll_write_at`, as `Port` and `serve` do
/// after a timer wake-up on tokio's 1 ms tick) starts on the wire at that start, between the
/// ticks; never before the line is free, and never more than the timer's resolution back.
#[tokio::test(start_paused = true)]
async fn a_frame_starts_where_its_writer_scheduled_it() {
    use drive_core::rt::write_all_at;
    let (mut a, mut b) = link::pair(LinkConfig::default());
    let t0 = Instant::now();
    // Scheduled for 2.345 ms, written on the tick at 3 ms.
    tokio::time::advance(Duration::from_millis(3)).await;
    let start = t0 + Duration::from_micros(2_345);
    write_all_at(&mut a, &[1, 2], start).await.unwrap();
    let got = read_timed_n(&mut b, 2).await;
    assert_eq!(got[0].at, start + CHAR_8E1_9600);
    assert_eq!(got[1].at, start + CHAR_8E1_9600 * 2);

    // A start before the end of what is still on the line: after it, in order.
    tokio::time::advance(Duration::from_millis(1)).await;
    let now = Instant::now();
    a.write_all(&[3, 4, 5]).await.unwrap(); // not flushed: on the line until now + 3 chars
    write_all_at(&mut a, &[6], now - Duration::from_micros(500))
        .await
        .unwrap();
    let got = read_timed_n(&mut b, 4).await;
    assert_eq!(got[0].at, now + CHAR_8E1_9600);
    for pair in got.windows(2) {
        assert_eq!(
            pair[1].at - pair[0].at,
            CHAR_8E1_9600,
            "back to back, in order"
        );
    }
    assert_eq!(
        got.iter().map(|c| c.ch.byte).collect::<Vec<_>>(),
        [3, 4, 5, 6]
    );

    // A start more than 1 ms in the past counts from now − 1 ms.
    tokio::time::advance(Duration::from_millis(10)).await;
    let now = Instant::now();
    write_all_at(&mut a, &[7], now - Duration::from_millis(5))
        .await
        .unwrap();
    let got = read_timed_n(&mut b, 1).await;
    assert_eq!(got[0].at, now - Duration::from_millis(1) + CHAR_8E1_9600);
}
