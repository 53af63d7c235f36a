//! `sbus-can`: SEW SBus, MOVILINK over CAN, for MOVIDRIVE drives, sans-IO (SEW serial
//! communication manual ch. 5 and 6.1).
//!
//! * [`ids`]: the identifiers of every telegram from the SBus address (P813), group address
//!   (P814) and synchronisation identifier (P817);
//! * [`telegram`]: the telegrams on CAN frames: SYNC, process data (three words) and the 8-byte
//!   parameter channel shared with MOVILINK ([`drive_profile::sew::ParamChannel`]);
//! * [`slave`]: the drive's side, a sans-IO [`Slave`](slave::Slave) on a [`Backend`](slave::Backend)
//!   (the drive), with the timing of ch. 5.1/5.2 (answers at once or after the SYNC, the PO
//!   sync window, group telegrams never answered);
//! * `sim` (feature `sim`): the simulated MOVIDRIVE on SBus, one drive or several behind one
//!   CAN interface, on `drive-sim`'s drive model;
//! * [`master`]: the sans-IO SBus master (parameter services in both handshake modes, group
//!   writes, process data, the SYNC producer, scan), a [`CanEndpoint`](drive_core::can::CanEndpoint);
//! * [`movlnk`]: the IPOSplus MOVLNK command (ch. 5.3) as typed data, and [`movlnk::MovlnkMaster`],
//!   the drive as SBus master;
//! * `driver` (feature `tokio`): `SbusDriver`, the async master over any `drive_core::rt::CanIo`.
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
#[cfg(feature = "tokio")]
pub mod driver;
pub mod ids;
pub mod master;
pub mod movlnk;
#[cfg(feature = "std")]
pub mod plan;
#[cfg(feature = "sim")]
pub mod sim;
pub mod slave;
pub mod telegram;
pub mod variable;

pub use ids::{Address, Kind};
pub use telegram::{DecodeError, ProcessData, Telegram};
