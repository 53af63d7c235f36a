//! A simulated SEW MOVIDRIVE, protocol-independent: the device that the MOVILINK (RS-485) and
//! SBus (CAN) slave front-ends put their codecs on. It speaks plain numbers only: parameter
//! services with a 16-bit index and 32-bit data, three process output words (PO, master →
//! drive) and three process input words (PI, drive → master).
//!
//! The model is documented in `docs/protocols/movidrive-profile.md` together with its sources
//! (SEW serial communication manual ch. 4, 6.2 and 7; the SEW fieldbus unit profile) and every
//! simulator choice. In short:
//!
//! * **Parameters** come from the generated table [`drive_profile::sew::params`] (RAM and
//!   EEPROM values, access flags, ranges, value lists) in a [`ParamStore`]; the services of
//!   [`ParamService`] answer with the 32-bit data or a MOVILINK [`ReturnCode`].
//! * **Process data** are mapped by P870–P872 (PO) and P873–P875 (PI) and taken only while
//!   P876 "PO data enable" is ON. The control word acts only when P101 "control signal source"
//!   is a bus (RS-485, fieldbus, SBus), the speed setpoint only when P100 "setpoint source" is a
//!   bus; see [`Movidrive::set_bus_control`].
//! * **Control word 1/2** (basic control block) drive the [`SimDrive`] state machine: bit 0
//!   controller inhibit, bit 1 rapid stop (active low), bit 2 stop (active low), bit 4
//!   integrator switchover, bit 5 parameter set switchover, bit 6 fault reset (rising edge).
//! * **Ramps** per P130–P137 (parameter set 1) and P140–P147 (set 2), reference 3000 1/min.
//! * **RS-485 timeout** per P812 (ms, 0 = off) with the P833 reaction; fault number 43.
//!
//! Time is always an argument ([`SimTime`]); nothing reads a clock.
//!
//! # Example
//!
//! ```
//! use std::time::Duration;
//! use drive_sim::SimTime;
//! use drive_sim::movidrive::{BusSource, Movidrive, control_word};
//!
//! let mut drive = Movidrive::new(1);
//! drive.set_bus_control(BusSource::Rs485, SimTime::ZERO);
//! // PO1 = control word 1 (enable), PO2 = speed 5000 × 0.2 = 1000 1/min
//! drive.process_output(&[control_word::ENABLE, 5000], SimTime::ZERO);
//! drive.tick(SimTime::ZERO + Duration::from_millis(2000)); // P130 = 2 s per 3000 1/min
//! assert!((drive.actual_speed_rpm() - 1000.0).abs() < 1e-9);
//! let mut pi = [0u16; 3];
//! drive.process_input(&mut pi);
//! assert_eq!(pi[1], 5000); // PI2 = actual speed
//! ```

use core::fmt;
use std::time::Duration;

use drive_profile::sew;
use drive_profile::{Access, ParamMeta};

use crate::drive::{SimDrive, SpeedMapping};
use crate::error::SimError;
use crate::ramp::RampConfig;
use crate::state::{Command, DriveState, FaultReaction};
use crate::store::{ParamStore, Persistence, StoreOptions};
use crate::time::SimTime;

/// MOVILINK indices of the parameters the device model uses (SEW manual ch. 7.2).
pub mod index {
    /// P000 speed, 0.001 1/min.
    pub const SPEED: u16 = 8318;
    /// P002 frequency, 0.001 Hz.
    pub const FREQUENCY: u16 = 8319;
    /// P003 actual position, increments (4096 per motor revolution).
    pub const POSITION: u16 = 8320;
    /// P004 output current, 0.001 % of the unit rated current.
    pub const OUTPUT_CURRENT_PERCENT: u16 = 8321;
    /// P005 active current, 0.001 % of the unit rated current.
    pub const ACTIVE_CURRENT_PERCENT: u16 = 8322;
    /// P008 DC link voltage, 0.001 V.
    pub const DC_LINK_VOLTAGE: u16 = 8325;
    /// P009 output current, 0.001 A.
    pub const OUTPUT_CURRENT_AMPERE: u16 = 8326;
    /// P010–P013 drive status / operating state / fault status / active parameter set (one
    /// index; the low word is coded like status word 1).
    pub const DRIVE_STATUS: u16 = 8310;
    /// P070 unit type.
    pub const UNIT_TYPE: u16 = 8301;
    /// P071 unit rated current, 0.001 A.
    pub const RATED_CURRENT: u16 = 8361;
    /// P076 firmware of the basic unit.
    pub const FIRMWARE: u16 = 8300;
    /// P080 fault t-0 (P081–P084 follow at 8367–8370).
    pub const FAULT_T0: u16 = 8366;
    /// P100 setpoint source.
    pub const SETPOINT_SOURCE: u16 = 8461;
    /// P101 control signal source.
    pub const CONTROL_SOURCE: u16 = 8462;
    /// P130 ramp t11 up CW, ms per 3000 1/min.
    pub const RAMP_T11_UP_CW: u16 = 8470;
    /// P131 ramp t11 down CW.
    pub const RAMP_T11_DOWN_CW: u16 = 8471;
    /// P132 ramp t11 up CCW.
    pub const RAMP_T11_UP_CCW: u16 = 8472;
    /// P133 ramp t11 down CCW.
    pub const RAMP_T11_DOWN_CCW: u16 = 8473;
    /// P134 ramp t12 up = down (integrator 2).
    pub const RAMP_T12: u16 = 8474;
    /// P136 stop ramp t13 (rapid stop).
    pub const STOP_RAMP_T13: u16 = 8476;
    /// P137 emergency ramp t14.
    pub const EMERGENCY_RAMP_T14: u16 = 8477;
    /// P140 ramp t21 up CW (parameter set 2; P141–P144 follow, P146 t23 at 8484, P147 t24 at
    /// 8485).
    pub const RAMP_T21_UP_CW: u16 = 8478;
    /// P302 maximum speed 1, 0.001 1/min.
    pub const MAX_SPEED_1: u16 = 8517;
    /// P312 maximum speed 2, 0.001 1/min.
    pub const MAX_SPEED_2: u16 = 8521;
    /// P620 binary output DO01 function.
    pub const DO01: u16 = 8350;
    /// P621 binary output DO02 function.
    pub const DO02: u16 = 8351;
    /// P802 factory setting.
    pub const FACTORY_SETTING: u16 = 8594;
    /// P803 parameter lock.
    pub const PARAMETER_LOCK: u16 = 8595;
    /// P804 reset statistics data.
    pub const RESET_STATISTICS: u16 = 8596;
    /// P810 RS-485 address.
    pub const RS485_ADDRESS: u16 = 8597;
    /// P811 RS-485 group address.
    pub const RS485_GROUP_ADDRESS: u16 = 8598;
    /// P812 RS-485 timeout time, ms.
    pub const RS485_TIMEOUT: u16 = 8599;
    /// P833 reaction to RS-485 timeout.
    pub const RS485_TIMEOUT_REACTION: u16 = 8612;
    /// P852 user unit, first index.
    pub const USER_UNIT: u16 = 8772;
    /// P852 user unit, second index.
    pub const USER_UNIT_2: u16 = 8773;
    /// P870 setpoint description PO1 (PO2, PO3: 8305, 8306).
    pub const PO1_DESCRIPTION: u16 = 8304;
    /// P873 actual value description PI1 (PI2, PI3: 8308, 8309).
    pub const PI1_DESCRIPTION: u16 = 8307;
    /// P876 PO data enable.
    pub const PO_DATA_ENABLE: u16 = 8622;
}

