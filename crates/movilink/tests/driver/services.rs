//! Every parameter service and the device errors, master ↔ simulated drive over the wire model.

use std::time::Duration;

use drive_sim::movidrive::UNIT_TYPE;
use drive_transport::link::{self, LinkConfig};
use movilink::driver::{DriverConfig, DriverError, MovilinkDriver, ParamServices};
use movilink::sim::SimulatedMovidrive;
use movilink::{Address, ParamChannel, PduType, ReturnCode, ScaleInfo, Telegram};

use crate::common::addr;

const SPEED: u16 = 8318;
const RAMP_UP: u16 = 8470;
const RAMP_DOWN: u16 = 8471;
const GROUP: u16 = 8598;

#[tokio::test(start_paused = true)]
async fn speed_follows_the_ramp_after_a_process_data_exchange() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let a = addr(1);
        assert_eq!(m.read(a, SPEED).await.unwrap(), 0);
        // PO1 control word "enable", PO2 speed 5000 × 0.2 = 1000 1/min.
        let req = Telegram::request(a, PduType::PD2_ACYCLIC).with_process_data(&[0x0006, 5000]);
        let resp = m.exchange(req).await.unwrap();
        assert_eq!(resp.pdu_type(), PduType::PD2_ACYCLIC);
        assert_eq!(resp.address(), a);
        let mut last = 0;
        let mut samples = Vec::new();
        for _ in 0..4 {
            tokio::time::sleep(Duration::from_millis(100)).await;
            let v = m.read(a, SPEED).await.unwrap() as i32;
            assert!(v > last, "speed must rise while ramping: {v} after {last}");
            samples.push(v);
            last = v;
        }
        // P130 = 2 s per 3000 1/min: 1500 1/min per second, 1000 1/min after 0.67 s.
        assert!(
            samples[0] < 250_000 && samples[3] < 1_000_000,
            "{samples:?}"
        );
        tokio::time::sleep(Duration::from_millis(1000)).await;
        assert_eq!(m.read(a, SPEED).await.unwrap(), 1_000_000); // 0.001 1/min
        m.stats()
    };
    let (served, stats) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(stats.transactions, 7);
    assert_eq!((stats.retries, stats.timeouts, stats.rejected), (0, 0, 0));
    assert!((sim.movidrive().actual_speed_rpm() - 1000.0).abs() < 1e-9);
}

#[tokio::test(start_paused = true)]
async fn every_service() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(3);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let a = addr(3);
        assert_eq!(m.read(a, 8301).await.unwrap(), UNIT_TYPE);
        assert_eq!(m.read(a, RAMP_UP).await.unwrap(), 2000);
        m.write_volatile(a, RAMP_UP, 1500).await.unwrap();
        assert_eq!(m.read(a, RAMP_UP).await.unwrap(), 1500);
        m.write(a, RAMP_UP, 3000).await.unwrap();
        assert_eq!(m.read(a, RAMP_UP).await.unwrap(), 3000);
        assert_eq!(m.read_minimum(a, RAMP_UP).await.unwrap(), 0);
        assert_eq!(m.read_maximum(a, RAMP_UP).await.unwrap(), 2_000_000);
        assert_eq!(m.read_default(a, RAMP_UP).await.unwrap(), 2000);
        assert_eq!(
            m.read_scale(a, RAMP_UP).await.unwrap(),
            ScaleInfo {
                size_index: 4,
                conversion_index: -3
            }
        );
        let attr = m.read_attribute(a, RAMP_UP).await.unwrap();
        assert_eq!(attr.next_index, RAMP_DOWN);
        // drive-sim's attribute byte: bit 3 RW, bit 4 N.
        assert_eq!(attr.attributes, 0x18);
        // The generic service call, acyclic and cyclic (the handshake is learned first).
        let p = m
            .param(a, PduType::PARAM_0PD_ACYCLIC, ParamChannel::read(RAMP_UP))
            .await
            .unwrap();
        assert_eq!(p.result(), Ok(3000));
        let p = m
            .param(
                a,
                PduType::PARAM_0PD,
                ParamChannel::write_volatile(RAMP_DOWN, 900),
            )
            .await
            .unwrap();
        assert!(p.result().is_ok());
        assert!(p.management.handshake()); // toggled from the drive's initial 0
        let p = m
            .param(a, PduType::PARAM_1PD, ParamChannel::read(RAMP_DOWN))
            .await
            .unwrap();
        assert_eq!(p.result(), Ok(900));
        // Requests that cannot work are refused before they reach the bus.
        assert!(matches!(
            m.param(a, PduType::PD3, ParamChannel::read(1)).await,
            Err(DriverError::Request(_))
        ));
        assert!(matches!(
            m.read(Address::BROADCAST, 1).await,
            Err(DriverError::Request(_))
        ));
        m.stats()
    };
    let (served, stats) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(
        stats.retries + stats.rejected + stats.timeouts,
        0,
        "{stats:?}"
    );
    assert_eq!(sim.movidrive().nv_writes(RAMP_UP), Some(1));
}

