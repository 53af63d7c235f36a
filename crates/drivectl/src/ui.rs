//! `drivectl ui`: the gateway's browser page for the drives on one bus, from the command line
//! (a laptop on one drive): a one-bus plant (`drivebus_gateway::ui::OneBus`) without a broker,
//! the page on 127.0.0.1, its address printed and opened where a desktop is. `drivectl ui
//! passwd` adds a user to the password file of a gateway's page (`[ui] users`).

use std::net::SocketAddr;

use clap::{Args, Subcommand};
use drivebus_gateway::Plant;
use drivebus_gateway::ui::OneBus;
use drivebus_gateway::ui::auth::{self, Role};

use crate::error::{CliError, Result};

/// `drivectl ui`.
#[derive(Debug, Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = "Examples:\n  drivectl ui movilink --port /dev/ttyUSB0 --addr 1\n  drivectl ui modbus-rtu --port /dev/ttyUSB0 --baud 19200 --addr 1 --addr 2\n  drivectl ui sbus --iface can0 --addr 1\n  drivectl ui uss --simulate --addr 1 --addr 2       simulated drives, no hardware\n  drivectl ui ctt2 --sim --addr 1 --addr 5           NORDAC LINKs at 1A and 5A on the simulated AS-i link\n  drivectl ui bonfiglioli --port /dev/ttyUSB0 --scan --to 10   serve the drives that answer\n\nA whole plant's page: `[ui] listen = \"127.0.0.1:8080\"` in the config of `drivectl gateway`;\n  drivectl ui passwd --file /etc/drivebus/page.users --user anna --role operator\nadds a user to its password file (`[ui] users`)."
)]
pub struct UiArgs {
    /// Another task than serving a page.
    #[command(subcommand)]
    pub command: Option<UiCommand>,
    /// The bus: movilink, sbus, uss, ctt2 (simulated AS-i link only: --sim), bonfiglioli
    /// (Modbus RTU, or ASCII with --mode ascii), modbus-rtu or modbus-ascii.
    #[arg(required = true, value_parser = ["movilink", "sbus", "uss", "ctt2", "bonfiglioli", "modbus-rtu", "modbus-ascii"])]
    pub protocol: Option<String>,
    /// bonfiglioli: the transmission mode (the drive's parameter 395).
    #[arg(long, value_parser = ["rtu", "ascii"])]
    pub mode: Option<String>,
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
    /// A drive's address; repeat for several drives (ctt2: the double slave's number 1–31,
    /// 5 for 5A/5B).
    #[arg(long = "addr", default_value = "1")]
    pub addresses: Vec<u8>,
    /// Response timeout of one attempt in ms (default: the protocol's; never below the least
    /// the line allows).
    #[arg(long)]
    pub timeout: Option<u64>,
    /// Attempts after a timeout or a corrupt answer (default: the gateway's, 2).
    #[arg(long)]
    pub retries: Option<u8>,
    #[command(flatten)]
    pub adapter: crate::tool::line::AdapterArgs,
    /// Serve the drives that answer: probe every address from --from to --to first (one read
    /// each, no retries) instead of taking --addr. With --simulate the drives of --addr answer.
    #[arg(long)]
    pub scan: bool,
    /// --scan: the first address (default: the protocol's first: MOVILINK, SBus, USS 0,
    /// CTT2 and Modbus 1).
    #[arg(long, requires = "scan")]
    pub from: Option<u8>,
    /// --scan: the last address (default: the protocol's last: MOVILINK 99, SBus 63, USS 31,
    /// CTT2 31, Modbus 247).
    #[arg(long, requires = "scan")]
    pub to: Option<u8>,
    /// Run against simulated drives (no port needed); `--sim` as `drivectl ctt2` spells it.
    #[arg(long, visible_alias = "sim")]
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

/// `drivectl ui …` tasks.
#[derive(Debug, Subcommand)]
pub enum UiCommand {
    /// Add a user to a gateway page's password file (`[ui] users`), or give one a new password
    /// or role.
    #[command(
        after_help = "The password is read twice without echo on a terminal, or as one line from standard input otherwise:\n  drivectl ui passwd --file page.users --user anna --role operator\n  printf '%s\\n' \"$PW\" | drivectl ui passwd --file page.users --user viewer1\n\nThe file is written atomically, mode 0600 when new (an existing file keeps its mode and owner)."
    )]
    Passwd(PasswdArgs),
}

