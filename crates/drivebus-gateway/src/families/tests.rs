//! Tests of the gateway's buses: the example config, every protocol's access against its
//! simulator, wire times, and reads under injected faults.

use std::time::Duration;

use drive_profile::Persistence;
use drive_transport::can::virtual_bus::BusFaults;
use drive_transport::link::FaultConfig;

use super::*;
use crate::bus::BusAccess;
use crate::config::{Point, Protocol};
use drive_client::MemoryWearLog;
use drive_client::write::{WriteRequest, check, write_checked};
use drive_client::{ClientError, ParamClient};

fn example() -> Plant {
    let mut plant = Plant::parse(EXAMPLE_CONFIG, "example").unwrap();
    for bus in &mut plant.buses {
        bus.endpoint = simulated_endpoint(bus);
    }
    plant
}

fn bus_of(plant: &Plant, p: Protocol) -> Bus {
    plant
        .buses
        .iter()
        .find(|b| b.protocol == p)
        .unwrap()
        .clone()
}

/// A raw value the write guard takes for `point`, other than `now` and `avoid`.
fn other_value(point: &Point, now: i64, avoid: &[i64]) -> i64 {
    let p = point.target.param.unwrap();
    let (lo, hi) = p.wire_range();
    let mut candidates = vec![p.default_raw().unwrap_or(now)];
    for k in [1000i64, 2000, 500, 400, 200, 100, 50, 10, 5, 2, 1] {
        candidates.push(now + k);
        candidates.push(now - k);
        candidates.push(lo.max(0) + k);
        candidates.push(hi.min(1_000_000) - k);
    }
    candidates
        .into_iter()
        .filter(|v| *v != now && !avoid.contains(v))
        .find(|&raw| {
            let req = WriteRequest {
                target: point.target,
                raw,
                persistence: Persistence::Volatile,
                force: false,
            };
            check("test", &req, &MemoryWearLog::default()).is_ok()
        })
        .unwrap_or_else(|| panic!("no writable value for {}", point.name))
}

/// Write a value other than the present one to every writable point of `bus` (through the
/// write guard, RAM) and read it back: the values, per drive address and point name.
async fn write_distinct(access: &mut Access, bus: &Bus) -> Vec<(u8, Point, i64)> {
    let mut written: Vec<(u8, Point, i64)> = Vec::new();
    for d in &bus.drives {
        for p in d.points.iter().filter(|p| p.writable) {
            let mut c = access.client(d.address);
            let now = c.read(&p.target).await.unwrap();
            let avoid: Vec<i64> = written.iter().map(|w| w.2).collect();
            let raw = other_value(p, now, &avoid);
            let req = WriteRequest {
                target: p.target,
                raw,
                persistence: Persistence::Volatile,
                force: false,
            };
            let done = write_checked(&mut c, &req, false, &MemoryWearLog::default(), &mut |_| {})
                .await
                .unwrap_or_else(|e| panic!("{}/{}/{}: {e}", bus.name, d.name, p.name));
            assert_eq!(done.back, raw, "{}/{}/{}", bus.name, d.name, p.name);
            written.push((d.address, p.clone(), raw));
        }
    }
    written
}

#[test]
fn the_example_config_parses_and_every_bus_fits_the_wire() {
    let plant = Plant::parse(EXAMPLE_CONFIG, "example").unwrap();
    let protocols: Vec<Protocol> = plant.buses.iter().map(|b| b.protocol).collect();
    // CTT2 runs only on the simulated AS-i link: it has its own config (CTT2_CONFIG).
    for p in Protocol::ALL.into_iter().filter(|p| *p != Protocol::Ctt2) {
        assert!(protocols.contains(&p), "no {} bus", p.name());
    }
    for bus in &plant.buses {
        let d = demand(bus);
        assert!(d > 0.0 && d < 0.6, "bus {}: demand {d}", bus.name);
        assert!(bus.drives.len() >= 2, "bus {}", bus.name);
        assert!(
            bus.drives
                .iter()
                .flat_map(|d| &d.points)
                .any(|p| p.writable),
            "bus {} has no writable point",
            bus.name
        );
    }
    assert!(
        plant
            .buses
            .iter()
            .flat_map(|b| &b.drives)
            .any(|d| d.process_data.is_some())
    );
    // Every [gateway] key is shown.
    for key in [
        "name",
        "broker",
        "client_id",
        "username",
        "password_file",
        "ca_file",
        "client_cert",
        "client_key",
        "prefix",
        "heartbeat",
        "max_set_age",
        "metrics",
        "keep_alive",
    ] {
        assert!(
            EXAMPLE_CONFIG.contains(&format!("\n{key} = "))
                || EXAMPLE_CONFIG.contains(&format!("\n# {key} = ")),
            "{key}"
        );
    }
    // Issue 18: it serves /metrics where the docs' `curl -s 127.0.0.1:9464/metrics` asks (it
    // said "off", and the documented sequence failed).
    assert_eq!(
        plant.gateway.metrics,
        Some(std::net::SocketAddr::from(([127, 0, 0, 1], 9464)))
    );
    // --check passes on it, and --simulate keeps it fitting.
    for p in [&plant, &example()] {
        let (text, verdict) = check_report(p);
        verdict.unwrap();
        assert_eq!(text.lines().count(), p.buses.len(), "{text}");
        assert!(text.lines().all(|l| l.ends_with(": fits")), "{text}");
    }
}

#[tokio::test(start_paused = true)]
async fn every_writable_point_of_the_example_is_written_on_its_simulated_drive() {
    let plant = example();
    for bus in &plant.buses {
        let mut sim = simulated_bus(bus);
        let written = write_distinct(&mut sim.access, bus).await;
        assert!(!written.is_empty(), "bus {}", bus.name);
        // Every polled point reads on its simulated drive.
        for d in &bus.drives {
            for p in &d.points {
                let r = sim.access.client(d.address).read(&p.target).await;
                assert!(
                    r.is_ok(),
                    "{}/{}/{}: {:?}",
                    bus.name,
                    d.name,
                    p.name,
                    r.err()
                );
            }
            assert_eq!(sim.access.fault(d.address).await.unwrap(), None);
        }
        let tally = sim.access.take_tally();
        assert_eq!(tally.retries, 0, "bus {}: {tally:?}", bus.name);
    }
}

