//! Bonfiglioli ACTIVE (ACT) and ACTIVE Cube (ACU) over Modbus RTU or ASCII:
//! [`BonfiglioliClient`], the [`ParamClient`] of one drive behind `bonfiglioli_modbus`'s
//! [`ModbusDriver`], with the function codes 3/6 (16 bit) and 100/101 (32 bit).
//!
//! [`Target::sub`] is the data set (0 = all four, 1–4, and 5–9 their RAM-only twins). The
//! width of a parameter comes from the table's data type, else from the caller (given for all
//! parameters, or per parameter), else it is found by trying ([`BonfiglioliClient::probing`]).
//! The variant (ACT or ACU) decodes the status word; it is given, or found by asking the drive
//! ([`BonfiglioliClient::find_variant`]).

use std::collections::HashMap;
use std::ops::RangeInclusive;

use bonfiglioli_modbus::driver::{CharIo, DriverError, ModbusDriver};
use bonfiglioli_modbus::frame::{Address, DataSet, ExceptionCode};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use drive_profile::bonfiglioli::{self as profile, DataType, Variant};
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::client::{ClientError, DeviceCode, DeviceError, DeviceErrorKind, ParamClient};
use crate::front::{FrontEnd, Note, Plain, Setting};
use crate::meaning::{Device, KnownVariant};
use crate::target::Target;
use crate::text::{canonical_port, physical_text};

/// Parameter numbers outside the table that may be read and written raw (the start address
/// carries 0–1599).
pub const RAW_INDICES: RangeInclusive<u16> = 0..=1599;

/// Parameter numbers of the table that clients and front ends use by name.
pub mod param {
    /// Baud rate (a link setting).
    pub const BAUD_RATE: u16 = 10;
    /// Configuration.
    pub const CONFIGURATION: u16 = 30;
    /// Program: a command (factory reset and others), never restored.
    pub const PROGRAM: u16 = 34;
    /// Current fault.
    pub const CURRENT_FAULT: u16 = 260;
    /// Warnings.
    pub const WARNINGS: u16 = 270;
    /// Protocol type (a link setting: 2 = Modbus RTU, 3 = Modbus ASCII).
    pub const PROTOCOL: u16 = 395;
    /// Control word (RAM only).
    pub const CONTROL_WORD: u16 = 410;
    /// Status word.
    pub const STATUS_WORD: u16 = 411;
    /// Local/remote (1 = state machine).
    pub const LOCAL_REMOTE: u16 = 412;
    /// RS232/RS485 watchdog timer (a link setting).
    pub const WATCHDOG: u16 = 413;
    /// Reference frequency RAM (write-only on the ACU).
    pub const FREQUENCY_RAM: u16 = 484;
    /// Reference percentage RAM (write-only on the ACU).
    pub const PERCENTAGE_RAM: u16 = 524;
    /// Modbus parity (a link setting).
    pub const PARITY: u16 = 1375;
    /// Modbus address (a link setting).
    pub const ADDRESS: u16 = 1376;
}

/// The drive's own settings for the Modbus link: baud rate 10, protocol type 395, watchdog
/// 413, parity 1375, address 1376.
pub const LINK_SETTINGS: &[u16] = &[
    param::BAUD_RATE,
    param::PROTOCOL,
    param::WATCHDOG,
    param::PARITY,
    param::ADDRESS,
];

/// What a restore never writes: the command 34 (program), the RAM-only control word and
/// setpoints (410, 484, 524), the link settings that would cut the connection (baud rate,
/// protocol, parity, address), and *local/remote* 412. The 413 watchdog is restored only when
/// the link settings are confirmed. Putting a drive under bus control sets 412 = 1 in RAM only
/// (data set 5), and a read returns the value in use whether it came from the EEPROM or from
/// such a RAM write: the manual offers no read of the stored value (ch. 7 names data sets 5–9
/// for writes only). A backup taken then holds 412 = 1, and restoring it would store 1 in the
/// EEPROM of all four data sets, handing the drive to the bus for good; who controls the drive
/// (contacts, bus, keypad) is set on purpose, not restored.
pub const NOT_RESTORED: &[u16] = &[
    param::BAUD_RATE,
    param::PROGRAM,
    param::PROTOCOL,
    param::CONTROL_WORD,
    param::LOCAL_REMOTE,
    param::FREQUENCY_RAM,
    param::PERCENTAGE_RAM,
    param::PARITY,
    param::ADDRESS,
];

