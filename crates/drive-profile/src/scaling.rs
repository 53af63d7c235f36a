//! Family-independent scaling between raw bus values and physical values.
//!
//! * Decimal places (Bonfiglioli: 10.3 A ↔ 103 with one decimal).
//! * Resolution steps (NORD: 99.99 s ↔ 9999 at 0.01 s).
//! * Percent words: 0x4000 = +100 %, 0xC000 = −100 % (NORD and SEW process data).
//! * 32-bit values split into high and low 16-bit words (positions over 16-bit process data).
//! * Linear PNO scaling `physical = raw × A + B` ([`Linear`]), used with SEW's conversion index.

use thiserror::Error;

/// Why a physical value cannot be turned into a raw value.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[non_exhaustive]
pub enum ScaleError {
    /// The value is NaN or infinite.
    #[error("value is not a finite number")]
    NotFinite,
    /// The scaled value does not fit the raw type.
    #[error("value {value} is outside the representable range {min}…{max}")]
    OutOfRange {
        /// The value asked for, in the physical unit.
        value: f64,
        /// The smallest representable physical value.
        min: f64,
        /// The largest representable physical value.
        max: f64,
    },
}

/// Round half away from zero without `std` (`f64::round` needs `std`).
pub fn round(x: f64) -> f64 {
    // Values beyond 2^52 are already integers.
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x;
    }
    let t = x as i64 as f64; // truncation toward zero
    let frac = x - t;
    if frac >= 0.5 {
        t + 1.0
    } else if frac <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// `10^n` for small `n` without `std`.
pub fn pow10(n: i32) -> f64 {
    let mut v = 1.0;
    if n >= 0 {
        for _ in 0..n {
            v *= 10.0;
        }
    } else {
        for _ in 0..(-n) {
            v /= 10.0;
        }
    }
    v
}

/// Raw value with `decimals` implied decimal places → physical value (103, 1 → 10.3).
pub fn from_decimals(raw: i64, decimals: u8) -> f64 {
    raw as f64 / pow10(i32::from(decimals))
}

/// Physical value → raw value with `decimals` implied places, checked against `[min, max]`.
pub fn to_decimals(value: f64, decimals: u8, min: i64, max: i64) -> Result<i64, ScaleError> {
    to_steps(value, pow10(-i32::from(decimals)), min, max)
}

/// Physical value → count of `step`s (NORD resolution 0.01 s: 99.99 → 9999), checked.
pub fn to_steps(value: f64, step: f64, min: i64, max: i64) -> Result<i64, ScaleError> {
    if !value.is_finite() || !step.is_finite() || step == 0.0 {
        return Err(ScaleError::NotFinite);
    }
    let raw = round(value / step);
    if raw < min as f64 || raw > max as f64 {
        return Err(ScaleError::OutOfRange {
            value,
            min: min as f64 * step,
            max: max as f64 * step,
        });
    }
    Ok(raw as i64)
}

/// Count of `step`s → physical value.
pub fn from_steps(raw: i64, step: f64) -> f64 {
    raw as f64 * step
}

/// 0x4000 in a percent word means +100 %.
pub const PERCENT_100: i16 = 0x4000;

/// Percent word (signed 16 bit, 0x4000 = 100 %) → percent.
pub fn percent_from_word(word: u16) -> f64 {
    f64::from(word as i16) * 100.0 / f64::from(PERCENT_100)
}

/// Percent → percent word, for −200 % ≤ value < +200 % (0x8000…0x7FFF).
pub fn percent_to_word(percent: f64) -> Result<u16, ScaleError> {
    let raw = to_steps(
        percent,
        100.0 / f64::from(PERCENT_100),
        i64::from(i16::MIN),
        i64::from(i16::MAX),
    )?;
    Ok(raw as i16 as u16)
}

/// Split a 32-bit value into (high word, low word).
pub const fn split_u32(v: u32) -> (u16, u16) {
    ((v >> 16) as u16, v as u16)
}

/// Join (high word, low word) into a 32-bit value.
pub const fn join_u32(high: u16, low: u16) -> u32 {
    ((high as u32) << 16) | low as u32
}

/// Split a signed 32-bit position into (high word, low word), two's complement.
pub const fn split_i32(v: i32) -> (u16, u16) {
    split_u32(v as u32)
}

/// Join (high word, low word) into a signed 32-bit position.
pub const fn join_i32(high: u16, low: u16) -> i32 {
    join_u32(high, low) as i32
}

/// Linear scaling `physical = raw × a + b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linear {
    /// Factor A.
    pub a: f64,
    /// Offset B.
    pub b: f64,
}

