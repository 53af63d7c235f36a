//! Serial line settings and the timing that follows from them.
//!
//! Every protocol of drivebus times its frames in character times: MOVILINK's start pause is
//! three characters, Modbus RTU separates frames by 3.5 and breaks them off after 1.5, USS
//! waits two before a telegram. A character time is the number of bits a character occupies
//! on the wire (start bit, data bits, parity bit, stop bits) divided by the baud rate, so it
//! depends on every setting of the line, not only on the baud rate: 9600 8E1 is 11 bits =
//! 1 145 833 ns, 9600 8N1 is 10 bits = 1 041 667 ns.
//!
//! [`LineSettings`] is the one description of a line, used by the serial ports of
//! `drive-transport`, the in-memory wire model, the protocol timing and the command line;
//! [`char_time`] is the one place the character time is computed (exact to the nanosecond).
//!
//! ```
//! use core::time::Duration;
//! use drive_core::line::{LineSettings, Parity};
//!
//! let movilink = LineSettings::new(9600); // 8E1
//! assert_eq!(movilink.bits_per_char(), 11);
//! assert_eq!(movilink.char_time(), Duration::from_nanos(1_145_833));
//! // 3.5 character times at 19200 8E1 (Modbus RTU's frame gap):
//! assert_eq!(LineSettings::new(19200).char_times(7, 2), Duration::from_nanos(2_005_208));
//! let pty = LineSettings { parity: Parity::None, ..LineSettings::new(19200) };
//! assert_eq!(pty.to_string(), "19200 8N1");
//! ```

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

/// Character parity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Parity {
    /// No parity bit.
    None,
    /// Even parity: the parity bit makes the number of ones in data + parity even.
    Even,
    /// Odd parity: the parity bit makes the number of ones in data + parity odd.
    Odd,
}

impl Parity {
    /// Number of parity bits on the wire (0 or 1).
    pub const fn bits(self) -> u32 {
        match self {
            Parity::None => 0,
            Parity::Even | Parity::Odd => 1,
        }
    }

    /// The parity bit a transmitter sends for `data`, or `None` without parity.
    pub const fn parity_bit(self, data: u8) -> Option<bool> {
        let odd_ones = data.count_ones() % 2 == 1;
        match self {
            Parity::None => None,
            Parity::Even => Some(odd_ones),
            Parity::Odd => Some(!odd_ones),
        }
    }

    /// The letter used in `8E1`-style notation (`N`, `E`, `O`).
    pub const fn letter(self) -> char {
        match self {
            Parity::None => 'N',
            Parity::Even => 'E',
            Parity::Odd => 'O',
        }
    }
}

impl fmt::Display for Parity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Parity::None => "none",
            Parity::Even => "even",
            Parity::Odd => "odd",
        })
    }
}

impl FromStr for Parity {
    type Err = ParseSettingError;

    /// Accepts `none`, `even`, `odd` (any case) and the letters `n`, `e`, `o`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        let eq = |a: &str| t.eq_ignore_ascii_case(a);
        if eq("none") || eq("n") {
            Ok(Parity::None)
        } else if eq("even") || eq("e") {
            Ok(Parity::Even)
        } else if eq("odd") || eq("o") {
            Ok(Parity::Odd)
        } else {
            Err(ParseSettingError {
                setting: "parity",
                expected: "even, odd or none",
            })
        }
    }
}

/// Number of stop bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StopBits {
    /// One stop bit.
    One,
    /// Two stop bits.
    Two,
}

impl StopBits {
    /// Number of stop bits on the wire.
    pub const fn bits(self) -> u32 {
        match self {
            StopBits::One => 1,
            StopBits::Two => 2,
        }
    }
}

impl fmt::Display for StopBits {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopBits::One => "1",
            StopBits::Two => "2",
        })
    }
}

impl FromStr for StopBits {
    type Err = ParseSettingError;

    /// Accepts `1` and `2`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "1" => Ok(StopBits::One),
            "2" => Ok(StopBits::Two),
            _ => Err(ParseSettingError {
                setting: "stop bits",
                expected: "1 or 2",
            }),
        }
    }
}

/// A [`Parity`] or [`StopBits`] string could not be parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("invalid {setting}: expected {expected}")]
pub struct ParseSettingError {
    /// The setting, e.g. `parity`.
    pub setting: &'static str,
    /// What would have been accepted.
    pub expected: &'static str,
}

/// The settings of a serial line that decide its timing: baud rate, data bits, parity and stop
/// bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LineSettings {
    /// Baud rate in bit/s.
    pub baud: u32,
    /// Data bits per character, 5 to 8.
    pub data_bits: u8,
    /// Parity.
    pub parity: Parity,
    /// Stop bits.
    pub stop_bits: StopBits,
}

impl LineSettings {
    /// 8 data bits, even parity, 1 stop bit (8E1, the default of MOVILINK, Modbus RTU and
    /// USS) at `baud`.
    pub const fn new(baud: u32) -> LineSettings {
        LineSettings {
            baud,
            data_bits: 8,
            parity: Parity::Even,
            stop_bits: StopBits::One,
        }
    }

