//! The edge node's session as a state machine without I/O: what the broker connection, the
//! bus tasks and the clock tell it goes in, the messages to publish and the writes to run
//! come out ([`Out`]). The task in [`super`] does the I/O; the tests drive this directly.
//!
//! A session (Sparkplug B 3.0, chapter 5):
//!
//! 1. Connected with the NDEATH of this connection's `bdSeq` as the will: subscribe to NCMD,
//!    DCMD (and the primary host's STATE).
//! 2. Every subscription acknowledged (and, with a primary host, its STATE online): NBIRTH with
//!    `seq` 0 and the same `bdSeq`, then a DBIRTH for every drive not timed out.
//! 3. Born: DDATA of the values that changed (by exception, aliases only), NDATA of the bus
//!    figures that changed, DDEATH when a drive times out and DBIRTH when it answers again;
//!    DCMD writes go to the bus, their outcome comes back as DDATA; NCMD `Node Control/Rebirth`
//!    sends every birth again.
//! 4. The primary host offline (its STATE not older than its last online): NDEATH, disconnect,
//!    and back to 1 at the next connection. A clean stop: NDEATH, disconnect.

use std::time::Duration;

use sparkplug_b::node::{HostState, PrimaryHost};
use sparkplug_b::seq::Seq;
use sparkplug_b::topic::{MessageType, Topic};
use sparkplug_b::value::{self, Number, Value};
use sparkplug_b::{DataType, Metric, Payload};

use super::catalogue::{Catalogue, DeviceRef, FAULT, NodeKind, STATE, WRITE_RESULT};
use crate::config::{Plant, Sparkplug};
use crate::model::{BusFigures, DriveStatus, Reconfig, SetOutcome, SetValue, Update};
use crate::mqtt::MAX_SET_FUTURE;

/// What the session asks its task to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Out {
    /// Publish a message.
    Publish(Message),
    /// Subscribe (QoS 1).
    Subscribe(String),
    /// Disconnect (after the messages before it).
    Disconnect,
    /// Write a point through its bus task's guard; the outcome goes to
    /// [`Node::write_done`].
    Write {
        /// The device.
        device: usize,
        /// The point's index in the device's metrics.
        point: usize,
        /// The value.
        value: SetValue,
        /// How long it may wait for the bus.
        max_age: Duration,
    },
}

/// A message to publish.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    /// Topic.
    pub topic: String,
    /// Encoded payload.
    pub payload: Vec<u8>,
    /// QoS 1 (else 0).
    pub qos1: bool,
    /// Retained.
    pub retain: bool,
}

/// Where the session is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// No connection.
    Offline,
    /// Connected, subscriptions not yet acknowledged (how many are left).
    Subscribing(usize),
    /// Subscribed, the primary host not (yet) online.
    WaitingForHost,
    /// Ready to be born, waiting (since then, ms) for every drive's first answers, so that the
    /// births carry values rather than nulls; at most [`SETTLE_LIMIT`].
    Settling(u64),
    /// NBIRTH and the DBIRTHs are out.
    Born,
    /// NDEATH sent, disconnecting.
    Leaving,
}

/// A drive's state in the session.
#[derive(Debug, Clone, Default)]
struct DeviceState {
    /// Each point's latest value (raw) and when it was read (ms).
    values: Vec<Option<(i64, u64)>>,
    /// Each point's value last published (raw).
    published: Vec<Option<i64>>,
    /// Each point's write result text.
    results: Vec<Option<String>>,
    /// A refusal for a point without a result metric (a property of its next DATA).
    notes: Vec<Option<String>>,
    /// Points to publish at the next flush.
    dirty: Vec<bool>,
    /// Results to publish.
    dirty_results: Vec<bool>,
    /// The status changed.
    dirty_status: bool,
    /// The drive's status and when (ms).
    status: Option<(DriveStatus, u64)>,
    /// Its DBIRTH is out in this session (no DDEATH since).
    born: bool,
    /// It is in [`Node::changed`].
    queued: bool,
}

/// The edge node's session.
#[derive(Debug)]
pub struct Node {
    cat: Catalogue,
    group: String,
    node: String,
    primary_host: Option<String>,
    max_set_age: Duration,
    phase: Phase,
    bd_seq: u8,
    seq: Seq,
    /// The primary host as its STATE messages say.
    host: PrimaryHost,
    devices: Vec<DeviceState>,
    figures: Vec<Option<BusFigures>>,
    figures_published: Vec<Option<BusFigures>>,
    figures_dirty: Vec<bool>,
    /// The drives with something to publish at the next flush (a flush looks at these only:
    /// on 64 × 31 drives, looking at every drive took most of the node's time).
    changed: Vec<usize>,
}

/// The longest the births wait for the drives' first answers.
pub const SETTLE_LIMIT: Duration = Duration::from_secs(10);

/// The largest `Node Control`/DCMD metrics taken from one command (more are refused).
pub const MAX_COMMAND_METRICS: usize = 256;

