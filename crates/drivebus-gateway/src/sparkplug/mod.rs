//! The plant as a Sparkplug B 3.0 edge node (`[sparkplug]`, `docs/sparkplug.md`): the gateway
//! is the node, each drive a device, each point a metric.
//!
//! - [`catalogue`]: the metrics, their aliases, datatypes and birth properties.
//! - [`node`]: the session as a state machine without I/O (births, deaths, data by exception,
//!   commands, the primary host).
//! - here: the task. Its own broker connection (MQTT 3.1.1, clean session) beside the JSON
//!   topics' one: a connection has one will, and the node's is its NDEATH with the `bdSeq` of
//!   that connection, which changes at every CONNECT. rumqttc's event loop runs in its own local
//!   task and sets the will before each connection attempt; `bdSeq` is kept in the state
//!   directory across restarts.

pub mod catalogue;
pub mod node;

#[cfg(test)]
mod measure_tests;
#[cfg(test)]
mod tests;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use rumqttc::{AsyncClient, Event, EventLoop, LastWill, Outgoing, Packet, QoS};
use sparkplug_b::seq::Seq;
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use crate::config::Plant;
use crate::error::Result;
use crate::metrics::Metrics;
use crate::model::{SetOutcome, SetRequest, Update};
use crate::mqtt::payload::millis;
use crate::mqtt::{AbortOnDrop, Backoff, SHUTDOWN_FLUSH};
use node::{Node, Out};

/// The client's request queue: a birth of a large plant is one message per drive.
const CLIENT_QUEUE: usize = 4096;
/// The most updates taken into one flush.
const DRAIN_MAX: usize = 4096;

/// Where `bdSeq` is kept: one file per group and node in the state directory.
#[derive(Debug, Clone)]
pub struct BdSeqStore {
    path: Option<PathBuf>,
}

impl BdSeqStore {
    /// The file of `group`/`node` in `dir` (`None`: nowhere; `bdSeq` starts at 0 each time).
    pub fn new(dir: Option<PathBuf>, group: &str, node: &str) -> BdSeqStore {
        BdSeqStore {
            path: dir.map(|d| d.join(format!("sparkplug-{group}-{node}.bdseq"))),
        }
    }

    /// The file, where there is one.
    pub fn path(&self) -> Option<&std::path::Path> {
        self.path.as_deref()
    }

    /// The `bdSeq` of the next connection: one after the last one kept, 0 without one.
    pub fn next(&self) -> Seq {
        let Some(p) = &self.path else {
            return Seq::default();
        };
        match std::fs::read_to_string(p) {
            Ok(text) => match text.trim().parse::<u8>() {
                Ok(v) => Seq::new(v).next(),
                Err(_) => {
                    tracing::warn!(path = %p.display(), "the bdSeq file is damaged (not 0–255): starting at 0");
                    Seq::default()
                }
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Seq::default(),
            Err(e) => {
                tracing::warn!(path = %p.display(), error = %e, "cannot read the bdSeq file: starting at 0");
                Seq::default()
            }
        }
    }

    /// Keep `used`, the `bdSeq` of a connection the broker took.
    pub fn save(&self, used: u8) -> std::result::Result<(), String> {
        let Some(p) = &self.path else {
            return Ok(());
        };
        if let Some(dir) = p.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let file =
            drive_client::outfile::OutputFile::prepare(p, true).map_err(|e| e.to_string())?;
        file.commit(&format!("{used}\n")).map_err(|e| e.to_string())
    }
}

/// The prepared Sparkplug connection (files read, options built).
#[derive(Debug)]
pub struct Sparkplug {
    plant: Arc<Plant>,
    options: rumqttc::MqttOptions,
    store: BdSeqStore,
    fingerprint: u64,
}

/// What the event-loop task reports.
#[derive(Debug)]
enum Link {
    /// Connected with this `bdSeq` in the will.
    Up(u8),
    Event(Box<Event>),
    Down {
        error: String,
        retry_in: Duration,
    },
}

/// A finished write, of the point its device (by id) had when it was asked for (a reload
/// meanwhile may have moved it).
#[derive(Debug)]
struct Done {
    device: String,
    point: String,
    outcome: SetOutcome,
}

impl Sparkplug {
    /// Build the connection's options from `plant` (reads the password and TLS files).
    pub fn prepare(plant: &Arc<Plant>) -> Result<Option<Sparkplug>> {
        let Some(sp) = &plant.sparkplug else {
            return Ok(None);
        };
        let fingerprint = Self::fingerprint_of(plant).unwrap_or_default();
        let options = crate::mqtt::connect::options_v4(&plant.gateway, &sp.client_id)?;
        let store = BdSeqStore::new(
            drive_client::wear::env_dir(),
            &sp.group_id,
            &sp.edge_node_id,
        );
        Ok(Some(Sparkplug {
            plant: plant.clone(),
            options,
            store,
            fingerprint,
        }))
    }

