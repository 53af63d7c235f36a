//! Generator for the SEW MOVIDRIVE tables.
//!
//! Inputs (in `crates/drive-profile/data/sew/`), all extracted from the SEW manuals:
//!
//! * `movidrive_parameters.csv`: the parameter list (serial communication manual ch. 7.2), one
//!   row per printed table row, in manual order;
//! * `movidrive_groups.csv`: the section headings of the parameter list;
//! * `movidrive_pno_units.csv` and `movidrive_pno_conversions.csv`: PNO size and conversion
//!   indices (ch. 7.3);
//! * `movilink_error_classes.csv` and `movilink_return_codes.csv`: MOVILINK return codes
//!   (ch. 6.2 and 5.2).
//!
//! Every row is validated; a bad row fails with `file:line: reason`. Outputs:
//! `sew_parameters.rs`, `sew_pno.rs` and `sew_return_codes.rs`.

use crate::render::{header, lit};
use crate::table::{Row, Table, parse_int};
use crate::{Output, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

/// Columns of `movidrive_parameters.csv`.
pub const PARAM_COLUMNS: &[&str] = &[
    "menu",
    "parent",
    "sub",
    "group",
    "md60a_only",
    "name_de",
    "name_en",
    "index",
    "index_hex",
    "index2",
    "unit",
    "display_unit",
    "size_index",
    "conversion_index",
    "access",
    "default",
    "default2",
    "default_outside_range",
    "range_de",
    "range_en",
    "ranges",
    "values",
    "values_ref",
    "errata",
];
/// Columns of `movidrive_groups.csv`.
pub const GROUP_COLUMNS: &[&str] = &["group", "name_de", "name_en"];
/// Columns of `movidrive_pno_units.csv`.
pub const UNIT_COLUMNS: &[&str] = &[
    "quantity_de",
    "quantity_en",
    "size_index",
    "unit_de",
    "unit_en",
    "symbol",
    "aliases",
    "conversion_index",
    "errata",
];
/// Columns of `movidrive_pno_conversions.csv`.
pub const CONVERSION_COLUMNS: &[&str] = &[
    "conversion_index",
    "kind",
    "a_expr",
    "a_printed",
    "inv_a_printed",
    "b",
    "errata",
];
/// Columns of `movilink_error_classes.csv`.
pub const CLASS_COLUMNS: &[&str] = &["class", "name", "meaning_de", "meaning_en"];
/// Columns of `movilink_return_codes.csv`.
pub const RETURN_CODE_COLUMNS: &[&str] = &[
    "class", "code", "add_high", "add_low", "name_de", "name_en", "source", "retry",
];

/// MOVILINK parameter indices lie in 2000h…5FFFh (manual ch. 7.2, "MOVILINK-Parameter").
const INDEX_MIN: i64 = 0x2000;
const INDEX_MAX: i64 = 0x5FFF;
/// Parameters are 32-bit values; signed or unsigned, a raw value lies in this span.
const RAW_MIN: i64 = i32::MIN as i64;
const RAW_MAX: i64 = u32::MAX as i64;
/// Conversion indices from -64 to +64 follow the decimal rule A = 10^n (manual ch. 7.3).
const DECIMAL_RULE: i64 = 64;

/// Validate the CSV files in `dir` and render the generated Rust files.
pub fn generate(dir: &Path) -> Result<Vec<Output>> {
    let conversions = read_conversions(dir)?;
    let units = read_units(dir, &conversions)?;
    let groups = read_groups(dir)?;
    let params = read_params(dir, &units, &conversions, &groups)?;
    let (classes, codes) = read_return_codes(dir)?;
    Ok(vec![
        Output {
            name: "sew_parameters.rs".into(),
            text: render_params(&params, &groups),
        },
        Output {
            name: "sew_pno.rs".into(),
            text: render_pno(&units, &conversions),
        },
        Output {
            name: "sew_return_codes.rs".into(),
            text: render_return_codes(&classes, &codes),
        },
    ])
}

/// Every errata id (`SEW-Enn`) used by the CSV files in `dir`, for the cross-check with
/// `docs/errata-sew.md`.
pub fn errata_ids(dir: &Path) -> Result<BTreeSet<String>> {
    let mut ids = BTreeSet::new();
    for (file, cols) in [
        ("movidrive_parameters.csv", PARAM_COLUMNS),
        ("movidrive_pno_units.csv", UNIT_COLUMNS),
        ("movidrive_pno_conversions.csv", CONVERSION_COLUMNS),
    ] {
        let t = Table::read(&dir.join(file), cols)?;
        for row in t.rows() {
            for id in row.str("errata")?.split_whitespace() {
                ids.insert(id.to_owned());
            }
        }
    }
    Ok(ids)
}

// ---------------------------------------------------------------------------------------------
// PNO conversion and size indices

/// One row of the conversion table.
#[derive(Debug, Clone)]
pub struct Conversion {
    /// Conversion index.
    pub index: i64,
    /// `decimal`, `special` or `reserved`.
    pub kind: String,
    /// Factor A (`None` for reserved indices).
    pub a: Option<f64>,
    /// Offset B.
    pub b: f64,
}

/// All conversion indices: the printed rows.
#[derive(Debug, Default)]
pub struct Conversions {
    rows: BTreeMap<i64, Conversion>,
}

impl Conversions {
    /// The scaling (A, B) of conversion index `i`, applying the decimal rule for -64…64.
    pub fn get(&self, i: i64) -> Option<(f64, f64)> {
        if (-DECIMAL_RULE..=DECIMAL_RULE).contains(&i) {
            return Some((decimal(i), 0.0));
        }
        let c = self.rows.get(&i)?;
        Some((c.a?, c.b))
    }
}

/// `10^n` computed the way the library does (exact for |n| ≤ 22).
fn decimal(n: i64) -> f64 {
    let mut p = 1.0_f64;
    for _ in 0..n.unsigned_abs() {
        p *= 10.0;
    }
    if n < 0 { 1.0 / p } else { p }
}

/// Evaluate a factor expression: numbers and `pi` joined by `*` and `/`, left to right.
pub fn eval_expr(s: &str) -> Option<f64> {
    let mut acc: Option<f64> = None;
    let mut op = '*';
    let mut tok = String::new();
    let apply = |acc: Option<f64>, op: char, tok: &str| -> Option<f64> {
        let t = tok.trim();
        let v = if t == "pi" {
            std::f64::consts::PI
        } else {
            t.parse::<f64>().ok()?
        };
        if !v.is_finite() {
            return None;
        }
        Some(match (acc, op) {
            (None, _) => v,
            (Some(a), '*') => a * v,
            (Some(a), _) => {
                if v == 0.0 {
                    return None;
                }
                a / v
            }
        })
    };
    for ch in s.chars() {
        if ch == '*' || ch == '/' {
            acc = Some(apply(acc, op, &tok)?);
            tok.clear();
            op = ch;
        } else {
            tok.push(ch);
        }
    }
    apply(acc, op, &tok)
}

/// A printed number like `1.667E-5` and half a unit in its last printed digit.
pub fn printed_value(s: &str) -> Option<(f64, f64)> {
    let s: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    let (mant, exp) = match s.find(['E', 'e']) {
        Some(p) => (&s[..p], s[p + 1..].parse::<i32>().ok()?),
        None => (s.as_str(), 0),
    };
    let v: f64 = mant.parse().ok()?;
    let digits = mant.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
    let half_ulp = 0.5 * 10f64.powi(exp - digits);
    Some((v * 10f64.powi(exp), half_ulp))
}

fn close(value: f64, printed: f64, tol: f64) -> bool {
    (value - printed).abs() <= tol * (1.0 + 1e-9) + printed.abs() * 1e-12
}

fn read_conversions(dir: &Path) -> Result<Conversions> {
    let t = Table::read(
        &dir.join("movidrive_pno_conversions.csv"),
        CONVERSION_COLUMNS,
    )?;
    let mut out = Conversions::default();
    for row in t.rows() {
        let index = row.int("conversion_index")?;
        if !(-128..=127).contains(&index) {
            return Err(row.err(format!("conversion index {index} is not a signed byte")));
        }
        let kind = row.req("kind")?.to_owned();
        check_errata(row)?;
        let b: f64 = row.parse("b")?;
        let a = match kind.as_str() {
            "reserved" => {
                for col in ["a_expr", "a_printed", "inv_a_printed"] {
                    if !row.str(col)?.is_empty() {
                        return Err(
                            row.err(format!("reserved index {index}: `{col}` must be empty"))
                        );
                    }
                }
                None
            }
            "decimal" | "special" => {
                let expr = row.req("a_expr")?;
                let a = eval_expr(expr).filter(|a| *a != 0.0).ok_or_else(|| {
                    row.err(format!("`a_expr` `{expr}` is not a factor expression"))
                })?;
                if kind == "decimal" {
                    if !(-DECIMAL_RULE..=DECIMAL_RULE).contains(&index) {
                        return Err(row.err(format!("decimal index {index} is outside -64…64")));
                    }
                    let rule = decimal(index);
                    if ((a - rule) / rule).abs() > 1e-12 {
                        return Err(row.err(format!("A = {a} breaks the rule 10^{index} = {rule}")));
                    }
                } else if (-DECIMAL_RULE..=DECIMAL_RULE).contains(&index) {
                    return Err(row.err(format!("index {index} falls under the decimal rule")));
                }
                let (pa, tol) = printed_value(row.req("a_printed")?)
                    .ok_or_else(|| row.err("`a_printed` is not a number"))?;
                if !close(a, pa, tol) {
                    return Err(row.err(format!("A = {a} does not round to the printed {pa}")));
                }
                let (pinv, tol) = printed_value(row.req("inv_a_printed")?)
                    .ok_or_else(|| row.err("`inv_a_printed` is not a number"))?;
                if !close(1.0 / a, pinv, tol) {
                    return Err(row.err(format!(
                        "1/A = {} does not round to the printed {pinv} (A = {a})",
                        1.0 / a
                    )));
                }
                Some(a)
            }
            other => {
                return Err(row.err(format!(
                    "kind `{other}` is not decimal, special or reserved"
                )));
            }
        };
        let c = Conversion { index, kind, a, b };
        if out.rows.insert(index, c).is_some() {
            return Err(row.err(format!("duplicate conversion index {index}")));
        }
    }
    Ok(out)
}

/// One unit of a size index.
#[derive(Debug, Clone)]
pub struct Unit {
    quantity_de: String,
    quantity_en: String,
    size: i64,
    unit_de: String,
    unit_en: String,
    symbol: String,
    aliases: Vec<String>,
    conversion: i64,
}

fn read_units(dir: &Path, conv: &Conversions) -> Result<Vec<Unit>> {
    let t = Table::read(&dir.join("movidrive_pno_units.csv"), UNIT_COLUMNS)?;
    let mut out: Vec<Unit> = Vec::new();
    for row in t.rows() {
        check_errata(row)?;
        let size = row.int("size_index")?;
        if !(0..=255).contains(&size) {
            return Err(row.err(format!("size index {size} is not a byte")));
        }
        let conversion = row.int("conversion_index")?;
        if conv.get(conversion).is_none() {
            return Err(row.err(format!("unknown or reserved conversion index {conversion}")));
        }
        let u = Unit {
            quantity_de: row.req("quantity_de")?.to_owned(),
            quantity_en: row.req("quantity_en")?.to_owned(),
            size,
            unit_de: row.req("unit_de")?.to_owned(),
            unit_en: row.req("unit_en")?.to_owned(),
            symbol: row.str("symbol")?.to_owned(),
            aliases: row
                .str("aliases")?
                .split('|')
                .filter(|s| !s.is_empty())
                .map(str::to_owned)
                .collect(),
            conversion,
        };
        if u.symbol.is_empty() && size != 0 {
            return Err(row.err("`symbol` must not be empty (only size index 0 is unitless)"));
        }
        if let Some(prev) = out.iter().rev().find(|p| p.size == size) {
            if prev.quantity_de != u.quantity_de || prev.quantity_en != u.quantity_en {
                return Err(row.err(format!(
                    "size index {size} is `{}` above but `{}` here",
                    prev.quantity_de, u.quantity_de
                )));
            }
            if let Some(last) = out.last() {
                if last.size != size {
                    return Err(row.err(format!("rows of size index {size} must be contiguous")));
                }
            }
        } else if out.last().is_some_and(|l| l.size > size) {
            return Err(row.err(format!("size index {size} out of ascending order")));
        }
        if out.iter().any(|p| p.size == size && p.symbol == u.symbol) {
            return Err(row.err(format!(
                "duplicate unit `{}` in size index {size}",
                u.symbol
            )));
        }
        out.push(u);
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Groups

#[derive(Debug, Clone)]
struct Group {
    code: String,
    name_de: String,
    name_en: String,
}

fn read_groups(dir: &Path) -> Result<Vec<Group>> {
    let t = Table::read(&dir.join("movidrive_groups.csv"), GROUP_COLUMNS)?;
    let mut out: Vec<Group> = Vec::new();
    for row in t.rows() {
        let code = row.req("group")?;
        let b = code.as_bytes();
        let ok = match b {
            [d, b'.', b'.'] => d.is_ascii_digit(),
            [d, e, b'.'] => d.is_ascii_digit() && e.is_ascii_digit(),
            _ => false,
        };
        if !ok {
            return Err(row.err(format!("group `{code}` is not `N..` or `NN.`")));
        }
        if out.iter().any(|g| g.code == code) {
            return Err(row.err(format!("duplicate group `{code}`")));
        }
        out.push(Group {
            code: code.to_owned(),
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Parameters

#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    min: i64,
    max: i64,
    step: i64,
}

#[derive(Debug, Clone)]
struct Param {
    line: u64,
    menu: Option<i64>,
    parent: Option<i64>,
    sub: i64,
    group: String,
    md60a_only: bool,
    name_de: String,
    name_en: String,
    index: i64,
    index_hex: String,
    index2: Option<i64>,
    unit: String,
    display_unit: String,
    size: i64,
    conversion: i64,
    display_conversion: Option<i64>,
    access: Vec<&'static str>,
    default: Option<i64>,
    default2: Option<i64>,
    default_outside_range: bool,
    range_de: String,
    range_en: String,
    ranges: Vec<Segment>,
    values: Vec<(i64, String, String)>,
    values_ref: Option<i64>,
    values_from: Option<usize>,
    decimals: u8,
    errata: String,
}

/// Parse SEW access notation into the names of the `Access` constants.
fn parse_access(s: &str) -> Option<Vec<&'static str>> {
    let mut out = Vec::new();
    let mut rw = 0;
    for part in s.split('/') {
        let name = match part.trim() {
            "N" => "NON_VOLATILE",
            "S" => "STORE_LOCKED",
            "R" => "NEEDS_INHIBIT",
            "RO" => {
                rw += 1;
                "READ_ONLY"
            }
            "RW" => {
                rw += 1;
                "READ_WRITE"
            }
            _ => return None,
        };
        if out.contains(&name) {
            return None;
        }
        out.push(name);
    }
    (rw == 1).then_some(out)
}

/// Parse `min..max/step;…` segments.
fn parse_ranges(row: &Row, s: &str) -> Result<Vec<Segment>> {
    let mut out = Vec::new();
    if s.is_empty() {
        return Ok(out);
    }
    for seg in s.split(';') {
        let bad = || row.err(format!("column `ranges`: `{seg}` is not `min..max/step`"));
        let (lo, rest) = seg.split_once("..").ok_or_else(bad)?;
        let (hi, step) = rest.split_once('/').ok_or_else(bad)?;
        let min = parse_int(lo.trim()).ok_or_else(bad)?;
        let max = parse_int(hi.trim()).ok_or_else(bad)?;
        let step = parse_int(step.trim()).ok_or_else(bad)?;
        if min > max {
            return Err(row.err(format!("column `ranges`: min {min} > max {max} in `{seg}`")));
        }
        if step <= 0 {
            return Err(row.err(format!("column `ranges`: step {step} must be positive")));
        }
        if min < RAW_MIN || max > RAW_MAX {
            return Err(row.err(format!(
                "column `ranges`: `{seg}` does not fit a 32-bit value"
            )));
        }
        out.push(Segment { min, max, step });
    }
    Ok(out)
}

/// Parse `value|German|English;…`.
fn parse_values(row: &Row, s: &str) -> Result<Vec<(i64, String, String)>> {
    let mut out: Vec<(i64, String, String)> = Vec::new();
    if s.is_empty() {
        return Ok(out);
    }
    for item in s.split(';') {
        let mut it = item.split('|');
        let (Some(v), Some(de), Some(en), None) = (it.next(), it.next(), it.next(), it.next())
        else {
            return Err(row.err(format!(
                "column `values`: `{item}` is not `value|German|English`"
            )));
        };
        let v = parse_int(v.trim())
            .ok_or_else(|| row.err(format!("column `values`: `{v}` is not an integer")))?;
        if de.trim().is_empty() || en.trim().is_empty() {
            return Err(row.err(format!(
                "column `values`: value {v} needs German and English text"
            )));
        }
        if out.last().is_some_and(|l| l.0 >= v) {
            return Err(row.err(format!(
                "column `values`: value {v} is not in ascending order"
            )));
        }
        out.push((v, de.trim().to_owned(), en.trim().to_owned()));
    }
    Ok(out)
}

fn check_errata(row: &Row) -> Result<()> {
    for id in row.str("errata")?.split_whitespace() {
        let ok = id
            .strip_prefix("SEW-E")
            .is_some_and(|n| n.len() == 2 && n.bytes().all(|b| b.is_ascii_digit()));
        if !ok {
            return Err(row.err(format!("errata id `{id}` is not `SEW-Enn`")));
        }
    }
    Ok(())
}

fn opt_menu(row: &Row, col: &str) -> Result<Option<i64>> {
    let s = row.str(col)?;
    if s.is_empty() {
        return Ok(None);
    }
    if s.len() != 3 || !s.bytes().all(|b| b.is_ascii_digit()) {
        return Err(row.err(format!(
            "column `{col}`: `{s}` is not a three-digit menu number"
        )));
    }
    Ok(s.parse::<i64>().ok())
}

fn read_params(
    dir: &Path,
    units: &[Unit],
    conv: &Conversions,
    groups: &[Group],
) -> Result<Vec<Param>> {
    let t = Table::read(&dir.join("movidrive_parameters.csv"), PARAM_COLUMNS)?;
    let mut out: Vec<Param> = Vec::new();
    for row in t.rows() {
        check_errata(row)?;
        let menu = opt_menu(row, "menu")?;
        let parent = opt_menu(row, "parent")?;
        let sub = row.opt_int("sub")?.unwrap_or(0);
        match (menu, parent) {
            (Some(m), None) => {
                if sub != 0 {
                    return Err(row.err("a row with a menu number has no `sub`"));
                }
                if out.iter().any(|p| p.menu == Some(m)) {
                    return Err(row.err(format!("duplicate menu number {m:03}")));
                }
            }
            (None, Some(p)) => {
                if !out.iter().any(|q| q.menu == Some(p)) {
                    return Err(row.err(format!("parent {p:03} is not a menu row above")));
                }
                if !(1..=99).contains(&sub) {
                    return Err(row.err(format!("`sub` {sub} must be 1…99")));
                }
                if out.iter().any(|q| q.parent == Some(p) && q.sub == sub) {
                    return Err(row.err(format!("duplicate sub-entry {p:03}.{sub}")));
                }
            }
            _ => return Err(row.err("exactly one of `menu` and `parent` must be given")),
        }
        let group = row.req("group")?.to_owned();
        if !groups.iter().any(|g| g.code == group) {
            return Err(row.err(format!("unknown group `{group}`")));
        }
        if let Some(m) = menu.or(parent) {
            if !group.starts_with(&format!("{:02}", m / 10)) {
                return Err(row.err(format!("menu {m:03} does not belong to group `{group}`")));
            }
        }
        let index = row.int("index")?;
        if !(INDEX_MIN..=INDEX_MAX).contains(&index) {
            return Err(row.err(format!("index {index} is outside 8192…24575 (2000h…5FFFh)")));
        }
        let index_hex = row.req("index_hex")?.to_owned();
        let hex = i64::from_str_radix(&index_hex, 16).map_err(|_| {
            row.err(format!(
                "column `index_hex`: `{index_hex}` is not hexadecimal"
            ))
        })?;
        if hex != index {
            return Err(row.err(format!(
                "index {index} is {index:04X}h, but `index_hex` says {index_hex}h (= {hex})"
            )));
        }
        let index2 = row.opt_int("index2")?;
        if let Some(i2) = index2 {
            if !(INDEX_MIN..=INDEX_MAX).contains(&i2) || i2 == index {
                return Err(row.err(format!("index2 {i2} is not a second MOVILINK index")));
            }
        }
        let size = row.int("size_index")?;
        let size_units: Vec<&Unit> = units.iter().filter(|u| u.size == size).collect();
        if size_units.is_empty() {
            return Err(row.err(format!("unknown size index {size}")));
        }
        let conversion = row.int("conversion_index")?;
        if conv.get(conversion).is_none() {
            return Err(row.err(format!("unknown or reserved conversion index {conversion}")));
        }
        let unit = row.str("unit")?.to_owned();
        if size != 0 || !unit.is_empty() {
            let known = size_units
                .iter()
                .any(|u| u.symbol == unit || u.aliases.contains(&unit));
            if !known {
                return Err(row.err(format!("unit `{unit}` is not a unit of size index {size}")));
            }
        }
        let display_unit = row.str("display_unit")?.to_owned();
        let display_conversion = if size == 0 {
            None
        } else {
            let u = size_units
                .iter()
                .find(|u| u.symbol == display_unit)
                .ok_or_else(|| {
                    row.err(format!(
                        "display unit `{display_unit}` is not a unit of size index {size} ({})",
                        size_units[0].quantity_en
                    ))
                })?;
            Some(u.conversion)
        };
        let access_s = row.req("access")?;
        let access = parse_access(access_s).ok_or_else(|| {
            row.err(format!(
                "access `{access_s}` is not SEW notation (N, S, R and one of RO, RW)"
            ))
        })?;
        let default = row.opt_int("default")?;
        let default2 = row.opt_int("default2")?;
        if default2.is_some() && index2.is_none() {
            return Err(row.err("`default2` needs `index2`"));
        }
        for d in [default, default2].into_iter().flatten() {
            if !(RAW_MIN..=RAW_MAX).contains(&d) {
                return Err(row.err(format!("default {d} does not fit a 32-bit value")));
            }
        }
        let default_outside_range = row.flag("default_outside_range")?;
        let ranges = parse_ranges(row, row.str("ranges")?)?;
        let values = parse_values(row, row.str("values")?)?;
        let values_ref = opt_menu(row, "values_ref")?;
        if !values.is_empty() && values_ref.is_some() {
            return Err(row.err("give either `values` or `values_ref`, not both"));
        }
        let mut values_from = None;
        if let Some(r) = values_ref {
            let target = out
                .iter()
                .position(|p| p.menu == Some(r))
                .ok_or_else(|| row.err(format!("values_ref {r:03} is not a menu row above")))?;
            let origin = out[target].values_from.unwrap_or(target);
            if out[origin].values.is_empty() {
                return Err(row.err(format!("values_ref {r:03} has no value list")));
            }
            values_from = Some(origin);
            // The printed reference names the referenced index too: it must match.
            let expect = format!("Nr {r:03} bzw. Index {}", out[target].index);
            let printed = row.str("range_de")?.replace("MenüNr", "Menü Nr");
            if !printed.contains(&expect) {
                return Err(row.err(format!("range_de must reference `{expect}`")));
            }
        }
        let range_de = row.str("range_de")?.to_owned();
        let range_en = row.str("range_en")?.to_owned();
        if range_de.is_empty() != range_en.is_empty() {
            return Err(row.err("`range_de` and `range_en` must both be given or both be empty"));
        }
        if !ranges.is_empty() && !range_de.contains("...") {
            return Err(row.err("`ranges` given but `range_de` prints no range"));
        }
        // The default must lie within the range / value list unless the row says otherwise.
        let list: Vec<i64> = match values_from {
            Some(o) => out[o].values.iter().map(|v| v.0).collect(),
            None => values.iter().map(|v| v.0).collect(),
        };
        if let Some(d) = default {
            let inside = if !ranges.is_empty() {
                Some(ranges.iter().any(|s| s.min <= d && d <= s.max))
            } else if !list.is_empty() {
                Some(list.contains(&d))
            } else {
                None
            };
            match (inside, default_outside_range) {
                (Some(false), false) => {
                    return Err(row.err(format!(
                        "default {d} lies outside the printed range; if the manual really says \
                         so, set `default_outside_range` and record it in docs/errata-sew.md"
                    )));
                }
                (Some(true) | None, true) => {
                    return Err(row.err("`default_outside_range` is set but the default is inside"));
                }
                _ => {}
            }
        } else if default_outside_range {
            return Err(row.err("`default_outside_range` is set but there is no default"));
        }
        // Decimals worth showing: the display resolution of the smallest step.
        let (a, _) = conv.get(conversion).unwrap_or((1.0, 0.0));
        let (ad, _) = display_conversion
            .and_then(|c| conv.get(c))
            .unwrap_or((1.0, 0.0));
        let step = ranges.iter().map(|s| s.step).min().unwrap_or(1) as f64;
        let resolution = (a / ad).abs() * step;
        let decimals = if values.is_empty() && values_from.is_none() {
            (-resolution.log10() - 1e-9).ceil().clamp(0.0, 6.0) as u8
        } else {
            0
        };
        out.push(Param {
            line: row.line(),
            menu,
            parent,
            sub,
            group,
            md60a_only: row.flag("md60a_only")?,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            index,
            index_hex,
            index2,
            unit,
            display_unit,
            size,
            conversion,
            display_conversion,
            access,
            default,
            default2,
            default_outside_range,
            range_de,
            range_en,
            ranges,
            values,
            values_ref,
            values_from,
            decimals,
            errata: row.str("errata")?.to_owned(),
        });
    }
    Ok(out)
}

fn render_params(params: &[Param], groups: &[Group]) -> String {
    let mut s = header(
        "SEW MOVIDRIVE parameter list, sew/movidrive_parameters.csv and movidrive_groups.csv",
    );
    s.push_str(
        "use crate::param::{Access, ValueName};\nuse crate::sew::{Group, Param, Segment};\n\n",
    );
    // Value lists.
    for (i, p) in params.iter().enumerate() {
        if p.values.is_empty() {
            continue;
        }
        let _ = writeln!(s, "static VALUES_{i}: &[ValueName] = &[");
        for (v, de, en) in &p.values {
            let _ = writeln!(
                s,
                "    ValueName {{ value: {v}, de: {}, en: {} }},",
                lit(de),
                lit(en)
            );
        }
        s.push_str("];\n");
    }
    s.push('\n');
    // Section headings.
    s.push_str("/// The section headings of the parameter list, in manual order.\npub static GROUPS: &[Group] = &[\n");
    for g in groups {
        let _ = writeln!(
            s,
            "    Group {{ code: {}, name_de: {}, name_en: {} }},",
            lit(&g.code),
            lit(&g.name_de),
            lit(&g.name_en)
        );
    }
    s.push_str("];\n\n");
    // Parameters.
    s.push_str(
        "/// Every row of the parameter list, in manual order.\npub static PARAMS: &[Param] = &[\n",
    );
    for (i, p) in params.iter().enumerate() {
        let access = p
            .access
            .iter()
            .map(|a| format!("Access::{a}"))
            .reduce(|a, b| format!("{a}.union({b})"))
            .unwrap_or_else(|| "Access::NONE".into());
        let values = match (p.values.is_empty(), p.values_from) {
            (false, _) => format!("VALUES_{i}"),
            (true, Some(o)) => format!("VALUES_{o}"),
            (true, None) => "&[]".into(),
        };
        let ranges = if p.ranges.is_empty() {
            "&[]".to_owned()
        } else {
            let segs: Vec<String> = p
                .ranges
                .iter()
                .map(|r| {
                    format!(
                        "Segment {{ min: {}, max: {}, step: {} }}",
                        r.min, r.max, r.step
                    )
                })
                .collect();
            format!("&[{}]", segs.join(", "))
        };
        let _ = writeln!(s, "    // csv line {}", p.line);
        s.push_str("    Param {\n");
        let _ = writeln!(s, "        menu: {},", opt_num(p.menu));
        let _ = writeln!(s, "        parent: {},", opt_num(p.parent));
        let _ = writeln!(s, "        sub: {},", p.sub);
        let _ = writeln!(s, "        group: {},", lit(&p.group));
        let _ = writeln!(s, "        md60a_only: {},", p.md60a_only);
        let _ = writeln!(s, "        name_de: {},", lit(&p.name_de));
        let _ = writeln!(s, "        name_en: {},", lit(&p.name_en));
        let _ = writeln!(s, "        index: {},", p.index);
        let _ = writeln!(s, "        index_hex: {},", lit(&p.index_hex));
        let _ = writeln!(s, "        index2: {},", opt_num(p.index2));
        let _ = writeln!(s, "        pno_unit: {},", lit(&p.unit));
        let _ = writeln!(s, "        display_unit: {},", lit(&p.display_unit));
        let _ = writeln!(s, "        size_index: {},", p.size);
        let _ = writeln!(s, "        conversion_index: {},", p.conversion);
        let _ = writeln!(
            s,
            "        display_conversion_index: {},",
            opt_num(p.display_conversion)
        );
        let _ = writeln!(s, "        access: {access},");
        let _ = writeln!(s, "        default: {},", opt_num(p.default));
        let _ = writeln!(s, "        default2: {},", opt_num(p.default2));
        let _ = writeln!(
            s,
            "        default_outside_range: {},",
            p.default_outside_range
        );
        let _ = writeln!(s, "        range_de: {},", lit(&p.range_de));
        let _ = writeln!(s, "        range_en: {},", lit(&p.range_en));
        let _ = writeln!(s, "        ranges: {ranges},");
        let _ = writeln!(s, "        values: {values},");
        let _ = writeln!(s, "        values_ref: {},", opt_num(p.values_ref));
        let _ = writeln!(s, "        decimals: {},", p.decimals);
        let _ = writeln!(s, "        errata: {},", lit(&p.errata));
        s.push_str("    },\n");
    }
    s.push_str("];\n\n");
    // Index table: (index, row) for index and index2, sorted.
    let mut by_index: Vec<(i64, usize)> = Vec::new();
    for (i, p) in params.iter().enumerate() {
        by_index.push((p.index, i));
        if let Some(i2) = p.index2 {
            by_index.push((i2, i));
        }
    }
    by_index.sort_unstable();
    s.push_str("/// `(index, row in PARAMS)` for every index and second index, sorted.\npub static BY_INDEX: &[(u16, u16)] = &[\n");
    for chunk in by_index.chunks(8) {
        let items: Vec<String> = chunk.iter().map(|(a, b)| format!("({a}, {b})")).collect();
        let _ = writeln!(s, "    {},", items.join(", "));
    }
    s.push_str("];\n\n");
    let mut by_menu: Vec<(i64, usize)> = params
        .iter()
        .enumerate()
        .filter_map(|(i, p)| p.menu.map(|m| (m, i)))
        .collect();
    by_menu.sort_unstable();
    s.push_str(
        "/// `(menu number, row in PARAMS)`, sorted.\npub static BY_MENU: &[(u16, u16)] = &[\n",
    );
    for chunk in by_menu.chunks(8) {
        let items: Vec<String> = chunk.iter().map(|(a, b)| format!("({a}, {b})")).collect();
        let _ = writeln!(s, "    {},", items.join(", "));
    }
    s.push_str("];\n");
    s
}

fn opt_num(v: Option<i64>) -> String {
    crate::render::opt(v, |x| x.to_string())
}

fn render_pno(units: &[Unit], conv: &Conversions) -> String {
    let mut s = header(
        "PNO size and conversion indices, sew/movidrive_pno_units.csv and movidrive_pno_conversions.csv",
    );
    s.push_str("use crate::sew::{Conversion, ConversionKind, SizeUnit};\n\n");
    s.push_str("/// The units of every size index, sorted by size index (manual order within one).\npub static UNITS: &[SizeUnit] = &[\n");
    for u in units {
        let aliases: Vec<String> = u.aliases.iter().map(|a| lit(a)).collect();
        let _ = writeln!(
            s,
            "    SizeUnit {{ size_index: {}, quantity_de: {}, quantity_en: {}, unit_de: {}, unit_en: {}, symbol: {}, aliases: &[{}], conversion_index: {} }},",
            u.size,
            lit(&u.quantity_de),
            lit(&u.quantity_en),
            lit(&u.unit_de),
            lit(&u.unit_en),
            lit(&u.symbol),
            aliases.join(", "),
            u.conversion
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// The printed conversion indices, sorted (decimal ones follow the rule 10^n).\npub static CONVERSIONS: &[Conversion] = &[\n");
    for c in conv.rows.values() {
        let kind = match c.kind.as_str() {
            "decimal" => "Decimal",
            "special" => "Special",
            _ => "Reserved",
        };
        let _ = writeln!(
            s,
            "    Conversion {{ index: {}, kind: ConversionKind::{kind}, a: {}, b: {:?} }},",
            c.index,
            crate::render::opt(c.a, |a| format!("{a:?}")),
            c.b
        );
    }
    s.push_str("];\n");
    s
}

// ---------------------------------------------------------------------------------------------
// Return codes

#[derive(Debug, Clone)]
struct Class {
    class: i64,
    name: String,
    de: String,
    en: String,
}

#[derive(Debug, Clone)]
struct Code {
    class: i64,
    code: i64,
    add: i64,
    de: String,
    en: String,
    source: String,
    retry: bool,
}

fn hex_byte(row: &Row, col: &str) -> Result<i64> {
    let s = row.req(col)?;
    match u8::from_str_radix(s, 16) {
        Ok(v) if s.len() == 2 => Ok(i64::from(v)),
        _ => Err(row.err(format!("column `{col}`: `{s}` is not two hex digits"))),
    }
}

fn read_return_codes(dir: &Path) -> Result<(Vec<Class>, Vec<Code>)> {
    let t = Table::read(&dir.join("movilink_error_classes.csv"), CLASS_COLUMNS)?;
    let mut classes: Vec<Class> = Vec::new();
    for row in t.rows() {
        let class = row.int("class")?;
        if !(0..=255).contains(&class) {
            return Err(row.err(format!("error class {class} is not a byte")));
        }
        if classes.iter().any(|c| c.class == class) {
            return Err(row.err(format!("duplicate error class {class}")));
        }
        classes.push(Class {
            class,
            name: row.req("name")?.to_owned(),
            de: row.req("meaning_de")?.to_owned(),
            en: row.req("meaning_en")?.to_owned(),
        });
    }
    let t = Table::read(&dir.join("movilink_return_codes.csv"), RETURN_CODE_COLUMNS)?;
    let mut codes: Vec<Code> = Vec::new();
    for row in t.rows() {
        let class = row.int("class")?;
        if !classes.iter().any(|c| c.class == class) {
            return Err(row.err(format!("unknown error class {class}")));
        }
        let code = row.int("code")?;
        if !(0..=255).contains(&code) {
            return Err(row.err(format!("error code {code} is not a byte")));
        }
        let add = (hex_byte(row, "add_high")? << 8) | hex_byte(row, "add_low")?;
        if codes
            .iter()
            .any(|c| (c.class, c.code, c.add) == (class, code, add))
        {
            return Err(row.err(format!("duplicate return code {class}/{code}/{add:04X}")));
        }
        let source = row.req("source")?.to_owned();
        if !["5.2", "6.2"].contains(&source.as_str()) {
            return Err(row.err(format!(
                "source `{source}` is not a manual section (5.2 or 6.2)"
            )));
        }
        codes.push(Code {
            class,
            code,
            add,
            de: row.req("name_de")?.to_owned(),
            en: row.req("name_en")?.to_owned(),
            source,
            retry: row.flag("retry")?,
        });
    }
    classes.sort_by_key(|c| c.class);
    codes.sort_by_key(|c| (c.class, c.code, c.add));
    Ok((classes, codes))
}

fn render_return_codes(classes: &[Class], codes: &[Code]) -> String {
    let mut s = header(
        "MOVILINK return codes, sew/movilink_error_classes.csv and movilink_return_codes.csv",
    );
    s.push_str("use crate::sew::{ErrorClassInfo, ReturnCodeInfo};\n\n");
    s.push_str(
        "/// The error classes (EN 50170), sorted.\npub static ERROR_CLASSES: &[ErrorClassInfo] = &[\n",
    );
    for c in classes {
        let _ = writeln!(
            s,
            "    ErrorClassInfo {{ class: {}, name: {}, de: {}, en: {} }},",
            c.class,
            lit(&c.name),
            lit(&c.de),
            lit(&c.en)
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// The return codes with a meaning, sorted by (class, code, additional code).\npub static RETURN_CODES: &[ReturnCodeInfo] = &[\n");
    for c in codes {
        let _ = writeln!(
            s,
            "    ReturnCodeInfo {{ class: {}, code: {}, additional: 0x{:04X}, de: {}, en: {}, section: {}, retry: {} }},",
            c.class,
            c.code,
            c.add,
            lit(&c.de),
            lit(&c.en),
            lit(&c.source),
            c.retry
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn data() -> PathBuf {
        crate::data_dir(&crate::workspace_root()).join("sew")
    }

    /// A copy of the real data folder with `file` edited by `edit`.
    fn with_edit(name: &str, file: &str, edit: impl Fn(&str) -> String) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("drivebus-sew-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(data()).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
        }
        let p = dir.join(file);
        let text = std::fs::read_to_string(&p).unwrap();
        let edited = edit(&text);
        assert_ne!(text, edited, "edit changed nothing");
        std::fs::write(&p, edited).unwrap();
        dir
    }

    fn err_of(dir: &Path) -> String {
        let e = generate(dir).expect_err("must fail").0;
        let _ = std::fs::remove_dir_all(dir);
        e
    }

    /// Replace one field of the parameter row with menu number `menu`.
    fn edit_param(text: &str, menu: &str, col: &str, value: &str) -> String {
        let ci = PARAM_COLUMNS.iter().position(|c| *c == col).unwrap();
        let mut out = String::new();
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .from_reader(text.as_bytes());
        let mut w = csv::WriterBuilder::new()
            .terminator(csv::Terminator::Any(b'\n'))
            .from_writer(Vec::new());
        for rec in rdr.records() {
            let rec = rec.unwrap();
            let mut f: Vec<String> = rec.iter().map(str::to_owned).collect();
            if f[0] == menu {
                f[ci] = value.to_owned();
            }
            w.write_record(&f).unwrap();
        }
        out.push_str(std::str::from_utf8(&w.into_inner().unwrap()).unwrap());
        out
    }

    /// The 1-based line of the row with menu number `menu` in the real CSV.
    fn line_of(menu: &str) -> usize {
        let text = std::fs::read_to_string(data().join("movidrive_parameters.csv")).unwrap();
        text.lines()
            .position(|l| l.starts_with(&format!("{menu},")))
            .unwrap()
            + 1
    }

    #[test]
    fn real_tables_validate() {
        let out = generate(&data()).unwrap();
        assert_eq!(out.len(), 3);
        assert!(out.iter().all(|o| o.text.starts_with("// @generated")));
    }

    #[test]
    fn bad_hex_index_names_file_and_line() {
        let dir = with_edit("hex", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "index_hex", "2199")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("813"))),
            "{e}"
        );
        assert!(e.contains("2199"), "{e}");
    }

    #[test]
    fn non_hex_digits_are_rejected() {
        let dir = with_edit("hexdigits", "movidrive_parameters.csv", |t| {
            edit_param(t, "000", "index_hex", "20G7")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("000"))),
            "{e}"
        );
    }

    #[test]
    fn bad_access_names_file_and_line() {
        let dir = with_edit("access", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "access", "N/XW")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("813"))),
            "{e}"
        );
        assert!(e.contains("access"), "{e}");
        // Both RO and RW at once is not SEW notation either.
        let dir = with_edit("access2", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "access", "RO/RW")
        });
        assert!(err_of(&dir).contains("access"));
    }

    #[test]
    fn unknown_size_index_names_file_and_line() {
        let dir = with_edit("size", "movidrive_parameters.csv", |t| {
            edit_param(t, "000", "size_index", "99")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("000"))),
            "{e}"
        );
        assert!(e.contains("size index 99"), "{e}");
    }

    #[test]
    fn display_unit_must_belong_to_size_index() {
        let dir = with_edit("display", "movidrive_parameters.csv", |t| {
            edit_param(t, "000", "display_unit", "V")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("000"))),
            "{e}"
        );
    }

    #[test]
    fn reserved_conversion_index_is_rejected() {
        let dir = with_edit("conv", "movidrive_parameters.csv", |t| {
            edit_param(t, "000", "conversion_index", "69")
        });
        assert!(err_of(&dir).contains("conversion index 69"));
    }

    #[test]
    fn default_outside_range_needs_marker() {
        let dir = with_edit("default", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "default", "64")
        });
        let e = err_of(&dir);
        assert!(
            e.contains(&format!("movidrive_parameters.csv:{}:", line_of("813"))),
            "{e}"
        );
        assert!(e.contains("default_outside_range"), "{e}");
        let dir = with_edit("marker", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "default_outside_range", "1")
        });
        assert!(err_of(&dir).contains("default is inside"));
    }

    #[test]
    fn bad_ranges_are_rejected() {
        let dir = with_edit("minmax", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "ranges", "63..0/1")
        });
        assert!(err_of(&dir).contains("min 63 > max 0"));
        let dir = with_edit("wide", "movidrive_parameters.csv", |t| {
            edit_param(t, "813", "ranges", "0..1099511627775/1")
        });
        assert!(err_of(&dir).contains("32-bit"));
    }

    #[test]
    fn values_ref_must_exist_and_match_the_printed_index() {
        let dir = with_edit("ref", "movidrive_parameters.csv", |t| {
            edit_param(t, "871", "values_ref", "869")
        });
        assert!(err_of(&dir).contains("values_ref 869"));
        let dir = with_edit("refidx", "movidrive_parameters.csv", |t| {
            edit_param(t, "871", "range_de", "Siehe Menü Nr 870 bzw. Index 8305")
        });
        assert!(err_of(&dir).contains("Index 8304"));
    }

    #[test]
    fn duplicate_menu_numbers_are_rejected() {
        let dir = with_edit("dup", "movidrive_parameters.csv", |t| {
            edit_param(t, "814", "menu", "813")
        });
        assert!(err_of(&dir).contains("duplicate menu number 813"));
    }

    #[test]
    fn conversion_table_checks_reciprocal() {
        let dir = with_edit("inv", "movidrive_pno_conversions.csv", |t| {
            t.replace(
                "66,special,1/1000/60,1.667E-5,6.000E+4",
                "66,special,1/1000/60,1.667E-5,6.100E+4",
            )
        });
        let e = err_of(&dir);
        assert!(e.contains("movidrive_pno_conversions.csv:"), "{e}");
        assert!(e.contains("1/A"), "{e}");
        let dir = with_edit("rule", "movidrive_pno_conversions.csv", |t| {
            t.replace("2,decimal,100,1.E+2,1.E-2", "2,decimal,1000,1.E+3,1.E-3")
        });
        assert!(err_of(&dir).contains("10^2"));
    }

    #[test]
    fn printed_precision() {
        assert_eq!(printed_value("1.667E-5").map(|p| p.0), Some(1.667e-5));
        let (v, tol) = printed_value("3.6 E+6").unwrap();
        assert_eq!(v, 3.6e6);
        assert!((tol - 0.05e6).abs() < 1e-6);
        assert!(close(
            1.0 / (1e-3 / 60.0),
            6.000e4,
            printed_value("6.000E+4").unwrap().1
        ));
        assert_eq!(eval_expr("pi/180"), Some(std::f64::consts::PI / 180.0));
        assert_eq!(eval_expr("3600*1000"), Some(3.6e6));
        assert_eq!(eval_expr("1/0"), None);
        assert_eq!(eval_expr("x"), None);
    }

    #[test]
    fn every_errata_id_is_documented() {
        let ids = errata_ids(&data()).unwrap();
        let doc =
            std::fs::read_to_string(crate::workspace_root().join("docs/errata-sew.md")).unwrap();
        for id in &ids {
            assert!(
                doc.contains(&format!("## {id}")),
                "{id} is used in the CSV files but has no section in docs/errata-sew.md"
            );
        }
        assert!(ids.len() >= 10);
    }

    #[test]
    fn access_parsing() {
        assert_eq!(
            parse_access("N/R/RW"),
            Some(vec!["NON_VOLATILE", "NEEDS_INHIBIT", "READ_WRITE"])
        );
        assert_eq!(parse_access("RO"), Some(vec!["READ_ONLY"]));
        assert_eq!(parse_access("N/S"), None);
        assert_eq!(parse_access("RW/RW"), None);
    }
}
