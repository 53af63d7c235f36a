//! Each protocol's [`BusAccess`](super::bus::BusAccess), opening a bus (its port, or simulated
//! drives on the wire model), and the example config.
//!
//! INTERFACE STUB.

use super::bus::BusContext;
use super::config::{Bus, Endpoint, Plant};
use crate::error::Result;

/// The commented example config of `drivectl gateway --example-config`.
pub const EXAMPLE_CONFIG: &str = "";

/// The simulated endpoint of `bus` (`--simulate`): the same line settings on the wire model.
pub fn simulated_endpoint(bus: &Bus) -> Endpoint {
    match &bus.endpoint {
        Endpoint::Serial { line, .. } => Endpoint::Simulated {
            line: *line,
            bitrate: 500_000,
        },
        _ => Endpoint::Simulated {
            line: drive_core::LineSettings::new(9600),
            bitrate: 500_000,
        },
    }
}

/// `--check`: each bus's wire demand.
pub fn print_check(_plant: &Plant) -> Result<()> {
    Ok(())
}

/// Open the bus of `ctx` and run its task (reopening a port that fails, with a back-off).
pub async fn run_bus(_ctx: BusContext) {}