    /// The same line with `parity`.
    #[must_use]
    pub const fn with_parity(self, parity: Parity) -> LineSettings {
        LineSettings { parity, ..self }
    }

    /// The same line with `stop_bits`.
    #[must_use]
    pub const fn with_stop_bits(self, stop_bits: StopBits) -> LineSettings {
        LineSettings { stop_bits, ..self }
    }

    /// Bits per character on the wire: start + data + parity + stop.
    pub const fn bits_per_char(&self) -> u32 {
        bits_per_char(self.data_bits, self.parity, self.stop_bits)
    }

    /// Time one character occupies the wire.
    pub const fn char_time(&self) -> Duration {
        char_time(self.baud, self.bits_per_char())
    }

    /// `num / den` character times, exact to the nanosecond (rounded to the nearest): `(7, 2)`
    /// is 3.5 character times. Zero for a zero baud rate or denominator.
    pub const fn char_times(&self, num: u32, den: u32) -> Duration {
        if self.baud == 0 || den == 0 {
            return Duration::ZERO;
        }
        let bits = self.bits_per_char() as u128 * num as u128 * 1_000_000_000;
        let div = self.baud as u128 * den as u128;
        let nanos = (bits + div / 2) / div;
        Duration::from_nanos(if nanos > u64::MAX as u128 {
            u64::MAX
        } else {
            nanos as u64
        })
    }

    /// Wire time of `chars` characters sent back to back.
    pub const fn wire_time(&self, chars: usize) -> Duration {
        let n = if chars > u32::MAX as usize {
            u32::MAX
        } else {
            chars as u32
        };
        self.char_times(n, 1)
    }
}

impl Default for LineSettings {
    /// 9600 8E1.
    fn default() -> Self {
        LineSettings::new(9600)
    }
}

impl fmt::Display for LineSettings {
    /// `9600 8E1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}{}{}",
            self.baud,
            self.data_bits,
            self.parity.letter(),
            self.stop_bits
        )
    }
}

/// Bits per character on the wire: 1 start bit + `data_bits` + parity (0 or 1) + stop bits.
///
/// ```
/// use drive_core::line::{bits_per_char, Parity, StopBits};
/// assert_eq!(bits_per_char(8, Parity::Even, StopBits::One), 11);
/// assert_eq!(bits_per_char(8, Parity::None, StopBits::Two), 11);
/// assert_eq!(bits_per_char(8, Parity::None, StopBits::One), 10);
/// ```
pub const fn bits_per_char(data_bits: u8, parity: Parity, stop_bits: StopBits) -> u32 {
    1 + data_bits as u32 + parity.bits() + stop_bits.bits()
}

/// Time `bits_per_char` bits take at `baud` bit/s, rounded to the nearest nanosecond;
/// [`Duration::ZERO`] for `baud == 0`. The only character-time function of drivebus.
///
/// ```
/// use core::time::Duration;
/// use drive_core::line::char_time;
/// assert_eq!(char_time(9600, 11), Duration::from_nanos(1_145_833)); // 8E1
/// assert_eq!(char_time(19200, 11), Duration::from_nanos(572_917));
/// assert_eq!(char_time(0, 11), Duration::ZERO);
/// ```
pub const fn char_time(baud: u32, bits_per_char: u32) -> Duration {
    if baud == 0 {
        return Duration::ZERO;
    }
    let nanos = (bits_per_char as u64 * 1_000_000_000 + baud as u64 / 2) / baud as u64;
    Duration::from_nanos(nanos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_settings() {
        assert_eq!("EVEN".parse(), Ok(Parity::Even));
        assert_eq!("n".parse(), Ok(Parity::None));
        assert_eq!("o".parse(), Ok(Parity::Odd));
        assert_eq!(
            "mark".parse::<Parity>(),
            Err(ParseSettingError {
                setting: "parity",
                expected: "even, odd or none"
            })
        );
        assert_eq!("2".parse(), Ok(StopBits::Two));
        assert!("3".parse::<StopBits>().is_err());
    }

    #[test]
    fn timing_follows_every_setting() {
        let l = LineSettings::new(9600);
        assert_eq!(l.char_time(), Duration::from_nanos(1_145_833));
        assert_eq!(
            l.with_parity(Parity::None).char_time(),
            Duration::from_nanos(1_041_667)
        );
        assert_eq!(
            l.with_parity(Parity::None)
                .with_stop_bits(StopBits::Two)
                .char_time(),
            l.char_time()
        );
        // 3 characters at 9600 8E1: 3.4375 ms (the manual rounds to 3.44 ms).
        assert_eq!(l.char_times(3, 1), Duration::from_nanos(3_437_500));
        assert_eq!(l.wire_time(18), Duration::from_nanos(20_625_000));
        assert_eq!(LineSettings::new(0).char_times(3, 1), Duration::ZERO);
        assert_eq!(l.char_times(3, 0), Duration::ZERO);
        assert_eq!(
            LineSettings::new(1).char_times(u32::MAX, 1),
            Duration::from_nanos(u64::MAX),
            "saturates"
        );
        assert_eq!(l.to_string(), "9600 8E1");
    }
}
