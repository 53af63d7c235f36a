//! `drivectl decode …`: the decoders are `drive_decode`'s; this module reads the input (hex
//! arguments, a file or standard input), prints what a decoder says, text or `--json` (one
//! object per entry, [`docs/decode-json.md`]), and says the library's errors in the command
//! line's words.
//!
//! [`docs/decode-json.md`]: ../../../docs/decode-json.md

use drive_decode::input::{self, Capture, InputError};
use drive_decode::{Decoded, Entry};

use crate::error::{CliError, Result};

pub use drive_decode::shape::escape;

/// Where a decode command's bytes come from: the arguments, a file, or standard input.
#[derive(Debug, clap::Args)]
pub struct CaptureArgs {
    /// The bytes; `-` reads a capture from standard input (as --file).
    #[arg(required_unless_present = "file", conflicts_with = "file", num_args = 1..)]
    pub hex: Vec<String>,
    /// Read the capture from a file: one telegram per line or a byte stream over several
    /// lines; blank lines, `#` comments, CR LF line ends and a UTF-8 BOM are allowed.
    #[arg(long, value_name = "PATH")]
    pub file: Option<String>,
}

/// The largest capture read (64 MiB of hex text: about 1.7 million telegrams).
pub const MAX_CAPTURE: u64 = 64 << 20;

/// The hint after an input error: what the input must look like.
fn hint(e: &InputError) -> &'static str {
    match e {
        InputError::NotHex { .. } => "; give bytes like `02 01 86`, `020186` or `0x02,0x01,0x86`",
        InputError::OddDigits { .. } => {
            "; a byte is two digits (`02`, not `2`), so a digit is missing or left over"
        }
        InputError::NoBytes => "; give a telegram like `02 01 86 …`",
        InputError::Empty { .. } | InputError::NotText { .. } => {
            "; give hex like `02 01 86 …`, one telegram per line"
        }
        _ => "",
    }
}

impl From<InputError> for CliError {
    fn from(e: InputError) -> Self {
        CliError::usage(format!("{e}{}", hint(&e)))
    }
}

/// Read the raw input from `path`, or from standard input for `-` (a device node, or more than
/// `limit`, is refused).
pub fn read_input(path: &str, limit: u64) -> Result<Vec<u8>> {
    crate::tool::infile::read_limited(std::path::Path::new(path), true, limit)
}

/// The name of `path` in messages: `standard input` for `-`.
fn input_name(path: &str) -> &str {
    if path == "-" { "standard input" } else { path }
}

/// A capture from `path` (`-`: standard input), at most [`MAX_CAPTURE`].
pub fn read_capture(path: &str) -> Result<Capture> {
    let raw = read_input(path, MAX_CAPTURE)?;
    Ok(input::parse_capture(raw, input_name(path))?)
}

/// The capture of a decode command: from `file`, from standard input for a lone `-`
/// argument, else the hex arguments.
pub fn capture(hex_args: &[String], file: Option<&str>) -> Result<Capture> {
    match (file, hex_args) {
        (Some(path), _) => read_capture(path),
        (None, [only]) if only == "-" => read_capture("-"),
        (None, args) => Ok(Capture::from_bytes(input::parse_hex(args)?)),
    }
}

/// Print one entry: its text, or its JSON object.
pub fn print_entry(entry: &Entry, json: bool) -> Result<()> {
    if json {
        outln!("{}", entry.telegram.to_json())
    } else {
        out!("{}", entry.text)
    }
}

/// Print every entry at once.
pub fn print(decoded: &Decoded, json: bool) -> Result<()> {
    let out = if json {
        decoded.json_lines()
    } else {
        decoded.text()
    };
    out!("{out}")
}

/// The error of a decoded capture with invalid `noun`s (`frame`, `message`), skipped runs
/// counted among them (`3 of 5 frame(s) are invalid (see above)`), or `Ok`.
pub fn check_all(decoded: &Decoded, noun: &str) -> Result<()> {
    let invalid = decoded.invalid() + decoded.skipped();
    if invalid > 0 {
        return Err(CliError::failed(format!(
            "{invalid} of {} {noun}(s) are invalid (see above)",
            decoded.entries.len()
        )));
    }
    Ok(())
}
