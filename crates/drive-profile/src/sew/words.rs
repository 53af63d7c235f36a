//! SEW control word 1 and status word 1 (the basic control and status blocks of SEW's fieldbus
//! unit profile), as typed bit sets. Sources and the simulator's reading of every bit are in
//! `docs/protocols/movidrive-profile.md`.
//!
//! ```
//! use drive_profile::sew::{BasicCommand, ControlWord1, StatusWord1, UnitStatus};
//! assert_eq!(ControlWord1::ENABLE.bits(), 0x0006);
//! assert_eq!(ControlWord1::from_bits(0x0006).command(), BasicCommand::Enable);
//! assert_eq!(ControlWord1::from_bits(0x0007).command(), BasicCommand::ControllerInhibit);
//! let sw = StatusWord1::from_bits(0x0407);
//! assert_eq!(sw.unit_status(), Some(UnitStatus::Enable));
//! assert_eq!(sw.to_string(), "output stage enabled, ready, PO data enabled, unit status 4 = enable");
//! assert_eq!(StatusWord1::from_bits(0x2B26).fault_number(), Some(43));
//! ```

use core::fmt;

use crate::words::bit_word;

bit_word! {
    /// Control word 1 (basic control block in the low byte; bits 8–15 select motor
    /// potentiometer and fixed setpoints, not named here). Control word 2 has the same low byte.
    ControlWord1 {
        /// Bit 0: controller inhibit "1" / enable "0" (output stage off, the motor coasts).
        CONTROLLER_INHIBIT = 0, "controller inhibit";
        /// Bit 1: enable "1" / rapid stop "0" (active low: 0 stops on the stop ramp t13).
        NO_RAPID_STOP = 1, "no rapid stop";
        /// Bit 2: enable "1" / stop "0" (active low: 0 stops on the integrator ramp).
        NO_STOP = 2, "no stop";
        /// Bit 4: integrator switchover (ramp t12 / t22).
        INTEGRATOR_2 = 4, "integrator 2";
        /// Bit 5: parameter set switchover (parameter set 2).
        PARAMETER_SET_2 = 5, "parameter set 2";
        /// Bit 6: fault reset, on the rising edge.
        FAULT_RESET = 6, "fault reset";
    }
}

/// What the basic control block of a control word commands, by priority: controller inhibit
/// over rapid stop over stop over enable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BasicCommand {
    /// Bit 0 set: output stage off, the motor coasts.
    ControllerInhibit,
    /// Bit 1 clear: decelerate on the stop ramp t13.
    RapidStop,
    /// Bit 2 clear: decelerate on the active integrator ramp.
    Stop,
    /// Bits 1 and 2 set, bit 0 clear: run to the setpoint.
    Enable,
}

impl BasicCommand {
    /// English name.
    pub const fn name(self) -> &'static str {
        match self {
            BasicCommand::ControllerInhibit => "controller inhibit",
            BasicCommand::RapidStop => "rapid stop",
            BasicCommand::Stop => "stop",
            BasicCommand::Enable => "enable",
        }
    }
}

impl ControlWord1 {
    /// `0x0006`: enable.
    pub const ENABLE: ControlWord1 = ControlWord1::NO_RAPID_STOP.union(ControlWord1::NO_STOP);
    /// `0x0002`: stop (decelerate with the active integrator ramp).
    pub const STOP: ControlWord1 = ControlWord1::NO_RAPID_STOP;
    /// `0x0000`: rapid stop (decelerate with the stop ramp t13).
    pub const RAPID_STOP: ControlWord1 = ControlWord1::empty();
    /// `0x0001`: controller inhibit.
    pub const INHIBIT: ControlWord1 = ControlWord1::CONTROLLER_INHIBIT;

    /// The command of the basic control block.
    pub const fn command(self) -> BasicCommand {
        if self.contains(ControlWord1::CONTROLLER_INHIBIT) {
            BasicCommand::ControllerInhibit
        } else if !self.contains(ControlWord1::NO_RAPID_STOP) {
            BasicCommand::RapidStop
        } else if !self.contains(ControlWord1::NO_STOP) {
            BasicCommand::Stop
        } else {
            BasicCommand::Enable
        }
    }
}

bit_word! {
    /// Status word 1: the basic status block in the low byte; the high byte holds the fault
    /// number while bit 5 is set, else the unit status ([`StatusWord1::unit_status`]).
    StatusWord1 {
        /// Bit 0: output stage enabled.
        OUTPUT_STAGE_ENABLED = 0, "output stage enabled";
        /// Bit 1: inverter ready.
        INVERTER_READY = 1, "ready";
        /// Bit 2: PO data enabled.
        PO_DATA_ENABLED = 2, "PO data enabled";
        /// Bit 3: current ramp generator set (integrator 2).
        INTEGRATOR_2 = 3, "integrator 2";
        /// Bit 4: current parameter set (parameter set 2).
        PARAMETER_SET_2 = 4, "parameter set 2";
        /// Bit 5: fault / warning (the high byte is the fault number).
        FAULT_WARNING = 5, "fault/warning";
        /// Bit 6: limit switch CW reached.
        LIMIT_SWITCH_CW = 6, "limit switch CW";
        /// Bit 7: limit switch CCW reached.
        LIMIT_SWITCH_CCW = 7, "limit switch CCW";
    }
}

