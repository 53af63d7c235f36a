//! Parameters: `parameters.csv` and the value lists in `values.csv` (P11 takes its values from
//! `vabus_errors.csv`), rendered into `bonfiglioli_params.rs`.

use super::{VABUS_PARAM, Value, check_in};
use crate::Result;
use crate::render::{header, lit, opt_display, value_name};
use crate::table::{Row, Table};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `parameters.csv`.
const PARAM_COLUMNS: &[&str] = &[
    "number",
    "name_de",
    "name_en",
    "aliases_de",
    "menu",
    "group_de",
    "group_en",
    "data_type",
    "type_source",
    "decimals",
    "unit",
    "min",
    "max",
    "default",
    "data_set",
    "not_in_operation",
    "setup",
    "bus_only",
    "ram_only",
    "access",
    "chapters",
    "notes",
];
/// Columns of `values.csv`.
const VALUE_COLUMNS: &[&str] = &["number", "value", "name_de", "name_en"];

/// The highest parameter number the 12-bit field of the start address carries (ch. 6.4.1).
const MAX_NUMBER: u16 = 1599;
/// Decimal places the manual knows: values are multiplied by 10, 100 or 1000 (ch. 6.4.1).
const MAX_DECIMALS: u8 = 3;

/// Data type of a parameter on the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DataType {
    UInt,
    Int,
    Long,
    Unknown,
}

impl DataType {
    fn parse(s: &str) -> Option<DataType> {
        match s {
            "uInt" => Some(DataType::UInt),
            "Int" => Some(DataType::Int),
            "Long" => Some(DataType::Long),
            "unknown" => Some(DataType::Unknown),
            _ => None,
        }
    }

    fn bounds(self) -> Option<(i64, i64)> {
        match self {
            DataType::UInt => Some((0, i64::from(u16::MAX))),
            DataType::Int => Some((i64::from(i16::MIN), i64::from(i16::MAX))),
            DataType::Long => Some((i64::from(i32::MIN), i64::from(i32::MAX))),
            DataType::Unknown => None,
        }
    }

    fn rust(self) -> &'static str {
        match self {
            DataType::UInt => "DataType::UInt",
            DataType::Int => "DataType::Int",
            DataType::Long => "DataType::Long",
            DataType::Unknown => "DataType::Unknown",
        }
    }
}

/// The `type_source` column: CSV word and the `TypeSource` it renders to.
const TYPE_SOURCES: &[(&str, &str)] = &[
    ("stated", "TypeSource::Stated"),
    ("example", "TypeSource::Example"),
    ("range", "TypeSource::Range"),
    ("layout", "TypeSource::Layout"),
    ("analogy", "TypeSource::Analogy"),
    ("unknown", "TypeSource::Unknown"),
];

/// One validated parameter row.
#[derive(Debug)]
pub(super) struct Param {
    pub(super) number: u16,
    name_de: String,
    name_en: String,
    aliases_de: String,
    menu_val: bool,
    group_de: String,
    group_en: String,
    data_type: DataType,
    type_source: &'static str,
    decimals: u8,
    unit: String,
    pub(super) min: Option<i64>,
    pub(super) max: Option<i64>,
    default: Option<i64>,
    data_set: Option<bool>,
    not_in_operation: bool,
    setup: bool,
    bus_only: bool,
    ram_only: bool,
    access: &'static str,
    chapters: String,
    notes: String,
}

/// Column `col` as an optional flag: `0`, `1` or empty.
fn bool_opt(row: &Row, col: &str) -> Result<Option<bool>> {
    match row.str(col)? {
        "" => Ok(None),
        "0" => Ok(Some(false)),
        "1" => Ok(Some(true)),
        other => Err(row.err(format!("column `{col}`: `{other}` is not 0, 1 or empty"))),
    }
}

