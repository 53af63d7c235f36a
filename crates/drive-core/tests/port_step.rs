//! `Port::step` ends the step when it hears anything: input read just before the master's frame
//! would go out may complete the request or make the master give up, and the driver must see
//! that before the port waits (an idle master has no deadline, so the wait would never end).
//!
//! The regression of `drivectl demo` hanging in its Modbus ASCII session about once in 15 runs
//! on a loaded machine: the answer's LF arrived between the step's read of what waits in the
//! port and the second read before sending; that read completed the request (an ASCII frame is
//! accepted at its LF, no end silence), nothing was due, and the port waited for input with
//! no deadline. The line here forces that timing: a character held back is readable only at
//! the second read after the one that would have returned it.

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::collections::VecDeque;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::exchange::Busy;
use drive_core::framing::{FrameTiming, Framing, LineError, Progress, Start};
use drive_core::master::{self, CharProtocol, Judgement, MasterEvent, Protocol};
use drive_core::rt::{CharIo, Clock, Driver, Failed, Flow, Port, ReceivedChar, Tally, WireTime};
use drive_core::{Exchange, ExchangeConfig, Queue};
use tokio::time::{Instant as TokioInstant, Sleep};

const START: u8 = b':';
const END: u8 = b'\n';

/// `:` address value `\n`, complete at its end character; with `end_silence` confirmed only
/// after that silence (as Modbus RTU, MOVILINK and USS frames are).
#[derive(Debug, Clone, Copy)]
struct Line {
    char_time: Duration,
    end_silence: Duration,
}

impl Framing for Line {
    type Frame = [u8; 2];
    type Error = LineError;
    fn timing(&self) -> FrameTiming {
        FrameTiming {
            char_time: self.char_time,
            start_gap: Duration::ZERO,
            max_gap: Duration::from_secs(1),
            end_silence: self.end_silence,
            ends_by_silence: false,
        }
    }
    fn start(&self, byte: u8) -> Start<LineError> {
        if byte == START {
            Start::Begin
        } else {
            Start::Ignore
        }
    }
    fn progress(&self, frame: &[u8]) -> Progress<LineError> {
        if frame.len() == 4 {
            Progress::Complete
        } else {
            Progress::More
        }
    }
    fn decode(&self, frame: &[u8]) -> Result<[u8; 2], LineError> {
        match *frame {
            [START, address, value, END] => Ok([address, value]),
            _ => Err(LineError::TrailingCharacter { byte: frame[3] }),
        }
    }
}

/// A request is an address; the answer is the value the addressed station sends.
#[derive(Debug, Clone, Copy)]
struct Ask;

type Event = MasterEvent<u8, LineError>;

impl Protocol for Ask {
    type Input = u8;
    type Request = u8;
    type Frame = [u8; 2];
    type Answer = u8;
    type Reason = LineError;
    type Failure = std::convert::Infallible;
    type Event = Event;
    type SendError = Busy;
    fn prepare(&mut self, input: u8) -> Result<u8, Busy> {
        Ok(input)
    }
    fn answered(&self, _: &u8) -> bool {
        true
    }
    fn judge(
        &mut self,
        request: &mut u8,
        [address, value]: [u8; 2],
    ) -> Judgement<u8, LineError, std::convert::Infallible> {
        if address == *request {
            Judgement::Ours(value)
        } else {
            Judgement::Foreign(LineError::TrailingCharacter { byte: address })
        }
    }
    fn report(&mut self, _: &u8, event: Event, events: &mut Queue<Event, { master::EVENTS }>) {
        events.push(event);
    }
}

impl CharProtocol for Ask {
    type Framing = Line;
    fn encode(&mut self, request: &u8, buf: &mut [u8], _: &mut Line) -> Option<usize> {
        buf.get_mut(..4)?
            .copy_from_slice(&[START, *request, 0, END]);
        Some(4)
    }
}

type AskMaster = master::Master<Ask, Exchange<Line, 8>>;

const CHAR: Duration = Duration::from_millis(1);

/// A wire-model-like line (exact arrival times): after each request written, `answer`
/// arrives one character per `CHAR`, starting 5 ms after the request has left. The character
/// at index `held` arrives at the same instant as the one before it, but between two reads:
/// the read that returns the one before stops short of it, the next read misses it, and only
/// the read after that returns it.
struct Racy {
    answer: Vec<u8>,
    held: usize,
    input: VecDeque<(TokioInstant, u8, bool)>,
    /// Whether a read missed the held character already.
    missed: bool,
    sleep: Option<Pin<Box<Sleep>>>,
    /// When the line is free for the next request.
    busy_until: Option<TokioInstant>,
}

