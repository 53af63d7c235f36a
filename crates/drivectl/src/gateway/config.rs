//! The gateway's configuration file (`plant.toml`): what it reads as TOML ([`File`]), and the
//! checked plant it runs ([`Plant`]).
//!
//! Every name, address, parameter and period is checked when the file is loaded, before any
//! port or broker is touched; an error names the file, the bus and drive, and what to write.

use std::collections::HashSet;
use std::time::Duration;

use drive_profile::Family;
use drive_transport::serial::{Parity, StopBits};
use serde::Deserialize;

use crate::error::{CliError, Result};
use crate::tool::client::Target;

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct File {
    /// `[gateway]`.
    pub gateway: GatewayFile,
    /// `[[bus]]`.
    #[serde(default, rename = "bus")]
    pub buses: Vec<BusFile>,
}

/// `[gateway]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatewayFile {
    /// The gateway's name: the second level of every topic.
    pub name: String,
    /// `mqtt://host:port` or `mqtts://[user@]host:port`.
    pub broker: String,
    /// MQTT client identifier (default `drivebus-<name>`).
    pub client_id: Option<String>,
    /// Broker user name (also in the broker URL as `user@`).
    pub username: Option<String>,
    /// A file holding the broker password (first line), never the password itself.
    pub password_file: Option<String>,
    /// PEM file of the CA that signed the broker's certificate (`mqtts`; default: the
    /// system's roots).
    pub ca_file: Option<String>,
    /// PEM client certificate (and `client_key`) for certificate authentication.
    pub client_cert: Option<String>,
    /// PEM private key of `client_cert`.
    pub client_key: Option<String>,
    /// Topic prefix (default `drivebus`).
    pub prefix: Option<String>,
    /// Republish every value at least this often, changed or not (default 60 s).
    pub heartbeat: Option<String>,
    /// A `set` whose `ts` is older than this is refused as stale (default 10 s).
    pub max_set_age: Option<String>,
    /// `host:port` of the Prometheus endpoint (default `127.0.0.1:9464`; `off` for none).
    pub metrics: Option<String>,
    /// MQTT keep-alive (default 30 s).
    pub keep_alive: Option<String>,
}

/// `[[bus]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusFile {
    /// The bus's name: the third level of its topics.
    pub name: String,
    /// `movilink`, `sbus`, `uss`, `modbus-rtu` or `modbus-ascii`.
    pub protocol: String,
    /// Serial port (MOVILINK, USS, Modbus).
    pub port: Option<String>,
    /// CAN interface for SBus: `can0` or `slcan:PATH[@BITRATE]`.
    pub iface: Option<String>,
    /// Baud rate (serial buses; default: the protocol's factory setting).
    pub baud: Option<u32>,
    /// `even`, `odd` or `none` (default: the protocol's).
    pub parity: Option<String>,
    /// 1 or 2.
    pub stop_bits: Option<u8>,
    /// Data bits: Modbus ASCII 7 (default) or 8 (some converters, pseudo-terminals); every
    /// other serial protocol 8.
    pub data_bits: Option<u8>,
    /// CAN bit rate for SBus on slcan or the simulated bus (default 500k).
    pub bitrate: Option<String>,
    /// Response timeout of one attempt (default: the protocol's).
    pub timeout: Option<String>,
    /// Retries after a failed attempt (default 1).
    pub retries: Option<u8>,
    /// How often each drive's fault status is read (default 5 s); any answer also shows the
    /// drive is online.
    pub status_period: Option<String>,
    /// Run this bus against simulated drives even without `--simulate`.
    #[serde(default)]
    pub simulate: bool,
    /// `[[bus.drive]]`.
    #[serde(default, rename = "drive")]
    pub drives: Vec<DriveFile>,
}

/// `[[bus.drive]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveFile {
    /// The drive's name: the fourth level of its topics.
    pub name: String,
    /// Bus address.
    pub address: u8,
    /// `movidrive`, `nord` or `bonfiglioli`: must match the protocol when given.
    pub family: Option<String>,
    /// `[[bus.drive.param]]`.
    #[serde(default, rename = "param")]
    pub params: Vec<ParamFile>,
    /// `[bus.drive.process_data]`.
    pub process_data: Option<ProcessDataFile>,
}

/// `[[bus.drive.param]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamFile {
    /// The parameter as `drivectl` names it (`P130`, `8318`, `P102`, `420`).
    pub param: String,
    /// Topic name (default: the parameter key with `/`, `+`, `#` and spaces replaced).
    pub name: Option<String>,
    /// Poll period; without one the parameter is read only after a write.
    pub period: Option<String>,
    /// May be set through `…/set`.
    #[serde(default)]
    pub writable: bool,
    /// Bonfiglioli data set 0–9 (default 0; 5–9 are the RAM images of 0–4).
    pub data_set: Option<u8>,
    /// NORD array element, 1-based as the manual counts them (`P543 [-02]` is 2).
    pub array: Option<u8>,
    /// NORD parameter set 1–4 (parameters with one value per set).
    pub set: Option<u8>,
    /// Writes go to EEPROM (guarded against wear) instead of RAM.
    #[serde(default)]
    pub eeprom: bool,
}