/// Read the parameters: sorted, unique numbers that fit the start address; data type, raw
/// range, default and flags that agree with each other.
pub(super) fn read_params(path: &Path) -> Result<Vec<Param>> {
    let table = Table::read(path, PARAM_COLUMNS)?;
    let mut out: Vec<Param> = Vec::new();
    for row in table.rows() {
        let number: u16 = row.parse("number")?;
        if number > MAX_NUMBER {
            return Err(row.err(format!(
                "parameter number {number} does not fit the start address (0…{MAX_NUMBER})"
            )));
        }
        if let Some(prev) = out.last() {
            if prev.number == number {
                return Err(row.err(format!("duplicate parameter number {number}")));
            }
            if prev.number > number {
                return Err(row.err(format!(
                    "parameter {number} out of order (after {}); keep the file sorted",
                    prev.number
                )));
            }
        }
        let menu_val = match row.req("menu")? {
            "VAL" => true,
            "PARA" => false,
            other => return Err(row.err(format!("menu `{other}` is not VAL or PARA"))),
        };
        let dt_text = row.req("data_type")?;
        let data_type = DataType::parse(dt_text).ok_or_else(|| {
            row.err(format!(
                "data type `{dt_text}` is not uInt, Int, Long or unknown"
            ))
        })?;
        let ts_text = row.req("type_source")?;
        let type_source = TYPE_SOURCES
            .iter()
            .find(|(k, _)| *k == ts_text)
            .map(|(_, v)| *v)
            .ok_or_else(|| row.err(format!("type source `{ts_text}` is not known")))?;
        if (data_type == DataType::Unknown) != (ts_text == "unknown") {
            return Err(row.err(format!(
                "data type `{dt_text}` and type source `{ts_text}` disagree (unknown goes with unknown)"
            )));
        }
        let decimals: u8 = row.parse("decimals")?;
        if decimals > MAX_DECIMALS {
            return Err(row.err(format!("decimals {decimals} exceed {MAX_DECIMALS}")));
        }
        let min = row.opt_int("min")?;
        let max = row.opt_int("max")?;
        let default = row.opt_int("default")?;
        if let Some((lo, hi)) = data_type.bounds() {
            for (what, v) in [("min", min), ("max", max), ("default", default)] {
                if let Some(v) = v {
                    check_in(row, &format!("{what} of a {dt_text} parameter:"), v, lo, hi)?;
                }
            }
        }
        if let (Some(lo), Some(hi)) = (min, max)
            && lo > hi
        {
            return Err(row.err(format!("min {lo} is greater than max {hi}")));
        }
        if let Some(d) = default
            && (min.is_some_and(|lo| d < lo) || max.is_some_and(|hi| d > hi))
        {
            return Err(row.err(format!(
                "default {d} is outside the range {}…{}",
                min.map_or("".into(), |v| v.to_string()),
                max.map_or("".into(), |v| v.to_string())
            )));
        }
        if ts_text == "range" {
            let needs_32 = min.is_some_and(|v| v < i64::from(i16::MIN))
                || max.is_some_and(|v| v > i64::from(u16::MAX));
            if !needs_32 || data_type != DataType::Long {
                return Err(row
                    .err("type source `range` needs a Long whose min or max does not fit 16 bit"));
            }
        }
        let access = match row.req("access")? {
            "RO" => "ParamAccess::ReadOnly",
            "RW" => "ParamAccess::ReadWrite",
            "WO" => "ParamAccess::WriteOnly",
            other => return Err(row.err(format!("access `{other}` is not RO, RW or WO"))),
        };
        let data_set = bool_opt(row, "data_set")?;
        let not_in_operation = row.flag("not_in_operation")?;
        let setup = row.flag("setup")?;
        let bus_only = row.flag("bus_only")?;
        let ram_only = row.flag("ram_only")?;
        if menu_val && access != "ParamAccess::ReadOnly" {
            return Err(row.err("an actual value (menu VAL) must be RO"));
        }
        if access == "ParamAccess::ReadOnly" && (not_in_operation || setup) {
            return Err(row.err("a read-only parameter cannot carry write flags"));
        }
        if ram_only && data_set == Some(true) {
            return Err(row.err("a RAM-only parameter is always data set 0 (ch. 7)"));
        }
        out.push(Param {
            number,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            aliases_de: row.str("aliases_de")?.to_owned(),
            menu_val,
            group_de: row.str("group_de")?.to_owned(),
            group_en: row.str("group_en")?.to_owned(),
            data_type,
            type_source,
            decimals,
            unit: row.str("unit")?.to_owned(),
            min,
            max,
            default,
            data_set,
            not_in_operation,
            setup,
            bus_only,
            ram_only,
            access,
            chapters: row.req("chapters")?.to_owned(),
            notes: row.str("notes")?.to_owned(),
        });
    }
    Ok(out)
}

