//! Parameters by their table entry: the [`ParamClient`] trait every protocol implements, and
//! how the command line names parameters and values.

use std::ops::RangeInclusive;

use drive_profile::family::{self, AnyParam};
use drive_profile::guard;
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::error::{CliError, Result};

/// Why a client call failed.
#[derive(Debug)]
pub enum ClientError {
    /// The drive answered negatively: the drive is there.
    Device(DeviceError),
    /// The line failed: no answer, garbled answers, the port is gone.
    Link(String),
}

/// A negative answer of the drive, sorted by what a tool does about it (each protocol maps its
/// own codes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceError {
    /// What kind of refusal.
    pub kind: DeviceErrorKind,
    /// The drive's answer, for a person (with the code).
    pub message: String,
}

/// What a negative answer means for the tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeviceErrorKind {
    /// This drive does not have the parameter (unknown index, not implemented, option card
    /// missing): a backup leaves it out.
    Absent,
    /// A passing fault of the drive (e.g. SEW 6/2 "internal communication error: repeat the
    /// service"): the same request may succeed when repeated.
    Transient,
    /// Anything else (value refused, parameter lock, controller inhibit needed, …).
    Refused,
}

impl std::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl From<ClientError> for CliError {
    fn from(e: ClientError) -> Self {
        match e {
            ClientError::Device(d) => CliError::failed(d.message),
            ClientError::Link(m) => CliError::failed(m),
        }
    }
}

/// Read and write parameters of one drive by their table entries: what a protocol gives the
/// tool layer. Values are raw (the family's table scales them).
pub trait ParamClient {
    /// The family whose table the drive's parameters come from.
    fn family(&self) -> Family;

    /// A name of the drive for the EEPROM-wear log: the port and the address.
    fn drive_key(&self) -> String;

    /// Indices a restore never writes (commands, the link's own settings).
    fn not_restored(&self) -> &'static [u16] {
        &[]
    }

    /// The raw value of `target`.
    async fn read(&mut self, target: &Target) -> std::result::Result<i64, ClientError>;

    /// Write raw `raw` to `target` (the value has passed [`Target::check_width`]).
    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> std::result::Result<(), ClientError>;

    /// Fields that identify the drive in a backup (device type, firmware, …).
    async fn identify(&mut self) -> std::result::Result<Map<String, Value>, ClientError>;
}

/// A parameter as named on the command line: its table entry if known, and its bus address.
#[derive(Clone, Copy)]
pub struct Target {
    /// The family.
    pub family: Family,
    /// Bus index (SEW index, NORD PNU, Bonfiglioli parameter number).
    pub index: u16,
    /// Sub-index (array element, data set); 0 where the family has none.
    pub sub: u16,
    /// The table entry, when the index is in the family's table.
    pub param: Option<AnyParam>,
}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Target")
            .field("family", &self.family)
            .field("index", &self.index)
            .field("sub", &self.sub)
            .field("param", &self.param.map(|p| p.label()))
            .finish()
    }
}

impl Target {
    /// The target of a table entry.
    pub fn of(param: AnyParam) -> Self {
        Self {
            family: param.family(),
            index: param.bus_index(),
            sub: param.sub_index().unwrap_or(0),
            param: Some(param),
        }
    }

    /// Resolve what the user typed: the family's parameter keys (`P813`, `813`, `8600`,
    /// `0x2198`), else a plain number in `raw_indices` (raw access to an index outside the
    /// table).
    pub fn resolve(family: Family, key: &str, raw_indices: RangeInclusive<u16>) -> Result<Self> {
        if let Some(p) = family::lookup(family, key) {
            return Ok(Self::of(p));
        }
        let t = key.trim();
        let numeric = t.strip_prefix(['P', 'p']).is_none();
        match parse_int(t).and_then(|v| u16::try_from(v).ok()) {
            Some(v) if numeric && raw_indices.contains(&v) => Ok(Self {
                family,
                index: v,
                sub: 0,
                param: None,
            }),
            _ => Err(CliError::usage(format!(
                "no {family} parameter `{key}`; give a parameter number or a bus index \
                 ({}…{} for raw access); `drivectl params {family} --search NAME` finds it",
                raw_indices.start(),
                raw_indices.end()
            ))),
        }
    }

