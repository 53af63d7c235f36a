//! The gateway's tasks for a plant, and the reload of its config without a restart.
//!
//! [`serve_source`] starts one task per bus, the publishers (the JSON topics' MQTT task, the
//! Sparkplug node), the page and `/metrics`, and a fan-out task that hands every update of the
//! buses to the page's hub and to each publisher. Then it waits for signals: a stop signal stops
//! the buses (the drives they control get their stop) and then the publishers; SIGHUP reads the
//! config again ([`Source`]) and, when all of it checks, puts it into effect:
//!
//! 1. **Check everything first** (`Running::prepare`): the config file, the broker
//!    connections' files where their settings changed, the page's certificate, key and users,
//!    the listeners of a page or `/metrics` that moved. Anything that fails leaves the running
//!    config as it is, says why in the log and on the gateway's status topic.
//! 2. **Buses** (`Running::commit`): a bus whose settings did not change keeps running: its
//!    port stays open, no poll is missed, its writes waiting stay. A bus that changed or went
//!    is stopped (the drives it controls over process data get their stop unless the new config
//!    carries their process data on on the same line), then the new ones start.
//! 3. **One step** moves every running bus to its index in the new plant and sends the
//!    [`Update::Reconfigured`] that tells the page and the publishers: the updates before it are
//!    the old plant's, those after it the new one's. The JSON publisher clears the retained
//!    topics of what went, and connects again only when the broker settings changed; the
//!    Sparkplug node sends DDEATH for a device that went and is born again.

use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime};

use tokio::sync::{mpsc, watch};

use crate::bus::{BusContext, Stop};
use crate::config::{Bus, Endpoint, Plant};
use crate::error::{Error, Result};
use crate::metrics::Metrics;
use crate::model::{Ask, BusIx, BusSlot, ConfigStatus, Reconfig, SetRequest, Update};
use crate::mqtt::payload::millis;
use crate::mqtt::{AbortOnDrop, End, Mqtt};
use crate::sparkplug::Sparkplug;
use crate::{families, metrics, ui};

/// How long the buses get at the stop (or a reload's bus that goes) to finish their
/// transaction and stop their drives.
pub const BUS_STOP_LIMIT: Duration = Duration::from_secs(10);

/// The update queue between the bus tasks and the fan-out, and from it to each publisher.
const UPDATES: usize = 4096;

/// Where a plant's config comes from, and how to read it again at SIGHUP.
pub struct Source {
    /// The file, as the gateway's status topic names it (`None`: not from a file).
    file: Option<String>,
    /// Reads and checks the config again (with what the command line adds to it); `None`:
    /// the config cannot be read again, and SIGHUP stops the gateway as the other stop
    /// signals do.
    load: Option<Box<dyn FnMut() -> Result<Plant>>>,
}

impl std::fmt::Debug for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Source")
            .field("file", &self.file)
            .field("reloads", &self.load.is_some())
            .finish()
    }
}

impl Source {
    /// A plant given by a program: SIGHUP stops the gateway (as Ctrl-C and SIGTERM do).
    pub fn fixed() -> Source {
        Source {
            file: None,
            load: None,
        }
    }

    /// A config read from `file` by `load`, which SIGHUP calls again (a reload).
    pub fn file(file: impl Into<String>, load: impl FnMut() -> Result<Plant> + 'static) -> Source {
        Source {
            file: Some(file.into()),
            load: Some(Box::new(load)),
        }
    }

    /// A config from `file` that cannot be read again (standard input): SIGHUP keeps the
    /// gateway running and says why it cannot reload (unless its terminal closed).
    pub fn once(file: impl Into<String>) -> Source {
        Source {
            file: Some(file.into()),
            load: None,
        }
    }
}

/// A running bus task.
#[derive(Debug)]
struct BusRun {
    config: Bus,
    slot: BusSlot,
    sets: mpsc::Sender<SetRequest>,
    asks: mpsc::Sender<Ask>,
    stop: watch::Sender<Stop>,
    /// `None` until [`spawn_bus`].
    task: Option<tokio::task::JoinHandle<()>>,
}

