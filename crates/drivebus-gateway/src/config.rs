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
use toml::Spanned;

use crate::error::{Error, Result};
use drive_client::infile::InputError;
use drive_client::target::Target;
use drive_transport::can::{Iface, IfaceError};

mod point;

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct File {
    /// `[gateway]`.
    pub gateway: Spanned<GatewayFile>,
    /// `[[bus]]`.
    #[serde(default, rename = "bus")]
    pub buses: Vec<Spanned<BusFile>>,
    /// `[ui]`: the browser page.
    pub ui: Option<Spanned<UiFile>>,
    /// `[sparkplug]`: the plant as a Sparkplug B edge node.
    pub sparkplug: Option<Spanned<SparkplugFile>>,
}

/// `[sparkplug]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SparkplugFile {
    /// The Sparkplug group (topic level 2).
    pub group_id: String,
    /// The gateway's edge node id (topic level 4).
    pub edge_node_id: String,
    /// A primary host application: no NBIRTH until its STATE says online.
    pub primary_host_id: Option<String>,
    /// The JSON topics beside Sparkplug (default true).
    pub json: Option<bool>,
    /// MQTT client id of the Sparkplug connection (default: the gateway's with `-spb`).
    pub client_id: Option<String>,
}

/// `[ui]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UiFile {
    /// Where the page is served, `host:port`.
    pub listen: String,
    /// PEM file of the page's certificate chain (TLS; with `tls_key`).
    pub tls_cert: Option<String>,
    /// PEM file of the certificate's private key.
    pub tls_key: Option<String>,
    /// The page's password file (`name:role:argon2id-hash` lines, `drivectl ui passwd`).
    pub users: Option<String>,
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
    /// `movilink`, `sbus`, `uss`, `ctt2` (simulated only), `modbus-rtu` or `modbus-ascii`.
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
    /// Serial buses: the adapter echoes what it sends (two-wire RS-485 converters); each frame
    /// is read back, compared and discarded, an echo that differs is a collision.
    #[serde(default)]
    pub echo: bool,
    /// Serial buses: Linux kernel RS-485 mode (RTS switches the transceiver).
    #[serde(default)]
    pub rs485: bool,
    /// RS-485 mode: RTS level while sending, `high` (default) or `low`.
    pub rs485_rts: Option<String>,
    /// RS-485 mode: delay between RTS on and the first bit (default 0 ms, at most 100 ms).
    pub rs485_delay_before: Option<String>,
    /// RS-485 mode: delay between the last bit and RTS off (default 0 ms, at most 100 ms).
    pub rs485_delay_after: Option<String>,
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
    pub drives: Vec<Spanned<DriveFile>>,
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
    /// Bonfiglioli: `act` (ACTIVE) or `acu` (ACTIVE Cube), for the status word 411's meaning
    /// (its bits differ); without it 411 is decoded for what both share.
    pub variant: Option<String>,
    /// `[[bus.drive.param]]`.
    #[serde(default, rename = "param")]
    pub params: Vec<Spanned<ParamFile>>,
    /// `[bus.drive.process_data]`.
    pub process_data: Option<Spanned<ProcessDataFile>>,
}

/// `[[bus.drive.param]]` (every key with its place in the file, for the messages).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamFile {
    /// The parameter as `drivectl` names it (`P130`, `8318`, `P102`, `420`).
    pub param: Spanned<String>,
    /// Topic name (default: the parameter key with `/`, `+`, `#` and spaces replaced).
    pub name: Option<Spanned<String>>,
    /// Poll period; without one the parameter is read only after a write.
    pub period: Option<Spanned<String>>,
    /// May be set through `…/set`.
    pub writable: Option<Spanned<bool>>,
    /// Bonfiglioli data set 0–9 (default 0; 5–9 are the RAM images of 0–4); only those the
    /// parameter has.
    pub data_set: Option<Spanned<u8>>,
    /// NORD array element, 1-based as the manual counts them (`P543 [-02]` is 2); required for
    /// an array, refused for a parameter that is none.
    pub array: Option<Spanned<u8>>,
    /// NORD parameter set 1–4 (parameters with one value per set; default 1).
    pub set: Option<Spanned<u8>>,
    /// Bonfiglioli: the bus width in bits, 16 (FC 3/6) or 32 (FC 100/101), for a parameter
    /// the manual gives no data type.
    pub width: Option<Spanned<u8>>,
    /// Writes go to EEPROM (guarded against wear) instead of RAM.
    pub eeprom: Option<Spanned<bool>>,
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
    /// The browser page may enable and stop the drive with a setpoint (`docs/ui.md`).
    #[serde(default)]
    pub page_control: bool,
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
    /// NORD CTT2 over AS-Interface, on the simulated AS-i link only (drivebus has no real AS-i
    /// master); a drive's address is its double slave's number 1–31 (`5`: 5A with 5B).
    Ctt2,
    /// Bonfiglioli Modbus RTU.
    ModbusRtu,
    /// Bonfiglioli Modbus ASCII.
    ModbusAscii,
}

