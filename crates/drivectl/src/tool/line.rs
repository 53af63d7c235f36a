//! Serial line and master options, shared by every protocol command and `drivectl sim`.

use clap::Args;
use drive_core::rt::echo::EchoCancel;
use drive_transport::serial::{self, LineSettings, Parity, SerialConfig, SerialPort, StopBits};
use drive_transport::{LineOption, TransportError};
use std::time::Duration;

use crate::error::{CliError, Result};

/// Serial line settings. Every option is accepted before or after the subcommand.
#[derive(Debug, Args, Clone)]
pub struct LineArgs {
    /// Baud rate in bit/s, 1–4000000 (the drive's rate); every pause and timeout follows it.
    #[arg(long, global = true, default_value_t = 9600, value_parser = clap::value_parser!(u32).range(1..=4_000_000))]
    pub baud: u32,
    /// Parity: even, odd or none, as the drive is set (pseudo-terminals only accept none).
    #[arg(long, global = true, default_value = "even")]
    pub parity: Parity,
    /// Stop bits: 1 or 2.
    #[arg(long, global = true, default_value = "1")]
    pub stop_bits: StopBits,
}

impl LineArgs {
    /// The line settings (8 data bits).
    pub fn line(&self) -> LineSettings {
        LineSettings::new(self.baud)
            .with_parity(self.parity)
            .with_stop_bits(self.stop_bits)
    }

    /// Open a master's port at `path` with these settings and `adapter`'s (every setting read
    /// back; a refused one is named, with the option that changes it).
    pub fn open(&self, path: &str, adapter: &AdapterArgs) -> Result<EchoPort> {
        adapter
            .open(path, self.line())
            .map_err(|e| open_cli_error(&e))
    }
}

/// Open `path` with `settings` (every setting read back): a setting the device refuses is the
/// user's to change (exit 2, naming the option, as `sim` refuses parity on a pty); a missing
/// or busy port is a failure (exit 1).
pub fn open_settings(path: &str, settings: LineSettings) -> Result<SerialPort> {
    serial::open(&SerialConfig::with_line(path, settings)).map_err(|e| open_cli_error(&e))
}

/// The RTS level in kernel RS-485 mode while a frame is sent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RtsLevel {
    /// RTS high while sending, low after (most transceivers).
    #[default]
    High,
    /// RTS low while sending, high after (inverted driver enable).
    Low,
}

/// The longest RTS delay in RS-485 mode, in milliseconds.
const MAX_RTS_DELAY_MS: u32 = serial::Rs485Config::MAX_DELAY_MS;

/// How the master's serial adapter drives an RS-485 line: the same options in every serial
/// family (MOVILINK, USS, Modbus RTU/ASCII). Every option is accepted before or after the
/// subcommand.
#[derive(Debug, Args, Clone, Default)]
pub struct AdapterArgs {
    /// The adapter echoes what it sends (two-wire RS-485 converters whose receiver stays on):
    /// each frame is read back, compared and discarded; an echo that differs is a bus
    /// collision and the frame is not taken. Without it, such an adapter's echo of a Modbus
    /// FC 5/6/8 request looks exactly like the drive's answer.
    #[arg(long, global = true)]
    pub echo: bool,
    /// Linux kernel RS-485 mode (TIOCSRS485): the UART switches the transceiver with RTS
    /// around each frame. For UARTs wired to a transceiver (boards, HATs); leave it out for
    /// USB adapters that switch direction themselves.
    #[arg(long, global = true)]
    pub rs485: bool,
    /// RS-485 mode: RTS level while sending, high or low.
    #[arg(long, global = true, default_value = "high", requires = "rs485")]
    pub rs485_rts: RtsLevel,
    /// RS-485 mode: milliseconds between RTS on and the first bit, 0–100.
    #[arg(long, global = true, default_value_t = 0, requires = "rs485", value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_RTS_DELAY_MS)))]
    pub rs485_delay_before: u32,
    /// RS-485 mode: milliseconds between the last bit and RTS off, 0–100.
    #[arg(long, global = true, default_value_t = 0, requires = "rs485", value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_RTS_DELAY_MS)))]
    pub rs485_delay_after: u32,
}

impl AdapterArgs {
    /// The kernel RS-485 setting asked for, if any.
    pub fn rs485(&self) -> Option<serial::Rs485Config> {
        self.rs485.then(|| {
            serial::Rs485Config::with_rts(
                self.rs485_rts == RtsLevel::High,
                self.rs485_delay_before,
                self.rs485_delay_after,
            )
        })
    }

    /// Open a master's port at `path` with `settings` and these adapter settings: the echo
    /// taken out when `--echo` is given.
    pub fn open(
        &self,
        path: &str,
        settings: LineSettings,
    ) -> std::result::Result<EchoPort, TransportError> {
        let mut config = SerialConfig::with_line(path, settings);
        config.rs485 = self.rs485();
        serial::open(&config).map(|port| EchoCancel::new(port, self.echo))
    }
}

