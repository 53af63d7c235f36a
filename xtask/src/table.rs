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

    /// Column `col` parsed as `T`; must not be empty.
    pub fn parse<T: FromStr>(&self, col: &str) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        let s = self.req(col)?;
        s.parse::<T>()
            .map_err(|e| self.err(format!("column `{col}`: `{s}`: {e}")))
    }

    /// Column `col` parsed as `T`, or `None` when empty.
    pub fn opt<T: FromStr>(&self, col: &str) -> Result<Option<T>>
    where
        T::Err: std::fmt::Display,
    {
        let s = self.str(col)?;
        if s.is_empty() {
            return Ok(None);
        }
        s.parse::<T>()
            .map(Some)
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
        let s = self.req(col)?;
        parse_int(s).ok_or_else(|| self.err(format!("column `{col}`: `{s}` is not an integer")))
    }

    /// Like [`Row::int`] but `None` when empty.
    pub fn opt_int(&self, col: &str) -> Result<Option<i64>> {
        let s = self.str(col)?;
        if s.is_empty() {
            return Ok(None);
        }
        parse_int(s)
            .map(Some)
            .ok_or_else(|| self.err(format!("column `{col}`: `{s}` is not an integer")))
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
