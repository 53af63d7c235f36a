//! Each protocol's [`BusAccess`]: the bus's one driver, the tool layer's per-drive clients on
//! it, process data, the drive's fault, the wire time of a transaction and the link's tally.
//!
//! [`Access`] is the one type every bus has, whatever its protocol and endpoint, so that the
//! gateway runs one bus task type; [`AnyClient`] is its per-drive client.

use drive_profile::sew::ControlWord1;
use drive_profile::sew::index as sew_index;
use std::collections::BTreeMap;
use std::time::Duration;

use bonfiglioli_modbus::framing::Mode;
use ctt2_uss::client::{ClientConfig, NordClient, ParameterChannel};
use ctt2_uss::ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
use ctt2_uss::ctt2::master::{Ctt2Driver, DriverConfig as Ctt2Config};
use ctt2_uss::ctt2::{AsiAddress, AsiNetwork, Bank, DoubleSlaveAddress};
use ctt2_uss::serial::driver::{DriverConfig as UssConfig, UssDriver};
use ctt2_uss::serial::{Layout, UssAddress, UssTiming};
use drive_core::LineSettings;
use drive_core::rt::CharIo;
use drive_profile::Family;
use drive_profile::nord::ControlWord;
use drive_profile::sew::StatusWord1;
use sbus_can::driver::SbusDriver;
use sbus_can::master::Handshake;
use serde_json::Map;

use super::io::{CanBox, LineIo, SharedLine};
use super::wire::WireDesc;
use crate::bus::{BusAccess, LinkTally, Op};
use crate::config::Bus;
use crate::model::PageCommand;
use drive_client::Plain;
use drive_client::bonfiglioli::BonfiglioliClient;
use drive_client::nord::NordParamClient;
use drive_client::sew::movilink::MovilinkLink;
use drive_client::sew::sbus::SbusLink;
use drive_client::sew::{SewClient, SewLink, control_word_slots, pd_warnings, with_command};
use drive_client::target::Target;
use drive_client::text::canonical_port;
use drive_client::{ClientError, ParamClient};

/// The USB serial adapters' burst delivery (an FTDI chip hands characters over every 16 ms):
/// the gap accepted inside an answer on a real port, as `drivectl` does by default. The
/// checksums, lengths and parity stay in force.
pub const REAL_PORT_CHAR_GAP: Duration = Duration::from_millis(20);

/// The per-drive client of a bus of any protocol.
pub enum AnyClient<'a> {
    /// MOVILINK.
    Movilink(SewClient<MovilinkLink<'a, LineIo>>),
    /// SBus.
    Sbus(SewClient<SbusLink<'a, CanBox>>),
    /// USS.
    Uss(NordParamClient<'a, UssDriver<SharedLine>>),
    /// CTT2 on the simulated AS-i link.
    Ctt2(NordParamClient<'a, Ctt2Driver<SimulatedLink>>),
    /// Modbus RTU or ASCII.
    Modbus(BonfiglioliClient<'a, LineIo>),
    /// An address the protocol cannot reach: every call fails with this message.
    Invalid {
        /// The drives' family.
        family: Family,
        /// Why.
        message: String,
    },
}

impl std::fmt::Debug for AnyClient<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AnyClient::Movilink(_) => f.write_str("AnyClient::Movilink"),
            AnyClient::Sbus(_) => f.write_str("AnyClient::Sbus"),
            AnyClient::Uss(_) => f.write_str("AnyClient::Uss"),
            AnyClient::Ctt2(_) => f.write_str("AnyClient::Ctt2"),
            AnyClient::Modbus(_) => f.write_str("AnyClient::Modbus"),
            AnyClient::Invalid { family, message } => f
                .debug_struct("AnyClient::Invalid")
                .field("family", family)
                .field("message", message)
                .finish(),
        }
    }
}

macro_rules! each {
    ($self:ident, $c:ident => $e:expr, $invalid:expr) => {
        match $self {
            AnyClient::Movilink($c) => $e,
            AnyClient::Sbus($c) => $e,
            AnyClient::Uss($c) => $e,
            AnyClient::Ctt2($c) => $e,
            AnyClient::Modbus($c) => $e,
            AnyClient::Invalid { .. } => $invalid,
        }
    };
}

impl AnyClient<'_> {
    fn invalid(&self) -> ClientError {
        match self {
            AnyClient::Invalid { message, .. } => ClientError::Request(message.clone()),
            _ => ClientError::Request("no such drive".to_owned()),
        }
    }
}

impl ParamClient for AnyClient<'_> {
    fn family(&self) -> Family {
        match self {
            AnyClient::Invalid { family, .. } => *family,
            other => each!(other, c => c.family(), Family::Movidrive),
        }
    }

    async fn drive_key(&mut self) -> Result<String, ClientError> {
        let e = self.invalid();
        each!(self, c => c.drive_key().await, Err(e))
    }

    fn link_settings(&self) -> &'static [u16] {
        each!(self, c => c.link_settings(), &[])
    }

    fn link_change(&self, target: &Target, raw: i64) -> String {
        each!(self, c => c.link_change(target, raw), String::new())
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        each!(self, c => c.follow_link_change(target, raw), String::new())
    }

    fn not_restored(&self) -> &'static [u16] {
        each!(self, c => c.not_restored(), &[])
    }

    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        let e = self.invalid();
        each!(self, c => c.read(target).await, Err(e))
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: drive_profile::Persistence,
    ) -> Result<(), ClientError> {
        let e = self.invalid();
        each!(self, c => c.write(target, raw, persistence).await, Err(e))
    }

    async fn identify(&mut self) -> Result<Map<String, serde_json::Value>, ClientError> {
        let e = self.invalid();
        each!(self, c => c.identify().await, Err(e))
    }
}

