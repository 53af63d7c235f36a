//! `drivectl bonfiglioli …`: talk to a Bonfiglioli ACTIVE (ACT) or ACTIVE Cube (ACU) over
//! Modbus RTU or ASCII with the function codes 3/6 (16 bit) and 100/101 (32 bit).
//!
//! A thin mapping onto the tool layer: drive-client's [`BonfiglioliClient`] is the
//! [`ParamClient`] of the `bonfiglioli-modbus` driver, with its messages in the command line's
//! words ([`Cli`]); reads, writes, watch, backup and restore are the tool layer's.
//! [`Target::sub`] is the data set (0 = all four, 1–4, and 5–9 their RAM-only twins). What only
//! this bus has lives here: the widths given (`--word`/`--long` where the manual gives no data
//! type), the FC 8 counters (`diag`), the address scan, `status` and `control`.

pub mod decode;
pub mod sim;

use std::time::Duration;

use bonfiglioli_modbus::driver::{CharIo, DriverConfig, DriverError, ModbusDriver as MasterDriver};
use bonfiglioli_modbus::frame::{Address, DataSet, DiagSubFunction};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use clap::{Args, Subcommand};
use drive_profile::bonfiglioli::{
    self, ActStateMachine, AcuPositioningStateMachine, AcuStateMachine, State, Variant,
};
use drive_profile::state::StateMachine;
use drive_profile::{Family, ParamMeta, Persistence};
use serde_json::{Map, Value, json};

use drive_client::bonfiglioli::{BonfiglioliClient, VariantFound, data_of, raw_of, table_width};
pub use drive_client::bonfiglioli::{LINK_SETTINGS, NOT_RESTORED, RAW_INDICES, param};

use crate::error::{CliError, Result};
use crate::tool::again::Again;
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ClientError, DeviceErrorKind, ParamClient, Target, ValueText};
use crate::tool::front::Cli;
use crate::tool::interrupt::Interrupt;
use crate::tool::line::{LineArgs, runtime};
use crate::tool::meaning::{Device, KnownVariant};
use crate::tool::motor::{AtEnd, Motion, MotorGuard, Stopped};
use crate::tool::output::physical_text;
use crate::tool::{backup, read, stale, watch, write};

const BONFIGLIOLI_HELP: &str = "\
Examples:
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 read 372 --dataset 2
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 376 1.5 --dataset 4
  drivectl bonfiglioli --port /dev/ttyUSB0 --mode ascii --addr 1 status
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 --variant acu read 411   an ACTIVE Cube, not asked
  drivectl bonfiglioli read 481 --port /dev/ttyUSB0 --addr 1      options after the command work too

Widths, data sets and value lists: `drivectl params bonfiglioli show 372`; with the drive's
values: `info`.";

const WRITE_HELP: &str = "\
Examples:
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 376 1.5 --dataset 4   1.5 kW in data set 4 (EEPROM)
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 481 10,00             decimal comma, all data sets
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 484 25 --volatile     a setpoint that changes often
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 1376 5 --yes          move the drive to address 5
  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 write 415 300 --word        a parameter without a data type

Data sets 0-4 are stored in EEPROM, which cyclic writes destroy (manual ch. 7): values that
change often go to RAM with --volatile (data set +5; --ram is the same). EEPROM-wear log:
non-volatile writes are remembered for a minute in eeprom-writes.json in $DRIVECTL_STATE_DIR,
else $XDG_STATE_HOME/drivectl, else ~/.local/state/drivectl.";

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
    /// Response timeout in milliseconds, 1–60000 (the manual: 500). Less than an exchange
    /// takes at the baud rate (request, the drive's 10 ms answer delay, answer) is refused.
    #[arg(long, global = true, default_value_t = 500, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    timeout: u64,
    /// Retries after a timeout or a corrupt answer.
    #[arg(long, global = true, default_value_t = 2)]
    retries: u8,
    /// Drive address 1–247 (parameter 1376); 0 broadcasts a write to every drive. Default 1:
    /// 1376's factory setting.
    #[arg(long, global = true, default_value_t = 1)]
    addr: u8,
    /// The device: act (ACTIVE), acu (ACTIVE Cube), or auto: asked of the drive where it matters
    /// (the status word 411 in read/watch/info/status, control, backup): bit 4 of 411 is set
    /// only by an ACU (ch. 9.1.3), and only the ACT answers a read of 484 (ch. 10.2.3). The
    /// variant found is said on standard error.
    #[arg(long, global = true, default_value = "auto", value_parser = ["auto", "act", "acu"])]
    variant: String,
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
    /// of them, 5–9 the RAM-only twins of 0–4. Only for parameters with data sets (`drivectl
    /// params bonfiglioli show N`: DS); one that exists once takes 0 (and 5 for a RAM-only
    /// write).
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
        /// power-off). `--ram` is the same.
        #[arg(long, visible_alias = "ram")]
        volatile: bool,
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
    /// Find responding drives with their variant, configuration (30) and status word (411).
    /// Each address waits the drive's 10 ms answer delay (ch. 6.8) and a margin for USB
    /// adapters, not --timeout. The manual defines no device type or firmware parameter.
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
    /// The status word 411 decoded for the drive's variant (ACT or ACU, asked of the drive
    /// unless --variant says it), the current fault 260 and the warnings 270.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 status\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 status --variant acu --json"
    )]
    Status,
    /// Command the drive through the state machine (410 control word, 412 = 1 state machine):
    /// enable, stop (switched on), quick-stop, disable (switch-on disabled) or reset a fault.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control enable --freq 25\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control stop\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 control reset"
    )]
    Control {
        /// What to do.
        #[arg(value_parser = ["enable", "stop", "quick-stop", "disable", "reset"])]
        action: String,
        /// Write this reference frequency in Hz to 484 (RAM) first (never read back: 484 is
        /// write-only on the ACTIVE Cube).
        #[arg(long, allow_hyphen_values = true, value_name = "HZ")]
        freq: Option<String>,
    },
    /// What the table knows of a parameter (range, default, unit, decimals, data type and
    /// width, data sets, access, RAM-only) and the drive's value in each data set it has.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 info 372\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 info 372 --dataset 2 --json\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 info 415 --word\n\nThe table alone, without a drive: `drivectl params bonfiglioli show 372`."
    )]
    Info {
        /// Parameter number (372 or P372).
        param: String,
        #[command(flatten)]
        access: Access,
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

/// Refuse a parameter without a data type when neither `--word` nor `--long` was given.
pub fn check_width_known(t: &Target, given: Option<Width>) -> Result<()> {
    if table_width(t, given).is_some() {
        return Ok(());
    }
    Err(CliError::usage(drive_client::bonfiglioli::unknown_width(
        t, &Cli,
    )))
}

/// The client of the drive at `address` behind `driver` on `port` (`width`: `--word` or
/// `--long`), its messages in the command line's words.
fn client<'a, IO: CharIo>(
    driver: &'a mut MasterDriver<IO>,
    address: Address,
    port: &str,
    width: Option<Width>,
) -> BonfiglioliClient<'a, IO> {
    BonfiglioliClient::new(driver, address, port, width).with_front_end(&Cli)
}

