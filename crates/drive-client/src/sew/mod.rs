//! SEW MOVIDRIVE: a drive's parameter channel is the same on RS-485 and on CAN (the same
//! services, return codes and parameter table), so the [`ParamClient`] of a MOVIDRIVE is written
//! once, [`SewClient`] on a [`SewLink`], and each bus gives only its way to the drive:
//! [`movilink::MovilinkLink`] on a serial line, [`sbus::SbusLink`] on a CAN interface.
//!
//! Beside the client: what a drive says about a parameter ([`describe`]: minimum, maximum,
//! default, scale, attributes), and what a process-data session needs to know first (the
//! control word slots, [`control_word_slots`]; the warnings of [`pd_warnings`]; the bus
//! timeout, [`bus_timeout`]).

pub mod movilink;
pub mod sbus;

use std::ops::RangeInclusive;
use std::time::Duration;

pub use drive_profile::sew::SERVICE_ATTEMPTS;
use drive_profile::sew::services::is_transient;
use drive_profile::sew::{AttributeInfo, ControlWord1, ParamChannel, ReturnCode, ScaleInfo, index};
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::client::{ClientError, DeviceCode, DeviceError, DeviceErrorKind, ParamClient};
use crate::front::{FrontEnd, Plain, Setting};
use crate::target::Target;

/// Indices outside the table that may be read and written raw (MOVIDRIVE indices start at
/// 8300; numbers below 1000 are menu numbers).
pub const RAW_INDICES: RangeInclusive<u16> = 1000..=0xFFFF;

/// One MOVIDRIVE's parameter channel over some bus.
#[allow(async_fn_in_trait)]
pub trait SewLink {
    /// Run `request` (a parameter service) on the drive: the answer's data, a refusal of the
    /// drive ([`device_error`]) or a link failure.
    async fn service(&mut self, request: ParamChannel) -> Result<u32, ClientError>;

    /// The bus the drive is on, for the EEPROM-wear log: a serial port's or CAN interface's
    /// canonical name (see [`crate::text::canonical_port`]).
    fn bus_key(&self) -> String;

    /// The drive's own address for the EEPROM-wear log (a point-to-point address is resolved
    /// by asking the drive).
    async fn drive_address(&mut self) -> Result<String, ClientError>;

    /// Indices of the drive's settings for this bus (address, timeouts): writing one needs
    /// confirmation.
    fn link_settings(&self) -> &'static [u16];

    /// Indices a restore over this bus never writes.
    fn not_restored(&self) -> &'static [u16];

    /// What writing `raw` to the link setting `target` does, for a person; what reaches the
    /// drive then is named in `front`'s words.
    fn link_change(&self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String;

    /// The link setting `target` was written with `raw`: follow it where possible.
    fn follow_link_change(&mut self, target: &Target, raw: i64, front: &dyn FrontEnd) -> String {
        self.link_change(target, raw, front)
    }

    /// The drive's address as a number, for `identify`.
    fn address_number(&self) -> u8;

    /// Bytes the bus's driver discarded as stale so far (see [`ParamClient::stale_bytes`]).
    fn stale_bytes(&self) -> u64 {
        0
    }
}

/// The [`ParamClient`] of a MOVIDRIVE on any [`SewLink`]: a service the drive answers with
/// "internal communication error" (6/2) is repeated, as the manual says.
#[derive(Debug)]
pub struct SewClient<L> {
    /// The way to the drive.
    pub link: L,
    /// The drive's key for the EEPROM-wear log, once known.
    key: Option<String>,
    /// Whose words name what a message points at.
    front: &'static dyn FrontEnd,
}

impl<L> SewClient<L> {
    /// The client of the drive behind `link`.
    pub fn new(link: L) -> Self {
        Self {
            link,
            key: None,
            front: &Plain,
        }
    }

