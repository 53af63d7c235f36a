//! A write guard for tools: checks a parameter write against the MOVIDRIVE parameter table
//! before it goes to the drive, and protects the drive's EEPROM from cyclic non-volatile
//! writes.
//!
//! * read-only parameters (`RO`) are refused; parameters that need controller inhibit (`R`)
//!   pass with a warning ([`WriteGuard::warning`]);
//! * values outside the table's range (or between its range segments) are refused with the
//!   allowed range;
//! * a non-volatile write to the same index less than [`MIN_NV_INTERVAL`] after the previous
//!   one is refused with a hint to use the volatile service; volatile writes are never
//!   limited.
//!
//! ```
//! use std::time::{Duration, Instant};
//! use movilink::guard::{GuardError, WriteGuard};
//!
//! let mut guard = WriteGuard::new();
//! let t0 = Instant::now();
//! // P130 ramp t11 up CW (index 8470), 1.5 s, non-volatile.
//! guard.check(8470, 1500, false, t0)?;
//! guard.record(8470, false, t0);
//! let again = guard.check(8470, 1600, false, t0 + Duration::from_millis(200));
//! assert!(matches!(again, Err(GuardError::TooFrequent { .. })));
//! guard.check(8470, 1600, true, t0 + Duration::from_millis(200))?; // volatile is fine
//! assert!(matches!(guard.check(8318, 0, true, t0), Err(GuardError::ReadOnly { .. })));
//! # Ok::<(), GuardError>(())
//! ```

use std::collections::HashMap;
use std::fmt;
use std::time::{Duration, Instant};

use drive_profile::sew;
use drive_profile::{Access, ParamMeta};

/// Shortest time between two non-volatile writes of one index the guard lets through.
pub const MIN_NV_INTERVAL: Duration = Duration::from_secs(1);

/// Remembers the time of the last non-volatile write per index; see the [module docs](self).
#[derive(Debug, Clone, Default)]
pub struct WriteGuard {
    last_nv: HashMap<u16, Instant>,
}

/// Why the guard refused a write. Each message names the way out (`--force`, `--volatile`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GuardError {
    /// The index is not in the MOVIDRIVE parameter table.
    #[error(
        "index {index} is not in the MOVIDRIVE parameter list; check the index (drivectl params search) or use --force to send it anyway"
    )]
    UnknownIndex {
        /// The index.
        index: u16,
    },
    /// The parameter is read-only.
    #[error("{} is read-only and cannot be written", Label(*.index, .name))]
    ReadOnly {
        /// The index.
        index: u16,
        /// English name (German original in the message).
        name: &'static str,
    },
    /// The value is outside the table's range.
    #[error(
        "value {raw} for {} is out of range: allowed {min} to {max}{} ({}); use a value in range, or --force to let the drive decide",
        Label(*.index, .name),
        unit_suffix(.unit),
        physical_range(*.index, *.min, *.max, .unit)
    )]
    OutOfRange {
        /// The index.
        index: u16,
        /// English name.
        name: &'static str,
        /// The refused raw value.
        raw: i64,
        /// Smallest allowed raw value.
        min: i64,
        /// Largest allowed raw value.
        max: i64,
        /// Unit of the displayed (physical) value, empty when unitless.
        unit: &'static str,
    },
    /// A non-volatile write of the same index came too soon after the previous one.
    #[error(
        "{} was written to EEPROM {} ms ago; repeated non-volatile writes wear out the drive's EEPROM: use --volatile for values that change often, or --force",
        Label(*.index, .name),
        .since.as_millis()
    )]
    TooFrequent {
        /// The index.
        index: u16,
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
        /// The index.
        index: u16,
        /// English name.
        name: &'static str,
    },
}

impl fmt::Display for GuardWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NeedsInhibit { index, name } => write!(
                f,
                "{} can only be changed under controller inhibit; the drive refuses the write while enabled (set control word bit 0 first)",
                Label(*index, name)
            ),
        }
    }
}

/// `P130 "Ramp t11 up CW [s]" (Rampe t11 auf RECHTS [s], index 8470)`.
struct Label<'a>(u16, &'a str);

impl fmt::Display for Label<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match sew::by_index(self.0) {
            Some(p) => write!(
                f,
                "{} \"{}\" ({}, index {})",
                p.menu_label().as_str(),
                self.1,
                p.name_de,
                self.0
            ),
            None => write!(f, "index {}", self.0),
        }
    }
}

fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() {
        String::from(" (raw)")
    } else {
        format!(" (raw; unit {unit} after scaling)")
    }
}

fn physical_range(index: u16, min: i64, max: i64, unit: &str) -> String {
    match sew::by_index(index) {
        Some(p) => {
            let s = p.scaling();
            let d = usize::from(p.decimals);
            format!(
                "{:.d$} to {:.d$} {unit}",
                s.to_physical(min),
                s.to_physical(max)
            )
            .trim_end()
            .to_owned()
        }
        None => String::new(),
    }
}

impl WriteGuard {
    /// A guard that has seen no write.
    pub fn new() -> Self {
        Self::default()
    }

    /// Check a write of `raw` to `index` at `now` (`volatile`: RAM only). Refuses writes to
    /// unknown or read-only parameters, values out of range, and a non-volatile write to an
    /// index written non-volatile less than [`MIN_NV_INTERVAL`] ago.
    pub fn check(
        &mut self,
        index: u16,
        raw: i64,
        volatile: bool,
        now: Instant,
    ) -> Result<(), GuardError> {
        let p = sew::by_index(index).ok_or(GuardError::UnknownIndex { index })?;
        let name = p.name_en;
        let access = p.access;
        if access.contains(Access::READ_ONLY) || !access.contains(Access::READ_WRITE) {
            return Err(GuardError::ReadOnly { index, name });
        }
        if let Some((min, max)) = p.raw_range() {
            if raw < min || raw > max || p.snap(raw).is_none() {
                return Err(GuardError::OutOfRange {
                    index,
                    name,
                    raw,
                    min,
                    max,
                    unit: p.display_unit,
                });
            }
        }
        if !volatile {
            if let Some(&last) = self.last_nv.get(&index) {
                let since = now.saturating_duration_since(last);
                if since < MIN_NV_INTERVAL {
                    return Err(GuardError::TooFrequent { index, name, since });
                }
            }
        }
        Ok(())
    }

    /// A warning for writes to `index` that pass but need care (controller inhibit).
    pub fn warning(&self, index: u16) -> Option<GuardWarning> {
        let p = sew::by_index(index)?;
        p.access
            .contains(Access::NEEDS_INHIBIT)
            .then_some(GuardWarning::NeedsInhibit {
                index,
                name: p.name_en,
            })
    }

    /// Record a write of `index` that was sent at `now` (only non-volatile writes count).
    pub fn record(&mut self, index: u16, volatile: bool, now: Instant) {
        if !volatile {
            self.last_nv.insert(index, now);
        }
    }
}
