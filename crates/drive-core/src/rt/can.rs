//! The runtime side of CAN: [`CanIo`], what a CAN transport (SocketCAN, an slcan adapter, the
//! in-memory virtual bus of `drive-transport`) offers the async masters and simulated drives.

use std::future::poll_fn;
use std::io;
use std::task::{Context, Poll};

use tokio::time::Instant as TokioInstant;

use crate::can::CanFrame;

/// A frame received from a CAN bus with the time its last bit arrived (exact on the virtual
/// bus; the time of the read on a real interface).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReceivedFrame {
    /// The frame.
    pub frame: CanFrame,
    /// When it was received, on tokio's clock.
    pub at: TokioInstant,
}

/// A CAN interface: send frames, receive every frame on the bus (filtering is the protocol's).
///
/// `poll_recv` returns `Err` with [`io::ErrorKind::UnexpectedEof`] when the interface is gone
/// (the virtual bus dropped, the adapter unplugged).
pub trait CanIo: Send {
    /// Poll for the next received frame.
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>>;

    /// Poll to send `frame`; `Ready(Ok(()))` once the interface has taken it (on the virtual
    /// bus: once it has won arbitration and left the wire).
    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>>;

    /// Poll to send `frame` as the protocol scheduled it: to start at `start` on tokio's clock,
    /// which may lie a little in the past (the timer that woke the sender ends on tokio's next
    /// tick, [`TIMER_RESOLUTION`](super::TIMER_RESOLUTION), after the instant the protocol
    /// asked for). Pass the same `start` on every poll of one frame.
    ///
    /// A real interface cannot send in the past: the default ignores `start` and calls
    /// [`CanIo::poll_send`]. The virtual bus of `drive-transport` lets the frame compete for
    /// the bus from `start` (never more than that resolution back), so an answer starts when
    /// the request ends and a periodic frame keeps its period, not the late wake-up.
    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: TokioInstant,
    ) -> Poll<io::Result<()>> {
        let _ = start;
        self.poll_send(cx, frame)
    }
}

/// Receive the next frame from `io`.
pub async fn recv_frame<C: CanIo + ?Sized>(io: &mut C) -> io::Result<ReceivedFrame> {
    poll_fn(|cx| io.poll_recv(cx)).await
}

/// Send `frame` on `io`.
pub async fn send_frame<C: CanIo + ?Sized>(io: &mut C, frame: &CanFrame) -> io::Result<()> {
    poll_fn(|cx| io.poll_send(cx, frame)).await
}

/// Send `frame` on `io` as scheduled to start at `start` (see [`CanIo::poll_send_at`]).
pub async fn send_frame_at<C: CanIo + ?Sized>(
    io: &mut C,
    frame: &CanFrame,
    start: TokioInstant,
) -> io::Result<()> {
    poll_fn(|cx| io.poll_send_at(cx, frame, start)).await
}

impl<C: CanIo + ?Sized> CanIo for Box<C> {
    fn poll_recv(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<ReceivedFrame>> {
        (**self).poll_recv(cx)
    }

    fn poll_send(&mut self, cx: &mut Context<'_>, frame: &CanFrame) -> Poll<io::Result<()>> {
        (**self).poll_send(cx, frame)
    }

    fn poll_send_at(
        &mut self,
        cx: &mut Context<'_>,
        frame: &CanFrame,
        start: TokioInstant,
    ) -> Poll<io::Result<()>> {
        (**self).poll_send_at(cx, frame, start)
    }
}
