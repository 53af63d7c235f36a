//! The MQTT side of the gateway: one task publishes what the bus tasks report and hands the
//! `set`s it receives to them (`docs/gateway.md`, "MQTT").
//!
//! - [`connect`]: the broker URL, password file, TLS and last-will, read at
//!   [`Mqtt::prepare`], before any bus opens.
//! - [`outbox`]: the latest payload of every retained topic, what is still to be published,
//!   results waiting for the broker (sans-IO).
//! - [`payload`]: the JSON of every topic and the `set` messages.
//! - here: the task. rumqttc's event loop runs in its own local task (never cancelled halfway
//!   through a write), reconnecting with a back-off of 0.5 s doubling to 30 s; the MQTT task
//!   owns the client and publishes only while connected, through the client's bounded queue
//!   (`try_publish`): while the broker is away nothing is queued but the latest payload of each
//!   topic, all republished at the next ConnAck.

pub mod connect;
pub mod outbox;
pub mod payload;

#[cfg(test)]
mod tests;

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use rumqttc::Outgoing;
use rumqttc::v5::mqttbytes::QoS;
use rumqttc::v5::mqttbytes::v5::{DisconnectReasonCode, Packet, Publish};
use rumqttc::v5::{AsyncClient, ConnectionError, Event, EventLoop, MqttOptions, StateError};
use tokio::sync::{mpsc, oneshot, watch};
use tokio::time::Instant;

use super::config::Plant;
use super::metrics::Metrics;
use super::model::{ConfigStatus, DriveStatus, Reconfig, SetOutcome, SetRequest, Update};
use crate::error::Result;
use outbox::{Outbox, ResultMsg};

/// How far in the future a `set`'s `ts` may be (clock skew between sender and gateway).
pub const MAX_SET_FUTURE: Duration = Duration::from_secs(5);
/// The first wait before reconnecting; it doubles after each failure.
pub const BACKOFF_FIRST: Duration = Duration::from_millis(500);
/// The longest wait before reconnecting.
pub const BACKOFF_MAX: Duration = Duration::from_secs(30);
/// How long the shutdown waits for `offline` and the disconnect to go out.
pub const SHUTDOWN_FLUSH: Duration = Duration::from_secs(2);
/// The client's request queue (messages handed to it and not yet written).
const CLIENT_QUEUE: usize = 128;
/// How long a `set` may wait for its bus task's answer beyond `max_set_age` before it is
/// answered `link_failed` (a bus task that never answers must not keep it for ever).
pub(crate) const ANSWER_GRACE: Duration = Duration::from_secs(60);

/// How the JSON publisher ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The gateway stops: every retained topic published stale (values, process data, the
    /// drives' statuses, the buses' figures), the status `offline`.
    Stop,
    /// A reloaded config publishes no JSON topics any more: every retained topic the gateway
    /// published is cleared, its status too.
    Clear,
}

/// Reconnection back-off: 0.5 s doubling to 30 s, back to 0.5 s at each ConnAck.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    next: Duration,
}

impl Default for Backoff {
    fn default() -> Self {
        Backoff {
            next: BACKOFF_FIRST,
        }
    }
}

impl Backoff {
    /// The wait after a failure (the next one is twice as long, up to [`BACKOFF_MAX`]).
    pub fn failed(&mut self) -> Duration {
        let wait = self.next;
        self.next = (self.next * 2).min(BACKOFF_MAX);
        wait
    }

    /// Connected: the next failure waits [`BACKOFF_FIRST`] again.
    pub fn reset(&mut self) {
        self.next = BACKOFF_FIRST;
    }
}

/// The broker connection as the gateway sees it (for tests and status displays).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BrokerState {
    /// Connected now.
    pub connected: bool,
    /// The `set` subscription is acknowledged on this connection.
    pub subscribed: bool,
    /// ConnAcks received since the start.
    pub connects: u64,
    /// Failed attempts and lost connections since the start.
    pub failures: u64,
    /// Why the last attempt failed or the connection was lost.
    pub last_error: Option<String>,
}

/// The prepared MQTT client (TLS material and password read, options built).
#[derive(Debug)]
pub struct Mqtt {
    plant: Arc<Plant>,
    options: MqttOptions,
    /// The broker URL as configured (for logs).
    broker: String,
    /// [`connect::fingerprint`] of the settings it was prepared from.
    fingerprint: u64,
    state: watch::Sender<BrokerState>,
}

/// What the event-loop task reports.
#[derive(Debug)]
enum Link {
    /// Boxed: an MQTT 5 event is large (its properties), the channel keeps 256 of them.
    Event(Box<Event>),
    Down {
        error: String,
        retry_in: Duration,
    },
}

/// Where a `set`'s result goes: its topic and the point's parameter (for the value read
/// back), taken when the set arrives, so that a reload meanwhile cannot send it elsewhere.
#[derive(Debug, Clone)]
struct ResultAt {
    topic: String,
    target: drive_client::target::Target,
}

/// A finished `set`, from its waiting task.
#[derive(Debug)]
struct Done {
    at: ResultAt,
    outcome: SetOutcome,
    id: Option<serde_json::Value>,
}

