//! Prometheus metrics of the gateway and the `/metrics` endpoint.
//!
//! [`Metrics`] holds one registry (the `prometheus-client` crate) with these families:
//!
//! | metric | labels |
//! |---|---|
//! | `drivebus_transactions_total` | `bus`, `drive`, `op`, `outcome` |
//! | `drivebus_transaction_seconds` (histogram, 0.5 ms … 2 s) | `bus`, `drive`, `op` |
//! | `drivebus_retries_total` | `bus` |
//! | `drivebus_rejected_frames_total` | `bus`, `reason` ([`REJECT_REASONS`]) |
//! | `drivebus_bus_utilisation`, `drivebus_bus_demand` | `bus` |
//! | `drivebus_drive_up` | `bus`, `drive`, `state` (1 for the current state, 0 for the others) |
//! | `drivebus_broker_connected` | |
//! | `drivebus_mqtt_published_total` | `kind` ([`PUBLISH_KINDS`]) |
//! | `drivebus_sets_total` | `outcome` ([`SET_OUTCOMES`]) |
//! | `drivebus_build_info` | `version` |
//! | `drivebus_runtime_tasks` | |
//! | `drivebus_config_generation` | |
//! | `drivebus_config_reloads_total` | `outcome` (`applied`, `unchanged`, `refused`) |
//!
//! Label values are the config's bus and drive names and fixed lists: nothing a drive or the
//! broker sends can add a series. An unknown rejection reason or `set` outcome is counted as
//! `other`; a metric call naming a bus or drive the plant does not have is dropped.
//!
//! The handles of every (bus, drive, op) are built in [`Metrics::new`], so a transaction looks
//! its handles up by name (or by index, [`Metrics::transaction_at`]) and allocates nothing.
//!
//! The endpoint ([`bind`], [`serve`]) is an axum router on hyper's HTTP/1.1 (the stack the
//! browser page runs on), one request per connection. It answers `GET /metrics` in the
//! OpenMetrics text format (`application/openmetrics-text; version=1.0.0`, the format
//! `prometheus-client` writes natively and Prometheus asks for first), `GET /` with a one-line
//! pointer, other paths with 404 and other methods with 405; hyper answers a malformed request
//! with 400. Its [`Limits`]: a request head is at most 8 KiB and 256 header lines (hyper's
//! 431) and must arrive
//! within 5 s (408); at most 16 connections are served at once, the next ones get 503 at once.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock, PoisonError, RwLock};
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::response::IntoResponse;
use axum::routing::any;
use hyper::body::Incoming;
use hyper_util::rt::TokioIo;
use prometheus_client::encoding::text;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::Histogram;
use prometheus_client::metrics::info::Info;
use prometheus_client::registry::{Registry, Unit};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tower_service::Service;

use super::config::Plant;
use super::model::{BusIx, DriveIx};

/// The `op` label of a transaction, in the order of the pre-built handles.
pub const OPS: [&str; 3] = ["read", "write", "process_data"];

/// The `outcome` label of a transaction.
pub const OUTCOMES: [&str; 5] = ["ok", "timeout", "device_error", "link_error", "not_sent"];

/// The `state` label of `drivebus_drive_up`.
pub const STATES: [&str; 3] = ["online", "timeout", "fault"];

/// The `reason` label of `drivebus_rejected_frames_total`; any other reason a link reports is
/// counted as `other`.
pub const REJECT_REASONS: [&str; 15] = [
    // The serial drivers count their rejections without a reason (parity, gaps, address,
    // length and block check alike).
    "checks",
    // SBus (the master's `MasterStats`).
    "mismatch",
    "unsolicited",
    "malformed",
    "foreign",
    "checksum",
    "framing",
    "line",
    "gap",
    "wrong_address",
    "wrong_function",
    "wrong_layout",
    "echo",
    "late",
    "other",
];

/// The `outcome` label of `drivebus_sets_total`: `written`, `device_refused`, `link_failed` and
/// the refusal reasons of [`SetOutcome::Refused`](super::model::SetOutcome::Refused); any
/// other is counted as `other`.
pub const SET_OUTCOMES: [&str; 19] = [
    "written",
    "device_refused",
    "link_failed",
    "not_writable",
    "range",
    "resolution",
    "access",
    "value_list",
    "width",
    "wear",
    "stale",
    "retained",
    "offline",
    "expired",
    "busy",
    "bad_request",
    "refused",
    "unknown_topic",
    "other",
];

