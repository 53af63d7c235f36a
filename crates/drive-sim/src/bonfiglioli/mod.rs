//! A simulated Bonfiglioli ACTIVE (ACT) or ACTIVE Cube (ACU), wire-independent: the device that
//! the Modbus RTU/ASCII slave front-end of `bonfiglioli-modbus` puts its codec on. It speaks
//! plain numbers only: a parameter number (0…1599), a data set (0…9), a [`Width`] (function
//! codes 3/6 or 100/101) and a 32-bit value; a refusal is a [`Refusal`], which carries the
//! Modbus exception code and, for exception 4, the cause the drive puts into its VABus error
//! register (parameter 11).
//!
//! The source is the manual `bonfiglioli-active-modbus-de.txt` (ch. 6.4, 6.6, 6.9, 7, 9, 10, 11,
//! 12); where it leaves something open, this module makes a **simulator choice** and says so.
//!
//! # Parameters (ch. 6.4, 7, 11)
//!
//! * The rows of [`drive_profile::bonfiglioli::params`] in a [`ParamStore`]: defaults, ranges,
//!   access (read-only, write-only, RAM-only), decimals (values travel as raw integers, 10.3 A
//!   with one decimal is 103) and data sets.
//! * **Width.** uInt and Int travel as [`Width::Word`] (FC 3/6), Long as [`Width::Long`]
//!   (FC 100/101). For the parameters whose type the manual does not give
//!   ([`DataType::Unknown`]) the simulated drive
//!   uses [`CHOSEN_WIDTHS`] (simulator choice, one place). Words of uInt parameters (and of the
//!   chosen ones) are unsigned, of Int parameters two's complement; Longs are two's complement.
//! * **Data sets** (ch. 7): data sets 0…4 write RAM and EEPROM, 5…9 (the data set + 5) RAM only.
//!   For a parameter that exists in four data sets, 1…4 (6…9) address one data set and 0 (5)
//!   all four: a write sets all four, a read succeeds only while the four are equal (VABus 9
//!   otherwise). **Simulator choice:** a parameter that exists once accepts only data set 0
//!   (or 5); data sets 1…4 (6…9) are refused with VABus 2 "invalid data set" (ch. 7: such
//!   values "exist once (data set 0)"; the data sets of 410, 484 and 524 "are always zero").
//!   Parameters whose data sets the manual does not state count as existing once.
//!   Every data set above 9 is refused with VABus 2.
//! * **EEPROM writes** are counted per cell: a write to data set 0 of a data-set parameter is
//!   four EEPROM writes, RAM-only parameters (410, 484, 524) and data sets 5…9 none
//!   ([`SimulatedBonfiglioli::eeprom_writes`]).
//! * **Write-only:** on the ACU, 484 and 524 cannot be read (ch. 10.2.3, VABus 3). The ACT
//!   chapter (ch. 9) says no such thing, so the simulated ACT reads them back.
//!
//! # Refusals (ch. 6.4.1–6.4.4, 6.6)
//!
//! | cause | exception | register 11 |
//! |---|---|---|
//! | request width does not match the parameter's type | 2 | unchanged |
//! | unknown parameter (not in the table, or above 1599) | 4 | 11 |
//! | data set above 9, or 1…4 / 6…9 on a parameter that exists once | 4 | 2 |
//! | read of a write-only parameter (ACU 484, 524) | 4 | 3 |
//! | write of a read-only parameter | 4 | 4 |
//! | value outside the range (or a word value above 0xFFFF) | 4 | 1 |
//! | write of a "not writable in operation" parameter while the drive runs | 4 | 8 |
//! | data set 0 read while the four data sets differ | 4 | 9 |
//!
//! * **Wrong width → exception 2** (ch. 6.6 lists "Datentyp des Parameters unzutreffend" under
//!   exception 2). The register value 14 ("data type does not match the number of bytes in the
//!   telegram") is not used: the simulated drive refuses a mismatched width before it touches
//!   the parameter, as the exception-code table says, and exception 2 is what the probe of
//!   `drive_profile`'s `DataType::Unknown` (FC 3, then FC 100 on exception 2) relies on.
//!   **Simulator choice**; the register is set only with exception 4, as ch. 6.6 describes it.
//! * **Unknown parameter → exception 4, VABus 11**, as the manual's examples 8.1.3/8.2.3 answer
//!   a read of parameter 1600; ch. 6.4.x and 6.6 list "Parameter unbekannt" under exception 2
//!   (`docs/errata-bonfiglioli.md`, E5, unresolved). **Simulator choice**: the examples are what
//!   the drive was seen to send, and it keeps exception 2 unambiguous for a wrong width.
//! * Reading parameter 11 returns the register and clears it (ch. 6.6). Every exception-4
//!   refusal overwrites it with its cause.
//! * Register-count and byte-count errors (exceptions 2 and 3) are framing matters of the
//!   front-end and never reach this model.
//!
//! # Control (ch. 9, 10), watchdog (ch. 6.9), faults and warnings (ch. 12)
//!
//! See [Control details](self#control-details) below and the method docs; in short: *Local/Remote*
//! 412 of the active data set (414, 249) selects contacts (0), the state machine through control
//! word 410 (1) or remote contacts (2); status word 411 is built from the state, ACU bit 4
//! (mains), bit 7 (warnings 270), bit 9 (remote) and bit 10 (setpoint reached, hysteresis 549 of
//! 419); line setpoint 484 drives a linear frequency ramp when *ramp setpoint* 434 includes it;
//! actual frequency is 241 and 210; faults show in 260, warnings in 270; watchdog 413 trips
//! F2010.
//!
//! ## Control details
//!
//! * **State machine (412 = 1)**, per the command tables of ch. 9.1.2 / 10.2 (bits 0…3 and 7):
//!   disable voltage (bit 1 = 0) → switch-on disabled (7, 9, 10, 12); quick stop (bit 2 = 0) →
//!   quick stop active from operation enabled (11), switch-on disabled from ready to switch on
//!   and switched on (7, 10; ACU table, ACT by erratum E6); shutdown (xxx0 with bits 1, 2 set)
//!   → ready to switch on (2, 6, 8); switch on (0111 or 1111) → switched on (3); enable
//!   operation 0x0F → operation enabled (4), also straight from switch-on disabled (the ACT
//!   shortcut 4, the ACU's 4' unless *configuration* 30 is x40); 0x07 in operation enabled →
//!   transition 5 per 392. The control word is a level: the drive keeps applying it, so 0x0F
//!   written in "ready to switch on" passes 3 and then 4.
//! * **Enable conditions.** ACT: transition 4 needs S1IND and (S2IND or S3IND) (ch. 9.1.2). ACU:
//!   STOA and STOB and (S2IND "start clockwise" or S3IND "start anticlockwise"), or STOA and
//!   STOB alone with positioning (30 = x40) (ch. 10.2); transitions 3 and 4' need mains voltage
//!   (status bit 4). Taking the hardware enable away in operation switches the output stage off
//!   at once (the motor coasts) and the drive goes to switched on (ch. 9.1.2).
//! * **Transition 5** (392 of the active data set): 0 free coast, immediately switched on;
//!   1 DC brake for *braking time* 632, control words are not acted on meanwhile, then switched
//!   on; 2 ramp: down on the deceleration ramp, switched on once the frequency is below the
//!   switch-off threshold 637 (% of *maximum frequency* 419) for *holding time* 638; 0x0F during
//!   the ramp resumes.
//! * **Quick stop**: down on *emergency stop clockwise* 424 (positive frequency) or
//!   *anticlockwise* 425; below the threshold 637 for the holding time 638, the drive changes to
//!   switch-on disabled (ch. 9.1.2.1: it stays energised "until the holding time has passed …
//!   so that the drive stands at the change of state"; the target state is DRIVECOM's
//!   transition 12; simulator reading).
//! * **Fault reset** on a rising edge of control word bit 7 in 412 = 1, acted on only 15 s or
//!   more after the fault (ch. 9.1.2: "erst 15 Sekunden nach dem Auftreten der Störung"); an
//!   edge earlier is ignored and a new edge is needed. A reset goes to switch-on disabled and
//!   clears 260. In the other modes [`SimulatedBonfiglioli::keypad_reset`] acknowledges.
//! * **Contacts (412 = 0)**: the drive runs while the hardware enable and S2IND (clockwise) or S3IND (anticlockwise, the
//!   setpoint negated) are on, status 0x27, and otherwise shows switched on 0x23, ramping down
//!   on the deceleration ramp (coasting when the enable is gone).
//!   **Remote contacts (412 = 2)**: as contacts, with control word bits 0…2 as S1IND…S3IND;
//!   enabling needs bit 0 *and* the hardware enable (ch. 9.1.3, 10.1). Parameter 250 shows the
//!   remote contacts only while both are on. **Every other value of 412** (3…44, the KP500
//!   keypad modes, 44 the factory setting) is "local": nothing starts the drive, it shows
//!   switched on 0x23 (simulator choice; the keypad is not simulated).
//! * **Setpoints**: 484 (Hz, 2 decimals) is the line setpoint; *ramp setpoint* 434 = 2 or 3 puts
//!   it on the ramp (the internal reference channel, 228, is 0 in the simulator), 1 does not.
//!   The setpoint is limited to ± *maximum frequency* 419 (282 shows 484, 283 the ramp input).
//!   The f_min limit of 434 = 2 is not modelled (no f_min parameter in the table). 524 (%) is
//!   shown in 229 and moves nothing (it feeds technology/torque functions).
//! * **Ramps** (simulator choice, the acceleration/deceleration parameters are not in this
//!   manual): [`RAMP_HZ_PER_S`] up and down; quick stop per 424/425.
//! * **Watchdog 413** (s, 0 = off): when no [`valid_exchange`](SimulatedBonfiglioli::valid_exchange)
//!   arrives for 413 seconds, the drive trips with F2010 (coasting); the time counts from the
//!   last valid exchange, from the write that set 413, or from the first tick.
//!   The front-end calls `valid_exchange` for every frame it accepts; reads and writes of this
//!   model do not feed the watchdog by themselves.
//! * The model passes "fault reaction active" over: a fault is at once "fault" (0x08) with the
//!   output stage off.
//!
//! Time is always an argument ([`Instant`]); nothing reads a clock. Timed conditions (holding
//! time, DC brake, watchdog, reset lockout) are evaluated at [`SimulatedBonfiglioli::tick`] and
//! at every read and write, so their resolution is the caller's tick interval.
//!
//! # Example
//!
//! ```
//! use std::time::Duration;
//! use drive_sim::Instant;
//! use drive_sim::bonfiglioli::{SimulatedBonfiglioli, Variant, Width};
//!
//! let mut drive = SimulatedBonfiglioli::new(Variant::Acu);
//! let t0 = Instant::ZERO;
//! drive.write(412, 0, Width::Word, 1, t0)?; // Local/Remote: state machine
//! drive.write(484, 0, Width::Long, 1000, t0)?; // 10.00 Hz
//! drive.write(410, 0, Width::Word, 0x0F, t0)?; // enable operation (transition 4')
//! assert_eq!(drive.read(411, 0, Width::Word, t0)? & 0x6F, 0x27); // operation enabled
//! let t1 = t0 + Duration::from_secs(2); // 5.00 Hz/s
//! assert_eq!(drive.read(241, 0, Width::Long, t1)?, 1000); // actual frequency 10.00 Hz
//! // A 16-bit read of a 32-bit parameter: exception 2.
//! assert_eq!(drive.read(241, 0, Width::Word, t1).unwrap_err().exception(), 2);
//! # Ok::<(), drive_sim::bonfiglioli::Refusal>(())
//! ```

