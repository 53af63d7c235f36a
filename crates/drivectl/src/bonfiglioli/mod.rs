//! `drivectl bonfiglioli …`: talk to a Bonfiglioli ACTIVE (ACT) or ACTIVE Cube (ACU) over
//! Modbus RTU or ASCII with the function codes 3/6 (16 bit) and 100/101 (32 bit).
//!
//! A thin mapping onto the tool layer: [`BonfiglioliClient`] is the [`ParamClient`] of the
//! `bonfiglioli-modbus` driver; reads, writes, watch, backup and restore are the tool layer's.
//! [`Target::sub`] is the data set (0 = all four, 1–4, and 5–9 their RAM-only twins). What only
//! this bus has lives here: the widths (from the table, or `--word`/`--long` where the manual
//! gives no data type), the FC 8 counters (`diag`), the address scan, `status` and `control`.

pub mod decode;
pub mod sim;

use std::collections::HashMap;
use std::ops::RangeInclusive;
use std::time::Duration;

use bonfiglioli_modbus::driver::{CharIo, DriverConfig, DriverError, MasterDriver};
use bonfiglioli_modbus::frame::{Address, DataSet, DiagSubFunction, ExceptionCode};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use clap::{Args, Subcommand};
use drive_profile::bonfiglioli::{
    self, ActStateMachine, ActStatusWord, AcuStateMachine, AcuStatusWord, DataType, State,
};
use drive_profile::state::StateMachine;
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value, json};

use crate::error::{CliError, Result};
use crate::tool::client::{
    ClientError, DeviceError, DeviceErrorKind, ParamClient, Target, ValueText, canonical_port,
};
use crate::tool::interrupt::Interrupt;
use crate::tool::line::{LineArgs, runtime};
use crate::tool::output::{physical_text, print_value};
use crate::tool::{backup, read, stale, watch, write};

/// Parameter numbers outside the table that may be read and written raw (the start address
/// carries 0–1599).
pub const RAW_INDICES: RangeInclusive<u16> = 0..=1599;

/// Parameter numbers of the table this command uses by name.
pub mod param {
    /// Baud rate (a link setting).
    pub const BAUD_RATE: u16 = 10;
    /// Configuration.
    pub const CONFIGURATION: u16 = 30;
    /// Program: a command (factory reset and others), never restored.
    pub const PROGRAM: u16 = 34;
    /// Current fault.
    pub const CURRENT_FAULT: u16 = 260;
    /// Warnings.
    pub const WARNINGS: u16 = 270;
    /// Protocol type (a link setting: 2 = Modbus RTU, 3 = Modbus ASCII).
    pub const PROTOCOL: u16 = 395;
    /// Control word (RAM only).
    pub const CONTROL_WORD: u16 = 410;
    /// Status word.
    pub const STATUS_WORD: u16 = 411;
    /// Local/remote (1 = state machine).
    pub const LOCAL_REMOTE: u16 = 412;
    /// RS232/RS485 watchdog timer (a link setting).
    pub const WATCHDOG: u16 = 413;
    /// Reference frequency RAM (write-only on the ACU).
    pub const FREQUENCY_RAM: u16 = 484;
    /// Reference percentage RAM (write-only on the ACU).
    pub const PERCENTAGE_RAM: u16 = 524;
    /// Modbus parity (a link setting).
    pub const PARITY: u16 = 1375;
    /// Modbus address (a link setting).
    pub const ADDRESS: u16 = 1376;
}

/// The drive's own settings for the Modbus link: baud rate 10, protocol type 395, watchdog
/// 413, parity 1375, address 1376 (`drivectl params bonfiglioli --search modbus`).
pub const LINK_SETTINGS: &[u16] = &[
    param::BAUD_RATE,
    param::PROTOCOL,
    param::WATCHDOG,
    param::PARITY,
    param::ADDRESS,
];

/// What a restore never writes: the command 34 (program), the RAM-only control word and
/// setpoints (410, 484, 524) and the link settings.
pub const NOT_RESTORED: &[u16] = &[
    param::BAUD_RATE,
    param::PROGRAM,
    param::PROTOCOL,
    param::CONTROL_WORD,
    param::WATCHDOG,
    param::FREQUENCY_RAM,
    param::PERCENTAGE_RAM,
    param::PARITY,
    param::ADDRESS,
];

const BONFIGLIOLI_HELP: &str = "\
Examples:
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 read 372 --dataset 2
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 376 1.5 --dataset 4
  drivectl bonfiglioli --port /dev/ttyUSB0 --mode ascii --addr 1 status
  drivectl bonfiglioli read 481 --port /dev/ttyUSB0 --addr 1      options after the command work too

Widths, data sets and value lists: `drivectl params bonfiglioli show 372`.";

const WRITE_HELP: &str = "\
Examples:
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 376 1.5 --dataset 4   1.5 kW in data set 4 (EEPROM)
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 481 10,00             decimal comma, all data sets
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 484 25 --ram          a setpoint that changes often
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 1376 5 --yes          move the drive to address 5
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 415 300 --word        a parameter without a data type

Data sets 0-4 are stored in EEPROM, which cyclic writes destroy (manual ch. 7): values that
change often go to RAM with --ram (data set +5). EEPROM-wear log: non-volatile writes are
remembered for a minute in eeprom-writes.json in $DRIVECTL_STATE_DIR, else
$XDG_STATE_HOME/drivectl, else ~/.local/state/drivectl.";

/// Arguments of `drivectl bonfiglioli`.
#[derive(Debug, Args)]
#[command(after_help = BONFIGLIOLI_HELP)]
pub struct BonfiglioliArgs {
    /// Serial port, e.g. /dev/ttyUSB0 (or the pty printed by `drivectl sim bonfiglioli --pty`).
    /// This and every line option are accepted before or after the subcommand.
    #[arg(long, global = true, default_value = "", hide_default_value = true)]
    port: String,
    /// Transmission mode (the drive's parameter 395: 2 = RTU, 3 = ASCII).
    #[arg(long, global = true, default_value = "rtu", value_parser = ["rtu", "ascii"])]
    mode: String,
    #[command(flatten)]
    line: LineArgs,
    /// Data bits, 7 or 8: by default the mode's (RTU 8, ASCII 7: ch. 6.7); a pseudo-terminal
    /// takes only 8.
    #[arg(long, global = true, value_parser = clap::value_parser!(u8).range(7..=8))]
    data_bits: Option<u8>,
    /// Response timeout in milliseconds, 1–60000 (the manual: 500).
    #[arg(long, global = true, default_value_t = 500, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    timeout: u64,
    /// Retries after a timeout or a corrupt answer.
    #[arg(long, global = true, default_value_t = 2)]
    retries: u8,
    /// Drive address 1–247 (parameter 1376).
    #[arg(long, global = true, default_value_t = 1)]
    addr: u8,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: BonfiglioliCommand,
}

