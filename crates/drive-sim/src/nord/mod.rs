//! A simulated NORD NORDAC LINK SK 270E-FDS / SK 280E-FDS field distributor, wire-independent:
//! the drive behind the AS-i double slave that the CTT2 and USS front-ends of `ctt2-uss` put
//! their codecs on. It speaks plain numbers only: a PNU, an array element and a parameter set
//! for the parameter channel (PKW), a control word and up to three setpoints for the process
//! data (PZD), and the five BusIO In / six BusIO Out bits of the double slave. A refused
//! parameter order is a [`PkwRefusal`], which carries the PWE2 error number of the AK 7 answer.
//!
//! The source is the manual `nord-nordac-link-asi-ctt2-de.txt` (BU 0255, chapters 3 to 6) with
//! the corrections of `docs/errata-nord.md`. Where the manual leaves something open, this
//! module makes a **simulator choice** and says so. The function codes of P480, P481, P543 and
//! P546 are the drive's digital input/output and bus-value functions from the public NORD
//! documentation (BU 0250); the simulated drive implements a small subset
//! ([`input_function`], [`output_function`], [`actual_value_function`],
//! [`setpoint_function`]). **Check these numbers against BU 0250 on a real drive** before
//! relying on them.
//!
//! # Parameters (ch. 4.6, 6)
//!
//! * Every row of [`drive_profile::nord::params`]. A parameter-set parameter
//!   ([`Param::parameter_set`]) has four independent values, `set` 0…3 = parameter sets 1…4. An
//!   array has [`Param::array_len`] elements, `element` 0-based (IND "0 = Arrayelement 1",
//!   `[-01]` = element 0). A parameter that is neither accepts only element 0 and set 0; any
//!   other address is refused with [`PkwRefusal::WrongSubindex`] (3).
//! * Values are 16-bit words (ch. 6: only positions are double words, and the table has none),
//!   so [`SimulatedNord::is_double_word`] is `Some(false)` for every parameter and a
//!   double-word write ([`SimulatedNord::write_width`] with [`Width::DoubleWord`], AK 3, 8, 11,
//!   13) is refused with [`PkwRefusal::InvalidDataType`] (5). Values are signed: a front-end
//!   passes PWE as an `i32` (PWE1 high word, PWE2 low word; negative values have FFFFh in PWE1,
//!   ch. 4.6.1.3). The range is the table's `raw_range`, else [`SIM_RANGES`], else the `i16`
//!   range; a value outside it is refused with [`PkwRefusal::LimitExceeded`] (2).
//! * Read-only rows (the information parameters P7xx) are refused with
//!   [`PkwRefusal::NotChangeable`] (1), except P701 (below).
//! * Start values: the table's defaults, and [`SIM_DEFAULTS`] where the table has none
//!   (P102 = 2.00 s, P509 = 5 "AS-i" so that the bus controls the drive, the BusIO functions,
//!   P543/P546 …). P105 is 50.0 Hz (table default), P112 401 "off".
//! * **Information parameters** show live data ([`SimulatedNord::read`]):
//!   * P700 `[-01]` present fault number (0 = none), `[-02]` present warning number
//!     ([`SimulatedNord::set_warning`]), `[-03]` reason for switch-on disabled as a simulator
//!     code ([`switch_on_disabled_reason`]; the real drive's codes are in BU 0250).
//!   * P701 `[-01]`…`[-05]`: fault memory, most recent first. **Simulator choice:** the fault
//!     memory survives [`SimulatedNord::restart`], and writing 0 to any element clears it (the
//!     simulator's "only resettable" parameter, so error 6 exists); any other value is refused
//!     with [`PkwRefusal::OnlyResettable`] (6). Clearing counts no EEPROM write.
//!   * P740 "process data bus in": the last control word received, valid (bit 10) or not, so a
//!     missing bit 10 can be diagnosed. P741 "process data bus out": the present status word.
//!     The table has both as single words (no array), so the setpoints and actual values are
//!     not shown. Both read 0 while P509 = 0 (ch. 6: "no display when P509 = 0").
//!   * P744 configuration level: the constant [`CONFIGURATION_LEVEL`] (simulator value).
//!
//! # EEPROM (ch. 4.1.2, 4.6; P560)
//!
//! * A write with `eeprom = true` (AK 2, 3, 7, 8) goes to RAM and, while P560 = 1 (the
//!   default), to EEPROM too, counted per cell ([`SimulatedNord::eeprom_writes_of`]). While
//!   P560 = 0 it goes to RAM only and counts nothing. A write with `eeprom = false` (AK 11…14)
//!   never touches EEPROM.
//! * **Simulator choice:** P560 itself is always written through to EEPROM by an
//!   `eeprom = true` write (whatever its old or new value), so that "RAM only" survives a power
//!   cycle as the user who selected it expects. Its range is 0…1 ([`SIM_RANGES`]).
//! * [`SimulatedNord::restart`] (power cycle) reloads RAM from EEPROM: RAM-only changes are
//!   lost.
//!
//! # Process data (ch. 4.5)
//!
//! * **Control word bit 10** must be set, or the whole telegram is ignored (no state change, no
//!   setpoint taken); the status word is still answered and P740 still shows the word.
//! * **Control source P509:** 5 "AS-i" (the simulator's default) = the control word drives the
//!   state machine of ch. 4.5.3. Any other value = control through the BusIO bits (the manual's
//!   recommendation for "control through AS-i bits", section 6): the enable functions of P480
//!   act like the control word (below), control words are then used only for their setpoints.
//!   **Simulator choice:** P510 (setpoint source) is not modelled: the setpoints of every valid
//!   telegram are taken, whatever P509 says, so a master can run the drive with a BusIO enable
//!   bit and a CTT2 setpoint. Setpoints a telegram does not carry keep their last value.
//! * **State machine:** the transitions of [`drive_profile::nord::transitions`] (1…15 and
//!   erratum E14's 12F). The control word is a level: the drive keeps applying it, so 047Fh in
//!   "ready to switch on" passes transition 3 and then 4. The table's bit patterns already make
//!   the commands of one state mutually exclusive in the priority order of ch. 4.5.1 (disable
//!   voltage, quick stop, shutdown, enable operation, switch on, disable operation, fault
//!   reset); a test checks that no word matches two transitions.
//!   * 1 A → B at power-on (and at [`SimulatedNord::restart`]); the simulated charging relay
//!     closes at once.
//!   * 8 "Stillsetzen" from operation enabled: the drive stays in operation enabled and ramps
//!     down with the braking time; at f = 0 Hz it switches the voltage off and shows ready to
//!     switch on. A control word that asks for operation again (047Fh) during the ramp-down
//!     resumes. 6 from switched on is immediate: the output is off there, f = 0 Hz already.
//!   * 5, 9, 10, 12 and a fault switch the output voltage off at once: the output frequency is
//!     0 Hz at once (the motor coasts; the simulator models the inverter's output, not the
//!     shaft).
//!   * 11 quick stop: ramps down with [`QUICK_STOP_TIME`], then 12F to switch-on disabled at
//!     0 Hz (erratum E14). 7b and 10b (quick stop without output voltage) are immediate.
//!   * 13 [`SimulatedNord::raise_fault`] → fault reaction active (G); 14 after
//!     [`FAULT_REACTION_TIME`] → fault (H); 15 a 0 → 1 edge of control bit 7 (bus control) or
//!     of a BusIO bit with function "fault acknowledgement" (any control source; each input's
//!     own edge counts) → switch-on disabled. The first valid control word counts as following
//!     a word with bit 7 = 0. The cause is always gone in the simulator. An edge during the fault reaction
//!     is ignored. A fault while G or H is active is ignored.
//!   * [`SimulatedNord::transition_log`] lists the transitions taken, by the table's ids.
//! * **Setpoint:** the first setpoint whose P546 function is 1 "setpoint frequency" (default
//!   SW1) in percent, 4000h = 100 % of P105 of the active parameter set, limited to ±P105.
//!   Direction: bit 12 = 1 counter-clockwise (the setpoint negated), else clockwise (footnote 3:
//!   bit 12 = 0 means "rotation right" whatever bit 11 says). Bit 6 = 0 sets the setpoint to
//!   0 (ramp down with the braking time), bit 5 = 0 holds the present frequency, bit 4 = 0 sets
//!   the ramp generator to 0 at once (the output frequency is 0 at once, the drive stays
//!   enabled); bit 4 wins over 5, 5 over 6.
//! * **Ramps:** P102 of the active parameter set is the time for 0 → P105 (acceleration).
//!   **Simulator choice:** the braking time (P103 in BU 0250, not in this table) equals P102;
//!   quick stop takes [`QUICK_STOP_TIME`] for P105 → 0 (BU 0250's P426).
//! * **Parameter set:** control bits 14/15 of the last valid control word select the active set
//!   at once (bus control only; set 1 under BusIO control); status bits 14/15 report it.
//! * **Status word** (ch. 4.5.2): bits 0…6 from the state's pattern; the bits a pattern leaves
//!   open (4 and 5 in A, B, G, H) show whether a "disable voltage" / "quick stop" command is
//!   present (control bits 1/2 or a BusIO function; before the first control word none is, so
//!   power-on shows 0B70h as in example 5.1.1). Bit 7 warning present; bit 8 the output
//!   frequency equals the ramp's target (also at standstill with target 0, as 0B70h and 0B31h
//!   show); bit 9 P509 = 5; bits 10 and 13 the P481 `[-09]` / `[-10]` output functions; bit 11
//!   / 12 the rotating field of the output: from the sign of the frequency, at standstill from
//!   the selected direction (0B70h shows bit 11 at standstill); bits 14/15 the active set.
//! * **Actual values** IW1…IW3 per P543 `[-01]`…`[-03]` ([`actual_value_function`]): actual
//!   and setpoint frequency in percent of P105; current in percent of P112 (401 "off" counts as
//!   400 %), simulated as 30 % of the reference with the output on, 60 % while the frequency
//!   ramps; the fault number; the position in increments as low and high word, so a master
//!   can read a 32-bit position across IW2/IW3 (ch. 4.5.4).
//! * **Position** (simulator choice): a 4-pole motor (2 pole pairs, slip ignored) with
//!   [`INCREMENTS_PER_REVOLUTION`] increments per revolution, integrated from the output
//!   frequency at every tick (trapezoid), limited to ±50000 revolutions (ch. 4.5.4). The value
//!   sent is increments × P607 / P608 (ch. 4.5.4: the ratio extends the range, the resolution
//!   drops); both default to 1 and are limited to 1…32767. A power cycle resets it to 0;
//!   [`SimulatedNord::set_position`] presets it.
//!
//! # BusIO bits (ch. 3.2, 3.3)
//!
//! * In (master → drive), [`SimulatedNord::set_busio_in`]: bits 0…3 are the 1st slave's D0…D3,
//!   bit 4 the 2nd slave's bit; their functions are P480 `[-01]`…`[-05]`. Control word bits 8
//!   and 9 are two more inputs with the functions P480 `[-11]` / `[-12]` (taken from the last
//!   valid control word).
//! * Out (drive → master), [`SimulatedNord::busio_out`]: bits 0…3 the 1st slave's, bits 4…5 the
//!   2nd slave's; their functions are P481 `[-01]`…`[-06]`; P481 `[-09]` / `[-10]` give status
//!   bits 10 and 13.
//! * **Precedence (simulator choice, as NORD's terminal functions):** the enable functions
//!   (1 right, 2 left) act only while P509 ≠ 5; with exactly one of them on, the drive runs up
//!   (switch-on disabled → ready → switched on → operation enabled by itself), with none (or
//!   both) it stops as with "Stillsetzen" (braking ramp, then ready to switch on). "Disable
//!   voltage" (10) and "quick stop" (11) are **active low** (an input at 0 commands them) and
//!   act in every mode, on top of the control word (they clear control bits 1 / 2). "Fault
//!   acknowledgement" (12) resets on a rising edge in every mode. Unknown function numbers
//!   (the real drive has many more) are accepted and do nothing.
//! * Defaults ([`SIM_DEFAULTS`]): In bit 1 enable right, bit 2 enable left, bit 3 fault
//!   acknowledgement, bits 4 and 5 no function (an active-low function by default would stop
//!   a drive whose master has not yet sent its bits). Out bit 1 drive ready (states C, D, E),
//!   bit 2 fault (active low: 1 = no fault), bit 3 drive running (output voltage on: E, F),
//!   bit 4 warning, bits 5 and 6 no function.
//!
//! Time is always an argument ([`Instant`]); nothing reads a clock. Every call with a `now`
//! advances the drive to `now` first; timed effects (ramps, fault reaction, 0 Hz transitions)
//! resolve at the caller's tick interval, and time going backwards counts as none.
//!
//! # Example
//!
//! ```
//! use std::time::Duration;
//! use drive_profile::nord::State;
//! use drive_sim::Instant;
//! use drive_sim::nord::SimulatedNord;
//!
//! let t0 = Instant::ZERO;
//! let mut drive = SimulatedNord::new();
//! assert_eq!(drive.status_word(), 0x0B70); // example 5.1.1: switch-on disabled
//! drive.process(0x047E, &[0x0000], t0); // shutdown
//! assert_eq!(drive.status_word(), 0x0B31); // ready to switch on
//! drive.process(0x047F, &[0x2000], t0); // enable operation, SW1 = 50 %
//! drive.tick(t0 + Duration::from_secs(1)); // P102 = 2.00 s for 0 → 50 Hz
//! assert_eq!(drive.state(), State::OperationEnabled);
//! assert_eq!(drive.status_word(), 0x0B37); // example 5.1.2
//! assert_eq!(drive.actual_values()[0], 0x2000); // IW1 = 50 %
//!
//! drive.write(102, 0, 2, 1000, true, t0)?; // P102 = 10.00 s in parameter set 3 (example 5.1.3)
//! assert_eq!(drive.read(102, 0, 2, t0)?, 1000);
//! assert_eq!(drive.eeprom_writes_of(102, 0, 2), Some(1));
//! # Ok::<(), drive_sim::nord::PkwRefusal>(())
//! ```
//!
//! [`Param::parameter_set`]: drive_profile::nord::Param::parameter_set
//! [`Param::array_len`]: drive_profile::nord::Param::array_len