    /// Messages name what reaches the drive in `front`'s words.
    #[must_use]
    pub fn with_front_end(mut self, front: &'static dyn FrontEnd) -> Self {
        self.front = front;
        self
    }
}

/// What a SEW return code means for a client.
pub fn device_error_kind(code: ReturnCode) -> DeviceErrorKind {
    if [
        ReturnCode::ILLEGAL_INDEX,
        ReturnCode::NOT_IMPLEMENTED,
        ReturnCode::OPTION_CARD_MISSING,
    ]
    .contains(&code)
    {
        DeviceErrorKind::Absent
    } else if is_transient(code) {
        DeviceErrorKind::Transient
    } else {
        DeviceErrorKind::Refused
    }
}

/// The client error of a drive's refusal `code`, with `message` for a person.
pub fn device_error(code: ReturnCode, message: String) -> ClientError {
    ClientError::Device(DeviceError {
        kind: device_error_kind(code),
        code: DeviceCode::Sew(code),
        message,
    })
}

/// The 32-bit data of a raw value (it has passed the width check: signed or unsigned 32 bits).
pub fn data_of(raw: i64) -> u32 {
    raw as u32
}

/// A raw value of 32-bit data: signed where the parameter's range goes below zero, else
/// unsigned (as the drive reads it); signed outside the table.
pub fn raw_of(t: &Target, data: u32) -> i64 {
    match t.param.map(|p| p.wire_range()) {
        Some((lo, _)) if lo >= 0 => i64::from(data),
        _ => i64::from(data as i32),
    }
}

/// The write service of `raw` to `index`: RAM only, or RAM and EEPROM.
pub fn write_service(index: u16, raw: i64, persistence: Persistence) -> ParamChannel {
    let data = data_of(raw);
    match persistence {
        Persistence::Volatile => ParamChannel::write_volatile(index, data),
        Persistence::NonVolatile => ParamChannel::write(index, data),
    }
}

impl<L: SewLink> SewClient<L> {
    /// `request`, repeated while the drive answers "internal communication error", at most
    /// [`SERVICE_ATTEMPTS`] times in all (drive-profile's rule of every SEW bus,
    /// [`ParamServices::service_repeated`](drive_profile::sew::ParamServices::service_repeated)).
    async fn service(&mut self, request: ParamChannel) -> Result<u32, ClientError> {
        let mut attempts = 0;
        loop {
            attempts += 1;
            match self.link.service(request).await {
                // The manual: "repeat the read or write service".
                Err(ClientError::Device(d))
                    if d.kind == DeviceErrorKind::Transient && attempts < SERVICE_ATTEMPTS => {}
                done => return done,
            }
        }
    }
}

impl<L: SewLink> ParamClient for SewClient<L> {
    fn family(&self) -> Family {
        Family::Movidrive
    }

    async fn drive_key(&mut self) -> Result<String, ClientError> {
        if let Some(k) = &self.key {
            return Ok(k.clone());
        }
        let address = self.link.drive_address().await?;
        let key = format!("{} {address}", self.link.bus_key());
        self.key = Some(key.clone());
        Ok(key)
    }

    fn link_settings(&self) -> &'static [u16] {
        self.link.link_settings()
    }

    fn stale_bytes(&self) -> u64 {
        self.link.stale_bytes()
    }

    fn link_change(&self, target: &Target, raw: i64) -> String {
        self.link.link_change(target, raw, self.front)
    }

    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        let before = self.link.address_number();
        let note = self.link.follow_link_change(target, raw, self.front);
        if self.link.address_number() != before {
            self.key = None;
        }
        note
    }

    fn not_restored(&self) -> &'static [u16] {
        self.link.not_restored()
    }

    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        let data = self.service(ParamChannel::read(target.index)).await?;
        Ok(raw_of(target, data))
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        self.service(write_service(target.index, raw, persistence))
            .await
            .map(drop)
    }

    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        let device_type = self.service(ParamChannel::read(index::UNIT_TYPE)).await?;
        let firmware = self.service(ParamChannel::read(index::FIRMWARE)).await?;
        let mut m = Map::new();
        m.insert("address".into(), self.link.address_number().into());
        m.insert("device_type".into(), device_type.into());
        m.insert("firmware".into(), firmware.into());
        Ok(m)
    }
}

/// What the drive says about a parameter beside its value ([`describe`]); data as the drive
/// sent it ([`raw_of`] makes raw values of them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Description {
    /// The minimum.
    pub minimum: u32,
    /// The maximum.
    pub maximum: u32,
    /// The factory setting.
    pub default: u32,
    /// Size and conversion index.
    pub scale: ScaleInfo,
    /// Access attributes and the next index.
    pub attribute: AttributeInfo,
    /// The value the drive holds.
    pub current: u32,
}