impl Protocol {
    /// All protocols, in the order the example config lists them.
    pub const ALL: [Protocol; 6] = [
        Protocol::Movilink,
        Protocol::Sbus,
        Protocol::Uss,
        Protocol::Ctt2,
        Protocol::ModbusRtu,
        Protocol::ModbusAscii,
    ];

    /// The name in the config file.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Movilink => "movilink",
            Protocol::Sbus => "sbus",
            Protocol::Uss => "uss",
            Protocol::Ctt2 => "ctt2",
            Protocol::ModbusRtu => "modbus-rtu",
            Protocol::ModbusAscii => "modbus-ascii",
        }
    }

    /// The drive family this protocol talks to.
    pub fn family(self) -> Family {
        match self {
            Protocol::Movilink | Protocol::Sbus => Family::Movidrive,
            Protocol::Uss | Protocol::Ctt2 => Family::Nord,
            Protocol::ModbusRtu | Protocol::ModbusAscii => Family::Bonfiglioli,
        }
    }

    /// Valid addresses of a drive.
    pub fn addresses(self) -> std::ops::RangeInclusive<u8> {
        match self {
            Protocol::Movilink => 0..=99,
            Protocol::Sbus => 0..=63,
            Protocol::Uss => 0..=31,
            // The double slave's number: 1A…31A (its 2nd slave the same number in bank B);
            // AS-i address 0 exchanges no data.
            Protocol::Ctt2 => 1..=31,
            Protocol::ModbusRtu | Protocol::ModbusAscii => 1..=247,
        }
    }

    /// Whether the gateway can exchange process data on this protocol.
    pub fn has_process_data(self) -> bool {
        matches!(
            self,
            Protocol::Movilink | Protocol::Sbus | Protocol::Uss | Protocol::Ctt2
        )
    }

    /// Default line settings: baud, parity (the drives' factory settings).
    fn default_line(self) -> (u32, Parity) {
        match self {
            Protocol::Movilink => (9600, Parity::Even),
            Protocol::Uss => (9600, Parity::Even),
            // No serial line: the AS-i network's size sets the CTT2 byte time.
            Protocol::Sbus | Protocol::Ctt2 => (0, Parity::None),
            Protocol::ModbusRtu | Protocol::ModbusAscii => (9600, Parity::None),
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
        /// How the adapter drives the line.
        adapter: Adapter,
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
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    /// Gateway settings.
    pub gateway: Gateway,
    /// Its buses.
    pub buses: Vec<Bus>,
    /// The browser page, when `[ui]` asks for it.
    pub ui: Option<Ui>,
    /// The Sparkplug B edge node, when `[sparkplug]` asks for it.
    pub sparkplug: Option<Sparkplug>,
}

/// Checked `[sparkplug]` (`docs/sparkplug.md`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sparkplug {
    /// Group id.
    pub group_id: String,
    /// Edge node id.
    pub edge_node_id: String,
    /// Primary host id.
    pub primary_host_id: Option<String>,
    /// The JSON topics are published too.
    pub json: bool,
    /// MQTT client id of the Sparkplug connection.
    pub client_id: String,
}

/// Checked `[ui]`. The files are named here and read at the start (`ui::auth::Security`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ui {
    /// Where the page is served (any address other than loopback only with `tls` and `users`).
    pub listen: std::net::SocketAddr,
    /// The certificate chain's and the key's PEM files: the page is served over HTTPS.
    pub tls: Option<UiTls>,
    /// The password file: the page asks for a user and a password.
    pub users: Option<String>,
}

/// `[ui] tls_cert` and `tls_key`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UiTls {
    /// The certificate chain (PEM), the server's certificate first.
    pub cert: String,
    /// Its private key (PEM).
    pub key: String,
}

impl Gateway {
    /// Whether the gateway publishes on a broker (`broker = "off"`: the page only).
    pub fn uses_broker(&self) -> bool {
        self.broker != BROKER_OFF
    }
}

impl Plant {
    /// Whether the JSON topics are published (a broker, and `[sparkplug] json` not false).
    pub fn publishes_json(&self) -> bool {
        self.gateway.uses_broker() && self.sparkplug.as_ref().is_none_or(|s| s.json)
    }
}

/// `broker = "off"`: no MQTT, the values only on the page.
pub const BROKER_OFF: &str = "off";