mod control;
mod params;
mod settings;
#[cfg(test)]
mod tests;

use core::fmt;
use std::collections::VecDeque;
use std::time::Duration;

use drive_profile::nord::{self, PweError, State};

pub use drive_profile::nord::Width;

use crate::error::SimError;
use crate::ramp::Ramp;
use crate::store::{ParamStore, Persistence, StoreOptions};
use drive_core::Instant;

use params::sub;
use settings::Settings;

/// The BusIO In / control-bit functions of P480 the simulated drive implements (the drive's
/// digital-input functions, public NORD documentation BU 0250; check on a real drive).
pub mod input_function {
    /// No function.
    pub const NONE: i64 = 0;
    /// Enable, clockwise (acts while P509 ≠ 5).
    pub const ENABLE_RIGHT: i64 = 1;
    /// Enable, counter-clockwise (acts while P509 ≠ 5).
    pub const ENABLE_LEFT: i64 = 2;
    /// Disable voltage, active low (0 = command present).
    pub const DISABLE_VOLTAGE: i64 = 10;
    /// Quick stop, active low (0 = command present).
    pub const QUICK_STOP: i64 = 11;
    /// Fault acknowledgement on a rising edge.
    pub const FAULT_ACK: i64 = 12;
}

/// The BusIO Out / status-bit functions of P481 the simulated drive implements (the drive's
/// digital-output functions, public NORD documentation BU 0250; check on a real drive).
pub mod output_function {
    /// No function (always 0).
    pub const NONE: i64 = 0;
    /// Drive running: output voltage on (operation enabled, quick stop active).
    pub const RUNNING: i64 = 2;
    /// Fault, active low: 1 = no fault, 0 = fault reaction active or fault.
    pub const FAULT: i64 = 7;
    /// Warning present.
    pub const WARNING: i64 = 8;
    /// Drive ready: ready to switch on, switched on or operation enabled.
    pub const READY: i64 = 18;
}

