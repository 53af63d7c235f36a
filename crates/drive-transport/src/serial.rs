//! Serial ports: configuration, opening with per-setting diagnostics, character timing.
//!
//! [`open`] opens the device at a neutral 9600 8N1 first and then applies baud rate, data bits,
//! parity and stop bits one at a time, reading each back. A setting the device refuses (an
//! error) or silently ignores (the read-back differs) becomes
//! [`TransportError::Unsupported`] naming exactly that setting, with a hint. Once the settings
//! are applied it discards what the port's input already holds (`tcflush(TCIFLUSH)`): bytes
//! an earlier program left there (an answer to a request of a master that was killed) are never
//! read as an answer; [`SerialPort::flushed_at_open`] says how many there were.
//!
//! A [`SerialPort`] is a [`CharIo`] itself: characters timed when read, and a frame that takes
//! its wire time to leave ([`WireTime::Real`]), except on a pseudo-terminal, which has no wire
//! time ([`WireTime::None`]).

use std::fmt;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::Duration;

use drive_core::rt::{CharIo, ReceivedChar, Stream, WireTime};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio_serial::SerialPort as _;

use crate::TransportError;

pub use drive_core::line::{
    LineSettings, Parity, ParseSettingError, StopBits, bits_per_char, char_time,
};

/// Linux kernel RS-485 mode (`TIOCSRS485`): the UART driver switches the transceiver's driver
/// enable through RTS around each transmission.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rs485Config {
    /// RTS level while sending (`SER_RS485_RTS_ON_SEND`); most transceivers need `true`.
    pub rts_on_send: bool,
    /// RTS level after sending (`SER_RS485_RTS_AFTER_SEND`); most transceivers need `false`.
    pub rts_after_send: bool,
    /// Delay between raising RTS and the first bit, in milliseconds.
    pub delay_rts_before_send_ms: u32,
    /// Delay between the last bit and dropping RTS, in milliseconds.
    pub delay_rts_after_send_ms: u32,
    /// Keep the receiver enabled while sending (`SER_RS485_RX_DURING_TX`): the port then reads
    /// back its own telegrams (an echo).
    pub rx_during_tx: bool,
}

impl Rs485Config {
    /// The longest RTS delay front ends accept, in milliseconds: the kernel takes more, but a
    /// delay this long already costs a whole telegram at 9600 baud.
    pub const MAX_DELAY_MS: u32 = 100;

    /// RTS `high` while sending (and the other level after), with the delays before the first
    /// bit and after the last one; the receiver off while sending.
    pub fn with_rts(high: bool, delay_before_ms: u32, delay_after_ms: u32) -> Self {
        Rs485Config {
            rts_on_send: high,
            rts_after_send: !high,
            delay_rts_before_send_ms: delay_before_ms,
            delay_rts_after_send_ms: delay_after_ms,
            rx_during_tx: false,
        }
    }
}

impl Default for Rs485Config {
    /// RTS high while sending, low afterwards, no delays, receiver off while sending.
    fn default() -> Self {
        Rs485Config {
            rts_on_send: true,
            rts_after_send: false,
            delay_rts_before_send_ms: 0,
            delay_rts_after_send_ms: 0,
            rx_during_tx: false,
        }
    }
}

/// Everything needed to open and configure a serial port.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct SerialConfig {
    /// Device path, e.g. `/dev/ttyUSB0` or a pty slave `/dev/pts/3`.
    pub path: String,
    /// Baud rate, data bits (5 to 8), parity and stop bits.
    pub line: LineSettings,
    /// Linux RS-485 mode, or `None` to leave the port's RS-485 setting untouched.
    pub rs485: Option<Rs485Config>,
}

impl SerialConfig {
    /// 8 data bits, even parity, 1 stop bit (8E1, the default of MOVILINK, Modbus RTU and
    /// USS) at `baud`, no RS-485 mode.
    pub fn new(path: impl Into<String>, baud: u32) -> Self {
        Self::with_line(path, LineSettings::new(baud))
    }

    /// The port at `path` with `line`, no RS-485 mode.
    pub fn with_line(path: impl Into<String>, line: LineSettings) -> Self {
        SerialConfig {
            path: path.into(),
            line,
            rs485: None,
        }
    }

    /// Bits per character on the wire: start + data + parity + stop.
    pub fn bits_per_char(&self) -> u32 {
        self.line.bits_per_char()
    }

