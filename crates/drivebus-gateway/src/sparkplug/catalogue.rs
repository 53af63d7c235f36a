//! The metrics the edge node reports, built once from the plant: names, aliases, Sparkplug
//! datatypes from the parameter tables, and the properties of each point's birth.
//!
//! Aliases are unique across the node and its devices (the node's metrics first, then each
//! drive's in plant order), so a host can resolve any alias of a DATA or CMD message.

use std::collections::HashMap;

use sparkplug_b::props::PropertySetBuilder;
use sparkplug_b::{DataType, PropertySet};

use crate::config::{Plant, Point};

/// The node control metric a host sets to ask for every birth again.
pub const REBIRTH: &str = sparkplug_b::node::REBIRTH;

/// What one of the node's own metrics shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeKind {
    /// The birth/death sequence number of the connection.
    BdSeq,
    /// `Node Control/Rebirth` (false; a host writes true).
    Rebirth,
    /// A bus's utilisation (0–1).
    Utilisation(usize),
    /// A bus's demand (0–1).
    Demand(usize),
    /// A bus's transactions.
    Transactions(usize),
    /// A bus's transactions without an answer.
    Timeouts(usize),
    /// A bus's repeated attempts.
    Retries(usize),
    /// A bus's late polls.
    LatePolls(usize),
}

/// One of the node's metrics.
#[derive(Debug, Clone)]
pub struct NodeMetric {
    /// Its name.
    pub name: String,
    /// Its alias (none for `Node Control/Rebirth`: a host asks for it by name, and the
    /// specification forbids it one).
    pub alias: Option<u64>,
    /// Its datatype.
    pub datatype: DataType,
    /// What it shows.
    pub kind: NodeKind,
}

/// A point's metric.
#[derive(Debug, Clone)]
pub struct PointMetric {
    /// The point's index in its drive (also its index in [`Device::points`]: every point of
    /// the drive is a metric, in the config's order).
    pub point: usize,
    /// The metric's name: the point's topic name.
    pub name: String,
    /// Its alias.
    pub alias: u64,
    /// Its datatype: the parameter's integer type where the value is the raw one, else Double.
    pub datatype: DataType,
    /// The value is the parameter's physical one (scaled from the raw value).
    pub scaled: bool,
    /// Decimals of a scaled value.
    pub decimals: u8,
    /// Read on a period (not only after writes).
    pub polled: bool,
    /// `<point>/Write Result` of a writable point: its alias.
    pub result_alias: Option<u64>,
    /// The birth's properties.
    pub properties: PropertySet,
    /// The parameter (its table entry's scaling).
    pub target: drive_client::target::Target,
}

impl PointMetric {
    /// A scaled point's value: the raw one in the parameter's unit, rounded to its decimals.
    pub fn physical(&self, raw: i64) -> f64 {
        match self.target.param {
            Some(p) => {
                let f = drive_profile::scaling::pow10(i32::from(self.decimals));
                (p.to_physical(raw) * f).round() / f
            }
            None => raw as f64,
        }
    }
}

/// What a device metric a command names is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceRef {
    /// A point (its index in [`Device::points`]).
    Point(usize),
    /// A point's write result.
    WriteResult(usize),
    /// `Status/State`.
    State,
    /// `Status/Fault`.
    Fault,
}

/// One drive as a Sparkplug device.
#[derive(Debug, Clone)]
pub struct Device {
    /// Its bus.
    pub bus: usize,
    /// Its index in the bus.
    pub drive: usize,
    /// The device id: the drive's config name.
    pub id: String,
    /// Its points' metrics.
    pub points: Vec<PointMetric>,
    /// `Status/State`'s alias.
    pub state_alias: u64,
    /// `Status/Fault`'s alias.
    pub fault_alias: u64,
    by_name: HashMap<String, DeviceRef>,
    by_alias: HashMap<u64, DeviceRef>,
}