impl Mqtt {
    /// Build the client's options from `plant` (reads the password, CA and certificate files).
    pub fn prepare(plant: &Arc<Plant>) -> Result<Mqtt> {
        let fingerprint = connect::fingerprint(&plant.gateway, "");
        let (options, _url) = connect::options(&plant.gateway)?;
        Ok(Mqtt {
            plant: plant.clone(),
            options,
            broker: plant.gateway.broker.clone(),
            fingerprint,
            state: watch::channel(BrokerState::default()).0,
        })
    }

    /// [`connect::fingerprint`] of the settings it was prepared from: a reload whose settings
    /// give another one connects again.
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// The broker connection's state, updated as it changes.
    #[allow(dead_code, reason = "for the tests and a later status display")]
    pub fn broker_state(&self) -> watch::Receiver<BrokerState> {
        self.state.subscribe()
    }

    /// Connect (and reconnect) to the broker, publish `updates`, hand `set`s to the bus
    /// tasks (`sets[bus]`), publish the gateway's status with `config` (again at each change),
    /// until `shutdown` resolves; then publish the gateway's `offline` and disconnect. An
    /// [`Update::Reconfigured`] switches to its plant, and to its connection where it brings one.
    pub async fn run(
        self,
        mut updates: mpsc::Receiver<Update>,
        sets: Vec<mpsc::Sender<SetRequest>>,
        metrics: Arc<Metrics>,
        mut config: watch::Receiver<ConfigStatus>,
        shutdown: impl std::future::Future<Output = End>,
    ) -> Result<()> {
        let (client, mut link_rx, mut driver) =
            start(self.options.clone(), &self.plant.gateway.client_id);
        let (done_tx, mut done_rx) = mpsc::unbounded_channel();
        let mut task = Task {
            plant: self.plant.clone(),
            outbox: Outbox::new(&self.plant),
            names: Names::new(&self.plant),
            client,
            sets,
            metrics,
            done_tx,
            connected: false,
            state: self.state,
            broker: self.broker,
            config: config.borrow_and_update().clone(),
            unknown_sets: 0,
            unknown_logged: None,
        };
        metrics_connected(&task.metrics, false);
        tokio::pin!(shutdown);
        let mut updates_open = true;
        let mut config_open = true;
        let end = loop {
            tokio::select! {
                biased;
                end = &mut shutdown => break end,
                link = link_rx.recv() => match link {
                    Some(Link::Event(e)) => task.event(*e),
                    Some(Link::Down { error, retry_in }) => task.down(error, retry_in),
                    None => break End::Stop,
                },
                Some(done) = done_rx.recv() => task.done(done),
                changed = config.changed(), if config_open => match changed {
                    Ok(()) => {
                        task.config = config.borrow_and_update().clone();
                        task.publish_status();
                    }
                    Err(_) => config_open = false,
                },
                u = updates.recv(), if updates_open => match u {
                    Some(Update::Reconfigured(r)) => {
                        let fresh = r.json.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
                        match fresh {
                            Some(m) => {
                                // Other broker settings: the old connection ends, the new one
                                // starts with what is known of the buses that keep running.
                                task.end_connection(&mut link_rx, &r).await;
                                drop(driver);
                                let (client, rx, d) = start(m.options.clone(), &r.plant.gateway.client_id);
                                task.client = client;
                                link_rx = rx;
                                driver = d;
                                task.broker = m.broker;
                                task.connected = false;
                                metrics_connected(&task.metrics, false);
                                task.reconfigure(&r, false);
                            }
                            None => task.reconfigure(&r, true),
                        }
                    }
                    Some(u) => {
                        if !task.outbox.update(u, Instant::now(), &task.plant) {
                            tracing::debug!("an update named no topic of the plant");
                        }
                    }
                    None => {
                        updates_open = false;
                        tracing::warn!("every bus task has ended; the broker connection stays up");
                    }
                },
            }
            task.flush();
        };
        // Writes the buses answered as they stopped: their waiting tasks run once more, and
        // their results go out before `offline`.
        tokio::task::yield_now().await;
        while let Ok(done) = done_rx.try_recv() {
            task.done(done);
        }
        task.flush();
        task.shutdown(&mut link_rx, end).await;
        drop(driver);
        Ok(())
    }
}

/// A client on `options` and its event loop, running in a task of its own (aborted when the
/// returned handle is dropped: the connection never outlives its owner).
fn start(
    options: MqttOptions,
    client_id: &str,
) -> (AsyncClient, mpsc::Receiver<Link>, AbortOnDrop) {
    let (client, eventloop) = AsyncClient::new(options, CLIENT_QUEUE);
    let (link_tx, link_rx) = mpsc::channel(256);
    let driver = AbortOnDrop(crate::tasks::spawn_local(drive(
        eventloop,
        link_tx,
        client_id.to_owned(),
    )));
    (client, link_rx, driver)
}

/// Aborts its task when dropped.
#[derive(Debug)]
pub(crate) struct AbortOnDrop(pub(crate) tokio::task::JoinHandle<()>);