impl Linear {
    /// Identity scaling.
    pub const IDENTITY: Linear = Linear { a: 1.0, b: 0.0 };

    /// Raw → physical.
    pub fn to_physical(self, raw: i64) -> f64 {
        raw as f64 * self.a + self.b
    }

    /// Physical → raw, rounded to the nearest integer and checked against `[min, max]`.
    pub fn to_raw(self, value: f64, min: i64, max: i64) -> Result<i64, ScaleError> {
        if !value.is_finite() || self.a == 0.0 || !self.a.is_finite() {
            return Err(ScaleError::NotFinite);
        }
        let raw = round((value - self.b) / self.a);
        if raw < min as f64 || raw > max as f64 {
            return Err(ScaleError::OutOfRange {
                value,
                min: self.to_physical(min),
                max: self.to_physical(max),
            });
        }
        Ok(raw as i64)
    }

    /// The scaling that expresses the value of `self` in the unit of `display` instead of the
    /// base unit: `(raw × A + B − B_d) / A_d`.
    pub fn rebase(self, display: Linear) -> Linear {
        Linear {
            a: self.a / display.a,
            b: (self.b - display.b) / display.a,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn manual_examples() {
        // Bonfiglioli: 10.3 A is sent as 103 with one decimal.
        assert_eq!(to_decimals(10.3, 1, 0, 65535), Ok(103));
        assert_eq!(from_decimals(103, 1), 10.3);
        // NORD: 99.99 s at 0.01 s resolution is 9999; 10 s is 0x3E8.
        assert_eq!(to_steps(99.99, 0.01, 0, 32767), Ok(9999));
        assert_eq!(to_steps(10.0, 0.01, 0, 32767), Ok(0x3E8));
        // Percent words.
        assert_eq!(percent_to_word(100.0), Ok(0x4000));
        assert_eq!(percent_to_word(-100.0), Ok(0xC000));
        assert_eq!(percent_from_word(0xC000), -100.0);
        assert_eq!(percent_from_word(0x2000), 50.0);
        // 32-bit split.
        assert_eq!(split_i32(-2), (0xFFFF, 0xFFFE));
        assert_eq!(join_i32(0xFFFF, 0xFFFE), -2);
        // PNO: 1500 with conversion index -3 in seconds is 1.5 s (SEW manual ch. 7.3).
        let ms = Linear { a: 0.001, b: 0.0 };
        assert_eq!(ms.to_physical(1500), 1.5);
    }

    #[test]
    fn out_of_range_and_nan_are_errors() {
        assert!(matches!(
            to_decimals(6553.6, 1, 0, 65535),
            Err(ScaleError::OutOfRange { .. })
        ));
        assert_eq!(to_steps(f64::NAN, 0.01, 0, 10), Err(ScaleError::NotFinite));
        assert!(percent_to_word(200.0).is_err());
        assert_eq!(percent_to_word(-200.0), Ok(0x8000));
    }

    #[test]
    fn rounding_is_half_away_from_zero() {
        assert_eq!(round(2.5), 3.0);
        assert_eq!(round(-2.5), -3.0);
        assert_eq!(round(2.49), 2.0);
        assert_eq!(round(1e300), 1e300);
    }

    proptest! {
        #[test]
        fn decimals_round_trip(raw in -1_000_000i64..1_000_000, d in 0u8..4) {
            let v = from_decimals(raw, d);
            prop_assert_eq!(to_decimals(v, d, i64::MIN / 2, i64::MAX / 2), Ok(raw));
        }

        #[test]
        fn steps_round_trip(raw in -32768i64..32768) {
            let v = from_steps(raw, 0.01);
            prop_assert_eq!(to_steps(v, 0.01, -32768, 32767), Ok(raw));
        }

        #[test]
        fn percent_words_round_trip(w in any::<u16>()) {
            prop_assert_eq!(percent_to_word(percent_from_word(w)), Ok(w));
        }

        #[test]
        fn split_join_round_trip(v in any::<i32>()) {
            let (h, l) = split_i32(v);
            prop_assert_eq!(join_i32(h, l), v);
        }

        #[test]
        fn linear_round_trip(raw in -2_000_000_000i64..2_000_000_000, conv in 0usize..4) {
            let lin = [
                Linear { a: 1e-3 / 60.0, b: 0.0 },
                Linear { a: 1.0, b: 273.15 },
                Linear { a: 5.0 / 9.0, b: 255.37 },
                Linear { a: 0.001, b: 0.0 },
            ][conv];
            let v = lin.to_physical(raw);
            prop_assert_eq!(lin.to_raw(v, i64::from(i32::MIN), i64::from(i32::MAX)), Ok(raw));
        }
    }
}
