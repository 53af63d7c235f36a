//! `drivectl sim movilink (--port PATH | --pty) [--addr N ...]`: simulated MOVIDRIVEs on a serial
//! port, or on a new pseudo-terminal whose path is printed (first line of standard output) for
//! other tools.

use std::ops::RangeInclusive;

use crate::error::Result;
use crate::tool::line::LineArgs;
use crate::tool::simrun::{SerialSim, SimFamily};
use clap::Args;
use movilink::sim;
use movilink::timing::LineTiming;

/// MOVILINK's words in `drivectl sim movilink`.
#[derive(Debug)]
pub struct MovilinkSim;

impl SimFamily for MovilinkSim {
    const ADDRESSES: RangeInclusive<u8> = 0..=99;
    const DEFAULT_ADDRESS: &'static str = "0";
    const ADDRESS_HELP: &'static str =
        "Drive address(es) 0…99 (P810); repeat for several drives on one bus, each address once";
    const ADDRESS_PARAM: &'static str = "P810";
    const DEFAULT_PARITY_NOTE: &'static str = " (the default, MOVILINK's 8E1)";
    const MASTER: &'static str = "drivectl movilink";
}

/// Arguments of `drivectl sim movilink`.
#[derive(Debug, Args)]
pub struct SimArgs {
    #[command(flatten)]
    sim: SerialSim<MovilinkSim>,
    #[command(flatten)]
    line: LineArgs,
}

/// Run the simulated bus until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    args.sim.check(args.line.parity)?;
    let line = args.line.line();
    let what = format!(
        "simulated MOVIDRIVE at address {} ({})",
        args.sim.address_list(),
        LineTiming::new(line)
    );
    args.sim
        .run(&mut sim::bus(&args.sim.addrs, line), line, &what)
}