/// A master's serial port, its adapter's echo taken out when asked for.
pub type EchoPort = EchoCancel<SerialPort>;

/// A port's refusal as the command line's error: a setting the device refuses or a path that
/// is no port at all (`/dev/ptmx`) is the user's to change (exit 2); a missing or busy port is a
/// failure (exit 1).
pub fn open_cli_error(e: &TransportError) -> CliError {
    if e.refused_setting().is_some() || e.not_a_port() {
        CliError::usage(open_error(e))
    } else {
        CliError::failed(open_error(e))
    }
}

/// A port's refusal with the drivectl option for the refused setting.
pub fn open_error(e: &TransportError) -> String {
    let option = match e.refused_setting() {
        Some(LineOption::Baud) => "--baud",
        Some(LineOption::Parity) => "--parity even|odd|none",
        Some(LineOption::StopBits) => "--stop-bits 1|2",
        Some(LineOption::DataBits) => "--data-bits 7|8",
        Some(LineOption::Rs485) => "--rs485",
        _ => return e.to_string(),
    };
    format!("{e} (option {option})")
}

/// The longest response timeout `--timeout` takes, in milliseconds (a minute: longer is a
/// hang to the user, and far beyond any drive's answer).
pub const MAX_TIMEOUT_MS: u64 = 60_000;
/// The widest `--char-gap`, in milliseconds.
pub const MAX_CHAR_GAP_MS: u64 = 10_000;

/// Options of a master on a serial line: how long to wait for an answer, how often to try.
/// Every option is accepted before or after the subcommand.
#[derive(Debug, Args, Clone)]
pub struct MasterArgs {
    /// Response timeout in milliseconds, 1–60000. Default 50: the longest response delay
    /// MOVILINK allows a drive. Less than the start pause a drive keeps before answering at the
    /// baud rate is refused.
    #[arg(long, global = true, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..=MAX_TIMEOUT_MS))]
    pub timeout: u64,
    /// Retries after a timeout or a corrupt answer, 0–255 (255: 256 attempts, then give up).
    #[arg(long, global = true, default_value_t = 2)]
    pub retries: u8,
    /// Longest gap in ms accepted between the characters of an answer, 0–10000. USB serial
    /// adapters hand characters over in bursts (FTDI: every 16 ms); 0 applies the protocol's
    /// own rule. Checksums, lengths and parity always apply.
    #[arg(long, global = true, default_value_t = 20, value_parser = clap::value_parser!(u64).range(0..=MAX_CHAR_GAP_MS))]
    pub char_gap: u64,
}

impl MasterArgs {
    /// The response timeout.
    pub fn response_timeout(&self) -> Duration {
        Duration::from_millis(self.timeout)
    }

    /// The widened gap limit, if any.
    pub fn max_char_gap(&self) -> Option<Duration> {
        (self.char_gap > 0).then(|| Duration::from_millis(self.char_gap))
    }
}

/// A tokio runtime for one command.
pub fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failed(format!("cannot start the async runtime: {e}")))
}

/// Run `session` on a virtual clock (`drive_core::rt::time::VirtualClock`): a simulated
/// session's wire time counted, not waited, the same on every run.
pub fn run_virtual<F: std::future::Future>(session: F) -> Result<F::Output> {
    drive_core::rt::time::VirtualClock::with_phase(drive_core::rt::time::PAUSE_PHASE)
        .run(session)
        .map_err(|e| CliError::failed(format!("cannot start the async runtime: {e}")))
}

/// The one check of every family that a port was given (`--port`, empty by default so that
/// `--help` and the offline commands work without one).
pub fn require_port(port: &str) -> Result<()> {
    if port.is_empty() {
        return Err(CliError::usage(
            "no serial port given; add --port PATH (e.g. /dev/ttyUSB0; `drivectl ports` lists them)",
        ));
    }
    Ok(())
}

/// The one check of every family that `--timeout` can be met: a response timeout shorter than
/// `least` (what an answer needs on this line at the least, `needs` saying what that is, with
/// its figure) is refused naming the least `--timeout` in whole milliseconds that works.
pub fn check_timeout(timeout: Duration, least: Duration, needs: &str) -> Result<()> {
    if timeout >= least {
        return Ok(());
    }
    Err(CliError::usage(format!(
        "a response timeout of {} ms is shorter than {needs}: no answer could arrive in time; \
         use --timeout {} or more",
        timeout.as_millis(),
        least.as_micros().div_ceil(1000)
    )))
}

#[cfg(test)]
mod checks {
    use super::*;

    #[test]
    fn a_timeout_below_the_least_is_refused_naming_the_whole_milliseconds_that_work() {
        let least = Duration::from_micros(3_440);
        assert!(check_timeout(least, least, "x").is_ok());
        let e = check_timeout(Duration::from_millis(3), least, "the start pause (3.44 ms)")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "a response timeout of 3 ms is shorter than the start pause (3.44 ms): no answer \
             could arrive in time; use --timeout 4 or more"
        );
        assert!(require_port("").is_err());
        assert!(require_port("/dev/ttyS0").is_ok());
    }
}