/// The channels of bus `bus` at index `ix`, and the context its task is to run with
/// ([`spawn_bus`]: a reload starts a new bus's task only after its notice).
fn bus_run(
    ix: BusIx,
    bus: &Bus,
    updates: &mpsc::Sender<Update>,
    metrics: &Arc<Metrics>,
    announce: &watch::Sender<u64>,
) -> (BusRun, BusContext) {
    let (sets, set_rx) = mpsc::channel(64);
    let (asks, ask_rx) = mpsc::channel(64);
    let (stop, stop_rx) = watch::channel(Stop::Run);
    let slot = BusSlot::new(ix);
    let ctx = BusContext {
        ix: slot.clone(),
        bus: bus.clone(),
        updates: updates.clone(),
        sets: set_rx,
        asks: ask_rx,
        metrics: metrics.clone(),
        shutdown: stop_rx,
        announce: announce.subscribe(),
    };
    let run = BusRun {
        config: bus.clone(),
        slot,
        sets,
        asks,
        stop,
        task: None,
    };
    (run, ctx)
}

/// Start the task of `ctx` into `run`.
fn spawn_bus(run: &mut BusRun, ctx: BusContext) {
    run.task = Some(crate::tasks::spawn_local(families::run_bus(ctx)));
}

/// A publisher task (the JSON topics, the Sparkplug node).
#[derive(Debug)]
struct Publisher<E> {
    /// What its connection depends on ([`crate::mqtt::connect::fingerprint`]).
    fingerprint: u64,
    /// Its stop.
    end: watch::Sender<Option<E>>,
    task: tokio::task::JoinHandle<Result<()>>,
}

/// The page: its hub, its listener's address, its security's fingerprint and its server.
#[derive(Debug)]
struct Page {
    hub: Arc<ui::Hub>,
    listen: std::net::SocketAddr,
    security: u64,
    _server: AbortOnDrop,
}

/// What the fan-out hands updates to.
#[derive(Debug, Default)]
struct Outputs {
    hub: Option<Arc<ui::Hub>>,
    json: Option<mpsc::Sender<Update>>,
    spb: Option<mpsc::Sender<Update>>,
}

/// A change of the fan-out's outputs that comes with the reload of `generation`: `None` keeps
/// an output (it gets the reload's notice), `Some(x)` replaces it by `x` after the notice (a new
/// output starts on the new plant; a removed one gets no notice).
#[derive(Debug, Default)]
struct Change {
    generation: u64,
    hub: Option<Option<Arc<ui::Hub>>>,
    json: Option<Option<mpsc::Sender<Update>>>,
    spb: Option<Option<mpsc::Sender<Update>>>,
}

/// Hand every update of the bus tasks to the page's hub and to each publisher (waiting for
/// the slowest: the buses never outrun them), and a reload's notice with its change of outputs.
async fn fanout(
    mut from: mpsc::Receiver<Update>,
    mut outs: Outputs,
    mut changes: mpsc::UnboundedReceiver<Change>,
) {
    while let Some(u) = from.recv().await {
        let reload = match &u {
            Update::Reconfigured(r) => Some(r.clone()),
            _ => None,
        };
        let Some(r) = reload else {
            if let Some(h) = &outs.hub {
                h.apply(&u);
            }
            send_both(&outs, u).await;
            continue;
        };
        // The change was sent before the notice: it is there.
        let mut change = None;
        while let Ok(c) = changes.try_recv() {
            if c.generation == r.generation {
                change = Some(c);
            }
        }
        let change = change.unwrap_or_default();
        if change.hub.is_none()
            && let Some(h) = &outs.hub
        {
            h.reconfigure(&r);
        }
        let keep = Outputs {
            hub: None,
            json: if change.json.is_none() {
                outs.json.clone()
            } else {
                None
            },
            spb: if change.spb.is_none() {
                outs.spb.clone()
            } else {
                None
            },
        };
        send_both(&keep, u).await;
        if let Some(h) = change.hub {
            outs.hub = h;
        }
        if let Some(j) = change.json {
            outs.json = j;
        }
        if let Some(s) = change.spb {
            outs.spb = s;
        }
    }
}

/// `u` to the JSON publisher and the Sparkplug node, where they are.
async fn send_both(outs: &Outputs, u: Update) {
    match (&outs.json, &outs.spb) {
        (Some(a), Some(b)) => {
            let _ = a.send(u.clone()).await;
            let _ = b.send(u).await;
        }
        (Some(a), None) => {
            let _ = a.send(u).await;
        }
        (None, Some(b)) => {
            let _ = b.send(u).await;
        }
        (None, None) => {}
    }
}

