//! Parameters by their table entry, on the command line: the client layer is `drive_client`'s
//! ([`ParamClient`], [`Target`], the strict number parsing); this module says its errors in the
//! command line's words, with the options that are the way out (`--raw`, `--force`, `--round`).

#[cfg(test)]
pub use drive_client::client::DeviceErrorKind;
pub use drive_client::client::{ClientError, ParamClient};
pub use drive_client::target::{Target, TargetError, ValueError, ValueText};
pub use drive_client::text::{canonical_port, parse_int};

use crate::error::CliError;

/// The command line's way out of a line whose adapter echoes what it sends while `--echo` is
/// not given (`LinkFault::Echo`).
pub const ECHO_HINT: &str =
    "; give --echo for an adapter that echoes what it sends (a two-wire RS-485 converter)";

/// [`ECHO_HINT`] where `e` is a line that echoes.
pub fn echo_hint(e: &ClientError) -> &'static str {
    match e {
        ClientError::Link(l) if l.fault == drive_client::LinkFault::Echo => ECHO_HINT,
        _ => "",
    }
}

impl From<ClientError> for CliError {
    fn from(e: ClientError) -> Self {
        CliError::failed(format!("{e}{}", echo_hint(&e)))
    }
}

impl From<TargetError> for CliError {
    fn from(e: TargetError) -> Self {
        let hint = match &e {
            TargetError::Unknown { family, .. } => {
                format!("; `drivectl params {family} --search NAME` finds it")
            }
            _ => String::new(),
        };
        CliError::usage(format!("{e}{hint}"))
    }
}

impl From<ValueError> for CliError {
    fn from(e: ValueError) -> Self {
        let hint = match &e {
            ValueError::NotANumber { .. } => ", or --raw",
            ValueError::OutOfRange { .. } => "; --force sends a value outside the table's range",
            ValueError::PastWidth { .. } => "; not even --force sends a value that would be cut",
            ValueError::NotExact { .. } => "; write that, or add --round to have it rounded",
            ValueError::Width { error, .. } => {
                return CliError::usage(
                    e.to_string() + &super::write::hint_of(error).unwrap_or_default(),
                );
            }
            _ => "",
        };
        CliError::usage(format!("{e}{hint}"))
    }
}

/// A client error on a target as the command line says it: the target's label first (the
/// client's messages do not carry it), then the drive's or the line's words.
pub trait OnTarget {
    /// `e` on this target.
    fn error(&self, e: ClientError) -> CliError;
}

impl OnTarget for Target {
    fn error(&self, e: ClientError) -> CliError {
        CliError::failed(format!("{}: {e}{}", self.label(), echo_hint(&e)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_profile::Family;

    #[test]
    fn issue18_a_value_wider_than_the_parameter_never_suggests_force() {
        // Bonfiglioli 410 control word: a 16-bit word (0…65535).
        let p410 = Target::resolve(Family::Bonfiglioli, "410", 0..=1599).unwrap();
        for force in [false, true] {
            let how = ValueText {
                force,
                ..ValueText::default()
            };
            let e = CliError::from(p410.value_from_text("65536", &how).unwrap_err()).to_string();
            assert!(e.contains("not even --force"), "{e}");
            assert!(!e.contains("or --force") && !e.contains("  "), "{e}");
        }
        // In the width but outside the table's range: --force is the way out.
        let p130 = Target::resolve(Family::Movidrive, "P130", 1000..=0xFFFF).unwrap();
        let text = |t: &str| {
            CliError::from(p130.value_from_text(t, &ValueText::default()).unwrap_err()).to_string()
        };
        let e = text("3000");
        assert!(e.contains("--force sends a value outside"), "{e}");
        let e = text("5000000");
        assert!(e.contains("not even --force"), "{e}");
    }
}