/// The target of parameter `number` (in the table or raw) in data set `dataset`.
pub fn target(number: u16, dataset: u8) -> Result<Target, ClientError> {
    let mut t = Target::resolve(Family::Bonfiglioli, &number.to_string(), RAW_INDICES)
        .map_err(|e| ClientError::Request(e.to_string()))?;
    t.sub = u16::from(dataset);
    Ok(t)
}

/// How the width of a parameter without a data type is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnknownWidth {
    /// Refuse: the caller must give the width.
    Refuse,
    /// Try FC 3 and fall back to FC 100 when the drive says the type does not match (the
    /// manual's advice; for a backup or a restore, which say so).
    Probe,
}

/// What [`BonfiglioliClient::find_variant`] knows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VariantFound {
    /// The drive's address.
    pub address: u8,
    /// ACT or ACU, and how it is known; `None` when the drive shows neither.
    pub variant: Option<KnownVariant>,
    /// When the drive was asked just now: what it showed, for a person (`None`: the variant
    /// was given, or found before).
    pub why: Option<String>,
}

/// The Modbus driver as a [`ParamClient`]: one drive at one address.
#[derive(Debug)]
pub struct BonfiglioliClient<'a, IO> {
    driver: &'a mut ModbusDriver<IO>,
    address: Address,
    port: String,
    /// The width given for every parameter without a data type.
    width: Option<Width>,
    unknown: UnknownWidth,
    /// Widths given or found by probing, per parameter number.
    probed: HashMap<u16, Width>,
    key: Option<String>,
    /// ACT or ACU, once given or found ([`BonfiglioliClient::find_variant`]).
    variant: Option<KnownVariant>,
    /// The value a link setting held before it was written, when it could be read: what the
    /// write changes for the link ([`ParamClient::follow_link_change`]).
    link_before: Option<(u16, i64)>,
    /// What reaches the drive once a link setting's new value applies, as the front end says it
    /// (the hint of the link-change note).
    link_reach: Option<String>,
    /// Whose words name what a message points at.
    front: &'static dyn FrontEnd,
}

impl<'a, IO: CharIo> BonfiglioliClient<'a, IO> {
    /// The drive at `address` behind `driver` on the port named `port`; `width` is the width of
    /// every parameter without a data type in the table (`None`: see [`UnknownWidth`]).
    pub fn new(
        driver: &'a mut ModbusDriver<IO>,
        address: Address,
        port: &str,
        width: Option<Width>,
    ) -> Self {
        Self {
            driver,
            address,
            port: port.to_owned(),
            width,
            unknown: UnknownWidth::Refuse,
            probed: HashMap::new(),
            key: None,
            variant: None,
            link_before: None,
            link_reach: None,
            front: &Plain,
        }
    }

    /// The widths of parameters without a data type, by parameter number, as the caller
    /// knows them (the gateway's `width` key).
    #[must_use]
    pub fn with_widths(mut self, widths: impl IntoIterator<Item = (u16, Width)>) -> Self {
        self.probed.extend(widths);
        self
    }

    /// What reaches the drive after the link-setting write this client makes, in the front
    /// end's words (a command to paste), for the note that says what changes.
    #[must_use]
    pub fn reaching_with(mut self, reach: Option<String>) -> Self {
        self.link_reach = reach;
        self
    }

    /// Messages name what they point at in `front`'s words, and the notes of
    /// [`ParamClient::identify`] go to it.
    #[must_use]
    pub fn with_front_end(mut self, front: &'static dyn FrontEnd) -> Self {
        self.front = front;
        self
    }

    /// The variant the caller knows (none: ask the drive where it matters).
    #[must_use]
    pub fn given(mut self, variant: Option<Variant>) -> Self {
        self.variant = variant.map(|variant| KnownVariant {
            variant,
            from: "given",
        });
        self
    }

    /// Find the width of parameters without a data type by trying (backup, restore).
    #[must_use]
    pub fn probing(mut self) -> Self {
        self.unknown = UnknownWidth::Probe;
        self
    }

    /// The drive's address (it follows a written address 1376).
    pub fn address(&self) -> Address {
        self.address
    }

