//! Shared helpers: addresses, a tap that logs received characters, a port that fails.

use std::io;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use movilink::Address;
use movilink::driver::{CharIo, ReceivedChar};
use tokio::time::Instant;

/// 11 bits at 9600 baud.
pub const CHAR: Duration = Duration::from_nanos(1_145_833);
/// The manual's start pause.
pub const START_PAUSE: Duration = Duration::from_micros(3440);

pub fn addr(a: u8) -> Address {
    Address::new(a).expect("valid address")
}

/// A port that logs every character it receives (with the exact arrival time).
pub struct Tap<IO> {
    pub inner: IO,
    pub log: Arc<Mutex<Vec<ReceivedChar>>>,
}

impl<IO> Tap<IO> {
    pub fn new(inner: IO) -> (Self, Arc<Mutex<Vec<ReceivedChar>>>) {
        let log = Arc::new(Mutex::new(Vec::new()));
        (
            Self {
                inner,
                log: log.clone(),
            },
            log,
        )
    }
}

impl<IO: CharIo> CharIo for Tap<IO> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        let r = self.inner.poll_read_chars(cx, buf);
        if let Poll::Ready(Ok(n)) = r {
            self.log.lock().unwrap().extend_from_slice(&buf[..n]);
        }
        r
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        self.inner.poll_write(cx, buf)
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        self.inner.poll_flush(cx)
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: tokio::time::Instant,
    ) -> Poll<io::Result<usize>> {
        self.inner.poll_write_at(cx, buf, start)
    }

    fn honours_write_start(&self) -> bool {
        self.inner.honours_write_start()
    }

    fn wire_time(&self) -> drive_core::rt::WireTime {
        self.inner.wire_time()
    }
}

/// A port whose next write takes `partial` bytes and then fails (once).
pub struct FailOnce<IO> {
    pub inner: IO,
    pub fail_after: Option<usize>,
}

impl<IO: CharIo> CharIo for FailOnce<IO> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        self.inner.poll_read_chars(cx, buf)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        match self.fail_after {
            Some(0) => {
                self.fail_after = None;
                Poll::Ready(Err(io::Error::other("simulated write failure")))
            }
            Some(k) => {
                let n = k.min(buf.len());
                match self.inner.poll_write(cx, &buf[..n]) {
                    Poll::Ready(Ok(done)) => {
                        self.fail_after = Some(k - done);
                        Poll::Ready(Ok(done))
                    }
                    other => other,
                }
            }
            None => self.inner.poll_write(cx, buf),
        }
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        self.inner.poll_flush(cx)
    }
}

/// A telegram seen on the line: when its first character started and its last one ended.
#[derive(Debug, Clone)]
pub struct Seen {
    pub bytes: Vec<u8>,
    pub start: Instant,
    pub end: Instant,
}

/// Split logged characters into telegrams: a new one starts after an idle gap of more than
/// one character time.
pub fn telegrams(log: &[ReceivedChar]) -> Vec<Seen> {
    let mut out: Vec<Seen> = Vec::new();
    for c in log {
        match out.last_mut() {
            Some(t) if c.at.saturating_duration_since(t.end) <= CHAR * 2 => {
                t.bytes.push(c.byte);
                t.end = c.at;
            }
            _ => out.push(Seen {
                bytes: vec![c.byte],
                start: c.at - CHAR,
                end: c.at,
            }),
        }
    }
    out
}

/// Both directions merged in time order.
pub fn timeline(a: &[ReceivedChar], b: &[ReceivedChar]) -> Vec<Seen> {
    let mut all = telegrams(a);
    all.extend(telegrams(b));
    all.sort_by_key(|t| t.start);
    all
}
