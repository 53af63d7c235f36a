//! `drivectl sbus`: SEW MOVIDRIVE over SBus (MOVILINK over CAN).
//!
//! `ids` and `plan` need no bus; the bus commands talk through `--iface` (a SocketCAN
//! interface, an slcan adapter on a serial port, or the built-in virtual bus with simulated
//! drives) with `sbus_can::driver::SbusDriver`. The parameter commands are MOVILINK's, on the
//! shared MOVIDRIVE client ([`crate::sew`]): the same table, checks, wear log, backup and
//! restore; what is SBus's own (identifiers, process data always three words, SYNC, groups)
//! lives here.

pub mod decode;
pub mod iface;
pub mod link;
pub mod pd;
pub mod plan;
pub mod sim;
mod timing;

use std::time::Duration;

use drive_core::can::Bitrate;

use clap::{Args, Subcommand};
use sbus_can::driver::SbusDriver;
use sbus_can::ids::{Address, Direction, SlaveIds};
use sbus_can::master::{Handshake, MasterConfig};
use serde_json::json;

use crate::error::{CliError, Result};
use crate::sew::{Sew, SewBus, SewDrive};
use crate::tool::backup;
use crate::tool::cmd;
use crate::tool::outfile::OutputFile;
use crate::tool::write;
use drive_transport::can::candump::Capture;

use self::iface::{Iface, IfaceName};
use self::link::{driver_error, open, virtual_addresses};
pub use self::timing::*;
use drive_client::sew::sbus::{NOT_RESTORED, SbusLink};

/// The longest response timeout (ms).
const MAX_TIMEOUT_MS: u64 = 60_000;

/// Below `drivectl sbus --help`.
const SBUS_HELP: &str = "\
Examples:
  drivectl sbus --iface can0 --addr 1 read P000 P130
  drivectl sbus --iface slcan:/dev/ttyACM0@500k --addr 1 write P130 0.5 --volatile
  drivectl sbus --iface virtual --addr 1 read 8318 --json      simulated drives, no hardware
  drivectl sbus --iface can0 scan
  drivectl sbus --iface can0 --addr 1 pd --out 0x0006,5000,0 --count 50
  drivectl sbus ids --addr 33                       the identifiers drive 33 uses (267, 268, …)
  drivectl sbus plan --example > bus.toml           a plan file to start from
  drivectl sbus plan bus.toml                       check a bus's identifier plan
  drivectl sbus --iface can0 --addr 1 --capture s.log read P000   candump log of the session

--iface: a SocketCAN interface (can0, vcan0: `ip link set can0 up type can bitrate 500000`),
slcan:PATH[@BITRATE] (an slcan/Lawicel USB-CAN adapter; 500k, the SBus factory setting, by
default) or virtual (simulated MOVIDRIVEs at SBus addresses 1 and 2, and --addr).
Identifiers (manual ch. 5.1): PO 8a+3, PI 8a+4, PO sync 8a+5, group PO 8g+6, parameter request
8a+515, response 8a+516, group parameter request 8g+518; SYNC on P817 (0 by default).";