use core::fmt;

use drive_profile::bonfiglioli::{self, DataType, Param, ParamAccess};

use crate::error::SimError;
use crate::ramp::Ramp;
use crate::store::{ParamStore, Persistence, StoreOptions};
use drive_core::Instant;

mod control;

pub use control::{RAMP_HZ_PER_S, RESET_LOCKOUT};

/// Fault key of "communication watchdog RS232/RS485" (F2010, ch. 6.9, 12.2).
pub const FAULT_WATCHDOG: u16 = 0x2010;

/// Which drive is simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// ACTIVE (ch. 9): hardware enable S1IND, status word bit 4 always 0.
    Act,
    /// ACTIVE Cube (ch. 10): hardware enable STOA and STOB, status word bit 4 = mains voltage,
    /// 484 and 524 write-only.
    Acu,
}

/// The width of a parameter access: the function codes a request uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Width {
    /// 16 bit: function codes 3 (read) and 6 (write); uInt and Int parameters.
    Word,
    /// 32 bit: function codes 100 (read) and 101 (write); Long parameters.
    Long,
}

impl fmt::Display for Width {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Width::Word => "16-bit (function codes 3/6)",
            Width::Long => "32-bit (function codes 100/101)",
        })
    }
}

/// A hardware input of the simulated drive (the terminals, not the bus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Input {
    /// ACT: digital input S1IND, the external (hardware) enable (ch. 9).
    S1ind,
    /// Digital input S2IND: start clockwise.
    S2ind,
    /// Digital input S3IND: start anticlockwise.
    S3ind,
    /// ACU: safe torque off channel A (STOA, S1IND, X210A.3), hardware enable (ch. 10).
    Stoa,
    /// ACU: safe torque off channel B (STOB, S7IND, X210B.2), hardware enable (ch. 10).
    Stob,
    /// ACU: mains voltage present (status word bit 4; the ACU may run its control electronics
    /// on an external 24 V supply, ch. 10.1).
    Mains,
}

