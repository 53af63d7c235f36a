//! `drivectl decode modbus-rtu|modbus-ascii`: Bonfiglioli Modbus captures explained by
//! `drive_decode::bonfiglioli`, printed.

use drive_decode::bonfiglioli::{self, AsciiError};

use crate::decode::{MAX_CAPTURE, capture, check_all, print, read_input};
use crate::error::{CliError, Result};

/// The usage error for ASCII input without any `:`: a Modbus ASCII frame starts with one. For
/// arguments that look like frames without it (hex digits), the command with it.
fn missing_colon(args: &[String], from_args: bool) -> CliError {
    let looks_like_frames = from_args
        && !args.is_empty()
        && args.iter().all(|a| {
            let t = a.trim();
            !t.is_empty() && t.chars().all(|c| c.is_ascii_hexdigit() || c == ' ')
        });
    let hint = if looks_like_frames {
        let with: Vec<String> = args
            .iter()
            .map(|a| format!(":{}", a.trim().replace(' ', "")))
            .collect();
        format!(
            "; with it: `drivectl decode modbus-ascii {}`",
            with.join(" ")
        )
    } else {
        String::new()
    };
    CliError::usage(format!(
        "{} (`:01032174000166`), or give its characters as hex bytes with the `:` as 3A \
         (`3A 30 31 …`){hint}",
        AsciiError::NoColon
    ))
}

/// An ASCII input error in the command line's words.
fn ascii_error(e: AsciiError, args: &[String], from_args: bool) -> CliError {
    match e {
        AsciiError::Input(e) => e.into(),
        AsciiError::NotAscii { .. } => {
            CliError::usage(format!("{e}; give frames like `:010321740001 66`"))
        }
        AsciiError::NoFrames => {
            CliError::usage(format!("{e}; give ASCII frames like `:010321740001 66`"))
        }
        AsciiError::NoColon => missing_colon(args, from_args),
        e => CliError::usage(e.to_string()),
    }
}

/// Run `drivectl decode modbus-rtu` (`ascii` false) or `modbus-ascii`.
pub fn run(ascii_mode: bool, args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let decoded = if ascii_mode {
        let from_stdin = file.is_some() || matches!(args, [only] if only == "-");
        let text = if from_stdin {
            let raw = read_input(file.unwrap_or("-"), MAX_CAPTURE)?;
            String::from_utf8(raw).map_err(|e| {
                CliError::usage(format!(
                    "the capture is not text (byte {} is not UTF-8)",
                    e.utf8_error().valid_up_to()
                ))
            })?
        } else {
            args.join("\n")
        };
        let chars = bonfiglioli::ascii_input(&text, !from_stdin)
            .map_err(|e| ascii_error(e, args, !from_stdin))?;
        bonfiglioli::decode_ascii(&chars)
    } else {
        bonfiglioli::decode_rtu(&capture(args, file)?)
    };
    print(&decoded, json)?;
    check_all(&decoded, "frame")
}