#[tokio::test(start_paused = true)]
async fn process_data_are_exchanged_on_movilink_sbus_and_uss() {
    let plant = example();
    for p in [Protocol::Movilink, Protocol::Sbus, Protocol::Uss] {
        let bus = bus_of(&plant, p);
        let mut sim = simulated_bus(&bus);
        let a = bus.drives[0].address;
        // Stop (SEW 0x0002; NORD: bit 10 clear, the drive only answers).
        let out: &[u16] = if p == Protocol::Uss {
            &[0, 0]
        } else {
            &[0x0002, 0, 0]
        };
        let words = sim.access.process_data(a, out).await.unwrap();
        assert_eq!(words.len(), out.len(), "{}", p.name());
        assert_ne!(words[0], 0, "{}: a status word", p.name());
    }
    let bus = bus_of(&plant, Protocol::ModbusRtu);
    let mut sim = simulated_bus(&bus);
    // Modbus has no process data: a request not made, not a failed link.
    assert!(matches!(
        sim.access.process_data(1, &[0]).await,
        Err(ClientError::Request(_))
    ));
}

#[tokio::test(start_paused = true)]
async fn an_address_the_protocol_cannot_reach_fails_without_a_transaction() {
    let plant = example();
    for (p, bad) in [
        (Protocol::Movilink, 150),
        (Protocol::Sbus, 64),
        (Protocol::Uss, 32),
        (Protocol::ModbusRtu, 0),
        (Protocol::ModbusAscii, 250),
    ] {
        let bus = bus_of(&plant, p);
        let mut sim = simulated_bus(&bus);
        let t = bus.drives[0].points[0].target;
        let r = sim.access.client(bad).read(&t).await;
        // Nothing sent: a request the client cannot make, not a failed link.
        assert!(
            matches!(r, Err(ClientError::Request(_))),
            "{}: {r:?}",
            p.name()
        );
        assert_eq!(sim.access.take_tally(), crate::bus::LinkTally::default());
    }
}

#[tokio::test(start_paused = true)]
async fn the_wire_time_of_a_read_is_what_the_wire_model_takes() {
    // One read of a simulated drive, measured on the paused clock, against the formula: the
    // wire model adds only tokio's timer resolution (1 ms) to the pauses.
    let plant = example();
    for bus in &plant.buses {
        let mut sim = simulated_bus(bus);
        let d = &bus.drives[0];
        let t = d.points[0].target;
        // A first read opens the drive's client state (USS: the "no order" telegram).
        sim.access.client(d.address).read(&t).await.unwrap();
        let n = 20u32;
        let start = tokio::time::Instant::now();
        for _ in 0..n {
            sim.access.client(d.address).read(&t).await.unwrap();
        }
        let measured = start.elapsed() / n;
        let formula = sim.access.wire_time(Op::Read);
        let slack = Duration::from_millis(2);
        assert!(
            measured <= formula + slack,
            "bus {}: measured {measured:?}, formula {formula:?}",
            bus.name
        );
        assert!(
            measured * 10 >= formula * 4,
            "bus {}: measured {measured:?}, formula {formula:?}",
            bus.name
        );
    }
}

/// What a fault campaign counted.
#[derive(Debug, Default)]
struct Campaign {
    reads: u32,
    right: u32,
    link_errors: u32,
    device_errors: u32,
    retries: u64,
    rejected: u64,
    /// Faults the serial line injected (both directions).
    injected: u64,
}

/// `n` reads of the distinctive values of `bus`'s writable points while faults are injected;
/// every value returned must be the one written.
async fn campaign(bus: &Bus, n: u32, faults: impl FnOnce(&SimulatedBus)) -> Campaign {
    let mut sim = simulated_bus(bus);
    let truth = write_distinct(&mut sim.access, bus).await;
    assert!(truth.len() >= 2, "bus {}", bus.name);
    sim.access.take_tally();
    faults(&sim);
    let mut c = Campaign::default();
    let before = sim.faults.stats();
    for i in 0..n {
        let Some((addr, point, want)) = truth.get(i as usize % truth.len()) else {
            continue;
        };
        c.reads += 1;
        match sim.access.client(*addr).read(&point.target).await {
            Ok(v) => {
                assert_eq!(
                    v, *want,
                    "bus {}: read {i} of {} at {addr} returned a wrong value",
                    bus.name, point.name
                );
                c.right += 1;
            }
            Err(ClientError::Device(_)) => c.device_errors += 1,
            Err(_) => c.link_errors += 1,
        }
        let t = sim.access.take_tally();
        // Every reason is one /metrics knows (not counted as "other").
        for (reason, _) in &t.rejected {
            assert!(
                crate::metrics::REJECT_REASONS[..crate::metrics::REJECT_REASONS.len() - 1]
                    .contains(reason),
                "{reason} is not in metrics::REJECT_REASONS"
            );
        }
        c.retries += t.retries;
        c.rejected += t.rejected.iter().map(|r| r.1).sum::<u64>();
    }
    let after = sim.faults.stats();
    c.injected = after
        .iter()
        .zip(before)
        .map(|(a, b)| {
            (a.dropped + a.inserted + a.flipped + a.delayed)
                - (b.dropped + b.inserted + b.flipped + b.delayed)
        })
        .sum();
    c
}

fn serial_faults(seed: u64, p: f64, flip_bits: u32) -> FaultConfig {
    FaultConfig {
        seed,
        drop: p,
        insert: p,
        flip: p,
        flip_bits,
        delay: p,
        delay_by: Duration::from_millis(5),
    }
}

