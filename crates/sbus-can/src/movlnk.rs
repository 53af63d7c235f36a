//! The IPOSplus command MOVLNK (`_Movilink(MI)`, manual ch. 5.3) as typed data, and
//! [`MovlnkMaster`]: a drive executing it as SBus master towards other nodes.
//!
//! An IPOSplus program fills two variable blocks (32-bit signed variables `H…`):
//!
//! | variable | name | values |
//! |---|---|---|
//! | H | `MI.BusType` | 1 = S0 (RS-485 #1), 2 = S1 (RS-485 #2), 5 = SBus; 0, 3, 4 reserved |
//! | H + 1 | `MI.Address` | 0–63, or 100–163 = 100 + SBus group address |
//! | H + 2 | `MI.Format` | 0 Param + 1PD, 1 1PD, 2 Param + 2PD, 3 2PD, 4 Param + 3PD, 5 3PD, 6 Param |
//! | H + 3 | `MI.Service` | 1 read, 2 write (non-volatile), 3 write without storing |
//! | H + 4 | `MI.Index` | the parameter index |
//! | H + 5 | `MI.DPointer` | number of the variable H' where the data block starts |
//! | H + 6 | `MI.Result` | "error code or 0" (encoding: [`MovlnkError::result_code`]) |
//!
//! and the data block at H' (`MLDATA`): `WritePar`, `ReadPar`, `PO1`–`PO3`, `PI1`–`PI3`.
//!
//! On SBus a command becomes at most two exchanges, done one after the other: the parameter
//! request (8a + 515, answered on 8a + 516) when the format has a parameter part, then the
//! process output data (8a + 3, answered with PI on 8a + 4) when it has process data. To a
//! group (100–163) the same go out as group telegrams (8g + 518, 8g + 6), unanswered; a read
//! to a group is refused. SBus always carries three process data words (ch. 5.1): the words
//! the format leaves out are sent as 0, and only the format's PI words are stored back.
//!
//! After the command, `ReadPar` holds the parameter answer and `PI1`… the process input
//! words, each only if its exchange succeeded (ch. 5.3: "falls kein Fehler bei der Übertragung
//! auftritt"); `Result` is 0 or the first error. Process data words are stored unsigned
//! (0–65535, the raw word); PO values must fit a word as unsigned or signed (−32768–65535),
//! anything else is refused, never cut.
//!
//! **Single master.** "Der Movilink-Befehl ist nicht multimaster-fähig": while a MOVLNK
//! command runs there may be only one master on the whole network (the manual points to SCOM
//! for multi-master exchanges). [`MovlnkMaster`] takes answers by identifier as any SBus master
//! does; a second master asking the same drive at the same time makes answers ambiguous.

use core::fmt;
use core::time::Duration;

use drive_core::Instant;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_profile::sew::{ParamChannel, ReturnCode, Service};

use crate::ids::Address;
use crate::master::{Answer, MasterConfig, MasterError, MasterEvent, SbusMaster};
use crate::telegram::ProcessData;

/// The interface a MOVLNK command uses (`MI.BusType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BusType {
    /// 1: S0, RS-485 interface #1 (MOVILINK).
    S0,
    /// 2: S1, RS-485 interface #2 (MOVILINK).
    S1,
    /// 5: SBus.
    SBus,
}

impl BusType {
    /// The value of `MI.BusType`.
    pub const fn code(self) -> i32 {
        match self {
            BusType::S0 => 1,
            BusType::S1 => 2,
            BusType::SBus => 5,
        }
    }
}

/// Whom a MOVLNK command addresses (`MI.Address`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// 0–63: one drive's SBus address.
    Single(Address),
    /// 100–163: 100 + an SBus group address.
    Group(Address),
}

impl Target {
    /// The value of `MI.Address`.
    pub const fn code(self) -> i32 {
        match self {
            Target::Single(a) => a.get() as i32,
            Target::Group(g) => 100 + g.get() as i32,
        }
    }
}