/// `--dataset`, `--word`, `--long` of the parameter commands.
#[derive(Debug, Args, Clone, Copy, Default)]
pub struct Access {
    /// Data set 0–9: 0 = all four (a read of 0 succeeds only where the four are equal), 1–4 one
    /// of them, 5–9 the RAM-only twins of 0–4.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=9))]
    dataset: u8,
    /// Access as 16 bit (FC 3/6): for parameters the manual gives no data type.
    #[arg(long, conflicts_with = "long")]
    word: bool,
    /// Access as 32 bit (FC 100/101): for parameters the manual gives no data type.
    #[arg(long)]
    long: bool,
}

impl Access {
    fn width(self) -> Option<Width> {
        match (self.word, self.long) {
            (true, _) => Some(Width::Word),
            (_, true) => Some(Width::Long),
            _ => None,
        }
    }
}

#[derive(Debug, Subcommand)]
enum BonfiglioliCommand {
    /// Read parameters: value with unit and decimals (status word, faults and warnings
    /// decoded), and the raw value; one line (or JSON object) per parameter.
    ///
    /// Every name is checked before anything is sent. A refusal of one parameter is reported
    /// for it and the others are still read (exit 1 at the end); a link failure stops.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 read 372 --dataset 2\n  \
        drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 read 411 260 270 --json\n  \
        drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 read 415 --word"
    )]
    Read {
        /// Parameter numbers (372 or P372).
        #[arg(required = true, num_args = 1..)]
        params: Vec<String>,
        #[command(flatten)]
        access: Access,
    },
    /// Write a parameter (checked against the table first), then read it back.
    #[command(after_help = WRITE_HELP)]
    Write {
        /// Parameter number.
        param: String,
        /// Value in the parameter's unit (or raw with --raw).
        #[arg(allow_hyphen_values = true)]
        value: String,
        #[command(flatten)]
        access: Access,
        /// Write to RAM only (data set +5: the way for values that change often; lost at
        /// power-off).
        #[arg(long)]
        ram: bool,
        /// VALUE is the raw bus value.
        #[arg(long)]
        raw: bool,
        /// Skip the access/range/value-list/EEPROM-wear checks of the table (a value that does
        /// not fit the parameter's width is never sent).
        #[arg(long)]
        force: bool,
        /// Accept a physical value the parameter cannot hold exactly and write the nearest one.
        #[arg(long)]
        round: bool,
        /// Confirm a write of the drive's link settings (10 baud rate, 395 protocol type, 413
        /// watchdog, 1375 parity, 1376 address).
        #[arg(long)]
        yes: bool,
    },
    /// Poll parameters at a steady rhythm (as `drivectl movilink watch`). Ctrl-C ends it.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 watch 241 411\n  \
        drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 watch 241 --interval 200 --count 50 --csv"
    )]
    Watch {
        /// Parameter numbers.
        #[arg(required = true, num_args = 1..)]
        params: Vec<String>,
        #[command(flatten)]
        access: Access,
        #[command(flatten)]
        watch: watch::WatchArgs,
    },
    /// The diagnostic counters of function code 8, named; --clear sets them to zero first.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 diag\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 diag --clear --json"
    )]
    Diag {
        /// Clear all counters (sub-function 0x0A) before reading them.
        #[arg(long)]
        clear: bool,
    },
    /// Find responding drives (a short timeout per address) with their configuration (30) and
    /// status word (411). The manual defines no device type or firmware parameter.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 scan\n  drivectl bonfiglioli --port /dev/ttyUSB0 scan --from 1 --to 10 --json"
    )]
    Scan {
        /// First address.
        #[arg(long, default_value_t = 1)]
        from: u8,
        /// Last address.
        #[arg(long, default_value_t = 247)]
        to: u8,
    },
    /// The status word 411 decoded (ACT or ACU), the current fault 260 and the warnings 270.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 status\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 status --variant acu --json"
    )]
    Status {
        /// Decode the status word as ACT (ACTIVE) or ACU (ACTIVE Cube).
        #[arg(long, default_value = "act", value_parser = ["act", "acu"])]
        variant: String,
    },
    /// Command the drive through the state machine (410 control word, 412 = 1 state machine):
    /// enable, stop (switched on), quick-stop, disable (switch-on disabled) or reset a fault.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control enable --freq 25\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control stop\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control reset"
    )]
    Control {
        /// What to do.
        #[arg(value_parser = ["enable", "stop", "quick-stop", "disable", "reset"])]
        action: String,
        /// Write this reference frequency in Hz to 484 (RAM) first.
        #[arg(long, allow_hyphen_values = true, value_name = "HZ")]
        freq: Option<String>,
        /// The device: act (ACTIVE) or acu (ACTIVE Cube; 484 is write-only there).
        #[arg(long, default_value = "act", value_parser = ["act", "acu"])]
        variant: String,
    },
    /// Show the line settings and the timing the master uses on this port.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 line\n  drivectl bonfiglioli --port /dev/ttyUSB0 --mode ascii --parity none line --json"
    )]
    Line,
    /// Save every readable parameter of the table in every data set it has to a JSON file.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 backup --out drive1.json\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 backup --out drive1.json --overwrite"
    )]
    Backup(backup::BackupArgs),
    /// Write a backup file back (data sets 1–4, never 0) and verify every value.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 restore drive1.json --dry-run\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 restore drive1.json"
    )]
    Restore(backup::RestoreArgs),
}

/// How the width of a parameter without a data type is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnknownWidth {
    /// Refuse: the user must give `--word` or `--long`.
    Refuse,
    /// Try FC 3 and fall back to FC 100 when the drive says the type does not match (the
    /// manual's advice; used by backup and restore, which say so).
    Probe,
}

/// The Modbus driver as the tool layer's [`ParamClient`]: one drive at one address.
#[derive(Debug)]
pub struct BonfiglioliClient<'a, IO> {
    driver: &'a mut MasterDriver<IO>,
    address: Address,
    port: String,
    /// `--word` / `--long`.
    width: Option<Width>,
    unknown: UnknownWidth,
    /// Widths found by probing, per parameter number.
    probed: HashMap<u16, Width>,
    key: Option<String>,
}

