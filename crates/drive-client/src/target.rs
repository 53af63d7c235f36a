//! A parameter as a front end names it ([`Target`]: the table entry and the selector — NORD
//! parameter set and array element, Bonfiglioli data set), resolved from the family's table,
//! and values read from text for it: value names, selections, physical values scaled and
//! checked against the range and the bus width, never rounded silently.
//!
//! Errors are typed ([`TargetError`], [`ValueError`]) and carry no front end's words: a command
//! line adds its options (`--raw`, `--force`, `--round`), a configuration file its keys.

use std::ops::RangeInclusive;

use ctt2_uss::uss::pkw::{Ind, IndLayout};
use drive_profile::family::{self, AnyParam};
use drive_profile::guard::{self, GuardError};
use drive_profile::{Family, ParamMeta};
use serde_json::{Map, Value};

use crate::text::{parse_decimal, parse_int, physical_text};

/// What a front end named is no parameter.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TargetError {
    /// Neither a parameter key of the family's table nor a bus index for raw access.
    #[error(
        "no {family} parameter `{key}`; give a parameter number or a bus index ({first}…{last} \
         for raw access)"
    )]
    Unknown {
        /// The family.
        family: Family,
        /// What was given.
        key: String,
        /// The first index open to raw access.
        first: u16,
        /// The last index open to raw access.
        last: u16,
    },
}

/// Why a value is none the parameter takes; nothing was sent. A front end adds its way out
/// (the command line: `--raw`, `--force`, `--round`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ValueError {
    /// Digits past any 32-bit raw value.
    #[error(
        "`{text}` is too large for any parameter (a raw value has at most 32 bits); nothing was \
         sent"
    )]
    TooLarge {
        /// The text given.
        text: String,
    },
    /// Not a strict integer where a raw value was asked for.
    #[error("`{text}` is not an integer raw value (decimal, 0x hex, a leading - for negative)")]
    NotAnInteger {
        /// The text given.
        text: String,
    },
    /// Not one of a selection parameter's values.
    #[error("`{text}` is not a value of {param} {name}; it takes one of: {list}")]
    NotInSelection {
        /// The text given.
        text: String,
        /// The parameter's label.
        param: String,
        /// Its English name.
        name: &'static str,
        /// Its values with their names.
        list: String,
    },
    /// Not a number in the parameter's unit (nor a value name).
    #[error(
        "`{text}` is not a number in {unit}{names}; give the value in the parameter's unit (1.5 \
         or 1,5)"
    )]
    NotANumber {
        /// The text given.
        text: String,
        /// The unit, or "the parameter's unit".
        unit: String,
        /// ` or a value name (…)` where the parameter has a value list, else empty.
        names: String,
    },
    /// Outside the table's range.
    #[error("{param} {name}: {reason}")]
    OutOfRange {
        /// The parameter's label.
        param: String,
        /// Its English name.
        name: &'static str,
        /// The scaling's reason.
        reason: String,
    },
    /// A physical value whose raw value does not fit the bus width: never sent.
    #[error("{param} {name}: {value} does not fit the parameter's bus width ({lo} … {hi})")]
    PastWidth {
        /// The parameter's label.
        param: String,
        /// Its English name.
        name: &'static str,
        /// The value with its unit.
        value: String,
        /// The width's lowest physical value.
        lo: f64,
        /// The width's highest physical value.
        hi: f64,
    },
    /// A physical value the parameter cannot hold exactly.
    #[error(
        "{param} {name} cannot hold {text} exactly: the nearest value it takes is {held} (raw \
         {raw})"
    )]
    NotExact {
        /// The parameter's label.
        param: String,
        /// Its English name.
        name: &'static str,
        /// The text given.
        text: String,
        /// The nearest value it takes, with its unit.
        held: String,
        /// Its raw value.
        raw: i64,
    },
    /// A raw value the parameter's bus width cannot carry (the guard's width check, named by
    /// the target's label).
    #[error("{message}")]
    Width {
        /// The guard's refusal.
        error: GuardError,
        /// Its message with the target's label (selector included).
        message: String,
    },
    /// A raw value outside 32 bits for an index outside the table.
    #[error(
        "value {raw} does not fit index {index}: a parameter carries {min} to {max}; nothing \
         was sent"
    )]
    WidthRaw {
        /// The raw value.
        raw: i64,
        /// The index.
        index: u16,
        /// Smallest value a parameter carries.
        min: i64,
        /// Largest.
        max: i64,
    },
}