/// The `outcome` label of `drivebus_config_reloads_total`.
pub const RELOAD_OUTCOMES: [&str; 3] = ["applied", "unchanged", "refused"];

/// The `kind` label of `drivebus_mqtt_published_total` counted without a lookup in the
/// family (another `&'static str` kind is counted too, through the family).
pub const PUBLISH_KINDS: [&str; 7] = [
    "value", "pd", "status", "result", "figures", "gateway", "clear",
];

/// Upper bounds of the latency histogram, in seconds: a MOVILINK read at 9600 baud takes
/// about 25 ms, an SBus one under 1 ms, a timeout with retries up to a few hundred ms.
pub const LATENCY_BUCKETS: [f64; 13] = [
    0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0,
];

/// The `Content-Type` of `GET /metrics`.
pub const CONTENT_TYPE: &str = "application/openmetrics-text; version=1.0.0; charset=utf-8";

type Labels = Vec<(&'static str, String)>;
type F64Gauge = Gauge<f64, AtomicU64>;

fn new_histogram() -> Histogram {
    Histogram::new(LATENCY_BUCKETS)
}

/// One drive's handles for one op.
#[derive(Debug)]
struct OpHandles {
    /// By [`OUTCOMES`].
    outcomes: [Counter; OUTCOMES.len()],
    latency: Histogram,
}

#[derive(Debug)]
struct DriveHandles {
    /// By [`OPS`]; built in `new` for the ops the drive's config uses, at first use for the
    /// others.
    ops: [OnceLock<OpHandles>; 3],
    /// By [`STATES`].
    up: [Gauge; 3],
}

#[derive(Debug)]
struct BusHandles {
    name: String,
    drive_names: Vec<String>,
    drive_ix: HashMap<String, DriveIx>,
    drives: Vec<DriveHandles>,
    retries: Counter,
    /// By [`REJECT_REASONS`].
    rejected: Vec<Counter>,
    utilisation: F64Gauge,
    demand: F64Gauge,
}

/// The handles of the plant's buses and drives, by name and by index (replaced whole at a
/// reload).
#[derive(Debug, Default)]
struct Table {
    buses: Vec<BusHandles>,
    bus_ix: HashMap<String, BusIx>,
}

/// The label families whose series are per bus or drive (a reload adds and removes series).
#[derive(Debug)]
struct PerBus {
    retries: Family<Labels, Counter>,
    rejected: Family<Labels, Counter>,
    utilisation: Family<Labels, F64Gauge>,
    demand: Family<Labels, F64Gauge>,
    up: Family<Labels, Gauge>,
}

/// The gateway's metrics registry.
#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    table: RwLock<Table>,
    per_bus: PerBus,
    /// The tokio runtime's alive tasks, read at each exposition.
    runtime_tasks: Gauge,
    /// The gateway's own tasks alive ([`crate::tasks`]).
    local_tasks: Arc<AtomicUsize>,
    /// The running config's generation (1 at the start).
    generation: Gauge,
    /// Reloads by outcome: applied, unchanged, refused.
    reloads: [Counter; 3],
    transactions: Family<Labels, Counter>,
    latency: Family<Labels, Histogram, fn() -> Histogram>,
    broker: Gauge,
    published_family: Family<Labels, Counter>,
    /// By [`PUBLISH_KINDS`].
    published: Vec<Counter>,
    /// By [`SET_OUTCOMES`].
    sets: Vec<Counter>,
    /// Size of the last exposition (the next one reserves it).
    last_size: AtomicUsize,
}

fn position(list: &[&str], item: &str) -> Option<usize> {
    list.iter().position(|x| *x == item)
}