/// Everything that runs for the plant.
struct Running {
    plant: Arc<Plant>,
    generation: u64,
    buses: Vec<BusRun>,
    updates: mpsc::Sender<Update>,
    metrics: Arc<Metrics>,
    metrics_server: Option<(std::net::SocketAddr, AbortOnDrop)>,
    page: Option<Page>,
    json: Option<Publisher<End>>,
    spb: Option<Publisher<bool>>,
    /// Publishers a reload removed, finishing their end.
    leaving: Vec<tokio::task::JoinHandle<Result<()>>>,
    changes: mpsc::UnboundedSender<Change>,
    config: watch::Sender<ConfigStatus>,
    /// Asks every bus task for its drives' statuses again.
    announce: watch::Sender<u64>,
}

/// What a reload found to do, all of it checked and prepared (`Running::prepare`).
struct Prepared {
    plant: Arc<Plant>,
    /// `None`: keep as it is; `Some(None)`: stop; `Some(Some(m))`: a new connection.
    json: Option<Option<Mqtt>>,
    spb: Option<Option<Sparkplug>>,
    /// `None`: keep; `Some(None)`: stop the page; `Some(Some(..))`: serve it anew with this
    /// security (and this listener where it moved).
    page: Option<Option<PageStart>>,
    /// `None`: keep; `Some(None)`: off; `Some(Some(..))`: a new listener.
    metrics: Option<Option<(std::net::SocketAddr, tokio::net::TcpListener)>>,
}

/// A page to serve: its security, the fingerprint of its files, and a listener where it moved.
struct PageStart {
    security: ui::auth::Security,
    fingerprint: u64,
    listen: std::net::SocketAddr,
    listener: Option<tokio::net::TcpListener>,
}

/// What the page's security depends on: `[ui]` and the contents of its files.
fn page_fingerprint(u: &crate::config::Ui) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    format!("{u:?}").hash(&mut h);
    let files = [
        u.tls.as_ref().map(|t| t.cert.as_str()),
        u.tls.as_ref().map(|t| t.key.as_str()),
        u.users.as_deref(),
    ];
    for f in files.into_iter().flatten() {
        match std::fs::read(f) {
            Ok(bytes) => bytes.hash(&mut h),
            Err(e) => e.kind().hash(&mut h),
        }
    }
    h.finish()
}

/// The address a page is served at, and how (for the log).
fn log_page(listener: &tokio::net::TcpListener, security: &ui::auth::Security) {
    if let Ok(at) = listener.local_addr() {
        let scheme = if security.tls.is_some() {
            "https"
        } else {
            "http"
        };
        let login = security.auth.login_required();
        tracing::info!(url = %format!("{scheme}://{at}/"), login, "the page is served");
    }
}

/// Serve the page on `listener` for `hub`, until the handle is dropped.
fn serve_page(
    listener: tokio::net::TcpListener,
    hub: Arc<ui::Hub>,
    security: ui::auth::Security,
) -> AbortOnDrop {
    log_page(&listener, &security);
    // The page's connections (live event streams) never end by themselves, so the gateway does
    // not wait for them at the stop.
    AbortOnDrop(crate::tasks::spawn_local(async move {
        if let Err(e) = ui::serve_with(listener, hub, security, std::future::pending()).await {
            tracing::error!(error = %e, "the page stopped");
        }
    }))
}

/// A hub for `plant` whose page's jobs run on this thread.
fn new_hub(plant: &Arc<Plant>, asks: Vec<mpsc::Sender<Ask>>) -> Arc<ui::Hub> {
    let (jobs, worker) = ui::drive::jobs();
    crate::tasks::spawn_local(worker.run());
    ui::Hub::serving(plant.clone(), asks, Some(jobs))
}

/// Start the JSON topics' publisher `m`.
fn start_json(
    m: Mqtt,
    sets: Vec<mpsc::Sender<SetRequest>>,
    metrics: &Arc<Metrics>,
    config: watch::Receiver<ConfigStatus>,
) -> (Publisher<End>, mpsc::Sender<Update>) {
    let (tx, rx) = mpsc::channel(UPDATES);
    let (end, mut end_rx) = watch::channel(None);
    let fingerprint = m.fingerprint();
    let shutdown = async move {
        let r = end_rx.wait_for(Option::is_some).await;
        r.ok().and_then(|e| *e).unwrap_or(End::Stop)
    };
    let task = crate::tasks::spawn_local(m.run(rx, sets, metrics.clone(), config, shutdown));
    (
        Publisher {
            fingerprint,
            end,
            task,
        },
        tx,
    )
}

