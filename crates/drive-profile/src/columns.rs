//! Every table column of a parameter row as a typed value, without allocation.
//!
//! [`ParamMeta::columns`] calls a sink once per column with its key and a [`Column`]. The keys
//! are defined once, in [`COLUMN_KEYS`]: the union over all families. A family emits only the
//! keys its table has (the common ones and its own); a consumer that wants the same shape for
//! every family starts from [`COLUMN_KEYS`] with every key null and fills in what it receives.
//! `drivectl params <family> --json` does exactly that; `docs/params-json.md` documents every
//! key with its type and the families that fill it.
//!
//! ```
//! use drive_profile::{Column, ParamMeta, sew};
//!
//! let p000 = sew::lookup("P000").unwrap();
//! let mut size_index = None;
//! p000.columns(&mut |key, value| {
//!     if let ("size_index", Column::Int(n)) = (key, value) {
//!         size_index = Some(n);
//!     }
//! });
//! assert_eq!(size_index, Some(11));
//! ```

use core::fmt;

use crate::param::{Access, ParamMeta, ValueName};

/// Receives columns (key and value): the top-level columns of a row, or the fields of a
/// [`Column::Record`].
pub type FieldSink<'s> = dyn FnMut(&'static str, Column<'_>) + 's;

/// Receives the items of a [`Column::List`], in order.
pub type ItemSink<'s> = dyn FnMut(Column<'_>) + 's;

/// One typed value of a table column.
///
/// Nested values (lists, records) are callbacks that feed a sink, so that nothing needs to be
/// allocated; a consumer calls them as often as it likes.
#[derive(Clone, Copy)]
pub enum Column<'a> {
    /// No value in this row (e.g. no default printed).
    Null,
    /// A flag.
    Bool(bool),
    /// An integer (raw values, indices, counts).
    Int(i64),
    /// A real number (physical values, resolution steps).
    Float(f64),
    /// Text as stored in the table (may be empty).
    Text(&'a str),
    /// Text produced by formatting (access notation, scaling description).
    Formatted(&'a dyn fmt::Display),
    /// A list: feeds each item to the sink.
    List(&'a dyn Fn(&mut ItemSink<'_>)),
    /// A record of named fields: feeds each field to the sink.
    Record(&'a dyn Fn(&mut FieldSink<'_>)),
}

impl Column<'_> {
    /// The JSON type of the value: `null`, `bool`, `int`, `float`, `text`, `list` or `record`.
    pub const fn kind(&self) -> &'static str {
        match self {
            Column::Null => "null",
            Column::Bool(_) => "bool",
            Column::Int(_) => "int",
            Column::Float(_) => "float",
            Column::Text(_) | Column::Formatted(_) => "text",
            Column::List(_) => "list",
            Column::Record(_) => "record",
        }
    }
}

impl fmt::Debug for Column<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Column::Null => f.write_str("Null"),
            Column::Bool(b) => f.debug_tuple("Bool").field(&b).finish(),
            Column::Int(n) => f.debug_tuple("Int").field(&n).finish(),
            Column::Float(x) => f.debug_tuple("Float").field(&x).finish(),
            Column::Text(s) => f.debug_tuple("Text").field(&s).finish(),
            Column::Formatted(d) => write!(f, "Formatted({d})"),
            Column::List(items) => {
                let mut list = f.debug_list();
                items(&mut |c| {
                    list.entry(&c);
                });
                list.finish()
            }
            Column::Record(fields) => {
                let mut map = f.debug_map();
                fields(&mut |k, c| {
                    map.entry(&k, &c);
                });
                map.finish()
            }
        }
    }
}

impl From<bool> for Column<'_> {
    fn from(b: bool) -> Self {
        Column::Bool(b)
    }
}

macro_rules! int_columns {
    ($($t:ty),*) => {
        $(
            impl From<$t> for Column<'_> {
                fn from(n: $t) -> Self {
                    Column::Int(i64::from(n))
                }
            }
        )*
    };
}

int_columns!(u8, u16, u32, i16, i32, i64);

impl From<f64> for Column<'_> {
    fn from(x: f64) -> Self {
        Column::Float(x)
    }
}

impl<'a> From<&'a str> for Column<'a> {
    fn from(s: &'a str) -> Self {
        Column::Text(s)
    }
}

impl<'a, T: Into<Column<'a>>> From<Option<T>> for Column<'a> {
    /// `None` becomes [`Column::Null`].
    fn from(v: Option<T>) -> Self {
        v.map_or(Column::Null, Into::into)
    }
}

