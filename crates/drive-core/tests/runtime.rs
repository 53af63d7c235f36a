//! The runtime layer with a protocol that is not MOVILINK: a small USS-like framing (STX, length,
//! payload, XOR), a master on drive-core's transaction skeleton driven by `Port`, and two
//! stations served by `serve` over a tokio duplex stream. Nothing here is specific to one
//! protocol: this is what every protocol's async driver and simulator are made of.

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::time::Duration;

use drive_core::framing::{FrameTiming, Framing, LineError, Progress, Start};
use drive_core::master::Control;
use drive_core::rt::{Clock, Driver, Failed, Flow, Port, Stream, Tally, Timebase, serve};
use drive_core::{
    Endpoint, Exchange, ExchangeConfig, ExchangeEvent, Instant, LineSettings, Receiver, RxChar,
    RxEvent, Verdict,
};

const STX: u8 = 0x02;

/// `STX, n, address, payload…, xor`: n counts address, payload and xor.
#[derive(Debug, Clone, Copy)]
struct Toy {
    line: LineSettings,
}

impl Framing for Toy {
    type Frame = ([u8; 8], usize);
    type Error = LineError;
    fn timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: self.line.char_time(),
            start_gap: self.line.char_times(2, 1),
            max_gap: self.line.char_times(2, 1),
            end_silence: Duration::ZERO,
            ends_by_silence: false,
        }
    }
    fn start(&self, byte: u8) -> Start<LineError> {
        if byte == STX {
            Start::Begin
        } else {
            Start::Ignore
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<LineError> {
        match frame.get(1) {
            Some(&n) if frame.len() == usize::from(n) + 2 => Progress::Complete,
            _ => Progress::More,
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<([u8; 8], usize), LineError> {
        let (xor, body) = frame
            .split_last()
            .ok_or(LineError::TooLong { capacity: 0 })?;
        if body.iter().fold(0, |a, b| a ^ b) != *xor {
            return Err(LineError::TrailingCharacter { byte: *xor });
        }
        let mut out = [0u8; 8];
        let payload = body.get(2..).unwrap_or(&[]);
        for (d, s) in out.iter_mut().zip(payload) {
            *d = *s;
        }
        Ok((out, payload.len()))
    }
}

fn encode(address: u8, payload: &[u8], buf: &mut [u8]) -> usize {
    let n = payload.len() + 2;
    buf[0] = STX;
    buf[1] = n as u8;
    buf[2] = address;
    buf[3..3 + payload.len()].copy_from_slice(payload);
    let xor = buf[..n + 1].iter().fold(0, |a, b| a ^ b);
    buf[n + 1] = xor;
    n + 2
}

/// A station that answers requests to its address with the payload incremented.
struct Station {
    address: u8,
    rx: Receiver<Toy, 16>,
    answer: Option<([u8; 16], usize, Instant)>,
    requests: u32,
}

impl Endpoint for Station {
    fn handle_char(&mut self, c: RxChar) {
        if let Some(RxEvent::Frame((payload, n))) = self.rx.handle_char(c)
            && payload[0] == self.address
        {
            self.requests += 1;
            let mut reply = [0u8; 8];
            reply[0] = self.address;
            for i in 1..n {
                reply[i] = payload[i].wrapping_add(1);
            }
            let mut buf = [0u8; 16];
            let len = encode(self.address, &reply[1..n], &mut buf);
            // Answer after two character times of silence.
            let due = c.time + self.rx.timing().start_gap;
            self.answer = Some((buf, len, due));
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        let _ = self.rx.handle_timeout(now);
    }
    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let (bytes, len, due) = self.answer?;
        if now < due {
            return None;
        }
        buf[..len].copy_from_slice(&bytes[..len]);
        self.answer = None;
        Some(len)
    }
    fn poll_timeout(&self) -> Option<Instant> {
        [self.answer.map(|a| a.2), self.rx.poll_timeout()]
            .into_iter()
            .flatten()
            .min()
    }
    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.answer.map(|a| a.2)
    }
    fn max_frame_len(&self) -> usize {
        16
    }
}

/// A master: one request at a time on the transaction skeleton.
struct Master {
    x: Exchange<Toy, 16>,
    request: Option<([u8; 16], usize)>,
    result: Option<Result<([u8; 8], usize), u16>>,
}

impl Master {
    fn send(&mut self, address: u8, payload: &[u8], now: Instant) {
        let mut buf = [0u8; 16];
        let n = encode(address, payload, &mut buf);
        self.x.begin(now).unwrap();
        self.request = Some((buf, n));
        self.result = None;
    }
    fn on(&mut self, ev: Option<ExchangeEvent<([u8; 8], usize), LineError>>) {
        match ev {
            Some(ExchangeEvent::Frame(f)) => {
                self.x.complete();
                self.result = Some(Ok(f));
            }
            Some(ExchangeEvent::Rejected(_, Verdict::GiveUp { attempts }))
            | Some(ExchangeEvent::NoAnswer(Verdict::GiveUp { attempts })) => {
                self.result = Some(Err(attempts));
            }
            _ => {}
        }
    }
}

impl Endpoint for Master {
    fn handle_char(&mut self, c: RxChar) {
        let ev = self.x.handle_char(c);
        self.on(ev);
    }
    fn handle_timeout(&mut self, now: Instant) {
        let ev = self.x.handle_timeout(now);
        self.on(ev);
    }
    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        let (bytes, n) = self.request?;
        if !self.x.may_transmit(now) {
            return None;
        }
        buf[..n].copy_from_slice(&bytes[..n]);
        self.x.transmitted(n, true);
        Some(n)
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.x.poll_timeout()
    }
    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.x.poll_quiet_timeout()
    }
    fn max_frame_len(&self) -> usize {
        16
    }
    fn frame_left(&mut self, at: Instant) {
        self.x.left_at(at);
    }
    fn stale_chars(&self) -> u64 {
        self.x.stale_chars()
    }
}

