//! A CSV table whose every error names `file:line`.
//!
//! Files are UTF-8, comma-separated, with a header row; fields containing commas or quotes are
//! quoted the usual CSV way. Lines starting with `#` are comments.

use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// A whole CSV file, validated against the expected header.
#[derive(Debug)]
pub struct Table {
    path: PathBuf,
    file: String,
    header: Vec<String>,
    rows: Vec<Row>,
}

/// One data row with its 1-based line number in the file.
#[derive(Debug, Clone)]
pub struct Row {
    file: String,
    line: u64,
    header: std::rc::Rc<Vec<String>>,
    fields: Vec<String>,
}

impl Table {
    /// Read `path`, requiring exactly the columns `expected` in this order.
    pub fn read(path: &Path, expected: &[&str]) -> Result<Table> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error(format!("{}: cannot read: {e}", path.display())))?;
        let file = display_path(path);
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .flexible(true)
            .from_reader(text.as_bytes());
        let header: Vec<String> = rdr
            .headers()
            .map_err(|e| Error(format!("{file}:1: bad header: {e}")))?
            .iter()
            .map(str::to_owned)
            .collect();
        if header != expected {
            return Err(Error(format!(
                "{file}:1: header must be `{}`, found `{}`",
                expected.join(","),
                header.join(",")
            )));
        }
        let shared = std::rc::Rc::new(header.clone());
        let mut rows = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line());
                Error(format!("{file}:{line}: {e}"))
            })?;
            let line = rec.position().map_or(0, |p| p.line());
            if rec.len() != header.len() {
                return Err(Error(format!(
                    "{file}:{line}: expected {} fields, found {}",
                    header.len(),
                    rec.len()
                )));
            }
            rows.push(Row {
                file: file.clone(),
                line,
                header: shared.clone(),
                fields: rec.iter().map(str::to_owned).collect(),
            });
        }
        if rows.is_empty() {
            return Err(Error(format!("{file}: no data rows")));
        }
        Ok(Table {
            path: path.to_path_buf(),
            file,
            header,
            rows,
        })
    }

    /// The data rows in file order.
    pub fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// The file this table came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The column names.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// An error about the file as a whole, not one row: `file: reason`.
    pub fn err(&self, reason: impl std::fmt::Display) -> Error {
        Error(format!("{}: {reason}", self.file))
    }
}

impl Row {
    /// An error located at this row.
    pub fn err(&self, reason: impl std::fmt::Display) -> Error {
        Error(format!("{}:{}: {reason}", self.file, self.line))
    }

    /// The line number of this row in its file.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The raw (trimmed) text of column `col`.
    pub fn str(&self, col: &str) -> Result<&str> {
        let i = self
            .header
            .iter()
            .position(|h| h == col)
            .ok_or_else(|| self.err(format!("no column `{col}` (generator bug)")))?;
        Ok(self.fields.get(i).map(|s| s.trim()).unwrap_or(""))
    }

    /// Column `col`, which must not be empty.
    pub fn req(&self, col: &str) -> Result<&str> {
        let s = self.str(col)?;
        if s.is_empty() {
            Err(self.err(format!("column `{col}` must not be empty")))
        } else {
            Ok(s)
        }
    }

    /// Column `col` turned into a value by `f`, or `None` when empty.
    pub fn opt_with<T>(&self, col: &str, f: impl FnOnce(&str) -> Result<T>) -> Result<Option<T>> {
        match self.str(col)? {
            "" => Ok(None),
            s => f(s).map(Some),
        }
    }

