//! PNO conversion and size indices (manual ch. 7.3): `movidrive_pno_conversions.csv` and
//! `movidrive_pno_units.csv`, rendered into `sew_pno.rs`.

use super::check_errata;
use crate::Result;
use crate::render::{header, lit};
use crate::table::Table;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

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
/// Conversion indices from -64 to +64 follow the decimal rule A = 10^n (manual ch. 7.3).
const DECIMAL_RULE: i64 = 64;

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

/// Read the conversion table: signed-byte indices, each once; printed factors that match
/// their expression, the decimal rule and the printed reciprocal.
pub(super) fn read_conversions(dir: &Path) -> Result<Conversions> {
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
    pub(super) quantity_en: String,
    pub(super) size: i64,
    unit_de: String,
    unit_en: String,
    pub(super) symbol: String,
    pub(super) aliases: Vec<String>,
    pub(super) conversion: i64,
}

/// Read the units of the size indices: ascending, contiguous per size index, each unit once,
/// with a known conversion index.
pub(super) fn read_units(dir: &Path, conv: &Conversions) -> Result<Vec<Unit>> {
    let t = Table::read(&dir.join("movidrive_pno_units.csv"), UNIT_COLUMNS)?;
    let mut out: Vec<Unit> = Vec::new();
    for row in t.rows() {
        check_errata(row)?;
        let size = i64::from(row.byte("size_index")?);
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
            aliases: row.list("aliases")?,
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
            if let Some(last) = out.last()
                && last.size != size
            {
                return Err(row.err(format!("rows of size index {size} must be contiguous")));
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

/// Render `sew_pno.rs`.
pub(super) fn render_pno(units: &[Unit], conv: &Conversions) -> String {
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

#[cfg(test)]
mod tests {
    use super::super::tests::{err_of, with_edit};
    use super::*;

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
}