/// The telegram layout of a MOVLNK command (`MI.Format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// 0: parameter and 1 process data word.
    Param1Pd,
    /// 1: 1 process data word.
    Pd1,
    /// 2: parameter and 2 process data words.
    Param2Pd,
    /// 3: 2 process data words.
    Pd2,
    /// 4: parameter and 3 process data words.
    Param3Pd,
    /// 5: 3 process data words.
    Pd3,
    /// 6: parameter only.
    Param,
}

impl Format {
    /// The format of `MI.Format` = `code`.
    pub const fn from_code(code: i32) -> Option<Format> {
        Some(match code {
            0 => Format::Param1Pd,
            1 => Format::Pd1,
            2 => Format::Param2Pd,
            3 => Format::Pd2,
            4 => Format::Param3Pd,
            5 => Format::Pd3,
            6 => Format::Param,
            _ => return None,
        })
    }

    /// The value of `MI.Format`.
    pub const fn code(self) -> i32 {
        match self {
            Format::Param1Pd => 0,
            Format::Pd1 => 1,
            Format::Param2Pd => 2,
            Format::Pd2 => 3,
            Format::Param3Pd => 4,
            Format::Pd3 => 5,
            Format::Param => 6,
        }
    }

    /// Whether a parameter service is part of it.
    pub const fn has_param(self) -> bool {
        matches!(
            self,
            Format::Param1Pd | Format::Param2Pd | Format::Param3Pd | Format::Param
        )
    }

    /// Process data words exchanged (0–3).
    pub const fn pd_words(self) -> usize {
        match self {
            Format::Param1Pd | Format::Pd1 => 1,
            Format::Param2Pd | Format::Pd2 => 2,
            Format::Param3Pd | Format::Pd3 => 3,
            Format::Param => 0,
        }
    }
}

/// The parameter service of a MOVLNK command (`MI.Service`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MovlnkService {
    /// 1: read the parameter.
    Read,
    /// 2: write and store non-volatile.
    Write,
    /// 3: write without storing (volatile).
    WriteVolatile,
}

impl MovlnkService {
    /// The value of `MI.Service`.
    pub const fn code(self) -> i32 {
        match self {
            MovlnkService::Read => 1,
            MovlnkService::Write => 2,
            MovlnkService::WriteVolatile => 3,
        }
    }

    /// The parameter channel's service.
    pub const fn service(self) -> Service {
        match self {
            MovlnkService::Read => Service::Read,
            MovlnkService::Write => Service::Write,
            MovlnkService::WriteVolatile => Service::WriteVolatile,
        }
    }
}

/// The highest IPOSplus variable number (H0–H1023).
pub const MAX_VARIABLE: i32 = 1023;

/// Variables of the data block (`MLDATA`): WritePar, ReadPar, PO1–PO3, PI1–PI3.
pub const DATA_VARIABLES: i32 = 8;

/// Variables of the command block (`MOVILINK`): H … H + 6.
pub const COMMAND_VARIABLES: usize = 7;

/// A MOVLNK command structure (`MI`), checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MovlnkCommand {
    /// `MI.BusType`.
    pub bus_type: BusType,
    /// `MI.Address`.
    pub target: Target,
    /// `MI.Format`.
    pub format: Format,
    /// `MI.Service`.
    pub service: MovlnkService,
    /// `MI.Index`.
    pub index: u16,
    /// `MI.DPointer`: the variable number of the data block.
    pub dpointer: u16,
}

