//! A metric's value in the field its datatype gives (specification ch. 6, "Datatype Details").
//!
//! | datatype | field |
//! |---|---|
//! | Int8, Int16, Int32, UInt8, UInt16 | `int_value` (`uint32`) |
//! | Int64, UInt64, DateTime | `long_value` (`uint64`) |
//! | UInt32 | `long_value` when sent; read from `int_value` or `long_value` |
//! | Float | `float_value` |
//! | Double | `double_value` |
//! | Boolean | `boolean_value` |
//! | String, Text | `string_value` |
//!
//! Signed integers travel in the unsigned fields as two's complement; the specification does
//! not say of which width, and the implementations differ: Tahu's Java encoder sign-extends
//! Int8 and Int16 to 32 bits (-1 is `0xFFFF_FFFF`), the Python hosts (Tahu's Python library,
//! pysparkplug) use the type's own width (-1 is `0xFFFF`) and refuse the 32-bit form as out of
//! range, while Tahu's Java decoder takes either (it casts to `byte` or `short`). [`set`] sends
//! the own-width form, which every one of them reads; [`get`] takes both (they never overlap:
//! `0x0000_0080..=0x0000_FFFF` against `0xFFFF_8000..`). Int32 in 32 bits, Int64 in 64.
//! `docs/errata-sparkplug.md` records it.
//!
//! UInt32: the specification's table names protobuf `uint32` (`int_value`), the Tahu encoders
//! and the specification's compatibility kit send `long_value`. [`set`] sends `long_value`, as
//! the host applications built on Tahu expect; [`get`] reads either.
//!
//! Datasets, templates, bytes, files, UUIDs and the array datatypes are not values a drive
//! point has: [`set`] and [`get`] refuse them ([`ValueError::Unsupported`]).

use crate::proto::DataType;
use crate::proto::payload::{Metric, metric, property_value};
use alloc::borrow::ToOwned;
use alloc::string::String;
use core::fmt;

/// A metric's value as the gateway has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value<'a> {
    /// A signed integer, for any integer datatype (or DateTime) whose range holds it.
    Int(i64),
    /// An unsigned integer, for any integer datatype (or DateTime) whose range holds it.
    UInt(u64),
    /// A 32-bit float, for Float or Double.
    Float(f32),
    /// A 64-bit float, for Double, or for Float when it converts exactly.
    Double(f64),
    /// A boolean, for Boolean.
    Bool(bool),
    /// Text, for String or Text.
    Text(&'a str),
}

impl Value<'_> {
    /// What kind of value this is.
    pub fn kind(&self) -> ValueKind {
        match self {
            Value::Int(_) => ValueKind::Int,
            Value::UInt(_) => ValueKind::UInt,
            Value::Float(_) => ValueKind::Float,
            Value::Double(_) => ValueKind::Double,
            Value::Bool(_) => ValueKind::Bool,
            Value::Text(_) => ValueKind::Text,
        }
    }
}

/// The kinds of [`Value`], for errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueKind {
    /// [`Value::Int`].
    Int,
    /// [`Value::UInt`].
    UInt,
    /// [`Value::Float`].
    Float,
    /// [`Value::Double`].
    Double,
    /// [`Value::Bool`].
    Bool,
    /// [`Value::Text`].
    Text,
}

impl fmt::Display for ValueKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ValueKind::Int => "a signed integer",
            ValueKind::UInt => "an unsigned integer",
            ValueKind::Float => "a 32-bit float",
            ValueKind::Double => "a 64-bit float",
            ValueKind::Bool => "a boolean",
            ValueKind::Text => "a text",
        })
    }
}

/// A command metric's value, read back for its datatype by [`get`].
#[derive(Clone, Debug, PartialEq)]
pub enum Number {
    /// Any integer datatype (Int8 … UInt64) and DateTime (milliseconds since the epoch).
    Int(i64),
    /// Float or Double.
    Float(f64),
    /// Boolean.
    Bool(bool),
    /// String or Text.
    Text(String),
}

