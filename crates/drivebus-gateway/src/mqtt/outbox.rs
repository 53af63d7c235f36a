//! What the MQTT task has to publish, without I/O: the latest payload of every retained topic
//! (one per topic, so an outage costs no memory beyond the plant's topics), which of them are
//! still to be sent, results waiting for the broker (bounded), and which results the broker
//! has not acknowledged yet (sent again after a reconnection). Time is an argument.

use std::collections::{HashMap, VecDeque};
use std::time::Duration;

use tokio::time::Instant;

use super::super::config::Plant;
use super::super::model::{DriveStatus, Reconfig, Update};
use super::payload;

/// Results kept while the broker is away; past this the oldest are dropped (and logged).
pub const MAX_RESULTS: usize = 1024;

/// What a retained topic carries (for metrics).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A parameter's value.
    Value,
    /// A drive's status.
    Status,
    /// Process data.
    ProcessData,
    /// A bus's figures.
    Figures,
}

impl Kind {
    /// The metrics label.
    pub fn label(self) -> &'static str {
        match self {
            Kind::Value => "value",
            Kind::Status => "status",
            Kind::ProcessData => "pd",
            Kind::Figures => "figures",
        }
    }
}

/// One retained topic.
#[derive(Debug)]
struct Slot {
    topic: String,
    kind: Kind,
    /// The latest payload (`None`: nothing known yet).
    payload: Option<String>,
    /// Still to be published.
    dirty: bool,
    /// When it was last handed to the client.
    published: Option<Instant>,
    /// The raw value last published (values).
    raw: Option<i64>,
    /// The input words last published (process data).
    words: Option<Vec<u16>>,
    /// Its payload says it is stale (a value or process data: the drive stopped answering;
    /// any topic: the gateway stopped): the next update publishes it fresh, changed or not.
    stale: bool,
}

/// A result to publish (not retained).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResultMsg {
    /// `…/result`.
    pub topic: String,
    /// Its JSON.
    pub payload: String,
}

/// A message handed to the client, in the order the client sends them.
#[derive(Debug)]
enum Sent {
    Other,
    Result(ResultMsg),
}

/// One message for the client.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Out<'a> {
    /// Topic.
    pub topic: &'a str,
    /// Payload.
    pub payload: &'a str,
    /// Retained.
    pub retain: bool,
    /// Metrics label (`value`, `status`, `pd`, `figures`, `result`).
    pub kind: &'static str,
}

/// The publishing state of the gateway's topics.
#[derive(Debug)]
pub struct Outbox {
    slots: Vec<Slot>,
    /// Slot of each bus's status; a drive's slots follow: status, pd, then its points.
    bus_slot: Vec<usize>,
    drive_slot: Vec<Vec<usize>>,
    /// Process output words of each drive (for the pd topic).
    pd_out: Vec<Vec<Vec<u16>>>,
    statuses: Vec<Vec<Option<DriveStatus>>>,
    queue: VecDeque<usize>,
    /// Retained topics to clear (an empty retained message each): those of buses, drives and
    /// points a reloaded config no longer has.
    clears: VecDeque<String>,
    results: VecDeque<ResultMsg>,
    /// Handed to the client, not yet seen going out.
    sent: VecDeque<Sent>,
    /// Sent with this packet id, not yet acknowledged.
    inflight: HashMap<u16, ResultMsg>,
    heartbeat: Duration,
    /// Results dropped because the bound was reached.
    pub dropped_results: u64,
}

impl Outbox {
    /// The topics of `plant`, nothing known yet.
    pub fn new(plant: &Plant) -> Outbox {
        let g = &plant.gateway;
        let mut slots = Vec::new();
        let mut bus_slot = Vec::new();
        let mut drive_slot = Vec::new();
        let mut pd_out = Vec::new();
        let mut statuses = Vec::new();
        let slot = |topic: String, kind: Kind| Slot {
            topic,
            kind,
            payload: None,
            dirty: false,
            published: None,
            raw: None,
            words: None,
            stale: false,
        };
        for bus in &plant.buses {
            let base = format!("{}/{}/{}", g.prefix, g.name, bus.name);
            bus_slot.push(slots.len());
            slots.push(slot(format!("{base}/status"), Kind::Figures));
            let mut ds = Vec::new();
            let mut outs = Vec::new();
            for d in &bus.drives {
                ds.push(slots.len());
                slots.push(slot(format!("{base}/{}/status", d.name), Kind::Status));
                slots.push(slot(format!("{base}/{}/pd", d.name), Kind::ProcessData));
                for p in &d.points {
                    slots.push(slot(format!("{base}/{}/{}", d.name, p.name), Kind::Value));
                }
                outs.push(
                    d.process_data
                        .as_ref()
                        .map(|pd| pd.out.clone())
                        .unwrap_or_default(),
                );
            }
            statuses.push(vec![None; bus.drives.len()]);
            drive_slot.push(ds);
            pd_out.push(outs);
        }
        Outbox {
            slots,
            bus_slot,
            drive_slot,
            pd_out,
            statuses,
            queue: VecDeque::new(),
            clears: VecDeque::new(),
            results: VecDeque::new(),
            sent: VecDeque::new(),
            inflight: HashMap::new(),
            heartbeat: g.heartbeat,
            dropped_results: 0,
        }
    }