/// `drivectl ui passwd`.
#[derive(Debug, Args)]
pub struct PasswdArgs {
    /// The password file (made when missing).
    #[arg(long)]
    pub file: String,
    /// The user's name (1–64 characters, no ':').
    #[arg(long)]
    pub user: String,
    /// What the user may do: viewer (reads) or operator (also writes and controls).
    #[arg(long, default_value = "viewer", value_parser = ["viewer", "operator"])]
    pub role: String,
}

/// The new password: twice without echo on a terminal, or one line of standard input.
fn read_new_password(user: &str) -> Result<String> {
    use std::io::IsTerminal as _;
    let fail = |e: std::io::Error| CliError::failed(format!("cannot read the password: {e}"));
    let password = if std::io::stdin().is_terminal() {
        let first =
            rpassword::prompt_password(format!("new password for {user}: ")).map_err(fail)?;
        let again = rpassword::prompt_password("the same again: ").map_err(fail)?;
        if first != again {
            return Err(CliError::usage(
                "the two passwords differ: nothing was changed",
            ));
        }
        first
    } else {
        let mut line = String::new();
        std::io::stdin().read_line(&mut line).map_err(fail)?;
        let l = line.strip_suffix('\n').unwrap_or(&line);
        l.strip_suffix('\r').unwrap_or(l).to_owned()
    };
    if password.is_empty() {
        return Err(CliError::usage(
            "the password is empty: nothing was changed",
        ));
    }
    if password.len() > auth::MAX_PASSWORD {
        return Err(CliError::usage(format!(
            "the password is longer than {} bytes: nothing was changed",
            auth::MAX_PASSWORD
        )));
    }
    Ok(password)
}

/// Run `drivectl ui passwd`: check the user name and the file before asking for the password,
/// then write the file atomically.
fn passwd(args: &PasswdArgs) -> Result<()> {
    use drive_client::outfile::OutputFile;
    let path = std::path::Path::new(&args.file);
    auth::check_user_name(&args.user).map_err(|e| CliError::usage(format!("--user: {e}")))?;
    let role = Role::parse(&args.role).unwrap_or(Role::Viewer);
    let old = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        _ => {
            let bytes = drive_client::infile::read_limited(path, false, 1 << 20)
                .map_err(|e| CliError::failed(format!("--file: {e}")))?;
            String::from_utf8(bytes).map_err(|_| {
                CliError::usage(format!(
                    "{}: not UTF-8 text: nothing was changed",
                    args.file
                ))
            })?
        }
    };
    let problem = |e: auth::UsersError| match e {
        auth::UsersError::Line { line, problem } => CliError::usage(format!(
            "{}:{line}: {problem}: nothing was changed",
            args.file
        )),
        other => CliError::usage(format!("{}: {other}", args.file)),
    };
    // A broken file is said before the password is asked for.
    auth::Users::parse(&old).map_err(problem)?;
    let password = read_new_password(&args.user)?;
    let out =
        OutputFile::prepare(path, true).map_err(|e| CliError::failed(format!("--file: {e}")))?;
    let phc = auth::hash_password(&password).map_err(|e| CliError::failed(e.to_string()))?;
    let text = auth::set_user(&old, &args.user, role, &phc).map_err(problem)?;
    if old.is_empty() {
        use std::os::unix::fs::PermissionsExt as _;
        out.writer()
            .and_then(|f| {
                f.set_permissions(std::fs::Permissions::from_mode(0o600))
                    .map_err(|source| drive_client::outfile::OutputError::Write {
                        path: path.to_path_buf(),
                        source,
                    })
            })
            .map_err(|e| CliError::failed(format!("--file: {e}")))?;
    }
    out.commit(&text)
        .map_err(|e| CliError::failed(format!("--file: {e}")))?;
    let verb = if auth::Users::parse(&old)
        .ok()
        .and_then(|u| u.get(&args.user).cloned())
        .is_some()
    {
        "replaced"
    } else {
        "added"
    };
    crate::tool::output::emit(format_args!(
        "{}: {verb} {} ({role})\n",
        args.file, args.user
    ))
}

