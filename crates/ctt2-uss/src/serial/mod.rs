//! USS on the RS-485 line (the serial framing around the PKW/PZD data of [`crate::uss`]):
//!
//! * [`telegram`]: [`UssAddress`], the [`Adr`] byte, the fixed [`Layout`] of the net data,
//!   [`Telegram`] with its allocation-free codec and [`FrameError`];
//! * [`framing`]: [`UssFraming`] on drive-core's character receiver (start delay, length from
//!   LGE, character gap, residual run time, BCC) and the USS times from the line settings;
//! * [`master`]: the sans-IO master, [`UssMaster`](master::UssMaster): drive-core's one master
//!   with USS's checks;
//! * [`slave`]: the sans-IO slave with its [`Backend`](slave::Backend);
//! * `driver` (feature `tokio`): `UssDriver`, the async driver (drive-core's runtime driver)
//!   implementing the client's parameter and process channels;
//! * `sim` (feature `sim`): simulated NORD drives on a line.
//!
//! The framing is the public USS specification (NORD's manual BU 0255 describes only the
//! PKW/PZD data); `docs/protocols/uss.md` cites the sources.

#[cfg(feature = "tokio")]
pub mod driver;
pub mod framing;
pub mod master;
#[cfg(feature = "sim")]
pub mod sim;
pub mod slave;
pub mod telegram;

pub use framing::{Side, UssFraming, UssReceiver, UssTiming};
pub use telegram::{Adr, FrameError, Layout, LayoutError, Telegram, TelegramError, UssAddress};