    /// What the connection of `plant`'s `[sparkplug]` depends on, as one number (the broker
    /// settings, their files, the group, node, primary host and client id); `None` without
    /// `[sparkplug]`. A reload that changes it connects again (NDEATH, then a new session).
    pub fn fingerprint_of(plant: &Plant) -> Option<u64> {
        let sp = plant.sparkplug.as_ref()?;
        let extra = format!(
            "{}\0{}\0{:?}\0{}",
            sp.group_id, sp.edge_node_id, sp.primary_host_id, sp.client_id
        );
        Some(crate::mqtt::connect::fingerprint(&plant.gateway, &extra))
    }

    /// The fingerprint it was prepared with ([`Sparkplug::fingerprint_of`]).
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Run the node until `stop` turns true: then NDEATH and the disconnect. An
    /// [`Update::Reconfigured`] moves it to its plant (every birth again), and to its
    /// connection where it brings one (NDEATH of this session first).
    pub async fn run(
        self,
        mut updates: mpsc::Receiver<Update>,
        mut sets: Vec<mpsc::Sender<SetRequest>>,
        metrics: Arc<Metrics>,
        mut stop: watch::Receiver<bool>,
    ) -> Result<()> {
        let Some(mut sp) = self.plant.sparkplug.clone() else {
            return Ok(());
        };
        let mut node = Node::new(&self.plant, &sp);
        let (mut client, mut link_rx, mut driver) = start(&self, &node, &sp);
        let (done_tx, mut done_rx) = mpsc::unbounded_channel::<Done>();
        let mut connected = false;
        let mut updates_open = true;
        // The births' wait for the drives' first answers ends at the latest with a tick.
        let mut tick = tokio::time::interval(Duration::from_secs(1));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        // A reload found among the updates of a flush, taken at the next turn.
        let mut held: Option<Update> = None;
        loop {
            let now = millis(SystemTime::now());
            let event = match held.take() {
                Some(u) => Next::Update(Some(u)),
                None => tokio::select! {
                    biased;
                    r = stop.wait_for(|s| *s) => {
                        let _ = r;
                        Next::Stop
                    }
                    link = link_rx.recv() => Next::Link(link),
                    Some(d) = done_rx.recv() => Next::Done(d),
                    _ = tick.tick() => Next::Tick,
                    u = updates.recv(), if updates_open => Next::Update(u),
                },
            };
            let mut outs = match event {
                Next::Stop => break,
                Next::Link(Some(Link::Up(bd))) => {
                    connected = true;
                    tracing::info!(bd_seq = bd, "Sparkplug: connected to the broker");
                    node.connected(bd)
                }
                Next::Link(Some(Link::Event(e))) => match *e {
                    Event::Incoming(Packet::SubAck(_)) => node.subscribed(now),
                    Event::Incoming(Packet::Publish(p)) => {
                        node.incoming(&p.topic, &p.payload, p.retain, now)
                    }
                    _ => Vec::new(),
                },
                Next::Link(Some(Link::Down { error, retry_in })) => {
                    if connected {
                        tracing::warn!(%error, retry_in_ms = retry_in.as_millis() as u64,
                            "Sparkplug: lost the broker connection; reconnecting");
                    } else {
                        tracing::warn!(%error, retry_in_ms = retry_in.as_millis() as u64,
                            "Sparkplug: cannot connect to the broker; retrying");
                    }
                    connected = false;
                    node.disconnected();
                    Vec::new()
                }
                Next::Link(None) => break,
                Next::Done(d) => {
                    metrics.set_outcome(d.outcome.label());
                    write_done(&mut node, &d, now);
                    Vec::new()
                }
                Next::Tick => Vec::new(),
                Next::Update(Some(Update::Reconfigured(r))) => {
                    let fresh = r
                        .sparkplug
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner)
                        .take();
                    sets.clone_from(&r.sets);
                    match (fresh, r.plant.sparkplug.clone()) {
                        (Some(next), Some(next_sp)) => {
                            // Another session: this one ends with its NDEATH.
                            if connected {
                                let outs = node.stopping(now);
                                execute(&client, &mut node, outs, &sets, &done_tx, &metrics, now);
                                wait_disconnect(&mut link_rx).await;
                            }
                            drop(driver);
                            connected = false;
                            sp = next_sp;
                            node = Node::new(&r.plant, &sp);
                            (client, link_rx, driver) = start(&next, &node, &sp);
                            tracing::info!(
                                generation = r.generation,
                                "Sparkplug: a new session for the reloaded config"
                            );
                            Vec::new()
                        }
                        (None, Some(next_sp)) => {
                            sp = next_sp;
                            tracing::info!(
                                generation = r.generation,
                                "Sparkplug: the reloaded config's devices, born again"
                            );
                            node.reconfigure(&r, &sp, now)
                        }
                        // No [sparkplug] any more: the gateway stops this task.
                        (_, None) => Vec::new(),
                    }
                }
                Next::Update(Some(u)) => node.update(&u, now),
                Next::Update(None) => {
                    updates_open = false;
                    Vec::new()
                }
            };
            // Whatever else is waiting joins this flush (one DDATA per drive for a burst), up
            // to a bound, so that the broker's events are never kept waiting behind a stream of
            // updates. A reload among them ends the flush and is taken at the next turn.
            for _ in 0..DRAIN_MAX {
                let Ok(u) = updates.try_recv() else {
                    break;
                };
                if let Update::Reconfigured(_) = u {
                    held = Some(u);
                    break;
                }
                outs.extend(node.update(&u, now));
            }
            outs.extend(node.flush(now));
            if connected {
                execute(&client, &mut node, outs, &sets, &done_tx, &metrics, now);
            }
        }
        // Writes answered as the buses stopped go out before the NDEATH.
        tokio::task::yield_now().await;
        let now = millis(SystemTime::now());
        while let Ok(d) = done_rx.try_recv() {
            write_done(&mut node, &d, now);
        }
        if connected {
            let mut outs = node.flush(now);
            outs.extend(node.stopping(now));
            execute(&client, &mut node, outs, &sets, &done_tx, &metrics, now);
            if wait_disconnect(&mut link_rx).await {
                tracing::info!("Sparkplug: NDEATH sent, disconnected");
            }
        }
        drop(driver);
        Ok(())
    }
}

