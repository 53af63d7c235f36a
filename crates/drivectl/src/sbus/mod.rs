//! `drivectl sbus`: SEW MOVIDRIVE over SBus (MOVILINK over CAN).
//!
//! `ids` and `plan` need no bus; the bus commands talk through `--iface` (a SocketCAN
//! interface, an slcan adapter on a serial port, or the built-in virtual bus with simulated
//! drives).

pub mod decode;
pub mod iface;

use clap::{Args, Subcommand};
use sbus_can::ids::{Address, Direction, SlaveIds};
use serde_json::json;

use crate::error::{CliError, Result};

/// Below `drivectl sbus --help`.
const SBUS_HELP: &str = "\
Examples:
  drivectl sbus ids --addr 33                       the identifiers drive 33 uses (267, 268, …)
  drivectl sbus ids --addr 1 --group 2 --json

Identifiers (manual ch. 5.1): PO 8a+3, PI 8a+4, PO sync 8a+5, group PO 8g+6, parameter request
8a+515, response 8a+516, group parameter request 8g+518; SYNC on P817 (0 by default).";

/// Arguments of `drivectl sbus`.
#[derive(Debug, Args)]
#[command(after_help = SBUS_HELP)]
pub struct SbusArgs {
    /// One JSON object per result.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: SbusCommand,
}

#[derive(Debug, Subcommand)]
enum SbusCommand {
    /// The CAN identifiers a drive uses as an SBus slave, from its SBus address (P813), group
    /// address (P814) and sync identifier (P817), with who sends each.
    #[command(
        after_help = "Examples:\n  drivectl sbus ids --addr 33\n  drivectl sbus ids --addr 1 --group 2 --sync-id 1000 --json"
    )]
    Ids {
        /// SBus address (P813), 0–63.
        #[arg(long, value_parser = clap::value_parser!(u8).range(0..=63))]
        addr: u8,
        /// SBus group address (P814), 0–63.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=63))]
        group: u8,
        /// SBus synchronisation identifier (P817), 0–2047.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=2047))]
        sync_id: u16,
    },
}

/// Run `drivectl sbus`.
pub fn run(args: &SbusArgs) -> Result<()> {
    match &args.command {
        SbusCommand::Ids {
            addr,
            group,
            sync_id,
        } => ids(*addr, *group, *sync_id, args.json),
    }
}

fn address(a: u8, what: &str) -> Result<Address> {
    Address::new(a).ok_or_else(|| CliError::usage(format!("{what} {a}: SBus addresses are 0…63")))
}

fn ids(addr: u8, group: u8, sync_id: u16, json: bool) -> Result<()> {
    let ids = SlaveIds {
        address: address(addr, "--addr")?,
        group: address(group, "--group")?,
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