impl Control for Master {
    fn is_idle(&self) -> bool {
        self.x.is_idle()
    }
    fn abort(&mut self, now: Instant) {
        self.x.abort(now);
    }
    fn clear_events(&mut self) {}
    fn stale(&self) -> u64 {
        self.x.stale_chars()
    }
}

/// One request through the runtime driver's transaction loop ([`Driver::run`]): the answer,
/// or the attempts after which the master gave up; and what the loop counted.
async fn run<IO: drive_core::rt::CharIo>(
    driver: &mut Driver<Port<IO>, Master>,
) -> (Result<([u8; 8], usize), u16>, Tally) {
    let mut tally = Tally::default();
    let r = driver
        .run(&mut tally, |m| {
            m.result.take().map(|r| match r {
                Ok(frame) => Flow::<_, LineError>::Done(frame),
                Err(attempts) => Flow::GaveUp { attempts },
            })
        })
        .await;
    let r = match r {
        Ok(frame) => Ok(frame),
        Err(Failed::NoAnswer { attempts }) => Err(u16::try_from(attempts).unwrap()),
        Err(Failed::Corrupt { reason, .. }) => panic!("nothing answered at all, but {reason:?}"),
        Err(Failed::Io(e)) => panic!("{e}"),
        Err(Failed::Ended(e)) => match e {},
    };
    (r, tally)
}

async fn session(clock: Clock) -> (Vec<(Result<([u8; 8], usize), u16>, Tally)>, u32) {
    let line = LineSettings::new(19200);
    let toy = Toy { line };
    let (a, b) = tokio::io::duplex(256);
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(20),
        retries: 1,
        retry_pause: line.char_times(4, 1),
        unanswered_hold: Duration::ZERO,
        min_idle_gap: Duration::ZERO,
    };
    let master = Master {
        x: Exchange::new(toy, config),
        request: None,
        result: None,
    };
    let stations = tokio::spawn(async move {
        let mut stations: Vec<Station> = [3u8, 7]
            .into_iter()
            .map(|address| Station {
                address,
                rx: Receiver::new(toy),
                answer: None,
                requests: 0,
            })
            .collect();
        let mut time = Timebase::new(clock, line.char_time());
        serve(&mut stations, &mut time, Stream(b)).await.unwrap();
        stations.iter().map(|s| s.requests).sum::<u32>()
    });
    let port = Port::new(Stream(a), clock, line.char_time());
    let mut driver = Driver::new(port, master);
    let mut results = Vec::new();
    for (address, payload) in [(3u8, [10u8, 20]), (7, [1, 2]), (9, [0, 0])] {
        let now = driver.prepare();
        driver.master_mut().send(address, &payload, now);
        results.push(run(&mut driver).await);
    }
    drop(driver);
    (results, stations.await.unwrap())
}

