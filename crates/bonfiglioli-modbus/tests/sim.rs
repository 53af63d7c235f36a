//! The master driver against the simulated ACT and ACU over the wire model, on tokio's paused
//! clock: the manual's examples answered by the drive model, the VABus cause of exception 4,
//! the state machine through 410/411 with the frequency setpoint 484, the watchdog 413 and a
//! change of the Modbus address 1376.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::time::Duration;

use bonfiglioli_modbus::driver::{DriverConfig, DriverError, LinkError, ModbusDriver};
use bonfiglioli_modbus::frame::{Address, DataSet, ExceptionCode, Request, Response, StartAddress};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::sim::{self, SimulatedBus};
use bonfiglioli_modbus::slave::Width;
use drive_core::{LineSettings, Parity};
use drive_profile::bonfiglioli::{AcuStateMachine, State};
use drive_profile::state::StateMachine;
use drive_sim::bonfiglioli::Variant;
use drive_transport::link::{self, LinkConfig, LinkEnd};

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

fn ds(n: u8) -> DataSet {
    DataSet::new(n).unwrap()
}

fn line(mode: Mode) -> LineSettings {
    mode.line_settings(19200, Parity::Even)
}

/// A master on a line with simulated drives of `variant` at 1 and 2.
fn bus(
    mode: Mode,
    variant: Variant,
) -> (ModbusDriver<LinkEnd>, tokio::task::JoinHandle<SimulatedBus>) {
    let (port, wire) = link::pair(LinkConfig::from_line(line(mode)));
    let mut sim = sim::bus(&[1, 2], variant, mode, line(mode));
    let task = tokio::spawn(async move {
        let _ = sim.serve(wire).await;
        sim
    });
    (
        ModbusDriver::new(port, DriverConfig::new(mode, line(mode))),
        task,
    )
}

#[tokio::test(start_paused = true)]
async fn the_manuals_examples_answered_by_the_drive_model() {
    for mode in [Mode::Rtu, Mode::Ascii] {
        for variant in [Variant::Act, Variant::Acu] {
            let (mut m, sim) = bus(mode, variant);
            // 8.1.1: rated speed 372 in data set 2 is 1390.
            assert_eq!(m.read(a(1), 372, ds(2), Width::Word).await.unwrap(), 1390);
            // 8.1.2: 1.5 kW to 376 in data set 4; 0 is refused with exception 4, VABus 1.
            m.write(a(1), 376, ds(4), Width::Word, 15).await.unwrap();
            assert_eq!(m.read(a(1), 376, ds(4), Width::Word).await.unwrap(), 15);
            match m.write(a(1), 376, ds(2), Width::Word, 0).await {
                Err(DriverError::Device {
                    exception,
                    vabus: Some(1),
                }) => {
                    assert_eq!(exception, ExceptionCode::SLAVE_DEVICE_FAILURE);
                }
                other => panic!("{mode} {variant:?}: {other:?}"),
            }
            // 8.1.3: fixed frequency 2 (481) is 10.00 Hz; unknown 1600 in data set 2 → E4 04.
            assert_eq!(
                m.read(a(1), 481, DataSet::ALL, Width::Long).await.unwrap(),
                1000
            );
            let r = m
                .transact(
                    a(1),
                    Request::ReadLong {
                        start: StartAddress::from_raw(0x2640),
                    },
                    Duration::from_millis(500),
                )
                .await
                .unwrap();
            assert_eq!(
                r,
                Some(Response::Exception {
                    function: 100,
                    code: ExceptionCode::SLAVE_DEVICE_FAILURE
                })
            );
            // Register 11 names the cause (unknown parameter) and is cleared by the read.
            assert_eq!(
                m.read(a(1), 11, DataSet::ALL, Width::Word).await.unwrap(),
                11
            );
            assert_eq!(
                m.read(a(1), 11, DataSet::ALL, Width::Word).await.unwrap(),
                0
            );
            // The wrong width: exception 2.
            match m.read(a(1), 481, DataSet::ALL, Width::Word).await {
                Err(DriverError::Device {
                    exception,
                    vabus: None,
                }) => {
                    assert_eq!(exception, ExceptionCode::ILLEGAL_DATA_ADDRESS);
                }
                other => panic!("{other:?}"),
            }
            drop(m);
            sim.await.unwrap();
        }
    }
}

