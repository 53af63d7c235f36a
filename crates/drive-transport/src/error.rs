//! The error type of every fallible operation in this crate.

use std::io;

/// Why opening or configuring a transport failed.
///
/// Every variant that concerns a device names its path, and where the user can do something
/// about it, a `hint` says what to try. Messages are lowercase and carry no full stop so that
/// they compose with context added by callers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    /// The device path does not exist.
    #[error(
        "serial port {path} not found (check the device name, e.g. /dev/ttyUSB0, and that the adapter is plugged in)"
    )]
    NotFound {
        /// The path that was tried.
        path: String,
    },

    /// The process may not open the device.
    #[error("permission denied opening {path}: {hint}")]
    PermissionDenied {
        /// The path that was tried.
        path: String,
        /// What to do about it.
        hint: String,
    },

    /// The device is already opened exclusively by another program.
    #[error("{path} is busy: {hint}")]
    Busy {
        /// The path that was tried.
        path: String,
        /// What to do about it.
        hint: String,
    },

    /// The device refused a setting, or accepted it but did not apply it.
    #[error("{path} does not support {setting}: {hint}")]
    Unsupported {
        /// The refused setting, e.g. `"parity even"`, `"baud 250000"`, `"RS-485 mode"`.
        setting: String,
        /// The device path.
        path: String,
        /// What to try instead.
        hint: String,
    },

    /// The path names a device that is no serial port a drive can be on (the pseudo-terminal
    /// multiplexer `/dev/ptmx`, which opens a new pty nobody listens to).
    #[error("{path} is not a serial port: {hint}")]
    NotAPort {
        /// The path that was given.
        path: String,
        /// What to give instead.
        hint: String,
    },

    /// A configuration value is out of range before any device was touched.
    #[error("invalid {setting}: {reason}")]
    InvalidConfig {
        /// The setting, e.g. `"data bits"`.
        setting: String,
        /// Why the value is invalid and which values are allowed.
        reason: String,
    },

    /// Applying a setting failed for a reason other than the device refusing it.
    #[error("failed to apply {setting} on {path}: {source}")]
    Setting {
        /// The setting being applied.
        setting: String,
        /// The device path.
        path: String,
        /// The underlying operating-system error.
        #[source]
        source: io::Error,
    },

    /// Opening the device failed for a reason not covered by a more specific variant.
    #[error("cannot open {path}: {source}")]
    Open {
        /// The device path.
        path: String,
        /// The underlying error.
        #[source]
        source: io::Error,
    },

    /// Creating or configuring a pseudo-terminal failed.
    #[error("pseudo-terminal: {operation} failed: {source}")]
    Pty {
        /// The operation that failed, e.g. `"posix_openpt"`.
        operation: &'static str,
        /// The underlying operating-system error.
        #[source]
        source: io::Error,
    },

    /// A SocketCAN interface of that name does not exist.
    #[error("CAN interface {name} not found: {hint}")]
    CanInterfaceNotFound {
        /// The interface name.
        name: String,
        /// How to create or bring up the interface.
        hint: String,
    },

    /// An slcan adapter has no `S` code for this bit rate.
    #[error(
        "slcan adapters cannot run at {bitrate} bit/s; the bit rates with an S code are 10, 20, 50, 100, 125, 250, 500, 800 and 1000 kbit/s"
    )]
    SlcanBitrate {
        /// The bit rate asked for, in bit/s.
        bitrate: u32,
    },

    /// An slcan adapter answered a set-up command with BEL (error).
    #[error(
        "the slcan adapter on {path} refused the command {command} (answered BEL); check that no other program uses it and that it speaks slcan"
    )]
    SlcanRefused {
        /// The port.
        path: String,
        /// The command, e.g. `"S6 (500 kbit/s)"`.
        command: String,
    },

    /// An slcan adapter did not answer a set-up command.
    #[error(
        "no answer from an slcan adapter on {path} to the command {command}; check that this is an slcan (Lawicel) adapter and its firmware"
    )]
    SlcanNoAnswer {
        /// The port.
        path: String,
        /// The command without its `\r`.
        command: String,
    },

    /// An I/O error that fits no other variant.
    #[error("i/o error: {0}")]
    Io(#[from] io::Error),
}

/// A line setting a device refused ([`TransportError::refused_setting`]), so that a front end
/// can name its own option for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum LineOption {
    /// The baud rate.
    Baud,
    /// The number of data bits.
    DataBits,
    /// Parity.
    Parity,
    /// The number of stop bits.
    StopBits,
    /// Kernel RS-485 mode.
    Rs485,
}

impl TransportError {
    /// Whether the path the user gave cannot be a port at all (a front end's usage error).
    pub fn not_a_port(&self) -> bool {
        matches!(self, TransportError::NotAPort { .. })
    }

    /// The line setting the device refused, if that is what this error is (its message names
    /// the setting and what to try; a front end adds its own option's name).
    pub fn refused_setting(&self) -> Option<LineOption> {
        let TransportError::Unsupported { setting, .. } = self else {
            return None;
        };
        // The settings are named by this crate's `serial` module: "baud 250000",
        // "7 data bits", "parity even", "2 stop bits", "RS-485 mode".
        if setting.starts_with("baud ") {
            Some(LineOption::Baud)
        } else if setting.ends_with(" data bits") {
            Some(LineOption::DataBits)
        } else if setting.starts_with("parity ") {
            Some(LineOption::Parity)
        } else if setting.ends_with(" stop bits") {
            Some(LineOption::StopBits)
        } else if setting == "RS-485 mode" {
            Some(LineOption::Rs485)
        } else {
            None
        }
    }

    /// The [`io::ErrorKind`] that best describes this error, for callers that must return
    /// `std::io::Error`.
    pub fn io_kind(&self) -> io::ErrorKind {
        match self {
            TransportError::NotFound { .. } => io::ErrorKind::NotFound,
            TransportError::PermissionDenied { .. } => io::ErrorKind::PermissionDenied,
            TransportError::Busy { .. } => io::ErrorKind::ResourceBusy,
            TransportError::Unsupported { .. } => io::ErrorKind::Unsupported,
            TransportError::InvalidConfig { .. }
            | TransportError::SlcanBitrate { .. }
            | TransportError::NotAPort { .. } => io::ErrorKind::InvalidInput,
            TransportError::CanInterfaceNotFound { .. } => io::ErrorKind::NotFound,
            TransportError::SlcanRefused { .. } => io::ErrorKind::Other,
            TransportError::SlcanNoAnswer { .. } => io::ErrorKind::TimedOut,
            TransportError::Setting { source, .. }
            | TransportError::Open { source, .. }
            | TransportError::Pty { source, .. }
            | TransportError::Io(source) => source.kind(),
        }
    }
}

impl From<TransportError> for io::Error {
    fn from(err: TransportError) -> io::Error {
        match err {
            TransportError::Io(inner) => inner,
            other => io::Error::new(other.io_kind(), other),
        }
    }
}
