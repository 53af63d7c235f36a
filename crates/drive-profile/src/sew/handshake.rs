//! The handshake bit of the parameter channel (management byte bit 6) in cyclic operation
//! (serial communication manual ch. 4.3, Bild 22): a drive executes a parameter service only
//! when the bit differs from the one of the service it executed last, and otherwise repeats its
//! last answer; the master toggles the bit for every new service and knows the service done when
//! the drive echoes the bit it sent.
//!
//! [`SlaveHandshake`] is the drive's side, [`MasterHandshake`] the master's record of every
//! drive's bit. Acyclic telegrams do not use the handshake: their service always runs.
//!
//! ```
//! use drive_profile::sew::{MasterHandshake, ParamChannel, Prepared, SlaveHandshake, Echo};
//!
//! let mut master = MasterHandshake::new();
//! let mut drive = SlaveHandshake::new();
//! // First contact: the master learns the drive's bit with an empty service.
//! assert_eq!(master.prepare(1, true, ParamChannel::read(8318)), Prepared::LearnFirst);
//! let answer = drive.handle(&ParamChannel::no_service(), |p| *p);
//! master.learn(1, answer.management.handshake());
//! // Now the read goes out with the bit toggled, and the drive executes it.
//! let Prepared::Send(req) = master.prepare(1, true, ParamChannel::read(8318)) else { panic!() };
//! let answer = drive.handle(&req, |p| p.answer(Ok(1500)));
//! assert_eq!(MasterHandshake::echo(&req, &answer), Echo::Done);
//! // Repeated, the drive does not execute it again: it repeats the answer.
//! let again = drive.handle(&req, |_| unreachable!());
//! assert_eq!(again, answer);
//! ```

use super::channel::ParamChannel;

/// The drive's side of the handshake: the bit of the last executed service and its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SlaveHandshake {
    last_bit: bool,
    last_answer: ParamChannel,
}

impl SlaveHandshake {
    /// A drive after power-on: bit 0, no answer yet (Bild 22); until the first service runs,
    /// a repeated answer is all zeros.
    pub const fn new() -> Self {
        Self {
            last_bit: false,
            last_answer: ParamChannel {
                management: super::channel::Management::from_raw(0),
                subindex: 0,
                index: 0,
                data: 0,
            },
        }
    }

    /// The answer to the parameter channel `request` of a cyclic telegram: `execute` runs when
    /// the handshake bit toggled, otherwise the previous answer is repeated unchanged.
    pub fn handle(
        &mut self,
        request: &ParamChannel,
        execute: impl FnOnce(&ParamChannel) -> ParamChannel,
    ) -> ParamChannel {
        let bit = request.management.handshake();
        if bit != self.last_bit {
            self.last_answer = execute(request);
            self.last_bit = bit;
        }
        self.last_answer
    }

    /// The bit of the last executed service.
    pub const fn last_bit(&self) -> bool {
        self.last_bit
    }
}

/// What the master sends for a new service ([`MasterHandshake::prepare`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Prepared {
    /// Send this channel (its handshake bit set as the drive expects it).
    Send(ParamChannel),
    /// The drive's bit is unknown: exchange an empty service first to learn it
    /// ([`MasterHandshake::learn`]), then prepare the service again.
    LearnFirst,
}

/// How a cyclic answer relates to the service the master sent ([`MasterHandshake::echo`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Echo {
    /// The drive echoed the sent bit with the answer of the sent service: done.
    Done,
    /// The drive has not executed the service yet: send it again.
    Wait,
    /// The drive echoes the sent bit but answers another service: its bit was not the one the
    /// master remembered (e.g. after a request whose responses were all lost). The service was
    /// not executed and will not be until the bit toggles again.
    Stale,
}

/// The master's record of the handshake bit of every drive address (0–255).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct MasterHandshake {
    /// Bit known, one per address byte value.
    known: [u128; 2],
    /// The drive's bit (unicast) or the bit sent last (group, broadcast).
    value: [u128; 2],
}

fn get(bits: &[u128; 2], address: u8) -> bool {
    bits.get(usize::from(address >> 7))
        .is_some_and(|w| w >> (address & 127) & 1 == 1)
}

fn set(bits: &mut [u128; 2], address: u8, on: bool) {
    if let Some(w) = bits.get_mut(usize::from(address >> 7)) {
        let m = 1u128 << (address & 127);
        if on { *w |= m } else { *w &= !m }
    }
}