// The campaign's figures are printed for docs/gateway.md (`--nocapture`).
#[allow(clippy::print_stderr)]
async fn serial_campaign(p: Protocol, seed: u64) -> Campaign {
    let plant = example();
    let bus = bus_of(&plant, p);
    let mut total = Campaign::default();
    // Single-bit flips (parity catches them), then double-bit flips (parity passes when both
    // are data bits: the block check must catch them).
    for flip_bits in [1, 2] {
        let c = campaign(&bus, 300, |s| {
            s.faults
                .set(serial_faults(seed + u64::from(flip_bits), 0.003, flip_bits));
        })
        .await;
        eprintln!("{} flip_bits {flip_bits}: {c:?}", p.name());
        total.reads += c.reads;
        total.right += c.right;
        total.link_errors += c.link_errors;
        total.device_errors += c.device_errors;
        total.retries += c.retries;
        total.rejected += c.rejected;
        total.injected += c.injected;
    }
    assert!(total.injected > 50, "{}: {total:?}", p.name());
    assert!(
        total.rejected > 0 && total.retries > 0,
        "{}: {total:?}",
        p.name()
    );
    assert!(total.right * 2 >= total.reads, "{}: {total:?}", p.name());
    total
}

#[tokio::test(start_paused = true)]
async fn movilink_publishes_no_wrong_value_under_line_faults() {
    serial_campaign(Protocol::Movilink, 11).await;
}

#[tokio::test(start_paused = true)]
async fn uss_publishes_no_wrong_value_under_line_faults() {
    serial_campaign(Protocol::Uss, 12).await;
}

#[tokio::test(start_paused = true)]
async fn modbus_rtu_publishes_no_wrong_value_under_line_faults() {
    serial_campaign(Protocol::ModbusRtu, 13).await;
}

#[tokio::test(start_paused = true)]
async fn modbus_ascii_publishes_no_wrong_value_under_line_faults() {
    serial_campaign(Protocol::ModbusAscii, 14).await;
}

#[tokio::test(start_paused = true)]
#[allow(clippy::print_stderr)]
async fn sbus_publishes_no_wrong_value_under_bus_faults() {
    let plant = example();
    let bus = bus_of(&plant, Protocol::Sbus);
    let c = campaign(&bus, 300, |s| {
        if let Some(v) = &s.can {
            v.set_faults(BusFaults {
                seed: 15,
                drop: 0.05,
                corrupt: 0.05,
                ..BusFaults::none()
            });
        }
    })
    .await;
    eprintln!("sbus: {c:?}");
    assert!(c.retries > 0, "{c:?}");
    assert!(c.right * 10 >= c.reads * 7, "{c:?}");
}

#[tokio::test(start_paused = true)]
async fn a_port_that_cannot_be_opened_fails_every_call_and_is_tried_again_with_a_back_off() {
    let mut plant = Plant::parse(EXAMPLE_CONFIG, "example").unwrap();
    let bus = plant
        .buses
        .iter_mut()
        .find(|b| b.protocol == Protocol::Movilink)
        .unwrap();
    bus.endpoint = Endpoint::Serial {
        path: "/nonexistent/ttyUSB9".into(),
        line: drive_core::LineSettings::new(9600),
        adapter: crate::config::Adapter::default(),
    };
    let mut access = open_bus(bus);
    let t = bus.drives[0].points[0].target;
    let start = tokio::time::Instant::now();
    for _ in 0..3 {
        let r = access.client(1).read(&t).await;
        let Err(ClientError::Link(m)) = r else {
            panic!("{r:?}")
        };
        assert!(m.message.contains("/nonexistent/ttyUSB9"), "{m}");
        assert_eq!(m.fault, drive_client::LinkFault::Port, "{m}");
    }
    // Failing calls take no time: a missing port does not stall the bus.
    assert!(start.elapsed() < Duration::from_millis(10));
    assert_eq!(
        io::Reopen::<io::LineIo>::backoff_after(1),
        Duration::from_secs(1)
    );
    assert_eq!(
        io::Reopen::<io::LineIo>::backoff_after(2),
        Duration::from_secs(2)
    );
    assert_eq!(
        io::Reopen::<io::LineIo>::backoff_after(6),
        Duration::from_secs(30)
    );
    assert_eq!(
        io::Reopen::<io::LineIo>::backoff_after(60),
        Duration::from_secs(30)
    );
}

#[test]
fn check_refuses_a_plant_whose_polls_ask_more_than_the_wire_and_names_the_bus() {
    let text = EXAMPLE_CONFIG.replace("period = \"1s\"", "period = \"10ms\"");
    let plant = Plant::parse(&text, "example").unwrap();
    let over: Vec<&str> = plant
        .buses
        .iter()
        .filter(|b| demand(b) > 1.0)
        .map(|b| b.name.as_str())
        .collect();
    assert!(!over.is_empty());
    let (text, verdict) = check_report(&plant);
    let e = verdict.unwrap_err();
    assert!(matches!(e, crate::Error::Failed(_)), "{e}");
    assert!(text.contains("does not fit"), "{text}");
    for name in over {
        assert!(e.to_string().contains(name), "{e}");
    }
}

