//! Values as text or JSON, the same for every family.

use std::io::Write as _;
use std::sync::atomic::{AtomicBool, Ordering};

use serde_json::json;

use super::client::Target;
use super::meaning::{Device, Meaning, meaning_in};
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

/// `errln!` for messages on standard error (see [`message`]).
#[macro_export]
macro_rules! errln {
    ($($t:tt)*) => {
        $crate::tool::output::message(format_args!($($t)*))
    };
}

/// Whether messages on standard error are JSON objects (`--json` was given).
static JSON_MESSAGES: AtomicBool = AtomicBool::new(false);

/// Make every message on standard error a JSON object (with `--json`): a script reads both
/// streams the same way.
pub fn json_messages(on: bool) {
    JSON_MESSAGES.store(on, Ordering::Relaxed);
}

/// One message on standard error: `drivectl: warning: …`, `drivectl: note: …` or an error
/// `drivectl: …` as text, or with `--json` as `{"type": "warning"|"note"|"error", "message":
/// …}` (lines without the `drivectl:` prefix, such as the simulator's, are notes). A standard
/// error that cannot be written (closed, a full disk) is not worth a panic, and the message
/// has nowhere else to go.
pub fn message(args: std::fmt::Arguments<'_>) {
    let text = args.to_string();
    let mut err = std::io::stderr().lock();
    if !JSON_MESSAGES.load(Ordering::Relaxed) {
        let _ = writeln!(err, "{text}");
        return;
    }
    let (kind, body) = match text.strip_prefix("drivectl: ") {
        Some(rest) => rest
            .strip_prefix("warning: ")
            .map(|m| ("warning", m))
            .or_else(|| rest.strip_prefix("note: ").map(|m| ("note", m)))
            .unwrap_or(("error", rest)),
        None => ("note", text.as_str()),
    };
    let _ = writeln!(err, "{}", json!({"type": kind, "message": body}));
}

/// The command's final error on standard error: a line of text, or with `--json` a JSON object
/// with the exit code.
pub fn final_error(e: &CliError) {
    if JSON_MESSAGES.load(Ordering::Relaxed) {
        let mut err = std::io::stderr().lock();
        let _ = writeln!(
            err,
            "{}",
            json!({"type": "error", "message": e.to_string(), "exit_code": e.exit_code()})
        );
    } else {
        errln!("drivectl: {e}");
    }
}

pub use drive_client::text::{physical_text, trim_float};

// The keys that name a target and its value, the same in `read --json` and `decode --json`.
#[cfg(test)]
pub use drive_client::meaning::value_json;
pub use drive_client::meaning::value_json_in;

/// One value as text without the parameter's name: the physical value with its unit and value
/// name (`1.50 s`, `9 (control word 1)`) or its meaning (`0 (no fault)`), a decoded word in hex
/// with its meaning (`0x0206: ready, PO data enabled, unit status 2 = no enable`), raw outside
/// the table; the meaning takes what is known of the drive, `device` ([`meaning_in`]).
pub fn value_text_in(t: &Target, raw: i64, device: &Device) -> String {
    match t.param {
        Some(p) => match meaning_in(t, raw, device) {
            Some(Meaning {
                text,
                decoded: Some(_),
            }) => format!("0x{:04X}: {text}", raw as u32),
            Some(Meaning {
                text,
                decoded: None,
            }) if p.value_name(raw).is_none() => {
                format!("{} ({text})", physical_text(p, raw))
            }
            _ => physical_text(p, raw),
        },
        None => format!("raw {raw} (0x{:08X})", raw as u32),
    }
}

/// [`value_text_in`] of a drive nothing is known of.
pub fn value_text(t: &Target, raw: i64) -> String {
    value_text_in(t, raw, &Device::default())
}

/// Print one value read from a drive: a line of text (`P102 set 3 acceleration time (PNU
/// 102): 10.00 s (raw 1000)`), or one JSON object ([`value_json_in`]).
pub fn print_value(t: &Target, raw: i64, json: bool) -> Result<()> {
    print_value_in(t, raw, json, &Device::default())
}

/// [`print_value`] with what is known of the drive (its meanings, [`meaning_in`]).
pub fn print_value_in(t: &Target, raw: i64, json: bool, device: &Device) -> Result<()> {
    match (t.names(), json) {
        (_, true) => outln!("{}", value_json_in(t, raw, device)),
        (Some((_, en)), false) => outln!(
            "{} {en} ({} {}): {} (raw {raw})",
            t.label(),
            t.index_word(),
            t.index,
            value_text_in(t, raw, device)
        ),
        (None, false) => outln!("{}: {}", t.label(), value_text_in(t, raw, device)),
    }
}

#[cfg(test)]
mod json_tests {
    use super::*;
    use drive_profile::Family;

    #[test]
    fn issue7_a_value_outside_the_table_has_the_keys_of_one_inside_it() {
        let keys = |v: &serde_json::Value| {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        let inside = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        let outside = Target::resolve(Family::Movidrive, "9999", 1000..=0xFFFF).unwrap();
        let (a, b) = (value_json(&inside, 1500), value_json(&outside, 5));
        assert_eq!(keys(&a), keys(&b));
        assert!(b["unit"].is_null() && b["number"].is_null() && b["name_en"].is_null());
        assert_eq!(b["value"], 5);
    }
}
