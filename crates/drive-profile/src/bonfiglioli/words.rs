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

use crate::words::bit_word;

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
