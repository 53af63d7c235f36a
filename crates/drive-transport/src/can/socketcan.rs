//! SocketCAN (Linux): a CAN interface of the kernel (`can0`, `vcan0`, `slcan0`) as a
//! [`CanIo`], through the `socketcan` crate's tokio socket.
//!
//! * Frames are converted to and from [`CanFrame`]: data and remote frames, standard and
//!   extended identifiers.
//! * The socket is a classical CAN socket: the kernel never delivers CAN FD frames to it, so
//!   none can be mistaken for a classical one, and [`CanFrame`] cannot express one to send.
//! * Error frames (bus errors, controller problems, bus-off) are switched on and *counted*
//!   ([`SocketCanStats`]), with the last one's description; they are not frames of the bus and
//!   never reach the protocol.
//! * [`CanIo::poll_send`] completes when the kernel has taken the frame (not when it has left
//!   the wire). A full transmit queue (`ENOBUFS`, which SocketCAN reports instead of blocking)
//!   is retried every millisecond.
//! * Receive times are tokio's clock at the read.
//!
//! A missing interface is [`TransportError::CanInterfaceNotFound`], whose message says how to
//! create a virtual one or bring up a real one.

use std::future::Future as _;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use std::time::Duration;

use drive_core::can::{CanFrame, Frame as _};
use drive_core::rt::{CanIo, ReceivedFrame};
use futures_core::Stream;
use futures_sink::Sink;
use socketcan::SocketOptions as _;
use tokio::time::{Instant, Sleep};

use crate::TransportError;

/// Counters of a [`SocketCanPort`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SocketCanStats {
    /// Frames received.
    pub received: u64,
    /// Frames sent.
    pub sent: u64,
    /// Error frames reported by the kernel.
    pub error_frames: u64,
    /// The description of the last error frame.
    pub last_error: Option<String>,
    /// Sends retried because the kernel's transmit queue was full.
    pub queue_full: u64,
}

/// A SocketCAN interface (see the module docs).
#[derive(Debug)]
pub struct SocketCanPort {
    socket: socketcan::tokio::CanSocket,
    name: String,
    stats: SocketCanStats,
    retry: Option<Pin<Box<Sleep>>>,
}

fn hint(name: &str) -> String {
    format!(
        "for a virtual bus: sudo ip link add {name} type vcan && sudo ip link set {name} up \
         (needs the vcan module: sudo modprobe vcan); for a real adapter: sudo ip link set \
         {name} up type can bitrate 500000"
    )
}

impl SocketCanPort {
    /// Opens interface `name` (e.g. `can0`, `vcan0`). Must be called within a tokio runtime.
    ///
    /// # Errors
    ///
    /// [`TransportError::CanInterfaceNotFound`] when there is no such interface;
    /// [`TransportError::Unsupported`] when the kernel has no SocketCAN or the interface is no
    /// CAN interface; [`TransportError::Open`] otherwise.
    pub fn open(name: &str) -> Result<Self, TransportError> {
        if tokio::runtime::Handle::try_current().is_err() {
            return Err(TransportError::Io(io::Error::other(
                "SocketCanPort::open must be called from within a tokio runtime with i/o enabled",
            )));
        }
        let socket = socketcan::tokio::CanSocket::open(name).map_err(|e| open_error(name, e))?;
        // Error frames are counted (module docs); failing to enable them only loses the count.
        let _ = socket.set_error_filter_accept_all();
        Ok(SocketCanPort {
            socket,
            name: name.to_owned(),
            stats: SocketCanStats::default(),
            retry: None,
        })
    }

    /// The interface name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Counters, with the last error frame's description.
    pub fn stats(&self) -> &SocketCanStats {
        &self.stats
    }

    fn io_error(&self, e: io::Error) -> io::Error {
        match e.raw_os_error() {
            Some(libc::ENETDOWN) => io::Error::new(
                io::ErrorKind::NotConnected,
                format!(
                    "CAN interface {} is down: sudo ip link set {} up (a real adapter also \
                     needs type can bitrate 500000)",
                    self.name, self.name
                ),
            ),
            Some(libc::ENODEV) | Some(libc::ENXIO) => io::Error::new(
                io::ErrorKind::UnexpectedEof,
                format!("CAN interface {} is gone (adapter unplugged?)", self.name),
            ),
            _ => e,
        }
    }
}