/// SEW fault number of "RS-485 timeout" (F43 in SEW's fault list).
pub const FAULT_RS485_TIMEOUT: u16 = 43;

/// P070 unit type as the simulator reports it (simulator choice: the manual gives no coding;
/// the digits spell MDX60A 0015-5-3, i.e. series 60, 1.5 kW, 380–500 V, 3 phases).
pub const UNIT_TYPE: u32 = 60_001_553;

/// P076 firmware of the basic unit as the simulator reports it: part number 822 609, version
/// 7.11, in the manual's format "822609711 = 822 609 7.11" (the manual's own example number,
/// reused as a simulator choice).
pub const FIRMWARE: u32 = 822_609_711;

/// P071 unit rated current in 0.001 A (simulator choice: 4.0 A, an MDX60A0015-5A3).
pub const RATED_CURRENT_MA: i64 = 4_000;

/// P008 DC link voltage in 0.001 V (simulator choice: constant 560 V, a 400 V supply).
pub const DC_LINK_VOLTAGE_MV: i64 = 560_000;

/// Bits and canonical values of control word 1 / the basic control block of control word 2
/// (SEW fieldbus unit profile).
pub mod control_word {
    /// Bit 0: controller inhibit "1" / enable "0".
    pub const CONTROLLER_INHIBIT_BIT: u16 = 1 << 0;
    /// Bit 1: enable "1" / rapid stop "0".
    pub const NO_RAPID_STOP_BIT: u16 = 1 << 1;
    /// Bit 2: enable "1" / stop "0".
    pub const NO_STOP_BIT: u16 = 1 << 2;
    /// Bit 4: integrator switchover (ramp set t12 / t22).
    pub const INTEGRATOR_BIT: u16 = 1 << 4;
    /// Bit 5: parameter set switchover (parameter set 2).
    pub const PARAMETER_SET_BIT: u16 = 1 << 5;
    /// Bit 6: fault reset (acts on the rising edge).
    pub const FAULT_RESET_BIT: u16 = 1 << 6;
    /// `0x0006`: enable.
    pub const ENABLE: u16 = 0x0006;
    /// `0x0002`: stop (decelerate with the active integrator ramp).
    pub const STOP: u16 = 0x0002;
    /// `0x0000`: rapid stop (decelerate with the stop ramp t13).
    pub const RAPID_STOP: u16 = 0x0000;
    /// `0x0001`: controller inhibit (output stage off, motor coasts).
    pub const CONTROLLER_INHIBIT: u16 = 0x0001;
}

/// Bits and unit-status codes of status word 1 (SEW fieldbus unit profile, basic status block).
pub mod status_word {
    /// Bit 0: output stage enabled.
    pub const OUTPUT_STAGE_ENABLED: u16 = 1 << 0;
    /// Bit 1: inverter ready.
    pub const INVERTER_READY: u16 = 1 << 1;
    /// Bit 2: PO data enabled.
    pub const PO_DATA_ENABLED: u16 = 1 << 2;
    /// Bit 3: current ramp generator set (integrator 2).
    pub const INTEGRATOR_2: u16 = 1 << 3;
    /// Bit 4: current parameter set (parameter set 2).
    pub const PARAMETER_SET_2: u16 = 1 << 4;
    /// Bit 5: fault / warning (high byte = fault number).
    pub const FAULT_WARNING: u16 = 1 << 5;
    /// Unit status 1: controller inhibit.
    pub const STATUS_CONTROLLER_INHIBIT: u8 = 1;
    /// Unit status 2: no enable.
    pub const STATUS_NO_ENABLE: u8 = 2;
    /// Unit status 4: enable (VFC operation).
    pub const STATUS_ENABLE: u8 = 4;
}

// ---------------------------------------------------------------------------------------------
// Return codes and services

/// A MOVILINK return code: error class, error code and additional code (bytes 4–7 of a negative
/// parameter answer, SEW manual ch. 6.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ReturnCode {
    /// Error class (8 = other, see additional code; 5 = service).
    pub error_class: u8,
    /// Error code (0 under class 8).
    pub error_code: u8,
    /// Additional code (SEW-specific under class 8).
    pub additional_code: u16,
}

impl ReturnCode {
    /// Error class 8, error code 0, with an SEW additional code.
    pub const fn other(additional_code: u16) -> ReturnCode {
        ReturnCode {
            error_class: 8,
            error_code: 0,
            additional_code,
        }
    }
    /// `8/0/0x0010` illegal parameter index.
    pub const ILLEGAL_INDEX: ReturnCode = ReturnCode::other(0x0010);
    /// `8/0/0x0011` function / parameter not implemented.
    pub const NOT_IMPLEMENTED: ReturnCode = ReturnCode::other(0x0011);
    /// `8/0/0x0012` read access only.
    pub const READ_ONLY: ReturnCode = ReturnCode::other(0x0012);
    /// `8/0/0x0013` parameter lock is active (P803).
    pub const PARAMETER_LOCK: ReturnCode = ReturnCode::other(0x0013);
    /// `8/0/0x0015` value too large.
    pub const TOO_LARGE: ReturnCode = ReturnCode::other(0x0015);
    /// `8/0/0x0016` value too small.
    pub const TOO_SMALL: ReturnCode = ReturnCode::other(0x0016);
    /// `8/0/0x0018` error in system software.
    pub const SYSTEM_SOFTWARE: ReturnCode = ReturnCode::other(0x0018);
    /// `8/0/0x001C` controller inhibit required.
    pub const CONTROLLER_INHIBIT_REQUIRED: ReturnCode = ReturnCode::other(0x001C);
    /// `8/0/0x001D` invalid value for the parameter.
    pub const INVALID_VALUE: ReturnCode = ReturnCode::other(0x001D);
    /// `8/0/0x001F` parameter was not saved in EEPROM.
    pub const NOT_SAVED_IN_EEPROM: ReturnCode = ReturnCode::other(0x001F);
    /// `8/0/0x0020` cannot be changed while the output stage is enabled.
    pub const OUTPUT_STAGE_ENABLED: ReturnCode = ReturnCode::other(0x0020);
    /// `5/5/0x0000` parameter setting error: illegal value (wrong coding of the management
    /// byte, e.g. an unknown service).
    pub const SERVICE_ERROR: ReturnCode = ReturnCode {
        error_class: 5,
        error_code: 5,
        additional_code: 0,
    };