/// Arguments of `drivectl sbus`.
#[derive(Debug, Args)]
#[command(after_help = SBUS_HELP)]
pub struct SbusArgs {
    /// CAN interface: can0 (SocketCAN), slcan:PATH or slcan:PATH@BITRATE (an slcan USB-CAN adapter) or
    /// virtual (simulated drives in this process). Accepted before or after the subcommand.
    #[arg(long, global = true, default_value = "", hide_default_value = true)]
    iface: String,
    /// SBus address of the drive (P813), 0–63. Default 0: P813's factory setting.
    #[arg(long, global = true, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=63))]
    addr: u8,
    /// Response timeout per attempt in milliseconds, 1–60000 (a drive answers within 1 ms;
    /// the default 50 leaves room for USB adapters). Less than an answer takes on the bus
    /// (both frames at the bit rate and the 1 ms) is refused.
    #[arg(long, global = true, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..=MAX_TIMEOUT_MS))]
    timeout: u64,
    /// Retries after a timeout, 0–255.
    #[arg(long, global = true, default_value_t = 2)]
    retries: u8,
    /// Handshake mode of the parameter services: async (the drive answers at once) or sync
    /// (it answers after the next SYNC, which drivectl sends).
    #[arg(long, global = true, default_value = "async", value_parser = ["async", "sync"])]
    handshake: String,
    /// The SYNC identifier (P817), 0–2047.
    #[arg(long, global = true, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=2047))]
    sync_id: u16,
    /// Bit rate of --iface virtual (125k, 250k, 500k, 1M); slcan takes it from the
    /// interface (slcan:PATH@BITRATE), SocketCAN from `ip link`.
    #[arg(long, global = true, default_value = "500k")]
    bitrate: String,
    /// Record every frame sent and received to this candump log (`(seconds.micros) iface
    /// ID#DATA`; `drivectl decode sbus --log FILE` explains it). Written as the frames come to
    /// a temporary file that takes the name when the command ends, also on an error or Ctrl-C;
    /// a new regular file (or --overwrite).
    #[arg(long, global = true, value_name = "FILE")]
    capture: Option<std::path::PathBuf>,
    /// Replace the --capture file if it exists.
    #[arg(long, global = true, requires = "capture")]
    overwrite: bool,
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: SbusCommand,
}

/// `--yes` and `--group` of `drivectl sbus write`.
#[derive(Debug, Clone, Copy, Args)]
pub struct GroupWrite {
    /// Confirm a write of the drive's SBus settings (P813–P817).
    #[arg(long)]
    yes: bool,
    /// Write to every drive of this SBus group (P814), 0–63, instead of --addr.
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=63))]
    group: Option<u8>,
}

impl cmd::Confirm for GroupWrite {
    fn yes(&self) -> bool {
        self.yes
    }
}

