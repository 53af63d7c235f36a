//! The one shell of a simulated device: a protocol's sans-IO slave ([`SlaveEndpoint`]) with a
//! thin front-end that follows the slave's events, and the line time it keeps for being served
//! alone. What every protocol's `Simulated…` device is; implementing [`Simulated`] makes it an
//! [`Endpoint`] and a [`Station`].

use core::time::Duration;

use super::bus::{LineTime, Station};
use super::clock::Clock;
use crate::char::RxChar;
use crate::endpoint::{Endpoint, SlaveEndpoint};
use crate::time::Instant;

/// What every simulated device holds: its protocol's slave and the line time it is served
/// alone with ([`serve_alone`](super::serve_alone)), kept across serves.
#[derive(Debug, Clone)]
pub struct Shell<S> {
    /// The protocol's slave state machine.
    pub slave: S,
    line: LineTime,
}

impl<S> Shell<S> {
    /// `slave`, not served yet, on [`Clock::Real`].
    pub const fn new(slave: S) -> Self {
        Self {
            slave,
            line: LineTime::new(),
        }
    }

    /// Serve on `clock` from now on; the slave keeps its line history, its time goes on from
    /// where it is.
    pub fn set_clock(&mut self, clock: Clock) {
        self.line.set_clock(clock);
    }
}

/// A simulated device built on a protocol's slave state machine, held in its [`Shell`].
///
/// The device is an [`Endpoint`] that hands characters (while it
/// [`hears`](Simulated::hears) the line) and time to its slave and lets the front-end follow
/// the slave's events after each; and a [`Station`] at the slave's address and character time.
pub trait Simulated {
    /// Drain the slave's events (follow a written address or mode, count telegrams); called
    /// after every character and every advance of time.
    fn follow_events(&mut self);

    /// Whether the slave hears characters now; a device switched to another protocol does
    /// not. Time always reaches the slave.
    fn hears(&self) -> bool {
        true
    }

    /// The address the device answers now, as a [`Station`]: by default its slave's.
    fn station_address(&self) -> u8 {
        self.shell().slave.address()
    }

    /// The shell.
    fn shell(&self) -> &Shell<impl SlaveEndpoint>;

    /// The shell, for changing.
    fn shell_mut(&mut self) -> &mut Shell<impl SlaveEndpoint>;
}

impl<T: Simulated> Endpoint for T {
    fn handle_char(&mut self, c: RxChar) {
        if self.hears() {
            self.shell_mut().slave.handle_char(c);
        }
        self.follow_events();
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.shell_mut().slave.handle_timeout(now);
        self.follow_events();
    }

    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
        self.shell_mut().slave.poll_transmit(now, buf)
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.shell().slave.poll_timeout()
    }

    fn poll_quiet_timeout(&self) -> Option<Instant> {
        self.shell().slave.poll_quiet_timeout()
    }

    fn max_frame_len(&self) -> usize {
        self.shell().slave.max_frame_len()
    }
}

impl<T: Simulated> Station for T {
    fn address(&self) -> u8 {
        self.station_address()
    }

    fn char_time(&self) -> Duration {
        self.shell().slave.char_time()
    }

    fn line_time(&mut self) -> &mut LineTime {
        &mut self.shell_mut().line
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LineSettings;
    use crate::rt::Bus;

    /// A toy slave: counts characters, echoes the last one at its deadline.
    #[derive(Debug, Default)]
    struct Echo {
        heard: u32,
        last: Option<(u8, Instant)>,
        now: Instant,
    }

    impl Endpoint for Echo {
        fn handle_char(&mut self, c: RxChar) {
            self.heard += 1;
            self.last = Some((c.byte, c.time));
        }
        fn handle_timeout(&mut self, now: Instant) {
            self.now = now;
        }
        fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize> {
            let (byte, at) = self.last?;
            if now < at + Duration::from_millis(1) {
                return None;
            }
            *buf.first_mut()? = byte;
            self.last = None;
            Some(1)
        }
        fn poll_timeout(&self) -> Option<Instant> {
            self.last.map(|(_, at)| at + Duration::from_millis(1))
        }
        fn poll_quiet_timeout(&self) -> Option<Instant> {
            Some(self.now + Duration::from_millis(7))
        }
        fn max_frame_len(&self) -> usize {
            3
        }
    }

    impl SlaveEndpoint for Echo {
        fn address(&self) -> u8 {
            9
        }
        fn char_time(&self) -> Duration {
            Duration::from_micros(520)
        }
    }

    /// A device that stops hearing after a 0 byte and counts the follow-ups.
    #[derive(Debug)]
    struct Device {
        shell: Shell<Echo>,
        deaf: bool,
        followed: u32,
    }

    impl Default for Device {
        fn default() -> Self {
            Self {
                shell: Shell::new(Echo::default()),
                deaf: false,
                followed: 0,
            }
        }
    }

    impl Simulated for Device {
        fn shell(&self) -> &Shell<impl SlaveEndpoint> {
            &self.shell
        }
        fn shell_mut(&mut self) -> &mut Shell<impl SlaveEndpoint> {
            &mut self.shell
        }
        fn hears(&self) -> bool {
            !self.deaf
        }
        fn follow_events(&mut self) {
            self.followed += 1;
            self.deaf |= self.shell.slave.last.is_some_and(|(b, _)| b == 0);
        }
    }

    fn char_at(byte: u8, ms: u64) -> RxChar {
        RxChar {
            byte,
            time: Instant::ZERO + Duration::from_millis(ms),
            error: None,
        }
    }

    #[test]
    fn the_slave_gets_characters_while_the_device_hears_and_time_always() {
        let mut d = Device::default();
        d.handle_char(char_at(5, 1));
        assert_eq!(
            d.poll_timeout(),
            Some(Instant::ZERO + Duration::from_millis(2))
        );
        let mut buf = [0u8; 3];
        assert_eq!(
            d.poll_transmit(Instant::ZERO + Duration::from_millis(2), &mut buf),
            Some(1)
        );
        assert_eq!(buf[0], 5);
        d.handle_char(char_at(0, 3));
        d.handle_char(char_at(6, 4));
        assert_eq!((d.shell.slave.heard, d.followed, d.deaf), (2, 3, true));
        d.handle_timeout(Instant::ZERO + Duration::from_millis(10));
        assert_eq!(d.followed, 4);
        assert_eq!(
            d.poll_quiet_timeout(),
            Some(Instant::ZERO + Duration::from_millis(17))
        );
        assert_eq!(d.max_frame_len(), 3);
    }

    #[test]
    fn a_simulated_device_is_a_station_of_a_bus() {
        let bus = Bus::new(
            [Device::default(), Device::default()],
            LineSettings::new(19200),
        );
        assert_eq!(
            bus.stations().len(),
            1,
            "the second device at address 9 is dropped"
        );
        let d = bus.station(9).map(|s| (s.address(), s.char_time()));
        assert_eq!(d, Some((9, Duration::from_micros(520))));
    }
}
