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
use drive_core::rt::{Clock, Port, Stream, Timebase, serve};
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
        if let Some(RxEvent::Frame((payload, n))) = self.rx.handle_char(c) {
            if payload[0] == self.address {
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
}

async fn run<IO: drive_core::rt::CharIo>(
    port: &mut Port<IO>,
    m: &mut Master,
) -> Result<([u8; 8], usize), u16> {
    let mut buf = [0u8; 16];
    loop {
        if let Some(r) = m.result {
            return r;
        }
        if port.transmit(m, &mut buf).await.unwrap().is_some() {
            continue;
        }
        assert!(port.wait(m).await.unwrap(), "line closed");
    }
}

async fn session(clock: Clock) -> (Vec<Result<([u8; 8], usize), u16>>, u32) {
    let line = LineSettings::new(19200);
    let toy = Toy { line };
    let (a, b) = tokio::io::duplex(256);
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(20),
        retries: 1,
        retry_pause: line.char_times(4, 1),
        unanswered_hold: Duration::ZERO,
    };
    let mut master = Master {
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
    let mut port = Port::new(Stream(a), clock, line.char_time());
    let mut results = Vec::new();
    for (address, payload) in [(3u8, [10u8, 20]), (7, [1, 2]), (9, [0, 0])] {
        master.send(address, &payload, port.now());
        results.push(run(&mut port, &mut master).await);
    }
    drop(port);
    (results, stations.await.unwrap())
}

#[tokio::test(start_paused = true)]
async fn a_master_and_two_stations_of_another_protocol_on_the_real_clock() {
    let (results, requests) = session(Clock::Real).await;
    assert_eq!(results[0].unwrap().0[..3], [3, 11, 21]);
    assert_eq!(results[1].unwrap().0[..3], [7, 2, 3]);
    // Nobody at 9: given up after 1 retry.
    assert_eq!(results[2], Err(2));
    assert_eq!(requests, 2);
}

#[tokio::test]
async fn the_same_session_on_the_virtual_clock() {
    let (results, requests) = session(Clock::Virtual).await;
    assert_eq!(results[0].unwrap().0[..3], [3, 11, 21]);
    assert_eq!(results[1].unwrap().0[..3], [7, 2, 3]);
    assert_eq!(results[2], Err(2));
    assert_eq!(requests, 2);
}