    /// Time one character occupies the wire at this configuration.
    pub fn char_time(&self) -> Duration {
        self.line.char_time()
    }
}

impl fmt::Display for SerialConfig {
    /// `/dev/ttyUSB0 9600 8E1`, followed by ` rs485` when RS-485 mode is requested.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.path, self.line)?;
        if self.rs485.is_some() {
            f.write_str(" rs485")?;
        }
        Ok(())
    }
}

/// An open, configured serial port; implements tokio's [`AsyncRead`] and [`AsyncWrite`].
///
/// Dropping it closes the device.
#[derive(Debug)]
pub struct SerialPort {
    stream: tokio_serial::SerialStream,
    config: SerialConfig,
    /// Bytes the input held when the port was opened (discarded).
    flushed: u32,
    /// A pseudo-terminal: no wire time.
    pty: bool,
}

impl SerialPort {
    /// The configuration the port was opened with (all of it verified by read-back).
    pub fn config(&self) -> &SerialConfig {
        &self.config
    }

    /// Time one character occupies the wire.
    pub fn char_time(&self) -> Duration {
        self.config.char_time()
    }

    /// How many bytes the port's input held when it was opened, discarded by [`open`]: what an
    /// earlier program left there (e.g. an answer to the request of a master that was
    /// killed). Bytes still on their way then (a USB adapter's buffer) come later; a master
    /// on the runtime layer's port never takes them for an answer either.
    pub fn flushed_at_open(&self) -> u32 {
        self.flushed
    }

    /// Whether the device is a pseudo-terminal (no wire time: a frame written to it has left
    /// once the write returned).
    pub fn is_pty(&self) -> bool {
        self.pty
    }

    /// Discards bytes received but not yet read and bytes written but not yet sent
    /// (`tcflush(TCIOFLUSH)`), e.g. after a timeout before retrying.
    pub fn discard_buffers(&self) -> io::Result<()> {
        self.stream
            .clear(tokio_serial::ClearBuffer::All)
            .map_err(io::Error::from)
    }
}