/// The actual-value functions of P543 the simulated drive implements (public NORD
/// documentation BU 0250; check on a real drive). Other values send 0.
pub mod actual_value_function {
    /// Off: the word is 0.
    pub const OFF: i64 = 0;
    /// Actual frequency, percent of P105 (4000h = 100 %).
    pub const ACTUAL_FREQUENCY: i64 = 1;
    /// Current, percent of P112.
    pub const CURRENT: i64 = 3;
    /// Setpoint frequency (the ramp's target), percent of P105.
    pub const SETPOINT_FREQUENCY: i64 = 8;
    /// Present fault number.
    pub const FAULT_NUMBER: i64 = 9;
    /// Actual position in increments, low word.
    pub const POSITION_LOW: i64 = 10;
    /// Actual position in increments, high word.
    pub const POSITION_HIGH: i64 = 15;
}

/// The setpoint functions of P546 the simulated drive implements (public NORD documentation
/// BU 0250; check on a real drive). Other values are ignored.
pub mod setpoint_function {
    /// Off: the setpoint is ignored.
    pub const OFF: i64 = 0;
    /// Setpoint frequency, percent of P105 (4000h = 100 %).
    pub const SETPOINT_FREQUENCY: i64 = 1;
}

/// The simulator's codes in P700 `[-03]` "reason for switch-on disabled" (simulator values;
/// the real drive's codes are in BU 0250).
pub mod switch_on_disabled_reason {
    /// The drive is not in switch-on disabled.
    pub const NONE: i32 = 0;
    /// Waiting for "Stillsetzen" (transition 2): after power-on, a fault reset, or a command
    /// that is no longer present.
    pub const AWAITING_SHUTDOWN: i32 = 1;
    /// "Disable voltage" is commanded (control bit 1 = 0 or a BusIO input).
    pub const DISABLE_VOLTAGE: i32 = 2;
    /// "Quick stop" is commanded (control bit 2 = 0 or a BusIO input).
    pub const QUICK_STOP: i32 = 3;
}

