//! The write guard (feature `std`): checks a parameter write against the family's table before
//! it goes to a drive, for every family, and protects the drive's EEPROM from repeated
//! non-volatile writes.
//!
//! In order:
//!
//! * the parameter must be in the table (the caller may still send raw writes to unknown
//!   indices on purpose, without the guard);
//! * the raw value must fit the parameter's bus width ([`ParamMeta::wire_range`]; a value that
//!   does not fit is refused by [`check_width`] too, which callers apply even when they skip the
//!   guard);
//! * read-only parameters are refused;
//! * values outside the table's range are refused with the allowed range in raw and physical
//!   units; where the value list is the whole domain ([`ParamMeta::value_list_exhaustive`]), a
//!   value not in it is refused with the allowed values;
//! * a non-volatile write to a parameter less than [`MIN_NV_INTERVAL`] after the previous one is
//!   refused ([`GuardError::TooFrequent`]); volatile writes are never limited.
//!
//! Parameters that can only be changed under controller inhibit (`R`) or not while the drive
//! runs pass with a [`GuardWarning`]. Time is an argument ([`Instant`]); the messages name no
//! command-line option (a tool adds its own hints).
//!
//! ```
//! use core::time::Duration;
//! use drive_core::Instant;
//! use drive_profile::guard::{GuardError, WriteGuard};
//! use drive_profile::{Persistence, sew};
//!
//! let p130 = sew::lookup("P130").unwrap(); // ramp t11 up CW, index 8470
//! let mut guard = WriteGuard::new();
//! let t0 = Instant::from_secs(100);
//! guard.check(p130, 1500, Persistence::NonVolatile, t0)?;
//! guard.record(p130, Persistence::NonVolatile, t0);
//! let again = guard.check(p130, 1600, Persistence::NonVolatile, t0 + Duration::from_millis(200));
//! assert!(matches!(again, Err(GuardError::TooFrequent { .. })));
//! guard.check(p130, 1600, Persistence::Volatile, t0 + Duration::from_millis(200))?;
//! let p000 = sew::lookup("P000").unwrap();
//! assert!(matches!(guard.check(p000, 0, Persistence::Volatile, t0), Err(GuardError::ReadOnly { .. })));
//! # Ok::<(), GuardError>(())
//! ```

use core::fmt;
use core::time::Duration;
use std::collections::HashMap;
use std::string::String;

use drive_core::Instant;

use crate::param::{Access, Family, Label, ParamMeta, Persistence};

/// Shortest time between two non-volatile writes of one parameter the guard lets through.
pub const MIN_NV_INTERVAL: Duration = Duration::from_secs(1);

/// Why the guard refused a write.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GuardError {
    /// The raw value does not fit the parameter's bus width: sending it would cut it.
    #[error(
        "value {raw} does not fit {label} \"{name}\": its bus width carries {min} to {max}; nothing was sent"
    )]
    DoesNotFit {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
        /// The refused raw value.
        raw: i64,
        /// Smallest value the width carries.
        min: i64,
        /// Largest value the width carries.
        max: i64,
    },
    /// The parameter is read-only.
    #[error("{label} \"{name}\" ({name_de}) is read-only and cannot be written")]
    ReadOnly {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
        /// German name as printed.
        name_de: &'static str,
    },
    /// The value is outside the table's range.
    #[error(
        "value {raw} for {label} \"{name}\" is out of range: allowed raw {min} to {max}{physical}"
    )]
    OutOfRange {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
        /// The refused raw value.
        raw: i64,
        /// Smallest allowed raw value.
        min: i64,
        /// Largest allowed raw value.
        max: i64,
        /// The range in the parameter's unit, e.g. ` (0.000 to 2000.000 s)`, or empty.
        physical: String,
    },
    /// The value is not in the parameter's value list, which is its whole domain.
    #[error("value {raw} is not one of the values of {label} \"{name}\": {allowed}")]
    NotInValueList {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
        /// The refused raw value.
        raw: i64,
        /// The allowed values with their meanings, e.g. `0 = no function, 1 = speed, …`.
        allowed: String,
    },
    /// A non-volatile write of the same parameter came too soon after the previous one.
    #[error(
        "{label} \"{name}\" was written to EEPROM {} ms ago; repeated non-volatile writes wear out the drive's EEPROM",
        .since.as_millis()
    )]
    TooFrequent {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
        /// Time since the previous non-volatile write.
        since: Duration,
    },
}

