//! `bonfiglioli-modbus`: Modbus RTU and ASCII with Bonfiglioli's function codes 100/101 for
//! ACTIVE and ACTIVE Cube drives, sans-IO.
//!
//! The crate will hold the Modbus frame types with function codes 100/101, their codec, the
//! RTU and ASCII framing descriptions and the master and slave state machines. It is a
//! placeholder for now: the protocol arrives with its own issue.
//!
//! What it builds on is in place:
//!
//! * [`drive_core`]: the one time type ([`Instant`](drive_core::Instant)), line timing
//!   ([`LineSettings`](drive_core::LineSettings)), the generic character
//!   [`Receiver`](drive_core::Receiver) a framing description plugs into, the
//!   [`Endpoint`](drive_core::Endpoint) interface and the transaction skeleton
//!   ([`Exchange`](drive_core::Exchange));
//! * [`drive_profile::bonfiglioli`]: Bonfiglioli's parameter table, Modbus exceptions, VABus
//!   errors, control/status words and state machines.
//!
//! Like every protocol crate of drivebus it is sans-IO (no I/O, no clock: time is an argument)
//! and `no_std` without its default `std` feature.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