/// Start values where the table has none, as the simulated drive ships (simulator choice):
/// `(parameter number, element (0-based), raw value)`; a parameter-set parameter gets the value
/// in all four sets.
pub const SIM_DEFAULTS: &[(u16, u8, i64)] = &[
    (102, 0, 200), // acceleration time 2.00 s
    (480, 0, input_function::ENABLE_RIGHT),
    (480, 1, input_function::ENABLE_LEFT),
    (480, 2, input_function::FAULT_ACK),
    (481, 0, output_function::READY),
    (481, 1, output_function::FAULT),
    (481, 2, output_function::RUNNING),
    (481, 3, output_function::WARNING),
    (509, 0, 5), // control word source: AS-i (CTT2), so the bus controls the drive
    (543, 0, actual_value_function::ACTUAL_FREQUENCY),
    (543, 1, actual_value_function::CURRENT),
    (543, 2, actual_value_function::SETPOINT_FREQUENCY),
    (546, 0, setpoint_function::SETPOINT_FREQUENCY),
    (607, 0, 1), // gear ratio 1 : 1
    (608, 0, 1),
];

/// Ranges where the table has none and the `i16` range does not fit (simulator choice):
/// `(parameter number, min, max)`.
pub const SIM_RANGES: &[(u16, i64, i64)] = &[
    (560, 0, 1),     // 0 RAM only, 1 RAM and EEPROM
    (607, 1, 32767), // a zero ratio would lose the position
    (608, 1, 32767), // divisor
];