impl<'a, IO: CharIo> BonfiglioliClient<'a, IO> {
    /// The drive at `address` behind `driver` on `port`; `width` overrides the table.
    pub fn new(
        driver: &'a mut MasterDriver<IO>,
        address: Address,
        port: &str,
        width: Option<Width>,
    ) -> Self {
        Self {
            driver,
            address,
            port: port.to_owned(),
            width,
            unknown: UnknownWidth::Refuse,
            probed: HashMap::new(),
            key: None,
        }
    }

    /// Find the width of parameters without a data type by trying (backup, restore).
    pub fn probing(mut self) -> Self {
        self.unknown = UnknownWidth::Probe;
        self
    }

    /// Parameters whose width was found by trying.
    pub fn probed(&self) -> usize {
        self.probed.len()
    }

    async fn read_width(
        &mut self,
        t: &Target,
        width: Width,
    ) -> std::result::Result<u32, DriverError> {
        let ds = data_set(t.sub);
        self.driver.read(self.address, t.index, ds, width).await
    }
}

/// The data set of a target's sub-index (checked by clap to be 0–9).
fn data_set(sub: u16) -> DataSet {
    u8::try_from(sub)
        .ok()
        .and_then(DataSet::new)
        .unwrap_or(DataSet::ALL)
}

/// The width of `t`: `--word`/`--long` when given, else the table's data type; `None` where
/// the manual gives none.
pub fn table_width(t: &Target, given: Option<Width>) -> Option<Width> {
    given.or_else(
        || match bonfiglioli::by_index(t.index).map(|p| p.data_type) {
            Some(DataType::UInt | DataType::Int) => Some(Width::Word),
            Some(DataType::Long) => Some(Width::Long),
            _ => None,
        },
    )
}

/// Refuse a parameter without a data type when neither `--word` nor `--long` was given.
pub fn check_width_known(t: &Target, given: Option<Width>) -> Result<()> {
    if table_width(t, given).is_some() {
        return Ok(());
    }
    Err(CliError::usage(format!(
        "the manual gives no data type for {}{}: add --word (16 bit, FC 3/6) or --long \
         (32 bit, FC 100/101); nothing is guessed",
        t.label(),
        t.param
            .map_or_else(String::new, |p| format!(" {}", p.name_en()))
    )))
}

/// A raw value of the bus data: signed where the parameter's range goes below zero (or the
/// table does not know it), 16-bit values sign-extended from 16 bits.
pub fn raw_of(t: &Target, width: Width, data: u32) -> i64 {
    let signed = t
        .param
        .and_then(|p| p.raw_range())
        .is_none_or(|(lo, _)| lo < 0);
    match (width, signed) {
        (Width::Word, true) => i64::from(data as u16 as i16),
        (Width::Word, false) => i64::from(data as u16),
        (Width::Long, true) => i64::from(data as i32),
        (Width::Long, false) => i64::from(data),
    }
}

/// The bus data of a raw value for `width`, or `None` when it does not fit.
pub fn data_of(width: Width, raw: i64) -> Option<u32> {
    match width {
        Width::Word => (-32768..=65535).contains(&raw).then_some(raw as u16 as u32),
        Width::Long => (i64::from(i32::MIN)..=i64::from(u32::MAX))
            .contains(&raw)
            .then_some(raw as u32),
    }
}

/// Whether a refusal says the access had the wrong width: exception 2 (the manual: "data type
/// does not match"), or exception 4 with VABus 14 or 10.
fn wrong_width(e: &DriverError) -> bool {
    match e {
        DriverError::Device { exception, vabus } => {
            *exception == ExceptionCode::ILLEGAL_DATA_ADDRESS
                || (*exception == ExceptionCode::SLAVE_DEVICE_FAILURE
                    && matches!(vabus, Some(10 | 14)))
        }
        _ => false,
    }
}

/// The tool layer's error for a driver error on `t` accessed with `width`.
pub fn client_error(t: &Target, width: Width, e: DriverError) -> ClientError {
    let DriverError::Device { vabus, .. } = &e else {
        return ClientError::Link(e.to_string());
    };
    let vabus = *vabus;
    let kind = match vabus {
        // Unknown parameter; not readable (write-only, 484/524 on the ACU).
        Some(11 | 3) => DeviceErrorKind::Absent,
        _ => DeviceErrorKind::Refused,
    };
    let hint = if wrong_width(&e) {
        match width {
            Width::Word => format!(" (the drive says {} is not 16-bit: try --long)", t.label()),
            Width::Long => format!(" (the drive says {} is not 32-bit: try --word)", t.label()),
        }
    } else if vabus == Some(9) {
        " (data set 0 reads only where the four data sets hold the same value: give --dataset \
         1, 2, 3 or 4)"
            .to_owned()
    } else {
        String::new()
    };
    ClientError::Device(DeviceError {
        kind,
        message: format!("{}: {e}{hint}", t.label()),
    })
}

