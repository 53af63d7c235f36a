//! `drivectl sim movilink (--port PATH | --pty) [--addr N ...]`: simulated MOVIDRIVEs on a serial
//! port, or on a new pseudo-terminal whose path is printed (first line of standard output) for
//! other tools.

use crate::error::Result;
use crate::tool::line::LineArgs;
use crate::tool::simrun;
use clap::Args;
use movilink::sim;
use movilink::timing::LineTiming;

/// Arguments of `drivectl sim movilink`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// Serve on this serial port.
    #[arg(long, conflicts_with = "pty", required_unless_present = "pty")]
    port: Option<String>,
    /// Serve on a new pseudo-terminal and print its path; needs `--parity none` (a pty carries
    /// no parity), on the master too.
    #[arg(long)]
    pty: bool,
    /// Drive address(es) 0…99 (P810); repeat for several drives on one bus, each address once.
    #[arg(long = "addr", default_value = "0")]
    addrs: Vec<u8>,
    #[command(flatten)]
    line: LineArgs,
}

/// Check the arguments before anything is opened: addresses 0…99, each once; on a pty no
/// parity (a pseudo-terminal carries none, and the master refuses parity on one too).
fn check(args: &SimArgs) -> Result<()> {
    simrun::check_addresses(&args.addrs, 0..=99, "P810")?;
    simrun::check_pty_parity(
        args.pty,
        args.line.parity,
        " (the default, MOVILINK's 8E1)",
        "drivectl movilink",
    )
}

/// Run the simulated bus until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    check(args)?;
    let line = args.line.line();
    let list = args
        .addrs
        .iter()
        .map(u8::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    let what = format!(
        "simulated MOVIDRIVE at address {list} ({})",
        LineTiming::new(line)
    );
    let mut bus = sim::bus(&args.addrs, line);
    crate::tool::line::runtime()?.block_on(simrun::serve(
        &mut bus,
        args.port.as_deref(),
        line,
        &what,
    ))
}
