//! Metric properties (specification ch. 6, "PropertySet", "PropertyValue", "Quality Codes"): a
//! property set is two arrays of equal length, keys and values, each value with its type.

use crate::proto::DataType;
use crate::proto::payload::{PropertySet, PropertyValue, property_value};
use crate::value::{self, Number};
use alloc::borrow::ToOwned;

/// The property key of a metric's quality, present when the quality is not good.
pub const QUALITY: &str = "Quality";

/// A metric's quality (the [`QUALITY`] property, an Int32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// 0: bad.
    Bad,
    /// 192: good (the default: a metric without the property is good).
    Good,
    /// 500: stale.
    Stale,
}

impl Quality {
    /// Its code: 0, 192 or 500.
    pub fn code(self) -> u32 {
        match self {
            Quality::Bad => 0,
            Quality::Good => 192,
            Quality::Stale => 500,
        }
    }
}

/// A property set built key by key, in order:
/// `PropertySetBuilder::default().text("engUnit", "s").int("number", 130).build()`.
///
/// `int` sends an Int64, `uint` a UInt64, `double` a Double, `bool` a Boolean, `text` a String,
/// `set` a nested PropertySet, `quality` the [`QUALITY`] property as an Int32. A key given twice
/// is kept twice (the specification does not forbid it; [`get`] finds the first).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PropertySetBuilder {
    set: PropertySet,
}

impl PropertySetBuilder {
    fn push(mut self, key: &str, datatype: DataType, value: property_value::Value) -> Self {
        self.set.keys.push(key.to_owned());
        self.set.values.push(PropertyValue {
            r#type: Some(datatype as u32),
            is_null: None,
            value: Some(value),
        });
        self
    }

    /// A String property.
    #[must_use]
    pub fn text(self, key: &str, value: &str) -> Self {
        self.push(
            key,
            DataType::String,
            property_value::Value::StringValue(value.to_owned()),
        )
    }

    /// An Int64 property (two's complement in `long_value`).
    #[must_use]
    pub fn int(self, key: &str, value: i64) -> Self {
        self.push(
            key,
            DataType::Int64,
            property_value::Value::LongValue(value.cast_unsigned()),
        )
    }

    /// A UInt64 property.
    #[must_use]
    pub fn uint(self, key: &str, value: u64) -> Self {
        self.push(
            key,
            DataType::UInt64,
            property_value::Value::LongValue(value),
        )
    }

    /// A Double property.
    #[must_use]
    pub fn double(self, key: &str, value: f64) -> Self {
        self.push(
            key,
            DataType::Double,
            property_value::Value::DoubleValue(value),
        )
    }

    /// A Boolean property.
    #[must_use]
    pub fn bool(self, key: &str, value: bool) -> Self {
        self.push(
            key,
            DataType::Boolean,
            property_value::Value::BooleanValue(value),
        )
    }

    /// A nested PropertySet property.
    #[must_use]
    pub fn set(self, key: &str, value: PropertySet) -> Self {
        self.push(
            key,
            DataType::PropertySet,
            property_value::Value::PropertysetValue(value),
        )
    }

    /// The [`QUALITY`] property: type Int32, the code in `int_value`, as the specification
    /// requires.
    #[must_use]
    pub fn quality(self, quality: Quality) -> Self {
        self.push(
            QUALITY,
            DataType::Int32,
            property_value::Value::IntValue(quality.code()),
        )
    }

    /// The property set.
    pub fn build(self) -> PropertySet {
        self.set
    }
}

/// The value of the property `key` (the first, if the key is there more than once); `None`
/// when the set has no such key or fewer values than keys.
pub fn get<'a>(set: &'a PropertySet, key: &str) -> Option<&'a PropertyValue> {
    let i = set.keys.iter().position(|k| k == key)?;
    set.values.get(i)
}

/// The property `key` as text: a String or Text property.
pub fn text<'a>(set: &'a PropertySet, key: &str) -> Option<&'a str> {
    let v = get(set, key)?;
    match (typed(v)?, v.value.as_ref()?) {
        (DataType::String | DataType::Text, property_value::Value::StringValue(s)) => Some(s),
        _ => None,
    }
}