impl MovlnkCommand {
    /// The command of the variables H … H + 6 (`MI.Result`, the last, is not read).
    ///
    /// ```
    /// use sbus_can::movlnk::{BusType, Format, MovlnkCommand};
    /// // Manual ch. 5.3: SBus, address 1, Param + 3PD, read, index 8318, data at H20.
    /// let cmd = MovlnkCommand::from_vars([5, 1, 4, 1, 8318, 20, 0]).unwrap();
    /// assert_eq!((cmd.bus_type, cmd.format, cmd.index), (BusType::SBus, Format::Param3Pd, 8318));
    /// assert!(MovlnkCommand::from_vars([3, 1, 4, 1, 8318, 20, 0]).is_err()); // reserved bus
    /// ```
    pub fn from_vars(vars: [i32; COMMAND_VARIABLES]) -> Result<MovlnkCommand, MovlnkError> {
        let [bus, address, format, service, index, dpointer, _result] = vars;
        let bus_type = match bus {
            1 => BusType::S0,
            2 => BusType::S1,
            5 => BusType::SBus,
            other => return Err(MovlnkError::BusType(other)),
        };
        let target = match address {
            0..=63 => Address::new(address as u8).map(Target::Single),
            100..=163 => Address::new((address - 100) as u8).map(Target::Group),
            _ => None,
        }
        .ok_or(MovlnkError::Address(address))?;
        let format = Format::from_code(format).ok_or(MovlnkError::Format(format))?;
        let service = match service {
            1 => MovlnkService::Read,
            2 => MovlnkService::Write,
            3 => MovlnkService::WriteVolatile,
            other => return Err(MovlnkError::Service(other)),
        };
        let index = u16::try_from(index).map_err(|_| MovlnkError::Index(index))?;
        let dpointer = match dpointer {
            0..=1016 => dpointer as u16,
            other => return Err(MovlnkError::DPointer(other)),
        };
        let cmd = MovlnkCommand {
            bus_type,
            target,
            format,
            service,
            index,
            dpointer,
        };
        if matches!(target, Target::Group(_))
            && service == MovlnkService::Read
            && format.has_param()
        {
            return Err(MovlnkError::ReadFromGroup);
        }
        Ok(cmd)
    }

    /// The variables H … H + 6 with `MI.Result` = `result`.
    pub fn to_vars(&self, result: i32) -> [i32; COMMAND_VARIABLES] {
        [
            self.bus_type.code(),
            self.target.code(),
            self.format.code(),
            self.service.code(),
            i32::from(self.index),
            i32::from(self.dpointer),
            result,
        ]
    }

    /// The parameter request's channel (`WritePar` as the data of a write), if the format has
    /// a parameter part.
    pub fn param_request(&self, data: &MlData) -> Option<ParamChannel> {
        self.format.has_param().then(|| {
            let value = match self.service {
                MovlnkService::Read => 0,
                _ => data.write_par as u32,
            };
            ParamChannel::request(self.service.service(), self.index, value)
        })
    }

    /// The process output words (PO1… of the format, 0 for the words it leaves out), if the
    /// format has process data; a PO value outside −32768–65535 is refused.
    pub fn process_output(&self, data: &MlData) -> Result<Option<ProcessData>, MovlnkError> {
        let n = self.format.pd_words();
        if n == 0 {
            return Ok(None);
        }
        let mut words = [0u16; 3];
        for (i, (w, v)) in words.iter_mut().zip(data.po).enumerate().take(n) {
            *w = match v {
                0..=65535 => v as u16,
                -32768..=-1 => v as i16 as u16,
                _ => {
                    return Err(MovlnkError::ProcessOutput {
                        word: i as u8 + 1,
                        value: v,
                    });
                }
            };
        }
        Ok(Some(ProcessData(words)))
    }
}

/// The data block of a MOVLNK command (`MLDATA`, variables H' … H' + 7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct MlData {
    /// H': the value a write sends.
    pub write_par: i32,
    /// H' + 1: the value a read got.
    pub read_par: i32,
    /// H' + 2 … H' + 4: PO1–PO3.
    pub po: [i32; 3],
    /// H' + 5 … H' + 7: PI1–PI3.
    pub pi: [i32; 3],
}