/// The table entry `key` of `family` as a target (the fault indications).
fn table_target(family: Family, key: &str) -> Result<Target, ClientError> {
    drive_profile::family::lookup(family, key)
        .map(Target::of)
        .ok_or_else(|| ClientError::Request(format!("{key} is not in the {family} table")))
}

/// A MOVIDRIVE's bus timeout `timeout_index` (P812, P815; raw milliseconds; `None` when off or
/// not read) and which of the first `words` process input words is status word 1 (its actual
/// value description P873–P875 is 6).
async fn sew_timeout_and_status<L: SewLink>(
    link: &mut L,
    timeout_index: u16,
    words: usize,
) -> (Option<Duration>, Option<usize>) {
    use drive_profile::sew::ParamChannel;
    // 650 s is off too (ch. 5.1).
    let timeout = match link.service(ParamChannel::read(timeout_index)).await {
        Ok(ms) if ms > 0 && ms < 650_000 => Some(Duration::from_millis(u64::from(ms))),
        _ => None,
    };
    let mut slot = None;
    for (i, index) in [sew_index::PI1_DESCRIPTION, 8308, 8309]
        .into_iter()
        .take(words)
        .enumerate()
    {
        if let Ok(6) = link.service(ParamChannel::read(index)).await {
            slot = Some(i);
            break;
        }
    }
    (timeout, slot)
}

/// The rejected-frame counter of a serial driver (which counts them without their reasons:
/// parity, gaps, address, length and block check alike) since the last tally.
fn serial_tally(retries: u64, rejected: u64) -> LinkTally {
    LinkTally {
        retries,
        rejected: if rejected > 0 {
            vec![("checks", rejected)]
        } else {
            Vec::new()
        },
    }
}

// ---------------------------------------------------------------------------------------------
// MOVILINK

/// A MOVILINK bus: one [`movilink::driver::MovilinkDriver`] on the line.
#[derive(Debug)]
pub struct MovilinkBus<IO> {
    driver: movilink::driver::MovilinkDriver<IO>,
    port: String,
    last: movilink::driver::DriverStats,
}

impl<IO: CharIo> MovilinkBus<IO> {
    /// The bus `bus` on `io` (the port named `port`, for the EEPROM-wear log) with `line`;
    /// `real`: a real port (answers may arrive in the bursts of a USB adapter).
    pub fn new(io: IO, bus: &Bus, port: &str, line: LineSettings, real: bool) -> Self {
        let config = movilink::driver::DriverConfig {
            line,
            response_timeout: bus.timeout,
            retries: bus.retries,
            max_char_gap: real.then_some(REAL_PORT_CHAR_GAP),
            ..movilink::driver::DriverConfig::default()
        };
        Self {
            driver: movilink::driver::MovilinkDriver::new(io, config),
            port: port.to_owned(),
            last: movilink::driver::DriverStats::default(),
        }
    }

    fn address(address: u8) -> Result<movilink::Address, String> {
        movilink::Address::unicast(address)
            .ok_or_else(|| format!("MOVILINK address {address}: a drive has 0–99"))
    }

    /// The PDU type of process data with `n` words (cyclic: the drive watches P812).
    fn pd_type(n: usize) -> Option<movilink::PduType> {
        let n = u8::try_from(n).ok().filter(|n| (1..=3).contains(n))?;
        movilink::PduType::from_layout(false, n, true)
    }
}

impl<IO: CharIo> MovilinkBus<IO> {
    fn client_of(&mut self, address: u8) -> Result<SewClient<MovilinkLink<'_, IO>>, String> {
        let a = Self::address(address)?;
        Ok(SewClient::new(MovilinkLink::new(
            &mut self.driver,
            a,
            &self.port,
        )))
    }

    async fn pd(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        let a = Self::address(address).map_err(ClientError::Request)?;
        let pdu = Self::pd_type(out.len()).ok_or_else(|| {
            ClientError::Request(format!(
                "MOVILINK carries 1–3 process data words, not {}",
                out.len()
            ))
        })?;
        let request = movilink::Telegram::request(a, pdu).with_process_data(out);
        let answer = self
            .driver
            .exchange(request)
            .await
            .map_err(drive_client::sew::movilink::client_error)?;
        Ok(answer.process_data().to_vec())
    }

    fn tally(&mut self) -> LinkTally {
        let s = self.driver.stats();
        let t = serial_tally(
            s.retries.saturating_sub(self.last.retries),
            s.rejected.saturating_sub(self.last.rejected),
        );
        self.last = s;
        t
    }
}

