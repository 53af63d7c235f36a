//! Opening `--iface` (SocketCAN, slcan, the virtual bus with simulated drives) and the SBus
//! master's errors on the command line; the way to a drive over SBus is drive-client's
//! `SbusLink`.

use drive_core::can::Bitrate;
use drive_core::rt::CanIo;
use sbus_can::driver::DriverError;
use sbus_can::sim::SimulatedSbusBus;

use crate::error::{CliError, Result};
use crate::sbus::iface::Iface;

/// A driver error as a one-line CLI error.
pub fn driver_error(e: DriverError) -> CliError {
    CliError::failed(e.to_string())
}

/// The simulated MOVIDRIVEs of `--iface virtual`: SBus addresses 1 and 2, and `addr` if it is
/// another one.
pub fn virtual_addresses(addr: u8) -> Vec<u8> {
    let mut v = vec![1, 2];
    if !v.contains(&addr) {
        v.push(addr);
    }
    v
}

/// An open CAN interface.
pub type BoxedIo = Box<dyn CanIo>;

/// Open `iface`. `virtual` starts a virtual bus at `bitrate` with simulated MOVIDRIVEs at
/// `sim_addresses` served in this process (the returned task ends with the bus).
pub async fn open(
    iface: &Iface,
    bitrate: Bitrate,
    sim_addresses: &[u8],
) -> Result<(BoxedIo, Option<tokio::task::JoinHandle<()>>)> {
    match iface.open().await {
        Some(opened) => {
            let port = opened.map_err(|e| match iface {
                // A setting or path the adapter's port refuses is the user's to change.
                Iface::Slcan { .. } => crate::tool::line::open_cli_error(&e),
                _ => CliError::failed(e.to_string()),
            })?;
            crate::tool::stale::note_flushed(port.flushed_at_open);
            Ok((port.io, None))
        }
        None => {
            let bus = drive_transport::can::virtual_bus::VirtualBus::new(bitrate);
            let node = bus.node();
            let master = bus.node();
            let mut drives = SimulatedSbusBus::new(sim_addresses);
            let task = tokio::spawn(async move {
                // The simulated drives serve until the master's node is dropped.
                let _ = drives.serve(node).await;
            });
            Ok((Box::new(master), Some(task)))
        }
    }
}