/// A driver error of an access with `width` as a client error, the way out of a refusal in the
/// command line's words (`try --long`).
pub fn client_error(width: Width, e: DriverError) -> ClientError {
    drive_client::bonfiglioli::client_error(width, e, &Cli)
}

/// What writing `raw` to a link setting does, in the command line's words (the note of a
/// client's write).
#[cfg(test)]
fn link_change_text(
    target: &Target,
    raw: i64,
    address: Address,
    before: Option<i64>,
    reach: Option<&str>,
) -> String {
    drive_client::bonfiglioli::link_change_text(target, raw, address, before, reach, &Cli)
}

/// Say what asking the drive at `address` for its variant found, on standard error: the
/// variant and what showed it, or that it cannot be told (`--variant` is the way out).
pub fn say_variant(address: u8, variant: Option<KnownVariant>, why: &str) {
    match variant {
        Some(k) => errln!(
            "drivectl: note: the drive at address {address} is an {}: {why}; --variant {} \
             skips this check",
            k.variant,
            k.variant.key()
        ),
        None => errln!(
            "drivectl: warning: cannot tell an ACT from an ACU at address {address}: {why}; \
             the status word is decoded for what both share: give --variant act or \
             --variant acu"
        ),
    }
}

/// [`say_variant`] of what [`BonfiglioliClient::find_variant`] found, when it asked the drive.
fn say_found(found: &VariantFound) {
    if let Some(why) = &found.why {
        say_variant(found.address, found.variant, why);
    }
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
            check_data_set(&t)?;
            check_width_known(&t, access.width())?;
            Ok(t)
        })
        .collect()
}

