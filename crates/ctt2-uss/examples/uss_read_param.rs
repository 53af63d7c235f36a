//! Read a parameter by its number from a simulated NORD NORDAC LINK over USS (RS-485).
//!
//! `cargo run -p ctt2-uss --example uss_read_param`. The simulated drive answers on
//! drive-transport's in-memory RS-485 line (9600 baud 8E1, with wire timing); for a real
//! drive, open the port with `drive_transport::serial::open(&SerialConfig::with_line(path, line))`.
//! Over AS-Interface the same [`NordClient`] runs on a `Ctt2Driver` (example `ctt2_read_param`).

use ctt2_uss::{Address, ClientConfig, Layout, NordClient, SimulatedDrive, UssAddress};
use ctt2_uss::{UssDriver, UssDriverConfig};
use drive_core::LineSettings;
use drive_profile::{ParamMeta, nord};
use drive_transport::link::{LinkConfig, pair};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let line = LineSettings::new(9600); // 8E1
    let address = UssAddress::new(1).ok_or("address")?;
    let (port, wire) = pair(LinkConfig::from_line(line));
    let mut drive = SimulatedDrive::new(address, Layout::PKW4_PZD4, line);
    tokio::spawn(async move { drive.serve(wire).await });

    let p102 = nord::lookup("P102").ok_or("P102 is not in the table")?;
    let config = UssDriverConfig::new(address, Layout::PKW4_PZD4, line);
    let mut client = NordClient::new(UssDriver::new(port, config), ClientConfig::default());
    let raw = client.read(Address::new(p102.bus_index())).await?; // parameter set 1
    let (label, name, unit) = (p102.label(), p102.name_en(), p102.unit());
    let value = p102.to_physical(raw.into());
    println!("{label} {name}: {value} {unit} (raw {raw})");
    Ok(())
}