/// What the Sparkplug task waits for.
enum Next {
    Stop,
    Link(Option<Link>),
    Done(Done),
    Tick,
    Update(Option<Update>),
}

/// The connection of `spb` for `node`'s session: a client and its event loop in a task of
/// its own (aborted when the handle is dropped).
fn start(
    spb: &Sparkplug,
    node: &Node,
    sp: &crate::config::Sparkplug,
) -> (AsyncClient, mpsc::Receiver<Link>, AbortOnDrop) {
    let (client, eventloop) = AsyncClient::new(spb.options.clone(), CLIENT_QUEUE);
    let (link_tx, link_rx) = mpsc::channel(256);
    let death_topic = node.death(0, 0).topic;
    let first = spb.store.next();
    tracing::info!(
        group = %sp.group_id, node = %sp.edge_node_id, bd_seq = first.get(),
        file = ?spb.store.path(), "Sparkplug edge node"
    );
    let driver = AbortOnDrop(crate::tasks::spawn_local(drive(
        eventloop,
        link_tx,
        spb.store.clone(),
        first,
        death_topic,
        sp.client_id.clone(),
    )));
    (client, link_rx, driver)
}

/// Wait (at most [`SHUTDOWN_FLUSH`]) for the client to have sent its DISCONNECT; false when
/// it did not.
async fn wait_disconnect(link_rx: &mut mpsc::Receiver<Link>) -> bool {
    let deadline = Instant::now() + SHUTDOWN_FLUSH;
    loop {
        match tokio::time::timeout_at(deadline, link_rx.recv()).await {
            Ok(Some(Link::Event(e))) if matches!(*e, Event::Outgoing(Outgoing::Disconnect)) => {
                return true;
            }
            Ok(Some(Link::Event(_) | Link::Up(_))) => {}
            Ok(Some(Link::Down { .. }) | None) => return false,
            Err(_) => {
                tracing::warn!("Sparkplug: the NDEATH and disconnect did not go out in time");
                return false;
            }
        }
    }
}

/// A write's outcome onto the point it was asked of, where the node still has it.
fn write_done(node: &mut Node, d: &Done, now: u64) {
    let cat = node.catalogue();
    let Some(dev) = cat.device_named(&d.device) else {
        return;
    };
    let Some(ix) = cat
        .devices
        .get(dev)
        .and_then(|x| x.points.iter().position(|p| p.name == d.point))
    else {
        return;
    };
    node.write_done(dev, ix, &d.outcome, now);
}

/// A published message's kind as the publish metrics count it.
fn kind_label(topic: &str) -> &'static str {
    use sparkplug_b::topic::MessageType as M;
    match sparkplug_b::topic::Topic::parse(topic).map(|t| t.kind) {
        Ok(M::NBirth) => "sparkplug_nbirth",
        Ok(M::DBirth) => "sparkplug_dbirth",
        Ok(M::NData) => "sparkplug_ndata",
        Ok(M::DData) => "sparkplug_ddata",
        Ok(M::DDeath) => "sparkplug_ddeath",
        Ok(M::NDeath) => "sparkplug_ndeath",
        _ => "sparkplug_other",
    }
}

