//! `drivectl gateway` as a Sparkplug B 3.0 edge node (issue 21), checked with a host nobody
//! here wrote: `tests/sparkplug/host.py` (pysparkplug and paho-mqtt from PyPI, harness
//! `tests/common/spb_host.rs`) against a real Mosquitto, with the drives as a `drivectl sim
//! movilink --pty` process. The host decodes NBIRTH and every DBIRTH, and the datatypes, values
//! and properties are compared with the simulator's own values (read directly) and the
//! parameter table; DDATA follows a changed value, by alias only; a DCMD (by name or alias,
//! with or without datatypes) is written and read back, a refused one writes nothing; a rebirth
//! request is answered; NDEATH comes on a kill and on a stop with the birth's bdSeq, which
//! increases across restarts; DDEATH when the simulated drives stop answering (SIGSTOP), DBIRTH
//! when they answer again; a primary host's STATE is waited for and followed.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::print_stderr
)]

mod common;
#[path = "common/gateway.rs"]
mod gateway;
#[path = "../../drivebus-gateway/tests/common/mosquitto.rs"]
mod mosquitto;
#[path = "common/spb_host.rs"]
mod spb_host;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::{PtySim, ok_json};
use gateway::{Gateway, signal};
use mosquitto::{BrokerOptions, Mosquitto};
use serde_json::{Value, json};
use spb_host::{Metric, Msg, SpbHost};

const GROUP: &str = "plant";
const NODE: &str = "gw";
/// How long a gateway may take from its start to its births.
const BIRTH: Duration = Duration::from_secs(15);
const WAIT: Duration = Duration::from_secs(10);

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

static SEQ: AtomicU32 = AtomicU32::new(0);

/// A temporary directory of this test process, removed when dropped.
struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A new empty directory of this test process (its owner removes it).
fn new_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "drivebus-spb-{what}-{}-{}",
        std::process::id(),
        SEQ.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn temp_dir(what: &str) -> TempDir {
    TempDir(new_dir(what))
}

/// A broker, the host on it, and two simulated MOVIDRIVEs (addresses 1 and 2) on one pty;
/// `None` where the broker or the host cannot be had outside CI (skipped, said once).
fn setup() -> Option<(Mosquitto, SpbHost, PtySim)> {
    let broker = Mosquitto::start(BrokerOptions::default())?;
    let host = SpbHost::start(broker.port, GROUP)?;
    let sim = PtySim::start(&[
        "sim", "movilink", "--pty", "--parity", "none", "--addr", "1", "--addr", "2",
    ]);
    Some((broker, host, sim))
}

/// The plant: bus `ml` on the simulator's pty; drive `d1` with `ramp` (P130, writable),
/// `P131` (named by its parameter key, read-only here) and `offset` (P225, writable: an
/// unscaled signed integer); drive `d2` with `ramp` (P130, read-only here). `sparkplug` is
/// added to the `[sparkplug]` table.
fn config(broker: &Mosquitto, sim: &PtySim, sparkplug: &str) -> String {
    format!(
        "[gateway]\nname = \"gw\"\nbroker = \"{}\"\nmetrics = \"off\"\n\n\
         [sparkplug]\ngroup_id = \"{GROUP}\"\nedge_node_id = \"{NODE}\"\n{sparkplug}\n\n\
         [[bus]]\nname = \"ml\"\nprotocol = \"movilink\"\nport = \"{}\"\nparity = \"none\"\n\
         timeout = \"50ms\"\nretries = 1\n\
         [[bus.drive]]\nname = \"d1\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\nwritable = true\n\
         [[bus.drive.param]]\nparam = \"P131\"\nperiod = \"200ms\"\n\
         [[bus.drive.param]]\nparam = \"P225\"\nname = \"offset\"\nperiod = \"200ms\"\nwritable = true\n\
         [[bus.drive]]\nname = \"d2\"\naddress = 2\n\
         [[bus.drive.param]]\nparam = \"P130\"\nname = \"ramp\"\nperiod = \"200ms\"\n",
        broker.url(),
        sim.path
    )
}