impl<IO: CharIo> ParamClient for BonfiglioliClient<'_, IO> {
    fn family(&self) -> Family {
        Family::Bonfiglioli
    }

    fn stale_bytes(&self) -> u64 {
        self.driver.stats().stale
    }

    async fn drive_key(&mut self) -> std::result::Result<String, ClientError> {
        if let Some(k) = &self.key {
            return Ok(k.clone());
        }
        let key = format!("{} {}", canonical_port(&self.port), self.address.get());
        self.key = Some(key.clone());
        Ok(key)
    }

    fn link_settings(&self) -> &'static [u16] {
        LINK_SETTINGS
    }

    fn link_change(&self, target: &Target, raw: i64) -> String {
        let value = target
            .param
            .map_or_else(|| raw.to_string(), |p| physical_text(p, raw));
        match target.index {
            param::ADDRESS => format!(
                "the drive will answer at address {raw}, no longer at {} (use --addr {raw})",
                self.address.get()
            ),
            param::BAUD_RATE => format!(
                "the drive will talk at another baud rate ({value}): use the matching --baud"
            ),
            param::PARITY => {
                format!("the drive will use another parity ({value}): use the matching --parity")
            }
            param::PROTOCOL => format!(
                "the drive will speak another protocol ({value}); 2 = Modbus RTU (--mode rtu), \
                 3 = Modbus ASCII (--mode ascii)"
            ),
            param::WATCHDOG if raw == 0 => "the drive will no longer watch the link (413 = 0): \
                 a master that stops leaves it running"
                .to_owned(),
            _ => format!(
                "the drive will trip when no valid request arrives for {value} (413 watchdog)"
            ),
        }
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        let note = self.link_change(target, raw);
        if target.index == param::ADDRESS
            && let Some(a) = u8::try_from(raw).ok().and_then(Address::new)
        {
            self.address = a;
            self.key = None;
        }
        note
    }

    fn not_restored(&self) -> &'static [u16] {
        NOT_RESTORED
    }

    async fn read(&mut self, target: &Target) -> std::result::Result<i64, ClientError> {
        let width = match table_width(target, self.width)
            .or_else(|| self.probed.get(&target.index).copied())
        {
            Some(w) => w,
            None if self.unknown == UnknownWidth::Probe => {
                match self.read_width(target, Width::Word).await {
                    Ok(v) => {
                        self.probed.insert(target.index, Width::Word);
                        return Ok(raw_of(target, Width::Word, v));
                    }
                    Err(e) if wrong_width(&e) => {
                        let v = self
                            .read_width(target, Width::Long)
                            .await
                            .map_err(|e| client_error(target, Width::Long, e))?;
                        self.probed.insert(target.index, Width::Long);
                        return Ok(raw_of(target, Width::Long, v));
                    }
                    Err(e) => return Err(client_error(target, Width::Word, e)),
                }
            }
            None => {
                return Err(ClientError::Link(
                    check_width_known(target, None)
                        .err()
                        .map_or_else(String::new, |e| e.to_string()),
                ));
            }
        };
        self.read_width(target, width)
            .await
            .map(|v| raw_of(target, width, v))
            .map_err(|e| client_error(target, width, e))
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> std::result::Result<(), ClientError> {
        let width = table_width(target, self.width)
            .or_else(|| self.probed.get(&target.index).copied())
            .ok_or_else(|| {
                ClientError::Link(format!(
                    "the width of {} is not known; add --word or --long",
                    target.label()
                ))
            })?;
        let data = data_of(width, raw).ok_or_else(|| {
            ClientError::Link(format!(
                "value {raw} does not fit {} bits; nothing was sent",
                if width == Width::Word { 16 } else { 32 }
            ))
        })?;
        let ram_only = target
            .param
            .is_some_and(|_| bonfiglioli::by_index(target.index).is_some_and(|p| p.ram_only));
        // RAM only: the twin data set (+5) of a stored one; parameters kept in RAM anyway
        // (410, 484, 524) are written where they are.
        let ds = match (persistence, target.sub) {
            (Persistence::Volatile, d @ 0..=4) if !ram_only => d + 5,
            (_, d) => d,
        };
        self.driver
            .write(self.address, target.index, data_set(ds), width, data)
            .await
            .map_err(|e| client_error(target, width, e))
    }

    async fn identify(&mut self) -> std::result::Result<Map<String, Value>, ClientError> {
        // The manual defines no device type or firmware parameter: the configuration (30)
        // identifies the drive's function as far as the bus can tell.
        let t = resolve_in(&param::CONFIGURATION.to_string(), 0)?;
        let configuration = match self.read(&t).await {
            Ok(v) => Value::from(v),
            Err(ClientError::Device(_)) => Value::Null,
            Err(e) => return Err(e),
        };
        let mut m = Map::new();
        m.insert("address".into(), self.address.get().into());
        m.insert("device_type".into(), Value::Null);
        m.insert("firmware".into(), Value::Null);
        m.insert("configuration".into(), configuration);
        Ok(m)
    }
}

fn resolve_in(key: &str, dataset: u8) -> std::result::Result<Target, ClientError> {
    resolve(key, dataset).map_err(|e| ClientError::Link(e.to_string()))
}

/// Resolve a parameter number (`372`, `P372`) in `dataset`; numbers outside the table are
/// allowed raw (0–1599).
pub fn resolve(key: &str, dataset: u8) -> Result<Target> {
    let mut t = Target::resolve(Family::Bonfiglioli, key, RAW_INDICES)?;
    t.sub = u16::from(dataset);
    Ok(t)
}

fn resolve_all(params: &[String], access: Access) -> Result<Vec<Target>> {
    params
        .iter()
        .map(|p| {
            let t = resolve(p, access.dataset)?;
            check_width_known(&t, access.width())?;
            Ok(t)
        })
        .collect()
}

/// A write to every drive (address 0): checked as any write (width, table, link settings,
/// EEPROM wear under the broadcast's own key), sent once, never answered, so nothing is read
/// back (ch. 6.1).
async fn write_broadcast<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    port: &str,
    request: &write::WriteRequest,
    width: Option<Width>,
    yes: bool,
    json: bool,
) -> Result<()> {
    let mut c = BonfiglioliClient::new(m, Address::BROADCAST, port, width);
    write::check_link_setting(&c, request, yes)?;
    let drive = c.drive_key().await?;
    if let Some(warning) = write::check(&mut c, request).await? {
        errln!("drivectl: warning: {warning}");
    }
    write_ram_hint(
        c.write(&request.target, request.raw, request.persistence)
            .await
            .map_err(CliError::from),
    )?;
    // Keep the line quiet for the broadcast's hold and the frame gap before this process lets
    // go of the port: the next request (perhaps from the next drivectl run, a few ms later)
    // must not follow sooner, or the drives take both frames for one and drop it.
    let hold = bonfiglioli_modbus::master::BROADCAST_HOLD + m.config().line.char_times(7, 2);
    tokio::time::sleep(hold).await;
    if let Err(e) = write::record(&drive, request) {
        errln!("drivectl: warning: {e}");
    }
    let t = request.target;
    if json {
        outln!(
            "{}",
            serde_json::json!({"parameter": t.index, "dataset": t.sub, "index": t.index,
                   "number": t.param.map(|p| p.label().to_string()),
                   "name_en": t.param.map(|p| p.name_en()),
                   "raw": request.raw, "address": 0, "answered": false})
        )
    } else {
        outln!(
            "sent {} = raw {} to every drive (broadcast, address 0; never answered by design)",
            t.label(),
            request.raw
        )
    }
}

fn address(a: u8) -> Result<Address> {
    Address::new(a)
        .filter(|a| !a.is_broadcast())
        .ok_or_else(|| {
            CliError::usage(format!(
                "address {a} cannot be asked for an answer; use 1–247 (parameter 1376)"
            ))
        })
}

fn mode_of(s: &str) -> Mode {
    if s.eq_ignore_ascii_case("ascii") {
        Mode::Ascii
    } else {
        Mode::Rtu
    }
}

