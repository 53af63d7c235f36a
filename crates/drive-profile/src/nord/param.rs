//! NORD parameter metadata and its [`ParamMeta`] view.

use core::fmt;

use crate::columns::{Column, FieldSink};
use crate::param::{
    Access, Family, ParamMeta, ValueName, WIRE_16, contains_ignore_case, field_accessors,
};
use crate::scaling::{self, ScaleError};

/// The resolution of a parameter: the physical value of one raw step (P102: 0.01 s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    /// The step, e.g. 0.01.
    pub step: f64,
    /// Decimal places of the step.
    pub decimals: u8,
    /// The step as written in the table, e.g. `0.01`.
    pub text: &'static str,
}

/// A named array element `[-nn]` of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArrayElement {
    /// 1-based element number as the manual writes it (`[-01]` = 1).
    pub element: u8,
    /// German name (empty where the manual names the element only by number).
    pub name_de: &'static str,
    /// English name (empty where the manual names the element only by number).
    pub name_en: &'static str,
}

/// One NORD parameter (BU 0255 names these; the full lists are in the drive manuals).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// Parameter number, `P102` → 102.
    pub number: u16,
    /// PNU sent in PKE bits 0..10; equal to the number (P102 = 66h).
    pub pnu: u16,
    /// German name as printed.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Unit of the physical value (may be empty).
    pub unit: &'static str,
    /// Physical value per raw step; `None` = integer value without a known resolution.
    pub resolution: Option<Resolution>,
    /// Smallest and largest raw value, where known.
    pub raw_range: Option<(i64, i64)>,
    /// Default (factory setting) as a raw value, where known.
    pub default_raw: Option<i64>,
    /// Range in German notation, e.g. `0,00 … 320,00 s` (empty where unknown).
    pub range_de: &'static str,
    /// Range in English notation, e.g. `0.00 … 320.00 s` (empty where unknown).
    pub range_en: &'static str,
    /// Read-only (information parameters P7xx) or read-write.
    pub access: Access,
    /// Whether the parameter has one value per parameter set 1..4 (IND bits 8..9).
    pub parameter_set: bool,
    /// Number of array elements, where the parameter is an array.
    pub array_len: Option<u8>,
    /// The array elements the manual names.
    pub elements: &'static [ArrayElement],
    /// Value list, where known.
    pub values: &'static [ValueName],
    /// What the manual says about the parameter (German).
    pub description_de: &'static str,
    /// What the manual says about the parameter (English).
    pub description_en: &'static str,
    /// Where the data come from (the manual, or public NORD documentation).
    pub source: &'static str,
}

impl Param {
    /// The physical value of one raw step (1.0 without a resolution).
    pub fn step(&self) -> f64 {
        self.resolution.map_or(1.0, |r| r.step)
    }

    /// The named entry of array element `element` (1-based, `[-01]` = 1).
    pub fn element_info(&self, element: u8) -> Option<&'static ArrayElement> {
        self.elements.iter().find(|e| e.element == element)
    }

    /// A view of array element `element` (1-based) that implements [`ParamMeta`] with its
    /// sub-index; `None` when the parameter is no array or the element is out of range.
    pub fn element(&'static self, element: u8) -> Option<ParamElement> {
        let len = self.array_len?;
        (1..=len).contains(&element).then_some(ParamElement {
            param: self,
            element,
        })
    }

    /// The label shown to users, `P102`.
    pub fn label(&self) -> crate::param::Label {
        crate::param::Label::new(format_args!("P{:03}", self.number))
    }

    fn raw_min_max(&self) -> (i64, i64) {
        // Parameters are 16-bit words (BU 0255 section 6); without a range take the word's.
        self.raw_range.unwrap_or(WIRE_16)
    }

    /// Whether `term` occurs in the parameter's or an element's name (German or English).
    pub fn matches(&self, term: &str) -> bool {
        self.name_matches(term)
            || self.elements.iter().any(|e| {
                contains_ignore_case(e.name_de, term) || contains_ignore_case(e.name_en, term)
            })
    }

    /// The NORD columns beyond the common ones, for the parameter and each element view.
    fn nord_columns(&self, out: &mut FieldSink<'_>) {
        let (lo, hi) = (self.raw_range.map(|r| r.0), self.raw_range.map(|r| r.1));
        out("table_min", lo.into());
        out("table_max", hi.into());
        out("pnu", self.pnu.into());
        match self.resolution {
            Some(r) => out(
                "resolution",
                Column::Record(&|f| {
                    f("step", Column::Float(r.step));
                    f("decimals", r.decimals.into());
                    f("text", Column::Text(r.text));
                }),
            ),
            None => out("resolution", Column::Null),
        }
        out("parameter_set", self.parameter_set.into());
        out("array_len", self.array_len.into());
        out(
            "elements",
            Column::List(&|items| {
                for e in self.elements {
                    items(Column::Record(&|f| {
                        f("element", e.element.into());
                        f("name_de", Column::Text(e.name_de));
                        f("name_en", Column::Text(e.name_en));
                    }));
                }
            }),
        );
        out("description_de", Column::Text(self.description_de));
        out("description_en", Column::Text(self.description_en));
        out("source", Column::Text(self.source));
    }
}