impl Racy {
    fn new(answer: &[u8], held: usize) -> Self {
        Self {
            answer: answer.to_vec(),
            held,
            input: VecDeque::new(),
            missed: false,
            sleep: None,
            busy_until: None,
        }
    }
}

impl CharIo for Racy {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        let now = TokioInstant::now();
        let mut n = 0;
        while let Some(&(at, byte, held)) = self.input.front() {
            if at > now || n == buf.len() {
                break;
            }
            if held {
                if n > 0 {
                    break;
                }
                if !self.missed {
                    self.missed = true;
                    // It arrives right after this read: a task waiting is woken at once.
                    cx.waker().wake_by_ref();
                    return Poll::Pending;
                }
            }
            self.input.pop_front();
            buf[n] = ReceivedChar::new(byte, at);
            n += 1;
        }
        if n > 0 {
            return Poll::Ready(Ok(n));
        }
        if let Some(&(at, _, _)) = self.input.front() {
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
    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        self.poll_write_at(cx, buf, TokioInstant::now())
    }
    fn poll_write_at(
        &mut self,
        _: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<std::io::Result<usize>> {
        let left = start + CHAR * u32::try_from(buf.len()).unwrap();
        self.busy_until = Some(left);
        let first = left + Duration::from_millis(5);
        self.missed = false;
        for (i, &byte) in self.answer.iter().enumerate() {
            let k = if i == self.held { i } else { i + 1 };
            let at = first + CHAR * u32::try_from(k).unwrap();
            self.input.push_back((at, byte, i == self.held));
        }
        Poll::Ready(Ok(buf.len()))
    }
    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        match self.busy_until {
            Some(t) if t > TokioInstant::now() => {
                let sleep = self
                    .sleep
                    .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(t)));
                sleep.as_mut().reset(t);
                sleep.as_mut().poll(cx).map(Ok)
            }
            _ => Poll::Ready(Ok(())),
        }
    }
    fn honours_write_start(&self) -> bool {
        true
    }
    fn wire_time(&self) -> WireTime {
        WireTime::Exact
    }
}

/// One request to address 1 on `line` with `end_silence`, `retries` retransmissions: the
/// answer or why none was taken, within 10 s of tokio's (paused) clock.
async fn ask(
    line: Racy,
    end_silence: Duration,
    retries: u8,
) -> Result<Option<u8>, Failed<LineError>> {
    let framing = Line {
        char_time: CHAR,
        end_silence,
    };
    let config = ExchangeConfig {
        response_timeout: Duration::from_millis(100),
        retries,
        retry_pause: Duration::from_millis(2),
        unanswered_hold: Duration::ZERO,
        min_idle_gap: Duration::from_millis(2),
    };
    let master = AskMaster::from_parts(Ask, Exchange::new(framing, config));
    let mut driver = Driver::new(Port::new(line, Clock::Real, CHAR), master);
    let now = driver.prepare();
    driver.master_mut().send(1, now).unwrap();
    let mut tally = Tally::default();
    let run = driver.run(&mut tally, |m| m.poll_event().map(Flow::from));
    tokio::time::timeout(Duration::from_secs(10), run)
        .await
        .expect("the transaction never ended: the port waited with no deadline")
}

/// The answer's end character arrives between the step's read and the read before sending:
/// it completes the request (no end silence, as Modbus ASCII), and the driver takes it.
#[tokio::test(start_paused = true)]
async fn an_answer_completed_by_the_read_before_sending_is_taken() {
    let answer = [START, 1, 42, END];
    let r = ask(Racy::new(&answer, 3), Duration::ZERO, 2).await;
    assert_eq!(r.unwrap(), Some(42));
}

/// A character right after a complete answer, within its end silence (Modbus RTU, MOVILINK,
/// USS), heard in the read before sending on the last attempt: the master gives up, and the
/// driver says so instead of waiting.
#[tokio::test(start_paused = true)]
async fn a_give_up_caused_by_the_read_before_sending_ends_the_transaction() {
    let answer = [START, 1, 42, END, 0x55];
    let r = ask(Racy::new(&answer, 4), Duration::from_millis(3), 0).await;
    match r {
        Err(Failed::Corrupt { attempts: 1, .. }) => {}
        other => panic!("expected the give-up after one attempt, got {other:?}"),
    }
}