impl Node {
    /// A session for `plant`'s `[sparkplug]`.
    pub fn new(plant: &Plant, sp: &Sparkplug) -> Node {
        let cat = Catalogue::new(plant);
        let devices = cat
            .devices
            .iter()
            .map(|d| {
                let n = d.points.len();
                DeviceState {
                    values: vec![None; n],
                    published: vec![None; n],
                    results: vec![None; n],
                    notes: vec![None; n],
                    dirty: vec![false; n],
                    dirty_results: vec![false; n],
                    ..DeviceState::default()
                }
            })
            .collect();
        let buses = plant.buses.len();
        Node {
            cat,
            group: sp.group_id.clone(),
            node: sp.edge_node_id.clone(),
            primary_host: sp.primary_host_id.clone(),
            max_set_age: plant.gateway.max_set_age,
            phase: Phase::Offline,
            bd_seq: 0,
            seq: Seq::default(),
            host: PrimaryHost::new(),
            devices,
            // Known from the start: the demand of the config's polls, nothing done yet.
            figures: plant
                .buses
                .iter()
                .map(|b| {
                    Some(BusFigures {
                        demand: crate::families::wire::demand(b),
                        ..BusFigures::default()
                    })
                })
                .collect(),
            figures_published: vec![None; buses],
            figures_dirty: vec![false; buses],
            changed: Vec::new(),
        }
    }

    /// Where the session is.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The metrics.
    pub fn catalogue(&self) -> &Catalogue {
        &self.cat
    }

    fn topic(&self, kind: MessageType, device: Option<&str>) -> String {
        Topic {
            group: &self.group,
            kind,
            node: &self.node,
            device,
        }
        .to_string()
    }

    fn encode(&mut self, payload: &Payload) -> Vec<u8> {
        // Into a buffer of its own: the client takes the bytes (no copy of a reused one).
        let mut buf = Vec::new();
        sparkplug_b::encode_into(payload, &mut buf);
        buf
    }

    /// The NDEATH of `bd_seq` (the will of the connection that uses it, and what a clean stop
    /// publishes): topic and payload.
    pub fn death(&self, bd_seq: u8, now_ms: u64) -> Message {
        Message {
            topic: self.topic(MessageType::NDeath, None),
            payload: death_payload(bd_seq, now_ms),
            qos1: true,
            retain: false,
        }
    }

    /// Every birth again (a rebirth asked for, or a message the client could not take), while
    /// born.
    pub fn rebirth(&mut self, now_ms: u64) -> Vec<Out> {
        if self.phase == Phase::Born {
            self.births(now_ms)
        } else {
            Vec::new()
        }
    }

    /// Connected with `bd_seq`'s NDEATH as the will: the subscriptions.
    pub fn connected(&mut self, bd_seq: u8) -> Vec<Out> {
        self.bd_seq = bd_seq;
        for d in &mut self.devices {
            d.born = false;
        }
        let mut out = vec![
            Out::Subscribe(self.topic(MessageType::NCmd, None)),
            Out::Subscribe(format!("{}/+", self.topic(MessageType::DCmd, None))),
        ];
        if let Some(h) = &self.primary_host {
            out.push(Out::Subscribe(sparkplug_b::topic::state_topic(h)));
        }
        self.phase = Phase::Subscribing(out.len());
        // The host's state is learned again on this connection (its retained STATE).
        self.host.reconnected();
        out
    }

    /// A subscription was acknowledged.
    pub fn subscribed(&mut self, now_ms: u64) -> Vec<Out> {
        match self.phase {
            Phase::Subscribing(n) if n > 1 => {
                self.phase = Phase::Subscribing(n - 1);
                Vec::new()
            }
            Phase::Subscribing(_) => {
                if self.primary_host.is_some() && !self.host.is_online() {
                    self.phase = Phase::WaitingForHost;
                    Vec::new()
                } else {
                    self.settle(now_ms)
                }
            }
            _ => Vec::new(),
        }
    }

    /// The connection is gone.
    pub fn disconnected(&mut self) {
        self.phase = Phase::Offline;
        for d in &mut self.devices {
            d.born = false;
        }
    }

    /// A clean stop: NDEATH and the disconnect, while connected.
    pub fn stopping(&mut self, now_ms: u64) -> Vec<Out> {
        if self.phase == Phase::Offline {
            return Vec::new();
        }
        self.phase = Phase::Leaving;
        let death = self.death(self.bd_seq, now_ms);
        vec![Out::Publish(death), Out::Disconnect]
    }

    /// Drive `d` has something to publish at the next flush.
    fn touch(&mut self, d: usize) {
        if let Some(s) = self.devices.get_mut(d)
            && !s.queued
        {
            s.queued = true;
            self.changed.push(d);
        }
    }

    /// Whether every drive has answered (or timed out) and every polled point of the drives
    /// that answer has a value.
    fn settled(&self) -> bool {
        self.cat
            .devices
            .iter()
            .zip(&self.devices)
            .all(|(dev, s)| match &s.status {
                None => false,
                Some((DriveStatus::Timeout, _)) => true,
                Some(_) => dev
                    .points
                    .iter()
                    .zip(&s.values)
                    .all(|(p, v)| !p.polled || v.is_some()),
            })
    }

