//! drivebus-gateway: every drive of a plant on an MQTT broker (`drivectl gateway` runs it).
//!
//! One task per bus ([`task`]: a scheduler that knows every transaction's wire time), one
//! MQTT task ([`mqtt`]: values, statuses, guarded writes), the Prometheus endpoint
//! ([`metrics`]). All run on one thread (a `LocalSet`): the work is waiting on wires, and a
//! bus's client futures need not be `Send`. See `docs/deploying.md`.
//!
//! A program checks a plant's config and runs it, as `drivectl gateway` does:
//!
//! ```
//! // The commented example config, every bus on simulated drives.
//! let mut plant = drivebus_gateway::Plant::parse(drivebus_gateway::EXAMPLE_CONFIG, "plant.toml")?;
//! drivebus_gateway::simulate_all(&mut plant);
//! // What `--check` prints: one line per bus, and whether every bus's polls fit its wire.
//! let (text, verdict) = drivebus_gateway::families::check_report(&plant);
//! assert_eq!(text.lines().count(), plant.buses.len());
//! verdict?;
//! // A mistake is one line that names the file, the line and the key.
//! let bad = drivebus_gateway::EXAMPLE_CONFIG.replacen("period = \"1s\"", "period = \"soon\"", 1);
//! let e = drivebus_gateway::Plant::parse(&bad, "plant.toml").unwrap_err();
//! assert!(matches!(e, drivebus_gateway::Error::Config(_)));
//! assert!(e.to_string().starts_with("plant.toml:"), "{e}");
//! // `drivebus_gateway::run(plant)` would serve it until a stop signal.
//! # Ok::<(), drivebus_gateway::Error>(())
//! ```

// The bus tasks run on one thread (a `LocalSet`): the futures of [`bus::BusAccess`] need not be
// `Send`, and callers of the trait's `async fn`s are the gateway's own tasks.
#![allow(async_fn_in_trait)]

pub mod bus;
pub mod config;
pub mod families;
pub mod load;
pub mod logfmt;
pub mod metrics;
pub mod model;
pub mod mqtt;
pub mod schedule;
pub mod sparkplug;
pub mod task;
pub mod ui;

pub mod error;

use std::sync::Arc;

use tokio::sync::mpsc;

pub use config::{Endpoint, Plant};
pub use error::{Error, Result};
pub use families::EXAMPLE_CONFIG;

/// The commented example config (runs as it is with every bus simulated).
pub fn example_config() -> &'static str {
    families::EXAMPLE_CONFIG
}

/// Put every bus of `plant` on simulated drives (each family's simulator on the wire model).
pub fn simulate_all(plant: &mut Plant) {
    for bus in &mut plant.buses {
        if !matches!(bus.endpoint, Endpoint::Simulated { .. }) {
            bus.endpoint = families::simulated_endpoint(bus);
        }
    }
}

/// Replace the config's broker by `url` (`mqtt://host:port`, `mqtts://[user@]host:port`).
pub fn set_broker(plant: &mut Plant, url: &str) -> Result<()> {
    plant.gateway.broker = config::check_broker(url).map_err(Error::config)?;
    Ok(())
}

/// Run the gateway on `plant` until a stop signal: a current-thread runtime with every task
/// on one thread (see [`serve`]).
pub fn run(plant: Plant) -> Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| Error::failed(format!("cannot start the runtime: {e}")))?;
    let local = tokio::task::LocalSet::new();
    local.block_on(&rt, serve(plant))
}