/// Quick stop: the time for P105 → 0 Hz (simulator choice; BU 0250's P426).
pub const QUICK_STOP_TIME: Duration = Duration::from_millis(100);

/// How long "fault reaction active" lasts before the drive shows "fault" (simulator choice).
pub const FAULT_REACTION_TIME: Duration = Duration::from_millis(50);

/// Increments per motor revolution of the simulated encoder (ch. 4.5.4: at most 1000).
pub const INCREMENTS_PER_REVOLUTION: i64 = 1000;

/// Pole pairs of the simulated motor (4-pole: 1500 1/min at 50 Hz, slip ignored).
pub const POLE_PAIRS: f64 = 2.0;

/// The value of P744 "configuration level" (simulator value without a meaning).
pub const CONFIGURATION_LEVEL: i32 = 1;

/// Entries of the fault memory P701.
const FAULT_MEMORY: usize = 5;

/// Transitions kept by the log.
const LOG_LEN: usize = 64;

/// Why the drive refuses a parameter order: the error number it puts into PWE2 of an AK 7
/// answer (ch. 4.6.1.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum PkwRefusal {
    /// 0 "Unzulässige Parameternummer": no parameter has this PNU.
    #[error("invalid parameter number")]
    InvalidParameter,
    /// 1 "Parameterwert nicht änderbar": the parameter is read-only.
    #[error("parameter value cannot be changed")]
    NotChangeable,
    /// 2 "Untere oder obere Wertgrenze überschritten": the value is out of range.
    #[error("lower or upper value limit exceeded")]
    LimitExceeded,
    /// 3 "Fehlerhafter Subindex": array element or parameter set out of range.
    #[error("wrong sub-index")]
    WrongSubindex,
    /// 4 "Kein Array": the number of elements was asked of a parameter that is no array.
    #[error("not an array")]
    NotArray,
    /// 5 "Unzulässiger Datentyp": a double word for a word parameter.
    #[error("invalid data type")]
    InvalidDataType,
    /// 6 "Nur rücksetzbar": only 0 may be written.
    #[error("only resettable (only 0 may be written)")]
    OnlyResettable,
}