/// `[bus.drive.process_data]`: the gateway exchanges process data with the drive as its
/// controller (MOVILINK, SBus, USS).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProcessDataFile {
    /// Cycle period.
    pub period: String,
    /// The output words sent every cycle (control word first).
    pub out: Vec<u16>,
}

/// The protocol of a bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Protocol {
    /// SEW MOVILINK over RS-485.
    Movilink,
    /// SEW SBus over CAN.
    Sbus,
    /// NORD USS over RS-485.
    Uss,
    /// Bonfiglioli Modbus RTU.
    ModbusRtu,
    /// Bonfiglioli Modbus ASCII.
    ModbusAscii,
}

impl Protocol {
    /// All protocols, in the order the example config lists them.
    pub const ALL: [Protocol; 5] = [
        Protocol::Movilink,
        Protocol::Sbus,
        Protocol::Uss,
        Protocol::ModbusRtu,
        Protocol::ModbusAscii,
    ];

    /// The name in the config file.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Movilink => "movilink",
            Protocol::Sbus => "sbus",
            Protocol::Uss => "uss",
            Protocol::ModbusRtu => "modbus-rtu",
            Protocol::ModbusAscii => "modbus-ascii",
        }
    }

    /// The drive family this protocol talks to.
    pub fn family(self) -> Family {
        match self {
            Protocol::Movilink | Protocol::Sbus => Family::Movidrive,
            Protocol::Uss => Family::Nord,
            Protocol::ModbusRtu | Protocol::ModbusAscii => Family::Bonfiglioli,
        }
    }

    /// Valid addresses of a drive.
    pub fn addresses(self) -> std::ops::RangeInclusive<u8> {
        match self {
            Protocol::Movilink => 0..=99,
            Protocol::Sbus => 0..=63,
            Protocol::Uss => 0..=31,
            Protocol::ModbusRtu | Protocol::ModbusAscii => 1..=247,
        }
    }

    /// Whether the gateway can exchange process data on this protocol.
    pub fn has_process_data(self) -> bool {
        matches!(self, Protocol::Movilink | Protocol::Sbus | Protocol::Uss)
    }

    /// Default line settings: baud, parity (the drives' factory settings).
    fn default_line(self) -> (u32, Parity) {
        match self {
            Protocol::Movilink => (9600, Parity::Even),
            Protocol::Uss => (9600, Parity::Even),
            Protocol::ModbusRtu | Protocol::ModbusAscii => (9600, Parity::None),
            Protocol::Sbus => (0, Parity::None),
        }
    }

    /// Resolve a `[[bus.drive.param]]` as the family's commands do (`drivectl movilink read
    /// P130`, `drivectl uss read P543 --array 2`, `drivectl bonfiglioli read 420`).
    fn resolve(self, p: &ParamFile) -> Result<Target> {
        let family_only =
            |what: &str, fam: &str| CliError::usage(format!("{what} is for {fam} parameters only"));
        match self.family() {
            Family::Nord => {
                if p.data_set.is_some() {
                    return Err(family_only("data_set", "Bonfiglioli"));
                }
                let sub = crate::nord::Sub {
                    array: p.array,
                    set: p.set,
                };
                let mut all = crate::nord::resolve(&p.param, sub, false)?;
                if all.len() != 1 {
                    return Err(CliError::usage(format!(
                        "{} is an array: give array = K (1-based element)",
                        p.param
                    )));
                }
                all.pop().ok_or_else(|| CliError::usage("no parameter"))
            }
            Family::Bonfiglioli => {
                if p.array.is_some() || p.set.is_some() {
                    return Err(family_only("array and set", "NORD"));
                }
                let ds = p.data_set.unwrap_or(0);
                if ds > 9 {
                    return Err(CliError::usage(format!("data_set = {ds}: give 0–9")));
                }
                crate::bonfiglioli::resolve(&p.param, ds)
            }
            _ => {
                if p.data_set.is_some() || p.array.is_some() || p.set.is_some() {
                    return Err(family_only(
                        "data_set, array and set",
                        "Bonfiglioli or NORD",
                    ));
                }
                crate::movilink::resolve(&p.param)
            }
        }
    }

    fn parse(text: &str) -> Option<Protocol> {
        Protocol::ALL.into_iter().find(|p| p.name() == text.trim())
    }
}

/// Where a bus's frames go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// A serial port with its line settings.
    Serial {
        /// Device path.
        path: String,
        /// Line settings (8 data bits).
        line: drive_core::LineSettings,
    },
    /// A CAN interface (`can0`, `slcan:…`), SBus.
    Can {
        /// The interface as `drivectl sbus --iface` takes it (slcan with its bit rate).
        iface: String,
        /// The bus's bit rate: slcan opens the adapter with it; a SocketCAN interface has its
        /// own (`ip link`), which the config states for the wire times.
        bitrate: u32,
    },
    /// Simulated drives in this process on the wire model (serial: at `line`; CAN: at
    /// `bitrate` bit/s).
    Simulated {
        /// Line settings of the wire model (serial buses).
        line: drive_core::LineSettings,
        /// CAN bit rate (SBus).
        bitrate: u32,
    },
}

