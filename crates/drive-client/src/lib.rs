//! Work with a drive by its parameter table, the same for every family and every front end
//! (the command line, the gateway, a program of yours):
//!
//! * [`Target`]: a parameter as a front end names it (`P130`, `P102` in parameter set 2,
//!   `372` in data set 3), resolved from the family's generated table, with values read from
//!   text, scaled and checked ([`ValueError`]);
//! * [`ParamClient`]: read and write a parameter by its table entry, what each family's client
//!   implements over its protocol crate; [`ClientError`] keeps a drive's refusal apart from a
//!   failing link;
//! * [`write`](mod@write): the one write path (width, table, guard, the EEPROM-wear rule of a [`WearLog`],
//!   link settings only when confirmed, the write, the read-back) with typed refusals
//!   ([`WriteError`]);
//! * [`meaning`]: what a raw value means (value names, decoded status and fault words);
//! * [`text`]: values as text and strict number parsing;
//! * [`motor`]: the rule of everything that enables or drives a motor — stopped on every early
//!   end ([`Interrupt`]), left running only on purpose — for every front end to say its way.
//!
//! Errors are typed and carry no front end's words: the command line and the gateway each say
//! them their own way.

#![warn(missing_docs)]

pub mod client;
pub mod interrupt;
pub mod meaning;
pub mod motor;
pub mod target;
pub mod text;
pub mod wear;
pub mod write;

pub use client::{ClientError, DeviceError, DeviceErrorKind, ParamClient};
pub use interrupt::{Cause, Interrupt};
pub use meaning::{Device, KnownVariant, Meaning};
pub use target::{
    Parsed, Target, TargetError, ValueError, ValueText, nord_sub, nord_sub_parts, nord_subs,
};
pub use wear::{FileWearLog, MemoryWearLog, WearLog, WearLogError};
pub use write::{WriteError, WriteRequest, Written};