impl PkwRefusal {
    /// The error number sent in PWE2 (0…6).
    pub const fn number(self) -> u16 {
        match self {
            PkwRefusal::InvalidParameter => 0,
            PkwRefusal::NotChangeable => 1,
            PkwRefusal::LimitExceeded => 2,
            PkwRefusal::WrongSubindex => 3,
            PkwRefusal::NotArray => 4,
            PkwRefusal::InvalidDataType => 5,
            PkwRefusal::OnlyResettable => 6,
        }
    }

    /// The manual's table entry of the error number (German and English meaning).
    pub fn meaning(self) -> Option<&'static PweError> {
        nord::pwe_error(self.number())
    }
}

/// The refusal of a store error.
fn refusal(e: SimError) -> PkwRefusal {
    match e {
        SimError::UnknownIndex { .. } => PkwRefusal::InvalidParameter,
        SimError::UnknownSubIndex { .. } => PkwRefusal::WrongSubindex,
        SimError::TooLarge { .. }
        | SimError::TooSmall { .. }
        | SimError::ValueNotAllowed { .. } => PkwRefusal::LimitExceeded,
        // Read-only, and the store checks the simulated NORD drive does not use (lock,
        // controller inhibit, EEPROM endurance): the value cannot be changed.
        _ => PkwRefusal::NotChangeable,
    }
}

/// A simulated NORDAC LINK SK 270E/280E-FDS (see the module docs).
pub struct SimulatedNord {
    store: ParamStore,
    /// What the process-data path reads of `store`, refreshed whenever it changes.
    settings: Settings,
    ramp: Ramp,
    state: State,
    /// The last valid control word (bit 10 set); `None` before the first.
    stw: Option<u16>,
    /// The last control word received, valid or not (P740).
    bus_in: u16,
    setpoints: [u16; 3],
    busio_in: u8,
    /// Transition 8 is under way: ramping down before "ready to switch on".
    stopping: bool,
    fault: u16,
    fault_at: Option<Instant>,
    warning: u16,
    fault_memory: [u16; FAULT_MEMORY],
    /// Position in increments.
    position: f64,
    log: VecDeque<&'static str>,
}

impl fmt::Debug for SimulatedNord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SimulatedNord")
            .field("state", &self.state)
            .field("control_word", &self.stw)
            .field("setpoints", &self.setpoints)
            .field("busio_in", &self.busio_in)
            .field("fault", &self.fault)
            .field("warning", &self.warning)
            .field("actual_hz", &self.ramp.actual())
            .field("position", &self.position)
            .finish_non_exhaustive()
    }
}

impl Default for SimulatedNord {
    fn default() -> SimulatedNord {
        SimulatedNord::new()
    }
}