// ---------------------------------------------------------------------------------------------
// SBus

/// An SBus bus: one [`SbusDriver`] on the CAN interface.
pub struct SbusBus<C> {
    master: SbusDriver<C>,
    iface: String,
    last: sbus_can::master::MasterStats,
}

impl<C> std::fmt::Debug for SbusBus<C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SbusBus")
            .field("iface", &self.iface)
            .finish()
    }
}

impl<C: drive_core::rt::CanIo> SbusBus<C> {
    /// The bus `bus` on `io` (the interface named `iface`).
    pub fn new(io: C, bus: &Bus, iface: &str) -> Self {
        let config = sbus_can::master::MasterConfig {
            response_timeout: bus.timeout,
            retries: bus.retries,
            late_guard: bus.timeout,
            ..sbus_can::master::MasterConfig::default()
        };
        Self {
            master: SbusDriver::new(io, config),
            iface: iface.to_owned(),
            last: sbus_can::master::MasterStats::default(),
        }
    }

    fn address(address: u8) -> Result<sbus_can::Address, String> {
        sbus_can::Address::new(address)
            .ok_or_else(|| format!("SBus address {address}: a drive has 0–63"))
    }

    fn client_of(&mut self, address: u8) -> Result<SewClient<SbusLink<'_, C>>, String> {
        let a = Self::address(address)?;
        Ok(SewClient::new(SbusLink {
            master: &mut self.master,
            address: a,
            handshake: Handshake::Async,
            iface: self.iface.clone(),
        }))
    }

    async fn pd(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        let a = Self::address(address).map_err(ClientError::Request)?;
        if out.is_empty() || out.len() > 3 {
            return Err(ClientError::Request(format!(
                "SBus carries 1–3 process data words, not {}",
                out.len()
            )));
        }
        let mut words = [0u16; 3];
        for (w, o) in words.iter_mut().zip(out) {
            *w = *o;
        }
        let input = self
            .master
            .process_data(a, sbus_can::ProcessData(words))
            .await
            .map_err(drive_client::sew::sbus::client_error)?;
        Ok(input.0.iter().take(out.len()).copied().collect())
    }

    fn tally(&mut self) -> LinkTally {
        let s = self.master.stats();
        let (r, l) = (s.rejected, self.last.rejected);
        let rejected = [
            ("mismatch", r.mismatch.saturating_sub(l.mismatch)),
            ("unsolicited", r.unsolicited.saturating_sub(l.unsolicited)),
            ("malformed", r.malformed.saturating_sub(l.malformed)),
            ("foreign", r.foreign.saturating_sub(l.foreign)),
        ]
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .collect();
        let t = LinkTally {
            retries: s.retries.saturating_sub(self.last.retries),
            rejected,
        };
        self.last = s;
        t
    }
}

// ---------------------------------------------------------------------------------------------
// USS

/// A USS bus: one [`UssDriver`] per drive (each keeps its drive's last PKW order and process
/// data, which USS repeats), all on one [`SharedLine`] that keeps the start delay between
/// telegrams of different drives.
#[derive(Debug)]
pub struct UssBus {
    line: SharedLine,
    settings: LineSettings,
    layout: Layout,
    timeout: Duration,
    retries: u8,
    port: String,
    drives: BTreeMap<u8, NordClient<UssDriver<SharedLine>>>,
    /// Totals of the drivers at the last tally.
    last: (u64, u64),
}

/// The telegram layout of a USS bus: 4 PKW words, and as many PZD words as the bus's widest
/// process data, at least 4 (NORD's: control word and three setpoints). The drives must be
/// set to it.
pub fn uss_layout(bus: &Bus) -> Layout {
    let widest = bus
        .drives
        .iter()
        .filter_map(|d| d.process_data.as_ref().map(|p| p.out.len()))
        .max()
        .unwrap_or(0)
        .max(4);
    let pzd = u8::try_from(widest).unwrap_or(4);
    Layout::new(4, pzd).unwrap_or(Layout::PKW4_PZD4)
}

impl UssBus {
    /// The bus `bus` on `io` (the port named `port`) with `line`.
    pub fn new(io: LineIo, bus: &Bus, port: &str, line: LineSettings) -> Self {
        let timing = UssTiming::from_line(&line);
        Self {
            line: SharedLine::new(io, timing.start_delay),
            settings: line,
            layout: uss_layout(bus),
            timeout: bus.timeout,
            retries: bus.retries,
            port: port.to_owned(),
            drives: BTreeMap::new(),
            last: (0, 0),
        }
    }

    fn drive(&mut self, address: u8) -> Result<&mut NordClient<UssDriver<SharedLine>>, String> {
        let a = UssAddress::new(address)
            .ok_or_else(|| format!("USS address {address}: a drive has 0–31"))?;
        let line = &self.line;
        let config = UssConfig {
            response_timeout: self.timeout,
            retries: self.retries,
            ..UssConfig::new(a, self.layout, self.settings)
        };
        Ok(self.drives.entry(address).or_insert_with(|| {
            NordClient::new(
                UssDriver::new(line.handle(), config),
                ClientConfig::default(),
            )
        }))
    }

