//! Classical CAN (ISO 11898-1, CAN 2.0 A and B) as every CAN protocol and transport of drivebus
//! sees it: one frame type, bit rates, frame lengths on the wire and the interface of a sans-IO
//! CAN participant.
//!
//! * [`CanFrame`]: a data or remote frame with a standard (11-bit) or extended (29-bit)
//!   identifier and 0–8 data bytes. It implements [`embedded_can::Frame`], so a protocol crate
//!   stays `no_std` and any `embedded-can` driver can carry its frames; the identifier types are
//!   `embedded-can`'s ([`Id`], [`StandardId`], [`ExtendedId`]).
//! * [`Bitrate`] and the frame length in bits: [`CanFrame::bits`] counts the stuff bits the
//!   frame really needs, [`worst_case_bits`] the most any frame of that length can need (the
//!   bound a bus-load budget must use).
//! * [`CanEndpoint`]: a sans-IO CAN participant (master, slave, simulated drive): frames and the
//!   passing of time go in, frames to send and deadlines come out.
//! * [`CanExchange`]: the transaction skeleton of a CAN master (attempts, retries, give-up, the
//!   late guard, responses received before the request went out counted as stale), the carrier
//!   of [`crate::master::Master`] on CAN.
//!
//! Nothing here allocates or panics on any frame.

use core::fmt;
use core::time::Duration;

pub use embedded_can::{ExtendedId, Frame, Id, StandardId};

mod exchange;
pub use exchange::{CanExchange, CanExchangeConfig, CanTally};

use crate::time::Instant;

/// One classical CAN frame: identifier, remote flag and 0–8 data bytes.
///
/// ```
/// use drive_core::can::{CanFrame, Frame, StandardId};
///
/// let f = CanFrame::standard(267, &[0x00, 0x06, 0x13, 0x88, 0x00, 0x00]).unwrap();
/// assert_eq!(f.raw_id(), 267);
/// assert_eq!(f.data(), &[0x00, 0x06, 0x13, 0x88, 0x00, 0x00]);
/// assert!(CanFrame::standard(2048, &[]).is_none()); // not an 11-bit identifier
/// assert!(CanFrame::standard(1, &[0; 9]).is_none()); // more than 8 bytes
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: Id,
    remote: bool,
    dlc: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A data frame with identifier `id`; `None` for more than 8 bytes.
    pub fn data_frame(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let len = data.len();
        if len > 8 {
            return None;
        }
        let mut bytes = [0u8; 8];
        bytes.get_mut(..len)?.copy_from_slice(data);
        Some(Self {
            id: id.into(),
            remote: false,
            dlc: len as u8,
            data: bytes,
        })
    }

    /// A data frame with identifier `id` and the first `len` bytes of `data` (`len` above 8
    /// counts as 8; bytes beyond `len` are cleared). Infallible, for encoders that know their
    /// length.
    pub const fn from_array(id: Id, data: [u8; 8], len: usize) -> Self {
        let dlc = if len > 8 { 8 } else { len };
        // Keep the first `dlc` bytes: one mask on the 64-bit word, no loop.
        let keep = if dlc == 0 {
            0
        } else {
            u64::MAX << (8 * (8 - dlc))
        };
        let bytes = (u64::from_be_bytes(data) & keep).to_be_bytes();
        Self {
            id,
            remote: false,
            dlc: dlc as u8,
            data: bytes,
        }
    }

    /// A data frame with the standard identifier `id`; `None` if `id` > 2047 or more than 8 bytes.
    pub fn standard(id: u16, data: &[u8]) -> Option<Self> {
        Self::data_frame(StandardId::new(id)?, data)
    }

    /// A remote frame asking for `dlc` bytes (0–8) with identifier `id`.
    pub fn remote_frame(id: impl Into<Id>, dlc: u8) -> Option<Self> {
        if dlc > 8 {
            return None;
        }
        Some(Self {
            id: id.into(),
            remote: true,
            dlc,
            data: [0; 8],
        })
    }

    /// The identifier as a number (11 or 29 bits).
    pub fn raw_id(&self) -> u32 {
        match self.id {
            Id::Standard(s) => u32::from(s.as_raw()),
            Id::Extended(e) => e.as_raw(),
        }
    }

    /// The standard identifier, `None` for an extended one.
    pub fn standard_id(&self) -> Option<u16> {
        match self.id {
            Id::Standard(s) => Some(s.as_raw()),
            Id::Extended(_) => None,
        }
    }

    /// The data length code (0–8; for a remote frame the length asked for).
    pub const fn len(&self) -> usize {
        self.dlc as usize
    }

    /// Whether the frame carries no data bytes.
    pub const fn is_empty(&self) -> bool {
        self.dlc == 0
    }

    /// The data bytes as an array, zero beyond [`CanFrame::len`].
    pub const fn data_array(&self) -> [u8; 8] {
        self.data
    }

    /// The frame's length on the wire in bits at its real bit stuffing: start of frame to the
    /// end of the intermission (3 bits), stuff bits included.
    pub fn bits(&self) -> u32 {
        exact_bits(self)
    }

    /// How long the frame occupies a bus at `rate` ([`CanFrame::bits`] bit times).
    pub fn duration(&self, rate: Bitrate) -> Duration {
        rate.bits_duration(self.bits())
    }
}

