//! Cyclic mode: a session keeps the drive's RS-485 timeout fed and runs parameter services
//! inside the cyclic stream; when the session stops, the drive's P812 timeout fires.

use std::time::Duration;

use drive_transport::link::{self, LinkConfig};
use movilink::driver::{DriverConfig, DriverError, MovilinkDriver, ParamServices};
use movilink::sim::SimulatedMovidrive;
use movilink::{ParamChannel, PduType};
use tokio::time::Instant;

use crate::common::addr;

#[tokio::test(start_paused = true)]
async fn a_cyclic_session_keeps_the_drive_fed_and_runs_parameter_services() {
    let mut sim = SimulatedMovidrive::new(1);
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        // P812 RS-485 timeout = 200 ms (raw ms, volatile).
        m.write_volatile(addr(1), 8599, 200).await.unwrap();
        let mut s = m
            .cyclic(addr(1), PduType::PARAM_3PD, Duration::from_millis(50))
            .unwrap();
        s.set_output(&[0x0006, 5000, 0]);
        let start = Instant::now();
        let mut cycles = 0u32;
        let mut last_speed_word = 0u16;
        while start.elapsed() < Duration::from_secs(1) {
            let response = s.cycle().await.unwrap();
            last_speed_word = response.process_data()[1];
            cycles += 1;
        }
        // 1 s at 50 ms: 20 cycles (the first one starts at once).
        assert!((20..=21).contains(&cycles), "{cycles} cycles");
        // A parameter service inside the stream: P000 actual speed, raw in 0.001 1/min.
        let answer = s.param(ParamChannel::read(8318)).await.unwrap();
        let speed = answer.result().unwrap() as i32;
        assert!(speed > 900_000, "speed {speed}");
        assert_eq!(last_speed_word, 5000, "PI2 reports 1000 1/min as 5000");
        // A volatile write in the cyclic stream, read back acyclically.
        s.param(ParamChannel::write_volatile(8470, 700))
            .await
            .unwrap();
        assert_eq!(m.read(addr(1), 8470).await.unwrap(), 700);
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(
        sim.movidrive().timeout_warning(),
        None,
        "the session kept the drive fed"
    );

    // Nothing cyclic any more: after P812 the drive reacts (P833 default: rapid stop, warning).
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let client = async move {
        let m = MovilinkDriver::new(port, DriverConfig::default());
        tokio::time::sleep(Duration::from_millis(300)).await;
        drop(m);
    };
    let (served, ()) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert!(
        sim.movidrive().timeout_warning().is_some(),
        "P812 fired without cyclic telegrams"
    );
}

#[tokio::test(start_paused = true)]
async fn cyclic_sessions_refuse_what_cannot_work() {
    let (port, _wire) = link::pair(LinkConfig::new(9600));
    let mut m = MovilinkDriver::new(port, DriverConfig::default());
    let acyclic = m.cyclic(addr(1), PduType::PD3_ACYCLIC, Duration::from_millis(50));
    assert!(matches!(acyclic, Err(DriverError::Request(_))));
    let zero = m.cyclic(addr(1), PduType::PD3, Duration::ZERO);
    assert!(matches!(zero, Err(DriverError::Request(_))));
    let broadcast = m.cyclic(
        movilink::Address::BROADCAST,
        PduType::PD3,
        Duration::from_millis(50),
    );
    assert!(matches!(broadcast, Err(DriverError::Request(_))));
    let mut s = m
        .cyclic(addr(1), PduType::PD3, Duration::from_millis(50))
        .unwrap();
    let no_param = s.param(ParamChannel::read(8318)).await;
    assert!(matches!(no_param, Err(DriverError::Request(_))));
}