impl MasterHandshake {
    /// Nothing known.
    pub const fn new() -> Self {
        Self {
            known: [0; 2],
            value: [0; 2],
        }
    }

    /// The drive's last known bit at `address`.
    pub fn bit(&self, address: u8) -> Option<bool> {
        get(&self.known, address).then(|| get(&self.value, address))
    }

    /// The drive at `address` answered with handshake bit `bit`.
    pub fn learn(&mut self, address: u8, bit: bool) {
        set(&mut self.known, address, true);
        set(&mut self.value, address, bit);
    }

    /// Forget what is known of `address` (e.g. the drive restarted).
    pub fn forget(&mut self, address: u8) {
        set(&mut self.known, address, false);
        set(&mut self.value, address, false);
    }

    /// The parameter channel of a cyclic request to `address` (`answered`: unicast or 254; a
    /// group or broadcast is executed without an answer): an empty service keeps the drive's
    /// bit; a new service toggles it; to an unanswered address the bit sent last is toggled.
    pub fn prepare(&mut self, address: u8, answered: bool, request: ParamChannel) -> Prepared {
        let value = get(&self.value, address);
        if request.management.service_code() == 0 {
            Prepared::Send(request.with_handshake(value))
        } else if !answered {
            set(&mut self.value, address, !value);
            Prepared::Send(request.with_handshake(!value))
        } else if get(&self.known, address) {
            Prepared::Send(request.with_handshake(!value))
        } else {
            Prepared::LearnFirst
        }
    }

    /// How the answer `got` relates to the service `sent`.
    pub fn echo(sent: &ParamChannel, got: &ParamChannel) -> Echo {
        let echoed = got.management.handshake() == sent.management.handshake();
        match (echoed, sent.is_answered_by(got)) {
            (true, true) => Echo::Done,
            (true, false) => Echo::Stale,
            (false, _) => Echo::Wait,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn master_record_per_address() {
        let mut m = MasterHandshake::new();
        assert_eq!(m.bit(200), None);
        m.learn(200, true);
        m.learn(3, false);
        assert_eq!(
            (m.bit(200), m.bit(3), m.bit(4)),
            (Some(true), Some(false), None)
        );
        let Prepared::Send(p) = m.prepare(200, true, ParamChannel::read(1)) else {
            panic!("known bit")
        };
        assert!(!p.management.handshake());
        // Empty services keep the bit.
        let Prepared::Send(p) = m.prepare(200, true, ParamChannel::no_service()) else {
            panic!("empty service")
        };
        assert!(p.management.handshake());
        // Broadcasts toggle what was sent last.
        let Prepared::Send(a) = m.prepare(255, false, ParamChannel::write(1, 2)) else {
            panic!("broadcast")
        };
        let Prepared::Send(b) = m.prepare(255, false, ParamChannel::write(1, 2)) else {
            panic!("broadcast")
        };
        assert_ne!(a.management.handshake(), b.management.handshake());
        m.forget(200);
        assert_eq!(m.bit(200), None);
    }

    #[test]
    fn echoes() {
        let sent = ParamChannel::read(8318).with_handshake(true);
        let done = sent.answer(Ok(5));
        assert_eq!(MasterHandshake::echo(&sent, &done), Echo::Done);
        let old = ParamChannel::read(8319).with_handshake(true).answer(Ok(5));
        assert_eq!(MasterHandshake::echo(&sent, &old), Echo::Stale);
        let waiting = ParamChannel::read(8319).answer(Ok(5));
        assert_eq!(MasterHandshake::echo(&sent, &waiting), Echo::Wait);
    }

    #[test]
    fn drive_executes_only_on_toggle() {
        let mut d = SlaveHandshake::new();
        let mut runs = 0;
        let mut exec = |p: &ParamChannel| {
            runs += 1;
            p.answer(Ok(runs))
        };
        let r0 = ParamChannel::read(1);
        assert_eq!(d.handle(&r0, &mut exec), ParamChannel::default());
        let r1 = r0.with_handshake(true);
        let a1 = d.handle(&r1, &mut exec);
        assert_eq!(a1.result(), Ok(1));
        assert_eq!(d.handle(&r1, &mut exec), a1);
        assert_eq!(d.handle(&r0, &mut exec).result(), Ok(2));
        assert!(!d.last_bit());
    }
}
