//! A master's side of a line: the async glue between a sans-IO [`Endpoint`] and a [`CharIo`].

use std::io;
use std::pin::Pin;
use std::time::Duration;

use tokio::time::{Instant as TokioInstant, Sleep};

use super::clock::{Clock, Timebase};
use super::io::{CHUNK, CharIo, ReceivedChar, Woken, read_or_sleep, write_all};
use crate::char::RxChar;
use crate::endpoint::Endpoint;
use crate::time::Instant;

/// The async side of a sans-IO master: it writes what the endpoint hands out, feeds every
/// received character with its arrival time, and calls the endpoint's `handle_timeout` when its
/// deadline is reached. Every protocol rule is the endpoint's; the port only waits and moves
/// bytes.
///
/// Timing ([`Clock`]): on [`Clock::Real`] every pause is waited for on tokio's clock. On
/// [`Clock::Virtual`] the endpoint's clock advances one character time per character and jumps
/// to every deadline that needs only a quiet line ([`Endpoint::poll_quiet_timeout`]); its other
/// deadlines (a response timeout) become real timers measured from the last transmission.
#[derive(Debug)]
pub struct Port<IO> {
    io: IO,
    time: Timebase,
    rx: Box<[ReceivedChar]>,
    /// The wait timer, made on first use (so that `new` works outside a runtime).
    sleep: Option<Pin<Box<Sleep>>>,
    /// Tokio time and endpoint time right after the last transmission.
    sent_at: Option<(TokioInstant, Instant)>,
    /// Arrival of the last character fed to the endpoint.
    last_rx: Option<TokioInstant>,
}

impl<IO: CharIo> Port<IO> {
    /// A port on `io` for a line with `char_time`; the epoch of its times is now.
    pub fn new(io: IO, clock: Clock, char_time: Duration) -> Self {
        let time = Timebase::new(clock, char_time);
        Self {
            io,
            rx: vec![ReceivedChar::new(0, time.epoch()); CHUNK].into_boxed_slice(),
            time,
            sleep: None,
            sent_at: None,
            last_rx: None,
        }
    }

    /// Now, as the endpoint sees it.
    pub fn now(&self) -> Instant {
        self.time.now()
    }

    /// The time base.
    pub fn timebase(&self) -> &Timebase {
        &self.time
    }

    /// The I/O object.
    pub fn get_ref(&self) -> &IO {
        &self.io
    }

    /// The I/O object, e.g. to inject faults on the wire model (do not read from it).
    pub fn get_mut(&mut self) -> &mut IO {
        &mut self.io
    }

    /// The I/O object back.
    pub fn into_inner(self) -> IO {
        self.io
    }

    /// Arrival (on tokio's clock) of the last character fed to the endpoint.
    pub fn last_rx_at(&self) -> Option<TokioInstant> {
        self.last_rx
    }

    /// Write the frame the endpoint has due now, if any; returns its length. After a write
    /// error the frame on the wire is broken: tell the endpoint (its `abort`) and call
    /// [`Port::settle`].
    pub async fn transmit<E: Endpoint>(
        &mut self,
        endpoint: &mut E,
        buf: &mut [u8],
    ) -> io::Result<Option<usize>> {
        let now = self.time.now();
        let Some(n) = endpoint.poll_transmit(now, buf) else {
            return Ok(None);
        };
        write_all(&mut self.io, buf.get(..n).unwrap_or(&[])).await?;
        self.time.sent(n);
        self.sent_at = Some((TokioInstant::now(), self.time.now()));
        Ok(Some(n))
    }

    /// Wait for the endpoint's next deadline or for received characters, and feed what
    /// happened. Returns `false` when the port was closed (end of file).
    pub async fn wait<E: Endpoint>(&mut self, endpoint: &mut E) -> io::Result<bool> {
        let deadline = endpoint.poll_timeout();
        let timer_at = match self.time.clock() {
            Clock::Real => match deadline {
                Some(d) => {
                    let at = self.time.to_tokio(d);
                    if at <= TokioInstant::now() {
                        endpoint.handle_timeout(self.time.now());
                        return Ok(true);
                    }
                    Some(at)
                }
                None => None,
            },
            Clock::Virtual => {
                if let Some(q) = endpoint.poll_quiet_timeout() {
                    self.time.jump_to(q);
                    endpoint.handle_timeout(self.time.now());
                    return Ok(true);
                }
                deadline.map(|d| {
                    let (real, virt) = self
                        .sent_at
                        .unwrap_or_else(|| (TokioInstant::now(), self.time.now()));
                    real + d.saturating_duration_since(virt)
                })
            }
        };
        let sleep = match timer_at {
            Some(at) => {
                let s = self
                    .sleep
                    .get_or_insert_with(|| Box::pin(tokio::time::sleep_until(at)));
                s.as_mut().reset(at);
                Some(s.as_mut())
            }
            None => None,
        };
        match read_or_sleep(&mut self.io, &mut self.rx, sleep).await? {
            Woken::Read(0) => Ok(false),
            Woken::Read(n) => {
                for i in 0..n {
                    let Some(c) = self.rx.get(i).copied() else {
                        break;
                    };
                    let time = self.time.arrival(c.at);
                    self.last_rx = Some(c.at);
                    endpoint.handle_char(RxChar {
                        byte: c.byte,
                        time,
                        error: c.error,
                    });
                }
                Ok(true)
            }
            Woken::Timer => {
                if let Some(d) = deadline {
                    self.time.jump_to(d);
                }
                endpoint.handle_timeout(self.time.now());
                Ok(true)
            }
        }
    }

    /// After a failed write: let what did get out leave the line (best effort, at most 1 s).
    pub async fn settle(&mut self) {
        let io = &mut self.io;
        let flush = std::future::poll_fn(|cx| io.poll_flush(cx));
        let _ = tokio::time::timeout(Duration::from_secs(1), flush).await;
    }
}
