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

use std::time::Duration;

use clap::{Args, Subcommand};
use ctt2_uss::client::{self, NordClient, ParameterChannel, ProcessChannel};
use ctt2_uss::uss::pzd::PzdIn;
use drive_profile::nord::{self, ControlWord, NordStateMachine, State, StatusWord, command};
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value, json};

pub use drive_client::nord::param;
use drive_client::nord::{NordParamClient, table_target};

use crate::error::{CliError, Result};
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ClientError, ParamClient, Target, ValueText, parse_decimal};
use crate::tool::front::Cli;
use crate::tool::interrupt::Interrupt;
use crate::tool::motor::{AtEnd, Motion, MotorGuard, Stopped};
use crate::tool::output::{physical_text, trim_float};
use crate::tool::{backup, watch, write};

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
    Read {
        /// Parameter numbers (P102 or 102; numbers outside the table are read raw).
        #[arg(required = true, num_args = 1..)]
        params: Vec<String>,
        #[command(flatten)]
        sub: Sub,
    },
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
    Info {
        /// Parameter number (P102 or 102; a number outside the table shows only the drive's
        /// value).
        param: String,
        #[command(flatten)]
        sub: Sub,
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
        sub: Sub,
        /// Write to RAM only (AK 11–14: the way for values that change often; lost at
        /// power-off). `--no-eeprom` is the same.
        #[arg(long, visible_alias = "no-eeprom")]
        volatile: bool,
        /// VALUE is the raw bus value.
        #[arg(long)]
        raw: bool,
        /// Skip the access/range/value-list/EEPROM-wear checks of the table (a value that does
        /// not fit the parameter's 16 bits is never sent).
        #[arg(long)]
        force: bool,
        /// Accept a physical value the parameter cannot hold exactly and write the nearest one.
        #[arg(long)]
        round: bool,
    },
    /// Poll parameters at a steady rhythm (as `drivectl movilink watch`). Ctrl-C ends it.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 watch P700 P740 P741\n  \
        drivectl uss --port /dev/ttyUSB0 --addr 1 watch P102 --set 2 --interval 500 --count 20 --csv"
    )]
    Watch {
        /// Parameter numbers.
        #[arg(required = true, num_args = 1..)]
        params: Vec<String>,
        #[command(flatten)]
        sub: Sub,
        #[command(flatten)]
        watch: watch::WatchArgs,
    },
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
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 backup --out drive1.json\n  drivectl uss --port /dev/ttyUSB0 --addr 1 backup --out drive1.json --overwrite"
    )]
    Backup(backup::BackupArgs),
    /// Write a backup file back (every array element and parameter set; P560 last) and verify
    /// every value.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 --addr 1 restore drive1.json --dry-run\n  drivectl uss --port /dev/ttyUSB0 --addr 1 restore drive1.json"
    )]
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

/// The value a write sends, checked without the drive.
#[derive(Debug, Clone, Copy)]
pub struct WriteValue {
    /// The parameter with its element and set.
    pub target: Target,
    /// The raw value.
    pub raw: i64,
    /// What the user typed, when it was rounded (`--round`).
    pub rounded_from: Option<f64>,
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

/// A setpoint as the SW1 word carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// The word (4000h = 100 %).
    pub word: u16,
    /// What the user typed, when the word is its nearest (`--round`).
    pub rounded_from: Option<f64>,
}

