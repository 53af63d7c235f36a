//! `drivectl movilink …`: talk to a MOVIDRIVE over MOVILINK (RS-485 / RS-232).
//!
//! A thin mapping: drive-client's [`MovilinkLink`] is the `movilink` driver as a `SewLink`, the
//! way to a MOVIDRIVE that SBus has too; read, watch, write, info, backup and restore are the
//! tool layer's common commands ([`crate::tool::cmd`]) on the SEW client ([`crate::sew`]).
//! What only MOVILINK has lives here: the address rules (254 point-to-point, groups 101–199,
//! broadcast 255), the address scan, `line`, and process data ([`pd`]).

pub mod decode;
pub mod pd;
pub mod sim;

use clap::{Args, Subcommand};
use movilink::driver::{CharIo, DriverConfig, DriverError, MovilinkDriver as MasterDriver};
use movilink::{Address, ParamChannel, PduType, Telegram};
use serde_json::json;
use std::time::Duration;

#[cfg(test)]
pub use drive_client::sew::movilink::LINK_SETTINGS;
use drive_client::sew::movilink::MovilinkLink;
pub use drive_client::sew::movilink::NOT_RESTORED;

use crate::error::{CliError, Result};
use crate::sew::{Sew, SewBus, SewDrive};
use crate::tool::again::Again;
use crate::tool::backup;
use crate::tool::cmd;
use crate::tool::line::{AdapterArgs, LineArgs, MasterArgs, runtime};
use crate::tool::{stale, write};
pub use drive_client::scan::firmware_text;

/// Where the EEPROM-wear log lives, for `--help`.
const WEAR_LOG_HELP: &str = "\
EEPROM-wear log: non-volatile writes are remembered for a minute in eeprom-writes.json in
$DRIVECTL_STATE_DIR, else $XDG_STATE_HOME/drivectl, else ~/.local/state/drivectl; set
DRIVECTL_STATE_DIR to move it. A log that cannot be written refuses non-volatile writes.";

/// Below `drivectl movilink write --help`.
const WRITE_HELP: &str = "\
Examples:
  drivectl movilink --port /dev/ttyUSB0 --addr 1 write P130 1.5 --volatile    1.5 s, RAM only
  drivectl movilink --port /dev/ttyUSB0 --addr 1 write P130 1,5               decimal comma, EEPROM
  drivectl movilink --port /dev/ttyUSB0 --addr 1 write P700 SERVO             a value by name
  drivectl movilink --port /dev/ttyUSB0 --addr 1 write P810 5 --yes           move the drive to address 5
  drivectl movilink --port /dev/ttyUSB0 --addr 101 write P130 0.8 --volatile  a group write, never answered

EEPROM-wear log: non-volatile writes are remembered for a minute in eeprom-writes.json in
$DRIVECTL_STATE_DIR, else $XDG_STATE_HOME/drivectl, else ~/.local/state/drivectl; set
DRIVECTL_STATE_DIR to move it. A log that cannot be written refuses non-volatile writes.";

/// Below `drivectl movilink --help`.
const MOVILINK_HELP: &str = "\
Examples:
  drivectl movilink --port /dev/ttyUSB0 --addr 1 read P000 P010
  drivectl movilink --port /dev/ttyUSB0 --addr 1 write P130 1.5 --volatile
  drivectl movilink read P000 --port /dev/ttyUSB0 --addr 1      options after the command work too
  drivectl movilink --port /dev/ttyUSB0 scan

Access codes, value names and ranges: `drivectl params movidrive show P130`.";

/// Arguments of `drivectl movilink`.
#[derive(Debug, Args)]
#[command(after_help = MOVILINK_HELP, after_long_help = format!("{MOVILINK_HELP}\n\n{WEAR_LOG_HELP}"))]
pub struct MovilinkArgs {
    /// Serial port, e.g. /dev/ttyUSB0 (or the pty printed by `drivectl sim movilink --pty`).
    /// This and every line option are accepted before or after the subcommand.
    #[arg(long, global = true, default_value = "", hide_default_value = true)]
    port: String,
    #[command(flatten)]
    line: LineArgs,
    #[command(flatten)]
    adapter: AdapterArgs,
    #[command(flatten)]
    master: MasterArgs,
    /// Drive address: 0–99 single drive, 254 point-to-point. Default 0: P810's factory
    /// setting.
    #[arg(long, global = true, default_value_t = 0)]
    addr: u8,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: MovilinkCommand,
}

