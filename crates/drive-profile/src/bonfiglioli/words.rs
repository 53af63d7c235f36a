//! Control word (parameter 410) and status word (parameter 411) as typed bit sets.
//!
//! Parameter 410 has two meanings, chosen by *Local/Remote* 412:
//!
//! * 412 = 1, state machine: [`ActControlWord`] (ch. 9.1.2) / [`AcuControlWord`] (ch. 10.2);
//! * 412 = 2, remote contacts: [`RemoteContacts`], bits 0…9 emulate the digital inputs
//!   (ch. 9.1.3 / 10.1, the same on ACT and ACU).
//!
//! The status word means the same in every mode, but ACT and ACU differ in bit 4 (ACT: "voltage
//! disabled", always 0 per ch. 9.1.3; ACU: mains voltage present) and in bits 10…13:
//! [`ActStatusWord`], [`AcuStatusWord`].
//!
//! `Debug` lists the set bits by English name, unnamed bits as hex:
//!
//! ```
//! use drive_profile::bonfiglioli::ActControlWord;
//! let w = ActControlWord::from_bits(0x0F);
//! assert_eq!(
//!     format!("{w:?}"),
//!     "ActControlWord(switch on | enable voltage | no quick stop | enable operation)"
//! );
//! ```

use super::state::{ActStateMachine, AcuStateMachine, State};
use crate::state::StateMachine;
use core::fmt;

macro_rules! bit_word {
    (
        $(#[$meta:meta])*
        $name:ident {
            $( $(#[$fmeta:meta])* $flag:ident = $bit:literal, $en:literal; )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub struct $name(u16);

        impl $name {
            $( $(#[$fmeta])* pub const $flag: $name = $name(1 << $bit); )*

            /// Every named bit with its English name, lowest bit first.
            pub const NAMED: &'static [($name, &'static str)] = &[ $( ($name::$flag, $en), )* ];

            /// No bit set.
            pub const fn empty() -> Self {
                Self(0)
            }

            /// From the raw 16-bit word (every bit is kept).
            pub const fn from_bits(bits: u16) -> Self {
                Self(bits)
            }

            /// The raw 16-bit word.
            pub const fn bits(self) -> u16 {
                self.0
            }

            /// Whether every bit of `other` is set.
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }

            /// Both bit sets combined.
            #[must_use]
            pub const fn union(self, other: Self) -> Self {
                Self(self.0 | other.0)
            }

            /// The bits of `self` without those of `other`.
            #[must_use]
            pub const fn difference(self, other: Self) -> Self {
                Self(self.0 & !other.0)
            }

            /// The English names of the set named bits.
            pub fn names(self) -> impl Iterator<Item = &'static str> {
                Self::NAMED.iter().filter(move |(f, _)| self.contains(*f)).map(|(_, n)| *n)
            }

            /// The set bits that have no name in the manual.
            pub fn unnamed_bits(self) -> u16 {
                let named = Self::NAMED.iter().fold(0u16, |a, (f, _)| a | f.0);
                self.0 & !named
            }
        }

        impl core::ops::BitOr for $name {
            type Output = Self;
            fn bitor(self, rhs: Self) -> Self {
                self.union(rhs)
            }
        }

        impl From<u16> for $name {
            fn from(bits: u16) -> Self {
                Self(bits)
            }
        }

        impl From<$name> for u16 {
            fn from(w: $name) -> u16 {
                w.0
            }
        }

        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(concat!(stringify!($name), "("))?;
                let mut first = true;
                for n in self.names() {
                    if !first {
                        f.write_str(" | ")?;
                    }
                    f.write_str(n)?;
                    first = false;
                }
                let rest = self.unnamed_bits();
                if rest != 0 {
                    if !first {
                        f.write_str(" | ")?;
                    }
                    write!(f, "{rest:#06x}")?;
                }
                f.write_str(")")
            }
        }
    };
}

bit_word! {
    /// ACT control word 410 in state-machine mode (412 = 1; ch. 9.1.2). Bits 4…6 and 8…15 are
    /// unused.
    ActControlWord {
        /// Bit 0 "Einschalten": switch on.
        SWITCH_ON = 0, "switch on";
        /// Bit 1 "Spannung - Sperren": 0 disables the voltage (DRIVECOM, active low).
        ENABLE_VOLTAGE = 1, "enable voltage";
        /// Bit 2 "Schnellhalt": 0 commands quick stop (active low).
        NO_QUICK_STOP = 2, "no quick stop";
        /// Bit 3 "Betrieb - Freigegeben": enable operation.
        ENABLE_OPERATION = 3, "enable operation";
        /// Bit 7 "Reset-Störung": fault reset on the rising edge.
        FAULT_RESET = 7, "fault reset";
    }
}

