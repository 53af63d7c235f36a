//! Adapters that echo what they send: two-wire RS-485 converters whose receiver stays on while
//! they transmit hand every request back to the master, byte for byte, before any answer.
//!
//! Unhandled, the echo is taken for an answer where a protocol's answer repeats its request
//! (Modbus FC 5, 6, 8: a write reported as done that no drive answered). [`EchoCancel`] wraps
//! a line and takes each written byte back out of what is received, in order: the master never
//! sees its own frames. What comes back different is a **collision** (another transmitter on
//! the line, or noise): the character is handed on flagged [`CharError::Collision`], as are the
//! rest of that frame's echo, so the endpoint throws the frame away as it would a corrupt one
//! and its retry rules apply. An echo that does not start (something else came first: the
//! adapter does not echo after all, or another station sent over the request) is counted as
//! **missing**, and the character that came instead is flagged too: an answer is never taken
//! from characters that may hold our own frame. An echo still outstanding when the next frame
//! is written is given up (missing): a frame's echo comes before the next frame.
//!
//! Why not in the endpoints: the echo is the adapter's, not the protocol's; every serial
//! family gets the same handling from one wrapper, and the endpoints' framing, stale-character
//! and timing rules see the line as it would be without the echo.

use std::collections::VecDeque;
use std::io;
use std::task::{Context, Poll};

use tokio::time::Instant as TokioInstant;

use super::io::{CharIo, ReceivedChar, WireTime};
use crate::char::CharError;

/// The most bytes written and not yet echoed that are kept (several of the longest frames of
/// any family); beyond, the oldest are dropped as missing.
const MAX_PENDING: usize = 2048;

/// What an [`EchoCancel`] saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EchoStats {
    /// Bytes taken back out of the received stream (echoed as sent).
    pub echoed: u64,
    /// Frames whose echo differed from what was sent (collisions).
    pub collisions: u64,
    /// Bytes whose echo never came.
    pub missing: u64,
}

/// A line whose adapter echoes what is written (see the [module docs](self)); with echo off
/// it passes everything through untouched.
#[derive(Debug)]
pub struct EchoCancel<IO> {
    io: IO,
    on: bool,
    /// Bytes written whose echo has not come back yet, oldest first.
    pending: VecDeque<u8>,
    /// Whether the echo of the bytes pending has started (a first byte matched).
    started: bool,
    /// After a collision: how many more bytes of that frame's echo are flagged.
    garbled: usize,
    /// A frame is being written (bytes written since the last flush).
    writing: bool,
    stats: EchoStats,
}

impl<IO> EchoCancel<IO> {
    /// `io`, its echo taken out when `on`.
    pub fn new(io: IO, on: bool) -> Self {
        Self {
            io,
            on,
            pending: VecDeque::new(),
            started: false,
            garbled: 0,
            writing: false,
            stats: EchoStats::default(),
        }
    }

    /// Whether the echo is taken out.
    pub fn is_on(&self) -> bool {
        self.on
    }

    /// What was seen so far.
    pub fn stats(&self) -> EchoStats {
        self.stats
    }

    /// The line underneath.
    pub fn get_ref(&self) -> &IO {
        &self.io
    }

    /// The line underneath, for changing.
    pub fn get_mut(&mut self) -> &mut IO {
        &mut self.io
    }

    /// The line back.
    pub fn into_inner(self) -> IO {
        self.io
    }

    /// A frame (or part of one) of `bytes` was written: its echo is expected after whatever
    /// is still pending. At the start of a frame (after a flush), an echo of an earlier frame
    /// that has not started is given up: a frame's echo comes before the next frame is sent.
    fn wrote(&mut self, bytes: &[u8]) {
        if !self.on || bytes.is_empty() {
            return;
        }
        if !self.writing && !self.started && !self.pending.is_empty() {
            self.stats.missing += self.pending.len() as u64;
            self.pending.clear();
        }
        self.writing = true;
        self.pending.extend(bytes);
        while self.pending.len() > MAX_PENDING {
            self.pending.pop_front();
            self.stats.missing += 1;
        }
    }

