//! Control word (STW), status word (ZSW) and setpoint/actual-value scaling
//! (BU 0255 sections 4.5.1, 4.5.2 and 4.5.4).

use core::fmt;

use crate::generated::nord_words::{CONTROL_BITS, STATUS_BITS};
use crate::scaling::{self, ScaleError};

use super::{BitInfo, NordStateMachine, State};
use crate::state::StateMachine;

fn list_bits(f: &mut fmt::Formatter<'_>, name: &str, word: u16, bits: &[BitInfo]) -> fmt::Result {
    write!(f, "{name}(0x{word:04X}")?;
    let mut sep = ": ";
    for b in bits.iter().filter(|b| word & b.mask() != 0) {
        write!(f, "{sep}{}", b.key)?;
        sep = " | ";
    }
    f.write_str(")")
}

/// The parameter set (1..=4) held in bits 14 and 15.
const fn set_from_bits(word: u16) -> u8 {
    (word >> 14) as u8 + 1
}

/// The control word (Steuerwort, STW): the first process-data word from master to drive.
///
/// Bit 10 ([`ControlWord::CONTROL_DATA_VALID`]) must always be set, or the drive ignores the
/// process data. The commands of the state machine are in [`command`](super::command).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ControlWord(pub u16);

impl ControlWord {
    /// Bit 0 `Betriebsbereit`: 1 = set the drive ready for operation (switch on); 0 = ramp down
    /// with the braking ramp and switch the voltage off at 0 Hz.
    pub const SWITCH_ON: ControlWord = ControlWord(1 << 0);
    /// Bit 1 `Spannung sperren` (active low): 0 = switch the output voltage off at once.
    pub const ENABLE_VOLTAGE: ControlWord = ControlWord(1 << 1);
    /// Bit 2 `Schnellhalt` (active low): 0 = quick stop.
    pub const NO_QUICK_STOP: ControlWord = ControlWord(1 << 2);
    /// Bit 3 `Betrieb freigeben`: 1 = enable the output voltage and run to the setpoint.
    pub const ENABLE_OPERATION: ControlWord = ControlWord(1 << 3);
    /// Bit 4 `Impulse freigeben`: 0 = ramp generator to 0 (the drive stays enabled).
    pub const ENABLE_PULSES: ControlWord = ControlWord(1 << 4);
    /// Bit 5 `Rampe freigeben`: 0 = freeze the ramp generator's output (hold frequency).
    pub const ENABLE_RAMP: ControlWord = ControlWord(1 << 5);
    /// Bit 6 `Sollwert freigeben`: 0 = selected setpoint to 0.
    pub const ENABLE_SETPOINT: ControlWord = ControlWord(1 << 6);
    /// Bit 7 `Fehler quittieren`: a change from 0 to 1 resets faults that are no longer active.
    pub const FAULT_RESET: ControlWord = ControlWord(1 << 7);
    /// Bit 8: start the function set in P480 [-11].
    pub const FUNCTION_480_11: ControlWord = ControlWord(1 << 8);
    /// Bit 9: start the function set in P480 [-12].
    pub const FUNCTION_480_12: ControlWord = ControlWord(1 << 9);
    /// Bit 10 `Steuerdaten gültig`: the process data are valid (must always be 1).
    pub const CONTROL_DATA_VALID: ControlWord = ControlWord(1 << 10);
    /// Bit 11 `Drehrichtung rechts ein`: clockwise (applies while bit 12 is 0).
    pub const ROTATION_RIGHT: ControlWord = ControlWord(1 << 11);
    /// Bit 12 `Drehrichtung links ein`: counter-clockwise, takes priority over bit 11.
    pub const ROTATION_LEFT: ControlWord = ControlWord(1 << 12);
    /// Bits 14 and 15: parameter set minus one.
    pub const PARAMETER_SET_MASK: u16 = 0xC000;

    /// The raw word.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: ControlWord) -> bool {
        self.0 & other.0 == other.0
    }

    /// Both words' bits.
    #[must_use]
    pub const fn union(self, other: ControlWord) -> ControlWord {
        ControlWord(self.0 | other.0)
    }

    /// This word without the bits of `other`.
    #[must_use]
    pub const fn without(self, other: ControlWord) -> ControlWord {
        ControlWord(self.0 & !other.0)
    }

    /// The parameter set selected by bits 14/15 (1..=4).
    pub const fn parameter_set(self) -> u8 {
        set_from_bits(self.0)
    }

    /// This word selecting parameter set `set` (1..=4); `None` for other numbers.
    pub const fn with_parameter_set(self, set: u8) -> Option<ControlWord> {
        if set == 0 || set > 4 {
            return None;
        }
        let bits = ((set - 1) as u16) << 14;
        Some(ControlWord((self.0 & !Self::PARAMETER_SET_MASK) | bits))
    }

    /// The table entries of the bits set in this word.
    pub fn set_bits(self) -> impl Iterator<Item = &'static BitInfo> {
        CONTROL_BITS.iter().filter(move |b| self.0 & b.mask() != 0)
    }

    /// The table entry of bit `bit` (0..15).
    pub fn bit_info(bit: u8) -> Option<&'static BitInfo> {
        CONTROL_BITS.get(usize::from(bit))
    }
}