#[tokio::test(start_paused = true)]
async fn the_acu_runs_up_under_the_state_machine_and_stops() {
    let (mut m, sim) = bus(Mode::Rtu, Variant::Acu);
    let d = a(1);
    // Local/Remote 412 = 1: control through the state machine (RAM data set 5 = all).
    m.write(d, 412, ds(5), Width::Word, 1).await.unwrap();
    let status = m.read(d, 411, DataSet::ALL, Width::Word).await.unwrap() as u16;
    assert_eq!(
        AcuStateMachine::decode(status),
        State::SwitchOnDisabled,
        "0x{status:04X}"
    );
    // 10.00 Hz, then 0x06, 0x07, 0x0F.
    m.write(d, 484, DataSet::ALL, Width::Long, 1000)
        .await
        .unwrap();
    for word in [0x06, 0x07, 0x0F] {
        m.write(d, 410, DataSet::ALL, Width::Word, word)
            .await
            .unwrap();
    }
    let status = m.read(d, 411, DataSet::ALL, Width::Word).await.unwrap() as u16;
    assert_eq!(
        AcuStateMachine::decode(status),
        State::OperationEnabled,
        "0x{status:04X}"
    );
    tokio::time::sleep(Duration::from_secs(5)).await;
    let f = m.read(d, 241, DataSet::ALL, Width::Long).await.unwrap();
    assert_eq!(f, 1000, "reached 10.00 Hz");
    // Disable operation (transition 5, 392 = ramp): the drive ramps down (5 Hz/s), holds at
    // standstill for its holding time (638: 1 s), then shows switched on.
    m.write(d, 410, DataSet::ALL, Width::Word, 0x07)
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_secs(1)).await;
    let status = m.read(d, 411, DataSet::ALL, Width::Word).await.unwrap() as u16;
    assert_eq!(
        AcuStateMachine::decode(status),
        State::OperationEnabled,
        "0x{status:04X}"
    );
    let f = m.read(d, 241, DataSet::ALL, Width::Long).await.unwrap();
    assert!(f < 1000, "ramping down: {f}");
    tokio::time::sleep(Duration::from_secs(3)).await;
    assert_eq!(m.read(d, 241, DataSet::ALL, Width::Long).await.unwrap(), 0);
    let status = m.read(d, 411, DataSet::ALL, Width::Word).await.unwrap() as u16;
    assert_eq!(
        AcuStateMachine::decode(status),
        State::SwitchedOn,
        "0x{status:04X}"
    );
    drop(m);
    sim.await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn the_watchdog_faults_when_the_master_goes_quiet() {
    let (mut m, sim) = bus(Mode::Rtu, Variant::Act);
    let d = a(2);
    m.write(d, 413, ds(5), Width::Word, 1).await.unwrap();
    // Exchanges every 500 ms keep it fed.
    for _ in 0..4 {
        tokio::time::sleep(Duration::from_millis(500)).await;
        assert_eq!(m.read(d, 260, DataSet::ALL, Width::Word).await.unwrap(), 0);
    }
    // Two quiet seconds: fault F2010.
    tokio::time::sleep(Duration::from_secs(2)).await;
    assert_eq!(
        m.read(d, 260, DataSet::ALL, Width::Word).await.unwrap(),
        0x2010
    );
    drop(m);
    sim.await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn a_new_modbus_address_takes_effect_at_once() {
    let (mut m, sim) = bus(Mode::Ascii, Variant::Act);
    m.write(a(2), 1376, ds(5), Width::Word, 17).await.unwrap();
    assert_eq!(m.read(a(17), 372, ds(2), Width::Word).await.unwrap(), 1390);
    match m.read(a(2), 372, ds(2), Width::Word).await {
        Err(DriverError::Link(LinkError::Timeout { address: 2, .. })) => {}
        other => panic!("{other:?}"),
    }
    drop(m);
    let sim = sim.await.unwrap();
    assert!(sim.station(17).is_some() && sim.station(2).is_none());
}

/// Issue 18: the drive's own line parameters say what it serves (10 baud rate, 395 protocol,
/// 1375 parity, 1376 address), and a new protocol type takes effect at once (ch. 6).
#[tokio::test(start_paused = true)]
async fn issue18_the_line_parameters_say_what_the_drive_serves() {
    for (mode, protocol) in [(Mode::Rtu, 2), (Mode::Ascii, 3)] {
        let (mut m, _sim) = bus(mode, Variant::Acu);
        let read = async |m: &mut ModbusDriver<LinkEnd>, p| {
            m.read(a(2), p, DataSet::ALL, Width::Word).await.unwrap()
        };
        // 19200 baud = 4, even parity = 0 (line()), the protocol of the mode, address 2.
        assert_eq!(read(&mut m, 10).await, 4);
        assert_eq!(read(&mut m, 395).await, protocol);
        assert_eq!(read(&mut m, 1375).await, 0);
        assert_eq!(read(&mut m, 1376).await, 2);
    }
    let l = Mode::Rtu.line_settings(9600, Parity::None);
    let drive = sim::SimulatedDrive::new(7, Variant::Act, Mode::Rtu, l);
    let s = drive.drive().store();
    assert_eq!(
        (s.read(10, 0), s.read(395, 0), s.read(1375, 0)),
        (Ok(3), Ok(2), Ok(2))
    );
}

#[tokio::test(start_paused = true)]
async fn issue18_a_new_protocol_type_takes_effect_at_once() {
    let (port, wire) = link::pair(LinkConfig::from_line(line(Mode::Rtu)));
    let mut sim = sim::bus(&[1], Variant::Act, Mode::Rtu, line(Mode::Rtu));
    let task = tokio::spawn(async move {
        let _ = sim.serve(wire).await;
    });
    let mut rtu = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line(Mode::Rtu)));
    // The write is answered in RTU; the drive listens for ASCII from then on.
    rtu.write(a(1), 395, DataSet::ALL, Width::Word, 3)
        .await
        .unwrap();
    match rtu.read(a(1), 372, ds(2), Width::Word).await {
        Err(DriverError::Link(LinkError::Timeout { .. })) => {}
        other => panic!("RTU after 395 = 3: {other:?}"),
    }
    let port = rtu.into_inner();
    let mut ascii = ModbusDriver::new(port, DriverConfig::new(Mode::Ascii, line(Mode::Ascii)));
    assert_eq!(
        ascii
            .read(a(1), 395, DataSet::ALL, Width::Word)
            .await
            .unwrap(),
        3
    );
    // VCB bus: no Modbus at all any more.
    ascii
        .write(a(1), 395, DataSet::ALL, Width::Word, 0)
        .await
        .unwrap();
    match ascii.read(a(1), 372, ds(2), Width::Word).await {
        Err(DriverError::Link(LinkError::Timeout { .. })) => {}
        other => panic!("ASCII after 395 = 0: {other:?}"),
    }
    drop(ascii);
    task.await.unwrap();
}