#[derive(Debug, Subcommand)]
enum SbusCommand {
    /// Read parameters: value with unit and scaling, and the raw value; one line (or JSON
    /// object) per parameter, in the order given.
    ///
    /// Every name is checked before the interface is opened. A drive's refusal of one
    /// parameter is reported for it and the others are still read (exit 1 at the end).
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 --addr 1 read P000\n  \
        drivectl sbus --iface can0 --addr 1 --handshake sync read P000 P130 8318 --json"
    )]
    Read(cmd::ReadArgs<Sew>),
    /// Poll parameters at a steady rhythm, every row with its time (RFC 3339, UTC); Ctrl-C ends
    /// it (exit 0).
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 --addr 1 watch P000 P004\n  \
        drivectl sbus --iface can0 --addr 1 watch P000 --interval 200 --count 50 --csv > speed.csv"
    )]
    Watch(cmd::WatchArgs<Sew>),
    /// Write a parameter (checked against the table first); --group writes to every drive of
    /// an SBus group (write services only, never answered).
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 --addr 1 write P130 0.5 --volatile\n  \
        drivectl sbus --iface can0 --addr 1 write 8470 500 --raw\n  \
        drivectl sbus --iface can0 write P130 0.5 --volatile --group 2      every drive with P814 = 2\n\n\
        EEPROM: the non-volatile write service stores every write in the drive's EEPROM, which\n\
        wears out; a write repeated soon after is refused unless --volatile (RAM only) or --force."
    )]
    Write(cmd::WriteArgs<Sew, GroupWrite>),
    /// Minimum, maximum, default, scale and attributes of a parameter.
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 --addr 1 info P130\n  drivectl sbus --iface can0 --addr 1 info 8470 --json"
    )]
    Info(cmd::InfoArgs<Sew>),
    /// Show the interface, its bit rate and the timing the master uses: the frame times of a
    /// parameter request and answer, the least response timeout an answer can meet, the
    /// response timeout and retries, the handshake mode and the SYNC identifier (the interface
    /// is opened, so one that is missing or busy is named).
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface slcan:/dev/ttyACM0@250k line\n  drivectl sbus --iface can0 --handshake sync line --json"
    )]
    Line,
    /// Find the drives on the bus: every SBus address of the range is asked for P070 (unit
    /// type) at once; the ones that answer are listed with their firmware.
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 scan\n  drivectl sbus --iface can0 scan --from 1 --to 16 --json"
    )]
    Scan {
        /// First address.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=63))]
        from: u8,
        /// Last address.
        #[arg(long, default_value_t = 63, value_parser = clap::value_parser!(u8).range(0..=63))]
        to: u8,
    },
    /// Exchange process data (always three words on SBus) and decode the status; at the end
    /// the drive is stopped unless --keep-running.
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 --addr 1 pd --out 0x0006,5000,0 --count 50     enable, 1000 1/min for 5 s, then stop\n  \
        drivectl sbus --iface can0 --addr 1 pd --out 0x0006,5000,0 --sync --count 0      PO sync every 5 ms cycle until Ctrl-C\n  \
        drivectl sbus --iface can0 pd --group 2 --out 0x0006,3000,0 --count 20            every drive of group 2, no answers"
    )]
    Pd(pd::PdArgs),
    /// Send SYNC telegrams (P817) every --period ms: the time base of synchronous process
    /// data and sync-mode parameter answers (ch. 5.1).
    #[command(
        after_help = "Examples:\n  drivectl sbus --iface can0 sync --period 5 --count 200\n  drivectl sbus --iface can0 --sync-id 1000 sync      until Ctrl-C"
    )]
    Sync(pd::SyncArgs),
    /// Save all readable parameters to a JSON file.
    #[command(after_help = backup_examples!("drivectl sbus --iface can0 --addr 1"))]
    Backup(backup::BackupArgs),
    /// Write a backup file back to the drive and verify every value (P813, P816 and P817 are
    /// never written: they would cut the bus).
    #[command(after_help = restore_examples!("drivectl sbus --iface can0 --addr 1"))]
    Restore(backup::RestoreArgs),
    /// The CAN identifiers a drive uses as an SBus slave, from its SBus address (P813), group
    /// address (P814) and sync identifier (P817), with who sends each.
    #[command(
        after_help = "Examples:\n  drivectl sbus ids --addr 33\n  drivectl sbus ids --addr 1 --group 2 --sync-id 1000 --json"
    )]
    Ids {
        /// SBus group address (P814), 0–63.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=63))]
        group: u8,
    },
    /// Check the identifier plan of a whole bus (TOML file): the two rules of ch. 5.5, sync
    /// identifier collisions, duplicate addresses, object limits and bus load.
    #[command(
        after_help = "Examples:\n  drivectl sbus plan bus.toml\n  drivectl sbus plan bus.toml --forbidden --json\n\n\
        The file: bitrate = \"500k\"; one [[device]] per node with name, address (P813; leave\n\
        out for a PLC), group (P814), sync_id (P817), master_of = [\"address 1\", \"group 2\"],\n\
        sends_sync = ID, and [[device.object]] tables (id, kind = cyclic|acyclic|receive,\n\
        cycle_ms, offset_ms, len 0–8, format = motorola|intel)."
    )]
    Plan {
        /// The plan file (`-`: standard input).
        #[arg(required_unless_present = "example")]
        file: Option<String>,
        /// Also list each device's forbidden variable identifiers.
        #[arg(long)]
        forbidden: bool,
        /// Print a commented plan file to start from (the manual's example of ch. 5.5, a
        /// PLC and two drives with a variable telegram) instead of checking one.
        #[arg(long, conflicts_with_all = ["file", "forbidden"])]
        example: bool,
    },
}

/// The command line that reaches the same drive again (for hints).
fn again(args: &SbusArgs) -> crate::tool::again::Again {
    crate::tool::again::Again::new("sbus")
        .arg("--iface", &args.iface)
        .arg_unless("--bitrate", args.bitrate.as_str(), "500k")
        .arg_unless("--timeout", args.timeout, 50)
        .arg_unless("--handshake", args.handshake.as_str(), "async")
        .arg_unless("--sync-id", args.sync_id, 0)
        .arg("--addr", args.addr)
}

