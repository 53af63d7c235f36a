//! In-memory bus for the benchmarks and the allocation test: the sans-IO master and one drive
//! exchange characters back to back with wire timestamps (one character time of the line per
//! character), no I/O, no allocation, and a trivial parameter store as the drive.
#![allow(dead_code)]

use bonfiglioli_modbus::frame::{ExceptionCode, StartAddress};
use bonfiglioli_modbus::framing::MAX_FRAME;
use bonfiglioli_modbus::master::{MasterEvent, ModbusMaster};
use bonfiglioli_modbus::slave::{Backend, Slave, Width};
use drive_core::time::earliest;
use drive_core::{Endpoint, Instant, RxChar};

/// A drive whose parameter `p` in every data set holds `p * 3 + 1` (16 bits) until written;
/// writes are kept in one slot per width.
#[derive(Debug, Clone, Copy, Default)]
pub struct Trivial {
    /// The last value written with FC 6 / 101 and its start address.
    pub written: Option<(StartAddress, Width, u32)>,
}

impl Trivial {
    /// What a read of `start` with `width` returns.
    pub fn value(&self, start: StartAddress, width: Width) -> u32 {
        match self.written {
            Some((s, w, v)) if s == start && w == width => v,
            _ => {
                let v = u32::from(start.raw()).wrapping_mul(3).wrapping_add(1);
                match width {
                    Width::Word => v & 0xFFFF,
                    Width::Long => v,
                }
            }
        }
    }
}

impl Backend for Trivial {
    fn read(
        &mut self,
        start: StartAddress,
        width: Width,
        _: Instant,
    ) -> Result<u32, ExceptionCode> {
        Ok(self.value(start, width))
    }

    fn write(
        &mut self,
        start: StartAddress,
        width: Width,
        value: u32,
        _: Instant,
    ) -> Result<(), ExceptionCode> {
        self.written = Some((start, width, value));
        Ok(())
    }
}

impl drive_core::Timers for Trivial {}

/// A master and a drive on one simulated line, character time `char_ns`.
#[derive(Debug)]
pub struct Bus<B: Backend> {
    pub master: ModbusMaster,
    pub slave: Slave<B>,
    pub now: Instant,
    pub char_ns: u64,
}

impl<B: Backend> Bus<B> {
    pub fn new(master: ModbusMaster, slave: Slave<B>) -> Self {
        let char_ns = master.config().line.char_time().as_nanos() as u64;
        Self {
            master,
            slave,
            now: Instant::ZERO,
            char_ns,
        }
    }

    /// Run until the master is idle with no events left, handing every master event to
    /// `on_event`; `false` if it did not settle in a sane number of steps (a hang is a bug).
    #[inline]
    pub fn run(&mut self, mut on_event: impl FnMut(MasterEvent)) -> bool {
        let mut buf = [0u8; MAX_FRAME];
        for _ in 0..10_000 {
            while let Some(ev) = self.master.poll_event() {
                on_event(ev);
            }
            if let Some(n) = self.master.poll_transmit(self.now, &mut buf) {
                let start = self.now;
                for (i, b) in buf.iter().take(n).enumerate() {
                    self.slave.handle_char(RxChar::new(
                        *b,
                        start.add_nanos(self.char_ns * (i as u64 + 1)),
                    ));
                }
                self.now = start.add_nanos(self.char_ns * n as u64);
                continue;
            }
            if self.master.is_idle() {
                return true;
            }
            if let Some(n) = self.slave.poll_transmit(self.now, &mut buf) {
                let start = self.now;
                for (i, b) in buf.iter().take(n).enumerate() {
                    self.master.handle_char(RxChar::new(
                        *b,
                        start.add_nanos(self.char_ns * (i as u64 + 1)),
                    ));
                }
                self.now = start.add_nanos(self.char_ns * n as u64);
                continue;
            }
            let Some(next) = earliest(self.master.poll_timeout(), self.slave.poll_timeout()) else {
                return false;
            };
            self.now = self.now.later(next);
            self.master.handle_timeout(self.now);
            self.slave.handle_timeout(self.now);
        }
        false
    }
}