    /// The drive's variant: the one given, else found by asking the drive once (see
    /// [`Variant`]: its status word's bit 4, then a read of 484), with what it showed.
    pub async fn find_variant(&mut self) -> Result<VariantFound, ClientError> {
        if self.variant.is_some() {
            return Ok(VariantFound {
                address: self.address.get(),
                variant: self.variant,
                why: None,
            });
        }
        let word = self
            .driver
            .read(self.address, param::STATUS_WORD, DataSet::ALL, Width::Word)
            .await
            .map_err(|e| client_error(Width::Word, e, self.front))?;
        let (found, why) = match Variant::of_status_word(word as u16) {
            Some(v) => (
                Some((v, "status word bit 4")),
                format!(
                    "its status word 411 = 0x{:04X} has bit 4 (mains voltage) set, which an ACT \
                     never sets (manual ch. 9.1.3)",
                    word as u16
                ),
            ),
            None => match self
                .driver
                .read(
                    self.address,
                    param::FREQUENCY_RAM,
                    DataSet::ALL,
                    Width::Long,
                )
                .await
            {
                Ok(_) => (
                    Some((Variant::Act, "484 readable")),
                    "it answers a read of 484, which an ACTIVE Cube refuses (manual ch. 10.2.3)"
                        .to_owned(),
                ),
                Err(DriverError::Device { exception, vabus }) => {
                    match Variant::of_484_read(false, vabus) {
                        Some(v) => (
                            Some((v, "484 not readable")),
                            "it refuses to read 484 (VABus error 3, not readable), as only an \
                             ACTIVE Cube does (manual ch. 10.2.3)"
                                .to_owned(),
                        ),
                        None => (
                            None,
                            format!(
                                "its status word has bit 4 clear and a read of 484 was refused \
                                 ({})",
                                DriverError::Device { exception, vabus }
                            ),
                        ),
                    }
                }
                Err(e) => return Err(client_error(Width::Long, e, self.front)),
            },
        };
        self.variant = found.map(|(variant, from)| KnownVariant { variant, from });
        Ok(VariantFound {
            address: self.address.get(),
            variant: self.variant,
            why: Some(why),
        })
    }

    /// What `target` held before this client wrote it, if that was read.
    fn before_of(&self, target: &Target) -> Option<i64> {
        self.link_before
            .filter(|(index, _)| *index == target.index)
            .map(|(_, raw)| raw)
    }

    /// Read what the link setting `target` holds now, so that its write can say what changes
    /// (nothing, when the value is the same). A refused read leaves it unknown.
    pub async fn remember_link_setting(&mut self, target: &Target) -> Result<(), ClientError> {
        self.link_before = match self.read(target).await {
            Ok(raw) => Some((target.index, raw)),
            Err(ClientError::Device(_)) => None,
            Err(e) => return Err(e),
        };
        Ok(())
    }

    /// Parameters whose width was given per parameter or found by trying.
    pub fn probed(&self) -> usize {
        self.probed.len()
    }

    /// The width `t` is accessed with: the table's, the one given, or the one found; `None`
    /// while unknown.
    pub fn width_of(&self, t: &Target) -> Option<Width> {
        table_width(t, self.width).or_else(|| self.probed.get(&t.index).copied())
    }

    async fn read_width(&mut self, t: &Target, width: Width) -> Result<u32, DriverError> {
        let ds = data_set(t.sub);
        self.driver.read(self.address, t.index, ds, width).await
    }
}

/// The data set of a target's sub-index (0–9; anything else is all four).
fn data_set(sub: u16) -> DataSet {
    u8::try_from(sub)
        .ok()
        .and_then(DataSet::new)
        .unwrap_or(DataSet::ALL)
}

/// The width of `t`: `given` when given, else the table's data type; `None` where the manual
/// gives none.
pub fn table_width(t: &Target, given: Option<Width>) -> Option<Width> {
    given.or_else(|| match profile::by_index(t.index).map(|p| p.data_type) {
        Some(DataType::UInt | DataType::Int) => Some(Width::Word),
        Some(DataType::Long) => Some(Width::Long),
        _ => None,
    })
}

/// Why `t` cannot be accessed without its width: the manual gives it no data type; the widths
/// to give are named in `front`'s words.
pub fn unknown_width(t: &Target, front: &dyn FrontEnd) -> String {
    let way = match (
        front.name(Setting::Width(Width::Word)),
        front.name(Setting::Width(Width::Long)),
    ) {
        (Some(word), Some(long)) => {
            format!("add {word} (16 bit, FC 3/6) or {long} (32 bit, FC 100/101)")
        }
        _ => "its width must be given, 16 bit (FC 3/6) or 32 bit (FC 100/101)".to_owned(),
    };
    format!(
        "the manual gives no data type for {}{}: {way}; nothing is guessed",
        t.label(),
        t.param
            .map_or_else(String::new, |p| format!(" {}", p.name_en()))
    )
}