bit_word! {
    /// ACU control word 410 in state-machine mode (412 = 1; ch. 10.2). Bits 4…6 and 8 are used
    /// only by configurations with positioning control (P30 = x40); bits 9…15 are unused.
    AcuControlWord {
        /// Bit 0 "Einschalten": switch on.
        SWITCH_ON = 0, "switch on";
        /// Bit 1 "Spannung – Freigegeben": enable voltage (0 disables it).
        ENABLE_VOLTAGE = 1, "enable voltage";
        /// Bit 2 "Schnellhalt": 0 commands quick stop (active low).
        NO_QUICK_STOP = 2, "no quick stop";
        /// Bit 3 "Betrieb – Freigegeben": enable operation.
        ENABLE_OPERATION = 3, "enable operation";
        /// Bit 4 "Betriebsartabhängig" (positioning only).
        OPERATION_MODE_4 = 4, "operation mode specific 4";
        /// Bit 5 "Betriebsartabhängig" (positioning only).
        OPERATION_MODE_5 = 5, "operation mode specific 5";
        /// Bit 6 "Betriebsartabhängig" (positioning only).
        OPERATION_MODE_6 = 6, "operation mode specific 6";
        /// Bit 7 "Fehler rücksetzen": fault reset on the rising edge.
        FAULT_RESET = 7, "fault reset";
        /// Bit 8 "Halt" (positioning only).
        HALT = 8, "halt";
    }
}

bit_word! {
    /// Control word 410 in remote-contact mode (412 = 2; ch. 9.1.3, 10.1): bits 0…9 emulate
    /// the digital inputs. The same on ACT and ACU. Enabling still needs the hardware enable
    /// (ACT: S1IND; ACU: STOA and STOB) together with bit 0.
    RemoteContacts {
        /// Bit 0: S1IND (enable, together with the hardware input).
        S1IND = 0, "S1IND";
        /// Bit 1: S2IND.
        S2IND = 1, "S2IND";
        /// Bit 2: S3IND.
        S3IND = 2, "S3IND";
        /// Bit 3: S4IND.
        S4IND = 3, "S4IND";
        /// Bit 4: S5IND.
        S5IND = 4, "S5IND";
        /// Bit 5: S6IND.
        S6IND = 5, "S6IND";
        /// Bit 6: multifunction input MFI1D.
        MFI1D = 6, "MFI1D";
        /// Bit 7: EM-S1IND (extension module).
        EM_S1IND = 7, "EM-S1IND";
        /// Bit 8: EM-S2IND (extension module).
        EM_S2IND = 8, "EM-S2IND";
        /// Bit 9: EM-S3IND (extension module).
        EM_S3IND = 9, "EM-S3IND";
    }
}

bit_word! {
    /// ACT status word 411 (ch. 9.1.1, 9.1.2, 9.1.3).
    ActStatusWord {
        /// Bit 0 "Einschaltbereit": ready to switch on.
        READY_TO_SWITCH_ON = 0, "ready to switch on";
        /// Bit 1 "Eingeschaltet": switched on.
        SWITCHED_ON = 1, "switched on";
        /// Bit 2 "Betrieb - Freigegeben": operation enabled.
        OPERATION_ENABLED = 2, "operation enabled";
        /// Bit 3 "Störung": fault.
        FAULT = 3, "fault";
        /// Bit 4 "Spannung - Gesperrt": voltage disabled; always 0 on the ACT (ch. 9.1.3).
        VOLTAGE_DISABLED = 4, "voltage disabled";
        /// Bit 5 "Schnellhalt": 0 while quick stop is active (active low).
        NO_QUICK_STOP = 5, "no quick stop";
        /// Bit 6 "Einschaltsperre": switch-on disabled.
        SWITCH_ON_DISABLED = 6, "switch-on disabled";
        /// Bit 7 "Warnung": a warning is present, see parameter 270.
        WARNING = 7, "warning";
        /// Bit 9 "Remote": the drive is controlled over the bus.
        REMOTE = 9, "remote";
        /// Bit 10 "Sollwert erreicht": setpoint reached (hysteresis P549).
        SETPOINT_REACHED = 10, "setpoint reached";
        /// Bit 11 "Grenzwert aktiv": an internal limit is active.
        LIMIT_ACTIVE = 11, "limit active";
        /// Bit 15 "Warnung 2": critical warning, a trip follows soon; bit 7 is set too.
        WARNING_2 = 15, "warning 2";
    }
}