    /// Column `col` parsed as `T`; must not be empty.
    pub fn parse<T: FromStr>(&self, col: &str) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        self.parse_text(col, self.req(col)?)
    }

    /// Column `col` parsed as `T`, or `None` when empty.
    pub fn opt<T: FromStr>(&self, col: &str) -> Result<Option<T>>
    where
        T::Err: std::fmt::Display,
    {
        self.opt_with(col, |s| self.parse_text(col, s))
    }

    /// Column `col` as a `|`-separated list of `T` (items trimmed, empty items skipped).
    pub fn list<T: FromStr>(&self, col: &str) -> Result<Vec<T>>
    where
        T::Err: std::fmt::Display,
    {
        self.str(col)?
            .split('|')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| self.parse_text(col, s))
            .collect()
    }

    /// `s`, the text of column `col`, parsed as `T`.
    fn parse_text<T: FromStr>(&self, col: &str, s: &str) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        s.parse::<T>()
            .map_err(|e| self.err(format!("column `{col}`: `{s}`: {e}")))
    }

    /// Column `col` as a boolean flag written `0` or `1` (empty = 0).
    pub fn flag(&self, col: &str) -> Result<bool> {
        match self.str(col)? {
            "" | "0" => Ok(false),
            "1" => Ok(true),
            other => Err(self.err(format!("column `{col}`: `{other}` is not 0 or 1"))),
        }
    }

    /// Column `col` as an integer written decimal or `0x`-prefixed hexadecimal.
    pub fn int(&self, col: &str) -> Result<i64> {
        self.int_text(col, self.req(col)?)
    }

    /// Like [`Row::int`] but `None` when empty.
    pub fn opt_int(&self, col: &str) -> Result<Option<i64>> {
        self.opt_with(col, |s| self.int_text(col, s))
    }

    /// `s`, the text of column `col`, parsed with [`parse_int`].
    fn int_text(&self, col: &str, s: &str) -> Result<i64> {
        parse_int(s).ok_or_else(|| self.err(format!("column `{col}`: `{s}` is not an integer")))
    }

    /// Column `col` as an integer ([`Row::int`]) that fits a byte, 0..255.
    pub fn byte(&self, col: &str) -> Result<u8> {
        let v = self.int(col)?;
        u8::try_from(v).map_err(|_| self.err(format!("column `{col}`: {v} is not a byte (0..255)")))
    }

    /// Column `col` as exactly `digits` hexadecimal digits without prefix, e.g. `2199` or `0A`.
    pub fn hex(&self, col: &str, digits: usize) -> Result<i64> {
        let s = self.req(col)?;
        i64::from_str_radix(s, 16)
            .ok()
            .filter(|_| s.len() == digits && s.bytes().all(|b| b.is_ascii_hexdigit()))
            .ok_or_else(|| self.err(format!("column `{col}`: `{s}` is not {digits} hex digits")))
    }

    /// The German and English texts of columns `de_col` and `en_col`, which must both be given
    /// or both be empty: a German text needs its English translation and vice versa.
    pub fn text_pair(&self, de_col: &str, en_col: &str) -> Result<(&str, &str)> {
        let (de, en) = (self.str(de_col)?, self.str(en_col)?);
        if de.is_empty() != en.is_empty() {
            return Err(self.err(format!(
                "`{de_col}` and `{en_col}` must both be given or both be empty"
            )));
        }
        Ok((de, en))
    }
}

/// Parse a decimal (optionally signed) or `0x` hexadecimal integer.
pub fn parse_int(s: &str) -> Option<i64> {
    let (neg, body) = match s.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let v = if let Some(h) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        i64::from_str_radix(h, 16).ok()?
    } else {
        body.parse::<i64>().ok()?
    };
    Some(if neg { -v } else { v })
}

fn display_path(path: &Path) -> String {
    // Paths relative to the workspace root read best in error messages.
    let root = crate::workspace_root();
    path.strip_prefix(&root)
        .unwrap_or(path)
        .display()
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one data row of a CSV file with `header` and `row`, written to a scratch file.
    fn row(test: &str, header: &str, row: &str) -> Row {
        let dir = std::env::temp_dir().join(format!(
            "drivebus-xtask-table-{}-{test}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.csv");
        std::fs::write(&path, format!("{header}\n{row}\n")).unwrap();
        let cols: Vec<&str> = header.split(',').collect();
        let t = Table::read(&path, &cols).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        t.rows()[0].clone()
    }

    #[test]
    fn hex_needs_exactly_the_digits() {
        let r = row("hex", "a,b,c,d", "2199,0A,+F,20G7");
        assert_eq!(r.hex("a", 4).unwrap(), 0x2199);
        assert_eq!(r.hex("b", 2).unwrap(), 0x0A);
        assert!(
            r.hex("a", 2)
                .unwrap_err()
                .0
                .contains("`2199` is not 2 hex digits")
        );
        assert!(r.hex("c", 2).is_err(), "a sign is not a hex digit");
        assert!(r.hex("d", 4).unwrap_err().0.contains("t.csv:2: column `d`"));
    }

    #[test]
    fn byte_list_and_optional_columns() {
        let r = row("list", "a,b,c,d,e", "255,256,1| 2 ||3,,x|1");
        assert_eq!(r.byte("a").unwrap(), 255);
        assert!(r.byte("b").unwrap_err().0.contains("256 is not a byte"));
        assert_eq!(r.list::<u8>("c").unwrap(), vec![1, 2, 3]);
        assert!(r.list::<u8>("d").unwrap().is_empty());
        assert!(r.list::<u8>("e").unwrap_err().0.contains("column `e`: `x`"));
        assert_eq!(r.opt_int("d").unwrap(), None);
        assert_eq!(r.opt_int("a").unwrap(), Some(255));
        assert_eq!(r.opt::<u8>("a").unwrap(), Some(255));
        assert!(r.opt::<u8>("b").is_err());
        assert_eq!(r.opt_with("d", |_| Ok(1)).unwrap(), None);
        assert_eq!(r.opt_with("a", |s| Ok(s.len())).unwrap(), Some(3));
    }

    #[test]
    fn text_pair_needs_both_languages_or_neither() {
        let r = row("pair", "a_de,a_en,b_de,b_en", "Ja,yes,,no");
        assert_eq!(r.text_pair("a_de", "a_en").unwrap(), ("Ja", "yes"));
        let e = r.text_pair("b_de", "b_en").unwrap_err().0;
        assert!(
            e.contains("`b_de` and `b_en` must both be given or both be empty"),
            "{e}"
        );
    }
}