/// The simulated drive at `addr`'s raw value of `param`, read directly (not while a gateway
/// holds the pty).
fn read_raw(sim: &PtySim, addr: u8, param: &str) -> i64 {
    let addr = addr.to_string();
    let v = ok_json(&sim.drivectl(&[
        "movilink", "--port", &sim.path, "--parity", "none", "--addr", &addr, "--json", "read",
        param,
    ]));
    v[0]["raw"]
        .as_i64()
        .unwrap_or_else(|| panic!("{param} at {addr}: {v:?}"))
}

/// The MOVIDRIVE table's entry for `param` (`drivectl params movidrive show … --json`).
fn table(param: &str) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["params", "movidrive", "show", param, "--json"])
        .output()
        .unwrap();
    ok_json(&out).remove(0)
}

/// The range of values a Sparkplug integer datatype holds; `None` for any other datatype.
fn integer_range(datatype: &str) -> Option<(i128, i128)> {
    Some(match datatype {
        "Int8" => (i8::MIN.into(), i8::MAX.into()),
        "Int16" => (i16::MIN.into(), i16::MAX.into()),
        "Int32" => (i32::MIN.into(), i32::MAX.into()),
        "Int64" => (i64::MIN.into(), i64::MAX.into()),
        "UInt8" => (0, u8::MAX.into()),
        "UInt16" => (0, u16::MAX.into()),
        "UInt32" => (0, u32::MAX.into()),
        "UInt64" => (0, u64::MAX.into()),
        _ => return None,
    })
}

/// The bdSeq metric of an NBIRTH or NDEATH: an Int64 0–255 (as Eclipse Tahu sends it and the
/// specification's NBIRTH example shows; its NDEATH example says UInt64, docs/errata-sparkplug.md).
fn bd_seq(m: &Msg) -> u64 {
    let bd = m.get("bdSeq");
    assert_eq!(bd.datatype, "Int64", "{}: {bd:?}", m.topic);
    assert!(bd.uint() <= 255, "{bd:?}");
    bd.uint()
}

/// The NBIRTH and the DBIRTHs of d1 and d2 since the mark; a gateway that exits before its
/// NBIRTH (a config it refuses) fails at once with its log.
fn births(host: &mut SpbHost, gw: &mut Gateway) -> (Msg, Msg, Msg) {
    let deadline = Instant::now() + BIRTH;
    while Instant::now() < deadline {
        if host
            .wait_for(Duration::from_millis(250), |m| m.is("NBIRTH", None))
            .is_some()
        {
            break;
        }
        gw.assert_running("its NBIRTH");
    }
    let n = host.expect_kind("NBIRTH", NODE, None, BIRTH);
    let d1 = host.expect_kind("DBIRTH", NODE, Some("d1"), BIRTH);
    let d2 = host.expect_kind("DBIRTH", NODE, Some("d2"), BIRTH);
    (n, d1, d2)
}

/// Every message the host received is in the edge node's sequence (seq as expected), and
/// none was undecodable.
fn assert_clean(host: &mut SpbHost) {
    let out_of_order: Vec<String> = host
        .all()
        .iter()
        .filter(|m| matches!((m.seq, m.expected_seq), (Some(s), Some(e)) if s != e))
        .map(|m| format!("{} seq {:?}, expected {:?}", m.topic, m.seq, m.expected_seq))
        .collect();
    assert!(out_of_order.is_empty(), "seq gaps: {out_of_order:?}");
    let bad = host.undecodable().to_vec();
    assert!(bad.is_empty(), "the host could not decode: {bad:?}");
}

