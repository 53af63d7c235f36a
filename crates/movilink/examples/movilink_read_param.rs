//! Read a parameter by its menu number from a simulated MOVIDRIVE over MOVILINK.
//!
//! `cargo run -p movilink --example movilink_read_param`. The simulated drive answers on
//! drive-transport's in-memory RS-485 line (9600 baud 8E1, with wire timing); for a real
//! drive, open the port with `drive_transport::serial::open(&SerialConfig::new(path, 9600))`.

use drive_profile::{ParamMeta, sew};
use drive_transport::link::{LinkConfig, pair};
use movilink::{Address, DriverConfig, MovilinkDriver, ParamServices, SimulatedMovidrive};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (port, wire) = pair(LinkConfig::new(9600));
    let mut drive = SimulatedMovidrive::new(1); // RS-485 address 1 (P810)
    tokio::spawn(async move { drive.serve(wire).await });

    let p130 = sew::lookup("P130").ok_or("P130 is not in the table")?;
    let mut master = MovilinkDriver::new(port, DriverConfig::default());
    let drive1 = Address::new(1).ok_or("address")?;
    let raw = master.read(drive1, p130.bus_index()).await?;
    // P130's range starts at 0: its 32-bit data is unsigned.
    let (label, name, unit) = (p130.label(), p130.name_en(), p130.unit());
    let value = p130.to_physical(raw.into());
    println!("{label} {name}: {value} {unit} (raw {raw})");
    Ok(())
}