    /// The births now if the drives have answered, else once they have ([`Node::flush`]).
    fn settle(&mut self, now_ms: u64) -> Vec<Out> {
        if self.settled() {
            self.births(now_ms)
        } else {
            self.phase = Phase::Settling(now_ms);
            Vec::new()
        }
    }

    /// NBIRTH (seq 0) and a DBIRTH for every drive not timed out.
    fn births(&mut self, now_ms: u64) -> Vec<Out> {
        self.seq = Seq::default();
        let mut metrics = Vec::with_capacity(self.cat.node.len());
        for m in &self.cat.node {
            let mut metric = Metric {
                name: Some(m.name.clone()),
                alias: m.alias,
                timestamp: Some(now_ms),
                ..Metric::default()
            };
            self.node_value(m.kind, m.datatype, &mut metric);
            metrics.push(metric);
        }
        self.figures_published.clone_from(&self.figures);
        self.figures_dirty.iter_mut().for_each(|x| *x = false);
        let payload = Payload {
            timestamp: Some(now_ms),
            metrics,
            seq: Some(self.seq.take()),
            ..Payload::default()
        };
        let mut out = vec![Out::Publish(Message {
            topic: self.topic(MessageType::NBirth, None),
            payload: self.encode(&payload),
            qos1: false,
            retain: false,
        })];
        self.phase = Phase::Born;
        for d in 0..self.devices.len() {
            if let Some(o) = self.device_birth(d, now_ms) {
                out.push(o);
            }
        }
        out
    }

    /// A node metric's current value into `metric`.
    fn node_value(&self, kind: NodeKind, datatype: DataType, metric: &mut Metric) {
        let f = |b: usize| self.figures.get(b).and_then(Option::as_ref);
        let v = match kind {
            NodeKind::BdSeq => Some(Value::Int(i64::from(self.bd_seq))),
            NodeKind::Rebirth => Some(Value::Bool(false)),
            NodeKind::Utilisation(b) => f(b).map(|f| Value::Double(share(f.utilisation))),
            NodeKind::Demand(b) => f(b).map(|f| Value::Double(share(f.demand))),
            NodeKind::Transactions(b) => f(b).map(|f| Value::UInt(f.transactions)),
            NodeKind::Timeouts(b) => f(b).map(|f| Value::UInt(f.timeouts)),
            NodeKind::Retries(b) => f(b).map(|f| Value::UInt(f.retries)),
            NodeKind::LatePolls(b) => f(b).map(|f| Value::UInt(f.late_polls)),
        };
        set_or_null(metric, datatype, v);
    }

    /// A drive's DBIRTH, unless it is timed out.
    fn device_birth(&mut self, d: usize, now_ms: u64) -> Option<Out> {
        let state = self.devices.get(d)?;
        if matches!(state.status, Some((DriveStatus::Timeout, _))) {
            return None;
        }
        let dev = self.cat.devices.get(d)?;
        let mut metrics = Vec::with_capacity(2 + 2 * dev.points.len());
        let (st, fault, st_at) = status_texts(state.status.as_ref());
        metrics.push(text_metric(
            Some(STATE),
            dev.state_alias,
            st,
            st_at.unwrap_or(now_ms),
        ));
        metrics.push(text_metric(
            Some(FAULT),
            dev.fault_alias,
            fault,
            st_at.unwrap_or(now_ms),
        ));
        for (ix, p) in dev.points.iter().enumerate() {
            let mut m = Metric {
                name: Some(p.name.clone()),
                alias: Some(p.alias),
                properties: Some(p.properties.clone()),
                ..Metric::default()
            };
            let v = state.values.get(ix).copied().flatten();
            point_value(p, v, now_ms, &mut m);
            metrics.push(m);
            if let Some(r) = p.result_alias {
                let text = state.results.get(ix).cloned().flatten();
                let name = format!("{}{WRITE_RESULT}", p.name);
                metrics.push(text_metric(Some(&name), r, text.as_deref(), now_ms));
            }
        }
        let payload = Payload {
            timestamp: Some(now_ms),
            metrics,
            seq: Some(self.seq.take()),
            ..Payload::default()
        };
        let topic = self.topic(MessageType::DBirth, Some(&dev.id.clone()));
        let state = self.devices.get_mut(d)?;
        state.born = true;
        state.dirty_status = false;
        for ix in 0..state.dirty.len() {
            if let Some(v) = state.values.get(ix).copied().flatten()
                && let Some(p) = state.published.get_mut(ix)
            {
                *p = Some(v.0);
            }
        }
        state.dirty.iter_mut().for_each(|x| *x = false);
        state.dirty_results.iter_mut().for_each(|x| *x = false);
        Some(Out::Publish(Message {
            topic,
            payload: self.encode(&payload),
            qos1: false,
            retain: false,
        }))
    }

