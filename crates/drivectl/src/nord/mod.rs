//! `drivectl uss …` and `drivectl ctt2 --sim …`: NORD NORDAC LINK (SK 270E-FDS, SK 280E-FDS)
//! over USS on RS-485 or over CTT2 through an AS-i master.
//!
//! Both transports carry the same USS parameter channel (PKW) and process data (PZD), so every
//! command here is written once, generic over `ctt2_uss::client::NordClient<C>` with `C` any
//! transport implementing [`ParameterChannel`] and [`ProcessChannel`]: drive-client's
//! [`NordParamClient`] is the [`ParamClient`], with its messages in the command line's words
//! ([`Cli`]); read, write, watch, backup and restore are the tool layer's. What only NORD has lives here: array elements and parameter sets (`--array K`,
//! `--set S`, 1-based as the manual counts them), `status` (status word with the state
//! A–H, actual values in % and Hz, P700) and `control` (the state machine of section 4.5.3
//! over process data).
//!
//! [`Target::sub`] of a NORD parameter is the IND word itself (section 4.6.1.2, see
//! [`nord_sub`](drive_client::target::nord_sub)): a parameter with parameter sets carries the set in bits 8–9 and an array
//! element in bits 10–15; a parameter without sets carries its element in bits 8–15.

pub mod ctt2;
pub mod decode;
pub mod sim;
pub mod uss;

mod control;
mod info;
mod status;

use std::time::Duration;

use clap::{Args, Subcommand};
use ctt2_uss::client::{self, NordClient, ParameterChannel, ProcessChannel};
use drive_profile::nord;
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

pub use drive_client::nord::param;
use drive_client::nord::{NordParamClient, table_target};

use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ParamClient, Target, ValueText};
use crate::tool::cmd::{self, WriteValue};
use crate::tool::front::Cli;
use crate::tool::output::trim_float;
use crate::tool::{backup, write};

use control::{ControlSession, Setpoint, control, setpoint_word};
use status::status;

/// Examples below `drivectl uss|ctt2 write --help`; the `ctt2` help gets its own prefix
/// ([`ctt2::with_help`]).
const WRITE_HELP: &str = "\
Examples:
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P102 10 --set 3       10.00 s in parameter set 3 (raw 1000)
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P102 2,5 --set 2      decimal comma: raw 250
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P543 3 --array 2      IW2 = current
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P102 1.5 --volatile   RAM only (AK 14), for values that change often
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P102 1000 --raw --set 3

Values are physical in the table's resolution (P102 0.01 s: 2.5 → raw 250) and checked against
the table before anything is sent; a NORD parameter is a 16-bit word (BU 0255 ch. 6). The
drive's EEPROM takes about 100 000 writes (ch. 4.1.2): values that change often go to RAM with
--volatile (--no-eeprom is the same), or set P560 save to EEPROM = 0. EEPROM-wear log:
non-volatile writes are remembered for a minute in eeprom-writes.json in $DRIVECTL_STATE_DIR,
else $XDG_STATE_HOME/drivectl, else ~/.local/state/drivectl.";

/// `--array` and `--set` of the parameter commands.
#[derive(Debug, Args, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sub {
    /// Array element, 1-based as the manual counts them ([-01] = 1): P543 [-02] is --array 2.
    /// Only for array parameters; `read` and `watch` of an array without it show every element.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u8).range(1..=64))]
    pub array: Option<u8>,
    /// Parameter set 1–4, only for parameters that have one value per set (P102, P105, P112);
    /// default 1.
    #[arg(long, value_name = "S", value_parser = clap::value_parser!(u8).range(1..=4))]
    pub set: Option<u8>,
}

