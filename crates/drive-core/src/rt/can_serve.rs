//! The serve loop of sans-IO CAN participants ([`CanEndpoint`]s: simulated drives) on one
//! [`CanIo`]: frames in, frames out, deadlines from [`CanEndpoint::poll_timeout`], on tokio's
//! clock (paused in tests).

use core::future::Future;
use core::pin::Pin;
use core::task::Poll;
use core::time::Duration;
use std::future::poll_fn;
use std::io;
use std::vec::Vec;

use super::time::Sleep;
use tokio::time::Instant as TokioInstant;

use super::TIMER_RESOLUTION;
use super::can::{CanIo, ReceivedFrame, send_frame_at};
use crate::can::{CanEndpoint, CanFrame};
use crate::time::Instant;

/// How late a deadline's wake-up may be before [`serve_can`] takes it for a host that did not
/// run the loop (tokio's timers end on their next 1 ms tick; a busy runtime adds a little).
pub const STALL: Duration = Duration::from_millis(10);

/// After a stall, how long before its deadline [`serve_can`] lets the endpoints' time resume:
/// enough for a backlog of frames to cross an adapter task and the bus.
pub const STALL_GRACE: Duration = Duration::from_millis(20);

/// Serve `endpoints` (several simulated nodes behind one CAN interface) on `io` until it
/// closes (`Ok`) or fails. Endpoint time is tokio's time since `epoch`, which moves on by the
/// host's stalls.
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
/// * A deadline met more than [`STALL`] late means the host did not run the loop (a loaded
///   machine, a stopped process). A real node would have heard whatever reached the bus
///   meanwhile, but here it waits in the interface, or in another task on its way to it (the
///   simulated slcan adapter reads its pty in a task of its own), and comes stamped after the
///   stall. So the stall is taken out of the endpoints' time (`epoch` moves on by it): they
///   resume [`STALL_GRACE`] before the deadline (never before the last event they heard), and
///   what waited is heard first. A stalled host does not make a simulated drive trip its bus
///   timeout; a bus that stays silent still trips it, that much later by the host's clock.
/// * Endpoints are polled for frames at the time of the event that woke the loop (a frame's
///   last bit, a deadline), and their frames are sent scheduled for that instant
///   ([`CanIo::poll_send_at`]): on the virtual bus an answer starts when its request ended
///   and a 1 ms telegram keeps its period, not tokio's tick.
pub async fn serve_can<E: CanEndpoint, IO: CanIo>(
    endpoints: &mut [E],
    epoch: &mut TokioInstant,
    mut io: IO,
) -> io::Result<()> {
    let at = |epoch: TokioInstant, t: TokioInstant| {
        Instant::from_duration(t.saturating_duration_since(epoch))
    };
    let mut sleep: Pin<Box<Sleep>> = Box::pin(super::time::sleep_until(*epoch));
    let mut armed_at = *epoch;
    let mut outgoing: Vec<CanFrame> = Vec::new();
    // The time of the event being handled: a received frame's last bit, a deadline met, never
    // more than the timer resolution behind tokio's clock.
    let mut woke = at(*epoch, super::time::now());
    let recent = |epoch: TokioInstant, t: Instant, woke: Instant| {
        let now = super::time::now();
        let floor = at(epoch, now.checked_sub(TIMER_RESOLUTION).unwrap_or(now));
        t.later(woke).later(floor).min(at(epoch, now))
    };
    loop {
        // Send what is due; what one endpoint sends, the others hear, and may answer.
        loop {
            let now = recent(*epoch, woke, woke);
            let mut sent = false;
            for i in 0..endpoints.len() {
                outgoing.clear();
                if let Some(e) = endpoints.get_mut(i) {
                    while let Some(f) = e.poll_transmit(now) {
                        outgoing.push(f);
                    }
                }
                for f in &outgoing {
                    send_frame_at(&mut io, f, *epoch + now.as_duration()).await?;
                    let t = at(*epoch, super::time::now());
                    for (j, other) in endpoints.iter_mut().enumerate() {
                        if j != i {
                            other.handle_frame(f, t);
                        }
                    }
                    woke = recent(*epoch, t, woke);
                    sent = true;
                }
            }
            if !sent {
                break;
            }
        }
        let deadline = endpoints.iter().filter_map(|e| e.poll_timeout()).min();
        if let Some(d) = deadline {
            let when = *epoch + d.as_duration();
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
                // Never before what the endpoints heard last (a frame stamped before a stall
                // that was taken out of their time).
                let t = at(*epoch, t).later(woke);
                for e in endpoints.iter_mut() {
                    e.handle_frame(&frame, t);
                }
                woke = recent(*epoch, t, woke);
            }
            Some(Err(e)) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(()),
            Some(Err(e)) => return Err(e),
            None => {
                let d = deadline.unwrap_or(woke);
                let tokio_now = super::time::now();
                let resume = d.saturating_sub(STALL_GRACE).later(woke);
                if tokio_now.saturating_duration_since(*epoch + d.as_duration()) > STALL
                    && resume < d
                    && let Some(e) = tokio_now.checked_sub(resume.as_duration())
                    && e > *epoch
                {
                    // The host stalled: the endpoints' time resumes before the deadline, and
                    // what waited is heard first.
                    *epoch = e;
                    continue;
                }
                let now = recent(*epoch, d, woke);
                for e in endpoints.iter_mut() {
                    e.handle_timeout(now);
                }
                woke = now;
            }
        }
    }
}