    fn drive_base(&self, bus: usize, drive: usize) -> Option<usize> {
        self.drive_slot.get(bus)?.get(drive).copied()
    }

    fn mark(&mut self, ix: usize) {
        if let Some(s) = self.slots.get_mut(ix)
            && !s.dirty
        {
            s.dirty = true;
            self.queue.push_back(ix);
        }
    }

    /// Take an update from a bus task at `now`: a value or process data is to be published
    /// when it changed or its last publication is a heartbeat old; a status or figures always.
    /// False when the update names no topic of the plant.
    pub fn update(&mut self, u: Update, now: Instant, plant: &Plant) -> bool {
        let heartbeat = self.heartbeat;
        let due = |s: &Slot| {
            s.published
                .is_none_or(|t| now.duration_since(t) >= heartbeat)
        };
        match u {
            Update::Value {
                bus,
                drive,
                point,
                raw,
                at,
            } => {
                let Some((target, device)) = plant
                    .buses
                    .get(bus)
                    .and_then(|b| b.drives.get(drive))
                    .and_then(|d| d.points.get(point).map(|p| (p.target, d.device)))
                else {
                    return false;
                };
                let Some(ix) = self.drive_base(bus, drive).map(|b| b + 2 + point) else {
                    return false;
                };
                let Some(s) = self.slots.get_mut(ix) else {
                    return false;
                };
                if s.raw != Some(raw) || s.payload.is_none() || s.stale || due(s) {
                    s.raw = Some(raw);
                    s.stale = false;
                    s.payload = Some(payload::value(&target, raw, payload::millis(at), &device));
                    self.mark(ix);
                }
                true
            }
            Update::ProcessData {
                bus,
                drive,
                words,
                at,
            } => {
                let Some(ix) = self.drive_base(bus, drive).map(|b| b + 1) else {
                    return false;
                };
                let out = self
                    .pd_out
                    .get(bus)
                    .and_then(|b| b.get(drive))
                    .map_or(&[][..], Vec::as_slice);
                let Some(s) = self.slots.get_mut(ix) else {
                    return false;
                };
                if s.words.as_deref() != Some(words.as_slice()) || s.stale || due(s) {
                    s.stale = false;
                    s.payload = Some(payload::process_data(&words, out, payload::millis(at)));
                    s.words = Some(words);
                    self.mark(ix);
                }
                true
            }
            Update::Status {
                bus,
                drive,
                status,
                at,
            } => {
                let Some(ix) = self.drive_base(bus, drive) else {
                    return false;
                };
                let Some(s) = self.slots.get_mut(ix) else {
                    return false;
                };
                s.stale = false;
                s.payload = Some(payload::status(&status, payload::millis(at)));
                let timed_out = status == DriveStatus::Timeout;
                if let Some(st) = self.statuses.get_mut(bus).and_then(|b| b.get_mut(drive)) {
                    *st = Some(status);
                }
                self.mark(ix);
                if timed_out {
                    // Its retained values and process data are republished as stale, so that
                    // no consumer takes what was read before the drive went quiet for current.
                    let n = plant
                        .buses
                        .get(bus)
                        .and_then(|b| b.drives.get(drive))
                        .map_or(0, |d| d.points.len());
                    // Its slots after the status: process data, then each point.
                    for slot in ix + 1..ix + 2 + n {
                        self.make_stale(slot, payload::millis(at));
                    }
                }
                true
            }
            Update::Figures { bus, figures } => {
                let Some(&ix) = self.bus_slot.get(bus) else {
                    return false;
                };
                let Some(s) = self.slots.get_mut(ix) else {
                    return false;
                };
                let ts = payload::millis(std::time::SystemTime::now());
                s.stale = false;
                s.payload = Some(payload::figures(&figures, ts));
                self.mark(ix);
                true
            }
            // The MQTT task takes a reload itself ([`Outbox::reconfigure`]).
            Update::Reconfigured(_) => false,
        }
    }

