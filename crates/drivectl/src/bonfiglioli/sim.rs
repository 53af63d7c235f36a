//! `drivectl sim bonfiglioli (--port PATH | --pty) [--addr N ...]`: simulated ACT or ACU drives
//! answering Modbus RTU or ASCII on a serial port, or on a new pseudo-terminal whose path is
//! printed (first line of standard output) for other tools.

use std::time::Duration;

use bonfiglioli_modbus::driver::Stream;
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::sim::SimulatedBus;
use clap::Args;
use drive_sim::bonfiglioli::Variant;
use drive_transport::pty::PtyPair;
use drive_transport::serial::{Parity, SerialConfig};

use crate::error::{CliError, Result};
use crate::tool::line::LineArgs;

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

/// Check the arguments before anything is opened: addresses 1…247, each once; on a pty no
/// parity.
fn check(args: &SimArgs) -> Result<()> {
    if let Some(bad) = args.addrs.iter().find(|a| **a == 0 || **a > 247) {
        return Err(CliError::usage(format!(
            "--addr {bad}: a drive address is 1…247 (parameter 1376; 0 is broadcast)"
        )));
    }
    for (i, a) in args.addrs.iter().enumerate() {
        if args.addrs.get(..i).is_some_and(|before| before.contains(a)) {
            return Err(CliError::usage(format!(
                "--addr {a} is given twice; each simulated drive needs its own address (parameter 1376)"
            )));
        }
    }
    if args.pty && args.line.parity != Parity::None {
        let default = if args.line.parity == Parity::Even {
            " (the default)"
        } else {
            ""
        };
        return Err(CliError::usage(format!(
            "--pty does not support parity {}{default}: pseudo-terminals accept only no parity; \
             add --parity none here and on the master (drivectl bonfiglioli --port PTY --parity \
             none), or serve a real port with --port",
            args.line.parity
        )));
    }
    Ok(())
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
    let rt = crate::tool::line::runtime()?;
    rt.block_on(async {
        let mut bus = SimulatedBus::new(&args.addrs, variant, mode, line);
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
        if let Some(path) = &args.port {
            let port = drive_transport::serial::open(&SerialConfig::with_line(path, line))
                .map_err(|e| {
                    let text = crate::tool::line::open_error(&e);
                    if e.refused_setting().is_some() {
                        CliError::usage(text)
                    } else {
                        CliError::failed(text)
                    }
                })?;
            errln!("{what} on {path}; Ctrl-C stops");
            return bus
                .serve(Stream(port))
                .await
                .map_err(|e| CliError::failed(format!("serving {path}: {e}")));
        }
        let mut pair = PtyPair::open().map_err(|e| CliError::failed(e.to_string()))?;
        let path = pair.slave_path().to_path_buf();
        // Keep the slave side open ourselves, so the master side never sees a hang-up between
        // two clients.
        let _keep = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| CliError::failed(format!("cannot open {}: {e}", path.display())))?;
        outln!("{}", path.display())?;
        errln!("{what} on {}; Ctrl-C stops", path.display());
        loop {
            if let Err(e) = bus.serve(Stream(pair.master())).await {
                return Err(CliError::failed(format!("serving {}: {e}", path.display())));
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
}
