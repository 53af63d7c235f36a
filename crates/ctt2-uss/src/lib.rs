//! `ctt2-uss`: NORD NORDAC LINK drives over AS-Interface CTT2, carrying USS PKW/PZD, sans-IO.
//!
//! The crate will hold the CTT2 frame types, the USS parameter (PKW) and process data (PZD)
//! channels carried in them, their codec and the master and slave state machines. It is a
//! placeholder for now: the protocol arrives with its own issue.
//!
//! What it builds on is in place:
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
