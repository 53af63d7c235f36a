//! Bus timing on tokio's paused clock, measured from the exact arrival times of the wire model.

use std::time::Duration;

use drive_transport::link::{self, LinkConfig, LinkEnd};
use movilink::driver::{DriverConfig, DriverError, LinkError, MovilinkDriver, ParamServices};
use movilink::sim::SimulatedMovidrive;
use movilink::{Address, ParamChannel, PduType, Telegram};
use tokio::time::Instant;

use crate::common::{CHAR, FailOnce, START_PAUSE, Tap, addr, telegrams, timeline};

/// Two start pauses.
const RESTART_PAUSE: Duration = Duration::from_micros(6880);

#[tokio::test(start_paused = true)]
async fn a_start_pause_precedes_every_telegram() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let (port, master_log) = Tap::new(port);
    let (wire, drive_log) = Tap::new(wire);
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let a = addr(1);
        for i in 0..5u32 {
            m.read(a, 8470).await.unwrap();
            m.write_volatile(a, 8471, 1000 + 10 * i).await.unwrap();
            let t = Telegram::request(a, PduType::PARAM_3PD)
                .with_param(ParamChannel::read(8301))
                .with_process_data(&[0x0006, 100, 0]);
            m.exchange(t).await.unwrap();
            m.exchange(Telegram::request(a, PduType::PD1_ACYCLIC).with_process_data(&[6]))
                .await
                .unwrap();
        }
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    let requests = drive_log.lock().unwrap().clone();
    let responses = master_log.lock().unwrap().clone();
    let all = timeline(&requests, &responses);
    // 5 × (read, write, cyclic service, PD) + 1 exchange that learns the handshake bit.
    assert_eq!(all.len(), 2 * 21);
    for pair in all.windows(2) {
        let gap = pair[1].start.saturating_duration_since(pair[0].end);
        assert!(
            gap >= START_PAUSE,
            "gap {gap:?} before {:02x?}",
            pair[1].bytes
        );
        // Only tokio's 1 ms timer resolution on top.
        assert!(gap < START_PAUSE + Duration::from_millis(1), "gap {gap:?}");
    }
    for (i, t) in all.iter().enumerate() {
        assert_eq!(t.bytes[0], if i % 2 == 0 { 0x02 } else { 0x1D });
    }
}

async fn time_until_timeout(timeout: Duration) -> Duration {
    let (port, _silent) = link::pair(LinkConfig::new(9600));
    let config = DriverConfig {
        response_timeout: timeout,
        retries: 0,
        ..DriverConfig::default()
    };
    let mut m = MovilinkDriver::new(port, config);
    let start = Instant::now();
    let r = m.read(addr(2), 8301).await;
    assert!(
        matches!(
            r,
            Err(DriverError::Link(LinkError::Timeout { attempts: 1, .. }))
        ),
        "{r:?}"
    );
    start.elapsed()
}

