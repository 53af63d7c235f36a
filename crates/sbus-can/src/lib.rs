//! `sbus-can`: SEW SBus, MOVILINK over CAN, for MOVIDRIVE drives, sans-IO (SEW serial
//! communication manual ch. 5 and 6.1).
//!
//! * [`ids`]: the identifiers of every telegram from the SBus address (P813), group address
//!   (P814) and synchronisation identifier (P817);
//! * [`telegram`]: the telegrams on CAN frames: SYNC, process data (three words) and the 8-byte
//!   parameter channel shared with MOVILINK ([`drive_profile::sew::ParamChannel`]);
//! * [`variable`]: variable telegrams (IPOS variables on free identifiers, MOTOROLA and INTEL
//!   byte order) and [`variable::VariableNode`], one device's cyclic, acyclic and receive
//!   objects as a sans-IO CAN endpoint;
//! * [`busload`]: the bus-load model (worst-case frame lengths) behind a cyclic object's
//!   free-capacity result;
//! * `plan` (feature `std`): the identifier plan checker for a whole bus (the rules of
//!   ch. 5.5, sync identifier, addresses, object limits).
//!
//! Frames are [`drive_core::can::CanFrame`], an [`embedded_can::Frame`](drive_core::can::Frame),
//! so any `embedded-can` driver can carry them. Like every protocol crate of drivebus this one
//! is sans-IO (no I/O, no clock: time is an argument) and `no_std` without its default `std`
//! feature.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

pub mod busload;
pub mod ids;
#[cfg(feature = "std")]
pub mod plan;
pub mod telegram;
pub mod variable;

pub use ids::{Address, Kind};
pub use telegram::{DecodeError, ProcessData, Telegram};
