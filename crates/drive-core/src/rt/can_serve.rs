//! The serve loop of sans-IO CAN participants ([`CanEndpoint`]s: simulated drives) on one
//! [`CanIo`]: frames in, frames out, deadlines from [`CanEndpoint::poll_timeout`], on tokio's
//! clock (paused in tests).

use core::future::Future;
use core::pin::Pin;
use core::task::Poll;
use std::future::poll_fn;
use std::io;
use std::vec::Vec;

use super::time::Sleep;
use tokio::time::Instant as TokioInstant;

use super::TIMER_RESOLUTION;
use super::can::{CanIo, ReceivedFrame, send_frame_at};
use crate::can::{CanEndpoint, CanFrame};
use crate::time::Instant;

/// Serve `endpoints` (several simulated nodes behind one CAN interface) on `io` until it
/// closes (`Ok`) or fails. Endpoint time is tokio's time since `epoch`.
///
/// * Every received frame goes to every endpoint with its arrival time.
/// * Whatever an endpoint has due is sent at once, in endpoint order, and handed to the
///   **other** endpoints with the time it was taken by the interface: nodes behind one
///   interface hear each other as on a bus (a master-slave master's group telegram reaches
///   the slaves served beside it). The interface must not echo a node's own frames back (a
///   SocketCAN socket does not by default; an slcan adapter does not).
/// * Deadlines: the loop sleeps until the earliest [`CanEndpoint::poll_timeout`] (tokio's
///   timers tick in 1 ms steps, so it wakes on the first tick at or after it, never before)
///   and then tells every endpoint the deadline itself as the time, at most
///   [`TIMER_RESOLUTION`] back (a later wake-up, a busy task, counts from its own time).
/// * Endpoints are polled for frames at the time of the event that woke the loop (a frame's
///   last bit, a deadline), and their frames are sent scheduled for that instant
///   ([`CanIo::poll_send_at`]): on the virtual bus an answer starts when its request ended
///   and a 1 ms telegram keeps its period, not tokio's tick.
pub async fn serve_can<E: CanEndpoint, IO: CanIo>(
    endpoints: &mut [E],
    epoch: TokioInstant,
    mut io: IO,
) -> io::Result<()> {
    let at = |t: TokioInstant| Instant::from_duration(t.saturating_duration_since(epoch));
    let mut sleep: Pin<Box<Sleep>> = Box::pin(super::time::sleep_until(epoch));
    let mut armed_at = epoch;
    let mut outgoing: Vec<CanFrame> = Vec::new();
    // The time of the event being handled: a received frame's last bit, a deadline met, never
    // more than the timer resolution behind tokio's clock.
    let mut woke = at(super::time::now());
    let recent = |t: Instant, woke: Instant| {
        let now = super::time::now();
        let floor = at(now.checked_sub(TIMER_RESOLUTION).unwrap_or(now));
        t.later(woke).later(floor).min(at(now))
    };
    loop {
        // Send what is due; what one endpoint sends, the others hear, and may answer.
        loop {
            let now = recent(woke, woke);
            let mut sent = false;
            for i in 0..endpoints.len() {
                outgoing.clear();
                if let Some(e) = endpoints.get_mut(i) {
                    while let Some(f) = e.poll_transmit(now) {
                        outgoing.push(f);
                    }
                }
                for f in &outgoing {
                    send_frame_at(&mut io, f, epoch + now.as_duration()).await?;
                    let t = at(super::time::now());
                    for (j, other) in endpoints.iter_mut().enumerate() {
                        if j != i {
                            other.handle_frame(f, t);
                        }
                    }
                    woke = recent(t, woke);
                    sent = true;
                }
            }
            if !sent {
                break;
            }
        }
        let deadline = endpoints.iter().filter_map(|e| e.poll_timeout()).min();
        if let Some(d) = deadline {
            let when = epoch + d.as_duration();
            if when != armed_at {
                sleep.as_mut().reset(when);
                armed_at = when;
            }
        }
        let event = poll_fn(|cx| {
            if let Poll::Ready(r) = io.poll_recv(cx) {
                return Poll::Ready(Some(r));
            }
            if deadline.is_some() && sleep.as_mut().poll(cx).is_ready() {
                return Poll::Ready(None);
            }
            Poll::Pending
        })
        .await;
        match event {
            Some(Ok(ReceivedFrame { frame, at: t })) => {
                let t = at(t);
                for e in endpoints.iter_mut() {
                    e.handle_frame(&frame, t);
                }
                woke = recent(t, woke);
            }
            Some(Err(e)) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(()),
            Some(Err(e)) => return Err(e),
            None => {
                let now = recent(deadline.unwrap_or(woke), woke);
                for e in endpoints.iter_mut() {
                    e.handle_timeout(now);
                }
                woke = now;
            }
        }
    }
}