/// A warning that does not stop the write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum GuardWarning {
    /// The parameter (`R`) can only be changed under controller inhibit.
    NeedsInhibit {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
    },
    /// The parameter cannot be changed while the drive is running.
    NotInOperation {
        /// The parameter's label.
        label: Label,
        /// English name.
        name: &'static str,
    },
}

impl fmt::Display for GuardWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NeedsInhibit { label, name } => write!(
                f,
                "{label} \"{name}\" can only be changed under controller inhibit; the drive refuses the write while enabled"
            ),
            Self::NotInOperation { label, name } => write!(
                f,
                "{label} \"{name}\" cannot be changed while the drive is running; the drive refuses the write in operation"
            ),
        }
    }
}

/// Refuse a raw value that does not fit the parameter's bus width ([`ParamMeta::wire_range`]).
/// Apply it to every write, also one the user forces past the guard.
pub fn check_width(param: &dyn ParamMeta, raw: i64) -> Result<(), GuardError> {
    let (min, max) = param.wire_range();
    if raw < min || raw > max {
        return Err(GuardError::DoesNotFit {
            label: param.label(),
            name: param.name_en(),
            raw,
            min,
            max,
        });
    }
    Ok(())
}

/// Remembers the time of the last non-volatile write per parameter; see the
/// [module docs](self).
#[derive(Debug, Clone, Default)]
pub struct WriteGuard {
    last_nv: HashMap<Key, Instant>,
}

/// A parameter of one family: bus index and sub-index.
type Key = (Family, u16, u16);

fn key(param: &dyn ParamMeta) -> Key {
    (
        param.family(),
        param.bus_index(),
        param.sub_index().unwrap_or(0),
    )
}

impl WriteGuard {
    /// A guard that has seen no write.
    pub fn new() -> Self {
        Self::default()
    }

    /// Check a write of `raw` to `param` at `now`; see the [module docs](self) for the rules.
    pub fn check(
        &self,
        param: &dyn ParamMeta,
        raw: i64,
        persistence: Persistence,
        now: Instant,
    ) -> Result<(), GuardError> {
        check_width(param, raw)?;
        let label = param.label();
        let name = param.name_en();
        if !param.access().is_writable() {
            return Err(GuardError::ReadOnly {
                label,
                name,
                name_de: param.name_de(),
            });
        }
        if param.value_list_exhaustive() {
            if param.value_name(raw).is_none() {
                return Err(GuardError::NotInValueList {
                    label,
                    name,
                    raw,
                    allowed: allowed_values(param),
                });
            }
        } else if let Some((min, max)) = param.raw_range()
            && !param.in_range(raw)
        {
            return Err(GuardError::OutOfRange {
                label,
                name,
                raw,
                min,
                max,
                physical: physical_range(param, min, max),
            });
        }
        if persistence == Persistence::NonVolatile
            && let Some(&last) = self.last_nv.get(&key(param))
        {
            let since = now.saturating_duration_since(last);
            if since < MIN_NV_INTERVAL {
                return Err(GuardError::TooFrequent { label, name, since });
            }
        }
        Ok(())
    }

    /// A warning for writes to `param` that pass but need care.
    pub fn warning(param: &dyn ParamMeta) -> Option<GuardWarning> {
        let access = param.access();
        let (label, name) = (param.label(), param.name_en());
        if access.contains(Access::NEEDS_INHIBIT) {
            Some(GuardWarning::NeedsInhibit { label, name })
        } else if access.contains(Access::NOT_IN_OPERATION) {
            Some(GuardWarning::NotInOperation { label, name })
        } else {
            None
        }
    }

    /// Record a write of `param` sent at `now` (only non-volatile writes count).
    pub fn record(&mut self, param: &dyn ParamMeta, persistence: Persistence, now: Instant) {
        if persistence == Persistence::NonVolatile {
            self.last_nv.insert(key(param), now);
        }
    }

    /// Record a non-volatile write of `param` known from elsewhere (e.g. a tool's write log
    /// across runs) that happened at `at`.
    pub fn remember(&mut self, param: &dyn ParamMeta, at: Instant) {
        let entry = self.last_nv.entry(key(param)).or_insert(at);
        *entry = entry.later(at);
    }
}