/// `addr` with a free port when its port is 0, checked by taking it and letting it go (the
/// gateway binds it a moment later), so a port in use is said with the option's name.
fn with_port(addr: SocketAddr) -> Result<SocketAddr> {
    let l = std::net::TcpListener::bind(addr)
        .map_err(|e| CliError::failed(format!("--listen {addr}: cannot listen: {e}")))?;
    l.local_addr()
        .map_err(|e| CliError::failed(format!("--listen {addr}: {e}")))
}

/// `--scan`: the addresses that answer between `from` and `to` (the protocol's range by
/// default), said on standard error as they are found.
fn scan(one: &OneBus, from: Option<u8>, to: Option<u8>) -> Result<Vec<u8>> {
    let (first, last) = drivebus_gateway::ui::scan_range(&one.protocol);
    let (from, to) = (from.unwrap_or(first), to.unwrap_or(last));
    if from > to || from < first || to > last {
        return Err(CliError::usage(format!(
            "--from {from} --to {to}: give {first} ≤ from ≤ to ≤ {last} for {}",
            one.protocol
        )));
    }
    crate::errln!(
        "drivectl: note: scanning {} addresses {from}–{to}…",
        one.protocol
    );
    let mut each = |a: u8, answered: bool| {
        if answered {
            crate::errln!("drivectl: note: a drive answers at address {a}");
        }
    };
    let found = one
        .scan(from, to, &mut each)
        .map_err(|e| CliError::failed(e.to_string()))?;
    if found.is_empty() && one.protocol == "ctt2" {
        return Err(CliError::failed(format!(
            "no double slave answered at {from}–{to}: the simulated AS-i link has those of --addr"
        )));
    }
    if found.is_empty() {
        return Err(CliError::failed(format!(
            "no drive answered at addresses {from}–{to}: check the port, the baud rate and the \
             parity (--baud, --parity), and that the drives are powered and wired"
        )));
    }
    Ok(found)
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
    if let Some(UiCommand::Passwd(p)) = &args.command {
        return passwd(p);
    }
    let protocol = args.protocol.clone().ok_or_else(|| {
        CliError::usage(
            "drivectl ui needs a protocol (movilink, sbus, uss, ctt2, bonfiglioli, modbus-rtu, \
             modbus-ascii)",
        )
    })?;
    let protocol = match (protocol.as_str(), args.mode.as_deref()) {
        ("bonfiglioli", Some("ascii")) => "modbus-ascii".to_owned(),
        ("bonfiglioli", _) => "modbus-rtu".to_owned(),
        (_, Some(_)) => {
            return Err(CliError::usage(format!(
                "--mode is for bonfiglioli, not {protocol}"
            )));
        }
        _ => protocol,
    };
    if !args.simulate {
        match protocol.as_str() {
            "ctt2" => {
                return Err(CliError::usage(
                    "drivectl ui ctt2 needs --sim: drivebus reaches CTT2 only through its \
                     simulated AS-i link (it has no real AS-i master)",
                ));
            }
            "sbus" if args.iface.is_none() => {
                return Err(CliError::usage(
                    "drivectl ui sbus needs --iface (can0 or slcan:PATH), or --simulate",
                ));
            }
            "sbus" => {}
            _ if args.port.is_none() => {
                return Err(CliError::usage(format!(
                    "drivectl ui {protocol} needs --port (e.g. /dev/ttyUSB0), or --simulate"
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
            "--listen {listen}: drivectl ui serves the page on a loopback address only \
             (127.0.0.1 or [::1]); for other hosts run drivectl gateway with [ui] tls_cert, \
             tls_key and users (see drivectl ui passwd)"
        )));
    }
    let mut one = OneBus {
        protocol,
        port: args.port.clone(),
        iface: args.iface.clone(),
        baud: args.baud,
        parity: args.parity.clone(),
        addresses: args.addresses.clone(),
        simulate: args.simulate,
        listen: with_port(listen)?,
        timeout_ms: args.timeout,
        retries: args.retries,
        echo: args.adapter.echo,
        rs485: args.adapter.rs485(),
    };
    if args.scan {
        one.addresses = scan(&one, args.from, args.to)?;
    }
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