/// Check `[ui] listen` alone (no TLS, no users): a loopback `host:port`.
pub fn check_ui(listen: &str) -> std::result::Result<Ui, String> {
    check_ui_file(UiFile {
        listen: listen.to_owned(),
        tls_cert: None,
        tls_key: None,
        users: None,
    })
}

/// Whether `ip` is a loopback address (127.0.0.0/8, `::1`, or `::ffff:127.x.y.z`).
fn loopback(ip: std::net::IpAddr) -> bool {
    match ip {
        std::net::IpAddr::V6(v6) => v6
            .to_ipv4_mapped()
            .map_or(v6.is_loopback(), |v4| v4.is_loopback()),
        v4 => v4.is_loopback(),
    }
}

/// Check `[ui]`: `listen` is a `host:port`; a page that can move motors is served to hosts other
/// than this one only over TLS and with users (both), never in the clear or to anyone.
pub fn check_ui_file(u: UiFile) -> std::result::Result<Ui, String> {
    let text = u.listen.trim();
    let addr: std::net::SocketAddr = text.parse().map_err(|_| {
        format!("[ui] listen = {text:?}: give host:port such as \"127.0.0.1:8080\"")
    })?;
    let nonempty = |key: &str, v: Option<String>| match v {
        Some(p) if p.trim().is_empty() => Err(format!("[ui] {key} = \"\": give a file's path")),
        other => Ok(other),
    };
    let tls = match (
        nonempty("tls_cert", u.tls_cert)?,
        nonempty("tls_key", u.tls_key)?,
    ) {
        (Some(cert), Some(key)) => Some(UiTls { cert, key }),
        (None, None) => None,
        (Some(_), None) => {
            return Err(
                "[ui] tls_cert needs tls_key (the certificate's private key, PEM)".to_owned(),
            );
        }
        (None, Some(_)) => {
            return Err("[ui] tls_key needs tls_cert (the certificate chain, PEM)".to_owned());
        }
    };
    let users = nonempty("users", u.users)?;
    if !loopback(addr.ip()) && (tls.is_none() || users.is_none()) {
        let missing = match (&tls, &users) {
            (None, None) => {
                "tls_cert = \"/etc/drivebus/page.crt\", tls_key = \"/etc/drivebus/page.key\" and users = \"/etc/drivebus/page.users\""
            }
            (None, Some(_)) => {
                "tls_cert = \"/etc/drivebus/page.crt\" and tls_key = \"/etc/drivebus/page.key\""
            }
            _ => "users = \"/etc/drivebus/page.users\"",
        };
        return Err(format!(
            "[ui] listen = {text:?}: a page that is not on a loopback address (127.0.0.1 or \
             [::1]) needs TLS and users: add {missing} to [ui] (the users file is made with \
             `drivectl ui passwd --file FILE --user NAME --role operator`), or listen on \
             127.0.0.1"
        ));
    }
    Ok(Ui {
        listen: addr,
        tls,
        users,
    })
}

/// Checked `[gateway]`.
#[derive(Debug, Clone, PartialEq)]
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
#[derive(Debug, Clone, PartialEq)]
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
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    /// Name (topic level 4).
    pub name: String,
    /// Bus address.
    pub address: u8,
    /// Parameters it publishes or takes.
    pub points: Vec<Point>,
    /// Process data exchanged cyclically.
    pub process_data: Option<ProcessData>,
    /// What is known of the drive for the meaning of its values (a Bonfiglioli variant).
    pub device: drive_client::meaning::Device,
}

/// One parameter of a drive on the broker.
#[derive(Debug, Clone, PartialEq)]
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
    /// Bonfiglioli: the bus width the config gives for a parameter the manual gives no data
    /// type (`width = 16 | 32`); `None` where the table's data type is used.
    pub width: Option<bonfiglioli_modbus::slave::Width>,
}

/// Process data of a drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessData {
    /// Cycle period.
    pub period: Duration,
    /// Output words.
    pub out: Vec<u16>,
    /// The browser page may enable and stop the drive with a setpoint: while a page drives it,
    /// the family's control and setpoint words replace `out`.
    pub page_control: bool,
}

/// The largest config file read (a plant of thousands of drives is far below it).
const CONFIG_LIMIT: u64 = 16 << 20;

/// How a serial bus's adapter drives the line (`echo`, `rs485…` keys).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Adapter {
    /// The adapter echoes what it sends: the echo is taken out (`drive_core::rt::echo`).
    pub echo: bool,
    /// Kernel RS-485 mode, if asked for.
    pub rs485: Option<drive_transport::serial::Rs485Config>,
}

