//! `drive-core`: the sans-IO core that every drivebus protocol crate shares.
//!
//! A protocol crate (MOVILINK, SBus, CTT2/USS, Bonfiglioli Modbus) is only its frame types, its
//! codec, a framing description and its semantics. Everything else is here, once:
//!
//! * [`time`]: [`Instant`], the one notion of time (nanoseconds since an epoch the caller
//!   picks); nothing in the sans-IO layers reads a clock;
//! * [`line`](mod@line): [`LineSettings`] (baud, data bits, parity, stop bits) and the one
//!   [`char_time`](line::char_time) function every pause is computed from;
//! * [`char`](mod@char): [`RxChar`], a received character with its time and UART error flag;
//! * [`framing`]: the [`Framing`] description and the generic [`Receiver`] (idle gap starts a
//!   frame, gap limit inside a frame, end confirmed by silence, resynchronisation);
//! * [`Endpoint`]: the interface of every sans-IO master and slave to what drives it;
//! * [`can`]: classical CAN: [`can::CanFrame`] (an `embedded-can` frame), bit rates, frame
//!   lengths with bit stuffing, and [`can::CanEndpoint`], the interface of a sans-IO CAN node;
//! * [`gate`]: [`TxGate`], when the next frame may start on a half-duplex bus;
//! * [`exchange`]: [`Exchange`], the transaction skeleton of a character line (attempts,
//!   retries, give-up, late answers, stale characters);
//! * [`master`]: the one master every protocol's master is: [`master::Master`], the job/event
//!   shell (one request in flight, attempts, retries, give-up, late answers, stale input) over a
//!   small [`master::Protocol`] (prepare, encode, judge a received frame: ours, again, stale,
//!   foreign, corrupt) and a carrier: [`Exchange`] for characters, [`can::CanExchange`] for CAN
//!   frames;
//! * [`Queue`]: the small event queue of the state machines; [`SplitMix64`]: the one seeded
//!   random generator for fault injection and simulators;
//! * `rt` (feature `tokio`): the runtime layer: `CharIo`, the byte-stream adapter, the clock
//!   choice, the serve loop of simulated devices and the one runtime driver, `rt::Driver` (a
//!   sans-IO master on a serial `rt::Port` or a `rt::CanPort`, one transaction at a time),
//!   which every protocol's async driver is.
//!
//! Features: `std` (default), `tokio` (the runtime layer `rt`, on tokio) and `alloc-count`
//! (`alloc_count`: the counting global allocator of the no-allocation tests, for test
//! binaries only).
//!
//! The crate is `no_std` without its default `std` feature, and nothing outside the runtime
//! layer (`rt`, feature `tokio`) allocates.
#![cfg_attr(not(feature = "std"), no_std)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![warn(missing_docs)]

#[cfg(feature = "alloc-count")]
#[cfg_attr(docsrs, doc(cfg(feature = "alloc-count")))]
pub mod alloc_count;
pub mod can;
pub mod char;
pub mod endpoint;
pub mod exchange;
pub mod framing;
pub mod gate;
pub mod line;
pub mod master;
mod queue;
pub mod rng;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod rt;
pub mod time;

pub use char::{CharError, RxChar};
pub use endpoint::{Endpoint, SlaveEndpoint, Timers};
pub use exchange::{Exchange, ExchangeConfig, ExchangeEvent, Verdict};
pub use framing::{FrameTiming, Framing, LineError, Progress, Receiver, RxEvent, Start};
pub use gate::TxGate;
pub use line::{LineSettings, Parity, StopBits};
pub use master::LinkFault;
pub use queue::Queue;
pub use rng::SplitMix64;
pub use time::Instant;