#[tokio::test(start_paused = true)]
async fn a_master_and_two_stations_of_another_protocol_on_the_real_clock() {
    let (results, requests) = session(Clock::Real).await;
    assert_eq!(results[0].0.unwrap().0[..3], [3, 11, 21]);
    assert_eq!(results[1].0.unwrap().0[..3], [7, 2, 3]);
    // Nobody at 9: given up after 1 retry.
    assert_eq!(results[2].0, Err(2));
    assert_eq!(requests, 2);
    // The loop counted one transmission for each answered request, two for the last.
    let tallies: Vec<(u32, u32, u32)> = results
        .iter()
        .map(|(_, t)| (t.sent, t.retries, t.rejected))
        .collect();
    assert_eq!(tallies, [(1, 0, 0), (1, 0, 0), (2, 1, 0)]);
}

#[tokio::test]
async fn the_same_session_on_the_virtual_clock() {
    let (results, requests) = session(Clock::Virtual).await;
    assert_eq!(results[0].0.unwrap().0[..3], [3, 11, 21]);
    assert_eq!(results[1].0.unwrap().0[..3], [7, 2, 3]);
    assert_eq!(results[2].0, Err(2));
    assert_eq!(requests, 2);
    assert_eq!(results[2].1.sent, 2);
}

// ----- The port's waiting rules, on a line whose received characters are scripted -----

use std::collections::VecDeque;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::{Context, Poll};

use drive_core::rt::{CharIo, ReceivedChar};
use tokio::time::{Instant as TokioInstant, Sleep};

/// A line whose received characters are scripted: each becomes readable at its arrival time
/// on tokio's clock and carries that time; what is written is swallowed.
#[derive(Default)]
struct Scripted {
    chars: VecDeque<(TokioInstant, u8)>,
    sleep: Option<Pin<Box<Sleep>>>,
}

impl Scripted {
    fn new(chars: impl IntoIterator<Item = (TokioInstant, u8)>) -> Self {
        Self {
            chars: chars.into_iter().collect(),
            sleep: None,
        }
    }
}

impl CharIo for Scripted {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        let Some(&(at, byte)) = self.chars.front() else {
            return Poll::Pending;
        };
        if at > TokioInstant::now() {
            let sleep = self
                .sleep
                .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(at)));
            sleep.as_mut().reset(at);
            if sleep.as_mut().poll(cx).is_pending() {
                return Poll::Pending;
            }
        }
        self.chars.pop_front();
        buf[0] = ReceivedChar::new(byte, at);
        Poll::Ready(Ok(1))
    }
    fn poll_write(&mut self, _: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        Poll::Ready(Ok(buf.len()))
    }
    fn poll_flush(&mut self, _: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

use std::future::Future as _;

/// An endpoint with one fixed deadline that records what it is fed.
struct Recorder {
    deadline: Option<Instant>,
    quiet: Option<Instant>,
    log: Vec<String>,
}

impl Recorder {
    fn new(deadline: Option<Instant>, quiet: Option<Instant>) -> Self {
        Self {
            deadline,
            quiet,
            log: Vec::new(),
        }
    }
}

impl Endpoint for Recorder {
    fn handle_char(&mut self, c: RxChar) {
        self.log
            .push(format!("char {:#04x} at {} µs", c.byte, c.time.as_micros()));
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.log.push(format!("timeout at {} µs", now.as_micros()));
    }
    fn poll_transmit(&mut self, _: Instant, _: &mut [u8]) -> Option<usize> {
        None
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.deadline
    }
    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.quiet
    }
    fn max_frame_len(&self) -> usize {
        0
    }
}

