//! SEW MOVIDRIVE: the parameter list, PNO size/conversion indices and MOVILINK return codes.
//!
//! All tables are generated from CSV files extracted from the SEW manuals
//! (`crates/drive-profile/data/sew/`, see `docs/errata-sew.md` for where the manuals are wrong).
//! Every lookup works on `static` tables and never allocates.
//!
//! # Parameters
//!
//! Each printed row of the parameter list is one [`Param`]. Rows with a menu number are
//! labelled `P000` … `P963`. Rows without one (the entries of the fault memory under P080 …
//! P084, the percent variants of the internal setpoints) are *sub-entries* of the numbered row
//! they belong to and are labelled `P<parent>.<n>`, numbered from 1 in manual order: `P080.1`
//! is "Eingangsklemmen 1...6" of fault t-0, index 8371.
//!
//! ```
//! use drive_profile::sew;
//! use drive_profile::ParamMeta;
//!
//! let speed = sew::by_index(8318).unwrap();
//! assert_eq!(speed.menu_label().as_str(), "P000");
//! assert_eq!(speed.unit(), "1/min");
//! assert_eq!(speed.to_physical(1_000_000), 1000.0);
//! assert_eq!(sew::lookup("P813").unwrap().bus_index(), 8600);
//! ```
//!
//! # Scaling
//!
//! The manual gives each parameter a PNO size index (the physical quantity) and a conversion
//! index (the unit the raw value counts in): `physical = raw × A + B` in the base unit of the
//! quantity. [`Param`] shows the value in its *display unit* (the unit in the name's brackets,
//! e.g. 1/min for speeds counted in 1/1000 min⁻¹) by rebasing onto that unit's A and B.
//!
//! # Return codes
//!
//! [`ReturnCode`] is a negative answer of the parameter channel ([`channel`]); [`return_code_info`]
//! finds its row in the manual's table, [`describe_return_code`] also covers codes the manual
//! does not list.
//!
//! # Parameter services
//!
//! [`ParamServices`] ([`services`]) are the services of the parameter channel (read, write,
//! write volatile, minimum, maximum, default, scale, attributes, and the repeat of a service
//! answered 6/2) written once over the one call each bus gives: MOVILINK's and SBus's drivers
//! implement it.

pub mod channel;
pub mod device;
mod handshake;
pub mod index;
pub mod services;
mod words;

pub use channel::{
    AttributeInfo, DataLength, ErrorClass, Management, ParamChannel, ReturnCode, ScaleInfo, Service,
};
pub use handshake::{Echo, MasterHandshake, Prepared, SlaveHandshake};
pub use services::{ParamServices, SERVICE_ATTEMPTS};
pub use words::{BasicCommand, ControlWord1, StatusWord1, UnitStatus};

use crate::columns::{Column, FieldSink, text_list};
use crate::param::{Access, Family, Label, ParamMeta, ValueName, WIRE_32, field_accessors};
use crate::scaling::{Linear, ScaleError, pow10};
use core::fmt;

use crate::generated::sew_parameters::{BY_INDEX, BY_MENU, GROUPS, PARAMS};
use crate::generated::sew_pno::{CONVERSIONS, UNITS};
use crate::generated::sew_return_codes::{ERROR_CLASSES, RETURN_CODES};

/// One segment of a parameter's range: `min..=max` in steps of `step` (raw values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// Smallest raw value.
    pub min: i64,
    /// Largest raw value.
    pub max: i64,
    /// Raw step between settable values.
    pub step: i64,
}

/// A section heading of the parameter list (`0..` Anzeigewerte, `00.` Prozesswerte, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Group {
    /// `N..` for a main group, `NN.` for a sub-group, as printed.
    pub code: &'static str,
    /// German heading.
    pub name_de: &'static str,
    /// English heading.
    pub name_en: &'static str,
}