/// Hand a write to its bus task (`tx`), the JSON topics' `set` and Sparkplug's DCMD alike:
/// `done` gets the outcome from a task that waits for it at most `max_age` and
/// [`ANSWER_GRACE`] (a bus task that never answers must not keep it for ever); a bus that
/// cannot take it now is the refusal returned at once.
pub(crate) fn hand_set(
    tx: &mpsc::Sender<SetRequest>,
    drive: usize,
    point: usize,
    value: crate::model::SetValue,
    max_age: Duration,
    done: impl FnOnce(SetOutcome) + 'static,
) -> std::result::Result<(), SetOutcome> {
    let (reply, answer) = oneshot::channel();
    let req = SetRequest {
        drive,
        point,
        value,
        received: Instant::now(),
        max_age,
        reply,
    };
    match tx.try_send(req) {
        Ok(()) => {
            crate::tasks::spawn_local(async move {
                let outcome = match tokio::time::timeout(max_age + ANSWER_GRACE, answer).await {
                    Ok(Ok(o)) => o,
                    Ok(Err(_)) => SetOutcome::Refused {
                        reason: "expired",
                        message: "the bus task ended without executing it".to_owned(),
                    },
                    Err(_) => SetOutcome::LinkFailed {
                        message: format!(
                            "no answer from the bus task within {} s: whether it was \
                             written is unknown",
                            (max_age + ANSWER_GRACE).as_secs()
                        ),
                    },
                };
                done(outcome);
            });
            Ok(())
        }
        Err(mpsc::error::TrySendError::Full(_)) => Err(SetOutcome::Refused {
            reason: "busy",
            message: "the bus has too many writes waiting: not queued; send it again later"
                .to_owned(),
        }),
        Err(mpsc::error::TrySendError::Closed(_)) => Err(SetOutcome::Refused {
            reason: "offline",
            message: "the bus task has ended: not sent".to_owned(),
        }),
    }
}

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

fn metrics_connected(m: &Metrics, up: bool) {
    m.broker_connected(up);
}

/// Runs rumqttc's event loop: every event to the MQTT task; after a failure, waits the
/// back-off and polls again (which reconnects).
async fn drive(mut el: EventLoop, tx: mpsc::Sender<Link>, client_id: String) {
    let mut backoff = Backoff::default();
    loop {
        match el.poll().await {
            Ok(ev) => {
                if matches!(ev, Event::Incoming(Packet::ConnAck(_))) {
                    backoff.reset();
                }
                if tx.send(Link::Event(Box::new(ev))).await.is_err() {
                    return;
                }
            }
            Err(e) => {
                let retry_in = backoff.failed();
                let error = describe(&e, &client_id);
                if tx.send(Link::Down { error, retry_in }).await.is_err() {
                    return;
                }
                tokio::time::sleep(retry_in).await;
            }
        }
    }
}

/// A connection error for a person: what failed and what to change. `client_id` is the
/// gateway's (a broker that ends the session because another client took the id).
pub fn describe(e: &ConnectionError, client_id: &str) -> String {
    use rumqttc::v5::mqttbytes::v5::ConnectReturnCode as C;
    match e {
        ConnectionError::ConnectionRefused(C::BadUserNamePassword) => {
            "the broker refused the user name or password: check username (or user@ in the \
             broker URL) and the password in password_file"
                .to_owned()
        }
        ConnectionError::ConnectionRefused(C::NotAuthorized) => {
            "the broker refused the connection as not authorised: check username (or user@ in \
             the broker URL), the password in password_file, client_cert, and the broker's \
             access rules"
                .to_owned()
        }
        ConnectionError::ConnectionRefused(C::BadClientId | C::ClientIdentifierNotValid) => {
            format!("the broker refused the client id {client_id:?}: set [gateway] client_id")
        }
        ConnectionError::ConnectionRefused(
            C::RefusedProtocolVersion | C::UnsupportedProtocolVersion,
        ) => "the broker does not speak MQTT 5, which the gateway needs (Mosquitto 1.6 or \
              later, EMQX, HiveMQ, VerneMQ do)"
            .to_owned(),
        ConnectionError::ConnectionRefused(code) => {
            format!("the broker refused the connection ({code:?})")
        }
        // A broker of MQTT 3.1.1 only answers a CONNECT of version 5 with its own return code
        // 1 (unacceptable protocol version), which is no MQTT 5 reason code.
        ConnectionError::MqttState(StateError::Deserialization(
            rumqttc::v5::mqttbytes::Error::InvalidConnectReturnCode(1),
        )) => "the broker does not speak MQTT 5 (it answered as an MQTT 3.1.1 broker: \
               unacceptable protocol version), and the gateway needs it (Mosquitto 1.6 or \
               later, EMQX, HiveMQ, VerneMQ do)"
            .to_owned(),
        ConnectionError::MqttState(StateError::ServerDisconnect {
            reason_code: DisconnectReasonCode::SessionTakenOver,
            ..
        }) => format!(
            "the broker ended the connection because another client connected with the same \
             client id {client_id:?} (the broker drops the older session): give each gateway \
             its own [gateway] client_id"
        ),
        // Closed without a word: what a broker does to the older of two clients with one id
        // (Mosquitto closes it at once, without the DISCONNECT MQTT 5 would let it send).
        ConnectionError::MqttState(StateError::ConnectionAborted) => format!(
            "the broker closed the connection without a reason: the client id {client_id:?} is \
             probably in use by another client (the broker drops the older session when \
             another connects with the same id: give each gateway its own [gateway] \
             client_id), or the broker is stopping"
        ),
        ConnectionError::MqttState(StateError::ServerDisconnect {
            reason_code,
            reason_string,
        }) => format!(
            "the broker ended the connection ({reason_code:?}{})",
            reason_string
                .as_deref()
                .map(|r| format!(": {r}"))
                .unwrap_or_default()
        ),
        ConnectionError::Tls(t) => format!(
            "TLS: {t}; check ca_file (the CA that signed the broker's certificate), that the \
             broker URL's host is a name in the certificate, and client_cert/client_key"
        ),
        ConnectionError::Io(io) if io.kind() == std::io::ErrorKind::ConnectionRefused => {
            format!("{io}: is the broker running at the configured host and port?")
        }
        ConnectionError::Io(io) => {
            let text = io.to_string();
            if text.contains("certificate") || text.contains("Certificate") {
                format!(
                    "TLS: {text}; check ca_file (the CA that signed the broker's certificate) \
                     and that the broker URL's host is a name in the certificate"
                )
            } else {
                format!("i/o: {text}")
            }
        }
        ConnectionError::Timeout(_) => {
            "no answer from the broker in time (network, firewall, or a TLS port spoken to \
             as plain mqtt://?)"
                .to_owned()
        }
        other => other.to_string(),
    }
}