#[tokio::test(start_paused = true)]
async fn characters_that_wait_are_fed_before_a_passed_deadline() {
    let epoch = TokioInstant::now();
    let line = Scripted::new([(epoch + Duration::from_millis(5), 0x55)]);
    let mut port = Port::new(line, Clock::Real, Duration::from_micros(1_146));
    let mut rec = Recorder::new(Some(Instant::from_millis(10)), None);
    // The task comes back to the port only at 20 ms: the character of 5 ms is older than the
    // deadline of 10 ms and goes first.
    tokio::time::advance(Duration::from_millis(20)).await;
    assert!(port.wait(&mut rec).await.unwrap());
    assert!(port.wait(&mut rec).await.unwrap());
    assert_eq!(rec.log, ["char 0x55 at 5000 µs", "timeout at 20000 µs"]);
}

#[tokio::test(start_paused = true)]
async fn a_deadline_that_stays_in_the_past_does_not_starve_the_runtime() {
    let ran = Arc::new(AtomicBool::new(false));
    let flag = ran.clone();
    tokio::spawn(async move { flag.store(true, Ordering::SeqCst) });
    let mut port = Port::new(
        Scripted::default(),
        Clock::Real,
        Duration::from_micros(1_146),
    );
    // An endpoint whose deadline never moves (a bug in it, or a deadline it cannot act on):
    // the port's loop must still let other tasks run.
    let mut stuck = Recorder::new(Some(Instant::ZERO), None);
    for _ in 0..10_000 {
        assert!(port.wait(&mut stuck).await.unwrap());
        if ran.load(Ordering::SeqCst) {
            break;
        }
    }
    assert!(ran.load(Ordering::SeqCst), "the other task never ran");
}

#[tokio::test(start_paused = true)]
async fn the_virtual_clock_waits_when_a_quiet_deadline_brings_no_progress() {
    let mut port = Port::new(
        Scripted::default(),
        Clock::Virtual,
        Duration::from_micros(1_146),
    );
    let mut stuck = Recorder::new(None, Some(Instant::ZERO));
    assert!(port.wait(&mut stuck).await.unwrap());
    // Handled once at 0; the same deadline again at the same time is waited for (nothing
    // else can happen here), not handled in a loop.
    let again = tokio::time::timeout(Duration::from_secs(1), port.wait(&mut stuck)).await;
    assert!(again.is_err(), "returned {again:?}");
    assert_eq!(stuck.log, ["timeout at 0 µs"]);
}

#[tokio::test(start_paused = true)]
async fn the_virtual_clock_measures_a_gap_limit_from_the_last_character() {
    // An answer whose characters come 1.5 ms apart in real time, on a line whose virtual
    // character time is 0.573 ms with a gap limit of two characters: each gap is within one
    // character time plus the gap limit (1.72 ms) of the character before it.
    let line = LineSettings::new(19200);
    let toy = Toy { line };
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(20),
        retries: 0,
        retry_pause: line.char_times(4, 1),
        unanswered_hold: Duration::ZERO,
        min_idle_gap: Duration::ZERO,
    };
    let master = Master {
        x: Exchange::new(toy, config),
        request: None,
        result: None,
    };
    let mut answer = [0u8; 16];
    let n = encode(3, &[1, 2, 3, 4, 5, 6], &mut answer);
    let epoch = TokioInstant::now();
    let script = answer[..n].iter().enumerate().map(|(i, &b)| {
        (
            epoch + Duration::from_millis(1) + Duration::from_micros(1_500) * i as u32,
            b,
        )
    });
    let port = Port::new(Scripted::new(script), Clock::Virtual, line.char_time());
    let mut driver = Driver::new(port, master);
    let now = driver.prepare();
    driver.master_mut().send(3, &[0, 1, 2, 3, 4, 5], now);
    let (result, _) = run(&mut driver).await;
    assert_eq!(
        result.map(|r| r.0[..7].to_vec()),
        Ok(vec![3, 1, 2, 3, 4, 5, 6])
    );
}