/// One row of the MOVIDRIVE parameter list (manual ch. 7.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// Menu number (`P813` → 813); `None` for sub-entries.
    pub menu: Option<u16>,
    /// For sub-entries: the menu number of the row they belong to.
    pub parent: Option<u16>,
    /// For sub-entries: position under the parent, from 1; 0 for numbered rows.
    pub sub: u8,
    /// Sub-group code, e.g. `08.`.
    pub group: &'static str,
    /// Marked `•` in the manual: effective on MOVIDRIVE MD_60A only.
    pub md60a_only: bool,
    /// German name as printed.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// MOVILINK index.
    pub index: u16,
    /// The index in hexadecimal as printed (corrected where the manual is wrong).
    pub index_hex: &'static str,
    /// Second index of a two-word parameter (P852).
    pub index2: Option<u16>,
    /// PNO unit abbreviation printed in the "Abk." column (empty when unitless); the
    /// displayed unit is [`Param::display_unit`].
    pub pno_unit: &'static str,
    /// Unit the physical value is shown in (empty when unitless).
    pub display_unit: &'static str,
    /// PNO size index.
    pub size_index: u8,
    /// PNO conversion index of the raw value.
    pub conversion_index: i16,
    /// Conversion index of the display unit; `None` for size index 0, whose values are shown
    /// in the base scaling (`raw × A + B`).
    pub display_conversion_index: Option<i16>,
    /// Access attributes.
    pub access: Access,
    /// Default (factory setting), raw.
    pub default: Option<i64>,
    /// Default of the second index, where printed.
    pub default2: Option<i64>,
    /// The manual's default lies outside its printed range (documented in the errata).
    pub default_outside_range: bool,
    /// Meaning / range as printed (German).
    pub range_de: &'static str,
    /// Meaning / range in English.
    pub range_en: &'static str,
    /// Range segments in raw values (empty when the manual prints none).
    pub ranges: &'static [Segment],
    /// Value list (the referenced row's list where the manual says "Siehe Menü Nr …").
    pub values: &'static [ValueName],
    /// The menu number whose value list this row uses ("Siehe Menü Nr …").
    pub values_ref: Option<u16>,
    /// Decimal places worth showing in the display unit.
    pub decimals: u8,
    /// Errata ids (`SEW-Enn`, space-separated) where this row differs from the print.
    pub errata: &'static str,
}

impl Param {
    /// `P813`, or `P080.3` for the third sub-entry under P080.
    pub fn menu_label(&self) -> Label {
        match (self.menu, self.parent) {
            (Some(m), _) => Label::new(format_args!("P{m:03}")),
            (None, Some(p)) => Label::new(format_args!("P{p:03}.{}", self.sub)),
            (None, None) => Label::new(format_args!("#{}", self.index)),
        }
    }

    /// The scaling from raw value to the display unit.
    pub fn scaling(&self) -> Linear {
        let base = conversion(self.conversion_index).unwrap_or(Linear::IDENTITY);
        match self.display_conversion_index.and_then(conversion) {
            Some(display) => base.rebase(display),
            None => base,
        }
    }

    /// The section heading this row is printed under.
    pub fn group(&self) -> Option<&'static Group> {
        GROUPS.iter().find(|g| g.code == self.group)
    }

    /// Name of the PNO quantity (English), e.g. `speed`.
    pub fn quantity(&self) -> Option<&'static str> {
        size_name(self.size_index)
    }

    /// The raw value rounded onto the step grid of the segment containing it; `None` when it
    /// lies in no segment. Without printed ranges every value is accepted as is.
    pub fn snap(&self, raw: i64) -> Option<i64> {
        if self.ranges.is_empty() {
            return Some(raw);
        }
        let seg = self.ranges.iter().find(|s| s.min <= raw && raw <= s.max)?;
        let k = (raw - seg.min + seg.step / 2) / seg.step;
        Some((seg.min + k * seg.step).min(seg.max))
    }
}

fn raw_bounds(p: &Param) -> (i64, i64) {
    p.raw_range().unwrap_or(WIRE_32)
}

