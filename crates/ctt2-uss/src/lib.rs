//! `ctt2_uss`: placeholder crate of the drivebus workspace; its protocol arrives in a later issue.
//!
//! The crate is sans-IO and `no_std` like every protocol crate of drivebus.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