    /// The four bytes 4–7 of the parameter channel: class, code, additional high, low.
    pub const fn to_bytes(self) -> [u8; 4] {
        let [hi, lo] = self.additional_code.to_be_bytes();
        [self.error_class, self.error_code, hi, lo]
    }

    /// The same four bytes as one 32-bit data word (byte 4 most significant).
    pub const fn to_data(self) -> u32 {
        u32::from_be_bytes(self.to_bytes())
    }

    /// The manual's description ([`sew::describe_return_code`]).
    pub fn describe(self) -> sew::DecodedReturnCode {
        sew::describe_return_code(self.error_class, self.error_code, self.additional_code)
    }

    /// The return code for a refusal of the simulated drive.
    pub fn from_sim_error(error: SimError) -> ReturnCode {
        match error {
            SimError::UnknownIndex { .. } | SimError::UnknownSubIndex { .. } => {
                ReturnCode::ILLEGAL_INDEX
            }
            SimError::ReadOnly { .. } => ReturnCode::READ_ONLY,
            SimError::Locked { .. } => ReturnCode::PARAMETER_LOCK,
            SimError::TooLarge { .. } => ReturnCode::TOO_LARGE,
            SimError::TooSmall { .. } => ReturnCode::TOO_SMALL,
            SimError::ValueNotAllowed { .. } => ReturnCode::INVALID_VALUE,
            SimError::NeedsInhibit { .. } => ReturnCode::CONTROLLER_INHIBIT_REQUIRED,
            SimError::NotInOperation { .. } => ReturnCode::OUTPUT_STAGE_ENABLED,
            SimError::EepromWornOut { .. } => ReturnCode::NOT_SAVED_IN_EEPROM,
            _ => ReturnCode::SYSTEM_SOFTWARE,
        }
    }
}

impl fmt::Display for ReturnCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.describe().fmt(f)
    }
}

impl std::error::Error for ReturnCode {}

/// A parameter service of the MOVILINK parameter channel (management byte bits 0–3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParamService {
    /// `0001` read the current (RAM) value.
    Read,
    /// `0010` write non-volatile (RAM and EEPROM; counted as EEPROM wear).
    Write,
    /// `0011` write volatile (RAM only).
    WriteVolatile,
    /// `0100` read the smallest settable value.
    ReadMinimum,
    /// `0101` read the largest settable value.
    ReadMaximum,
    /// `0110` read the default (factory setting).
    ReadDefault,
    /// `0111` read size index (byte 6) and conversion index (byte 7).
    ReadScale,
    /// `1000` read the next available index (bytes 4–5) and the access attributes (bytes 6–7,
    /// byte 6 zero, see [`attribute_byte`]); the layout of `movilink::AttributeInfo`.
    ReadAttribute,
}

impl ParamService {
    /// The service ID of the management byte (bits 0–3).
    pub const fn id(self) -> u8 {
        match self {
            ParamService::Read => 1,
            ParamService::Write => 2,
            ParamService::WriteVolatile => 3,
            ParamService::ReadMinimum => 4,
            ParamService::ReadMaximum => 5,
            ParamService::ReadDefault => 6,
            ParamService::ReadScale => 7,
            ParamService::ReadAttribute => 8,
        }
    }

    /// The service with this ID; `None` for 0 ("no service") and undefined IDs.
    pub const fn from_id(id: u8) -> Option<ParamService> {
        Some(match id {
            1 => ParamService::Read,
            2 => ParamService::Write,
            3 => ParamService::WriteVolatile,
            4 => ParamService::ReadMinimum,
            5 => ParamService::ReadMaximum,
            6 => ParamService::ReadDefault,
            7 => ParamService::ReadScale,
            8 => ParamService::ReadAttribute,
            _ => return None,
        })
    }
}

/// The access-attribute byte of a Read Attribute answer (drivebus convention; the manual says
/// the coding is device specific): bit 0 `S`, bit 1 `RO`, bit 2 `R`, bit 3 `RW`, bit 4 `N`,
/// bits 5–7 zero. These are the bits of [`Access`] for the SEW flags.
pub const fn attribute_byte(access: Access) -> u8 {
    access.bits() & 0x1f
}

// ---------------------------------------------------------------------------------------------
// Process data descriptions

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

/// Which bus the drive takes its control word and setpoint from ([`Movidrive::set_bus_control`]).
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
    const fn setpoint_source(self) -> i64 {
        match self {
            BusSource::Rs485 => 2,
            BusSource::Fieldbus => 3,
            BusSource::SBus => 10,
        }
    }
    const fn control_source(self) -> i64 {
        match self {
            BusSource::Rs485 => 1,
            BusSource::Fieldbus => 2,
            BusSource::SBus => 3,
        }
    }
}

/// The deceleration ramp a quick stop uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum QuickRamp {
    /// Stop ramp t13 / t23 (rapid stop).
    Rapid,
    /// Emergency ramp t14 / t24.
    Emergency,
}

const PO_WORDS: usize = 3;
/// Speed process data: 0.2 1/min per digit.
const RPM_PER_DIGIT: f64 = drive_profile::sew::SPEED_RPM_PER_DIGIT;
/// Relative speed: 0x4000 = 100 %.
const PERCENT_100: f64 = 16384.0;
/// Increments per motor revolution.
const INC_PER_REV: f64 = 4096.0;
/// Output current model: magnetising share at standstill, % In.
const MAGNETISING_PERCENT: f64 = 20.0;
/// Output current model: load share at maximum speed, % In.
const LOAD_PERCENT: f64 = 60.0;

// ---------------------------------------------------------------------------------------------
// The device