impl cmd::Selector for Sub {
    const FAMILY: Family = Family::Nord;
    const PARAMS: &'static str =
        "Parameter numbers (P102 or 102; numbers outside the table are read raw)";
    const PARAM: &'static str = "Parameter number";
    const INFO_PARAM: &'static str =
        "Parameter number (P102 or 102; a number outside the table shows only the drive's value)";
    const VOLATILE: &'static str = "Write to RAM only (AK 11–14: the way for values that change \
        often; lost at power-off). `--no-eeprom` is the same";
    const VOLATILE_ALIAS: Option<&'static str> = Some("no-eeprom");
    const FORCE: &'static str = "Skip the access/range/value-list/EEPROM-wear checks of the \
        table (a value that does not fit the parameter's 16 bits is never sent)";

    fn targets(params: &[String], sub: Self) -> Result<Vec<Target>> {
        resolve_all(params, sub)
    }

    fn check_info(param: &str, sub: Self) -> Result<()> {
        info::info_targets(param, sub).map(drop)
    }

    fn write_value(param: &str, value: &str, sub: Self, how: &ValueText) -> Result<WriteValue> {
        write_value(param, value, sub, how)
    }

    /// The table's checks that do not depend on the drive (access, range, value list; the
    /// EEPROM-wear rule needs P560, read later): a write they refuse reads and sends nothing.
    fn precheck_write(v: &WriteValue, force: bool) -> Result<()> {
        let request = write::WriteRequest {
            target: v.target,
            raw: v.raw,
            persistence: Persistence::Volatile,
            force,
        };
        write::check_drive("", &request).map(drop)
    }
}

/// The commands `drivectl uss` and `drivectl ctt2` share.
#[derive(Debug, Subcommand)]
pub enum NordCommand {
    /// Read parameters: value with unit and resolution (faults, control and status words
    /// decoded) and the raw value; one line (or JSON object) per parameter, array element or
    /// set.
    ///
    /// Every name, --array and --set is checked against the table before anything is sent. A
    /// refusal of one parameter is reported for it and the others are still read (exit 1 at the
    /// end); a link failure stops.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 read P102 --set 3\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 read P543 --array 2 --json\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 read P700              all three elements\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 read P105 P560 P744"
    )]
    Read(cmd::ReadArgs<Sub>),
    /// What the table knows about a parameter — range, default, unit, resolution, parameter
    /// sets, array elements, access — and the drive's current value in every set and element
    /// (or the one --set/--array names); for an array, the drive's own count of elements (AK
    /// 9).
    ///
    /// USS and CTT2 have no order that reads a parameter's description from the drive (BU 0255
    /// 4.6.1.1 lists AK 0–14: values and the number of array elements only), so range and
    /// default are the table's; MOVILINK's `info` reads them from the drive.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 info P102              every parameter set\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 info P102 --set 3 --json\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 info P700              every element, with AK 9's count"
    )]
    Info(cmd::InfoArgs<Sub>),
    /// Write a parameter (checked against the table first), then read it back.
    #[command(after_help = WRITE_HELP)]
    Write(cmd::WriteArgs<Sub, cmd::NoConfirm>),
    /// Poll parameters at a steady rhythm (as `drivectl movilink watch`). Ctrl-C ends it.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 watch P700 P740 P741\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 watch P102 --set 2 --interval 500 --count 20 --csv"
    )]
    Watch(cmd::WatchArgs<Sub>),
    /// The status word decoded (state A–H with its English and German name, every bit), the
    /// actual values IW1–IW3 in % and as P543 says (frequency in Hz of P105), and P700 present
    /// fault, warning and reason for switch-on disabled.
    ///
    /// The process data exchange that reads the status word sends a control word without bit
    /// 10 ("control data valid"), which the drive ignores: `status` never changes the drive.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 status\n  drivectl uss --port /dev/ttyUSB0 --addr 1 status --json"
    )]
    Status,
    /// Drive the state machine (section 4.5.3) over process data: enable (operation enabled,
    /// SW1 = --setpoint), stop (shutdown: braking ramp, then ready to switch on), quick-stop
    /// (quick stop, then switch-on disabled), disable (voltage off at once: the motor coasts)
    /// or reset a fault (a 0→1 edge of bit 7).
    ///
    /// Ctrl-C or a failure while the drive is being enabled sends shutdown and says so; an
    /// enabled drive keeps running after drivectl ends, and drivectl says how to stop it.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 control enable --setpoint 50     50 % of P105 clockwise\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 control enable --setpoint -25    counter-clockwise\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 control stop\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 control reset"
    )]
    Control {
        /// What to do.
        #[arg(value_parser = ["enable", "stop", "quick-stop", "disable", "reset"])]
        action: String,
        /// Setpoint SW1 in percent of P105 maximum frequency, sent with every control word;
        /// negative = counter-clockwise; default 0. The word holds −200 % (8000h) … 199.9939 %
        /// (7FFFh) in steps of 100/16384 % (4000h = 100 %, BU 0255 4.5.4): the nearest step is
        /// sent when it reads as typed (10 → 0666h = 9.9976 %); a value more precise than the
        /// word (100.0001) is refused naming the nearest step, unless --round.
        #[arg(long, allow_hyphen_values = true, value_name = "PERCENT")]
        setpoint: Option<String>,
        /// Accept a setpoint SW1 cannot hold exactly and send the nearest one (said on
        /// standard error).
        #[arg(long)]
        round: bool,
        /// The parameter set the drive runs with (control word bits 14/15), 1–4.
        #[arg(long, default_value_t = 1, value_name = "S", value_parser = clap::value_parser!(u8).range(1..=4))]
        set: u8,
        /// Give up waiting for the state after this many seconds, 1–600 (a stop waits for the
        /// braking ramp).
        #[arg(long, default_value_t = 30, value_name = "SECONDS", value_parser = clap::value_parser!(u64).range(1..=600))]
        wait: u64,
    },
    /// Save every readable parameter in every array element and parameter set to a JSON file.
    #[command(after_help = backup_examples!("drivectl uss --port /dev/ttyUSB0 --addr 1"))]
    Backup(backup::BackupArgs),
    /// Write a backup file back (every array element and parameter set; P560 last) and verify
    /// every value.
    #[command(after_help = restore_examples!("drivectl uss --port /dev/ttyUSB0 --addr 1"))]
    Restore(backup::RestoreArgs),
}