impl SimulatedNord {
    /// A drive after power-on: transition 1 taken (switch-on disabled), standstill, no control
    /// word yet, BusIO In bits 0, table defaults plus [`SIM_DEFAULTS`] (P509 = 5: the bus
    /// controls the drive).
    pub fn new() -> SimulatedNord {
        let options = StoreOptions {
            eeprom_for_unflagged: true,
            ..StoreOptions::default()
        };
        let store = ParamStore::from_rows(params::rows(), options);
        let mut drive = SimulatedNord {
            settings: Settings::load(&store),
            store,
            ramp: Ramp::default(),
            state: State::NotReadyToSwitchOn,
            stw: None,
            bus_in: 0,
            setpoints: [0; 3],
            busio_in: 0,
            stopping: false,
            fault: 0,
            fault_at: None,
            warning: 0,
            fault_memory: [0; FAULT_MEMORY],
            position: 0.0,
            log: VecDeque::new(),
        };
        drive.power_on();
        drive
    }

    /// Transition 1: the charging relay closes at once.
    fn power_on(&mut self) {
        self.state = State::NotReadyToSwitchOn;
        self.enter(State::SwitchOnDisabled, "1");
    }

    /// Read element `element` (0-based) of parameter set `set` (0…3) of parameter `pnu` at
    /// `now` (the drive is advanced to `now` first). Information parameters show live data.
    pub fn read(
        &mut self,
        pnu: u16,
        element: u8,
        set: u8,
        now: Instant,
    ) -> Result<i32, PkwRefusal> {
        self.tick(now);
        params::address(pnu, element, set)?;
        match self.live_value(pnu, element) {
            Some(v) => Ok(v),
            None => self
                .stored(pnu, element, set)
                .ok_or(PkwRefusal::InvalidParameter),
        }
    }

    /// Write a word (AK 2, 7, 12, 14): [`SimulatedNord::write_width`] with [`Width::Word`].
    /// `eeprom = false` is the AK 11…14 "without writing to EEPROM" orders.
    pub fn write(
        &mut self,
        pnu: u16,
        element: u8,
        set: u8,
        value: i32,
        eeprom: bool,
        now: Instant,
    ) -> Result<(), PkwRefusal> {
        self.write_width(pnu, element, set, Width::Word, value, eeprom, now)
    }

    /// Write `value` with an order of `width` at `now`. Checks, in order: PNU (0), element and
    /// set (3), width (5), P701 only resettable (6), read-only (1), range (2). A refused write
    /// changes nothing. Where it goes: see the module docs (P560).
    #[allow(clippy::too_many_arguments)]
    pub fn write_width(
        &mut self,
        pnu: u16,
        element: u8,
        set: u8,
        width: Width,
        value: i32,
        eeprom: bool,
        now: Instant,
    ) -> Result<(), PkwRefusal> {
        self.tick(now);
        params::address(pnu, element, set)?;
        if width != Width::Word {
            return Err(PkwRefusal::InvalidDataType);
        }
        if pnu == 701 {
            if value != 0 {
                return Err(PkwRefusal::OnlyResettable);
            }
            self.fault_memory = [0; FAULT_MEMORY];
            return Ok(());
        }
        let persistence = if eeprom && (pnu == 560 || self.element(560, 0) != 0) {
            Persistence::NonVolatile
        } else {
            Persistence::Volatile
        };
        self.store
            .write(pnu, sub(element, set), i64::from(value), persistence, now)
            .map_err(refusal)?;
        self.settings = Settings::load(&self.store);
        self.evaluate(now);
        Ok(())
    }

    /// The number of array elements (AK 9): [`PkwRefusal::NotArray`] (4) for a parameter that
    /// is no array, [`PkwRefusal::InvalidParameter`] (0) for an unknown PNU.
    pub fn array_len(&self, pnu: u16) -> Result<u8, PkwRefusal> {
        let p = nord::by_index(pnu).ok_or(PkwRefusal::InvalidParameter)?;
        p.array_len.ok_or(PkwRefusal::NotArray)
    }

    /// Whether parameter `pnu` travels as a double word: `Some(false)` for every parameter of
    /// the table (ch. 6: words; only positions are double words and the table has none),
    /// `None` for an unknown PNU.
    pub fn is_double_word(&self, pnu: u16) -> Option<bool> {
        nord::by_index(pnu).map(|_| false)
    }

