//! `drivectl uss --port PATH [--addr N] …`: a NORD drive over USS on RS-485 (or the pty of
//! `drivectl sim uss --pty`).
//!
//! The shared NORD commands run on `ctt2_uss::serial::driver::UssDriver`; what only the serial
//! line has lives here: the telegram layout (`--pkw 3|4`, `--pzd N`, the drive's setting), the
//! address scan 0–31 and `line`.
//!
//! The line is 8E1 by default (the USS specification: 11-bit characters, even parity) at 9600
//! baud: 9600 is the rate every USS drive supports and the specification's usual default; a
//! NORD drive's USS baud rate is a setting of the drive (4800–38400 and, on some drives,
//! higher), so match it with `--baud`.

use std::time::Duration;

use clap::{Args, Subcommand};
use ctt2_uss::client::{ClientConfig, NordClient};
use ctt2_uss::serial::driver::{DriverConfig, UssDriver};
use ctt2_uss::serial::framing::UssTiming;
use ctt2_uss::serial::{Layout, UssAddress};
use drive_core::rt::CharIo;
use serde_json::{Map, Value, json};

use super::{NordCommand, Session, execute, precheck};
use crate::error::{CliError, Result};
use crate::tool::client::canonical_port;
use crate::tool::line::{AdapterArgs, LineArgs, MAX_TIMEOUT_MS, runtime};
use crate::tool::stale;

/// Below `drivectl uss --help`.
const USS_HELP: &str = "\
Examples:
  drivectl uss --port /dev/ttyUSB0 --addr 1 read P102 --set 3
  drivectl uss --port /dev/ttyUSB0 --addr 1 write P102 10 --set 3
  drivectl uss --port /dev/ttyUSB0 --addr 1 control enable --setpoint 50
  drivectl uss --port /dev/ttyUSB0 scan
  drivectl uss read P700 --port /dev/ttyUSB0 --addr 1      options after the command work too

The line: 8E1 (USS: 11-bit characters with even parity), 9600 baud by default; USS drives take
4800, 9600, 19200 and 38400 baud, some 57600, 115200 or 187500: give the drive's rate with
--baud. The telegram layout (--pkw, --pzd) is a setting of the drive too.
Parameters, sets and arrays: `drivectl params nord show P102`.";

/// Arguments of `drivectl uss`.
#[derive(Debug, Args)]
#[command(after_help = USS_HELP)]
pub struct UssArgs {
    /// Serial port, e.g. /dev/ttyUSB0 (or the pty printed by `drivectl sim uss --pty`). This
    /// and every line option are accepted before or after the subcommand.
    #[arg(long, global = true, default_value = "", hide_default_value = true)]
    port: String,
    #[command(flatten)]
    line: LineArgs,
    #[command(flatten)]
    adapter: AdapterArgs,
    /// Response timeout in milliseconds, 1–60000: from the end of a telegram to the start of
    /// its answer. Default 50: the 20 ms a USS drive may take before it answers at most (the
    /// USS response delay; NORD BU 0050 1.7), and 30 ms for USB adapters that hand characters
    /// over late.
    #[arg(long, global = true, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..=MAX_TIMEOUT_MS))]
    timeout: u64,
    /// Retries after a timeout or a rejected answer, 0–255.
    #[arg(long, global = true, default_value_t = 2)]
    retries: u8,
    /// USS address of the drive, 0–31 (the drive's USS address setting). Default 0: the
    /// address a USS drive answers at until it is given another (NORD BU 0050's telegram
    /// examples use it); `scan` finds the address a drive has.
    #[arg(long, global = true, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=31))]
    addr: u8,
    /// PKW words in every telegram: 4 (PKE, IND, PWE1, PWE2) or 3 (no PWE1), as the drive is
    /// set.
    #[arg(long, global = true, default_value_t = 4, value_parser = clap::value_parser!(u8).range(3..=4))]
    pkw: u8,
    /// PZD words in every telegram, 0–16, as the drive is set: the control/status word and
    /// up to 3 setpoints/actual values (NORD: 4).
    #[arg(long, global = true, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=16))]
    pzd: u8,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: UssCommand,
}

#[derive(Debug, Subcommand)]
enum UssCommand {
    #[command(flatten)]
    Nord(NordCommand),
    /// Find the drives that answer on the line: every USS address in the range gets one
    /// telegram (no retries); a drive that answers is shown with its state and P744.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 scan\n  drivectl uss --port /dev/ttyUSB0 --baud 38400 scan --from 1 --to 8 --json"
    )]
    Scan {
        /// First address.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=31))]
        from: u8,
        /// Last address.
        #[arg(long, default_value_t = 31, value_parser = clap::value_parser!(u8).range(0..=31))]
        to: u8,
    },
    /// Show the line settings, the telegram layout and the USS times the master uses.
    #[command(
        after_help = "Examples:\n  drivectl uss --port /dev/ttyUSB0 line\n  drivectl uss --port /dev/ttyUSB0 --baud 38400 --pzd 2 line --json"
    )]
    Line,
}

/// The telegram layout of the options.
fn layout(args: &UssArgs) -> Result<Layout> {
    Layout::new(args.pkw, args.pzd).map_err(|e| CliError::usage(format!("--pkw/--pzd: {e}")))
}