    /// Take the echo out of `buf[..n]` in place; the number of characters left.
    fn cancel(&mut self, buf: &mut [ReceivedChar], n: usize) -> usize {
        let mut kept = 0;
        for i in 0..n {
            let Some(mut c) = buf.get(i).copied() else {
                break;
            };
            if self.garbled > 0 {
                self.garbled -= 1;
                c.error = Some(CharError::Collision);
            } else if let Some(&sent) = self.pending.front() {
                if c.byte == sent && c.error.is_none() {
                    self.pending.pop_front();
                    self.started = !self.pending.is_empty();
                    self.stats.echoed += 1;
                    continue;
                }
                if self.started {
                    // The echo began and then differed: the frame on the line was not ours.
                    self.stats.collisions += 1;
                    self.garbled = self.pending.len().saturating_sub(1);
                    self.pending.clear();
                    self.started = false;
                    c.error = Some(CharError::Collision);
                } else {
                    // Something else came before the echo: the adapter did not echo this
                    // frame, or another station sent over it. Never an answer.
                    self.stats.missing += self.pending.len() as u64;
                    self.pending.clear();
                    c.error = Some(CharError::Collision);
                }
            }
            if let Some(slot) = buf.get_mut(kept) {
                *slot = c;
            }
            kept += 1;
        }
        kept
    }
}

