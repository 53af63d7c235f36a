//! The value lists the device model acts on: P870–P872 (what a process output word carries),
//! P873–P875 (process input words), P833 (the reaction to an RS-485 timeout), and the bus
//! selections of P100/P101.

/// What a process output word carries (P870–P872 value list).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PoFunction {
    /// 0: no function.
    None,
    /// 1: speed setpoint, signed, 0.2 1/min per digit.
    Speed,
    /// 2: current setpoint (accepted, not modelled).
    Current,
    /// 3: position setpoint, low word (accepted, not modelled).
    PositionLow,
    /// 4: position setpoint, high word (accepted, not modelled).
    PositionHigh,
    /// 5: maximum speed, 0.2 1/min per digit (limits the setpoint; 0 = no limit).
    MaxSpeed,
    /// 6: maximum current (accepted, not modelled).
    MaxCurrent,
    /// 7: slip (accepted, not modelled).
    Slip,
    /// 8: ramp, 1 ms per digit per 3000 1/min (replaces the integrator ramps up and down).
    Ramp,
    /// 9: control word 1.
    ControlWord1,
    /// 10: control word 2 (basic control block as control word 1; virtual terminals not
    /// modelled).
    ControlWord2,
    /// 11: speed setpoint in percent, 0x4000 = 100 % of the maximum speed (P302 / P312).
    SpeedPercent,
    /// 12: IPOS PO data (accepted, not modelled).
    IposData,
}

impl PoFunction {
    /// The function for a raw P870–P872 value (`None` outside the value list).
    pub const fn from_raw(raw: i64) -> Option<PoFunction> {
        Some(match raw {
            0 => PoFunction::None,
            1 => PoFunction::Speed,
            2 => PoFunction::Current,
            3 => PoFunction::PositionLow,
            4 => PoFunction::PositionHigh,
            5 => PoFunction::MaxSpeed,
            6 => PoFunction::MaxCurrent,
            7 => PoFunction::Slip,
            8 => PoFunction::Ramp,
            9 => PoFunction::ControlWord1,
            10 => PoFunction::ControlWord2,
            11 => PoFunction::SpeedPercent,
            12 => PoFunction::IposData,
            _ => return None,
        })
    }
}

/// What a process input word carries (P873–P875 value list).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PiFunction {
    /// 0: no function (0).
    None,
    /// 1: actual speed, signed, 0.2 1/min per digit.
    Speed,
    /// 2: output current, 0.1 % of the unit rated current per digit.
    OutputCurrent,
    /// 3: active current, signed, 0.1 % of the unit rated current per digit.
    ActiveCurrent,
    /// 4: actual position, low word (increments, 4096 per revolution).
    PositionLow,
    /// 5: actual position, high word.
    PositionHigh,
    /// 6: status word 1.
    StatusWord1,
    /// 7: status word 2.
    StatusWord2,
    /// 8: actual speed in percent, 0x4000 = 100 % of the maximum speed.
    SpeedPercent,
    /// 9: IPOS PI data (0).
    IposData,
    /// 10: reserved (0).
    Reserved,
    /// 11: status word 3 (not documented in the sources; 0).
    StatusWord3,
}

impl PiFunction {
    /// The function for a raw P873–P875 value (`None` outside the value list).
    pub const fn from_raw(raw: i64) -> Option<PiFunction> {
        Some(match raw {
            0 => PiFunction::None,
            1 => PiFunction::Speed,
            2 => PiFunction::OutputCurrent,
            3 => PiFunction::ActiveCurrent,
            4 => PiFunction::PositionLow,
            5 => PiFunction::PositionHigh,
            6 => PiFunction::StatusWord1,
            7 => PiFunction::StatusWord2,
            8 => PiFunction::SpeedPercent,
            9 => PiFunction::IposData,
            10 => PiFunction::Reserved,
            11 => PiFunction::StatusWord3,
            _ => return None,
        })
    }
}

/// The reaction to an RS-485 timeout (P833, value list of P830).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeoutReaction {
    /// 0: no response.
    NoResponse,
    /// 1: display fault (fault number shown, the drive keeps running).
    DisplayFault,
    /// 2: immediate stop / fault: output stage off, fault latched.
    ImmediateStopFault,
    /// 3: emergency stop / fault: emergency ramp t14, then fault.
    EmergencyStopFault,
    /// 4: rapid stop / fault: stop ramp t13, then fault.
    RapidStopFault,
    /// 5: immediate stop / warning.
    ImmediateStopWarning,
    /// 6: emergency stop / warning.
    EmergencyStopWarning,
    /// 7: rapid stop / warning (factory setting of P833).
    RapidStopWarning,
}

impl TimeoutReaction {
    /// The reaction for a raw P830-list value (`None` outside the list).
    pub const fn from_raw(raw: i64) -> Option<TimeoutReaction> {
        Some(match raw {
            0 => TimeoutReaction::NoResponse,
            1 => TimeoutReaction::DisplayFault,
            2 => TimeoutReaction::ImmediateStopFault,
            3 => TimeoutReaction::EmergencyStopFault,
            4 => TimeoutReaction::RapidStopFault,
            5 => TimeoutReaction::ImmediateStopWarning,
            6 => TimeoutReaction::EmergencyStopWarning,
            7 => TimeoutReaction::RapidStopWarning,
            _ => return None,
        })
    }

    /// Whether the reaction latches a fault (needs a fault reset).
    pub const fn is_fault(self) -> bool {
        matches!(
            self,
            TimeoutReaction::ImmediateStopFault
                | TimeoutReaction::EmergencyStopFault
                | TimeoutReaction::RapidStopFault
        )
    }
}

/// Which bus the drive takes its control word and setpoint from ([`Movidrive::set_bus_control`](super::Movidrive::set_bus_control)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BusSource {
    /// P100 = 2 RS485, P101 = 1 RS485.
    Rs485,
    /// P100 = 3 FIELDBUS, P101 = 2 FIELDBUS.
    Fieldbus,
    /// P100 = 10 SBus, P101 = 3 SBus.
    SBus,
}

impl BusSource {
    pub(super) const fn setpoint_source(self) -> i64 {
        match self {
            BusSource::Rs485 => 2,
            BusSource::Fieldbus => 3,
            BusSource::SBus => 10,
        }
    }
    pub(super) const fn control_source(self) -> i64 {
        match self {
            BusSource::Rs485 => 1,
            BusSource::Fieldbus => 2,
            BusSource::SBus => 3,
        }
    }
}

/// The deceleration ramp a quick stop uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum QuickRamp {
    /// Stop ramp t13 / t23 (rapid stop).
    Rapid,
    /// Emergency ramp t14 / t24.
    Emergency,
}

pub(super) const PO_WORDS: usize = 3;
/// Speed process data: 0.2 1/min per digit.
pub(super) const RPM_PER_DIGIT: f64 = drive_profile::sew::SPEED_RPM_PER_DIGIT;
/// Relative speed: 0x4000 = 100 %.
pub(super) const PERCENT_100: f64 = 16384.0;
/// Increments per motor revolution.
pub(super) const INC_PER_REV: f64 = 4096.0;
/// Output current model: magnetising share at standstill, % In.
pub(super) const MAGNETISING_PERCENT: f64 = 20.0;
/// Output current model: load share at maximum speed, % In.
pub(super) const LOAD_PERCENT: f64 = 60.0;
