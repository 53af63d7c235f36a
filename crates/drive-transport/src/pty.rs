//! Pseudo-terminal pairs: a serial-port stand-in for tests and simulators.
//!
//! A pty has a *master* side (a file descriptor held by this process) and a *slave* side
//! (`/dev/pts/N`) that any program can open like a serial port. Bytes written to one side
//! arrive on the other. Both sides are put into raw mode (`cfmakeraw`), so bytes pass unchanged:
//! no echo, no CR/LF translation, no control characters interpreted.
//!
//! Ptys have no baud rate and no parity: open the slave with
//! [`serial::open`](crate::serial::open) using [`Parity::None`]
//! (see [`PtyPair::slave_config`]); even or odd parity is refused with
//! [`TransportError::Unsupported`].

use std::fs::File;
use std::io::{self, Read as _, Write as _};
use std::os::fd::AsFd as _;
use std::os::unix::fs::OpenOptionsExt as _;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::task::{Context, Poll, ready};

use tokio::io::unix::AsyncFd;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

use crate::TransportError;
use crate::serial::{LineSettings, Parity, SerialConfig};
use crate::sys;

/// One side of a pseudo-terminal, usable from tokio.
///
/// Reading returns end of file once the other side is closed (Linux reports this as `EIO`,
/// which is translated).
#[derive(Debug)]
pub struct PtyStream {
    fd: AsyncFd<File>,
}

impl PtyStream {
    fn new(file: File) -> Result<Self, TransportError> {
        sys::set_nonblocking(file.as_fd()).map_err(|source| TransportError::Pty {
            operation: "set O_NONBLOCK",
            source,
        })?;
        let fd = sys::register_async_fd(file).map_err(|source| TransportError::Pty {
            operation: "register with tokio",
            source,
        })?;
        Ok(PtyStream { fd })
    }
}

impl AsyncRead for PtyStream {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        loop {
            let mut guard = ready!(self.fd.poll_read_ready(cx))?;
            let unfilled = buf.initialize_unfilled();
            match guard.try_io(|inner| inner.get_ref().read(unfilled)) {
                Ok(Ok(n)) => {
                    buf.advance(n);
                    return Poll::Ready(Ok(()));
                }
                // The other side hung up: end of file.
                Ok(Err(e)) if e.raw_os_error() == Some(libc::EIO) => {
                    return Poll::Ready(Ok(()));
                }
                Ok(Err(e)) => return Poll::Ready(Err(e)),
                Err(_would_block) => continue,
            }
        }
    }
}

impl AsyncWrite for PtyStream {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        loop {
            let mut guard = ready!(self.fd.poll_write_ready(cx))?;
            match guard.try_io(|inner| inner.get_ref().write(buf)) {
                Ok(result) => return Poll::Ready(result),
                Err(_would_block) => continue,
            }
        }
    }

    fn poll_flush(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }

    fn poll_shutdown(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

/// A pseudo-terminal: this value is the master side (it implements [`AsyncRead`] and
/// [`AsyncWrite`]); [`slave_path`](PtyPair::slave_path) is the device another program (or
/// [`serial::open`](crate::serial::open)) opens.
///
/// The pair keeps a descriptor of the slave open for its whole life, so the master never sees
/// a hang-up while the other program opens and closes the slave.
#[derive(Debug)]
pub struct PtyPair {
    master: PtyStream,
    slave_path: PathBuf,
    _slave_keepalive: File,
}

/// Creates a master, makes its slave openable and returns both plus the slave's path.
fn create(slave_nonblocking: bool) -> Result<(File, File, PathBuf), TransportError> {
    if tokio::runtime::Handle::try_current().is_err() {
        return Err(TransportError::Io(io::Error::other(
            "pty pairs must be created from within a tokio runtime with i/o enabled",
        )));
    }
    let pty_err = |operation| move |source| TransportError::Pty { operation, source };
    let master = sys::posix_openpt().map_err(pty_err("posix_openpt"))?;
    sys::grant_and_unlock(master.as_fd()).map_err(pty_err("grantpt/unlockpt"))?;
    let slave_path = sys::ptsname(master.as_fd()).map_err(pty_err("ptsname_r"))?;
    let mut flags = libc::O_NOCTTY;
    if slave_nonblocking {
        flags |= libc::O_NONBLOCK;
    }
    let slave = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(flags)
        .open(&slave_path)
        .map_err(pty_err("open slave"))?;
    // Termios settings live with the slave; raw mode there makes both directions transparent
    // (the master side of a Linux pty is raw already).
    sys::make_raw(slave.as_fd()).map_err(pty_err("cfmakeraw"))?;
    Ok((File::from(master), slave, slave_path))
}

impl PtyPair {
    /// Opens a new pseudo-terminal in raw mode.
    ///
    /// Must be called from within a tokio runtime with I/O enabled.
    ///
    /// # Errors
    ///
    /// [`TransportError::Pty`] naming the failed step.
    pub fn open() -> Result<PtyPair, TransportError> {
        let (master, slave, slave_path) = create(false)?;
        Ok(PtyPair {
            master: PtyStream::new(master)?,
            slave_path,
            _slave_keepalive: slave,
        })
    }

    /// Opens a new pseudo-terminal and returns both sides as tokio streams:
    /// `(master, slave)`. Dropping one makes the other read end of file.
    ///
    /// # Errors
    ///
    /// [`TransportError::Pty`] naming the failed step.
    pub fn open_streams() -> Result<(PtyStream, PtyStream), TransportError> {
        let (master, slave, _) = create(true)?;
        Ok((PtyStream::new(master)?, PtyStream::new(slave)?))
    }

    /// Path of the slave device, e.g. `/dev/pts/3`.
    pub fn slave_path(&self) -> &Path {
        &self.slave_path
    }

    /// A [`SerialConfig`] that opens the slave: 8 data bits, no parity, 1 stop bit (ptys
    /// refuse parity), the given nominal baud rate.
    pub fn slave_config(&self, baud: u32) -> SerialConfig {
        SerialConfig::with_line(
            self.slave_path.to_string_lossy().into_owned(),
            LineSettings::new(baud).with_parity(Parity::None),
        )
    }

    /// The master side as a stream (the pair itself also implements the I/O traits).
    pub fn master(&mut self) -> &mut PtyStream {
        &mut self.master
    }
}

impl AsyncRead for PtyPair {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.master).poll_read(cx, buf)
    }
}

impl AsyncWrite for PtyPair {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.master).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.master).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.master).poll_shutdown(cx)
    }
}
