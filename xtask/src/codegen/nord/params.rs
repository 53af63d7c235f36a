//! Parameters: `nord_parameters.csv`, `nord_param_arrays.csv` and
//! `nord_param_values.csv`, rendered into `nord_params.rs`.

use crate::Result;
use crate::render::{header, lit, opt, opt_display, value_name};
use crate::table::{Row, Table};
use std::fmt::Write as _;
use std::path::Path;

/// One parameter with its array elements and value list.
#[derive(Debug, Clone)]
pub struct ParamRow {
    number: u16,
    pnu: u16,
    name_de: String,
    name_en: String,
    unit: String,
    /// Resolution text and its (mantissa, scale).
    resolution: Option<(String, Decimal)>,
    raw_range: Option<(i64, i64)>,
    default_raw: Option<i64>,
    range_de: String,
    range_en: String,
    read_only: bool,
    param_set: bool,
    array_len: Option<u8>,
    description_de: String,
    description_en: String,
    source: String,
    elements: Vec<(u8, String, String)>,
    values: Vec<(i64, String, String)>,
}

/// A decimal number as (mantissa, number of fractional digits): `320.00` = (32000, 2).
type Decimal = (i128, u32);

/// Parse `-12.345` style decimals (a dot, no exponent).
fn decimal(s: &str) -> Option<Decimal> {
    let (neg, body) = match s.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, s),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    if int.is_empty() || !int.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if !frac.bytes().all(|b| b.is_ascii_digit()) || body.ends_with('.') || frac.len() > 9 {
        return None;
    }
    let digits = format!("{int}{frac}");
    let m: i128 = digits.parse().ok()?;
    Some((if neg { -m } else { m }, frac.len() as u32))
}

/// `value / step` when it is a whole number.
fn steps(value: Decimal, step: Decimal) -> Option<i64> {
    let scale = value.1.max(step.1);
    let v = value.0 * 10i128.pow(scale - value.1);
    let s = step.0 * 10i128.pow(scale - step.1);
    if s <= 0 || v % s != 0 {
        return None;
    }
    i64::try_from(v / s).ok()
}

/// Format `raw` steps of `step` with the step's decimals, using `sep` as decimal separator.
fn format_steps(raw: i64, step: Decimal, sep: char) -> String {
    let v = i128::from(raw) * step.0;
    let d = step.1 as usize;
    let sign = if v < 0 { "-" } else { "" };
    let digits = format!("{:0>width$}", v.abs(), width = d + 1);
    if d == 0 {
        format!("{sign}{digits}")
    } else {
        let (int, frac) = digits.split_at(digits.len() - d);
        format!("{sign}{int}{sep}{frac}")
    }
}