/// The adapter keys of bus `b` (at `at` for messages): RS-485 settings only with `rs485 =
/// true`, delays within 100 ms.
fn adapter_of(b: &BusFile, at: &str) -> std::result::Result<Adapter, String> {
    let given =
        b.rs485_rts.is_some() || b.rs485_delay_before.is_some() || b.rs485_delay_after.is_some();
    if given && !b.rs485 {
        return Err(format!(
            "{at}: rs485_rts and rs485_delay_* apply in RS-485 mode: add rs485 = true (or leave              them out)"
        ));
    }
    let delay = |key: &str, text: &Option<String>| -> std::result::Result<u32, String> {
        let d = duration(&format!("{at}: {key}"), text.as_deref(), Duration::ZERO)?;
        let max = drive_transport::serial::Rs485Config::MAX_DELAY_MS;
        let ms = d.as_millis();
        if d != Duration::from_millis(u64::try_from(ms).unwrap_or(u64::MAX)) || ms > u128::from(max)
        {
            return Err(format!(
                "{at}: {key} = {:?}: give whole milliseconds, 0ms to {max}ms",
                text.as_deref().unwrap_or_default()
            ));
        }
        Ok(u32::try_from(ms).unwrap_or(max))
    };
    let rs485 = if b.rs485 {
        let rts_high = match b.rs485_rts.as_deref() {
            None | Some("high") => true,
            Some("low") => false,
            Some(other) => {
                return Err(format!(
                    "{at}: rs485_rts = {other:?}: give \"high\" (RTS high while sending, most                      transceivers) or \"low\""
                ));
            }
        };
        Some(drive_transport::serial::Rs485Config::with_rts(
            rts_high,
            delay("rs485_delay_before", &b.rs485_delay_before)?,
            delay("rs485_delay_after", &b.rs485_delay_after)?,
        ))
    } else {
        None
    };
    Ok(Adapter {
        echo: b.echo,
        rs485,
    })
}

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
            drive_client::infile::read_limited(std::path::Path::new(path), true, CONFIG_LIMIT)
                .map_err(|e| match e {
                    InputError::NotAFile { .. } => Error::config(format!("{e}; give a file")),
                    InputError::TooLarge { .. } => {
                        Error::config(format!("{e}: not a config file; check the path"))
                    }
                    InputError::Open { .. } => Error::failed(format!(
                        "{e}; check the path and that it is a readable file"
                    )),
                    e => Error::failed(e.to_string()),
                })?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::config(format!("{path}: not UTF-8 text")))?;
        // A file saved by Notepad starts with a byte-order mark; TOML does not allow one.
        Self::parse(text.strip_prefix('\u{feff}').unwrap_or(&text), path)
    }

    /// Check the text of a config file; `origin` names it in errors (with the line:
    /// `plant.toml:14: bus "line1" drive "pump" point "ramp": set = 5: …`).
    pub fn parse(text: &str, origin: &str) -> Result<Plant> {
        let file: File = toml::from_str(text).map_err(|e: toml::de::Error| {
            Error::config(match e.span() {
                Some(at) => format!(
                    "{origin}:{}: {}",
                    line_of(text, at.start),
                    e.message().trim_end()
                ),
                None => format!("{origin}: {}", e.to_string().trim_end()),
            })
        })?;
        check(file).map_err(|f| {
            Error::config(match f.at {
                Some(at) => format!("{origin}:{}: {}", line_of(text, at), f.message),
                None => format!("{origin}: {}", f.message),
            })
        })
    }
}

/// A mistake in the config: where it is (a byte offset into the file) and what to write.
#[derive(Debug)]
struct Fault {
    at: Option<usize>,
    message: String,
}

impl Fault {
    fn new(at: usize, message: String) -> Self {
        Fault {
            at: Some(at),
            message,
        }
    }

    fn nowhere(message: String) -> Self {
        Fault { at: None, message }
    }
}

/// The 1-based line of byte `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.get(..at)
        .unwrap_or(text)
        .bytes()
        .filter(|b| *b == b'\n')
        .count()
        + 1
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

