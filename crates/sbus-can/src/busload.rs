//! The bus-load model behind the `Result` of a cyclic variable object (manual ch. 5.5,
//! `_SBusCommDef(SCD_TRCYCL, …)`: "freie Buskapazität in %", −3 "Busüberlastung").
//!
//! A frame occupies the bus for its worst-case length in bits ([`frame_bits`]: standard
//! identifier, worst-case bit stuffing, intermission included, from
//! [`drive_core::can::worst_case_bits`]); a frame of `len` bytes every `period` loads a bus of
//! bit rate `r` by `bits / (r × period)`. Loads add up. The free capacity is
//! ⌊100 − load %⌋; a load above 100 % is an overload.
//!
//! The load is kept exactly enough for a percentage: in parts per 10¹² of the bus time, each
//! term rounded up, so a model load is never below the real one.
//!
//! ```
//! use core::time::Duration;
//! use drive_core::can::Bitrate;
//! use sbus_can::busload::BusLoad;
//!
//! // The manual's screenshots: 8 bytes every 100 ms at the factory 500 kbit/s → Result 99.
//! let load = BusLoad::periodic(8, Duration::from_millis(100), Bitrate::K500);
//! assert_eq!(load.free_capacity(), Some(99));
//! assert_eq!(load.ppm(), 2700); // 135 bits = 270 µs per 100 ms = 0.27 %
//! ```

use core::fmt;
use core::ops::{Add, AddAssign};
use core::time::Duration;

use drive_core::can::{Bitrate, worst_case_bits};

/// The SBus bit rates of P816, slowest first (factory setting 500 kbit/s).
pub const SBUS_BITRATES: [Bitrate; 4] = [Bitrate::K125, Bitrate::K250, Bitrate::K500, Bitrate::M1];

/// The factory setting of P816 "SBus baud rate".
pub const DEFAULT_BITRATE: Bitrate = Bitrate::K500;

/// The whole bus time, in the unit of [`BusLoad`] (10⁻¹²).
const FULL: u64 = 1_000_000_000_000;

/// The most bits a standard-identifier data frame of `len` bytes (0–8; more counts as 8) takes
/// on the wire: worst-case stuffing, intermission included (55 bits for 0 bytes, 135 for 8).
pub const fn frame_bits(len: usize) -> u32 {
    worst_case_bits(false, len)
}

/// How long such a frame occupies a bus at `rate` (rounded up to the nanosecond).
pub const fn frame_time(len: usize, rate: Bitrate) -> Duration {
    rate.bits_duration(frame_bits(len))
}

/// A share of the bus time, as parts per 10¹²; add loads with `+`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct BusLoad(u64);

impl BusLoad {
    /// No load.
    pub const ZERO: BusLoad = BusLoad(0);

    /// A frame of `len` data bytes every `period` at `rate`. A zero period is the whole bus
    /// many times over (an overload), not a division by zero.
    pub const fn periodic(len: usize, period: Duration, rate: Bitrate) -> BusLoad {
        let frame_ns = frame_time(len, rate).as_nanos();
        let period_ns = period.as_nanos();
        if period_ns == 0 {
            return BusLoad(u64::MAX);
        }
        // In 64 bits where it fits (every P816 rate and period): a 128-bit division costs
        // several times more.
        if frame_ns <= u64::MAX as u128
            && period_ns <= u64::MAX as u128
            && let Some(p) = (frame_ns as u64).checked_mul(FULL)
        {
            return BusLoad(p.div_ceil(period_ns as u64));
        }
        let share = (frame_ns * FULL as u128).div_ceil(period_ns);
        BusLoad(if share > u64::MAX as u128 {
            u64::MAX
        } else {
            share as u64
        })
    }

    /// A frame of `len` bytes every `cycle_ms` milliseconds at `rate` (a variable object).
    pub const fn cyclic_ms(len: usize, cycle_ms: u32, rate: Bitrate) -> BusLoad {
        BusLoad::periodic(len, Duration::from_millis(cycle_ms as u64), rate)
    }

    /// The load in parts per 10¹² of the bus time.
    pub const fn raw(self) -> u64 {
        self.0
    }

    /// The load in parts per million, rounded up.
    pub const fn ppm(self) -> u64 {
        self.0.div_ceil(1_000_000)
    }

    /// The load in percent (for display).
    pub fn percent(self) -> f64 {
        self.0 as f64 / 1e10
    }

    /// Whether the load exceeds the whole bus (100 %).
    pub const fn is_overload(self) -> bool {
        self.0 > FULL
    }

    /// The free capacity ⌊100 − load %⌋ in percent, `None` for an overload.
    pub const fn free_capacity(self) -> Option<u8> {
        if self.0 > FULL {
            None
        } else {
            Some(((FULL - self.0) / (FULL / 100)) as u8)
        }
    }

    /// `self + other`, saturating.
    pub const fn saturating_add(self, other: BusLoad) -> BusLoad {
        BusLoad(self.0.saturating_add(other.0))
    }
}

impl Add for BusLoad {
    type Output = BusLoad;

    fn add(self, rhs: BusLoad) -> BusLoad {
        self.saturating_add(rhs)
    }
}

impl AddAssign for BusLoad {
    fn add_assign(&mut self, rhs: BusLoad) {
        *self = self.saturating_add(rhs);
    }
}

