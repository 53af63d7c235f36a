//! An adapter that echoes what it sends, on the wire model (`LinkConfig::echo`: the master's
//! end hears its own characters), for every serial family, as a library caller meets it: the
//! port wrapped in `EchoCancel` with the echo on or off, as drivectl and the gateway wrap theirs.
//! The same cases run through a pty relay in drivectl's `tests/echo_pty.rs`.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::time::Duration;

use bonfiglioli_modbus::driver::{
    DriverConfig as ModbusConfig, DriverError as ModbusError, LinkError as ModbusLink, ModbusDriver,
};
use bonfiglioli_modbus::frame::{Address as ModbusAddress, DataSet, DiagSubFunction};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use ctt2_uss::Storage;
use ctt2_uss::client::{Address as Pnu, ClientConfig, ClientError as UssClientError, NordClient};
use ctt2_uss::serial::driver::{
    DriverConfig as UssConfig, DriverError as UssError, LinkError as UssLink, UssDriver,
};
use ctt2_uss::serial::sim::SimulatedDrive;
use ctt2_uss::serial::{Layout, UssAddress};
use drive_client::bonfiglioli::BonfiglioliClient;
use drive_client::sew::SewClient;
use drive_client::sew::movilink::MovilinkLink;
use drive_client::{ParamClient, Target};
use drive_core::rt::echo::{EchoCancel, EchoStats};
use drive_core::{LineSettings, Parity};
use drive_profile::{Family, Persistence};
use drive_sim::bonfiglioli::Variant;
use drive_transport::link::{self, Fault, LinkConfig, LinkEnd};
use movilink::driver::{DriverConfig as MovilinkConfig, MovilinkDriver};
use movilink::sim::SimulatedMovidrive;

fn modbus_line() -> LineSettings {
    Mode::Rtu.line_settings(19200, Parity::Even)
}

/// An echoing line: the master's end (wrapped, echo on or off) and the bus's end.
fn echoing(line: LineSettings, echo: bool) -> (EchoCancel<LinkEnd>, LinkEnd) {
    let (port, wire) = link::pair(LinkConfig::from_line(line).with_echo());
    (EchoCancel::new(port, echo), wire)
}

fn modbus(port: EchoCancel<LinkEnd>) -> ModbusDriver<EchoCancel<LinkEnd>> {
    ModbusDriver::new(port, ModbusConfig::new(Mode::Rtu, modbus_line()))
}

fn a1() -> ModbusAddress {
    ModbusAddress::new(1).unwrap()
}

/// `read` done within a second (a missing character fails the test instead of waiting forever).
async fn within<F: std::future::Future<Output = std::io::Result<usize>>>(read: F) {
    match tokio::time::timeout(Duration::from_secs(1), read).await {
        Ok(Ok(_)) => {}
        other => panic!("nothing read within a second: {other:?}"),
    }
}

#[tokio::test(start_paused = true)]
async fn the_wire_model_echoes_the_first_end_and_only_it() {
    use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
    let (mut a, mut b) = link::pair(LinkConfig::new(9600).with_echo());
    a.write_all(b"req").await.unwrap();
    let (mut at_a, mut at_b) = ([0u8; 3], [0u8; 3]);
    within(a.read_exact(&mut at_a)).await;
    within(b.read_exact(&mut at_b)).await;
    assert_eq!((&at_a, &at_b), (b"req", b"req"));
    // The answer reaches the first end after its echo; the second end hears nothing of its own.
    b.write_all(b"ans").await.unwrap();
    within(a.read_exact(&mut at_a)).await;
    assert_eq!(&at_a, b"ans");
    let nothing = tokio::time::timeout(Duration::from_secs(1), b.read(&mut at_b)).await;
    assert!(nothing.is_err(), "the second end heard {at_b:?}");
    // A character flipped on the wire is flipped in the echo too; a drop is the far end's.
    a.inject(Fault::Flip(1 << 1));
    a.inject(Fault::Drop);
    a.write_all(&[0x10, 0x20]).await.unwrap();
    let mut two = [0u8; 2];
    within(a.read_exact(&mut two)).await;
    assert_eq!(two, [0x11, 0x20]);
    let mut one = [0u8; 1];
    within(b.read_exact(&mut one)).await;
    assert_eq!(one, [0x11]);
}