impl AsyncRead for SerialPort {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for SerialPort {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
}

/// Characters timed when read (as [`Stream`]); frames take their wire time except on a
/// pseudo-terminal.
impl CharIo for SerialPort {
    fn poll_read_chars(
        &mut self,
        cx: &mut Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> Poll<io::Result<usize>> {
        Stream(&mut self.stream).poll_read_chars(cx, buf)
    }

    fn poll_write(&mut self, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }

    /// Waits for the transmitter (`tcdrain`): on a UART the frame has left when it returns.
    fn poll_flush(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn wire_time(&self) -> WireTime {
        if self.pty {
            WireTime::None
        } else {
            WireTime::Real
        }
    }
}

const DIALOUT_HINT: &str = "add your user to the dialout group (sudo usermod -aG dialout $USER, \
     then log in again) or check the device's permissions";
const BUSY_HINT: &str = "another program has the port open; close it (terminal programs, \
     ModemManager, another drivectl) and try again";

/// Opens and configures a serial port.
///
/// Must be called from within a tokio runtime with I/O enabled.
///
/// # Errors
///
/// - [`TransportError::InvalidConfig`] for data bits outside 5–8 or a zero baud rate;
/// - [`TransportError::NotFound`], [`TransportError::PermissionDenied`],
///   [`TransportError::Busy`] or [`TransportError::Open`] when the device cannot be opened;
/// - [`TransportError::Unsupported`] naming the setting (`"baud 250000"`, `"7 data bits"`,
///   `"parity even"`, `"2 stop bits"`, `"RS-485 mode"`) the device refuses or ignores —
///   pseudo-terminals, for example, refuse parity;
/// - [`TransportError::Setting`] when applying a setting fails for another reason.
pub fn open(config: &SerialConfig) -> Result<SerialPort, TransportError> {
    if !(5..=8).contains(&config.line.data_bits) {
        return Err(TransportError::InvalidConfig {
            setting: "data bits".into(),
            reason: format!("{} is not in 5..=8", config.line.data_bits),
        });
    }
    if config.line.baud == 0 {
        return Err(TransportError::InvalidConfig {
            setting: "baud".into(),
            reason: "the baud rate must be greater than zero".into(),
        });
    }
    if tokio::runtime::Handle::try_current().is_err() {
        return Err(TransportError::Io(io::Error::other(
            "serial::open must be called from within a tokio runtime with i/o enabled",
        )));
    }

    let path = config.path.as_str();
    if is_pty_multiplexer(path) {
        return Err(TransportError::NotAPort {
            path: path.into(),
            hint: "it is the pseudo-terminal multiplexer, which opens a new pseudo-terminal \
                   nobody listens to; give the pty a simulator printed (/dev/pts/N) or the \
                   adapter's port"
                .into(),
        });
    }
    let builder = tokio_serial::new(path, 9600)
        .data_bits(tokio_serial::DataBits::Eight)
        .parity(tokio_serial::Parity::None)
        .stop_bits(tokio_serial::StopBits::One)
        .flow_control(tokio_serial::FlowControl::None);
    let mut stream =
        tokio_serial::SerialStream::open(&builder).map_err(|e| classify_open_error(path, e))?;

    apply_baud(&mut stream, path, config.line.baud)?;
    apply_data_bits(&mut stream, path, config.line.data_bits)?;
    apply_parity(&mut stream, path, config.line.parity)?;
    apply_stop_bits(&mut stream, path, config.line.stop_bits)?;
    if let Some(rs485) = &config.rs485 {
        apply_rs485(&stream, path, rs485)?;
    }
    let flushed = flush_input(&stream, path)?;

    Ok(SerialPort {
        stream,
        config: config.clone(),
        flushed,
        pty: is_pty_path(path),
    })
}

/// Discard what the port's input holds (`tcflush(TCIFLUSH)`), after the settings are applied;
/// returns how many bytes that was (`FIONREAD` just before; 0 where the device cannot say).
fn flush_input(stream: &tokio_serial::SerialStream, path: &str) -> Result<u32, TransportError> {
    let waiting = stream.bytes_to_read().unwrap_or(0);
    stream
        .clear(tokio_serial::ClearBuffer::Input)
        .map_err(|e| TransportError::Setting {
            setting: "discarding the input left in the port".into(),
            path: path.into(),
            source: io::Error::from(e),
        })?;
    Ok(waiting)
}

/// Whether `path` (symbolic links followed) is the pseudo-terminal multiplexer: `/dev/ptmx` or
/// `/dev/pts/ptmx` (Linux: character device 5:2), whose every open makes a new pty master.
pub fn is_pty_multiplexer(path: &str) -> bool {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::{FileTypeExt as _, MetadataExt as _};
        if let Ok(m) = std::fs::metadata(path)
            && m.file_type().is_char_device()
            && libc::major(m.rdev()) == 5
            && libc::minor(m.rdev()) == 2
        {
            return true;
        }
    }
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.into());
    real.file_name().is_some_and(|n| n == "ptmx")
}

/// Whether `path` (symbolic links followed) is a pseudo-terminal's slave: Linux numbers them
/// with the UNIX98 majors 136–143 (and 3 for the old BSD ones).
#[cfg(target_os = "linux")]
fn is_pty_path(path: &str) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    std::fs::metadata(path).is_ok_and(|m| {
        let major = libc::major(m.rdev());
        (136..=143).contains(&major) || major == 3
    })
}

/// Whether `path` looks like a pseudo-terminal's slave (`/dev/pts/N`, macOS `/dev/ttysNNN`).
#[cfg(not(target_os = "linux"))]
fn is_pty_path(path: &str) -> bool {
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.into());
    let real = real.to_string_lossy();
    real.starts_with("/dev/pts/") || real.starts_with("/dev/ttys")
}