/// The checked plant.
#[derive(Debug, Clone)]
pub struct Plant {
    /// Gateway settings.
    pub gateway: Gateway,
    /// Its buses.
    pub buses: Vec<Bus>,
}

/// Checked `[gateway]`.
#[derive(Debug, Clone)]
pub struct Gateway {
    /// Name (topic level 2).
    pub name: String,
    /// Topic prefix (level 1).
    pub prefix: String,
    /// Broker URL as given (`mqtt://` or `mqtts://`).
    pub broker: String,
    /// MQTT client id.
    pub client_id: String,
    /// User name.
    pub username: Option<String>,
    /// Password file.
    pub password_file: Option<String>,
    /// CA file.
    pub ca_file: Option<String>,
    /// Client certificate and key.
    pub client_cert: Option<(String, String)>,
    /// Heartbeat.
    pub heartbeat: Duration,
    /// Oldest `set` executed.
    pub max_set_age: Duration,
    /// Metrics endpoint (`None`: off).
    pub metrics: Option<std::net::SocketAddr>,
    /// Keep-alive.
    pub keep_alive: Duration,
}

/// A checked bus.
#[derive(Debug, Clone)]
pub struct Bus {
    /// Name (topic level 3).
    pub name: String,
    /// Protocol.
    pub protocol: Protocol,
    /// Where the frames go.
    pub endpoint: Endpoint,
    /// Response timeout per attempt.
    pub timeout: Duration,
    /// Retries after a failed attempt.
    pub retries: u8,
    /// How often each drive's fault status is read.
    pub status_period: Duration,
    /// Its drives.
    pub drives: Vec<Drive>,
}

/// A checked drive.
#[derive(Debug, Clone)]
pub struct Drive {
    /// Name (topic level 4).
    pub name: String,
    /// Bus address.
    pub address: u8,
    /// Parameters it publishes or takes.
    pub points: Vec<Point>,
    /// Process data exchanged cyclically.
    pub process_data: Option<ProcessData>,
}

/// One parameter of a drive on the broker.
#[derive(Debug, Clone)]
pub struct Point {
    /// Topic name (level 5).
    pub name: String,
    /// The parameter.
    pub target: Target,
    /// Poll period (`None`: read after writes only).
    pub period: Option<Duration>,
    /// Settable through `…/set`.
    pub writable: bool,
    /// Writes go to EEPROM.
    pub eeprom: bool,
}

/// Process data of a drive.
#[derive(Debug, Clone)]
pub struct ProcessData {
    /// Cycle period.
    pub period: Duration,
    /// Output words.
    pub out: Vec<u16>,
}

/// The largest config file read (a plant of thousands of drives is far below it).
const CONFIG_LIMIT: u64 = 16 << 20;

/// Parse a duration: `250ms`, `5s`, `2m`, `1h`, `500us` (a bare number is refused: the unit
/// is never guessed).
pub fn parse_duration(text: &str) -> Option<Duration> {
    let t = text.trim();
    let split = t.find(|c: char| !c.is_ascii_digit() && c != '.')?;
    let (num, unit) = t.split_at(split);
    let v: f64 = num.parse().ok()?;
    let secs = match unit.trim() {
        "us" | "µs" => v / 1e6,
        "ms" => v / 1e3,
        "s" => v,
        "m" | "min" => v * 60.0,
        "h" => v * 3600.0,
        _ => return None,
    };
    if !secs.is_finite() || !(0.0..=86_400.0 * 365.0).contains(&secs) {
        return None;
    }
    Some(Duration::from_secs_f64(secs))
}

/// Check a broker URL: `mqtt://host[:port]` or `mqtts://[user@]host[:port]` (no password in
/// the URL: it would show in `ps` and in the shell history; use `password_file`).
pub fn check_broker(url: &str) -> std::result::Result<String, String> {
    let url = url.trim();
    let rest = url
        .strip_prefix("mqtt://")
        .or_else(|| url.strip_prefix("mqtts://"))
        .ok_or_else(|| format!("{url:?}: give mqtt://host:port or mqtts://[user@]host:port"))?;
    let host_port = match rest.rsplit_once('@') {
        Some((user, hp)) => {
            if user.contains(':') {
                return Err(format!(
                    "{url:?}: no password in the URL (it shows in `ps` and the shell history); \
                     put it in the file password_file names"
                ));
            }
            hp
        }
        None => rest,
    };
    let host_port = host_port.trim_end_matches('/');
    if host_port.is_empty() || host_port.contains('/') {
        return Err(format!(
            "{url:?}: give mqtt://host:port or mqtts://[user@]host:port"
        ));
    }
    if let Some((_, port)) = host_port.rsplit_once(':')
        && !host_port.ends_with(']')
        && port.parse::<u16>().map_or(true, |p| p == 0)
    {
        return Err(format!("{url:?}: port {port:?}: give 1–65535"));
    }
    Ok(url.to_owned())
}