fn check(file: File) -> std::result::Result<Plant, Fault> {
    let gateway_at = file.gateway.span().start;
    let gateway =
        check_gateway(file.gateway.into_inner()).map_err(|m| Fault::new(gateway_at, m))?;
    if file.buses.is_empty() {
        return Err(Fault::nowhere(
            "no [[bus]]: a gateway needs at least one bus".to_owned(),
        ));
    }
    let mut names = HashSet::new();
    let mut buses = Vec::new();
    let mut places = Vec::new();
    for b in file.buses {
        let at = b.span().start;
        let bus = check_bus(at, b.into_inner())?;
        if !names.insert(bus.name.clone()) {
            return Err(Fault::new(at, format!("bus {:?} is named twice", bus.name)));
        }
        buses.push(bus);
        places.push(at);
    }
    let mut ports = HashSet::new();
    for (b, at) in buses.iter().zip(places) {
        let key = match &b.endpoint {
            Endpoint::Serial { path, .. } => drive_client::text::canonical_port(path),
            Endpoint::Can { iface, .. } => match iface.strip_prefix("slcan:") {
                // The adapter's serial port, as for a serial bus (symlinks resolved).
                Some(rest) => drive_client::text::canonical_port(
                    rest.rsplit_once('@').map_or(rest, |(path, _)| path),
                ),
                None => iface.clone(),
            },
            Endpoint::Simulated { .. } => continue,
        };
        if !ports.insert(key.clone()) {
            return Err(Fault::new(
                at,
                format!(
                    "bus {:?}: {key} is already another bus's: one port, one bus",
                    b.name
                ),
            ));
        }
    }
    let ui = match file.ui {
        Some(u) => {
            let at = u.span().start;
            Some(check_ui_file(u.into_inner()).map_err(|m| Fault::new(at, m))?)
        }
        None => None,
    };
    if !gateway.uses_broker() && ui.is_none() {
        return Err(Fault::new(
            gateway_at,
            "[gateway] broker = \"off\" needs a [ui] with listen = \"127.0.0.1:PORT\": \
             without a broker only the page shows the drives"
                .to_owned(),
        ));
    }
    let sparkplug = match file.sparkplug {
        Some(s) => {
            let at = s.span().start;
            let s = check_sparkplug(s.into_inner(), &gateway).map_err(|m| Fault::new(at, m))?;
            // The drive's config name is its device id: one node, one device of a name.
            let mut seen: std::collections::HashMap<&str, &str> = std::collections::HashMap::new();
            for b in &buses {
                for d in &b.drives {
                    if let Some(other) = seen.insert(&d.name, &b.name) {
                        return Err(Fault::new(
                            at,
                            format!(
                                "[sparkplug]: drive {:?} is on bus {other:?} and on bus {:?}; a \
                                 drive's name is its Sparkplug device id, unique in the node: \
                                 rename one",
                                d.name, b.name
                            ),
                        ));
                    }
                }
            }
            Some(s)
        }
        None => None,
    };
    Ok(Plant {
        gateway,
        buses,
        ui,
        sparkplug,
    })
}

/// Check `[sparkplug]`: ids usable as Sparkplug topic levels, a broker to publish on.
fn check_sparkplug(s: SparkplugFile, g: &Gateway) -> std::result::Result<Sparkplug, String> {
    if !g.uses_broker() {
        return Err(
            "[sparkplug] needs a broker: [gateway] broker = \"off\" publishes nothing".to_owned(),
        );
    }
    for (key, id) in [
        ("group_id", Some(&s.group_id)),
        ("edge_node_id", Some(&s.edge_node_id)),
        ("primary_host_id", s.primary_host_id.as_ref()),
    ] {
        if let Some(id) = id
            && !topic_level_ok(id)
        {
            return Err(format!(
                "[sparkplug] {key} = {id:?}: a Sparkplug id is one topic level of 1–64 \
                 characters without '/', '+', '#' or spaces"
            ));
        }
    }
    let client_id = s
        .client_id
        .unwrap_or_else(|| format!("{}-spb", g.client_id));
    if client_id == g.client_id && s.json != Some(false) {
        return Err(format!(
            "[sparkplug] client_id = {client_id:?} is the JSON connection's: each connection \
             needs its own (the broker drops the older of two with one id)"
        ));
    }
    Ok(Sparkplug {
        group_id: s.group_id,
        edge_node_id: s.edge_node_id,
        primary_host_id: s.primary_host_id,
        json: s.json.unwrap_or(true),
        client_id,
    })
}

fn check_gateway(g: GatewayFile) -> std::result::Result<Gateway, String> {
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
    let broker = if g.broker.trim() == BROKER_OFF {
        BROKER_OFF.to_owned()
    } else {
        check_broker(&g.broker).map_err(|e| format!("[gateway] broker: {e}"))?
    };
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
    Ok(Gateway {
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
    })
}

fn check_bus(place: usize, b: BusFile) -> std::result::Result<Bus, Fault> {
    let at = format!("bus {:?}", b.name);
    let drives = b.drives;
    let b = BusFile {
        drives: Vec::new(),
        ..b
    };
    let mut bus = check_line(&at, b).map_err(|m| Fault::new(place, m))?;
    let mut addrs = HashSet::new();
    let mut dnames = HashSet::new();
    for d in drives {
        let d_at = d.span().start;
        let drive = check_drive(&at, bus.protocol, d_at, d.into_inner())?;
        if !addrs.insert(drive.address) {
            return Err(Fault::new(
                d_at,
                format!("{at}: two drives at address {}", drive.address),
            ));
        }
        if !dnames.insert(drive.name.clone()) {
            return Err(Fault::new(
                d_at,
                format!("{at}: drive {:?} is named twice", drive.name),
            ));
        }
        bus.drives.push(drive);
    }
    if bus.drives.is_empty() {
        return Err(Fault::new(place, format!("{at}: no [[bus.drive]]")));
    }
    Ok(bus)
}