impl Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        Self::data_frame(id, data)
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        Self::remote_frame(id, u8::try_from(dlc).ok()?)
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        self.dlc as usize
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            self.data.get(..self.dlc as usize).unwrap_or(&[])
        }
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// The candump spelling: `10B#0006138800000000`, `12345678#…` for an extended identifier,
/// `123#R` (or `123#R4`) for a remote frame.
impl fmt::Display for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.id {
            Id::Standard(s) => write!(f, "{:03X}#", s.as_raw())?,
            Id::Extended(e) => write!(f, "{:08X}#", e.as_raw())?,
        }
        if self.remote {
            f.write_str("R")?;
            if self.dlc > 0 {
                write!(f, "{}", self.dlc)?;
            }
            return Ok(());
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// A CAN bit rate in bit/s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Bitrate(u32);

impl Bitrate {
    /// 10 kbit/s (slcan `S0`).
    pub const K10: Bitrate = Bitrate(10_000);
    /// 20 kbit/s (slcan `S1`).
    pub const K20: Bitrate = Bitrate(20_000);
    /// 50 kbit/s (slcan `S2`).
    pub const K50: Bitrate = Bitrate(50_000);
    /// 100 kbit/s (slcan `S3`).
    pub const K100: Bitrate = Bitrate(100_000);
    /// 125 kbit/s (slcan `S4`; SBus P816).
    pub const K125: Bitrate = Bitrate(125_000);
    /// 250 kbit/s (slcan `S5`; SBus P816).
    pub const K250: Bitrate = Bitrate(250_000);
    /// 500 kbit/s (slcan `S6`; SBus P816, factory setting).
    pub const K500: Bitrate = Bitrate(500_000);
    /// 800 kbit/s (slcan `S7`).
    pub const K800: Bitrate = Bitrate(800_000);
    /// 1000 kbit/s (slcan `S8`; SBus P816).
    pub const M1: Bitrate = Bitrate(1_000_000);

    /// A bit rate of `bits_per_second` (1 bit/s to 1 Mbit/s, the classical CAN maximum).
    pub const fn new(bits_per_second: u32) -> Option<Bitrate> {
        if bits_per_second == 0 || bits_per_second > 1_000_000 {
            None
        } else {
            Some(Bitrate(bits_per_second))
        }
    }

    /// Bits per second.
    pub const fn bits_per_second(self) -> u32 {
        self.0
    }

    /// The time of one bit.
    pub const fn bit_time(self) -> Duration {
        Duration::from_nanos(1_000_000_000 / self.0 as u64)
    }

    /// The time of `bits` bits, exact to the nanosecond (rounded up).
    pub const fn bits_duration(self, bits: u32) -> Duration {
        let n = bits as u64 * 1_000_000_000;
        Duration::from_nanos(n.div_ceil(self.0 as u64))
    }
}

impl fmt::Display for Bitrate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_multiple_of(1000) {
            write!(f, "{} kbit/s", self.0 / 1000)
        } else {
            write!(f, "{} bit/s", self.0)
        }
    }
}

