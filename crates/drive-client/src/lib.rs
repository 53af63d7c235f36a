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
//! * one client per family: [`sew`] (MOVIDRIVE, written once over the [`sew::SewLink`] of
//!   MOVILINK and SBus), [`nord`] (NORDAC LINK over USS or CTT2), [`bonfiglioli`] (ACT/ACU over
//!   Modbus RTU or ASCII), each generic over the protocol crate's transport (`CharIo`, `CanIo`;
//!   opening a port is `drive-transport`'s);
//! * [`front`]: what a front end names in its own words where a client's message points at it
//!   (the command line's options, the gateway's config keys), and the notes it hears;
//! * [`backup`]: the `drivebus-backup` file (its bytes, and the checks of one read back) and
//!   the backup of a drive; [`restore`]: plan, apply and verify a restore, with typed skips,
//!   refusals and a half-finished restore that says what was and was not written; both tell a
//!   front end how far they are through [`Progress`];
//! * [`info`]: one parameter described (the table's entry, what the drive says of it, its value
//!   per set, element or data set with the typed refusal) and its `info --json` object;
//!   [`status`]: a drive's status and fault memory as typed readings; [`scan`]: one address
//!   probed, what answers there as a typed [`scan::Found`];
//! * [`motor`]: the rule of everything that enables or drives a motor — stopped on every early
//!   end ([`Interrupt`]), left running only on purpose — for every front end to say its way;
//!   `signals` (feature `signals`): `Interrupt::install` over SIGINT, SIGTERM, SIGHUP, SIGQUIT;
//! * [`watch`]: a [`watch::Sampler`] polling parameters at a steady rhythm, typed samples;
//! * [`outfile`]: output files written safely (regular files only, atomic, never replaced
//!   unasked); [`infile`]: input files read whole, never past a limit.
//!
//! Errors are typed and carry no front end's words: the command line and the gateway each say
//! them their own way.

#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod backup;
pub mod bonfiglioli;
pub mod client;
pub mod control;
pub mod front;
pub mod infile;
pub mod info;
pub mod interrupt;
pub mod meaning;
pub mod motor;
pub mod nord;
pub mod outfile;
pub mod progress;
pub mod restore;
pub mod scan;
pub mod sew;
#[cfg(feature = "signals")]
#[cfg_attr(docsrs, doc(cfg(feature = "signals")))]
pub mod signals;
pub mod status;
pub mod target;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod text;
pub mod watch;
pub mod wear;
pub mod write;

pub use client::{
    ClientError, DeviceCode, DeviceError, DeviceErrorKind, LinkError, LinkFault, ParamClient,
};
pub use front::{FrontEnd, Note, Plain, Setting};
pub use interrupt::{Cause, Interrupt};
pub use meaning::{Device, KnownVariant, Meaning};
pub use progress::{Notice, Phase, Progress};
pub use target::{
    Parsed, Target, TargetError, ValueError, ValueText, nord_sub, nord_sub_parts, nord_subs,
};
pub use wear::{FileWearLog, MemoryWearLog, WearLog, WearLogError};
pub use write::{WriteError, WriteRequest, Written};
