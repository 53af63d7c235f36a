//! `ctt2-uss`: NORD NORDAC LINK drives over AS-Interface CTT2, carrying USS PKW/PZD, sans-IO.
//!
//! * [`uss`]: the USS parameter channel (PKW: orders, answers, the plausibility check) and
//!   process data (PZD), shared by both transports;
//! * [`ctt2`]: CTT2 over AS-Interface — messages, ID/diagnosis objects, PKW/PZD in channel
//!   data, the double slave (sans-IO), AS-i addresses, BusIO bits and transfer times; with
//!   feature `tokio` the CTT2 master over a user's AS-i link, with `sim` an in-memory link;
//! * `client` (feature `tokio`): the master logic both transports share — orders to their
//!   plausible answers, reads and writes, control through the state machine;
//! * [`serial`]: USS on RS-485 — telegrams (STX, LGE, ADR, PKW, PZD, BCC), the framing on
//!   drive-core's receiver, the sans-IO master and slave, the async master (feature `tokio`)
//!   and simulated NORD drives on a line (feature `sim`);
//!
//! It builds on:
//!
//! * [`drive_core`]: the one time type ([`Instant`](drive_core::Instant)), the
//!   [`Endpoint`](drive_core::Endpoint) interface of every sans-IO master and slave and the
//!   transaction skeleton ([`Exchange`](drive_core::Exchange));
//! * [`drive_profile::nord`]: NORD's parameter table with resolution scaling, control/status
//!   words and state machine, the USS AK/PWE error tables and the CTT2 codes.
//!
//! Like every protocol crate of drivebus it is sans-IO (no I/O, no clock: time is an argument)
//! and `no_std` without its default `std` feature.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

#[cfg(feature = "tokio")]
pub mod client;
pub mod ctt2;
pub mod serial;
pub mod uss;
