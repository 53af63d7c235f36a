//! Values as text or JSON, the same for every family.

use std::fmt::Write as _;

use drive_profile::ParamMeta;
use serde_json::json;

use super::client::Target;

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

/// Print one value read from a drive: a line of text, or one JSON object.
pub fn print_value(t: &Target, raw: i64, json: bool) {
    match (t.param, json) {
        (Some(p), true) => println!(
            "{}",
            json!({
                "index": t.index, "number": p.label().to_string(), "name_de": p.name_de(),
                "name_en": p.name_en(), "raw": raw, "value": p.to_physical(raw), "unit": p.unit(),
                "meaning": p.value_name(raw).map(|v| v.en),
            })
        ),
        (Some(p), false) => println!(
            "{} {} (index {}): {} (raw {raw})",
            p.label(),
            p.name_en(),
            t.index,
            physical_text(p, raw)
        ),
        (None, true) => println!(
            "{}",
            json!({"index": t.index, "raw": raw, "value": raw, "unit": ""})
        ),
        (None, false) => println!("index {}: raw {raw} (0x{:08X})", t.index, raw as u32),
    }
}