/// The handles of `plant`'s buses and drives (series that exist already are taken as they are:
/// their counts go on).
fn table(
    plant: &Plant,
    per_bus: &PerBus,
    transactions: &Family<Labels, Counter>,
    latency: &Family<Labels, Histogram, fn() -> Histogram>,
) -> Table {
    let mut buses = Vec::with_capacity(plant.buses.len());
    let mut bus_ix = HashMap::with_capacity(plant.buses.len());
    for (bi, bus) in plant.buses.iter().enumerate() {
        let b = || vec![("bus", bus.name.clone())];
        let mut drives = Vec::with_capacity(bus.drives.len());
        let mut drive_ix = HashMap::with_capacity(bus.drives.len());
        for (di, drive) in bus.drives.iter().enumerate() {
            let handles = DriveHandles {
                ops: Default::default(),
                up: STATES.map(|s| {
                    per_bus.up.get_or_create_owned(&vec![
                        ("bus", bus.name.clone()),
                        ("drive", drive.name.clone()),
                        ("state", s.to_owned()),
                    ])
                }),
            };
            // Zero series for what the drive does, so that rate() works from the start.
            let used = [
                true,
                drive.points.iter().any(|p| p.writable),
                drive.process_data.is_some(),
            ];
            for (op, slot) in handles.ops.iter().enumerate() {
                if used.get(op).copied().unwrap_or(false) {
                    let h = op_handles(transactions, latency, &bus.name, &drive.name, op);
                    let _ = slot.set(h);
                }
            }
            drives.push(handles);
            drive_ix.insert(drive.name.clone(), di);
        }
        buses.push(BusHandles {
            name: bus.name.clone(),
            drive_names: bus.drives.iter().map(|d| d.name.clone()).collect(),
            drive_ix,
            drives,
            retries: per_bus.retries.get_or_create_owned(&b()),
            rejected: REJECT_REASONS
                .iter()
                .map(|r| {
                    per_bus.rejected.get_or_create_owned(&vec![
                        ("bus", bus.name.clone()),
                        ("reason", (*r).to_owned()),
                    ])
                })
                .collect(),
            utilisation: per_bus.utilisation.get_or_create_owned(&b()),
            demand: per_bus.demand.get_or_create_owned(&b()),
        });
        bus_ix.insert(bus.name.clone(), bi);
    }
    Table { buses, bus_ix }
}

impl Metrics {
    /// A registry for `plant`'s buses and drives.
    pub fn new(plant: &Plant) -> Self {
        let mut registry = Registry::default();
        let transactions = Family::<Labels, Counter>::default();
        let latency = Family::<Labels, Histogram, fn() -> Histogram>::new_with_constructor(
            new_histogram as fn() -> Histogram,
        );
        let per_bus = PerBus {
            retries: Family::default(),
            rejected: Family::default(),
            utilisation: Family::default(),
            demand: Family::default(),
            up: Family::default(),
        };
        let broker = Gauge::default();
        let published_family = Family::<Labels, Counter>::default();
        let sets = Family::<Labels, Counter>::default();
        let table = table(plant, &per_bus, &transactions, &latency);
        let runtime_tasks = Gauge::default();
        let generation = Gauge::default();
        generation.set(1);
        let reload_family = Family::<Labels, Counter>::default();
        let reloads = RELOAD_OUTCOMES
            .map(|o| reload_family.get_or_create_owned(&vec![("outcome", o.to_owned())]));
        let published = PUBLISH_KINDS
            .iter()
            .map(|k| published_family.get_or_create_owned(&vec![("kind", (*k).to_owned())]))
            .collect();
        let set_counters = SET_OUTCOMES
            .iter()
            .map(|o| sets.get_or_create_owned(&vec![("outcome", (*o).to_owned())]))
            .collect();

        registry.register(
            "drivebus_transactions",
            "Transactions with a drive by op and outcome",
            transactions.clone(),
        );
        registry.register_with_unit(
            "drivebus_transaction",
            "Time from a request to its answer or the give-up",
            Unit::Seconds,
            latency.clone(),
        );
        registry.register(
            "drivebus_retries",
            "Attempts repeated after a failed one",
            per_bus.retries.clone(),
        );
        registry.register(
            "drivebus_rejected_frames",
            "Received frames refused, by reason",
            per_bus.rejected.clone(),
        );
        registry.register(
            "drivebus_bus_utilisation",
            "Share of the time the wire was busy with the gateway's transactions (0-1)",
            per_bus.utilisation.clone(),
        );
        registry.register(
            "drivebus_bus_demand",
            "Share of the wire the configured polls ask for (above 1 the polls are stretched)",
            per_bus.demand.clone(),
        );
        registry.register(
            "drivebus_drive_up",
            "1 for the drive's current state, 0 for the others (all 0 before the first answer or timeout)",
            per_bus.up.clone(),
        );
        registry.register(
            "drivebus_broker_connected",
            "1 while the MQTT broker connection is up",
            broker.clone(),
        );
        registry.register(
            "drivebus_mqtt_published",
            "MQTT messages published, by kind",
            published_family.clone(),
        );
        registry.register("drivebus_sets", "set messages by outcome", sets);
        registry.register(
            "drivebus_build",
            "The drivectl version running the gateway",
            Info::new(vec![("version", env!("CARGO_PKG_VERSION"))]),
        );
        registry.register(
            "drivebus_runtime_tasks",
            "Tasks alive at the scrape: the tokio runtime's and the gateway's own on its LocalSet",
            runtime_tasks.clone(),
        );
        registry.register(
            "drivebus_config_generation",
            "The running config's generation: 1 at the start, one more at each reload that took effect",
            generation.clone(),
        );
        registry.register(
            "drivebus_config_reloads",
            "Reloads of the config (SIGHUP) by outcome",
            reload_family,
        );
        Self {
            registry,
            table: RwLock::new(table),
            per_bus,
            runtime_tasks,
            local_tasks: Arc::new(AtomicUsize::new(0)),
            generation,
            reloads,
            transactions,
            latency,
            broker,
            published_family,
            published,
            sets: set_counters,
            last_size: AtomicUsize::new(0),
        }
    }

