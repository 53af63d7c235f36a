//! Values as text, the same for every front end: a physical value with its unit and value name,
//! floats without trailing zeros, and the strict number parsing every command and file uses.

use std::fmt::Write as _;

use drive_profile::ParamMeta;

/// A physical value with the parameter's decimals, unit and value name, e.g. `1.50 s` or
/// `9 (control word 1)`.
pub fn physical_text(p: &dyn ParamMeta, raw: i64) -> String {
    let v = p.to_physical(raw);
    let d = usize::from(p.decimals());
    let mut s = format!("{v:.d$}");
    if !p.unit().is_empty() {
        s.push(' ');
        s.push_str(p.unit());
    }
    if let Some(name) = p.value_name(raw) {
        let _ = write!(s, " ({})", name.en);
    }
    s
}

/// A float with at most `decimals` places and no trailing zeros.
pub fn trim_float(v: f64, decimals: u8) -> String {
    let d = usize::from(decimals);
    let s = format!("{v:.d$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// The port path as the EEPROM-wear log keys it: symlinks, `.`/`..` and doubled slashes
/// resolved (`/dev//pts/0`, `/dev/serial/by-id/…` → `/dev/pts/0`, `/dev/ttyUSB0`); the path as
/// given when it cannot be resolved (it was opened, so that is rare).
pub fn canonical_port(path: &str) -> String {
    std::fs::canonicalize(path).map_or_else(|_| path.to_owned(), |p| p.display().to_string())
}

/// Parse an integer strictly: decimal digits or `0x` hex digits, with at most one leading `-`
/// (`--5`, `0x-5`, `+5`, `5 000` and `1e3` are not integers).
pub fn parse_int(s: &str) -> Option<i64> {
    let t = s.trim();
    let (neg, body) = t.strip_prefix('-').map_or((false, t), |b| (true, b));
    let (digits, radix) = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        Some(h) => (h, 16),
        None => (body, 10),
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    // The magnitude as u64, so that i64::MIN (whose magnitude is no i64) parses too.
    let m = u64::from_str_radix(digits, radix).ok()?;
    if neg {
        0i64.checked_sub_unsigned(m)
    } else {
        i64::try_from(m).ok()
    }
}

/// Parse a decimal number strictly: an optional `-`, digits, and an optional fraction after
/// `.` or `,` (a decimal comma, as German drive documentation writes it). No exponent, no
/// `inf`/`NaN`, no thousands separators.
pub fn parse_decimal(s: &str) -> Option<f64> {
    let t = s.trim();
    let body = t.strip_prefix('-').unwrap_or(t);
    let (int, frac) = match body.split_once(['.', ',']) {
        Some((i, f)) => (i, Some(f)),
        None => (body, None),
    };
    let digits = |d: &str| d.chars().all(|c| c.is_ascii_digit());
    let ok = digits(int)
        && frac.is_none_or(|f| digits(f) && !f.is_empty())
        && !(int.is_empty() && frac.is_none());
    if !ok {
        return None;
    }
    t.replace(',', ".").parse().ok()
}