    /// What a bus task reported.
    pub fn update(&mut self, u: &Update, now_ms: u64) -> Vec<Out> {
        match u {
            Update::Value {
                bus,
                drive,
                point,
                raw,
                at,
            } => {
                let Some(d) = self.cat.device_of(*bus, *drive) else {
                    return Vec::new();
                };
                // The catalogue has every point of the drive, in its order.
                let ix = *point;
                if let Some(s) = self.devices.get_mut(d) {
                    let ts = crate::mqtt::payload::millis(*at);
                    if let Some(v) = s.values.get_mut(ix) {
                        *v = Some((*raw, ts));
                    }
                    let changed = s.published.get(ix).copied().flatten() != Some(*raw);
                    if changed && let Some(x) = s.dirty.get_mut(ix) {
                        *x = true;
                        self.touch(d);
                    }
                }
                Vec::new()
            }
            Update::Status {
                bus,
                drive,
                status,
                at,
            } => {
                let Some(d) = self.cat.device_of(*bus, *drive) else {
                    return Vec::new();
                };
                self.status(d, status.clone(), crate::mqtt::payload::millis(*at), now_ms)
            }
            Update::Figures { bus, figures } => {
                if let Some(f) = self.figures.get_mut(*bus) {
                    *f = Some(figures.clone());
                }
                let changed =
                    self.figures_published.get(*bus).and_then(Option::as_ref) != Some(figures);
                if changed && let Some(x) = self.figures_dirty.get_mut(*bus) {
                    *x = true;
                }
                Vec::new()
            }
            // The task takes a reload itself ([`Node::reconfigure`]).
            Update::ProcessData { .. } | Update::Reconfigured(_) => Vec::new(),
        }
    }

    /// A reloaded config on the same connection (the same group, node, primary host and
    /// broker): the new plant's devices and metrics, with what is known of the drives on the
    /// buses that keep running. While born: a DDEATH for every device born in this session
    /// whose bus the new plant removed or restarts, then every birth again (NBIRTH with `seq` 0
    /// and the same `bdSeq`, a DBIRTH per device: a device's metrics and aliases are those of
    /// the new catalogue, which a host learns only from births) once the drives of new and
    /// restarted buses have answered, as at the start ([`SETTLE_LIMIT`] at most).
    pub fn reconfigure(&mut self, r: &Reconfig, sp: &Sparkplug, now_ms: u64) -> Vec<Out> {
        let mut new = Node::new(&r.plant, sp);
        new.phase = self.phase;
        new.bd_seq = self.bd_seq;
        new.seq = self.seq;
        new.host = std::mem::replace(&mut self.host, PrimaryHost::new());
        for (old_bus, f) in self.figures.iter().enumerate() {
            if let Some(slot) = r.kept(old_bus).and_then(|b| new.figures.get_mut(b)) {
                slot.clone_from(f);
            }
        }
        let mut out = Vec::new();
        for (d, dev) in self.cat.devices.iter().enumerate() {
            let Some(state) = self.devices.get_mut(d) else {
                continue;
            };
            let carried = r
                .kept(dev.bus)
                .and_then(|b| new.cat.device_of(b, dev.drive))
                .and_then(|nd| Some((nd, new.devices.get_mut(nd)?)));
            match carried {
                Some((_, slot)) => {
                    let mut moved = std::mem::take(state);
                    moved.queued = false;
                    *slot = moved;
                }
                None if state.born && self.phase == Phase::Born => {
                    // A device a host knows that is gone (or on a bus restarted with other
                    // settings, whose device is born again below if it stays).
                    let payload = Payload {
                        timestamp: Some(now_ms),
                        seq: Some(new.seq.take()),
                        ..Payload::default()
                    };
                    out.push(Out::Publish(Message {
                        topic: new.topic(MessageType::DDeath, Some(&dev.id)),
                        payload: new.encode(&payload),
                        qos1: false,
                        retain: false,
                    }));
                }
                None => {}
            }
        }
        *self = new;
        if self.phase == Phase::Born {
            // Born again once the drives of new and restarted buses have answered (at most
            // [`SETTLE_LIMIT`]), so that their births carry values, as at the start.
            out.extend(self.settle(now_ms));
        }
        out
    }

    fn status(&mut self, d: usize, status: DriveStatus, at_ms: u64, now_ms: u64) -> Vec<Out> {
        let Some(s) = self.devices.get_mut(d) else {
            return Vec::new();
        };
        let before = s.status.as_ref().map(|(st, _)| st.clone());
        s.status = Some((status.clone(), at_ms));
        if self.phase != Phase::Born {
            return Vec::new();
        }
        match (status, s.born) {
            (DriveStatus::Timeout, true) => {
                s.born = false;
                let id = self.cat.devices.get(d).map(|x| x.id.clone());
                let payload = Payload {
                    timestamp: Some(at_ms),
                    seq: Some(self.seq.take()),
                    ..Payload::default()
                };
                vec![Out::Publish(Message {
                    topic: self.topic(MessageType::DDeath, id.as_deref()),
                    payload: self.encode(&payload),
                    qos1: false,
                    retain: false,
                })]
            }
            (DriveStatus::Timeout, false) => Vec::new(),
            (_, false) => self.device_birth(d, now_ms).into_iter().collect(),
            (st, true) => {
                if before.as_ref() != Some(&st) {
                    s.dirty_status = true;
                    self.touch(d);
                }
                Vec::new()
            }
        }
    }