/// A setpoint in percent as the SW1 word, strictly parsed: BU 0255 4.5.4 sends it as an
/// integer −32768…32767 (8000h…7FFFh) with 4000h = 100 %, so it holds −200 % … 199.9939 %
/// in steps of 100/16384 = 0.006103515625 %. The word holds a value when its nearest step,
/// written with as many decimals as were typed, reads as typed (`10` → 0666h = 9.9976 %,
/// `33.3` → 1550h = 33.3008 %); a value with more precision than the word has (`100.0001`) is
/// refused naming the nearest step, unless `round`. A value past the word's ends is refused,
/// not even `round` cuts it to fit.
pub fn setpoint_word(text: &str, round: bool) -> Result<Setpoint> {
    let p = parse_decimal(text).ok_or_else(|| {
        CliError::usage(format!(
            "`{}` is not a setpoint in percent (e.g. 50, -25 or 12,5)",
            crate::decode::escape(text)
        ))
    })?;
    let text = text.trim();
    let percent_of = |w: i16| nord::percent_from_word(w as u16);
    // Four decimals name every step apart (0.0061 % each), and are taken back as typed.
    let shown = |w: i16| format!("{} % (0x{:04X})", trim_float(percent_of(w), 4), w as u16);
    // The nearest step, then whether the word has it.
    let steps =
        drive_profile::scaling::round(p * f64::from(drive_profile::scaling::PERCENT_100) / 100.0);
    let end = if !steps.is_finite() || steps > f64::from(i16::MAX) {
        Some(i16::MAX)
    } else if steps < f64::from(i16::MIN) {
        Some(i16::MIN)
    } else {
        None
    };
    if let Some(end) = end {
        return Err(CliError::usage(format!(
            "setpoint {text} % is past what SW1 holds: {} … {} (BU 0255 4.5.4: −32768…32767, \
             4000h = 100 %); the nearest setpoint it holds is {}; nothing was sent",
            shown(i16::MIN),
            shown(i16::MAX),
            shown(end)
        )));
    }
    let word = steps as i16;
    let held = percent_of(word);
    let decimals = text.split_once(['.', ',']).map_or(0, |(_, f)| f.len());
    let at_typed = |x: f64| format!("{x:.decimals$}").parse::<f64>().unwrap_or(f64::NAN);
    if (held - p).abs() <= 1e-9 * p.abs().max(1.0) || at_typed(held) == at_typed(p) {
        return Ok(Setpoint {
            word: word as u16,
            rounded_from: None,
        });
    }
    if !round {
        return Err(CliError::usage(format!(
            "SW1 cannot hold {text} % (steps of 100/16384 = 0.006103515625 %, 4000h = 100 %): \
             the nearest setpoint it holds is {}; give that, or add --round to have it rounded; \
             nothing was sent",
            shown(word)
        )));
    }
    Ok(Setpoint {
        word: word as u16,
        rounded_from: Some(p),
    })
}

