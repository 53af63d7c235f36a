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
//! * `sim` (feature `sim`): what both simulated front-ends share — an order carried out on the
//!   drive model `drive_sim::nord::SimulatedNord`.
//!
//! It builds on:
//!
//! * [`drive_core`]: the one time type ([`Instant`](drive_core::Instant)), the
//!   [`Endpoint`](drive_core::Endpoint) interface of every sans-IO master and slave and the
//!   transaction skeleton ([`Exchange`](drive_core::Exchange));
//! * [`drive_profile::nord`]: NORD's parameter table with resolution scaling, control/status
//!   words and state machine, the USS AK/PWE error tables and the CTT2 codes.
//!
//! Features: `std` (default), `tokio` (the async drivers and the client), `sim` (simulated
//! drives on drive-sim's model, on a line and behind a simulated AS-i master).
//!
//! What a program needs is at the root: the drive's addresses ([`UssAddress`],
//! [`AsiAddress`], [`DoubleSlaveAddress`]), the USS telegram [`Layout`] and the PKW/PZD data
//! ([`Order`], [`Pkw`], [`Reply`], [`Storage`], [`PzdOut`], [`PzdIn`]); with `tokio` the
//! client over either transport (`NordClient`, `ClientConfig`, `ClientError` and `Address`,
//! which value of a parameter), the USS driver (`UssDriver`, `UssDriverConfig`,
//! `UssDriverError`) and the CTT2 driver over an AS-i master (`Ctt2Driver`, `Ctt2Link`,
//! `Ctt2DriverConfig`, `Ctt2DriverError`); with `sim` the simulated drives (`SimulatedDrive` on
//! a USS line, `SimulatedLink` with a `SimulatedDoubleSlave` for CTT2).
//! `examples/uss_read_param.rs` and `examples/ctt2_read_param.rs` read P102 from a simulated
//! drive in a dozen lines (`cargo run -p ctt2-uss --example uss_read_param`).
//!
//! Like every protocol crate of drivebus it is sans-IO (no I/O, no clock: time is an argument)
//! and `no_std` without its default `std` feature.
#![cfg_attr(not(feature = "std"), no_std)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![warn(missing_docs)]

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod client;
pub mod ctt2;
pub mod serial;
#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub mod sim;
pub mod uss;

pub use ctt2::{AsiAddress, DoubleSlaveAddress, IdObject};
pub use serial::{Layout, UssAddress};
pub use uss::{Order, Pkw, PkwError, PzdIn, PzdOut, Reply, Storage};

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub use client::{Address, ClientConfig, ClientError, NordClient};
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub use ctt2::master::{
    Ctt2Driver, Ctt2Link, DriverConfig as Ctt2DriverConfig, DriverError as Ctt2DriverError,
};
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub use serial::driver::{
    DriverConfig as UssDriverConfig, DriverError as UssDriverError, UssDriver,
};

#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub use ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub use serial::sim::SimulatedDrive;