    /// A reloaded config: the series of its buses and drives, those of buses and drives it
    /// no longer has removed (a bus or drive that stays keeps its counts, also when a reload
    /// restarts its bus).
    pub fn reconfigure(&self, plant: &Plant) {
        let new = table(plant, &self.per_bus, &self.transactions, &self.latency);
        let old = std::mem::replace(&mut *self.write_table(), new);
        let table = self.read_table();
        for b in &old.buses {
            let kept = table.bus_ix.get(&b.name).and_then(|&i| table.buses.get(i));
            if kept.is_none() {
                let bus = vec![("bus", b.name.clone())];
                self.per_bus.retries.remove(&bus);
                self.per_bus.utilisation.remove(&bus);
                self.per_bus.demand.remove(&bus);
                for r in REJECT_REASONS {
                    self.per_bus
                        .rejected
                        .remove(&vec![("bus", b.name.clone()), ("reason", r.to_owned())]);
                }
            }
            for d in &b.drive_names {
                if kept.is_some_and(|k| k.drive_ix.contains_key(d)) {
                    continue;
                }
                for s in STATES {
                    self.per_bus.up.remove(&vec![
                        ("bus", b.name.clone()),
                        ("drive", d.clone()),
                        ("state", s.to_owned()),
                    ]);
                }
                for op in OPS {
                    let base = vec![
                        ("bus", b.name.clone()),
                        ("drive", d.clone()),
                        ("op", op.to_owned()),
                    ];
                    self.latency.remove(&base);
                    for o in OUTCOMES {
                        let mut labels = base.clone();
                        labels.push(("outcome", o.to_owned()));
                        self.transactions.remove(&labels);
                    }
                }
            }
        }
    }