    /// The DATA messages of what changed since the last flush (or the births, once the drives
    /// have answered or [`SETTLE_LIMIT`] has passed).
    pub fn flush(&mut self, now_ms: u64) -> Vec<Out> {
        if let Phase::Settling(since) = self.phase {
            let limit = u64::try_from(SETTLE_LIMIT.as_millis()).unwrap_or(u64::MAX);
            if self.settled() || now_ms.saturating_sub(since) >= limit {
                return self.births(now_ms);
            }
        }
        if self.phase != Phase::Born {
            return Vec::new();
        }
        let mut out = Vec::new();
        if self.figures_dirty.iter().any(|x| *x) {
            let mut metrics = Vec::new();
            for m in &self.cat.node {
                let bus = match m.kind {
                    NodeKind::Utilisation(b)
                    | NodeKind::Demand(b)
                    | NodeKind::Transactions(b)
                    | NodeKind::Timeouts(b)
                    | NodeKind::Retries(b)
                    | NodeKind::LatePolls(b) => b,
                    NodeKind::BdSeq | NodeKind::Rebirth => continue,
                };
                if !self.figures_dirty.get(bus).copied().unwrap_or(false) {
                    continue;
                }
                let mut metric = Metric {
                    alias: m.alias,
                    timestamp: Some(now_ms),
                    ..Metric::default()
                };
                self.node_value(m.kind, m.datatype, &mut metric);
                let same = self.figures_published.get(bus) == self.figures.get(bus)
                    || same_node_value(
                        m.kind,
                        self.figures_published.get(bus).and_then(Option::as_ref),
                        self.figures.get(bus).and_then(Option::as_ref),
                    );
                if !same {
                    metric.datatype = None;
                    metrics.push(metric);
                }
            }
            for ((published, now), dirty) in self
                .figures_published
                .iter_mut()
                .zip(&self.figures)
                .zip(self.figures_dirty.iter_mut())
            {
                if *dirty {
                    published.clone_from(now);
                    *dirty = false;
                }
            }
            if !metrics.is_empty() {
                let payload = Payload {
                    timestamp: Some(now_ms),
                    metrics,
                    seq: Some(self.seq.take()),
                    ..Payload::default()
                };
                out.push(Out::Publish(Message {
                    topic: self.topic(MessageType::NData, None),
                    payload: self.encode(&payload),
                    qos1: false,
                    retain: false,
                }));
            }
        }
        for d in std::mem::take(&mut self.changed) {
            if let Some(s) = self.devices.get_mut(d) {
                s.queued = false;
            }
            if let Some(o) = self.device_data(d, now_ms) {
                out.push(o);
            }
        }
        out
    }

    /// A drive's DDATA of what changed, if anything did.
    fn device_data(&mut self, d: usize, now_ms: u64) -> Option<Out> {
        let s = self.devices.get_mut(d)?;
        if !s.born
            || !(s.dirty_status || s.dirty.iter().any(|x| *x) || s.dirty_results.iter().any(|x| *x))
        {
            return None;
        }
        let dev = self.cat.devices.get(d)?;
        let mut metrics = Vec::new();
        if s.dirty_status {
            let (st, fault, at) = status_texts(s.status.as_ref());
            let at = at.unwrap_or(now_ms);
            metrics.push(text_metric(None, dev.state_alias, st, at));
            metrics.push(text_metric(None, dev.fault_alias, fault, at));
            s.dirty_status = false;
        }
        for (ix, p) in dev.points.iter().enumerate() {
            if s.dirty.get(ix).copied().unwrap_or(false) {
                let mut m = Metric {
                    alias: Some(p.alias),
                    ..Metric::default()
                };
                let v = s.values.get(ix).copied().flatten();
                point_value(p, v, now_ms, &mut m);
                if let Some(note) = s.notes.get_mut(ix).and_then(Option::take) {
                    m.properties = Some(
                        sparkplug_b::props::PropertySetBuilder::default()
                            .text("writeResult", &note)
                            .build(),
                    );
                }
                metrics.push(m);
                if let (Some(v), Some(pubd)) = (v, s.published.get_mut(ix)) {
                    *pubd = Some(v.0);
                }
                if let Some(x) = s.dirty.get_mut(ix) {
                    *x = false;
                }
            }
            if s.dirty_results.get(ix).copied().unwrap_or(false) {
                if let Some(r) = p.result_alias {
                    let text = s.results.get(ix).cloned().flatten();
                    metrics.push(text_metric(None, r, text.as_deref(), now_ms));
                }
                if let Some(x) = s.dirty_results.get_mut(ix) {
                    *x = false;
                }
            }
        }
        // The birth gave each metric's datatype; DATA messages should not repeat it
        // (tck-id-payloads-metric-datatype-not-req).
        for m in &mut metrics {
            m.datatype = None;
        }
        let payload = Payload {
            timestamp: Some(now_ms),
            metrics,
            seq: Some(self.seq.take()),
            ..Payload::default()
        };
        let topic = self.topic(MessageType::DData, Some(&dev.id.clone()));
        Some(Out::Publish(Message {
            topic,
            payload: self.encode(&payload),
            qos1: false,
            retain: false,
        }))
    }

