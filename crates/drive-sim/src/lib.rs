//! Simulated drives for the drivebus workspace: one drive model that every protocol front-end
//! (MOVILINK, SBus, CTT2/USS, Bonfiglioli Modbus) puts a thin slave on.
//!
//! * [`ParamStore`]: the parameters of any family table ([`drive_profile::ParamMeta`]), with
//!   RAM and EEPROM values, access checks (read-only, `R`, not in operation, parameter lock,
//!   range, value lists), EEPROM write counters and restart semantics.
//! * [`DriveStateMachine`]: [`DriveState`] and the [`Command`]s enable, inhibit, stop, quick
//!   stop and fault reset, with a configurable [`FaultReaction`].
//! * [`Ramp`]: setpoint and actual speed in 1/min with SEW-style ramp times (per
//!   [`RampConfig::reference_speed`], 3000 1/min by default).
//! * [`FaultInjector`]: delayed and dropped answers, driven by the seeded
//!   [`drive_core::SplitMix64`].
//! * [`SimDrive`]: all of the above, advanced with [`SimDrive::tick`].
//! * [`Ticker`]: a [`Timed`] model woken every period while it is busy, between requests.
//! * Family models on top: [`movidrive::Movidrive`] (SEW MOVIDRIVE) and
//!   [`bonfiglioli::SimulatedBonfiglioli`] (Bonfiglioli ACT / ACU, parameters by number, data
//!   set and width, refusals as Modbus exception + VABus error register) and
//!   [`nord::SimulatedNord`] (NORD NORDAC LINK SK 270E/280E-FDS: parameters by PNU, array
//!   element and parameter set, refusals as USS PWE2 error numbers, process data, AS-i BusIO
//!   bits).
//!
//! # Time
//!
//! The crate never reads a clock and does no I/O. Time is an [`Instant`] argument (drivebus's
//! one time type, from `drive-core`): nanoseconds
//! since an epoch the caller picks. Tests step it by hand; a front-end on tokio converts its
//! (possibly paused) clock.
//!
//! # Errors
//!
//! Refusals are a typed [`SimError`] that front-ends map onto their own return codes.
//!
//! # Example
//!
//! ```
//! use std::time::Duration;
//! use drive_profile::{Access, Family, ParamMeta};
//! use drive_profile::scaling::ScaleError;
//! use drive_sim::{DriveState, Instant, ParamStore, Persistence, SimDrive, SimError, SpeedMapping};
//!
//! // A two-parameter table; real front-ends use `drive_profile::sew::params()` and friends.
//! struct Row { index: u16, access: Access, default: i64, range: Option<(i64, i64)> }
//! impl ParamMeta for Row {
//!     fn family(&self) -> Family { Family::Movidrive }
//!     fn number(&self) -> Option<u16> { None }
//!     fn bus_index(&self) -> u16 { self.index }
//!     fn name_de(&self) -> &'static str { "" }
//!     fn name_en(&self) -> &'static str { "" }
//!     fn unit(&self) -> &'static str { "" }
//!     fn access(&self) -> Access { self.access }
//!     fn default_raw(&self) -> Option<i64> { Some(self.default) }
//!     fn raw_range(&self) -> Option<(i64, i64)> { self.range }
//!     fn range_de(&self) -> &'static str { "" }
//!     fn range_en(&self) -> &'static str { "" }
//!     fn decimals(&self) -> u8 { 0 }
//!     fn to_physical(&self, raw: i64) -> f64 { raw as f64 }
//!     fn from_physical(&self, v: f64) -> Result<i64, ScaleError> { Ok(v as i64) }
//! }
//! static TABLE: [Row; 2] = [
//!     // actual speed, read-only, 0.001 1/min
//!     Row { index: 8318, access: Access::READ_ONLY, default: 0, range: None },
//!     // ramp up in ms, N/RW
//!     Row {
//!         index: 8470,
//!         access: Access::NON_VOLATILE.union(Access::READ_WRITE),
//!         default: 2000,
//!         range: Some((0, 2_000_000)),
//!     },
//! ];
//!
//! let mut drive = SimDrive::new(ParamStore::new(&TABLE));
//! drive.set_speed_actual_mapping(Some(SpeedMapping {
//!     index: 8318,
//!     sub: 0,
//!     to_raw: |rpm| (rpm * 1000.0).round() as i64,
//! }))?;
//!
//! let t0 = Instant::ZERO;
//! assert_eq!(drive.write(8318, 0, 5, Persistence::Volatile, t0), Err(SimError::ReadOnly { index: 8318 }));
//! drive.write(8470, 0, 1000, Persistence::NonVolatile, t0)?;
//! assert_eq!(drive.store().nv_writes(8470, 0)?, 1);
//!
//! drive.set_setpoint(1500.0, t0)?;
//! assert_eq!(drive.enable(t0)?, DriveState::Enabled);
//! drive.tick(t0 + Duration::from_millis(250)); // 1 s per 3000 1/min
//! assert_eq!(drive.actual_speed(), 750.0);
//! assert_eq!(drive.read(8318, 0)?, 750_000);
//! # Ok::<(), SimError>(())
//! ```
#![warn(missing_docs)]

pub mod bonfiglioli;
mod drive;
mod error;
pub mod inject;
pub mod movidrive;
pub mod nord;
pub mod ramp;
pub mod state;
pub mod store;
pub mod ticker;

pub use drive::{SimDrive, SpeedMapping, TickHook};
pub use drive_core::Instant;
pub use error::SimError;
pub use inject::{FaultInjector, Response};
pub use ramp::{Ramp, RampConfig, RampMode};
pub use state::{Command, DriveState, DriveStateMachine, FaultReaction};
pub use store::{Meta, OperatingCondition, ParamStore, Persistence, StoreOptions};
pub use ticker::{Ticker, Timed};
