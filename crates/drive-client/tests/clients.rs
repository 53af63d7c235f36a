//! The family clients as a library caller uses them: against the simulated drives over the wire
//! model of drive-transport, on tokio's paused clock. Values come from the table and the
//! drive, a drive's refusal is a device error and a drive that is not there a link failure.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use bonfiglioli_modbus::driver::ModbusDriver;
use bonfiglioli_modbus::framing::Mode;
use drive_client::bonfiglioli::BonfiglioliClient;
use drive_client::sew::movilink::MovilinkLink;
use drive_client::sew::{SewClient, describe};
use drive_client::{ClientError, DeviceCode, DeviceErrorKind, LinkFault, ParamClient, Target};
use drive_core::{LineSettings, Parity};
use drive_profile::{Family, Persistence};
use drive_transport::link::{self, LinkConfig};
use movilink::Address;
use movilink::driver::{DriverConfig, MovilinkDriver};
use movilink::sim::SimulatedMovidrive;

fn sew(key: &str) -> Target {
    Target::resolve(Family::Movidrive, key, drive_client::sew::RAW_INDICES).unwrap()
}

fn address(a: u8) -> Address {
    Address::new(a).unwrap()
}

#[tokio::test(start_paused = true)]
async fn a_movidrive_over_movilink_reads_writes_identifies_and_refuses_typed() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut driver = MovilinkDriver::new(port, DriverConfig::default());
        let mut c = SewClient::new(MovilinkLink::new(&mut driver, address(1), "/dev/ttyS7"));
        // P130 ramp up: written to RAM, read back as written.
        let p130 = sew("P130");
        c.write(&p130, 1500, Persistence::Volatile).await.unwrap();
        assert_eq!(c.read(&p130).await.unwrap(), 1500);
        let identity = c.identify().await.unwrap();
        assert_eq!(identity["address"], 1);
        assert_eq!(identity["device_type"], drive_sim::movidrive::UNIT_TYPE);
        assert_eq!(c.drive_key().await.unwrap(), "/dev/ttyS7 1");
        // What the drive says about P130 beside its value.
        let d = describe(&mut c.link, p130.index).await.unwrap();
        assert_eq!(d.current, 1500);
        assert!(d.minimum <= d.current && d.current <= d.maximum, "{d:?}");
        // An index the drive does not have: its refusal, sorted as absent (a backup skips it).
        match c.read(&sew("9999")).await {
            Err(ClientError::Device(e)) => {
                assert_eq!(e.kind, DeviceErrorKind::Absent, "{e}");
                // The drive's own code, as the parameter channel carried it.
                let DeviceCode::Sew(code) = e.code else {
                    panic!("a SEW drive's refusal carries its return code: {e:?}");
                };
                assert_eq!(
                    drive_client::sew::device_error_kind(code),
                    DeviceErrorKind::Absent
                );
            }
            other => panic!("expected the drive's refusal, got {other:?}"),
        }
        // Point-to-point: the drive names itself by its own address (P810).
        let mut p2p = SewClient::new(MovilinkLink::new(&mut driver, address(254), "/dev/ttyS7"));
        assert_eq!(p2p.drive_key().await.unwrap(), "/dev/ttyS7 1");
        // Nobody at address 2: a link failure of the kind "no answer", not a refusal.
        let mut absent = SewClient::new(MovilinkLink::new(&mut driver, address(2), "/dev/ttyS7"));
        match absent.read(&p130).await {
            Err(ClientError::Link(e)) => {
                assert_eq!(e.fault, LinkFault::NoAnswer, "{e}");
                assert!(e.message.contains("check address"), "{e}");
            }
            other => panic!("address 2 answered: {other:?}"),
        }
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
}

fn line() -> LineSettings {
    Mode::Rtu.line_settings(19200, Parity::Even)
}

#[tokio::test(start_paused = true)]
async fn an_active_cube_over_modbus_rtu_in_its_data_sets_and_by_its_variant() {
    use bonfiglioli_modbus::driver::DriverConfig;
    use bonfiglioli_modbus::frame::Address;
    use drive_sim::bonfiglioli::Variant;

    let (port, wire) = link::pair(LinkConfig::from_line(line()));
    let mut sim = bonfiglioli_modbus::sim::bus(&[1], Variant::Acu, Mode::Rtu, line());
    let client = async move {
        let mut driver = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line()));
        let a = Address::new(1).unwrap();
        let mut c = BonfiglioliClient::new(&mut driver, a, "/dev/ttyS8", None);
        let found = c.find_variant().await.unwrap();
        assert_eq!(
            found.variant.map(|k| k.variant),
            Some(drive_profile::bonfiglioli::Variant::Acu)
        );
        assert!(found.why.is_some(), "the drive was asked");
        // 372 rated speed (16-bit, one value per data set) in data set 2: written to RAM, read
        // back from that data set only.
        let in_set = |n: u8| drive_client::bonfiglioli::target(372, n).unwrap();
        let before = c.read(&in_set(1)).await.unwrap();
        c.write(&in_set(2), before + 100, Persistence::Volatile)
            .await
            .unwrap();
        assert_eq!(c.read(&in_set(2)).await.unwrap(), before + 100);
        assert_eq!(c.read(&in_set(1)).await.unwrap(), before);
        assert_eq!(c.drive_key().await.unwrap(), "/dev/ttyS8 1");
        // 376 = 0 kW the drive refuses: exception 4 with the VABus error it names (1, an
        // illegal parameter value); a caller can match on both.
        let p376 = drive_client::bonfiglioli::target(376, 2).unwrap();
        match c.write(&p376, 0, Persistence::Volatile).await {
            Err(ClientError::Device(e)) => assert_eq!(
                e.code,
                DeviceCode::Modbus {
                    exception: 4,
                    vabus: Some(1)
                },
                "{e}"
            ),
            other => panic!("376 = 0 was not refused: {other:?}"),
        }
        // Nobody at address 2: no answer, with what to check.
        let b = Address::new(2).unwrap();
        let mut absent = BonfiglioliClient::new(&mut driver, b, "/dev/ttyS8", None);
        match absent.read(&in_set(1)).await {
            Err(ClientError::Link(e)) => assert_eq!(e.fault, LinkFault::NoAnswer, "{e}"),
            other => panic!("address 2 answered: {other:?}"),
        }
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
}
