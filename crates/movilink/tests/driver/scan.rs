//! Address scan over several simulated drives on one line.

use std::time::Duration;

use drive_sim::movidrive::UNIT_TYPE;
use drive_transport::link::{self, LinkConfig};
use movilink::driver::{DriverConfig, MovilinkDriver, ParamServices};
use movilink::sim;

use crate::common::addr;

#[tokio::test(start_paused = true)]
async fn probe_finds_exactly_the_drives_on_the_bus() {
    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut bus = sim::bus(&[1, 5, 17], movilink::timing::LINE);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let start = tokio::time::Instant::now();
        let mut found = Vec::new();
        for a in 0..=31u8 {
            if let Some(unit) = m.probe(addr(a), Duration::from_millis(20)).await.unwrap() {
                found.push((a, unit));
            }
        }
        // 29 silent addresses cost one short timeout each, not the 50 ms default (or retries).
        let took = start.elapsed();
        assert!(took < Duration::from_millis(32 * 40), "{took:?}");
        // Each drive answers its own address only.
        assert_eq!(m.read(addr(5), 8597).await.unwrap(), 5);
        assert_eq!(m.read(addr(17), 8597).await.unwrap(), 17);
        (found, m.stats())
    };
    let (served, (found, stats)) = tokio::join!(bus.serve(wire), client);
    served.unwrap();
    assert_eq!(found, vec![(1, UNIT_TYPE), (5, UNIT_TYPE), (17, UNIT_TYPE)]);
    assert_eq!(stats.timeouts, 29);
    assert_eq!(stats.retries, 0);
    assert_eq!(stats.rejected, 0);
    assert!(bus.station(5).is_some() && bus.station(6).is_none());
}