/// Bits of a frame that are not subject to bit stuffing: CRC delimiter, ACK slot and
/// delimiter, end of frame (7) and intermission (3).
const UNSTUFFED_TAIL: u32 = 1 + 2 + 7 + 3;

/// The most bits a data frame with `len` data bytes (0–8, more counts as 8) can take on the
/// wire: the stuffed part (start of frame to the CRC) with the worst case of one stuff bit per
/// four bits after the first, plus the unstuffed tail and the intermission.
///
/// Standard identifier: 34 + 8·len stuffed bits, so 47 + 8·len + ⌊(33 + 8·len) / 4⌋
/// (55 bits for 0 bytes, 135 for 8); extended: 54 + 8·len stuffed bits, so
/// 67 + 8·len + ⌊(53 + 8·len) / 4⌋ (80 and 160).
///
/// ```
/// use drive_core::can::worst_case_bits;
/// assert_eq!(worst_case_bits(false, 8), 135);
/// assert_eq!(worst_case_bits(false, 0), 55);
/// assert_eq!(worst_case_bits(true, 8), 160);
/// ```
pub const fn worst_case_bits(extended: bool, len: usize) -> u32 {
    let len = if len > 8 { 8 } else { len as u32 };
    let stuffed = if extended { 54 } else { 34 } + 8 * len;
    stuffed + (stuffed - 1) / 4 + UNSTUFFED_TAIL
}

/// The frame's bits from start of frame to the last CRC bit, as a bit string (first bit
/// transmitted in the highest position used) and its length. At most 54 + 64 + 15 = 133 bits.
struct BitString {
    bits: [u64; 3],
    len: u32,
}

impl BitString {
    const fn new() -> Self {
        Self {
            bits: [0; 3],
            len: 0,
        }
    }

    fn push(&mut self, value: u64, width: u32) {
        let mut i = width;
        while i > 0 {
            i -= 1;
            let bit = (value >> i) & 1;
            let word = (self.len / 64) as usize;
            if let Some(w) = self.bits.get_mut(word) {
                *w |= bit << (63 - self.len % 64);
            }
            self.len += 1;
        }
    }

    fn get(&self, i: u32) -> bool {
        self.bits
            .get((i / 64) as usize)
            .is_some_and(|w| (w >> (63 - i % 64)) & 1 == 1)
    }
}

/// CAN's CRC-15 (polynomial 4599h) over the first `len` bits of `s`.
fn crc15(s: &BitString) -> u16 {
    let mut crc: u16 = 0;
    for i in 0..s.len {
        let next = s.get(i) ^ ((crc >> 14) & 1 == 1);
        crc = (crc << 1) & 0x7FFF;
        if next {
            crc ^= 0x4599;
        }
    }
    crc
}

fn exact_bits(f: &CanFrame) -> u32 {
    let mut s = BitString::new();
    s.push(0, 1); // start of frame (dominant)
    match f.id {
        Id::Standard(id) => {
            s.push(u64::from(id.as_raw()), 11);
            s.push(u64::from(f.remote), 1); // RTR
            s.push(0, 1); // IDE
            s.push(0, 1); // r0
        }
        Id::Extended(id) => {
            let raw = u64::from(id.as_raw());
            s.push(raw >> 18, 11);
            s.push(1, 1); // SRR
            s.push(1, 1); // IDE
            s.push(raw & 0x3FFFF, 18);
            s.push(u64::from(f.remote), 1); // RTR
            s.push(0, 2); // r1, r0
        }
    }
    s.push(u64::from(f.dlc), 4);
    if !f.remote {
        for b in f.data() {
            s.push(u64::from(*b), 8);
        }
    }
    let crc = crc15(&s);
    s.push(u64::from(crc), 15);
    // A stuff bit follows five equal bits; it counts towards the next run.
    let mut stuff = 0;
    let mut run = 0;
    let mut last = None;
    for i in 0..s.len {
        let b = s.get(i);
        if Some(b) == last {
            run += 1;
        } else {
            run = 1;
            last = Some(b);
        }
        if run == 5 {
            stuff += 1;
            run = 1;
            last = Some(!b);
        }
    }
    s.len + stuff + UNSTUFFED_TAIL
}