/// What the bus task publishes while the link injects faults: every `Update::Value` of a
/// point is compared with the value the simulated drive holds (written distinctively first).
/// Returns (values published, drive status changes to `timeout`).
async fn published_under_faults(p: Protocol, faults: impl FnOnce(&SimulatedBus)) -> (u64, u64) {
    use crate::bus::BusContext;
    use crate::model::{DriveStatus, Update};
    let plant = example();
    let mut bus = bus_of(&plant, p);
    for d in &mut bus.drives {
        d.points.retain(|p| p.writable);
        for pt in &mut d.points {
            pt.period = Some(Duration::from_millis(100));
        }
        d.process_data = None;
    }
    let mut sim = simulated_bus(&bus);
    let truth = write_distinct(&mut sim.access, &bus).await;
    faults(&sim);
    let (utx, mut urx) = tokio::sync::mpsc::channel(4096);
    let (_stx, srx) = tokio::sync::mpsc::channel(1);
    let (_stop, shutdown) = tokio::sync::watch::channel(crate::bus::Stop::Run);
    let ctx = BusContext {
        shutdown,
        announce: crate::bus::BusContext::no_announce(),
        ix: crate::model::BusSlot::new(0),
        bus: bus.clone(),
        updates: utx,
        sets: srx,
        asks: crate::bus::BusContext::no_asks(),
        metrics: std::sync::Arc::new(crate::metrics::Metrics::new(&plant)),
    };
    let task = tokio::task::spawn_local(crate::task::run_bus(ctx, sim.access));
    let end = tokio::time::Instant::now() + Duration::from_secs(60);
    let (mut values, mut timeouts) = (0, 0);
    loop {
        tokio::select! {
            () = tokio::time::sleep_until(end) => break,
            u = urx.recv() => match u {
                Some(Update::Value { drive, point, raw, .. }) => {
                    let d = &bus.drives[drive];
                    let pt = &d.points[point];
                    let want = truth
                        .iter()
                        .find(|t| t.0 == d.address && t.1.name == pt.name)
                        .unwrap()
                        .2;
                    assert_eq!(raw, want, "{}: {}/{} published a wrong value", p.name(), d.name, pt.name);
                    values += 1;
                }
                Some(Update::Status { status: DriveStatus::Timeout, .. }) => timeouts += 1,
                Some(_) => {}
                None => break,
            },
        }
    }
    task.abort();
    (values, timeouts)
}

/// The bus task on every protocol's simulated bus with faults on the link for a minute of
/// virtual time: what it publishes is never a wrong value (1- and 2-bit flips, drops,
/// inserted and delayed characters; CAN: dropped and corrupted frames).
#[tokio::test(start_paused = true)]
#[allow(clippy::print_stderr)]
async fn the_bus_task_never_publishes_a_wrong_value_under_faults() {
    tokio::task::LocalSet::new()
        .run_until(async {
            for (i, p) in [
                Protocol::Movilink,
                Protocol::Uss,
                Protocol::ModbusRtu,
                Protocol::ModbusAscii,
            ]
            .into_iter()
            .enumerate()
            {
                for flip_bits in [1, 2] {
                    let seed = 100 + i as u64 * 10 + u64::from(flip_bits);
                    let (values, timeouts) = published_under_faults(p, |s| {
                        s.faults.set(serial_faults(seed, 0.003, flip_bits));
                    })
                    .await;
                    eprintln!(
                        "{} flip_bits {flip_bits}: {values} values published, {timeouts} timeouts",
                        p.name()
                    );
                    assert!(values > 100, "{}: {values}", p.name());
                }
            }
            let (values, timeouts) = published_under_faults(Protocol::Sbus, |s| {
                if let Some(v) = &s.can {
                    v.set_faults(BusFaults {
                        seed: 150,
                        drop: 0.05,
                        corrupt: 0.05,
                        ..BusFaults::none()
                    });
                }
            })
            .await;
            eprintln!("sbus: {values} values published, {timeouts} timeouts");
            assert!(values > 100, "sbus: {values}");
        })
        .await;
}

/// The stop at the gateway's end, on each protocol's simulated drive: a drive enabled over
/// process data is no longer enabled after `stop_process_data` (SEW: the control word slot from
/// P870 gets 0x02 in its low byte; NORD: STW 0x047E), and the output words' other entries are
/// kept.
#[tokio::test(start_paused = true)]
async fn the_stop_in_process_data_stops_each_protocols_simulated_drive() {
    use drive_profile::nord::StatusWord as NordStatus;
    use drive_profile::sew::{StatusWord1, UnitStatus};
    let plant = example();
    for p in [Protocol::Movilink, Protocol::Sbus, Protocol::Uss] {
        let bus = bus_of(&plant, p);
        let mut sim = simulated_bus(&bus);
        let a = bus.drives[0].address;
        let enabled = |w: u16| match p {
            Protocol::Uss => NordStatus(w).contains(NordStatus::OPERATION_ENABLED),
            _ => StatusWord1::from_bits(w).unit_status() == Some(UnitStatus::Enable),
        };
        // Enable: SEW control word 0x0006 with 1500 1/min (PO2, factory: speed, 0.2 1/min);
        // NORD: shutdown, then enable operation with bit 10 (control data valid).
        let out: Vec<u16> = match p {
            Protocol::Uss => {
                sim.access.process_data(a, &[0x047E, 0]).await.unwrap();
                tokio::time::sleep(Duration::from_millis(50)).await;
                vec![0x047F, 0x1000]
            }
            _ => vec![0x0006, 7500, 0],
        };
        let mut words = Vec::new();
        for _ in 0..5 {
            words = sim.access.process_data(a, &out).await.unwrap();
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        assert!(
            enabled(words[0]),
            "{}: enabled first: 0x{:04X}",
            p.name(),
            words[0]
        );
        // NORD ramps down on the braking ramp before it switches off ("Stillsetzen"); a
        // MOVIDRIVE shows the stop at once (and its SBus timeout P815, factory 0.1 s, would
        // trip after a longer silence). The control: the same silence alone leaves the drive
        // enabled.
        let wait = if p == Protocol::Uss {
            Duration::from_secs(5)
        } else {
            Duration::from_millis(30)
        };
        tokio::time::sleep(wait).await;
        let still = sim.access.process_data(a, &out).await.unwrap();
        assert!(
            enabled(still[0]),
            "{}: still enabled: 0x{:04X}",
            p.name(),
            still[0]
        );
        let stopped = sim
            .access
            .stop_process_data(a, &out)
            .await
            .unwrap()
            .unwrap();
        // The gateway's stop is one telegram; then the drive is on its own.
        tokio::time::sleep(wait).await;
        // The next answer (to the stop words again) shows the drive no longer enabled.
        let after = sim
            .access
            .stop_process_data(a, &out)
            .await
            .unwrap()
            .unwrap();
        assert_eq!(stopped.len(), out.len());
        assert!(
            !enabled(after[0]),
            "{}: stopped: 0x{:04X}",
            p.name(),
            after[0]
        );
    }
    // Modbus has no process data: nothing sent, the reason given.
    let bus = bus_of(&plant, Protocol::ModbusRtu);
    let mut sim = simulated_bus(&bus);
    let why = sim
        .access
        .stop_process_data(1, &[0])
        .await
        .unwrap()
        .unwrap_err();
    assert!(why.contains("Modbus"), "{why}");
}

/// Before it exchanges process data the gateway says what would surprise: a MOVIDRIVE on
/// MOVILINK has its RS-485 timeout P812 off by default (it would keep running when the gateway
/// goes quiet), SBus's P815 is on (0.1 s); P876 off means the drive ignores the output words;
/// no control word among P870–P872 means it cannot be stopped over process data.
#[tokio::test(start_paused = true)]
async fn process_data_warnings_name_what_the_drive_is_set_to() {
    let plant = example();
    let ml = bus_of(&plant, Protocol::Movilink);
    let mut sim = simulated_bus(&ml);
    let w = sim
        .access
        .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(50))
        .await
        .unwrap();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("RS-485 timeout P812") && w[0].contains("keeps running"),
        "{w:?}"
    );
    let sb = bus_of(&plant, Protocol::Sbus);
    let mut sim = simulated_bus(&sb);
    assert_eq!(
        sim.access
            .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(50))
            .await
            .unwrap(),
        Vec::<String>::new()
    );
    // P876 off and PO1 no longer a control word (P870 = 11, say: speed).
    let mut c = sim.access.client(1);
    for (key, raw) in [("P876", 0), ("P870", 11)] {
        let t = drive_client::target::Target::of(
            drive_profile::family::lookup(drive_profile::Family::Movidrive, key).unwrap(),
        );
        c.write(&t, raw, Persistence::Volatile).await.unwrap();
    }
    let w = sim
        .access
        .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(50))
        .await
        .unwrap();
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(
        w[0].contains("control word") && w[1].contains("P876"),
        "{w:?}"
    );
    // NORD and Modbus: nothing checked.
    let uss = bus_of(&plant, Protocol::Uss);
    let mut sim = simulated_bus(&uss);
    assert!(
        sim.access
            .process_data_warnings(1, &[0x047E, 0], Duration::from_millis(50))
            .await
            .unwrap()
            .is_empty()
    );
}

