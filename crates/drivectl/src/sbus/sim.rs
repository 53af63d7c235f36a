//! `drivectl sim sbus (--pty | --iface IFACE) [--addr N ...]`: simulated MOVIDRIVEs on SBus.
//!
//! With `--pty` the drives sit on a virtual CAN bus behind a simulated slcan adapter on a new
//! pseudo-terminal, whose path is printed (first line of standard output): `drivectl sbus
//! --iface slcan:PTY` (or any slcan tool) reaches them as through a USB-CAN adapter. With
//! `--iface can0` or `--iface slcan:PATH` they serve a real CAN interface.

use clap::Args;
use drive_core::can::Bitrate;
use drive_transport::can::slcan::SlcanAdapter;
use drive_transport::can::virtual_bus::VirtualBus;
use sbus_can::sim::SimulatedSbusBus;

use crate::error::{CliError, Result};
use crate::sbus::iface::{self, Iface, parse_bitrate};
use crate::tool::simrun;

/// Arguments of `drivectl sim sbus`.
#[derive(Debug, Args)]
#[command(
    after_help = "Examples:\n  drivectl sim sbus --pty --addr 1 --addr 2          prints the pty; then:\n  drivectl sbus --iface slcan:/dev/pts/3 --addr 1 read P000\n  drivectl sim sbus --iface vcan0 --addr 5            on a SocketCAN interface"
)]
pub struct SimArgs {
    /// Serve on this CAN interface: can0/vcan0 (SocketCAN), slcan:PATH or slcan:PATH@BITRATE.
    #[arg(long, conflicts_with = "pty", required_unless_present = "pty")]
    iface: Option<String>,
    /// Serve behind a simulated slcan adapter on a new pseudo-terminal and print its path.
    #[arg(long)]
    pty: bool,
    /// SBus address(es) 0…63 (P813); repeat for several drives on one bus, each once.
    #[arg(long = "addr", default_value = "1")]
    addrs: Vec<u8>,
    /// The virtual bus's bit rate behind the pty (125k, 250k, 500k, 1M); the drives' P816 is
    /// set to it. An slcan client must open the adapter at the same rate.
    #[arg(long, default_value = "500k")]
    bitrate: String,
}

/// P816's value of a bit rate.
fn p816(bitrate: Bitrate) -> Option<u32> {
    match bitrate.bits_per_second() {
        125_000 => Some(0),
        250_000 => Some(1),
        500_000 => Some(2),
        1_000_000 => Some(3),
        _ => None,
    }
}

/// Run the simulated drives until interrupted.
pub fn run(args: &SimArgs) -> Result<()> {
    simrun::check_addresses(&args.addrs, 0..=63, "P813")?;
    let bitrate = parse_bitrate(&args.bitrate)?;
    let p816 = p816(bitrate).ok_or_else(|| {
        CliError::usage(format!(
            "--bitrate {}: a MOVIDRIVE runs SBus at 125k, 250k, 500k or 1M (P816)",
            args.bitrate
        ))
    })?;
    let iface = args.iface.as_deref().map(iface::parse).transpose()?;
    if iface == Some(Iface::Virtual) {
        return Err(CliError::usage(
            "--iface virtual is a bus inside one drivectl process; to reach simulated drives \
             from another process use --pty (a simulated slcan adapter) or a vcan interface",
        ));
    }
    let mut bus = SimulatedSbusBus::new(&args.addrs);
    for d in bus.drives_mut() {
        // P816 follows the bus the drives are on.
        let _ = d.movidrive_mut().param(
            &drive_profile::sew::ParamChannel::write_volatile(
                drive_profile::sew::index::SBUS_BAUD_RATE,
                p816,
            ),
            drive_core::Instant::ZERO,
        );
    }
    let list = simrun::address_list(&args.addrs);
    let what = format!("simulated MOVIDRIVE at SBus address {list}");
    crate::tool::line::runtime()?.block_on(async move {
        match iface {
            Some(Iface::SocketCan(name)) => {
                let port = drive_transport::can::socketcan::SocketCanPort::open(&name)
                    .map_err(|e| CliError::failed(e.to_string()))?;
                errln!("{what} on {name}; Ctrl-C stops");
                bus.serve(port)
                    .await
                    .map_err(|e| CliError::failed(format!("serving {name}: {e}")))
            }
            Some(Iface::Slcan { path, bitrate }) => {
                let port = drive_transport::can::slcan::SlcanPort::open(&path, bitrate)
                    .await
                    .map_err(|e| CliError::failed(e.to_string()))?;
                errln!("{what} on the slcan adapter {path} at {bitrate}; Ctrl-C stops");
                bus.serve(port)
                    .await
                    .map_err(|e| CliError::failed(format!("serving {path}: {e}")))
            }
            Some(Iface::Virtual) => Ok(()),
            None => serve_pty(bus, bitrate, &what).await,
        }
    })
}

/// The drives on a virtual bus behind a simulated slcan adapter on a new pty.
async fn serve_pty(mut bus: SimulatedSbusBus, bitrate: Bitrate, what: &str) -> Result<()> {
    let can = VirtualBus::new(bitrate);
    let drives = can.node();
    let (mut pair, path, _keep) = crate::tool::simrun::sim_pty()?;
    errln!(
        "{what} on a virtual CAN bus at {bitrate} behind an slcan adapter on {} (open it with \
         --iface slcan:{}@{}k); Ctrl-C stops",
        path.display(),
        path.display(),
        bitrate.bits_per_second() / 1000
    );
    let serve = tokio::spawn(async move { bus.serve(drives).await });
    loop {
        let adapter = SlcanAdapter::new(pair.master(), can.node(), bitrate);
        if let Err(e) = adapter.run().await {
            serve.abort();
            return Err(CliError::failed(format!("serving {}: {e}", path.display())));
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
}