/// The cause of an exception-4 refusal, as the drive puts it into the VABus error register,
/// parameter 11 (ch. 6.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum VabusCause {
    /// 1 "Unzulässiger Parameterwert".
    #[error("value out of range")]
    ValueOutOfRange,
    /// 2 "Unzulässiger Datensatz".
    #[error("invalid data set")]
    InvalidDataSet,
    /// 3 "Parameter nicht lesbar (nur schreibbar)".
    #[error("parameter is write-only")]
    WriteOnly,
    /// 4 "Parameter nicht schreibbar (nur lesbar)".
    #[error("parameter is read-only")]
    ReadOnly,
    /// 6 "Schreibfehler EEPROM".
    #[error("EEPROM write error")]
    EepromWrite,
    /// 8 "Parameter kann nicht geschrieben werden, während der Antrieb läuft".
    #[error("not writable while the drive is running")]
    NotWhileRunning,
    /// 9 "Werte der Datensätze unterscheiden sich voneinander".
    #[error("the data sets hold different values")]
    DataSetsDiffer,
    /// 11 "Unbekannter Parameter".
    #[error("unknown parameter")]
    UnknownParameter,
    /// 15 "Unbekannter Fehler".
    #[error("unknown error")]
    Unknown,
}

impl VabusCause {
    /// The value of parameter 11.
    pub const fn code(self) -> u16 {
        match self {
            VabusCause::ValueOutOfRange => 1,
            VabusCause::InvalidDataSet => 2,
            VabusCause::WriteOnly => 3,
            VabusCause::ReadOnly => 4,
            VabusCause::EepromWrite => 6,
            VabusCause::NotWhileRunning => 8,
            VabusCause::DataSetsDiffer => 9,
            VabusCause::UnknownParameter => 11,
            VabusCause::Unknown => 15,
        }
    }