/// Read the value lists: of a known parameter (not P11), once per value, inside its range.
pub(super) fn read_values(path: &Path, params: &[Param]) -> Result<BTreeMap<u16, Vec<Value>>> {
    let table = Table::read(path, VALUE_COLUMNS)?;
    let mut out: BTreeMap<u16, Vec<Value>> = BTreeMap::new();
    for row in table.rows() {
        let number: u16 = row.parse("number")?;
        let p = params
            .iter()
            .find(|p| p.number == number)
            .ok_or_else(|| row.err(format!("parameter {number} is not in parameters.csv")))?;
        if number == VABUS_PARAM {
            return Err(row.err("the values of P11 belong in vabus_errors.csv"));
        }
        let value = row.int("value")?;
        if p.min.is_some_and(|lo| value < lo) || p.max.is_some_and(|hi| value > hi) {
            return Err(row.err(format!("value {value} is outside the range of P{number}")));
        }
        if let Some((lo, hi)) = p.data_type.bounds() {
            check_in(row, "value", value, lo, hi)?;
        }
        let list = out.entry(number).or_default();
        if list.iter().any(|v| v.value == value) {
            return Err(row.err(format!("duplicate value {value} of P{number}")));
        }
        list.push(Value {
            value,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    Ok(out)
}

/// A raw value as physical text: `-99999` with 2 decimals → `-999.99` (German: `-999,99`).
fn physical(raw: i64, decimals: u8, hex: bool, german: bool) -> String {
    if hex && raw > 0 {
        return format!("{raw:#06X}").replacen("0X", "0x", 1);
    }
    if decimals == 0 {
        return raw.to_string();
    }
    let div = 10i64.pow(u32::from(decimals));
    let sign = if raw < 0 { "-" } else { "" };
    let abs = raw.unsigned_abs();
    let sep = if german { ',' } else { '.' };
    format!(
        "{sign}{}{sep}{:0width$}",
        abs / div as u64,
        abs % div as u64,
        width = usize::from(decimals)
    )
}

fn range_text(p: &Param, german: bool) -> String {
    let hex = p.data_type == DataType::UInt && p.max == Some(i64::from(u16::MAX));
    let f = |v: i64| physical(v, p.decimals, hex, german);
    match (p.min, p.max) {
        (Some(lo), Some(hi)) => format!("{} … {}", f(lo), f(hi)),
        (Some(lo), None) => format!("≥ {}", f(lo)),
        (None, Some(hi)) => format!("≤ {}", f(hi)),
        (None, None) => String::new(),
    }
}

/// Render `bonfiglioli_params.rs`.
pub(super) fn render_params(params: &[Param], values: &BTreeMap<u16, Vec<Value>>) -> String {
    let mut s = header("bonfiglioli/parameters.csv, values.csv, vabus_errors.csv");
    s.push_str(
        "use crate::bonfiglioli::{DataType, Menu, Param, ParamAccess, TypeSource};\n\
         use crate::ValueName;\n\n",
    );
    let _ = writeln!(s, "/// Every parameter the manual names, sorted by number.");
    let _ = writeln!(s, "pub static PARAMS: &[Param] = &[");
    for p in params {
        let _ = writeln!(s, "    Param {{");
        let _ = writeln!(s, "        number: {},", p.number);
        let _ = writeln!(s, "        name_de: {},", lit(&p.name_de));
        let _ = writeln!(s, "        name_en: {},", lit(&p.name_en));
        let _ = writeln!(s, "        aliases_de: {},", lit(&p.aliases_de));
        let menu = if p.menu_val {
            "Menu::Val"
        } else {
            "Menu::Para"
        };
        let _ = writeln!(s, "        menu: {menu},");
        let _ = writeln!(s, "        group_de: {},", lit(&p.group_de));
        let _ = writeln!(s, "        group_en: {},", lit(&p.group_en));
        let _ = writeln!(s, "        data_type: {},", p.data_type.rust());
        let _ = writeln!(s, "        type_source: {},", p.type_source);
        let _ = writeln!(s, "        decimals: {},", p.decimals);
        let _ = writeln!(s, "        unit: {},", lit(&p.unit));
        let _ = writeln!(s, "        min: {},", opt_display(p.min));
        let _ = writeln!(s, "        max: {},", opt_display(p.max));
        let _ = writeln!(s, "        default: {},", opt_display(p.default));
        let _ = writeln!(s, "        data_set: {},", opt_display(p.data_set));
        let _ = writeln!(s, "        not_in_operation: {},", p.not_in_operation);
        let _ = writeln!(s, "        setup: {},", p.setup);
        let _ = writeln!(s, "        bus_only: {},", p.bus_only);
        let _ = writeln!(s, "        ram_only: {},", p.ram_only);
        let _ = writeln!(s, "        access: {},", p.access);
        let _ = writeln!(s, "        range_de: {},", lit(&range_text(p, true)));
        let _ = writeln!(s, "        range_en: {},", lit(&range_text(p, false)));
        match values.get(&p.number) {
            Some(list) if !list.is_empty() => {
                let _ = writeln!(s, "        values: &[");
                for v in list {
                    let _ = writeln!(
                        s,
                        "            {},",
                        value_name(v.value, &v.name_de, &v.name_en)
                    );
                }
                let _ = writeln!(s, "        ],");
            }
            _ => {
                let _ = writeln!(s, "        values: &[],");
            }
        }
        let _ = writeln!(s, "        chapters: {},", lit(&p.chapters));
        let _ = writeln!(s, "        notes: {},", lit(&p.notes));
        let _ = writeln!(s, "    }},");
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{expect_err, line_of, replace_line, with_edit};
    use super::*;

    #[test]
    fn unknown_data_type_is_rejected() {
        let line = line_of("parameters.csv", "1376,");
        let out = with_edit("dtype", "parameters.csv", |t| {
            t.replace("1376,Modbus Adresse,Modbus address,Modbus Knotenadresse,PARA,Modbus,Modbus,unknown,unknown",
                      "1376,Modbus Adresse,Modbus address,Modbus Knotenadresse,PARA,Modbus,Modbus,Word,unknown")
        });
        expect_err(out, "parameters.csv", line, "data type `Word`");
    }

    #[test]
    fn min_above_max_is_rejected() {
        let line = line_of("parameters.csv", "413,");
        let out = with_edit("minmax", "parameters.csv", |t| {
            t.replace(",s,0,10000,0,", ",s,10001,10000,0,")
        });
        expect_err(out, "parameters.csv", line, "greater than max");
    }

    #[test]
    fn default_out_of_range_is_rejected() {
        let line = line_of("parameters.csv", "1376,");
        let out = with_edit("default", "parameters.csv", |t| {
            t.replace(",1,247,1,0,0,0,0,0,RW,", ",1,247,248,0,0,0,0,0,RW,")
        });
        expect_err(out, "parameters.csv", line, "default 248");
    }

    #[test]
    fn too_many_decimals_are_rejected() {
        let line = line_of("parameters.csv", "481,");
        let out = with_edit("decimals", "parameters.csv", |t| {
            t.replace(
                "Long,example,2,Hz,,,,,0,0,0,0,RW,8.1.3",
                "Long,example,4,Hz,,,,,0,0,0,0,RW,8.1.3",
            )
        });
        expect_err(out, "parameters.csv", line, "decimals 4");
    }

    #[test]
    fn duplicate_number_is_rejected() {
        let line = line_of("parameters.csv", "1376,");
        let out = with_edit("dup", "parameters.csv", |t| t.replace("\n1376,", "\n1375,"));
        expect_err(
            out,
            "parameters.csv",
            line,
            "duplicate parameter number 1375",
        );
    }

    #[test]
    fn value_outside_type_is_rejected() {
        let line = line_of("parameters.csv", "260,");
        let out = with_edit("type", "parameters.csv", |t| {
            t.replace(
                "uInt,layout,0,,0,0xFFFF,,0,0,0,0,0,RO,9.1; 12.2",
                "uInt,layout,0,,0,0x10000,,0,0,0,0,0,RO,9.1; 12.2",
            )
        });
        expect_err(out, "parameters.csv", line, "outside 0…65535");
    }

    #[test]
    fn range_source_must_need_32_bit() {
        let line = line_of("parameters.csv", "228,");
        let out = with_edit("range", "parameters.csv", |t| {
            t.replace("Long,range,2,Hz,-100000,100000,,0,0,0,0,0,RO,9.2.1; 10.2.3,\"-1000.00 … 1000.00 Hz needs 32 bit.\"",
                      "Long,range,2,Hz,-1000,1000,,0,0,0,0,0,RO,9.2.1; 10.2.3,\"x\"")
        });
        expect_err(out, "parameters.csv", line, "type source `range`");
    }

    #[test]
    fn value_list_outside_range_is_rejected() {
        let line = line_of("values.csv", "10,6,");
        let out = with_edit("values", "values.csv", |t| {
            replace_line(t, "10,6,", "10,7,230400 Baud,230400 baud")
        });
        expect_err(out, "values.csv", line, "outside the range of P10");
    }

    #[test]
    fn german_and_english_ranges_render() {
        let p = Param {
            number: 484,
            name_de: String::new(),
            name_en: String::new(),
            aliases_de: String::new(),
            menu_val: false,
            group_de: String::new(),
            group_en: String::new(),
            data_type: DataType::Long,
            type_source: "TypeSource::Stated",
            decimals: 2,
            unit: "Hz".into(),
            min: Some(-99999),
            max: Some(99999),
            default: Some(0),
            data_set: Some(false),
            not_in_operation: false,
            setup: false,
            bus_only: true,
            ram_only: true,
            access: "ParamAccess::WriteOnly",
            chapters: String::new(),
            notes: String::new(),
        };
        assert_eq!(range_text(&p, true), "-999,99 … 999,99");
        assert_eq!(range_text(&p, false), "-999.99 … 999.99");
        assert_eq!(physical(5, 2, false, false), "0.05");
        assert_eq!(physical(0xFFFF, 0, true, false), "0xFFFF");
    }
}
