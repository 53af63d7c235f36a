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
    /// Serve on a new pseudo-terminal and print its path.
    #[arg(long)]
    pty: bool,
    /// Drive address(es) (P810); repeat for several drives on one bus.
    #[arg(long = "addr", default_value = "0")]
    addrs: Vec<u8>,
    #[command(flatten)]
    line: LineArgs,
}

/// Run the simulated bus until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    if let Some(bad) = args.addrs.iter().find(|a| **a > 99) {
        return Err(CliError::usage(format!(
            "--addr {bad}: a drive address is 0…99 (P810)"
        )));
    }
    let rt = crate::tool::line::runtime()?;
    rt.block_on(async {
        // A pty carries no parity: its characters are 8N1 whatever was asked.
        let line = if args.port.is_some() {
            args.line.line()
        } else {
            args.line.line().with_parity(Parity::None)
        };
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
        if args.line.parity != Parity::None {
            errln!("note: pseudo-terminals carry no parity; serving the pty as 8N1");
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