    /// The label users know the parameter by (`index 9999` outside the table).
    pub fn label(&self) -> String {
        self.param.map_or_else(
            || format!("index {}", self.index),
            |p| p.label().to_string(),
        )
    }

    /// Refuse a raw value the parameter's bus width cannot carry (32 bits of either sign
    /// outside the table). Applies to every write, forced or not: nothing is ever cut.
    pub fn check_width(&self, raw: i64) -> Result<()> {
        let (min, max) = match self.param {
            Some(p) => {
                return guard::check_width(p, raw)
                    .map_err(|e| CliError::usage(super::write::with_hint(&e)));
            }
            None => drive_profile::param::WIRE_32,
        };
        if raw < min || raw > max {
            return Err(CliError::usage(format!(
                "value {raw} does not fit index {}: a parameter carries {min} to {max}; nothing was sent",
                self.index
            )));
        }
        Ok(())
    }

    /// The raw value of what the user typed: a value name of the parameter's list (German or
    /// English), a number in the parameter's unit, or with `raw` (or outside the table) a raw
    /// integer (decimal, `0x` hex, negative).
    pub fn raw_from_text(&self, value: &str, raw: bool) -> Result<i64> {
        let Some(p) = self.param.filter(|_| !raw) else {
            return parse_int(value)
                .ok_or_else(|| CliError::usage(format!("`{value}` is not an integer raw value")));
        };
        if let Some(v) = p
            .values()
            .iter()
            .find(|v| v.de.eq_ignore_ascii_case(value) || v.en.eq_ignore_ascii_case(value))
        {
            return Ok(v.value);
        }
        let x: f64 = value.trim().parse().map_err(|_| {
            CliError::usage(format!(
                "`{value}` is not a number in {}; give the value in the parameter's unit, or --raw",
                if p.unit().is_empty() {
                    "the parameter's unit"
                } else {
                    p.unit()
                }
            ))
        })?;
        p.from_physical(x).map_err(|e| {
            CliError::usage(format!(
                "{} {}: {e}; --raw --force sends a raw value unchecked by the table",
                p.label(),
                p.name_en()
            ))
        })
    }
}

/// Parse an integer given as decimal, `0x` hex or negative decimal.
pub fn parse_int(s: &str) -> Option<i64> {
    let t = s.trim();
    let (neg, body) = t.strip_prefix('-').map_or((false, t), |b| (true, b));
    let v = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        Some(h) => i64::from_str_radix(h, 16).ok()?,
        None => body.parse::<i64>().ok()?,
    };
    if neg { v.checked_neg() } else { Some(v) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_and_values() {
        let t = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        assert_eq!((t.index, t.label()), (8470, "P130".to_owned()));
        assert_eq!(t.raw_from_text("1.5", false).unwrap(), 1500);
        assert_eq!(t.raw_from_text("1500", true).unwrap(), 1500);
        let raw = Target::resolve(Family::Movidrive, "9999", 1000..=0xFFFF).unwrap();
        assert!(raw.param.is_none());
        assert!(Target::resolve(Family::Movidrive, "999", 1000..=0xFFFF).is_err());
        assert!(Target::resolve(Family::Movidrive, "P9999", 1000..=0xFFFF).is_err());
        let p870 = Target::resolve(Family::Movidrive, "P870", 1000..=0xFFFF).unwrap();
        assert_eq!(p870.raw_from_text("control word 1", false).unwrap(), 9);
        assert_eq!(parse_int("-0x10"), Some(-16));
        assert_eq!(parse_int("x"), None);
    }

    #[test]
    fn no_value_is_ever_cut() {
        // 2^40 for an unsigned 32-bit parameter, for an index outside the table, and -1 for an
        // unsigned one: refused, whatever else is forced.
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        assert!(p130.check_width(1 << 40).is_err());
        assert!(p130.check_width(-1).is_err());
        p130.check_width(4_294_967_295).unwrap();
        let raw = Target::resolve(Family::Movidrive, "9999", 1000..=0xFFFF).unwrap();
        assert!(raw.check_width(1 << 40).is_err());
        raw.check_width(-1).unwrap();
        raw.check_width(4_294_967_295).unwrap();
        let e = raw.check_width(4_294_967_296).unwrap_err().to_string();
        assert!(e.contains("nothing was sent"), "{e}");
    }
}
