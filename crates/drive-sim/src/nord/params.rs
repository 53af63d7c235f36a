//! The cells of the simulated NORD drive's parameter memory: one [`ParamStore`] cell per
//! parameter, array element and parameter set.
//!
//! The shared [`ParamStore`](crate::ParamStore) keys cells by `(bus index, sub-index)`; a NORD
//! parameter is addressed by element and parameter set, so each cell gets a row of its own
//! whose sub-index is [`sub`]`(element, set)`. The rows carry the simulator's defaults and
//! ranges ([`SIM_DEFAULTS`], [`SIM_RANGES`]) on top of the table's.

use std::sync::OnceLock;

use drive_profile::nord::{self, Param};
use drive_profile::scaling::ScaleError;
use drive_profile::{Access, Family, ParamMeta, ValueName};

use super::{PkwRefusal, SIM_DEFAULTS, SIM_RANGES};
use crate::store::Meta;

/// The range of a word parameter without a range of its own: signed 16 bit.
const WORD: (i64, i64) = (i16::MIN as i64, i16::MAX as i64);

/// The store sub-index of element `element` (0-based) in parameter set `set` (0…3).
pub(super) const fn sub(element: u8, set: u8) -> u16 {
    (element as u16) * 4 + set as u16
}

/// The table row of `pnu` if `element` and `set` address one of its cells.
pub(super) fn address(pnu: u16, element: u8, set: u8) -> Result<&'static Param, PkwRefusal> {
    let p = nord::by_index(pnu).ok_or(PkwRefusal::InvalidParameter)?;
    let sets = if p.parameter_set { 4 } else { 1 };
    if set >= sets || element >= p.array_len.unwrap_or(1) {
        return Err(PkwRefusal::WrongSubindex);
    }
    Ok(p)
}

/// One cell's row: the table row with its sub-index, default and range.
#[derive(Debug)]
pub(super) struct CellRow {
    param: &'static Param,
    sub: u16,
    default: Option<i64>,
    range: (i64, i64),
}

/// Every cell's row, built once.
pub(super) fn rows() -> impl Iterator<Item = Meta> {
    static ROWS: OnceLock<Vec<CellRow>> = OnceLock::new();
    ROWS.get_or_init(build).iter().map(|r| r as Meta)
}

fn build() -> Vec<CellRow> {
    let mut rows = Vec::new();
    for param in nord::params() {
        let sets = if param.parameter_set { 4 } else { 1 };
        let range = param
            .raw_range
            .or_else(|| {
                SIM_RANGES
                    .iter()
                    .find(|(n, _, _)| *n == param.number)
                    .map(|(_, lo, hi)| (*lo, *hi))
            })
            .unwrap_or(WORD);
        for element in 0..param.array_len.unwrap_or(1) {
            let default = SIM_DEFAULTS
                .iter()
                .find(|(n, e, _)| *n == param.number && *e == element)
                .map(|(_, _, v)| *v)
                .or(param.default_raw);
            for set in 0..sets {
                rows.push(CellRow {
                    param,
                    sub: sub(element, set),
                    default,
                    range,
                });
            }
        }
    }
    rows
}

impl ParamMeta for CellRow {
    fn family(&self) -> Family {
        Family::Nord
    }
    fn number(&self) -> Option<u16> {
        Some(self.param.number)
    }
    fn bus_index(&self) -> u16 {
        self.param.pnu
    }
    fn sub_index(&self) -> Option<u16> {
        Some(self.sub)
    }
    fn name_de(&self) -> &'static str {
        self.param.name_de
    }
    fn name_en(&self) -> &'static str {
        self.param.name_en
    }
    fn unit(&self) -> &'static str {
        self.param.unit
    }
    fn access(&self) -> Access {
        self.param.access
    }
    fn default_raw(&self) -> Option<i64> {
        self.default
    }
    fn raw_range(&self) -> Option<(i64, i64)> {
        Some(self.range)
    }
    fn range_de(&self) -> &'static str {
        self.param.range_de
    }
    fn range_en(&self) -> &'static str {
        self.param.range_en
    }
    fn values(&self) -> &'static [ValueName] {
        self.param.values
    }
    fn decimals(&self) -> u8 {
        ParamMeta::decimals(self.param)
    }
    fn to_physical(&self, raw: i64) -> f64 {
        self.param.to_physical(raw)
    }
    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        self.param.from_physical(value)
    }
}