/// Start the Sparkplug node `s`.
fn start_spb(
    s: Sparkplug,
    sets: Vec<mpsc::Sender<SetRequest>>,
    metrics: &Arc<Metrics>,
) -> (Publisher<bool>, mpsc::Sender<Update>) {
    let (tx, rx) = mpsc::channel(UPDATES);
    let (end, end_rx) = watch::channel(None);
    let fingerprint = s.fingerprint();
    // The node's stop is a flag.
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut end_rx2: watch::Receiver<Option<bool>> = end_rx;
    crate::tasks::spawn_local(async move {
        let _ = end_rx2.wait_for(Option::is_some).await;
        let _ = stop_tx.send(true);
    });
    let task = crate::tasks::spawn_local(s.run(rx, sets, metrics.clone(), stop_rx));
    (
        Publisher {
            fingerprint,
            end,
            task,
        },
        tx,
    )
}

impl Running {
    fn sets(&self) -> Vec<mpsc::Sender<SetRequest>> {
        self.buses.iter().map(|b| b.sets.clone()).collect()
    }

    fn asks(&self) -> Vec<mpsc::Sender<Ask>> {
        self.buses.iter().map(|b| b.asks.clone()).collect()
    }

    /// Read the config again and put it into effect, or keep the running one and say why.
    async fn reload(&mut self, source: &mut Source) {
        let at = millis(SystemTime::now());
        let Some(load) = source.load.as_mut() else {
            let why = "the config came from standard input: nothing to read again; restart \
                       the gateway to change it";
            tracing::warn!("SIGHUP: {why}");
            self.metrics.reload("refused", self.generation);
            self.config
                .send_modify(|c| c.last_reload = Some((at, Some(why.to_owned()))));
            return;
        };
        tracing::info!(file = ?source.file, "SIGHUP: reading the config again");
        let prepared = match load() {
            Ok(plant) => self.prepare(plant).await,
            Err(e) => Err(e),
        };
        match prepared {
            Ok(Some(p)) => {
                self.commit(p).await;
                let generation = self.generation;
                self.metrics.reload("applied", generation);
                self.config.send_modify(|c| {
                    c.generation = generation;
                    c.loaded = millis(SystemTime::now());
                    c.last_reload = Some((at, None));
                });
            }
            Ok(None) => {
                tracing::info!("the config is unchanged: nothing to do");
                self.metrics.reload("unchanged", self.generation);
                self.config
                    .send_modify(|c| c.last_reload = Some((at, None)));
            }
            Err(e) => {
                tracing::error!(error = %e, "the reloaded config was refused: the running config stays as it is");
                self.metrics.reload("refused", self.generation);
                self.config
                    .send_modify(|c| c.last_reload = Some((at, Some(e.to_string()))));
            }
        }
    }

    /// Check all of `plant` and prepare what it changes; `None` when nothing changes.
    async fn prepare(&self, plant: Plant) -> Result<Option<Prepared>> {
        let plant = Arc::new(plant);
        let json = match (plant.publishes_json(), &self.json) {
            (true, Some(p))
                if p.fingerprint == crate::mqtt::connect::fingerprint(&plant.gateway, "") =>
            {
                None
            }
            (true, _) => Some(Some(Mqtt::prepare(&plant)?)),
            (false, Some(_)) => Some(None),
            (false, None) => None,
        };
        let spb = match (Sparkplug::fingerprint_of(&plant), &self.spb) {
            (Some(fp), Some(p)) if p.fingerprint == fp => None,
            (Some(_), _) => Some(Sparkplug::prepare(&plant)?),
            (None, Some(_)) => Some(None),
            (None, None) => None,
        };
        let page = match (&plant.ui, &self.page) {
            (Some(u), running) => {
                let fingerprint = page_fingerprint(u);
                match running {
                    Some(p) if p.listen == u.listen && p.security == fingerprint => None,
                    _ => {
                        // Read and checked as at the start (a bad file keeps the page as it is).
                        let security = ui::auth::Security::load(u)?;
                        let listener = match running {
                            Some(p) if p.listen == u.listen => None,
                            _ => Some(ui::bind(u.listen).await?),
                        };
                        Some(Some(PageStart {
                            security,
                            fingerprint,
                            listen: u.listen,
                            listener,
                        }))
                    }
                }
            }
            (None, Some(_)) => Some(None),
            (None, None) => None,
        };
        let metrics = match (plant.gateway.metrics, &self.metrics_server) {
            (Some(a), Some((b, _))) if a == *b => None,
            (Some(a), _) => Some(Some((a, metrics::bind(a).await?))),
            (None, Some(_)) => Some(None),
            (None, None) => None,
        };
        let unchanged = *plant == *self.plant
            && json.is_none()
            && spb.is_none()
            && page.is_none()
            && metrics.is_none();
        if unchanged {
            return Ok(None);
        }
        Ok(Some(Prepared {
            plant,
            json,
            spb,
            page,
            metrics,
        }))
    }