/// The character format of `mode` on the command line's line (ch. 6.7): RTU 8 data bits,
/// ASCII 7 unless `data_bits` says otherwise; one stop bit with parity and two without, or two
/// where `--stop-bits 2` asks for them.
pub fn line_of(mode: Mode, line: &LineArgs, data_bits: Option<u8>) -> drive_core::LineSettings {
    let mut settings = mode.line_settings(line.baud, line.parity);
    if let Some(bits) = data_bits {
        settings.data_bits = bits;
    }
    if line.stop_bits == drive_core::StopBits::Two {
        settings.stop_bits = drive_core::StopBits::Two;
    }
    settings
}

/// The driver configuration of the command-line options.
fn driver_config(args: &BonfiglioliArgs) -> DriverConfig {
    let mode = mode_of(&args.mode);
    DriverConfig {
        response_timeout: Duration::from_millis(args.timeout),
        retries: args.retries,
        ..DriverConfig::new(mode, line_of(mode, &args.line, args.data_bits))
    }
}

/// The value a write sends, checked without the drive.
struct WriteValue {
    target: Target,
    raw: i64,
    rounded_from: Option<f64>,
}

#[allow(clippy::fn_params_excessive_bools)]
fn write_value(param: &str, value: &str, access: Access, how: &ValueText) -> Result<WriteValue> {
    let t = resolve(param, access.dataset)?;
    check_width_known(&t, access.width())?;
    let parsed = t.value_from_text(value, how)?;
    t.check_width(parsed.raw)?;
    if let Some(w) = access.width()
        && data_of(w, parsed.raw).is_none()
    {
        return Err(CliError::usage(format!(
            "value {} does not fit 16 bits (--word: -32768…65535); nothing was sent",
            parsed.raw
        )));
    }
    Ok(WriteValue {
        target: t,
        raw: parsed.raw,
        rounded_from: parsed.rounded_from,
    })
}

/// Run `drivectl bonfiglioli`.
pub fn run(args: &BonfiglioliArgs) -> Result<()> {
    if args.port.is_empty() {
        return Err(CliError::usage(
            "no serial port given; add --port PATH (e.g. /dev/ttyUSB0; `drivectl ports` lists them)",
        ));
    }
    precheck(args)?;
    let config = driver_config(args);
    let rt = runtime()?;
    rt.block_on(async {
        // The mode's character format: RTU 8 data bits, ASCII 7 (ch. 6.7).
        let port = open(&args.port, config.line)?;
        stale::note_flushed(port.flushed_at_open());
        let mut master = MasterDriver::new(port, config);
        let r = execute(&mut master, args).await;
        stale::note_stale(master.stats().stale);
        r
    })
}

/// Open `path` with `settings` (the mode's data bits).
fn open(
    path: &str,
    settings: drive_core::LineSettings,
) -> Result<drive_transport::serial::SerialPort> {
    let config = drive_transport::serial::SerialConfig::with_line(path, settings);
    drive_transport::serial::open(&config).map_err(|e| {
        if e.refused_setting().is_some() {
            CliError::usage(crate::tool::line::open_error(&e))
        } else {
            CliError::failed(crate::tool::line::open_error(&e))
        }
    })
}

/// Names, widths and values are checked before the port is opened.
fn precheck(args: &BonfiglioliArgs) -> Result<()> {
    match &args.command {
        BonfiglioliCommand::Read { params, access }
        | BonfiglioliCommand::Watch { params, access, .. } => {
            resolve_all(params, *access).map(drop)
        }
        BonfiglioliCommand::Write {
            param,
            value,
            access,
            raw,
            force,
            round,
            ..
        } => {
            let how = ValueText {
                raw: *raw,
                force: *force,
                round: *round,
            };
            write_value(param, value, *access, &how).map(drop)
        }
        BonfiglioliCommand::Control { freq: Some(f), .. } => freq_raw(f).map(drop),
        BonfiglioliCommand::Restore(r) => {
            backup::check_file(&r.file, Family::Bonfiglioli, NOT_RESTORED)
        }
        BonfiglioliCommand::Scan { from, to } if *from == 0 || from > to || *to > 247 => Err(
            CliError::usage("scan range must satisfy 1 ≤ --from ≤ --to ≤ 247"),
        ),
        _ => Ok(()),
    }
    .and_then(|()| match &args.command {
        BonfiglioliCommand::Scan { .. } => Ok(()),
        // Address 0 broadcasts a write to every drive (never answered, ch. 6.1).
        BonfiglioliCommand::Write { .. } if args.addr == 0 => Ok(()),
        _ => address(args.addr).map(drop),
    })
}