/// A sans-IO CAN participant (a master, a slave, a simulated drive), in the style of
/// [`Endpoint`](crate::Endpoint): frames and the passing of time go in, frames to send and
/// deadlines come out. Time is always an argument.
///
/// Every node on a CAN bus sees every frame, its own included only if the transport echoes it;
/// an endpoint filters by identifier itself.
pub trait CanEndpoint {
    /// Feed one frame received from the bus at `now` (the end of its last bit).
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant);

    /// Advance the time to `now` and do what is due by then. May be called at any time; an
    /// endpoint with nothing due does nothing.
    fn handle_timeout(&mut self, now: Instant);

    /// The next frame to send, if one is due at `now`.
    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame>;

    /// When [`CanEndpoint::handle_timeout`] (or [`CanEndpoint::poll_transmit`]) has work to do.
    fn poll_timeout(&self) -> Option<Instant>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worst_case_is_never_exceeded() {
        // Exhaustive over lengths and a spread of identifiers and data patterns.
        let patterns = [0x00u8, 0xFF, 0x0F, 0xF0, 0x55, 0xAA, 0x78, 0x87];
        for len in 0..=8usize {
            for id in (0u16..2048).step_by(7) {
                for p in patterns {
                    let data = [p; 8];
                    let f = CanFrame::standard(id, &data[..len]).unwrap();
                    let bits = f.bits();
                    let worst = worst_case_bits(false, len);
                    assert!(bits <= worst, "{f}: {bits} > {worst}");
                    assert!(bits >= 47 + 8 * len as u32, "{f}: {bits}");
                }
            }
        }
    }

    #[test]
    fn hand_computed_frame_lengths() {
        // 0x000, DLC 0: SOF + 11 id + RTR + IDE + r0 + DLC 0000 = 19 dominant bits, and the
        // CRC of all-zero bits is 0: 34 dominant bits. A stuff bit (recessive) follows every
        // five, and starts the next run, so the next one comes five zeros later: after bits
        // 5, 10, …, 30, six stuff bits. 34 + 6 + 13 = 53, two less than the worst case (which
        // needs runs of four after each stuff bit: 0000 1111 0000 …).
        let f = CanFrame::standard(0, &[]).unwrap();
        assert_eq!(f.bits(), 34 + 6 + 13);
        assert_eq!(worst_case_bits(false, 0), 55);
        // The Bitrate arithmetic: 135 bits at 500 kbit/s are 270 µs.
        assert_eq!(Bitrate::K500.bits_duration(135), Duration::from_micros(270));
        assert_eq!(Bitrate::M1.bit_time(), Duration::from_micros(1));
    }

    #[test]
    fn crc15_of_a_known_frame() {
        // The generator itself: the CRC of the single bit 1 is the polynomial.
        let mut s = BitString::new();
        s.push(1, 1);
        assert_eq!(crc15(&s), 0x4599);
    }

    #[test]
    fn from_array_keeps_only_its_length() {
        let id = Id::Standard(StandardId::new(5).unwrap());
        let data = [1, 2, 3, 4, 5, 6, 7, 8];
        for len in 0..=10 {
            let f = CanFrame::from_array(id, data, len);
            let n = len.min(8);
            assert_eq!(f.data(), &data[..n]);
            assert!(f.data_array()[n..].iter().all(|b| *b == 0), "{len}");
            assert_eq!(f, CanFrame::data_frame(id, &data[..n]).unwrap());
        }
    }

    #[test]
    fn display_is_candump_spelling() {
        let f = CanFrame::standard(0x10B, &[0, 6, 0x13, 0x88]).unwrap();
        assert_eq!(f.to_string(), "10B#00061388");
        let r = CanFrame::remote_frame(StandardId::new(0x7FF).unwrap(), 3).unwrap();
        assert_eq!(r.to_string(), "7FF#R3");
        assert!(r.data().is_empty());
        let e = CanFrame::data_frame(ExtendedId::new(0x1234_5678).unwrap(), &[1]).unwrap();
        assert_eq!(e.to_string(), "12345678#01");
        assert_eq!(e.raw_id(), 0x1234_5678);
        assert!(e.is_extended());
        assert_eq!(e.standard_id(), None);
    }
}