/// The first DDATA of `device` since the mark with a metric known as `name` that satisfies
/// `pred`; that metric.
fn ddata_metric(
    host: &mut SpbHost,
    device: &str,
    name: &str,
    mut pred: impl FnMut(&Metric) -> bool,
) -> Metric {
    let what = format!("DDATA of {device} with {name} as wanted");
    let m = host.expect(&what, WAIT, |m| {
        m.is("DDATA", Some(device)) && m.metric(name).is_some_and(&mut pred)
    });
    m.get(name).clone()
}

/// The write result metric's text for `point` in the next DDATA of d1 that has one.
fn write_result(host: &mut SpbHost, point: &str) -> String {
    let name = format!("{point}/Write Result");
    ddata_metric(host, "d1", &name, |_| true).text().to_owned()
}

/// NBIRTH and every DBIRTH, decoded by the host: the node's metrics with their datatypes;
/// every point with the simulator's value in the datatype of its table entry, and the table's
/// unit, range, names, parameter and index as properties; the drive's status; every metric with
/// an alias unique across the edge node; the sequence numbers in order.
#[test]
fn births_carry_the_simulators_values_and_the_tables_properties() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let ramp1 = read_raw(&sim, 1, "P130");
    let p131 = read_raw(&sim, 1, "P131");
    let offset = read_raw(&sim, 1, "P225");
    let ramp2 = read_raw(&sim, 2, "P130");
    let state = temp_dir("state");
    let start = now_ms();
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (n, d1, d2) = births(&mut host, &mut gw);

    // NBIRTH: seq 0, bdSeq 0 for a new state directory, the node's own metrics.
    assert_eq!((n.seq, n.group.as_str()), (Some(0), GROUP));
    assert_eq!(bd_seq(&n), 0, "a fresh state directory starts at bdSeq 0");
    let rebirth = n.get("Node Control/Rebirth");
    assert_eq!(
        (rebirth.datatype.as_str(), rebirth.boolean()),
        ("Boolean", false)
    );
    for (name, datatype) in [
        ("Buses/ml/Utilisation", "Double"),
        ("Buses/ml/Demand", "Double"),
        ("Buses/ml/Transactions", "UInt64"),
        ("Buses/ml/Timeouts", "UInt64"),
    ] {
        let m = n.get(name);
        assert_eq!(m.datatype, datatype, "{m:?}");
        assert!(!m.is_null && m.value.is_number(), "{m:?}");
    }
    let demand = n.get("Buses/ml/Demand").float();
    assert!(
        demand > 0.0 && demand < 1.0,
        "three 200 ms polls fit the bus: {demand}"
    );
    assert!(n.timestamp.is_some_and(|t| t >= start), "{n:?}");

    // Aliases: one on every device metric, none used twice on the edge node.
    let mut aliases: BTreeMap<u64, String> = BTreeMap::new();
    for b in [&n, &d1, &d2] {
        for m in &b.metrics {
            let name = format!(
                "{}:{}",
                b.device.as_deref().unwrap_or("node"),
                m.known_name().unwrap()
            );
            if b.device.is_some() {
                assert!(m.alias.is_some(), "no alias on {name}");
            }
            if let Some(a) = m.alias
                && let Some(other) = aliases.insert(a, name.clone())
            {
                panic!("alias {a} twice on the edge node: {other} and {name}");
            }
        }
    }

    // d1: the simulator's values, each in the datatype its table entry gives.
    let ramp = d1.get("ramp");
    assert_eq!(
        ramp.datatype, "Double",
        "P130 is scaled (ms to s): {ramp:?}"
    );
    assert_eq!(ramp.float(), ramp1 as f64 * 1e-3, "{ramp:?}");
    assert_eq!(d1.get("P131").datatype, "Double");
    assert_eq!(d1.get("P131").float(), p131 as f64 * 1e-3);
    let off = d1.get("offset");
    let (lo, hi) = integer_range(&off.datatype)
        .unwrap_or_else(|| panic!("P225 is unscaled: an integer datatype, not {off:?}"));
    assert!(
        lo <= -32767 && hi >= 32767,
        "{} holds P225's range -32767…32767",
        off.datatype
    );
    assert_eq!(off.int(), offset, "the raw value, unscaled: {off:?}");
    assert_eq!(d1.get("Status/State").text(), "online");
    assert_eq!(d1.get("Status/Fault").text(), "");
    assert!(d1.metric("ramp/Write Result").is_some(), "writable: {d1:?}");
    assert!(
        d1.metric("offset/Write Result").is_some(),
        "writable: {d1:?}"
    );
    assert!(d1.metric("P131/Write Result").is_none(), "not writable");
    assert_eq!(d1.get("ramp/Write Result").datatype, "String");

    // The table's facts as properties.
    let t = table("P130");
    let p = |m: &Metric, key: &str| -> (Value, String) {
        let (v, dt) = m
            .property(key)
            .unwrap_or_else(|| panic!("{:?} has no property {key}: {m:?}", m.known_name()));
        (v.clone(), dt.to_owned())
    };
    let s = |v: &str| (json!(v), "String".to_owned());
    assert_eq!(p(ramp, "engUnit"), s("s"));
    assert_eq!(p(ramp, "engLow"), (json!(0.0), "Double".to_owned()));
    assert_eq!(p(ramp, "engHigh"), (json!(2000.0), "Double".to_owned()));
    assert_eq!(p(ramp, "writable"), (json!(true), "Boolean".to_owned()));
    assert_eq!(p(ramp, "nameDe"), s(t["name_de"].as_str().unwrap()));
    assert_eq!(p(ramp, "nameEn"), s(t["name_en"].as_str().unwrap()));
    assert_eq!(p(ramp, "parameter"), s("P130"));
    assert_eq!(p(ramp, "index"), (json!(8470), "UInt64".to_owned()));
    for key in ["set", "element", "dataSet"] {
        assert!(
            ramp.property(key).is_none(),
            "MOVIDRIVE P130 has no {key}: {ramp:?}"
        );
    }
    assert_eq!(
        p(d1.get("P131"), "writable"),
        (json!(false), "Boolean".to_owned())
    );
    assert_eq!(p(d1.get("P131"), "parameter"), s("P131"));
    assert_eq!(p(off, "engUnit"), s("Inc"));
    assert_eq!(p(off, "engLow"), (json!(-32767.0), "Double".to_owned()));
    assert_eq!(p(off, "engHigh"), (json!(32767.0), "Double".to_owned()));
    assert_eq!(p(off, "index"), (json!(8506), "UInt64".to_owned()));

    // d2: its own birth, its own value.
    assert_eq!(d2.get("ramp").float(), ramp2 as f64 * 1e-3);
    assert_eq!(
        p(d2.get("ramp"), "writable"),
        (json!(false), "Boolean".to_owned())
    );
    assert!(d2.metric("ramp/Write Result").is_none());
    assert_eq!(d2.get("Status/State").text(), "online");
    for m in d1.metrics.iter().chain(&d2.metrics) {
        assert!(m.datatype_sent, "a birth carries every datatype: {m:?}");
        assert!(
            m.timestamp.is_none_or(|t| t >= start && t <= now_ms()),
            "{m:?}"
        );
    }
    drop(gw);
    assert_clean(&mut host);
}

