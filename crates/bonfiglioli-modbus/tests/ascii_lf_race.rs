//! The `drivectl demo` hang of the Modbus ASCII session (about once in 15 runs on a loaded
//! machine), on tokio's paused clock with the timing that triggered it forced.
//!
//! An ASCII answer is accepted at its LF (no end silence). The runtime port read what waited
//! before sending, found nothing, read once more, and that second read heard the LF that had
//! just arrived: the request was complete, nothing was due, and the port went on to wait for
//! input with no deadline (an idle master has none), so the call never returned. Here the
//! master's side of the wire model hands out an LF that arrives together with the characters
//! before it one read late, as if it arrived between two reads. The session is the demo's,
//! and every call must end.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::collections::VecDeque;
use std::task::{Context, Poll};
use std::time::Duration;

use bonfiglioli_modbus::driver::{CharIo, DriverConfig, DriverError, ModbusDriver, ReceivedChar};
use bonfiglioli_modbus::frame::{Address, DataSet, DiagSubFunction};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::sim::{self, Variant};
use bonfiglioli_modbus::slave::Width;
use drive_core::Parity;
use drive_core::rt::WireTime;
use drive_transport::link::{LinkConfig, LinkEnd, pair};

const LF: u8 = 0x0A;

/// The master's end of the line: an LF read together with characters before it is held
/// back; the next read misses it, the one after returns it.
struct LateLf {
    inner: LinkEnd,
    pending: VecDeque<(ReceivedChar, bool)>,
    missed: bool,
    /// How often an LF was held back this way.
    forced: u32,
}

impl CharIo for LateLf {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<std::io::Result<usize>> {
        if self.pending.is_empty() {
            let mut chunk = [ReceivedChar::new(0, tokio::time::Instant::now()); 64];
            let n = match CharIo::poll_read_chars(&mut self.inner, cx, &mut chunk) {
                Poll::Ready(Ok(n)) => n,
                other => return other,
            };
            if n == 0 {
                return Poll::Ready(Ok(0));
            }
            for (i, c) in chunk[..n].iter().enumerate() {
                let held = c.byte == LF && i > 0;
                self.forced += u32::from(held);
                self.pending.push_back((*c, held));
            }
        }
        let mut n = 0;
        while let Some(&(c, held)) = self.pending.front() {
            if n == buf.len() {
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
                self.missed = false;
            }
            self.pending.pop_front();
            buf[n] = c;
            n += 1;
        }
        Poll::Ready(Ok(n))
    }
    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        CharIo::poll_write(&mut self.inner, cx, buf)
    }
    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        CharIo::poll_flush(&mut self.inner, cx)
    }
    fn poll_write_at(
        &mut self,
        cx: &mut Context<'_>,
        buf: &[u8],
        start: tokio::time::Instant,
    ) -> Poll<std::io::Result<usize>> {
        self.inner.poll_write_at(cx, buf, start)
    }
    fn honours_write_start(&self) -> bool {
        self.inner.honours_write_start()
    }
    fn wire_time(&self) -> WireTime {
        self.inner.wire_time()
    }
}

/// Each call of the demo's session within 5 s of the paused clock.
async fn within<T>(what: &str, call: impl Future<Output = T>) -> T {
    tokio::time::timeout(Duration::from_secs(5), call)
        .await
        .unwrap_or_else(|_| panic!("{what} never returned"))
}

#[tokio::test(start_paused = true)]
async fn demo_hang_an_ascii_answer_whose_lf_comes_between_two_reads_is_taken() {
    let mode = Mode::Ascii;
    let line = mode.line_settings(19200, Parity::Even);
    let (master_end, drive_end) = pair(LinkConfig::from_line(line));
    let sim = tokio::spawn(async move {
        let mut bus = sim::bus(&[1], Variant::Acu, mode, line);
        bus.serve(drive_end).await
    });
    let io = LateLf {
        inner: master_end,
        pending: VecDeque::new(),
        missed: false,
        forced: 0,
    };
    let mut m = ModbusDriver::new(io, DriverConfig::new(mode, line));
    let d = Address::new(1).unwrap();
    let ds = |n| DataSet::new(n).unwrap();
    let rated = within("read 372", m.read(d, 372, ds(2), Width::Word)).await;
    assert_eq!(rated.unwrap(), 1390);
    within("write 376", m.write(d, 376, ds(4), Width::Word, 15))
        .await
        .unwrap();
    let f2 = within("read 481", m.read(d, 481, DataSet::ALL, Width::Long)).await;
    assert_eq!(f2.unwrap(), 1000);
    match within("write 376 = 0", m.write(d, 376, ds(2), Width::Word, 0)).await {
        Err(DriverError::Device { vabus: Some(1), .. }) => {}
        other => panic!("376 = 0 was not refused with VABus error 1: {other:?}"),
    }
    let msgs = within(
        "FC 8 slave messages",
        m.diagnostics(d, DiagSubFunction::SLAVE_MESSAGES),
    )
    .await;
    assert_eq!(msgs.unwrap(), 6);
    let stats = m.stats();
    assert_eq!((stats.retries, stats.timeouts), (0, 0));
    let io = m.into_inner();
    // The forced timing happened (the line hands characters out on tokio's 1 ms ticks, two
    // ASCII characters per tick at 19200 baud, so an LF often comes with the CR before it).
    assert!(io.forced > 0, "no LF came between two reads");
    drop(io);
    sim.await.unwrap().unwrap();
}
