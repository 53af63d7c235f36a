//! A changed value published as Sparkplug B (`Node::update`, then `Node::flush`: one DDATA of
//! one metric, topic and encoded payload) against the same value as its JSON topic
//! (`payload::value` and the topic `<prefix>/<gateway>/<bus>/<drive>/<point>`), in one
//! criterion group so that the ratio is measured in one run. The example plant's
//! `conveyor/speed` (a scaled value) and `lift/status_word` (whose JSON carries the decoded
//! status text); and the DDATA of a value of the 64 × 31 load plant, whose flush looks at
//! 1984 drives.
//!
//! ```text
//! cargo bench -p drivebus-gateway --bench sparkplug
//! ```

// A bench's own fixtures: a plant that does not parse or a node that publishes nothing is a
// broken bench, stopped at once.
#![allow(clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::hint::black_box;
use std::time::{Duration, UNIX_EPOCH};

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use drivebus_gateway::config::Plant;
use drivebus_gateway::model::Update;
use drivebus_gateway::mqtt::payload;
use drivebus_gateway::sparkplug::node::{Node, Out, Phase};

const NOW: u64 = 1_767_000_000_000;

fn example_plant() -> Plant {
    let text = format!(
        "{}\n[sparkplug]\ngroup_id = \"plant-1\"\nedge_node_id = \"cabinet-1\"\n",
        drivebus_gateway::EXAMPLE_CONFIG
    );
    let mut plant = Plant::parse(&text, "example.toml").expect("the example config parses");
    drivebus_gateway::simulate_all(&mut plant);
    plant
}

/// A node of `plant` past its births (every value null in them: the next one is a change).
fn born(plant: &Plant) -> Node {
    let sp = plant.sparkplug.as_ref().expect("a [sparkplug] table");
    let mut n = Node::new(plant, sp);
    let subs = n.connected(0);
    for _ in &subs {
        let _ = n.subscribed(NOW - 10_000);
    }
    let births = n.flush(NOW);
    assert!(!births.is_empty() && n.phase() == Phase::Born);
    n
}

/// `(bus, drive, point)` of a point by its drive's and its own name.
fn find(plant: &Plant, drive: &str, point: &str) -> (usize, usize, usize) {
    for (b, bus) in plant.buses.iter().enumerate() {
        for (d, dr) in bus.drives.iter().enumerate() {
            if dr.name == drive
                && let Some(p) = dr.points.iter().position(|p| p.name == point)
            {
                return (b, d, p);
            }
        }
    }
    panic!("no {drive}/{point}");
}

/// One changed value to the node and its flush: the DDATA.
fn ddata(node: &mut Node, (bus, drive, point): (usize, usize, usize), raw: i64) -> Vec<Out> {
    let u = Update::Value {
        bus,
        drive,
        point,
        raw,
        at: UNIX_EPOCH + Duration::from_millis(NOW - 250),
    };
    let mut outs = node.update(&u, NOW);
    outs.extend(node.flush(NOW));
    outs
}

/// The same value as its JSON topic: topic and payload.
fn json(plant: &Plant, (bus, drive, point): (usize, usize, usize), raw: i64) -> (String, String) {
    let g = &plant.gateway;
    let b = &plant.buses[bus];
    let d = &b.drives[drive];
    let p = &d.points[point];
    let topic = format!("{}/{}/{}/{}/{}", g.prefix, g.name, b.name, d.name, p.name);
    (topic, payload::value(&p.target, raw, NOW - 250, &d.device))
}

fn changed_value(c: &mut Criterion) {
    let mut group = c.benchmark_group("changed_value");
    let plant = example_plant();
    for (drive, point, raw) in [("conveyor", "speed", 1450), ("lift", "status_word", 0x0407)] {
        let at = find(&plant, drive, point);
        let mut node = born(&plant);
        // Each iteration changes the value (raw and raw + 1 in turn): one DDATA each.
        let check = ddata(&mut node, at, raw + 1);
        assert!(
            matches!(check.as_slice(), [Out::Publish(m)] if m.topic.contains("/DDATA/")),
            "{check:?}"
        );
        let mut flip = 0;
        group.bench_function(BenchmarkId::new("sparkplug_ddata", point), |b| {
            b.iter(|| {
                flip ^= 1;
                black_box(ddata(&mut node, at, black_box(raw + flip)))
            })
        });
        group.bench_function(BenchmarkId::new("json_topic", point), |b| {
            b.iter(|| black_box(json(&plant, at, black_box(raw))))
        });
    }
    // The load plant: the flush after one change looks at every drive of the node.
    let big = drivebus_gateway::load::sparkplug_plant(64, 31, "1s").expect("the load plant");
    let mut node = born(&big);
    let at = (63, 30, 0);
    let check = ddata(&mut node, at, 1001);
    assert!(matches!(check.as_slice(), [Out::Publish(_)]), "{check:?}");
    let mut flip = 0;
    group.bench_function(BenchmarkId::new("sparkplug_ddata", "64x31"), |b| {
        b.iter(|| {
            flip ^= 1;
            black_box(ddata(&mut node, at, black_box(1000 + flip)))
        })
    });
    group.finish();
}

criterion_group!(benches, changed_value);
criterion_main!(benches);