/// Everything a command can check without the drive, before the port is opened.
pub fn precheck(cmd: &NordCommand) -> Result<()> {
    match cmd {
        NordCommand::Read { params, sub } | NordCommand::Watch { params, sub, .. } => {
            resolve_all(params, *sub).map(drop)
        }
        NordCommand::Info { param, sub } => info_targets(param, *sub).map(drop),
        NordCommand::Write {
            param,
            value,
            sub,
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
            let v = write_value(param, value, *sub, &how)?;
            // The table's checks that do not depend on the drive (access, range, value list;
            // the EEPROM-wear rule needs P560, read later): a write they refuse reads and
            // sends nothing.
            let request = write::WriteRequest {
                target: v.target,
                raw: v.raw,
                persistence: Persistence::Volatile,
                force: *force,
            };
            write::check_drive("", &request).map(drop)
        }
        NordCommand::Control {
            setpoint: Some(s),
            round,
            ..
        } => setpoint_word(s, *round).map(drop),
        NordCommand::Restore(r) => backup::check_file(&r.file, Family::Nord, &[]),
        _ => Ok(()),
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

/// Run one of the shared commands on the drive behind `c`.
pub async fn execute<C>(c: &mut NordClient<C>, s: &Session, cmd: &NordCommand) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    let json = s.json;
    match cmd {
        NordCommand::Read { params, sub } => {
            let targets = resolve_all(params, *sub)?;
            let mut pc = param_client(c, s).raw_array(sub.array.is_some());
            crate::tool::read::read_all(&mut pc, &targets, json).await
        }
        NordCommand::Watch {
            params,
            sub,
            watch: watch_args,
        } => {
            let targets = resolve_all(params, *sub)?;
            let options = watch_args.options(json)?;
            let mut pc = param_client(c, s).raw_array(sub.array.is_some());
            watch::watch(
                &mut pc,
                &targets,
                options,
                &mut |text| out!("{text}"),
                watch::ctrl_c(),
            )
            .await
            .map(drop)
        }
        NordCommand::Write {
            param,
            value,
            sub,
            volatile,
            raw,
            force,
            round,
        } => {
            let how = ValueText {
                raw: *raw,
                force: *force,
                round: *round,
            };
            let v = write_value(param, value, *sub, &how)?;
            if let (Some(x), Some(p)) = (v.rounded_from, v.target.param) {
                errln!(
                    "drivectl: note: {} cannot hold {x} exactly; writing the nearest value it takes, {}",
                    p.label(),
                    physical_text(p, v.raw)
                );
            }
            let mut pc = param_client(c, s).raw_array(sub.array.is_some());
            let (persistence, ram_only) = if *volatile {
                (Persistence::Volatile, false)
            } else {
                eeprom_or_ram(&mut pc, &v.target).await?
            };
            let request = write::WriteRequest {
                target: v.target,
                raw: v.raw,
                persistence,
                force: *force,
            };
            let done = write::write_checked(&mut pc, &request, false).await?;
            if ram_only {
                errln!(
                    "drivectl: note: P560 save to EEPROM is 0 (RAM only) on this drive: {} is \
                     kept in RAM and lost at power-off (write P560 = 1 to keep changes)",
                    v.target.label()
                );
            }
            write::print_written(&v.target, &done, json)
        }
        NordCommand::Info { param, sub } => info(c, s, &info_targets(param, *sub)?, *sub).await,
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
        NordCommand::Backup(b) => {
            let mut pc = param_client(c, s);
            let stop = Interrupt::install("the backup file was not written");
            backup::backup(&mut pc, &b.out, b.overwrite, json, &stop).await
        }
        NordCommand::Restore(r) => {
            let mut pc = param_client(c, s);
            if !r.dry_run {
                warn_ram_only(&mut pc).await;
            }
            let stop = Interrupt::install(
                "the drive may be half restored; run the same restore again to finish it",
            );
            let opts = r.options();
            backup::restore(&mut pc, &r.file, opts, json, &stop).await
        }
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

/// A state with the manual's letter and both names: `E operation enabled (Betrieb
/// freigegeben)`.
pub fn state_text(state: State) -> String {
    match nord::state_info(state) {
        Some(i) => format!("{} {} ({})", i.letter, i.name_en, i.name_de),
        None => format!("? {} (no state of the manual)", state.name_en()),
    }
}

/// The set bits of a status word by their English names.
fn status_bits(sw: StatusWord) -> Vec<&'static str> {
    sw.set_bits().map(|b| b.name_en).collect()
}

/// What one actual value means, from its P543 function (the simulator's subset of the public
/// NORD documentation's list; 4000h = 100 % of P105 for frequencies, of P112 for current).
fn actual_json(word: u16, function: Option<i64>, p105_hz: Option<f64>, p112: Option<f64>) -> Value {
    let percent = nord::percent_from_word(word);
    let name = function.and_then(|f| {
        nord::by_index(param::BUS_ACTUAL_VALUE)
            .and_then(|p| p.values.iter().find(|v| v.value == f))
            .map(|v| v.en)
    });
    let (value, unit) = match function {
        Some(1 | 8) => (p105_hz.map(|r| nord::word_to_physical(word, r)), Some("Hz")),
        // The current's 100 % is P112 (itself in % of the rated current).
        Some(3) => (
            p112.map(|r| nord::word_to_physical(word, r)),
            Some("% of rated current"),
        ),
        _ => (None, None),
    };
    json!({"word": word, "hex": format!("0x{word:04X}"), "percent": percent,
           "function": function, "function_name": name, "value": value, "unit": unit})
}

fn actual_text(v: &Value) -> String {
    let mut s = format!(
        "{} = {} %",
        v["hex"].as_str().unwrap_or(""),
        trim_float(v["percent"].as_f64().unwrap_or(0.0), 2)
    );
    if let (Some(x), Some(unit)) = (v["value"].as_f64(), v["unit"].as_str()) {
        s.push_str(&format!(" = {} {unit}", trim_float(x, 2)));
    }
    match (v["function"].as_i64(), v["function_name"].as_str()) {
        (Some(f), Some(n)) => s.push_str(&format!(" (P543 function {f}: {n})")),
        (Some(f), None) => s.push_str(&format!(" (P543 function {f})")),
        _ => {}
    }
    s
}

/// The targets `info` reads: what `--array`/`--set` name, else every array element in every
/// parameter set.
pub fn info_targets(key: &str, sub: Sub) -> Result<Vec<Target>> {
    let first = resolve(key, sub, true)?;
    let sets = first
        .first()
        .filter(|t| t.param.is_some())
        .and_then(|t| nord::by_index(t.index))
        .is_some_and(|p| p.parameter_set);
    if !sets || sub.set.is_some() {
        return Ok(first);
    }
    let mut all = Vec::new();
    for set in 1..=4 {
        all.extend(resolve(
            key,
            Sub {
                set: Some(set),
                ..sub
            },
            true,
        )?);
    }
    Ok(all)
}

/// `info`: see [`NordCommand::Info`]. A refusal of one set or element is shown for it; a link
/// failure stops.
async fn info<C: ParameterChannel>(
    c: &mut NordClient<C>,
    s: &Session,
    targets: &[Target],
    sub: Sub,
) -> Result<()> {
    let Some(first) = targets.first().copied() else {
        return Err(CliError::failed("no parameter to show"));
    };
    let p = first.param.and_then(|_| nord::by_index(first.index));
    let mut pc = param_client(c, s).raw_array(sub.array.is_some());
    let mut current = Vec::new();
    for t in targets {
        match pc.read(t).await {
            Ok(raw) => current.push((*t, Ok(raw))),
            Err(ClientError::Device(d)) => current.push((*t, Err(d.message))),
            Err(e) => return Err(t.error(e)),
        }
    }
    // AK 9: the drive's own number of elements, for an array (or a raw PNU read as one).
    let count = if p.map_or(sub.array.is_some(), |p| p.array_len.is_some()) {
        match pc.element_count(first.index).await {
            Ok(n) => Some(Ok(n)),
            Err(ClientError::Device(d)) => Some(Err(d.message)),
            Err(e) => return Err(first.error(e)),
        }
    } else {
        None
    };
    let physical = |raw: i64| first.param.map_or(raw as f64, |q| q.to_physical(raw));
    let text_of = |raw: i64| {
        first
            .param
            .map_or_else(|| raw.to_string(), |q| physical_text(q, raw))
    };
    if s.json {
        let values: Vec<Value> = current
            .iter()
            .map(|(t, r)| {
                let mut v = crate::decode::param_json(t, r.as_ref().ok().copied());
                if let (Value::Object(m), Err(e)) = (&mut v, r) {
                    m.insert("error".into(), e.clone().into());
                }
                v
            })
            .collect();
        outln!(
            "{}",
            json!({
                // The keys of `movilink info --json` and `params --json` where they mean the
                // same: raw values plain, physical ones as `*_value` in the table's unit.
                "index": first.index,
                "number": p.map(|q| q.label().to_string()),
                // One target: its label and selector; several (every set or element): the
                // parameter, each one's in `current`.
                "label": if targets.len() == 1 { first.label() } else {
                    p.map_or_else(|| first.label(), |q| q.label().to_string())
                },
                "selector": if targets.len() == 1 { first.selector_json() } else { Value::Null },
                "name_de": p.map(|q| q.name_de), "name_en": p.map(|q| q.name_en),
                "unit": p.map(|q| q.unit),
                "range": p.and_then(|q| q.raw_range).map(|(lo, hi)| json!({
                    "min": lo, "max": hi, "min_value": physical(lo), "max_value": physical(hi),
                })),
                "default": p.and_then(|q| q.default_raw),
                "default_value": p.and_then(|q| q.default_raw).map(physical),
                "resolution": p.and_then(|q| q.resolution).map(|r| json!({
                    "step": r.step, "decimals": r.decimals, "text": r.text,
                })),
                "access": p.map(|q| q.access.to_string()),
                "parameter_set": p.map(|q| q.parameter_set),
                "array_len": p.and_then(|q| q.array_len),
                "array_len_drive": count.as_ref().and_then(|c| c.as_ref().ok().copied()),
                "limits_from": p.map(|_| "table"),
                // The drive's values (every set/element asked for), as `read --json` shows
                // them; `values` is the value list in `params --json`.
                "current": values,
                "values": p.map(|q| q.values.iter().map(|v| json!({
                    "value": v.value, "de": v.de, "en": v.en,
                })).collect::<Vec<_>>()),
            })
        )?;
        return info_outcome(&current);
    }
    match p {
        Some(q) => outln!(
            "{} {} ({}), PNU {} (0x{:03X})",
            q.label(),
            q.name_en,
            q.name_de,
            first.index,
            first.index
        )?,
        None => outln!(
            "PNU {} (0x{:03X}): not in the NORD table; only the drive's value is known",
            first.index,
            first.index
        )?,
    }
    if let Some(q) = p {
        let range = q.raw_range.map_or_else(
            || "not in the table (a 16-bit word)".to_owned(),
            |(lo, hi)| format!("{} … {} (raw {lo} … {hi})", text_of(lo), text_of(hi)),
        );
        outln!("  range       {range}")?;
        outln!(
            "  default     {}",
            q.default_raw.map_or_else(
                || "not in the table".to_owned(),
                |d| format!("{} (raw {d})", text_of(d))
            )
        )?;
        outln!(
            "  resolution  {}",
            q.resolution.map_or_else(
                || "1 (an integer)".to_owned(),
                |r| format!("{} {}", r.text, q.unit).trim_end().to_owned()
            )
        )?;
        outln!(
            "  access      {}",
            if q.access.is_writable() {
                "read-write"
            } else {
                "read-only"
            }
        )?;
        outln!(
            "  sets        {}",
            if q.parameter_set {
                "one value per parameter set 1–4 (IND bits 8–9; --set)"
            } else {
                "none (one value for every parameter set)"
            }
        )?;
        let drive = match &count {
            Some(Ok(n)) => format!("; the drive counts {n} (AK 9)"),
            Some(Err(e)) => format!("; the drive's count (AK 9): {e}"),
            None => String::new(),
        };
        outln!(
            "  elements    {}{drive}",
            q.array_len.map_or_else(
                || "none (no array)".to_owned(),
                |n| format!("{n}: [-01] … [-{n:02}] (--array 1…{n})")
            )
        )?;
        outln!(
            "  (range and default from the NORD table: USS and CTT2 have no order that reads \
             them from the drive)"
        )?;
    } else if let Some(c) = &count {
        outln!(
            "  elements    {}",
            match c {
                Ok(n) => format!("the drive counts {n} (AK 9)"),
                Err(e) => format!("the drive's count (AK 9): {e}"),
            }
        )?;
    }
    for (t, r) in &current {
        match r {
            Ok(raw) => outln!(
                "  {:<11} {} (raw {raw})",
                t.label(),
                crate::tool::output::value_text(t, *raw)
            )?,
            Err(e) => outln!("  {:<11} refused: {e}", t.label())?,
        }
    }
    info_outcome(&current)
}

/// The end of `info`: as `read` of several, a value the drive refused fails the command (the
/// drive's answers are shown above).
fn info_outcome(current: &[(Target, std::result::Result<i64, String>)]) -> Result<()> {
    let refused: Vec<String> = current
        .iter()
        .filter(|(_, r)| r.is_err())
        .map(|(t, _)| t.label())
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(CliError::failed(format!(
        "{} of {} values could not be read: {} (the drive's answers are above)",
        refused.len(),
        current.len(),
        refused.join(", ")
    )))
}

/// `status`: see [`NordCommand::Status`].
async fn status<C>(c: &mut NordClient<C>, s: &Session) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    // Bit 10 clear: the drive does not evaluate this control word (section 4.5.1 footnote 2),
    // it only answers its status word and actual values.
    let answer = c
        .process(ControlWord(0), &[], s.actuals)
        .await
        .map_err(link_error)?;
    let sw = answer.status();
    let state = sw.state();
    let set = sw.parameter_set();
    let mut pc = param_client(c, s);
    let p105 = target_of(param::MAXIMUM_FREQUENCY, None, Some(set))?;
    let p112 = target_of(param::CURRENT_LIMIT, None, Some(set))?;
    let hz = read_physical(&mut pc, &p105).await?;
    let current = read_physical(&mut pc, &p112).await?;
    let mut actuals = Vec::new();
    for (i, word) in answer.actuals().iter().enumerate() {
        let t = target_of(param::BUS_ACTUAL_VALUE, Some(i as u8 + 1), None)?;
        let function = read_optional(&mut pc, &t).await?;
        actuals.push(actual_json(*word, function, hz, current));
    }
    let mut p700 = Vec::new();
    for e in 1..=3 {
        let t = target_of(param::PRESENT_FAULT, Some(e), None)?;
        let v = read_optional(&mut pc, &t).await?;
        let text = v
            .and_then(|raw| crate::tool::meaning::meaning_of(&t, raw))
            .map(|m| m.text);
        p700.push((v, text));
    }
    let info = nord::state_info(state);
    if s.json {
        let p = |i: usize| p700.get(i).and_then(|(v, _)| *v);
        return outln!(
            "{}",
            json!({
                "status_word": sw.0, "hex": format!("0x{:04X}", sw.0),
                "state": info.map(|i| i.letter.to_string()),
                "state_en": state.name_en(), "state_de": state.name_de(),
                "bits": status_bits(sw), "parameter_set": set,
                "p105_hz": hz, "actuals": actuals,
                "fault": p(0), "warning": p(1), "switch_on_disabled_reason": p(2),
            })
        );
    }
    outln!("status word 0x{:04X}: {}", sw.0, state_text(state))?;
    outln!("  bits: {}", status_bits(sw).join(", "))?;
    outln!(
        "  parameter set {set}; P105 maximum frequency {} (the 100 % of frequencies)",
        hz.map_or_else(
            || "unreadable".to_owned(),
            |h| format!("{} Hz", trim_float(h, 1))
        )
    )?;
    for (i, a) in actuals.iter().enumerate() {
        outln!("  actual value {} (IW{}): {}", i + 1, i + 1, actual_text(a))?;
    }
    let names = [
        "present fault",
        "present warning",
        "reason for switch-on disabled",
    ];
    for (i, (v, text)) in p700.iter().enumerate() {
        outln!(
            "  P700 [-{:02}] {}: {}",
            i + 1,
            names.get(i).copied().unwrap_or(""),
            match (v, text) {
                (Some(_), Some(t)) => t.clone(),
                (Some(v), None) => v.to_string(),
                (None, _) => "unreadable".to_owned(),
            }
        )?;
    }
    Ok(())
}

/// A parameter's physical value, `None` when the drive refuses it (a link failure is an
/// error).
async fn read_physical<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    t: &Target,
) -> Result<Option<f64>> {
    Ok(read_optional(pc, t)
        .await?
        .and_then(|raw| t.param.map(|p| p.to_physical(raw))))
}