/// An endpoint that claims a frame longer than the buffer it was given.
struct Overlong;

impl Endpoint for Overlong {
    fn handle_char(&mut self, _: RxChar) {}
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_transmit(&mut self, _: Instant, buf: &mut [u8]) -> Option<usize> {
        Some(buf.len() + 1)
    }
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
    fn poll_quiet_timeout(&self) -> Option<Instant> {
        None
    }
    fn max_frame_len(&self) -> usize {
        4
    }
}

#[tokio::test(start_paused = true)]
async fn a_frame_longer_than_its_buffer_is_an_error_not_a_cut_frame() {
    let mut port = Port::new(
        Scripted::default(),
        Clock::Real,
        Duration::from_micros(1_146),
    );
    let mut buf = [0u8; 4];
    let err = port.transmit(&mut Overlong, &mut buf).await.unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidData);
    assert!(
        err.to_string().contains("5-byte frame in a 4-byte buffer"),
        "{err}"
    );

    let mut time = Timebase::new(Clock::Real, Duration::from_micros(1_146));
    let err = serve(&mut [Overlong], &mut time, Scripted::default())
        .await
        .unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidData);
}

// ----- Exact frame starts despite tokio's 1 ms timers -----

/// A line that records every write with the start it was meant for, and places the frame the
/// way the wire model does (`max(start, now − 1 ms)`, never before the previous frame's end):
/// what it reads is nothing, until `close` says the port was closed.
#[derive(Default)]
struct Wire {
    char_time: Duration,
    /// (intended start if any, tokio time of the write, wire start, bytes).
    writes: Vec<(Option<TokioInstant>, TokioInstant, TokioInstant, Vec<u8>)>,
    busy_until: Option<TokioInstant>,
    close_after: usize,
}

impl Wire {
    fn new(char_time: Duration, close_after: usize) -> Self {
        Self {
            char_time,
            close_after,
            ..Self::default()
        }
    }

    fn put(&mut self, buf: &[u8], start: Option<TokioInstant>) -> usize {
        let now = TokioInstant::now();
        let earliest = start.map_or(now, |s| {
            s.max(now - drive_core::rt::TIMER_RESOLUTION).min(now)
        });
        let wire_start = self.busy_until.map_or(earliest, |b| b.max(earliest));
        self.busy_until = Some(wire_start + self.char_time * buf.len() as u32);
        self.writes.push((start, now, wire_start, buf.to_vec()));
        buf.len()
    }
}