/// The gateway's tasks for `plant`, until Ctrl-C, SIGTERM, SIGHUP or SIGQUIT.
pub async fn serve(plant: Plant) -> Result<()> {
    // Taken before anything starts: from here on no stop signal ends the process without
    // the drives' stop.
    let mut signals = Signals::new();
    let plant = Arc::new(plant);
    let metrics = Arc::new(metrics::Metrics::new(&plant));
    // Prepared before anything else starts, so that a bad certificate or password file is
    // an error before a bus is opened.
    let mqtt = if plant.publishes_json() {
        Some(mqtt::Mqtt::prepare(&plant)?)
    } else {
        None
    };
    let sparkplug = sparkplug::Sparkplug::prepare(&plant)?;
    // The page's files (certificate, key, users) are read and its port is taken before a bus
    // opens: a bad file or a port in use is an error at the start.
    let page = match &plant.ui {
        Some(u) => Some((ui::auth::Security::load(u)?, ui::bind(u.listen).await?)),
        None => None,
    };
    let (update_tx, update_rx) = mpsc::channel(4096);
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let mut set_txs = Vec::new();
    let mut ask_txs = Vec::new();
    let mut buses = Vec::new();
    for (ix, bus) in plant.buses.iter().enumerate() {
        let (set_tx, set_rx) = mpsc::channel(64);
        set_txs.push(set_tx);
        let (ask_tx, ask_rx) = mpsc::channel(64);
        ask_txs.push(ask_tx);
        let ctx = bus::BusContext {
            ix,
            bus: bus.clone(),
            updates: update_tx.clone(),
            sets: set_rx,
            asks: ask_rx,
            metrics: metrics.clone(),
            shutdown: stop_rx.clone(),
        };
        buses.push(tokio::task::spawn_local(families::run_bus(ctx)));
    }
    drop(update_tx);
    // Without a page nobody asks the buses anything.
    if page.is_none() {
        ask_txs.clear();
    }
    if let Some(addr) = plant.gateway.metrics {
        let listener = metrics::bind(addr).await?;
        tokio::task::spawn_local(metrics::serve(listener, metrics.clone()));
    }
    // At a stop signal the bus tasks finish their transaction and stop the drives they
    // control over process data (bounded), then the MQTT task says `offline`.
    let shutdown = async move {
        let signal = signals.recv().await;
        tracing::info!(
            signal,
            "stopping: the buses finish, then the broker is told offline"
        );
        let _ = stop_tx.send(true);
        let all = tokio::time::timeout(BUS_STOP_LIMIT, futures_join(buses));
        // A second stop signal stops at once, without waiting for the buses.
        tokio::select! {
            r = all => if r.is_err() {
                tracing::warn!(
                    "the buses did not finish within {} s: stopping without them",
                    BUS_STOP_LIMIT.as_secs()
                );
            },
            signal = signals.recv() => tracing::warn!(
                signal,
                "stopping at once: drives controlled over process data may not have been sent their stop"
            ),
        }
    };
    // With a page, the updates pass through its hub on their way to the broker.
    let updates = match page {
        Some((security, listener)) => {
            // The page's jobs (reads, writes, backups) run on this thread, each bus's part of
            // them in its bus task.
            let (jobs, worker) = ui::drive::jobs();
            tokio::task::spawn_local(worker.run());
            let hub = ui::Hub::serving(plant.clone(), std::mem::take(&mut ask_txs), Some(jobs));
            if let Ok(at) = listener.local_addr() {
                let scheme = if security.tls.is_some() {
                    "https"
                } else {
                    "http"
                };
                let login = security.auth.login_required();
                tracing::info!(url = %format!("{scheme}://{at}/"), login, "the page is served");
            }
            let (onward_tx, onward_rx) = mpsc::channel(4096);
            let onward = mqtt.is_some().then_some(onward_tx);
            tokio::task::spawn_local(ui::relay(hub.clone(), update_rx, onward));
            // Ends with the runtime: the page's connections (live event streams) never end
            // by themselves, so the gateway does not wait for them at the stop.
            tokio::task::spawn_local(async move {
                if let Err(e) =
                    ui::serve_with(listener, hub, security, std::future::pending()).await
                {
                    tracing::error!(error = %e, "the page stopped");
                }
            });
            onward_rx
        }
        None => update_rx,
    };
    // The stop reaches every publisher once the buses are done.
    let (stopped_tx, stopped_rx) = tokio::sync::watch::channel(false);
    tokio::task::spawn_local(async move {
        shutdown.await;
        let _ = stopped_tx.send(true);
    });
    let stopped = |mut rx: tokio::sync::watch::Receiver<bool>| async move {
        let _ = rx.wait_for(|s| *s).await;
    };
    // Both ways of publishing see every update.
    let (json_updates, spb_updates) = match (&mqtt, &sparkplug) {
        (Some(_), Some(_)) => {
            let (a_tx, a_rx) = mpsc::channel(4096);
            let (b_tx, b_rx) = mpsc::channel(4096);
            tokio::task::spawn_local(tee(updates, a_tx, b_tx));
            (Some(a_rx), Some(b_rx))
        }
        (Some(_), None) => (Some(updates), None),
        (None, Some(_)) => (None, Some(updates)),
        (None, None) => {
            drop(updates);
            (None, None)
        }
    };
    let spb_task = match (sparkplug, spb_updates) {
        (Some(spb), Some(u)) => Some(tokio::task::spawn_local(spb.run(
            u,
            set_txs.clone(),
            metrics.clone(),
            stopped_rx.clone(),
        ))),
        _ => None,
    };
    let json = match (mqtt, json_updates) {
        (Some(mqtt), Some(u)) => {
            mqtt.run(u, set_txs, metrics, stopped(stopped_rx.clone()))
                .await
        }
        _ => {
            // No JSON topics: the page or Sparkplug shows the drives until a stop signal.
            drop(set_txs);
            stopped(stopped_rx.clone()).await;
            Ok(())
        }
    };
    if let Some(t) = spb_task {
        match t.await {
            Ok(r) => r?,
            Err(e) => tracing::error!(error = %e, "the Sparkplug task ended abnormally"),
        }
    }
    json
}