fn open_error(name: &str, e: io::Error) -> TransportError {
    match e.raw_os_error() {
        Some(libc::ENODEV) | Some(libc::ENXIO) => TransportError::CanInterfaceNotFound {
            name: name.to_owned(),
            hint: hint(name),
        },
        Some(libc::EAFNOSUPPORT) | Some(libc::EPROTONOSUPPORT) => TransportError::Unsupported {
            setting: "SocketCAN".into(),
            path: name.to_owned(),
            hint: "this kernel has no SocketCAN support loaded: sudo modprobe can can_raw (and \
                   vcan for virtual buses)"
                .into(),
        },
        Some(libc::EINVAL) => TransportError::Unsupported {
            setting: "SocketCAN".into(),
            path: name.to_owned(),
            hint: "this interface is not a CAN interface; list them with ip -details link \
                   show type can (or type vcan)"
                .into(),
        },
        _ => TransportError::Open {
            path: name.to_owned(),
            source: e,
        },
    }
}

fn to_io(e: socketcan::Error) -> io::Error {
    match e {
        socketcan::Error::Io(e) => e,
        other => io::Error::other(other.to_string()),
    }
}

/// Converts a frame from the socket; `None` for an error frame.
fn from_socketcan(frame: &socketcan::CanFrame) -> Option<CanFrame> {
    match frame {
        socketcan::CanFrame::Data(d) => CanFrame::data_frame(d.id(), d.data()),
        socketcan::CanFrame::Remote(r) => CanFrame::remote_frame(r.id(), r.dlc().min(8) as u8),
        socketcan::CanFrame::Error(_) => None,
    }
}

fn to_socketcan(frame: &CanFrame) -> Option<socketcan::CanFrame> {
    if frame.is_remote_frame() {
        socketcan::CanFrame::new_remote(frame.id(), frame.dlc())
    } else {
        socketcan::CanFrame::new(frame.id(), frame.data())
    }
}

impl CanIo for SocketCanPort {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        loop {
            let next = ready!(Pin::new(&mut self.socket).poll_next(cx));
            let Some(result) = next else {
                return Poll::Ready(Err(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    format!("CAN interface {} closed", self.name),
                )));
            };
            let frame = result.map_err(|e| self.io_error(to_io(e)))?;
            match from_socketcan(&frame) {
                Some(frame) => {
                    self.stats.received += 1;
                    return Poll::Ready(Ok(ReceivedFrame {
                        frame,
                        at: Instant::now(),
                    }));
                }
                None => {
                    self.stats.error_frames += 1;
                    if let socketcan::CanFrame::Error(e) = frame {
                        self.stats.last_error = Some(e.into_error().to_string());
                    }
                }
            }
        }
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        let Some(out) = to_socketcan(frame) else {
            return Poll::Ready(Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("frame {frame} cannot be expressed as a SocketCAN frame"),
            )));
        };
        loop {
            if let Some(timer) = self.retry.as_mut() {
                ready!(timer.as_mut().poll(cx));
                self.retry = None;
            }
            let mut socket = Pin::new(&mut self.socket);
            ready!(socket.as_mut().poll_ready(cx)).map_err(|e| self.io_error(to_io(e)))?;
            match Pin::new(&mut self.socket).start_send(out) {
                Ok(()) => {
                    self.stats.sent += 1;
                    return Poll::Ready(Ok(()));
                }
                Err(e) => {
                    let e = to_io(e);
                    if e.raw_os_error() == Some(libc::ENOBUFS)
                        || e.kind() == io::ErrorKind::WouldBlock
                    {
                        self.stats.queue_full += 1;
                        self.retry = Some(Box::pin(tokio::time::sleep(Duration::from_millis(1))));
                        continue;
                    }
                    return Poll::Ready(Err(self.io_error(e)));
                }
            }
        }
    }
}