#[tokio::test(start_paused = true)]
async fn a_write_to_a_silent_echoing_bus_is_never_a_success() {
    for echo in [false, true] {
        // FC 6 (a 16-bit write): its answer repeats the request byte for byte.
        let (port, _bus) = echoing(modbus_line(), echo);
        let mut m = modbus(port);
        let ds = DataSet::new(2).unwrap();
        let r = m.write(a1(), 372, ds, Width::Word, 1390).await;
        match (echo, &r) {
            // Echo off: the copy could be the echo or an answer; the line shows it echoes.
            (false, Err(ModbusError::Link(ModbusLink::Echo { address: 1, .. }))) => {}
            // Echo on: the echo is taken out and nobody answered.
            (true, Err(ModbusError::Link(ModbusLink::Timeout { address: 1, .. }))) => {}
            _ => panic!("echo {echo}: FC 6 to nobody gave {r:?}"),
        }
        // FC 8 (diagnostics: a counter of a drive that is not there) likewise.
        let r = m.diagnostics(a1(), DiagSubFunction::BUS_MESSAGES).await;
        assert!(
            matches!(
                (echo, &r),
                (false, Err(ModbusError::Link(ModbusLink::Echo { .. })))
                    | (true, Err(ModbusError::Link(ModbusLink::Timeout { .. })))
            ),
            "echo {echo}: FC 8 to nobody gave {r:?}"
        );
    }
    // A USS read (AK 1): a drive's mirror-like answer could repeat it too.
    for echo in [false, true] {
        let line = LineSettings::new(9600);
        let (port, _bus) = echoing(line, echo);
        let a = UssAddress::new(1).unwrap();
        let mut c = NordClient::new(
            UssDriver::new(port, UssConfig::new(a, Layout::PKW4_PZD4, line)),
            ClientConfig::default(),
        );
        let r = c.read(Pnu::new(102)).await;
        match (echo, &r) {
            (false, Err(UssClientError::Transport(UssError::Link(UssLink::Echo { .. })))) => {}
            (true, Err(UssClientError::Transport(UssError::Link(UssLink::Timeout { .. })))) => {}
            _ => panic!("echo {echo}: a USS read from nobody gave {r:?}"),
        }
    }
}

fn sew(key: &str) -> Target {
    Target::resolve(Family::Movidrive, key, drive_client::sew::RAW_INDICES).unwrap()
}

#[tokio::test(start_paused = true)]
async fn with_echo_every_serial_family_works_through_an_echoing_adapter() {
    // MOVILINK.
    let echoes = movilink_round_trip(true, 1500).await;
    assert!(echoes.echoed > 0, "{echoes:?}");
    assert_eq!(echoes.collisions, 0, "{echoes:?}");
    // USS.
    let line = LineSettings::new(9600);
    let (port, wire) = echoing(line, true);
    let a = UssAddress::new(1).unwrap();
    let mut sim = SimulatedDrive::new(a, Layout::PKW4_PZD4, line);
    let client = async move {
        let mut c = NordClient::new(
            UssDriver::new(port, UssConfig::new(a, Layout::PKW4_PZD4, line)),
            ClientConfig::default(),
        );
        let (p102, width) = c.read_value(Pnu::new(102)).await.unwrap();
        let value = i64::from(p102) + 10;
        c.write(Pnu::new(102), width, Storage::Ram, value)
            .await
            .unwrap();
        assert_eq!(i64::from(c.read(Pnu::new(102)).await.unwrap()), value);
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the USS simulator ended: {r:?}"),
        () = client => {}
    }
    // Modbus RTU, FC 6 included: the answer that repeats the request is heard after the echo.
    let (port, wire) = echoing(modbus_line(), true);
    let mut sim = bonfiglioli_modbus::sim::bus(&[1], Variant::Acu, Mode::Rtu, modbus_line());
    let client = async move {
        let mut driver = modbus(port);
        let mut c = BonfiglioliClient::new(&mut driver, a1(), "/dev/ttyS8", None);
        let in_set = drive_client::bonfiglioli::target(372, 2).unwrap();
        let before = c.read(&in_set).await.unwrap();
        c.write(&in_set, before + 100, Persistence::Volatile)
            .await
            .unwrap();
        assert_eq!(c.read(&in_set).await.unwrap(), before + 100);
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the Modbus simulator ended: {r:?}"),
        () = client => {}
    }
}