/// Nothing unchanged is sent again (by exception); a value changed by someone else (a JSON
/// `set`) arrives as a DDATA by alias only, with a timestamp of its read.
#[test]
fn ddata_follows_a_changed_value_by_alias_only() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (_, d1, _) = births(&mut host, &mut gw);
    let alias = d1.get("ramp").alias.unwrap();

    // Polled every 200 ms, unchanged: no DDATA with it for a while.
    host.mark();
    std::thread::sleep(Duration::from_millis(1500));
    let repeated: Vec<Msg> = host
        .since_mark()
        .iter()
        .filter(|m| m.is("DDATA", Some("d1")) && m.metric("ramp").is_some())
        .cloned()
        .collect();
    assert!(
        repeated.is_empty(),
        "an unchanged value sent again: {repeated:?}"
    );

    // Changed through the JSON topics (json defaults to on beside Sparkplug).
    let set = json!({"value": 4.5, "ts": now_ms()}).to_string();
    let sent = now_ms();
    host.publish_command(json!({
        "cmd": "raw", "topic": "drivebus/gw/ml/d1/ramp/set",
        "hex": set.bytes().map(|b| format!("{b:02x}")).collect::<String>(), "qos": 1
    }))
    .unwrap();
    let m = ddata_metric(&mut host, "d1", "ramp", |m| m.value == json!(4.5));
    assert_eq!(m.name, None, "DATA carries the alias only: {m:?}");
    assert_eq!(m.alias, Some(alias));
    assert_eq!(m.datatype, "Double");
    assert!(
        m.timestamp
            .is_some_and(|t| t + 1000 >= sent && t <= now_ms()),
        "the time of the bus read: {m:?}"
    );
    for d in host.since_mark().iter().filter(|m| m.kind == "DDATA") {
        for x in &d.metrics {
            assert!(x.name.is_none() && x.alias.is_some(), "{}: {x:?}", d.topic);
        }
    }
    drop(gw);
    assert_clean(&mut host);
}