/// Issue 18 A2: a Modbus point of a parameter the manual gives no data type is read and
/// written with the config's `width` (415 is 16 bit on the simulated ACTIVE Cube); without the
/// width the client refuses it rather than guessing.
#[tokio::test(start_paused = true)]
async fn issue18_a_modbus_points_width_is_used_for_its_reads_and_writes() {
    let text = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\n[[bus]]\nname = \"b\"\n\
                protocol = \"modbus-rtu\"\nsimulate = true\n[[bus.drive]]\nname = \"d\"\n\
                address = 1\n[[bus.drive.param]]\nparam = \"415\"\nwidth = 16\nperiod = \"1s\"\n\
                writable = true\n";
    let plant = Plant::parse(text, "plant.toml").unwrap();
    let bus = plant.buses[0].clone();
    let point = bus.drives[0].points[0].clone();
    let mut sim = simulated_bus(&bus);
    let mut c = sim.access.client(1);
    let now = c.read(&point.target).await.unwrap();
    let raw = other_value(&point, now, &[]);
    let req = WriteRequest {
        target: point.target,
        raw,
        persistence: Persistence::Volatile,
        force: false,
    };
    let done = write_checked(&mut c, &req, false, &MemoryWearLog::default(), &mut |_| {})
        .await
        .unwrap();
    assert_eq!(done.back, raw);
    // Another drive's client knows no width for it: nothing is guessed.
    let mut other = sim.access.client(2);
    assert!(matches!(
        other.read(&point.target).await,
        Err(ClientError::Request(_))
    ));
}

/// Issue 18 B5: a process-data period at or above the drive's own bus timeout (SBus P815, the
/// simulated drive's 100 ms; MOVILINK P812 once set) is warned about before the first cycle,
/// not only a timeout that is off.
#[tokio::test(start_paused = true)]
async fn issue18_a_process_data_period_at_or_above_the_bus_timeout_is_warned() {
    let plant = example();
    let sb = bus_of(&plant, Protocol::Sbus);
    let mut sim = simulated_bus(&sb);
    for ms in [100, 150, 1000] {
        let w = sim
            .access
            .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(ms))
            .await
            .unwrap();
        assert_eq!(w.len(), 1, "{ms} ms: {w:?}");
        assert!(
            w[0].contains("at or above the drive's SBus timeout P815 (100 ms)")
                && w[0].contains("F47")
                && w[0].contains("[bus.drive.process_data] period"),
            "{w:?}"
        );
    }
    let w = sim
        .access
        .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(99))
        .await
        .unwrap();
    assert!(w.is_empty(), "{w:?}");
    // MOVILINK: P812 set to 0.2 s.
    let ml = bus_of(&plant, Protocol::Movilink);
    let mut sim = simulated_bus(&ml);
    let t = drive_client::target::Target::of(
        drive_profile::family::lookup(drive_profile::Family::Movidrive, "P812").unwrap(),
    );
    sim.access
        .client(1)
        .write(&t, 200, Persistence::Volatile)
        .await
        .unwrap();
    let w = sim
        .access
        .process_data_warnings(1, &[6, 0, 0], Duration::from_millis(250))
        .await
        .unwrap();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("RS-485 timeout P812 (200 ms)") && w[0].contains("F43"),
        "{w:?}"
    );
}

