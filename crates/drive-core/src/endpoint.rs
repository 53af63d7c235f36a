//! The interface between a sans-IO state machine and whatever drives it (the runtime layer's
//! `rt::Port` and serve loop with the `tokio` feature, a test pump, an embedded main loop).

use crate::char::RxChar;
use crate::time::Instant;

/// A sans-IO bus participant (a master or a slave of any protocol), in the quinn-proto style:
/// characters and the passing of time go in, frames to send and deadlines come out. Time is
/// always an argument.
pub trait Endpoint {
    /// Feed one character received from the bus.
    fn handle_char(&mut self, c: RxChar);

    /// Advance the time to `now` and do what is due by then. May be called at any time, not only
    /// at [`Endpoint::poll_timeout`] (a serve loop calls every station when one station's
    /// deadline comes); an endpoint with nothing due does nothing.
    fn handle_timeout(&mut self, now: Instant);

    /// The next frame to send, if one is due at `now`; its bytes start on the wire at `now`.
    /// Returns the number of bytes written to `buf`.
    fn poll_transmit(&mut self, now: Instant, buf: &mut [u8]) -> Option<usize>;

    /// When [`Endpoint::handle_timeout`] (or [`Endpoint::poll_transmit`]) has work to do.
    fn poll_timeout(&self) -> Option<Instant>;

    /// The next deadline that only needs a quiet line: a complete frame's end confirmation, a
    /// transmission falling due after a pause. A virtual clock (which does not wait for real
    /// time) may jump to it; it must not jump to the other deadlines (a gap limit while a frame
    /// is arriving, a response timeout, a device's own timers), because characters may still
    /// come.
    fn poll_quiet_timeout(&self) -> Option<Instant>;

    /// The longest frame [`Endpoint::poll_transmit`] writes.
    fn max_frame_len(&self) -> usize;

    /// The frame the last [`Endpoint::poll_transmit`] returned has completely left the port at
    /// `at`. A port that carries frames without wire time (a pseudo-terminal, an in-memory
    /// pipe) or knows the moment better than the frame's length × character time says so; a
    /// master judges characters that completed by then as stale (they cannot answer it). By
    /// default nothing happens: the frame's wire time stands.
    fn frame_left(&mut self, at: Instant) {
        let _ = at;
    }

    /// Characters received so far that were never taken as an answer because they arrived
    /// while a request waited for the bus or was still leaving it (stale: an answer an earlier
    /// program left in the port, a late answer, another master); cumulative, 0 for an endpoint
    /// that sends no requests.
    fn stale_chars(&self) -> u64 {
        0
    }
}

/// A slave on a line: an [`Endpoint`] that answers one address, which a simulated device
/// sharing the line with others is found by.
pub trait SlaveEndpoint: Endpoint {
    /// The address it answers now.
    fn address(&self) -> u8;

    /// The character time of its line.
    fn char_time(&self) -> core::time::Duration;
}

/// The own deadlines of what a slave state machine drives (a drive model's ramp, its link
/// watchdog): part of the slave's [`Endpoint::poll_timeout`], reaching it through
/// [`Timers::handle_timeout`]. By default there are none.
pub trait Timers {
    /// The next own deadline, if any.
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }

    /// Time advanced to `now` (at least to the deadline of [`Timers::poll_timeout`], or
    /// further).
    fn handle_timeout(&mut self, now: Instant) {
        let _ = now;
    }
}
