//! `drivectl ui`: the gateway's browser page for the drives on one bus, from the command line
//! (a laptop on one drive): a one-bus plant (`drivebus_gateway::ui::OneBus`) without a broker,
//! the page on 127.0.0.1, its address printed and opened where a desktop is.

use std::net::SocketAddr;

use clap::Args;
use drivebus_gateway::Plant;
use drivebus_gateway::ui::OneBus;

use crate::error::{CliError, Result};

/// `drivectl ui`.
#[derive(Debug, Args)]
#[command(
    after_help = "Examples:\n  drivectl ui movilink --port /dev/ttyUSB0 --addr 1\n  drivectl ui modbus-rtu --port /dev/ttyUSB0 --baud 19200 --addr 1 --addr 2\n  drivectl ui sbus --iface can0 --addr 1\n  drivectl ui uss --simulate --addr 1 --addr 2       simulated drives, no hardware\n\nA whole plant's page: `[ui] listen = \"127.0.0.1:8080\"` in the config of `drivectl gateway`."
)]
pub struct UiArgs {
    /// The bus: movilink, sbus, uss, modbus-rtu or modbus-ascii.
    #[arg(value_parser = ["movilink", "sbus", "uss", "modbus-rtu", "modbus-ascii"])]
    pub protocol: String,
    /// Serial port (not SBus), e.g. /dev/ttyUSB0.
    #[arg(long)]
    pub port: Option<String>,
    /// SBus: the CAN interface (`can0`, `slcan:PATH[@BITRATE]`).
    #[arg(long)]
    pub iface: Option<String>,
    /// Baud rate (default: the protocol's factory setting).
    #[arg(long)]
    pub baud: Option<u32>,
    /// Parity: even, odd or none (default: the protocol's factory setting).
    #[arg(long, value_parser = ["even", "odd", "none"])]
    pub parity: Option<String>,
    /// A drive's address; repeat for several drives.
    #[arg(long = "addr", default_value = "1")]
    pub addresses: Vec<u8>,
    /// Run against simulated drives (no port needed).
    #[arg(long)]
    pub simulate: bool,
    /// Where to serve the page: a loopback host:port; port 0 picks a free one.
    #[arg(long, default_value = "127.0.0.1:0")]
    pub listen: String,
    /// Only print the page's address; do not open a browser.
    #[arg(long)]
    pub no_open: bool,
    /// Log level: error, warn, info, debug or trace.
    #[arg(long, default_value = "warn", value_parser = ["error", "warn", "info", "debug", "trace"])]
    pub log_level: String,
}

/// `addr` with a free port when its port is 0, checked by taking it and letting it go (the
/// gateway binds it a moment later), so a port in use is said with the option's name.
fn with_port(addr: SocketAddr) -> Result<SocketAddr> {
    let l = std::net::TcpListener::bind(addr)
        .map_err(|e| CliError::failed(format!("--listen {addr}: cannot listen: {e}")))?;
    l.local_addr()
        .map_err(|e| CliError::failed(format!("--listen {addr}: {e}")))
}

/// Open `url` in the desktop's browser, where there is a desktop (quietly nothing elsewhere).
fn open(url: &str) {
    let desktop = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()));
    if desktop {
        let _ = std::process::Command::new("xdg-open")
            .arg(url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn();
    }
}

/// Run `drivectl ui`.
pub fn run(args: &UiArgs) -> Result<()> {
    if !args.simulate {
        match args.protocol.as_str() {
            "sbus" if args.iface.is_none() => {
                return Err(CliError::usage(
                    "drivectl ui sbus needs --iface (can0 or slcan:PATH), or --simulate",
                ));
            }
            "sbus" => {}
            _ if args.port.is_none() => {
                return Err(CliError::usage(format!(
                    "drivectl ui {} needs --port (e.g. /dev/ttyUSB0), or --simulate",
                    args.protocol
                )));
            }
            _ => {}
        }
    }
    let listen: SocketAddr = args.listen.trim().parse().map_err(|_| {
        CliError::usage(format!(
            "--listen {}: give host:port such as 127.0.0.1:8080",
            args.listen
        ))
    })?;
    if !listen.ip().is_loopback() {
        return Err(CliError::usage(format!(
            "--listen {listen}: the page is served on a loopback address only (127.0.0.1 or \
             [::1]); serving it to other hosts needs TLS and users, which this version does not \
             have"
        )));
    }
    let one = OneBus {
        protocol: args.protocol.clone(),
        port: args.port.clone(),
        iface: args.iface.clone(),
        baud: args.baud,
        parity: args.parity.clone(),
        addresses: args.addresses.clone(),
        simulate: args.simulate,
        listen: with_port(listen)?,
    };
    let plant = Plant::parse(&one.config(), "the command line").map_err(|e| match e {
        drivebus_gateway::Error::Config(m) => CliError::usage(m),
        other => CliError::failed(other.to_string()),
    })?;
    let url = format!("http://{}/", one.listen);
    crate::tool::output::emit(format_args!("{url}\n"))?;
    if !args.no_open {
        open(&url);
    }
    drivebus_gateway::init_logs("text", &args.log_level);
    drivebus_gateway::run(plant).map_err(|e| CliError::failed(e.to_string()))
}