/// The property `key` as an integer: a property of an integer type whose value is in its
/// field and range (as [`value::get`] reads a metric).
pub fn int(set: &PropertySet, key: &str) -> Option<i64> {
    match number(set, key)? {
        Number::Int(i) => Some(i),
        _ => None,
    }
}

/// The property `key` as a boolean: a Boolean property.
pub fn bool(set: &PropertySet, key: &str) -> Option<bool> {
    match number(set, key)? {
        Number::Bool(b) => Some(b),
        _ => None,
    }
}

/// The [`QUALITY`] property: `None` when the set has none (the metric is good) or its value
/// is no quality code.
pub fn quality(set: &PropertySet) -> Option<Quality> {
    match int(set, QUALITY)? {
        0 => Some(Quality::Bad),
        192 => Some(Quality::Good),
        500 => Some(Quality::Stale),
        _ => None,
    }
}

/// The property's type, when it has one, it is known and the value is not null.
fn typed(v: &PropertyValue) -> Option<DataType> {
    if v.is_null == Some(true) {
        return None;
    }
    value::data_type(v.r#type?).ok()
}

fn number(set: &PropertySet, key: &str) -> Option<Number> {
    let v = get(set, key)?;
    let datatype = typed(v)?;
    value::number(datatype, value::property_raw(v.value.as_ref()?)).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_properties_read_back() {
        let unit = PropertySetBuilder::default().text("de", "Sekunden").build();
        let set = PropertySetBuilder::default()
            .text("engUnit", "s")
            .int("number", 130)
            .int("low", -32768)
            .uint("high", u64::MAX)
            .double("scale", 0.1)
            .bool("writable", true)
            .set("names", unit.clone())
            .quality(Quality::Stale)
            .build();
        assert_eq!(set.keys.len(), set.values.len());
        assert_eq!(text(&set, "engUnit"), Some("s"));
        assert_eq!(int(&set, "number"), Some(130));
        assert_eq!(int(&set, "low"), Some(-32768));
        // u64::MAX is no i64: not read as an integer.
        assert_eq!(int(&set, "high"), None);
        assert_eq!(
            get(&set, "high").and_then(|v| v.value.clone()),
            Some(property_value::Value::LongValue(u64::MAX))
        );
        assert_eq!(bool(&set, "writable"), Some(true));
        assert_eq!(
            get(&set, "scale").map(|v| (v.r#type, v.value.clone())),
            Some((Some(10), Some(property_value::Value::DoubleValue(0.1))))
        );
        assert_eq!(
            get(&set, "names").and_then(|v| v.value.clone()),
            Some(property_value::Value::PropertysetValue(unit))
        );
        assert_eq!(quality(&set), Some(Quality::Stale));
        // The quality property is an Int32 with its code in int_value.
        assert_eq!(
            get(&set, QUALITY),
            Some(&PropertyValue {
                r#type: Some(3),
                is_null: None,
                value: Some(property_value::Value::IntValue(500))
            })
        );
        // Wrong kinds and missing keys are None.
        assert_eq!(text(&set, "number"), None);
        assert_eq!(bool(&set, "engUnit"), None);
        assert_eq!(int(&set, "nothing"), None);
    }

    #[test]
    fn malformed_sets_read_as_absent() {
        // A key without its value.
        let mut set = PropertySetBuilder::default().bool("a", true).build();
        set.keys.push("b".into());
        assert_eq!(get(&set, "b"), None);
        // A null value, and one without a type.
        set.values.push(PropertyValue {
            r#type: Some(11),
            is_null: Some(true),
            value: None,
        });
        assert_eq!(bool(&set, "b"), None);
        set.values[0].r#type = None;
        assert_eq!(bool(&set, "a"), None);
        // A quality that is no quality code.
        let set = PropertySetBuilder::default().int(QUALITY, 7).build();
        assert_eq!(quality(&set), None);
        assert_eq!(quality(&PropertySet::default()), None);
    }
}