/// Issue 18 B5: a drive that trips with F47 (SBus timeout: process data every 150 ms against
/// its P815 of 100 ms) is reported in fault at the next process-data cycle, from the status
/// word in its input words, not at the next status read (5 s).
#[tokio::test(start_paused = true)]
async fn issue18_an_sbus_timeout_trip_is_reported_at_the_next_cycle() {
    use crate::bus::BusContext;
    use crate::model::{DriveStatus, Update};
    tokio::task::LocalSet::new()
        .run_until(async {
            let text = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\n[[bus]]\nname = \"can\"\n\
                        protocol = \"sbus\"\nsimulate = true\nstatus_period = \"5s\"\n\
                        [[bus.drive]]\nname = \"d\"\naddress = 1\n\
                        [bus.drive.process_data]\nperiod = \"150ms\"\nout = [6, 1500, 0]\n";
            let plant = Plant::parse(text, "plant.toml").unwrap();
            let bus = plant.buses[0].clone();
            let sim = simulated_bus(&bus);
            let (utx, mut urx) = tokio::sync::mpsc::channel(4096);
            let (_stx, srx) = tokio::sync::mpsc::channel(1);
            let (_stop, shutdown) = tokio::sync::watch::channel(crate::bus::Stop::Run);
            let ctx = BusContext {
                shutdown,
                announce: crate::bus::BusContext::no_announce(),
                ix: crate::model::BusSlot::new(0),
                bus: bus.clone(),
                updates: utx,
                sets: srx,
                asks: crate::bus::BusContext::no_asks(),
                metrics: std::sync::Arc::new(crate::metrics::Metrics::new(&plant)),
            };
            let start = tokio::time::Instant::now();
            let task = tokio::task::spawn_local(crate::task::run_bus(ctx, sim.access));
            let fault = tokio::time::timeout(Duration::from_secs(10), async {
                loop {
                    match urx.recv().await {
                        Some(Update::Status {
                            status: DriveStatus::Fault(text),
                            ..
                        }) => return (text, start.elapsed()),
                        Some(_) => {}
                        None => panic!("the task ended"),
                    }
                }
            })
            .await
            .expect("a fault within 10 s");
            task.abort();
            assert!(fault.0.starts_with("F47"), "{fault:?}");
            assert!(
                fault.1 < Duration::from_millis(600),
                "the F47 trip was reported after {:?}",
                fault.1
            );
        })
        .await;
}

/// Issue 18 B5, its Modbus neighbour: a Bonfiglioli drive whose watchdog 413 is at or below the
/// longest gap between the gateway's requests to it trips with F2010 between two; the gateway
/// says so at the start (413 off, or longer than the gap: nothing).
#[tokio::test(start_paused = true)]
async fn issue18_a_bonfiglioli_watchdog_below_the_polling_gap_is_warned() {
    // 413 polled (16 bit, as the simulated drive has it), so that the test can set it.
    let text = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\n[[bus]]\nname = \"b\"\n\
                protocol = \"modbus-rtu\"\nsimulate = true\n[[bus.drive]]\nname = \"d\"\n\
                address = 1\n[[bus.drive.param]]\nparam = \"413\"\nwidth = 16\nperiod = \"1s\"\n";
    let plant = Plant::parse(text, "plant.toml").unwrap();
    let bus = plant.buses[0].clone();
    let mut sim = simulated_bus(&bus);
    let five = Duration::from_secs(5);
    assert!(
        sim.access
            .watchdog_warnings(1, five)
            .await
            .unwrap()
            .is_empty()
    );
    let t = bus.drives[0].points[0].target;
    sim.access
        .client(1)
        .write(&t, 3, Persistence::Volatile)
        .await
        .unwrap();
    let w = sim.access.watchdog_warnings(1, five).await.unwrap();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("watchdog 413 (3 s)") && w[0].contains("(5 s,") && w[0].contains("F2010"),
        "{w:?}"
    );
    let w = sim
        .access
        .watchdog_warnings(1, Duration::from_secs(3))
        .await
        .unwrap();
    assert_eq!(w.len(), 1, "at the watchdog itself: {w:?}");
    assert!(
        sim.access
            .watchdog_warnings(1, Duration::from_secs(2))
            .await
            .unwrap()
            .is_empty()
    );
    // The other families have no such watchdog.
    let ml = bus_of(&example(), Protocol::Movilink);
    let mut sim = simulated_bus(&ml);
    assert!(
        sim.access
            .watchdog_warnings(1, five)
            .await
            .unwrap()
            .is_empty()
    );
}

/// A port that refuses a setting names the config key, never a command-line option (the
/// gateway's open used drivectl's, whose message said `option --parity even|odd|none`).
#[tokio::test]
async fn a_refused_line_setting_names_the_config_key() {
    let pty = drive_transport::pty::PtyPair::open().unwrap();
    let path = pty.slave_path().to_str().unwrap().to_owned();
    // Pseudo-terminals refuse parity.
    let line = drive_core::LineSettings::new(9600).with_parity(drive_core::Parity::Even);
    let adapter = crate::config::Adapter::default();
    let e = super::open_serial(&path, line, adapter)
        .map(drop)
        .unwrap_err();
    assert!(e.contains("the bus's parity in the config"), "{e}");
    assert!(!e.contains("--"), "{e}");
    // Nor kernel RS-485 mode.
    let adapter = crate::config::Adapter {
        echo: false,
        rs485: Some(drive_transport::serial::Rs485Config::default()),
    };
    let e = super::open_serial(&path, line.with_parity(drive_core::Parity::None), adapter)
        .map(drop)
        .unwrap_err();
    assert!(
        e.contains("RS-485") && e.contains("the bus's rs485 in the config"),
        "{e}"
    );
    assert!(!e.contains("--"), "{e}");
    // A missing adapter: the transport's words, no option either.
    let e = super::open_can("slcan:/nonexistent/tty@500k")
        .await
        .map(drop)
        .unwrap_err();
    assert!(!e.contains("--"), "{e}");
    assert!(e.contains("/nonexistent/tty"), "{e}");
}

/// The page's jobs on every protocol's simulated bus, through its bus task: a backup made
/// through the asks is the backup `drive-client` makes straight on the drive (the same file),
/// and a guarded write through them is read back, the polls running meanwhile.
#[tokio::test(start_paused = true)]
async fn the_pages_backup_and_write_run_on_every_protocols_bus_task() {
    tokio::task::LocalSet::new()
        .run_until(pages_jobs_on_every_bus())
        .await;
}