    fn read_table(&self) -> std::sync::RwLockReadGuard<'_, Table> {
        self.table.read().unwrap_or_else(PoisonError::into_inner)
    }

    fn write_table(&self) -> std::sync::RwLockWriteGuard<'_, Table> {
        self.table.write().unwrap_or_else(PoisonError::into_inner)
    }

    /// Run `f` on the handles of `bus` (dropped and logged when the plant has no such bus).
    fn with_bus(&self, bus: &str, f: impl FnOnce(&BusHandles)) {
        let table = self.read_table();
        let found = table
            .bus_ix
            .get(bus)
            .and_then(|&ix| table.buses.get(ix))
            .filter(|b| b.name == bus);
        match found {
            Some(b) => f(b),
            None => tracing::debug!(bus, "metrics for a bus the plant does not have: dropped"),
        }
    }

    fn drive(table: &Table, bus: &str, drive: &str) -> Option<(BusIx, DriveIx)> {
        let b = table.bus_ix.get(bus).copied()?;
        let d = table.buses.get(b)?.drive_ix.get(drive).copied();
        if d.is_none() {
            tracing::debug!(
                bus,
                drive,
                "metrics for a drive the plant does not have: dropped"
            );
        }
        Some((b, d?))
    }

    /// One transaction on `bus` with `drive`: `op` is `read`, `write`, `process_data`;
    /// `outcome` is `ok`, `timeout`, `device_error`, `link_error` or `not_sent`; `latency` from the
    /// request to the answer or the give-up.
    pub fn transaction(
        &self,
        bus: &str,
        drive: &str,
        op: &'static str,
        outcome: &'static str,
        latency: Duration,
    ) {
        let table = self.read_table();
        if let Some((b, d)) = Self::drive(&table, bus, drive) {
            Self::transaction_in(
                &table,
                &self.transactions,
                &self.latency,
                b,
                d,
                op,
                outcome,
                latency,
            );
        }
    }

    /// [`Metrics::transaction`] with the bus and drive by their indices in the plant (no
    /// name lookup).
    pub fn transaction_at(
        &self,
        bus: BusIx,
        drive: DriveIx,
        op: &'static str,
        outcome: &'static str,
        latency: Duration,
    ) {
        let table = self.read_table();
        Self::transaction_in(
            &table,
            &self.transactions,
            &self.latency,
            bus,
            drive,
            op,
            outcome,
            latency,
        );
    }

    #[allow(clippy::too_many_arguments)]
    fn transaction_in(
        table: &Table,
        transactions: &Family<Labels, Counter>,
        latency_family: &Family<Labels, Histogram, fn() -> Histogram>,
        bus: BusIx,
        drive: DriveIx,
        op: &'static str,
        outcome: &'static str,
        latency: Duration,
    ) {
        let Some(b) = table.buses.get(bus) else {
            return;
        };
        let (Some(d), Some(name)) = (b.drives.get(drive), b.drive_names.get(drive)) else {
            return;
        };
        let secs = latency.as_secs_f64();
        let (Some(opi), Some(oi)) = (position(&OPS, op), position(&OUTCOMES, outcome)) else {
            // A label outside the lists: a `&'static str` of this program, so the series
            // stay few; counted through the families (this allocates).
            let mut labels = vec![
                ("bus", b.name.clone()),
                ("drive", name.clone()),
                ("op", op.to_owned()),
            ];
            latency_family.get_or_create(&labels).observe(secs);
            labels.push(("outcome", outcome.to_owned()));
            transactions.get_or_create(&labels).inc();
            return;
        };
        let Some(slot) = d.ops.get(opi) else {
            return;
        };
        let h = slot.get_or_init(|| op_handles(transactions, latency_family, &b.name, name, opi));
        if let Some(c) = h.outcomes.get(oi) {
            c.inc();
        }
        h.latency.observe(secs);
    }

    /// Repeated attempts on `bus`.
    pub fn retries(&self, bus: &str, n: u64) {
        self.with_bus(bus, |b| {
            b.retries.inc_by(n);
        });
    }

    /// Received frames refused on `bus` for `reason` (one of [`REJECT_REASONS`]; any other is
    /// counted as `other`).
    pub fn rejected(&self, bus: &str, reason: &str, n: u64) {
        self.with_bus(bus, |b| Self::rejected_on(b, reason, n));
    }

    fn rejected_on(b: &BusHandles, reason: &str, n: u64) {
        let bus = b.name.as_str();
        let i = position(&REJECT_REASONS, reason).unwrap_or_else(|| {
            tracing::debug!(
                bus,
                reason,
                "rejection reason outside the list: counted as other"
            );
            REJECT_REASONS.len() - 1
        });
        if let Some(c) = b.rejected.get(i) {
            c.inc_by(n);
        }
    }

    /// The bus's wire utilisation (0–1) and the share its polls ask for (0 or more; above 1
    /// the polls are stretched). A value that is not a finite number leaves the gauge as it
    /// was.
    pub fn utilisation(&self, bus: &str, utilisation: f64, demand: f64) {
        self.with_bus(bus, |b| {
            if utilisation.is_finite() {
                b.utilisation.set(utilisation.clamp(0.0, 1.0));
            }
            if demand.is_finite() {
                b.demand.set(demand.max(0.0));
            }
        });
    }

    /// A drive's status (`online`, `timeout`, `fault`).
    pub fn drive_status(&self, bus: &str, drive: &str, state: &'static str) {
        let table = self.read_table();
        let Some((b, d)) = Self::drive(&table, bus, drive) else {
            return;
        };
        let Some(h) = table.buses.get(b).and_then(|b| b.drives.get(d)) else {
            return;
        };
        if position(&STATES, state).is_none() {
            tracing::debug!(bus, drive, state, "drive state outside the list: ignored");
            return;
        }
        for (s, g) in STATES.iter().zip(&h.up) {
            g.set(i64::from(*s == state));
        }
    }

    /// The broker connection is up or down.
    pub fn broker_connected(&self, up: bool) {
        self.broker.set(i64::from(up));
    }

    /// MQTT messages published (`kind`: value, status, result, figures).
    pub fn published(&self, kind: &'static str) {
        match position(&PUBLISH_KINDS, kind).and_then(|i| self.published.get(i)) {
            Some(c) => {
                c.inc();
            }
            None => {
                self.published_family
                    .get_or_create(&vec![("kind", kind.to_owned())])
                    .inc();
            }
        }
    }

    /// `set` messages by outcome (`written`, a refusal reason, `device_refused`, `link_failed`;
    /// [`SET_OUTCOMES`], any other is counted as `other`).
    pub fn set_outcome(&self, outcome: &str) {
        let i = position(&SET_OUTCOMES, outcome).unwrap_or_else(|| {
            tracing::debug!(outcome, "set outcome outside the list: counted as other");
            SET_OUTCOMES.len() - 1
        });
        if let Some(c) = self.sets.get(i) {
            c.inc();
        }
    }

    /// The counter of the gateway's own tasks ([`crate::tasks::count_on_this_thread`]).
    pub fn local_task_count(&self) -> Arc<AtomicUsize> {
        self.local_tasks.clone()
    }

    /// A reload's outcome (`applied`, `unchanged` or `refused`, [`RELOAD_OUTCOMES`]) and the
    /// generation running after it.
    pub fn reload(&self, outcome: &str, generation: u64) {
        if let Some(c) = position(&RELOAD_OUTCOMES, outcome).and_then(|i| self.reloads.get(i)) {
            c.inc();
        }
        self.generation
            .set(i64::try_from(generation).unwrap_or(i64::MAX));
    }

    /// The text exposition (OpenMetrics, [`CONTENT_TYPE`]); empty if it cannot be written.
    #[cfg(test)]
    pub fn encode(&self) -> String {
        self.try_encode().unwrap_or_default()
    }

    /// The text exposition, or why it could not be written. `drivebus_runtime_tasks` is read
    /// here from the runtime this runs in (also on its blocking threads, where the endpoint
    /// writes it); outside a runtime it keeps its last value.
    pub fn try_encode(&self) -> Result<String, std::fmt::Error> {
        if let Ok(rt) = tokio::runtime::Handle::try_current() {
            let alive = rt.metrics().num_alive_tasks();
            let own = self.local_tasks.load(Ordering::Relaxed);
            self.runtime_tasks
                .set(i64::try_from(alive.saturating_add(own)).unwrap_or(i64::MAX));
        }
        let mut out = String::with_capacity(self.last_size.load(Ordering::Relaxed) + 1024);
        text::encode(&mut out, &self.registry)?;
        self.last_size.store(out.len(), Ordering::Relaxed);
        Ok(out)
    }
}