/// `--yes` of `drivectl movilink write`.
#[derive(Debug, Clone, Copy, Args)]
pub struct Yes {
    /// Confirm a write of the drive's own link settings (P810 address, P811 group address,
    /// P812 RS-485 timeout): it changes how the drive is reached.
    #[arg(long)]
    yes: bool,
}

impl cmd::Confirm for Yes {
    fn yes(&self) -> bool {
        self.yes
    }
}

#[derive(Debug, Subcommand)]
enum MovilinkCommand {
    /// Read parameters: value with unit and scaling (status and fault words decoded), and the
    /// raw value; one line (or JSON object) per parameter, in the order given.
    ///
    /// Every name is checked before anything is sent. A drive's refusal of one parameter is
    /// reported for it and the others are still read (exit 1 at the end); a link failure stops.
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 read P000\n  \
        drivectl movilink --port /dev/ttyUSB0 --addr 1 read P000 P010 P130 8318"
    )]
    Read(cmd::ReadArgs<Sew>),
    /// Poll parameters at a steady rhythm, every row with its time (RFC 3339, UTC): a table
    /// redrawn in place on a terminal, one line per poll when piped, CSV or JSON (one object
    /// per poll, "type": "sample"). Ctrl-C ends it (exit 0).
    ///
    /// Polls start every --interval; one that takes longer than the interval lets the slots it
    /// overran pass (they are skipped, not fired back to back). A drive's refusal shows in the
    /// parameter's cell and the polls go on; a link failure (no answer) ends the watch (exit 1).
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 watch P000 P004 P010\n  \
        drivectl movilink --port /dev/ttyUSB0 --addr 1 watch P000 --interval 200 --count 50 --csv > speed.csv"
    )]
    Watch(cmd::WatchArgs<Sew>),
    /// Write a parameter (checked against the table first).
    #[command(after_help = WRITE_HELP)]
    Write(cmd::WriteArgs<Sew, Yes>),
    /// Minimum, maximum, default, scale and attributes of a parameter.
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 info P130\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 info 8470 --json"
    )]
    Info(cmd::InfoArgs<Sew>),
    /// Find responding drives with their device type (P070, index 8301: named where a manual
    /// codes it, else `device_type_name` null), rated current (P071) and firmware (P076).
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 scan\n  drivectl movilink --port /dev/ttyUSB0 --timeout 20 scan --from 1 --to 31 --json"
    )]
    Scan {
        /// First address.
        #[arg(long, default_value_t = 0)]
        from: u8,
        /// Last address.
        #[arg(long, default_value_t = 99)]
        to: u8,
    },
    /// Exchange process data and decode the status.
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 pd --out 0x0006,5000,0 --count 50     enable, 1000 1/min for 5 s, then stop\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 pd --type 0x05 --out 0x0006,5000,0 --count 0 --interval 50    cyclic until Ctrl-C, then stop\n  drivectl movilink --port /dev/ttyUSB0 --addr 1 pd --out 0x0006,5000,0 --keep-running   leave it running (P812 should be set)"
    )]
    Pd(pd::PdArgs),
    /// Show the line settings and the timing the master uses on this port: character time,
    /// start pause, gap limit, response timeout and retries (the port is opened, so a setting
    /// it refuses is named).
    #[command(
        after_help = "Examples:\n  drivectl movilink --port /dev/ttyUSB0 line\n  drivectl movilink --port /dev/ttyUSB0 --baud 19200 --parity none line --json"
    )]
    Line,
    /// Save all readable parameters to a JSON file.
    #[command(after_help = backup_examples!("drivectl movilink --port /dev/ttyUSB0 --addr 1"))]
    Backup(backup::BackupArgs),
    /// Write a backup file back to the drive and verify every value. Everything is checked
    /// before the first write; Ctrl-C stops after the write in progress and lists what was
    /// written; running it again finishes it.
    #[command(after_help = restore_examples!("drivectl movilink --port /dev/ttyUSB0 --addr 1"))]
    Restore(backup::RestoreArgs),
}