/// A raw value, `None` when the drive refuses it (a link failure is an error).
async fn read_optional<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    t: &Target,
) -> Result<Option<i64>> {
    match pc.read(t).await {
        Ok(v) => Ok(Some(v)),
        Err(ClientError::Device(d)) => {
            errln!("drivectl: warning: {}: {d}", t.label());
            Ok(None)
        }
        Err(e) => Err(t.error(e)),
    }
}

/// What `control` was asked to do.
#[derive(Debug, Clone, Copy)]
struct ControlSession<'a> {
    action: &'a str,
    /// SW1, `None` = 0 %.
    setpoint: Option<u16>,
    /// Parameter set 1–4.
    set: u8,
    /// How long to wait for the state.
    wait: Duration,
}

/// How long the stop of an interrupted `control enable` waits for the drive to leave
/// "operation enabled" (its braking ramp).
const STOP_WAIT: Duration = Duration::from_secs(5);

/// Time between two process data exchanges while `control` waits for a state.
const CONTROL_PERIOD: Duration = Duration::from_millis(50);

/// `control`: see [`NordCommand::Control`].
async fn control<C>(c: &mut NordClient<C>, s: &Session, a: &ControlSession<'_>) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    let (target, fixed) = match a.action {
        "enable" => (State::OperationEnabled, None),
        "stop" => (State::ReadyToSwitchOn, None),
        "quick-stop" => (State::SwitchOnDisabled, Some(command::QUICK_STOP.0)),
        "disable" => (State::SwitchOnDisabled, Some(command::DISABLE_VOLTAGE.0)),
        "reset" => (State::SwitchOnDisabled, None),
        other => return Err(CliError::usage(format!("unknown control action `{other}`"))),
    };
    let sw1 = if a.action == "enable" {
        a.setpoint.unwrap_or(0)
    } else {
        0
    };
    // SW1 and IW1, where the process data carry them.
    let sw1_slot: &[u16] = if s.actuals > 0 { &[sw1] } else { &[] };
    let iw = s.actuals.min(1);
    // P509 0 (control terminals or keypad): the drive does not take the bus control word.
    {
        let mut pc = param_client(c, s);
        let t = target_of(param::CONTROL_WORD_SOURCE, None, None)?;
        if let Some(0) = read_optional(&mut pc, &t).await? {
            errln!(
                "drivectl: warning: P509 control word source is 0 (control terminals or \
                 keypad): the drive may not act on the bus control word"
            );
        }
    }
    let with_set = |w: u16| ControlWord(w).with_parameter_set(a.set).map_or(w, |c| c.0);
    let enabling = a.action == "enable";
    let stop_command = format!("{} control stop", s.again);
    // `enable` runs under the motor guard: an interrupt, a closed pipe or a failure while the
    // drive is being enabled sends shutdown (047Eh: braking ramp, then ready to switch on).
    let guard = enabling.then(|| MotorGuard::install(AtEnd::Run, stop_command.clone()));
    let interrupt = match &guard {
        Some(g) => g.interrupt().clone(),
        None => Interrupt::install("the drive keeps the last control word it was sent"),
    };
    let armed = std::cell::Cell::new(false);
    let in_fault = |st: State| matches!(st, State::Fault | State::FaultReactionActive);
    let work = async |c: &mut NordClient<C>, motion: &Motion<'_>| -> Result<(PzdIn, u16)> {
        let stop = motion.interrupt();
        // First only look (bit 10 clear: the drive ignores this word).
        let mut answer = c
            .process(ControlWord(0), &[], iw)
            .await
            .map_err(link_error)?;
        let start = answer.status().state();
        if a.action == "reset" && !in_fault(start) {
            errln!(
                "drivectl: note: the drive shows no fault ({})",
                state_text(start)
            );
            // Nothing to reset: a word sent now could only change what the drive does.
            return Ok((answer, 0));
        }
        if matches!(a.action, "enable" | "stop") && in_fault(start) {
            return Err(CliError::failed(format!(
                "the drive shows a fault ({}): read P700 (`{} status`) and reset it with `{} \
                 control reset` first",
                state_text(start),
                s.again,
                s.again
            )));
        }
        // The word the drive holds from before this command is not known: every word planned
        // here has bit 7 = 0, so the fault reset that follows one of them is a rising edge.
        let mut last: u16 = 0;
        let mut sent = false;
        let deadline = tokio::time::Instant::now() + a.wait;
        loop {
            let state = answer.status().state();
            let reached = if a.action == "reset" {
                !in_fault(state)
            } else {
                state == target
            };
            if (reached && sent) || stop.requested() {
                return Ok((answer, last));
            }
            if sent && tokio::time::Instant::now() >= deadline {
                return Ok((answer, last));
            }
            let word = match fixed {
                Some(w) => w,
                None => NordStateMachine::next_control(last, state, target)
                    .unwrap_or_else(|| hold_word(target)),
            };
            let word = with_set(word);
            // Sent, whether or not the answer comes back: a lost answer to 047Fh may leave the
            // motor running.
            last = word;
            sent = true;
            motion.armed();
            answer = c
                .process(ControlWord(word), sw1_slot, iw)
                .await
                .map_err(link_error)?;
            tokio::select! {
                () = tokio::time::sleep(CONTROL_PERIOD) => {}
                () = stop.wait() => {}
            }
        }
    };
    let (answer, last) = match &guard {
        Some(g) => {
            let shutdown = with_set(command::SHUTDOWN.0);
            let zero: &[u16] = if s.actuals > 0 { &[0] } else { &[] };
            let stop = async |c: &mut NordClient<C>| -> Result<Stopped> {
                // The drive brakes on its ramp and only then leaves "operation enabled": send
                // shutdown until it has (a few seconds at most; a second signal ends it).
                let deadline = tokio::time::Instant::now() + STOP_WAIT;
                let mut answer = c
                    .process(ControlWord(shutdown), zero, iw)
                    .await
                    .map_err(link_error)?;
                while answer.status().state() == State::OperationEnabled
                    && tokio::time::Instant::now() < deadline
                {
                    tokio::time::sleep(CONTROL_PERIOD).await;
                    answer = c
                        .process(ControlWord(shutdown), zero, iw)
                        .await
                        .map_err(link_error)?;
                }
                let state = answer.status().state();
                Ok(Stopped {
                    sent: format!(
                        "shutdown 0x{shutdown:04X} (braking ramp, then ready to switch on)"
                    ),
                    reports: if state == State::OperationEnabled {
                        format!(
                            "{} after {} s, still braking on its ramp",
                            state_text(state),
                            STOP_WAIT.as_secs()
                        )
                    } else {
                        state_text(state)
                    },
                })
            };
            g.run(c, work, stop).await?
        }
        None => {
            let motion = Motion::new(interrupt.inner(), &armed);
            let (answer, last) = work(c, &motion).await?;
            if let Some(sig) = interrupt.signal() {
                // A stop, quick stop or disable keeps acting in the drive: say what it was
                // sent and where it is.
                return Err(CliError::with_code(
                    format!(
                        "interrupted by {}; the drive was sent {} and shows {}",
                        sig.name(),
                        control_word_text(last),
                        state_text(answer.status().state())
                    ),
                    sig.exit_code(),
                ));
            }
            (answer, last)
        }
    };
    let sw = answer.status();
    let state = sw.state();
    let reached = if a.action == "reset" {
        !in_fault(state)
    } else {
        state == target
    };
    if reached && enabling {
        // Said before the output: a closed output pipe must not swallow the note that the
        // motor runs.
        let percent = trim_float(nord::percent_from_word(sw1), 4);
        if s.simulated {
            // The simulated drive ends with this command: there is nothing left to stop.
            errln!(
                "drivectl: note: the simulated motor was enabled and followed SW1 = 0x{sw1:04X} \
                 ({percent} % of P105) until the simulation ended with the command"
            );
        } else if let Some(g) = &guard {
            g.left_running(&format!(
                "the motor is enabled and follows SW1 = 0x{sw1:04X} ({percent} % of P105)"
            ));
        }
    }
    let printed = print_control(s, a, answer, last, sw1, reached);
    if !reached {
        let running = state == State::OperationEnabled;
        return Err(CliError::failed(format!(
            "the drive did not reach {} within {} s (it shows {}{}); check P509 control word \
             source, P700 [-03] reason for switch-on disabled (`{} status`){}",
            state_text(target),
            a.wait.as_secs(),
            state_text(state),
            if running { ", still running" } else { "" },
            s.again,
            if running {
                " and --wait for a long braking ramp"
            } else {
                ""
            }
        )));
    }
    printed
}

