//! Read a parameter by its number from a simulated Bonfiglioli ACTIVE Cube over Modbus RTU.
//!
//! `cargo run -p bonfiglioli-modbus --example bonfiglioli_read_param`. The simulated drive
//! answers on drive-transport's in-memory RS-485 line (19200 baud 8E1, with wire timing); for a
//! real drive, open the port with `drive_transport::serial::open(&SerialConfig::with_line(path,
//! line))`.

use bonfiglioli_modbus::sim::{SimulatedDrive, Variant};
use bonfiglioli_modbus::{Address, DataSet, DriverConfig, ModbusDriver, Mode, Width};
use drive_core::LineSettings;
use drive_profile::{ParamMeta, bonfiglioli};
use drive_transport::link::{LinkConfig, pair};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let line = LineSettings::new(19200); // 8E1
    let (port, wire) = pair(LinkConfig::from_line(line));
    let mut drive = SimulatedDrive::new(1, Variant::Acu, Mode::Rtu, line); // Modbus address 1
    tokio::spawn(async move { drive.serve(wire).await });

    let p372 = bonfiglioli::lookup("372").ok_or("372 is not in the table")?;
    let width = Width::of_param(p372.number).ok_or("the table gives no data type")?;
    let drive1 = Address::new(1).ok_or("address")?;
    let data_set = DataSet::new(1).ok_or("data set")?;
    let mut master = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line));
    let raw = master.read(drive1, p372.number, data_set, width).await?;
    // 372 is uInt: its 16-bit data is unsigned.
    let (name, unit) = (p372.name_en, p372.unit);
    let value = p372.to_physical(raw.into());
    println!("372 {name}, data set 1: {value} {unit} (raw {raw})");
    Ok(())
}