/// The way to the drive at `address` behind `driver` on `port`.
pub fn link<'a, IO>(
    driver: &'a mut MasterDriver<IO>,
    address: Address,
    port: &str,
) -> MovilinkLink<'a, IO> {
    MovilinkLink::new(driver, address, port)
}

pub use crate::sew::resolve;

fn address(a: u8) -> Result<Address> {
    Address::new(a)
        .filter(|a| a.expects_response())
        .ok_or_else(|| {
            CliError::usage(format!(
                "address {a} cannot be asked for an answer; use 0–99 or 254 (point-to-point)"
            ))
        })
}

/// An address for a write: a single drive, 254, a group (101–199) or broadcast (255).
fn any_address(a: u8) -> Result<Address> {
    match Address::new(a) {
        Some(addr) if a != 100 && a != 253 => Ok(addr),
        _ => Err(CliError::usage(format!(
            "address {a} cannot be written to; use 0–99, 254, a group 101–199 or 255 (broadcast)"
        ))),
    }
}

/// Turn a driver error into a one-line CLI error.
pub fn driver_error(e: DriverError) -> CliError {
    CliError::failed(e.to_string())
}

/// The driver configuration of the command-line options. A response timeout shorter than the
/// start pause a drive waits before answering is refused: no answer could come in time (below
/// about 660 baud the default of 50 ms is such a timeout).
fn driver_config(line: &LineArgs, master: &MasterArgs) -> Result<DriverConfig> {
    let settings = line.line();
    let pause = movilink::timing::start_pause(&settings);
    let timeout = master.response_timeout();
    crate::tool::line::check_timeout(
        timeout,
        pause,
        &format!(
            "the start pause a drive waits before answering at {} baud ({:.2} ms)",
            settings.baud,
            pause.as_secs_f64() * 1e3
        ),
    )?;
    Ok(DriverConfig {
        line: settings,
        response_timeout: timeout,
        retries: master.retries,
        max_char_gap: master.max_char_gap(),
        ..DriverConfig::default()
    })
}

/// The command line that reaches the same drive again (for hints).
fn again(args: &MovilinkArgs) -> Again {
    Again::new("movilink")
        .arg("--port", &args.port)
        .line(&args.line)
        .adapter(&args.adapter)
        .arg_unless("--timeout", args.master.timeout, 50)
        .arg_unless("--char-gap", args.master.char_gap, 20)
        .arg("--addr", args.addr)
}

/// Run `drivectl movilink`.
pub fn run(args: &MovilinkArgs) -> Result<()> {
    crate::tool::line::require_port(&args.port)?;
    let config = driver_config(&args.line, &args.master)?;
    precheck(&args.command)?;
    let rt = runtime()?;
    rt.block_on(async {
        let port = args.line.open(&args.port, &args.adapter)?;
        stale::note_flushed(port.get_ref().flushed_at_open());
        let mut master = MasterDriver::new(port, config);
        let r = execute(&mut master, args).await;
        stale::note_stale(master.stats().stale);
        r
    })
}

/// What can be checked without the drive is checked before the port is opened: parameter names
/// and a write's value (a mistyped name is reported as such, not as a busy or missing port).
fn precheck(command: &MovilinkCommand) -> Result<()> {
    match common_of!(command, MovilinkCommand) {
        Some(c) => cmd::precheck(c, NOT_RESTORED),
        None => Ok(()),
    }
}

/// The MOVILINK line with the drive of `--addr` on it.
struct Bus<'a, IO> {
    m: &'a mut MasterDriver<IO>,
    args: &'a MovilinkArgs,
}