impl<IO: CharIo> CharIo for EchoCancel<IO> {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        loop {
            let n = match self.io.poll_read_chars(cx, buf) {
                Poll::Ready(Ok(n)) => n,
                other => return other,
            };
            if n == 0 || !self.on {
                return Poll::Ready(Ok(n));
            }
            let kept = self.cancel(buf, n);
            if kept > 0 {
                return Poll::Ready(Ok(kept));
            }
            // Only echo: read again (the line is polled until it is pending, so the waker
            // is registered).
        }
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        let r = self.io.poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = r {
            self.wrote(buf.get(..n).unwrap_or(buf));
        }
        r
    }

    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = self.io.poll_flush(cx);
        if let Poll::Ready(Ok(())) = r {
            self.writing = false;
        }
        r
    }

    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: TokioInstant,
    ) -> Poll<io::Result<usize>> {
        let r = self.io.poll_write_at(cx, buf, start);
        if let Poll::Ready(Ok(n)) = r {
            self.wrote(buf.get(..n).unwrap_or(buf));
        }
        r
    }

    fn honours_write_start(&self) -> bool {
        self.io.honours_write_start()
    }

    fn wire_time(&self) -> WireTime {
        self.io.wire_time()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::task::Waker;

    /// A line with scripted received bytes (all of them handed out at the next read) that
    /// keeps what is written.
    #[derive(Default)]
    struct Script {
        rx: VecDeque<u8>,
        written: Vec<u8>,
    }

    impl CharIo for Script {
        fn poll_read_chars(
            &mut self,
            _cx: &mut Context<'_>,
            buf: &mut [ReceivedChar],
        ) -> Poll<io::Result<usize>> {
            if self.rx.is_empty() {
                return Poll::Pending;
            }
            let at = TokioInstant::now();
            let mut n = 0;
            for slot in buf.iter_mut() {
                let Some(b) = self.rx.pop_front() else { break };
                *slot = ReceivedChar::new(b, at);
                n += 1;
            }
            Poll::Ready(Ok(n))
        }

        fn poll_write(&mut self, _cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
            self.written.extend_from_slice(buf);
            Poll::Ready(Ok(buf.len()))
        }

        fn poll_flush(&mut self, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }
    }

    fn send(e: &mut EchoCancel<Script>, frame: &[u8]) {
        let mut cx = Context::from_waker(Waker::noop());
        assert!(matches!(e.poll_write(&mut cx, frame), Poll::Ready(Ok(_))));
        assert!(matches!(e.poll_flush(&mut cx), Poll::Ready(Ok(()))));
    }

    /// What a read hands on: (byte, flagged as a collision).
    fn read(e: &mut EchoCancel<Script>, arriving: &[u8]) -> Vec<(u8, bool)> {
        e.get_mut().rx.extend(arriving);
        let mut cx = Context::from_waker(Waker::noop());
        let mut buf = [ReceivedChar::new(0, TokioInstant::now()); 64];
        match e.poll_read_chars(&mut cx, &mut buf) {
            Poll::Ready(Ok(n)) => buf[..n]
                .iter()
                .map(|c| (c.byte, c.error == Some(CharError::Collision)))
                .collect(),
            Poll::Ready(Err(err)) => panic!("{err}"),
            Poll::Pending => Vec::new(),
        }
    }

    fn clean(bytes: &[u8]) -> Vec<(u8, bool)> {
        bytes.iter().map(|&b| (b, false)).collect()
    }

    /// Modbus FC 6 to address 1, register 0x0010 = 0x0003 (CRC included): its answer is the
    /// same eight bytes.
    const FC6: [u8; 8] = [0x01, 0x06, 0x00, 0x10, 0x00, 0x03, 0xC8, 0x0E];

    #[tokio::test]
    async fn the_echo_is_taken_out_and_an_identical_answer_after_it_is_heard() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        assert_eq!(e.get_ref().written, FC6);
        // The echo alone: nothing for the master (a silent bus is a timeout, not an answer).
        assert_eq!(read(&mut e, &FC6), []);
        // The drive's answer, identical to the request, comes after it.
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        // Echo and answer in one read.
        send(&mut e, &FC6);
        let both: Vec<u8> = FC6.iter().chain(&FC6).copied().collect();
        assert_eq!(read(&mut e, &both), clean(&FC6));
        assert_eq!(
            e.stats(),
            EchoStats {
                echoed: 16,
                collisions: 0,
                missing: 0
            }
        );
    }

    #[tokio::test]
    async fn an_echo_that_differs_is_a_collision_and_the_rest_of_it_is_flagged() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        let mut garbled = FC6;
        garbled[3] = 0x11;
        let got = read(&mut e, &garbled);
        // The first three matched and were taken out; from the fourth on, all flagged.
        assert_eq!(got.len(), 5);
        assert!(got.iter().all(|&(_, flagged)| flagged), "{got:?}");
        assert_eq!(e.stats().collisions, 1);
        // The next answer is clean again.
        assert_eq!(
            read(&mut e, &[0x01, 0x83, 0x02]),
            clean(&[0x01, 0x83, 0x02])
        );
    }

    #[tokio::test]
    async fn an_echo_that_does_not_start_flags_what_came_instead() {
        let mut e = EchoCancel::new(Script::default(), true);
        send(&mut e, &FC6);
        // Another station's frame where the echo should be.
        let got = read(&mut e, &[0x02, 0x83, 0x02, 0xC0, 0xF1]);
        assert_eq!(
            got[0],
            (0x02, true),
            "the first character is never an answer's"
        );
        assert_eq!(got[1..], clean(&[0x83, 0x02, 0xC0, 0xF1]));
        assert_eq!(e.stats().missing, 8);
        // One that starts like the echo and then differs is a collision: all of it flagged.
        send(&mut e, &FC6);
        let got = read(&mut e, &[0x01, 0x83, 0x02, 0xC0, 0xF1]);
        assert_eq!(got.len(), 4);
        assert!(got.iter().all(|&(_, flagged)| flagged), "{got:?}");
        assert_eq!(e.stats().collisions, 1);
    }

    #[tokio::test]
    async fn a_frame_written_in_parts_is_one_echo_and_an_unstarted_echo_ends_at_the_next_frame() {
        let mut e = EchoCancel::new(Script::default(), true);
        let mut cx = Context::from_waker(Waker::noop());
        let _ = e.poll_write(&mut cx, &FC6[..3]);
        let _ = e.poll_write(&mut cx, &FC6[3..]);
        let _ = e.poll_flush(&mut cx);
        assert_eq!(read(&mut e, &FC6), []);
        // A frame whose echo never came, then the next frame and its echo.
        send(&mut e, &[0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A]);
        send(&mut e, &FC6);
        assert_eq!(read(&mut e, &FC6), []);
        assert_eq!(e.stats().missing, 8);
        assert_eq!(e.stats().echoed, 16);
    }

    #[tokio::test]
    async fn with_echo_off_everything_passes() {
        let mut e = EchoCancel::new(Script::default(), false);
        send(&mut e, &FC6);
        assert_eq!(read(&mut e, &FC6), clean(&FC6));
        assert_eq!(e.stats(), EchoStats::default());
    }
}
