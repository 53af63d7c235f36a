//! `drivectl sim movilink (--port PATH | --pty) [--addr N ...]`: simulated MOVIDRIVEs on a serial
//! port, or on a new pseudo-terminal whose path is printed (first line of standard output) for
//! other tools.

use crate::error::{CliError, Result};
use crate::tool::line::LineArgs;
use clap::Args;
use drive_transport::pty::PtyPair;
use drive_transport::serial::Parity;
use movilink::driver::Stream;
use movilink::sim::SimulatedBus;
use movilink::timing::LineTiming;
use std::time::Duration;

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
    if let Some(bad) = args.addrs.iter().find(|a| **a > 99) {
        return Err(CliError::usage(format!(
            "--addr {bad}: a drive address is 0…99 (P810)"
        )));
    }
    for (i, a) in args.addrs.iter().enumerate() {
        if args.addrs.get(..i).is_some_and(|before| before.contains(a)) {
            return Err(CliError::usage(format!(
                "--addr {a} is given twice; each simulated drive needs its own address (P810)"
            )));
        }
    }
    if args.pty && args.line.parity != Parity::None {
        let default = if args.line.parity == Parity::Even {
            " (the default, MOVILINK's 8E1)"
        } else {
            ""
        };
        return Err(CliError::usage(format!(
            "--pty does not support parity {}{default}: pseudo-terminals accept only no parity; \
             add --parity none here and on the master (drivectl movilink --port PTY --parity \
             none), or serve a real port with --port",
            args.line.parity
        )));
    }
    Ok(())
}

/// Run the simulated bus until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    check(args)?;
    let rt = crate::tool::line::runtime()?;
    rt.block_on(async {
        let line = args.line.line();
        let mut bus = SimulatedBus::with_line(&args.addrs, line);
        let timing = LineTiming::new(line);
        let list = args
            .addrs
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(", ");
        if let Some(path) = &args.port {
            let port = args.line.open(path)?;
            errln!("simulated MOVIDRIVE at address {list} on {path} ({timing}); Ctrl-C stops");
            return bus
                .serve(Stream(port))
                .await
                .map_err(|e| CliError::failed(format!("serving {path}: {e}")));
        }
        let mut pair = PtyPair::open().map_err(|e| CliError::failed(e.to_string()))?;
        let path = pair.slave_path().to_path_buf();
        // Keep the slave side open ourselves, so the master side never sees a hang-up between
        // two clients (each `drivectl movilink` run opens and closes the pty).
        let _keep = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| CliError::failed(format!("cannot open {}: {e}", path.display())))?;
        outln!("{}", path.display())?;
        errln!(
            "simulated MOVIDRIVE at address {list} on {} ({timing}); Ctrl-C stops",
            path.display()
        );
        loop {
            let served = bus.serve(Stream(pair.master())).await;
            if let Err(e) = served {
                return Err(CliError::failed(format!("serving {}: {e}", path.display())));
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
}