/// The unit status in the high byte of status word 1 (while bit 5 is clear).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum UnitStatus {
    /// 0: 24 V operation (unit not ready).
    Supply24V,
    /// 1: controller inhibit.
    ControllerInhibit,
    /// 2: no enable.
    NoEnable,
    /// 3: standstill current.
    StandstillCurrent,
    /// 4: enable (VFC operation).
    Enable,
    /// 5: speed control.
    SpeedControl,
    /// Another code of the unit's status list.
    Other(u8),
}

impl UnitStatus {
    /// The status of code `code`.
    pub const fn from_code(code: u8) -> UnitStatus {
        match code {
            0 => UnitStatus::Supply24V,
            1 => UnitStatus::ControllerInhibit,
            2 => UnitStatus::NoEnable,
            3 => UnitStatus::StandstillCurrent,
            4 => UnitStatus::Enable,
            5 => UnitStatus::SpeedControl,
            c => UnitStatus::Other(c),
        }
    }

    /// The code.
    pub const fn code(self) -> u8 {
        match self {
            UnitStatus::Supply24V => 0,
            UnitStatus::ControllerInhibit => 1,
            UnitStatus::NoEnable => 2,
            UnitStatus::StandstillCurrent => 3,
            UnitStatus::Enable => 4,
            UnitStatus::SpeedControl => 5,
            UnitStatus::Other(c) => c,
        }
    }

    /// English name; empty for codes not named here.
    pub const fn name(self) -> &'static str {
        match self {
            UnitStatus::Supply24V => "24 V operation",
            UnitStatus::ControllerInhibit => "controller inhibit",
            UnitStatus::NoEnable => "no enable",
            UnitStatus::StandstillCurrent => "standstill current",
            UnitStatus::Enable => "enable",
            UnitStatus::SpeedControl => "n-control",
            UnitStatus::Other(_) => "",
        }
    }
}

impl StatusWord1 {
    /// A status word from its basic status block and its high byte.
    pub const fn with_high_byte(self, high: u8) -> StatusWord1 {
        StatusWord1::from_bits((self.bits() & 0x00FF) | (high as u16) << 8)
    }

    /// The high byte.
    pub const fn high_byte(self) -> u8 {
        (self.bits() >> 8) as u8
    }

    /// The fault number, while bit 5 (fault / warning) is set.
    pub const fn fault_number(self) -> Option<u8> {
        if self.contains(StatusWord1::FAULT_WARNING) {
            Some(self.high_byte())
        } else {
            None
        }
    }

    /// The unit status, while bit 5 is clear.
    pub const fn unit_status(self) -> Option<UnitStatus> {
        if self.contains(StatusWord1::FAULT_WARNING) {
            None
        } else {
            Some(UnitStatus::from_code(self.high_byte()))
        }
    }
}

impl fmt::Display for StatusWord1 {
    /// One line: the set bits of the basic status block (bits 0–2), then the fault number or the
    /// unit status, e.g. `output stage enabled, ready, PO data enabled, unit status 4 = enable`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut sep = "";
        for (flag, name) in StatusWord1::NAMED.iter().take(3) {
            if self.contains(*flag) {
                write!(f, "{sep}{name}")?;
                sep = ", ";
            }
        }
        match (self.fault_number(), self.unit_status()) {
            (Some(n), _) => write!(f, "{sep}fault/warning {n}"),
            (None, Some(s)) if !s.name().is_empty() => {
                write!(f, "{sep}unit status {} = {}", s.code(), s.name())
            }
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_word_priorities() {
        for w in 0..=0xFFFFu16 {
            let cw = ControlWord1::from_bits(w);
            let expected = if w & 1 != 0 {
                BasicCommand::ControllerInhibit
            } else if w & 2 == 0 {
                BasicCommand::RapidStop
            } else if w & 4 == 0 {
                BasicCommand::Stop
            } else {
                BasicCommand::Enable
            };
            assert_eq!(cw.command(), expected, "{w:#06x}");
        }
        // The named words are the commands their names say.
        assert_eq!(ControlWord1::STOP.command(), BasicCommand::Stop);
        assert_eq!(ControlWord1::RAPID_STOP.command(), BasicCommand::RapidStop);
        assert_eq!(
            ControlWord1::INHIBIT.command(),
            BasicCommand::ControllerInhibit
        );
        assert_eq!(ControlWord1::ENABLE.command(), BasicCommand::Enable);
        assert_eq!(
            format!("{:?}", ControlWord1::from_bits(0x0046)),
            "ControlWord1(no rapid stop | no stop | fault reset)"
        );
    }

    #[test]
    fn status_word_readings() {
        // The manual's example response (ch. 4.3): PI1 = 0206h.
        let sw = StatusWord1::from_bits(0x0206);
        assert_eq!(
            sw.to_string(),
            "ready, PO data enabled, unit status 2 = no enable"
        );
        assert_eq!(sw.unit_status(), Some(UnitStatus::NoEnable));
        let fault = StatusWord1::from_bits(0x2B25);
        assert_eq!(fault.fault_number(), Some(0x2B));
        assert_eq!(fault.unit_status(), None);
        assert_eq!(
            fault.to_string(),
            "output stage enabled, PO data enabled, fault/warning 43"
        );
        assert_eq!(StatusWord1::INVERTER_READY.with_high_byte(1).bits(), 0x0102);
        assert_eq!(UnitStatus::from_code(9), UnitStatus::Other(9));
        assert_eq!(StatusWord1::from_bits(0x0900).to_string(), "");
        for c in 0..=255u8 {
            assert_eq!(UnitStatus::from_code(c).code(), c);
        }
    }
}