/// [`describe`] for the Sparkplug connection's MQTT 3.1.1 client.
pub fn describe_v4(e: &rumqttc::ConnectionError, client_id: &str) -> String {
    use rumqttc::ConnectReturnCode as C;
    use rumqttc::ConnectionError as E;
    match e {
        E::ConnectionRefused(C::BadUserNamePassword | C::NotAuthorized) => {
            "the broker refused the user name or password: check username (or user@ in the \
             broker URL), the password in password_file, client_cert, and the broker's access \
             rules"
                .to_owned()
        }
        E::ConnectionRefused(C::BadClientId) => {
            format!("the broker refused the client id {client_id:?}: set [sparkplug] client_id")
        }
        E::ConnectionRefused(code) => format!("the broker refused the connection ({code:?})"),
        E::Tls(t) => format!(
            "TLS: {t}; check ca_file (the CA that signed the broker's certificate), that the \
             broker URL's host is a name in the certificate, and client_cert/client_key"
        ),
        E::Io(io) if io.kind() == std::io::ErrorKind::ConnectionRefused => {
            format!("{io}: is the broker running at the configured host and port?")
        }
        E::Io(io) => format!("i/o: {io}"),
        E::MqttState(rumqttc::StateError::Deserialization(
            rumqttc::mqttbytes::Error::PayloadSizeLimitExceeded(n),
        )) => format!(
            "the broker sent a message of {n} bytes, more than the {} the Sparkplug connection \
             takes: a retained message on a command or STATE topic? remove it (mosquitto_pub \
             -r -n -t TOPIC)",
            connect::MAX_INCOMING_PACKET_V4
        ),
        E::NetworkTimeout | E::FlushTimeout => {
            "no answer from the broker in time (network, firewall, or a TLS port spoken to \
             as plain mqtt://?)"
                .to_owned()
        }
        other => other.to_string(),
    }
}

/// Topic names → indices, built once.
#[derive(Debug)]
struct Names {
    /// `<prefix>/<gw>/`.
    base: String,
    /// `bus/drive/point` → indices.
    points: HashMap<String, (usize, usize, usize)>,
    /// The gateway's status topic.
    status: String,
    /// The subscription of the `set`s ([`SETS`]).
    set_filter: String,
    /// The subscription that finds retained topics of an earlier config ([`EARLIER`]):
    /// everything under `base`, without the gateway's own messages (MQTT 5 no-local).
    all_filter: String,
    /// The retained topics the gateway publishes.
    known: std::collections::HashSet<String>,
}

/// The subscription identifier (MQTT 5) of the `set` subscription: a `set` is executed only
/// when it came through it.
const SETS: usize = 1;
/// The subscription identifier of the subscription to everything under the gateway's topics.
const EARLIER: usize = 2;

impl Names {
    fn new(plant: &Plant) -> Names {
        let g = &plant.gateway;
        let base = format!("{}/{}/", g.prefix, g.name);
        let mut points = HashMap::new();
        let mut known = std::collections::HashSet::new();
        for (b, bus) in plant.buses.iter().enumerate() {
            known.insert(format!("{base}{}/status", bus.name));
            for (d, drive) in bus.drives.iter().enumerate() {
                known.insert(format!("{base}{}/{}/status", bus.name, drive.name));
                known.insert(format!("{base}{}/{}/pd", bus.name, drive.name));
                for (p, point) in drive.points.iter().enumerate() {
                    let at = format!("{}/{}/{}", bus.name, drive.name, point.name);
                    known.insert(format!("{base}{at}"));
                    points.insert(at, (b, d, p));
                }
            }
        }
        let status = connect::gateway_status_topic(g);
        known.insert(status.clone());
        Names {
            set_filter: format!("{base}+/+/+/set"),
            all_filter: format!("{base}#"),
            status,
            base,
            points,
            known,
        }
    }

    /// The point a `…/set` topic names.
    fn set_target(&self, topic: &str) -> Option<(usize, usize, usize)> {
        let rest = topic.strip_prefix(&self.base)?.strip_suffix("/set")?;
        self.points.get(rest).copied()
    }
}

/// The MQTT task's state.
struct Task {
    plant: Arc<Plant>,
    outbox: Outbox,
    names: Names,
    client: AsyncClient,
    sets: Vec<mpsc::Sender<SetRequest>>,
    metrics: Arc<Metrics>,
    done_tx: mpsc::UnboundedSender<Done>,
    connected: bool,
    state: watch::Sender<BrokerState>,
    broker: String,
    /// The running config, for the gateway's status topic.
    config: ConfigStatus,
    unknown_sets: u64,
    /// When a set for an unknown point was last logged, and the count then (a flood of them is
    /// logged once per [`UNKNOWN_LOG_EVERY`], with the number left out).
    unknown_logged: Option<(Instant, u64)>,
}