impl ParamMeta for Param {
    field_accessors!(
        name_de: &'static str,
        name_en: &'static str,
        access: Access,
        range_de: &'static str,
        range_en: &'static str,
        values: &'static [ValueName],
        decimals: u8,
    );
    fn family(&self) -> Family {
        Family::Movidrive
    }
    fn number(&self) -> Option<u16> {
        self.menu
    }
    fn bus_index(&self) -> u16 {
        self.index
    }
    fn unit(&self) -> &'static str {
        self.display_unit
    }
    fn default_raw(&self) -> Option<i64> {
        self.default
    }
    /// The printed range; for rows with a value list and no range, the smallest and largest
    /// listed value.
    fn raw_range(&self) -> Option<(i64, i64)> {
        let lo = self.ranges.iter().map(|s| s.min).min();
        let hi = self.ranges.iter().map(|s| s.max).max();
        match (lo, hi) {
            (Some(lo), Some(hi)) => Some((lo, hi)),
            _ => {
                let lo = self.values.iter().map(|v| v.value).min()?;
                let hi = self.values.iter().map(|v| v.value).max()?;
                Some((lo, hi))
            }
        }
    }
    fn to_physical(&self, raw: i64) -> f64 {
        self.scaling().to_physical(raw)
    }
    /// The list is the domain where the manual prints no range.
    fn value_list_exhaustive(&self) -> bool {
        self.ranges.is_empty() && !self.values.is_empty()
    }
    /// 32-bit data: signed where the range goes below 0, unsigned where it starts at 0 or
    /// above (the drive reads the data that way), either sign without a range.
    fn wire_range(&self) -> (i64, i64) {
        match self.raw_range() {
            Some((lo, _)) if lo < 0 => (i64::from(i32::MIN), i64::from(i32::MAX)),
            Some(_) => (0, i64::from(u32::MAX)),
            None => WIRE_32,
        }
    }
    /// `P813`, or `P080.1` for a sub-entry.
    fn label(&self) -> Label {
        self.menu_label()
    }
    /// Rounds to the nearest raw value, then onto the step grid of its range segment; values in
    /// a gap between segments (e.g. −9…9 for P224) are out of range.
    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        let (lo, hi) = raw_bounds(self);
        let lin = self.scaling();
        let raw = lin.to_raw(value, lo, hi)?;
        self.snap(raw).ok_or(ScaleError::OutOfRange {
            value,
            min: lin.to_physical(lo),
            max: lin.to_physical(hi),
        })
    }
    fn describe_scaling(&self, f: &mut dyn fmt::Write) -> fmt::Result {
        let base = conversion(self.conversion_index).unwrap_or(Linear::IDENTITY);
        write!(f, "size index {}", self.size_index)?;
        if let Some(q) = size_name(self.size_index) {
            write!(f, " ({q})")?;
        }
        write!(f, ", conversion index {}: A = ", self.conversion_index)?;
        write_number(f, base.a)?;
        f.write_str(", B = ")?;
        write_number(f, base.b)?;
        if let Some(d) = self.display_conversion_index
            && d != self.conversion_index
        {
            write!(f, "; shown in {} (conversion index {d})", self.display_unit)?;
        }
        Ok(())
    }
    /// The columns of the parameter list beyond the common ones; `menu` is the common
    /// `param_number`, the printed segments are `range_segments` (their outer ends
    /// `table_min` / `table_max`), `group_de` / `group_en` the heading of `group`.
    fn family_columns(&self, out: &mut FieldSink<'_>) {
        let heading = self.group();
        out("table_min", self.ranges.iter().map(|s| s.min).min().into());
        out("table_max", self.ranges.iter().map(|s| s.max).max().into());
        out("group", Column::Text(self.group));
        out("group_de", heading.map(|g| g.name_de).into());
        out("group_en", heading.map(|g| g.name_en).into());
        out("parent", self.parent.into());
        out("sub", self.sub.into());
        out("md60a_only", self.md60a_only.into());
        out("index_hex", Column::Text(self.index_hex));
        out("index2", self.index2.into());
        out("pno_unit", Column::Text(self.pno_unit));
        out("display_unit", Column::Text(self.display_unit));
        out("size_index", self.size_index.into());
        out("conversion_index", self.conversion_index.into());
        out(
            "display_conversion_index",
            self.display_conversion_index.into(),
        );
        out("default2", self.default2.into());
        out("default_outside_range", self.default_outside_range.into());
        out(
            "range_segments",
            Column::List(&|items| {
                for seg in self.ranges {
                    items(Column::Record(&|f| {
                        f("min", Column::Int(seg.min));
                        f("max", Column::Int(seg.max));
                        f("step", Column::Int(seg.step));
                    }));
                }
            }),
        );
        out("values_ref", self.values_ref.into());
        out(
            "errata",
            Column::List(&|items| text_list(self.errata, ' ', items)),
        );
    }
    fn in_range(&self, raw: i64) -> bool {
        if self.ranges.is_empty() {
            return self
                .raw_range()
                .is_none_or(|(lo, hi)| lo <= raw && raw <= hi);
        }
        self.ranges.iter().any(|s| s.min <= raw && raw <= s.max)
    }
}