    /// Put a prepared reload into effect (nothing in it can fail).
    async fn commit(&mut self, p: Prepared) {
        let new = p.plant;
        let generation = self.generation + 1;
        // Which running buses keep running, and where.
        let kept: Vec<Option<BusIx>> = self
            .buses
            .iter()
            .map(|b| new.buses.iter().position(|n| *n == b.config))
            .collect();
        // The buses that change or go: stopped first (their ports closed before a new bus
        // opens the same one).
        let mut going = Vec::new();
        for (run, k) in self.buses.iter().zip(&kept) {
            if k.is_none() {
                let continued = continued_addresses(&run.config, &new);
                let _ = run.stop.send(Stop::Retire { continued });
            }
        }
        let old_buses = std::mem::take(&mut self.buses);
        let mut slots: Vec<Option<BusRun>> = (0..new.buses.len()).map(|_| None).collect();
        for (run, k) in old_buses.into_iter().zip(&kept) {
            match k {
                Some(ix) => {
                    if let Some(s) = slots.get_mut(*ix) {
                        *s = Some(run);
                    }
                }
                None => going.push(run),
            }
        }
        let names: Vec<String> = going.iter().map(|r| r.config.name.clone()).collect();
        let stops = futures_join(going.into_iter().filter_map(|r| r.task).collect());
        if tokio::time::timeout(BUS_STOP_LIMIT, stops).await.is_err() {
            tracing::warn!(
                "a bus that the reloaded config changes or removes did not stop within {} s: \
                 going on without it",
                BUS_STOP_LIMIT.as_secs()
            );
        }
        self.metrics.reconfigure(&new);
        // The new and changed buses: channels now, tasks after the notice.
        let mut starts = Vec::new();
        let mut buses = Vec::with_capacity(new.buses.len());
        for (ix, slot) in slots.into_iter().enumerate() {
            match slot {
                Some(run) => buses.push(run),
                None => {
                    let Some(bus) = new.buses.get(ix) else {
                        continue;
                    };
                    let (run, ctx) = bus_run(ix, bus, &self.updates, &self.metrics, &self.announce);
                    buses.push(run);
                    starts.push((ix, ctx));
                }
            }
        }
        self.buses = buses;
        let sets = self.sets();
        let asks = self.asks();
        // The publishers: a JSON or Sparkplug connection that changes is the task's own
        // business (the notice brings it); one added starts on the new plant, one removed ends.
        let mut change = Change {
            generation,
            ..Change::default()
        };
        let mut json_next = None;
        match p.json {
            None => {}
            Some(Some(m)) if self.json.is_some() => {
                if let Some(j) = &mut self.json {
                    j.fingerprint = m.fingerprint();
                }
                json_next = Some(m);
            }
            Some(Some(m)) => {
                let (publisher, tx) =
                    start_json(m, sets.clone(), &self.metrics, self.config.subscribe());
                self.json = Some(publisher);
                change.json = Some(Some(tx));
            }
            Some(None) => {
                if let Some(j) = self.json.take() {
                    let _ = j.end.send(Some(End::Clear));
                    self.leaving.push(j.task);
                }
                change.json = Some(None);
            }
        }
        let mut spb_next = None;
        match p.spb {
            None => {}
            Some(Some(s)) if self.spb.is_some() => {
                if let Some(j) = &mut self.spb {
                    j.fingerprint = s.fingerprint();
                }
                spb_next = Some(s);
            }
            Some(Some(s)) => {
                let (publisher, tx) = start_spb(s, sets.clone(), &self.metrics);
                self.spb = Some(publisher);
                change.spb = Some(Some(tx));
            }
            Some(None) => {
                if let Some(j) = self.spb.take() {
                    let _ = j.end.send(Some(true));
                    self.leaving.push(j.task);
                }
                change.spb = Some(None);
            }
        }
        match p.page {
            None => {}
            Some(None) => {
                self.page = None;
                change.hub = Some(None);
                tracing::info!("the page is no longer served");
            }
            Some(Some(start)) => {
                let (hub, fresh) = match &self.page {
                    Some(page) => (page.hub.clone(), false),
                    None => {
                        let hub = new_hub(&new, asks.clone());
                        hub.begin_at(generation);
                        (hub, true)
                    }
                };
                if fresh {
                    change.hub = Some(Some(hub.clone()));
                }
                // A page that stays where it is: its old server goes first (its listener's
                // address is taken again at once).
                let listener = match start.listener {
                    Some(l) => Some(l),
                    None => {
                        self.page = None;
                        tokio::task::yield_now().await;
                        match ui::bind(start.listen).await {
                            Ok(l) => Some(l),
                            Err(e) => {
                                tracing::error!(error = %e, "the page cannot be served again");
                                None
                            }
                        }
                    }
                };
                self.page = listener.map(|l| Page {
                    _server: serve_page(l, hub.clone(), start.security),
                    hub,
                    listen: start.listen,
                    security: start.fingerprint,
                });
                if self.page.is_none() && !fresh {
                    change.hub = Some(None);
                }
            }
        }
        match p.metrics {
            None => {}
            Some(None) => {
                self.metrics_server = None;
                tracing::info!("/metrics is no longer served");
            }
            Some(Some((addr, listener))) => {
                let server = AbortOnDrop(crate::tasks::spawn_local(metrics::serve(
                    listener,
                    self.metrics.clone(),
                )));
                self.metrics_server = Some((addr, server));
                tracing::info!(%addr, "/metrics served at the reloaded config's address");
            }
        }
        let r = Arc::new(Reconfig {
            generation,
            plant: new.clone(),
            kept: kept.clone(),
            sets,
            asks,
            json: Mutex::new(json_next),
            sparkplug: Mutex::new(spb_next),
        });
        let _ = self.changes.send(change);
        // One step: every running bus to its new index, then the notice, with nothing in
        // between (the queue's place is taken first).
        match self.updates.reserve().await {
            Ok(permit) => {
                for (old, k) in kept.iter().enumerate() {
                    if let Some(ix) = k
                        && let Some(run) = self.buses.get(*ix)
                    {
                        tracing::trace!(old, new = ix, bus = %run.config.name, "bus moved");
                        run.slot.set(*ix);
                    }
                }
                permit.send(Update::Reconfigured(r));
            }
            Err(_) => tracing::warn!(
                "the gateway's update queue is gone: the reload reaches no publisher"
            ),
        }
        // A publisher or page started now has seen no drive's status (each is reported when it
        // changes): every bus reports them again.
        self.announce.send_modify(|n| *n += 1);
        for (ix, ctx) in starts {
            if let Some(run) = self.buses.get_mut(ix) {
                spawn_bus(run, ctx);
            }
        }
        let started: Vec<&str> = self
            .buses
            .iter()
            .zip(0..)
            .filter(|(_, ix)| !kept.contains(&Some(*ix)))
            .map(|(b, _)| b.config.name.as_str())
            .collect();
        let running_on: Vec<&str> = kept
            .iter()
            .flatten()
            .filter_map(|ix| self.buses.get(*ix))
            .map(|b| b.config.name.as_str())
            .collect();
        tracing::info!(
            generation,
            kept = ?running_on,
            stopped = ?names,
            started = ?started,
            "the reloaded config is in effect"
        );
        self.plant = new;
        self.generation = generation;
    }

