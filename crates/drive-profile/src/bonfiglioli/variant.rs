//! ACTIVE (ACT) or ACTIVE Cube (ACU): what tells them apart on the bus, and what the status
//! word 411 of each means.
//!
//! The manual describes both devices with the same parameters, function codes and data sets
//! and defines no device-type parameter. What differs on the bus (ch. 9 for the ACT, ch. 10 for
//! the ACU):
//!
//! * **Status word bit 4.** ACT: "Spannung – Gesperrt", which "steht bei den Geräten des Typs
//!   ACT auf logisch 0" (ch. 9.1.3): always 0. ACU: "Spannung – Freigegeben", the mains voltage
//!   (0 = no mains, the drive cannot start; ch. 10.1, 10.2). A status word with bit 4 set comes
//!   from an ACU ([`Variant::of_status_word`]); one with bit 4 clear can come from either.
//! * **Reading 484 and 524.** The ACU cannot read them: "können nur beschrieben werden. Ein
//!   Lesezugriff ist nicht möglich" (ch. 10.2.3); the ACT chapter lists them without such a
//!   restriction (ch. 9, 9.2). A read of 484 that the drive answers comes from an ACT, one it
//!   refuses as not readable (VABus error 3) from an ACU ([`Variant::of_484_read`]).
//! * Status word bits 8 and 12–14 are unused on the ACT; on the ACU bit 8 is manufacturer
//!   specific and bits 12 and 13 depend on the operation mode (positioning, *configuration* 30
//!   = x40, exists on the ACU only). The ACU table has no "not ready to switch on".
//!
//! ```
//! use drive_profile::bonfiglioli::{State, Variant};
//!
//! // 0x33: switched on with bit 4 set, which only an ACU shows (its mains voltage).
//! assert_eq!(Variant::of_status_word(0x33), Some(Variant::Acu));
//! assert_eq!(Variant::Acu.state(0x33), State::SwitchedOn);
//! assert_eq!(Variant::Acu.mains_voltage(0x33), Some(true));
//! assert_eq!(Variant::Act.mains_voltage(0x23), None);
//! // 0x00 is "not ready to switch on" on the ACT only.
//! assert_eq!(Variant::Act.state(0x00), State::NotReadyToSwitchOn);
//! assert_eq!(Variant::Acu.state(0x00), State::Unknown);
//! ```

use super::state::{ActStateMachine, AcuStateMachine, State};
use super::words::{ActStatusWord, AcuStatusWord};
use crate::state::StateMachine;

/// Which Bonfiglioli drive: the ACTIVE (ACT, ch. 9) or the ACTIVE Cube (ACU, ch. 10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// ACTIVE: hardware enable S1IND; status word bit 4 always 0.
    Act,
    /// ACTIVE Cube: hardware enable STOA and STOB; status word bit 4 = mains voltage; 484 and
    /// 524 write-only.
    Acu,
}

/// Status word bit 4: ACT "voltage disabled" (always 0), ACU "voltage enabled" (mains).
const BIT4: u16 = 1 << 4;

impl Variant {
    /// Both variants.
    pub const ALL: [Variant; 2] = [Variant::Act, Variant::Acu];