/// The value fields of the schema, as [`ValueError::WrongField`] names them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Field {
    /// `int_value`.
    IntValue,
    /// `long_value`.
    LongValue,
    /// `float_value`.
    FloatValue,
    /// `double_value`.
    DoubleValue,
    /// `boolean_value`.
    BooleanValue,
    /// `string_value`.
    StringValue,
    /// `bytes_value`.
    BytesValue,
    /// `dataset_value`.
    DatasetValue,
    /// `template_value`.
    TemplateValue,
    /// `propertyset_value`.
    PropertysetValue,
    /// `propertysets_value`.
    PropertysetsValue,
    /// `extension_value`.
    ExtensionValue,
}

impl Field {
    /// The field's name in the schema.
    pub fn as_str(self) -> &'static str {
        match self {
            Field::IntValue => "int_value",
            Field::LongValue => "long_value",
            Field::FloatValue => "float_value",
            Field::DoubleValue => "double_value",
            Field::BooleanValue => "boolean_value",
            Field::StringValue => "string_value",
            Field::BytesValue => "bytes_value",
            Field::DatasetValue => "dataset_value",
            Field::TemplateValue => "template_value",
            Field::PropertysetValue => "propertyset_value",
            Field::PropertysetsValue => "propertysets_value",
            Field::ExtensionValue => "extension_value",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a value was not set or not read back.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ValueError {
    /// The integer is outside the datatype's range (for a received signed datatype: the
    /// field read as two's complement of its width).
    #[error("{value} is out of range for {}", .datatype.as_str_name())]
    OutOfRange {
        /// The datatype.
        datatype: DataType,
        /// The value.
        value: i128,
    },
    /// A 64-bit float that a Float would not hold exactly.
    #[error("{value} is not exactly a {}", .datatype.as_str_name())]
    Inexact {
        /// The datatype.
        datatype: DataType,
        /// The value.
        value: f64,
    },
    /// A value of a kind the datatype does not take (text for Int16, an integer for Double, …).
    #[error("{kind} value cannot be sent as {}", .datatype.as_str_name())]
    WrongKind {
        /// The datatype.
        datatype: DataType,
        /// The value's kind.
        kind: ValueKind,
    },
    /// The metric's value is in a field that does not belong to the datatype.
    #[error("value in {field}, which does not carry {}", .datatype.as_str_name())]
    WrongField {
        /// The datatype.
        datatype: DataType,
        /// The field the value is in.
        field: Field,
    },
    /// The metric has no value and is not marked null.
    #[error("the {} metric has no value", .datatype.as_str_name())]
    Missing {
        /// The datatype.
        datatype: DataType,
    },
    /// The metric is marked null (`is_null`).
    #[error("the {} metric is null", .datatype.as_str_name())]
    Null {
        /// The datatype.
        datatype: DataType,
    },
    /// A datatype this module does not handle: Unknown, UUID, DataSet, Bytes, File, Template,
    /// PropertySet, PropertySetList and the arrays.
    #[error("{} values are not supported", .datatype.as_str_name())]
    Unsupported {
        /// The datatype.
        datatype: DataType,
    },
    /// A UInt64 or DateTime above `i64::MAX`, which [`Number::Int`] does not hold.
    #[error("{value} ({}) is above the largest number read back, {max}", .datatype.as_str_name(), max = i64::MAX)]
    TooLarge {
        /// The datatype.
        datatype: DataType,
        /// The value.
        value: u64,
    },
    /// A datatype number that is not in the specification's list.
    #[error("datatype {0} is not a Sparkplug datatype")]
    UnknownDataType(u32),
}

/// The datatype with the number `code` (a metric's `datatype`, a property value's `type`).
pub fn data_type(code: u32) -> Result<DataType, ValueError> {
    i32::try_from(code)
        .ok()
        .and_then(|c| DataType::try_from(c).ok())
        .ok_or(ValueError::UnknownDataType(code))
}

/// A metric's own datatype: `None` when it has none (usual in data and command messages).
pub fn metric_type(metric: &Metric) -> Result<Option<DataType>, ValueError> {
    metric.datatype.map(data_type).transpose()
}

/// Set `metric.datatype` and the value field the specification gives that datatype from
/// `value` (see the [module](self) for the table), and clear `is_null`.
///
/// Refuses a value that does not fit the datatype (out of its range, of another kind, a
/// Double that is not exactly a Float) and the datatypes this module does not handle; then
/// nothing is set.
pub fn set(metric: &mut Metric, datatype: DataType, value: Value<'_>) -> Result<(), ValueError> {
    let raw = encode(datatype, value)?;
    metric.datatype = Some(datatype as u32);
    metric.value = Some(match raw {
        Raw::Int(x) => metric::Value::IntValue(x),
        Raw::Long(x) => metric::Value::LongValue(x),
        Raw::Float(x) => metric::Value::FloatValue(x),
        Raw::Double(x) => metric::Value::DoubleValue(x),
        Raw::Bool(x) => metric::Value::BooleanValue(x),
        Raw::Str(x) => metric::Value::StringValue(x.to_owned()),
        // `encode` makes none of the others.
        Raw::Other(_) => return Err(ValueError::Unsupported { datatype }),
    });
    metric.is_null = None;
    Ok(())
}

/// Mark `metric` null with its datatype (a point not read yet, in a birth): `datatype` set,
/// `is_null` true, no value. Refuses Unknown, which is no datatype.
pub fn set_null(metric: &mut Metric, datatype: DataType) -> Result<(), ValueError> {
    if datatype == DataType::Unknown {
        return Err(ValueError::Unsupported { datatype });
    }
    metric.datatype = Some(datatype as u32);
    metric.value = None;
    metric.is_null = Some(true);
    Ok(())
}

/// A command metric's value read back for `datatype` (the metric's own datatype when it has
/// one, else the one the birth gave; a metric whose own datatype disagrees with the birth's is
/// the caller's to refuse).
///
/// Int* and UInt* and DateTime give [`Number::Int`], Float and Double [`Number::Float`],
/// Boolean [`Number::Bool`], String and Text [`Number::Text`]. Refuses a null metric, one
/// without a value, a value in a field that is not the datatype's, an integer outside the
/// datatype's range (UInt8 with 300, Int16 with `0x8000`), a UInt64 above `i64::MAX`, and
/// the datatypes this module does not handle.
pub fn get(metric: &Metric, datatype: DataType) -> Result<Number, ValueError> {
    if metric.is_null == Some(true) {
        return Err(ValueError::Null { datatype });
    }
    let raw = match &metric.value {
        None => return Err(ValueError::Missing { datatype }),
        Some(metric::Value::IntValue(x)) => Raw::Int(*x),
        Some(metric::Value::LongValue(x)) => Raw::Long(*x),
        Some(metric::Value::FloatValue(x)) => Raw::Float(*x),
        Some(metric::Value::DoubleValue(x)) => Raw::Double(*x),
        Some(metric::Value::BooleanValue(x)) => Raw::Bool(*x),
        Some(metric::Value::StringValue(x)) => Raw::Str(x),
        Some(metric::Value::BytesValue(_)) => Raw::Other(Field::BytesValue),
        Some(metric::Value::DatasetValue(_)) => Raw::Other(Field::DatasetValue),
        Some(metric::Value::TemplateValue(_)) => Raw::Other(Field::TemplateValue),
        Some(metric::Value::ExtensionValue(_)) => Raw::Other(Field::ExtensionValue),
    };
    number(datatype, raw)
}

/// The smallest integer datatype that holds every value of `min..=max` (the ends in either
/// order): UInt8, UInt16, UInt32 or UInt64 when neither is negative, else Int8, Int16, Int32
/// or Int64. `-32768..=32767` is Int16, `0..=65535` UInt16, `-1..=255` Int16.
pub fn integer_type(min: i64, max: i64) -> DataType {
    let (lo, hi) = if min <= max { (min, max) } else { (max, min) };
    if lo >= 0 {
        if hi <= u8::MAX.into() {
            DataType::UInt8
        } else if hi <= u16::MAX.into() {
            DataType::UInt16
        } else if hi <= u32::MAX.into() {
            DataType::UInt32
        } else {
            DataType::UInt64
        }
    } else {
        let fits = |l: i64, h: i64| lo >= l && hi <= h;
        if fits(i8::MIN.into(), i8::MAX.into()) {
            DataType::Int8
        } else if fits(i16::MIN.into(), i16::MAX.into()) {
            DataType::Int16
        } else if fits(i32::MIN.into(), i32::MAX.into()) {
            DataType::Int32
        } else {
            DataType::Int64
        }
    }
}

/// A value field of a metric or property value, as it is on the wire.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Raw<'a> {
    Int(u32),
    Long(u64),
    Float(f32),
    Double(f64),
    Bool(bool),
    Str(&'a str),
    Other(Field),
}

impl Raw<'_> {
    fn field(self) -> Field {
        match self {
            Raw::Int(_) => Field::IntValue,
            Raw::Long(_) => Field::LongValue,
            Raw::Float(_) => Field::FloatValue,
            Raw::Double(_) => Field::DoubleValue,
            Raw::Bool(_) => Field::BooleanValue,
            Raw::Str(_) => Field::StringValue,
            Raw::Other(f) => f,
        }
    }
}

/// Whether [`set`] and [`get`] handle `datatype`.
fn supported(datatype: DataType) -> bool {
    use DataType::*;
    matches!(
        datatype,
        Int8 | Int16
            | Int32
            | Int64
            | UInt8
            | UInt16
            | UInt32
            | UInt64
            | Float
            | Double
            | Boolean
            | String
            | DateTime
            | Text
    )
}

/// The inclusive range of an integer datatype (DateTime: milliseconds, not negative).
fn range(datatype: DataType) -> Option<(i128, i128)> {
    use DataType::*;
    Some(match datatype {
        Int8 => (i8::MIN.into(), i8::MAX.into()),
        Int16 => (i16::MIN.into(), i16::MAX.into()),
        Int32 => (i32::MIN.into(), i32::MAX.into()),
        Int64 => (i64::MIN.into(), i64::MAX.into()),
        UInt8 => (0, u8::MAX.into()),
        UInt16 => (0, u16::MAX.into()),
        UInt32 => (0, u32::MAX.into()),
        UInt64 | DateTime => (0, u64::MAX.into()),
        _ => return None,
    })
}

/// `value` in the field of `datatype`, checked.
pub(crate) fn encode<'a>(datatype: DataType, value: Value<'a>) -> Result<Raw<'a>, ValueError> {
    use DataType as T;
    if !supported(datatype) {
        return Err(ValueError::Unsupported { datatype });
    }
    let wrong = ValueError::WrongKind {
        datatype,
        kind: value.kind(),
    };
    let integer = match value {
        Value::Int(i) => Some(i128::from(i)),
        Value::UInt(u) => Some(i128::from(u)),
        _ => None,
    };
    if let Some((lo, hi)) = range(datatype) {
        let n = integer.ok_or(wrong)?;
        if n < lo || n > hi {
            return Err(ValueError::OutOfRange { datatype, value: n });
        }
        let out_of_range = ValueError::OutOfRange { datatype, value: n };
        return match datatype {
            // Int8 and Int16 in the two's complement of their own width (-1 is 0xFF, 0xFFFF):
            // what the Python hosts take (pysparkplug refuses a sign-extended one as out of
            // range) and what Tahu's Java decoder reads too (it casts the field to byte or
            // short). Int32 in 32 bits.
            T::Int8 => i8::try_from(n)
                .map(|x| Raw::Int(u32::from(x.cast_unsigned())))
                .map_err(|_| out_of_range),
            T::Int16 => i16::try_from(n)
                .map(|x| Raw::Int(u32::from(x.cast_unsigned())))
                .map_err(|_| out_of_range),
            T::Int32 => i32::try_from(n)
                .map(|x| Raw::Int(x.cast_unsigned()))
                .map_err(|_| out_of_range),
            T::UInt8 | T::UInt16 => u32::try_from(n).map(Raw::Int).map_err(|_| out_of_range),
            T::Int64 => i64::try_from(n)
                .map(|x| Raw::Long(x.cast_unsigned()))
                .map_err(|_| out_of_range),
            _ => u64::try_from(n).map(Raw::Long).map_err(|_| out_of_range),
        };
    }
    match (datatype, value) {
        (T::Float, Value::Float(f)) => Ok(Raw::Float(f)),
        (T::Float, Value::Double(d)) => {
            let f = d as f32;
            if f64::from(f) == d || d.is_nan() {
                Ok(Raw::Float(f))
            } else {
                Err(ValueError::Inexact { datatype, value: d })
            }
        }
        (T::Double, Value::Float(f)) => Ok(Raw::Double(f.into())),
        (T::Double, Value::Double(d)) => Ok(Raw::Double(d)),
        (T::Boolean, Value::Bool(b)) => Ok(Raw::Bool(b)),
        (T::String | T::Text, Value::Text(s)) => Ok(Raw::Str(s)),
        _ => Err(wrong),
    }
}

