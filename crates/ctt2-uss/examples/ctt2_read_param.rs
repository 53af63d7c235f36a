//! Read a parameter by its number from a simulated NORD NORDAC LINK over CTT2 (AS-Interface).
//!
//! `cargo run -p ctt2-uss --example ctt2_read_param`. The drive's double slave sits on a
//! simulated AS-i network of two slaves ([`SimulatedLink`], which models the AS-i master and
//! the transfer times); for a real AS-i master, implement [`Ctt2Link`](ctt2_uss::Ctt2Link).

use ctt2_uss::{Address, ClientConfig, Ctt2Driver, Ctt2DriverConfig, NordClient};
use ctt2_uss::{SimulatedDoubleSlave, SimulatedLink};
use drive_profile::{ParamMeta, nord};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let link = SimulatedLink::new(SimulatedDoubleSlave::default(), 2)?;

    let p102 = nord::lookup("P102").ok_or("P102 is not in the table")?;
    let master = Ctt2Driver::new(link, Ctt2DriverConfig::default());
    let mut client = NordClient::new(master, ClientConfig::default());
    let raw = client.read(Address::new(p102.bus_index())).await?; // parameter set 1
    let (label, name, unit) = (p102.label(), p102.name_en(), p102.unit());
    let value = p102.to_physical(raw.into());
    println!("{label} {name}: {value} {unit} (raw {raw})");
    Ok(())
}