fn classify_open_error(path: &str, err: tokio_serial::Error) -> TransportError {
    use tokio_serial::ErrorKind;
    let busy = || TransportError::Busy {
        path: path.into(),
        hint: BUSY_HINT.into(),
    };
    match err.kind {
        ErrorKind::Io(io::ErrorKind::NotFound) => {
            return TransportError::NotFound { path: path.into() };
        }
        ErrorKind::Io(io::ErrorKind::PermissionDenied) => {
            return TransportError::PermissionDenied {
                path: path.into(),
                hint: DIALOUT_HINT.into(),
            };
        }
        // serialport reports EBUSY from `TIOCEXCL` and a held `flock` as `NoDevice`; an
        // absent device is `NotFound` (ENOENT), checked again below.
        ErrorKind::NoDevice | ErrorKind::Io(io::ErrorKind::WouldBlock)
            if std::fs::metadata(path).is_ok() =>
        {
            return busy();
        }
        _ => {}
    }
    if err.description.contains("busy") {
        return busy();
    }
    match std::fs::metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return TransportError::NotFound { path: path.into() };
        }
        #[cfg(unix)]
        Ok(meta) => {
            use std::os::unix::fs::FileTypeExt as _;
            if !meta.file_type().is_char_device() {
                return TransportError::Unsupported {
                    setting: "serial port access".into(),
                    path: path.into(),
                    hint: "this is not a character device; give a serial port such as \
                           /dev/ttyUSB0, /dev/ttyS0 or a pty slave /dev/pts/N"
                        .into(),
                };
            }
        }
        _ => {}
    }
    // ENOTTY: a character device that is no terminal (e.g. /dev/null).
    if err.description.contains("Not a typewriter")
        || err.description.contains("Inappropriate ioctl")
    {
        return TransportError::Unsupported {
            setting: "serial port access".into(),
            path: path.into(),
            hint: "this device is not a serial port (no terminal settings); give a serial port \
                   such as /dev/ttyUSB0, /dev/ttyS0 or a pty slave /dev/pts/N"
                .into(),
        };
    }
    TransportError::Open {
        path: path.into(),
        source: io::Error::from(err),
    }
}

/// Whether a serialport error means "the device refuses this value" (EINVAL, ENOTTY) rather
/// than a failure of the device itself.
fn is_refusal(err: &tokio_serial::Error) -> bool {
    matches!(err.kind, tokio_serial::ErrorKind::InvalidInput)
        || err.description == "Invalid argument"
        || err.description == "Inappropriate ioctl for device"
        || err.description == "Operation not supported"
}

fn setting_error(
    path: &str,
    setting: String,
    hint: String,
    err: tokio_serial::Error,
) -> TransportError {
    if is_refusal(&err) {
        TransportError::Unsupported {
            setting,
            path: path.into(),
            hint,
        }
    } else {
        TransportError::Setting {
            setting,
            path: path.into(),
            source: io::Error::from(err),
        }
    }
}

fn apply_baud(
    stream: &mut tokio_serial::SerialStream,
    path: &str,
    baud: u32,
) -> Result<(), TransportError> {
    let setting = format!("baud {baud}");
    let hint = format!(
        "this device refuses {baud} baud; try a standard rate such as 9600, 19200, 38400, \
         57600 or 115200 and set the drive to match"
    );
    stream
        .set_baud_rate(baud)
        .map_err(|e| setting_error(path, setting.clone(), hint.clone(), e))?;
    // Drivers may round to the nearest rate they can generate; a UART tolerates about 3 %.
    match stream.baud_rate() {
        Ok(actual) if actual.abs_diff(baud) as u64 * 100 > baud as u64 * 3 => {
            Err(TransportError::Unsupported {
                setting,
                path: path.into(),
                hint: format!("{hint} (the device runs at {actual} baud instead)"),
            })
        }
        // Some drivers cannot report the rate; accept what was set without error.
        _ => Ok(()),
    }
}

fn apply_data_bits(
    stream: &mut tokio_serial::SerialStream,
    path: &str,
    data_bits: u8,
) -> Result<(), TransportError> {
    use tokio_serial::DataBits;
    let wanted = match data_bits {
        5 => DataBits::Five,
        6 => DataBits::Six,
        7 => DataBits::Seven,
        _ => DataBits::Eight,
    };
    let setting = format!("{data_bits} data bits");
    let hint = format!(
        "this device refuses {data_bits} data bits (pseudo-terminals take only 8); give the \
         data bits the drive uses"
    );
    stream
        .set_data_bits(wanted)
        .map_err(|e| setting_error(path, setting.clone(), hint.clone(), e))?;
    verify(stream.data_bits(), wanted, path, setting, hint)
}

fn apply_parity(
    stream: &mut tokio_serial::SerialStream,
    path: &str,
    parity: Parity,
) -> Result<(), TransportError> {
    let wanted = match parity {
        Parity::None => tokio_serial::Parity::None,
        Parity::Even => tokio_serial::Parity::Even,
        Parity::Odd => tokio_serial::Parity::Odd,
    };
    let setting = format!("parity {parity}");
    let hint = "this device refuses parity; pseudo-terminals accept only no parity".to_owned();
    stream
        .set_parity(wanted)
        .map_err(|e| setting_error(path, setting.clone(), hint.clone(), e))?;
    verify(stream.parity(), wanted, path, setting, hint)
}

