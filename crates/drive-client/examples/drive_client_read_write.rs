//! A parameter by its name, the way a front end works with a drive: read, then written to RAM
//! through the write guard (range, access, the EEPROM-wear rule) and read back.
//!
//! `cargo run -p drive-client --example drive_client_read_write`. A simulated MOVIDRIVE answers
//! over MOVILINK on drive-transport's in-memory RS-485 line; the same client runs over SBus
//! (`drive_client::sew::sbus::SbusLink`), and NORD and Bonfiglioli have theirs
//! (`drive_client::nord`, `drive_client::bonfiglioli`).

use drive_client::sew::{RAW_INDICES, SewClient, movilink::MovilinkLink};
use drive_client::text::physical_text;
use drive_client::write::write_checked;
use drive_client::{MemoryWearLog, ParamClient, Target, ValueText, WriteRequest};
use drive_profile::{Family, Persistence};
use drive_transport::link::{LinkConfig, pair};
use movilink::{Address, DriverConfig, MovilinkDriver, SimulatedMovidrive};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (port, wire) = pair(LinkConfig::new(9600));
    tokio::spawn(async move { SimulatedMovidrive::new(1).serve(wire).await });
    let mut driver = MovilinkDriver::new(port, DriverConfig::default());
    let link = MovilinkLink::new(&mut driver, Address::new(1).ok_or("address")?, "sim");
    let mut drive = SewClient::new(link);

    let p130 = Target::resolve(Family::Movidrive, "P130", RAW_INDICES)?;
    let meta = p130.param.ok_or("P130 is in the table")?;
    let raw = drive.read(&p130).await?;
    println!("{}: {}", p130.label(), physical_text(meta, raw));

    let raw = p130.value_from_text("1.5", &ValueText::default())?.raw; // 1.5 s, checked
    let req = WriteRequest {
        target: p130,
        raw,
        persistence: Persistence::Volatile,
        force: false,
    };
    let written = write_checked(
        &mut drive,
        &req,
        false,
        &MemoryWearLog::default(),
        &mut |w| eprintln!("warning: {w}"),
    )
    .await?;
    println!(
        "{} = {} (read back)",
        p130.label(),
        physical_text(meta, written.back)
    );
    Ok(())
}