/// A raw value of the bus data: signed where the parameter's range goes below zero (or the
/// table does not know it), 16-bit values sign-extended from 16 bits.
pub fn raw_of(t: &Target, width: Width, data: u32) -> i64 {
    let signed = t
        .param
        .and_then(|p| p.raw_range())
        .is_none_or(|(lo, _)| lo < 0);
    match (width, signed) {
        (Width::Word, true) => i64::from(data as u16 as i16),
        (Width::Word, false) => i64::from(data as u16),
        (Width::Long, true) => i64::from(data as i32),
        (Width::Long, false) => i64::from(data),
    }
}

/// The bus data of a raw value for `width`, or `None` when it does not fit.
pub fn data_of(width: Width, raw: i64) -> Option<u32> {
    match width {
        Width::Word => (-32768..=65535).contains(&raw).then_some(raw as u16 as u32),
        Width::Long => (i64::from(i32::MIN)..=i64::from(u32::MAX))
            .contains(&raw)
            .then_some(raw as u32),
    }
}

/// Whether a refusal says the access had the wrong width: exception 2 (the manual: "data type
/// does not match"), or exception 4 with VABus 14 or 10.
fn wrong_width(e: &DriverError) -> bool {
    match e {
        DriverError::Device { exception, vabus } => {
            *exception == ExceptionCode::ILLEGAL_DATA_ADDRESS
                || (*exception == ExceptionCode::SLAVE_DEVICE_FAILURE
                    && matches!(vabus, Some(10 | 14)))
        }
        _ => false,
    }
}

/// The client error of a driver error of an access with `width` (the caller names the
/// parameter); the way out of a refusal is named in `front`'s words.
pub fn client_error(width: Width, e: DriverError, front: &dyn FrontEnd) -> ClientError {
    let DriverError::Device { exception, vabus } = &e else {
        return match e {
            DriverError::Link(l) => ClientError::link(l.fault(), l.to_string()),
            other => ClientError::Request(other.to_string()),
        };
    };
    let (exception, vabus) = (*exception, *vabus);
    let kind = match vabus {
        // Unknown parameter; not readable (write-only, 484/524 on the ACU).
        Some(11 | 3) => DeviceErrorKind::Absent,
        _ => DeviceErrorKind::Refused,
    };
    let hint = if wrong_width(&e) {
        let (bits, other) = match width {
            Width::Word => (16, Width::Long),
            Width::Long => (32, Width::Word),
        };
        format!(
            " (the drive says it is not {bits}-bit{})",
            front
                .name(Setting::Width(other))
                .map_or_else(String::new, |w| format!(": try {w}"))
        )
    } else if vabus == Some(9) {
        format!(
            " (data set 0 reads only where the four data sets hold the same value{})",
            front
                .name(Setting::DataSet)
                .map_or_else(String::new, |w| format!(": give {w} 1, 2, 3 or 4"))
        )
    } else {
        String::new()
    };
    ClientError::Device(DeviceError {
        kind,
        code: DeviceCode::Modbus {
            exception: exception.0,
            vabus,
        },
        message: format!("{e}{hint}"),
    })
}

