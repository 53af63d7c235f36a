//! Drive profiles for the drivebus workspace.
//!
//! * Parameter metadata generated from the vendor manuals ([`sew`], [`nord`], [`bonfiglioli`]),
//!   with lookups by bus index, by menu/parameter number and by name, none of which allocate.
//! * Every table column of a parameter row as a typed value ([`ParamMeta::columns`], keys in
//!   [`COLUMN_KEYS`], see [`columns`]), for output such as `drivectl params --json`.
//! * Scaling between raw bus values and physical values ([`scaling`], and per family: PNO
//!   size/conversion index for SEW, resolution for NORD, decimals for Bonfiglioli).
//! * Control and status words as typed bit sets and DRIVECOM-style state machines per family
//!   ([`state`]).
//! * The family-generic write guard (`guard`, feature `std`): width, access, range, value list
//!   and EEPROM wear, for every family's table.
//!
//! The crate is `no_std` without its default `std` feature.
//!
//! ```
//! use drive_profile::scaling::{percent_from_word, percent_to_word};
//! assert_eq!(percent_to_word(-100.0), Ok(0xC000));
//! assert_eq!(percent_from_word(0x4000), 100.0);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![warn(missing_docs)]

pub mod bonfiglioli;
pub mod columns;
pub mod family;
#[cfg(feature = "std")]
#[cfg_attr(docsrs, doc(cfg(feature = "std")))]
pub mod guard;
#[allow(missing_docs, clippy::all)]
#[rustfmt::skip]
pub mod generated;
pub mod nord;
pub mod param;
pub mod scaling;
pub mod sew;
pub mod state;
mod words;

pub use columns::{COLUMN_KEYS, Column};
pub use param::{Access, Family, Label, ParamMeta, Persistence, ValueName};