/// The value of a `raw` field read for `datatype`, checked.
pub(crate) fn number(datatype: DataType, raw: Raw<'_>) -> Result<Number, ValueError> {
    use DataType as T;
    if !supported(datatype) {
        return Err(ValueError::Unsupported { datatype });
    }
    let checked = |n: i128| match range(datatype) {
        Some((lo, hi)) if n >= lo && n <= hi => {
            i64::try_from(n).map_err(|_| ValueError::TooLarge {
                datatype,
                value: u64::try_from(n).unwrap_or(u64::MAX),
            })
        }
        _ => Err(ValueError::OutOfRange { datatype, value: n }),
    };
    match (datatype, raw) {
        // Int8 and Int16 in either form a sender uses: the two's complement of their own
        // width (0xFF is -1 for Int8) or sign-extended to 32 bits (0xFFFF_FFFF is -1); the two
        // never overlap. Int32: the 32 bits read as a signed number.
        (T::Int8, Raw::Int(x)) if x <= 0xFF => Ok(Number::Int(i64::from((x as u8).cast_signed()))),
        (T::Int16, Raw::Int(x)) if x <= 0xFFFF => {
            Ok(Number::Int(i64::from((x as u16).cast_signed())))
        }
        (T::Int8 | T::Int16 | T::Int32, Raw::Int(x)) => {
            checked(x.cast_signed().into()).map(Number::Int)
        }
        (T::Int64, Raw::Long(x)) => Ok(Number::Int(x.cast_signed())),
        (T::UInt8 | T::UInt16 | T::UInt32, Raw::Int(x)) => checked(x.into()).map(Number::Int),
        (T::UInt32 | T::UInt64 | T::DateTime, Raw::Long(x)) => checked(x.into()).map(Number::Int),
        (T::Float, Raw::Float(f)) => Ok(Number::Float(f.into())),
        (T::Double, Raw::Double(d)) => Ok(Number::Float(d)),
        (T::Boolean, Raw::Bool(b)) => Ok(Number::Bool(b)),
        (T::String | T::Text, Raw::Str(s)) => Ok(Number::Text(s.to_owned())),
        (_, raw) => Err(ValueError::WrongField {
            datatype,
            field: raw.field(),
        }),
    }
}