    fn client_of(
        &mut self,
        address: u8,
    ) -> Result<NordParamClient<'_, UssDriver<SharedLine>>, String> {
        let key = format!("{} uss {address}", canonical_port(&self.port));
        let client = self.drive(address)?;
        let mut identity = Map::new();
        identity.insert("address".into(), address.into());
        Ok(NordParamClient::new(client, &key, identity))
    }

    async fn pd(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        let layout = usize::from(self.layout.pzd_words());
        let (control, setpoints) = out.split_first().ok_or_else(|| {
            ClientError::Request("USS process data need at least the control word".to_owned())
        })?;
        if out.len() > layout {
            return Err(ClientError::Request(format!(
                "{} process data words do not fit the bus's {layout} PZD words",
                out.len()
            )));
        }
        let actuals = u8::try_from(setpoints.len()).unwrap_or(0);
        let client = self.drive(address).map_err(ClientError::Request)?;
        let answer = client
            .process(ControlWord(*control), setpoints, actuals)
            .await
            .map_err(|e| {
                drive_client::nord::client_error(
                    e,
                    <UssDriver<SharedLine> as ParameterChannel>::link_fault,
                    &Plain,
                )
            })?;
        let mut words = vec![answer.status().0];
        words.extend_from_slice(answer.actuals());
        Ok(words)
    }

    fn tally(&mut self) -> LinkTally {
        let (retries, rejected) = self.drives.values().fold((0u64, 0u64), |(r, j), c| {
            let s = c.channel().stats();
            (r + s.retries, j + s.rejected)
        });
        let t = serial_tally(
            retries.saturating_sub(self.last.0),
            rejected.saturating_sub(self.last.1),
        );
        self.last = (retries, rejected);
        t
    }
}

// ---------------------------------------------------------------------------------------------
// CTT2

/// The double slave of a CTT2 drive at `address` (its number: `5` is 5A with its 2nd slave
/// 5B, as `drivectl ctt2 --asi-address 5A` names it).
pub fn ctt2_double_slave(address: u8) -> Option<DoubleSlaveAddress> {
    let first = AsiAddress::new(address, Bank::A)?;
    let second = AsiAddress::new(address, Bank::B)?;
    DoubleSlaveAddress::new(first, second)
}

/// The AS-i network of a CTT2 bus: a double slave per drive (two AS-i slaves each), nothing
/// else; its size sets the CTT2 byte time (BU 0255 4.4). Drives whose address is no double
/// slave's are left out (their clients fail without a transaction).
pub fn ctt2_network(bus: &Bus) -> AsiNetwork {
    let mut net = AsiNetwork::new();
    for d in &bus.drives {
        if let Some(a) = ctt2_double_slave(d.address) {
            let _ = net.add_double_slave(a);
        }
    }
    net
}

/// A CTT2 bus: one simulated AS-i link per drive (each double slave has its own CTT2
/// channel; the AS-i master polls all of them in every cycle), all on the bus's one
/// [`AsiNetwork`] (see [`ctt2_network`]), each with a [`Ctt2Driver`] and the drive's
/// [`NordClient`] (which keeps its last PKW answer for the plausibility check).
///
/// drivebus has no real AS-i master: a real one needs its own
/// [`Ctt2Link`](ctt2_uss::ctt2::master::Ctt2Link), and this bus would hold it instead.
#[derive(Debug)]
pub struct Ctt2Bus {
    drives: BTreeMap<u8, NordClient<Ctt2Driver<SimulatedLink>>>,
    /// Repetitions after error 4 or 5 at the last tally.
    last: u64,
}

impl Ctt2Bus {
    /// A simulated NORDAC LINK after power-on behind the double slave of every drive of
    /// `bus`, on the bus's AS-i network.
    pub fn simulated(bus: &Bus) -> Self {
        let network = ctt2_network(bus);
        let mut drives = BTreeMap::new();
        for d in &bus.drives {
            let Some(a) = ctt2_double_slave(d.address) else {
                continue;
            };
            let Some(id) = network.double_slave_at(a.first) else {
                continue;
            };
            let link =
                SimulatedLink::on_network(SimulatedDoubleSlave::default(), network.clone(), id);
            let driver = Ctt2Driver::new(link, Ctt2Config::default());
            drives.insert(d.address, NordClient::new(driver, ClientConfig::default()));
        }
        Self { drives, last: 0 }
    }

    fn drive(&mut self, address: u8) -> Result<&mut NordClient<Ctt2Driver<SimulatedLink>>, String> {
        let Some(a) = ctt2_double_slave(address) else {
            return Err(format!(
                "CTT2 address {address}: a double slave has the number 1–31 (1A…31A)"
            ));
        };
        self.drives.get_mut(&address).ok_or_else(|| {
            format!(
                "no double slave at AS-i address {} on this simulated AS-i network",
                a.first
            )
        })
    }

