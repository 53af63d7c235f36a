//! The bus task. INTERFACE STUB.

use super::bus::{BusAccess, BusContext};

/// Run the bus of `ctx` on `access` until the gateway stops.
pub async fn run_bus<B: BusAccess>(_ctx: BusContext, _access: B) {}