/// Read the parameters: unique numbers, PNU equal to the number and within PKE bits 0..10,
/// min/max/default whole multiples of the resolution, within a 16-bit word, default in range.
pub fn read_params(path: &Path) -> Result<Vec<ParamRow>> {
    let table = Table::read(
        path,
        &[
            "number",
            "pnu",
            "name_de",
            "name_en",
            "unit",
            "resolution",
            "min",
            "max",
            "default",
            "access",
            "param_set",
            "array_len",
            "description_de",
            "description_en",
            "source",
        ],
    )?;
    let mut out: Vec<ParamRow> = Vec::new();
    for row in table.rows() {
        let number = row.int("number")?;
        let number = u16::try_from(number)
            .ok()
            .filter(|n| *n <= 999)
            .ok_or_else(|| row.err(format!("parameter number {number} is outside 0..999")))?;
        let pnu = row.int("pnu")?;
        if pnu != i64::from(number) {
            return Err(row.err(format!(
                "PNU {pnu:#X} differs from the parameter number P{number} ({:#X}); the manual \
                 sends the parameter number as PNU (P102 = 66h, P701 = 2BDh)",
                number
            )));
        }
        if pnu > 0x7FF {
            return Err(row.err(format!("PNU {pnu:#X} does not fit PKE bits 0..10")));
        }
        if out.iter().any(|p| p.number == number) {
            return Err(row.err(format!("P{number} appears twice")));
        }
        let resolution = row.opt_with("resolution", |s| {
            let d = decimal(s)
                .filter(|d| d.0 > 0)
                .ok_or_else(|| row.err(format!("resolution `{s}` is not a positive decimal")))?;
            Ok((s.to_owned(), d))
        })?;
        let step = resolution.as_ref().map_or((1, 0), |r| r.1);
        let raw = |col: &str| {
            row.opt_with(col, |s| {
                let d = decimal(s)
                    .ok_or_else(|| row.err(format!("column `{col}`: `{s}` is not a decimal")))?;
                let r = steps(d, step).ok_or_else(|| {
                    row.err(format!(
                        "column `{col}`: {s} is not a whole multiple of the resolution"
                    ))
                })?;
                if !(-32768..=65535).contains(&r) {
                    return Err(row.err(format!(
                        "column `{col}`: raw value {r} does not fit a 16-bit word (section 6)"
                    )));
                }
                Ok(r)
            })
        };
        let (min, max, default) = (raw("min")?, raw("max")?, raw("default")?);
        let raw_range = match (min, max) {
            (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
            (Some(lo), Some(hi)) => {
                return Err(row.err(format!("min (raw {lo}) is above max (raw {hi})")));
            }
            (None, None) => None,
            _ => return Err(row.err("give both min and max, or neither")),
        };
        if let (Some(d), Some((lo, hi))) = (default, raw_range)
            && !(lo..=hi).contains(&d)
        {
            return Err(row.err(format!("default (raw {d}) is outside raw {lo}..{hi}")));
        }
        let read_only = match row.req("access")? {
            "RO" => true,
            "RW" => false,
            other => return Err(row.err(format!("access `{other}` is not RO or RW"))),
        };
        let array_len = match row.opt_int("array_len")? {
            None => None,
            Some(n) if (1..=64).contains(&n) => Some(n as u8),
            Some(n) => {
                return Err(row.err(format!("array_len {n} is outside 1..64 (IND bits 10..15)")));
            }
        };
        let unit = row.str("unit")?.to_owned();
        let (range_de, range_en) = match raw_range {
            Some((lo, hi)) => {
                let u = if unit.is_empty() {
                    String::new()
                } else {
                    format!(" {unit}")
                };
                (
                    format!(
                        "{} … {}{u}",
                        format_steps(lo, step, ','),
                        format_steps(hi, step, ',')
                    ),
                    format!(
                        "{} … {}{u}",
                        format_steps(lo, step, '.'),
                        format_steps(hi, step, '.')
                    ),
                )
            }
            None => (String::new(), String::new()),
        };
        out.push(ParamRow {
            number,
            pnu: pnu as u16,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            unit,
            resolution,
            raw_range,
            default_raw: default,
            range_de,
            range_en,
            read_only,
            param_set: row.flag("param_set")?,
            array_len,
            description_de: row.req("description_de")?.to_owned(),
            description_en: row.req("description_en")?.to_owned(),
            source: row.req("source")?.to_owned(),
            elements: Vec::new(),
            values: Vec::new(),
        });
    }
    out.sort_by_key(|p| p.number);
    Ok(out)
}

fn param_of<'a>(row: &Row, params: &'a mut [ParamRow]) -> Result<&'a mut ParamRow> {
    let n = row.int("number")?;
    params
        .iter_mut()
        .find(|p| i64::from(p.number) == n)
        .ok_or_else(|| row.err(format!("P{n} is not in nord_parameters.csv")))
}

/// Read the named array elements: of an array parameter, within its length, once each.
pub fn read_param_arrays(path: &Path, params: &mut [ParamRow]) -> Result<()> {
    let table = Table::read(path, &["number", "element", "name_de", "name_en", "source"])?;
    for row in table.rows() {
        let p = param_of(row, params)?;
        let len = p
            .array_len
            .ok_or_else(|| row.err(format!("P{} is not an array (array_len empty)", p.number)))?;
        let e = row.int("element")?;
        if !(1..=i64::from(len)).contains(&e) {
            return Err(row.err(format!("element {e} is outside [-01]..[-{len:02}]")));
        }
        let e = e as u8;
        if p.elements.iter().any(|x| x.0 == e) {
            return Err(row.err(format!("P{} [-{e:02}] appears twice", p.number)));
        }
        let (de, en) = row.text_pair("name_de", "name_en")?;
        row.req("source")?;
        p.elements.push((e, de.to_owned(), en.to_owned()));
    }
    for p in params.iter_mut() {
        p.elements.sort_by_key(|e| e.0);
    }
    Ok(())
}

/// Read the value lists: of a known parameter, once per value, inside the parameter's range.
pub fn read_param_values(path: &Path, params: &mut [ParamRow]) -> Result<()> {
    let table = Table::read(path, &["number", "value", "de", "en", "source"])?;
    for row in table.rows() {
        let p = param_of(row, params)?;
        let v = row.int("value")?;
        if p.values.iter().any(|x| x.0 == v) {
            return Err(row.err(format!("value {v} of P{} appears twice", p.number)));
        }
        if let Some((lo, hi)) = p.raw_range
            && !(lo..=hi).contains(&v)
        {
            return Err(row.err(format!("value {v} is outside the raw range {lo}..{hi}")));
        }
        row.req("source")?;
        p.values
            .push((v, row.req("de")?.to_owned(), row.req("en")?.to_owned()));
    }
    for p in params.iter_mut() {
        p.values.sort_by_key(|v| v.0);
    }
    Ok(())
}