    /// EEPROM writes so far, over all cells (for the wear tests).
    pub fn eeprom_writes(&self) -> u64 {
        self.store.total_nv_writes()
    }

    /// EEPROM writes of one cell; `None` for an address that does not exist.
    pub fn eeprom_writes_of(&self, pnu: u16, element: u8, set: u8) -> Option<u64> {
        params::address(pnu, element, set).ok()?;
        self.store.nv_writes(pnu, sub(element, set)).ok()
    }

    /// The value the drive works with (RAM; live data for the information parameters);
    /// `None` for an address that does not exist.
    pub fn ram_value(&self, pnu: u16, element: u8, set: u8) -> Option<i32> {
        params::address(pnu, element, set).ok()?;
        self.live_value(pnu, element)
            .or_else(|| self.stored(pnu, element, set))
    }

    /// The value held in EEPROM (what a restart restores); `None` for an address that does not
    /// exist and for the read-only information parameters, which have no EEPROM value.
    pub fn eeprom_value(&self, pnu: u16, element: u8, set: u8) -> Option<i32> {
        params::address(pnu, element, set).ok()?;
        let cell = sub(element, set);
        if !self.store.has_eeprom(pnu, cell).ok()? {
            return None;
        }
        self.store.read_eeprom(pnu, cell).ok().map(|v| v as i32)
    }

    /// Power cycle at `now`: RAM ← EEPROM (RAM-only changes are lost), transition 1 to
    /// switch-on disabled, standstill, position 0, no control word, setpoints 0, fault and
    /// warning cleared. The fault memory P701 and the BusIO In bits (the master keeps sending
    /// them) are kept; write counters too.
    pub fn restart(&mut self, now: Instant) {
        self.store.restart();
        self.settings = Settings::load(&self.store);
        self.ramp.reset(now);
        self.stw = None;
        self.bus_in = 0;
        self.setpoints = [0; 3];
        self.stopping = false;
        self.fault = 0;
        self.fault_at = None;
        self.warning = 0;
        self.position = 0.0;
        self.power_on();
        self.evaluate(now);
    }

    /// The transitions taken, oldest first, by the ids of
    /// [`drive_profile::nord::transitions`] (`"1"`, `"7a"`, `"12F"` …); the last 64 are kept.
    pub fn transition_log(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.log.iter().copied()
    }

    /// Move to `to` by transition `id`.
    fn enter(&mut self, to: State, id: &'static str) {
        self.state = to;
        self.stopping = false;
        if self.log.len() >= LOG_LEN {
            self.log.pop_front();
        }
        self.log.push_back(id);
    }

    /// The stored RAM value of a cell.
    fn stored(&self, pnu: u16, element: u8, set: u8) -> Option<i32> {
        self.store
            .read(pnu, sub(element, set))
            .ok()
            .map(|v| v as i32)
    }

    /// Element `element` of a parameter that is not set-dependent (0 where missing).
    fn element(&self, number: u16, element: u8) -> i64 {
        self.settings
            .element(number, element)
            .unwrap_or_else(|| self.store.read(number, sub(element, 0)).unwrap_or(0))
    }

    /// A parameter-set parameter in the active set (0 where missing).
    fn active(&self, number: u16) -> i64 {
        let set = self.active_set_index();
        self.settings
            .in_set(number, set)
            .unwrap_or_else(|| self.store.read(number, sub(0, set)).unwrap_or(0))
    }

    /// Live values of the information parameters; `None` for stored parameters.
    fn live_value(&self, pnu: u16, element: u8) -> Option<i32> {
        let shown = self.element(509, 0) != 0;
        Some(match pnu {
            700 => match element {
                0 => i32::from(self.fault),
                1 => i32::from(self.warning),
                _ => self.switch_on_disabled_reason(),
            },
            701 => i32::from(
                self.fault_memory
                    .get(usize::from(element))
                    .copied()
                    .unwrap_or(0),
            ),
            740 if shown => i32::from(self.bus_in),
            741 if shown => i32::from(self.status_word()),
            740 | 741 => 0,
            744 => CONFIGURATION_LEVEL,
            _ => return None,
        })
    }
}