/// A control word as the manual names the command it carries (parameter set bits aside).
fn control_word_text(word: u16) -> String {
    let plain = word & !ControlWord::PARAMETER_SET_MASK;
    let name = [
        (command::SHUTDOWN, "shutdown"),
        (command::SWITCH_ON, "switch on"),
        (command::ENABLE_OPERATION, "enable operation"),
        (command::DISABLE_VOLTAGE, "disable voltage"),
        (command::QUICK_STOP, "quick stop"),
        (command::FAULT_RESET, "fault reset"),
    ]
    .into_iter()
    .find(|(c, _)| c.0 == plain)
    .map(|(_, n)| n);
    match (word, name) {
        (0, _) => "nothing (only the status was read)".to_owned(),
        (_, Some(n)) => format!("{n} 0x{word:04X}"),
        (_, None) => format!("control word 0x{word:04X}"),
    }
}

/// The word that keeps a drive in `target` once it is there.
fn hold_word(target: State) -> u16 {
    match target {
        State::OperationEnabled => command::ENABLE_OPERATION.0,
        State::ReadyToSwitchOn => command::SHUTDOWN.0,
        _ => command::DISABLE_VOLTAGE.0,
    }
}

/// The outcome of `control`: the status word with its state and IW1.
fn print_control(
    s: &Session,
    a: &ControlSession<'_>,
    answer: PzdIn,
    last: u16,
    sw1: u16,
    reached: bool,
) -> Result<()> {
    let sw = answer.status();
    let state = sw.state();
    let iw1 = answer.actuals().first().copied();
    if s.json {
        return outln!(
            "{}",
            json!({"action": a.action, "status_word": sw.0, "hex": format!("0x{:04X}", sw.0),
                   "state": nord::state_info(state).map(|i| i.letter.to_string()),
                   "state_en": state.name_en(), "state_de": state.name_de(),
                   "reached": reached, "control_word": (last != 0).then_some(last),
                   "setpoint": sw1, "setpoint_percent": nord::percent_from_word(sw1),
                   "iw1": iw1, "iw1_percent": iw1.map(nord::percent_from_word)})
        );
    }
    outln!(
        "status word 0x{:04X}: {}{}",
        sw.0,
        state_text(state),
        iw1.map_or_else(String::new, |w| format!(
            "; IW1 0x{w:04X} = {} %",
            trim_float(nord::percent_from_word(w), 2)
        ))
    )
}

#[cfg(test)]
mod tests;
