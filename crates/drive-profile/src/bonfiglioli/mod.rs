//! Bonfiglioli ACTIVE (ACT) and ACTIVE Cube (ACU): parameter tables, warnings, fault keys and
//! the VABus error register from the Modbus manual, plus control/status words and the
//! DRIVECOM-style state machine ([`words`], [`state`]), and what tells the ACT from the ACU
//! ([`variant`]).
//!
//! A parameter is addressed by its number and a data set (ch. 6.4.1, ch. 7); for Bonfiglioli the
//! bus index is the parameter number. Values with decimals travel as integers: 10.3 A with one
//! decimal is sent as 103.
//!
//! ```
//! use drive_profile::bonfiglioli;
//! use drive_profile::ParamMeta;
//!
//! let p = bonfiglioli::lookup("P1376").unwrap();
//! assert_eq!(p.name_en, "Modbus address");
//! assert_eq!(p.raw_range(), Some((1, 247)));
//! assert_eq!(p.default_raw(), Some(1));
//!
//! let f = bonfiglioli::fault(0x2010).unwrap();
//! assert_eq!(f.key, "F2010");
//! ```
//!
//! Where the manual gives no data type, [`DataType::Unknown`] says so; [`TypeSource`] records
//! where every known type comes from.

pub mod link;
pub mod state;
pub mod variant;
pub mod words;

use crate::columns::{Column, FieldSink, text_list};
use crate::generated::bonfiglioli_exceptions::EXCEPTIONS;
use crate::generated::bonfiglioli_faults::FAULTS;
use crate::generated::bonfiglioli_params::PARAMS;
use crate::generated::bonfiglioli_vabus_errors::VABUS_ERRORS;
use crate::generated::bonfiglioli_warnings::WARNINGS;
use crate::param::{
    Access, Family, ParamMeta, ValueName, WIRE_32, contains_ignore_case, field_accessors,
};
use crate::scaling::{self, ScaleError};
use core::fmt;

pub use state::{
    ActStateMachine, AcuPositioningStateMachine, AcuStateMachine, ControlSequencer, State,
    Transition5, act_transitions,
};
pub use variant::Variant;
pub use words::{
    ActControlWord, ActStatusWord, AcuControlWord, AcuStatusWord, ContactState, RemoteContacts,
};

/// The menu a parameter is listed in (ch. 11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Menu {
    /// Actual values (`VAL`, "Istwertmenü"): read-only.
    Val,
    /// Parameters (`PARA`, "Parametermenü").
    Para,
}

impl Menu {
    /// `VAL` or `PARA`, as the manual writes it.
    pub const fn name(self) -> &'static str {
        match self {
            Menu::Val => "VAL",
            Menu::Para => "PARA",
        }
    }
}

/// The data type of a parameter on the bus (ch. 6.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataType {
    /// Unsigned 16 bit, read with function code 3, written with 6.
    UInt,
    /// Signed 16 bit, read with function code 3, written with 6.
    Int,
    /// Signed 32 bit, read with function code 100, written with 101.
    Long,
    /// The manual does not say. A master may try function code 3 and fall back to 100 on
    /// exception 2 ("data type of the parameter does not match", ch. 6.6).
    Unknown,
}

impl DataType {
    /// The name used in the manual (`uInt`, `Int`, `Long`) or `unknown type`.
    pub const fn name(self) -> &'static str {
        match self {
            DataType::UInt => "uInt",
            DataType::Int => "Int",
            DataType::Long => "Long",
            DataType::Unknown => "unknown type",
        }
    }

    /// A short key: `uInt`, `Int`, `Long` or `unknown` (the JSON column `data_type`).
    pub const fn key(self) -> &'static str {
        match self {
            DataType::Unknown => "unknown",
            known => known.name(),
        }
    }

    /// Width in bits, where known.
    pub const fn bits(self) -> Option<u8> {
        match self {
            DataType::UInt | DataType::Int => Some(16),
            DataType::Long => Some(32),
            DataType::Unknown => None,
        }
    }

    /// The raw values the type can carry, where known.
    pub const fn bounds(self) -> Option<(i64, i64)> {
        match self {
            DataType::UInt => Some((0, u16::MAX as i64)),
            DataType::Int => Some((i16::MIN as i64, i16::MAX as i64)),
            DataType::Long => Some((i32::MIN as i64, i32::MAX as i64)),
            DataType::Unknown => None,
        }
    }

    /// Whether the value travels in 32 bits (function codes 100/101). `None` when unknown.
    pub const fn is_32_bit(self) -> Option<bool> {
        match self.bits() {
            Some(b) => Some(b == 32),
            None => None,
        }
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a parameter's data type comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TypeSource {
    /// The manual names the type (e.g. ch. 9: `Steuerwort 410 (Datentyp uInt)`).
    Stated,
    /// A ch. 8 example reads or writes it with a 16-bit or 32-bit function code.
    Example,
    /// The raw range does not fit 16 bit.
    Range,
    /// The manual gives a 16-bit bit or byte layout (warnings, fault keys).
    Layout,
    /// The same quantity has a stated type (frequencies in Hz are Long).
    Analogy,
    /// Not known.
    Unknown,
}