    /// The table entry of `drive_profile` (German and English meaning).
    pub fn meaning(self) -> Option<&'static bonfiglioli::VabusError> {
        bonfiglioli::vabus_error(self.code())
    }
}

/// A refusal as the drive gives it (see the module docs for which cause gives which).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// Exception 2 "illegal data address": the request's width does not match the parameter's
    /// data type. Parameter 11 is not changed.
    #[error("parameter {param} is {actual}, not {requested}")]
    WrongWidth {
        /// The parameter number.
        param: u16,
        /// The width of the request.
        requested: Width,
        /// The parameter's width.
        actual: Width,
    },
    /// Exception 4 "slave device failure"; the cause is in parameter 11.
    #[error("slave device failure: {0}")]
    Device(VabusCause),
}

impl Refusal {
    /// The Modbus exception code: 2 or 4.
    pub const fn exception(&self) -> u8 {
        match self {
            Refusal::WrongWidth { .. } => 2,
            Refusal::Device(_) => 4,
        }
    }

    /// The value the drive puts into parameter 11 (exception 4 only).
    pub const fn vabus(&self) -> Option<u16> {
        match self {
            Refusal::WrongWidth { .. } => None,
            Refusal::Device(cause) => Some(cause.code()),
        }
    }
}

/// The widths the simulated drive gives the parameters whose data type the manual leaves open
/// (simulator choice, **not** a fact of the manual). Every such parameter of the table is
/// listed (a test checks it). All of them are 16-bit unsigned words: their ranges fit 16 bit
/// (none exceeds 10000), and the manual uses Long only for frequencies, percentages with two
/// decimals and ramp rates, which all have a stated or inferred type.
pub const CHOSEN_WIDTHS: &[(u16, Width)] = &[
    (10, Width::Word),   // baud rate, 1…6
    (11, Width::Word),   // VABus error register, 0…15
    (30, Width::Word),   // configuration, e.g. 110, 210, x40
    (34, Width::Word),   // program, 0…9999
    (68, Width::Word),   // start clockwise (signal source, an operation mode number)
    (69, Width::Word),   // start anticlockwise (signal source)
    (249, Width::Word),  // active data set, 1…4
    (250, Width::Word),  // digital inputs, 0…255
    (392, Width::Word),  // transition 5, 0…2
    (394, Width::Word),  // node ID, 1…30
    (395, Width::Word),  // protocol type, 0…3
    (412, Width::Word),  // local/remote, 0…44
    (413, Width::Word),  // watchdog, 0…10000 s
    (414, Width::Word),  // data set selection, 0…4
    (415, Width::Word),  // IDC compensation limit
    (434, Width::Word),  // ramp setpoint, 1…3
    (475, Width::Word),  // reference frequency source (an operation mode number)
    (476, Width::Word),  // reference percentage source (an operation mode number)
    (506, Width::Word),  // brake chopper trigger threshold
    (507, Width::Word),  // motor chopper trigger threshold
    (549, Width::Word),  // max. control deviation, 0.01…20.00 %
    (632, Width::Word),  // braking time, 0.0…200.0 s
    (637, Width::Word),  // switch-off threshold, 0.0…100.0 %
    (638, Width::Word),  // holding time, 0.0…200.0 s
    (680, Width::Word),  // DC link limitation reference
    (1375, Width::Word), // Modbus parity, 0…2
    (1376, Width::Word), // Modbus address, 1…247
];