    /// A reloaded config ([`Reconfig`]) after `old`: the topics of the new plant, with all
    /// that is known of the buses that keep running (their latest payloads, what is still to
    /// be published, their drives' statuses), and every retained topic of `old` that the new
    /// plant does not have queued to be cleared (an empty retained message), so that no
    /// consumer reads the last value of a removed point as current. Results waiting and
    /// unacknowledged stay. Returns how many topics are to be cleared.
    pub fn reconfigure(&mut self, old: &Plant, r: &Reconfig) -> usize {
        let mut new = Outbox::new(&r.plant);
        for (old_bus, bus) in old.buses.iter().enumerate() {
            let Some(new_bus) = r.kept(old_bus) else {
                continue;
            };
            // A kept bus has the same drives and points: its slots line up one to one.
            if let (Some(&from), Some(&to)) =
                (self.bus_slot.get(old_bus), new.bus_slot.get(new_bus))
            {
                self.move_slot(from, &mut new, to);
            }
            for (d, drive) in bus.drives.iter().enumerate() {
                let (Some(from), Some(to)) =
                    (self.drive_base(old_bus, d), new.drive_base(new_bus, d))
                else {
                    continue;
                };
                for k in 0..2 + drive.points.len() {
                    self.move_slot(from + k, &mut new, to + k);
                }
            }
            if let (Some(from), Some(to)) = (
                self.statuses.get_mut(old_bus),
                new.statuses.get_mut(new_bus),
            ) {
                *to = std::mem::take(from);
            }
        }
        let topics: std::collections::HashSet<&str> =
            new.slots.iter().map(|s| s.topic.as_str()).collect();
        let mut clears = std::mem::take(&mut self.clears);
        let before = clears.len();
        for s in &self.slots {
            if !s.topic.is_empty() && !topics.contains(s.topic.as_str()) {
                clears.push_back(s.topic.clone());
            }
        }
        let cleared = clears.len() - before;
        // A topic queued to be cleared that the new plant has again is no longer cleared.
        clears.retain(|t| !topics.contains(t.as_str()));
        new.clears = clears;
        new.results = std::mem::take(&mut self.results);
        new.sent = std::mem::take(&mut self.sent);
        new.inflight = std::mem::take(&mut self.inflight);
        new.dropped_results = self.dropped_results;
        for ix in 0..new.slots.len() {
            if new.slots.get(ix).is_some_and(|s| s.dirty) {
                new.queue.push_back(ix);
            }
        }
        *self = new;
        cleared
    }

    /// Move what is known of slot `from` into slot `to` of `new` (its topic is `new`'s); the
    /// old slot is left without a topic.
    fn move_slot(&mut self, from: usize, new: &mut Outbox, to: usize) {
        let (Some(a), Some(b)) = (self.slots.get_mut(from), new.slots.get_mut(to)) else {
            return;
        };
        b.payload = a.payload.take();
        b.dirty = a.dirty;
        b.published = a.published;
        b.raw = a.raw;
        b.words = a.words.take();
        b.stale = a.stale;
        a.topic.clear();
    }

    /// Topics waiting to be cleared.
    pub fn clears_waiting(&self) -> usize {
        self.clears.len()
    }

    /// Forget the topics waiting to be cleared (a new connection after the old one's topics
    /// were cleared there).
    pub fn drop_clears(&mut self) {
        self.clears.clear();
    }

    /// Every retained topic of the plant.
    pub fn topics(&self) -> impl Iterator<Item = &str> {
        self.slots
            .iter()
            .map(|s| s.topic.as_str())
            .filter(|t| !t.is_empty())
    }

    /// Every retained topic published and still fresh (values, process data, drive statuses,
    /// bus figures), as a stale copy since `since` (ms), without changing what is kept: for a
    /// connection that ends while the gateway runs on (the next connection publishes them as
    /// they are).
    pub fn stale_copies(&self, since: u64) -> Vec<(String, String)> {
        self.slots
            .iter()
            .filter(|s| s.published.is_some() && !s.stale)
            .filter_map(|s| {
                Some((
                    s.topic.clone(),
                    payload::stale(s.payload.as_deref()?, since)?,
                ))
            })
            .collect()
    }

    /// Republish slot `ix` as stale since `since` (ms), if it has a fresh payload.
    fn make_stale(&mut self, ix: usize, since: u64) {
        let Some(s) = self.slots.get_mut(ix) else {
            return;
        };
        if s.stale {
            return;
        }
        if let Some(p) = s.payload.as_deref().and_then(|p| payload::stale(p, since)) {
            s.payload = Some(p);
            s.stale = true;
            self.mark(ix);
        }
    }