/// How often sets for unknown points are logged at most.
const UNKNOWN_LOG_EVERY: Duration = Duration::from_secs(10);

impl Task {
    fn event(&mut self, e: Event) {
        match e {
            Event::Incoming(Packet::ConnAck(c)) => {
                // A broker without subscription identifiers gets the set subscription alone
                // (without them a set matching both could not be told from its copy).
                let ids = c
                    .properties
                    .as_ref()
                    .and_then(|p| p.subscription_identifiers_available)
                    != Some(0);
                self.connack(ids)
            }
            Event::Incoming(Packet::Publish(p)) => self.incoming(p),
            Event::Incoming(Packet::PubAck(a)) => self.outbox.acked(a.pkid),
            Event::Incoming(Packet::SubAck(_)) => {
                self.state.send_modify(|s| s.subscribed = true);
            }
            Event::Outgoing(Outgoing::Publish(pkid)) => self.outbox.sent_publish(pkid),
            _ => {}
        }
    }

    fn connack(&mut self, subscription_ids: bool) {
        self.connected = true;
        tracing::info!(broker = %self.broker, "connected to the broker");
        metrics_connected(&self.metrics, true);
        self.state.send_modify(|s| {
            s.connected = true;
            s.connects += 1;
        });
        self.outbox.connected();
        // A fresh connection's queue is empty: these fit.
        self.publish_status();
        use rumqttc::v5::mqttbytes::v5::{Filter, SubscribeProperties};
        let id = |id| SubscribeProperties {
            id: Some(id),
            user_properties: Vec::new(),
        };
        // Retain As Published (MQTT 5): a set the broker holds retained arrives with its
        // retained flag also while the gateway is connected (a retained set published then, or
        // one a bridge passes on from another broker at each of its reconnections), so it is
        // refused and cleared, never executed.
        let mut sets = Filter::new(&self.names.set_filter, QoS::AtLeastOnce);
        sets.preserve_retain = true;
        if let Err(e) = self
            .client
            .try_subscribe_many_with_properties(vec![sets], id(SETS))
        {
            tracing::warn!(error = %e, "cannot subscribe to the set topics");
        }
        // Retained topics of an earlier config: what the broker holds under the gateway's
        // topics arrives with this subscription (a broker whose access rules do not allow it
        // refuses it: logged at its acknowledgement, the sets are not touched).
        if !subscription_ids {
            tracing::info!(
                "the broker has no subscription identifiers: retained topics of an earlier config are not looked for"
            );
            return;
        }
        let mut all = Filter::new(&self.names.all_filter, QoS::AtLeastOnce);
        all.nolocal = true;
        if let Err(e) = self
            .client
            .try_subscribe_many_with_properties(vec![all], id(EARLIER))
        {
            tracing::warn!(error = %e, "cannot subscribe to the gateway's own topics");
        }
    }

    /// The gateway's status (`online`, with the running config), while connected.
    fn publish_status(&mut self) {
        if !self.connected {
            return;
        }
        let payload = payload::gateway_online(&self.config, payload::millis(SystemTime::now()));
        match self
            .client
            .try_publish(&self.names.status, QoS::AtLeastOnce, true, payload)
        {
            Ok(()) => {
                self.outbox.handed_other();
                self.metrics.published("gateway");
            }
            Err(e) => tracing::warn!(error = %e, "cannot publish the gateway's status"),
        }
    }

    /// A reloaded config: its topics (the retained ones of buses, drives and points it no
    /// longer has cleared when `clear`), its set topics and bus tasks.
    fn reconfigure(&mut self, r: &Reconfig, clear: bool) {
        let cleared = self.outbox.reconfigure(&self.plant, r);
        if !clear {
            // A new connection: the old one's topics were dealt with as it ended.
            self.outbox.drop_clears();
        }
        self.plant = r.plant.clone();
        self.names = Names::new(&self.plant);
        self.sets = r.sets.clone();
        tracing::info!(
            generation = r.generation,
            cleared = if clear { cleared } else { 0 },
            "MQTT: the reloaded config's topics"
        );
    }

    /// The connection ends for one with other settings: a reload changed the broker, the
    /// credentials, or the gateway's topics. When the topics stay (`prefix` and `name`), every
    /// retained topic is published stale and the status `offline`, as at a stop (what they
    /// hold stays known for the next connection); when they change, every retained topic of the old ones is
    /// cleared (the gateway no longer publishes there). At most [`SHUTDOWN_FLUSH`].
    async fn end_connection(&mut self, link_rx: &mut mpsc::Receiver<Link>, r: &Reconfig) {
        let (old, new) = (&self.plant.gateway, &r.plant.gateway);
        let same_topics = old.prefix == new.prefix && old.name == new.name;
        let messages = if same_topics {
            self.farewell(Farewell::Stale {
                reason: "reconfigured",
                keep: true,
            })
        } else {
            self.farewell(Farewell::Clear)
        };
        tracing::info!(
            broker = %self.broker,
            messages = messages.len(),
            "MQTT: the reloaded config connects otherwise: {} the old connection's topics",
            if same_topics { "marking stale" } else { "clearing" }
        );
        self.leave(link_rx, messages).await;
    }