/// The raw field of a property value.
pub(crate) fn property_raw(value: &property_value::Value) -> Raw<'_> {
    use property_value::Value as V;
    match value {
        V::IntValue(x) => Raw::Int(*x),
        V::LongValue(x) => Raw::Long(*x),
        V::FloatValue(x) => Raw::Float(*x),
        V::DoubleValue(x) => Raw::Double(*x),
        V::BooleanValue(x) => Raw::Bool(*x),
        V::StringValue(x) => Raw::Str(x),
        V::PropertysetValue(_) => Raw::Other(Field::PropertysetValue),
        V::PropertysetsValue(_) => Raw::Other(Field::PropertysetsValue),
        V::ExtensionValue(_) => Raw::Other(Field::ExtensionValue),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;
    use metric::Value as M;

    fn with(datatype: DataType, value: Value<'_>) -> Result<Metric, ValueError> {
        let mut m = Metric::default();
        set(&mut m, datatype, value).map(|()| m)
    }

    /// The datatype → field table of ch. 6 for every basic datatype, and the value read back.
    #[test]
    fn every_basic_datatype_goes_in_its_field() {
        use DataType as T;
        let cases: &[(DataType, Value, M, Number)] = &[
            (T::Int8, Value::Int(100), M::IntValue(100), Number::Int(100)),
            (
                T::Int16,
                Value::Int(30000),
                M::IntValue(30000),
                Number::Int(30000),
            ),
            (
                T::Int32,
                Value::Int(-1),
                M::IntValue(0xFFFF_FFFF),
                Number::Int(-1),
            ),
            (
                T::Int64,
                Value::Int(-2),
                M::LongValue(u64::MAX - 1),
                Number::Int(-2),
            ),
            (
                T::UInt8,
                Value::UInt(255),
                M::IntValue(255),
                Number::Int(255),
            ),
            (
                T::UInt16,
                Value::Int(65535),
                M::IntValue(65535),
                Number::Int(65535),
            ),
            (
                T::UInt32,
                Value::UInt(4_294_967_295),
                M::LongValue(4_294_967_295),
                Number::Int(4_294_967_295),
            ),
            (
                T::UInt64,
                Value::UInt(1 << 40),
                M::LongValue(1 << 40),
                Number::Int(1 << 40),
            ),
            (
                T::Float,
                Value::Float(12.1),
                M::FloatValue(12.1),
                Number::Float(f64::from(12.1f32)),
            ),
            (
                T::Double,
                Value::Double(0.1),
                M::DoubleValue(0.1),
                Number::Float(0.1),
            ),
            (
                T::Boolean,
                Value::Bool(true),
                M::BooleanValue(true),
                Number::Bool(true),
            ),
            (
                T::String,
                Value::Text("Raspbian"),
                M::StringValue("Raspbian".into()),
                Number::Text("Raspbian".into()),
            ),
            (
                T::DateTime,
                Value::UInt(1_486_144_502_122),
                M::LongValue(1_486_144_502_122),
                Number::Int(1_486_144_502_122),
            ),
            (
                T::Text,
                Value::Text("Pi 3 Model B"),
                M::StringValue("Pi 3 Model B".into()),
                Number::Text("Pi 3 Model B".into()),
            ),
        ];
        for (datatype, value, field, number) in cases {
            let m = with(*datatype, *value).unwrap();
            assert_eq!(m.datatype, Some(*datatype as u32), "{datatype:?}");
            assert_eq!(m.value.as_ref(), Some(field), "{datatype:?}");
            assert_eq!(get(&m, *datatype).as_ref(), Ok(number), "{datatype:?}");
        }
    }

    #[test]
    fn negative_small_integers_go_in_their_own_width_and_are_read_in_either() {
        for (datatype, value, bits, extended) in [
            (DataType::Int8, -1, 0xFF, 0xFFFF_FFFF),
            (DataType::Int8, -128, 0x80, 0xFFFF_FF80),
            (DataType::Int16, -87, 0xFFA9, 0xFFFF_FFA9),
            (DataType::Int16, -32768, 0x8000, 0xFFFF_8000),
            (
                DataType::Int32,
                i64::from(i32::MIN),
                0x8000_0000,
                0x8000_0000,
            ),
        ] {
            let m = with(datatype, Value::Int(value)).unwrap();
            assert_eq!(m.value, Some(M::IntValue(bits)), "{datatype:?} {value}");
            assert_eq!(get(&m, datatype), Ok(Number::Int(value)));
            // Tahu's Java encoder sends the sign-extended form: read as the same value.
            let ext = received(Some(M::IntValue(extended)));
            assert_eq!(
                get(&ext, datatype),
                Ok(Number::Int(value)),
                "{datatype:?} {extended:#x}"
            );
        }
        // Positive values are the same in both forms.
        let m = with(DataType::Int16, Value::Int(300)).unwrap();
        assert_eq!(m.value, Some(M::IntValue(300)));
    }

    #[test]
    fn a_value_outside_the_datatypes_range_is_refused_and_nothing_set() {
        for (datatype, value) in [
            (DataType::Int8, Value::Int(128)),
            (DataType::Int8, Value::Int(-129)),
            (DataType::Int16, Value::UInt(32768)),
            (DataType::Int32, Value::Int(1 << 31)),
            (DataType::Int64, Value::UInt(1 << 63)),
            (DataType::UInt8, Value::Int(300)),
            (DataType::UInt8, Value::Int(-1)),
            (DataType::UInt16, Value::Int(65536)),
            (DataType::UInt32, Value::Int(1 << 32)),
            (DataType::UInt64, Value::Int(-1)),
            (DataType::DateTime, Value::Int(-1)),
        ] {
            let mut m = Metric {
                name: Some("p".into()),
                ..Metric::default()
            };
            let before = m.clone();
            let err = set(&mut m, datatype, value).unwrap_err();
            assert!(matches!(err, ValueError::OutOfRange { .. }), "{err:?}");
            assert_eq!(m, before, "{datatype:?}");
        }
        assert_eq!(
            with(DataType::UInt8, Value::Int(300))
                .unwrap_err()
                .to_string(),
            "300 is out of range for UInt8"
        );
    }

    #[test]
    fn values_of_another_kind_are_refused() {
        let err = with(DataType::Int16, Value::Text("5")).unwrap_err();
        assert_eq!(err.to_string(), "a text value cannot be sent as Int16");
        let err = with(DataType::Double, Value::Int(5)).unwrap_err();
        assert_eq!(
            err.to_string(),
            "a signed integer value cannot be sent as Double"
        );
        assert!(with(DataType::Boolean, Value::UInt(1)).is_err());
        assert!(with(DataType::String, Value::Bool(true)).is_err());
        let err = with(DataType::Float, Value::Double(0.1)).unwrap_err();
        assert_eq!(err.to_string(), "0.1 is not exactly a Float");
        assert_eq!(
            with(DataType::Float, Value::Double(0.5)).unwrap().value,
            Some(M::FloatValue(0.5))
        );
        for datatype in [
            DataType::Unknown,
            DataType::Uuid,
            DataType::Bytes,
            DataType::DataSet,
            DataType::Int16Array,
        ] {
            assert_eq!(
                with(datatype, Value::Int(1)),
                Err(ValueError::Unsupported { datatype })
            );
        }
    }

    fn received(value: Option<M>) -> Metric {
        Metric {
            alias: Some(3),
            value,
            ..Metric::default()
        }
    }

    #[test]
    fn get_refuses_what_does_not_belong_to_the_datatype() {
        // UInt8 with 300 in int_value.
        let err = get(&received(Some(M::IntValue(300))), DataType::UInt8).unwrap_err();
        assert_eq!(
            err,
            ValueError::OutOfRange {
                datatype: DataType::UInt8,
                value: 300
            }
        );
        // Int16 with a 32-bit value that is neither its own width nor sign-extended from 16.
        let err = get(&received(Some(M::IntValue(0x0001_0000))), DataType::Int16).unwrap_err();
        assert_eq!(err.to_string(), "65536 is out of range for Int16");
        // Int8 with a 32-bit value that is not sign-extended from 8 bits.
        let err = get(&received(Some(M::IntValue(0x8000_0000))), DataType::Int8).unwrap_err();
        assert_eq!(err.to_string(), "-2147483648 is out of range for Int8");
        // A oneof field that does not match.
        let err = get(&received(Some(M::LongValue(5))), DataType::Int16).unwrap_err();
        assert_eq!(
            err.to_string(),
            "value in long_value, which does not carry Int16"
        );
        let err = get(
            &received(Some(M::StringValue("1".into()))),
            DataType::Boolean,
        )
        .unwrap_err();
        assert_eq!(
            err,
            ValueError::WrongField {
                datatype: DataType::Boolean,
                field: Field::StringValue
            }
        );
        assert!(get(&received(Some(M::DoubleValue(1.0))), DataType::Float).is_err());
        // No value, and null.
        let err = get(&received(None), DataType::Double).unwrap_err();
        assert_eq!(err.to_string(), "the Double metric has no value");
        let null = Metric {
            is_null: Some(true),
            ..received(None)
        };
        assert_eq!(
            get(&null, DataType::Double),
            Err(ValueError::Null {
                datatype: DataType::Double
            })
        );
        // Null wins over a value: a value marked null is not acted on.
        let null = Metric {
            is_null: Some(true),
            ..received(Some(M::DoubleValue(1.0)))
        };
        assert_eq!(
            get(&null, DataType::Double),
            Err(ValueError::Null {
                datatype: DataType::Double
            })
        );
        // Bytes, datasets and templates are not read.
        let bytes = received(Some(M::BytesValue(alloc::vec![1, 2])));
        assert_eq!(
            get(&bytes, DataType::Bytes),
            Err(ValueError::Unsupported {
                datatype: DataType::Bytes
            })
        );
        assert_eq!(
            get(&bytes, DataType::Int32),
            Err(ValueError::WrongField {
                datatype: DataType::Int32,
                field: Field::BytesValue
            })
        );
        // UInt32 from either field; UInt64 above i64::MAX does not fit a Number.
        assert_eq!(
            get(&received(Some(M::IntValue(7))), DataType::UInt32),
            Ok(Number::Int(7))
        );
        assert_eq!(
            get(&received(Some(M::LongValue(7))), DataType::UInt32),
            Ok(Number::Int(7))
        );
        assert!(get(&received(Some(M::LongValue(1 << 32))), DataType::UInt32).is_err());
        let err = get(&received(Some(M::LongValue(u64::MAX))), DataType::UInt64).unwrap_err();
        assert_eq!(
            err,
            ValueError::TooLarge {
                datatype: DataType::UInt64,
                value: u64::MAX
            }
        );
    }

    #[test]
    fn set_null_marks_the_metric_null() {
        let mut m = with(DataType::Int16, Value::Int(5)).unwrap();
        set_null(&mut m, DataType::Int16).unwrap();
        assert_eq!(
            (m.datatype, m.is_null, &m.value),
            (Some(2), Some(true), &None)
        );
        assert!(set_null(&mut m, DataType::Unknown).is_err());
        set(&mut m, DataType::Int16, Value::Int(6)).unwrap();
        assert_eq!(
            (m.is_null, get(&m, DataType::Int16)),
            (None, Ok(Number::Int(6)))
        );
    }

    #[test]
    fn datatype_numbers() {
        assert_eq!(data_type(2), Ok(DataType::Int16));
        assert_eq!(data_type(34), Ok(DataType::DateTimeArray));
        assert_eq!(data_type(35), Err(ValueError::UnknownDataType(35)));
        assert_eq!(
            data_type(u32::MAX),
            Err(ValueError::UnknownDataType(u32::MAX))
        );
        let m = Metric {
            datatype: Some(10),
            ..Metric::default()
        };
        assert_eq!(metric_type(&m), Ok(Some(DataType::Double)));
        assert_eq!(metric_type(&Metric::default()), Ok(None));
    }

    #[test]
    fn integer_type_is_the_smallest_that_holds_the_range() {
        use DataType as T;
        for (min, max, datatype) in [
            (0, 255, T::UInt8),
            (0, 256, T::UInt16),
            (0, 65535, T::UInt16),
            (0, 65536, T::UInt32),
            (0, 0xFFFF_FFFF, T::UInt32),
            (0, 1 << 32, T::UInt64),
            (-128, 127, T::Int8),
            (-1, 128, T::Int16),
            (-32768, 32767, T::Int16),
            (-32769, 0, T::Int32),
            (i64::from(i32::MIN), i64::from(i32::MAX), T::Int32),
            (-1, 1 << 31, T::Int64),
            (i64::MIN, i64::MAX, T::Int64),
            (32767, -32768, T::Int16),
        ] {
            assert_eq!(integer_type(min, max), datatype, "{min}..={max}");
        }
    }
}
