//! The only module with `unsafe` code: thin, checked wrappers around the libc calls that the
//! standard library does not expose (pseudo-terminal creation, termios raw mode, `O_NONBLOCK`,
//! the `TIOCSRS485` ioctl).
//!
//! Every function takes or returns owned/borrowed file descriptors, so the rest of the crate
//! never handles raw descriptors. Linux only (the whole module is compiled only there).

#![allow(unsafe_code)]

use std::ffi::CStr;
use std::io;
use std::os::fd::{AsRawFd, BorrowedFd, FromRawFd, OwnedFd};
use std::path::PathBuf;

/// Turns a libc return value of `-1` into the current `errno`.
fn check(ret: libc::c_int) -> io::Result<libc::c_int> {
    if ret == -1 {
        Err(io::Error::last_os_error())
    } else {
        Ok(ret)
    }
}

/// Opens a new pseudo-terminal master (`posix_openpt`), with close-on-exec set.
pub(crate) fn posix_openpt() -> io::Result<OwnedFd> {
    // SAFETY: `posix_openpt` takes flags by value and returns a new descriptor or -1; it does
    // not touch memory we own.
    let fd = check(unsafe { libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY) })?;
    // SAFETY: `fd` was just returned by `posix_openpt`, is valid, and nothing else owns it.
    let owned = unsafe { OwnedFd::from_raw_fd(fd) };
    // SAFETY: `F_SETFD` with a flag value reads no memory; the descriptor is valid (owned above).
    check(unsafe { libc::fcntl(owned.as_raw_fd(), libc::F_SETFD, libc::FD_CLOEXEC) })?;
    Ok(owned)
}

/// `grantpt` + `unlockpt`: makes the slave side openable.
pub(crate) fn grant_and_unlock(master: BorrowedFd<'_>) -> io::Result<()> {
    // SAFETY: both calls take a valid descriptor (guaranteed by `BorrowedFd`) by value.
    check(unsafe { libc::grantpt(master.as_raw_fd()) })?;
    // SAFETY: as above.
    check(unsafe { libc::unlockpt(master.as_raw_fd()) })?;
    Ok(())
}

/// The path of the slave side of a pseudo-terminal master (`ptsname_r`).
pub(crate) fn ptsname(master: BorrowedFd<'_>) -> io::Result<PathBuf> {
    let mut buf = [0 as libc::c_char; 128];
    // SAFETY: `buf` is a writable buffer of the length we pass; `ptsname_r` writes at most
    // `buf.len()` bytes including the terminating NUL, or fails with ERANGE.
    let ret = unsafe { libc::ptsname_r(master.as_raw_fd(), buf.as_mut_ptr(), buf.len()) };
    if ret != 0 {
        return Err(io::Error::from_raw_os_error(ret));
    }
    // SAFETY: on success `ptsname_r` stored a NUL-terminated string inside `buf`, which lives
    // until the end of this function; we copy it out before returning.
    let name = unsafe { CStr::from_ptr(buf.as_ptr()) };
    let name = name
        .to_str()
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "pty name is not UTF-8"))?;
    Ok(PathBuf::from(name))
}

/// Sets `O_NONBLOCK` on a descriptor (needed before handing it to tokio's `AsyncFd`).
pub(crate) fn set_nonblocking(fd: BorrowedFd<'_>) -> io::Result<()> {
    // SAFETY: `F_GETFL` reads no memory; the descriptor is valid (`BorrowedFd`).
    let flags = check(unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_GETFL) })?;
    // SAFETY: `F_SETFL` with an integer argument reads no memory; the descriptor is valid.
    check(unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_SETFL, flags | libc::O_NONBLOCK) })?;
    Ok(())
}

/// Puts a terminal into raw mode (`cfmakeraw`): no echo, no line editing, no CR/LF
/// translation, no signals, 8-bit characters; `VMIN = 1`, `VTIME = 0`.
pub(crate) fn make_raw(fd: BorrowedFd<'_>) -> io::Result<()> {
    let mut termios = std::mem::MaybeUninit::<libc::termios>::uninit();
    // SAFETY: `termios` points to writable memory of the right type and size; the descriptor
    // is valid.
    check(unsafe { libc::tcgetattr(fd.as_raw_fd(), termios.as_mut_ptr()) })?;
    // SAFETY: `tcgetattr` succeeded, so it fully initialised `termios`.
    let mut termios = unsafe { termios.assume_init() };
    // SAFETY: `cfmakeraw` only modifies the struct we pass by exclusive reference.
    unsafe { libc::cfmakeraw(&mut termios) };
    termios.c_cc[libc::VMIN] = 1;
    termios.c_cc[libc::VTIME] = 0;
    // SAFETY: `termios` is an initialised struct read by reference; the descriptor is valid.
    check(unsafe { libc::tcsetattr(fd.as_raw_fd(), libc::TCSANOW, &termios) })?;
    Ok(())
}

/// Registers an owned file with tokio's reactor (the file must be in non-blocking mode).
pub(crate) fn register_async_fd(
    file: std::fs::File,
) -> io::Result<tokio::io::unix::AsyncFd<std::fs::File>> {
    // SAFETY: `File` owns its descriptor: it stays open, refers to the same file description
    // and `as_raw_fd` returns the same value until the `AsyncFd` (which takes ownership of the
    // `File`) is dropped or consumed.
    unsafe { tokio::io::unix::AsyncFd::register(file) }.map_err(io::Error::from)
}

/// `SER_RS485_ENABLED` from `<linux/serial.h>`.
pub(crate) const SER_RS485_ENABLED: u32 = 1 << 0;
/// `SER_RS485_RTS_ON_SEND`: RTS level while sending is logical 1.
pub(crate) const SER_RS485_RTS_ON_SEND: u32 = 1 << 1;
/// `SER_RS485_RTS_AFTER_SEND`: RTS level after sending is logical 1.
pub(crate) const SER_RS485_RTS_AFTER_SEND: u32 = 1 << 2;
/// `SER_RS485_RX_DURING_TX`: keep the receiver enabled while sending.
pub(crate) const SER_RS485_RX_DURING_TX: u32 = 1 << 4;

/// `struct serial_rs485` from `<linux/serial.h>` (32 bytes; the trailing union is only
/// padding for our purposes and must be zero).
#[repr(C)]
#[derive(Debug, Default)]
struct SerialRs485 {
    flags: u32,
    delay_rts_before_send: u32,
    delay_rts_after_send: u32,
    padding: [u32; 5],
}

/// Applies RS-485 mode with the `TIOCSRS485` ioctl.
pub(crate) fn set_rs485(
    port: &tokio_serial::SerialStream,
    flags: u32,
    delay_before_ms: u32,
    delay_after_ms: u32,
) -> io::Result<()> {
    let mut conf = SerialRs485 {
        flags,
        delay_rts_before_send: delay_before_ms,
        delay_rts_after_send: delay_after_ms,
        ..SerialRs485::default()
    };
    // SAFETY: `TIOCSRS485` takes a pointer to a `struct serial_rs485`, which `SerialRs485`
    // mirrors exactly (`repr(C)`, 8 × u32). The kernel may write the applied values back, so
    // we pass a pointer to a live, exclusively borrowed value. The descriptor is owned by
    // `port`, which is borrowed for the whole call, so it stays open.
    check(unsafe {
        libc::ioctl(
            port.as_raw_fd(),
            libc::TIOCSRS485 as _,
            &mut conf as *mut SerialRs485,
        )
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn serial_rs485_has_kernel_size() {
        assert_eq!(std::mem::size_of::<super::SerialRs485>(), 32);
    }
}