    /// The retained messages that end this connection's topics ([`Farewell`]).
    fn farewell(&mut self, how: Farewell) -> Vec<(String, Vec<u8>)> {
        let now = payload::millis(SystemTime::now());
        let (mut m, status): (Vec<(String, Vec<u8>)>, Vec<u8>) = match how {
            Farewell::Stale { reason, keep } => {
                let stale = if keep {
                    self.outbox.stale_copies(now)
                } else {
                    self.outbox.stopping(now)
                };
                (
                    stale
                        .into_iter()
                        .map(|(t, p)| (t, p.into_bytes()))
                        .collect(),
                    payload::gateway_offline(reason, Some(now)).into_bytes(),
                )
            }
            Farewell::Clear => (
                self.outbox
                    .topics()
                    .map(|t| (t.to_owned(), Vec::new()))
                    .collect(),
                Vec::new(),
            ),
        };
        m.push((self.names.status.clone(), status));
        m
    }

    /// Publish `messages` (retained) and disconnect, while connected, waiting at most
    /// [`SHUTDOWN_FLUSH`] for both to go out; whether they did.
    async fn leave(
        &mut self,
        link_rx: &mut mpsc::Receiver<Link>,
        messages: Vec<(String, Vec<u8>)>,
    ) -> bool {
        if !self.connected {
            return false;
        }
        let deadline = Instant::now() + SHUTDOWN_FLUSH;
        let client = self.client.clone();
        let handed = async {
            for (topic, p) in messages {
                client.publish(topic, QoS::AtLeastOnce, true, p).await?;
            }
            client.disconnect().await
        };
        match tokio::time::timeout_at(deadline, handed).await {
            Ok(Ok(())) => {
                wait_disconnect(link_rx, deadline).await;
                true
            }
            Ok(Err(e)) => {
                tracing::warn!(error = %e, "cannot publish the last messages and disconnect");
                false
            }
            Err(_) => {
                tracing::warn!("the broker did not take the last messages in time");
                false
            }
        }
    }

    /// A retained topic under the gateway's that none of its points, drives or buses has (an
    /// earlier config's): cleared, so that nobody reads its last value as current.
    fn earlier(&mut self, topic: &str, retained: bool) {
        if !retained || topic.ends_with("/set") || self.names.known.contains(topic) {
            return;
        }
        match self
            .client
            .try_publish(topic, QoS::AtLeastOnce, true, Vec::new())
        {
            Ok(()) => {
                self.outbox.handed_other();
                tracing::info!(%topic, "cleared a retained topic no point of the config has");
            }
            Err(e) => {
                tracing::warn!(%topic, error = %e, "cannot clear a retained topic of an earlier config")
            }
        }
    }

    fn down(&mut self, error: String, retry_in: Duration) {
        if self.connected {
            tracing::warn!(broker = %self.broker, %error, retry_in_ms = retry_in.as_millis() as u64,
                "lost the broker connection; reconnecting");
        } else {
            tracing::warn!(broker = %self.broker, %error, retry_in_ms = retry_in.as_millis() as u64,
                "cannot connect to the broker; retrying");
        }
        self.connected = false;
        metrics_connected(&self.metrics, false);
        self.outbox.disconnected();
        self.state.send_modify(|s| {
            s.connected = false;
            s.subscribed = false;
            s.failures += 1;
            s.last_error = Some(error);
        });
    }

    fn flush(&mut self) {
        if !self.connected {
            return;
        }
        let client = &self.client;
        let metrics = &self.metrics;
        self.outbox.flush(Instant::now(), |m| {
            match client.try_publish(
                m.topic,
                QoS::AtLeastOnce,
                m.retain,
                m.payload.as_bytes().to_vec(),
            ) {
                Ok(()) => {
                    metrics.published(m.kind);
                    true
                }
                Err(_) => false,
            }
        });
    }

    /// Where the result of a set of point `(bus, drive, point)` goes.
    fn result_at(&self, bus: usize, drive: usize, point: usize) -> Option<ResultAt> {
        let b = self.plant.buses.get(bus)?;
        let d = b.drives.get(drive)?;
        let p = d.points.get(point)?;
        Some(ResultAt {
            topic: format!("{}{}/{}/{}/result", self.names.base, b.name, d.name, p.name),
            target: p.target,
        })
    }

    fn result(&mut self, at: &ResultAt, outcome: &SetOutcome, id: Option<&serde_json::Value>) {
        let label = outcome.label();
        self.metrics.set_outcome(label);
        let payload = payload::result(outcome, &at.target, id, payload::millis(SystemTime::now()));
        tracing::info!(topic = %at.topic, outcome = label, "set answered");
        let topic = at.topic.clone();
        if self.outbox.push_result(ResultMsg { topic, payload }) {
            tracing::warn!("more results waiting for the broker than kept: dropped the oldest");
        }
    }

    fn done(&mut self, d: Done) {
        self.result(&d.at, &d.outcome, d.id.as_ref());
    }

