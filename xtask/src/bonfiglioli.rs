//! Generator for the Bonfiglioli ACTIVE (ACT) / ACTIVE Cube (ACU) tables.
//!
//! Inputs (in `crates/drive-profile/data/bonfiglioli/`):
//!
//! * `parameters.csv`: one row per parameter, raw ranges, data type and its source, flags;
//! * `values.csv`: value lists of parameters (P11 takes its values from `vabus_errors.csv`);
//! * `warnings.csv`: the bits of P270;
//! * `faults.csv`: the fault keys of P260 (`FXXYY`, group in the high byte);
//! * `vabus_errors.csv`: the VABus SST error register P11;
//! * `exceptions.csv`: the Modbus exception codes of ch. 6.6.
//!
//! Every rule is checked before anything is rendered; every error names `file:line`.

use crate::render::{header, lit, opt};
use crate::table::{Row, Table};
use crate::{Error, Output, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

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
const VALUE_COLUMNS: &[&str] = &["number", "value", "name_de", "name_en"];
const WARNING_COLUMNS: &[&str] = &[
    "bit", "code", "name_de", "name_en", "implies", "note_de", "note_en",
];
const FAULT_COLUMNS: &[&str] = &["value", "key", "group_de", "group_en", "text_de", "text_en"];
const VABUS_COLUMNS: &[&str] = &["value", "name_de", "name_en"];
const EXCEPTION_COLUMNS: &[&str] = &[
    "code",
    "modbus_name",
    "name_de",
    "name_en",
    "cause_de",
    "cause_en",
];

/// The highest parameter number the 12-bit field of the start address carries (ch. 6.4.1).
const MAX_NUMBER: u16 = 1599;
/// Decimal places the manual knows: values are multiplied by 10, 100 or 1000 (ch. 6.4.1).
const MAX_DECIMALS: u8 = 3;
/// The parameter whose value list is the VABus error register.
const VABUS_PARAM: u16 = 11;

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
struct Param {
    number: u16,
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
    min: Option<i64>,
    max: Option<i64>,
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

#[derive(Debug, Clone)]
struct Value {
    value: i64,
    name_de: String,
    name_en: String,
}

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let params = read_params(&dir.join("parameters.csv"))?;
    let vabus = read_vabus(&dir.join("vabus_errors.csv"), &params)?;
    let mut values = read_values(&dir.join("values.csv"), &params)?;
    values.insert(VABUS_PARAM, vabus.clone());
    let warnings = read_warnings(&dir.join("warnings.csv"))?;
    let faults = read_faults(&dir.join("faults.csv"))?;
    let exceptions = read_exceptions(&dir.join("exceptions.csv"))?;
    Ok(vec![
        Output {
            name: "bonfiglioli_params.rs".into(),
            text: render_params(&params, &values),
        },
        Output {
            name: "bonfiglioli_warnings.rs".into(),
            text: render_warnings(&warnings),
        },
        Output {
            name: "bonfiglioli_faults.rs".into(),
            text: render_faults(&faults),
        },
        Output {
            name: "bonfiglioli_vabus_errors.rs".into(),
            text: render_vabus(&vabus),
        },
        Output {
            name: "bonfiglioli_exceptions.rs".into(),
            text: render_exceptions(&exceptions),
        },
    ])
}

fn bool_opt(row: &Row, col: &str) -> Result<Option<bool>> {
    match row.str(col)? {
        "" => Ok(None),
        "0" => Ok(Some(false)),
        "1" => Ok(Some(true)),
        other => Err(row.err(format!("column `{col}`: `{other}` is not 0, 1 or empty"))),
    }
}

fn check_in(row: &Row, what: &str, v: i64, lo: i64, hi: i64) -> Result<()> {
    if v < lo || v > hi {
        return Err(row.err(format!("{what} {v} is outside {lo}…{hi}")));
    }
    Ok(())
}

fn read_params(path: &Path) -> Result<Vec<Param>> {
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
        if let Some(d) = default {
            if min.is_some_and(|lo| d < lo) || max.is_some_and(|hi| d > hi) {
                return Err(row.err(format!(
                    "default {d} is outside the range {}…{}",
                    min.map_or("".into(), |v| v.to_string()),
                    max.map_or("".into(), |v| v.to_string())
                )));
            }
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

fn read_values(path: &Path, params: &[Param]) -> Result<BTreeMap<u16, Vec<Value>>> {
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

fn read_vabus(path: &Path, params: &[Param]) -> Result<Vec<Value>> {
    let table = Table::read(path, VABUS_COLUMNS)?;
    let p11 = params.iter().find(|p| p.number == VABUS_PARAM);
    let mut out: Vec<Value> = Vec::new();
    for row in table.rows() {
        let value = row.int("value")?;
        let (lo, hi) = p11.map_or((0, 255), |p| (p.min.unwrap_or(0), p.max.unwrap_or(255)));
        check_in(row, "VABus error number", value, lo, hi)?;
        if out.iter().any(|v| v.value == value) {
            return Err(row.err(format!("duplicate VABus error number {value}")));
        }
        out.push(Value {
            value,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    out.sort_by_key(|v| v.value);
    Ok(out)
}

#[derive(Debug)]
struct Warning {
    bit: u8,
    name_de: String,
    name_en: String,
    implies: Option<u8>,
    note_de: String,
    note_en: String,
}

fn read_warnings(path: &Path) -> Result<Vec<Warning>> {
    let table = Table::read(path, WARNING_COLUMNS)?;
    let mut out: Vec<Warning> = Vec::new();
    for row in table.rows() {
        let bit = row.int("bit")?;
        check_in(row, "warning bit", bit, 0, 15)?;
        let bit = bit as u8;
        if out.iter().any(|w| w.bit == bit) {
            return Err(row.err(format!("duplicate warning bit {bit}")));
        }
        let code = row.int("code")?;
        if code != 1i64 << bit {
            return Err(row.err(format!(
                "warning code {code:#06X} of bit {bit} must be {:#06X} (1 << bit)",
                1u32 << bit
            )));
        }
        let implies = match row.opt_int("implies")? {
            None => None,
            Some(b) => {
                check_in(row, "implied bit", b, 0, 15)?;
                if b == i64::from(bit) {
                    return Err(row.err("a warning bit cannot imply itself"));
                }
                Some(b as u8)
            }
        };
        out.push(Warning {
            bit,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            implies,
            note_de: row.str("note_de")?.to_owned(),
            note_en: row.str("note_en")?.to_owned(),
        });
    }
    out.sort_by_key(|w| w.bit);
    if out.len() != 16 {
        let have: BTreeSet<u8> = out.iter().map(|w| w.bit).collect();
        let missing: Vec<String> = (0..16u8)
            .filter(|b| !have.contains(b))
            .map(|b| b.to_string())
            .collect();
        return Err(Error(format!(
            "{}: warning bits missing: {}",
            path.display(),
            missing.join(", ")
        )));
    }
    Ok(out)
}

#[derive(Debug)]
struct Fault {
    value: u16,
    key: String,
    group_de: String,
    group_en: String,
    text_de: String,
    text_en: String,
}

fn read_faults(path: &Path) -> Result<Vec<Fault>> {
    let table = Table::read(path, FAULT_COLUMNS)?;
    let mut out: Vec<Fault> = Vec::new();
    let mut groups: BTreeMap<u8, (String, u64)> = BTreeMap::new();
    for row in table.rows() {
        let value = row.int("value")?;
        check_in(row, "fault value", value, 0, i64::from(u16::MAX))?;
        let value = value as u16;
        let key = row.req("key")?;
        let expected = format!("F{value:04X}");
        if key != expected {
            return Err(row.err(format!(
                "fault key `{key}` does not match value {value:#06X}: group {:02X} in the high \
                 byte and code {:02X} in the low byte give `{expected}`",
                value >> 8,
                value & 0xFF
            )));
        }
        if let Some(prev) = out.last()
            && prev.value >= value
        {
            return Err(row.err(format!(
                "fault {key} duplicate or out of order (after {}); keep the file sorted",
                prev.key
            )));
        }
        let group_de = row.req("group_de")?.to_owned();
        let group_en = row.req("group_en")?.to_owned();
        let group = (value >> 8) as u8;
        if let Some((name, line)) = groups.get(&group)
            && *name != group_en
        {
            return Err(row.err(format!(
                "group F{group:02X} is named `{group_en}` here but `{name}` on line {line}"
            )));
        }
        groups
            .entry(group)
            .or_insert((group_en.clone(), row.line()));
        out.push(Fault {
            value,
            key: key.to_owned(),
            group_de,
            group_en,
            text_de: row.req("text_de")?.to_owned(),
            text_en: row.req("text_en")?.to_owned(),
        });
    }
    Ok(out)
}

#[derive(Debug)]
struct Exception {
    code: u8,
    modbus_name: String,
    name_de: String,
    name_en: String,
    cause_de: String,
    cause_en: String,
}

fn read_exceptions(path: &Path) -> Result<Vec<Exception>> {
    let table = Table::read(path, EXCEPTION_COLUMNS)?;
    let mut out: Vec<Exception> = Vec::new();
    for row in table.rows() {
        let code = row.int("code")?;
        check_in(row, "exception code", code, 1, 127)?;
        let code = code as u8;
        if out.iter().any(|e| e.code == code) {
            return Err(row.err(format!("duplicate exception code {code}")));
        }
        out.push(Exception {
            code,
            modbus_name: row.req("modbus_name")?.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            cause_de: row.req("cause_de")?.to_owned(),
            cause_en: row.req("cause_en")?.to_owned(),
        });
    }
    out.sort_by_key(|e| e.code);
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

fn render_params(params: &[Param], values: &BTreeMap<u16, Vec<Value>>) -> String {
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
        let _ = writeln!(s, "        min: {},", opt(p.min, |v| v.to_string()));
        let _ = writeln!(s, "        max: {},", opt(p.max, |v| v.to_string()));
        let _ = writeln!(s, "        default: {},", opt(p.default, |v| v.to_string()));
        let _ = writeln!(
            s,
            "        data_set: {},",
            opt(p.data_set, |v| v.to_string())
        );
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
                        "            ValueName {{ value: {}, de: {}, en: {} }},",
                        v.value,
                        lit(&v.name_de),
                        lit(&v.name_en)
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

fn render_warnings(warnings: &[Warning]) -> String {
    let mut s = header("bonfiglioli/warnings.csv");
    s.push_str("use crate::bonfiglioli::Warning;\n\n");
    let _ = writeln!(
        s,
        "/// The warning bits of parameter 270, indexed by bit number."
    );
    let _ = writeln!(s, "pub static WARNINGS: [Warning; 16] = [");
    for w in warnings {
        let _ = writeln!(
            s,
            "    Warning {{ bit: {}, code: {:#06X}, name_de: {}, name_en: {}, implies: {}, note_de: {}, note_en: {} }},",
            w.bit,
            1u16 << w.bit,
            lit(&w.name_de),
            lit(&w.name_en),
            opt(w.implies, |b| b.to_string()),
            lit(&w.note_de),
            lit(&w.note_en)
        );
    }
    s.push_str("];\n");
    s
}

fn render_faults(faults: &[Fault]) -> String {
    let mut s = header("bonfiglioli/faults.csv");
    s.push_str("use crate::bonfiglioli::Fault;\n\n");
    let _ = writeln!(s, "/// The fault keys of parameter 260, sorted by value.");
    let _ = writeln!(s, "pub static FAULTS: &[Fault] = &[");
    for f in faults {
        let _ = writeln!(
            s,
            "    Fault {{ value: {:#06X}, key: {}, group_de: {}, group_en: {}, text_de: {}, text_en: {} }},",
            f.value,
            lit(&f.key),
            lit(&f.group_de),
            lit(&f.group_en),
            lit(&f.text_de),
            lit(&f.text_en)
        );
    }
    s.push_str("];\n");
    s
}

fn render_vabus(errors: &[Value]) -> String {
    let mut s = header("bonfiglioli/vabus_errors.csv");
    s.push_str("use crate::bonfiglioli::VabusError;\n\n");
    let _ = writeln!(
        s,
        "/// The values of the VABus SST error register (parameter 11), sorted."
    );
    let _ = writeln!(s, "pub static VABUS_ERRORS: &[VabusError] = &[");
    for e in errors {
        let _ = writeln!(
            s,
            "    VabusError {{ value: {}, name_de: {}, name_en: {} }},",
            e.value,
            lit(&e.name_de),
            lit(&e.name_en)
        );
    }
    s.push_str("];\n");
    s
}

fn render_exceptions(exceptions: &[Exception]) -> String {
    let mut s = header("bonfiglioli/exceptions.csv");
    s.push_str("use crate::bonfiglioli::ModbusException;\n\n");
    let _ = writeln!(
        s,
        "/// The Modbus exception codes the drive sends (ch. 6.6), sorted."
    );
    let _ = writeln!(s, "pub static EXCEPTIONS: &[ModbusException] = &[");
    for e in exceptions {
        let _ = writeln!(
            s,
            "    ModbusException {{ code: {}, modbus_name: {}, name_de: {}, name_en: {}, cause_de: {}, cause_en: {} }},",
            e.code,
            lit(&e.modbus_name),
            lit(&e.name_de),
            lit(&e.name_en),
            lit(&e.cause_de),
            lit(&e.cause_en)
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const FILES: &[&str] = &[
        "parameters.csv",
        "values.csv",
        "warnings.csv",
        "faults.csv",
        "vabus_errors.csv",
        "exceptions.csv",
    ];

    fn real_dir() -> PathBuf {
        crate::data_dir(&crate::workspace_root()).join("bonfiglioli")
    }

    /// A copy of the real inputs in a fresh temporary folder, with `file` edited by `edit`.
    fn with_edit(
        name: &str,
        file: &str,
        edit: impl FnOnce(String) -> String,
    ) -> Result<Vec<Output>> {
        let dir = std::env::temp_dir().join(format!(
            "drivebus-bonfiglioli-{}-{name}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut edit = Some(edit);
        for f in FILES {
            let text = std::fs::read_to_string(real_dir().join(f)).unwrap();
            let text = match edit.take() {
                Some(e) if *f == file => e(text),
                other => {
                    edit = other;
                    text
                }
            };
            std::fs::write(dir.join(f), text).unwrap();
        }
        let out = generate(&dir);
        let _ = std::fs::remove_dir_all(&dir);
        out
    }

    /// Replace the line starting with `prefix` by `line`.
    fn replace_line(text: &str, prefix: &str, line: &str) -> String {
        let mut found = false;
        let out: Vec<String> = text
            .lines()
            .map(|l| {
                if !found && l.starts_with(prefix) {
                    found = true;
                    line.to_owned()
                } else {
                    l.to_owned()
                }
            })
            .collect();
        assert!(found, "no line starts with {prefix:?}");
        out.join("\n") + "\n"
    }

    /// The 1-based line number of the line starting with `prefix` in the real file.
    fn line_of(file: &str, prefix: &str) -> usize {
        let text = std::fs::read_to_string(real_dir().join(file)).unwrap();
        text.lines().position(|l| l.starts_with(prefix)).unwrap() + 1
    }

    fn expect_err(out: Result<Vec<Output>>, file: &str, line: usize, needle: &str) {
        let e = out.expect_err("the edit must be rejected").0;
        let loc = format!("{file}:{line}:");
        assert!(e.contains(&loc), "error `{e}` does not name {loc}");
        assert!(
            e.contains(needle),
            "error `{e}` does not mention `{needle}`"
        );
    }

    #[test]
    fn real_tables_generate() {
        let out = generate(&real_dir()).unwrap();
        assert_eq!(out.len(), 5);
        let params = &out[0].text;
        assert!(params.contains("number: 1376,"));
    }

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
            replace_line(&t, "10,6,", "10,7,230400 Baud,230400 baud")
        });
        expect_err(out, "values.csv", line, "outside the range of P10");
    }

    #[test]
    fn warning_code_must_be_its_bit() {
        let line = line_of("warnings.csv", "5,");
        let out = with_edit("warn", "warnings.csv", |t| {
            replace_line(
                &t,
                "5,",
                "5,0x0040,Warnung I-Limit,Warning current limit,,,",
            )
        });
        expect_err(out, "warnings.csv", line, "must be 0x0020");
    }

    #[test]
    fn duplicate_warning_bit_is_rejected() {
        let line = line_of("warnings.csv", "15,");
        let out = with_edit("warndup", "warnings.csv", |t| {
            replace_line(
                &t,
                "15,",
                "14,0x4000,Warnung Udc,Warning DC link voltage,,,",
            )
        });
        expect_err(out, "warnings.csv", line, "duplicate warning bit 14");
    }

    #[test]
    fn fault_key_must_match_value() {
        let line = line_of("faults.csv", "0x2010,");
        let out = with_edit("fault", "faults.csv", |t| {
            replace_line(
                &t,
                "0x2010,",
                "0x2010,F2016,Kommunikation,Communication,x,y",
            )
        });
        expect_err(out, "faults.csv", line, "give `F2010`");
    }

    #[test]
    fn duplicate_vabus_error_is_rejected() {
        let line = line_of("vabus_errors.csv", "15,");
        let out = with_edit("vabus", "vabus_errors.csv", |t| {
            replace_line(&t, "15,", "14,Unbekannter Fehler,Unknown error")
        });
        expect_err(
            out,
            "vabus_errors.csv",
            line,
            "duplicate VABus error number 14",
        );
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