fn op_handles(
    transactions: &Family<Labels, Counter>,
    latency: &Family<Labels, Histogram, fn() -> Histogram>,
    bus: &str,
    drive: &str,
    op: usize,
) -> OpHandles {
    let op = OPS.get(op).copied().unwrap_or("read");
    let base = vec![
        ("bus", bus.to_owned()),
        ("drive", drive.to_owned()),
        ("op", op.to_owned()),
    ];
    OpHandles {
        outcomes: OUTCOMES.map(|o| {
            let mut labels = base.clone();
            labels.push(("outcome", o.to_owned()));
            transactions.get_or_create_owned(&labels)
        }),
        latency: latency.get_or_create_owned(&base),
    }
}

/// Bind the metrics endpoint (an error names the address and what to change).
pub async fn bind(addr: std::net::SocketAddr) -> crate::error::Result<tokio::net::TcpListener> {
    tokio::net::TcpListener::bind(addr).await.map_err(|e| {
        crate::error::Error::failed(format!(
            "cannot listen on {addr} for /metrics: {e}; set [gateway] metrics to another \
             host:port or \"off\""
        ))
    })
}

/// The endpoint's limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest request head (request line and headers) read; a longer one, or one of more
    /// than 256 header lines, gets 431.
    pub max_head: usize,
    /// Time a client has, from its connection, to send the request head; then 408.
    pub head_timeout: Duration,
    /// Time the answer may take, after the head's deadline, to be taken by the client; then
    /// the connection is dropped.
    pub write_timeout: Duration,
    /// Connections served at once; the next ones get 503 at once.
    pub max_connections: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_head: 8 * 1024,
            head_timeout: Duration::from_secs(5),
            write_timeout: Duration::from_secs(10),
            max_connections: 16,
        }
    }
}