fn apply_stop_bits(
    stream: &mut tokio_serial::SerialStream,
    path: &str,
    stop_bits: StopBits,
) -> Result<(), TransportError> {
    let wanted = match stop_bits {
        StopBits::One => tokio_serial::StopBits::One,
        StopBits::Two => tokio_serial::StopBits::Two,
    };
    let setting = format!("{stop_bits} stop bits");
    let hint = format!(
        "this device refuses {stop_bits} stop bits; try {} stop bit(s)",
        match stop_bits {
            StopBits::One => 2,
            StopBits::Two => 1,
        }
    );
    stream
        .set_stop_bits(wanted)
        .map_err(|e| setting_error(path, setting.clone(), hint.clone(), e))?;
    verify(stream.stop_bits(), wanted, path, setting, hint)
}

/// Compares a read-back value with the requested one: a device that accepts a setting but
/// does not apply it (Linux ptys silently clear `PARENB`, for example) is as unsupported as one
/// that refuses it.
fn verify<T: PartialEq>(
    actual: tokio_serial::Result<T>,
    wanted: T,
    path: &str,
    setting: String,
    hint: String,
) -> Result<(), TransportError> {
    match actual {
        Ok(actual) if actual != wanted => Err(TransportError::Unsupported {
            setting,
            path: path.into(),
            hint,
        }),
        Ok(_) => Ok(()),
        Err(err) => Err(TransportError::Setting {
            setting,
            path: path.into(),
            source: io::Error::from(err),
        }),
    }
}

const RS485_SETTING: &str = "RS-485 mode";

#[cfg(target_os = "linux")]
fn apply_rs485(
    stream: &tokio_serial::SerialStream,
    path: &str,
    rs485: &Rs485Config,
) -> Result<(), TransportError> {
    use crate::sys;

    let mut flags = sys::SER_RS485_ENABLED;
    if rs485.rts_on_send {
        flags |= sys::SER_RS485_RTS_ON_SEND;
    }
    if rs485.rts_after_send {
        flags |= sys::SER_RS485_RTS_AFTER_SEND;
    }
    if rs485.rx_during_tx {
        flags |= sys::SER_RS485_RX_DURING_TX;
    }
    let result = sys::set_rs485(
        stream,
        flags,
        rs485.delay_rts_before_send_ms,
        rs485.delay_rts_after_send_ms,
    );
    match result {
        Ok(()) => Ok(()),
        Err(err)
            if matches!(
                err.raw_os_error(),
                Some(libc::ENOTTY | libc::EINVAL | libc::EOPNOTSUPP)
            ) =>
        {
            Err(TransportError::Unsupported {
                setting: RS485_SETTING.into(),
                path: path.into(),
                hint: format!(
                    "the driver of this device has no kernel RS-485 support ({err}); use an \
                     adapter with automatic direction control and leave RS-485 mode off"
                ),
            })
        }
        Err(source) => Err(TransportError::Setting {
            setting: RS485_SETTING.into(),
            path: path.into(),
            source,
        }),
    }
}

/// RS-485 mode through `TIOCSRS485` exists only on Linux; elsewhere this is decided at compile
/// time and always reports the setting as unsupported.
#[cfg(not(target_os = "linux"))]
fn apply_rs485(
    _stream: &tokio_serial::SerialStream,
    path: &str,
    _rs485: &Rs485Config,
) -> Result<(), TransportError> {
    Err(TransportError::Unsupported {
        setting: RS485_SETTING.into(),
        path: path.into(),
        hint: "kernel RS-485 mode (TIOCSRS485) is available only on Linux; use an adapter with \
               automatic direction control and leave RS-485 mode off"
            .into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_shows_its_line() {
        let cfg = SerialConfig::new("/dev/ttyUSB0", 9600);
        assert_eq!(cfg.bits_per_char(), 11);
        assert_eq!(cfg.char_time(), Duration::from_nanos(1_145_833));
        assert_eq!(cfg.to_string(), "/dev/ttyUSB0 9600 8E1");
        let pty = SerialConfig::with_line(
            "/dev/pts/3",
            LineSettings::new(19200).with_parity(Parity::None),
        );
        assert_eq!(pty.char_time(), Duration::from_nanos(520_833));
        assert_eq!(pty.to_string(), "/dev/pts/3 19200 8N1");
    }
}