/// A name usable as one topic level: no `/`, `+`, `#`, no control characters, not empty,
/// at most 64 bytes.
pub fn topic_level_ok(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && !name
            .chars()
            .any(|c| matches!(c, '/' | '+' | '#') || c.is_control() || c.is_whitespace())
}

impl Plant {
    /// Read and check `path` (`-`: standard input).
    pub fn load(path: &str) -> Result<Plant> {
        let bytes =
            crate::tool::infile::read_limited(std::path::Path::new(path), true, CONFIG_LIMIT)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| CliError::usage(format!("{path}: not UTF-8 text")))?;
        // A file saved by Notepad starts with a byte-order mark; TOML does not allow one.
        Self::parse(text.strip_prefix('\u{feff}').unwrap_or(&text), path)
    }

    /// Check the text of a config file; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Plant> {
        let file: File = toml::from_str(text)
            .map_err(|e| CliError::usage(format!("{origin}: {}", e.to_string().trim_end())))?;
        check(file).map_err(|m| CliError::usage(format!("{origin}: {m}")))
    }
}

fn duration(
    what: &str,
    text: Option<&str>,
    default: Duration,
) -> std::result::Result<Duration, String> {
    match text {
        None => Ok(default),
        Some(t) => parse_duration(t).ok_or_else(|| {
            format!("{what} = \"{t}\": give a duration like \"250ms\", \"5s\" or \"2m\"")
        }),
    }
}

fn check(file: File) -> std::result::Result<Plant, String> {
    let g = file.gateway;
    if !topic_level_ok(&g.name) {
        return Err(format!(
            "[gateway] name = {:?}: a topic level needs 1–64 characters without '/', '+', '#' or spaces",
            g.name
        ));
    }
    let prefix = g.prefix.clone().unwrap_or_else(|| "drivebus".to_owned());
    if prefix.split('/').any(|l| !topic_level_ok(l)) {
        return Err(format!(
            "[gateway] prefix = {prefix:?}: topic levels without '+', '#' or spaces"
        ));
    }
    let broker = check_broker(&g.broker).map_err(|e| format!("[gateway] broker: {e}"))?;
    let client_cert = match (g.client_cert, g.client_key) {
        (Some(c), Some(k)) => Some((c, k)),
        (None, None) => None,
        _ => return Err("[gateway] client_cert and client_key go together".to_owned()),
    };
    let metrics = match g.metrics.as_deref().map(str::trim) {
        Some("off") => None,
        None => Some(std::net::SocketAddr::from(([127, 0, 0, 1], 9464))),
        Some(a) => Some(a.parse().map_err(|_| {
            format!(
                "[gateway] metrics = {a:?}: give host:port such as \"127.0.0.1:9464\", or \"off\""
            )
        })?),
    };
    let heartbeat = duration(
        "[gateway] heartbeat",
        g.heartbeat.as_deref(),
        Duration::from_secs(60),
    )?;
    let max_set_age = duration(
        "[gateway] max_set_age",
        g.max_set_age.as_deref(),
        Duration::from_secs(10),
    )?;
    let keep_alive = duration(
        "[gateway] keep_alive",
        g.keep_alive.as_deref(),
        Duration::from_secs(30),
    )?;
    if keep_alive < Duration::from_secs(5) {
        return Err("[gateway] keep_alive: at least 5s".to_owned());
    }
    if heartbeat < Duration::from_secs(1) {
        return Err("[gateway] heartbeat: at least 1s".to_owned());
    }
    let gateway = Gateway {
        client_id: g
            .client_id
            .unwrap_or_else(|| format!("drivebus-{}", g.name)),
        name: g.name,
        prefix,
        broker,
        username: g.username,
        password_file: g.password_file,
        ca_file: g.ca_file,
        client_cert,
        heartbeat,
        max_set_age,
        metrics,
        keep_alive,
    };
    if file.buses.is_empty() {
        return Err("no [[bus]]: a gateway needs at least one bus".to_owned());
    }
    let mut names = HashSet::new();
    let mut buses = Vec::new();
    for b in file.buses {
        let bus = check_bus(b)?;
        if !names.insert(bus.name.clone()) {
            return Err(format!("bus {:?} is named twice", bus.name));
        }
        buses.push(bus);
    }
    let mut ports = HashSet::new();
    for b in &buses {
        let key = match &b.endpoint {
            Endpoint::Serial { path, .. } => crate::tool::client::canonical_port(path),
            Endpoint::Can { iface, .. } => match iface.strip_prefix("slcan:") {
                // The adapter's serial port, as for a serial bus (symlinks resolved).
                Some(rest) => crate::tool::client::canonical_port(
                    rest.rsplit_once('@').map_or(rest, |(path, _)| path),
                ),
                None => iface.clone(),
            },
            Endpoint::Simulated { .. } => continue,
        };
        if !ports.insert(key.clone()) {
            return Err(format!(
                "bus {:?}: {key} is already another bus's: one port, one bus",
                b.name
            ));
        }
    }
    Ok(Plant { gateway, buses })
}

