//! `drivectl decode sbus`: one frame (`--id ID HEX…`) or a candump log (`--log FILE`)
//! explained by `drive_decode::sbus`, printed.

use drive_decode::sbus::{self, FrameError, LogDecoder};

use crate::decode::{print_entry, read_input};
use crate::error::{CliError, Result};

/// The most a log file may have (a day of a busy 1 Mbit/s bus is far more; split it).
const LOG_LIMIT: u64 = 256 << 20;

impl From<FrameError> for CliError {
    fn from(e: FrameError) -> Self {
        CliError::usage(match e {
            FrameError::TooLarge { text } => format!(
                "--id {text}: too large; a standard identifier is 0…2047 (11 bits), an extended \
                 one (--extended) 0…1FFFFFFFh (29 bits)"
            ),
            FrameError::NotStandard { text } => format!(
                "--id {text}: a standard identifier is 0…2047 (11 bits; SBus uses only these); \
                 --extended for a 29-bit one"
            ),
            e @ (FrameError::NotANumber { .. } | FrameError::NotExtended { .. }) => {
                format!("--id {e}")
            }
            e => e.to_string(),
        })
    }
}

/// Run `drivectl decode sbus --id ID HEX…`.
pub fn run_frame(
    id: Option<&str>,
    extended: bool,
    hex_args: &[String],
    sync_id: u16,
    json: bool,
) -> Result<()> {
    let id = sbus::parse_id(
        id.ok_or_else(|| {
            CliError::usage(
                "give the frame's identifier (--id ID HEX…) or a candump log (--log FILE)",
            )
        })?,
        extended,
    )?;
    let bytes = drive_decode::input::parse_hex(hex_args)?;
    let entry = sbus::decode_frame(&sbus::data_frame(id, &bytes)?, sync_id);
    print_entry(&entry, json)?;
    match &entry.telegram.error {
        Some(er) => Err(CliError::failed(format!(
            "the frame is no valid SBus telegram: {er}"
        ))),
        None => Ok(()),
    }
}

/// Run `drivectl decode sbus --log FILE`: every record of a candump log (`-`: standard input)
/// explained; a line that is no record is reported with its number and the rest is read on.
pub fn run_log(path: &str, sync_id: u16, json: bool) -> Result<()> {
    let bytes = read_input(path, LOG_LIMIT)?;
    let mut log = LogDecoder::new(&bytes, path, sync_id);
    for entry in log.by_ref() {
        print_entry(&entry, json)?;
    }
    if !json {
        outln!("{}", log.tally())?;
    }
    if log.frames() == 0 && log.unreadable() == 0 {
        return Err(CliError::usage(format!(
            "{path}: no candump records (lines like `(1735270496.916858) can0 20B#3100207E00000000`)"
        )));
    }
    if log.unreadable() > 0 {
        return Err(CliError::failed(format!(
            "{} line(s) of {path} are no candump records (see above)",
            log.unreadable()
        )));
    }
    Ok(())
}
