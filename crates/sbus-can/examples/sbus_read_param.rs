//! Read a parameter by its menu number from a simulated MOVIDRIVE over SBus (CAN).
//!
//! `cargo run -p sbus-can --example sbus_read_param`. The simulated drive sits on drive-transport's
//! in-memory CAN bus (500 kbit/s, with frame times); for a real bus, give the driver a
//! SocketCAN interface or an slcan adapter from `drive_transport::can`.

use drive_core::can::Bitrate;
use drive_profile::{ParamMeta, sew};
use drive_transport::can::virtual_bus::VirtualBus;
use sbus_can::{Address, MasterConfig, ParamServices, SbusDriver, SimulatedSbusBus};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let bus = VirtualBus::new(Bitrate::K500);
    let mut drives = SimulatedSbusBus::new(&[1]); // SBus address 1 (P813)
    let node = bus.node();
    tokio::spawn(async move { drives.serve(node).await });

    let p130 = sew::lookup("P130").ok_or("P130 is not in the table")?;
    let mut master = SbusDriver::new(bus.node(), MasterConfig::default());
    let drive1 = Address::new(1).ok_or("address")?;
    let raw = master.read(drive1, p130.bus_index()).await?;
    // P130's range starts at 0: its 32-bit data is unsigned.
    let (label, name, unit) = (p130.label(), p130.name_en(), p130.unit());
    let value = p130.to_physical(raw.into());
    println!("{label} {name}: {value} {unit} (raw {raw})");
    Ok(())
}
