//! `drivectl decode movilink <HEX...>`: a MOVILINK capture explained by
//! `drive_decode::movilink`, printed.

use crate::decode::{capture, print};
use crate::error::{CliError, Result};

pub use drive_decode::movilink::pdu_name;

/// Run `drivectl decode movilink`: bytes from the arguments, or a capture from `file`
/// (`-` = standard input; a lone `-` argument means the same).
pub fn run(hex_args: &[String], file: Option<&str>, json: bool) -> Result<()> {
    let decoded = drive_decode::movilink::decode(&capture(hex_args, file)?);
    print(&decoded, json)?;
    let mut problems = Vec::new();
    if decoded.invalid() > 0 {
        problems.push(format!(
            "{} of {} telegram(s) are invalid",
            decoded.invalid(),
            decoded.telegrams()
        ));
    }
    if decoded.skipped_bytes() > 0 {
        problems.push(format!(
            "{} byte(s) start no telegram and were skipped",
            decoded.skipped_bytes()
        ));
    }
    if !problems.is_empty() {
        return Err(CliError::failed(format!(
            "{} (see above)",
            problems.join("; ")
        )));
    }
    Ok(())
}