/// A parameter as a front end names it: its table entry if known, and its bus address.
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

/// Two targets are equal when they name the same parameter the same way: family, index,
/// sub-index and the same table entry (or none).
impl PartialEq for Target {
    fn eq(&self, other: &Self) -> bool {
        self.family == other.family
            && self.index == other.index
            && self.sub == other.sub
            && match (self.param, other.param) {
                (Some(a), Some(b)) => std::ptr::addr_eq(a, b),
                (None, None) => true,
                _ => false,
            }
    }
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
    pub fn resolve(
        family: Family,
        key: &str,
        raw_indices: RangeInclusive<u16>,
    ) -> Result<Self, TargetError> {
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
            _ => Err(TargetError::Unknown {
                family,
                key: key.to_owned(),
                first: *raw_indices.start(),
                last: *raw_indices.end(),
            }),
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

    /// Refuse a raw value the parameter's bus width cannot carry (32 bits of either sign
    /// outside the table). Applies to every write, forced or not: nothing is ever cut.
    pub fn check_width(&self, raw: i64) -> Result<(), ValueError> {
        let (min, max) = match self.param {
            Some(p) => {
                return guard::check_width(p, raw).map_err(|error| ValueError::Width {
                    message: self.relabel(&error.to_string()),
                    error,
                });
            }
            None => drive_profile::param::WIRE_32,
        };
        if raw < min || raw > max {
            return Err(ValueError::WidthRaw {
                raw,
                index: self.index,
                min,
                max,
            });
        }
        Ok(())
    }

    /// [`Target::value_from_text`] with only `raw` set (tests).
    #[cfg(test)]
    pub fn raw_from_text(&self, value: &str, raw: bool) -> Result<i64, ValueError> {
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
    pub fn value_from_text(&self, value: &str, how: &ValueText) -> Result<Parsed, ValueError> {
        let exact = |raw| Parsed {
            raw,
            rounded_from: None,
        };
        let Some(p) = self.param.filter(|_| !how.raw) else {
            return parse_int(value).map(exact).ok_or_else(|| {
                let t = value.trim();
                let digits = t.strip_prefix('-').unwrap_or(t);
                if !digits.is_empty() && digits.chars().all(|c| c.is_ascii_digit()) {
                    ValueError::TooLarge {
                        text: value.to_owned(),
                    }
                } else {
                    ValueError::NotAnInteger {
                        text: value.to_owned(),
                    }
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
                _ => Err(ValueError::NotInSelection {
                    text: value.to_owned(),
                    param: p.label().to_string(),
                    name: p.name_en(),
                    list: list(),
                }),
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
            return Err(ValueError::NotANumber {
                text: value.to_owned(),
                unit: unit.to_owned(),
                names,
            });
        };
        // A value beyond the bus width is refused as such first: --force cannot send it, so
        // it is not offered.
        let forced = forced_raw(p, x);
        let raw = if how.force {
            forced
        } else {
            p.from_physical(x).map_err(|e| match forced {
                Err(wide) => wide,
                Ok(_) => ValueError::OutOfRange {
                    param: p.label().to_string(),
                    name: p.name_en(),
                    reason: e.to_string(),
                },
            })
        }?;
        let held = p.to_physical(raw);
        if (held - x).abs() <= 1e-9 * x.abs().max(1.0) {
            return Ok(exact(raw));
        }
        if !how.round {
            return Err(ValueError::NotExact {
                param: p.label().to_string(),
                name: p.name_en(),
                text: value.to_owned(),
                held: physical_text(p, raw),
                raw,
            });
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
fn forced_raw(p: &dyn ParamMeta, x: f64) -> Result<i64, ValueError> {
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
        return Err(ValueError::PastWidth {
            param: p.label().to_string(),
            name: p.name_en(),
            value: with_unit(x),
            lo: p.to_physical(lo),
            hi: p.to_physical(hi),
        });
    }
    Ok(r as i64)
}

#[cfg(test)]
#[path = "target_tests.rs"]
mod tests;