/// A simulated MOVIDRIVE: a [`SimDrive`] built from the SEW parameter table plus the fieldbus
/// unit profile (process data, control and status words, RS-485 timeout monitor).
pub struct Movidrive {
    drive: SimDrive,
    /// Last process output words taken (PO data enabled).
    po: [u16; PO_WORDS],
    /// Fault-reset bit of the last control word taken (for the rising edge).
    reset_bit: bool,
    /// Time of the last cyclic request telegram since the monitor was (re-)armed.
    last_cyclic: Option<SimTime>,
    /// After power-on / fault reset with the monitor on: enable is held off until the first
    /// cyclic request telegram.
    held: bool,
    /// Active timeout warning (warning reactions and "display fault").
    warning: Option<TimeoutReaction>,
    /// The ramp of a running fault reaction with quick stop.
    fault_ramp: QuickRamp,
    /// Actual position in increments (integrated from the speed).
    position: f64,
    /// Time and speed of the last position update.
    last_update: Option<(SimTime, f64)>,
}

impl fmt::Debug for Movidrive {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Movidrive")
            .field("address", &self.address())
            .field("po", &self.po)
            .field("held", &self.held)
            .field("warning", &self.warning)
            .field("last_cyclic", &self.last_cyclic)
            .field("drive", &self.drive)
            .finish_non_exhaustive()
    }
}

impl Movidrive {
    /// A MOVIDRIVE at RS-485 address `address` (P810, clamped to its range 0…99), every other
    /// parameter at its table default, standstill under controller inhibit.
    ///
    /// With the table defaults P100/P101 select the terminals, so process data do not move the
    /// drive until [`Movidrive::set_bus_control`] (or a write of P100/P101) selects a bus.
    pub fn new(address: u8) -> Movidrive {
        let store = ParamStore::with_options(
            sew::params(),
            StoreOptions {
                value_lists_exhaustive: true,
                lock_index: Some(index::PARAMETER_LOCK),
                ..StoreOptions::default()
            },
        );
        let mut drive = SimDrive::new(store);
        let _ = drive.set_speed_actual_mapping(Some(SpeedMapping {
            index: index::SPEED,
            sub: 0,
            to_raw: |rpm| (rpm * 1000.0).round() as i64,
        }));
        let store = drive.store_mut();
        // P852's second index; the generated table holds it as `index2` of the P852 row.
        if let Some(p852) = sew::params()
            .iter()
            .find(|p| p.index2 == Some(index::USER_UNIT_2))
        {
            let _ = store.add_second_index(index::USER_UNIT_2, p852, p852.default2);
        }
        let _ = store.set_internal(index::UNIT_TYPE, i64::from(UNIT_TYPE));
        let _ = store.set_internal(index::FIRMWARE, i64::from(FIRMWARE));
        let _ = store.set_internal(index::RATED_CURRENT, RATED_CURRENT_MA);
        let _ = store.set_internal(index::RS485_ADDRESS, i64::from(address.min(99)));
        let mut md = Movidrive {
            drive,
            po: [0; PO_WORDS],
            reset_bit: false,
            last_cyclic: None,
            held: false,
            warning: None,
            fault_ramp: QuickRamp::Rapid,
            position: 0.0,
            last_update: None,
        };
        md.held = md.rs485_timeout().is_some();
        md.update(SimTime::ZERO);
        md
    }

    // ----- identity and communication settings -----

    /// RS-485 address (P810).
    pub fn address(&self) -> u8 {
        self.param_u8(index::RS485_ADDRESS)
    }

    /// RS-485 group address (P811; 100 = no group).
    pub fn group_address(&self) -> u8 {
        self.param_u8(index::RS485_GROUP_ADDRESS)
    }

    /// RS-485 timeout time (P812, ms); `None` when 0 (monitoring off).
    pub fn rs485_timeout(&self) -> Option<Duration> {
        let ms = self.param(index::RS485_TIMEOUT);
        u64::try_from(ms)
            .ok()
            .filter(|&ms| ms > 0)
            .map(Duration::from_millis)
    }

    /// The reaction to an RS-485 timeout (P833).
    pub fn rs485_timeout_reaction(&self) -> TimeoutReaction {
        TimeoutReaction::from_raw(self.param(index::RS485_TIMEOUT_REACTION))
            .unwrap_or(TimeoutReaction::RapidStopWarning)
    }

