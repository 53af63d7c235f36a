use super::*;
use crate::family;
use crate::param::Family;
use std::collections::{BTreeMap, BTreeSet};
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

/// An owned copy of a [`Column`], to compare in tests.
#[derive(Debug, Clone, PartialEq)]
enum Owned {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Text(String),
    List(Vec<Owned>),
    Record(Vec<(&'static str, Owned)>),
}

fn own(c: Column<'_>) -> Owned {
    match c {
        Column::Null => Owned::Null,
        Column::Bool(b) => Owned::Bool(b),
        Column::Int(n) => Owned::Int(n),
        Column::Float(x) => Owned::Float(x),
        Column::Text(s) => Owned::Text(s.to_string()),
        Column::Formatted(d) => Owned::Text(d.to_string()),
        Column::List(items) => {
            let mut v = Vec::new();
            items(&mut |c| v.push(own(c)));
            Owned::List(v)
        }
        Column::Record(fields) => {
            let mut v = Vec::new();
            fields(&mut |k, c| v.push((k, own(c))));
            Owned::Record(v)
        }
    }
}

impl Owned {
    fn kind(&self) -> &'static str {
        match self {
            Owned::Null => "null",
            Owned::Bool(_) => "bool",
            Owned::Int(_) => "int",
            Owned::Float(_) => "float",
            Owned::Text(_) => "text",
            Owned::List(_) => "list",
            Owned::Record(_) => "record",
        }
    }

    fn field(&self, key: &str) -> &Owned {
        match self {
            Owned::Record(fields) => get(fields, key),
            other => panic!("{other:?} is no record"),
        }
    }
}

type Row = Vec<(&'static str, Owned)>;

fn row<P: ParamMeta + ?Sized>(p: &P) -> Row {
    let mut v = Vec::new();
    p.columns(&mut |k, c| v.push((k, own(c))));
    v
}

fn get<'r>(row: &'r [(&'static str, Owned)], key: &str) -> &'r Owned {
    row.iter()
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v)
        .unwrap_or_else(|| panic!("no column {key}"))
}

/// Every row of every family, NORD array elements included, with its label.
fn every_row() -> Vec<(Family, String, Row)> {
    let mut rows = Vec::new();
    for fam in Family::ALL {
        for p in family::params(fam) {
            rows.push((fam, p.label().to_string(), row(p)));
        }
    }
    for p in crate::nord::params() {
        for e in 1..=p.array_len.unwrap_or(0) {
            let el = p.element(e).unwrap();
            rows.push((Family::Nord, ParamMeta::label(&el).to_string(), row(&el)));
        }
    }
    rows
}

/// Record every `path → kind` below `value` (lists as `path[]`, record fields as `path.key`),
/// checking that no record repeats a field name.
fn walk(path: &str, value: &Owned, kinds: &mut BTreeMap<String, BTreeSet<&'static str>>) {
    kinds
        .entry(path.to_string())
        .or_default()
        .insert(value.kind());
    match value {
        Owned::List(items) => {
            let p = format!("{path}[]");
            for item in items {
                walk(&p, item, kinds);
            }
        }
        Owned::Record(fields) => {
            let mut seen = BTreeSet::new();
            for (k, v) in fields {
                assert!(seen.insert(*k), "{path}: field {k} twice");
                walk(&format!("{path}.{k}"), v, kinds);
            }
        }
        _ => {}
    }
}

#[test]
fn column_keys_are_unique_snake_case_and_cover_the_common_keys() {
    let keys: BTreeSet<_> = COLUMN_KEYS.iter().collect();
    assert_eq!(keys.len(), COLUMN_KEYS.len(), "a key is listed twice");
    for k in COLUMN_KEYS {
        assert!(
            !k.is_empty()
                && k.bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_'),
            "{k} is not snake_case"
        );
    }
    for k in COMMON_KEYS {
        assert!(keys.contains(k), "common key {k} missing from COLUMN_KEYS");
    }
    // The common block ends at `values`; the groups are the first family-specific keys.
    assert_eq!(COMMON_KEYS.last(), Some(&"values"));
    assert_eq!(COLUMN_KEYS.get(COMMON_KEYS.len()), Some(&"group"));
}

#[test]
fn every_row_emits_known_keys_once_and_every_common_key() {
    let mut used = BTreeSet::new();
    let mut per_family: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (fam, label, row) in every_row() {
        let mut seen = BTreeSet::new();
        for (k, _) in &row {
            assert!(COLUMN_KEYS.contains(k), "{fam} {label}: unknown key {k}");
            assert!(seen.insert(*k), "{fam} {label}: key {k} twice");
        }
        for k in COMMON_KEYS {
            assert!(seen.contains(k), "{fam} {label}: common key {k} missing");
        }
        // Rows of one family all have the same columns.
        let keys = per_family.entry(fam.name()).or_insert_with(|| seen.clone());
        assert_eq!(
            *keys, seen,
            "{fam} {label}: other columns than the first row"
        );
        used.extend(seen);
    }
    let all: BTreeSet<&str> = COLUMN_KEYS.iter().copied().collect();
    assert_eq!(used, all, "every listed key is emitted by some family");
}

#[test]
fn every_key_has_one_type_in_every_family() {
    let mut kinds = BTreeMap::new();
    for (_, _, row) in every_row() {
        for (k, v) in &row {
            walk(k, v, &mut kinds);
        }
    }
    for (path, set) in &kinds {
        let typed: Vec<_> = set.iter().filter(|k| **k != "null").collect();
        assert!(typed.len() <= 1, "{path} has types {set:?}");
    }
    // Numbers stay numbers.
    assert!(kinds["size_index"].contains("int"));
    assert!(kinds["default_value"].contains("float"));
    assert!(kinds["resolution.step"].contains("float"));
    assert!(kinds["range_segments[].step"].contains("int"));
}

#[test]
fn sew_p000_carries_index_size_and_conversion_index_as_numbers() {
    let p = row(crate::sew::lookup("P000").unwrap());
    assert_eq!(get(&p, "family"), &Owned::Text("movidrive".into()));
    assert_eq!(get(&p, "number"), &Owned::Text("P000".into()));
    assert_eq!(get(&p, "param_number"), &Owned::Int(0));
    assert_eq!(get(&p, "index"), &Owned::Int(8318));
    assert_eq!(get(&p, "index_hex"), &Owned::Text("207E".into()));
    assert_eq!(get(&p, "size_index"), &Owned::Int(11));
    assert_eq!(get(&p, "conversion_index"), &Owned::Int(66));
    assert_eq!(get(&p, "display_conversion_index"), &Owned::Int(67));
    assert_eq!(get(&p, "group"), &Owned::Text("00.".into()));
    assert_eq!(get(&p, "access"), &Owned::Text("RO".into()));
    assert_eq!(
        get(&p, "access_flags").field("read_only"),
        &Owned::Bool(true)
    );
    assert_eq!(
        get(&p, "access_flags").field("read_write"),
        &Owned::Bool(false)
    );
    assert_eq!(get(&p, "sub_index"), &Owned::Null);
    let Owned::Text(scaling) = get(&p, "scaling") else {
        panic!("scaling is text")
    };
    assert!(scaling.contains("size index 11"), "{scaling}");

    // A row with range segments and errata.
    let p = row(crate::sew::lookup("P224").unwrap());
    let Owned::List(segs) = get(&p, "range_segments") else {
        panic!("segments are a list")
    };
    assert!(segs.len() >= 2, "P224 has a gap: {segs:?}");
    assert!(matches!(segs[0].field("step"), Owned::Int(s) if *s > 0));
    assert_eq!(get(&p, "table_min"), segs[0].field("min"));
    let errata = crate::sew::params()
        .iter()
        .find(|p| p.errata.contains(' '))
        .unwrap();
    let Owned::List(ids) = get(&row(errata), "errata").clone() else {
        panic!("errata are a list")
    };
    assert!(
        ids.len() >= 2
            && ids
                .iter()
                .all(|i| matches!(i, Owned::Text(t) if t.starts_with("SEW-E")))
    );
}

#[test]
fn nord_p102_resolution_is_a_typed_record() {
    let p = row(crate::nord::lookup("P102").unwrap());
    let res = get(&p, "resolution");
    assert_eq!(res.field("step"), &Owned::Float(0.01));
    assert_eq!(res.field("decimals"), &Owned::Int(2));
    assert_eq!(res.field("text"), &Owned::Text("0.01".into()));
    assert_eq!(get(&p, "pnu"), &Owned::Int(0x66));
    assert_eq!(get(&p, "parameter_set"), &Owned::Bool(true));
    assert_eq!(get(&p, "array_len"), &Owned::Null);
    assert_eq!(get(&p, "range").field("max_value"), &Owned::Float(320.0));
    assert_eq!(get(&p, "table_max"), &Owned::Int(32000));

    // An array element: its own name and sub-index, the parameter's columns.
    let p700 = crate::nord::by_number(700).unwrap();
    let el = row(&p700.element(2).unwrap());
    assert_eq!(get(&el, "sub_index"), &Owned::Int(1));
    assert_eq!(get(&el, "number"), &Owned::Text("P700[-02]".into()));
    let Owned::List(elements) = get(&el, "elements") else {
        panic!("elements are a list")
    };
    assert!(
        elements
            .iter()
            .any(|e| e.field("element") == &Owned::Int(2))
    );
}

#[test]
fn bonfiglioli_1376_range_and_data_type() {
    let p = row(crate::bonfiglioli::lookup("1376").unwrap());
    assert_eq!(get(&p, "range").field("min"), &Owned::Int(1));
    assert_eq!(get(&p, "range").field("max"), &Owned::Int(247));
    assert_eq!(get(&p, "table_min"), &Owned::Int(1));
    assert_eq!(get(&p, "table_max"), &Owned::Int(247));
    assert_eq!(get(&p, "default"), &Owned::Int(1));
    assert_eq!(get(&p, "data_type"), &Owned::Text("unknown".into()));
    assert_eq!(get(&p, "type_source"), &Owned::Text("unknown".into()));
    assert_eq!(get(&p, "menu"), &Owned::Text("PARA".into()));
    assert_eq!(get(&p, "data_set"), &Owned::Bool(false));
    assert_eq!(get(&p, "bus_access"), &Owned::Text("read_write".into()));
    assert_eq!(
        get(&p, "chapters"),
        &Owned::List(
            ["5", "5.2.2", "5.3.2"]
                .map(|c| Owned::Text(c.into()))
                .to_vec()
        )
    );
    assert_eq!(
        get(&p, "aliases_de"),
        &Owned::List(std::vec![Owned::Text("Modbus Knotenadresse".into())])
    );
    // A stated data type.
    let p210 = row(crate::bonfiglioli::lookup("210").unwrap());
    assert_eq!(get(&p210, "data_type"), &Owned::Text("Long".into()));
}

#[test]
fn debug_shows_nested_columns() {
    let c = Column::List(&|items| {
        items(Column::Int(1));
        items(Column::Record(&|f| f("a", Column::Text("x"))));
    });
    assert_eq!(format!("{c:?}"), r#"[Int(1), {"a": Text("x")}]"#);
    assert_eq!(c.kind(), "list");
}
