//! A load run of the gateway's bus tasks: `buses` × `drives` on the caller's buses (a bus
//! factory: the fake bus in tests, each family's simulated bus on the wire model), on the
//! caller's clock (tokio's paused clock: virtual time), reporting per bus the transactions and
//! the utilisation against the wire bound, and the real CPU time per transaction and the memory
//! per bus.
//!
//! Call it inside a `LocalSet` on a current-thread runtime whose clock is paused: the buses
//! then run `dur` of virtual time as fast as the processor allows.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::mpsc;

use super::bus::{BusAccess, BusContext};
use super::config::{Bus, Plant};
use super::metrics::Metrics;
use super::model::{BusFigures, Update};

/// One bus's figures at the end of a load run.
#[derive(Debug, Clone, PartialEq)]
pub struct BusLoad {
    /// The bus's name.
    pub bus: String,
    /// Its figures (the last of the run).
    pub figures: BusFigures,
    /// What the wire allows the polls to take: the demand, at most 1.
    pub bound: f64,
}

/// What a load run measured.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadReport {
    /// Per bus.
    pub buses: Vec<BusLoad>,
    /// Transactions of all buses.
    pub transactions: u64,
    /// Real (processor) time per transaction: the run's real time over the transactions.
    pub cpu_per_transaction: Duration,
    /// Growth of the resident memory per bus while the buses ran (the gateway's side: the
    /// bus tasks, their schedulers, clients and metrics; from `/proc/self/status`; `None`
    /// where it cannot be read).
    pub rss_per_bus: Option<u64>,
    /// Growth per bus when the buses were made (the caller's: simulated drives and links).
    pub rss_per_bus_made: Option<u64>,
}

/// The config of the load plant: `buses` simulated MOVILINK buses of `drives` drives, each
/// drive with P130 polled every `period` (and its status read every 5 s).
pub fn plant(buses: usize, drives: usize, period: &str) -> crate::error::Result<Plant> {
    Plant::parse(&plant_text(buses, drives, period, ""), "load plant")
}

/// The load plant as a Sparkplug B edge node only (`[sparkplug]` with `json = false`), its
/// drives named `b<bus>d<drive>`: a drive's name is its device id, unique in the node.
pub fn sparkplug_plant(buses: usize, drives: usize, period: &str) -> crate::error::Result<Plant> {
    let sparkplug = "[sparkplug]\ngroup_id = \"load\"\nedge_node_id = \"gw\"\njson = false\n";
    Plant::parse(&plant_text(buses, drives, period, sparkplug), "load plant")
}

fn plant_text(buses: usize, drives: usize, period: &str, sparkplug: &str) -> String {
    let mut t = String::from(
        "[gateway]\nname = \"load\"\nbroker = \"mqtt://127.0.0.1:1883\"\nmetrics = \"off\"\n",
    );
    t.push_str(sparkplug);
    for b in 0..buses {
        t.push_str(&format!(
            "[[bus]]\nname = \"bus{b}\"\nprotocol = \"movilink\"\nsimulate = true\n"
        ));
        for d in 0..drives {
            // Unique across buses only where they are device ids.
            let name = if sparkplug.is_empty() {
                format!("d{d}")
            } else {
                format!("b{b}d{d}")
            };
            t.push_str(&format!(
                "[[bus.drive]]\nname = \"{name}\"\naddress = {}\n[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"{period}\"\n",
                d + 1
            ));
        }
    }
    t
}