/// Start values where the table gives no default (or one outside its own range), as the
/// simulated drive ships (simulator choice; raw values).
pub const SIM_DEFAULTS: &[(u16, i64)] = &[
    (30, 110),   // configuration 110, sensorless U/f (the manual's example; allows 392 = 1)
    (372, 1390), // rated speed 1390 1/min: what example 8.1.1 reads from data set 2
    (375, 5000), // rated frequency 50.00 Hz
    (376, 15),   // rated mechanical power 1.5 kW: what example 8.1.2 writes
    (394, 1),    // node ID (range 1…30)
    (419, 5000), // maximum frequency 50.00 Hz
    (424, 1000), // emergency stop clockwise 10.00 Hz/s
    (425, 1000), // emergency stop anticlockwise 10.00 Hz/s
    (481, 1000), // fixed frequency 2 10.00 Hz: what example 8.1.3 reads
    (549, 100),  // max. control deviation 1.00 %
    (632, 10),   // braking time 1.0 s
    (637, 10),   // switch-off threshold 1.0 % of 419
    (638, 10),   // holding time 1.0 s
];

/// The width the simulated drive uses for parameter `number` (`None`: no such parameter).
pub fn width_of(number: u16) -> Option<Width> {
    let p = bonfiglioli::by_number(number)?;
    match p.data_type {
        DataType::UInt | DataType::Int => Some(Width::Word),
        DataType::Long => Some(Width::Long),
        _ => CHOSEN_WIDTHS
            .iter()
            .find(|(n, _)| *n == number)
            .map(|(_, w)| *w),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Inputs {
    s1ind: bool,
    s2ind: bool,
    s3ind: bool,
    stoa: bool,
    stob: bool,
    mains: bool,
}

/// The stopping phase of transition 5 or quick stop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stopping {
    /// Not stopping.
    None,
    /// Transition 5 with the ramp (392 = 2).
    Ramp,
    /// Transition 5 with the DC brake (392 = 1), until the given time.
    DcBrake(Instant),
}

/// A simulated ACT or ACU (see the module docs).
pub struct SimulatedBonfiglioli {
    variant: Variant,
    store: ParamStore,
    ramp: Ramp,
    state: bonfiglioli::State,
    error_register: u16,
    inputs: Inputs,
    control_word: u16,
    fault: u16,
    fault_since: Option<Instant>,
    warnings: u16,
    stopping: Stopping,
    hold_since: Option<Instant>,
    watch_from: Option<Instant>,
    last_tick: Option<Instant>,
}

impl fmt::Debug for SimulatedBonfiglioli {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SimulatedBonfiglioli")
            .field("variant", &self.variant)
            .field("state", &self.state)
            .field("control_word", &self.control_word)
            .field("fault", &self.fault)
            .field("warnings", &self.warnings)
            .field("actual_hz", &self.ramp.actual())
            .field("error_register", &self.error_register)
            .finish_non_exhaustive()
    }
}