    /// The gateway is stopping: every retained topic it has published (values, process data,
    /// drive statuses, bus figures), as stale since `since` (ms), to publish before `offline`
    /// (a consumer reading only one of those topics sees that it is no longer kept current).
    pub fn stopping(&mut self, since: u64) -> Vec<(String, String)> {
        let mut out = Vec::new();
        for ix in 0..self.slots.len() {
            let fresh = self
                .slots
                .get(ix)
                .is_some_and(|s| s.published.is_some() && !s.stale);
            if !fresh {
                continue;
            }
            self.make_stale(ix, since);
            if let Some(s) = self.slots.get_mut(ix)
                && s.stale
                && let Some(p) = &s.payload
            {
                out.push((s.topic.clone(), p.clone()));
                // Handed directly by the caller: not queued again.
                s.dirty = false;
            }
        }
        self.queue
            .retain(|ix| self.slots.get(*ix).is_some_and(|s| s.dirty));
        out
    }

    /// The drive's last reported status.
    pub fn status(&self, bus: usize, drive: usize) -> Option<&DriveStatus> {
        self.statuses.get(bus)?.get(drive)?.as_ref()
    }

    /// Queue a result (the oldest is dropped past [`MAX_RESULTS`]); true if one was dropped.
    pub fn push_result(&mut self, r: ResultMsg) -> bool {
        self.results.push_back(r);
        if self.results.len() > MAX_RESULTS {
            self.results.pop_front();
            self.dropped_results += 1;
            return true;
        }
        false
    }

    /// A (new) connection is up: every known payload is to be published again; what was
    /// handed to the client and not acknowledged is forgotten by the client (clean session),
    /// so its results are queued again, first.
    pub fn connected(&mut self) {
        self.requeue_unacknowledged();
        self.queue.clear();
        for s in &mut self.slots {
            s.dirty = false;
        }
        for ix in 0..self.slots.len() {
            if self.slots.get(ix).is_some_and(|s| s.payload.is_some()) {
                self.mark(ix);
            }
        }
    }

    /// The connection is down: results not acknowledged are queued again (the client drops
    /// what it had at the next clean session).
    pub fn disconnected(&mut self) {
        self.requeue_unacknowledged();
    }

    fn requeue_unacknowledged(&mut self) {
        let mut again: Vec<ResultMsg> = Vec::new();
        let mut ids: Vec<u16> = self.inflight.keys().copied().collect();
        ids.sort_unstable();
        again.extend(ids.into_iter().filter_map(|id| self.inflight.remove(&id)));
        again.extend(self.sent.drain(..).filter_map(|s| match s {
            Sent::Result(r) => Some(r),
            Sent::Other => None,
        }));
        for r in again.into_iter().rev() {
            self.results.push_front(r);
        }
        while self.results.len() > MAX_RESULTS {
            self.results.pop_back();
            self.dropped_results += 1;
        }
    }

    /// A message the caller handed to the client directly (the gateway's status).
    pub fn handed_other(&mut self) {
        self.sent.push_back(Sent::Other);
    }

    /// The client sent the next handed message with packet id `pkid`.
    pub fn sent_publish(&mut self, pkid: u16) {
        if let Some(Sent::Result(r)) = self.sent.pop_front() {
            self.inflight.insert(pkid, r);
        }
    }

    /// The broker acknowledged `pkid`.
    pub fn acked(&mut self, pkid: u16) {
        self.inflight.remove(&pkid);
    }