/// ` (0.000 to 2000.000 s)` for a parameter with a unit or scaling, else empty.
fn physical_range(param: &dyn ParamMeta, min: i64, max: i64) -> String {
    let (lo, hi) = (param.to_physical(min), param.to_physical(max));
    let scaled = lo != min as f64 || hi != max as f64;
    if param.unit().is_empty() && !scaled {
        return String::new();
    }
    let d = usize::from(param.decimals());
    let unit = param.unit();
    let text = format!("{lo:.d$} to {hi:.d$} {unit}");
    format!(" ({})", text.trim_end())
}

/// `0 = no function, 1 = speed, …` (at most 12 entries, then the count).
fn allowed_values(param: &dyn ParamMeta) -> String {
    let values = param.values();
    let mut parts: Vec<String> = values
        .iter()
        .take(12)
        .map(|v| format!("{} = {}", v.value, v.en))
        .collect();
    if values.len() > 12 {
        parts.push(format!("… ({} values)", values.len()));
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{bonfiglioli, family, sew};

    fn sew(key: &str) -> &'static sew::Param {
        sew::lookup(key).unwrap()
    }

    #[test]
    fn every_rule_in_order() {
        let mut g = WriteGuard::new();
        let t = Instant::from_secs(10);
        let nv = Persistence::NonVolatile;
        // Width first: P130 is unsigned 32 bits.
        assert!(matches!(
            g.check(sew("P130"), 1 << 40, nv, t),
            Err(GuardError::DoesNotFit {
                min: 0,
                max: 4_294_967_295,
                ..
            })
        ));
        assert!(matches!(
            g.check(sew("P130"), -1, Persistence::Volatile, t),
            Err(GuardError::DoesNotFit { .. })
        ));
        // Read-only.
        let e = g.check(sew("P000"), 0, nv, t).unwrap_err();
        assert_eq!(
            e.to_string(),
            "P000 \"Speed [1/min]\" (Drehzahl [1/min]) is read-only and cannot be written"
        );
        // Range, with the physical range.
        let e = g.check(sew("P130"), 3_000_000, nv, t).unwrap_err();
        assert!(matches!(e, GuardError::OutOfRange { .. }), "{e}");
        assert!(e.to_string().contains("(0.00 to 2000.00 s)"), "{e}");
        // Value list: P870 knows 0…12.
        let e = g.check(sew("P870"), 13, nv, t).unwrap_err();
        assert!(matches!(e, GuardError::NotInValueList { .. }), "{e}");
        assert!(e.to_string().contains("9 = control word 1"), "{e}");
        g.check(sew("P870"), 9, nv, t).unwrap();
        // EEPROM wear: the same parameter too soon, not another one, not volatile.
        g.record(sew("P130"), nv, t);
        let soon = t + Duration::from_millis(300);
        let e = g.check(sew("P130"), 1000, nv, soon).unwrap_err();
        assert_eq!(
            e,
            GuardError::TooFrequent {
                label: sew("P130").label(),
                name: sew("P130").name_en,
                since: Duration::from_millis(300)
            }
        );
        g.check(sew("P131"), 1000, nv, soon).unwrap();
        g.check(sew("P130"), 1000, Persistence::Volatile, soon)
            .unwrap();
        g.check(sew("P130"), 1000, nv, t + MIN_NV_INTERVAL).unwrap();
        // A write known from elsewhere counts too; the later one wins.
        let mut g = WriteGuard::new();
        g.remember(sew("P131"), t);
        g.remember(sew("P131"), t.saturating_sub(Duration::from_secs(5)));
        assert!(g.check(sew("P131"), 1000, nv, soon).is_err());
    }

    #[test]
    fn every_family_and_warnings() {
        let g = WriteGuard::new();
        let t = Instant::ZERO;
        let nv = Persistence::NonVolatile;
        // Bonfiglioli: 1376 (Modbus address) is 1…247.
        let addr = bonfiglioli::lookup("1376").unwrap();
        assert!(g.check(addr, 0, nv, t).is_err());
        g.check(addr, 247, nv, t).unwrap();
        // Widths follow the data type: 218 is a 16-bit Int.
        let p218 = bonfiglioli::lookup("218").unwrap();
        assert!(matches!(
            check_width(p218, 40_000),
            Err(GuardError::DoesNotFit { .. })
        ));
        // NORD P102 acceleration time has a range.
        let p102 = family::lookup(Family::Nord, "P102").unwrap();
        let (_, max) = p102.raw_range().unwrap();
        assert!(g.check(p102, max + 1, nv, t).is_err());
        g.check(p102, max, nv, t).unwrap();
        // NORD parameters are 16-bit words: with or without a range (P480 has none, also as
        // an array element), a value past the word is refused even when the range is not
        // checked.
        assert!(matches!(
            check_width(p102, 70_000),
            Err(GuardError::DoesNotFit {
                min: -32768,
                max: 65535,
                ..
            })
        ));
        let p480 = family::lookup(Family::Nord, "P480").unwrap();
        assert_eq!(p480.raw_range(), None);
        check_width(p480, 65_535).unwrap();
        check_width(p480, -32_768).unwrap();
        assert!(check_width(p480, 65_536).is_err());
        assert!(check_width(p480, -32_769).is_err());
        let p480_11 = crate::nord::lookup("P480").unwrap().element(11).unwrap();
        assert!(check_width(&p480_11, 65_536).is_err());
        // Warnings: SEW `R`, Bonfiglioli "not in operation".
        let r = sew::params()
            .iter()
            .find(|p| p.access.contains(Access::NEEDS_INHIBIT))
            .unwrap();
        assert!(matches!(
            WriteGuard::warning(r),
            Some(GuardWarning::NeedsInhibit { .. })
        ));
        let nop = bonfiglioli::params()
            .iter()
            .find(|p| p.not_in_operation)
            .unwrap();
        assert!(matches!(
            WriteGuard::warning(nop),
            Some(GuardWarning::NotInOperation { .. })
        ));
        assert_eq!(WriteGuard::warning(sew("P130")), None);
    }

    // The MOVILINK guard's tests, on the family-generic guard.

    #[test]
    fn read_only_is_refused() {
        let g = WriteGuard::new();
        let e = g
            .check(sew("8318"), 0, Persistence::Volatile, Instant::ZERO)
            .unwrap_err();
        assert!(matches!(e, GuardError::ReadOnly { .. }));
        let msg = e.to_string();
        assert!(msg.contains("read-only") && msg.contains("P000"), "{msg}");
    }

    #[test]
    fn out_of_range_is_refused_with_the_range() {
        let g = WriteGuard::new();
        let t = Instant::ZERO;
        let e = g
            .check(sew("8470"), 3_000_000, Persistence::NonVolatile, t)
            .unwrap_err();
        assert!(
            matches!(
                e,
                GuardError::OutOfRange {
                    raw: 3_000_000,
                    min: 0,
                    max: 2_000_000,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("0 to 2000000"), "{e}");
        assert!(matches!(
            g.check(sew("8598"), 99, Persistence::Volatile, t),
            Err(GuardError::OutOfRange {
                min: 100,
                max: 199,
                ..
            })
        ));
        g.check(sew("8598"), 150, Persistence::Volatile, t).unwrap();
        g.check(sew("8470"), 2_000_000, Persistence::Volatile, t)
            .unwrap();
    }

    #[test]
    fn a_second_non_volatile_write_within_a_second_is_refused() {
        let mut g = WriteGuard::new();
        let t0 = Instant::from_secs(1);
        let nv = Persistence::NonVolatile;
        g.check(sew("8470"), 1000, nv, t0).unwrap();
        g.record(sew("8470"), nv, t0);
        let e = g
            .check(sew("8470"), 1100, nv, t0 + Duration::from_millis(400))
            .unwrap_err();
        assert!(matches!(e, GuardError::TooFrequent { .. }), "{e:?}");
        assert!(e.to_string().contains("EEPROM"), "{e}");
        g.check(sew("8471"), 1100, nv, t0 + Duration::from_millis(400))
            .unwrap();
        g.check(sew("8470"), 1100, nv, t0 + Duration::from_secs(1))
            .unwrap();
    }

    #[test]
    fn volatile_writes_are_never_rate_limited() {
        let mut g = WriteGuard::new();
        let t0 = Instant::from_secs(1);
        g.record(sew("8470"), Persistence::NonVolatile, t0);
        for i in 0..100u64 {
            let t = t0 + Duration::from_millis(i);
            g.check(sew("8470"), 1000, Persistence::Volatile, t)
                .unwrap();
            g.record(sew("8470"), Persistence::Volatile, t);
        }
        // Volatile writes do not count for the EEPROM limit either.
        g.check(
            sew("8470"),
            1000,
            Persistence::NonVolatile,
            t0 + Duration::from_millis(1000),
        )
        .unwrap();
    }
}