impl fmt::Display for BusLoad {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Hundredths of a percent, rounded up (never shows less load than there is).
        let hundredths = self.0.div_ceil(100_000_000);
        write!(f, "{}.{:02} %", hundredths / 100, hundredths % 100)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frame lengths written out by hand: a standard data frame has SOF 1, identifier 11, RTR 1,
    /// IDE 1, r0 1, DLC 4, data 8·len and CRC 15 bits, 34 + 8·len stuffed bits; at worst one
    /// stuff bit after every four bits following the first, ⌊(34 + 8·len − 1) / 4⌋; then CRC
    /// delimiter 1, ACK 2, EOF 7 and intermission 3: 13 bits.
    #[test]
    fn frame_bits_by_hand() {
        // 8 bytes: 98 stuffed bits + ⌊97 / 4⌋ = 24 stuff bits + 13 = 135.
        assert_eq!(frame_bits(8), 98 + 24 + 13);
        // 6 bytes (process data): 82 + ⌊81 / 4⌋ = 20 + 13 = 115.
        assert_eq!(frame_bits(6), 82 + 20 + 13);
        // 4 bytes: 66 + 16 + 13 = 95.
        assert_eq!(frame_bits(4), 66 + 16 + 13);
        // 0 bytes (SYNC): 34 + 8 + 13 = 55.
        assert_eq!(frame_bits(0), 34 + 8 + 13);
    }

    #[test]
    fn frame_time_at_every_p816_rate() {
        // 135 bits at 125/250/500/1000 kbit/s: 8, 4, 2, 1 µs per bit.
        let want_us = [1080, 540, 270, 135];
        for (rate, us) in SBUS_BITRATES.into_iter().zip(want_us) {
            assert_eq!(frame_time(8, rate), Duration::from_micros(us), "{rate}");
        }
        // 115 bits (process data) at 500 kbit/s: 230 µs.
        assert_eq!(frame_time(6, Bitrate::K500), Duration::from_micros(230));
    }

    /// The manual's screenshots (Bild 36, 37, 39, 40): an 8-byte object every 100 ms and every
    /// 120 ms at 500 kbit/s, Result 99.
    #[test]
    fn manual_result_99() {
        let l100 = BusLoad::cyclic_ms(8, 100, Bitrate::K500);
        let l120 = BusLoad::cyclic_ms(8, 120, Bitrate::K500);
        // 270 µs / 100 ms = 0.27 %; 270 µs / 120 ms = 0.225 %.
        assert_eq!(l100.ppm(), 2_700);
        assert_eq!(l120.ppm(), 2_250);
        assert_eq!(l100.free_capacity(), Some(99));
        assert_eq!(l120.free_capacity(), Some(99));
        // Both objects together, as seen by the bus: 0.495 %, still 99.
        assert_eq!((l100 + l120).free_capacity(), Some(99));
        assert_eq!(l100.to_string(), "0.27 %");
    }

    #[test]
    fn load_at_every_p816_rate() {
        // 8 bytes every 1 ms: 1080/540/270/135 µs per ms = 108 % (overload), 54 %, 27 %, 13.5 %.
        let want = [
            (1_080_000, None),
            (540_000, Some(46)),
            (270_000, Some(73)),
            (135_000, Some(86)),
        ];
        for (rate, (ppm, free)) in SBUS_BITRATES.into_iter().zip(want) {
            let l = BusLoad::cyclic_ms(8, 1, rate);
            assert_eq!((l.ppm(), l.free_capacity()), (ppm, free), "{rate}");
            assert_eq!(l.is_overload(), free.is_none());
        }
        // Exactly full is no overload but 0 % free: 8 bytes every 1080 µs at 125 kbit/s.
        let full = BusLoad::periodic(8, Duration::from_micros(1080), Bitrate::K125);
        assert_eq!(full.free_capacity(), Some(0));
        assert!(!full.is_overload());
        let over = full + BusLoad(1);
        assert!(over.is_overload());
        assert_eq!(over.free_capacity(), None);
    }

    #[test]
    fn free_capacity_floors() {
        // 0.27 % + 0.73 % = 1.00 % exactly → 99; one part more → 98.
        let a = BusLoad(2_700_000_000);
        let b = BusLoad(7_300_000_000);
        assert_eq!((a + b).free_capacity(), Some(99));
        assert_eq!((a + b + BusLoad(1)).free_capacity(), Some(98));
        assert_eq!(BusLoad::ZERO.free_capacity(), Some(100));
    }

    #[test]
    fn degenerate_periods_do_not_panic() {
        assert!(BusLoad::periodic(8, Duration::ZERO, Bitrate::K125).is_overload());
        let tiny = BusLoad::periodic(8, Duration::from_nanos(1), Bitrate::K125);
        assert!(tiny.is_overload());
        assert_eq!(tiny.raw(), 1_080_000 * FULL); // 1080 µs per ns
        let zero = BusLoad::periodic(8, Duration::ZERO, Bitrate::K125);
        assert_eq!((zero + tiny).raw(), u64::MAX);
        // The 128-bit path: 135 s per frame at 1 bit/s does not fit 64 bits × 10¹².
        let one = Bitrate::new(1).unwrap();
        assert_eq!(
            BusLoad::periodic(8, Duration::from_secs(270), one).free_capacity(),
            Some(50)
        );
        assert!(BusLoad::periodic(8, Duration::from_secs(134), one).is_overload());
        let slow = BusLoad::cyclic_ms(0, u32::MAX, Bitrate::M1);
        assert_eq!(slow.free_capacity(), Some(99));
        assert_eq!(slow.raw(), 13); // 55 µs / 4 294 967 s, rounded up
    }
}