    fn client_of(
        &mut self,
        address: u8,
    ) -> Result<NordParamClient<'_, Ctt2Driver<SimulatedLink>>, String> {
        let client = self.drive(address)?;
        let first = ctt2_double_slave(address).map(|a| a.first.to_string());
        let first = first.unwrap_or_default();
        // The key `drivectl ctt2 --sim --asi-address …` uses (the EEPROM-wear log's).
        let key = format!("ctt2-sim {first}");
        let mut identity = Map::new();
        identity.insert("asi_address".into(), first.into());
        Ok(NordParamClient::new(client, &key, identity))
    }

    async fn pd(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        let (control, setpoints) = out.split_first().ok_or_else(|| {
            ClientError::Request("CTT2 process data need at least the control word".to_owned())
        })?;
        if setpoints.len() > ctt2_uss::uss::pzd::MAX_VALUES {
            return Err(ClientError::Request(format!(
                "the CTT2 process channel carries the control word and up to {} setpoints, not \
                 {} words",
                ctt2_uss::uss::pzd::MAX_VALUES,
                out.len()
            )));
        }
        let actuals = u8::try_from(setpoints.len()).unwrap_or(0);
        let client = self.drive(address).map_err(ClientError::Request)?;
        let answer = client
            .process(ControlWord(*control), setpoints, actuals)
            .await
            .map_err(|e| {
                drive_client::nord::client_error(
                    e,
                    <Ctt2Driver<SimulatedLink> as ParameterChannel>::link_fault,
                    &Plain,
                )
            })?;
        let mut words = vec![answer.status().0];
        words.extend_from_slice(answer.actuals());
        Ok(words)
    }

    /// The simulated drive at `address` (tests look at what a write did).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn simulated_drive(&self, address: u8) -> Option<&drive_sim::nord::SimulatedNord> {
        self.drives
            .get(&address)
            .map(|c| c.channel().link().drive())
    }

    fn tally(&mut self) -> LinkTally {
        let retries = self
            .drives
            .values()
            .map(|c| c.channel().counters().retries)
            .sum::<u64>();
        // The simulated link checks nothing a fault could break: no frames are refused.
        let t = LinkTally {
            retries: retries.saturating_sub(self.last),
            rejected: Vec::new(),
        };
        self.last = retries;
        t
    }
}

// ---------------------------------------------------------------------------------------------
// Modbus

/// A Bonfiglioli Modbus bus (RTU or ASCII): one [`bonfiglioli_modbus::driver::ModbusDriver`].
#[derive(Debug)]
pub struct ModbusBus<IO> {
    driver: bonfiglioli_modbus::driver::ModbusDriver<IO>,
    port: String,
    last: bonfiglioli_modbus::driver::DriverStats,
    /// The config's `width` of parameters the manual gives no data type: (address, parameter,
    /// width).
    widths: Vec<(u8, u16, bonfiglioli_modbus::slave::Width)>,
}

/// The line a Bonfiglioli drive speaks `mode` on: RTU 8 data bits, ASCII 7 (ch. 6.7), with
/// the configured baud rate, parity and stop bits.
pub fn modbus_line(mode: Mode, line: LineSettings) -> LineSettings {
    LineSettings {
        // ASCII: the config's (7 by default, 8 where a converter or a pty needs it).
        data_bits: match mode {
            Mode::Rtu => 8,
            Mode::Ascii => line.data_bits,
        },
        ..line
    }
}

impl<IO: CharIo> ModbusBus<IO> {
    /// The bus `bus` in `mode` on `io` (the port named `port`) with `line` (see
    /// [`modbus_line`]).
    pub fn new(io: IO, bus: &Bus, port: &str, mode: Mode, line: LineSettings) -> Self {
        let config = bonfiglioli_modbus::driver::DriverConfig {
            response_timeout: bus.timeout,
            retries: bus.retries,
            ..bonfiglioli_modbus::driver::DriverConfig::new(mode, line)
        };
        let widths = bus
            .drives
            .iter()
            .flat_map(|d| {
                d.points
                    .iter()
                    .filter_map(move |p| p.width.map(|w| (d.address, p.target.index, w)))
            })
            .collect();
        Self {
            driver: bonfiglioli_modbus::driver::ModbusDriver::new(io, config),
            port: port.to_owned(),
            last: bonfiglioli_modbus::driver::DriverStats::default(),
            widths,
        }
    }

    fn client_of(&mut self, address: u8) -> Result<BonfiglioliClient<'_, IO>, String> {
        let a = bonfiglioli_modbus::frame::Address::new(address)
            .filter(|a| !a.is_broadcast())
            .ok_or_else(|| format!("Modbus address {address}: a drive has 1–247"))?;
        let widths = self
            .widths
            .iter()
            .filter(|(drive, _, _)| *drive == address)
            .map(|(_, param, width)| (*param, *width));
        Ok(BonfiglioliClient::new(&mut self.driver, a, &self.port, None).with_widths(widths))
    }

    fn tally(&mut self) -> LinkTally {
        let s = self.driver.stats();
        let t = serial_tally(
            s.retries.saturating_sub(self.last.retries),
            s.rejected.saturating_sub(self.last.rejected),
        );
        self.last = s;
        t
    }
}

// ---------------------------------------------------------------------------------------------
// Any protocol

