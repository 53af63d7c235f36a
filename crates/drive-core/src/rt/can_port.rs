//! A CAN master's side of a bus: [`CanPort`], the CAN [`Link`] of the runtime driver.

use std::future::{Future, poll_fn};
use std::io;
use std::pin::pin;
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use embedded_can::Frame as _;
use tokio::time::Instant as TokioInstant;

use super::can::{CanIo, send_frame_at};
use super::clock::{Clock, Timebase};
use super::driver::Link;
use super::port::Step;
use crate::can::CanEndpoint;
use crate::time::{Instant, earliest};

/// The async side of a sans-IO CAN master on a [`CanIo`]: it hears the frames that wait in the
/// interface before it sends (an answer an earlier program left there is never judged against
/// the request sent after it), sends the frames the endpoint has due scheduled for the
/// endpoint's time ([`CanIo::poll_send_at`]: a deadline, not tokio's later tick), and waits for
/// the endpoint's next deadline or the next frame. Time is tokio's clock (paused in tests).
///
/// A step does one thing and returns, so that the driver reads the master's events in
/// between: the endpoint's time is advanced ([`CanEndpoint::handle_timeout`]) after every
/// frame heard, every frame sent and every wake-up, in a step of its own, before anything else
/// is heard or sent.
#[derive(Debug)]
pub struct CanPort<C> {
    io: C,
    time: Timebase,
    /// The endpoint's time of the transaction: the last frame's, a deadline woken for, or the
    /// time after a transmission.
    now: Instant,
    /// The endpoint is to be told `now` before anything else.
    due: bool,
    last_tx: Option<TokioInstant>,
    last_rx: Option<TokioInstant>,
}

impl<C: CanIo> CanPort<C> {
    /// A port on `io`; the epoch of its times is now.
    pub fn new(io: C) -> Self {
        Self {
            io,
            time: Timebase::new(Clock::Real, Duration::ZERO),
            now: Instant::ZERO,
            due: false,
            last_tx: None,
            last_rx: None,
        }
    }

    /// Now, on the endpoint's time base.
    pub fn now(&self) -> Instant {
        self.time.now()
    }

    /// The time base.
    pub fn timebase(&self) -> &Timebase {
        &self.time
    }

    /// The interface.
    pub fn get_ref(&self) -> &C {
        &self.io
    }

    /// The interface (do not receive from it).
    pub fn get_mut(&mut self) -> &mut C {
        &mut self.io
    }

    /// The interface back.
    pub fn into_inner(self) -> C {
        self.io
    }

    /// A transaction starts now.
    pub fn begin(&mut self) {
        self.now = self.time.now();
        self.due = true;
    }

    /// One step (see the [type docs](CanPort)).
    pub async fn step<E: CanEndpoint>(&mut self, endpoint: &mut E) -> io::Result<Step> {
        Ok(self
            .step_until(endpoint, None)
            .await?
            .unwrap_or(Step::Waited))
    }

    /// One step, or `None` once the endpoint's time has reached `until` and nothing is due.
    pub async fn step_until<E: CanEndpoint>(
        &mut self,
        endpoint: &mut E,
        until: Option<Instant>,
    ) -> io::Result<Option<Step>> {
        if self.due {
            self.due = false;
            endpoint.handle_timeout(self.now);
            return Ok(Some(Step::Waited));
        }
        self.due = true;
        // Listen before talking: what waits in the interface arrived before anything sent now,
        // and the endpoint hears it with the time it was read.
        if let Some(at) = self.feed_waiting(endpoint)? {
            self.now = self.time.now().later(at);
            return Ok(Some(Step::Waited));
        }
        if let Some(frame) = endpoint.poll_transmit(self.now) {
            // Scheduled for the endpoint's time (a deadline, not tokio's later tick).
            let start = self.time.to_tokio(self.now);
            send_frame_at(&mut self.io, &frame, start).await?;
            self.last_tx = Some(start);
            self.now = self.time.now();
            return Ok(Some(Step::Sent(frame.data().len())));
        }
        if until.is_some_and(|u| self.now >= u) {
            self.due = false;
            return Ok(None);
        }
        let deadline = earliest(endpoint.poll_timeout(), until);
        let timer = deadline.map(|d| self.time.to_tokio(d));
        let sleep = sleep_until(timer);
        let mut sleep = pin!(sleep);
        let io = &mut self.io;
        // A frame first: what arrived by a deadline is heard before the deadline is handled.
        let woken = poll_fn(|cx| {
            if let Poll::Ready(r) = io.poll_recv(cx) {
                return Poll::Ready(Some(r));
            }
            sleep.as_mut().poll(cx).map(|()| None)
        })
        .await;
        match woken {
            Some(r) => {
                let r = r?;
                let at = self.time.to_instant(r.at);
                self.last_rx = Some(r.at);
                endpoint.handle_frame(&r.frame, at);
                self.now = self.time.now().later(at);
            }
            None => {
                self.now = match deadline {
                    Some(d) => self.time.woken_at(d),
                    None => self.time.now(),
                };
            }
        }
        Ok(Some(Step::Waited))
    }

    /// Step the endpoint (a producer of periodic frames) until its time reaches `until`.
    pub async fn run_until<E: CanEndpoint>(
        &mut self,
        endpoint: &mut E,
        until: Instant,
    ) -> io::Result<()> {
        self.begin();
        while self.step_until(endpoint, Some(until)).await?.is_some() {}
        Ok(())
    }

    /// Feed the frames that wait in the interface now, without waiting; the time of the last
    /// one fed, if any.
    fn feed_waiting<E: CanEndpoint>(&mut self, endpoint: &mut E) -> io::Result<Option<Instant>> {
        let mut cx = Context::from_waker(Waker::noop());
        let mut last = None;
        for _ in 0..WAITING_FRAMES {
            match self.io.poll_recv(&mut cx) {
                Poll::Ready(Ok(r)) => {
                    let at = self.time.to_instant(r.at);
                    self.last_rx = Some(r.at);
                    endpoint.handle_frame(&r.frame, at);
                    last = Some(at);
                }
                Poll::Ready(Err(e)) => return Err(e),
                Poll::Pending => break,
            }
        }
        Ok(last)
    }
}

impl<C: CanIo, E: CanEndpoint> Link<E> for CanPort<C> {
    fn now(&self) -> Instant {
        CanPort::now(self)
    }

    fn begin(&mut self) {
        CanPort::begin(self);
    }

    async fn step(&mut self, endpoint: &mut E) -> io::Result<Step> {
        CanPort::step(self, endpoint).await
    }

    fn last_tx_start(&self) -> Option<TokioInstant> {
        self.last_tx
    }

    fn last_rx_at(&self) -> Option<TokioInstant> {
        self.last_rx
    }
}

/// Frames read from the interface before a transmission, at most (the rest are read while
/// waiting).
const WAITING_FRAMES: usize = 64;

async fn sleep_until(t: Option<TokioInstant>) {
    match t {
        Some(t) => super::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}