/// DCMD by name and by alias, with and without datatypes: written, the read-back value and
/// `written` come as DDATA, and the simulator holds it. Refused ones (out of range, in the
/// table's gap, too wide, stale, not writable) write nothing and say why.
#[test]
fn a_dcmd_is_written_and_read_back_and_a_refused_one_writes_nothing() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let p131 = read_raw(&sim, 1, "P131");
    let ramp2 = read_raw(&sim, 2, "P130");
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (_, d1, _) = births(&mut host, &mut gw);
    let ramp_alias = d1.get("ramp").alias.unwrap();
    let offset_alias = d1.get("offset").alias.unwrap();

    // By name, with its datatype.
    host.mark();
    host.dcmd(
        NODE,
        "d1",
        json!([{"name": "ramp", "datatype": "Double", "value": 3.5}]),
    );
    assert_eq!(write_result(&mut host, "ramp"), "written");
    ddata_metric(&mut host, "d1", "ramp", |m| m.value == json!(3.5));
    // By alias, without a datatype (the host encodes it as the birth's).
    host.mark();
    host.dcmd(NODE, "d1", json!([{"alias": offset_alias, "value": -20}]));
    assert_eq!(write_result(&mut host, "offset"), "written");
    ddata_metric(&mut host, "d1", "offset", |m| m.value == json!(-20));
    // By name without a datatype, and by alias with one.
    host.mark();
    host.dcmd(NODE, "d1", json!([{"name": "ramp", "value": 4.0}]));
    ddata_metric(&mut host, "d1", "ramp", |m| m.value == json!(4.0));
    host.mark();
    host.dcmd(
        NODE,
        "d1",
        json!([{"alias": ramp_alias, "datatype": "Double", "value": 3.0}]),
    );
    ddata_metric(&mut host, "d1", "ramp", |m| m.value == json!(3.0));

    // Refused: out of the table's range, inside its gap (-10…10 is not allowed), wider than
    // the point, stale (sent a minute ago). A written value between two refusals of one point
    // makes each refusal a change of its Write Result.
    host.mark();
    host.dcmd(
        NODE,
        "d1",
        json!([{"name": "ramp", "datatype": "Double", "value": 99999.0}]),
    );
    let r = write_result(&mut host, "ramp");
    assert!(r.starts_with("refused "), "out of range: {r}");
    host.mark();
    host.dcmd(NODE, "d1", json!([{"name": "offset", "value": 5}]));
    let r = write_result(&mut host, "offset");
    assert!(r.starts_with("refused "), "in the table's gap: {r}");
    host.mark();
    host.dcmd(NODE, "d1", json!([{"name": "offset", "value": -30}]));
    assert_eq!(write_result(&mut host, "offset"), "written");
    host.mark();
    host.dcmd(
        NODE,
        "d1",
        json!([{"name": "offset", "datatype": "Int64", "value": 1u64 << 40}]),
    );
    let r = write_result(&mut host, "offset");
    assert!(r.starts_with("refused "), "2^40 is not cut to fit: {r}");
    host.mark();
    host.publish_command(json!({
        "cmd": "DCMD", "node": NODE, "device": "d1", "timestamp": now_ms() - 60_000,
        "metrics": [{"name": "ramp", "datatype": "Double", "value": 7.5}]
    }))
    .unwrap();
    let r = write_result(&mut host, "ramp");
    assert!(r.starts_with("refused stale"), "a minute old: {r}");
    // Not writable (P131 of d1, ramp of d2): no write.
    host.dcmd(
        NODE,
        "d1",
        json!([{"name": "P131", "datatype": "Double", "value": 9.0}]),
    );
    host.dcmd(
        NODE,
        "d2",
        json!([{"name": "ramp", "datatype": "Double", "value": 9.0}]),
    );
    // Nothing of the refused ones reached the drives: a value published since is the one
    // they held (an outcome may repeat it, it must not change it).
    std::thread::sleep(Duration::from_millis(1000));
    let held = |device: &str, name: &str| -> Option<Value> {
        match (device, name) {
            ("d1", "ramp") => Some(json!(3.0)),
            ("d1", "P131") => Some(json!(p131 as f64 * 1e-3)),
            ("d2", "ramp") => Some(json!(ramp2 as f64 * 1e-3)),
            _ => None,
        }
    };
    let moved: Vec<String> = host
        .since_mark()
        .iter()
        .filter(|m| m.kind == "DDATA")
        .flat_map(|m| {
            let device = m.device.clone().unwrap_or_default();
            m.metrics
                .iter()
                .filter(move |x| {
                    held(&device, x.known_name().unwrap_or("")).is_some_and(|v| v != x.value)
                })
                .map(move |x| format!("{}: {:?} = {}", m.topic, x.known_name(), x.value))
        })
        .collect();
    assert!(
        moved.is_empty(),
        "a refused DCMD changed a value: {moved:?}"
    );

    assert!(gw.stop_with("TERM").success(), "{}", gw.log());
    assert_eq!(read_raw(&sim, 1, "P130"), 3000, "the last written ramp");
    assert_eq!(read_raw(&sim, 1, "P225"), -30, "the last written offset");
    assert_eq!(read_raw(&sim, 1, "P131"), p131, "not writable: unchanged");
    assert_eq!(read_raw(&sim, 2, "P130"), ramp2, "not writable: unchanged");
    assert_clean(&mut host);
}

