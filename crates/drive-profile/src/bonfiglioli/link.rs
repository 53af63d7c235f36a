//! The drive's own settings of its Modbus line (ch. 5, 6): the codes of *baud rate* 10,
//! *protocol type* 395 and *Modbus parity* 1375, and when a written value takes effect.
//!
//! ```
//! use drive_core::Parity;
//! use drive_profile::bonfiglioli::link;
//!
//! assert_eq!(link::baud_code(19200), Some(4)); // the factory setting (ch. 5)
//! assert_eq!(link::baud_of_code(3), Some(9600));
//! assert_eq!(link::baud_code(1200), None); // not a rate of the drive
//! assert_eq!(link::parity_code(Parity::None), 2);
//! assert_eq!(link::parity_of_code(0), Some(Parity::Even));
//! ```

use drive_core::Parity;

/// *Baud rate* 10: the code of each rate (ch. 5.2.1, 5.3.1).
pub const BAUD_RATES: [(u16, u32); 6] = [
    (1, 2400),
    (2, 4800),
    (3, 9600),
    (4, 19200),
    (5, 57600),
    (6, 115_200),
];

/// *Protocol type* 395: Modbus RTU (ch. 6).
pub const PROTOCOL_RTU: u16 = 2;
/// *Protocol type* 395: Modbus ASCII (ch. 6).
pub const PROTOCOL_ASCII: u16 = 3;

/// The code of parameter 10 for `baud`, if the drive has that rate.
pub fn baud_code(baud: u32) -> Option<u16> {
    BAUD_RATES
        .iter()
        .find(|(_, b)| *b == baud)
        .map(|(code, _)| *code)
}

/// The rate of code `code` of parameter 10.
pub fn baud_of_code(code: i64) -> Option<u32> {
    BAUD_RATES
        .iter()
        .find(|(c, _)| i64::from(*c) == code)
        .map(|(_, baud)| *baud)
}

/// The code of parameter 1375 for `parity`: 0 even, 1 odd, 2 none (ch. 5.2.1).
pub const fn parity_code(parity: Parity) -> u16 {
    match parity {
        Parity::Even => 0,
        Parity::Odd => 1,
        Parity::None => 2,
    }
}

/// The parity of code `code` of parameter 1375.
pub const fn parity_of_code(code: i64) -> Option<Parity> {
    match code {
        0 => Some(Parity::Even),
        1 => Some(Parity::Odd),
        2 => Some(Parity::None),
        _ => None,
    }
}

/// When a written link setting takes effect: baud rate 10 and parity 1375 after a software
/// reset (*program* 34 = 123) or a power cycle (ch. 5.2.1, 5.3.1); protocol type 395 and the
/// address 1376 at once (ch. 5.2.2, 6). `None` for other parameters.
pub const fn takes_effect_at_once(param: u16) -> Option<bool> {
    match param {
        10 | 1375 => Some(false),
        395 | 1376 => Some(true),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_codes_are_the_tables_value_lists() {
        let p10 = super::super::by_number(10).unwrap();
        for (code, baud) in BAUD_RATES {
            let name = p10
                .values
                .iter()
                .find(|v| v.value == i64::from(code))
                .unwrap();
            assert!(
                name.en.starts_with(&baud.to_string()),
                "{code}: {}",
                name.en
            );
            assert_eq!(baud_of_code(i64::from(code)), Some(baud));
        }
        let p1375 = super::super::by_number(1375).unwrap();
        for parity in [Parity::Even, Parity::Odd, Parity::None] {
            let code = parity_code(parity);
            assert!(p1375.values.iter().any(|v| v.value == i64::from(code)));
            assert_eq!(parity_of_code(i64::from(code)), Some(parity));
        }
        assert_eq!(baud_of_code(0), None);
        assert_eq!(parity_of_code(3), None);
    }
}