impl Device {
    /// The metric a command names (by name, else by alias).
    pub fn find(&self, name: Option<&str>, alias: Option<u64>) -> Option<DeviceRef> {
        match name {
            Some(n) => self.by_name.get(n).copied(),
            None => alias.and_then(|a| self.by_alias.get(&a).copied()),
        }
    }
}

/// Every metric of the node.
#[derive(Debug, Clone)]
pub struct Catalogue {
    /// The node's own metrics.
    pub node: Vec<NodeMetric>,
    /// The drives.
    pub devices: Vec<Device>,
    by_drive: HashMap<(usize, usize), usize>,
    by_id: HashMap<String, usize>,
}

/// `Status/State`.
pub const STATE: &str = "Status/State";
/// `Status/Fault`.
pub const FAULT: &str = "Status/Fault";
/// The suffix of a writable point's result metric.
pub const WRITE_RESULT: &str = "/Write Result";

impl Catalogue {
    /// The metrics of `plant`.
    pub fn new(plant: &Plant) -> Catalogue {
        let mut next = 0u64;
        let mut alias = || {
            let a = next;
            next += 1;
            a
        };
        let mut node = vec![
            NodeMetric {
                name: sparkplug_b::node::BD_SEQ.to_owned(),
                alias: Some(alias()),
                datatype: DataType::Int64,
                kind: NodeKind::BdSeq,
            },
            NodeMetric {
                name: REBIRTH.to_owned(),
                alias: None,
                datatype: DataType::Boolean,
                kind: NodeKind::Rebirth,
            },
        ];
        for (b, bus) in plant.buses.iter().enumerate() {
            for (what, datatype, kind) in [
                ("Utilisation", DataType::Double, NodeKind::Utilisation(b)),
                ("Demand", DataType::Double, NodeKind::Demand(b)),
                ("Transactions", DataType::UInt64, NodeKind::Transactions(b)),
                ("Timeouts", DataType::UInt64, NodeKind::Timeouts(b)),
                ("Retries", DataType::UInt64, NodeKind::Retries(b)),
                ("Late polls", DataType::UInt64, NodeKind::LatePolls(b)),
            ] {
                node.push(NodeMetric {
                    name: format!("Buses/{}/{what}", bus.name),
                    alias: Some(alias()),
                    datatype,
                    kind,
                });
            }
        }
        let mut devices = Vec::new();
        let mut by_drive = HashMap::new();
        let mut by_id = HashMap::new();
        for (b, bus) in plant.buses.iter().enumerate() {
            for (d, drive) in bus.drives.iter().enumerate() {
                let mut by_name = HashMap::new();
                let mut by_alias = HashMap::new();
                let state_alias = alias();
                let fault_alias = alias();
                by_name.insert(STATE.to_owned(), DeviceRef::State);
                by_name.insert(FAULT.to_owned(), DeviceRef::Fault);
                by_alias.insert(state_alias, DeviceRef::State);
                by_alias.insert(fault_alias, DeviceRef::Fault);
                let mut points = Vec::new();
                for (p, point) in drive.points.iter().enumerate() {
                    let (datatype, scaled, decimals) = datatype_of(point);
                    let a = alias();
                    let result_alias = point.writable.then(&mut alias);
                    let ix = points.len();
                    by_name.insert(point.name.clone(), DeviceRef::Point(ix));
                    by_alias.insert(a, DeviceRef::Point(ix));
                    if let Some(r) = result_alias {
                        by_name.insert(
                            format!("{}{WRITE_RESULT}", point.name),
                            DeviceRef::WriteResult(ix),
                        );
                        by_alias.insert(r, DeviceRef::WriteResult(ix));
                    }
                    points.push(PointMetric {
                        point: p,
                        name: point.name.clone(),
                        alias: a,
                        datatype,
                        scaled,
                        decimals,
                        polled: point.period.is_some(),
                        result_alias,
                        properties: properties(point),
                        target: point.target,
                    });
                }
                by_drive.insert((b, d), devices.len());
                by_id.insert(drive.name.clone(), devices.len());
                devices.push(Device {
                    bus: b,
                    drive: d,
                    id: drive.name.clone(),
                    points,
                    state_alias,
                    fault_alias,
                    by_name,
                    by_alias,
                });
            }
        }
        Catalogue {
            node,
            devices,
            by_drive,
            by_id,
        }
    }