impl MlData {
    /// The block of the 8 variables H' … H' + 7.
    pub const fn from_vars(v: [i32; 8]) -> MlData {
        let [write_par, read_par, po1, po2, po3, pi1, pi2, pi3] = v;
        MlData {
            write_par,
            read_par,
            po: [po1, po2, po3],
            pi: [pi1, pi2, pi3],
        }
    }

    /// The 8 variables.
    pub const fn to_vars(&self) -> [i32; 8] {
        let [po1, po2, po3] = self.po;
        let [pi1, pi2, pi3] = self.pi;
        [self.write_par, self.read_par, po1, po2, po3, pi1, pi2, pi3]
    }
}

/// Why a MOVLNK command failed; [`MovlnkError::result_code`] is what goes into `MI.Result`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MovlnkError {
    /// `MI.BusType` is reserved (0, 3, 4) or undefined.
    BusType(i32),
    /// `MI.Address` is neither 0–63 nor 100–163.
    Address(i32),
    /// `MI.Format` is not 0–6.
    Format(i32),
    /// `MI.Service` is not 1–3.
    Service(i32),
    /// `MI.Index` is not 0–65535.
    Index(i32),
    /// `MI.DPointer`: the data block H' … H' + 7 does not fit in H0–H1023.
    DPointer(i32),
    /// A PO word's value does not fit 16 bits.
    ProcessOutput {
        /// 1–3.
        word: u8,
        /// The variable's value.
        value: i32,
    },
    /// A read service to a group address: group telegrams are never answered.
    ReadFromGroup,
    /// The bus type is an RS-485 interface; this executor drives SBus only.
    NotSbus(BusType),
    /// The drive answered the parameter service with a return code.
    Drive(ReturnCode),
    /// No answer in any attempt.
    Timeout,
    /// A command is already running.
    Busy,
}

impl MovlnkError {
    /// `MI.Result` for a timeout.
    pub const RESULT_TIMEOUT: i32 = -1;
    /// `MI.Result` for a command structure the executor refuses (any of the checks).
    pub const RESULT_BAD_COMMAND: i32 = -2;
    /// `MI.Result` for a PO value that does not fit a word.
    pub const RESULT_PO_RANGE: i32 = -3;
    /// `MI.Result` for a bus type other than SBus.
    pub const RESULT_NOT_SBUS: i32 = -4;
    /// `MI.Result` for a drive return code whose 32 bits would read as 0 or as one of the codes
    /// above (class byte ≥ 80h, or an error answer with all-zero data).
    pub const RESULT_UNREADABLE_CODE: i32 = -16;

    /// The value of `MI.Result`: 0 is success (never returned here); a drive's return code is
    /// its 32 bits as in the parameter channel (error class, error code, additional code high
    /// and low; e.g. 08000010h = 134217744 for an illegal index), always positive for the
    /// defined classes 1–8; errors of the executor are negative: −1 timeout, −2 invalid command
    /// structure, −3 PO value out of range, −4 not SBus, −16 a drive code that would not read
    /// as positive.
    pub const fn result_code(self) -> i32 {
        match self {
            MovlnkError::Drive(rc) => {
                let v = rc.to_data() as i32;
                if v > 0 {
                    v
                } else {
                    Self::RESULT_UNREADABLE_CODE
                }
            }
            MovlnkError::Timeout => Self::RESULT_TIMEOUT,
            MovlnkError::ProcessOutput { .. } => Self::RESULT_PO_RANGE,
            MovlnkError::NotSbus(_) => Self::RESULT_NOT_SBUS,
            _ => Self::RESULT_BAD_COMMAND,
        }
    }
}

