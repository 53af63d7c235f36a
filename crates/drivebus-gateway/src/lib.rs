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
pub mod supervise;
pub mod task;
pub mod tasks;
pub mod ui;

pub mod error;

pub use config::{Endpoint, Plant};
pub use error::{Error, Result};
pub use families::EXAMPLE_CONFIG;
pub use supervise::{Source, serve_source};

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
/// on one thread (see [`serve`]). SIGHUP stops it too (there is no file to read again): see
/// [`run_source`] for a gateway that reloads its config.
pub fn run(plant: Plant) -> Result<()> {
    run_source(plant, Source::fixed())
}

/// Run the gateway on `plant`, read from `source`, until a stop signal; SIGHUP reads the
/// config again and puts it into effect without a restart ([`supervise`]).
pub fn run_source(plant: Plant, source: Source) -> Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(supervise::runtime_error)?;
    let local = tokio::task::LocalSet::new();
    local.block_on(&rt, serve_source(plant, source))
}

/// The gateway's tasks for `plant`, until Ctrl-C, SIGTERM, SIGHUP or SIGQUIT.
pub async fn serve(plant: Plant) -> Result<()> {
    serve_source(plant, Source::fixed()).await
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