async fn execute<IO: CharIo>(m: &mut MasterDriver<IO>, args: &BonfiglioliArgs) -> Result<()> {
    let json = args.json;
    match &args.command {
        BonfiglioliCommand::Read { params, access } => {
            let targets = resolve_all(params, *access)?;
            let mut c = BonfiglioliClient::new(m, address(args.addr)?, &args.port, access.width());
            if json {
                // The tool layer's keys plus `parameter` and `dataset`.
                return read_json(&mut c, &targets).await;
            }
            read::read_all(&mut c, &targets, json).await
        }
        BonfiglioliCommand::Watch {
            params,
            access,
            watch: watch_args,
        } => {
            let targets = resolve_all(params, *access)?;
            let options = watch_args.options(json)?;
            let mut c = BonfiglioliClient::new(m, address(args.addr)?, &args.port, access.width());
            watch::watch(
                &mut c,
                &targets,
                options,
                &mut |s| out!("{s}"),
                watch::ctrl_c(),
            )
            .await
            .map(drop)
        }
        BonfiglioliCommand::Write {
            param,
            value,
            access,
            ram,
            raw,
            force,
            round,
            yes,
        } => {
            let how = ValueText {
                raw: *raw,
                force: *force,
                round: *round,
            };
            let mut v = write_value(param, value, *access, &how)?;
            if let (Some(x), Some(p)) = (v.rounded_from, v.target.param) {
                errln!(
                    "drivectl: note: {} cannot hold {x} exactly; writing the nearest value it takes, {}",
                    p.label(),
                    physical_text(p, v.raw)
                );
            }
            let ram_only = bonfiglioli::by_index(v.target.index).is_some_and(|p| p.ram_only);
            if *ram && v.target.sub <= 4 && !ram_only {
                // The RAM-only twin of the data set.
                v.target.sub += 5;
            }
            let persistence = if v.target.sub >= 5 || ram_only {
                Persistence::Volatile
            } else {
                Persistence::NonVolatile
            };
            let request = write::WriteRequest {
                target: v.target,
                raw: v.raw,
                persistence,
                force: *force,
            };
            if args.addr == 0 {
                return write_broadcast(m, &args.port, &request, access.width(), *yes, json).await;
            }
            let mut c = BonfiglioliClient::new(m, address(args.addr)?, &args.port, access.width());
            let done = write_ram_hint(write::write_checked(&mut c, &request, *yes).await)?;
            if let Some(note) = &done.link_note {
                errln!("drivectl: note: {note}");
            }
            print_value_ds(&v.target, done.back, json)
        }
        BonfiglioliCommand::Diag { clear } => diag(m, address(args.addr)?, *clear, json).await,
        BonfiglioliCommand::Scan { from, to } => scan(m, *from, *to, json).await,
        BonfiglioliCommand::Status { variant } => {
            status(m, address(args.addr)?, variant == "acu", json).await
        }
        BonfiglioliCommand::Control {
            action,
            freq,
            variant,
        } => {
            let session = ControlSession {
                addr: address(args.addr)?,
                port: &args.port,
                action,
                freq: freq.as_deref().map(freq_raw).transpose()?,
                acu: variant == "acu",
                json,
            };
            control(m, &session).await
        }
        BonfiglioliCommand::Line => {
            let c = *m.config();
            let l = c.line;
            let char_us = l.char_time().as_nanos() as f64 / 1000.0;
            if json {
                outln!(
                    "{}",
                    json!({
                        "port": args.port, "mode": c.mode.to_string(), "baud": l.baud,
                        "data_bits": l.data_bits, "parity": l.parity.to_string(),
                        "stop_bits": l.stop_bits.bits(), "bits_per_char": l.bits_per_char(),
                        "char_time_us": char_us,
                        "response_timeout_ms": c.response_timeout.as_millis() as u64,
                        "retries": c.retries,
                    })
                )?;
            } else {
                outln!(
                    "{} Modbus {} at {} baud, {} data bits, parity {}, {} stop bit(s): character \
                     time {char_us:.1} µs; response timeout {} ms, {} retries",
                    args.port,
                    c.mode.to_string().to_uppercase(),
                    l.baud,
                    l.data_bits,
                    l.parity,
                    l.stop_bits.bits(),
                    c.response_timeout.as_millis(),
                    c.retries
                )?;
            }
            Ok(())
        }
        BonfiglioliCommand::Backup(b) => {
            let mut c = BonfiglioliClient::new(m, address(args.addr)?, &args.port, None).probing();
            let stop = Interrupt::install("the backup file was not written");
            backup::backup(&mut c, &b.out, b.overwrite, json, &stop).await?;
            note_probed(c.probed());
            Ok(())
        }
        BonfiglioliCommand::Restore(r) => {
            let mut c = BonfiglioliClient::new(m, address(args.addr)?, &args.port, None).probing();
            let stop = Interrupt::install(
                "the drive may be half restored; run the same restore again to finish it",
            );
            let opts = r.options();
            let r = backup::restore(&mut c, &r.file, opts, json, &stop).await;
            note_probed(c.probed());
            r
        }
    }
}

fn note_probed(n: usize) {
    if n > 0 {
        errln!(
            "drivectl: note: the manual gives no data type for {n} of these parameters: their \
             width was found by reading with FC 3 and, where the drive refused the type, FC 100"
        );
    }
}

/// The tool layer's EEPROM-wear refusal names `--volatile`; this command's option is `--ram`.
fn write_ram_hint<T>(r: Result<T>) -> Result<T> {
    r.map_err(|e| {
        let text = e.to_string();
        if text.contains("--volatile") {
            CliError::usage(text.replace("--volatile", "--ram"))
        } else {
            e
        }
    })
}

/// One value with `parameter` and `dataset` added to the tool layer's JSON.
fn value_json_ds(t: &Target, raw: i64) -> Value {
    let mut v = crate::tool::output::value_json(t, raw);
    if let Value::Object(o) = &mut v {
        o.insert("parameter".into(), t.index.into());
        o.insert("dataset".into(), t.sub.into());
    }
    v
}

fn print_value_ds(t: &Target, raw: i64, json: bool) -> Result<()> {
    if json {
        outln!("{}", value_json_ds(t, raw))
    } else {
        print_value(t, raw, false)
    }
}

/// `read --json`: as [`read::read_all`], one object per parameter with `parameter` and
/// `dataset`.
async fn read_json<IO: CharIo>(
    c: &mut BonfiglioliClient<'_, IO>,
    targets: &[Target],
) -> Result<()> {
    let mut refused = Vec::new();
    for (i, t) in targets.iter().enumerate() {
        match c.read(t).await {
            Ok(raw) => outln!("{}", value_json_ds(t, raw))?,
            Err(ClientError::Device(d)) if targets.len() > 1 => {
                errln!("drivectl: {d}");
                refused.push(t.label());
            }
            Err(ClientError::Link(msg)) if targets.len() > 1 => {
                let unread: Vec<String> = targets.iter().skip(i).map(Target::label).collect();
                return Err(CliError::failed(format!(
                    "{}: {msg}; not read: {}",
                    t.label(),
                    unread.join(", ")
                )));
            }
            Err(e) => return Err(e.into()),
        }
    }
    if refused.is_empty() {
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "{} of {} parameters could not be read: {} (the drive's answers are above)",
            refused.len(),
            targets.len(),
            refused.join(", ")
        )))
    }
}

fn driver_error(e: DriverError) -> CliError {
    CliError::failed(e.to_string())
}

async fn diag<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    clear: bool,
    json: bool,
) -> Result<()> {
    if clear {
        m.diagnostics(addr, DiagSubFunction::CLEAR_COUNTERS)
            .await
            .map_err(driver_error)?;
    }
    let mut counters = Map::new();
    let mut lines = Vec::new();
    for sub in DiagSubFunction::COUNTERS {
        let v = m.diagnostics(addr, sub).await.map_err(driver_error)?;
        let name = sub.name().unwrap_or("counter");
        counters.insert(name.replace(' ', "_"), v.into());
        lines.push(format!("  0x{:02X} {name:<38} {v}", sub.0));
    }
    if json {
        outln!(
            "{}",
            json!({"address": addr.get(), "cleared": clear, "counters": counters})
        )?;
    } else {
        outln!(
            "diagnostic counters of address {}{}:",
            addr.get(),
            if clear { " (cleared first)" } else { "" }
        )?;
        for l in lines {
            outln!("{l}")?;
        }
    }
    Ok(())
}