impl fmt::Display for MovlnkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MovlnkError::BusType(v) => write!(
                f,
                "MI.BusType {v} is not 1 (S0), 2 (S1) or 5 (SBus); 0, 3 and 4 are reserved"
            ),
            MovlnkError::Address(v) => write!(
                f,
                "MI.Address {v} is neither an SBus address 0-63 nor a group 100-163"
            ),
            MovlnkError::Format(v) => write!(f, "MI.Format {v} is not 0-6"),
            MovlnkError::Service(v) => write!(
                f,
                "MI.Service {v} is not 1 (read), 2 (write) or 3 (write without storing)"
            ),
            MovlnkError::Index(v) => write!(f, "MI.Index {v} is not a parameter index 0-65535"),
            MovlnkError::DPointer(v) => write!(
                f,
                "MI.DPointer {v}: the data block H{v}..H{v}+7 does not fit in H0-H1023"
            ),
            MovlnkError::ProcessOutput { word, value } => write!(
                f,
                "Mld.PO{word} = {value} does not fit a process data word (-32768 to 65535)"
            ),
            MovlnkError::ReadFromGroup => f.write_str(
                "a read service to a group address (100-163): group telegrams are never answered",
            ),
            MovlnkError::NotSbus(b) => write!(
                f,
                "bus type {} is an RS-485 interface; this executor drives SBus (5) only",
                b.code()
            ),
            MovlnkError::Drive(rc) => write!(f, "the drive refused the parameter service: {rc}"),
            MovlnkError::Timeout => f.write_str("no answer from the addressed drive"),
            MovlnkError::Busy => f.write_str("a MOVLNK command is already running"),
        }
    }
}

impl core::error::Error for MovlnkError {}

/// The outcome of a command run by [`MovlnkMaster`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MovlnkDone {
    /// `MI.Result`: 0 or [`MovlnkError::result_code`] of the first error.
    pub result: i32,
    /// The first error, if any.
    pub error: Option<MovlnkError>,
    /// The data block after the command (ReadPar and PI updated where their exchange succeeded).
    pub data: MlData,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Param,
    ProcessData,
}

#[derive(Debug, Clone, Copy)]
struct Running {
    command: MovlnkCommand,
    data: MlData,
    step: Step,
    error: Option<MovlnkError>,
}

/// A drive as SBus master executing MOVLNK commands (a [`CanEndpoint`] on [`SbusMaster`]).
///
/// ```
/// use drive_core::can::{CanEndpoint, CanFrame};
/// use drive_core::Instant;
/// use sbus_can::movlnk::{MlData, MovlnkCommand, MovlnkMaster};
///
/// let mut m = MovlnkMaster::new(Default::default());
/// let cmd = MovlnkCommand::from_vars([5, 1, 6, 1, 8318, 20, 0]).unwrap(); // Param only
/// m.execute(cmd, MlData::default(), Instant::ZERO).unwrap();
/// let t = Instant::ZERO;
/// assert_eq!(m.poll_transmit(t).unwrap().raw_id(), 523);
/// m.handle_frame(&CanFrame::standard(524, &[0x31, 0, 0x20, 0x7E, 0, 0x0F, 0x42, 0x40]).unwrap(), t);
/// let done = m.poll_done().unwrap();
/// assert_eq!((done.result, done.data.read_par), (0, 1_000_000));
/// ```
#[derive(Debug, Clone)]
pub struct MovlnkMaster {
    master: SbusMaster,
    running: Option<Running>,
    done: Option<MovlnkDone>,
}

impl MovlnkMaster {
    /// An executor whose exchanges use `config` (timeout, retries, sync identifier).
    pub fn new(config: MasterConfig) -> Self {
        Self {
            master: SbusMaster::new(config),
            running: None,
            done: None,
        }
    }

    /// The SBus master underneath (its counters, configuration).
    pub fn master(&self) -> &SbusMaster {
        &self.master
    }

    /// Whether a command runs.
    pub fn is_busy(&self) -> bool {
        self.running.is_some()
    }