    /// Hand what is waiting to `publish` (results first, then retained topics in the order
    /// they changed) until it refuses one (its queue is full: call again later). Returns the
    /// number handed.
    pub fn flush(&mut self, now: Instant, mut publish: impl FnMut(Out<'_>) -> bool) -> usize {
        let mut n = 0;
        while let Some(t) = self.clears.front() {
            let out = Out {
                topic: t,
                payload: "",
                retain: true,
                kind: "clear",
            };
            if !publish(out) {
                return n;
            }
            self.clears.pop_front();
            self.sent.push_back(Sent::Other);
            n += 1;
        }
        while let Some(r) = self.results.front() {
            let out = Out {
                topic: &r.topic,
                payload: &r.payload,
                retain: false,
                kind: "result",
            };
            if !publish(out) {
                return n;
            }
            if let Some(r) = self.results.pop_front() {
                self.sent.push_back(Sent::Result(r));
            }
            n += 1;
        }
        while let Some(&ix) = self.queue.front() {
            let Some(s) = self.slots.get_mut(ix) else {
                self.queue.pop_front();
                continue;
            };
            if let (true, Some(p)) = (s.dirty, &s.payload) {
                let out = Out {
                    topic: &s.topic,
                    payload: p,
                    retain: true,
                    kind: s.kind.label(),
                };
                if !publish(out) {
                    return n;
                }
                s.published = Some(now);
                self.sent.push_back(Sent::Other);
                n += 1;
            }
            s.dirty = false;
            self.queue.pop_front();
        }
        n
    }

    /// Messages waiting (clears, results and retained topics).
    #[cfg(test)]
    pub fn waiting(&self) -> usize {
        self.clears.len() + self.results.len() + self.queue.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::SystemTime;

    use crate::model::BusFigures;

    fn plant() -> Plant {
        Plant::parse(
            "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\nheartbeat = \"10s\"\n\
             [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
             [[bus.drive]]\nname = \"d\"\naddress = 1\n\
             [bus.drive.process_data]\nperiod = \"10ms\"\nout = [6, 1500]\n\
             [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n\
             [[bus.drive.param]]\nparam = \"P700\"\nperiod = \"1s\"\nwritable = true\n",
            "test",
        )
        .unwrap()
    }

    fn value(point: usize, raw: i64) -> Update {
        Update::Value {
            bus: 0,
            drive: 0,
            point,
            raw,
            at: SystemTime::UNIX_EPOCH + Duration::from_millis(1234),
        }
    }

    fn drain(o: &mut Outbox, now: Instant) -> Vec<(String, String, bool)> {
        let mut all = Vec::new();
        o.flush(now, |m| {
            all.push((m.topic.to_owned(), m.payload.to_owned(), m.retain));
            true
        });
        all
    }

    fn status(s: DriveStatus, at_ms: u64) -> Update {
        Update::Status {
            bus: 0,
            drive: 0,
            status: s,
            at: SystemTime::UNIX_EPOCH + Duration::from_millis(at_ms),
        }
    }

    fn json(p: &str) -> serde_json::Value {
        serde_json::from_str(p).unwrap()
    }

    /// Issue 22, item 3: a drive that stops answering has its retained values republished
    /// stale; the next read publishes them fresh even unchanged; at the stop every value is
    /// stale.
    #[tokio::test(start_paused = true)]
    async fn values_go_stale_at_a_timeout_and_fresh_at_the_next_read() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let t = Instant::now();
        o.update(value(0, 2000), t, &p);
        o.update(value(1, 3), t, &p);
        drain(&mut o, t);
        o.update(status(DriveStatus::Timeout, 5000), t, &p);
        let out = drain(&mut o, t);
        let topics: Vec<&str> = out.iter().map(|(t, _, _)| t.as_str()).collect();
        assert_eq!(
            topics,
            [
                "drivebus/gw/b/d/status",
                "drivebus/gw/b/d/P130",
                "drivebus/gw/b/d/P700"
            ]
        );
        let v = json(&out[1].1);
        assert_eq!(
            v,
            serde_json::json!({"value": 2.0, "unit": "s", "raw": 2000, "ts": 1234,
                               "stale": true, "stale_since": 5000})
        );
        assert!(out[1].2, "retained");
        // A second timeout report changes nothing more.
        o.update(status(DriveStatus::Timeout, 6000), t, &p);
        assert_eq!(drain(&mut o, t).len(), 1, "the status only");
        // Back: the same raw value is published fresh at once (not at the heartbeat).
        o.update(status(DriveStatus::Online, 7000), t, &p);
        o.update(value(0, 2000), t, &p);
        let out = drain(&mut o, t);
        assert_eq!(out.len(), 2);
        assert_eq!(json(&out[1].1).get("stale"), None);
        // A fault is no timeout: the drive answers, its values are read and current.
        o.update(status(DriveStatus::Fault("F07".into()), 8000), t, &p);
        assert_eq!(drain(&mut o, t).len(), 1, "the status only");
        // The stop: every topic published so far, stale (P700 stayed stale from before; the
        // drive's status too, see the next test).
        let stop = o.stopping(9000);
        let topics: Vec<&str> = stop.iter().map(|(t, _)| t.as_str()).collect();
        assert_eq!(topics, ["drivebus/gw/b/d/status", "drivebus/gw/b/d/P130"]);
        assert_eq!(json(&stop[1].1)["stale_since"], 9000);
        assert!(
            drain(&mut o, t).is_empty(),
            "handed by the caller, not queued"
        );
    }

    /// Issue 22, item 3: not only the values. A drive's process data (its input words) go
    /// stale with its values at a timeout and are published fresh at the next cycle, unchanged
    /// or not; at the stop every retained topic the gateway published says stale: the values,
    /// the process data, the drive's status and the bus's figures (a status `online` or a bus
    /// utilisation read weeks after the gateway stopped is no more current than a value).
    #[tokio::test(start_paused = true)]
    async fn process_data_statuses_and_figures_say_stale_too() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let t = Instant::now();
        let pd = |words: Vec<u16>| Update::ProcessData {
            bus: 0,
            drive: 0,
            words,
            at: SystemTime::UNIX_EPOCH + Duration::from_millis(1234),
        };
        o.update(status(DriveStatus::Online, 1000), t, &p);
        o.update(pd(vec![7, 1500]), t, &p);
        o.update(value(0, 2000), t, &p);
        o.update(
            Update::Figures {
                bus: 0,
                figures: BusFigures::default(),
            },
            t,
            &p,
        );
        assert_eq!(drain(&mut o, t).len(), 4);
        o.update(status(DriveStatus::Timeout, 5000), t, &p);
        let out = drain(&mut o, t);
        let topics: Vec<&str> = out.iter().map(|(t, _, _)| t.as_str()).collect();
        assert_eq!(
            topics,
            [
                "drivebus/gw/b/d/status",
                "drivebus/gw/b/d/pd",
                "drivebus/gw/b/d/P130"
            ]
        );
        assert_eq!(
            json(&out[1].1),
            serde_json::json!({"in": [7, 1500], "out": [6, 1500], "ts": 1234,
                               "stale": true, "stale_since": 5000})
        );
        // The drive's status says timeout: that is current, not stale.
        assert_eq!(json(&out[0].1).get("stale"), None);
        // Back: the same words are published fresh at once (not at the heartbeat).
        o.update(status(DriveStatus::Online, 7000), t, &p);
        o.update(pd(vec![7, 1500]), t, &p);
        let out = drain(&mut o, t);
        assert_eq!(out.len(), 2, "{out:?}");
        assert_eq!(out[1].0, "drivebus/gw/b/d/pd");
        assert_eq!(json(&out[1].1).get("stale"), None);
        // The stop: every topic published and fresh, stale since the stop (P130 was already).
        let stop = o.stopping(9000);
        let topics: Vec<&str> = stop.iter().map(|(t, _)| t.as_str()).collect();
        assert_eq!(
            topics,
            [
                "drivebus/gw/b/status",
                "drivebus/gw/b/d/status",
                "drivebus/gw/b/d/pd"
            ]
        );
        for (topic, payload) in &stop {
            let v = json(payload);
            assert_eq!(
                (&v["stale"], &v["stale_since"]),
                (&serde_json::json!(true), &serde_json::json!(9000)),
                "{topic}: {v}"
            );
        }
        assert_eq!(
            json(&stop[1].1)["state"],
            "online",
            "what it was, marked stale"
        );
        // A connection that ends while the gateway runs on (a reload to another broker): the
        // same topics as stale copies, what is kept unchanged.
        let mut o = Outbox::new(&p);
        o.update(status(DriveStatus::Online, 1000), t, &p);
        o.update(pd(vec![7, 1500]), t, &p);
        drain(&mut o, t);
        let copies = o.stale_copies(9000);
        let topics: Vec<&str> = copies.iter().map(|(t, _)| t.as_str()).collect();
        assert_eq!(topics, ["drivebus/gw/b/d/status", "drivebus/gw/b/d/pd"]);
        assert!(
            o.stale_copies(9500)
                .iter()
                .all(|(_, p)| json(p)["stale_since"] == 9500)
        );
    }