/// Hand every update to both publishers (waits for the slower: the buses never outrun it).
async fn tee(
    mut from: mpsc::Receiver<model::Update>,
    a: mpsc::Sender<model::Update>,
    b: mpsc::Sender<model::Update>,
) {
    while let Some(u) = from.recv().await {
        let (ra, rb) = (a.send(u.clone()).await, b.send(u).await);
        if ra.is_err() && rb.is_err() {
            return;
        }
    }
}

/// How long the buses get at the stop to finish their transaction and stop their drives.
const BUS_STOP_LIMIT: std::time::Duration = std::time::Duration::from_secs(10);

/// Wait for every task (their panics and cancellations are the tasks' business: logged by
/// tokio, nothing to do here).
async fn futures_join(tasks: Vec<tokio::task::JoinHandle<()>>) {
    for t in tasks {
        let _ = t.await;
    }
}

/// The signals that stop the gateway: Ctrl-C (SIGINT), SIGTERM (systemd's stop), SIGHUP (the
/// terminal closed, or a reload asked: a clean stop for now) and SIGQUIT. Each is taken from
/// [`Signals::new`] on, so that none of them ends the process with its default action (without
/// the drives' stop).
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

    /// The next stop signal's name.
    async fn recv(&mut self) -> &'static str {
        async fn next(s: &mut Option<tokio::signal::unix::Signal>) {
            let got = match s {
                Some(s) => s.recv().await.is_some(),
                None => false,
            };
            if !got {
                std::future::pending::<()>().await;
            }
        }
        tokio::select! {
            () = next(&mut self.int) => "SIGINT",
            () = next(&mut self.term) => "SIGTERM",
            () = next(&mut self.hup) => "SIGHUP",
            () = next(&mut self.quit) => "SIGQUIT",
        }
    }
}

/// Structured logs on standard error.
/// Send the gateway's logs to standard error: `format` `text` or `json`, `level` `error`,
/// `warn`, `info`, `debug` or `trace` (anything else is `info`).
pub fn init_logs(format: &str, level: &str) {
    let level = match level {
        "error" => tracing::Level::ERROR,
        "warn" => tracing::Level::WARN,
        "debug" => tracing::Level::DEBUG,
        "trace" => tracing::Level::TRACE,
        _ => tracing::Level::INFO,
    };
    // Colours only on a terminal: the journal and log files get plain text.
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let builder = tracing_subscriber::fmt()
        .with_max_level(level)
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .with_target(false);
    // A second initialisation (tests running `serve` twice) keeps the first.
    let _ = if format == "json" {
        builder.json().try_init()
    } else {
        builder.try_init()
    };
}
