//! In-memory USS line for the tests, the allocation test and the benchmarks: the sans-IO master
//! and slaves exchange characters back to back with wire timestamps (one character time of the
//! line per character), no I/O, no allocation while running, and a small parameter store as the
//! drive.
#![allow(dead_code)]

use core::time::Duration;

use ctt2_uss::serial::master::{MasterEvent, UssMaster};
use ctt2_uss::serial::slave::{Backend, Slave};
use ctt2_uss::serial::telegram::MAX_TELEGRAM;
use ctt2_uss::uss::pkw::{Order, OrderKind, Pkw, Reply};
use drive_core::time::earliest;
use drive_core::{Endpoint, Instant, RxChar};
use drive_profile::nord::Width;

/// A drive whose word parameter (pnu, IND) holds `pnu * 3 + IND` until written (16 slots of
/// writes, newest wins); answers the control word inverted and the setpoints as actual values.
#[derive(Debug, Clone, Copy)]
pub struct Store {
    writes: [(u16, u16, i32); 16],
    next: usize,
    /// How long each new order takes.
    pub processing: Duration,
    /// Orders executed.
    pub executed: u64,
    /// Process-data telegrams handled.
    pub processed: u64,
}

impl Default for Store {
    fn default() -> Self {
        Store {
            writes: [(u16::MAX, 0, 0); 16],
            next: 0,
            processing: Duration::ZERO,
            executed: 0,
            processed: 0,
        }
    }
}

impl Store {
    /// What a read of `pnu` with IND `ind` returns now.
    pub fn value(&self, pnu: u16, ind: u16) -> i32 {
        let mut v = None;
        for k in 0..16 {
            let i = (self.next + k) % 16;
            let (p, x, val) = self.writes[i];
            if p == pnu && x == ind {
                v = Some(val);
            }
        }
        v.unwrap_or(i32::from(pnu) * 3 + i32::from(ind))
    }
}

impl Backend for Store {
    fn execute(&mut self, order: &Pkw, _now: Instant) -> Pkw {
        self.executed += 1;
        let Ok(o) = Order::from_pkw(order) else {
            return Reply::Error(ctt2_uss::uss::DriveError(201)).to_pkw(order.pke.pnu(), order.ind);
        };
        let reply = match o.kind() {
            OrderKind::None => Reply::None,
            OrderKind::Read { array } => Reply::Value {
                width: Width::Word,
                array,
                value: self.value(o.pnu(), o.ind().0),
            },
            OrderKind::Write {
                width,
                array,
                value,
                ..
            } => {
                self.writes[self.next] = (o.pnu(), o.ind().0, value);
                self.next = (self.next + 1) % 16;
                Reply::Value {
                    width,
                    array,
                    value,
                }
            }
            OrderKind::Count => Reply::Count(4),
        };
        reply.to_pkw(o.pnu(), o.ind())
    }

    fn processing_time(&self, _order: &Pkw) -> Duration {
        self.processing
    }

    fn process(&mut self, request: &[u16], answer: &mut [u16], _now: Instant) {
        self.processed += 1;
        for (i, (a, r)) in answer.iter_mut().zip(request).enumerate() {
            *a = if i == 0 { !*r } else { *r };
        }
    }
}

impl drive_core::Timers for Store {}

/// What happens to a slave's telegram on its way to the master: the function may change the
/// bytes and returns their new length, or `None` to drop the telegram.
pub type Tamper = fn(&mut [u8; MAX_TELEGRAM], usize) -> Option<usize>;

/// A master and slaves on one simulated line, character time `char_ns`.
#[derive(Debug)]
pub struct Bus<B: Backend> {
    pub master: UssMaster,
    pub slaves: Vec<Slave<B>>,
    pub now: Instant,
    pub char_ns: u64,
    /// Applied to every answer (tests of rejections).
    pub tamper: Option<Tamper>,
    /// Start and end of every telegram on the line: (start, end, from master).
    pub log: Option<Vec<(Instant, Instant, bool)>>,
}

impl<B: Backend> Bus<B> {
    pub fn new(master: UssMaster, slaves: Vec<Slave<B>>) -> Self {
        let char_ns = master.config().line.char_time().as_nanos() as u64;
        Self {
            master,
            slaves,
            now: Instant::ZERO,
            char_ns,
            tamper: None,
            log: None,
        }
    }

    /// Hand `bytes` to everyone but the sender, one character time each from `self.now`.
    #[inline]
    fn put(&mut self, bytes: &[u8], from: Option<usize>) {
        let start = self.now;
        for (i, b) in bytes.iter().enumerate() {
            let c = RxChar::new(*b, start.add_nanos(self.char_ns * (i as u64 + 1)));
            if from.is_some() {
                self.master.handle_char(c);
            }
            for (k, s) in self.slaves.iter_mut().enumerate() {
                if from != Some(k) {
                    s.handle_char(c);
                }
            }
        }
        self.now = start.add_nanos(self.char_ns * bytes.len() as u64);
        if let Some(log) = self.log.as_mut() {
            log.push((start, self.now, from.is_none()));
        }
    }

    /// Run until the master is idle with no events left, handing every master event to
    /// `on_event`; `false` if it did not settle in a sane number of steps (a hang is a bug).
    #[inline]
    pub fn run(&mut self, mut on_event: impl FnMut(MasterEvent)) -> bool {
        let mut buf = [0u8; MAX_TELEGRAM];
        for _ in 0..100_000 {
            while let Some(ev) = self.master.poll_event() {
                on_event(ev);
            }
            if let Some(n) = self.master.poll_transmit(self.now, &mut buf) {
                self.put(&buf[..n], None);
                continue;
            }
            if self.master.is_idle() {
                return true;
            }
            let mut sent = false;
            for k in 0..self.slaves.len() {
                if let Some(n) = self.slaves[k].poll_transmit(self.now, &mut buf) {
                    let n = match self.tamper {
                        Some(f) => f(&mut buf, n),
                        None => Some(n),
                    };
                    if let Some(n) = n {
                        self.put(&buf[..n], Some(k));
                    }
                    sent = true;
                    break;
                }
            }
            if sent {
                continue;
            }
            let slaves = self
                .slaves
                .iter()
                .map(|s| s.poll_timeout())
                .fold(None, earliest);
            let Some(next) = earliest(self.master.poll_timeout(), slaves) else {
                return false;
            };
            self.now = self.now.later(next);
            self.master.handle_timeout(self.now);
            for s in &mut self.slaves {
                s.handle_timeout(self.now);
            }
        }
        false
    }
}