    /// Stop everything: the buses first (bounded; a second stop signal stops at once), then
    /// the publishers. The JSON publisher's result.
    async fn stop(mut self, signals: &mut Signals) -> Result<()> {
        for b in &self.buses {
            let _ = b.stop.send(Stop::Gateway);
        }
        let all = tokio::time::timeout(
            BUS_STOP_LIMIT,
            futures_join(self.buses.drain(..).filter_map(|b| b.task).collect()),
        );
        tokio::select! {
            r = all => if r.is_err() {
                tracing::warn!(
                    "the buses did not finish within {} s: stopping without them",
                    BUS_STOP_LIMIT.as_secs()
                );
            },
            signal = signals.stop() => tracing::warn!(
                signal,
                "stopping at once: drives controlled over process data may not have been sent their stop"
            ),
        }
        if let Some(s) = &self.spb {
            let _ = s.end.send(Some(true));
        }
        if let Some(j) = &self.json {
            let _ = j.end.send(Some(End::Stop));
        }
        let mut result = Ok(());
        if let Some(s) = self.spb.take() {
            match s.task.await {
                Ok(r) => r?,
                Err(e) => tracing::error!(error = %e, "the Sparkplug task ended abnormally"),
            }
        }
        if let Some(j) = self.json.take() {
            match j.task.await {
                Ok(r) => result = r,
                Err(e) => tracing::error!(error = %e, "the MQTT task ended abnormally"),
            }
        }
        futures_join(std::mem::take(&mut self.leaving)).await;
        result
    }
}