/// Short number formatting: integers plainly, others with four significant digits.
fn write_number(f: &mut dyn fmt::Write, v: f64) -> fmt::Result {
    let is_int = v == crate::scaling::round(v) && v.abs() < 1e7;
    if is_int {
        write!(f, "{}", v as i64)
    } else if (0.01..1e7).contains(&v.abs()) && v == crate::scaling::round(v * 100.0) / 100.0 {
        write!(f, "{v}")
    } else {
        // `{:e}` is the shortest exact form; use it when short, else round to 4 digits.
        let mut probe = Label::new(format_args!("{v:e}"));
        if probe.as_str().len() > 8 {
            probe = Label::new(format_args!("{v:.3e}"));
        }
        f.write_str(probe.as_str())
    }
}

// ---------------------------------------------------------------------------------------------
// Parameter lookups

/// Every row of the parameter list, in manual order.
pub fn params() -> &'static [Param] {
    PARAMS
}

/// The section headings, in manual order.
pub fn groups() -> &'static [Group] {
    GROUPS
}

fn row(pos: u16) -> Option<&'static Param> {
    PARAMS.get(usize::from(pos))
}

/// The first row (in manual order) with `index` as its index or second index.
pub fn by_index(index: u16) -> Option<&'static Param> {
    all_by_index(index).next()
}

/// Every row with `index` as its index or second index, in manual order (P010 … P013 share
/// index 8310).
pub fn all_by_index(index: u16) -> impl Iterator<Item = &'static Param> {
    let start = BY_INDEX.partition_point(|&(i, _)| i < index);
    BY_INDEX
        .get(start..)
        .unwrap_or(&[])
        .iter()
        .take_while(move |&&(i, _)| i == index)
        .filter_map(|&(_, pos)| row(pos))
}

/// The row with menu number `menu` (`813` for P813).
pub fn by_number(menu: u16) -> Option<&'static Param> {
    let pos = BY_MENU.binary_search_by_key(&menu, |&(m, _)| m).ok()?;
    BY_MENU.get(pos).and_then(|&(_, r)| row(r))
}

/// The sub-entry `sub` (from 1) under menu number `parent` (`P080.1` → (80, 1)).
pub fn by_label(parent: u16, sub: u8) -> Option<&'static Param> {
    if sub == 0 {
        return by_number(parent);
    }
    PARAMS
        .iter()
        .find(|p| p.parent == Some(parent) && p.sub == sub)
}

fn parse_dec(s: &str) -> Option<u16> {
    if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    s.parse().ok()
}

