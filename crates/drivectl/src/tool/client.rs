//! Parameters by their table entry: the [`ParamClient`] trait every protocol implements, and
//! how the command line names parameters and values.

use std::ops::RangeInclusive;

use ctt2_uss::uss::pkw::{Ind, IndLayout};
use drive_profile::family::{self, AnyParam};
use drive_profile::guard;
use drive_profile::{Family, ParamMeta, Persistence};
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

    /// A name of the drive for the EEPROM-wear log: the canonical port path (symlinks and `//`
    /// resolved, see [`canonical_port`]) and the address the drive really has (a point-to-point
    /// address is resolved by asking the drive), so that no second way to the same drive
    /// starts a fresh log.
    async fn drive_key(&mut self) -> std::result::Result<String, ClientError>;

    /// Indices of the drive's own settings for the link this client talks over (address,
    /// baud rate, timeouts): writing one needs confirmation.
    fn link_settings(&self) -> &'static [u16] {
        &[]
    }

    /// What writing `raw` to the link setting `target` does to the link, for a person (e.g.
    /// "the drive will answer at address 5 (--addr 5)").
    fn link_change(&self, target: &Target, raw: i64) -> String {
        format!(
            "writing {raw} to {} changes how the drive is reached",
            target.label()
        )
    }

    /// The link setting `target` was just written with `raw`: follow it where the client can
    /// (talk to the new address from now on) and say where the drive answers now.
    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        self.link_change(target, raw)
    }

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

    /// What is known of the drive beyond the table, for the meaning of its values (a
    /// Bonfiglioli drive's variant decodes its status word): nothing by default.
    fn device(&self) -> super::meaning::Device {
        super::meaning::Device::default()
    }

    /// Bytes the link discarded so far because they arrived before a request had left the
    /// port (an answer an earlier program left there, a late answer): never taken as an
    /// answer, reported by [`crate::tool::stale::note_stale`].
    fn stale_bytes(&self) -> u64 {
        0
    }
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
        let name = self.param.map_or_else(
            || format!("index {}", self.index),
            |p| p.label().to_string(),
        );
        // A Bonfiglioli data set other than 0 (all four) is part of the name.
        if self.family == Family::Bonfiglioli && self.sub != 0 {
            format!("{name} data set {}", self.sub)
        } else if self.family == Family::Nord {
            // NORD: the array element and the parameter set of the IND word (`P543 [-02]`,
            // `P102 set 3`).
            let (element, set) = nord_sub_parts(self.index, self.sub);
            let mut label = name;
            if self.param.is_none() && self.sub != 0 {
                label.push_str(&format!(" IND 0x{:04X}", self.sub));
            }
            if let Some(e) = element {
                label.push_str(&format!(" [-{e:02}]"));
            }
            if let Some(s) = set {
                label.push_str(&format!(" set {s}"));
            }
            label
        } else {
            name
        }
    }

    /// The selector of the parameter as JSON, in the words of the family's manual: `null`
    /// where the parameter has none (SEW, a NORD parameter without sets or elements, a
    /// Bonfiglioli parameter without data sets), else an object with what applies — NORD
    /// `{"set": 2}`, `{"array": 2}` (1-based, [-02] = 2) and the IND word sent
    /// (`"ind": "0x0100"`); Bonfiglioli `{"dataset": 2}` (0 = all four, 5–9 the RAM twins).
    pub fn selector_json(&self) -> Value {
        match self.family {
            Family::Nord => {
                let (element, set) = nord_sub_parts(self.index, self.sub);
                if element.is_none() && set.is_none() && self.sub == 0 {
                    return Value::Null;
                }
                let mut m = Map::new();
                if let Some(s) = set {
                    m.insert("set".into(), s.into());
                }
                if let Some(e) = element {
                    m.insert("array".into(), e.into());
                }
                m.insert("ind".into(), format!("0x{:04X}", self.sub).into());
                Value::Object(m)
            }
            Family::Bonfiglioli => {
                let has_sets = drive_profile::bonfiglioli::by_index(self.index)
                    .filter(|_| self.param.is_some())
                    .is_none_or(|p| p.data_set != Some(false));
                if !has_sets && self.sub == 0 {
                    return Value::Null;
                }
                let mut m = Map::new();
                m.insert("dataset".into(), self.sub.into());
                Value::Object(m)
            }
            _ if self.sub != 0 => {
                let mut m = Map::new();
                m.insert("subindex".into(), self.sub.into());
                Value::Object(m)
            }
            _ => Value::Null,
        }
    }

    /// The German and English names of what this target reads: a NORD array element's own
    /// names where the table gives them (P700 [-02] "warning"), else the parameter's.
    pub fn names(&self) -> Option<(&'static str, &'static str)> {
        let p = self.param?;
        if self.family == Family::Nord {
            let (element, _) = nord_sub_parts(self.index, self.sub);
            if let Some(e) = drive_profile::nord::by_index(self.index)
                .and_then(|n| n.element_info(element.unwrap_or(0)))
                .filter(|e| !e.name_en.is_empty())
            {
                return Some((e.name_de, e.name_en));
            }
        }
        Some((p.name_de(), p.name_en()))
    }

    /// The target for a person: its label with the name of what it reads (`P130 Ramp t11 up
    /// CW [s]`, `372 data set 2 Rated speed`, `P700 [-02] present warning`); the label alone
    /// outside the table (`index 9999`).
    pub fn title(&self) -> String {
        match self.names() {
            Some((_, en)) => format!("{} {en}", self.label()),
            None => self.label(),
        }
    }

    /// A message of the table layer (the write guard's, which names a parameter by its table
    /// label: `372 "Rated speed" …`) with this target's label instead, so that it says which
    /// data set, parameter set or array element it is about (`372 data set 2 "Rated
    /// speed" …`).
    pub fn relabel(&self, message: &str) -> String {
        match self.param {
            Some(p) if p.label().as_str() != self.label() => message.replacen(
                &format!("{} \"", p.label()),
                &format!("{} \"", self.label()),
                1,
            ),
            _ => message.to_owned(),
        }
    }

    /// What the family calls the number the bus addresses a parameter by: NORD's PNU, the
    /// others' index.
    pub fn index_word(&self) -> &'static str {
        if self.family == Family::Nord {
            "PNU"
        } else {
            "index"
        }
    }

    /// A client error on this target as the command line says it: the target's label first
    /// (the client's messages do not carry it), then the drive's or the line's words.
    pub fn error(&self, e: ClientError) -> CliError {
        match e {
            ClientError::Device(d) => CliError::failed(format!("{}: {d}", self.label())),
            ClientError::Link(m) => CliError::failed(format!("{}: {m}", self.label())),
        }
    }

    /// Refuse a raw value the parameter's bus width cannot carry (32 bits of either sign
    /// outside the table). Applies to every write, forced or not: nothing is ever cut.
    pub fn check_width(&self, raw: i64) -> Result<()> {
        let (min, max) = match self.param {
            Some(p) => {
                return guard::check_width(p, raw)
                    .map_err(|e| CliError::usage(self.relabel(&super::write::with_hint(&e))));
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

    /// [`Target::value_from_text`] with only `raw` set (tests).
    #[cfg(test)]
    pub fn raw_from_text(&self, value: &str, raw: bool) -> Result<i64> {
        self.value_from_text(
            value,
            &ValueText {
                raw,
                ..ValueText::default()
            },
        )
        .map(|v| v.raw)
    }

    /// The raw value of what the user typed, read as `how` says ([`ValueText`]), and the
    /// rounding that happened: with `raw` (or outside the table) a strict integer; a value name
    /// of the parameter's list; for a selection parameter an integer of its list; else a
    /// number in the parameter's unit, converted within its range (`force`: within the wire
    /// width only) and refused when the parameter cannot hold it exactly unless `round`.
    pub fn value_from_text(&self, value: &str, how: &ValueText) -> Result<Parsed> {
        let exact = |raw| Parsed {
            raw,
            rounded_from: None,
        };
        let Some(p) = self.param.filter(|_| !how.raw) else {
            return parse_int(value).map(exact).ok_or_else(|| {
                let t = value.trim();
                let digits = t.strip_prefix('-').unwrap_or(t);
                if !digits.is_empty() && digits.chars().all(|c| c.is_ascii_digit()) {
                    CliError::usage(format!(
                        "`{value}` is too large for any parameter (a raw value has at most 32 \
                         bits); nothing was sent"
                    ))
                } else {
                    CliError::usage(format!(
                        "`{value}` is not an integer raw value (decimal, 0x hex, a leading - for \
                         negative)"
                    ))
                }
            });
        };
        let t = value.trim();
        if let Some(v) = p
            .values()
            .iter()
            .find(|v| v.de.eq_ignore_ascii_case(t) || v.en.eq_ignore_ascii_case(t))
        {
            return Ok(exact(v.value));
        }
        let list = || {
            p.values()
                .iter()
                .map(|v| format!("{} ({})", v.value, v.en))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if p.value_list_exhaustive() && !p.values().is_empty() {
            // A selection: one of its values, by number or name; never a fraction.
            return match parse_int(t) {
                Some(v) if how.force || p.value_name(v).is_some() => Ok(exact(v)),
                _ => Err(CliError::usage(format!(
                    "`{value}` is not a value of {} {}; it takes one of: {}",
                    p.label(),
                    p.name_en(),
                    list()
                ))),
            };
        }
        let Some(x) = parse_decimal(t) else {
            let unit = if p.unit().is_empty() {
                "the parameter's unit"
            } else {
                p.unit()
            };
            let names = if p.values().is_empty() {
                String::new()
            } else {
                format!(" or a value name ({})", list())
            };
            return Err(CliError::usage(format!(
                "`{value}` is not a number in {unit}{names}; give the value in the parameter's \
                 unit (1.5 or 1,5), or --raw"
            )));
        };
        // A value beyond the bus width is refused as such first: --force cannot send it, so
        // it is not offered.
        let forced = forced_raw(p, x);
        let raw = if how.force {
            forced
        } else {
            p.from_physical(x).map_err(|e| match forced {
                Err(wide) => wide,
                Ok(_) => CliError::usage(format!(
                    "{} {}: {e}; --force sends a value outside the table's range",
                    p.label(),
                    p.name_en()
                )),
            })
        }?;
        let held = p.to_physical(raw);
        if (held - x).abs() <= 1e-9 * x.abs().max(1.0) {
            return Ok(exact(raw));
        }
        let held_text = super::output::physical_text(p, raw);
        if !how.round {
            return Err(CliError::usage(format!(
                "{} {} cannot hold {value} exactly: the nearest value it takes is {held_text} \
                 (raw {raw}); write that, or add --round to have it rounded",
                p.label(),
                p.name_en()
            )));
        }
        Ok(Parsed {
            raw,
            rounded_from: Some(x),
        })
    }
}

/// NORD: the IND word (BU 0255 section 4.6.1.2) of array element `element` and parameter set
/// `set` (both 1-based, `None` where the parameter has none) of parameter `pnu`, laid out by
/// `ctt2_uss`'s one rule ([`IndLayout`]): a parameter with parameter sets takes the set in bits
/// 8–9 and an element in bits 10–15; a parameter without sets takes the element as its
/// sub-index in bits 8–15. Outside the table a given set means the first layout. A NORD
/// [`Target::sub`] is this word.
pub fn nord_sub(pnu: u16, element: Option<u8>, set: Option<u8>) -> u16 {
    let layout = if drive_profile::nord::by_index(pnu).is_some() {
        IndLayout::of_pnu(pnu)
    } else if set.is_some() {
        IndLayout::ParameterSets
    } else {
        IndLayout::Subindex
    };
    let zero_based = |v: Option<u8>| v.unwrap_or(1).saturating_sub(1);
    Ind::address(layout, zero_based(element), zero_based(set)).map_or(0, |i| i.0)
}

/// NORD: the array element and parameter set (1-based) of parameter `pnu`'s IND word `sub`,
/// as the table describes the parameter (see [`nord_sub`]). Outside the table the IND bits
/// cannot be told apart: neither is known.
pub fn nord_sub_parts(pnu: u16, sub: u16) -> (Option<u8>, Option<u8>) {
    let Some(p) = drive_profile::nord::by_index(pnu) else {
        return (None, None);
    };
    let array = p.array_len.is_some();
    let (element, set) = Ind(sub).split(IndLayout::of_pnu(pnu), array);
    (
        array.then_some(element + 1),
        p.parameter_set.then_some(set + 1),
    )
}

/// NORD: every IND word of parameter `pnu` in the table: each array element in each parameter
/// set it has (a parameter with neither has just 0).
pub fn nord_subs(pnu: u16) -> Vec<u16> {
    let Some(p) = drive_profile::nord::by_index(pnu) else {
        return vec![0];
    };
    let sets: Vec<Option<u8>> = if p.parameter_set {
        (1..=4).map(Some).collect()
    } else {
        vec![None]
    };
    let elements: Vec<Option<u8>> = p
        .array_len
        .map_or_else(|| vec![None], |n| (1..=n).map(Some).collect());
    elements
        .iter()
        .flat_map(|e| sets.iter().map(move |s| nord_sub(pnu, *e, *s)))
        .collect()
}

/// How a value typed on the command line is read (the `write` options).
#[derive(Debug, Clone, Copy, Default)]
pub struct ValueText {
    /// The text is the raw bus value.
    pub raw: bool,
    /// Convert outside the table's range (within the wire width) and take any integer for a
    /// selection parameter.
    pub force: bool,
    /// Accept a value the parameter cannot hold exactly, rounded to the nearest one it can.
    pub round: bool,
}

/// A value read from the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parsed {
    /// The raw bus value.
    pub raw: i64,
    /// What the user typed, when `raw` is a rounded form of it (`--round`).
    pub rounded_from: Option<f64>,
}

/// A physical value converted without the table's range (`--force`): the family's scaling is
/// linear in the raw value, so two points give it; the result is checked against the wire
/// width only.
fn forced_raw(p: &dyn ParamMeta, x: f64) -> Result<i64> {
    let b = p.to_physical(0);
    let a = p.to_physical(1) - b;
    let (lo, hi) = p.wire_range();
    let r = ((x - b) / a).round();
    if !r.is_finite() || r < lo as f64 || r > hi as f64 {
        let with_unit = |v: f64| {
            if p.unit().is_empty() {
                v.to_string()
            } else {
                format!("{v} {}", p.unit())
            }
        };
        return Err(CliError::usage(format!(
            "{} {}: {} does not fit the parameter's bus width ({} … {}); not even --force \
             sends a value that would be cut",
            p.label(),
            p.name_en(),
            with_unit(x),
            p.to_physical(lo),
            p.to_physical(hi)
        )));
    }
    Ok(r as i64)
}

/// The port path as the EEPROM-wear log keys it: symlinks, `.`/`..` and doubled slashes
/// resolved (`/dev//pts/0`, `/dev/serial/by-id/…` → `/dev/pts/0`, `/dev/ttyUSB0`); the path as
/// given when it cannot be resolved (it was opened, so that is rare).
pub fn canonical_port(path: &str) -> String {
    std::fs::canonicalize(path).map_or_else(|_| path.to_owned(), |p| p.display().to_string())
}

/// Parse an integer strictly: decimal digits or `0x` hex digits, with at most one leading `-`
/// (`--5`, `0x-5`, `+5`, `5 000` and `1e3` are not integers).
pub fn parse_int(s: &str) -> Option<i64> {
    let t = s.trim();
    let (neg, body) = t.strip_prefix('-').map_or((false, t), |b| (true, b));
    let (digits, radix) = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        Some(h) => (h, 16),
        None => (body, 10),
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    // The magnitude as u64, so that i64::MIN (whose magnitude is no i64) parses too.
    let m = u64::from_str_radix(digits, radix).ok()?;
    if neg {
        0i64.checked_sub_unsigned(m)
    } else {
        i64::try_from(m).ok()
    }
}

/// Parse a decimal number strictly: an optional `-`, digits, and an optional fraction after
/// `.` or `,` (a decimal comma, as German drive documentation writes it). No exponent, no
/// `inf`/`NaN`, no thousands separators.
pub fn parse_decimal(s: &str) -> Option<f64> {
    let t = s.trim();
    let body = t.strip_prefix('-').unwrap_or(t);
    let (int, frac) = match body.split_once(['.', ',']) {
        Some((i, f)) => (i, Some(f)),
        None => (body, None),
    };
    let digits = |d: &str| d.chars().all(|c| c.is_ascii_digit());
    let ok = digits(int)
        && frac.is_none_or(|f| digits(f) && !f.is_empty())
        && !(int.is_empty() && frac.is_none());
    if !ok {
        return None;
    }
    t.replace(',', ".").parse().ok()
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
    fn issue7_numbers_are_parsed_strictly() {
        for bad in [
            "--5", "0x-5", "-0x-5", "+5", "", "-", "0x", "5 000", "1e3", "1.0", "٣",
        ] {
            assert_eq!(parse_int(bad), None, "{bad:?}");
        }
        assert_eq!(parse_int(" -5 "), Some(-5));
        assert_eq!(parse_int("0xFFFFFFFF"), Some(0xFFFF_FFFF));
        assert_eq!(parse_int("-9223372036854775808"), Some(i64::MIN));
        assert_eq!(parse_int("9223372036854775808"), None);
        for bad in [
            "--1.5", "1.5.2", "1,5,2", "inf", "NaN", "1e3", ".", "1.", "+1", "1 5", "0x10",
        ] {
            assert_eq!(parse_decimal(bad), None, "{bad:?}");
        }
        assert_eq!(parse_decimal("1,5"), Some(1.5));
        assert_eq!(parse_decimal("-0.25"), Some(-0.25));
        assert_eq!(parse_decimal(".5"), Some(0.5));
        // `--5 --raw` is not +5.
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        assert!(p130.raw_from_text("--5", true).is_err());
        assert_eq!(p130.raw_from_text("1,5", false).unwrap(), 1500);
    }

    #[test]
    fn issue7_selections_take_integers_or_names_and_rounding_is_never_silent() {
        let p700 = Target::resolve(Family::Movidrive, "P700", 1000..=0xFFFF).unwrap();
        let e = p700.raw_from_text("2.5", false).unwrap_err().to_string();
        assert!(
            e.contains("not a value of P700") && e.contains("16 (SERVO)"),
            "{e}"
        );
        let e = p700
            .raw_from_text("servo-ish", false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("it takes one of: 0 ("), "{e}");
        assert_eq!(p700.raw_from_text("16", false).unwrap(), 16);
        assert_eq!(p700.raw_from_text("SERVO", false).unwrap(), 16);
        // 1.25 s lies in P130's 0.1 s steps (1…10 s): refused, named, or rounded when asked.
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        let e = p130.raw_from_text("1.25", false).unwrap_err().to_string();
        assert!(
            e.contains("cannot hold 1.25 exactly") && e.contains("1.30 s (raw 1300)"),
            "{e}"
        );
        let how = ValueText {
            round: true,
            ..ValueText::default()
        };
        assert_eq!(
            p130.value_from_text("1.25", &how).unwrap(),
            Parsed {
                raw: 1300,
                rounded_from: Some(1.25)
            }
        );
        // An address of 0.4 is no address.
        let p810 = Target::resolve(Family::Movidrive, "P810", 1000..=0xFFFF).unwrap();
        assert!(p810.raw_from_text("0.4", false).is_err());
    }

    #[test]
    fn issue7_force_lifts_the_range_of_a_physical_value_but_not_the_width() {
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        assert!(p130.raw_from_text("3000", false).is_err());
        let forced = ValueText {
            force: true,
            ..ValueText::default()
        };
        assert_eq!(
            p130.value_from_text("3000", &forced).unwrap().raw,
            3_000_000
        );
        // Off the steps but on the resolution (1 ms): exact when forced.
        assert_eq!(p130.value_from_text("1.25", &forced).unwrap().raw, 1250);
        let e = p130
            .value_from_text("5000000", &forced)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bus width"), "{e}");
    }

    #[test]
    fn issue18_a_value_wider_than_the_parameter_never_suggests_force() {
        // Bonfiglioli 410 control word: a 16-bit word (0…65535).
        let p410 = Target::resolve(Family::Bonfiglioli, "410", 0..=1599).unwrap();
        for force in [false, true] {
            let how = ValueText {
                force,
                ..ValueText::default()
            };
            let e = p410.value_from_text("65536", &how).unwrap_err().to_string();
            assert!(e.contains("not even --force"), "{e}");
            assert!(!e.contains("or --force") && !e.contains("  "), "{e}");
        }
        // In the width but outside the table's range: --force is the way out.
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        let e = p130.raw_from_text("3000", false).unwrap_err().to_string();
        assert!(e.contains("--force sends a value outside"), "{e}");
        let e = p130
            .raw_from_text("5000000", false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not even --force"), "{e}");
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
