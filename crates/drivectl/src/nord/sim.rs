//! `drivectl sim uss (--port PATH | --pty) [--addr N ...]`: simulated NORD drives answering USS
//! on a serial port, or on a new pseudo-terminal whose path is printed (first line of standard
//! output) for other tools.

use std::ops::RangeInclusive;
use std::time::Duration;

use clap::Args;
use ctt2_uss::serial::sim;
use ctt2_uss::serial::{Layout, UssAddress};

use crate::error::{CliError, Result};
use crate::tool::line::LineArgs;
use crate::tool::simrun::{SerialSim, SimFamily};

/// Examples below `drivectl sim uss --help`.
const AFTER_HELP: &str = "\
Examples:
  drivectl sim uss --pty --parity none                     a NORD drive at USS address 0
  drivectl sim uss --pty --parity none --addr 1 --addr 7   two drives on one line
  drivectl sim uss --pty --parity none --pkw-time 30       orders take 30 ms (the master repeats)
  drivectl sim uss --port /dev/ttyUSB1 --baud 38400        a real port (8E1)";

/// USS's words in `drivectl sim uss`.
#[derive(Debug)]
pub struct UssSim;

impl SimFamily for UssSim {
    const ADDRESSES: RangeInclusive<u8> = 0..=31;
    const DEFAULT_ADDRESS: &'static str = "0";
    const ADDRESS_HELP: &'static str =
        "USS address(es) 0…31; repeat for several drives on one line, each address once";
    const ADDRESS_PARAM: &'static str = "USS address";
    const DEFAULT_PARITY_NOTE: &'static str = " (the default)";
    const MASTER: &'static str = "drivectl uss";
}

/// Arguments of `drivectl sim uss`.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct SimArgs {
    #[command(flatten)]
    sim: SerialSim<UssSim>,
    #[command(flatten)]
    line: LineArgs,
    /// PKW words of every telegram: 3 or 4 (the master's --pkw must match).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(3..=4))]
    pkw: u8,
    /// PZD words of every telegram, 0–16 (the master's --pzd must match).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=16))]
    pzd: u8,
    /// Milliseconds each drive works on a new parameter order, 0–10000, answering the previous
    /// order meanwhile (the master repeats the telegram until the answer fits).
    #[arg(long, default_value_t = 0, value_name = "MS", value_parser = clap::value_parser!(u64).range(0..=10_000))]
    pkw_time: u64,
}

/// Run the simulated line until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    args.sim.check(args.line.parity)?;
    let layout = Layout::new(args.pkw, args.pzd)
        .map_err(|e| CliError::usage(format!("--pkw/--pzd: {e}")))?;
    let line = args.line.line();
    let addrs: Vec<UssAddress> = args
        .sim
        .addrs
        .iter()
        .filter_map(|a| UssAddress::new(*a))
        .collect();
    let mut bus = sim::bus(&addrs, layout, line);
    for d in bus.stations_mut() {
        d.set_processing_time(Duration::from_millis(args.pkw_time));
    }
    let what = format!(
        "simulated NORD drive(s) at USS address {}, {} baud, parity {}, {} PKW + {} PZD words",
        args.sim.address_list(),
        line.baud,
        line.parity,
        args.pkw,
        args.pzd
    );
    args.sim.run(&mut bus, line, &what)
}