impl CharIo for Wire {
    fn poll_read_chars(
        &mut self,
        _: &mut Context<'_>,
        _: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        if self.close_after > 0 && self.writes.len() >= self.close_after {
            Poll::Ready(Ok(0))
        } else {
            Poll::Pending
        }
    }
    fn poll_write(&mut self, _: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        Poll::Ready(Ok(self.put(buf, None)))
    }
    fn poll_write_at(
        &mut self,
        _: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<std::io::Result<usize>> {
        Poll::Ready(Ok(self.put(buf, Some(start))))
    }
    fn honours_write_start(&self) -> bool {
        true
    }
    fn poll_flush(&mut self, _: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

/// An endpoint that sends `frame` once its deadline has come, and records the times it is
/// told.
struct Due {
    at: Option<Instant>,
    frame: &'static [u8],
    ready: bool,
    log: Vec<String>,
}

impl Due {
    fn new(at: Instant, frame: &'static [u8]) -> Self {
        Self {
            at: Some(at),
            frame,
            ready: false,
            log: Vec::new(),
        }
    }
}

impl Endpoint for Due {
    fn handle_char(&mut self, _: RxChar) {}
    fn handle_timeout(&mut self, now: Instant) {
        self.log.push(format!("timeout at {} µs", now.as_micros()));
        if self.at.is_some_and(|at| now >= at) {
            self.at = None;
            self.ready = true;
        }
    }
    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        if !self.ready {
            return None;
        }
        self.ready = false;
        self.log.push(format!("transmit at {} µs", now.as_micros()));
        buf.get_mut(..self.frame.len())?.copy_from_slice(self.frame);
        Some(self.frame.len())
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.at
    }
    fn poll_quiet_timeout(&self) -> Option<Instant> {
        None
    }
    fn max_frame_len(&self) -> usize {
        self.frame.len()
    }
}

/// A frame due at 2.345 ms (between tokio's ticks): tokio's timer ends at 3 ms, but the master
/// is told 2.345 ms, `Port::now` says so, and the frame is written with that start, so the
/// wire puts it there, not on the tick.
#[tokio::test(start_paused = true)]
async fn a_port_frame_due_between_ticks_starts_on_the_wire_at_its_deadline() {
    let char_time = Duration::from_nanos(572_917);
    let mut port = Port::new(Wire::new(char_time, 0), Clock::Real, char_time);
    let epoch = port.timebase().epoch();
    let due = Instant::from_micros(2_345);
    let mut master = Due::new(due, &[0x01, 0x03]);
    let mut buf = [0u8; 8];
    assert_eq!(port.transmit(&mut master, &mut buf).await.unwrap(), None);
    assert!(port.wait(&mut master).await.unwrap());
    // tokio woke on its next 1 ms tick …
    let woke = TokioInstant::now() - epoch;
    assert!(woke > Duration::from_micros(2_345) && woke <= Duration::from_millis(3));
    // … the endpoint's time is the deadline.
    assert_eq!(port.now(), due);
    assert_eq!(port.transmit(&mut master, &mut buf).await.unwrap(), Some(2));
    assert_eq!(master.log, ["timeout at 2345 µs", "transmit at 2345 µs"]);
    let (start, written, on_wire, bytes) = port.get_ref().writes[0].clone();
    assert_eq!(start, Some(epoch + Duration::from_micros(2_345)));
    assert!(written > on_wire, "written on the tick, after the deadline");
    assert_eq!(on_wire - epoch, Duration::from_micros(2_345));
    assert_eq!(bytes, [0x01, 0x03]);
    // Once time has moved on by more than the timer's resolution, now is tokio's again.
    tokio::time::advance(Duration::from_millis(2)).await;
    assert_eq!(
        port.now().as_duration(),
        TokioInstant::now() - epoch,
        "a stale deadline must not hold the port's time back"
    );
}

/// The same in `serve`: a station's answer due at 10.417 ms starts there on the wire.
#[tokio::test(start_paused = true)]
async fn a_served_frame_due_between_ticks_starts_on_the_wire_at_its_deadline() {
    let char_time = Duration::from_nanos(572_917);
    let mut time = Timebase::new(Clock::Real, char_time);
    let epoch = time.epoch();
    let mut stations = [Due::new(Instant::from_micros(10_417), &[0x01, 0x03, 0x02])];
    let mut wire = Wire::new(char_time, 1);
    serve(&mut stations, &mut time, &mut wire).await.unwrap();
    assert_eq!(
        stations[0].log,
        ["timeout at 10417 µs", "transmit at 10417 µs"]
    );
    let (start, written, on_wire, _) = wire.writes[0].clone();
    assert_eq!(start, Some(epoch + Duration::from_micros(10_417)));
    assert_eq!(written - epoch, Duration::from_millis(11));
    assert_eq!(on_wire - epoch, Duration::from_micros(10_417));
}

/// A wake-up later than the timer's resolution (the task was busy) is not backdated: the
/// endpoint is told now and the frame starts now.
#[tokio::test(start_paused = true)]
async fn a_late_wake_up_is_not_backdated() {
    let char_time = Duration::from_nanos(572_917);
    let mut port = Port::new(Wire::new(char_time, 0), Clock::Real, char_time);
    let mut master = Due::new(Instant::from_micros(2_345), &[0x01]);
    tokio::time::advance(Duration::from_millis(5)).await;
    assert!(port.wait(&mut master).await.unwrap());
    let mut buf = [0u8; 4];
    assert_eq!(port.transmit(&mut master, &mut buf).await.unwrap(), Some(1));
    assert_eq!(master.log, ["timeout at 5000 µs", "transmit at 5000 µs"]);
    let (_, written, on_wire, _) = port.get_ref().writes[0].clone();
    assert_eq!(on_wire, written);
    assert_eq!(on_wire - port.timebase().epoch(), Duration::from_millis(5));
}

/// A port that sends when it is written to (a real serial port): it cannot place a frame in
/// the past.
struct SendsNow(Wire);

impl CharIo for SendsNow {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        self.0.poll_read_chars(cx, buf)
    }
    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        self.0.poll_write(cx, buf)
    }
    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        self.0.poll_flush(cx)
    }
}