#[tokio::test(start_paused = true)]
async fn the_response_timeout_fires_at_50_ms_or_as_configured() {
    for timeout in [Duration::from_millis(50), Duration::from_millis(120)] {
        let took = time_until_timeout(timeout).await;
        // Request (12 characters), the timeout, and the SD2 that would have had to arrive.
        let due = CHAR * 12 + timeout + CHAR;
        assert!(took >= due, "{took:?} < {due:?}");
        assert!(took <= due + Duration::from_millis(1), "{took:?} > {due:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn retransmissions_follow_the_timeout() {
    let (port, silent) = link::pair(LinkConfig::new(9600));
    let (mut silent, log) = Tap::new(silent);
    let reader = tokio::spawn(async move {
        let mut buf = [movilink::driver::ReceivedChar::new(0, Instant::now()); 32];
        let mut sink = &mut silent;
        while std::future::poll_fn(|cx| {
            movilink::driver::CharIo::poll_read_chars(&mut sink, cx, &mut buf)
        })
        .await
        .unwrap()
            > 0
        {}
    });
    let mut m = MovilinkDriver::new(port, DriverConfig::default());
    assert!(m.read(addr(2), 8301).await.is_err());
    drop(m);
    reader.await.unwrap();
    let seen = telegrams(&log.lock().unwrap());
    assert_eq!(seen.len(), 3);
    for pair in seen.windows(2) {
        assert_eq!(pair[0].bytes, pair[1].bytes);
        let gap = pair[1].start - pair[0].end;
        let due = Duration::from_millis(50) + CHAR;
        assert!(
            gap >= due && gap <= due + Duration::from_millis(1),
            "{gap:?}"
        );
    }
}

#[tokio::test(start_paused = true)]
async fn broadcast_spacing_is_25_ms() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let (wire, drive_log) = Tap::new(wire);
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        for target in [Address::BROADCAST, addr(120)] {
            let t = Telegram::request(target, PduType::PD2_ACYCLIC).with_process_data(&[1, 2]);
            m.send_unanswered(t).await.unwrap();
            m.read(addr(1), 8301).await.unwrap();
        }
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    let seen = telegrams(&drive_log.lock().unwrap());
    assert_eq!(seen.len(), 4);
    for pair in seen.chunks(2) {
        let gap = pair[1].start - pair[0].end;
        assert!(gap >= Duration::from_millis(25), "{gap:?}");
        assert!(gap <= Duration::from_millis(26), "{gap:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn two_start_pauses_after_an_aborted_telegram() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let port = FailOnce {
        inner: port,
        fail_after: Some(5),
    };
    let (wire, drive_log) = Tap::new(wire);
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let first = m.read(addr(1), 8301).await;
        assert!(
            matches!(first, Err(DriverError::Link(LinkError::Io(_)))),
            "{first:?}"
        );
        m.read(addr(1), 8301).await.unwrap();
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    let seen = telegrams(&drive_log.lock().unwrap());
    assert_eq!(seen.len(), 2);
    assert_eq!(seen[0].bytes.len(), 5);
    let gap = seen[1].start - seen[0].end;
    assert!(gap >= RESTART_PAUSE, "{gap:?}");
    assert!(gap <= RESTART_PAUSE + Duration::from_millis(2), "{gap:?}");
}

/// Cyclic PD exchanges every `period` for `duration`.
async fn feed_cyclic(m: &mut MovilinkDriver<LinkEnd>, period: Duration, duration: Duration) {
    let end = Instant::now() + duration;
    while Instant::now() < end {
        let t = Telegram::request(addr(1), PduType::PD2).with_process_data(&[0x0006, 5000]);
        m.exchange(t).await.unwrap();
        tokio::time::sleep(period).await;
    }
}

#[tokio::test(start_paused = true)]
async fn p812_timeout_triggers_the_p833_reaction_only_without_cyclic_telegrams() {
    use drive_sim::movidrive::TimeoutReaction;
    // The simulator's time base starts with its first serve, now (the clock is paused).
    let epoch = Instant::now();
    let mut sim = SimulatedMovidrive::new(1);

    // Session 1: P812 = 200 ms, then a second of cyclic telegrams every 50 ms.
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        m.write_volatile(addr(1), 8599, 200).await.unwrap();
        feed_cyclic(&mut m, Duration::from_millis(50), Duration::from_secs(1)).await;
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(
        sim.movidrive().rs485_timeout(),
        Some(Duration::from_millis(200))
    );
    assert_eq!(sim.movidrive().timeout_warning(), None);
    assert!(sim.movidrive().actual_speed_rpm() > 500.0);

    // Session 2: the master stops; 150 ms later nothing has happened yet …
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        feed_cyclic(&mut m, Duration::from_millis(1), Duration::from_millis(1)).await;
        tokio::time::sleep(Duration::from_millis(150)).await;
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(sim.movidrive().timeout_warning(), None);
    let running = sim.movidrive().actual_speed_rpm();

    // … and after 200 ms the drive reacts with P833 (default: rapid stop / warning, fault 43).
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let client = async move {
        let m = MovilinkDriver::new(port, DriverConfig::default());
        tokio::time::sleep(Duration::from_millis(100)).await;
        drop(m);
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    // The drive was last told the time of its P812 deadline, where the rapid stop begins (at
    // the deadline itself, no longer on tokio's later tick): let the drive model run on to
    // the end of the session before looking at the ramp.
    let end = movilink::Instant::from_duration(Instant::now() - epoch);
    sim.movidrive_mut().tick(end);
    let md = sim.movidrive();
    assert_eq!(
        md.timeout_warning(),
        Some(TimeoutReaction::RapidStopWarning)
    );
    assert_eq!(
        md.fault_number(),
        Some(drive_sim::movidrive::FAULT_RS485_TIMEOUT)
    );
    assert!(md.actual_speed_rpm() < running, "rapid stop ramps down");
}

#[tokio::test(start_paused = true)]
async fn a_cyclic_param_3pd_exchange_takes_the_wire_time_and_two_start_pauses() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let t = Telegram::request(addr(1), PduType::PARAM_3PD)
            .with_param(ParamChannel::no_service())
            .with_process_data(&[0x0006, 0, 0]);
        m.exchange(t).await.unwrap();
        let mut figures = Vec::new();
        let mut periods = Vec::new();
        for _ in 0..5 {
            let before = Instant::now();
            m.exchange(t).await.unwrap();
            periods.push(before.elapsed());
            let timing = m.last_timing().unwrap();
            figures.push(START_PAUSE + timing.duration());
        }
        (figures, periods)
    };
    let (served, (figures, periods)) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    // (18 + 18) × 11 / 9600 s + 2 × 3.44 ms = 48.13 ms
    let bound = CHAR * 36 + START_PAUSE * 2;
    assert_eq!(bound.as_micros(), 48_129);
    for f in &figures {
        println!(
            "cyclic PARAM+3PD exchange: {:.3} ms (bound {:.3} ms, {:+.2} %)",
            f.as_secs_f64() * 1e3,
            bound.as_secs_f64() * 1e3,
            (f.as_secs_f64() / bound.as_secs_f64() - 1.0) * 100.0
        );
        // The drive's response latency: tokio's 1 ms timer tick, nothing else.
        assert!(
            *f >= bound && *f <= bound + Duration::from_millis(1),
            "{f:?}"
        );
        assert!(f.as_secs_f64() <= bound.as_secs_f64() * 1.02);
    }
    for p in &periods {
        // Back to back, measured on tokio's clock at the master's wake-ups, which fall on 1 ms
        // ticks: the wire keeps the bound exactly, the tick-to-tick period is within 1 ms of it.
        assert!(
            *p + Duration::from_millis(1) > bound && *p <= bound + Duration::from_millis(2),
            "{p:?}"
        );
    }
}

/// The driver and the simulated drive follow the line settings they are given: at 19200 baud
/// 8E1 a PARAM + 3PD exchange takes half the 9600-baud wire time and the 19200-baud start
/// pauses (1.72 ms), on the 19200-baud wire model.
#[tokio::test(start_paused = true)]
async fn driver_and_simulator_follow_19200_baud() {
    use drive_core::LineSettings;
    let line = LineSettings::new(19200);
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let (wire, drive_log) = Tap::new(wire);
    let mut sim = SimulatedMovidrive::with_line(1, line);
    let client = async move {
        let config = DriverConfig {
            line,
            ..DriverConfig::default()
        };
        let mut m = MovilinkDriver::new(port, config);
        let t = Telegram::request(addr(1), PduType::PARAM_3PD)
            .with_param(ParamChannel::no_service())
            .with_process_data(&[0x0006, 0, 0]);
        let mut figures = Vec::new();
        for _ in 0..4 {
            m.exchange(t).await.unwrap();
            figures.push(m.last_timing().unwrap().duration());
        }
        figures
    };
    let (served, figures) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    let char_time = line.char_time();
    assert_eq!(char_time, Duration::from_nanos(572_917));
    let pause = Duration::from_micros(1720);
    // Request and answer on the wire, the drive's start pause before its answer.
    let bound = char_time * 36 + pause;
    for f in &figures {
        assert!(
            *f >= bound && *f <= bound + Duration::from_millis(1),
            "{f:?} (bound {bound:?})"
        );
    }
    // Between the requests the master waits the 19200-baud start pause, not 9600's 3.44 ms.
    let requests = drive_log.lock().unwrap().clone();
    let starts: Vec<_> = telegrams(&requests).iter().map(|t| t.start).collect();
    assert!(starts.len() >= 4);
    let ends: Vec<_> = telegrams(&requests).iter().map(|t| t.end).collect();
    for (end, next) in ends.iter().zip(starts.iter().skip(1)) {
        // (`telegrams` puts a telegram's start one 9600-baud character before its first
        // arrival: here a 19200-baud character is meant.)
        let period = next.saturating_duration_since(*end) + (CHAR - char_time);
        // From a request's end to the next request: the answer (18 characters), two pauses
        // and tokio's 1 ms timer ticks at most, all at 19200.
        assert!(
            period >= char_time * 18 + pause * 2
                && period < char_time * 18 + pause * 2 + Duration::from_millis(2),
            "{period:?}"
        );
    }
}

/// Feed `request` to `drive` character by character from `start` (wire time); returns the end
/// of its last character.
fn feed_request(
    drive: &mut SimulatedMovidrive,
    request: Telegram,
    start: movilink::Instant,
) -> movilink::Instant {
    use drive_core::Endpoint as _;
    let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
    let n = movilink::encode(&request, &mut buf).unwrap();
    let mut t = start;
    for &b in &buf[..n] {
        t += movilink::timing::CHAR_TIME;
        drive.handle_char(movilink::RxChar::new(b, t));
    }
    t
}

/// Advance `drive` through every deadline up to `until` as a serve loop would.
fn pump(drive: &mut SimulatedMovidrive, until: movilink::Instant) {
    use drive_core::Endpoint as _;
    let mut buf = [0u8; movilink::MAX_TELEGRAM_LEN];
    while let Some(t) = drive.poll_timeout().filter(|t| *t <= until) {
        drive.handle_timeout(t);
        let _ = drive.poll_transmit(t, &mut buf);
    }
    drive.handle_timeout(until);
}

#[test]
fn a_cyclic_request_complete_before_the_p812_deadline_is_in_time() {
    use drive_profile::sew::{ControlWord1, index};
    use movilink::Instant as T;
    let mut drive = SimulatedMovidrive::new(1);
    let md = drive.movidrive_mut();
    // P812 = 100 ms, P833 = 4 (rapid stop / fault): a late telegram would latch F43.
    md.param(
        &ParamChannel::write_volatile(index::RS485_TIMEOUT, 100),
        T::ZERO,
    )
    .unwrap();
    md.param(
        &ParamChannel::write_volatile(index::RS485_TIMEOUT_REACTION, 4),
        T::ZERO,
    )
    .unwrap();
    let request = Telegram::request(addr(1), PduType::PD3).with_process_data(&[
        ControlWord1::ENABLE.bits(),
        0,
        0,
    ]);
    let end1 = feed_request(&mut drive, request, T::from_millis(10));
    pump(&mut drive, end1 + Duration::from_millis(5));
    // The next request's check byte ends 1 ms before the deadline (end1 + 100 ms); its end is
    // confirmed by the start pause after it, 2.44 ms after the deadline.
    let start2 = end1 + (Duration::from_millis(99) - movilink::timing::CHAR_TIME * 10);
    let end2 = feed_request(&mut drive, request, start2);
    assert_eq!(end2, end1 + Duration::from_millis(99));
    pump(&mut drive, end2 + Duration::from_millis(10));
    assert_eq!(drive.movidrive().fault_number(), None);
    // Without further telegrams the monitor does fire, 100 ms after the second one.
    pump(&mut drive, end2 + Duration::from_millis(101));
    assert_eq!(
        drive.movidrive().fault_number(),
        Some(drive_sim::movidrive::FAULT_RS485_TIMEOUT)
    );
}

#[tokio::test(start_paused = true)]
async fn a_simulator_switched_to_the_virtual_clock_still_answers() {
    use movilink::driver::{Clock, Stream};
    let mut sim = SimulatedMovidrive::new(1);
    // Ten seconds on tokio's clock, one read.
    tokio::time::advance(Duration::from_secs(10)).await;
    let (a, b) = tokio::io::duplex(256);
    let client = async move {
        let mut m = MovilinkDriver::new(Stream(a), DriverConfig::default());
        m.read(addr(1), 8470).await
    };
    let (served, value) = tokio::join!(sim.serve(Stream(b)), client);
    served.unwrap();
    assert_eq!(value.unwrap(), 2000);
    // Then the same drive on the virtual clock: its line history stays valid.
    sim.set_clock(Clock::Virtual);
    let (a, b) = tokio::io::duplex(256);
    let client = async move {
        let config = DriverConfig {
            clock: Clock::Virtual,
            ..DriverConfig::default()
        };
        let mut m = MovilinkDriver::new(Stream(a), config);
        m.read(addr(1), 8470).await
    };
    let (served, value) = tokio::join!(sim.serve(Stream(b)), client);
    served.unwrap();
    assert_eq!(value.unwrap(), 2000);
}