/// Find a parameter by what a user types: `P813`, `p813` or `813` (menu number), `P080.1`
/// (sub-entry), `8600` or `0x2198` (index; plain numbers ≥ 1000 are indices).
pub fn lookup(s: &str) -> Option<&'static Param> {
    let s = s.trim();
    if let Some(h) = s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        return by_index(u16::from_str_radix(h, 16).ok()?);
    }
    let (menu_only, body) = match s.strip_prefix(['P', 'p']) {
        Some(b) => (true, b),
        None => (false, s),
    };
    if let Some((m, sub)) = body.split_once('.') {
        return by_label(parse_dec(m)?, u8::try_from(parse_dec(sub)?).ok()?);
    }
    let n = parse_dec(body)?;
    if !menu_only && n >= 1000 {
        by_index(n)
    } else {
        by_number(n)
    }
}

/// Rows whose German or English name contains `term`, ignoring case.
pub fn search(term: &str) -> impl Iterator<Item = &'static Param> + '_ {
    PARAMS.iter().filter(move |p| p.name_matches(term))
}

// ---------------------------------------------------------------------------------------------
// PNO size and conversion indices

/// One unit of a PNO size index (manual ch. 7.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SizeUnit {
    /// Size index.
    pub size_index: u8,
    /// Physical quantity (German).
    pub quantity_de: &'static str,
    /// Physical quantity (English).
    pub quantity_en: &'static str,
    /// Unit name (German).
    pub unit_de: &'static str,
    /// Unit name (English).
    pub unit_en: &'static str,
    /// Unit symbol (corrected; empty for size index 0).
    pub symbol: &'static str,
    /// Other spellings of the symbol (the manual's, e.g. `Ws` for J, `min^-1` for 1/min).
    pub aliases: &'static [&'static str],
    /// Conversion index of this unit.
    pub conversion_index: i16,
}

/// How a conversion index is defined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConversionKind {
    /// A = 10^n (printed for −3 … 3, the rule holds for −64 … 64).
    Decimal,
    /// One of the indices above 64 with its own factor and offset.
    Special,
    /// Printed without a factor (69).
    Reserved,
}

/// A printed row of the conversion table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conversion {
    /// Conversion index.
    pub index: i16,
    /// How it is defined.
    pub kind: ConversionKind,
    /// Factor A; `None` when reserved.
    pub a: Option<f64>,
    /// Offset B in the base unit.
    pub b: f64,
}

/// The scaling of conversion index `index`: `physical (base unit) = raw × A + B`.
///
/// Indices −64 … 64 follow the decimal rule A = 10^n; indices above 64 are looked up in the
/// printed table. `None` for reserved (69) and unknown indices.
pub fn conversion(index: i16) -> Option<Linear> {
    if (-64..=64).contains(&index) {
        let a = if index < 0 {
            1.0 / pow10(-i32::from(index))
        } else {
            pow10(i32::from(index))
        };
        return Some(Linear { a, b: 0.0 });
    }
    let pos = CONVERSIONS.binary_search_by_key(&index, |c| c.index).ok()?;
    let c = CONVERSIONS.get(pos)?;
    Some(Linear { a: c.a?, b: c.b })
}

/// The printed conversion table.
pub fn conversions() -> &'static [Conversion] {
    CONVERSIONS
}

/// Every unit of every size index.
pub fn units() -> &'static [SizeUnit] {
    UNITS
}

/// The units of size index `size`, in manual order.
pub fn size_units(size: u8) -> impl Iterator<Item = &'static SizeUnit> {
    UNITS.iter().filter(move |u| u.size_index == size)
}

/// English name of the quantity of size index `size` (`11` → `speed`).
pub fn size_name(size: u8) -> Option<&'static str> {
    size_units(size).next().map(|u| u.quantity_en)
}

/// The unit of size index `size` with conversion index `conv` (`11`, `67` → 1/min).
pub fn unit_of(size: u8, conv: i16) -> Option<&'static SizeUnit> {
    size_units(size).find(|u| u.conversion_index == conv)
}