/// Run `drivectl sbus`.
pub fn run(args: &SbusArgs) -> Result<()> {
    match &args.command {
        SbusCommand::Ids { group } => return ids(args.addr, *group, args.sync_id, args.json),
        SbusCommand::Plan { example: true, .. } => return out!("{}", plan::EXAMPLE),
        SbusCommand::Plan {
            file: Some(file),
            forbidden,
            ..
        } => return plan::run(file, *forbidden, args.json),
        SbusCommand::Plan { file: None, .. } => {
            return Err(CliError::usage(
                "give the plan file (or --example for one to start from)",
            ));
        }
        _ => {}
    }
    let iface = iface::parse(&args.iface)?;
    let bitrate = iface::parse_bitrate(&args.bitrate)?;
    precheck(&args.command)?;
    let config = master_config(args);
    check_timeout(&config, iface.bitrate().unwrap_or(bitrate), &iface)?;
    // The capture file is checked (and its temporary file created) before the bus is opened.
    let capture = args
        .capture
        .as_deref()
        .map(|p| OutputFile::prepare(p, args.overwrite))
        .transpose()?;
    let rt = crate::tool::line::runtime()?;
    rt.block_on(async {
        let (io, sim) = open(&iface, bitrate, &virtual_addresses(args.addr)).await?;
        let result = match capture {
            None => {
                let mut master = SbusDriver::new(io, config);
                let r = execute(&mut master, args, &iface).await;
                note_stale(&master);
                r
            }
            Some(file) => {
                // Streamed to the temporary file as the frames come (memory stays bounded over a
                // long `pd` or `watch`), renamed into place at the end.
                let writer = std::io::BufWriter::new(file.writer()?);
                let log = Capture::new(io, writer, iface.log_name());
                let mut master = SbusDriver::new(log, config);
                let result = execute(&mut master, args, &iface).await;
                note_stale(&master);
                let kept = save_capture(master.into_inner(), file, args.capture.as_deref());
                // The command's own error comes first; a failed capture is reported after it.
                match (result, kept) {
                    (Err(e), Err(c)) => {
                        errln!("drivectl: warning: {c}");
                        Err(e)
                    }
                    (r, k) => r.and(k),
                }
            }
        };
        if let Some(task) = sim {
            task.abort();
        }
        result
    })
}

/// The note for the frames the SBus master heard before its request went out.
fn note_stale<C: drive_core::rt::CanIo>(master: &SbusDriver<C>) {
    crate::tool::stale::note_stale_frames(master.stats().stale);
}

/// Finish the capture log of a finished command: flushed, then moved into place.
fn save_capture<C: drive_core::rt::CanIo>(
    capture: Capture<C, std::io::BufWriter<std::fs::File>>,
    file: OutputFile,
    path: Option<&std::path::Path>,
) -> Result<()> {
    let records = capture.records();
    let (_, log) = capture
        .finish()
        .map_err(|e| CliError::failed(format!("the capture log was not written: {e}")))?;
    drop(log);
    file.commit("")?;
    errln!(
        "drivectl: note: {records} frame(s) captured to {}",
        path.map_or_else(String::new, |p| p.display().to_string())
    );
    Ok(())
}

/// What can be checked without the bus is checked before the interface is opened.
fn precheck(command: &SbusCommand) -> Result<()> {
    match command {
        SbusCommand::Scan { from, to } if from > to => Err(CliError::usage(format!(
            "scan --from {from} --to {to}: the range must satisfy 0 ≤ --from ≤ --to ≤ 63"
        ))),
        SbusCommand::Pd(p) => p.check().map(drop),
        c => common_of!(c, SbusCommand).map_or(Ok(()), |c| cmd::precheck(c, NOT_RESTORED)),
    }
}

fn address(a: u8) -> Result<Address> {
    Address::new(a).ok_or_else(|| CliError::usage(format!("--addr {a}: SBus addresses are 0…63")))
}

/// The bus with the drive of `--addr` on it.
struct Bus<'a, C> {
    m: &'a mut SbusDriver<C>,
    args: &'a SbusArgs,
    iface: &'a Iface,
}

