//! The command line that reaches the same drive again, for the hints that say how to stop a
//! drive or read its state: a hint is a command that works when pasted, so it carries every
//! option that differs from its default (`--baud 1200 --parity none`) and quotes what a shell
//! would split.

use std::fmt::Display;

use super::line::{AdapterArgs, LineArgs, RtsLevel};

/// A `drivectl …` command line being put together.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Again(String);

/// `value` as one shell word: as it is when it holds only characters no shell treats
/// specially, else in single quotes (a quote inside as `'\''`).
pub fn shell_word(value: &str) -> String {
    let plain = !value.is_empty()
        && value
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./:@%+=,".contains(c));
    if plain {
        value.to_owned()
    } else {
        format!("'{}'", value.replace('\'', r"'\''"))
    }
}

impl Again {
    /// `drivectl <command>` (e.g. `uss`, `bonfiglioli`).
    pub fn new(command: &str) -> Self {
        Self(format!("drivectl {command}"))
    }

    /// Add `flag value`.
    pub fn arg(mut self, flag: &str, value: impl Display) -> Self {
        self.0.push(' ');
        self.0.push_str(flag);
        self.0.push(' ');
        self.0.push_str(&shell_word(&value.to_string()));
        self
    }

    /// Add `flag value` unless `value` is the option's default.
    pub fn arg_unless<T: Display + PartialEq>(self, flag: &str, value: T, default: T) -> Self {
        if value == default {
            self
        } else {
            self.arg(flag, value)
        }
    }

    /// Add the serial line options that differ from their defaults (9600 baud, even parity,
    /// one stop bit).
    pub fn line(self, line: &LineArgs) -> Self {
        self.arg_unless("--baud", line.baud, 9600)
            .arg_unless("--parity", line.parity, drive_core::Parity::Even)
            .arg_unless("--stop-bits", line.stop_bits.bits(), 1)
    }

    /// Add the adapter options given (`--echo`, `--rs485` and its settings that differ from
    /// their defaults).
    pub fn adapter(mut self, adapter: &AdapterArgs) -> Self {
        if adapter.echo {
            self.0.push_str(" --echo");
        }
        if adapter.rs485 {
            self.0.push_str(" --rs485");
            if adapter.rs485_rts == RtsLevel::Low {
                self.0.push_str(" --rs485-rts low");
            }
            self = self
                .arg_unless("--rs485-delay-before", adapter.rs485_delay_before, 0)
                .arg_unless("--rs485-delay-after", adapter.rs485_delay_after, 0);
        }
        self
    }

    /// The command line with `rest` (a subcommand and its arguments) at the end.
    pub fn then(&self, rest: &str) -> String {
        format!("{} {rest}", self.0)
    }
}

impl Display for Again {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_differs_and_quoted_where_a_shell_would_split() {
        let line = LineArgs {
            baud: 1200,
            parity: drive_core::Parity::None,
            stop_bits: drive_core::StopBits::One,
        };
        let a = Again::new("bonfiglioli")
            .arg("--port", "/dev/serial/by-id/usb-FTDI my adapter")
            .line(&line)
            .arg_unless("--mode", "rtu", "rtu")
            .arg("--addr", 3);
        assert_eq!(
            a.then("control stop"),
            "drivectl bonfiglioli --port '/dev/serial/by-id/usb-FTDI my adapter' --baud 1200 \
             --parity none --addr 3 control stop"
        );
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word("/dev/pts/3"), "/dev/pts/3");
        assert_eq!(shell_word(""), "''");
    }

    #[test]
    fn the_adapter_options_given_are_carried() {
        let plain = Again::new("uss").adapter(&AdapterArgs::default());
        assert_eq!(plain.to_string(), "drivectl uss");
        let a = Again::new("uss").adapter(&AdapterArgs {
            echo: true,
            rs485: true,
            rs485_rts: RtsLevel::Low,
            rs485_delay_before: 2,
            rs485_delay_after: 0,
        });
        assert_eq!(
            a.to_string(),
            "drivectl uss --echo --rs485 --rs485-rts low --rs485-delay-before 2"
        );
    }
}