/// The addresses of `old`'s drives that `new` controls over process data on the same line
/// (the same serial port or CAN interface, or the same simulated bus): their task in the new
/// config carries their process data on, so the old one sends them no stop.
fn continued_addresses(old: &Bus, new: &Plant) -> Vec<u8> {
    let same_line = |b: &Bus| match (&old.endpoint, &b.endpoint) {
        (Endpoint::Serial { path: a, .. }, Endpoint::Serial { path: c, .. }) => a == c,
        (Endpoint::Can { iface: a, .. }, Endpoint::Can { iface: c, .. }) => a == c,
        // Simulated drives live with their bus task: a new task has new ones.
        _ => false,
    };
    let Some(next) = new
        .buses
        .iter()
        .find(|b| b.protocol == old.protocol && same_line(b))
    else {
        return Vec::new();
    };
    old.drives
        .iter()
        .filter(|d| d.process_data.is_some())
        .filter(|d| {
            next.drives
                .iter()
                .any(|n| n.address == d.address && n.process_data.is_some())
        })
        .map(|d| d.address)
        .collect()
}

/// Wait for every task (their panics and cancellations are the tasks' business: logged by
/// tokio, nothing to do here).
async fn futures_join<T>(tasks: Vec<tokio::task::JoinHandle<T>>) {
    for t in tasks {
        let _ = t.await;
    }
}

/// Run the gateway's tasks for `plant` until a stop signal; SIGHUP reloads from `source`.
pub async fn serve_source(plant: Plant, mut source: Source) -> Result<()> {
    // Taken before anything starts: from here on no stop signal ends the process without
    // the drives' stop.
    let mut signals = Signals::new();
    let terminal = Terminal::at_start();
    let plant = Arc::new(plant);
    let metrics = Arc::new(Metrics::new(&plant));
    crate::tasks::count_on_this_thread(metrics.local_task_count());
    // Prepared before anything else starts, so that a bad certificate or password file is
    // an error before a bus is opened.
    let json = if plant.publishes_json() {
        Some(Mqtt::prepare(&plant)?)
    } else {
        None
    };
    let spb = Sparkplug::prepare(&plant)?;
    // The page's files (certificate, key, users) are read and its port is taken before a bus
    // opens: a bad file or a port in use is an error at the start.
    let page = match &plant.ui {
        Some(u) => Some((
            ui::auth::Security::load(u)?,
            ui::bind(u.listen).await?,
            u.listen,
            page_fingerprint(u),
        )),
        None => None,
    };
    let metrics_listener = match plant.gateway.metrics {
        Some(addr) => Some((addr, metrics::bind(addr).await?)),
        None => None,
    };
    let (config, config_rx) = watch::channel(ConfigStatus {
        file: source.file.clone(),
        generation: 1,
        loaded: millis(SystemTime::now()),
        last_reload: None,
    });
    let (updates, updates_rx) = mpsc::channel(UPDATES);
    let (announce, _) = watch::channel(0);
    let mut buses = Vec::with_capacity(plant.buses.len());
    for (ix, bus) in plant.buses.iter().enumerate() {
        let (mut run, ctx) = bus_run(ix, bus, &updates, &metrics, &announce);
        spawn_bus(&mut run, ctx);
        buses.push(run);
    }
    let metrics_server = metrics_listener.map(|(addr, listener)| {
        (
            addr,
            AbortOnDrop(crate::tasks::spawn_local(metrics::serve(
                listener,
                metrics.clone(),
            ))),
        )
    });
    let sets: Vec<_> = buses.iter().map(|b: &BusRun| b.sets.clone()).collect();
    let asks: Vec<_> = buses.iter().map(|b: &BusRun| b.asks.clone()).collect();
    let mut outs = Outputs::default();
    let page = page.map(|(security, listener, listen, fingerprint)| {
        let hub = new_hub(&plant, asks.clone());
        outs.hub = Some(hub.clone());
        Page {
            _server: serve_page(listener, hub.clone(), security),
            hub,
            listen,
            security: fingerprint,
        }
    });
    let json = json.map(|m| {
        let (p, tx) = start_json(m, sets.clone(), &metrics, config_rx.clone());
        outs.json = Some(tx);
        p
    });
    let spb = spb.map(|s| {
        let (p, tx) = start_spb(s, sets.clone(), &metrics);
        outs.spb = Some(tx);
        p
    });
    let (changes, changes_rx) = mpsc::unbounded_channel();
    crate::tasks::spawn_local(fanout(updates_rx, outs, changes_rx));
    let mut running = Running {
        plant,
        generation: 1,
        buses,
        updates,
        metrics,
        metrics_server,
        page,
        json,
        spb,
        leaving: Vec::new(),
        changes,
        config,
        announce,
    };
    let signal = loop {
        match signals.next().await {
            Signal::Stop(name) => break name,
            Signal::Hangup if source.load.is_none() && source.file.is_none() => break "SIGHUP",
            Signal::Hangup if terminal.hung_up() => {
                tracing::info!("SIGHUP: the terminal closed");
                break "SIGHUP";
            }
            Signal::Hangup => running.reload(&mut source).await,
        }
        // Publishers a reload removed that have finished.
        running.leaving.retain(|t| !t.is_finished());
    };
    tracing::info!(
        signal,
        "stopping: the buses finish, then the broker is told offline"
    );
    running.stop(&mut signals).await
}