impl TypeSource {
    /// Lowercase name: `stated`, `example`, `range`, `layout`, `analogy` or `unknown`.
    pub const fn name(self) -> &'static str {
        match self {
            TypeSource::Stated => "stated",
            TypeSource::Example => "example",
            TypeSource::Range => "range",
            TypeSource::Layout => "layout",
            TypeSource::Analogy => "analogy",
            TypeSource::Unknown => "unknown",
        }
    }
}

/// Whether a parameter can be read and written over the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParamAccess {
    /// Read-only (actual values, the error register).
    ReadOnly,
    /// Read and write.
    ReadWrite,
    /// Write-only: the ACU cannot read back P484 and P524 (ch. 10.2.3).
    WriteOnly,
}

impl ParamAccess {
    /// `read_only`, `read_write` or `write_only`.
    pub const fn name(self) -> &'static str {
        match self {
            ParamAccess::ReadOnly => "read_only",
            ParamAccess::ReadWrite => "read_write",
            ParamAccess::WriteOnly => "write_only",
        }
    }
}

/// One parameter of the Bonfiglioli tables (generated from `data/bonfiglioli/parameters.csv`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct Param {
    /// Parameter number, also the bus index (0…1599).
    pub number: u16,
    /// German name as printed in the manual.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Other German spellings the manual uses (`;`-separated), found by [`search`].
    pub aliases_de: &'static str,
    /// Menu (VAL or PARA).
    pub menu: Menu,
    /// Group heading in ch. 11 (German), may be empty.
    pub group_de: &'static str,
    /// Group heading in English, may be empty.
    pub group_en: &'static str,
    /// Data type on the bus.
    pub data_type: DataType,
    /// Evidence for [`Param::data_type`].
    pub type_source: TypeSource,
    /// Implied decimal places of the raw value.
    pub decimals: u8,
    /// Unit of the physical value (may be empty).
    pub unit: &'static str,
    /// Smallest raw value the manual gives.
    pub min: Option<i64>,
    /// Largest raw value the manual gives.
    pub max: Option<i64>,
    /// Default (factory setting), raw.
    pub default: Option<i64>,
    /// Whether the parameter exists in four data sets; `None` where the manual does not say.
    pub data_set: Option<bool>,
    /// Not writable while the drive is running.
    pub not_in_operation: bool,
    /// Set by the SETUP routine.
    pub setup: bool,
    /// Only reachable over the communication channel, not from KP500 / VPlus.
    pub bus_only: bool,
    /// Kept in RAM only, never written to EEPROM (P410, P484, P524; ch. 7).
    pub ram_only: bool,
    /// Read/write access.
    pub access: ParamAccess,
    /// Range as text, German number format.
    pub range_de: &'static str,
    /// Range as text, English number format.
    pub range_en: &'static str,
    /// Value list (empty when the manual gives none).
    pub values: &'static [ValueName],
    /// Chapters of the manual that describe it.
    pub chapters: &'static str,
    /// Evidence and remarks (English).
    pub notes: &'static str,
}

impl Param {
    /// Whether the value can be read over the bus.
    pub const fn is_readable(&self) -> bool {
        !matches!(self.access, ParamAccess::WriteOnly)
    }

    /// Whether the value can be written over the bus.
    pub const fn is_writable(&self) -> bool {
        !matches!(self.access, ParamAccess::ReadOnly)
    }

    /// Whether the value exists four times (data sets 1…4).
    pub const fn is_data_set(&self) -> bool {
        matches!(self.data_set, Some(true))
    }

    /// A label such as `P1376`.
    pub fn label(&self) -> crate::param::Label {
        crate::param::Label::new(format_args!("P{}", self.number))
    }
}

impl ParamMeta for Param {
    field_accessors!(
        name_de: &'static str,
        name_en: &'static str,
        unit: &'static str,
        range_de: &'static str,
        range_en: &'static str,
        values: &'static [ValueName],
        decimals: u8,
    );

    fn family(&self) -> Family {
        Family::Bonfiglioli
    }

    fn number(&self) -> Option<u16> {
        Some(self.number)
    }

    fn bus_index(&self) -> u16 {
        self.number
    }

    /// The data set field of the start address. 0 addresses the single value, or all four data
    /// sets of a data-set parameter at once (writes set all four; reads succeed only when the
    /// four are equal, ch. 7).
    fn sub_index(&self) -> Option<u16> {
        Some(0)
    }