/// P130 written to RAM and read back from a simulated MOVIDRIVE through an echoing line whose
/// echo is taken out (`echo`) or not; what the line's echo handling counted.
async fn movilink_round_trip(echo: bool, value: i64) -> EchoStats {
    let (port, wire) = echoing(LineSettings::new(9600), echo);
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut driver = MovilinkDriver::new(port, MovilinkConfig::default());
        let at = movilink::Address::new(1).unwrap();
        let mut c = SewClient::new(MovilinkLink::new(&mut driver, at, "/dev/ttyS7"));
        let p130 = sew("P130");
        c.write(&p130, value, Persistence::Volatile).await.unwrap();
        assert_eq!(c.read(&p130).await.unwrap(), value);
        driver.into_inner().stats()
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the MOVILINK simulator ended: {r:?}"),
        stats = client => stats,
    }
}

#[tokio::test(start_paused = true)]
async fn without_echo_movilink_cannot_take_its_echo_for_an_answer() {
    // A MOVILINK request (SD1) and its answer (SD2) never look alike: with the echo off the
    // echo is a frame of the wrong kind, skipped, and the drive's answer after it is taken.
    let echoes = movilink_round_trip(false, 1200).await;
    assert_eq!(
        echoes.echoed, 0,
        "nothing taken out with the echo off: {echoes:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_corrupted_echo_is_a_collision_and_nothing_is_taken() {
    let (port, wire) = link::pair(LinkConfig::from_line(modbus_line()).with_echo());
    // The first read's request (8 characters) goes out whole; in the second's, a bit of the
    // third character is flipped on the wire: the drive throws the frame away (CRC), the echo
    // differs, and the retry is answered.
    for _ in 0..8 + 2 {
        port.inject(Fault::Delay(Duration::ZERO));
    }
    port.inject(Fault::Flip(1 << 3));
    let mut sim = bonfiglioli_modbus::sim::bus(&[1], Variant::Acu, Mode::Rtu, modbus_line());
    let client = async move {
        let mut m = modbus(EchoCancel::new(port, true));
        let ds = DataSet::new(2).unwrap();
        let before = m.read(a1(), 372, ds, Width::Word).await.unwrap();
        assert_eq!(m.stats().retries, 0);
        let again = m.read(a1(), 372, ds, Width::Word).await.unwrap();
        assert_eq!(again, before);
        assert_eq!(m.stats().retries, 1, "{:?}", m.stats());
        // Every attempt corrupted: a collision each time, never a value.
        let line = m.into_inner();
        assert_eq!(line.stats().collisions, 1, "{:?}", line.stats());
        line.get_ref()
            .set_faults(drive_transport::link::FaultConfig {
                flip: 1.0,
                ..drive_transport::link::FaultConfig::none()
            });
        let echoed = line.stats().echoed;
        let mut m = modbus(line);
        let r = m.read(a1(), 372, ds, Width::Word).await;
        assert!(
            matches!(
                r,
                Err(ModbusError::Link(
                    ModbusLink::Corrupt { .. } | ModbusLink::Timeout { .. }
                ))
            ),
            "{r:?}"
        );
        assert_eq!(m.stats().retries, 2, "three attempts: {:?}", m.stats());
        // No echo came back as sent: each differed (a collision once it had begun, foreign
        // characters before), and none of it reached the master unflagged.
        let echoes = m.into_inner().stats();
        assert!(echoes.collisions + echoes.foreign > 0, "{echoes:?}");
        assert!(echoes.echoed - echoed < 8, "{echoes:?}");
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the Modbus simulator ended: {r:?}"),
        () = client => {}
    }
}