    /// A message on a subscribed topic: a command, or the primary host's STATE.
    pub fn incoming(&mut self, topic: &str, payload: &[u8], retain: bool, now_ms: u64) -> Vec<Out> {
        let Ok(t) = Topic::parse(topic) else {
            tracing::debug!(%topic, "not a Sparkplug topic: ignored");
            return Vec::new();
        };
        match t.kind {
            MessageType::State => self.host_state(t.node, payload, now_ms),
            MessageType::NCmd if t.group == self.group && t.node == self.node => {
                self.node_command(topic, payload, retain, now_ms)
            }
            MessageType::DCmd if t.group == self.group && t.node == self.node => {
                let device = t.device.unwrap_or_default().to_owned();
                self.device_command(topic, &device, payload, retain, now_ms)
            }
            _ => Vec::new(),
        }
    }

    fn host_state(&mut self, host: &str, payload: &[u8], now_ms: u64) -> Vec<Out> {
        if self.primary_host.as_deref() != Some(host) {
            return Vec::new();
        }
        let Some((online, ts)) = parse_state(payload) else {
            tracing::warn!(
                host,
                "a STATE message that is not {{\"online\":…,\"timestamp\":…}}: ignored"
            );
            return Vec::new();
        };
        // An older session's STATE arriving late is not this one's.
        if self.host.on_state(online, ts) == HostState::Stale {
            tracing::info!(
                host,
                online,
                ts,
                "an older STATE of the primary host: ignored"
            );
            return Vec::new();
        }
        match (online, self.phase) {
            (true, Phase::WaitingForHost) => {
                tracing::info!(host, "the primary host is online: births");
                self.settle(now_ms)
            }
            (false, Phase::Born) => {
                tracing::warn!(
                    host,
                    "the primary host is offline: NDEATH, disconnecting, and waiting for it at the next connection"
                );
                self.stopping(now_ms)
            }
            (false, Phase::Settling(_)) => {
                tracing::info!(
                    host,
                    "the primary host is offline: no births until it is online"
                );
                self.phase = Phase::WaitingForHost;
                Vec::new()
            }
            (false, Phase::Subscribing(_) | Phase::WaitingForHost) => {
                tracing::info!(
                    host,
                    "the primary host is offline: no births until it is online"
                );
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    /// A retained command is never executed (it would run again at every reconnection): it is
    /// cleared.
    fn clear_retained(topic: &str) -> Out {
        Out::Publish(Message {
            topic: topic.to_owned(),
            payload: Vec::new(),
            qos1: true,
            retain: true,
        })
    }

    fn node_command(&mut self, topic: &str, payload: &[u8], retain: bool, now_ms: u64) -> Vec<Out> {
        if retain {
            tracing::warn!(%topic, "a retained NCMD: not executed, cleared");
            return vec![Self::clear_retained(topic)];
        }
        let p = match sparkplug_b::decode(payload) {
            Ok(p) => p,
            Err(e) => {
                tracing::warn!(%topic, error = %e, "an NCMD that does not decode: ignored");
                return Vec::new();
            }
        };
        let mut rebirth = false;
        for m in p.metrics.iter().take(MAX_COMMAND_METRICS) {
            if sparkplug_b::node::is_rebirth(m) {
                rebirth = true;
            } else if m.name.as_deref() != Some(sparkplug_b::node::REBIRTH) {
                tracing::warn!(%topic, name = ?m.name, alias = ?m.alias, "an NCMD metric the node does not take: ignored");
            }
        }
        if rebirth && matches!(self.phase, Phase::Born) {
            tracing::info!("rebirth asked: NBIRTH and every DBIRTH again");
            return self.births(now_ms);
        }
        Vec::new()
    }

    fn device_command(
        &mut self,
        topic: &str,
        device: &str,
        payload: &[u8],
        retain: bool,
        now_ms: u64,
    ) -> Vec<Out> {
        let Some(d) = self.cat.device_named(device) else {
            tracing::warn!(%topic, "a DCMD for no drive of this node: ignored");
            return Vec::new();
        };
        let mut out = Vec::new();
        if retain {
            out.push(Self::clear_retained(topic));
        }
        let p = match sparkplug_b::decode(payload) {
            Ok(p) => p,
            Err(e) => {
                tracing::warn!(%topic, error = %e, "a DCMD that does not decode: nothing written");
                return out;
            }
        };
        // Stale: the command's own timestamp (the payload's), as a JSON set's `ts`.
        let stale = if retain {
            Some((
                "retained",
                "a retained DCMD is never executed (it would move the machine again at every \
                 reconnection); publish commands with retain = false"
                    .to_owned(),
            ))
        } else {
            p.timestamp.and_then(|ts| {
                let age = i128::from(now_ms) - i128::from(ts);
                let max = self.max_set_age.as_millis() as i128;
                if age > max {
                    Some((
                        "stale",
                        format!("sent {age} ms ago (timestamp), more than max_set_age = {max} ms: not executed"),
                    ))
                } else if -age > MAX_SET_FUTURE.as_millis() as i128 {
                    Some((
                        "stale",
                        format!("timestamp is {} ms in the future: check the sender's clock", -age),
                    ))
                } else {
                    None
                }
            })
        };
        let age = p.timestamp.map_or(0, |ts| now_ms.saturating_sub(ts));
        let max_age = self.max_set_age.saturating_sub(Duration::from_millis(age));
        for m in p.metrics.iter().take(MAX_COMMAND_METRICS) {
            let Some(dev) = self.cat.devices.get(d) else {
                break;
            };
            let Some(r) = dev.find(m.name.as_deref(), m.alias) else {
                tracing::warn!(%topic, name = ?m.name, alias = ?m.alias, "a DCMD metric the drive does not have: ignored");
                continue;
            };
            let ix = match r {
                DeviceRef::Point(ix) => ix,
                DeviceRef::WriteResult(_) | DeviceRef::State | DeviceRef::Fault => {
                    tracing::warn!(%topic, name = ?m.name, alias = ?m.alias, "a DCMD for a status metric: not writable, ignored");
                    continue;
                }
            };
            if let Some((reason, message)) = &stale {
                self.refused(d, ix, reason, message.clone());
                continue;
            }
            match self.command_value(d, ix, m) {
                Ok(value) => out.push(Out::Write {
                    device: d,
                    point: ix,
                    value,
                    max_age,
                }),
                Err((reason, message)) => self.refused(d, ix, reason, message),
            }
        }
        out.extend(self.flush(now_ms));
        out
    }

    /// The value a DCMD metric asks for, or why it is refused.
    fn command_value(
        &self,
        d: usize,
        ix: usize,
        m: &Metric,
    ) -> Result<SetValue, (&'static str, String)> {
        let (dev, state) = match (self.cat.devices.get(d), self.devices.get(d)) {
            (Some(a), Some(b)) => (a, b),
            _ => return Err(("bad_request", "no such drive".to_owned())),
        };
        let Some(p) = dev.points.get(ix) else {
            return Err(("bad_request", "no such point".to_owned()));
        };
        if p.result_alias.is_none() {
            return Err((
                "not_writable",
                "this point is not writable: the gateway's config must say writable = true for it"
                    .to_owned(),
            ));
        }
        if let Some(dt) = m.datatype
            && dt != p.datatype as u32
        {
            return Err((
                "bad_request",
                format!(
                    "datatype {} is not the birth's {}",
                    DataType::try_from(dt as i32)
                        .map_or_else(|_| dt.to_string(), |t| t.as_str_name().to_owned()),
                    p.datatype.as_str_name()
                ),
            ));
        }
        if m.is_null == Some(true) {
            return Err(("bad_request", "a null value writes nothing".to_owned()));
        }
        if matches!(state.status, Some((DriveStatus::Timeout, _))) {
            return Err((
                "offline",
                "the drive does not answer (status timeout): not sent".to_owned(),
            ));
        }
        match value::get(m, p.datatype) {
            Ok(Number::Int(i)) => Ok(SetValue::Value(serde_json::json!(i))),
            Ok(Number::Float(f)) => serde_json::Number::from_f64(f)
                .map(|n| SetValue::Value(serde_json::Value::Number(n)))
                .ok_or_else(|| ("bad_request", format!("{f} is not a number to write"))),
            Ok(Number::Text(t)) => Ok(SetValue::Value(serde_json::Value::String(t))),
            Ok(Number::Bool(_)) => Err((
                "bad_request",
                format!("a boolean for a {} point", p.datatype.as_str_name()),
            )),
            Err(e) => Err(("bad_request", e.to_string())),
        }
    }

    /// Record a refusal of a command on point `ix` of device `d` (published at the next flush).
    fn refused(&mut self, d: usize, ix: usize, reason: &str, message: String) {
        tracing::info!(device = d, point = ix, reason, %message, "DCMD refused");
        let has_result = self
            .cat
            .devices
            .get(d)
            .and_then(|dev| dev.points.get(ix))
            .is_some_and(|p| p.result_alias.is_some());
        let text = format!("refused {reason}: {message}");
        if let Some(s) = self.devices.get_mut(d) {
            if has_result {
                if let Some(r) = s.results.get_mut(ix) {
                    *r = Some(text);
                }
                if let Some(x) = s.dirty_results.get_mut(ix) {
                    *x = true;
                }
            } else if let Some(n) = s.notes.get_mut(ix) {
                *n = Some(text);
            }
            if let Some(x) = s.dirty.get_mut(ix) {
                *x = true;
            }
        }
        self.touch(d);
    }

    /// A write's outcome: the point's read-back value and its result, at the next flush.
    pub fn write_done(&mut self, d: usize, ix: usize, outcome: &SetOutcome, now_ms: u64) {
        let text = match outcome {
            SetOutcome::Written { differs: None, .. } => "written".to_owned(),
            SetOutcome::Written {
                differs: Some((_, m)),
                ..
            } => format!("written: {m}"),
            SetOutcome::Refused { reason, message } => format!("refused {reason}: {message}"),
            SetOutcome::DeviceRefused { message } => format!("device_refused: {message}"),
            SetOutcome::LinkFailed { message } => format!("link_failed: {message}"),
        };
        if let Some(s) = self.devices.get_mut(d) {
            if let SetOutcome::Written { raw, .. } = outcome
                && let Some(v) = s.values.get_mut(ix)
            {
                *v = Some((*raw, now_ms));
            }
            if let Some(r) = s.results.get_mut(ix) {
                *r = Some(text);
            }
            if let Some(x) = s.dirty_results.get_mut(ix) {
                *x = true;
            }
            if let Some(x) = s.dirty.get_mut(ix) {
                *x = true;
            }
        }
        self.touch(d);
    }
}

/// An NDEATH's payload: the timestamp and `bdSeq`, no `seq` (the specification forbids one).
pub fn death_payload(bd_seq: u8, now_ms: u64) -> Vec<u8> {
    let payload = sparkplug_b::node::death(Seq::new(bd_seq), Some(now_ms));
    let mut buf = Vec::new();
    sparkplug_b::encode_into(&payload, &mut buf);
    buf
}

/// Set a metric's value, or mark it null (no value yet, or one its datatype cannot carry).
fn set_or_null(m: &mut Metric, datatype: DataType, v: Option<Value<'_>>) {
    let ok = match v {
        Some(v) => match value::set(m, datatype, v) {
            Ok(()) => true,
            Err(e) => {
                tracing::warn!(name = ?m.name, alias = ?m.alias, error = %e, "a value the metric's datatype cannot carry: published as null");
                false
            }
        },
        None => false,
    };
    if !ok {
        m.datatype = Some(datatype as u32);
        m.value = None;
        m.is_null = Some(true);
    }
}

/// A point's value into `m`: the raw one, or its physical one (scaled, rounded to the table's
/// decimals); its timestamp the read's.
fn point_value(
    p: &super::catalogue::PointMetric,
    v: Option<(i64, u64)>,
    now_ms: u64,
    m: &mut Metric,
) {
    m.timestamp = Some(v.map_or(now_ms, |(_, at)| at));
    let value = v.map(|(raw, _)| {
        if p.scaled {
            Value::Double(p.physical(raw))
        } else {
            Value::Int(raw)
        }
    });
    set_or_null(m, p.datatype, value);
}

/// A String metric (`name` in births only).
fn text_metric(name: Option<&str>, alias: u64, text: Option<&str>, at: u64) -> Metric {
    let mut m = Metric {
        name: name.map(str::to_owned),
        alias: Some(alias),
        timestamp: Some(at),
        ..Metric::default()
    };
    set_or_null(&mut m, DataType::String, text.map(Value::Text));
    m
}

/// `Status/State` and `Status/Fault` of a status, and when it was learned.
fn status_texts(
    s: Option<&(DriveStatus, u64)>,
) -> (Option<&'static str>, Option<&str>, Option<u64>) {
    match s {
        None => (None, None, None),
        Some((st, at)) => (
            Some(st.state()),
            Some(match st {
                DriveStatus::Fault(t) => t.as_str(),
                _ => "",
            }),
            Some(*at),
        ),
    }
}

/// A share (0–1) to four decimals, as the JSON bus status gives it: a change in the fifth is
/// no news.
fn share(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

/// Whether a node metric's value is the same in two sets of figures.
fn same_node_value(kind: NodeKind, a: Option<&BusFigures>, b: Option<&BusFigures>) -> bool {
    let (Some(a), Some(b)) = (a, b) else {
        return false;
    };
    match kind {
        NodeKind::Utilisation(_) => share(a.utilisation) == share(b.utilisation),
        NodeKind::Demand(_) => share(a.demand) == share(b.demand),
        NodeKind::Transactions(_) => a.transactions == b.transactions,
        NodeKind::Timeouts(_) => a.timeouts == b.timeouts,
        NodeKind::Retries(_) => a.retries == b.retries,
        NodeKind::LatePolls(_) => a.late_polls == b.late_polls,
        NodeKind::BdSeq | NodeKind::Rebirth => true,
    }
}

/// A primary host's STATE payload (`{"online": true, "timestamp": 1668114759262}`).
pub fn parse_state(payload: &[u8]) -> Option<(bool, u64)> {
    if payload.len() > 4096 {
        return None;
    }
    let v: serde_json::Value = serde_json::from_slice(payload).ok()?;
    Some((v.get("online")?.as_bool()?, v.get("timestamp")?.as_u64()?))
}