    /// A plant of the buses named, each with one drive `d` (address 1) and points `P130`
    /// and the names in `points` (P700).
    fn plant_of(buses: &[(&str, &[&str])]) -> Plant {
        let mut text = "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\n".to_owned();
        for (bus, points) in buses {
            text.push_str(&format!(
                "[[bus]]\nname = \"{bus}\"\nprotocol = \"movilink\"\nsimulate = true\n\
                 [[bus.drive]]\nname = \"d\"\naddress = 1\n\
                 [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n"
            ));
            for p in *points {
                text.push_str(&format!(
                    "[[bus.drive.param]]\nparam = \"P700\"\nname = \"{p}\"\nperiod = \"1s\"\n"
                ));
            }
        }
        Plant::parse(&text, "test").unwrap()
    }

    fn reconfig(plant: &Plant, kept: Vec<Option<usize>>) -> Reconfig {
        Reconfig {
            generation: 2,
            plant: std::sync::Arc::new(plant.clone()),
            kept,
            sets: Vec::new(),
            asks: Vec::new(),
            json: std::sync::Mutex::new(None),
            sparkplug: std::sync::Mutex::new(None),
        }
    }

    fn value_on(bus: usize, point: usize, raw: i64) -> Update {
        Update::Value {
            bus,
            drive: 0,
            point,
            raw,
            at: SystemTime::UNIX_EPOCH + Duration::from_millis(1234),
        }
    }