/// A bus's own keys (its drives are checked by [`check_bus`]).
fn check_line(at: &str, b: BusFile) -> std::result::Result<Bus, String> {
    if !topic_level_ok(&b.name) {
        return Err(format!(
            "{at}: a topic level needs 1–64 characters without '/', '+', '#' or spaces"
        ));
    }
    let protocol = Protocol::parse(&b.protocol).ok_or_else(|| {
        format!(
            "{at}: protocol = {:?}: give one of movilink, sbus, uss, ctt2, modbus-rtu, \
             modbus-ascii",
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
    if protocol == Protocol::Ctt2 {
        // drivebus reaches CTT2 only through its simulated AS-i link (`drivectl ctt2 --sim`).
        if b.port.is_some() || b.iface.is_some() || !b.simulate {
            return Err(format!(
                "{at}: drivebus has no real AS-i master: a ctt2 bus runs only on the simulated \
                 AS-i link; write simulate = true and no port or iface"
            ));
        }
        if b.baud.is_some() || b.parity.is_some() || b.stop_bits.is_some() || b.data_bits.is_some()
        {
            return Err(format!(
                "{at}: a ctt2 bus has no serial line (baud, parity, stop_bits, data_bits): the \
                 AS-i network's size sets its byte time"
            ));
        }
    }
    if !matches!(protocol, Protocol::Sbus | Protocol::Ctt2) && !(1..=4_000_000).contains(&baud) {
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
        Some(t) => drive_transport::can::parse_bitrate(t)
            .map_err(|e| format!("{at}: {e}"))?
            .bits_per_second(),
    };
    let adapter = adapter_of(&b, at)?;
    if protocol == Protocol::Sbus && adapter != Adapter::default() {
        return Err(format!(
            "{at}: echo and rs485 are settings of a serial adapter; an SBus bus runs on a CAN \
             interface"
        ));
    }
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
        let parsed = Iface::parse(&iface).map_err(|e| match e {
            IfaceError::Empty => {
                format!("{at}: iface = \"\": give \"can0\" or \"slcan:PATH\" (or simulate = true)")
            }
            e => format!("{at}: iface = {iface:?}: {e}"),
        })?;
        match parsed {
            Iface::Slcan { bitrate: given, .. } if iface.contains('@') => {
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
            Iface::Slcan { .. } => Endpoint::Can {
                iface: format!("{iface}@{bitrate}"),
                bitrate,
            },
            Iface::Virtual => {
                return Err(format!(
                    "{at}: iface = \"virtual\": write simulate = true for simulated drives"
                ));
            }
            Iface::SocketCan(_) => Endpoint::Can { iface, bitrate },
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
        if drive_transport::serial::is_pty_multiplexer(&path) {
            return Err(format!(
                "{at}: port = {path:?} is the pseudo-terminal multiplexer, no serial port: give \
                 the adapter's port (or a simulator's /dev/pts/N)"
            ));
        }
        Endpoint::Serial {
            path,
            line,
            adapter,
        }
    };
    // As `drivectl movilink` and `drivectl uss` refuse it: a timeout shorter than the pause a
    // drive keeps before answering lets no answer arrive in time (the drives would flap).
    // The same floors `drivectl` puts under `--timeout` in every family (issue 18 C).
    let before_answer = match protocol {
        Protocol::Movilink => Some((
            format!(
                "start pause a drive keeps before answering at {} baud",
                line.baud
            ),
            movilink::timing::start_pause(&line),
        )),
        Protocol::Uss => Some((
            format!(
                "start delay a drive keeps before answering at {} baud",
                line.baud
            ),
            ctt2_uss::serial::framing::UssTiming::from_line(&line).start_delay,
        )),
        Protocol::ModbusRtu | Protocol::ModbusAscii => {
            let mode = if protocol == Protocol::ModbusAscii {
                bonfiglioli_modbus::framing::Mode::Ascii
            } else {
                bonfiglioli_modbus::framing::Mode::Rtu
            };
            Some((
                format!(
                    "exchange takes at {} baud (request, the drive's 10 ms answer delay, answer)",
                    line.baud
                ),
                bonfiglioli_modbus::master::least_response_timeout(mode, &line),
            ))
        }
        // The double slave answers within its 200 ms window or with error 4 (BU 0255 4.3.5):
        // the driver waits for that, there is no response timeout to floor.
        Protocol::Ctt2 => None,
        Protocol::Sbus => drive_core::can::Bitrate::new(bitrate).map(|rate| {
            (
                format!(
                    "parameter answer takes at {} kbit/s (both frames and the drive's 1 ms)",
                    bitrate / 1000
                ),
                sbus_can::master::least_response_timeout(rate, sbus_can::master::Handshake::Async),
            )
        }),
    };
    // Without a timeout in the file, the protocol's default, raised to the floor below where
    // the line is so slow that an answer takes longer (Modbus at 1200 baud: 193 ms).
    let floor = before_answer.as_ref().map(|(_, pause)| {
        Duration::from_millis(u64::try_from(pause.as_micros().div_ceil(1000)).unwrap_or(u64::MAX))
    });
    let timeout = duration(
        &format!("{at}: timeout"),
        b.timeout.as_deref(),
        default_timeout(protocol).max(floor.unwrap_or_default()),
    )?;
    if timeout.is_zero() || timeout > Duration::from_secs(60) {
        return Err(format!("{at}: timeout: give 1ms–60s"));
    }
    if let Some((what, pause)) = before_answer
        && timeout < pause
    {
        return Err(format!(
            "{at}: timeout = {} ms is shorter than the {what} ({:.2} ms): no answer could \
             arrive in time; give at least \"{}ms\"",
            timeout.as_millis(),
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
    Ok(Bus {
        name: b.name,
        protocol,
        endpoint,
        timeout,
        retries,
        status_period,
        drives: Vec::new(),
    })
}

/// The response timeout a bus gets when the config gives none.
pub fn default_timeout(p: Protocol) -> Duration {
    match p {
        Protocol::Sbus => Duration::from_millis(50),
        _ => Duration::from_millis(100),
    }
}

fn check_drive(
    bus: &str,
    protocol: Protocol,
    place: usize,
    d: DriveFile,
) -> std::result::Result<Drive, Fault> {
    let at = format!("{bus} drive {:?}", d.name);
    let fail = |m: String| Fault::new(place, m);
    if !topic_level_ok(&d.name) {
        return Err(fail(format!(
            "{at}: a topic level needs 1–64 characters without '/', '+', '#' or spaces"
        )));
    }
    let family = protocol.family();
    if let Some(f) = &d.family
        && !f.eq_ignore_ascii_case(&family.to_string())
    {
        return Err(fail(format!(
            "{at}: family = {f:?}, but {} talks to {family} drives",
            protocol.name()
        )));
    }
    let device = match (d.variant.as_deref(), family) {
        (None, _) => drive_client::meaning::Device::default(),
        (Some(v), Family::Bonfiglioli) => {
            let variant = match v.to_ascii_lowercase().as_str() {
                "act" => drive_profile::bonfiglioli::Variant::Act,
                "acu" => drive_profile::bonfiglioli::Variant::Acu,
                _ => {
                    return Err(fail(format!(
                        "{at}: variant = {v:?}: give \"act\" (ACTIVE) or \"acu\" (ACTIVE Cube)"
                    )));
                }
            };
            drive_client::meaning::Device::bonfiglioli(variant, "given")
        }
        (Some(_), _) => {
            return Err(fail(format!(
                "{at}: variant is a key of Bonfiglioli drives (act or acu); {} drives have none",
                family
            )));
        }
    };
    let r = protocol.addresses();
    if protocol == Protocol::Ctt2 && !r.contains(&d.address) {
        return Err(fail(format!(
            "{at}: address = {}: a ctt2 drive is addressed by its AS-i double slave's number, \
             1–31 (address = 5 is 5A, its 2nd slave 5B; AS-i address 0 exchanges no data)",
            d.address
        )));
    }
    if !r.contains(&d.address) {
        return Err(fail(format!(
            "{at}: address = {}: {} drives have addresses {}–{}",
            d.address,
            protocol.name(),
            r.start(),
            r.end()
        )));
    }
    let mut points: Vec<Point> = Vec::new();
    let mut names = HashSet::new();
    for p in d.params {
        let p_at = p.span().start;
        let p = p.into_inner();
        let point = check_point(&at, protocol, p_at, &p)?;
        if !names.insert(point.name.clone()) {
            return Err(Fault::new(
                p_at,
                format!("{at}: point {:?} is listed twice", point.name),
            ));
        }
        // One width per parameter of a drive (the client keeps it by parameter number).
        if let Some(other) = points.iter().find(|o| {
            o.target.index == point.target.index && o.width.is_some() && o.width != point.width
        }) {
            return Err(Fault::new(
                place_of(&p.width, p_at),
                format!(
                    "{at} point {:?}: width differs from point {:?} of the same parameter: give \
                     one width",
                    point.name, other.name
                ),
            ));
        }
        points.push(point);
    }
    let process_data = match d.process_data {
        None => None,
        Some(pd) => {
            let pd_at = pd.span().start;
            let pd = pd.into_inner();
            let fail = |m: String| Fault::new(pd_at, m);
            if !protocol.has_process_data() {
                return Err(fail(format!(
                    "{at}: {} has no process data; poll parameters instead",
                    protocol.name()
                )));
            }
            let period = parse_duration(&pd.period)
                .filter(|p| *p >= Duration::from_millis(1))
                .ok_or_else(|| {
                    fail(format!(
                        "{at}: process_data period = {:?}: give 1ms or more",
                        pd.period
                    ))
                })?;
            let max = match protocol {
                Protocol::Uss => 16,
                // The PZD channel: control word and up to 3 setpoints (BU 0255 4.3.4).
                Protocol::Ctt2 => 4,
                _ => 3,
            };
            if pd.out.is_empty() || pd.out.len() > max {
                return Err(fail(format!("{at}: process_data out: 1–{max} words")));
            }
            Some(ProcessData {
                period,
                out: pd.out,
                page_control: pd.page_control,
            })
        }
    };
    if points.is_empty() && process_data.is_none() {
        return Err(fail(format!(
            "{at}: no [[bus.drive.param]] and no process data"
        )));
    }
    Ok(Drive {
        name: d.name,
        address: d.address,
        points,
        process_data,
        device,
    })
}

/// Where an optional key is, else `or`.
fn place_of<T>(k: &Option<Spanned<T>>, or: usize) -> usize {
    k.as_ref().map_or(or, |s| s.span().start)
}

/// One `[[bus.drive.param]]` of the drive `drive` (`bus "b" drive "d"`) at `place`.
fn check_point(
    drive: &str,
    protocol: Protocol,
    place: usize,
    p: &ParamFile,
) -> std::result::Result<Point, Fault> {
    let name = match &p.name {
        Some(n) => n.get_ref().clone(),
        None => p
            .param
            .get_ref()
            .trim()
            .chars()
            .map(|c| {
                if topic_level_ok(&c.to_string()) {
                    c
                } else {
                    '_'
                }
            })
            .collect(),
    };
    if !topic_level_ok(&name) || matches!(name.as_str(), "status" | "pd" | "set" | "result") {
        return Err(Fault::new(
            place_of(&p.name, place),
            format!("{drive}: point name {name:?}: one topic level, not status, pd, set or result"),
        ));
    }
    let at = format!("{drive} point {name:?}");
    let resolved = point::resolve(protocol, p, &at)?;
    let period = match &p.period {
        None => None,
        Some(t) => {
            let fail = |m: String| Fault::new(t.span().start, m);
            let t = t.get_ref();
            let v = parse_duration(t).ok_or_else(|| {
                fail(format!(
                    "{at}: period = {t:?}: give a duration like \"500ms\" or \"5s\""
                ))
            })?;
            if v < Duration::from_millis(1) {
                return Err(fail(format!("{at}: period = {t:?}: at least 1ms")));
            }
            Some(v)
        }
    };
    let writable = p.writable.as_ref().is_some_and(|w| *w.get_ref());
    if period.is_none() && !writable {
        return Err(Fault::new(
            place,
            format!("{at}: neither polled (period) nor writable: nothing to do"),
        ));
    }
    Ok(Point {
        name,
        target: resolved.target,
        period,
        writable,
        eeprom: p.eeprom.as_ref().is_some_and(|e| *e.get_ref()),
        width: resolved.width,
    })
}

#[cfg(test)]
mod tests;

/// A small config file read whole: a regular file only (never a device node or a FIFO, which
/// could block the start for ever), at most `limit` bytes. `key` names the config key in errors
/// (`[gateway] ca_file`, `[ui] users`).
pub(crate) fn read_small_file(path: &str, key: &str, limit: u64) -> crate::error::Result<Vec<u8>> {
    use std::io::Read as _;
    let fail = |why: String| {
        crate::error::Error::config(format!(
            "{key} = {path:?}: {why}; give a readable regular file"
        ))
    };
    let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read it: {e}")))?;
    if !meta.is_file() {
        return Err(fail(if meta.is_dir() {
            "a directory".to_owned()
        } else {
            "not a regular file (a device node, FIFO or socket)".to_owned()
        }));
    }
    let mut buf = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut buf))
        .map_err(|e| fail(format!("cannot read it: {e}")))?;
    if buf.len() as u64 > limit {
        let size = if limit >= 1 << 20 {
            format!("{} MiB", limit >> 20)
        } else {
            format!("{} KiB", limit >> 10)
        };
        return Err(fail(format!("larger than {size}")));
    }
    Ok(buf)
}