bit_word! {
    /// ACU status word 411 (ch. 10.1, 10.2).
    AcuStatusWord {
        /// Bit 0 "Einschaltbereit": ready to switch on.
        READY_TO_SWITCH_ON = 0, "ready to switch on";
        /// Bit 1 "Eingeschaltet": switched on.
        SWITCHED_ON = 1, "switched on";
        /// Bit 2 "Betrieb – Freigegeben": operation enabled.
        OPERATION_ENABLED = 2, "operation enabled";
        /// Bit 3 "Fehler": fault.
        FAULT = 3, "fault";
        /// Bit 4 "Spannung – Freigegeben": mains voltage present; transitions 3 and 4' are only
        /// processed while it is set.
        VOLTAGE_ENABLED = 4, "voltage enabled";
        /// Bit 5 "Schnellhalt": 0 while quick stop is active (active low).
        NO_QUICK_STOP = 5, "no quick stop";
        /// Bit 6 "Einschalten gesperrt": switch-on disabled.
        SWITCH_ON_DISABLED = 6, "switch-on disabled";
        /// Bit 7 "Warnung": a warning is present, see parameter 270.
        WARNING = 7, "warning";
        /// Bit 9 "Remote": the drive is controlled over the bus.
        REMOTE = 9, "remote";
        /// Bit 10 "Ziel erreicht": target reached (hysteresis P549).
        TARGET_REACHED = 10, "target reached";
        /// Bit 11 "Interner Grenzwert aktiv": an internal limit is active.
        INTERNAL_LIMIT_ACTIVE = 11, "internal limit active";
        /// Bit 12 "Betriebsartabhängig" (positioning only).
        OPERATION_MODE_12 = 12, "operation mode specific 12";
        /// Bit 13 "Betriebsartabhängig" (positioning only).
        OPERATION_MODE_13 = 13, "operation mode specific 13";
        /// Bit 15 "Warnung 2": critical warning, a trip follows soon.
        WARNING_2 = 15, "warning 2";
    }
}

/// The state shown in contact and remote-contact mode (412 = 0 or 2), where the manual lists
/// only three states (ch. 9.1.1, 9.1.3, 10.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContactState {
    /// "Eingeschaltet" 0x23.
    SwitchedOn,
    /// "Betrieb freigegeben" 0x27.
    OperationEnabled,
    /// "Störung" / "Fehler".
    Fault,
    /// Any other word.
    Other,
}

impl ActStatusWord {
    /// The state-machine state (412 = 1).
    pub fn state(self) -> State {
        ActStateMachine::decode(self.0)
    }

    /// The state in contact / remote-contact mode: bits 0…3, 5, 6 as in ch. 9.1.1 / 9.1.3.
    pub fn contact_state(self) -> ContactState {
        match self.0 & 0x6F {
            0x23 => ContactState::SwitchedOn,
            0x27 => ContactState::OperationEnabled,
            _ if self.0 & 0x4F == 0x08 => ContactState::Fault,
            _ => ContactState::Other,
        }
    }
}

impl AcuStatusWord {
    /// The state-machine state (412 = 1).
    pub fn state(self) -> State {
        AcuStateMachine::decode(self.0)
    }

    /// Whether the mains voltage is present (bit 4): without it the drive cannot start.
    pub const fn mains_on(self) -> bool {
        self.contains(Self::VOLTAGE_ENABLED)
    }

    /// The state in contact / remote-contact mode (ch. 10.1): bit 3 alone means fault; bit 4
    /// only reports the mains voltage and is ignored (see docs/errata-bonfiglioli.md).
    pub fn contact_state(self) -> ContactState {
        if self.contains(Self::FAULT) {
            return ContactState::Fault;
        }
        match self.0 & 0x2F {
            0x23 => ContactState::SwitchedOn,
            0x27 => ContactState::OperationEnabled,
            _ => ContactState::Other,
        }
    }
}