/// `Node Control/Rebirth` = true in an NCMD: NBIRTH again at seq 0 with the same bdSeq, then
/// every DBIRTH.
#[test]
fn a_rebirth_request_is_answered_with_every_birth() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (n, d1, _) = births(&mut host, &mut gw);
    host.mark();
    host.rebirth(NODE);
    let (again, d1_again, d2_again) = births(&mut host, &mut gw);
    assert_eq!(again.seq, Some(0));
    assert_eq!(
        bd_seq(&again),
        bd_seq(&n),
        "the same session: the same bdSeq"
    );
    assert!(!again.get("Node Control/Rebirth").boolean());
    assert_eq!(d1_again.get("ramp").value, d1.get("ramp").value);
    assert_eq!(d2_again.get("Status/State").text(), "online");
    assert!(host.since_mark().iter().all(|m| m.kind != "NDEATH"));
    drop(gw);
    assert_clean(&mut host);
}

/// NDEATH with the birth's bdSeq on a clean stop (SIGTERM) and as the will on a kill
/// (SIGKILL); bdSeq increases by one across each restart (kept in the state directory).
#[test]
fn ndeath_carries_the_births_bdseq_which_increases_across_restarts() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (n, _, _) = births(&mut host, &mut gw);
    let first = bd_seq(&n);

    host.mark();
    assert!(gw.stop_with("TERM").success(), "{}", gw.log());
    let death = host.expect_kind("NDEATH", NODE, None, WAIT);
    assert_eq!(bd_seq(&death), first, "NDEATH at a clean stop");

    host.mark();
    gw.spawn(&[]);
    let (n, _, _) = births(&mut host, &mut gw);
    let second = bd_seq(&n);
    assert_eq!(second, (first + 1) % 256, "bdSeq across a restart");

    host.mark();
    gw.stop_with("KILL");
    let will = host.expect_kind("NDEATH", NODE, None, WAIT);
    assert_eq!(bd_seq(&will), second, "the will of the killed gateway");

    host.mark();
    gw.spawn(&[]);
    let (n, _, _) = births(&mut host, &mut gw);
    assert_eq!(bd_seq(&n), (second + 1) % 256, "bdSeq after a kill");
    drop(gw);
    assert_clean(&mut host);
}