/// The driver configuration of the options.
fn driver_config(args: &UssArgs, address: UssAddress) -> Result<DriverConfig> {
    let line = args.line.line();
    let timing = UssTiming::from_line(&line);
    let timeout = Duration::from_millis(args.timeout);
    crate::tool::line::check_timeout(
        timeout,
        timing.start_delay,
        &format!(
            "the start delay a drive keeps before answering at {} baud ({:.2} ms)",
            line.baud,
            timing.start_delay.as_secs_f64() * 1e3
        ),
    )?;
    Ok(DriverConfig {
        response_timeout: timeout,
        retries: args.retries,
        ..DriverConfig::new(address, layout(args)?, line)
    })
}

fn address(a: u8) -> Result<UssAddress> {
    UssAddress::new(a).ok_or_else(|| CliError::usage(format!("--addr {a}: a USS address is 0…31")))
}

/// The command line that reaches the same drive again (for notes): every option that differs
/// from its default.
fn again(args: &UssArgs) -> String {
    crate::tool::again::Again::new("uss")
        .arg("--port", &args.port)
        .line(&args.line)
        .adapter(&args.adapter)
        .arg_unless("--timeout", args.timeout, 50)
        .arg_unless("--retries", args.retries, 2)
        .arg_unless("--pkw", args.pkw, 4)
        .arg_unless("--pzd", args.pzd, 4)
        .arg("--addr", args.addr)
        .to_string()
}

/// Run `drivectl uss`.
pub fn run(args: &UssArgs) -> Result<()> {
    crate::tool::line::require_port(&args.port)?;
    let config = driver_config(args, address(args.addr)?)?;
    match &args.command {
        UssCommand::Nord(cmd) => {
            precheck(cmd)?;
            check_pzd(cmd, args.pzd)?;
        }
        UssCommand::Scan { from, to } if from > to => {
            return Err(CliError::usage(
                "scan range must satisfy 0 ≤ --from ≤ --to ≤ 31",
            ));
        }
        _ => {}
    }
    let rt = runtime()?;
    rt.block_on(async {
        let port = args.line.open(&args.port, &args.adapter)?;
        stale::note_flushed(port.get_ref().flushed_at_open());
        let master = UssDriver::new(port, config);
        match &args.command {
            UssCommand::Nord(cmd) => {
                let mut identity = Map::new();
                identity.insert("address".into(), args.addr.into());
                let session = Session {
                    json: args.json,
                    key: format!("{} uss {}", canonical_port(&args.port), args.addr),
                    again: again(args),
                    identity,
                    simulated: false,
                    actuals: args.pzd.saturating_sub(1).min(3),
                };
                let mut client = NordClient::new(master, ClientConfig::default());
                let r = execute(&mut client, &session, cmd).await;
                stale::note_stale(client.channel().stats().stale);
                r
            }
            UssCommand::Scan { from, to } => scan(master, args.json, *from, *to).await,
            UssCommand::Line => line(&master, args),
        }
    })
}

/// `status` and `control` need process data: at least the status word.
fn check_pzd(cmd: &NordCommand, pzd: u8) -> Result<()> {
    match cmd {
        NordCommand::Status | NordCommand::Control { .. } if pzd == 0 => Err(CliError::usage(
            "the telegram layout has no PZD words (--pzd 0): status and control need process \
             data; give the drive's PZD length with --pzd",
        )),
        _ => Ok(()),
    }
}

/// `scan`: one telegram per address (no retries); for each drive that answers, its state and
/// P744 configuration level.
async fn scan<IO: CharIo>(master: UssDriver<IO>, json: bool, from: u8, to: u8) -> Result<()> {
    let shown = crate::tool::scan::Shown {
        range: 0..=31,
        message: Some(&|a, _| format!("address {a}")),
        json,
    };
    let mut bus = drive_client::scan::UssScan::new(master);
    crate::tool::scan::scan(&mut bus, from, to, shown, |e| {
        CliError::failed(e.to_string())
    })
    .await
}

/// `line`: the settings and times in use.
fn line<IO: CharIo>(master: &UssDriver<IO>, args: &UssArgs) -> Result<()> {
    let c = master.config();
    let l = c.line;
    let us = |d: Duration| d.as_nanos() as f64 / 1000.0;
    let timing = c.timing;
    let v: Value = json!({
        "port": args.port, "baud": l.baud, "data_bits": l.data_bits,
        "parity": l.parity.to_string(), "stop_bits": l.stop_bits.bits(),
        "bits_per_char": l.bits_per_char(), "char_time_us": us(timing.char_time),
        "start_delay_us": us(timing.start_delay), "max_char_gap_us": us(timing.max_char_gap),
        "pkw_words": c.layout.pkw_words(), "pzd_words": c.layout.pzd_words(),
        "telegram_bytes": c.layout.telegram_len(),
        "response_timeout_ms": c.response_timeout.as_millis() as u64, "retries": c.retries,
        "address": c.address.get(),
    });
    if args.json {
        return outln!("{v}");
    }
    outln!(
        "{} USS at {} baud, {} data bits, parity {}, {} stop bit(s) ({} bits per character): \
         character time {:.1} µs, start delay {:.1} µs",
        args.port,
        l.baud,
        l.data_bits,
        l.parity,
        l.stop_bits.bits(),
        l.bits_per_char(),
        us(timing.char_time),
        us(timing.start_delay)
    )?;
    outln!(
        "telegrams of {} PKW and {} PZD words ({} bytes) to address {}; response timeout {} ms, \
         {} retries",
        c.layout.pkw_words(),
        c.layout.pzd_words(),
        c.layout.telegram_len(),
        c.address.get(),
        c.response_timeout.as_millis(),
        c.retries
    )
}