/// Carry out what the session asks for.
#[allow(clippy::too_many_arguments)]
fn execute(
    client: &AsyncClient,
    node: &mut Node,
    outs: Vec<Out>,
    sets: &[mpsc::Sender<SetRequest>],
    done: &mpsc::UnboundedSender<Done>,
    metrics: &Metrics,
    now: u64,
) {
    let mut lost = false;
    for o in outs {
        match o {
            Out::Publish(m) => {
                let qos = if m.qos1 {
                    QoS::AtLeastOnce
                } else {
                    QoS::AtMostOnce
                };
                let kind = kind_label(&m.topic);
                match client.try_publish(&m.topic, qos, m.retain, m.payload) {
                    Ok(()) => metrics.published(kind),
                    Err(e) => {
                        tracing::warn!(topic = %m.topic, error = %e, "Sparkplug: the client's queue is full: message dropped");
                        lost = true;
                    }
                }
            }
            Out::Subscribe(filter) => {
                if let Err(e) = client.try_subscribe(&filter, QoS::AtLeastOnce) {
                    tracing::warn!(%filter, error = %e, "Sparkplug: cannot subscribe");
                }
            }
            Out::Disconnect => {
                if let Err(e) = client.try_disconnect() {
                    tracing::warn!(error = %e, "Sparkplug: cannot disconnect");
                }
            }
            Out::Write {
                device,
                point,
                value,
                max_age,
            } => write(node, device, point, value, max_age, sets, done, now),
        }
    }
    if lost {
        // A host sees the gap in `seq` and asks for a rebirth; the node sends it anyway.
        let again = node.rebirth(now);
        for o in again {
            if let Out::Publish(m) = o {
                let _ = client.try_publish(&m.topic, QoS::AtMostOnce, false, m.payload);
            }
        }
    }
}

/// Hand a write to its bus task; its outcome comes back through `done` (a bus that cannot
/// take it now: the refusal at once).
#[allow(clippy::too_many_arguments)]
fn write(
    node: &mut Node,
    device: usize,
    point: usize,
    value: crate::model::SetValue,
    max_age: Duration,
    sets: &[mpsc::Sender<SetRequest>],
    done: &mpsc::UnboundedSender<Done>,
    now: u64,
) {
    let Some((bus, drive, p, id, name)) = node.catalogue().devices.get(device).and_then(|d| {
        let pm = d.points.get(point)?;
        Some((d.bus, d.drive, pm.point, d.id.clone(), pm.name.clone()))
    }) else {
        return;
    };
    let Some(tx) = sets.get(bus) else {
        return;
    };
    let done = done.clone();
    let handed = crate::mqtt::hand_set(tx, drive, p, value, max_age, move |outcome| {
        let _ = done.send(Done {
            device: id,
            point: name,
            outcome,
        });
    });
    if let Err(outcome) = handed {
        node.write_done(device, point, &outcome, now);
    }
}

/// Runs rumqttc's event loop. Before each connection attempt the will becomes the NDEATH of
/// the next `bdSeq` (one more per CONNECT, as the specification asks, so that a late will of
/// an earlier connection is never taken for this one's); a connection the broker takes is
/// reported with its `bdSeq`, which is kept in the state directory.
async fn drive(
    mut el: EventLoop,
    tx: mpsc::Sender<Link>,
    store: BdSeqStore,
    mut next: Seq,
    death_topic: String,
    client_id: String,
) {
    let mut backoff = Backoff::default();
    let mut attempt: Option<u8> = None;
    let mut save_failed = false;
    loop {
        if el.network.is_none() {
            let bd = next.get();
            next = next.next();
            attempt = Some(bd);
            let payload = node::death_payload(bd, millis(SystemTime::now()));
            el.mqtt_options.set_last_will(LastWill::new(
                death_topic.clone(),
                payload,
                QoS::AtLeastOnce,
                false,
            ));
        }
        match el.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                backoff.reset();
                let bd = attempt.unwrap_or_default();
                if let Err(e) = store.save(bd) {
                    if !save_failed {
                        tracing::warn!(error = %e, "cannot keep bdSeq in the state directory: after a restart it starts at 0 again (set DRIVECTL_STATE_DIR to a writable directory)");
                    }
                    save_failed = true;
                }
                if tx.send(Link::Up(bd)).await.is_err() {
                    return;
                }
            }
            Ok(ev) => {
                if tx.send(Link::Event(Box::new(ev))).await.is_err() {
                    return;
                }
            }
            Err(e) => {
                let retry_in = backoff.failed();
                let error = crate::mqtt::describe_v4(&e, &client_id);
                if tx.send(Link::Down { error, retry_in }).await.is_err() {
                    return;
                }
                tokio::time::sleep(retry_in).await;
            }
        }
    }
}