/// On a port that sends when written to, the endpoint keeps tokio's time at the wake-up (the
/// frame really leaves then), so its response timeout counts from the request's true end.
#[tokio::test(start_paused = true)]
async fn a_port_that_sends_now_keeps_tokios_time() {
    let char_time = Duration::from_nanos(572_917);
    let mut port = Port::new(SendsNow(Wire::new(char_time, 0)), Clock::Real, char_time);
    let epoch = port.timebase().epoch();
    let mut master = Due::new(Instant::from_micros(2_345), &[0x01, 0x03]);
    assert!(port.wait(&mut master).await.unwrap());
    let woke = TokioInstant::now() - epoch;
    assert_eq!(port.now().as_duration(), woke);
    let mut buf = [0u8; 8];
    assert_eq!(port.transmit(&mut master, &mut buf).await.unwrap(), Some(2));
    let told = woke.as_micros();
    assert_eq!(
        master.log,
        [
            format!("timeout at {told} µs"),
            format!("transmit at {told} µs")
        ]
    );
    let (start, written, on_wire, _) = port.get_ref().0.writes[0].clone();
    assert_eq!(start, None);
    assert_eq!(on_wire, written);
}

// ----- Issue 18: stale characters on the port -----

use drive_core::rt::WireTime;

/// A line for the stale rules: characters readable from given instants and timed when read
/// (as a serial port or a pseudo-terminal times them), bytes that appear while a frame is
/// written (they arrived while it was leaving), the drive's answer a while after each write,
/// and the wire time the line declares.
struct Line {
    wire: WireTime,
    input: VecDeque<(TokioInstant, u8)>,
    sleep: Option<Pin<Box<Sleep>>>,
    /// Readable as soon as the next frame has been written.
    during_write: Vec<u8>,
    /// Readable this long after each write, with this delay.
    answer: Option<(Duration, Vec<u8>)>,
}

impl Line {
    fn new(wire: WireTime) -> Self {
        Self {
            wire,
            input: VecDeque::new(),
            sleep: None,
            during_write: Vec::new(),
            answer: None,
        }
    }
    fn readable(&mut self, at: TokioInstant, bytes: &[u8]) {
        self.input.extend(bytes.iter().map(|&b| (at, b)));
        self.input.make_contiguous().sort_by_key(|&(t, _)| t);
    }
}

impl CharIo for Line {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        let now = TokioInstant::now();
        let mut n = 0;
        while let Some(&(at, byte)) = self.input.front() {
            if at > now || n == buf.len() {
                break;
            }
            self.input.pop_front();
            buf[n] = ReceivedChar::new(byte, now);
            n += 1;
        }
        if n > 0 {
            return Poll::Ready(Ok(n));
        }
        if let Some(&(at, _)) = self.input.front() {
            let sleep = self
                .sleep
                .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(at)));
            sleep.as_mut().reset(at);
            if sleep.as_mut().poll(cx).is_ready() {
                cx.waker().wake_by_ref();
            }
        }
        Poll::Pending
    }
    fn poll_write(&mut self, _: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        let now = TokioInstant::now();
        let during = std::mem::take(&mut self.during_write);
        self.readable(now, &during);
        if let Some((delay, bytes)) = self.answer.clone() {
            self.readable(now + delay, &bytes);
        }
        Poll::Ready(Ok(buf.len()))
    }
    fn poll_flush(&mut self, _: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Poll::Ready(Ok(()))
    }
    fn wire_time(&self) -> WireTime {
        self.wire
    }
}