    fn incoming(&mut self, p: Publish) {
        if p.payload.is_empty() {
            // The deletion of a retained message (the gateway clears retained sets itself).
            return;
        }
        // MQTT topics are UTF-8 (the broker checks it).
        let topic = String::from_utf8_lossy(&p.topic).into_owned();
        // Which subscription it came through (a broker that matches a message to both sends
        // one copy with both identifiers, or one copy per subscription): a `set` is taken only
        // through the set subscription.
        let ids = p
            .properties
            .as_ref()
            .map(|pp| pp.subscription_identifiers.as_slice())
            .unwrap_or_default();
        if ids.contains(&EARLIER) {
            self.earlier(&topic, p.retain);
        }
        if !ids.is_empty() && !ids.contains(&SETS) {
            return;
        }
        let Some(((bus, drive, point), at)) = self
            .names
            .set_target(&topic)
            .and_then(|(b, d, p)| Some(((b, d, p), self.result_at(b, d, p)?)))
        else {
            self.unknown_sets += 1;
            self.metrics.set_outcome("unknown_topic");
            let now = Instant::now();
            let due = self
                .unknown_logged
                .is_none_or(|(at, _)| now.duration_since(at) >= UNKNOWN_LOG_EVERY);
            if due {
                let left_out = self
                    .unknown_logged
                    .map_or(0, |(_, n)| self.unknown_sets.saturating_sub(n + 1));
                tracing::warn!(
                    %topic,
                    left_out,
                    "a set for no point of this gateway: ignored (logged at most every 10 s; left_out: how many since the last)"
                );
                self.unknown_logged = Some((now, self.unknown_sets));
            }
            return;
        };
        if p.retain {
            // Cleared (an empty retained message deletes it), so that it is not refused again
            // at every reconnection.
            match self
                .client
                .try_publish(&topic, QoS::AtLeastOnce, true, Vec::new())
            {
                Ok(()) => self.outbox.handed_other(),
                Err(e) => {
                    tracing::warn!(%topic, error = %e, "cannot clear a retained set")
                }
            }
        }
        let refuse =
            |reason: &'static str, message: String| SetOutcome::Refused { reason, message };
        let msg = match payload::parse_set(&p.payload) {
            Ok(m) => m,
            Err(bad) => {
                let outcome = if p.retain {
                    refuse("retained", retained_text())
                } else {
                    refuse("bad_request", bad.message)
                };
                self.result(&at, &outcome, bad.id.as_ref());
                return;
            }
        };
        match self.check(bus, drive, point, &msg, p.retain) {
            Err(outcome) => self.result(&at, &outcome, msg.id.as_ref()),
            Ok(max_age) => self.send(bus, drive, point, at, msg, max_age),
        }
    }

    /// Whether the set may go to the bus: its remaining age, or the refusal.
    fn check(
        &self,
        bus: usize,
        drive: usize,
        point: usize,
        msg: &payload::SetMessage,
        retained: bool,
    ) -> std::result::Result<Duration, SetOutcome> {
        let refuse =
            |reason: &'static str, message: String| SetOutcome::Refused { reason, message };
        if retained {
            return Err(refuse("retained", retained_text()));
        }
        let max = self.plant.gateway.max_set_age;
        let mut max_age = max;
        if let Some(ts) = msg.ts {
            let now = i128::from(payload::millis(SystemTime::now()));
            let age_ms = now - i128::from(ts);
            if age_ms > max.as_millis() as i128 {
                return Err(refuse(
                    "stale",
                    format!(
                        "sent {} ms ago (ts), more than max_set_age = {} ms: not executed",
                        age_ms,
                        max.as_millis()
                    ),
                ));
            }
            if -age_ms > MAX_SET_FUTURE.as_millis() as i128 {
                return Err(refuse(
                    "stale",
                    format!(
                        "ts is {} ms in the future: check the sender's clock (at most {} ms \
                         ahead is taken)",
                        -age_ms,
                        MAX_SET_FUTURE.as_millis()
                    ),
                ));
            }
            let age = Duration::from_millis(u64::try_from(age_ms.max(0)).unwrap_or(u64::MAX));
            max_age = max.saturating_sub(age);
        }
        let writable = self
            .plant
            .buses
            .get(bus)
            .and_then(|b| b.drives.get(drive))
            .and_then(|d| d.points.get(point))
            .is_some_and(|p| p.writable);
        if !writable {
            return Err(refuse(
                "not_writable",
                "this point is not writable: the gateway's config must say writable = true for \
                 it"
                .to_owned(),
            ));
        }
        if self.outbox.status(bus, drive) == Some(&DriveStatus::Timeout) {
            return Err(refuse(
                "offline",
                "the drive does not answer (status timeout): not sent".to_owned(),
            ));
        }
        Ok(max_age)
    }

    fn send(
        &mut self,
        bus: usize,
        drive: usize,
        point: usize,
        at: ResultAt,
        msg: payload::SetMessage,
        max_age: Duration,
    ) {
        let Some(tx) = self.sets.get(bus) else {
            return;
        };
        let done = self.done_tx.clone();
        let id = msg.id.clone();
        let at_done = at.clone();
        let handed = hand_set(tx, drive, point, msg.value, max_age, move |outcome| {
            let _ = done.send(Done {
                at: at_done,
                outcome,
                id,
            });
        });
        if let Err(outcome) = handed {
            self.result(&at, &outcome, msg.id.as_ref());
        }
    }