    fn access(&self) -> Access {
        let mut a = match self.access {
            ParamAccess::ReadOnly => Access::READ_ONLY,
            ParamAccess::ReadWrite | ParamAccess::WriteOnly => Access::READ_WRITE,
        };
        if self.is_writable() && !self.ram_only {
            // Written values go to EEPROM automatically (ch. 7).
            a = a.union(Access::NON_VOLATILE);
        }
        if self.not_in_operation {
            a = a.union(Access::NOT_IN_OPERATION);
        }
        if self.is_data_set() {
            a = a.union(Access::DATA_SET);
        }
        a
    }

    fn default_raw(&self) -> Option<i64> {
        self.default
    }

    /// The manual's range; a missing end is filled from the data type.
    fn raw_range(&self) -> Option<(i64, i64)> {
        let tb = self.data_type.bounds();
        let lo = self.min.or(tb.map(|b| b.0))?;
        let hi = self.max.or(tb.map(|b| b.1))?;
        Some((lo, hi))
    }

    fn to_physical(&self, raw: i64) -> f64 {
        scaling::from_decimals(raw, self.decimals)
    }

    /// The data type's width (uInt, Int, Long); 32 bits of either sign where the manual gives
    /// no type.
    fn wire_range(&self) -> (i64, i64) {
        self.data_type.bounds().unwrap_or(WIRE_32)
    }

    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        let (lo, hi) = self.raw_range().unwrap_or(WIRE_32);
        scaling::to_decimals(value, self.decimals, lo, hi)
    }

    /// E.g. `2 decimals, Long (32 bit)` or `0 decimals, unknown type`.
    fn describe_scaling(&self, f: &mut dyn fmt::Write) -> fmt::Result {
        let d = self.decimals;
        let s = if d == 1 { "" } else { "s" };
        match self.data_type.bits() {
            Some(bits) => write!(f, "{d} decimal{s}, {} ({bits} bit)", self.data_type.name()),
            None => write!(f, "{d} decimal{s}, data type not given in the manual"),
        }
    }

    /// The table columns beyond the common ones; `min` / `max` are `table_min` / `table_max`,
    /// `access` is `bus_access`, the `;`-separated `aliases_de` and `chapters` are lists.
    fn family_columns(&self, out: &mut FieldSink<'_>) {
        out("table_min", self.min.into());
        out("table_max", self.max.into());
        out("group_de", Column::Text(self.group_de));
        out("group_en", Column::Text(self.group_en));
        out(
            "aliases_de",
            Column::List(&|items| text_list(self.aliases_de, ';', items)),
        );
        out("menu", Column::Text(self.menu.name()));
        out("data_type", Column::Text(self.data_type.key()));
        out("type_source", Column::Text(self.type_source.name()));
        out("data_set", self.data_set.into());
        out("not_in_operation", self.not_in_operation.into());
        out("setup", self.setup.into());
        out("bus_only", self.bus_only.into());
        out("ram_only", self.ram_only.into());
        out("bus_access", Column::Text(self.access.name()));
        out(
            "chapters",
            Column::List(&|items| text_list(self.chapters, ';', items)),
        );
        out("notes", Column::Text(self.notes));
    }

    fn name_matches(&self, term: &str) -> bool {
        contains_ignore_case(self.name_de, term)
            || contains_ignore_case(self.name_en, term)
            || contains_ignore_case(self.aliases_de, term)
    }
}

/// Every parameter, sorted by number.
pub fn params() -> &'static [Param] {
    PARAMS
}

/// The parameter with bus index `n` (for Bonfiglioli, the parameter number).
pub fn by_index(n: u16) -> Option<&'static Param> {
    by_number(n)
}

/// The parameter with number `n`.
pub fn by_number(n: u16) -> Option<&'static Param> {
    PARAMS
        .binary_search_by_key(&n, |p| p.number)
        .ok()
        .and_then(|i| PARAMS.get(i))
}

/// Look up `1376`, `P1376` or `p1376` (surrounding blanks ignored).
pub fn lookup(s: &str) -> Option<&'static Param> {
    let s = s.trim();
    let digits = s.strip_prefix(['P', 'p']).unwrap_or(s);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse::<u16>().ok().and_then(by_number)
}

/// Parameters whose German or English name (or a German alias) contains `term`, ignoring case.
pub fn search(term: &str) -> impl Iterator<Item = &'static Param> + '_ {
    PARAMS.iter().filter(move |p| p.name_matches(term))
}

