//! `sbus-can`: SEW SBus, MOVILINK over CAN, for MOVIDRIVE drives, sans-IO.
//!
//! The crate will hold SBus's frame types, their codec to and from CAN frames and the master
//! and slave state machines. It is a placeholder for now: the protocol arrives with its own
//! issue.
//!
//! What it builds on is in place:
//!
//! * [`drive_core`]: the one time type ([`Instant`](drive_core::Instant)), the
//!   [`Endpoint`](drive_core::Endpoint) interface of every sans-IO master and slave and the
//!   transaction skeleton ([`Exchange`](drive_core::Exchange));
//! * [`drive_profile::sew`]: SEW's parameter channel, services, return codes and control/status
//!   words, shared with MOVILINK and the simulated MOVIDRIVE.
//!
//! Like every protocol crate of drivebus it is sans-IO (no I/O, no clock: time is an argument)
//! and `no_std` without its default `std` feature.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