/// Issue 22, item 2: SIGHUP with a changed config on the same connection: a DDEATH for a drive
/// the config removed (and one whose bus it restarts), then every birth again with the same
/// bdSeq (NBIRTH at seq 0): the new drive's DBIRTH, the kept drive's with its values; no NDEATH.
#[test]
fn a_reload_kills_a_removed_drive_and_is_born_again_with_a_new_one() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    let (n, _, _) = births(&mut host, &mut gw);
    host.mark();
    // d2 goes (its bus `ml` changes: d1 is restarted with it); a simulated bus with `fan` comes.
    let two = config(&broker, &sim, "")
        .split("[[bus.drive]]\nname = \"d2\"")
        .next()
        .unwrap()
        .to_owned()
        + "[[bus]]\nname = \"sim\"\nprotocol = \"modbus-rtu\"\nsimulate = true\n\
           [[bus.drive]]\nname = \"fan\"\naddress = 1\n\
           [[bus.drive.param]]\nparam = \"241\"\nname = \"frequency\"\nperiod = \"200ms\"\n";
    std::fs::write(gw.dir.join("plant.toml"), two).unwrap();
    gw.signal("HUP");
    let d2 = host.expect_kind("DDEATH", NODE, Some("d2"), WAIT);
    assert!(d2.seq.is_some());
    let again = host.expect_kind("NBIRTH", NODE, None, BIRTH);
    assert_eq!(again.seq, Some(0));
    assert_eq!(
        bd_seq(&again),
        bd_seq(&n),
        "the same session: the same bdSeq"
    );
    let d1 = host.expect_kind("DBIRTH", NODE, Some("d1"), BIRTH);
    assert!(d1.metric("ramp").is_some_and(|m| !m.is_null), "{d1:?}");
    let fan = host.expect_kind("DBIRTH", NODE, Some("fan"), BIRTH);
    assert_eq!(fan.get("Status/State").text(), "online");
    assert!(
        fan.metric("frequency").is_some_and(|m| !m.is_null),
        "{fan:?}"
    );
    let since = host.since_mark().to_vec();
    assert!(since.iter().all(|m| m.kind != "NDEATH"), "{since:?}");
    assert!(
        !since.iter().any(|m| m.is("DBIRTH", Some("d2"))),
        "the removed drive is not born again"
    );
    assert!(gw.log().contains("born again"), "{}", gw.log());
    drop(gw);
    assert_clean(&mut host);
}

