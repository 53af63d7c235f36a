//! In-memory bus for tests and benchmarks: a master and a drive exchange characters with wire
//! timing (one character = 11 bits at 9600 baud), optional faults, and a simple parameter store.
#![allow(dead_code)]

use core::time::Duration;

use drive_core::time::earliest;

use movilink::timing::{CHAR_TIME, Instant, START_PAUSE};
use movilink::{
    AttributeInfo, Backend, MasterEvent, MovilinkMaster, ParamChannel, RequestContext, ReturnCode,
    RxChar, ScaleInfo, Service, Slave,
};

/// A drive with a few parameters: (index, value, min, max, read-only).
#[derive(Debug, Clone)]
pub struct TestDrive {
    pub params: [(u16, u32, u32, u32, bool); 4],
    /// Parameter services executed.
    pub executed: u32,
    /// Last process output words received.
    pub po: [u16; 3],
    /// Process input words answered.
    pub pi: [u16; 3],
    /// Timeouts of its own link monitor (like the MOVIDRIVE's P812).
    pub timeouts: u32,
    /// Its link monitor: the longest time between cyclic requests, if on.
    pub monitor: Option<Duration>,
    /// When the monitor fires, while armed.
    pub deadline: Option<Instant>,
    /// The context of the last request.
    pub last_request: Option<RequestContext>,
}

impl Default for TestDrive {
    fn default() -> Self {
        Self {
            params: [
                // P131 ramp t11 down CW [ms], 0…2 000 000, default 2000.
                (8471, 2000, 0, 2_000_000, false),
                // P000 speed, read-only.
                (8318, 1500, 0, 0xFFFF_FFFF, true),
                // P810 RS-485 address.
                (8597, 1, 0, 99, false),
                // P812 RS-485 timeout [ms].
                (8599, 0, 0, 650_000, false),
            ],
            executed: 0,
            po: [0; 3],
            pi: [0x0206, 0x0000, 0x0606],
            timeouts: 0,
            monitor: None,
            deadline: None,
            last_request: None,
        }
    }
}

impl TestDrive {
    pub fn value(&self, index: u16) -> Option<u32> {
        self.params.iter().find(|p| p.0 == index).map(|p| p.1)
    }
}

impl Backend for TestDrive {
    fn on_request(&mut self, ctx: &RequestContext) {
        self.last_request = Some(*ctx);
        if ctx.cyclic {
            self.deadline = self.monitor.map(|m| ctx.end + m);
        }
    }

    fn param(&mut self, _ctx: &RequestContext, req: &ParamChannel) -> Result<u32, ReturnCode> {
        self.executed += 1;
        let Some(p) = self.params.iter_mut().find(|p| p.0 == req.index) else {
            return Err(ReturnCode::ILLEGAL_INDEX);
        };
        match req.service() {
            Some(Service::Read) => Ok(p.1),
            Some(Service::Write | Service::WriteVolatile) => {
                if p.4 {
                    Err(ReturnCode::READ_ONLY)
                } else if req.data > p.3 {
                    Err(ReturnCode::VALUE_TOO_LARGE)
                } else if req.data < p.2 {
                    Err(ReturnCode::VALUE_TOO_SMALL)
                } else {
                    p.1 = req.data;
                    Ok(req.data)
                }
            }
            Some(Service::ReadMinimum) => Ok(p.2),
            Some(Service::ReadMaximum) => Ok(p.3),
            Some(Service::ReadDefault) => Ok(2000),
            Some(Service::ReadScale) => Ok(ScaleInfo {
                size_index: 4,
                conversion_index: -3,
            }
            .to_data()),
            Some(Service::ReadAttribute) => Ok(AttributeInfo {
                next_index: req.index + 1,
                attributes: 0x0003,
            }
            .to_data()),
            _ => Err(ReturnCode::NOT_IMPLEMENTED),
        }
    }

    fn process_data(&mut self, _ctx: &RequestContext, output: &[u16], input: &mut [u16]) {
        for (dst, src) in self.po.iter_mut().zip(output) {
            *dst = *src;
        }
        for (dst, src) in input.iter_mut().zip(self.pi) {
            *dst = src;
        }
    }
}

impl drive_core::Timers for TestDrive {
    fn poll_timeout(&self) -> Option<Instant> {
        self.deadline
    }

    fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|d| now >= d) {
            self.timeouts += 1;
            self.deadline = None;
        }
    }
}

/// Faults injected on the wire (each counter is consumed by the next telegrams).
#[derive(Debug, Clone, Copy, Default)]
pub struct Faults {
    /// Requests that do not reach the drive.
    pub drop_requests: u32,
    /// Responses that do not reach the master.
    pub drop_responses: u32,
    /// Responses whose last PDU byte is flipped (BCC mismatch).
    pub corrupt_responses: u32,
    /// Responses whose 4th character arrives with a parity error.
    pub parity_responses: u32,
}

/// A master and a drive on one simulated RS-485 line.
#[derive(Debug)]
pub struct Bus<B: Backend> {
    pub master: MovilinkMaster,
    pub slave: Slave<B>,
    pub now: Instant,
    pub faults: Faults,
    /// Telegrams put on the wire by the master / the drive.
    pub requests: u32,
    pub responses: u32,
}

impl<B: Backend> Bus<B> {
    pub fn new(master: MovilinkMaster, slave: Slave<B>) -> Self {
        Self {
            master,
            slave,
            now: Instant::ZERO,
            faults: Faults::default(),
            requests: 0,
            responses: 0,
        }
    }

    /// Run until the master is idle with no events left, handing every master event to
    /// `on_event`. Panics after an absurd number of steps (a hang is a bug).
    pub fn run(&mut self, mut on_event: impl FnMut(MasterEvent)) {
        let mut buf = [0u8; 18];
        for _ in 0..100_000 {
            while let Some(ev) = self.master.poll_event() {
                on_event(ev);
            }
            if let Some(n) = self.master.poll_transmit(self.now, &mut buf) {
                self.requests += 1;
                let start = self.now;
                if self.faults.drop_requests > 0 {
                    self.faults.drop_requests -= 1;
                } else {
                    for (i, b) in buf[..n].iter().enumerate() {
                        self.slave.handle_char(RxChar::new(*b, after(start, i + 1)));
                    }
                }
                self.now = after(start, n);
                continue;
            }
            if self.master.is_idle() {
                // A request without response (group, broadcast) is executed once the quiet
                // line after it confirmed its end, a start pause after its last character.
                let settle = self.now + START_PAUSE;
                if self.slave.poll_timeout().is_some_and(|t| t <= settle) {
                    self.slave.handle_timeout(settle);
                }
                return;
            }
            if let Some(n) = self.slave.poll_transmit(self.now, &mut buf) {
                self.responses += 1;
                let start = self.now;
                if self.faults.drop_responses > 0 {
                    self.faults.drop_responses -= 1;
                } else {
                    let corrupt = self.faults.corrupt_responses > 0;
                    let parity = !corrupt && self.faults.parity_responses > 0;
                    if corrupt {
                        self.faults.corrupt_responses -= 1;
                        buf[n - 2] ^= 0x40;
                    }
                    if parity {
                        self.faults.parity_responses -= 1;
                    }
                    for (i, b) in buf[..n].iter().enumerate() {
                        let t = after(start, i + 1);
                        let c = if parity && i == 3 {
                            RxChar::with_error(*b, t, movilink::CharError::Parity)
                        } else {
                            RxChar::new(*b, t)
                        };
                        self.master.handle_char(c);
                    }
                }
                self.now = after(start, n);
                continue;
            }
            let next = earliest(self.master.poll_timeout(), self.slave.poll_timeout());
            let Some(next) = next else { return };
            if next > self.now {
                self.now = next;
            }
            self.master.handle_timeout(self.now);
            self.slave.handle_timeout(self.now);
        }
        panic!("bus did not settle");
    }

    /// Run and collect the events.
    pub fn run_collect(&mut self) -> Vec<MasterEvent> {
        let mut v = Vec::new();
        self.run(|e| v.push(e));
        v
    }
}

/// The end of `n` characters sent back to back from `start` (in nanoseconds: the pump is part
/// of the exchange benchmark).
fn after(start: Instant, n: usize) -> Instant {
    const CHAR_NS: u64 = CHAR_TIME.as_nanos() as u64;
    start.add_nanos(CHAR_NS * n as u64)
}