async fn scan<IO: CharIo>(m: &mut MasterDriver<IO>, from: u8, to: u8, json: bool) -> Result<()> {
    if from == 0 || from > to || to > 247 {
        return Err(CliError::usage(
            "scan range must satisfy 1 ≤ --from ≤ --to ≤ 247",
        ));
    }
    // The answer delay (10 ms), request and answer (at most 40 characters in ASCII) and a
    // margin: an answering drive is heard well within it.
    let char_time = m.config().line.char_time();
    let timeout =
        bonfiglioli_modbus::slave::ANSWER_DELAY + char_time * 60 + Duration::from_millis(20);
    let bar = backup::progress(usize::from(to - from) + 1, "scanning");
    let mut found = 0;
    for a in from..=to {
        bar.set_message(format!("address {a}"));
        let addr = address(a)?;
        let answered = m.probe(addr, timeout).await.map_err(driver_error)?;
        bar.inc(1);
        if !answered {
            continue;
        }
        found += 1;
        let mut c = BonfiglioliClient::new(m, addr, "", None).probing();
        let configuration = c
            .read(&resolve(&param::CONFIGURATION.to_string(), 0)?)
            .await
            .ok();
        let status = c.read(&resolve("411", 0)?).await.ok();
        bar.suspend(|| -> Result<()> {
            if json {
                outln!(
                    "{}",
                    json!({"address": a, "configuration": configuration, "status_word": status,
                           "device_type": null, "firmware": null})
                )
            } else {
                outln!(
                    "address {a:>3}: configuration {}, status word {} (the manual defines no \
                     device type or firmware parameter)",
                    configuration.map_or_else(|| "unreadable".to_owned(), |v| v.to_string()),
                    status.map_or_else(|| "unreadable".to_owned(), |v| format!("0x{v:04X}"))
                )
            }
        })?;
    }
    bar.finish_and_clear();
    if !json {
        outln!("{found} drive(s) answered between {from} and {to}")?;
    }
    Ok(())
}

/// The state-machine state of a status word.
fn state_of(word: u16, acu: bool) -> State {
    if acu {
        AcuStateMachine::decode(word)
    } else {
        ActStateMachine::decode(word)
    }
}

/// The status word's set bits by name.
fn bits_text(word: u16, acu: bool) -> String {
    let s = if acu {
        format!("{:?}", AcuStatusWord::from_bits(word))
    } else {
        format!("{:?}", ActStatusWord::from_bits(word))
    };
    s.split_once('(')
        .and_then(|(_, rest)| rest.strip_suffix(')'))
        .map_or(s.clone(), str::to_owned)
}

async fn read_word<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address, p: u16) -> Result<u16> {
    let t = resolve(&p.to_string(), 0)?;
    m.read(addr, p, DataSet::ALL, Width::Word)
        .await
        .map(|v| v as u16)
        .map_err(|e| CliError::from(client_error(&t, Width::Word, e)))
}

async fn status<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    acu: bool,
    json: bool,
) -> Result<()> {
    let word = read_word(m, addr, param::STATUS_WORD).await?;
    let fault = read_word(m, addr, param::CURRENT_FAULT).await?;
    let warnings = read_word(m, addr, param::WARNINGS).await?;
    let state = state_of(word, acu);
    let fault_text = if fault == 0 {
        "no fault".to_owned()
    } else {
        bonfiglioli::fault(fault).map_or_else(
            || format!("fault 0x{fault:04X} (not in the manual's list)"),
            |f| f.to_string(),
        )
    };
    let warning_names: Vec<&str> = bonfiglioli::warning_bits(warnings)
        .map(|w| w.name_en)
        .collect();
    if json {
        outln!(
            "{}",
            json!({"address": addr.get(), "variant": if acu {"acu"} else {"act"},
                   "status_word": word, "state": state.name_en(), "bits": bits_text(word, acu),
                   "fault": fault, "fault_text": fault_text,
                   "warnings": warnings, "warning_names": warning_names})
        )
    } else {
        outln!(
            "status word 411: 0x{word:04X} = {} ({})",
            state.name_en(),
            bits_text(word, acu)
        )?;
        outln!("current fault 260: {fault_text}")?;
        outln!(
            "warnings 270: 0x{warnings:04X}{}",
            if warning_names.is_empty() {
                " (none)".to_owned()
            } else {
                format!(" = {}", warning_names.join(", "))
            }
        )
    }
}

/// A reference frequency in Hz as 484's raw value (2 decimals, ±999.99 Hz).
fn freq_raw(text: &str) -> Result<i64> {
    let t = resolve("484", 0)?;
    let v = t.value_from_text(text, &ValueText::default())?;
    Ok(v.raw)
}

struct ControlSession<'a> {
    addr: Address,
    port: &'a str,
    action: &'a str,
    freq: Option<i64>,
    acu: bool,
    json: bool,
}

