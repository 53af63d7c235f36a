//! Shared helpers of the sans-IO master tests: the responder and a tiny bus loop.

#![allow(dead_code)]

pub mod responder;

use std::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanEndpoint, CanFrame};
use sbus_can::master::{MasterEvent, SbusMaster};

pub use responder::Responder;

/// Frame time on the loop's bus (about a 8-byte frame at 500 kbit/s).
pub const LATENCY: Duration = Duration::from_micros(250);

/// What the bus does to a drive's frame: deliver (possibly changed, possibly more than once,
/// possibly later) or drop.
pub type Fault = Box<dyn FnMut(&CanFrame) -> Vec<(CanFrame, Duration)>>;

/// One master and some drives; every frame reaches every other node `LATENCY` later. A log of
/// every frame with its time.
pub struct Bus {
    pub now: Instant,
    pub master: SbusMaster,
    pub drives: Vec<Responder>,
    pub fault: Option<Fault>,
    /// (time, sender: None = master, frame).
    pub log: Vec<(Instant, Option<usize>, CanFrame)>,
    in_flight: Vec<(Instant, Option<usize>, CanFrame)>,
}

impl Bus {
    pub fn new(master: SbusMaster, drives: Vec<Responder>) -> Self {
        Self {
            now: Instant::ZERO,
            master,
            drives,
            fault: None,
            log: Vec::new(),
            in_flight: Vec::new(),
        }
    }

    /// Inject a frame from outside (another node) at `at`.
    pub fn inject(&mut self, frame: CanFrame, at: Instant) {
        self.in_flight.push((at, Some(usize::MAX), frame));
    }

    /// Run until the master reports an event or `limit` passes.
    pub fn run(&mut self, limit: Duration) -> Option<MasterEvent> {
        let end = self.now.saturating_add(limit);
        loop {
            if let Some(ev) = self.master.poll_event() {
                return Some(ev);
            }
            // Deliver what arrived by now.
            self.in_flight.sort_by_key(|(t, _, _)| *t);
            while let Some(&(t, from, f)) = self.in_flight.first() {
                if t > self.now {
                    break;
                }
                self.in_flight.remove(0);
                self.log.push((t, from, f));
                if from.is_some() {
                    self.master.handle_frame(&f, t);
                }
                for (i, d) in self.drives.iter_mut().enumerate() {
                    if from != Some(i) {
                        d.handle_frame(&f, t);
                    }
                }
                if let Some(ev) = self.master.poll_event() {
                    return Some(ev);
                }
            }
            self.master.handle_timeout(self.now);
            if let Some(ev) = self.master.poll_event() {
                return Some(ev);
            }
            while let Some(f) = self.master.poll_transmit(self.now) {
                self.in_flight
                    .push((self.now.saturating_add(LATENCY), None, f));
            }
            for i in 0..self.drives.len() {
                while let Some(f) = self.drives[i].poll_transmit(self.now) {
                    let out = match self.fault.as_mut() {
                        Some(fault) => fault(&f),
                        None => vec![(f, Duration::ZERO)],
                    };
                    for (g, delay) in out {
                        self.in_flight
                            .push((self.now.saturating_add(LATENCY + delay), Some(i), g));
                    }
                }
            }
            if let Some(ev) = self.master.poll_event() {
                return Some(ev);
            }
            let next = [
                self.master.poll_timeout(),
                self.in_flight.iter().map(|(t, _, _)| *t).min(),
            ]
            .into_iter()
            .flatten()
            .min();
            match next {
                Some(t) if t <= end => self.now = self.now.later(t),
                _ => {
                    self.now = end;
                    self.master.handle_timeout(end);
                    return self.master.poll_event();
                }
            }
        }
    }

    /// The frames the master sent, with their times.
    pub fn sent(&self) -> Vec<(Instant, CanFrame)> {
        self.log
            .iter()
            .filter(|(_, from, _)| from.is_none())
            .map(|(t, _, f)| (t.saturating_sub(LATENCY), *f))
            .collect()
    }
}