    /// `act` or `acu` (the command line's and the JSON's spelling).
    pub const fn key(self) -> &'static str {
        match self {
            Variant::Act => "act",
            Variant::Acu => "acu",
        }
    }

    /// `ACTIVE (ACT)` or `ACTIVE Cube (ACU)`.
    pub const fn name(self) -> &'static str {
        match self {
            Variant::Act => "ACTIVE (ACT)",
            Variant::Acu => "ACTIVE Cube (ACU)",
        }
    }

    /// The variant of `act` or `acu` (case ignored).
    pub fn from_key(s: &str) -> Option<Variant> {
        Variant::ALL
            .into_iter()
            .find(|v| v.key().eq_ignore_ascii_case(s.trim()))
    }

    /// The state-machine state of a status word (ch. 9.1.2, 10.2).
    pub fn state(self, word: u16) -> State {
        match self {
            Variant::Act => ActStateMachine::decode(word),
            Variant::Acu => AcuStateMachine::decode(word),
        }
    }

    /// The named bits of this variant's status word with their English names, lowest first.
    pub fn status_bits(self) -> impl Iterator<Item = (u16, &'static str)> {
        let act: &[(ActStatusWord, &str)] = match self {
            Variant::Act => ActStatusWord::NAMED,
            Variant::Acu => &[],
        };
        let acu: &[(AcuStatusWord, &str)] = match self {
            Variant::Act => &[],
            Variant::Acu => AcuStatusWord::NAMED,
        };
        act.iter()
            .map(|(f, n)| (f.bits(), *n))
            .chain(acu.iter().map(|(f, n)| (f.bits(), *n)))
    }

    /// The English names of the bits set in `word`, lowest first.
    pub fn set_bits(self, word: u16) -> impl Iterator<Item = &'static str> {
        self.status_bits()
            .filter(move |(bit, _)| word & bit != 0)
            .map(|(_, name)| name)
    }

    /// The bits of `word` this variant gives no name (0 when there are none).
    pub fn unnamed_bits(self, word: u16) -> u16 {
        let named = self.status_bits().fold(0, |acc, (bit, _)| acc | bit);
        word & !named
    }

    /// Whether the mains voltage is present (bit 4): the ACU reports it, the ACT does not
    /// (`None`).
    pub const fn mains_voltage(self, word: u16) -> Option<bool> {
        match self {
            Variant::Act => None,
            Variant::Acu => Some(word & BIT4 != 0),
        }
    }

    /// What a status word alone says about the device: bit 4 set is an ACU (the ACT keeps it
    /// at 0, ch. 9.1.3); bit 4 clear says nothing (an ACU without mains voltage shows it too).
    pub const fn of_status_word(word: u16) -> Option<Variant> {
        if word & BIT4 != 0 {
            Some(Variant::Acu)
        } else {
            None
        }
    }

    /// What reading 484 (reference frequency RAM) says about the device: answered is an ACT,
    /// refused as not readable (VABus error 3) an ACU (ch. 10.2.3); any other refusal says
    /// nothing.
    pub const fn of_484_read(answered: bool, vabus: Option<u16>) -> Option<Variant> {
        match (answered, vabus) {
            (true, _) => Some(Variant::Act),
            (false, Some(3)) => Some(Variant::Acu),
            _ => None,
        }
    }
}

impl core::fmt::Display for Variant {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_4_tells_an_acu_and_only_an_acu_names_it_mains() {
        // ch. 9.1.3: bit 4 is always 0 on the ACT; ch. 10.1: 1 = mains voltage on.
        assert_eq!(Variant::of_status_word(0x0023), None);
        assert_eq!(Variant::of_status_word(0x0037), Some(Variant::Acu));
        assert_eq!(Variant::Acu.mains_voltage(0x0023), Some(false));
        assert_eq!(
            Variant::Acu.set_bits(0x0033).collect::<Vec<_>>(),
            [
                "ready to switch on",
                "switched on",
                "voltage enabled",
                "no quick stop"
            ]
        );
        assert_eq!(
            Variant::Act.set_bits(0x0023).collect::<Vec<_>>(),
            ["ready to switch on", "switched on", "no quick stop"]
        );
    }

    #[test]
    fn unused_bits_are_kept_per_variant() {
        // Bits 12 and 13 are operation-mode bits on the ACU and unused on the ACT; bit 14 is
        // unused on both.
        assert_eq!(Variant::Act.unnamed_bits(0x7123), 0x7100);
        assert_eq!(Variant::Acu.unnamed_bits(0x7123), 0x4100);
    }

    #[test]
    fn reading_484_tells_them_apart() {
        assert_eq!(Variant::of_484_read(true, None), Some(Variant::Act));
        assert_eq!(Variant::of_484_read(false, Some(3)), Some(Variant::Acu));
        assert_eq!(Variant::of_484_read(false, Some(2)), None);
        assert_eq!(Variant::of_484_read(false, None), None);
    }

    #[test]
    fn keys_round_trip() {
        for v in Variant::ALL {
            assert_eq!(Variant::from_key(v.key()), Some(v));
        }
        assert_eq!(Variant::from_key("ACU"), Some(Variant::Acu));
        assert_eq!(Variant::from_key("cube"), None);
    }
}