/// Whether the gateway runs in a terminal, to tell a closed terminal's SIGHUP (stop: nobody
/// watches any more) from a reload asked with `kill -HUP` or `systemctl reload`.
#[derive(Debug, Clone, Copy)]
struct Terminal {
    had: bool,
}

impl Terminal {
    fn at_start() -> Terminal {
        Terminal {
            had: std::fs::File::open("/dev/tty").is_ok(),
        }
    }

    /// The gateway had a controlling terminal and has it no more: it closed (its SIGHUP).
    fn hung_up(&self) -> bool {
        self.had && std::fs::File::open("/dev/tty").is_err()
    }
}

/// A signal the gateway acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Signal {
    /// Ctrl-C (SIGINT), SIGTERM or SIGQUIT.
    Stop(&'static str),
    /// SIGHUP: a reload, or the terminal closed.
    Hangup,
}

/// The signals the gateway takes: Ctrl-C (SIGINT), SIGTERM (systemd's stop) and SIGQUIT stop
/// it; SIGHUP reloads the config (or stops it, where its terminal closed or there is nothing
/// to read again). Each is taken from [`Signals::new`] on, so that none of them ends the
/// process with its default action (without the drives' stop).
struct Signals {
    int: Option<tokio::signal::unix::Signal>,
    term: Option<tokio::signal::unix::Signal>,
    hup: Option<tokio::signal::unix::Signal>,
    quit: Option<tokio::signal::unix::Signal>,
}

impl Signals {
    fn new() -> Signals {
        use tokio::signal::unix::{SignalKind, signal};
        let take = |name: &str, kind: SignalKind| match signal(kind) {
            Ok(s) => Some(s),
            Err(e) => {
                tracing::warn!(signal = name, error = %e, "cannot take the signal");
                None
            }
        };
        Signals {
            int: take("SIGINT", SignalKind::interrupt()),
            term: take("SIGTERM", SignalKind::terminate()),
            hup: take("SIGHUP", SignalKind::hangup()),
            quit: take("SIGQUIT", SignalKind::quit()),
        }
    }

    /// The next signal.
    async fn next(&mut self) -> Signal {
        tokio::select! {
            () = recv(&mut self.int) => Signal::Stop("SIGINT"),
            () = recv(&mut self.term) => Signal::Stop("SIGTERM"),
            () = recv(&mut self.hup) => Signal::Hangup,
            () = recv(&mut self.quit) => Signal::Stop("SIGQUIT"),
        }
    }

    /// The next signal of any kind, as a reason to stop at once (during the stop).
    async fn stop(&mut self) -> &'static str {
        match self.next().await {
            Signal::Stop(name) => name,
            Signal::Hangup => "SIGHUP",
        }
    }
}

async fn recv(s: &mut Option<tokio::signal::unix::Signal>) {
    let got = match s {
        Some(s) => s.recv().await.is_some(),
        None => false,
    };
    if !got {
        std::future::pending::<()>().await;
    }
}

/// A failure to start the runtime.
pub(crate) fn runtime_error(e: std::io::Error) -> Error {
    Error::failed(format!("cannot start the runtime: {e}"))
}