/// The Toy master of this file, for a request to station 3 on `line` at 9600 baud (8E1,
/// 1.146 ms per character): `(answer payload, what the transaction counted)`.
async fn stale_session(line: Line) -> (Result<([u8; 8], usize), u16>, Tally) {
    let settings = LineSettings::new(9600);
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(50),
        retries: 0,
        retry_pause: settings.char_times(4, 1),
        unanswered_hold: Duration::ZERO,
        min_idle_gap: Duration::ZERO,
    };
    let master = Master {
        x: Exchange::new(Toy { line: settings }, config),
        request: None,
        result: None,
    };
    let port = Port::new(line, Clock::Real, settings.char_time());
    let mut driver = Driver::new(port, master);
    let now = driver.prepare();
    driver.master_mut().send(3, &[10, 20], now);
    run(&mut driver).await
}

fn frame(address: u8, payload: &[u8]) -> Vec<u8> {
    let mut buf = [0u8; 16];
    let n = encode(address, payload, &mut buf);
    buf[..n].to_vec()
}

/// The request of `stale_session` is 6 characters: 6.875 ms on the wire at 9600 8E1.
const REQUEST_WIRE_TIME: Duration = Duration::from_nanos(6 * 1_145_834);

/// An answer an earlier program left waiting in the port is heard before the request goes out:
/// stale (counted, never the answer) on every kind of port, even with no retries.
#[tokio::test(start_paused = true)]
async fn issue18_an_answer_waiting_in_the_port_is_stale_on_every_kind_of_port() {
    for wire in [
        WireTime::Real,
        WireTime::None,
        WireTime::Unknown,
        WireTime::Exact,
    ] {
        let mut line = Line::new(wire);
        line.readable(TokioInstant::now(), &frame(3, &[99, 99]));
        line.answer = Some((
            REQUEST_WIRE_TIME + Duration::from_millis(5),
            frame(3, &[11, 21]),
        ));
        let (r, tally) = stale_session(line).await;
        assert_eq!(r.unwrap().0[..3], [3, 11, 21], "{wire:?}");
        assert_eq!((tally.sent, tally.stale), (1, 6), "{wire:?}");
    }
}

/// What arrives while the request is being written arrived before it had left: stale on a
/// serial port and on a pseudo-terminal (read right after the write); on a real line also what
/// comes after the write returned but within the request's wire time.
#[tokio::test(start_paused = true)]
async fn issue18_what_arrives_while_the_request_leaves_is_stale() {
    for wire in [WireTime::Real, WireTime::None] {
        let mut line = Line::new(wire);
        line.during_write = frame(3, &[99, 99]);
        line.answer = Some((
            REQUEST_WIRE_TIME + Duration::from_millis(5),
            frame(3, &[11, 21]),
        ));
        let (r, tally) = stale_session(line).await;
        assert_eq!(r.unwrap().0[..3], [3, 11, 21], "{wire:?}");
        assert_eq!(tally.stale, 6, "{wire:?}");
    }
    // A real line: a frame 2 ms after the write is still within the request's 6.9 ms.
    let mut line = Line::new(WireTime::Real);
    let start = TokioInstant::now();
    line.readable(start + Duration::from_millis(2), &frame(3, &[99, 99]));
    line.answer = Some((
        REQUEST_WIRE_TIME + Duration::from_millis(5),
        frame(3, &[11, 21]),
    ));
    let (r, tally) = stale_session(line).await;
    assert_eq!(r.unwrap().0[..3], [3, 11, 21]);
    assert_eq!(tally.stale, 6);
}

/// A pseudo-terminal carries no wire time: the other side answers as soon as it has read the
/// request, long before its wire time is over, and that answer is taken.
#[tokio::test(start_paused = true)]
async fn issue18_an_early_answer_on_a_pseudo_terminal_is_the_answer() {
    let mut line = Line::new(WireTime::None);
    line.answer = Some((Duration::from_millis(1), frame(3, &[11, 21])));
    let (r, tally) = stale_session(line).await;
    assert_eq!(r.unwrap().0[..3], [3, 11, 21]);
    assert_eq!(tally.stale, 0);
}