impl ParamMeta for Param {
    field_accessors!(
        name_de: &'static str,
        name_en: &'static str,
        unit: &'static str,
        access: Access,
        default_raw: Option<i64>,
        raw_range: Option<(i64, i64)>,
        range_de: &'static str,
        range_en: &'static str,
        values: &'static [ValueName],
    );
    fn family(&self) -> Family {
        Family::Nord
    }
    fn number(&self) -> Option<u16> {
        Some(self.number)
    }
    fn bus_index(&self) -> u16 {
        self.pnu
    }
    /// A 16-bit word (BU 0255 section 6: parameters go as words; only position values, of
    /// which the table has none, go as double words).
    fn wire_range(&self) -> (i64, i64) {
        WIRE_16
    }
    fn decimals(&self) -> u8 {
        self.resolution.map_or(0, |r| r.decimals)
    }
    fn to_physical(&self, raw: i64) -> f64 {
        scaling::from_steps(raw, self.step())
    }
    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        let (lo, hi) = self.raw_min_max();
        scaling::to_steps(value, self.step(), lo, hi)
    }
    /// `pnu`, `resolution`, `parameter_set`, `array_len`, `elements`, `description_de` /
    /// `description_en` and `source`; `raw_range` gives `table_min` / `table_max`.
    fn family_columns(&self, out: &mut FieldSink<'_>) {
        self.nord_columns(out);
    }
    /// `resolution 0.01 s`, or `integer` where no resolution is known.
    fn describe_scaling(&self, f: &mut dyn fmt::Write) -> fmt::Result {
        match self.resolution {
            Some(r) if self.unit.is_empty() => write!(f, "resolution {}", r.text),
            Some(r) => write!(f, "resolution {} {}", r.text, self.unit),
            None => f.write_str("integer"),
        }
    }
}

/// One array element of a [`Param`]: the same metadata with the element's name and sub-index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamElement {
    /// The parameter.
    pub param: &'static Param,
    /// 1-based element number (`[-01]` = 1).
    pub element: u8,
}

impl ParamElement {
    fn named(&self) -> Option<&'static ArrayElement> {
        self.param
            .element_info(self.element)
            .filter(|e| !e.name_de.is_empty())
    }

    /// The label shown to users, `P700[-02]`.
    pub fn label(&self) -> crate::param::Label {
        crate::param::Label::new(format_args!(
            "P{:03}[-{:02}]",
            self.param.number, self.element
        ))
    }
}

impl ParamMeta for ParamElement {
    fn family(&self) -> Family {
        Family::Nord
    }
    fn number(&self) -> Option<u16> {
        Some(self.param.number)
    }
    fn bus_index(&self) -> u16 {
        self.param.pnu
    }
    /// The sub-index sent in IND bits 10..15 (arrays of parameter-set parameters) or 8..15:
    /// element − 1 (`[-01]` → 0).
    fn sub_index(&self) -> Option<u16> {
        u16::from(self.element).checked_sub(1)
    }
    fn name_de(&self) -> &'static str {
        self.named().map_or(self.param.name_de, |e| e.name_de)
    }
    fn name_en(&self) -> &'static str {
        self.named().map_or(self.param.name_en, |e| e.name_en)
    }
    fn unit(&self) -> &'static str {
        self.param.unit
    }
    fn access(&self) -> Access {
        self.param.access
    }
    fn default_raw(&self) -> Option<i64> {
        self.param.default_raw
    }
    fn wire_range(&self) -> (i64, i64) {
        self.param.wire_range()
    }
    fn raw_range(&self) -> Option<(i64, i64)> {
        self.param.raw_range
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
        self.param.decimals()
    }
    fn to_physical(&self, raw: i64) -> f64 {
        self.param.to_physical(raw)
    }
    fn from_physical(&self, value: f64) -> Result<i64, ScaleError> {
        self.param.from_physical(value)
    }
    fn describe_scaling(&self, f: &mut dyn fmt::Write) -> fmt::Result {
        self.param.describe_scaling(f)
    }
    /// The parameter's columns (the element shows in the common `name_*` and `sub_index`).
    fn family_columns(&self, out: &mut FieldSink<'_>) {
        self.param.nord_columns(out);
    }
    /// `P700[-02]`.
    fn label(&self) -> crate::param::Label {
        ParamElement::label(self)
    }
}