/// After the answer, what the client still sends is read and dropped for at most this long
/// (closing with unread data would reset the connection and could lose the answer).
const LINGER: Duration = Duration::from_millis(500);
/// … and at most this much.
const LINGER_BYTES: usize = 64 * 1024;

/// Header lines a request head may have (hyper counts them: 100 unless told; 8 KiB hold
/// about 140 of a Prometheus scraper's size).
const MAX_HEADERS: usize = 256;

/// The smallest read buffer hyper takes (it refuses a smaller `max_buf_size`).
const HYPER_MIN_BUF: usize = 8192;

/// The answer to a connection over the limit: written without waiting for its request (the
/// connection gets no task of its own), then closed.
const BUSY: &[u8] = b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: 38\r\nRetry-After: 1\r\nConnection: close\r\n\r\ntoo many connections to /metrics now\r\n";

/// The answer to a request head that did not arrive within [`Limits::head_timeout`] (hyper's
/// own header timeout closes without an answer).
const SLOW: &[u8] = b"HTTP/1.1 408 Request Timeout\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: 33\r\nConnection: close\r\n\r\nthe request head came too slowly\n";

/// Serve `GET /metrics` on `listener` until the task is dropped.
pub async fn serve(listener: tokio::net::TcpListener, metrics: std::sync::Arc<Metrics>) {
    serve_with(listener, metrics, Limits::default()).await;
}