    /// The device of a bus's drive.
    pub fn device_of(&self, bus: usize, drive: usize) -> Option<usize> {
        self.by_drive.get(&(bus, drive)).copied()
    }

    /// The device of an id.
    pub fn device_named(&self, id: &str) -> Option<usize> {
        self.by_id.get(id).copied()
    }

    /// The node metric of a name (by name, else by alias).
    pub fn node_metric(&self, name: Option<&str>, alias: Option<u64>) -> Option<&NodeMetric> {
        match name {
            Some(n) => self.node.iter().find(|m| m.name == n),
            None => alias.and_then(|a| self.node.iter().find(|m| m.alias == Some(a))),
        }
    }
}

/// A point's datatype: the integer type of its wire width and sign where its value is the raw
/// one (scale 1, no offset, no decimals), else Double; whether it is scaled; its decimals.
pub fn datatype_of(point: &Point) -> (DataType, bool, u8) {
    let Some(p) = point.target.param else {
        // Outside the table: 32 bits of either sign.
        return (
            sparkplug_b::value::integer_type(
                drive_profile::param::WIRE_32.0,
                drive_profile::param::WIRE_32.1,
            ),
            false,
            0,
        );
    };
    let identity = p.decimals() == 0
        && [-1i64, 0, 1, 1000]
            .iter()
            .all(|&r| p.to_physical(r) == r as f64);
    if !identity {
        return (DataType::Double, true, p.decimals());
    }
    let (wire_lo, wire_hi) = match point.width {
        Some(bonfiglioli_modbus::slave::Width::Word) => drive_profile::param::WIRE_16,
        Some(bonfiglioli_modbus::slave::Width::Long) => drive_profile::param::WIRE_32,
        None => p.wire_range(),
    };
    let bits16 = wire_hi <= i64::from(u16::MAX);
    // The sign the table's range gives; unknown: what the wire can carry of either sign.
    let (lo, hi) = match (p.raw_range(), bits16) {
        (Some((lo, _)), true) if lo < 0 => (i64::from(i16::MIN), i64::from(i16::MAX)),
        (Some(_), true) => (0, i64::from(u16::MAX)),
        (Some((lo, _)), false) if lo < 0 => (i64::from(i32::MIN), i64::from(i32::MAX)),
        (Some(_), false) => (0, i64::from(u32::MAX)),
        (None, _) => (wire_lo, wire_hi),
    };
    (sparkplug_b::value::integer_type(lo, hi), false, 0)
}

/// A point's birth properties: unit, range, writable, the manual's names, the parameter and
/// its selector.
fn properties(point: &Point) -> PropertySet {
    let t = &point.target;
    let mut b = PropertySetBuilder::default()
        .text("parameter", &t.label())
        .uint("index", u64::from(t.index))
        .bool("writable", point.writable);
    if let Some(p) = t.param {
        let unit = p.unit();
        if !unit.is_empty() && unit != "-" {
            b = b.text("engUnit", unit);
        }
        if let Some((lo, hi)) = p.raw_range() {
            b = b
                .double("engLow", p.to_physical(lo))
                .double("engHigh", p.to_physical(hi));
        }
    }
    if let Some((de, en)) = t.names() {
        b = b.text("nameDe", de).text("nameEn", en);
    }
    if let serde_json::Value::Object(sel) = t.selector_json() {
        for (k, v) in sel {
            let key = match k.as_str() {
                "dataset" => "dataSet",
                "array" => "element",
                other => other,
            };
            b = match v {
                serde_json::Value::Number(n) => b.uint(key, n.as_u64().unwrap_or(0)),
                serde_json::Value::String(s) => b.text(key, &s),
                _ => b,
            };
        }
    }
    if point.eeprom {
        b = b.bool("eeprom", true);
    }
    b.build()
}