/// Ask the drive about `index`: minimum, maximum, default, scale, attributes and its value, in
/// that order, one service each.
pub async fn describe<L: SewLink>(link: &mut L, index: u16) -> Result<Description, ClientError> {
    let minimum = link.service(ParamChannel::read_minimum(index)).await?;
    let maximum = link.service(ParamChannel::read_maximum(index)).await?;
    let default = link.service(ParamChannel::read_default(index)).await?;
    let scale = ScaleInfo::from_data(link.service(ParamChannel::read_scale(index)).await?);
    let attribute =
        AttributeInfo::from_data(link.service(ParamChannel::read_attribute(index)).await?);
    let current = link.service(ParamChannel::read(index)).await?;
    Ok(Description {
        minimum,
        maximum,
        default,
        scale,
        attribute,
        current,
    })
}

/// Per process output word (the first `words`, at most 3): whether the drive takes it as a
/// control word (its setpoint description P870–P872 is 9, control word 1, or 10, control word
/// 2), or why the description could not be read.
pub async fn control_word_slots<L: SewLink>(
    link: &mut L,
    words: usize,
) -> Vec<Result<bool, ClientError>> {
    let mut slots = Vec::new();
    for i in [index::PO1_DESCRIPTION, 8305, 8306].into_iter().take(words) {
        slots.push(
            link.service(ParamChannel::read(i))
                .await
                .map(|d| matches!(d, 9 | 10)),
        );
    }
    slots
}

/// `words` with the command `cmd` in the low byte of every control word slot (its high byte
/// kept): the stop telegram at the end of process data.
pub fn with_command(words: &[u16], slots: &[usize], cmd: ControlWord1) -> Vec<u16> {
    let mut w = words.to_vec();
    for &i in slots {
        if let Some(x) = w.get_mut(i) {
            *x = (*x & 0xFF00) | cmd.bits();
        }
    }
    w
}

/// Before process data: the control word slots among the process output words, and the
/// warnings a person should see: no control word (when `stopping`: the drive cannot be stopped
/// over process data at the end), the bus's timeout (`timeout`: P812 RS-485, P815 SBus, with its
/// name) 0 (off), P876 PO data enable off. A parameter the drive does not answer gets a warning,
/// not an error: the session itself says what is wrong. What leaves a running motor running is
/// named in `front`'s words.
pub async fn pd_warnings<L: SewLink>(
    link: &mut L,
    words: usize,
    stopping: bool,
    timeout: (u16, &str),
    front: &dyn FrontEnd,
) -> (Vec<usize>, Vec<String>) {
    let mut warnings = Vec::new();
    let mut slots = Vec::new();
    for (slot, r) in control_word_slots(link, words)
        .await
        .into_iter()
        .enumerate()
    {
        match r {
            Ok(true) => slots.push(slot),
            Ok(false) => {}
            Err(e) => warnings.push(format!(
                "cannot read the setpoint description of PO{} ({e})",
                slot + 1
            )),
        }
    }
    if stopping && slots.is_empty() {
        warnings.push(
            "no process output word of this drive is a control word (P870–P872): it cannot be \
             stopped over process data at the end"
                .to_owned(),
        );
    }
    let (timeout_index, timeout_name) = timeout;
    match link.service(ParamChannel::read(timeout_index)).await {
        Ok(0) => warnings.push(format!(
            "the drive's {timeout_name} is 0 (off): it keeps running when the master goes quiet{}",
            if stopping {
                String::new()
            } else {
                front
                    .name(Setting::KeepRunning)
                    .map_or_else(String::new, |w| format!(" (and {w} leaves it running)"))
            }
        )),
        Ok(_) => {}
        Err(e) => warnings.push(format!("cannot read the {timeout_name} ({e})")),
    }
    if let Ok(0) = link
        .service(ParamChannel::read(index::PO_DATA_ENABLE))
        .await
    {
        warnings
            .push("P876 PO data enable is off: the drive ignores process output data".to_owned());
    }
    (slots, warnings)
}

/// The bus timeout at `index` (P812, P815: milliseconds in the drive), `None` when it is off
/// (0, and for P815 also 650 s, the manual: "no monitoring") or unreadable.
pub async fn bus_timeout<L: SewLink>(link: &mut L, index: u16) -> Option<Duration> {
    match link.service(ParamChannel::read(index)).await {
        Ok(0) => None,
        Ok(650_000) if index == index::SBUS_TIMEOUT => None,
        Ok(ms) => Some(Duration::from_millis(u64::from(ms))),
        Err(_) => None,
    }
}

#[cfg(test)]
mod tests;