    /// Issue 22, item 2: a reload keeps what is known of the buses that run on (moved to their
    /// new places, nothing published again), queues the retained topics of what went to be
    /// cleared (first, before results and values), and starts the new ones empty.
    #[tokio::test(start_paused = true)]
    async fn a_reload_carries_kept_buses_over_and_clears_the_topics_that_went() {
        let old = plant_of(&[("a", &["mode"]), ("b", &["mode", "extra"])]);
        let mut o = Outbox::new(&old);
        let t = Instant::now();
        o.update(value_on(0, 0, 100), t, &old);
        o.update(value_on(1, 0, 200), t, &old);
        o.update(value_on(1, 1, 11), t, &old);
        o.update(
            Update::Status {
                bus: 1,
                drive: 0,
                status: DriveStatus::Timeout,
                at: SystemTime::UNIX_EPOCH,
            },
            t,
            &old,
        );
        drain(&mut o, t);
        o.push_result(ResultMsg {
            topic: "r".into(),
            payload: "{}".into(),
        });
        // Bus b stays as it was and moves to index 0; bus a goes; bus c is new.
        let new = plant_of(&[("b", &["mode", "extra"]), ("c", &[])]);
        let r = reconfig(&new, vec![None, Some(0)]);
        let cleared = o.reconfigure(&old, &r);
        let gone = [
            "drivebus/gw/a/status",
            "drivebus/gw/a/d/status",
            "drivebus/gw/a/d/pd",
            "drivebus/gw/a/d/P130",
            "drivebus/gw/a/d/mode",
        ];
        assert_eq!(cleared, gone.len());
        let out = drain(&mut o, t);
        let topics: Vec<&str> = out.iter().map(|(t, _, _)| t.as_str()).collect();
        // The clears (empty, retained), then the result; nothing of b again.
        let mut want: Vec<&str> = gone.to_vec();
        want.push("r");
        assert_eq!(topics, want, "{out:?}");
        assert!(out[..gone.len()].iter().all(|(_, p, r)| p.is_empty() && *r));
        // b's state came along: its drive is still in timeout, its value unchanged is not
        // published again, a changed one is, under b's topic.
        assert_eq!(o.status(0, 0), Some(&DriveStatus::Timeout));
        o.update(value_on(0, 1, 11), t, &new);
        let out = drain(&mut o, t);
        assert_eq!(out.len(), 1, "stale, so published fresh: {out:?}");
        assert_eq!(out[0].0, "drivebus/gw/b/d/mode");
        o.update(value_on(0, 1, 11), t, &new);
        assert!(
            drain(&mut o, t).is_empty(),
            "unchanged within the heartbeat"
        );
        // c is new: nothing known, its first value published.
        assert_eq!(o.status(1, 0), None);
        o.update(value_on(1, 0, 5), t, &new);
        assert_eq!(drain(&mut o, t)[0].0, "drivebus/gw/c/d/P130");
        // Updates that name the old numbering's bus 1 point 1 now name nothing.
        assert!(!o.update(value_on(1, 1, 1), t, &new));
        // At the next connection, what was known is published again, b's values included.
        o.connected();
        let again: Vec<String> = drain(&mut o, t).into_iter().map(|m| m.0).collect();
        assert!(
            again.contains(&"drivebus/gw/b/d/P130".to_owned()),
            "{again:?}"
        );
        assert!(
            !again.iter().any(|t| t.starts_with("drivebus/gw/a/")),
            "{again:?}"
        );
    }

    /// Clears wait for the connection (they are queued, not lost) and a topic that comes back
    /// before they went out is not cleared.
    #[tokio::test(start_paused = true)]
    async fn clears_wait_for_the_broker_and_a_topic_back_again_is_kept() {
        let one = plant_of(&[("a", &[]), ("b", &[])]);
        let mut o = Outbox::new(&one);
        let t = Instant::now();
        let two = plant_of(&[("b", &[])]);
        o.reconfigure(&one, &reconfig(&two, vec![None, Some(0)]));
        assert_eq!(o.clears_waiting(), 4);
        // a comes back (another reload) before the broker took the clears.
        let three = plant_of(&[("b", &[]), ("a", &[])]);
        o.reconfigure(&two, &reconfig(&three, vec![Some(0)]));
        assert_eq!(o.clears_waiting(), 0, "a's topics are the config's again");
        o.drop_clears();
        assert!(drain(&mut o, t).is_empty());
    }

