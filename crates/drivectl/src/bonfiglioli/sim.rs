//! `drivectl sim bonfiglioli (--port PATH | --pty) [--addr N ...]`: simulated ACT or ACU drives
//! answering Modbus RTU or ASCII on a serial port, or on a new pseudo-terminal whose path is
//! printed (first line of standard output) for other tools. Their parameters 10 (baud rate),
//! 395 (protocol type), 1375 (parity) and 1376 (address) say what they serve; a baud rate the
//! drive does not have (10 offers 2400–115200) is refused.

use std::ops::RangeInclusive;

use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::sim;
use clap::Args;
use drive_sim::bonfiglioli::Variant;

use crate::error::Result;
use crate::tool::line::LineArgs;
use crate::tool::simrun::{SerialSim, SimFamily};

/// Examples below `drivectl sim bonfiglioli --help`.
const AFTER_HELP: &str = "\
Examples:
  drivectl sim bonfiglioli --pty --parity none                 an ACT at address 1, Modbus RTU
  drivectl sim bonfiglioli --pty --parity none --mode ascii --variant acu --addr 1 --addr 2
  drivectl sim bonfiglioli --port /dev/ttyUSB1 --baud 19200    a real port (8E1; ASCII 7E1)";

/// Bonfiglioli's words in `drivectl sim bonfiglioli`.
#[derive(Debug)]
pub struct BonfiglioliSim;

impl SimFamily for BonfiglioliSim {
    const ADDRESSES: RangeInclusive<u8> = 1..=247;
    const DEFAULT_ADDRESS: &'static str = "1";
    const ADDRESS_HELP: &'static str = "Drive address(es) 1…247 (parameter 1376); repeat for several drives on one bus, each address once";
    const ADDRESS_PARAM: &'static str = "parameter 1376; 0 is broadcast";
    const DEFAULT_PARITY_NOTE: &'static str = " (the default)";
    const MASTER: &'static str = "drivectl bonfiglioli";
}

/// Arguments of `drivectl sim bonfiglioli`.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct SimArgs {
    #[command(flatten)]
    sim: SerialSim<BonfiglioliSim>,
    /// Transmission mode: rtu or ascii (parameter 395).
    #[arg(long, default_value = "rtu", value_parser = ["rtu", "ascii"])]
    mode: String,
    /// The device: act (ACTIVE) or acu (ACTIVE Cube).
    #[arg(long, default_value = "act", value_parser = ["act", "acu"])]
    variant: String,
    #[command(flatten)]
    line: LineArgs,
    /// Data bits, 7 or 8: by default the mode's (RTU 8, ASCII 7: ch. 6.7); on --pty they only
    /// set the timing.
    #[arg(long, value_parser = clap::value_parser!(u8).range(7..=8))]
    data_bits: Option<u8>,
}

/// Check the arguments before anything is opened: addresses 1…247, each once; a baud rate the
/// drive has (parameter 10, ch. 5.2.1); on a pty no parity.
fn check(args: &SimArgs) -> Result<()> {
    args.sim.check_addresses()?;
    if drive_profile::bonfiglioli::link::baud_code(args.line.baud).is_none() {
        let rates: Vec<String> = drive_profile::bonfiglioli::link::BAUD_RATES
            .iter()
            .map(|(_, b)| b.to_string())
            .collect();
        return Err(crate::error::CliError::usage(format!(
            "a Bonfiglioli drive does not talk at {} baud: its baud rate parameter 10 offers {} \
             baud (manual ch. 5.2.1); give one of them with --baud",
            args.line.baud,
            rates.join(", ")
        )));
    }
    args.sim.check_pty_parity(args.line.parity)
}

/// Run the simulated bus until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    check(args)?;
    let mode: Mode = args.mode.parse().unwrap_or(Mode::Rtu);
    let variant = if args.variant == "acu" {
        Variant::Acu
    } else {
        Variant::Act
    };
    let line = super::line_of(mode, &args.line, args.data_bits);
    let what = format!(
        "simulated {} at address {}, Modbus {} at {} baud, parity {}",
        args.variant.to_uppercase(),
        args.sim.address_list(),
        args.mode.to_uppercase(),
        line.baud,
        line.parity
    );
    args.sim.run(
        &mut sim::bus(&args.sim.addrs, variant, mode, line),
        line,
        &what,
    )
}
