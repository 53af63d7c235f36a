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

mod control;
mod info;
mod link;
mod params;
mod scan;
mod status;
#[cfg(test)]
mod tests;

use self::control::*;
use self::info::*;
pub use self::link::*;
pub use self::params::*;
pub use self::scan::*;
use self::status::*;

use std::time::Duration;

use bonfiglioli_modbus::driver::{CharIo, DriverConfig, DriverError, ModbusDriver as MasterDriver};
use bonfiglioli_modbus::frame::{Address, DiagSubFunction};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use clap::{Args, Subcommand};
use drive_profile::bonfiglioli::{self, Variant};
use drive_profile::{Family, Persistence};
use serde_json::{Map, json};

#[cfg(test)]
use drive_client::bonfiglioli::raw_of;
use drive_client::bonfiglioli::{BonfiglioliClient, VariantFound, data_of, table_width};
pub use drive_client::bonfiglioli::{LINK_SETTINGS, NOT_RESTORED, RAW_INDICES, param};

use crate::error::{CliError, Result};
use crate::tool::again::Again;
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ParamClient, Target, ValueText};
use crate::tool::cmd::{self, WriteValue};
use crate::tool::front::Cli;
use crate::tool::interrupt::Interrupt;
use crate::tool::line::{AdapterArgs, LineArgs, runtime};
use crate::tool::meaning::KnownVariant;
use crate::tool::motor::{AtEnd, Motion, MotorGuard, Stopped};
use crate::tool::{backup, stale, write};

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
    #[command(flatten)]
    adapter: AdapterArgs,
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
    Read(cmd::ReadArgs<Access>),
    /// Write a parameter (checked against the table first), then read it back.
    #[command(after_help = WRITE_HELP)]
    Write(cmd::WriteArgs<Access, Yes>),
    /// Poll parameters at a steady rhythm (as `drivectl movilink watch`). Ctrl-C ends it.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 watch 241 411\n  \
        drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1 watch 241 --interval 200 --count 50 --csv"
    )]
    Watch(cmd::WatchArgs<Access>),
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
    Info(cmd::InfoArgs<Access>),
    /// Show the line settings and the timing the master uses on this port.
    #[command(
        after_help = "Examples:\n  drivectl bonfiglioli --port /dev/ttyUSB0 line\n  drivectl bonfiglioli --port /dev/ttyUSB0 --mode ascii --parity none line --json"
    )]
    Line,
    /// Save every readable parameter of the table in every data set it has to a JSON file.
    #[command(after_help = backup_examples!("drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1"))]
    Backup(backup::BackupArgs),
    /// Write a backup file back (data sets 1–4, never 0) and verify every value.
    #[command(after_help = restore_examples!("drivectl bonfiglioli --port /dev/ttyUSB0 --addr 1"))]
    Restore(backup::RestoreArgs),
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

/// Run `drivectl bonfiglioli`.
pub fn run(args: &BonfiglioliArgs) -> Result<()> {
    crate::tool::line::require_port(&args.port)?;
    precheck(args)?;
    let config = driver_config(args)?;
    let rt = runtime()?;
    rt.block_on(async {
        // The mode's character format: RTU 8 data bits, ASCII 7 (ch. 6.7).
        let port = open(args, config.line)?;
        stale::note_flushed(port.get_ref().flushed_at_open());
        let mut master = MasterDriver::new(port, config);
        let r = execute(&mut master, args).await;
        stale::note_stale(master.stats().stale);
        r
    })
}

/// Names, widths and values are checked before the port is opened.
fn precheck(args: &BonfiglioliArgs) -> Result<()> {
    match &args.command {
        BonfiglioliCommand::Control { freq: Some(f), .. } => freq_raw(f).map(drop),
        BonfiglioliCommand::Scan { from, to } if *from == 0 || from > to || *to > 247 => Err(
            CliError::usage("scan range must satisfy 1 ≤ --from ≤ --to ≤ 247"),
        ),
        c => common_of!(c, BonfiglioliCommand).map_or(Ok(()), |c| cmd::precheck(c, NOT_RESTORED)),
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
    if let Some(c) = common_of!(&args.command, BonfiglioliCommand) {
        return cmd::execute(&mut Drive { m, args }, c, json).await;
    }
    match &args.command {
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
        _ => Ok(()),
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

fn driver_error(e: DriverError) -> CliError {
    let hint = match &e {
        DriverError::Link(l) if l.fault() == drive_client::LinkFault::Echo => {
            crate::tool::client::ECHO_HINT
        }
        _ => "",
    };
    CliError::failed(format!("{e}{hint}"))
}