    #[tokio::test(start_paused = true)]
    async fn values_on_change_and_heartbeat() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let t0 = Instant::now();
        assert!(o.update(value(0, 2000), t0, &p));
        let out = drain(&mut o, t0);
        assert_eq!(out.len(), 1);
        assert_eq!(
            (out[0].0.as_str(), out[0].2),
            ("drivebus/gw/b/d/P130", true)
        );
        let v: serde_json::Value = serde_json::from_str(&out[0].1).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"value": 2.0, "unit": "s", "raw": 2000, "ts": 1234})
        );
        // Unchanged within the heartbeat: nothing.
        tokio::time::advance(Duration::from_secs(9)).await;
        o.update(value(0, 2000), Instant::now(), &p);
        assert!(drain(&mut o, Instant::now()).is_empty());
        // Changed: published at once.
        o.update(value(0, 2500), Instant::now(), &p);
        assert_eq!(drain(&mut o, Instant::now()).len(), 1);
        // Unchanged, a heartbeat after the last publication: published again.
        tokio::time::advance(Duration::from_millis(9_999)).await;
        o.update(value(0, 2500), Instant::now(), &p);
        assert!(drain(&mut o, Instant::now()).is_empty());
        tokio::time::advance(Duration::from_millis(1)).await;
        o.update(value(0, 2500), Instant::now(), &p);
        assert_eq!(drain(&mut o, Instant::now()).len(), 1);
        // Names nothing: refused, no panic.
        assert!(!o.update(value(9, 1), Instant::now(), &p));
        assert!(!o.update(
            Update::Status {
                bus: 3,
                drive: 0,
                status: DriveStatus::Online,
                at: SystemTime::now()
            },
            Instant::now(),
            &p
        ));
    }

    #[tokio::test(start_paused = true)]
    async fn outage_keeps_only_the_latest_per_topic() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let now = Instant::now();
        for raw in 0..1000 {
            o.update(value(0, raw), now, &p);
            o.update(
                Update::ProcessData {
                    bus: 0,
                    drive: 0,
                    words: vec![raw as u16, 7],
                    at: SystemTime::UNIX_EPOCH,
                },
                now,
                &p,
            );
        }
        assert_eq!(o.waiting(), 2, "one per topic, however many updates");
        o.connected();
        let mut out = drain(&mut o, now);
        out.sort();
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].0, "drivebus/gw/b/d/P130");
        assert!(out[0].1.contains(r#""raw":999"#), "{out:?}");
        assert_eq!(out[1].0, "drivebus/gw/b/d/pd");
        assert_eq!(out[1].1, r#"{"in":[999,7],"out":[6,1500],"ts":0}"#);
        // At the next connection everything known is published again.
        o.connected();
        assert_eq!(drain(&mut o, now).len(), 2);
    }

    #[tokio::test(start_paused = true)]
    async fn a_full_client_queue_keeps_the_rest_for_later() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let now = Instant::now();
        o.update(value(0, 1), now, &p);
        o.update(value(1, 2), now, &p);
        let mut first = Vec::new();
        assert_eq!(
            o.flush(now, |m| {
                first.push(m.topic.to_owned());
                first.len() < 2
            }),
            1
        );
        assert_eq!(first, ["drivebus/gw/b/d/P130", "drivebus/gw/b/d/P700"]);
        // Refused one comes next.
        let out = drain(&mut o, now);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].0, "drivebus/gw/b/d/P700");
        assert!(
            out[0].1.contains(r#""text":"VFC 1 & hoist""#),
            "{}",
            out[0].1
        );
    }

    #[tokio::test(start_paused = true)]
    async fn unacknowledged_results_are_sent_again_after_reconnection() {
        let p = plant();
        let mut o = Outbox::new(&p);
        let now = Instant::now();
        let r = |n: u32| ResultMsg {
            topic: format!("t/{n}"),
            payload: n.to_string(),
        };
        o.push_result(r(1));
        o.push_result(r(2));
        o.push_result(r(3));
        assert_eq!(drain(&mut o, now).len(), 3);
        o.sent_publish(11); // r1 went out as 11
        o.sent_publish(12); // r2 as 12; r3 still in the client's queue
        o.acked(11);
        o.disconnected();
        o.connected();
        let again: Vec<String> = drain(&mut o, now).into_iter().map(|m| m.0).collect();
        assert_eq!(again, ["t/2", "t/3"]);
        // Bounded.
        for n in 0..(MAX_RESULTS as u32 + 5) {
            o.push_result(r(n));
        }
        assert_eq!(o.waiting(), MAX_RESULTS);
        assert_eq!(o.dropped_results, 5);
    }
}