/// Resident memory of this process in bytes (`VmRSS`).
fn rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Run every bus of `plant` for `dur` (on the runtime's clock), each on the bus `make_bus`
/// gives it.
pub async fn load<B, F>(plant: &Plant, dur: Duration, mut make_bus: F) -> LoadReport
where
    B: BusAccess + 'static,
    F: FnMut(&Bus) -> B,
{
    let made_before = rss();
    let buses: Vec<B> = plant.buses.iter().map(&mut make_bus).collect();
    let before = rss();
    let metrics = Arc::new(Metrics::new(plant));
    let real = std::time::Instant::now();
    let (tx, mut rx) = mpsc::channel(4096);
    // Never set: a load run ends by aborting its tasks.
    let (_stop_tx, stop_rx) = tokio::sync::watch::channel(crate::bus::Stop::Run);
    let mut tasks = Vec::new();
    let mut keep = Vec::new();
    for ((ix, bus), access) in plant.buses.iter().enumerate().zip(buses) {
        let (set_tx, set_rx) = mpsc::channel(1);
        keep.push(set_tx);
        let ctx = BusContext {
            ix: crate::model::BusSlot::new(ix),
            bus: bus.clone(),
            updates: tx.clone(),
            sets: set_rx,
            asks: crate::bus::BusContext::no_asks(),
            metrics: metrics.clone(),
            shutdown: stop_rx.clone(),
            announce: crate::bus::BusContext::no_announce(),
        };
        tasks.push(tokio::task::spawn_local(super::task::run_bus(ctx, access)));
    }
    drop(tx);
    let mut last: Vec<Option<BusFigures>> = vec![None; plant.buses.len()];
    let end = tokio::time::Instant::now() + dur;
    loop {
        tokio::select! {
            () = tokio::time::sleep_until(end) => break,
            u = rx.recv() => match u {
                Some(Update::Figures { bus, figures }) => {
                    if let Some(slot) = last.get_mut(bus) {
                        *slot = Some(figures);
                    }
                }
                Some(_) => {}
                None => break,
            },
        }
    }
    let after = rss();
    for t in &tasks {
        t.abort();
    }
    let elapsed = real.elapsed();
    let buses: Vec<BusLoad> = plant
        .buses
        .iter()
        .zip(last)
        .map(|(bus, f)| {
            let figures = f.unwrap_or_default();
            BusLoad {
                bus: bus.name.clone(),
                bound: figures.demand.min(1.0),
                figures,
            }
        })
        .collect();
    let transactions: u64 = buses.iter().map(|b| b.figures.transactions).sum();
    let n = u32::try_from(transactions.max(1)).unwrap_or(u32::MAX);
    LoadReport {
        cpu_per_transaction: elapsed / n,
        rss_per_bus_made: made_before.zip(before).map(|(b, a)| {
            a.saturating_sub(b) / u64::try_from(plant.buses.len().max(1)).unwrap_or(1)
        }),
        rss_per_bus: before
            .zip(after)
            .map(|(b, a)| a.saturating_sub(b) / u64::try_from(buses.len().max(1)).unwrap_or(1)),
        buses,
        transactions,
    }
}

#[cfg(test)]
mod tests {
    use super::super::task::fake::FakeBus;
    use super::*;

    /// The real simulated MOVILINK drives on the wire model: 4 buses of 31 drives asking
    /// 150 % of the wire; every bus keeps within 5 % of its wire bound, and the transactions
    /// counted agree with the wire time of a read.
    #[tokio::test(start_paused = true)]
    async fn simulated_movilink_buses_stay_within_five_percent_of_the_wire_bound() {
        tokio::task::LocalSet::new()
            .run_until(async {
                let plant = plant(4, 31, "1s").unwrap();
                let wire =
                    crate::families::WireDesc::of(&plant.buses[0]).time(crate::bus::Op::Read);
                let report = load(&plant, Duration::from_secs(16), |bus| {
                    crate::families::simulated_bus(bus).access
                })
                .await;
                for b in &report.buses {
                    assert!(b.figures.demand > 1.0, "saturated: {b:?}");
                    assert!(
                        (0.95..=1.0 + 1e-9).contains(&b.figures.utilisation),
                        "{b:?}"
                    );
                    assert_eq!(b.figures.timeouts, 0, "{b:?}");
                    // Figures at 15 s: transactions × the formula's wire time of a read is
                    // within 5 % below 15 s (the gateway loses no more), and at most 1 % above
                    // (the formula is that close to the wire model's real transaction time).
                    let busy = b.figures.transactions as f64 * wire.as_secs_f64();
                    assert!((14.25..=15.15).contains(&busy), "{busy} s of 15: {b:?}");
                }
            })
            .await;
    }

    #[test]
    fn the_sparkplug_load_plant_is_an_edge_node_only_with_a_device_id_per_drive() {
        let p = sparkplug_plant(3, 31, "1s").unwrap();
        let sp = p.sparkplug.as_ref().unwrap();
        assert_eq!(
            (sp.group_id.as_str(), sp.edge_node_id.as_str()),
            ("load", "gw")
        );
        assert!(!p.publishes_json());
        let mut ids: Vec<&str> = p
            .buses
            .iter()
            .flat_map(|b| b.drives.iter().map(|d| d.name.as_str()))
            .collect();
        assert_eq!(ids.len(), 93);
        assert_eq!((ids[0], ids[92]), ("b0d0", "b2d30"));
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), 93);
        // The JSON load plant is the one it always was.
        assert_eq!(plant(2, 1, "1s").unwrap().buses[1].drives[0].name, "d0");
    }

    // The figures are what this test is for: `cargo test … gateway::load -- --nocapture`.
    #[allow(clippy::print_stderr)]
    #[tokio::test(start_paused = true)]
    async fn every_bus_stays_within_five_percent_of_its_wire_bound_from_1_to_64_buses() {
        tokio::task::LocalSet::new()
            .run_until(async {
                for buses in [1, 8, 64] {
                    // 31 drives polled every 100 ms at 5 ms a read: 155 % of the wire.
                    let plant = plant(buses, 31, "100ms").unwrap();
                    let report = load(&plant, Duration::from_secs(20), |bus| {
                        FakeBus::new(bus, Duration::from_millis(5)).0
                    })
                    .await;
                    for b in &report.buses {
                        assert!(b.bound > 0.99, "{b:?}");
                        assert!(
                            b.figures.utilisation >= 0.95 * b.bound
                                && b.figures.utilisation <= b.bound + 1e-6,
                            "{b:?}"
                        );
                    }
                    eprintln!(
                        "load: {buses} buses x 31 drives, 20 s virtual: {} transactions, utilisation {:.3}-{:.3}, {:?} per transaction, {} bytes per bus",
                        report.transactions,
                        report
                            .buses
                            .iter()
                            .map(|b| b.figures.utilisation)
                            .fold(f64::MAX, f64::min),
                        report
                            .buses
                            .iter()
                            .map(|b| b.figures.utilisation)
                            .fold(0.0, f64::max),
                        report.cpu_per_transaction,
                        report.rss_per_bus.unwrap_or(0)
                    );
                }
            })
            .await;
    }
}