/// [`serve`] with other [`Limits`].
pub async fn serve_with(listener: TcpListener, metrics: Arc<Metrics>, limits: Limits) {
    let app = router(metrics);
    let permits = Arc::new(Semaphore::new(limits.max_connections));
    // Dropping the set (this task ends) ends every connection.
    let mut connections = tokio::task::JoinSet::new();
    loop {
        while connections.try_join_next().is_some() {}
        let (stream, peer) = match listener.accept().await {
            Ok(s) => s,
            Err(e) => {
                // Out of file descriptors and the like: wait instead of spinning.
                tracing::warn!(error = %e, "metrics endpoint: cannot accept a connection");
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        match permits.clone().try_acquire_owned() {
            Ok(permit) => {
                connections.spawn(connection(stream, app.clone(), limits, permit));
            }
            Err(_) => {
                tracing::debug!(%peer, "metrics endpoint: over the connection limit, 503");
                // A fresh socket's send buffer takes these few bytes at once; if not, the
                // client just sees the connection closed.
                let _ = stream.try_write(BUSY);
            }
        }
    }
}

/// The endpoint's routes: `GET /metrics`, `GET /` (a pointer), 404 elsewhere, 405 for every
/// method but GET; every answer closes its connection.
fn router(metrics: Arc<Metrics>) -> Router {
    Router::new()
        .route("/metrics", any(exposition))
        .route("/", any(pointer))
        .fallback(not_found)
        .layer(axum::middleware::map_response(close))
        .with_state(metrics)
}

fn text(status: StatusCode, body: &str) -> axum::response::Response {
    (
        status,
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        format!("{body}\n"),
    )
        .into_response()
}

fn only_get() -> axum::response::Response {
    let mut r = text(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    r.headers_mut()
        .insert(header::ALLOW, HeaderValue::from_static("GET"));
    r
}

async fn exposition(
    method: Method,
    State(metrics): State<Arc<Metrics>>,
) -> axum::response::Response {
    if method != Method::GET {
        return only_get();
    }
    // Written on a blocking thread: a plant of thousands of drives takes milliseconds, which
    // the bus tasks on the gateway's one thread should not wait.
    match tokio::task::spawn_blocking(move || metrics.try_encode()).await {
        Ok(Ok(body)) => ([(header::CONTENT_TYPE, CONTENT_TYPE)], body).into_response(),
        _ => text(
            StatusCode::INTERNAL_SERVER_ERROR,
            "the metrics could not be written",
        ),
    }
}

async fn pointer(method: Method) -> axum::response::Response {
    if method != Method::GET {
        return only_get();
    }
    text(
        StatusCode::OK,
        "drivectl gateway: Prometheus metrics at /metrics",
    )
}

async fn not_found(method: Method) -> axum::response::Response {
    if method != Method::GET {
        return only_get();
    }
    text(
        StatusCode::NOT_FOUND,
        "not found; the metrics are at /metrics",
    )
}

/// One request per connection: every answer says so.
async fn close(mut r: axum::response::Response) -> axum::response::Response {
    tracing::debug!(status = r.status().as_u16(), "metrics endpoint");
    r.headers_mut()
        .insert(header::CONNECTION, HeaderValue::from_static("close"));
    r
}

/// One connection on hyper's HTTP/1.1: one request (its head at most `max_head` bytes,
/// within `head_timeout`), its answer (taken within `write_timeout` more), a lingering close.
async fn connection(stream: TcpStream, app: Router, limits: Limits, permit: OwnedSemaphorePermit) {
    // Set once the request head is in and the router has it.
    let asked = Arc::new(AtomicBool::new(false));
    let seen = asked.clone();
    let service = hyper::service::service_fn(move |request: hyper::Request<Incoming>| {
        seen.store(true, Ordering::Relaxed);
        let mut app = app.clone();
        Box::pin(async move { app.call(request).await })
    });
    let mut conn = hyper::server::conn::http1::Builder::new()
        .max_header_size(limits.max_head)
        .max_buf_size(limits.max_head.max(HYPER_MIN_BUF))
        .max_headers(MAX_HEADERS)
        .keep_alive(false)
        .title_case_headers(true)
        .serve_connection(TokioIo::new(stream), service);
    let head_by = tokio::time::Instant::now() + limits.head_timeout;
    let mut deadline = head_by;
    let timed_out = loop {
        tokio::select! {
            done = std::future::poll_fn(|cx| conn.poll_without_shutdown(cx)) => {
                if let Err(e) = done {
                    tracing::debug!(error = %e, "metrics endpoint: connection ended");
                }
                break false;
            }
            () = tokio::time::sleep_until(deadline) => {
                if !asked.load(Ordering::Relaxed) {
                    break true;
                }
                if deadline > head_by {
                    // The answer was not taken in time: dropped.
                    return;
                }
                deadline = head_by + limits.write_timeout;
            }
        }
    };
    let mut stream = conn.into_parts().io.into_inner();
    if timed_out {
        tracing::debug!("metrics endpoint: request head too slow, 408");
        let sent = tokio::time::timeout(limits.write_timeout, stream.write_all(SLOW)).await;
        if !matches!(sent, Ok(Ok(()))) {
            return;
        }
    }
    if stream.shutdown().await.is_err() {
        return;
    }
    // Lingering close: take what the client still sends (the rest of an oversized head) so
    // that closing does not reset the connection before it has read the answer.
    let _ = tokio::time::timeout(LINGER, async {
        let mut sink = [0u8; 1024];
        let mut total = 0;
        while total < LINGER_BYTES {
            match stream.read(&mut sink).await {
                Ok(0) | Err(_) => break,
                Ok(n) => total += n,
            }
        }
    })
    .await;
    drop(permit);
}

#[cfg(test)]
mod tests;