/// A bus of any protocol, on any endpoint: what the gateway's bus task runs on.
#[derive(Debug)]
pub struct Access {
    /// The protocol's bus.
    pub proto: Proto,
    /// Its wire times.
    pub wire: WireDesc,
    /// MOVIDRIVE: the process input word that is status word 1 (P873–P875 = 6), per drive
    /// address, as read before the first cycle.
    pub status_slots: Vec<(u8, usize)>,
    /// MOVIDRIVE: where the page's control goes in the process output words, per drive
    /// address, read (P870–P872) before the page's first cycle.
    pub control_layouts: Vec<(u8, SewLayout)>,
}

/// Where a MOVIDRIVE takes the page's control in its process output words (P870–P872).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SewLayout {
    /// The words that are control words (9, 10).
    pub control: Vec<usize>,
    /// The word that is the speed setpoint (1), if one is.
    pub speed: Option<usize>,
}

/// The layout P870–P872 (their values `descriptions`) give the first words.
pub fn sew_layout(descriptions: &[u32]) -> SewLayout {
    SewLayout {
        control: descriptions
            .iter()
            .enumerate()
            .filter(|(_, d)| matches!(d, 9 | 10))
            .map(|(i, _)| i)
            .collect(),
        speed: descriptions.iter().position(|d| *d == 1),
    }
}

/// P870–P872 of the first `words` process output words.
async fn read_layout<L: SewLink>(link: &mut L, words: usize) -> Result<SewLayout, ClientError> {
    let mut d = Vec::new();
    for i in [sew_index::PO1_DESCRIPTION, 8305, 8306]
        .into_iter()
        .take(words)
    {
        d.push(
            link.service(drive_profile::sew::ParamChannel::read(i))
                .await?,
        );
    }
    Ok(sew_layout(&d))
}

/// The output words that carry `command` to a MOVIDRIVE whose output words are laid out as
/// `layout`, the others as `out` has them.
pub fn sew_control_words(
    layout: &SewLayout,
    out: &[u16],
    command: PageCommand,
) -> Result<Vec<u16>, String> {
    if layout.control.is_empty() {
        return Err(
            "no process output word is a control word (P870–P872 = 9 or 10): the \
                    drive cannot be driven over process data"
                .to_owned(),
        );
    }
    let (cmd, word) = match command {
        PageCommand::Enable { word } => (ControlWord1::ENABLE, word),
        PageCommand::Stop => (ControlWord1::STOP, 0),
    };
    let mut words = with_command(out, &layout.control, cmd);
    match (layout.speed.and_then(|s| words.get_mut(s)), command) {
        (Some(w), _) => *w = word,
        (None, PageCommand::Enable { word: 0 }) | (None, PageCommand::Stop) => {}
        (None, PageCommand::Enable { .. }) => {
            return Err(
                "no process output word is the speed setpoint (P870–P872 = 1 speed): set one \
                 in the drive or give [bus.drive.process_data] out more words"
                    .to_owned(),
            );
        }
    }
    Ok(words)
}

/// The output words that carry `command` to a NORD drive: STW first, toward "operation
/// enabled" from the state the status word in `inputs` shows (after `sent`), or shutdown;
/// SW1 second.
pub fn nord_control_words(
    out: &[u16],
    command: PageCommand,
    sent: &[u16],
    inputs: &[u16],
) -> Result<Vec<u16>, String> {
    use drive_profile::nord::{NordStateMachine, State, StatusWord, command as nord_command};
    let mut words = out.to_vec();
    let (stw, sw1) = match command {
        PageCommand::Enable { word } => {
            let state = StatusWord(inputs.first().copied().unwrap_or(0)).state();
            let last = sent.first().copied().unwrap_or(0);
            let stw = NordStateMachine::next_control(last, state, State::OperationEnabled)
                .unwrap_or_else(|| drive_client::control::nord::hold_word(State::OperationEnabled));
            (stw, word)
        }
        PageCommand::Stop => (nord_command::SHUTDOWN.0, 0),
    };
    match words.first_mut() {
        Some(w) => *w = stw,
        None => return Err("no process data words configured".to_owned()),
    }
    match (words.get_mut(1), command) {
        (Some(w), _) => *w = sw1,
        (None, PageCommand::Enable { word: 0 }) | (None, PageCommand::Stop) => {}
        (None, PageCommand::Enable { .. }) => {
            return Err(
                "the process data carry no setpoint word: give [bus.drive.process_data] out \
                 two words (STW, SW1)"
                    .to_owned(),
            );
        }
    }
    Ok(words)
}

/// The protocol's part of an [`Access`].
#[derive(Debug)]
pub enum Proto {
    /// MOVILINK.
    Movilink(Box<MovilinkBus<LineIo>>),
    /// SBus.
    Sbus(Box<SbusBus<CanBox>>),
    /// USS.
    Uss(Box<UssBus>),
    /// CTT2 (simulated AS-i link).
    Ctt2(Box<Ctt2Bus>),
    /// Modbus RTU or ASCII.
    Modbus(Box<ModbusBus<LineIo>>),
}