/// The unit of size index `size` written `symbol` (or one of its aliases).
pub fn unit_by_symbol(size: u8, symbol: &str) -> Option<&'static SizeUnit> {
    size_units(size).find(|u| u.symbol == symbol || u.aliases.contains(&symbol))
}

// ---------------------------------------------------------------------------------------------
// MOVILINK return codes

/// An error class of the return codes (EN 50170), as the manual's table gives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ErrorClassInfo {
    /// Error class number.
    pub class: u8,
    /// EN 50170 name, e.g. `access`.
    pub name: &'static str,
    /// German meaning.
    pub de: &'static str,
    /// English meaning.
    pub en: &'static str,
}

/// A return code with a meaning given in the manual (a row of its table; the code itself is
/// [`ReturnCode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReturnCodeInfo {
    /// Error class (byte 4 of the parameter channel).
    pub class: u8,
    /// Error code (byte 5).
    pub code: u8,
    /// Additional code, high byte 6 and low byte 7.
    pub additional: u16,
    /// German meaning as printed.
    pub de: &'static str,
    /// English meaning.
    pub en: &'static str,
    /// Manual section defining it.
    pub section: &'static str,
    /// The manual says to repeat the service.
    pub retry: bool,
}

impl ReturnCodeInfo {
    /// The error class entry.
    pub fn error_class(&self) -> Option<&'static ErrorClassInfo> {
        error_class_info(self.class)
    }
}

impl fmt::Display for ReturnCodeInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (error class {}, error code {}, additional code 0x{:04X})",
            self.en, self.class, self.code, self.additional
        )
    }
}

/// The error class `class`.
pub fn error_class_info(class: u8) -> Option<&'static ErrorClassInfo> {
    ERROR_CLASSES.iter().find(|c| c.class == class)
}

/// The return code for error class, error code and additional code, if the manual lists it.
pub fn return_code_info(class: u8, code: u8, additional: u16) -> Option<&'static ReturnCodeInfo> {
    let key = (class, code, additional);
    let pos = RETURN_CODES
        .binary_search_by_key(&key, |r| (r.class, r.code, r.additional))
        .ok()?;
    RETURN_CODES.get(pos)
}

/// Every return code the manual lists.
pub fn return_codes() -> &'static [ReturnCodeInfo] {
    RETURN_CODES
}

/// A decoded return code, known or not; `Display` gives an English description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DecodedReturnCode {
    /// Error class as received.
    pub class: u8,
    /// Error code as received.
    pub code: u8,
    /// Additional code as received.
    pub additional: u16,
    /// The manual's entry, when it lists this combination.
    pub known: Option<&'static ReturnCodeInfo>,
    /// The error class entry, when the class is known.
    pub error_class: Option<&'static ErrorClassInfo>,
}

/// Decode the four return-code bytes (bytes 4 … 7 of an error answer).
pub fn describe_return_code(class: u8, code: u8, additional: u16) -> DecodedReturnCode {
    DecodedReturnCode {
        class,
        code,
        additional,
        known: return_code_info(class, code, additional),
        error_class: error_class_info(class),
    }
}

impl fmt::Display for DecodedReturnCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(k) = self.known {
            return k.fmt(f);
        }
        match self.error_class {
            Some(c) => write!(f, "{} ({})", c.en, c.name)?,
            None => f.write_str("unknown error class")?,
        }
        write!(
            f,
            " (error class {}, error code {}, additional code 0x{:04X})",
            self.class, self.code, self.additional
        )
    }
}

#[cfg(test)]
mod tests;

/// Speed in process data (MOVIDRIVE fieldbus profile): signed, 0.2 1/min per digit, so
/// 5000 = 1000 1/min. Sources in `docs/protocols/movidrive-profile.md`.
pub const SPEED_RPM_PER_DIGIT: f64 = 0.2;

/// A speed process-data word (setpoint or actual value) in 1/min.
pub fn speed_from_word(word: u16) -> f64 {
    f64::from(word as i16) * SPEED_RPM_PER_DIGIT
}