/// Render `nord_params.rs`.
pub(super) fn render_params(params: &[ParamRow]) -> String {
    let mut s =
        header("nord/nord_parameters.csv, nord/nord_param_arrays.csv, nord/nord_param_values.csv");
    s.push_str("use crate::nord::{ArrayElement, Param, Resolution};\n");
    s.push_str("use crate::param::{Access, ValueName};\n\n");
    s.push_str("/// The parameters BU 0255 names, sorted by number (= PNU).\n");
    let _ = writeln!(s, "pub static PARAMS: [Param; {}] = [", params.len());
    for p in params {
        let resolution = opt(p.resolution.as_ref(), |(text, d)| {
            let step = if text.contains('.') {
                text.clone()
            } else {
                format!("{text}.0")
            };
            format!(
                "Resolution {{ step: {step}, decimals: {}, text: {} }}",
                d.1,
                lit(text)
            )
        });
        let elements: Vec<String> = p
            .elements
            .iter()
            .map(|(e, de, en)| {
                format!(
                    "ArrayElement {{ element: {e}, name_de: {}, name_en: {} }}",
                    lit(de),
                    lit(en)
                )
            })
            .collect();
        let values: Vec<String> = p
            .values
            .iter()
            .map(|(v, de, en)| value_name(*v, de, en))
            .collect();
        let _ = writeln!(s, "    Param {{");
        let _ = writeln!(s, "        number: {},", p.number);
        let _ = writeln!(s, "        pnu: 0x{:03X},", p.pnu);
        let _ = writeln!(s, "        name_de: {},", lit(&p.name_de));
        let _ = writeln!(s, "        name_en: {},", lit(&p.name_en));
        let _ = writeln!(s, "        unit: {},", lit(&p.unit));
        let _ = writeln!(s, "        resolution: {resolution},");
        let _ = writeln!(
            s,
            "        raw_range: {},",
            opt(p.raw_range, |(a, b)| format!("({a}, {b})"))
        );
        let _ = writeln!(s, "        default_raw: {},", opt_display(p.default_raw));
        let _ = writeln!(s, "        range_de: {},", lit(&p.range_de));
        let _ = writeln!(s, "        range_en: {},", lit(&p.range_en));
        let _ = writeln!(
            s,
            "        access: Access::{},",
            if p.read_only {
                "READ_ONLY"
            } else {
                "READ_WRITE"
            }
        );
        let _ = writeln!(s, "        parameter_set: {},", p.param_set);
        let _ = writeln!(s, "        array_len: {},", opt_display(p.array_len));
        let _ = writeln!(s, "        elements: &[{}],", elements.join(", "));
        let _ = writeln!(s, "        values: &[{}],", values.join(", "));
        let _ = writeln!(s, "        description_de: {},", lit(&p.description_de));
        let _ = writeln!(s, "        description_en: {},", lit(&p.description_en));
        let _ = writeln!(s, "        source: {},", lit(&p.source));
        let _ = writeln!(s, "    }},");
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{edited, expect_err, line_of, real};
    use super::*;

    #[test]
    fn pnu_must_equal_the_number() {
        let f = "nord_parameters.csv";
        let n = line_of(f, "102,");
        let d = edited(
            "pnu",
            f,
            "102,",
            "102,0x67,Hochlaufzeit,acc,s,0.01,0,320.00,,RW,1,,d,d,s",
        );
        expect_err(
            read_params(&d.file(f)),
            f,
            n,
            "differs from the parameter number",
        );
    }

    #[test]
    fn values_must_be_multiples_of_the_resolution() {
        let f = "nord_parameters.csv";
        let n = line_of(f, "102,");
        let d = edited(
            "res",
            f,
            "102,",
            "102,0x66,Hochlaufzeit,acc,s,0.01,0,320.005,,RW,1,,d,d,s",
        );
        expect_err(read_params(&d.file(f)), f, n, "whole multiple");
        let d = edited(
            "word",
            f,
            "102,",
            "102,0x66,Hochlaufzeit,acc,s,0.01,0,700.00,,RW,1,,d,d,s",
        );
        expect_err(read_params(&d.file(f)), f, n, "16-bit word");
    }

    #[test]
    fn array_elements_must_fit_the_array() {
        let mut params = read_params(&real("nord_parameters.csv")).unwrap();
        let f = "nord_param_arrays.csv";
        let n = line_of(f, "700,3,");
        let d = edited("elem", f, "700,3,", "700,4,x,x,manual");
        let r = read_param_arrays(&d.file(f), &mut params);
        expect_err(r, f, n, "outside [-01]..[-03]");
    }

    #[test]
    fn decimals_parse_and_format() {
        assert_eq!(decimal("320.00"), Some((32000, 2)));
        assert_eq!(decimal("-0.5"), Some((-5, 1)));
        assert_eq!(decimal("1."), None);
        assert_eq!(decimal(".5"), None);
        assert_eq!(steps((32000, 2), (1, 2)), Some(32000));
        assert_eq!(steps((4000, 1), (1, 1)), Some(4000));
        assert_eq!(steps((5, 1), (1, 0)), None);
        assert_eq!(format_steps(32000, (1, 2), ','), "320,00");
        assert_eq!(format_steps(1, (1, 1), '.'), "0.1");
        assert_eq!(format_steps(-5, (1, 2), '.'), "-0.05");
    }
}