/// What writing `raw` to the link setting `target` does to the link of the drive at `address`,
/// which held `before` (if known): nothing when it is the same; a baud rate or parity from the
/// next reset (34 = 123) or power cycle on (ch. 5.2.1); a protocol or an address at once
/// (ch. 5.2.2, 6); with what reaches the drive then: `reach` (a front end's command), else the
/// setting in `front`'s words.
pub fn link_change_text(
    target: &Target,
    raw: i64,
    address: Address,
    before: Option<i64>,
    reach: Option<&str>,
    front: &dyn FrontEnd,
) -> String {
    // ": then use --baud 19200", ": `drivectl … status`", or nothing.
    let then = |lead: &str, setting: Setting| {
        reach
            .map(|cmd| format!("`{cmd}`"))
            .or_else(|| front.name(setting).map(|w| format!("use {w}")))
            .map_or_else(String::new, |way| format!("{lead}{way}"))
    };
    let text = |raw: i64| {
        target
            .param
            .map_or_else(|| raw.to_string(), |p| physical_text(p, raw))
    };
    let value = text(raw);
    if before == Some(raw) {
        return format!(
            "{} already holds {value}: nothing changes for the link",
            target.label()
        );
    }
    // A baud rate or parity stays until the reset; a protocol changes at once.
    let until = before.map_or_else(String::new, |b| format!(" (until then {})", text(b)));
    let was = before.map_or_else(String::new, |b| format!(" (it held {})", text(b)));
    const AFTER_RESET: &str = "after the next reset (34 = 123) or power cycle (manual ch. 5.2.1)";
    match target.index {
        param::ADDRESS => format!(
            "the drive answers at address {raw} from now on, no longer at {}{}",
            address.get(),
            then(": ", Setting::Address(raw))
        ),
        param::BAUD_RATE => match profile::link::baud_of_code(raw) {
            Some(baud) => format!(
                "the drive talks at {baud} baud {AFTER_RESET}{until}{}",
                then(": then ", Setting::Baud(baud))
            ),
            None => format!("{value} is not a baud rate of the drive (1–6)"),
        },
        param::PARITY => match profile::link::parity_of_code(raw) {
            Some(parity) => format!(
                "the drive uses parity {parity} {AFTER_RESET}{until}{}",
                then(": then ", Setting::Parity(parity))
            ),
            None => format!("{value} is not a parity of the drive (0–2)"),
        },
        param::PROTOCOL => match u16::try_from(raw).ok() {
            Some(profile::link::PROTOCOL_RTU) => format!(
                "the drive speaks Modbus RTU from now on (effective at once, ch. 6){was}{}",
                then(": ", Setting::Mode(Mode::Rtu))
            ),
            Some(profile::link::PROTOCOL_ASCII) => format!(
                "the drive speaks Modbus ASCII from now on (effective at once, ch. 6){was}{}",
                then(": ", Setting::Mode(Mode::Ascii))
            ),
            _ => format!(
                "the drive stops speaking Modbus at once ({value}, ch. 6): no Modbus master \
                 reaches it any more; set 395 back to 2 or 3 with the KP500 keypad (ch. 5.1)"
            ),
        },
        param::WATCHDOG if raw == 0 => "the drive will no longer watch the link (413 = 0): \
             a master that stops leaves it running"
            .to_owned(),
        _ => format!(
            "the drive will trip when no valid request arrives for {value} (413 watchdog){was}"
        ),
    }
}

