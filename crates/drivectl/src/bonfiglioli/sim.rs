//! `drivectl sim bonfiglioli (--port PATH | --pty) [--addr N ...]`: simulated ACT or ACU drives
//! answering Modbus RTU or ASCII on a serial port, or on a new pseudo-terminal whose path is
//! printed (first line of standard output) for other tools. Their parameters 10 (baud rate),
//! 395 (protocol type), 1375 (parity) and 1376 (address) say what they serve; a baud rate the
//! drive does not have (10 offers 2400–115200) is refused.

use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::sim;
use clap::Args;
use drive_sim::bonfiglioli::Variant;

use crate::error::Result;
use crate::tool::line::LineArgs;
use crate::tool::simrun;

/// Examples below `drivectl sim bonfiglioli --help`.
const AFTER_HELP: &str = "\
Examples:
  drivectl sim bonfiglioli --pty --parity none                 an ACT at address 1, Modbus RTU
  drivectl sim bonfiglioli --pty --parity none --mode ascii --variant acu --addr 1 --addr 2
  drivectl sim bonfiglioli --port /dev/ttyUSB1 --baud 19200    a real port (8E1; ASCII 7E1)";

/// Arguments of `drivectl sim bonfiglioli`.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct SimArgs {
    /// Serve on this serial port.
    #[arg(long, conflicts_with = "pty", required_unless_present = "pty")]
    port: Option<String>,
    /// Serve on a new pseudo-terminal and print its path; needs `--parity none` (a pty carries
    /// no parity), on the master too.
    #[arg(long)]
    pty: bool,
    /// Drive address(es) 1…247 (parameter 1376); repeat for several drives on one bus, each
    /// address once.
    #[arg(long = "addr", default_value = "1")]
    addrs: Vec<u8>,
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
    simrun::check_addresses(&args.addrs, 1..=247, "parameter 1376; 0 is broadcast")?;
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
    simrun::check_pty_parity(
        args.pty,
        args.line.parity,
        " (the default)",
        "drivectl bonfiglioli",
    )
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
    let list = args
        .addrs
        .iter()
        .map(u8::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    let what = format!(
        "simulated {} at address {list}, Modbus {} at {} baud, parity {}",
        args.variant.to_uppercase(),
        args.mode.to_uppercase(),
        line.baud,
        line.parity
    );
    let mut bus = sim::bus(&args.addrs, variant, mode, line);
    crate::tool::line::runtime()?.block_on(simrun::serve(
        &mut bus,
        args.port.as_deref(),
        line,
        &what,
    ))
}