impl SimulatedBonfiglioli {
    /// A drive after power-on: switch-on disabled, standstill, *Local/Remote* 412 = 44 (the
    /// factory setting: not bus-controlled), table defaults plus [`SIM_DEFAULTS`]. The hardware
    /// enables (S1IND, or STOA and STOB), S2IND "start clockwise" and the ACU's mains voltage
    /// are on, as on a wired-up drive; switch them with [`SimulatedBonfiglioli::set_input`].
    pub fn new(variant: Variant) -> SimulatedBonfiglioli {
        let options = StoreOptions {
            data_sets: 4,
            ..StoreOptions::default()
        };
        let mut store = ParamStore::with_options(bonfiglioli::params(), options);
        for (number, raw) in SIM_DEFAULTS {
            // Every listed number is in the table (a test checks it); a missing one is skipped.
            let _ = store.set_internal(*number, *raw);
        }
        SimulatedBonfiglioli {
            variant,
            store,
            ramp: Ramp::default(),
            state: bonfiglioli::State::SwitchOnDisabled,
            error_register: 0,
            inputs: Inputs {
                s1ind: true,
                s2ind: true,
                s3ind: false,
                stoa: true,
                stob: true,
                mains: true,
            },
            control_word: 0,
            fault: 0,
            fault_since: None,
            warnings: 0,
            stopping: Stopping::None,
            hold_since: None,
            watch_from: None,
            last_tick: None,
        }
    }

    /// The simulated variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// Read parameter `param` of data set `data_set` with a request of `width`, at `now`
    /// (the drive is advanced to `now` first). The value is the raw 16 bits (zero-extended) or
    /// 32 bits as they travel on the wire.
    pub fn read(
        &mut self,
        param: u16,
        data_set: u8,
        width: Width,
        now: Instant,
    ) -> Result<u32, Refusal> {
        self.tick(now);
        let result = self.read_inner(param, data_set, width);
        self.note(result)
    }

    /// Write `value` (raw, as it travels: the low 16 bits for [`Width::Word`]) to parameter
    /// `param` of data set `data_set` at `now`. Data sets 0…4 write RAM and EEPROM, 5…9 RAM
    /// only. A refused write changes nothing but parameter 11.
    pub fn write(
        &mut self,
        param: u16,
        data_set: u8,
        width: Width,
        value: u32,
        now: Instant,
    ) -> Result<(), Refusal> {
        self.tick(now);
        let result = self.write_inner(param, data_set, width, value, now);
        let result = self.note(result);
        if result.is_ok() {
            self.after_write(param, now);
        }
        result
    }

    /// The VABus error register (parameter 11) without clearing it.
    pub fn error_register(&self) -> u16 {
        self.error_register
    }

    /// EEPROM writes so far, over all parameters and data sets (for the wear tests).
    pub fn eeprom_writes(&self) -> u64 {
        self.store.total_nv_writes()
    }

    /// EEPROM writes of one parameter's data set (1…4 for a data-set parameter, 0 otherwise).
    pub fn eeprom_writes_of(&self, param: u16, data_set: u8) -> Option<u64> {
        self.store.nv_writes(param, u16::from(data_set)).ok()
    }

    /// The parameter store (values, EEPROM values, counters) for inspection.
    pub fn store(&self) -> &ParamStore {
        &self.store
    }