impl<IO: CharIo> ParamClient for BonfiglioliClient<'_, IO> {
    fn family(&self) -> Family {
        Family::Bonfiglioli
    }

    fn stale_bytes(&self) -> u64 {
        self.driver.stats().stale
    }

    async fn drive_key(&mut self) -> Result<String, ClientError> {
        if let Some(k) = &self.key {
            return Ok(k.clone());
        }
        let key = format!("{} {}", canonical_port(&self.port), self.address.get());
        self.key = Some(key.clone());
        Ok(key)
    }

    fn link_settings(&self) -> &'static [u16] {
        LINK_SETTINGS
    }

    fn link_change(&self, target: &Target, raw: i64) -> String {
        link_change_text(
            target,
            raw,
            self.address,
            self.before_of(target),
            self.link_reach.as_deref(),
            self.front,
        )
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        let note = self.link_change(target, raw);
        if target.index == param::ADDRESS
            && let Some(a) = u8::try_from(raw).ok().and_then(Address::new)
        {
            self.address = a;
            self.key = None;
        }
        note
    }

    fn not_restored(&self) -> &'static [u16] {
        NOT_RESTORED
    }

    fn device(&self) -> Device {
        self.variant
            .map_or_else(Device::default, |k| Device::bonfiglioli(k.variant, k.from))
    }

    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        let width = match self.width_of(target) {
            Some(w) => w,
            None if self.unknown == UnknownWidth::Probe => {
                match self.read_width(target, Width::Word).await {
                    Ok(v) => {
                        self.probed.insert(target.index, Width::Word);
                        return Ok(raw_of(target, Width::Word, v));
                    }
                    Err(e) if wrong_width(&e) => {
                        let v = self
                            .read_width(target, Width::Long)
                            .await
                            .map_err(|e| client_error(Width::Long, e, self.front))?;
                        self.probed.insert(target.index, Width::Long);
                        return Ok(raw_of(target, Width::Long, v));
                    }
                    Err(e) => return Err(client_error(Width::Word, e, self.front)),
                }
            }
            None => return Err(ClientError::Request(unknown_width(target, self.front))),
        };
        self.read_width(target, width)
            .await
            .map(|v| raw_of(target, width, v))
            .map_err(|e| client_error(width, e, self.front))
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        let width = self.width_of(target).ok_or_else(|| {
            let give = match (
                self.front.name(Setting::Width(Width::Word)),
                self.front.name(Setting::Width(Width::Long)),
            ) {
                (Some(word), Some(long)) => format!("; add {word} or {long}"),
                _ => String::new(),
            };
            ClientError::Request(format!(
                "the width of {} is not known{give}",
                target.label()
            ))
        })?;
        let data = data_of(width, raw).ok_or_else(|| {
            ClientError::Request(format!(
                "value {raw} does not fit {} bits; nothing was sent",
                if width == Width::Word { 16 } else { 32 }
            ))
        })?;
        let ram_only = target
            .param
            .is_some_and(|_| profile::by_index(target.index).is_some_and(|p| p.ram_only));
        // RAM only: the twin data set (+5) of a stored one; parameters kept in RAM anyway
        // (410, 484, 524) are written where they are.
        let ds = match (persistence, target.sub) {
            (Persistence::Volatile, d @ 0..=4) if !ram_only => d + 5,
            (_, d) => d,
        };
        self.driver
            .write(self.address, target.index, data_set(ds), width, data)
            .await
            .map_err(|e| client_error(width, e, self.front))
    }

    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        // The manual defines no device type or firmware parameter: the configuration (30)
        // identifies the drive's function as far as the bus can tell.
        let t = target(param::CONFIGURATION, 0)?;
        let configuration = match self.read(&t).await {
            Ok(v) => Value::from(v),
            Err(ClientError::Device(_)) => Value::Null,
            Err(e) => return Err(e),
        };
        let found = self.find_variant().await?;
        if let Some(why) = &found.why {
            self.front.note(&Note::Variant {
                address: found.address,
                variant: found.variant,
                why,
            });
        }
        let variant = found.variant;
        let mut m = Map::new();
        m.insert("address".into(), self.address.get().into());
        m.insert("device_type".into(), Value::Null);
        m.insert("firmware".into(), Value::Null);
        m.insert("configuration".into(), configuration);
        // ACT or ACU (null when the drive shows neither), and how that is known.
        m.insert("variant".into(), variant.map(|k| k.variant.key()).into());
        m.insert("variant_from".into(), variant.map(|k| k.from).into());
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(number: u16) -> Target {
        target(number, 0).unwrap()
    }

    #[test]
    fn refusals_and_link_changes_name_no_setting_without_a_front_ends_words() {
        let e = |exception, vabus| DriverError::Device {
            exception: ExceptionCode(exception),
            vabus,
        };
        for (x, v) in [(2, None), (4, Some(9)), (4, Some(14))] {
            let m = client_error(Width::Word, e(x, v), &Plain).to_string();
            assert!(!m.contains("--") && !m.contains("try"), "{m}");
        }
        let m = client_error(Width::Long, e(2, None), &Plain).to_string();
        assert!(m.ends_with("(the drive says it is not 32-bit)"), "{m}");
        let a = Address::new(1).unwrap();
        assert_eq!(
            link_change_text(&t(param::ADDRESS), 5, a, Some(1), None, &Plain),
            "the drive answers at address 5 from now on, no longer at 1"
        );
        let baud = link_change_text(&t(param::BAUD_RATE), 4, a, Some(3), None, &Plain);
        assert!(
            baud.ends_with("(until then 3 (9600 baud))") && !baud.contains("then use"),
            "{baud}"
        );
        // A front end's command to paste reaches the drive whatever its words.
        assert!(
            link_change_text(&t(param::ADDRESS), 5, a, Some(1), Some("status 5"), &Plain)
                .ends_with(": `status 5`")
        );
        let w = unknown_width(&t(415), &Plain);
        assert!(
            w.contains("its width must be given") && !w.contains("--"),
            "{w}"
        );
    }

    #[test]
    fn link_settings_are_the_tables_bus_parameters() {
        for p in LINK_SETTINGS.iter().chain(NOT_RESTORED) {
            assert!(profile::by_index(*p).is_some(), "{p}");
        }
    }
}