/// Resolve a NORD parameter (`P102`, `102`, a PNU outside the table for raw access) with its
/// array element and parameter set. Checked against the table: `--set` only for parameters
/// with parameter sets, `--array` only for arrays and within their length. An array without
/// `--array` is every element when `every_element`, else refused.
pub fn resolve(key: &str, sub: Sub, every_element: bool) -> Result<Vec<Target>> {
    use drive_client::nord::SelectorError as E;
    drive_client::nord::resolve(key, sub.array, sub.set, every_element).map_err(|e| match e {
        E::Target(e) => CliError::from(e),
        E::NoSets { name } => CliError::usage(format!(
            "{name} has no parameter sets: it takes no --set; nothing was sent"
        )),
        E::NotAnArray { name } => CliError::usage(format!(
            "{name} is no array: it takes no --array; nothing was sent"
        )),
        E::NoSuchElement { name, len, element } => CliError::usage(format!(
            "{name} has the elements [-01]…[-{len:02}]: --array {element} is none of them \
             (1…{len}); nothing was sent"
        )),
        E::WholeArray { name, len } => CliError::usage(format!(
            "{name} is an array of {len} elements: add --array 1…{len} ([-01] = 1)"
        )),
        other => CliError::usage(other.to_string()),
    })
}

/// Resolve every name (arrays as all their elements).
pub fn resolve_all(params: &[String], sub: Sub) -> Result<Vec<Target>> {
    let mut all = Vec::new();
    for p in params {
        all.extend(resolve(p, sub, true)?);
    }
    Ok(all)
}