async fn pages_jobs_on_every_bus() {
    for plant in [example(), ctt2_plant()] {
        pages_jobs_on(&plant).await;
    }
}

async fn pages_jobs_on(plant: &Plant) {
    use crate::bus::BusContext;
    use crate::ui::drive::Remote;
    for bus in &plant.buses {
        let mut bus = bus.clone();
        for d in &mut bus.drives {
            d.process_data = None;
        }
        let mut sim = simulated_bus(&bus);
        let d = &bus.drives[0];
        let point = d.points.iter().find(|p| p.writable).unwrap().clone();
        // As `drivectl … backup` makes it (a Bonfiglioli client that finds unknown widths).
        let direct = {
            let mut c = sim.access.page_client(d.address);
            drive_client::backup::backup(&mut c, &mut (), &drive_client::Interrupt::new())
                .await
                .unwrap_or_else(|e| panic!("{}: {e}", bus.name))
                .text()
                .unwrap()
        };
        let now = sim
            .access
            .client(d.address)
            .read(&point.target)
            .await
            .unwrap();
        let raw = other_value(&point, now, &[]);
        let (utx, mut urx) = tokio::sync::mpsc::channel(4096);
        let (_stx, srx) = tokio::sync::mpsc::channel(1);
        let (atx, arx) = tokio::sync::mpsc::channel(64);
        let (_stop, shutdown) = tokio::sync::watch::channel(crate::bus::Stop::Run);
        let ctx = BusContext {
            shutdown,
            announce: crate::bus::BusContext::no_announce(),
            ix: crate::model::BusSlot::new(0),
            bus: bus.clone(),
            updates: utx,
            sets: srx,
            asks: arx,
            metrics: std::sync::Arc::new(crate::metrics::Metrics::new(plant)),
        };
        let values = std::rc::Rc::new(std::cell::Cell::new(0u32));
        let seen = values.clone();
        tokio::task::spawn_local(async move {
            while let Some(u) = urx.recv().await {
                if matches!(u, crate::model::Update::Value { .. }) {
                    seen.set(seen.get() + 1);
                }
            }
        });
        let task = tokio::task::spawn_local(crate::task::run_bus(ctx, sim.access));
        let mut remote = Remote::connect(atx, 0, Duration::from_secs(30))
            .await
            .unwrap();
        let polls_before = values.get();
        let paged =
            drive_client::backup::backup(&mut remote, &mut (), &drive_client::Interrupt::new())
                .await
                .unwrap_or_else(|e| panic!("{}: {e}", bus.name))
                .text()
                .unwrap();
        assert_eq!(
            paged, direct,
            "bus {}: the page's backup is drive-client's",
            bus.name
        );
        assert!(
            values.get() > polls_before,
            "bus {}: the polls ran during the backup",
            bus.name
        );
        let req = WriteRequest {
            target: point.target,
            raw,
            persistence: Persistence::Volatile,
            force: false,
        };
        let done = write_checked(
            &mut remote,
            &req,
            false,
            &MemoryWearLog::default(),
            &mut |_| {},
        )
        .await
        .unwrap_or_else(|e| panic!("{}/{}: {e}", bus.name, point.name));
        assert_eq!(done.back, raw, "bus {}", bus.name);
        assert_eq!(
            remote.read(&point.target).await.unwrap(),
            raw,
            "bus {}",
            bus.name
        );
        task.abort();
    }
}

// ---------------------------------------------------------------------------------------------
// CTT2 (simulated AS-i link only: not in the example config, which names real ports)

/// A CTT2 bus of two simulated NORDAC LINKs at the double slaves 1A/1B and 5A/5B.
const CTT2_CONFIG: &str = r#"
[gateway]
name = "asi"
broker = "off"
metrics = "off"

[ui]
listen = "127.0.0.1:8080"

[[bus]]
name = "asi-1"
protocol = "ctt2"
simulate = true

[[bus.drive]]
name = "feeder"
address = 1

[[bus.drive.param]]
param = "P700"
array = 1
name = "fault"
period = "5s"

[[bus.drive.param]]
param = "P102"
name = "ramp_up"
writable = true

[[bus.drive]]
name = "lift"
address = 5

[[bus.drive.param]]
param = "P112"
name = "current_limit"
writable = true

[bus.drive.process_data]
period = "1s"
out = [0x047E, 0]
"#;

fn ctt2_plant() -> Plant {
    Plant::parse(CTT2_CONFIG, "ctt2").unwrap()
}

#[test]
fn a_ctt2_bus_is_simulated_only_and_its_drives_are_double_slave_numbers() {
    let plant = ctt2_plant();
    let bus = &plant.buses[0];
    assert_eq!(bus.protocol, Protocol::Ctt2);
    assert!(matches!(bus.endpoint, Endpoint::Simulated { .. }));
    // Two double slaves: four AS-i slaves, 16 × 154 µs × 6 per byte (BU 0255 4.4).
    assert_eq!(WireDesc::of(bus).asi_slaves, 4);
    let (text, verdict) = check_report(&plant);
    verdict.unwrap();
    assert!(
        text.contains("ctt2 on the simulated AS-i link, 2 drive(s)"),
        "{text}"
    );
    assert!(text.trim_end().ends_with(": fits"), "{text}");
    let refused = |from: &str, to: &str| {
        let text = CTT2_CONFIG.replacen(from, to, 1);
        assert_ne!(text, CTT2_CONFIG, "{from}");
        Plant::parse(&text, "ctt2").unwrap_err().to_string()
    };
    for (from, to) in [
        ("simulate = true", "simulate = false"),
        ("simulate = true", "port = \"/dev/ttyUSB0\""),
        (
            "simulate = true",
            "simulate = true\nport = \"/dev/ttyUSB0\"",
        ),
        ("simulate = true", "simulate = true\niface = \"can0\""),
    ] {
        let e = refused(from, to);
        assert!(e.contains("no real AS-i master"), "{to}: {e}");
        assert!(e.contains("simulate = true"), "{to}: {e}");
    }
    let e = refused("simulate = true", "simulate = true\nbaud = 19200");
    assert!(e.contains("no serial line"), "{e}");
    for bad in ["address = 0", "address = 32"] {
        let e = refused("address = 1", bad);
        assert!(e.contains("double slave's number, 1–31"), "{bad}: {e}");
        assert!(e.contains("5A"), "{bad}: {e}");
    }
    let e = refused("out = [0x047E, 0]", "out = [0x047E, 0, 0, 0, 0]");
    assert!(e.contains("1–4 words"), "{e}");
    let e = refused("protocol = \"ctt2\"", "protocol = \"asi\"");
    assert!(e.contains("ctt2"), "{e}");
}