/// Drives that stop answering (the simulator held with SIGSTOP) get a DDEATH each, the node
/// stays; when they answer again (SIGCONT), a DBIRTH each.
#[test]
fn a_drive_that_stops_answering_gets_ddeath_and_dbirth_when_it_answers() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(&config(&broker, &sim, ""), state.to_path_buf());
    births(&mut host, &mut gw);

    host.mark();
    signal(sim.pid(), "STOP");
    let d1 = host.expect_kind("DDEATH", NODE, Some("d1"), WAIT);
    let d2 = host.expect_kind("DDEATH", NODE, Some("d2"), WAIT);
    assert!(d1.seq.is_some() && d2.seq.is_some());
    assert!(
        host.since_mark().iter().all(|m| m.kind != "NDEATH"),
        "the node stays"
    );

    host.mark();
    signal(sim.pid(), "CONT");
    let b1 = host.expect_kind("DBIRTH", NODE, Some("d1"), WAIT);
    let b2 = host.expect_kind("DBIRTH", NODE, Some("d2"), WAIT);
    assert_eq!(b1.get("Status/State").text(), "online");
    assert_eq!(b2.get("Status/State").text(), "online");
    assert!(b1.metric("ramp").is_some_and(|m| !m.is_null));
    drop(gw);
    assert_clean(&mut host);
}

/// With `primary_host_id`: no NBIRTH until the host's STATE says online; STATE offline ends
/// the session (NDEATH); online again, a new session with the next bdSeq.
#[test]
fn with_a_primary_host_the_node_waits_for_it_and_follows_it_offline() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let state = temp_dir("state");
    let mut gw = Gateway::start_with_state(
        &config(&broker, &sim, "primary_host_id = \"scada\""),
        state.to_path_buf(),
    );
    // Connected and waiting: the broker logs its subscription to the host's STATE.
    let log = broker.dir.join("mosquitto.log");
    let deadline = Instant::now() + BIRTH;
    while !std::fs::read_to_string(&log)
        .unwrap_or_default()
        .contains("spBv1.0/STATE/scada")
    {
        gw.assert_running("subscribing to STATE");
        assert!(
            Instant::now() < deadline,
            "the gateway did not subscribe to spBv1.0/STATE/scada:\n{}",
            gw.log()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let early = host.wait_for(Duration::from_secs(2), |m| m.kind == "NBIRTH");
    assert!(
        early.is_none(),
        "an NBIRTH before the primary host is online: {early:?}"
    );

    host.state("scada", true);
    let (n, _, _) = births(&mut host, &mut gw);
    let first = bd_seq(&n);

    host.mark();
    host.state("scada", false);
    let death = host.expect_kind("NDEATH", NODE, None, WAIT);
    assert_eq!(bd_seq(&death), first);
    let early = host.wait_for(Duration::from_secs(3), |m| m.kind == "NBIRTH");
    assert!(
        early.is_none(),
        "an NBIRTH while the primary host is offline: {early:?}"
    );

    host.mark();
    host.state("scada", true);
    let (n, _, _) = births(&mut host, &mut gw);
    assert_eq!(bd_seq(&n), (first + 1) % 256, "a new session");
    drop(gw);
    assert_clean(&mut host);
}

/// `json = false`: the plant is on Sparkplug only; no JSON value or status topics.
#[test]
fn json_false_publishes_sparkplug_only() {
    let Some((broker, mut host, sim)) = setup() else {
        return;
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let mut json_client = rt.block_on(mosquitto::TestClient::connect(
        broker.client_options("json-watch", None),
        &["drivebus/#"],
    ));
    let state = temp_dir("state");
    let mut gw =
        Gateway::start_with_state(&config(&broker, &sim, "json = false"), state.to_path_buf());
    births(&mut host, &mut gw);
    let seen = rt.block_on(json_client.collect(Duration::from_secs(2)));
    let points: Vec<&str> = seen
        .iter()
        .map(|p| p.topic.as_str())
        .filter(|t| t.starts_with("drivebus/gw/ml/"))
        .collect();
    assert!(
        points.is_empty(),
        "JSON topics with json = false: {points:?}"
    );
    drop(gw);
    assert_clean(&mut host);
}