/// A client error without a parameter (process data).
fn link_error<E: std::fmt::Display>(e: client::ClientError<E>) -> CliError {
    CliError::failed(e.to_string())
}

/// The client of the drive behind `c` (`s` names and identifies it), its messages in the
/// command line's words.
fn param_client<'a, C>(c: &'a mut NordClient<C>, s: &Session) -> NordParamClient<'a, C> {
    NordParamClient::new(c, &s.key, s.identity.clone()).with_front_end(&Cli)
}

/// The target of `number` with element `array` and set `set` (1-based).
fn target_of(number: u16, array: Option<u8>, set: Option<u8>) -> Result<Target> {
    resolve(&number.to_string(), Sub { array, set }, false)?
        .into_iter()
        .next()
        .ok_or_else(|| CliError::failed(format!("P{number} is not in the NORD table")))
}

/// Resolve and parse a write: names, element, set, strict value, the 16-bit width (a NORD
/// parameter is a word, BU 0255 ch. 6; outside the table too).
pub fn write_value(param: &str, value: &str, sub: Sub, how: &ValueText) -> Result<WriteValue> {
    let t = resolve(param, sub, false)?
        .into_iter()
        .next()
        .ok_or_else(|| CliError::usage(format!("no NORD parameter `{param}`")))?;
    let parsed = t.value_from_text(value, how)?;
    t.check_width(parsed.raw)?;
    let (lo, hi) = drive_profile::param::WIRE_16;
    if !(lo..=hi).contains(&parsed.raw) {
        return Err(CliError::usage(format!(
            "value {} does not fit {}: a NORD parameter is a 16-bit word ({lo}…{hi}, BU 0255 \
             ch. 6); nothing was sent",
            parsed.raw,
            t.label()
        )));
    }
    Ok(WriteValue {
        target: t,
        raw: parsed.raw,
        rounded_from: parsed.rounded_from,
    })
}

/// Everything a command can check without the drive, before the port is opened.
pub fn precheck(cmd: &NordCommand) -> Result<()> {
    match cmd {
        NordCommand::Control {
            setpoint: Some(s),
            round,
            ..
        } => control::setpoint_word(s, *round).map(drop),
        c => common_of!(c, NordCommand).map_or(Ok(()), |c| cmd::precheck(c, &[])),
    }
}

/// What the transport tells the shared commands.
#[derive(Debug, Clone, Default)]
pub struct Session {
    /// `--json`.
    pub json: bool,
    /// The drive's name in the EEPROM-wear log.
    pub key: String,
    /// The command line that reaches this drive again (`drivectl uss --port … --addr 1`), for
    /// the notes that say how to stop a drive left running.
    pub again: String,
    /// Fields that identify the drive in a backup.
    pub identity: Map<String, Value>,
    /// The drive is simulated by this very process: it ends with the command.
    pub simulated: bool,
    /// Setpoints and actual values the process data carry beside the control and status word
    /// (0–3: a USS telegram's PZD words − 1; CTT2: 3).
    pub actuals: u8,
}

/// The drive behind a NORD client, for the common commands.
struct Drive<'a, C> {
    c: &'a mut NordClient<C>,
    s: &'a Session,
}