    /// Publish `offline` (retained) and disconnect, waiting at most [`SHUTDOWN_FLUSH`]; at
    /// [`End::Clear`] every retained topic is cleared instead.
    async fn shutdown(&mut self, link_rx: &mut mpsc::Receiver<Link>, end: End) {
        if !self.connected {
            return;
        }
        let messages = match end {
            // Every value published, retained as stale: after the stop no consumer takes one
            // for a current value.
            End::Stop => self.farewell(Farewell::Stale {
                reason: "stopped",
                keep: false,
            }),
            End::Clear => self.farewell(Farewell::Clear),
        };
        tracing::info!(
            messages = messages.len(),
            "{}",
            match end {
                End::Stop => "stopping: the values as stale, then offline",
                End::Clear => "the reloaded config has no JSON topics: clearing them",
            }
        );
        if self.leave(link_rx, messages).await {
            tracing::info!("disconnected from the broker");
        }
        metrics_connected(&self.metrics, false);
    }
}

/// How a connection's topics are left ([`Task::farewell`]).
#[derive(Debug, Clone, Copy)]
enum Farewell {
    /// Every value published stale and the status `offline` with `reason`; `keep`: the values
    /// stay known as they were (for a next connection), else they are kept as stale.
    Stale { reason: &'static str, keep: bool },
    /// Every retained topic cleared, the status too.
    Clear,
}

/// Wait (until `deadline`) for the client to have sent its DISCONNECT.
async fn wait_disconnect(link_rx: &mut mpsc::Receiver<Link>, deadline: Instant) {
    loop {
        match tokio::time::timeout_at(deadline, link_rx.recv()).await {
            Ok(Some(Link::Event(e))) if matches!(*e, Event::Outgoing(Outgoing::Disconnect)) => {
                break;
            }
            Ok(Some(Link::Event(_))) => {}
            Ok(Some(Link::Down { .. }) | None) => break,
            Err(_) => {
                tracing::warn!("the disconnect did not go out in time");
                break;
            }
        }
    }
}

fn retained_text() -> String {
    "a retained set is never executed (it would move the machine again at every reconnection); \
     publish sets with retain = false"
        .to_owned()
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn backoff_doubles_to_30s_and_resets() {
        let mut b = Backoff::default();
        let waits: Vec<u64> = (0..9).map(|_| b.failed().as_millis() as u64).collect();
        assert_eq!(
            waits,
            [500, 1000, 2000, 4000, 8000, 16000, 30000, 30000, 30000]
        );
        b.reset();
        assert_eq!(b.failed(), BACKOFF_FIRST);
    }

    /// Issue 18: the broker's reasons for a person, with the config key to change.
    #[test]
    fn connection_errors_name_the_cause() {
        use rumqttc::v5::mqttbytes::v5::ConnectReturnCode as C;
        let taken = ConnectionError::MqttState(StateError::ServerDisconnect {
            reason_code: DisconnectReasonCode::SessionTakenOver,
            reason_string: None,
        });
        let text = describe(&taken, "drivebus-gw1");
        assert!(
            text.contains("another client connected with the same client id \"drivebus-gw1\"")
                && text.contains("[gateway] client_id"),
            "{text}"
        );
        let closed = ConnectionError::MqttState(StateError::ConnectionAborted);
        let text = describe(&closed, "drivebus-gw1");
        assert!(
            text.contains("client id \"drivebus-gw1\" is probably in use by another client")
                && text.contains("[gateway] client_id"),
            "{text}"
        );
        let old = ConnectionError::MqttState(StateError::Deserialization(
            rumqttc::v5::mqttbytes::Error::InvalidConnectReturnCode(1),
        ));
        assert!(describe(&old, "x").contains("does not speak MQTT 5"));
        let pw = ConnectionError::ConnectionRefused(C::BadUserNamePassword);
        assert!(describe(&pw, "x").contains("password_file"));
        let id = ConnectionError::ConnectionRefused(C::ClientIdentifierNotValid);
        assert!(describe(&id, "gw").contains("[gateway] client_id"));
    }

    #[test]
    fn set_topics_by_name() {
        let plant = Plant::parse(
            "[gateway]\nname = \"gw\"\nbroker = \"mqtt://h\"\nprefix = \"plant/a\"\n\
             [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
             [[bus.drive]]\nname = \"d\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n\
             [[bus.drive.param]]\nparam = \"P700\"\nname = \"mode\"\nwritable = true\n",
            "test",
        )
        .unwrap();
        let n = Names::new(&plant);
        assert_eq!(n.set_filter, "plant/a/gw/+/+/+/set");
        assert_eq!(n.all_filter, "plant/a/gw/#");
        assert!(n.known.contains("plant/a/gw/b/d/mode"));
        assert!(n.known.contains("plant/a/gw/b/d/status"));
        assert!(n.known.contains("plant/a/gw/b/d/pd"));
        assert!(n.known.contains("plant/a/gw/b/status"));
        assert!(n.known.contains("plant/a/gw/status"));
        assert!(!n.known.contains("plant/a/gw/b/d/P700"));
        assert_eq!(n.set_target("plant/a/gw/b/d/P130/set"), Some((0, 0, 0)));
        assert_eq!(n.set_target("plant/a/gw/b/d/mode/set"), Some((0, 0, 1)));
        for bad in [
            "plant/a/gw/b/d/P700/set",
            "plant/a/gw/b/d/mode",
            "plant/a/gw/b/x/mode/set",
            "plant/a/gx/b/d/mode/set",
            "plant/a/gw/b/d/mode/set/set",
            "",
        ] {
            assert_eq!(n.set_target(bad), None, "{bad}");
        }
    }
}