fn check_bus(b: BusFile) -> std::result::Result<Bus, String> {
    let at = format!("bus {:?}", b.name);
    if !topic_level_ok(&b.name) {
        return Err(format!(
            "{at}: a topic level needs 1–64 characters without '/', '+', '#' or spaces"
        ));
    }
    let protocol = Protocol::parse(&b.protocol).ok_or_else(|| {
        format!(
            "{at}: protocol = {:?}: give one of movilink, sbus, uss, modbus-rtu, modbus-ascii",
            b.protocol
        )
    })?;
    let (baud0, parity0) = protocol.default_line();
    let parity = match b.parity.as_deref() {
        None => parity0,
        Some("even") => Parity::Even,
        Some("odd") => Parity::Odd,
        Some("none") => Parity::None,
        Some(p) => return Err(format!("{at}: parity = {p:?}: give even, odd or none")),
    };
    let stop = match b.stop_bits {
        None | Some(1) => StopBits::One,
        Some(2) => StopBits::Two,
        Some(n) => return Err(format!("{at}: stop_bits = {n}: give 1 or 2")),
    };
    let baud = b.baud.unwrap_or(baud0);
    if protocol != Protocol::Sbus && !(1..=4_000_000).contains(&baud) {
        return Err(format!("{at}: baud = {baud}: give 1–4000000"));
    }
    let data_bits = match (protocol, b.data_bits) {
        (Protocol::ModbusAscii, None) => 7,
        (Protocol::ModbusAscii, Some(n @ (7 | 8))) | (_, Some(n @ 8)) => n,
        (_, None) => 8,
        (p, Some(n)) => {
            return Err(format!(
                "{at}: data_bits = {n}: {} uses {}",
                p.name(),
                if p == Protocol::ModbusAscii {
                    "7 or 8"
                } else {
                    "8"
                }
            ));
        }
    };
    let line = drive_core::LineSettings {
        data_bits,
        ..drive_core::LineSettings::new(baud.max(1))
            .with_parity(parity)
            .with_stop_bits(stop)
    };
    let bitrate = match &b.bitrate {
        None => 500_000,
        Some(t) => crate::sbus::iface::parse_bitrate(t)
            .map_err(|e| format!("{at}: {e}"))?
            .bits_per_second(),
    };
    let endpoint = if b.simulate {
        Endpoint::Simulated { line, bitrate }
    } else if protocol == Protocol::Sbus {
        if b.port.is_some() {
            return Err(format!(
                "{at}: SBus runs on a CAN interface: give iface = \"can0\" or \"slcan:/dev/ttyACM0\""
            ));
        }
        let iface = b.iface.ok_or_else(|| {
            format!("{at}: give iface = \"can0\" or \"slcan:PATH\" (or simulate = true)")
        })?;
        let parsed = crate::sbus::iface::Iface::parse(&iface).map_err(|e| format!("{at}: {e}"))?;
        match parsed {
            crate::sbus::iface::Iface::Slcan { bitrate: given, .. } if iface.contains('@') => {
                if b.bitrate.is_some() && given.bits_per_second() != bitrate {
                    return Err(format!(
                        "{at}: iface = {iface:?} and bitrate = {:?} differ: give the bit rate once",
                        b.bitrate.as_deref().unwrap_or_default()
                    ));
                }
                Endpoint::Can {
                    iface,
                    bitrate: given.bits_per_second(),
                }
            }
            // slcan without a rate: the config's (500k by default) is the adapter's.
            crate::sbus::iface::Iface::Slcan { .. } => Endpoint::Can {
                iface: format!("{iface}@{bitrate}"),
                bitrate,
            },
            crate::sbus::iface::Iface::Virtual => {
                return Err(format!(
                    "{at}: iface = \"virtual\": write simulate = true for simulated drives"
                ));
            }
            crate::sbus::iface::Iface::SocketCan(_) => Endpoint::Can { iface, bitrate },
        }
    } else {
        if b.iface.is_some() {
            return Err(format!(
                "{at}: {} runs on a serial port: give port = \"/dev/ttyUSB0\"",
                protocol.name()
            ));
        }
        let path = b
            .port
            .ok_or_else(|| format!("{at}: give port = \"/dev/ttyUSB0\" (or simulate = true)"))?;
        Endpoint::Serial { path, line }
    };
    let timeout = duration(
        &format!("{at}: timeout"),
        b.timeout.as_deref(),
        default_timeout(protocol),
    )?;
    if timeout.is_zero() || timeout > Duration::from_secs(60) {
        return Err(format!("{at}: timeout: give 1ms–60s"));
    }
    // As `drivectl movilink` and `drivectl uss` refuse it: a timeout shorter than the pause a
    // drive keeps before answering lets no answer arrive in time (the drives would flap).
    let before_answer = match protocol {
        Protocol::Movilink => Some(("start pause", movilink::timing::start_pause(&line))),
        Protocol::Uss => Some((
            "start delay",
            ctt2_uss::serial::framing::UssTiming::from_line(&line).start_delay,
        )),
        _ => None,
    };
    if let Some((what, pause)) = before_answer
        && timeout < pause
    {
        return Err(format!(
            "{at}: timeout = {} ms is shorter than the {what} a drive keeps before answering at \
             {} baud ({:.2} ms): no answer could arrive in time; give at least \"{}ms\"",
            timeout.as_millis(),
            line.baud,
            pause.as_secs_f64() * 1e3,
            pause.as_micros().div_ceil(1000)
        ));
    }
    let retries = b.retries.unwrap_or(1);
    if retries > 10 {
        return Err(format!("{at}: retries = {retries}: give 0–10"));
    }
    let status_period = duration(
        &format!("{at}: status_period"),
        b.status_period.as_deref(),
        Duration::from_secs(5),
    )?;
    if status_period < Duration::from_millis(100) {
        return Err(format!("{at}: status_period: at least 100ms"));
    }
    if b.drives.is_empty() {
        return Err(format!("{at}: no [[bus.drive]]"));
    }
    let mut drives = Vec::new();
    let mut addrs = HashSet::new();
    let mut dnames = HashSet::new();
    for d in b.drives {
        let drive = check_drive(&at, protocol, d)?;
        if !addrs.insert(drive.address) {
            return Err(format!("{at}: two drives at address {}", drive.address));
        }
        if !dnames.insert(drive.name.clone()) {
            return Err(format!("{at}: drive {:?} is named twice", drive.name));
        }
        drives.push(drive);
    }
    Ok(Bus {
        name: b.name,
        protocol,
        endpoint,
        timeout,
        retries,
        status_period,
        drives,
    })
}

