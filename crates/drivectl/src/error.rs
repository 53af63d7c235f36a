//! The command-line error: one line for the user, and an exit code.

use std::fmt;

/// What went wrong, phrased for the user: what failed and what to try.
#[derive(Debug)]
pub struct CliError {
    message: String,
    code: u8,
}

impl CliError {
    /// A usage error (bad argument, unknown family or parameter): exit code 2.
    pub fn usage(message: impl Into<String>) -> Self {
        CliError {
            message: message.into(),
            code: 2,
        }
    }

    /// A failure while doing the work (I/O, device, timeout): exit code 1.
    pub fn failed(message: impl Into<String>) -> Self {
        CliError {
            message: message.into(),
            code: 1,
        }
    }

    /// A failure with its own exit code (a command ended by a signal: 128 + its number).
    pub fn with_code(message: impl Into<String>, code: u8) -> Self {
        CliError {
            message: message.into(),
            code,
        }
    }

    /// Standard output was closed by its reader (`drivectl … | head`): the command ends
    /// quietly, with the exit code a shell reports for a process ended by SIGPIPE (141), so a
    /// `pipefail` script sees what it sees for any other Unix tool.
    pub fn closed_pipe() -> Self {
        CliError {
            message: String::new(),
            code: 141,
        }
    }

    /// True for [`CliError::closed_pipe`]: nothing is printed.
    pub fn is_closed_pipe(&self) -> bool {
        self.code == 141 && self.message.is_empty()
    }

    /// The process exit code.
    pub fn exit_code(&self) -> u8 {
        self.code
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Keep it to one line whatever the source said.
        f.write_str(&self.message.replace('\n', " "))
    }
}

impl From<std::io::Error> for CliError {
    fn from(e: std::io::Error) -> Self {
        CliError::failed(format!("i/o error: {e}"))
    }
}

/// Result alias of the command-line tool.
pub type Result<T> = std::result::Result<T, CliError>;