/// Refuse a data set the parameter does not have, before anything is sent: a parameter that
/// exists once (the table's data-set flag, ch. 11) has data set 0 and, for a RAM-only write,
/// 5; the RAM parameters 410, 484 and 524 are always data set 0 (ch. 7). Parameters whose
/// data sets the manual does not state, and numbers outside the table, are left to the drive.
pub fn check_data_set(t: &Target) -> Result<()> {
    let Some(p) = t.param.and(bonfiglioli::by_index(t.index)) else {
        return Ok(());
    };
    let name = format!("{} {}", p.number, p.name_en);
    if p.ram_only && t.sub != 0 {
        return Err(CliError::usage(format!(
            "{name} is kept in RAM and always addressed as data set 0 (manual ch. 7): \
             --dataset {} is refused before anything is sent; leave --dataset out",
            t.sub
        )));
    }
    if p.data_set == Some(false) && !matches!(t.sub, 0 | 5) {
        let ram = if p.is_writable() {
            " (--volatile writes it to RAM only, data set 5)"
        } else {
            ""
        };
        return Err(CliError::usage(format!(
            "{name} exists once, without data sets (manual ch. 7, 11): --dataset {} is \
             refused before anything is sent; leave --dataset out{ram}",
            t.sub
        )));
    }
    Ok(())
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
    let mut c = client(m, Address::BROADCAST, port, width);
    write::check_link_setting(&c, request, yes)?;
    let drive = c.drive_key().await?;
    if let Some(warning) = write::check(&mut c, request).await? {
        errln!("drivectl: warning: {warning}");
    }
    c.write(&request.target, request.raw, request.persistence)
        .await
        .map_err(|e| request.target.error(e))?;
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

pub use bonfiglioli_modbus::master::{least_response_timeout as least_timeout, longest_frame};

/// The driver configuration of the command-line options. A response timeout shorter than an
/// exchange takes at the line's baud rate ([`least_timeout`]) is refused: no answer could come
/// in time.
fn driver_config(args: &BonfiglioliArgs) -> Result<DriverConfig> {
    let mode = mode_of(&args.mode);
    let line = line_of(mode, &args.line, args.data_bits);
    let timeout = Duration::from_millis(args.timeout);
    let least = least_timeout(mode, &line);
    let frame = longest_frame(mode);
    crate::tool::line::check_timeout(
        timeout,
        least,
        &format!(
            "an exchange takes at {} baud ({:.2} ms: the request and the answer, up to {frame} \
             characters each, {:.1} ms each, and the drive's answer delay of 10 ms, manual ch. \
             6.8)",
            line.baud,
            least.as_secs_f64() * 1e3,
            (line.char_time() * frame).as_secs_f64() * 1e3,
        ),
    )?;
    Ok(DriverConfig {
        response_timeout: timeout,
        retries: args.retries,
        ..DriverConfig::new(mode, line)
    })
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
    check_data_set(&t)?;
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

/// The command line that reaches the same drive again (for hints): every line option that
/// differs from its default.
fn again(args: &BonfiglioliArgs) -> Again {
    again_with_data_bits(args, args.data_bits)
}

/// [`again`] with `--data-bits` as `data_bits` says.
fn again_with_data_bits(args: &BonfiglioliArgs, data_bits: Option<u8>) -> Again {
    let mut a = Again::new("bonfiglioli")
        .arg("--port", &args.port)
        .arg_unless("--mode", args.mode.as_str(), "rtu")
        .line(&args.line);
    if let Some(bits) = data_bits {
        a = a.arg("--data-bits", bits);
    }
    a.arg_unless("--timeout", args.timeout, 500)
        .arg_unless("--retries", args.retries, 2)
        .arg_unless("--variant", args.variant.as_str(), "auto")
        .arg("--addr", args.addr)
}

/// The command that reaches the drive of `args` once `raw` written to the link setting `index`
/// applies: the same line options with the new address, baud rate, parity or mode (ASCII with
/// 7 data bits unless `--data-bits` was given), asking for the drive's status; `None` for a
/// setting after which no Modbus master reaches it, or that changes nothing of the line.
pub fn reach_after(args: &BonfiglioliArgs, index: u16, raw: i64) -> Option<String> {
    let mut line = args.line.clone();
    let mut mode = args.mode.as_str();
    let mut addr = args.addr;
    match index {
        param::ADDRESS => addr = u8::try_from(raw).ok().filter(|a| (1..=247).contains(a))?,
        param::BAUD_RATE => line.baud = bonfiglioli::link::baud_of_code(raw)?,
        param::PARITY => line.parity = bonfiglioli::link::parity_of_code(raw)?,
        param::PROTOCOL => {
            mode = match u16::try_from(raw).ok()? {
                bonfiglioli::link::PROTOCOL_RTU => "rtu",
                bonfiglioli::link::PROTOCOL_ASCII => "ascii",
                _ => return None,
            }
        }
        _ => return None,
    }
    let mut a = Again::new("bonfiglioli")
        .arg("--port", &args.port)
        .arg_unless("--mode", mode, "rtu")
        .line(&line);
    if let Some(bits) = args.data_bits {
        a = a.arg("--data-bits", bits);
    }
    Some(
        a.arg_unless("--timeout", args.timeout, 500)
            .arg_unless("--retries", args.retries, 2)
            .arg_unless("--variant", args.variant.as_str(), "auto")
            .arg("--addr", addr)
            .then("status"),
    )
}

/// The `--variant` given (none for `auto`).
fn given_variant(args: &BonfiglioliArgs) -> Option<Variant> {
    Variant::from_key(&args.variant)
}

/// Run `drivectl bonfiglioli`.
pub fn run(args: &BonfiglioliArgs) -> Result<()> {
    crate::tool::line::require_port(&args.port)?;
    precheck(args)?;
    let config = driver_config(args)?;
    let rt = runtime()?;
    rt.block_on(async {
        // The mode's character format: RTU 8 data bits, ASCII 7 (ch. 6.7).
        let port = open(args, config.line)?;
        stale::note_flushed(port.flushed_at_open());
        let mut master = MasterDriver::new(port, config);
        let r = execute(&mut master, args).await;
        stale::note_stale(master.stats().stale);
        r
    })
}

/// Open the port of `args` with `settings` (the mode's data bits). A port that refuses ASCII's
/// 7 data bits (every pseudo-terminal does) is told apart: the manual's ASCII is 7 data bits,
/// and a pty runs only with 8 on both sides.
fn open(
    args: &BonfiglioliArgs,
    settings: drive_core::LineSettings,
) -> Result<drive_transport::serial::SerialPort> {
    let path = &args.port;
    let config = drive_transport::serial::SerialConfig::with_line(path, settings);
    drive_transport::serial::open(&config).map_err(|e| match e.refused_setting() {
        Some(drive_transport::LineOption::DataBits) if settings.data_bits == 7 => {
            let sim = Again::new("sim bonfiglioli --pty --parity none --mode ascii --data-bits 8")
                .arg_unless("--baud", args.line.baud, 9600)
                .arg_unless("--addr", args.addr, 1);
            CliError::usage(format!(
                "{path} does not take 7 data bits (a pseudo-terminal takes only 8). Modbus ASCII \
                 uses 7 data bits (manual ch. 6.7.2.1), and so does a drive set to ASCII: on a \
                 real line use an adapter that takes 7. Against a simulator on a pty, run both \
                 sides with 8 data bits: `{sim}` and `{}`",
                again_with_data_bits(args, Some(8))
            ))
        }
        _ => crate::tool::line::open_cli_error(&e),
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
        BonfiglioliCommand::Info { param, access } => {
            resolve(param, access.dataset).and_then(|t| check_data_set(&t))
        }
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
            let mut c = client(m, address(args.addr)?, &args.port, access.width())
                .given(given_variant(args));
            find_variant_for(&mut c, &targets).await?;
            read::read_all(&mut c, &targets, json).await
        }
        BonfiglioliCommand::Watch {
            params,
            access,
            watch: watch_args,
        } => {
            let targets = resolve_all(params, *access)?;
            let options = watch_args.options(json)?;
            let mut c = client(m, address(args.addr)?, &args.port, access.width())
                .given(given_variant(args));
            find_variant_for(&mut c, &targets).await?;
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
            volatile,
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
            // RAM only: the data set + 5 on the wire (ch. 7), which the client sends for a
            // volatile write. The target stays the data set itself (`--dataset 7` is data set 2
            // in RAM): the manual names 5–9 for writes only, so the value is read back, and
            // shown, as data set 2, the value in use.
            let volatile = *volatile || v.target.sub >= 5 || ram_only;
            if v.target.sub >= 5 {
                v.target.sub -= 5;
            }
            let persistence = if volatile {
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
            let mut c = client(m, address(args.addr)?, &args.port, access.width())
                .reaching_with(reach_after(args, request.target.index, request.raw));
            if LINK_SETTINGS.contains(&request.target.index) && *yes {
                // What the write changes for the link (nothing, when the value is the same).
                c.remember_link_setting(&request.target)
                    .await
                    .map_err(|e| request.target.error(e))?;
            }
            let done = write::write_checked(&mut c, &request, *yes).await?;
            write::print_written(&v.target, &done, json)
        }
        BonfiglioliCommand::Diag { clear } => diag(m, address(args.addr)?, *clear, json).await,
        BonfiglioliCommand::Scan { from, to } => scan(m, *from, *to, json).await,
        BonfiglioliCommand::Status => {
            let addr = address(args.addr)?;
            let mut c = client(m, addr, &args.port, None).given(given_variant(args));
            let found = c.find_variant().await.map_err(CliError::from)?;
            say_found(&found);
            status(m, addr, found.variant, json).await
        }
        BonfiglioliCommand::Control { action, freq } => {
            let addr = address(args.addr)?;
            let freq = freq.as_deref().map(freq_raw).transpose()?;
            let mut c = client(m, addr, &args.port, None).given(given_variant(args));
            let found = c.find_variant().await.map_err(CliError::from)?;
            say_found(&found);
            let Some(known) = found.variant else {
                return Err(CliError::usage(
                    "control needs to know the device (the ACT and the ACU have different state \
                     tables); nothing was written: add --variant act or --variant acu",
                ));
            };
            let session = ControlSession {
                addr,
                // The stop command names the variant, so it does not ask again.
                again: again(args).arg_unless(
                    "--variant",
                    known.variant.key(),
                    args.variant.as_str(),
                ),
                action,
                freq,
                variant: known.variant,
                json,
            };
            control(m, &session).await
        }
        BonfiglioliCommand::Info { param, access } => info(m, args, param, *access, json).await,
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
                        "address": args.addr,
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
            let mut c = client(m, address(args.addr)?, &args.port, None).probing();
            let stop = Interrupt::install("the backup file was not written");
            backup::backup(&mut c, &b.out, b.overwrite, json, &stop).await?;
            note_probed(c.probed());
            Ok(())
        }
        BonfiglioliCommand::Restore(r) => {
            let mut c = client(m, address(args.addr)?, &args.port, None).probing();
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

/// `info`: what the table knows of one parameter (range, default, unit, decimals, data type
/// and width, data sets, access, RAM-only) and the drive's value in each data set it has (1–4
/// for a data-set parameter, else 0; only `--dataset N` when given). The JSON keys are those of
/// `drivectl movilink info --json` where they mean the same (`index`, `number`, `name_de`,
/// `name_en`, `unit`, `range`, `default`, `default_value`, `access`), the table's columns as
/// `drivectl params bonfiglioli --json` names them, and `current`: one value object per data
/// set as `read --json` prints it, or `{label, selector, error}` for a refused one. A width the
/// manual does not give is found by trying (FC 3, then FC 100) unless --word/--long gives it.
async fn info<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    args: &BonfiglioliArgs,
    key: &str,
    access: Access,
    json: bool,
) -> Result<()> {
    let t = resolve(key, access.dataset)?;
    check_data_set(&t)?;
    let table = t.param.and(bonfiglioli::by_index(t.index));
    let subs: Vec<u16> = match table {
        _ if access.dataset != 0 => vec![u16::from(access.dataset)],
        Some(p) if p.is_data_set() => vec![1, 2, 3, 4],
        _ => vec![0],
    };
    let mut c =
        client(m, address(args.addr)?, &args.port, access.width()).given(given_variant(args));
    let probing = table_width(&t, access.width()).is_none();
    if probing {
        c = c.probing();
    }
    find_variant_for(&mut c, &[t]).await?;
    let device = c.device();
    let mut current = Vec::new();
    // Refusals other than the write-only parameter's "not readable" (484/524 on the ACU, as
    // the table says): the command fails at the end, after showing what it has.
    let write_only = table.is_some_and(|p| !p.is_readable());
    let mut refused = Vec::new();
    for sub in &subs {
        let at = Target { sub: *sub, ..t };
        match c.read(&at).await {
            Ok(raw) => current.push((at, Ok(raw))),
            Err(ClientError::Device(d)) => {
                if !(write_only && d.kind == DeviceErrorKind::Absent) {
                    refused.push(at.label());
                }
                current.push((at, Err(d.message)));
            }
            Err(e) => return Err(at.error(e)),
        }
    }
    let outcome = || {
        if refused.is_empty() {
            Ok(())
        } else {
            Err(CliError::failed(format!(
                "the drive refused to read {} (its answer is above)",
                refused.join(", ")
            )))
        }
    };
    let width = c.width_of(&t);
    let width_text = width.map(|w| match w {
        Width::Word => "16 bit (FC 3/6)",
        Width::Long => "32 bit (FC 100/101)",
    });
    let physical = |raw: i64| t.param.map_or(raw as f64, |p| p.to_physical(raw));
    if json {
        let row = t.param.map(|p| crate::params::to_json(p));
        let col = |k: &str| {
            row.as_ref()
                .and_then(|r| r.get(k).cloned())
                .unwrap_or(Value::Null)
        };
        let range = t.param.and_then(|p| p.raw_range()).map(|(lo, hi)| {
            json!({"min": lo, "max": hi, "min_value": physical(lo), "max_value": physical(hi)})
        });
        let default = t.param.and_then(|p| p.default_raw());
        let values: Vec<Value> = current
            .iter()
            .map(|(at, r)| match r {
                Ok(raw) => crate::tool::output::value_json_in(at, *raw, &device),
                Err(e) => json!({"label": at.label(), "selector": at.selector_json(), "error": e}),
            })
            .collect();
        outln!(
            "{}",
            crate::tool::output::info_json(
                &t,
                json!({
                    "range": range,
                    "default": default,
                    "default_value": default.map(physical),
                    "access": t.param.map(|p| p.access().to_string()),
                    "decimals": col("decimals"),
                    "data_type": col("data_type"),
                    "type_source": col("type_source"),
                    "bits": table.and_then(|p| p.data_type.bits()),
                    "width": width_text,
                    "data_sets": col("data_set"),
                    "ram_only": col("ram_only"),
                    "not_in_operation": col("not_in_operation"),
                    "bus_only": col("bus_only"),
                    "bus_access": col("bus_access"),
                    "values": col("values"),
                    "chapters": col("chapters"),
                    "current": values,
                })
            )
        )?;
        return outcome();
    }
    let Some(p) = table else {
        outln!(
            "{} is not in the table (raw access){}",
            t.label(),
            width_text.map_or_else(String::new, |w| format!(", read as {w}"))
        )?;
        print_current(&current, &device)?;
        return outcome();
    };
    outln!(
        "{} {} / {} (index {})",
        p.number,
        p.name_de,
        p.name_en,
        p.number
    )?;
    if let Some((lo, hi)) = ParamMeta::raw_range(p) {
        outln!(
            "  range      {} … {} (raw {lo} … {hi})",
            physical_text(p, lo),
            physical_text(p, hi)
        )?;
    }
    match p.default {
        Some(d) => outln!("  default    {} (raw {d})", physical_text(p, d))?,
        None => outln!("  default    not given in the manual")?,
    }
    outln!(
        "  unit       {}, {} decimal(s)",
        if p.unit.is_empty() { "-" } else { p.unit },
        p.decimals
    )?;
    outln!(
        "  data type  {}{}",
        match p.data_type.bits() {
            Some(bits) => format!(
                "{} ({bits} bit; {})",
                p.data_type.name(),
                match p.type_source {
                    bonfiglioli::TypeSource::Stated => "stated in the manual",
                    bonfiglioli::TypeSource::Example => "from an example of the manual",
                    bonfiglioli::TypeSource::Range => "from its range",
                    bonfiglioli::TypeSource::Layout => "from its bit layout in the manual",
                    bonfiglioli::TypeSource::Analogy => "by analogy with a stated type",
                    bonfiglioli::TypeSource::Unknown => "source not known",
                }
            ),
            None => "not given in the manual".to_owned(),
        },
        width_text.map_or_else(
            || " (give --word or --long)".to_owned(),
            |w| format!("; read as {w}")
        )
    )?;
    outln!(
        "  data sets  {}",
        match p.data_set {
            Some(true) => "four (1–4; 0 addresses all four; 5–9 their RAM-only twins)",
            Some(false) => "none: exists once (data set 0; 5 for a RAM-only write)",
            None => "not stated in the manual",
        }
    )?;
    let mut notes = Vec::new();
    if p.ram_only {
        notes.push("kept in RAM only, never written to EEPROM");
    } else if p.is_writable() {
        notes.push("a write goes to EEPROM (--volatile: RAM only)");
    }
    if matches!(p.access, bonfiglioli::ParamAccess::WriteOnly) {
        notes.push("write-only on the ACTIVE Cube (ch. 10.2.3)");
    }
    if p.not_in_operation {
        notes.push("not writable while the drive runs");
    }
    if p.bus_only {
        notes.push("only over the bus, not from KP500/VPlus");
    }
    outln!(
        "  access     {} ({}){}",
        ParamMeta::access(p),
        match p.access {
            bonfiglioli::ParamAccess::ReadOnly => "read-only",
            bonfiglioli::ParamAccess::ReadWrite => "read/write",
            bonfiglioli::ParamAccess::WriteOnly => "write-only",
        },
        if notes.is_empty() {
            String::new()
        } else {
            format!("; {}", notes.join("; "))
        }
    )?;
    if !p.values.is_empty() {
        outln!("  values")?;
        for v in p.values {
            outln!("    {:>6} = {} ({})", v.value, v.en, v.de)?;
        }
    }
    print_current(&current, &device)?;
    outcome()
}

/// The drive's values of `info`, one line per data set.
fn print_current(
    current: &[(Target, std::result::Result<i64, String>)],
    device: &Device,
) -> Result<()> {
    for (i, (at, r)) in current.iter().enumerate() {
        let head = if i == 0 {
            "  drive     "
        } else {
            "            "
        };
        let place = if at.sub == 0 && at.selector_json().is_null() {
            "value".to_owned()
        } else {
            format!("data set {}", at.sub)
        };
        match r {
            Ok(raw) => outln!(
                "{head} {place}: {} (raw {raw})",
                crate::tool::output::value_text_in(at, *raw, device)
            )?,
            Err(e) => outln!("{head} {place}: refused: {e}")?,
        }
    }
    Ok(())
}

/// Find the drive's variant before `targets` are read when one of them is the status word 411,
/// whose meaning depends on it (the drive is asked only for `--variant auto`).
async fn find_variant_for<IO: CharIo>(
    c: &mut BonfiglioliClient<'_, IO>,
    targets: &[Target],
) -> Result<()> {
    if targets.iter().any(|t| t.index == param::STATUS_WORD) {
        let found = c.find_variant().await.map_err(|e| {
            CliError::failed(format!(
                "finding out whether the drive is an ACT or an ACU: {}",
                CliError::from(e)
            ))
        })?;
        say_found(&found);
    }
    Ok(())
}

fn note_probed(n: usize) {
    if n > 0 {
        errln!(
            "drivectl: note: the manual gives no data type for {n} of these parameters: their \
             width was found by reading with FC 3 and, where the drive refused the type, FC 100"
        );
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

/// A margin for the answer of a drive that is there: USB serial adapters hand received
/// characters over late (FTDI: every 16 ms by default) and the operating system schedules.
pub const SCAN_MARGIN: Duration = Duration::from_millis(20);

/// How long `scan` waits for an answer at each address: the response timeout counts from the
/// request's end to the first character of the answer, which a drive sends 10 ms after a
/// request at the earliest (ch. 6.8); with two character times for that first character and
/// [`SCAN_MARGIN`]. The 500 ms of ch. 6.8 are for a drive under load, not for finding one.
pub fn scan_timeout(line: &drive_core::LineSettings) -> Duration {
    bonfiglioli_modbus::slave::ANSWER_DELAY + line.char_time() * 2 + SCAN_MARGIN
}

async fn scan<IO: CharIo>(m: &mut MasterDriver<IO>, from: u8, to: u8, json: bool) -> Result<()> {
    if from == 0 || from > to || to > 247 {
        return Err(CliError::usage(
            "scan range must satisfy 1 ≤ --from ≤ --to ≤ 247",
        ));
    }
    let timeout = scan_timeout(&m.config().line);
    let bar = backup::progress(usize::from(to - from) + 1, "scanning");
    let mut found = 0;
    for a in from..=to {
        bar.set_message(format!(
            "address {a} ({found} found, {} ms each)",
            timeout.as_millis()
        ));
        let addr = address(a)?;
        let answered = m.probe(addr, timeout).await.map_err(driver_error)?;
        bar.inc(1);
        if !answered {
            continue;
        }
        found += 1;
        let mut c = client(m, addr, "", None).probing();
        let configuration = c
            .read(&resolve(&param::CONFIGURATION.to_string(), 0)?)
            .await
            .ok();
        let status = c.read(&resolve("411", 0)?).await.ok();
        // A drive that answers but refuses what tells the variant shows none.
        let variant = c.find_variant().await.ok().and_then(|f| f.variant);
        bar.suspend(|| -> Result<()> {
            if json {
                outln!(
                    "{}",
                    json!({"address": a, "variant": variant.map(|k| k.variant.key()),
                           "variant_from": variant.map(|k| k.from),
                           "configuration": configuration, "status_word": status,
                           "device_type": null, "firmware": null})
                )
            } else {
                outln!(
                    "address {a:>3}: {}, configuration {}, status word {} (the manual defines \
                     no device type or firmware parameter)",
                    variant.map_or("ACT or ACU (not told apart)", |k| k.variant.name()),
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

/// The status word's set bits by name, for `variant`.
fn bits_text(word: u16, variant: Variant) -> String {
    variant.set_bits(word).collect::<Vec<_>>().join(" | ")
}

async fn read_word<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address, p: u16) -> Result<u16> {
    let t = resolve(&p.to_string(), 0)?;
    m.read(addr, p, DataSet::ALL, Width::Word)
        .await
        .map(|v| v as u16)
        .map_err(|e| t.error(client_error(Width::Word, e)))
}

/// `status`: 411, 260 and 270 with their meanings ([`crate::tool::meaning`]), 411 for the
/// drive's variant (`None`: neither given nor shown by the drive; decoded for what both share).
async fn status<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    variant: Option<KnownVariant>,
    json: bool,
) -> Result<()> {
    let device = Device {
        bonfiglioli: variant,
    };
    let mut read = async |p: u16| -> Result<(Target, u16, Option<crate::tool::meaning::Meaning>)> {
        let t = resolve(&p.to_string(), 0)?;
        let word = read_word(m, addr, p).await?;
        let meaning = crate::tool::meaning::meaning_in(&t, i64::from(word), &device);
        Ok((t, word, meaning))
    };
    let (_, word, status) = read(param::STATUS_WORD).await?;
    let (_, fault, fault_meaning) = read(param::CURRENT_FAULT).await?;
    let (_, warnings, warning_meaning) = read(param::WARNINGS).await?;
    let decoded = status
        .as_ref()
        .and_then(|m| m.decoded.clone())
        .unwrap_or(Value::Null);
    let key = |k: &str| decoded.get(k).cloned().unwrap_or(Value::Null);
    if key("variant_contradicted") == true {
        errln!(
            "drivectl: warning: status word 411 = 0x{word:04X} has bit 4 set, which an ACT never \
             sets (manual ch. 9.1.3): the drive looks like an ACTIVE Cube; --variant acu decodes \
             it as one"
        );
    }
    let text = |m: &Option<crate::tool::meaning::Meaning>| {
        m.as_ref().map_or_else(String::new, |m| m.text.clone())
    };
    let warning_names: Vec<&str> = bonfiglioli::warning_bits(warnings)
        .map(|w| w.name_en)
        .collect();
    let shown = variant.map(|k| k.variant).or(Variant::of_status_word(word));
    if json {
        outln!(
            "{}",
            json!({"address": addr.get(), "variant": shown.map(Variant::key),
                   "variant_from": key("variant_from"),
                   "status_word": word, "state": key("state"),
                   "bits": bits_text(word, shown.unwrap_or(Variant::Act)),
                   "decoded": decoded,
                   "fault": fault, "fault_text": text(&fault_meaning),
                   "warnings": warnings, "warning_names": warning_names})
        )
    } else {
        outln!("status word 411: 0x{word:04X} = {}", text(&status))?;
        outln!("current fault 260: {}", text(&fault_meaning))?;
        outln!(
            "warnings 270: 0x{warnings:04X} = {}",
            text(&warning_meaning)
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
    action: &'a str,
    freq: Option<i64>,
    variant: Variant,
    json: bool,
    /// The command line that reaches the drive again (for the hint that says how to stop it).
    again: Again,
}

/// How long the stop of an interrupted `control enable` waits for the drive to leave
/// "operation enabled".
const STOP_WAIT: Duration = Duration::from_secs(5);

/// What `control` reached: the last status word and control word.
struct Reached {
    word: u16,
    last: Option<u16>,
    /// `enable`: 241 actual frequency in Hz once enabled (read as part of the enabling, so an
    /// interrupt during it still stops the motor).
    actual: Option<f64>,
}

/// The state `action` drives toward.
fn target_of_action(action: &str) -> Result<State> {
    match action {
        "enable" => Ok(State::OperationEnabled),
        "stop" => Ok(State::SwitchedOn),
        "quick-stop" => Ok(State::QuickStopActive),
        "disable" | "reset" => Ok(State::SwitchOnDisabled),
        other => Err(CliError::usage(format!("unknown control action `{other}`"))),
    }
}

/// `control`: 412 = 1 (state machine) in RAM, the reference frequency 484 (RAM), then control
/// words 410 toward the action's state, polling 411 until it is reached. `enable` runs under
/// the motor guard ([`MotorGuard`]): an interrupt, a closed pipe or a failure while enabling
/// sends "disable operation" (0x0007, transition 5: the drive stops as P392 says, by default
/// on its ramp); once enabled, the motor keeps running on purpose and the note says how to
/// stop it.
async fn control<IO: CharIo>(m: &mut MasterDriver<IO>, s: &ControlSession<'_>) -> Result<()> {
    let addr = s.addr;
    let target = target_of_action(s.action)?;
    let stop_command = s.again.then("control stop");
    let enabling = s.action == "enable";
    let guard = enabling.then(|| MotorGuard::install(AtEnd::Run, stop_command.clone()));
    let work = async |m: &mut MasterDriver<IO>, motion: &Motion<'_>| -> Result<Reached> {
        control_steps(m, s, target, motion).await
    };
    let reached = match &guard {
        Some(g) => {
            let stop = async |m: &mut MasterDriver<IO>| -> Result<Stopped> {
                let cw = bonfiglioli::state::command::DISABLE_OPERATION;
                write_cw(m, addr, cw).await?;
                // Transition 5 follows P392: by default the drive stops on its ramp first and
                // only then shows "switched on". Wait a few seconds for it (a second signal
                // ends the wait at once).
                let deadline = tokio::time::Instant::now() + STOP_WAIT;
                let mut word = read_word(m, addr, param::STATUS_WORD).await?;
                while s.variant.state(word) == State::OperationEnabled
                    && tokio::time::Instant::now() < deadline
                {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    word = read_word(m, addr, param::STATUS_WORD).await?;
                }
                let state = s.variant.state(word);
                Ok(Stopped {
                    sent: format!("disable operation (410 = 0x{cw:04X})"),
                    reports: if state == State::OperationEnabled {
                        format!(
                            "411 = 0x{word:04X} still operation enabled after {} s: it stops as \
                             P392 says (by default on its ramp)",
                            STOP_WAIT.as_secs()
                        )
                    } else {
                        format!("411 = 0x{word:04X} {}", state.name_en())
                    },
                })
            };
            g.run(m, work, stop).await?
        }
        None => {
            // Not a command that moves the motor: an interrupt ends the waiting, and the
            // drive is left in whatever state it reached.
            let interrupt =
                Interrupt::install("the drive may not have reached the state asked for");
            let armed = std::cell::Cell::new(false);
            control_steps(m, s, target, &Motion::new(interrupt.inner(), &armed)).await?
        }
    };
    let word = reached.word;
    let state = s.variant.state(word);
    let done = s.action == "reset" && state != State::Fault || state == target;
    // Said before the output, so that a closed standard output cannot swallow it.
    let actual = reached.actual;
    if done && enabling {
        let f = actual;
        if let Some(g) = &guard {
            g.left_running(&format!(
                "the motor is enabled (411 = 0x{word:04X} {}){}",
                state.name_en(),
                f.as_ref().map_or_else(String::new, |hz| format!(
                    ", actual frequency 241 = {hz:.2} Hz"
                ))
            ));
        }
    }
    let freq = s.freq.map(|raw| {
        // 484 is write-only on the ACU: never read back. The drive's answer repeated the value
        // (the master checks the echo), and the actual frequency shows the drive follows it.
        json!({"raw": raw, "hz": raw as f64 / 100.0, "confirmed_by": "echo"})
    });
    if s.json {
        outln!(
            "{}",
            json!({"address": addr.get(), "action": s.action, "status_word": word,
                   "state": state.name_en(), "reached": done,
                   "control_word": reached.last, "freq_raw": s.freq,
                   "reference": freq, "actual_frequency_hz": actual})
        )?;
    } else {
        if let Some(raw) = s.freq {
            outln!(
                "reference frequency 484 = {:.2} Hz written to RAM, confirmed by the drive's echo \
                 of the write (484 is write-only on the ACTIVE Cube and is never read back){}",
                raw as f64 / 100.0,
                actual.map_or_else(String::new, |hz| format!(
                    "; actual frequency 241 = {hz:.2} Hz"
                ))
            )?;
        }
        outln!(
            "status word 411: 0x{word:04X} = {} ({})",
            state.name_en(),
            bits_text(word, s.variant)
        )?;
    }
    if !done {
        return Err(CliError::failed(format!(
            "the drive did not reach {} (it shows {}); check the hardware enable (ACT: S1IND, \
             ACU: STOA/STOB), 412 local/remote and the current fault (`{}`)",
            target.name_en(),
            state.name_en(),
            s.again.then("status")
        )));
    }
    Ok(())
}

/// 241 actual frequency in Hz, if the drive answers it.
async fn actual_frequency<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address) -> Option<f64> {
    let t = resolve("241", 0).ok()?;
    let width = table_width(&t, None)?;
    let data = m.read(addr, 241, DataSet::ALL, width).await.ok()?;
    let p = t.param?;
    Some(p.to_physical(raw_of(&t, width, data)))
}

/// The steps of `control` toward `target`, checking the interrupt between exchanges.
async fn control_steps<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    s: &ControlSession<'_>,
    target: State,
    motion: &Motion<'_>,
) -> Result<Reached> {
    let addr = s.addr;
    let stop = motion.interrupt();
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
        .map_err(|e| t412.error(client_error(Width::Word, e)))?;
    if mode != 1 {
        m.write(
            addr,
            param::LOCAL_REMOTE,
            DataSet::new(5).unwrap_or(DataSet::ALL),
            Width::Word,
            1,
        )
        .await
        .map_err(|e| t412.error(client_error(Width::Word, e)))?;
        errln!(
            "drivectl: note: 412 local/remote was {mode}; set to 1 (state machine) in RAM \
             (data set 5: all four data sets, not stored)"
        );
    }
    if let Some(raw) = s.freq {
        let t = resolve("484", 0)?;
        let data = data_of(Width::Long, raw).unwrap_or(0);
        // The reference moves a running motor at once.
        motion.armed();
        m.write(addr, param::FREQUENCY_RAM, DataSet::ALL, Width::Long, data)
            .await
            .map_err(|e| t.error(client_error(Width::Long, e)))?;
    }
    // The ACU with positioning control (configuration 30 = x40) has no shortcut 4' (ch. 10.2).
    let positioning = s.variant == Variant::Acu && {
        let t30 = resolve(&param::CONFIGURATION.to_string(), 0)?;
        let mut c = client(m, addr, "", None).probing();
        match c.read(&t30).await {
            Ok(config) => config % 100 == 40,
            Err(ClientError::Device(d)) => {
                errln!(
                    "drivectl: note: configuration 30 cannot be read ({d}): going on as without \
                     positioning control"
                );
                false
            }
            Err(e) => return Err(t30.error(e)),
        }
    };
    let mut last: Option<u16> = None;
    let mut word = read_word(m, addr, param::STATUS_WORD).await?;
    let start_state = s.variant.state(word);
    if s.action == "reset" && start_state != State::Fault {
        errln!(
            "drivectl: note: the drive shows no fault ({})",
            start_state.name_en()
        );
    }
    // At most a handful of steps: every state reaches every target in four.
    for _ in 0..8 {
        if stop.requested() {
            break;
        }
        let state = s.variant.state(word);
        let next = if s.action == "reset" && state == State::Fault {
            Some(bonfiglioli::state::command::FAULT_RESET)
        } else if s.action == "reset" {
            None
        } else if s.variant == Variant::Acu && positioning {
            // No shortcut 4' with positioning control (ch. 10.2).
            AcuPositioningStateMachine::control_toward(state, target)
        } else if s.variant == Variant::Acu {
            AcuStateMachine::control_toward(state, target)
        } else {
            ActStateMachine::control_toward(state, target)
        };
        let Some(cw) = next else { break };
        motion.armed();
        // A fault reset acts on a rising edge of bit 7.
        if cw & 0x80 != 0 && last.is_none_or(|l| l & 0x80 != 0) {
            write_cw(m, addr, cw & !0x80).await?;
        }
        write_cw(m, addr, cw).await?;
        last = Some(cw);
        // The drive may take a while (a stop ramps down first): poll until the state changes.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
        loop {
            tokio::select! {
                () = tokio::time::sleep(Duration::from_millis(50)) => {}
                () = stop.wait() => {}
            }
            word = read_word(m, addr, param::STATUS_WORD).await?;
            if s.variant.state(word) != state
                || tokio::time::Instant::now() >= deadline
                || stop.requested()
            {
                break;
            }
        }
        if s.variant.state(word) == state || s.action == "reset" {
            break;
        }
    }
    let actual = if s.action == "enable" && s.variant.state(word) == target {
        actual_frequency(m, addr).await
    } else {
        None
    };
    Ok(Reached { word, last, actual })
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
    .map_err(|e| t.error(client_error(Width::Word, e)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bonfiglioli_modbus::frame::ExceptionCode;

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
        let e = |exception, vabus| DriverError::Device {
            exception: ExceptionCode(exception),
            vabus,
        };
        match client_error(Width::Word, e(4, Some(9))) {
            ClientError::Device(d) => {
                assert_eq!(d.kind, DeviceErrorKind::Refused);
                assert!(d.message.contains("--dataset 1"), "{}", d.message);
            }
            other => panic!("{other:?}"),
        }
        match client_error(Width::Word, e(4, Some(11))) {
            ClientError::Device(d) => assert_eq!(d.kind, DeviceErrorKind::Absent),
            other => panic!("{other:?}"),
        }
        for (x, v) in [(2, None), (4, Some(14)), (4, Some(10))] {
            match client_error(Width::Word, e(x, v)) {
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
    fn issue18_412_is_never_restored() {
        // `control` leaves 412 = 1 in RAM; a backup reads it; a restore would store it in the
        // EEPROM of all four data sets.
        assert!(NOT_RESTORED.contains(&param::LOCAL_REMOTE));
    }

    #[test]
    fn issue18_scan_waits_the_answer_delay_and_a_margin_not_500_ms() {
        let line = |baud, mode: Mode| mode.line_settings(baud, drive_core::Parity::None);
        // 9600 8N2: 11 bits, 1.146 ms a character: 10 ms + 2.29 ms + 20 ms.
        let t = scan_timeout(&line(9600, Mode::Rtu));
        assert_eq!(t.as_micros(), 10_000 + 2_291 + 20_000);
        // 19200: 10 ms + 1.15 ms + 20 ms; 115200: hardly more than the answer delay.
        assert_eq!(scan_timeout(&line(19200, Mode::Rtu)).as_micros(), 31_145);
        assert!(scan_timeout(&line(115_200, Mode::Rtu)) < Duration::from_millis(31));
        // The timeout it replaced: answer delay, 60 characters and 20 ms (99 ms at 9600).
        let old = bonfiglioli_modbus::slave::ANSWER_DELAY
            + line(9600, Mode::Rtu).char_time() * 60
            + Duration::from_millis(20);
        assert!(t * 3 < old, "{t:?} vs {old:?}");
        // Never below what a drive needs before its first character.
        for baud in [2400, 9600, 19200, 57600, 115_200] {
            let l = line(baud, Mode::Ascii);
            assert!(scan_timeout(&l) > bonfiglioli_modbus::slave::ANSWER_DELAY + l.char_time());
        }
    }

    #[test]
    fn issue18_a_data_set_the_parameter_has_not_is_refused() {
        let refused = |key: &str, ds: u8| {
            check_data_set(&resolve(key, ds).unwrap())
                .err()
                .map(|e| e.to_string())
        };
        let e = refused("260", 2).unwrap();
        assert!(e.starts_with("260 Current fault exists once"), "{e}");
        assert!(!e.contains("--volatile"), "read-only: {e}");
        assert!(refused("1376", 3).unwrap().contains("--volatile"));
        assert!(
            refused("484", 5)
                .unwrap()
                .contains("always addressed as data set 0")
        );
        // Data sets 0 and 5 of a parameter that exists once; any of a data-set parameter; any
        // number outside the table.
        for (key, ds) in [("260", 0), ("1376", 5), ("372", 4), ("372", 9), ("1500", 3)] {
            assert_eq!(refused(key, ds), None, "{key} {ds}");
        }
    }

    #[test]
    fn issue18_a_link_setting_says_what_changes_and_when() {
        let a = Address::new(1).unwrap();
        let t10 = resolve("10", 0).unwrap();
        assert_eq!(
            link_change_text(&t10, 3, a, Some(3), None),
            "10 already holds 3 (9600 baud): nothing changes for the link"
        );
        let e = link_change_text(&t10, 4, a, Some(3), None);
        assert!(
            e.contains("19200 baud after the next reset (34 = 123)")
                && e.contains("until then 3 (9600 baud)")
                && e.ends_with("then use --baud 19200"),
            "{e}"
        );
        let t1375 = resolve("1375", 0).unwrap();
        assert!(link_change_text(&t1375, 2, a, None, None).ends_with("then use --parity none"));
        let t395 = resolve("395", 0).unwrap();
        assert!(link_change_text(&t395, 3, a, Some(2), None).ends_with("use --mode ascii"));
        assert!(link_change_text(&t395, 0, a, Some(2), None).contains("KP500"));
        let t1376 = resolve("1376", 0).unwrap();
        assert!(link_change_text(&t1376, 5, a, Some(1), None).contains("use --addr 5"));
        // With the command that reaches the drive then: that command, to paste.
        let e = link_change_text(
            &t1376,
            5,
            a,
            Some(1),
            Some("drivectl bonfiglioli --addr 5 status"),
        );
        assert!(
            e.ends_with(": `drivectl bonfiglioli --addr 5 status`"),
            "{e}"
        );
    }

    #[test]
    fn link_settings_are_the_tables_bus_parameters() {
        for p in LINK_SETTINGS {
            assert!(bonfiglioli::by_index(*p).is_some(), "{p}");
        }
        assert!(NOT_RESTORED.contains(&param::ADDRESS));
    }
}