/// The response timeout a bus gets when the config gives none.
pub fn default_timeout(p: Protocol) -> Duration {
    match p {
        Protocol::Sbus => Duration::from_millis(50),
        _ => Duration::from_millis(100),
    }
}

fn check_drive(bus: &str, protocol: Protocol, d: DriveFile) -> std::result::Result<Drive, String> {
    let at = format!("{bus}, drive {:?}", d.name);
    if !topic_level_ok(&d.name) {
        return Err(format!(
            "{at}: a topic level needs 1–64 characters without '/', '+', '#' or spaces"
        ));
    }
    let family = protocol.family();
    if let Some(f) = &d.family
        && !f.eq_ignore_ascii_case(&family.to_string())
    {
        return Err(format!(
            "{at}: family = {f:?}, but {} talks to {family} drives",
            protocol.name()
        ));
    }
    let r = protocol.addresses();
    if !r.contains(&d.address) {
        return Err(format!(
            "{at}: address = {}: {} drives have addresses {}–{}",
            d.address,
            protocol.name(),
            r.start(),
            r.end()
        ));
    }
    let mut points = Vec::new();
    let mut names = HashSet::new();
    for p in d.params {
        let target = protocol.resolve(&p).map_err(|e| format!("{at}: {e}"))?;
        let name = p.name.clone().unwrap_or_else(|| {
            p.param
                .trim()
                .chars()
                .map(|c| {
                    if topic_level_ok(&c.to_string()) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        });
        if !topic_level_ok(&name) || matches!(name.as_str(), "status" | "pd" | "set" | "result") {
            return Err(format!(
                "{at}: parameter name {name:?}: one topic level, not status, pd, set or result"
            ));
        }
        if !names.insert(name.clone()) {
            return Err(format!("{at}: {name:?} is listed twice"));
        }
        let period = match &p.period {
            None => None,
            Some(t) => {
                let v = parse_duration(t).ok_or_else(|| {
                    format!(
                        "{at}, {name}: period = {t:?}: give a duration like \"500ms\" or \"5s\""
                    )
                })?;
                if v < Duration::from_millis(1) {
                    return Err(format!("{at}, {name}: period: at least 1ms"));
                }
                Some(v)
            }
        };
        if period.is_none() && !p.writable {
            return Err(format!(
                "{at}, {name}: neither polled (period) nor writable: nothing to do"
            ));
        }
        points.push(Point {
            name,
            target,
            period,
            writable: p.writable,
            eeprom: p.eeprom,
        });
    }
    let process_data = match d.process_data {
        None => None,
        Some(pd) => {
            if !protocol.has_process_data() {
                return Err(format!(
                    "{at}: {} has no process data; poll parameters instead",
                    protocol.name()
                ));
            }
            let period = parse_duration(&pd.period)
                .filter(|p| *p >= Duration::from_millis(1))
                .ok_or_else(|| {
                    format!(
                        "{at}: process_data period = {:?}: give 1ms or more",
                        pd.period
                    )
                })?;
            let max = match protocol {
                Protocol::Uss => 16,
                _ => 3,
            };
            if pd.out.is_empty() || pd.out.len() > max {
                return Err(format!("{at}: process_data out: 1–{max} words"));
            }
            Some(ProcessData {
                period,
                out: pd.out,
            })
        }
    };
    if points.is_empty() && process_data.is_none() {
        return Err(format!("{at}: no [[bus.drive.param]] and no process data"));
    }
    Ok(Drive {
        name: d.name,
        address: d.address,
        points,
        process_data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[gateway]
name = "gw1"
broker = "mqtt://127.0.0.1:1883"

[[bus]]
name = "line1"
protocol = "movilink"
port = "/dev/ttyUSB0"

[[bus.drive]]
name = "conveyor"
address = 1

[[bus.drive.param]]
param = "P130"
period = "1s"
writable = true
"#;

    fn err(text: &str) -> String {
        match Plant::parse(text, "plant.toml") {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    fn with(replace: &str, by: &str) -> String {
        assert!(MINIMAL.contains(replace), "{replace}");
        MINIMAL.replace(replace, by)
    }

    #[test]
    fn a_minimal_config_gets_the_documented_defaults() {
        let p = Plant::parse(MINIMAL, "plant.toml").unwrap();
        assert_eq!(p.gateway.prefix, "drivebus");
        assert_eq!(p.gateway.client_id, "drivebus-gw1");
        assert_eq!(p.gateway.heartbeat, Duration::from_secs(60));
        assert_eq!(p.gateway.max_set_age, Duration::from_secs(10));
        assert_eq!(p.gateway.metrics, Some("127.0.0.1:9464".parse().unwrap()));
        let b = &p.buses[0];
        assert_eq!(b.protocol, Protocol::Movilink);
        assert_eq!(b.timeout, Duration::from_millis(100));
        assert_eq!(b.retries, 1);
        assert_eq!(b.status_period, Duration::from_secs(5));
        match &b.endpoint {
            Endpoint::Serial { path, line } => {
                assert_eq!(path, "/dev/ttyUSB0");
                assert_eq!(line.baud, 9600);
                assert_eq!(line.parity, Parity::Even);
            }
            other => panic!("{other:?}"),
        }
        let d = &b.drives[0];
        assert_eq!(d.points[0].target.family, Family::Movidrive);
        let pt = &d.points[0];
        assert_eq!(pt.name, "P130");
        assert_eq!(pt.target.index, 8470, "P130 ramp t11 up CW is index 8470");
        assert_eq!(pt.period, Some(Duration::from_secs(1)));
        assert!(pt.writable && !pt.eeprom);
    }

    #[test]
    fn durations_need_a_unit() {
        assert_eq!(parse_duration("250ms"), Some(Duration::from_millis(250)));
        assert_eq!(parse_duration(" 5s "), Some(Duration::from_secs(5)));
        assert_eq!(parse_duration("1.5s"), Some(Duration::from_millis(1500)));
        assert_eq!(parse_duration("2m"), Some(Duration::from_secs(120)));
        assert_eq!(parse_duration("500us"), Some(Duration::from_micros(500)));
        for bad in ["5", "", "s", "-1s", "1e400s", "5 parsecs", "NaNs", "1.2.3s"] {
            assert_eq!(parse_duration(bad), None, "{bad}");
        }
    }

    #[test]
    fn every_mistake_is_named_with_what_to_write() {
        let cases = [
            (with("name = \"gw1\"", "name = \"gw/1\""), "topic level"),
            (
                with("mqtt://127.0.0.1:1883", "http://x"),
                "mqtt://host:port",
            ),
            (
                with("mqtt://127.0.0.1:1883", "mqtt://u:secret@h:1883"),
                "no password in the URL",
            ),
            (with("mqtt://127.0.0.1:1883", "mqtt://h:99999"), "1–65535"),
            (
                with("protocol = \"movilink\"", "protocol = \"profibus\""),
                "movilink, sbus",
            ),
            (with("address = 1", "address = 100"), "addresses 0–99"),
            (with("period = \"1s\"", "period = \"1\""), "give a duration"),
            (
                with(
                    "port = \"/dev/ttyUSB0\"",
                    "port = \"/dev/ttyUSB0\"\ntimeout = \"1ms\"",
                ),
                "shorter than the start pause",
            ),
            (
                with(
                    "port = \"/dev/ttyUSB0\"",
                    "port = \"/dev/ttyUSB0\"\nbaud = 300\ntimeout = \"20ms\"",
                ),
                "at 300 baud",
            ),
            (
                with("param = \"P130\"", "param = \"P9999\""),
                "no movidrive parameter",
            ),
            (
                with("writable = true", "writable = false\nperiod2 = 1"),
                "unknown field",
            ),
            (
                with("port = \"/dev/ttyUSB0\"", "iface = \"can0\""),
                "serial port",
            ),
            (
                with(
                    "[[bus.drive.param]]",
                    "[bus.drive.process_data]\nperiod = \"20ms\"\nout = [1,2,3,4]\n[[bus.drive.param]]",
                ),
                "1–3 words",
            ),
        ];
        for (text, needle) in cases {
            let e = err(&text);
            assert!(e.starts_with("plant.toml: "), "{e}");
            assert!(e.contains(needle), "`{needle}` not in: {e}");
        }
    }

    #[test]
    fn two_buses_on_one_port_are_refused_also_through_a_symlink() {
        let dir = std::env::temp_dir().join(format!("gwcfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let real = dir.join("ttyREAL");
        std::fs::write(&real, "").unwrap();
        let link = dir.join("ttyLINK");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let second = MINIMAL
            .split("[[bus]]")
            .nth(1)
            .unwrap()
            .replace("line1", "line2")
            .replace("/dev/ttyUSB0", link.to_str().unwrap());
        let text = format!(
            "{}\n[[bus]]{second}",
            MINIMAL.replace("/dev/ttyUSB0", real.to_str().unwrap())
        );
        let e = err(&text);
        assert!(e.contains("one port, one bus"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_can_bus_has_one_bit_rate() {
        let sbus = |iface: &str, extra: &str| {
            MINIMAL
                .replace("protocol = \"movilink\"", "protocol = \"sbus\"")
                .replace(
                    "port = \"/dev/ttyUSB0\"",
                    &format!("iface = \"{iface}\"\n{extra}"),
                )
        };
        let rate = |text: String| match Plant::parse(&text, "p").unwrap().buses[0].endpoint.clone()
        {
            Endpoint::Can { iface, bitrate } => (iface, bitrate),
            other => panic!("{other:?}"),
        };
        assert_eq!(rate(sbus("can0", "")), ("can0".into(), 500_000));
        assert_eq!(
            rate(sbus("can0", "bitrate = \"250k\"")),
            ("can0".into(), 250_000)
        );
        // slcan: the adapter is opened at the config's rate.
        assert_eq!(
            rate(sbus("slcan:/dev/ttyACM0", "bitrate = \"125k\"")),
            ("slcan:/dev/ttyACM0@125000".into(), 125_000)
        );
        assert_eq!(
            rate(sbus("slcan:/dev/ttyACM0@1M", "")),
            ("slcan:/dev/ttyACM0@1M".into(), 1_000_000)
        );
        assert!(
            err(&sbus("slcan:/dev/ttyACM0@1M", "bitrate = \"500k\""))
                .contains("give the bit rate once")
        );
        assert!(err(&sbus("virtual", "")).contains("simulate = true"));
        // Two buses on one slcan adapter, once with its rate.
        let two = format!(
            "{}\n[[bus]]{}",
            sbus("slcan:/dev/ttyACM0", ""),
            sbus("slcan:/dev/ttyACM0@500k", "")
                .split("[[bus]]")
                .nth(1)
                .unwrap()
                .replace("line1", "line2")
        );
        assert!(err(&two).contains("one port, one bus"), "{}", err(&two));
    }

    #[test]
    fn duplicates_are_refused() {
        let two_drives = MINIMAL.replace(
            "[[bus.drive]]",
            "[[bus.drive]]\nname = \"other\"\naddress = 1\n[[bus.drive.param]]\nparam = \"P000\"\nperiod = \"1s\"\n\n[[bus.drive]]",
        );
        assert!(err(&two_drives).contains("two drives at address 1"));
        let two_points =
            format!("{MINIMAL}\n[[bus.drive.param]]\nparam = \"P130\"\nperiod = \"2s\"\n");
        assert!(err(&two_points).contains("listed twice"));
        let reserved = with("period = \"1s\"", "period = \"1s\"\nname = \"status\"");
        assert!(err(&reserved).contains("not status"));
    }

    #[test]
    fn a_notepad_file_with_bom_and_crlf_loads() {
        let dir = std::env::temp_dir().join(format!("gwcfg-bom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("plant.toml");
        std::fs::write(&f, format!("\u{feff}{}", MINIMAL.replace('\n', "\r\n"))).unwrap();
        let p = Plant::load(f.to_str().unwrap()).unwrap();
        assert_eq!(p.buses[0].drives[0].points[0].name, "P130");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_device_node_is_not_read_as_a_config() {
        let e = Plant::load("/dev/zero").unwrap_err().to_string();
        assert!(e.contains("device node"), "{e}");
    }

    #[test]
    fn family_specific_keys_follow_the_protocol() {
        let nord = MINIMAL
            .replace("\"movilink\"", "\"uss\"")
            .replace("P130", "P102")
            .replace("writable = true", "writable = true\nset = 2");
        let p = Plant::parse(&nord, "p").unwrap();
        assert_eq!(p.buses[0].drives[0].points[0].target.family, Family::Nord);
        let bonf = MINIMAL
            .replace("\"movilink\"", "\"modbus-rtu\"")
            .replace("P130", "420")
            .replace("writable = true", "writable = true\ndata_set = 7");
        let p = Plant::parse(&bonf, "p").unwrap();
        assert_eq!(p.buses[0].drives[0].points[0].target.sub, 7);
        let wrong = MINIMAL.replace("writable = true", "writable = true\ndata_set = 1");
        assert!(err(&wrong).contains("for Bonfiglioli or NORD parameters only"));
        let fam = MINIMAL.replace("address = 1", "address = 1\nfamily = \"nord\"");
        assert!(err(&fam).contains("movilink talks to"));
    }
}