impl<IO: CharIo> SewBus for Bus<'_, IO> {
    type Link<'a>
        = MovilinkLink<'a, IO>
    where
        Self: 'a;
    type Confirm = Yes;

    fn link(&mut self) -> Result<MovilinkLink<'_, IO>> {
        Ok(link(self.m, address(self.args.addr)?, &self.args.port))
    }

    async fn unanswered(
        &mut self,
        args: &cmd::WriteArgs<Sew, Yes>,
        request: &write::WriteRequest,
        json: bool,
    ) -> Result<bool> {
        let addr = any_address(self.args.addr)?;
        if addr.expects_response() {
            return Ok(false);
        }
        write_unanswered(
            self.m,
            addr,
            &self.args.port,
            request,
            args.confirm.yes,
            json,
        )
        .await?;
        Ok(true)
    }
}

async fn execute<IO: CharIo>(m: &mut MasterDriver<IO>, args: &MovilinkArgs) -> Result<()> {
    let json = args.json;
    if let Some(c) = common_of!(&args.command, MovilinkCommand) {
        return cmd::execute(&mut SewDrive(Bus { m, args }), c, json).await;
    }
    match &args.command {
        MovilinkCommand::Scan { from, to } => scan(m, *from, *to, args.master.timeout, json).await,
        MovilinkCommand::Pd(p) => pd::pd(m, address(args.addr)?, p, json, again(args)).await,
        MovilinkCommand::Line => {
            let c = m.config();
            let t = c.line_timing();
            let us = |d: Duration| d.as_nanos() as f64 / 1000.0;
            if json {
                outln!(
                    "{}",
                    json!({
                        "port": args.port, "baud": t.line.baud, "data_bits": t.line.data_bits,
                        "parity": t.line.parity.to_string(), "stop_bits": t.line.stop_bits.bits(),
                        "bits_per_char": t.line.bits_per_char(),
                        "char_time_us": us(t.char_time), "start_pause_us": us(t.start_pause),
                        "max_gap_us": us(t.max_gap),
                        "response_timeout_ms": c.response_timeout.as_millis() as u64,
                        "address": args.addr,
                        "retries": c.retries,
                    })
                )?;
            } else {
                outln!(
                    "{} {t}; response timeout {} ms, {} retries",
                    args.port,
                    c.response_timeout.as_millis(),
                    c.retries
                )?;
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A write to a group (101–199) or broadcast (255): every drive addressed executes it, none
/// answers, so there is nothing to read back.
async fn write_unanswered<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    port: &str,
    request: &write::WriteRequest,
    yes: bool,
    json: bool,
) -> Result<()> {
    let to = crate::sew::Unanswered {
        text: if addr.is_broadcast() {
            format!("broadcast {}", addr.get())
        } else {
            format!("group {}", addr.get())
        },
        key: "address",
        number: addr.get(),
    };
    let send = async |l: &mut MovilinkLink<'_, IO>, channel: ParamChannel| -> Result<()> {
        let telegram = Telegram::request(l.address, PduType::PARAM_0PD_ACYCLIC).with_param(channel);
        l.driver
            .send_unanswered(telegram)
            .await
            .map_err(driver_error)?;
        // Keep the line idle for the broadcast spacing before this process lets go of the
        // port, so the next telegram (perhaps from the next drivectl run) cannot follow sooner
        // than the 25 ms the drives need.
        tokio::time::sleep(movilink::timing::BROADCAST_SPACING).await;
        Ok(())
    };
    crate::sew::write_unanswered(link(m, addr, port), request, yes, json, to, send).await
}

/// `scan`: one read of P070 per address, then P076 and P071 of a drive that answers.
async fn scan<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    from: u8,
    to: u8,
    timeout_ms: u64,
    json: bool,
) -> Result<()> {
    let shown = crate::tool::scan::Shown {
        range: 0..=99,
        message: Some(&|a, _| format!("address {a}")),
        json,
    };
    let mut bus = drive_client::scan::MovilinkScan {
        driver: m,
        timeout: Duration::from_millis(timeout_ms),
    };
    crate::tool::scan::scan(&mut bus, from, to, shown, driver_error).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::client::ClientError;
    use crate::tool::client::DeviceErrorKind;
    use crate::tool::client::ParamClient;
    use drive_client::sew::{SERVICE_ATTEMPTS, device_error_kind};
    use drive_core::rt::{Timebase, serve};
    use movilink::driver::{Clock, Stream};
    use movilink::{Backend, RequestContext, ReturnCode, Slave, SlaveConfig};

    /// A drive whose first `failures` parameter services answer "internal communication
    /// error" (6/2), then 1234.
    struct Flaky {
        failures: u32,
        calls: u32,
    }

    impl Backend for Flaky {
        fn param(
            &mut self,
            _: &RequestContext,
            _: &ParamChannel,
        ) -> std::result::Result<u32, ReturnCode> {
            self.calls += 1;
            if self.calls <= self.failures {
                Err(ReturnCode::INTERNAL_COMMUNICATION_ERROR)
            } else {
                Ok(1234)
            }
        }
        fn process_data(&mut self, _: &RequestContext, _: &[u16], _: &mut [u16]) {}
    }

    impl drive_core::Timers for Flaky {}

    /// Read P130 from a flaky drive; the result and how many services the drive saw.
    fn read_from_flaky(failures: u32) -> (std::result::Result<i64, ClientError>, u32) {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap();
        rt.block_on(async {
            let (a, b) = tokio::io::duplex(256);
            let drive = Address::new(1).unwrap();
            let slave = Slave::new(SlaveConfig::new(drive), Flaky { failures, calls: 0 });
            let station = tokio::spawn(async move {
                let mut stations = [slave];
                let mut time = Timebase::new(Clock::Virtual, movilink::timing::CHAR_TIME);
                let _ = serve(&mut stations, &mut time, Stream(b)).await;
                let [slave] = stations;
                slave.backend().calls
            });
            let config = DriverConfig {
                clock: Clock::Virtual,
                ..DriverConfig::default()
            };
            let mut driver = MasterDriver::new(Stream(a), config);
            let target = resolve("P130").unwrap();
            let r = crate::sew::SewClient::new(link(&mut driver, drive, "test"))
                .read(&target)
                .await;
            drop(driver);
            (r, station.await.unwrap())
        })
    }

    #[test]
    fn internal_communication_errors_are_repeated_as_the_manual_says() {
        let (r, calls) = read_from_flaky(2);
        assert_eq!(r.unwrap(), 1234);
        assert_eq!(calls, 3);
        let (r, calls) = read_from_flaky(3);
        match r {
            Err(ClientError::Device(d)) => assert_eq!(d.kind, DeviceErrorKind::Transient),
            other => panic!("{other:?}"),
        }
        assert_eq!(calls, SERVICE_ATTEMPTS);
    }

    #[test]
    fn return_codes_sort_into_what_the_tool_does() {
        for absent in [
            ReturnCode::ILLEGAL_INDEX,
            ReturnCode::NOT_IMPLEMENTED,
            ReturnCode::OPTION_CARD_MISSING,
        ] {
            assert_eq!(
                device_error_kind(absent),
                DeviceErrorKind::Absent,
                "{absent}"
            );
        }
        assert_eq!(
            device_error_kind(ReturnCode::INTERNAL_COMMUNICATION_ERROR),
            DeviceErrorKind::Transient
        );
        assert_eq!(
            device_error_kind(ReturnCode::new(6, 2, 0x0001)),
            DeviceErrorKind::Transient
        );
        for refused in [
            ReturnCode::READ_ONLY,
            ReturnCode::PARAMETER_LOCK,
            ReturnCode::VALUE_TOO_LARGE,
            ReturnCode::CONTROLLER_INHIBIT_REQUIRED,
        ] {
            assert_eq!(
                device_error_kind(refused),
                DeviceErrorKind::Refused,
                "{refused}"
            );
        }
    }
}