impl fmt::Debug for ControlWord {
    /// `ControlWord(0x047E: enable_voltage | no_quick_stop | ...)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        list_bits(f, "ControlWord", self.0, &CONTROL_BITS)
    }
}

impl From<u16> for ControlWord {
    fn from(v: u16) -> Self {
        ControlWord(v)
    }
}

impl From<ControlWord> for u16 {
    fn from(v: ControlWord) -> Self {
        v.0
    }
}

/// The status word (Zustandswort, ZSW): the first process-data word from drive to master.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StatusWord(pub u16);

impl StatusWord {
    /// Bit 0 `Einschaltbereit`: initialisation done, charging relay on, output voltage off.
    pub const READY_TO_SWITCH_ON: StatusWord = StatusWord(1 << 0);
    /// Bit 1 `Betriebsbereit`: switch-on command present and no fault.
    pub const READY_FOR_OPERATION: StatusWord = StatusWord(1 << 1);
    /// Bit 2 `Betrieb freigegeben`: output voltage enabled.
    pub const OPERATION_ENABLED: StatusWord = StatusWord(1 << 2);
    /// Bit 3 `Störung`: the drive is faulted.
    pub const FAULT: StatusWord = StatusWord(1 << 3);
    /// Bit 4 `Spannung freigegeben` (0 = disable voltage commanded).
    pub const VOLTAGE_ENABLED: StatusWord = StatusWord(1 << 4);
    /// Bit 5 `Schnellhalt` (active low: 0 = quick stop commanded).
    pub const NO_QUICK_STOP: StatusWord = StatusWord(1 << 5);
    /// Bit 6 `Einschaltsperre`: switch-on disabled.
    pub const SWITCH_ON_DISABLED: StatusWord = StatusWord(1 << 6);
    /// Bit 7 `Warnung aktiv`: the drive keeps running, no reset needed.
    pub const WARNING: StatusWord = StatusWord(1 << 7);
    /// Bit 8 `Sollwert erreicht`: actual value equals setpoint.
    pub const SETPOINT_REACHED: StatusWord = StatusWord(1 << 8);
    /// Bit 9 `Bussteuerung aktiv`: the bus master is asked to take control.
    pub const BUS_CONTROL: StatusWord = StatusWord(1 << 9);
    /// Bit 10: function set in P481 [-09].
    pub const FUNCTION_481_9: StatusWord = StatusWord(1 << 10);
    /// Bit 11: the output has a clockwise rotating field.
    pub const ROTATION_RIGHT: StatusWord = StatusWord(1 << 11);
    /// Bit 12: the output has a counter-clockwise rotating field.
    pub const ROTATION_LEFT: StatusWord = StatusWord(1 << 12);
    /// Bit 13: function set in P481 [-10].
    pub const FUNCTION_481_10: StatusWord = StatusWord(1 << 13);

    /// The raw word.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: StatusWord) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether the fault bit (3) is set.
    pub const fn is_fault(self) -> bool {
        self.contains(Self::FAULT)
    }

    /// Whether the warning bit (7) is set.
    pub const fn is_warning(self) -> bool {
        self.contains(Self::WARNING)
    }

    /// The active parameter set reported in bits 14/15 (1..=4).
    pub const fn parameter_set(self) -> u8 {
        set_from_bits(self.0)
    }

    /// The drive state this word shows.
    pub fn state(self) -> State {
        NordStateMachine::decode(self.0)
    }

    /// The table entries of the bits set in this word.
    pub fn set_bits(self) -> impl Iterator<Item = &'static BitInfo> {
        STATUS_BITS.iter().filter(move |b| self.0 & b.mask() != 0)
    }

    /// The table entry of bit `bit` (0..15).
    pub fn bit_info(bit: u8) -> Option<&'static BitInfo> {
        STATUS_BITS.get(usize::from(bit))
    }
}

impl fmt::Debug for StatusWord {
    /// `StatusWord(0x0B31: ready_to_switch_on | voltage_enabled | ...)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        list_bits(f, "StatusWord", self.0, &STATUS_BITS)
    }
}

impl From<u16> for StatusWord {
    fn from(v: u16) -> Self {
        StatusWord(v)
    }
}

impl From<StatusWord> for u16 {
    fn from(v: StatusWord) -> Self {
        v.0
    }
}

/// Percent → setpoint word (4000h = 100 %, C000h = −100 %; −200 % ≤ value < 200 %).
pub fn setpoint_from_percent(percent: f64) -> Result<u16, ScaleError> {
    scaling::percent_to_word(percent)
}

/// Setpoint or actual-value word → percent (4000h = 100 %).
pub fn percent_from_word(word: u16) -> f64 {
    scaling::percent_from_word(word)
}

/// Process word → physical value for a 100 % reference: `word × reference / 16384`
/// (section 4.5.4: frequency with reference P105, current with reference P112).
pub fn word_to_physical(word: u16, reference: f64) -> f64 {
    f64::from(word as i16) * reference / f64::from(scaling::PERCENT_100)
}

/// Physical value → process word for a 100 % reference (inverse of [`word_to_physical`]).
pub fn physical_to_word(value: f64, reference: f64) -> Result<u16, ScaleError> {
    if !reference.is_finite() || reference == 0.0 {
        return Err(ScaleError::NotFinite);
    }
    setpoint_from_percent(value * 100.0 / reference)
}
