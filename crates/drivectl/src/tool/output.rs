//! Values as text or JSON, the same for every family.

use std::fmt::Write as _;
use std::io::Write as _;

use drive_profile::ParamMeta;
use serde_json::json;

use super::client::Target;
use crate::error::{CliError, Result};

/// Write one piece of standard output. A reader that went away (`drivectl … | head`) is not an
/// error of the command: it becomes [`CliError::closed_pipe`], which ends the command through
/// its normal exit path (a `pd` session still stops the drive) and quietly.
pub fn emit(args: std::fmt::Arguments<'_>) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args).and_then(|()| out.flush()).map_err(|e| {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            CliError::closed_pipe()
        } else {
            CliError::failed(format!("cannot write to standard output: {e}"))
        }
    })
}

/// `println!` for command output: `outln!(…)?` returns the closed-pipe error instead of
/// panicking (see [`emit`]).
#[macro_export]
macro_rules! outln {
    () => { $crate::tool::output::emit(format_args!("\n")) };
    ($($t:tt)*) => { $crate::tool::output::emit(format_args!("{}\n", format_args!($($t)*))) };
}

/// `print!` for command output (see [`outln!`]).
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => { $crate::tool::output::emit(format_args!($($t)*)) };
}

/// `errln!` for messages: a standard error that cannot be written (closed, a full disk) is
/// not worth a panic, and the message has nowhere else to go.
#[macro_export]
macro_rules! errln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($t)*);
    }};
}

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
pub fn print_value(t: &Target, raw: i64, json: bool) -> Result<()> {
    match (t.param, json) {
        (Some(p), true) => outln!(
            "{}",
            json!({
                "index": t.index, "number": p.label().to_string(), "name_de": p.name_de(),
                "name_en": p.name_en(), "raw": raw, "value": p.to_physical(raw), "unit": p.unit(),
                "meaning": p.value_name(raw).map(|v| v.en),
            })
        ),
        (Some(p), false) => outln!(
            "{} {} (index {}): {} (raw {raw})",
            p.label(),
            p.name_en(),
            t.index,
            physical_text(p, raw)
        ),
        (None, true) => outln!(
            "{}",
            json!({"index": t.index, "raw": raw, "value": raw, "unit": ""})
        ),
        (None, false) => outln!("index {}: raw {raw} (0x{:08X})", t.index, raw as u32),
    }
}