async fn control<IO: CharIo>(m: &mut MasterDriver<IO>, s: &ControlSession<'_>) -> Result<()> {
    let addr = s.addr;
    let target = match s.action {
        "enable" => State::OperationEnabled,
        "stop" => State::SwitchedOn,
        "quick-stop" => State::QuickStopActive,
        "disable" | "reset" => State::SwitchOnDisabled,
        other => return Err(CliError::usage(format!("unknown control action `{other}`"))),
    };
    let t412 = resolve("412", 0)?;
    // 412 = 1: the control word drives the state machine (a data-set parameter: all four).
    let mode = m
        .read(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(1).unwrap_or(DataSet::ALL),
            Width::Word,
        )
        .await
        .map_err(|e| CliError::from(client_error(&t412, Width::Word, e)))?;
    if mode != 1 {
        m.write(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(5).unwrap_or(DataSet::ALL),
            Width::Word,
            1,
        )
        .await
        .map_err(|e| CliError::from(client_error(&t412, Width::Word, e)))?;
        errln!(
            "drivectl: note: 412 local/remote was {mode}; set to 1 (state machine) in RAM \
             (data set 5: all four data sets, not stored)"
        );
    }
    if let Some(raw) = s.freq {
        let t = resolve("484", 0)?;
        let data = data_of(Width::Long, raw).unwrap_or(0);
        m.write(addr, param::FREQUENCY_RAM, DataSet::ALL, Width::Long, data)
            .await
            .map_err(|e| CliError::from(client_error(&t, Width::Long, e)))?;
        if !s.acu {
            let back = m
                .read(addr, param::FREQUENCY_RAM, DataSet::ALL, Width::Long)
                .await
                .map_err(|e| CliError::from(client_error(&t, Width::Long, e)))?;
            if i64::from(back as i32) != raw {
                return Err(CliError::failed(format!(
                    "484 reference frequency RAM was written with raw {raw} but reads back {}",
                    back as i32
                )));
            }
        }
    }
    let mut last: Option<u16> = None;
    let mut word = read_word(m, addr, param::STATUS_WORD).await?;
    let start_state = state_of(word, s.acu);
    if s.action == "reset" && start_state != State::Fault {
        errln!(
            "drivectl: note: the drive shows no fault ({})",
            start_state.name_en()
        );
    }
    // At most a handful of steps: every state reaches every target in four.
    for _ in 0..8 {
        let state = state_of(word, s.acu);
        let next = if s.action == "reset" && state == State::Fault {
            Some(bonfiglioli::state::command::FAULT_RESET)
        } else if s.action == "reset" {
            None
        } else if s.acu {
            AcuStateMachine::control_toward(state, target)
        } else {
            ActStateMachine::control_toward(state, target)
        };
        let Some(cw) = next else { break };
        // A fault reset acts on a rising edge of bit 7.
        if cw & 0x80 != 0 && last.is_none_or(|l| l & 0x80 != 0) {
            write_cw(m, addr, cw & !0x80).await?;
        }
        write_cw(m, addr, cw).await?;
        last = Some(cw);
        // The drive may take a while (a stop ramps down first): poll until the state changes.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
        loop {
            tokio::time::sleep(Duration::from_millis(50)).await;
            word = read_word(m, addr, param::STATUS_WORD).await?;
            if state_of(word, s.acu) != state || tokio::time::Instant::now() >= deadline {
                break;
            }
        }
        if state_of(word, s.acu) == state || s.action == "reset" {
            break;
        }
    }
    let state = state_of(word, s.acu);
    let reached = s.action == "reset" && state != State::Fault || state == target;
    if s.json {
        outln!(
            "{}",
            json!({"address": addr.get(), "action": s.action, "status_word": word,
                   "state": state.name_en(), "reached": reached,
                   "control_word": last, "freq_raw": s.freq})
        )?;
    } else {
        outln!(
            "status word 411: 0x{word:04X} = {} ({})",
            state.name_en(),
            bits_text(word, s.acu)
        )?;
    }
    if !reached {
        return Err(CliError::failed(format!(
            "the drive did not reach {} (it shows {}); check the hardware enable (ACT: S1IND, \
             ACU: STOA/STOB), 412 local/remote and the current fault (drivectl bonfiglioli \
             status)",
            target.name_en(),
            state.name_en()
        )));
    }
    if s.action == "enable" {
        errln!(
            "drivectl: note: the motor is now enabled and follows the reference; stop it with \
             `drivectl bonfiglioli --port {} --addr {} control stop` (or quick-stop / disable)",
            s.port,
            addr.get()
        );
    }
    Ok(())
}

async fn write_cw<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address, cw: u16) -> Result<()> {
    let t = resolve("410", 0)?;
    m.write(
        addr,
        param::CONTROL_WORD,
        DataSet::ALL,
        Width::Word,
        u32::from(cw),
    )
    .await
    .map_err(|e| CliError::from(client_error(&t, Width::Word, e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_come_from_the_table_or_the_user() {
        let t372 = resolve("372", 2).unwrap();
        assert_eq!(t372.sub, 2);
        assert_eq!(table_width(&t372, None), Some(Width::Word));
        let t481 = resolve("P481", 0).unwrap();
        assert_eq!(table_width(&t481, None), Some(Width::Long));
        // 415 has no data type in the manual: refused without --word/--long.
        let t415 = resolve("415", 0).unwrap();
        assert_eq!(table_width(&t415, None), None);
        let e = check_width_known(&t415, None).unwrap_err().to_string();
        assert!(e.contains("--word") && e.contains("--long"), "{e}");
        assert_eq!(table_width(&t415, Some(Width::Long)), Some(Width::Long));
    }

    #[test]
    fn raw_values_keep_their_sign() {
        let t241 = resolve("241", 0).unwrap();
        assert_eq!(raw_of(&t241, Width::Long, 0xFFFF_FFFF), -1);
        let t372 = resolve("372", 0).unwrap();
        assert_eq!(raw_of(&t372, Width::Word, 0xFFFF), 65535);
        assert_eq!(data_of(Width::Word, 65536), None);
        assert_eq!(data_of(Width::Word, -1), Some(0xFFFF));
        assert_eq!(data_of(Width::Long, -1), Some(0xFFFF_FFFF));
        assert_eq!(data_of(Width::Long, 1 << 33), None);
    }

    #[test]
    fn bad_values_are_refused_before_the_port_opens() {
        let how = ValueText::default();
        let a = Access::default();
        // 376 1.5 kW → raw 15 (ch. 8.1.2).
        assert_eq!(write_value("376", "1.5", a, &how).unwrap().raw, 15);
        assert!(write_value("9999", "1", a, &how).is_err());
        assert!(write_value("415", "1", a, &how).is_err());
        let raw = ValueText { raw: true, ..how };
        assert!(write_value("372", "--5", a, &raw).is_err());
        // 372 is uInt: 70000 does not fit.
        assert!(write_value("372", "70000", a, &raw).is_err());
        let word = Access { word: true, ..a };
        assert!(write_value("415", "70000", word, &raw).is_err());
        assert_eq!(write_value("415", "300", word, &raw).unwrap().raw, 300);
    }

    #[test]
    fn refusals_name_the_cause_and_the_way_out() {
        let t = resolve("372", 0).unwrap();
        let e = |exception, vabus| DriverError::Device {
            exception: ExceptionCode(exception),
            vabus,
        };
        match client_error(&t, Width::Word, e(4, Some(9))) {
            ClientError::Device(d) => {
                assert_eq!(d.kind, DeviceErrorKind::Refused);
                assert!(d.message.contains("--dataset 1"), "{}", d.message);
            }
            other => panic!("{other:?}"),
        }
        match client_error(&t, Width::Word, e(4, Some(11))) {
            ClientError::Device(d) => assert_eq!(d.kind, DeviceErrorKind::Absent),
            other => panic!("{other:?}"),
        }
        for (x, v) in [(2, None), (4, Some(14)), (4, Some(10))] {
            match client_error(&t, Width::Word, e(x, v)) {
                ClientError::Device(d) => assert!(
                    d.message.contains("is not 16-bit: try --long"),
                    "{}",
                    d.message
                ),
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn link_settings_are_the_tables_bus_parameters() {
        for p in LINK_SETTINGS {
            assert!(bonfiglioli::by_index(*p).is_some(), "{p}");
        }
        assert!(NOT_RESTORED.contains(&param::ADDRESS));
    }
}