/// One warning bit of parameter 270 (ch. 12.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct Warning {
    /// Bit number 0…15.
    pub bit: u8,
    /// Warning code (`1 << bit`).
    pub code: u16,
    /// German text.
    pub name_de: &'static str,
    /// English text.
    pub name_en: &'static str,
    /// A bit that is always set together with this one (bits 1 and 2 set bit 0).
    pub implies: Option<u8>,
    /// German footnote.
    pub note_de: &'static str,
    /// English footnote.
    pub note_en: &'static str,
}

/// All 16 warning bits of parameter 270, indexed by bit.
pub fn warnings() -> &'static [Warning; 16] {
    &WARNINGS
}

/// The warnings set in `word` (value of parameter 270), lowest bit first.
pub fn warning_bits(word: u16) -> impl Iterator<Item = &'static Warning> {
    WARNINGS.iter().filter(move |w| word & w.code != 0)
}

/// Whether `word` respects the footnotes of ch. 12.1 (bit 0 set whenever bit 1 or 2 is).
pub fn warnings_consistent(word: u16) -> bool {
    warning_bits(word).all(|w| w.implies.is_none_or(|b| word & (1u16 << b) != 0))
}

/// A fault key of parameter 260 (ch. 12.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct Fault {
    /// The 16-bit value: group in the high byte, code in the low byte.
    pub value: u16,
    /// The key as printed, e.g. `F2010`.
    pub key: &'static str,
    /// Group heading (German).
    pub group_de: &'static str,
    /// Group heading (English).
    pub group_en: &'static str,
    /// Meaning and advice (German).
    pub text_de: &'static str,
    /// Meaning and advice (English).
    pub text_en: &'static str,
}

impl Fault {
    /// The fault group `XX` of `FXXYY` (high byte).
    pub const fn group(&self) -> u8 {
        (self.value >> 8) as u8
    }

    /// The code `YY` of `FXXYY` (low byte).
    pub const fn code(&self) -> u8 {
        self.value as u8
    }

    /// Whether this is a fault at all (`F0000` means no fault).
    pub const fn is_fault(&self) -> bool {
        self.value != 0
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.key, self.text_en)
    }
}

/// Any value of parameter 260, listed or not; displays as `FXXYY`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FaultCode(pub u16);

impl FaultCode {
    /// The table entry, where the manual lists this key.
    pub fn meaning(self) -> Option<&'static Fault> {
        fault(self.0)
    }

    /// The group `XX` (high byte).
    pub const fn group(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// The code `YY` (low byte).
    pub const fn code(self) -> u8 {
        self.0 as u8
    }
}

impl fmt::Display for FaultCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F{:04X}", self.0)
    }
}

/// The listed fault keys, sorted by value.
pub fn faults() -> &'static [Fault] {
    FAULTS
}

/// The fault with the 16-bit value `code` (as read from parameter 260), e.g. `0x2010` → `F2010`.
/// `0` is listed too ("no fault").
pub fn fault(code: u16) -> Option<&'static Fault> {
    FAULTS
        .binary_search_by_key(&code, |f| f.value)
        .ok()
        .and_then(|i| FAULTS.get(i))
}

/// The fault with key `s`, e.g. `F0101` or `f2010`.
pub fn fault_by_key(s: &str) -> Option<&'static Fault> {
    let hex = s.trim().strip_prefix(['F', 'f'])?;
    if hex.len() != 4 {
        return None;
    }
    u16::from_str_radix(hex, 16).ok().and_then(fault)
}

/// One value of the VABus SST error register, parameter 11 (ch. 6.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct VabusError {
    /// Error number.
    pub value: u16,
    /// German meaning.
    pub name_de: &'static str,
    /// English meaning.
    pub name_en: &'static str,
}

impl fmt::Display for VabusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "VABus error {}: {}", self.value, self.name_en)
    }
}

/// The meaning of value `v` of parameter 11.
pub fn vabus_error(v: u16) -> Option<&'static VabusError> {
    VABUS_ERRORS.iter().find(|e| e.value == v)
}

/// All VABus error register values, sorted.
pub fn vabus_errors() -> &'static [VabusError] {
    VABUS_ERRORS
}

/// A Modbus exception code the drive sends (ch. 6.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct ModbusException {
    /// Exception code.
    pub code: u8,
    /// The Modbus specification's name, e.g. `ILLEGAL DATA ADDRESS`.
    pub modbus_name: &'static str,
    /// German name as printed.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Causes in this drive (German).
    pub cause_de: &'static str,
    /// Causes in this drive (English).
    pub cause_en: &'static str,
}

/// The exception with code `code`.
pub fn modbus_exception(code: u8) -> Option<&'static ModbusException> {
    EXCEPTIONS.iter().find(|e| e.code == code)
}

/// All exception codes the drive sends, sorted.
pub fn modbus_exceptions() -> &'static [ModbusException] {
    EXCEPTIONS
}

#[cfg(test)]
mod tests;
