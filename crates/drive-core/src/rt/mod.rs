//! The runtime layer (feature `tokio`): what every protocol's async master and simulated
//! devices share.
//!
//! * [`CharIo`]: characters with arrival times and UART flags, for any tokio byte stream
//!   ([`Stream`]); `drive-transport` implements it for its in-memory wire model;
//! * [`time`]: the clock and timers every part of this layer uses: tokio's, or a
//!   [`VirtualClock`](time::VirtualClock)'s that jumps to the next deadline when every task is
//!   idle;
//! * [`Clock`] and [`Timebase`]: tokio's (real or paused) clock, or a virtual clock for
//!   benchmarks of software overhead;
//! * [`Port`]: a master's side of a line: transmit what a sans-IO [`Endpoint`] hands out, wait
//!   for its deadlines or for characters and feed them;
//! * [`CanIo`]: a CAN interface (frames, not characters) for the CAN masters and drives, and
//!   [`CanPort`]: a CAN master's side of a bus;
//! * [`Driver`]: the one runtime driver, a sans-IO master on a [`Link`] (a [`Port`] or a
//!   [`CanPort`]), one transaction at a time; every protocol's async driver is one;
//! * [`serve`]: the serve loop of simulated devices ([`Endpoint`]s) on one line, and [`Bus`]:
//!   several simulated devices ([`Station`]s, endpoints with an address) served on one line;
//! * [`Simulated`]: every protocol's simulated device, a [`Shell`] (its slave and line time)
//!   and a front-end following the slave's events, which makes it an [`Endpoint`] and a
//!   [`Station`].
//!
//! Serial ports are opened by `drive-transport`; this layer needs nothing but tokio, so a
//! protocol crate's `tokio` feature does not pull in serial-port or libc dependencies.
//!
//! [`Endpoint`]: crate::Endpoint

mod bus;
mod can;
mod can_port;
pub mod can_serve;
mod clock;
mod driver;
pub mod echo;
mod io;
mod port;
mod serve;
mod simulated;
pub mod time;

pub use bus::{Bus, LineTime, Station, serve_alone};
pub use can::{CanIo, ReceivedFrame, recv_frame, send_frame, send_frame_at};
pub use can_port::CanPort;
pub use clock::{Clock, Timebase};
pub use driver::{Driver, DriverStats, ExchangeTiming, Failed, Flow, Link, Tally};
pub use io::{
    CHUNK, CharIo, ReceivedChar, Stream, TIMER_RESOLUTION, WireTime, Woken, read_or_sleep,
    write_all, write_all_at,
};
pub use port::{Port, Step};
pub use serve::serve;
pub use simulated::{Shell, Simulated};
