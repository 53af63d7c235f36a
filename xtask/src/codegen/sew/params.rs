//! The parameter list (manual ch. 7.2): `movidrive_parameters.csv`, rendered into
//! `sew_parameters.rs`.

use super::check_errata;
use super::groups::{self, Group};
use super::pno::{Conversions, Unit};
use crate::Result;
use crate::render::{header, lit, opt_display, value_name};
use crate::table::{Row, Table, parse_int};
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
/// MOVILINK parameter indices lie in 2000h…5FFFh (manual ch. 7.2, "MOVILINK-Parameter").
const INDEX_MIN: i64 = 0x2000;
const INDEX_MAX: i64 = 0x5FFF;
/// Parameters are 32-bit values; signed or unsigned, a raw value lies in this span.
const RAW_MIN: i64 = i32::MIN as i64;
const RAW_MAX: i64 = u32::MAX as i64;

/// One `min..max/step` segment of a printed range.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    min: i64,
    max: i64,
    step: i64,
}

/// One validated row of the parameter list.
#[derive(Debug, Clone)]
pub(super) struct Param {
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

/// Column `col` as an optional three-digit menu number (`000`…`999`).
fn opt_menu(row: &Row, col: &str) -> Result<Option<i64>> {
    row.opt_with(col, |s| {
        s.parse::<i64>()
            .ok()
            .filter(|_| s.len() == 3 && s.bytes().all(|b| b.is_ascii_digit()))
            .ok_or_else(|| {
                row.err(format!(
                    "column `{col}`: `{s}` is not a three-digit menu number"
                ))
            })
    })
}

/// Read the parameter list and check every row against the units, conversions and groups.
pub(super) fn read_params(
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
        if let Some(m) = menu.or(parent)
            && !group.starts_with(&format!("{:02}", m / 10))
        {
            return Err(row.err(format!("menu {m:03} does not belong to group `{group}`")));
        }
        let index = row.int("index")?;
        if !(INDEX_MIN..=INDEX_MAX).contains(&index) {
            return Err(row.err(format!("index {index} is outside 8192…24575 (2000h…5FFFh)")));
        }
        let hex = row.hex("index_hex", 4)?;
        let index_hex = row.req("index_hex")?.to_owned();
        if hex != index {
            return Err(row.err(format!(
                "index {index} is {index:04X}h, but `index_hex` says {index_hex}h (= {hex})"
            )));
        }
        let index2 = row.opt_int("index2")?;
        if let Some(i2) = index2
            && (!(INDEX_MIN..=INDEX_MAX).contains(&i2) || i2 == index)
        {
            return Err(row.err(format!("index2 {i2} is not a second MOVILINK index")));
        }
        let size = row.int("size_index")?;
        let size_units: Vec<&Unit> = units.iter().filter(|u| u.size == size).collect();
        let Some(quantity) = size_units.first().map(|u| &u.quantity_en) else {
            return Err(row.err(format!("unknown size index {size}")));
        };
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
                        "display unit `{display_unit}` is not a unit of size index {size} ({quantity})"
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
            let (target, referenced) = out
                .iter()
                .enumerate()
                .find(|(_, p)| p.menu == Some(r))
                .ok_or_else(|| row.err(format!("values_ref {r:03} is not a menu row above")))?;
            let origin = referenced.values_from.unwrap_or(target);
            if out.get(origin).is_none_or(|p| p.values.is_empty()) {
                return Err(row.err(format!("values_ref {r:03} has no value list")));
            }
            values_from = Some(origin);
            // The printed reference names the referenced index too: it must match.
            let expect = format!("Nr {r:03} bzw. Index {}", referenced.index);
            let printed = row.str("range_de")?.replace("MenüNr", "Menü Nr");
            if !printed.contains(&expect) {
                return Err(row.err(format!("range_de must reference `{expect}`")));
            }
        }
        let (range_de, range_en) = row.text_pair("range_de", "range_en")?;
        if !ranges.is_empty() && !range_de.contains("...") {
            return Err(row.err("`ranges` given but `range_de` prints no range"));
        }
        // The default must lie within the range / value list unless the row says otherwise.
        let list: Vec<i64> = match values_from {
            Some(o) => out
                .get(o)
                .into_iter()
                .flat_map(|p| &p.values)
                .map(|v| v.0)
                .collect(),
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
            range_de: range_de.to_owned(),
            range_en: range_en.to_owned(),
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

/// Render `sew_parameters.rs`: value lists, section headings, parameters and lookup tables.
pub(super) fn render_params(params: &[Param], groups: &[Group]) -> String {
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
            let _ = writeln!(s, "    {},", value_name(*v, de, en));
        }
        s.push_str("];\n");
    }
    s.push('\n');
    // Section headings.
    groups::render(&mut s, groups);
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
        let _ = writeln!(s, "        menu: {},", opt_display(p.menu));
        let _ = writeln!(s, "        parent: {},", opt_display(p.parent));
        let _ = writeln!(s, "        sub: {},", p.sub);
        let _ = writeln!(s, "        group: {},", lit(&p.group));
        let _ = writeln!(s, "        md60a_only: {},", p.md60a_only);
        let _ = writeln!(s, "        name_de: {},", lit(&p.name_de));
        let _ = writeln!(s, "        name_en: {},", lit(&p.name_en));
        let _ = writeln!(s, "        index: {},", p.index);
        let _ = writeln!(s, "        index_hex: {},", lit(&p.index_hex));
        let _ = writeln!(s, "        index2: {},", opt_display(p.index2));
        let _ = writeln!(s, "        pno_unit: {},", lit(&p.unit));
        let _ = writeln!(s, "        display_unit: {},", lit(&p.display_unit));
        let _ = writeln!(s, "        size_index: {},", p.size);
        let _ = writeln!(s, "        conversion_index: {},", p.conversion);
        let _ = writeln!(
            s,
            "        display_conversion_index: {},",
            opt_display(p.display_conversion)
        );
        let _ = writeln!(s, "        access: {access},");
        let _ = writeln!(s, "        default: {},", opt_display(p.default));
        let _ = writeln!(s, "        default2: {},", opt_display(p.default2));
        let _ = writeln!(
            s,
            "        default_outside_range: {},",
            p.default_outside_range
        );
        let _ = writeln!(s, "        range_de: {},", lit(&p.range_de));
        let _ = writeln!(s, "        range_en: {},", lit(&p.range_en));
        let _ = writeln!(s, "        ranges: {ranges},");
        let _ = writeln!(s, "        values: {values},");
        let _ = writeln!(s, "        values_ref: {},", opt_display(p.values_ref));
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

#[cfg(test)]
mod tests {
    use super::super::tests::{data, err_of, with_edit};
    use super::*;

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