impl<C: ParameterChannel> cmd::Drive for Drive<'_, C> {
    type Selector = Sub;
    type Confirm = cmd::NoConfirm;
    type Client<'b>
        = NordParamClient<'b, C>
    where
        Self: 'b;

    async fn reader(&mut self, sub: Sub, _: &[Target]) -> Result<Self::Client<'_>> {
        Ok(param_client(self.c, self.s).raw_array(sub.array.is_some()))
    }

    fn keeper(&mut self) -> Result<Self::Client<'_>> {
        Ok(param_client(self.c, self.s))
    }

    async fn before_restore<'c>(pc: &mut Self::Client<'c>)
    where
        Self: 'c,
    {
        warn_ram_only(pc).await;
    }

    async fn writer(
        &mut self,
        args: &cmd::WriteArgs<Sub, cmd::NoConfirm>,
        request: &mut write::WriteRequest,
        _: bool,
    ) -> Result<cmd::Writer<Self::Client<'_>>> {
        let mut pc = param_client(self.c, self.s).raw_array(args.sel.array.is_some());
        let mut note = None;
        if !args.volatile {
            let (persistence, ram_only) = eeprom_or_ram(&mut pc, &request.target).await?;
            request.persistence = persistence;
            note = ram_only.then(|| {
                format!(
                    "P560 save to EEPROM is 0 (RAM only) on this drive: {} is kept in RAM and \
                     lost at power-off (write P560 = 1 to keep changes)",
                    request.target.label()
                )
            });
        }
        Ok(cmd::Writer::To {
            client: pc,
            yes: false,
            note,
        })
    }

    async fn info(&mut self, args: &cmd::InfoArgs<Sub>) -> Result<drive_client::info::Info> {
        let targets = info::info_targets(&args.param, args.sel)?;
        info::info(self.c, self.s, &targets, args.sel).await
    }
}

/// Run one of the shared commands on the drive behind `c`.
pub async fn execute<C>(c: &mut NordClient<C>, s: &Session, cmd: &NordCommand) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    if let Some(common) = common_of!(cmd, NordCommand) {
        return cmd::execute(&mut Drive { c, s }, common, s.json).await;
    }
    match cmd {
        NordCommand::Status => status(c, s).await,
        NordCommand::Control {
            action,
            setpoint,
            round,
            set,
            wait,
        } => {
            let setpoint = setpoint
                .as_deref()
                .map(|t| setpoint_word(t, *round))
                .transpose()?;
            if let Some(Setpoint {
                word,
                rounded_from: Some(x),
            }) = setpoint
            {
                errln!(
                    "drivectl: note: SW1 cannot hold {x} %; sending the nearest setpoint it \
                     holds, {} % (0x{word:04X})",
                    trim_float(nord::percent_from_word(word), 4)
                );
            }
            let session = ControlSession {
                action: action.as_str(),
                setpoint: setpoint.map(|s| s.word),
                set: *set,
                wait: Duration::from_secs(*wait),
            };
            control(c, s, &session).await
        }
        _ => Ok(()),
    }
}

/// Where a write without `--volatile` goes: to EEPROM as P560 says. With P560 = 0 the drive
/// keeps it in RAM only, so it is a RAM-only write (AK 14/12, which does the same) that wears
/// no EEPROM and is not held back by the EEPROM-wear rule; the second value says so, for the
/// note after the write that the value is lost at power-off. P560 itself always counts as an
/// EEPROM write.
async fn eeprom_or_ram<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    target: &Target,
) -> Result<(Persistence, bool)> {
    if target.index == param::SAVE_TO_EEPROM || target.param.is_none() {
        return Ok((Persistence::NonVolatile, false));
    }
    let p560 = table_target(param::SAVE_TO_EEPROM)?;
    match pc.read(&p560).await {
        Ok(0) => Ok((Persistence::Volatile, true)),
        Ok(_) => Ok((Persistence::NonVolatile, false)),
        Err(e) => Err(p560.error(e)),
    }
}

/// A restore writes with AK 2/7, which P560 = 0 keeps in RAM: say so before writing.
async fn warn_ram_only<C: ParameterChannel>(pc: &mut NordParamClient<'_, C>) {
    let Ok(t) = table_target(param::SAVE_TO_EEPROM) else {
        return;
    };
    if let Ok(0) = pc.read(&t).await {
        errln!(
            "drivectl: warning: P560 save to EEPROM is 0 (RAM only) on this drive: the restored \
             values are lost at power-off unless the file sets P560 to 1 (it is written last) or \
             you write P560 1 afterwards"
        );
    }
}

pub use drive_client::meaning::nord_state_text as state_text;

#[cfg(test)]
mod tests;