    /// Select `source` as setpoint source (P100) and control signal source (P101), in RAM and
    /// EEPROM, as a commissioning tool would; no EEPROM write is counted. Acts at `now`.
    pub fn set_bus_control(&mut self, source: BusSource, now: SimTime) {
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::SETPOINT_SOURCE, source.setpoint_source());
        let _ = store.set_internal(index::CONTROL_SOURCE, source.control_source());
        self.update(now);
    }

    /// Whether the PO data are enabled (status word 1 bit 2): P876 = ON and P100 or P101 select
    /// a bus (RS-485, fieldbus or SBus).
    pub fn po_data_enabled(&self) -> bool {
        self.param(index::PO_DATA_ENABLE) == 1
            && (self.setpoint_from_bus() || self.control_from_bus())
    }

    // ----- parameter services -----

    /// Execute a parameter service on `index` with `data` (ignored by the read services) at
    /// `now`; the answer's 32-bit data or a return code.
    ///
    /// Values are exchanged as 32-bit two's complement; parameters whose range starts at 0 or
    /// above read `data` as unsigned. Values on a range with steps are rounded onto the step
    /// grid (e.g. P130 1005 → 1000).
    pub fn param_service(
        &mut self,
        service: ParamService,
        index: u16,
        data: u32,
        now: SimTime,
    ) -> Result<u32, ReturnCode> {
        self.update(now);
        let store = self.drive.store();
        let meta = store.meta(index, 0).map_err(ReturnCode::from_sim_error)?;
        let rc = ReturnCode::from_sim_error;
        match service {
            ParamService::Read => store.read(index, 0).map(to_data).map_err(rc),
            ParamService::Write => self.write(index, data, Persistence::NonVolatile, now),
            ParamService::WriteVolatile => self.write(index, data, Persistence::Volatile, now),
            ParamService::ReadMinimum => store
                .min_raw(index, 0)
                .map(|m| m.map_or(i32::MIN as u32, to_data))
                .map_err(rc),
            ParamService::ReadMaximum => store
                .max_raw(index, 0)
                .map(|m| m.map_or(i32::MAX as u32, to_data))
                .map_err(rc),
            ParamService::ReadDefault => store.default_raw(index, 0).map(to_data).map_err(rc),
            ParamService::ReadScale => {
                let (size, conversion) =
                    sew::by_index(index).map_or((0, 0), |p| (p.size_index, p.conversion_index));
                let conversion = i8::try_from(conversion).map_or(0xff, |c| c as u8);
                Ok(u32::from(size) << 8 | u32::from(conversion))
            }
            ParamService::ReadAttribute => {
                let next = store.keys().map(|k| k.0).find(|&i| i > index).unwrap_or(0);
                Ok(u32::from(next) << 16 | u32::from(attribute_byte(meta.access())))
            }
        }
    }

    /// [`Movidrive::param_service`] by the management byte's service ID (bits 0–3): ID 0 "no
    /// service" answers 0, undefined IDs answer [`ReturnCode::SERVICE_ERROR`].
    pub fn param_request(
        &mut self,
        service_id: u8,
        index: u16,
        data: u32,
        now: SimTime,
    ) -> Result<u32, ReturnCode> {
        match ParamService::from_id(service_id) {
            Some(service) => self.param_service(service, index, data, now),
            None if service_id == 0 => {
                self.update(now);
                Ok(0)
            }
            None => {
                self.update(now);
                Err(ReturnCode::SERVICE_ERROR)
            }
        }
    }

    /// Non-volatile writes `index` has received (EEPROM wear); `None` for an unknown index.
    pub fn nv_writes(&self, index: u16) -> Option<u64> {
        self.drive.store().nv_writes(index, 0).ok()
    }

    /// Time of the last non-volatile write of `index`; `None` for an unknown index or none yet.
    pub fn last_nv_write(&self, index: u16) -> Option<SimTime> {
        self.drive.store().last_nv_write(index, 0).ok().flatten()
    }

    // ----- process data -----

    /// Process output words PO1…PO3 received from the master at `now` (missing words keep their
    /// last value, extra words are ignored). Taken only while P876 "PO data enable" is ON; the
    /// control word acts only with P101 = bus, the speed only with P100 = bus.
    ///
    /// For a cyclic telegram call [`Movidrive::cyclic_telegram_received`] as well (after this
    /// call, so that an enable received with the first telegram takes effect at once).
    pub fn process_output(&mut self, po: &[u16], now: SimTime) {
        self.update(now);
        if self.param(index::PO_DATA_ENABLE) != 1 {
            return;
        }
        for (slot, word) in self.po.iter_mut().zip(po) {
            *slot = *word;
        }
        let cw = self.control_word();
        let reset = cw.is_some_and(|w| w & control_word::FAULT_RESET_BIT != 0);
        let edge = reset && !self.reset_bit;
        self.reset_bit = reset;
        if edge && self.control_from_bus() {
            self.fault_reset(now);
        }
        self.update(now);
    }

    /// Process input words PI1…PI3 as mapped by P873–P875 (a shorter slice gets the first
    /// words; words beyond PI3 are set to 0). Reflects the state of the last call that took a
    /// time.
    pub fn process_input(&self, pi: &mut [u16]) {
        let descriptions = [
            index::PI1_DESCRIPTION,
            index::PI1_DESCRIPTION + 1,
            index::PI1_DESCRIPTION + 2,
        ];
        for (i, word) in pi.iter_mut().enumerate() {
            *word = descriptions
                .get(i)
                .and_then(|&d| PiFunction::from_raw(self.param(d)))
                .map_or(0, |f| self.pi_word(f));
        }
    }

    /// The value of one process input function now.
    pub fn pi_word(&self, function: PiFunction) -> u16 {
        let rpm = self.drive.actual_speed();
        match function {
            PiFunction::Speed => saturate_i16(rpm / RPM_PER_DIGIT),
            PiFunction::SpeedPercent => {
                let max = self.max_speed_rpm();
                if max > 0.0 {
                    saturate_i16(rpm / max * PERCENT_100)
                } else {
                    0
                }
            }
            PiFunction::OutputCurrent => saturate_i16(self.output_current_percent() * 10.0),
            PiFunction::ActiveCurrent => saturate_i16(self.active_current_percent() * 10.0),
            PiFunction::PositionLow => (self.position_increments() & 0xffff) as u16,
            PiFunction::PositionHigh => ((self.position_increments() >> 16) & 0xffff) as u16,
            PiFunction::StatusWord1 => self.status_word_1(),
            PiFunction::StatusWord2 => self.status_word_2(),
            PiFunction::None
            | PiFunction::IposData
            | PiFunction::Reserved
            | PiFunction::StatusWord3 => 0,
        }
    }

    /// The last process output words taken.
    pub fn process_output_words(&self) -> [u16; 3] {
        self.po
    }

    // ----- RS-485 timeout -----

    /// A cyclic request telegram was received at `now`: feeds the RS-485 timeout monitor,
    /// releases the safe state held after power-on / fault reset, and ends a timeout warning
    /// (the last process data become effective again).
    pub fn cyclic_telegram_received(&mut self, now: SimTime) {
        self.update(now);
        self.last_cyclic = Some(now);
        self.held = false;
        if self.warning.is_some() {
            self.warning = None;
        }
        self.update(now);
    }

    /// Whether the drive is held in the safe state until the first cyclic request telegram
    /// (after power-on or fault reset with the RS-485 timeout monitor on; display "t").
    pub fn held_until_first_telegram(&self) -> bool {
        self.held
    }

    /// The active timeout warning, if any (warning reactions and "display fault").
    pub fn timeout_warning(&self) -> Option<TimeoutReaction> {
        self.warning
    }

    // ----- time, power -----

    /// Advance the model to `now`: RS-485 timeout monitor, control, ramp, actual values.
    pub fn tick(&mut self, now: SimTime) {
        self.update(now);
    }

    /// Power cycle at `now`: RAM ← EEPROM, controller inhibit, standstill, PO buffer cleared;
    /// held in the safe state if the RS-485 timeout monitor is on.
    pub fn restart(&mut self, now: SimTime) {
        self.drive.restart(now);
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::UNIT_TYPE, i64::from(UNIT_TYPE));
        let _ = store.set_internal(index::FIRMWARE, i64::from(FIRMWARE));
        let _ = store.set_internal(index::RATED_CURRENT, RATED_CURRENT_MA);
        self.po = [0; PO_WORDS];
        self.reset_bit = false;
        self.last_cyclic = None;
        self.warning = None;
        self.held = self.rs485_timeout().is_some();
        self.last_update = None;
        self.update(now);
    }

    // ----- status -----

    /// Status word 1: basic status block in the low byte; in the high byte the fault number
    /// while bit 5 is set, else the unit status (1 controller inhibit, 2 no enable, 4 enable).
    pub fn status_word_1(&self) -> u16 {
        let high = match self.fault_number() {
            Some(code) => code.min(0xff),
            None => u16::from(self.unit_status()),
        };
        high << 8 | self.basic_status_block()
    }

    /// Status word 2: basic status block in the low byte; high byte = virtual output terminals:
    /// bit 8 DB00 /brake (1 = brake released), bit 9 DO01 and bit 10 DO02 with their P620/P621
    /// functions (factory setting: ready, /fault); bits 11–15 0.
    pub fn status_word_2(&self) -> u16 {
        let brake_released = u16::from(self.output_stage_enabled()) << 8;
        let do01 = u16::from(self.binary_output(self.param(index::DO01))) << 9;
        let do02 = u16::from(self.binary_output(self.param(index::DO02))) << 10;
        brake_released | do01 | do02 | self.basic_status_block()
    }

    /// The fault number shown (drive fault, or a timeout warning's 43).
    pub fn fault_number(&self) -> Option<u16> {
        self.drive
            .state()
            .fault_code()
            .or(self.warning.map(|_| FAULT_RS485_TIMEOUT))
    }

    /// Whether the output stage is enabled (status word 1 bit 0): enabled, or still
    /// decelerating after stop / rapid stop / a quick-stop fault reaction; the output stage is
    /// inhibited once the motor stands still in those states.
    pub fn output_stage_enabled(&self) -> bool {
        match self.drive.state() {
            DriveState::Enabled => true,
            DriveState::Ready | DriveState::QuickStop => self.drive.motor_turning(),
            DriveState::Fault(_) => {
                self.drive.fault_reaction() == FaultReaction::QuickStop
                    && self.drive.motor_turning()
            }
            DriveState::Inhibited => false,
        }
    }

    /// Actual speed in 1/min.
    pub fn actual_speed_rpm(&self) -> f64 {
        self.drive.actual_speed()
    }

    /// Output current in % of the unit rated current (simulator model: 0 with the output stage
    /// inhibited, else 20 % + 60 % × |n| / n_max).
    pub fn output_current_percent(&self) -> f64 {
        if !self.output_stage_enabled() {
            return 0.0;
        }
        MAGNETISING_PERCENT + LOAD_PERCENT * self.speed_ratio().abs()
    }

    /// Active current in % of the unit rated current (simulator model: 60 % × n / n_max, signed).
    pub fn active_current_percent(&self) -> f64 {
        if !self.output_stage_enabled() {
            return 0.0;
        }
        LOAD_PERCENT * self.speed_ratio()
    }

    /// Actual position in increments (4096 per revolution, integrated from the speed).
    pub fn position_increments(&self) -> i32 {
        let p = self.position.round();
        if p.is_finite() {
            p.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
        } else {
            0
        }
    }

    /// The simulated drive core.
    pub fn drive(&self) -> &SimDrive {
        &self.drive
    }

    /// The simulated drive core, mutably (the profile re-applies the control word at the next
    /// call that takes a time).
    pub fn drive_mut(&mut self) -> &mut SimDrive {
        &mut self.drive
    }

    // ----- internals -----

    fn param(&self, index: u16) -> i64 {
        self.drive.store().read(index, 0).unwrap_or(0)
    }

    fn param_u8(&self, index: u16) -> u8 {
        u8::try_from(self.param(index)).unwrap_or(0)
    }

    fn setpoint_from_bus(&self) -> bool {
        matches!(self.param(index::SETPOINT_SOURCE), 2 | 3 | 10)
    }

    fn control_from_bus(&self) -> bool {
        matches!(self.param(index::CONTROL_SOURCE), 1..=3)
    }

    fn po_function(&self, slot: u16) -> Option<PoFunction> {
        PoFunction::from_raw(self.param(index::PO1_DESCRIPTION + slot))
    }

    /// The first PO word carrying `wanted`.
    fn po_word(&self, wanted: fn(PoFunction) -> bool) -> Option<u16> {
        (0..PO_WORDS as u16)
            .zip(self.po)
            .find(|(slot, _)| self.po_function(*slot).is_some_and(wanted))
            .map(|(_, w)| w)
    }

    fn control_word(&self) -> Option<u16> {
        self.po_word(|f| matches!(f, PoFunction::ControlWord1 | PoFunction::ControlWord2))
    }

    fn parameter_set_2(&self) -> bool {
        self.control_from_bus()
            && self
                .control_word()
                .is_some_and(|w| w & control_word::PARAMETER_SET_BIT != 0)
    }

    fn integrator_2(&self) -> bool {
        self.control_from_bus()
            && self
                .control_word()
                .is_some_and(|w| w & control_word::INTEGRATOR_BIT != 0)
    }

    fn max_speed_rpm(&self) -> f64 {
        let index = if self.parameter_set_2() {
            index::MAX_SPEED_2
        } else {
            index::MAX_SPEED_1
        };
        self.param(index) as f64 / 1000.0
    }

    fn speed_ratio(&self) -> f64 {
        let max = self.max_speed_rpm();
        if max > 0.0 {
            (self.drive.actual_speed() / max).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    }

    /// The speed setpoint from the process data, 1/min (0 unless P100 selects a bus).
    fn setpoint_rpm(&self) -> f64 {
        if !self.setpoint_from_bus() {
            return 0.0;
        }
        if let Some(w) = self.po_word(|f| f == PoFunction::Speed) {
            return f64::from(w as i16) * RPM_PER_DIGIT;
        }
        if let Some(w) = self.po_word(|f| f == PoFunction::SpeedPercent) {
            return f64::from(w as i16) / PERCENT_100 * self.max_speed_rpm();
        }
        0.0
    }

    /// What the control word, the safe state and a timeout warning ask for.
    fn desired(&self) -> (Command, QuickRamp) {
        if !self.control_from_bus() {
            // No binary inputs are simulated: with P101 = terminals, DI00 "/controller
            // inhibit" reads 0.
            return (Command::Inhibit, QuickRamp::Rapid);
        }
        let cw = self.control_word().unwrap_or(control_word::RAPID_STOP);
        let mut command = if cw & control_word::CONTROLLER_INHIBIT_BIT != 0 {
            Command::Inhibit
        } else if cw & control_word::NO_RAPID_STOP_BIT == 0 {
            Command::QuickStop
        } else if cw & control_word::NO_STOP_BIT == 0 {
            Command::Stop
        } else {
            Command::Enable
        };
        if self.held && command == Command::Enable {
            command = Command::Stop;
        }
        let mut ramp = QuickRamp::Rapid;
        let reaction = match self.warning {
            Some(TimeoutReaction::ImmediateStopWarning) => Some((Command::Inhibit, ramp)),
            Some(TimeoutReaction::EmergencyStopWarning) => {
                Some((Command::QuickStop, QuickRamp::Emergency))
            }
            Some(TimeoutReaction::RapidStopWarning) => Some((Command::QuickStop, ramp)),
            _ => None,
        };
        if let Some((r, r_ramp)) = reaction {
            if severity(r) >= severity(command) {
                command = r;
                ramp = r_ramp;
            }
        }
        (command, ramp)
    }

    fn ramp_config(&self, quick: QuickRamp, setpoint: f64) -> RampConfig {
        let set2 = self.parameter_set_2();
        let ms = |i: u16| Duration::from_millis(u64::try_from(self.param(i)).unwrap_or(0));
        let base = if set2 {
            index::RAMP_T21_UP_CW
        } else {
            index::RAMP_T11_UP_CW
        };
        // t11/t21 up CW, down CW, up CCW, down CCW, t12/t22 at base + 0…4;
        // t13/t23 at base + 6, t14/t24 at base + 7.
        let ccw = {
            let actual = self.drive.actual_speed();
            actual < 0.0 || (actual == 0.0 && setpoint < 0.0)
        };
        let (mut up, mut down) = if self.integrator_2() {
            (ms(base + 4), ms(base + 4))
        } else if ccw {
            (ms(base + 2), ms(base + 3))
        } else {
            (ms(base), ms(base + 1))
        };
        if let Some(w) = self.po_word(|f| f == PoFunction::Ramp) {
            up = Duration::from_millis(u64::from(w));
            down = up;
        }
        let quick_stop = match quick {
            QuickRamp::Rapid => ms(base + 6),
            QuickRamp::Emergency => ms(base + 7),
        };
        let mut limit = self.max_speed_rpm();
        if let Some(w) = self.po_word(|f| f == PoFunction::MaxSpeed) {
            let po_limit = f64::from(w as i16).abs() * RPM_PER_DIGIT;
            if po_limit > 0.0 {
                limit = limit.min(po_limit);
            }
        }
        RampConfig {
            reference_speed: 3000.0,
            acceleration: up,
            deceleration: down,
            quick_stop,
            coast: Duration::ZERO,
            speed_limit: limit,
        }
    }

    /// Bring everything up to `now`.
    fn update(&mut self, now: SimTime) {
        self.check_timeout(now);
        self.apply_control(now);
        self.drive.tick(now);
        self.publish(now);
    }

    /// Fire the RS-485 timeout at its deadline if it has passed.
    fn check_timeout(&mut self, now: SimTime) {
        let (Some(timeout), Some(last)) = (self.rs485_timeout(), self.last_cyclic) else {
            return;
        };
        if now.saturating_since(last) <= timeout {
            return;
        }
        let deadline = last + timeout;
        // Motion up to the deadline under the old control.
        self.apply_control(deadline);
        self.drive.tick(deadline);
        self.publish(deadline);
        self.last_cyclic = None;
        let reaction = self.rs485_timeout_reaction();
        match reaction {
            TimeoutReaction::NoResponse => {}
            TimeoutReaction::ImmediateStopFault
            | TimeoutReaction::EmergencyStopFault
            | TimeoutReaction::RapidStopFault => {
                let (fr, ramp) = match reaction {
                    TimeoutReaction::ImmediateStopFault => (FaultReaction::Coast, QuickRamp::Rapid),
                    TimeoutReaction::EmergencyStopFault => {
                        (FaultReaction::QuickStop, QuickRamp::Emergency)
                    }
                    _ => (FaultReaction::QuickStop, QuickRamp::Rapid),
                };
                if self.drive.state().fault_code().is_none() {
                    self.fault_ramp = ramp;
                    self.drive.set_fault_reaction(fr);
                    let cfg = self.ramp_config(ramp, self.setpoint_rpm());
                    self.drive.set_ramp_config(cfg, deadline);
                    self.drive.raise_fault(FAULT_RS485_TIMEOUT, deadline);
                    self.record_fault(FAULT_RS485_TIMEOUT);
                }
            }
            TimeoutReaction::DisplayFault
            | TimeoutReaction::ImmediateStopWarning
            | TimeoutReaction::EmergencyStopWarning
            | TimeoutReaction::RapidStopWarning => {
                self.warning = Some(reaction);
            }
        }
        self.apply_control(deadline);
    }

    /// Bring the state machine, ramps and setpoint in line with the control inputs at `now`.
    fn apply_control(&mut self, now: SimTime) {
        let state = self.drive.state();
        let (command, quick) = self.desired();
        let quick = if state.fault_code().is_some() {
            self.fault_ramp
        } else {
            quick
        };
        let rpm = self.setpoint_rpm();
        let config = self.ramp_config(quick, rpm);
        if config != *self.drive.ramp_config() {
            self.drive.set_ramp_config(config, now);
        }
        if rpm != self.drive.setpoint() {
            let _ = self.drive.set_setpoint(rpm, now);
        }
        let in_line = matches!(
            (command, state),
            (_, DriveState::Fault(_))
                | (Command::Enable, DriveState::Enabled)
                | (Command::Stop, DriveState::Ready)
                | (
                    Command::QuickStop,
                    DriveState::QuickStop | DriveState::Inhibited
                )
                | (Command::Inhibit, DriveState::Inhibited)
        );
        if !in_line {
            let _ = self.drive.command(command, now);
        }
    }

    fn fault_reset(&mut self, now: SimTime) {
        if self.drive.state().fault_code().is_some() || self.warning.is_some() {
            let _ = self.drive.fault_reset(now);
            self.warning = None;
            if self.rs485_timeout().is_some() {
                self.held = true;
                self.last_cyclic = None;
            }
        }
    }

    /// Shift the fault memory P080…P084 and enter `code` as fault t-0.
    fn record_fault(&mut self, code: u16) {
        let store = self.drive.store_mut();
        for i in (index::FAULT_T0..index::FAULT_T0 + 4).rev() {
            let older = store.read(i, 0).unwrap_or(0);
            let _ = store.set_internal(i + 1, older);
        }
        let _ = store.set_internal(index::FAULT_T0, i64::from(code));
    }

    /// Mirror actual values into the display parameters.
    fn publish(&mut self, now: SimTime) {
        let rpm = self.drive.actual_speed();
        if let Some((t, last_rpm)) = self.last_update {
            if now > t {
                let secs = now.saturating_since(t).as_secs_f64();
                self.position += (rpm + last_rpm) / 2.0 / 60.0 * secs * INC_PER_REV;
            }
        }
        let t = self.last_update.map_or(now, |(t, _)| t.max(now));
        self.last_update = Some((t, rpm));
        let current = self.output_current_percent();
        let active = self.active_current_percent();
        let status = i64::from(self.status_word_1());
        let position = i64::from(self.position_increments());
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::FREQUENCY, (rpm / 30.0 * 1000.0).round() as i64);
        let _ = store.set_internal(index::POSITION, position);
        let _ = store.set_internal(
            index::OUTPUT_CURRENT_PERCENT,
            (current * 1000.0).round() as i64,
        );
        let _ = store.set_internal(
            index::ACTIVE_CURRENT_PERCENT,
            (active * 1000.0).round() as i64,
        );
        let _ = store.set_internal(
            index::OUTPUT_CURRENT_AMPERE,
            (current / 100.0 * RATED_CURRENT_MA as f64).round() as i64,
        );
        let _ = store.set_internal(index::DC_LINK_VOLTAGE, DC_LINK_VOLTAGE_MV);
        let _ = store.set_internal(index::DRIVE_STATUS, status);
    }

    fn basic_status_block(&self) -> u16 {
        let mut w = 0;
        if self.output_stage_enabled() {
            w |= status_word::OUTPUT_STAGE_ENABLED;
        }
        if self.drive.state().fault_code().is_none() {
            w |= status_word::INVERTER_READY;
        }
        if self.po_data_enabled() {
            w |= status_word::PO_DATA_ENABLED;
        }
        if self.integrator_2() {
            w |= status_word::INTEGRATOR_2;
        }
        if self.parameter_set_2() {
            w |= status_word::PARAMETER_SET_2;
        }
        if self.fault_number().is_some() {
            w |= status_word::FAULT_WARNING;
        }
        w
    }

    fn unit_status(&self) -> u8 {
        match self.drive.state() {
            DriveState::Inhibited => status_word::STATUS_CONTROLLER_INHIBIT,
            DriveState::Enabled => status_word::STATUS_ENABLE,
            DriveState::Ready | DriveState::QuickStop | DriveState::Fault(_) => {
                status_word::STATUS_NO_ENABLE
            }
        }
    }

    /// A binary output with a P620 function (only the functions the model knows; others 0).
    fn binary_output(&self, function: i64) -> bool {
        let fault = self.fault_number().is_some();
        match function {
            1 => !fault,                                    // /fault
            2 => self.drive.state().fault_code().is_none(), // ready
            3 => self.output_stage_enabled(),               // output stage on
            4 => self.output_stage_enabled(),               // rotating field on
            5 => self.output_stage_enabled(),               // brake released
            6 => !self.output_stage_enabled(),              // brake applied
            7 => !self.drive.motor_turning(),               // motor standstill
            8 => self.parameter_set_2(),                    // parameter set
            _ => false,
        }
    }

    /// A write service: table checks in the store, then the MOVIDRIVE specifics.
    fn write(
        &mut self,
        index: u16,
        data: u32,
        persistence: Persistence,
        now: SimTime,
    ) -> Result<u32, ReturnCode> {
        let store = self.drive.store();
        let signed = store
            .min_raw(index, 0)
            .ok()
            .flatten()
            .is_none_or(|min| min < 0);
        let mut raw = if signed {
            i64::from(data as i32)
        } else {
            i64::from(data)
        };
        let row = sew::all_by_index(index).find(|p| p.index == index);
        if let Some(p) = row.filter(|p| !p.ranges.is_empty()) {
            if p.raw_range().is_some_and(|(lo, hi)| lo <= raw && raw <= hi) {
                match p.snap(raw) {
                    Some(snapped) => raw = snapped,
                    // In a gap between range segments: invalid, once access is granted.
                    None => {
                        return Err(self
                            .access_refusal(index)
                            .unwrap_or(ReturnCode::INVALID_VALUE));
                    }
                }
            }
        }
        let enumerated = row.is_some_and(|p| p.ranges.is_empty() && !p.values.is_empty());
        let result = self
            .drive
            .store_mut()
            .write(index, 0, raw, persistence, now);
        if let Err(e) = result {
            return Err(match e {
                // An enumeration's range is its value list: outside it is an invalid value.
                SimError::TooLarge { .. } | SimError::TooSmall { .. } if enumerated => {
                    ReturnCode::INVALID_VALUE
                }
                SimError::NeedsInhibit { .. } => self.inhibit_refusal(),
                other => ReturnCode::from_sim_error(other),
            });
        }
        match index {
            index::FACTORY_SETTING if raw == 1 => self.factory_setting(persistence, now),
            index::RESET_STATISTICS if raw != 0 => {
                if raw == 1 {
                    let store = self.drive.store_mut();
                    for i in index::FAULT_T0..=index::FAULT_T0 + 4 {
                        let _ = store.set_internal(i, 0);
                    }
                }
                let _ = self
                    .drive
                    .store_mut()
                    .set_internal(index::RESET_STATISTICS, 0);
            }
            _ => {}
        }
        self.update(now);
        Ok(0)
    }

    /// The answer to a write of an `R` parameter without controller inhibit: `0x0020` while the
    /// output stage is still on without enable (stop / rapid stop ramp running), else `0x001C`.
    fn inhibit_refusal(&self) -> ReturnCode {
        if self.drive.state() != DriveState::Enabled && self.output_stage_enabled() {
            ReturnCode::OUTPUT_STAGE_ENABLED
        } else {
            ReturnCode::CONTROLLER_INHIBIT_REQUIRED
        }
    }

    /// The store's access checks (read-only, lock, `R`) without a value, in the store's order.
    fn access_refusal(&self, index: u16) -> Option<ReturnCode> {
        let store = self.drive.store();
        let access = match store.meta(index, 0) {
            Ok(meta) => meta.access(),
            Err(e) => return Some(ReturnCode::from_sim_error(e)),
        };
        if !access.is_writable() {
            Some(ReturnCode::READ_ONLY)
        } else if store.is_locked() && !access.contains(Access::STORE_LOCKED) {
            Some(ReturnCode::PARAMETER_LOCK)
        } else if access.contains(Access::NEEDS_INHIBIT) && !store.condition().controller_inhibited
        {
            Some(self.inhibit_refusal())
        } else {
            None
        }
    }

    /// P802 = 1: every writable parameter back to its default, except the RS-485 address and
    /// group address (simulator choice, so the master keeps its connection); P802 returns to 0.
    fn factory_setting(&mut self, persistence: Persistence, now: SimTime) {
        let address = self.param(index::RS485_ADDRESS);
        let group = self.param(index::RS485_GROUP_ADDRESS);
        let store = self.drive.store_mut();
        store.reset_to_defaults(persistence, now);
        let _ = store.set_internal(index::RS485_ADDRESS, address);
        let _ = store.set_internal(index::RS485_GROUP_ADDRESS, group);
        let _ = store.set_internal(index::FACTORY_SETTING, 0);
    }
}

/// Order of the basic control commands by how much they take away.
const fn severity(command: Command) -> u8 {
    match command {
        Command::Enable | Command::FaultReset => 0,
        Command::Stop => 1,
        Command::QuickStop => 2,
        Command::Inhibit => 3,
    }
}

/// A raw value as 32-bit data (two's complement; values beyond 32 bits are truncated).
fn to_data(raw: i64) -> u32 {
    raw as u32
}

fn saturate_i16(v: f64) -> u16 {
    if v.is_nan() {
        return 0;
    }
    (v.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16) as u16
}