#[tokio::test(start_paused = true)]
async fn a_ctt2_bus_reads_writes_and_exchanges_process_data_with_its_simulated_drives() {
    use drive_profile::nord::StatusWord as NordStatus;
    let plant = ctt2_plant();
    let bus = &plant.buses[0];
    let mut sim = simulated_bus(bus);
    // A guarded write of each writable point, read back; then seen on the simulated drive.
    let written = write_distinct(&mut sim.access, bus).await;
    assert_eq!(written.len(), 2);
    let Proto::Ctt2(b) = &sim.access.proto else {
        panic!("not a CTT2 bus");
    };
    for (address, point, raw) in &written {
        let drive = b.simulated_drive(*address).unwrap();
        assert_eq!(
            drive.ram_value(point.target.index, 0, 0).map(i64::from),
            Some(*raw),
            "{address}: {}",
            point.name
        );
    }
    for d in &bus.drives {
        assert_eq!(sim.access.fault(d.address).await.unwrap(), None);
    }
    // A number that is no double slave, or none on this network: refused without a transaction.
    for bad in [0u8, 3, 32] {
        let t = bus.drives[0].points[0].target;
        let r = sim.access.client(bad).read(&t).await;
        assert!(matches!(r, Err(ClientError::Request(_))), "{bad}: {r:?}");
    }
    // Process data: enable, then the gateway's stop ramps the drive down.
    let a = 5;
    sim.access.process_data(a, &[0x047E, 0]).await.unwrap();
    let out = [0x047F, 0x1000];
    let mut words = Vec::new();
    for _ in 0..3 {
        words = sim.access.process_data(a, &out).await.unwrap();
    }
    assert_eq!(words.len(), 2);
    assert!(
        NordStatus(words[0]).contains(NordStatus::OPERATION_ENABLED),
        "0x{:04X}",
        words[0]
    );
    sim.access
        .stop_process_data(a, &out)
        .await
        .unwrap()
        .unwrap();
    tokio::time::sleep(Duration::from_secs(5)).await;
    let after = sim
        .access
        .stop_process_data(a, &out)
        .await
        .unwrap()
        .unwrap();
    assert!(
        !NordStatus(after[0]).contains(NordStatus::OPERATION_ENABLED),
        "0x{:04X}",
        after[0]
    );
    assert!(matches!(
        sim.access.process_data(a, &[0x047E, 0, 0, 0, 0]).await,
        Err(ClientError::Request(_))
    ));
    assert_eq!(sim.access.take_tally(), crate::bus::LinkTally::default());
}

#[tokio::test(start_paused = true)]
async fn the_wire_time_of_a_ctt2_transaction_is_what_the_simulated_link_takes() {
    // Each op against the formula on the paused clock: the link keeps its byte times exactly,
    // tokio's clock to the millisecond (hence 1 ms below the formula allowed).
    let plant = ctt2_plant();
    let bus = &plant.buses[0];
    let mut sim = simulated_bus(bus);
    let d = &bus.drives[1];
    let t = d.points[0].target;
    let read = sim.access.wire_time(Op::Read);
    // 4 AS-i slaves: 14.784 ms per byte; an order is 12 bytes of the write and 12 of a read,
    // and the same parameter again needs a "no order" before it.
    assert_eq!(read, Duration::from_micros(14_784 * 48));
    let pd = sim.access.wire_time(Op::ProcessData(2));
    assert_eq!(pd, Duration::from_micros(14_784 * (9 + 6)));
    let n = 10u32;
    let start = tokio::time::Instant::now();
    for _ in 0..n {
        sim.access.client(d.address).read(&t).await.unwrap();
    }
    let measured = start.elapsed() / n;
    assert!(
        measured + Duration::from_millis(1) >= read && measured <= read + Duration::from_millis(2),
        "read: measured {measured:?}, formula {read:?}"
    );
    let start = tokio::time::Instant::now();
    for _ in 0..n {
        sim.access
            .process_data(d.address, &[0x047E, 0])
            .await
            .unwrap();
    }
    let measured = start.elapsed() / n;
    assert!(
        measured + Duration::from_millis(1) >= pd && measured <= pd + Duration::from_millis(2),
        "process data: measured {measured:?}, formula {pd:?}"
    );
    // One drive alone (2 slaves, 9.856 ms per byte): the drive's 50 ms on the order outlast
    // the first read of the channel, which the client repeats (the "no order" before it is
    // answered at once).
    let mut one = bus.clone();
    one.drives.truncate(1);
    let w = WireDesc::of(&one);
    assert_eq!(w.time(Op::Read), Duration::from_micros(9_856 * 60));
    let mut sim = simulated_bus(&one);
    let t = one.drives[0].points[0].target;
    let start = tokio::time::Instant::now();
    sim.access.client(1).read(&t).await.unwrap();
    let measured = start.elapsed();
    assert!(
        measured + Duration::from_millis(1) >= w.time(Op::Read)
            && measured <= w.time(Op::Read) + Duration::from_millis(2),
        "one drive: measured {measured:?}, formula {:?}",
        w.time(Op::Read)
    );
}