impl<C: drive_core::rt::CanIo> SewBus for Bus<'_, C> {
    type Link<'a>
        = SbusLink<'a, C>
    where
        Self: 'a;
    type Confirm = GroupWrite;

    fn link(&mut self) -> Result<SbusLink<'_, C>> {
        Ok(SbusLink {
            master: self.m,
            address: address(self.args.addr)?,
            handshake: handshake(self.args),
            iface: self.iface.name(),
        })
    }

    async fn unanswered(
        &mut self,
        args: &cmd::WriteArgs<Sew, GroupWrite>,
        request: &write::WriteRequest,
        json: bool,
    ) -> Result<bool> {
        let Some(g) = args.confirm.group else {
            return Ok(false);
        };
        group_write(
            self.m,
            address(g)?,
            self.iface,
            request,
            args.confirm.yes,
            json,
        )
        .await?;
        Ok(true)
    }
}

async fn execute<C: drive_core::rt::CanIo>(
    m: &mut SbusDriver<C>,
    args: &SbusArgs,
    iface: &Iface,
) -> Result<()> {
    let json = args.json;
    let addr = address(args.addr)?;
    if let Some(c) = common_of!(&args.command, SbusCommand) {
        return cmd::execute(&mut SewDrive(Bus { m, args, iface }), c, json).await;
    }
    match &args.command {
        SbusCommand::Scan { from, to } => scan(m, *from, *to, json).await,
        SbusCommand::Pd(p) => pd::pd(m, addr, p, json, &again(args)).await,
        SbusCommand::Sync(s) => pd::sync(m, s, args.sync_id, json).await,
        SbusCommand::Line => line(args, iface, json),
        _ => Ok(()),
    }
}

/// A write to an SBus group: every drive with that P814 executes it, none answers (ch. 5.1),
/// so there is nothing to read back; the drives of a group share the wear-log entry of the
/// group.
async fn group_write<C: drive_core::rt::CanIo>(
    m: &mut SbusDriver<C>,
    group: Address,
    iface: &Iface,
    request: &write::WriteRequest,
    yes: bool,
    json: bool,
) -> Result<()> {
    let l = SbusLink {
        master: m,
        address: group,
        handshake: Handshake::Async,
        iface: format!("{} group", iface.name()),
    };
    let to = crate::sew::Unanswered {
        text: format!("SBus group {}", group.get()),
        key: "group",
        number: group.get(),
    };
    let send = async |l: &mut SbusLink<'_, C>, channel| -> Result<()> {
        l.master
            .group_write(l.address, channel)
            .await
            .map_err(driver_error)
    };
    crate::sew::write_unanswered(l, request, yes, json, to, send).await
}

/// `scan`: every address of the range asked for P070 at once, then the firmware of each that
/// answers.
async fn scan<C: drive_core::rt::CanIo>(
    m: &mut SbusDriver<C>,
    from: u8,
    to: u8,
    json: bool,
) -> Result<()> {
    let shown = crate::tool::scan::Shown {
        range: 0..=63,
        message: None,
        json,
    };
    let mut bus = drive_client::scan::SbusScan::new(m, from, to);
    crate::tool::scan::scan(&mut bus, from, to, shown, driver_error).await
}

fn ids(addr: u8, group: u8, sync_id: u16, json: bool) -> Result<()> {
    let ids = SlaveIds {
        address: address(addr)?,
        group: address(group)?,
        sync_id,
    };
    for u in ids.uses() {
        let name = u.kind.map_or("SYNC (P817)", |k| k.name());
        let dir = match u.direction {
            Direction::Receive => "receives",
            Direction::Transmit => "transmits",
        };
        let by = match u.kind {
            Some(k) if k.is_group() => format!("group {group}"),
            Some(_) => format!("address {addr}"),
            None => "sync identifier".to_owned(),
        };
        if json {
            outln!(
                "{}",
                json!({"id": u.id, "telegram": name, "drive": dir, "by": by})
            )?;
        } else {
            outln!("{:>5}  {:<44} the drive {dir} it ({by})", u.id, name)?;
        }
    }
    Ok(())
}
