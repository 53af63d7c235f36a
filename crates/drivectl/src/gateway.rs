//! `drivectl gateway`: the command line of the gateway crate (`drivebus_gateway`): every drive
//! of a plant on an MQTT broker. The options are read here; the config, the buses, MQTT and
//! the metrics are the crate's, its errors said with the exit codes of every command (2 for a
//! config to change, 1 for a failure).

use clap::Args;
use drivebus_gateway::{Error, Plant};

use crate::error::{CliError, Result};

/// `drivectl gateway`.
#[derive(Debug, Args)]
#[command(
    after_help = "Examples:\n  drivectl gateway --example-config > plant.toml\n  drivectl gateway --config plant.toml --simulate\n  drivectl gateway --config plant.toml --broker mqtts://gw1@broker.plant.local:8883\n  drivectl gateway --config plant.toml --check"
)]
pub struct GatewayArgs {
    /// The plant's config file (TOML; `-`: standard input).
    #[arg(long, required_unless_present = "example_config")]
    pub config: Option<String>,
    /// The broker, overriding the config's: mqtt://host:port, mqtts://host:port or mqtts://user@host:port.
    #[arg(long)]
    pub broker: Option<String>,
    /// Run every bus against simulated drives (each family's simulator on the wire model).
    #[arg(long)]
    pub simulate: bool,
    /// Print a commented example config (runs as it is with --simulate) and exit.
    #[arg(long, conflicts_with_all = ["config", "broker", "simulate", "check"])]
    pub example_config: bool,
    /// Check the config, print each bus's wire demand, and exit.
    #[arg(long)]
    pub check: bool,
    /// Log format: text or json (logs go to standard error).
    #[arg(long, default_value = "text", value_parser = ["text", "json"])]
    pub log_format: String,
    /// Log level: error, warn, info, debug or trace.
    #[arg(long, default_value = "info", value_parser = ["error", "warn", "info", "debug", "trace"])]
    pub log_level: String,
}

/// A gateway error as the command line's: a config to change exits 2, a failure 1.
fn cli_error(e: Error) -> CliError {
    match e {
        Error::Config(m) => CliError::usage(m),
        other => CliError::failed(other.to_string()),
    }
}

/// Run `drivectl gateway`.
pub fn run(args: &GatewayArgs) -> Result<()> {
    if args.example_config {
        return crate::tool::output::emit(format_args!("{}", drivebus_gateway::example_config()));
    }
    let path = args.config.as_deref().unwrap_or("-");
    let plant = load(path, args.broker.as_deref(), args.simulate).map_err(cli_error)?;
    if args.check {
        // The page's certificate, key and password file are read as at the start.
        if let Some(ui) = &plant.ui {
            drivebus_gateway::ui::auth::Security::load(ui).map_err(cli_error)?;
        }
        let (text, verdict) = drivebus_gateway::families::check_report(&plant);
        crate::tool::output::emit(format_args!("{text}"))?;
        return verdict.map_err(cli_error);
    }
    drivebus_gateway::init_logs(&args.log_format, &args.log_level);
    // SIGHUP (`systemctl reload`) reads the file again, with the same --broker and --simulate.
    let source = if path == "-" {
        drivebus_gateway::Source::once("-")
    } else {
        let (file, broker, simulate) = (path.to_owned(), args.broker.clone(), args.simulate);
        // The status topic names the file as a plant's IT finds it.
        let shown = std::fs::canonicalize(path)
            .map(|p| p.display().to_string())
            .unwrap_or_else(|_| path.to_owned());
        drivebus_gateway::Source::file(shown, move || load(&file, broker.as_deref(), simulate))
    };
    drivebus_gateway::run_source(plant, source).map_err(cli_error)
}

/// The plant of the config file `path` with what the command line adds (`--broker`,
/// `--simulate`).
fn load(path: &str, broker: Option<&str>, simulate: bool) -> std::result::Result<Plant, Error> {
    let mut plant = Plant::load(path)?;
    if let Some(b) = broker {
        drivebus_gateway::set_broker(&mut plant, b)?;
    }
    if simulate {
        drivebus_gateway::simulate_all(&mut plant);
    }
    Ok(plant)
}