/// Every column key any family emits, in display order: the columns every family has first,
/// then SEW's, NORD's and Bonfiglioli's. See `docs/params-json.md` for types and meanings.
pub const COLUMN_KEYS: &[&str] = &[
    // Every family.
    "family",
    "number",
    "param_number",
    "index",
    "sub_index",
    "name_de",
    "name_en",
    "unit",
    "access",
    "access_flags",
    "default",
    "default_value",
    "range",
    "table_min",
    "table_max",
    "range_de",
    "range_en",
    "decimals",
    "scaling",
    "values",
    // Groups (SEW: code and heading; Bonfiglioli: heading).
    "group",
    "group_de",
    "group_en",
    // SEW MOVIDRIVE.
    "parent",
    "sub",
    "md60a_only",
    "index_hex",
    "index2",
    "pno_unit",
    "display_unit",
    "size_index",
    "conversion_index",
    "display_conversion_index",
    "default2",
    "default_outside_range",
    "range_segments",
    "values_ref",
    "errata",
    // NORD.
    "pnu",
    "resolution",
    "parameter_set",
    "array_len",
    "elements",
    "description_de",
    "description_en",
    "source",
    // Bonfiglioli.
    "aliases_de",
    "menu",
    "data_type",
    "type_source",
    "data_set",
    "not_in_operation",
    "setup",
    "bus_only",
    "ram_only",
    "bus_access",
    "chapters",
    "notes",
];

/// The keys every family emits, from [`ParamMeta`] alone ([`common_columns`] plus
/// `table_min` / `table_max`, which each family fills from its own range columns): the first
/// block of [`COLUMN_KEYS`], up to `values`.
pub const COMMON_KEYS: &[&str] = COLUMN_KEYS.split_at(COMMON_KEY_COUNT).0;

/// How many of [`COLUMN_KEYS`] every family emits.
const COMMON_KEY_COUNT: usize = 20;

/// [`ParamMeta::describe_scaling`] as a [`fmt::Display`].
struct Scaling<'p, P: ?Sized>(&'p P);

impl<P: ParamMeta + ?Sized> fmt::Display for Scaling<'_, P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.describe_scaling(f)
    }
}

/// The access flags as a record of booleans, named after the [`Access`] constants.
fn access_flags(a: Access, out: &mut FieldSink<'_>) {
    let flags = [
        ("non_volatile", Access::NON_VOLATILE),
        ("store_locked", Access::STORE_LOCKED),
        ("needs_inhibit", Access::NEEDS_INHIBIT),
        ("read_only", Access::READ_ONLY),
        ("read_write", Access::READ_WRITE),
        ("not_in_operation", Access::NOT_IN_OPERATION),
        ("data_set", Access::DATA_SET),
    ];
    for (name, flag) in flags {
        out(name, Column::Bool(a.contains(flag)));
    }
}

/// A value list as a list of `{value, de, en}` records.
pub(crate) fn value_list(values: &[ValueName], out: &mut ItemSink<'_>) {
    for v in values {
        out(Column::Record(&|f| {
            f("value", Column::Int(v.value));
            f("de", Column::Text(v.de));
            f("en", Column::Text(v.en));
        }));
    }
}

/// The parts of `text` between `sep`, trimmed, empty parts left out, as a list of text.
pub(crate) fn text_list(text: &str, sep: char, out: &mut ItemSink<'_>) {
    for part in text.split(sep).map(str::trim).filter(|s| !s.is_empty()) {
        out(Column::Text(part));
    }
}

/// The columns every family has, from the [`ParamMeta`] methods: `family` … `values` of
/// [`COMMON_KEYS`] except `table_min` / `table_max`.
pub fn common_columns<P: ParamMeta + ?Sized>(p: &P, out: &mut FieldSink<'_>) {
    let label = p.label();
    let access = p.access();
    out("family", Column::Text(p.family().name()));
    out("number", Column::Text(label.as_str()));
    out("param_number", p.number().into());
    out("index", p.bus_index().into());
    out("sub_index", p.sub_index().into());
    out("name_de", Column::Text(p.name_de()));
    out("name_en", Column::Text(p.name_en()));
    out("unit", Column::Text(p.unit()));
    out("access", Column::Formatted(&access));
    out("access_flags", Column::Record(&|f| access_flags(access, f)));
    out("default", p.default_raw().into());
    out(
        "default_value",
        p.default_raw().map(|d| p.to_physical(d)).into(),
    );
    match p.raw_range() {
        Some((lo, hi)) => out(
            "range",
            Column::Record(&|f| {
                f("min", Column::Int(lo));
                f("max", Column::Int(hi));
                f("min_value", Column::Float(p.to_physical(lo)));
                f("max_value", Column::Float(p.to_physical(hi)));
            }),
        ),
        None => out("range", Column::Null),
    }
    out("range_de", Column::Text(p.range_de()));
    out("range_en", Column::Text(p.range_en()));
    out("decimals", p.decimals().into());
    out("scaling", Column::Formatted(&Scaling(p)));
    out(
        "values",
        Column::List(&|items| value_list(p.values(), items)),
    );
}

#[cfg(test)]
mod tests;