    /// Power cycle at `now`: RAM ← EEPROM (RAM-only values and data sets 5…9 writes are lost),
    /// switch-on disabled, standstill, fault and register cleared.
    pub fn restart(&mut self, now: Instant) {
        self.store.restart();
        self.ramp.reset(now);
        self.state = bonfiglioli::State::SwitchOnDisabled;
        self.error_register = 0;
        self.control_word = 0;
        self.fault = 0;
        self.fault_since = None;
        self.stopping = Stopping::None;
        self.hold_since = None;
        self.watch_from = Some(now);
        self.last_tick = Some(now);
        let _ = self.store.set_internal(410, 0);
        self.sync_condition();
    }

    fn note<T>(&mut self, result: Result<T, Refusal>) -> Result<T, Refusal> {
        if let Err(Refusal::Device(cause)) = &result {
            self.error_register = cause.code();
        }
        result
    }

    /// The table row, the data-set sub-index and whether the data set writes EEPROM.
    fn resolve(
        &self,
        param: u16,
        data_set: u8,
        width: Width,
    ) -> Result<(&'static Param, u16, Persistence), Refusal> {
        let row = bonfiglioli::by_number(param)
            .filter(|_| param <= 1599)
            .ok_or(Refusal::Device(VabusCause::UnknownParameter))?;
        let actual = width_of(param).ok_or(Refusal::Device(VabusCause::UnknownParameter))?;
        if actual != width {
            return Err(Refusal::WrongWidth {
                param,
                requested: width,
                actual,
            });
        }
        if data_set > 9 {
            return Err(Refusal::Device(VabusCause::InvalidDataSet));
        }
        let (sub, persistence) = if data_set >= 5 {
            (u16::from(data_set - 5), Persistence::Volatile)
        } else {
            (u16::from(data_set), Persistence::NonVolatile)
        };
        self.store.meta(param, sub).map_err(device)?;
        Ok((row, sub, persistence))
    }

    fn read_inner(&mut self, param: u16, data_set: u8, width: Width) -> Result<u32, Refusal> {
        let (row, sub, _) = self.resolve(param, data_set, width)?;
        if self.write_only(row) {
            return Err(Refusal::Device(VabusCause::WriteOnly));
        }
        let raw = match self.live_value(param) {
            Some(v) => v,
            None => self.store.read(param, sub).map_err(device)?,
        };
        if param == 11 {
            self.error_register = 0;
        }
        Ok(match width {
            Width::Word => u32::from(raw as u16),
            Width::Long => raw as i32 as u32,
        })
    }

    fn write_inner(
        &mut self,
        param: u16,
        data_set: u8,
        width: Width,
        value: u32,
        now: Instant,
    ) -> Result<(), Refusal> {
        let (row, sub, persistence) = self.resolve(param, data_set, width)?;
        let raw = match width {
            Width::Word => {
                let word = u16::try_from(value)
                    .map_err(|_| Refusal::Device(VabusCause::ValueOutOfRange))?;
                if row.data_type == DataType::Int {
                    i64::from(word as i16)
                } else {
                    i64::from(word)
                }
            }
            Width::Long => i64::from(value as i32),
        };
        self.store
            .write(param, sub, raw, persistence, now)
            .map_err(device)
    }

    fn write_only(&self, row: &Param) -> bool {
        row.access == ParamAccess::WriteOnly && self.variant == Variant::Acu
    }
}

/// The register cause of a store refusal.
fn device(e: SimError) -> Refusal {
    Refusal::Device(match e {
        SimError::UnknownIndex { .. } => VabusCause::UnknownParameter,
        SimError::UnknownSubIndex { .. } => VabusCause::InvalidDataSet,
        SimError::ReadOnly { .. } | SimError::Locked { .. } => VabusCause::ReadOnly,
        SimError::TooLarge { .. }
        | SimError::TooSmall { .. }
        | SimError::ValueNotAllowed { .. } => VabusCause::ValueOutOfRange,
        SimError::NeedsInhibit { .. } | SimError::NotInOperation { .. } => {
            VabusCause::NotWhileRunning
        }
        SimError::DataSetsDiffer { .. } => VabusCause::DataSetsDiffer,
        SimError::EepromWornOut { .. } => VabusCause::EepromWrite,
        _ => VabusCause::Unknown,
    })
}