#[tokio::test(start_paused = true)]
async fn device_errors_are_typed() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let a = addr(1);
        let cases: [(Result<u32, DriverError>, ReturnCode); 5] = [
            (m.read(a, 9999).await, ReturnCode::ILLEGAL_INDEX),
            (
                m.write_volatile(a, SPEED, 5).await.map(|()| 0),
                ReturnCode::READ_ONLY,
            ),
            (
                m.write_volatile(a, RAMP_UP, 3_000_000).await.map(|()| 0),
                ReturnCode::VALUE_TOO_LARGE,
            ),
            (
                m.write_volatile(a, GROUP, 50).await.map(|()| 0),
                ReturnCode::VALUE_TOO_SMALL,
            ),
            (
                m.read_scale(a, 9999).await.map(|_| 0),
                ReturnCode::ILLEGAL_INDEX,
            ),
        ];
        for (got, want) in cases {
            match got {
                Err(DriverError::Device(rc)) => assert_eq!(rc, want),
                other => panic!("expected {want:?}, got {other:?}"),
            }
        }
        let msg = m.read(a, 9999).await.unwrap_err().to_string();
        assert!(msg.contains("illegal parameter index"), "{msg}");
        assert!(
            msg.contains("(error class 8, error code 0, additional code 0x0010)"),
            "{msg}"
        );
        // A negative answer in an exchange is data, not an error.
        let t = Telegram::request(a, PduType::PARAM_1PD_ACYCLIC)
            .with_param(ParamChannel::read(9999))
            .with_process_data(&[0]);
        let resp = m.exchange(t).await.unwrap();
        assert_eq!(
            resp.param().map(|p| p.result()),
            Some(Err(ReturnCode::ILLEGAL_INDEX))
        );
        m.stats()
    };
    let (served, stats) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(stats.device_errors, 7);
    assert_eq!(stats.timeouts + stats.retries, 0);
}

#[tokio::test(start_paused = true)]
async fn group_and_broadcast_writes_change_the_drive_without_an_answer() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(7);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let a = addr(7);
        // P811 group address 150.
        m.write_volatile(a, GROUP, 150).await.unwrap();
        let group = Telegram::request(addr(150), PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::write_volatile(RAMP_UP, 1200));
        m.send_unanswered(group).await.unwrap();
        assert_eq!(m.read(a, RAMP_UP).await.unwrap(), 1200);
        // Another group does not reach it.
        let other = Telegram::request(addr(151), PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::write_volatile(RAMP_UP, 1700));
        m.send_unanswered(other).await.unwrap();
        assert_eq!(m.read(a, RAMP_UP).await.unwrap(), 1200);
        let broadcast = Telegram::request(Address::BROADCAST, PduType::PARAM_0PD_ACYCLIC)
            .with_param(ParamChannel::write_volatile(RAMP_DOWN, 1300));
        m.send_unanswered(broadcast).await.unwrap();
        assert_eq!(m.read(a, RAMP_DOWN).await.unwrap(), 1300);
        // Unicast telegrams are refused by send_unanswered, and groups by exchange.
        assert!(matches!(
            m.send_unanswered(Telegram::request(a, PduType::PD1)).await,
            Err(DriverError::Request(_))
        ));
        assert!(matches!(
            m.exchange(Telegram::request(addr(150), PduType::PD1)).await,
            Err(DriverError::Request(_))
        ));
        // Characters the drive sent: nothing but the answers to the unicast requests.
        m.get_ref().rx_fault_stats().written
    };
    let (served, answered) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(answered, 4 * 12);
    assert_eq!(sim.movidrive().group_address(), 150);
}

#[tokio::test(start_paused = true)]
async fn point_to_point_address_254() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(42);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        assert_eq!(
            m.read(Address::POINT_TO_POINT, 8301).await.unwrap(),
            UNIT_TYPE
        );
        // The drive's own address, read through 254 (P810).
        assert_eq!(m.read(Address::POINT_TO_POINT, 8597).await.unwrap(), 42);
        assert_eq!(
            m.probe(Address::POINT_TO_POINT, Duration::from_millis(20))
                .await
                .unwrap(),
            Some(UNIT_TYPE)
        );
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
}

#[tokio::test(start_paused = true)]
async fn changed_address_is_followed() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        m.write_volatile(addr(1), 8597, 9).await.unwrap(); // P810 = 9
        assert_eq!(m.read(addr(9), 8597).await.unwrap(), 9);
        assert_eq!(
            m.probe(addr(1), Duration::from_millis(20)).await.unwrap(),
            None
        );
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(sim.slave_config().address, addr(9));
}