impl Access {
    /// The drives' family.
    pub fn family(&self) -> Family {
        match &self.proto {
            Proto::Movilink(_) | Proto::Sbus(_) => Family::Movidrive,
            Proto::Uss(_) | Proto::Ctt2(_) => Family::Nord,
            Proto::Modbus(_) => Family::Bonfiglioli,
        }
    }
}

impl BusAccess for Access {
    type Client<'a> = AnyClient<'a>;

    fn client(&mut self, address: u8) -> AnyClient<'_> {
        let family = self.family();
        let r = match &mut self.proto {
            Proto::Movilink(b) => b.client_of(address).map(AnyClient::Movilink),
            Proto::Sbus(b) => b.client_of(address).map(AnyClient::Sbus),
            Proto::Uss(b) => b.client_of(address).map(AnyClient::Uss),
            Proto::Ctt2(b) => b.client_of(address).map(AnyClient::Ctt2),
            Proto::Modbus(b) => b.client_of(address).map(AnyClient::Modbus),
        };
        r.unwrap_or_else(|message| AnyClient::Invalid { family, message })
    }

    fn page_client(&mut self, address: u8) -> AnyClient<'_> {
        if !matches!(self.proto, Proto::Modbus(_)) {
            return self.client(address);
        }
        let family = self.family();
        let r = match &mut self.proto {
            Proto::Modbus(b) => b.client_of(address).map(|c| AnyClient::Modbus(c.probing())),
            _ => Err(String::new()),
        };
        r.unwrap_or_else(|message| AnyClient::Invalid { family, message })
    }

    async fn process_data(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        match &mut self.proto {
            Proto::Movilink(b) => b.pd(address, out).await,
            Proto::Sbus(b) => b.pd(address, out).await,
            Proto::Uss(b) => b.pd(address, out).await,
            Proto::Ctt2(b) => b.pd(address, out).await,
            Proto::Modbus(_) => Err(ClientError::Request(
                "Modbus has no process data: poll parameters instead".to_owned(),
            )),
        }
    }

    async fn process_data_warnings(
        &mut self,
        address: u8,
        out: &[u16],
        period: Duration,
    ) -> Result<Vec<String>, ClientError> {
        // The checks `drivectl movilink pd` and `sbus pd` make (`sew::pd_warnings`). NORD: the
        // control word's source and a USS telegram timeout are not in the manual's table;
        // Modbus has no process data.
        // Then the period against that timeout, and where the input words carry status word
        // 1 (P873–P875 = 6, the factory setting of PI1).
        let (mut warnings, timeout, slots) = match &mut self.proto {
            Proto::Movilink(b) => {
                let mut c = b.client_of(address).map_err(ClientError::Request)?;
                let timeout = (sew_index::RS485_TIMEOUT, "RS-485 timeout P812");
                let (_, w) = pd_warnings(&mut c.link, out.len(), true, timeout, &Plain).await;
                let (t, s) = sew_timeout_and_status(&mut c.link, timeout.0, out.len()).await;
                (w, t.map(|t| (t, timeout.1, "F43 RS-485 timeout")), s)
            }
            Proto::Sbus(b) => {
                let mut c = b.client_of(address).map_err(ClientError::Request)?;
                let timeout = (sew_index::SBUS_TIMEOUT, "SBus timeout P815");
                let (_, w) = pd_warnings(&mut c.link, out.len(), true, timeout, &Plain).await;
                let (t, s) = sew_timeout_and_status(&mut c.link, timeout.0, out.len()).await;
                (w, t.map(|t| (t, timeout.1, "F47 SBus timeout")), s)
            }
            Proto::Uss(_) | Proto::Ctt2(_) | Proto::Modbus(_) => return Ok(Vec::new()),
        };
        if let Some((timeout, name, fault)) = timeout
            && period >= timeout
        {
            warnings.push(format!(
                "the process data period ({}) is at or above the drive's {name} ({}): the drive \
                 trips with {fault} between two cycles; give [bus.drive.process_data] period \
                 well below it",
                super::super::logfmt::duration(period),
                super::super::logfmt::duration(timeout)
            ));
        }
        self.status_slots.retain(|(a, _)| *a != address);
        if let Some(slot) = slots {
            self.status_slots.push((address, slot));
        }
        Ok(warnings)
    }

    async fn watchdog_warnings(
        &mut self,
        address: u8,
        gap: Duration,
    ) -> Result<Vec<String>, ClientError> {
        let Proto::Modbus(b) = &mut self.proto else {
            return Ok(Vec::new());
        };
        // The manual gives 413 no data type: read by trying FC 3, then FC 100 (a read only).
        let t = table_target(Family::Bonfiglioli, "413")?;
        let mut c = b
            .client_of(address)
            .map_err(ClientError::Request)?
            .probing();
        let seconds = c.read(&t).await?;
        let Ok(watchdog) = u64::try_from(seconds) else {
            return Ok(Vec::new());
        };
        let watchdog = Duration::from_secs(watchdog);
        if watchdog.is_zero() || gap < watchdog {
            return Ok(Vec::new());
        }
        Ok(vec![format!(
            "the drive's watchdog 413 ({}) is at or below the longest gap between the gateway's \
             requests to it ({}, its shortest period with status_period): it trips with F2010 \
             between two; poll it more often (a shorter period or status_period) or raise 413",
            super::super::logfmt::duration(watchdog),
            super::super::logfmt::duration(gap)
        )])
    }

    fn fault_in_inputs(&self, address: u8, inputs: &[u16]) -> Option<Option<String>> {
        let (_, slot) = self.status_slots.iter().find(|(a, _)| *a == address)?;
        let word = *inputs.get(*slot)?;
        Some(drive_client::meaning::sew_fault_text(
            StatusWord1::from_bits(word),
        ))
    }

    async fn stop_process_data(
        &mut self,
        address: u8,
        out: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError> {
        let mut words = out.to_vec();
        match &mut self.proto {
            Proto::Movilink(_) | Proto::Sbus(_) => {
                // The control word slots (P870–P872), as `drivectl pd` finds them; a drive that
                // does not answer them is not sent anything.
                let found = match &mut self.proto {
                    Proto::Movilink(b) => {
                        let mut c = b.client_of(address).map_err(ClientError::Request)?;
                        control_word_slots(&mut c.link, out.len()).await
                    }
                    Proto::Sbus(b) => {
                        let mut c = b.client_of(address).map_err(ClientError::Request)?;
                        control_word_slots(&mut c.link, out.len()).await
                    }
                    _ => Vec::new(),
                };
                let mut slots = Vec::new();
                for (slot, is_control) in found.into_iter().enumerate() {
                    if is_control? {
                        slots.push(slot);
                    }
                }
                if slots.is_empty() {
                    return Ok(Err(
                        "no process output word is a control word (P870–P872): \
                                   the drive cannot be stopped over process data"
                            .to_owned(),
                    ));
                }
                words = with_command(out, &slots, ControlWord1::STOP);
            }
            Proto::Uss(_) | Proto::Ctt2(_) => {
                // The first PZD word is the control word (STW): "Stillsetzen", the ramp down.
                match words.first_mut() {
                    Some(w) => *w = drive_profile::nord::command::SHUTDOWN.0,
                    None => return Ok(Err("no process data words configured".to_owned())),
                }
            }
            Proto::Modbus(_) => return Ok(Err("Modbus has no process data".to_owned())),
        }
        self.process_data(address, &words).await.map(Ok)
    }

    async fn control_words(
        &mut self,
        address: u8,
        out: &[u16],
        command: PageCommand,
        sent: &[u16],
        inputs: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError> {
        // NORD, over USS or CTT2: STW and SW1 as the first two words.
        if let Proto::Uss(_) | Proto::Ctt2(_) = self.proto {
            return Ok(nord_control_words(out, command, sent, inputs));
        }
        if let Some((_, layout)) = self.control_layouts.iter().find(|(a, _)| *a == address) {
            return Ok(sew_control_words(layout, out, command));
        }
        let layout = match &mut self.proto {
            Proto::Movilink(b) => {
                let mut c = b.client_of(address).map_err(ClientError::Request)?;
                read_layout(&mut c.link, out.len()).await?
            }
            Proto::Sbus(b) => {
                let mut c = b.client_of(address).map_err(ClientError::Request)?;
                read_layout(&mut c.link, out.len()).await?
            }
            Proto::Uss(_) | Proto::Ctt2(_) | Proto::Modbus(_) => {
                return Ok(Err(
                    "Bonfiglioli drives have no process data in the gateway: no control from \
                     the page"
                        .to_owned(),
                ));
            }
        };
        let words = sew_control_words(&layout, out, command);
        self.control_layouts.push((address, layout));
        Ok(words)
    }

    fn state_in_inputs(&self, address: u8, inputs: &[u16]) -> Option<String> {
        match &self.proto {
            Proto::Uss(_) | Proto::Ctt2(_) => inputs.first().map(|w| {
                drive_client::meaning::nord_state_text(drive_profile::nord::StatusWord(*w).state())
            }),
            Proto::Movilink(_) | Proto::Sbus(_) => {
                let (_, slot) = self.status_slots.iter().find(|(a, _)| *a == address)?;
                let sw = StatusWord1::from_bits(*inputs.get(*slot)?);
                if let Some(fault) = drive_client::meaning::sew_fault_text(sw) {
                    return Some(format!("fault: {fault}"));
                }
                let unit = sw.unit_status().map_or("?", |u| u.name());
                let stage = if sw.contains(StatusWord1::OUTPUT_STAGE_ENABLED) {
                    "output stage enabled"
                } else {
                    "output stage inhibited"
                };
                Some(format!("{unit}, {stage}"))
            }
            Proto::Modbus(_) => None,
        }
    }

    async fn fault(&mut self, address: u8) -> Result<Option<String>, ClientError> {
        self.client(address).present_fault().await
    }

    fn wire_time(&self, op: Op) -> Duration {
        self.wire.time(op)
    }

    fn take_tally(&mut self) -> LinkTally {
        match &mut self.proto {
            Proto::Movilink(b) => b.tally(),
            Proto::Sbus(b) => b.tally(),
            Proto::Uss(b) => b.tally(),
            Proto::Ctt2(b) => b.tally(),
            Proto::Modbus(b) => b.tally(),
        }
    }
}