    /// Start `command` with the data block `data` at `now`. Refused at once (and nothing is
    /// sent) for RS-485 bus types, PO values that do not fit a word and while a command runs.
    pub fn execute(
        &mut self,
        command: MovlnkCommand,
        data: MlData,
        now: Instant,
    ) -> Result<(), MovlnkError> {
        if self.running.is_some() {
            return Err(MovlnkError::Busy);
        }
        if command.bus_type != BusType::SBus {
            return Err(MovlnkError::NotSbus(command.bus_type));
        }
        if let (Target::Group(_), MovlnkService::Read, true) =
            (command.target, command.service, command.format.has_param())
        {
            return Err(MovlnkError::ReadFromGroup);
        }
        command.process_output(&data)?;
        self.done = None;
        let step = if command.format.has_param() {
            Step::Param
        } else {
            Step::ProcessData
        };
        self.running = Some(Running {
            command,
            data,
            step,
            error: None,
        });
        self.start_step(now);
        Ok(())
    }

    /// The outcome of the last command, once it is done (taken).
    pub fn poll_done(&mut self) -> Option<MovlnkDone> {
        self.done.take()
    }

    fn start_step(&mut self, now: Instant) {
        let Some(run) = self.running else { return };
        let c = run.command;
        let started = match (run.step, c.target) {
            (Step::Param, target) => match c.param_request(&run.data) {
                Some(ch) => match target {
                    Target::Single(a) => {
                        let hs = self.master.config().handshake;
                        self.master.param(a, ch, hs, now)
                    }
                    Target::Group(g) => self.master.group_param(g, ch, now),
                },
                None => Ok(()),
            },
            (Step::ProcessData, target) => match c.process_output(&run.data) {
                Ok(Some(pd)) => match target {
                    Target::Single(a) => self.master.process_data(a, pd, now),
                    Target::Group(g) => self.master.group_process_data(g, pd, now),
                },
                _ => Ok(()),
            },
        };
        if started.is_err() {
            self.fail_step(MovlnkError::Busy, now);
        }
    }

    fn fail_step(&mut self, e: MovlnkError, now: Instant) {
        if let Some(run) = self.running.as_mut() {
            run.error.get_or_insert(e);
        }
        self.next_step(now);
    }

    fn next_step(&mut self, now: Instant) {
        let Some(mut run) = self.running else { return };
        if run.step == Step::Param && run.command.format.pd_words() > 0 {
            run.step = Step::ProcessData;
            self.running = Some(run);
            self.start_step(now);
            return;
        }
        self.running = None;
        self.done = Some(MovlnkDone {
            result: run.error.map_or(0, MovlnkError::result_code),
            error: run.error,
            data: run.data,
        });
    }

    fn drain(&mut self, now: Instant) {
        while let Some(ev) = self.master.poll_event() {
            let MasterEvent::Done(result) = ev else {
                continue;
            };
            let Some(run) = self.running.as_mut() else {
                continue;
            };
            match result {
                Ok(Answer::Param(ch)) => {
                    if run.command.service == MovlnkService::Read {
                        run.data.read_par = ch.data as i32;
                    }
                }
                Ok(Answer::ProcessInput(ProcessData(words))) => {
                    let n = run.command.format.pd_words();
                    for (pi, w) in run.data.pi.iter_mut().zip(words).take(n) {
                        *pi = i32::from(w);
                    }
                }
                Ok(Answer::Sent) => {}
                Err(MasterError::Drive { code, .. }) => {
                    run.error.get_or_insert(MovlnkError::Drive(code));
                }
                Err(_) => {
                    run.error.get_or_insert(MovlnkError::Timeout);
                }
            }
            self.next_step(now);
        }
    }

    /// The response timeout of each attempt.
    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.master.set_response_timeout(timeout);
    }
}

impl CanEndpoint for MovlnkMaster {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.master.handle_frame(frame, now);
        self.drain(now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.master.handle_timeout(now);
        self.drain(now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        let f = self.master.poll_transmit(now);
        self.drain(now);
        f
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.master.poll_timeout()
    }
}
