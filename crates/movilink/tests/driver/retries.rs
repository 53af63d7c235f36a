//! Retries after lost or corrupt answers, and the final errors.

use drive_sim::movidrive::UNIT_TYPE;
use drive_transport::link::{self, Fault, LinkConfig};
use movilink::RejectReason;
use movilink::driver::{DriverConfig, DriverError, LinkError, MovilinkDriver, ParamServices};
use movilink::sim::SimulatedMovidrive;

use crate::common::addr;

#[tokio::test(start_paused = true)]
async fn a_lost_response_is_retried() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    // The drive's whole first answer (12 characters) is lost on the line.
    for _ in 0..12 {
        wire.inject(Fault::Drop);
    }
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let v = m.read(addr(1), 8301).await;
        (v.unwrap(), m.stats())
    };
    let (served, (v, stats)) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(v, UNIT_TYPE);
    assert_eq!(
        (stats.transactions, stats.retries, stats.timeouts),
        (1, 1, 0)
    );
}

#[tokio::test(start_paused = true)]
async fn a_corrupt_response_is_retried() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    // The SD2 of the first answer is lost: the rest starts with a bad start character.
    wire.inject(Fault::Drop);
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let v = m.read(addr(1), 8301).await;
        (v.unwrap(), m.stats())
    };
    let (served, (v, stats)) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    assert_eq!(v, UNIT_TYPE);
    assert_eq!((stats.retries, stats.rejected), (1, 1));
}

#[tokio::test(start_paused = true)]
async fn answers_that_keep_failing_parity_are_corrupt() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    for _ in 0..3 * 12 {
        wire.inject(Fault::Flip(1 << 9)); // parity bit
    }
    let mut sim = SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        m.read(addr(1), 8301).await
    };
    let (served, r) = tokio::join!(sim.serve(wire), client);
    served.unwrap();
    match r {
        Err(DriverError::Link(LinkError::Corrupt {
            address: 1,
            reason: RejectReason::Char(movilink::CharError::Parity),
            attempts: 3,
        })) => {}
        other => panic!("{other:?}"),
    }
}

#[tokio::test(start_paused = true)]
async fn permanent_silence_is_a_timeout_after_every_attempt() {
    let (port, _silent) = link::pair(LinkConfig::new(9600));
    let config = DriverConfig {
        retries: 4,
        ..DriverConfig::default()
    };
    let mut m = MovilinkDriver::new(port, config);
    let err = m.read(addr(12), 8301).await.unwrap_err();
    assert!(
        matches!(
            err,
            DriverError::Link(LinkError::Timeout {
                address: 12,
                attempts: 5
            })
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        "no answer from address 12 after 5 attempts; check address, baud rate, wiring, termination and P810"
    );
    let s = m.stats();
    assert_eq!((s.transactions, s.retries, s.timeouts), (1, 4, 1));
    let mut m = MovilinkDriver::new(m.into_inner(), DriverConfig::default());
    assert!(matches!(
        m.read(addr(12), 8301).await,
        Err(DriverError::Link(LinkError::Timeout { attempts: 3, .. }))
    ));
}

#[tokio::test(start_paused = true)]
async fn a_closed_port_is_an_io_error() {
    let (port, peer) = link::pair(LinkConfig::new(9600));
    drop(peer);
    let mut m = MovilinkDriver::new(port, DriverConfig::default());
    let err = m.read(addr(1), 8301).await.unwrap_err();
    assert!(
        matches!(err, DriverError::Link(LinkError::Io(_))),
        "{err:?}"
    );
}
