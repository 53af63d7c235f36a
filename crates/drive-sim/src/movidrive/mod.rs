//! A simulated SEW MOVIDRIVE, protocol-independent: the device that the MOVILINK (RS-485) and
//! SBus (CAN) slave front-ends put their codecs on. It speaks plain numbers only: parameter
//! services with a 16-bit index and 32-bit data, three process output words (PO, master →
//! drive) and three process input words (PI, drive → master).
//!
//! The model is documented in `docs/protocols/movidrive-profile.md` together with its sources
//! (SEW serial communication manual ch. 4, 6.2 and 7; the SEW fieldbus unit profile) and every
//! simulator choice. In short:
//!
//! * **Parameters** come from the generated table [`drive_profile::sew::params`] (RAM and
//!   EEPROM values, access flags, ranges, value lists) in a [`ParamStore`]; the services of
//!   [`Service`](sew::Service) answer with the 32-bit data or a [`ReturnCode`](sew::ReturnCode), in
//!   the parameter channel's own types ([`Movidrive::param`] takes a [`ParamChannel`](sew::ParamChannel)),
//!   shared with the MOVILINK and SBus front-ends.
//! * **Process data** are mapped by P870–P872 (PO) and P873–P875 (PI) and taken only while
//!   P876 "PO data enable" is ON. The control word acts only when P101 "control signal source"
//!   is a bus (RS-485, fieldbus, SBus), the speed setpoint only when P100 "setpoint source" is a
//!   bus; see [`Movidrive::set_bus_control`].
//! * **Control word 1/2** ([`ControlWord1`](sew::ControlWord1), basic control block) drive the
//!   [`SimDrive`] state machine: bit 0
//!   controller inhibit, bit 1 rapid stop (active low), bit 2 stop (active low), bit 4
//!   integrator switchover, bit 5 parameter set switchover, bit 6 fault reset (rising edge).
//! * **Ramps** per P130–P137 (parameter set 1) and P140–P147 (set 2), reference 3000 1/min.
//! * **RS-485 timeout** per P812 (ms, 0 = off) with the P833 reaction; fault number 43.
//! * **SBus** (`sbus.rs`): P813–P817 live, the SBus timeout P815 with the P836 reaction
//!   (fault 47, the same reaction machinery as RS-485), master-slave operation (P750/P751,
//!   P100 = MASTER-SBus).
//!
//! Time is always an argument ([`Instant`]); nothing reads a clock. The model lives in
//! `mod.rs` (the device, identity, power), `services.rs` (parameter services), `process.rs`
//! (process data), `control.rs` (control word, ramps, RS-485 timeout) and `status.rs` (status
//! words and actual values); `profile.rs` has the value lists of P870–P876 and P833.
//!
//! # Example
//!
//! ```
//! use std::time::Duration;
//! use drive_sim::Instant;
//! use drive_profile::sew::ControlWord1;
//! use drive_sim::movidrive::{BusSource, Movidrive};
//!
//! let mut drive = Movidrive::new(1);
//! drive.set_bus_control(BusSource::Rs485, Instant::ZERO);
//! // PO1 = control word 1 (enable), PO2 = speed 5000 × 0.2 = 1000 1/min
//! drive.process_output(&[ControlWord1::ENABLE.bits(), 5000], Instant::ZERO);
//! drive.tick(Instant::ZERO + Duration::from_millis(2000)); // P130 = 2 s per 3000 1/min
//! assert!((drive.actual_speed_rpm() - 1000.0).abs() < 1e-9);
//! let mut pi = [0u16; 3];
//! drive.process_input(&mut pi);
//! assert_eq!(pi[1], 5000); // PI2 = actual speed
//! ```

use core::fmt;
use std::time::Duration;

use drive_profile::sew;
pub use drive_profile::sew::index;

use crate::drive::{SimDrive, SpeedMapping};
use crate::store::{ParamStore, StoreOptions};
use drive_core::Instant;

mod control;
mod process;
mod profile;
mod sbus;
mod services;
mod status;

pub use profile::{BusSource, PiFunction, PoFunction, TimeoutReaction};
pub use sbus::{FAULT_SBUS_TIMEOUT, MasterSlave, MasterSlaveError};
pub use services::{attribute_byte, return_code};

use profile::{PO_WORDS, QuickRamp};

/// SEW fault number of "RS-485 timeout" (F43 in SEW's fault list).
pub const FAULT_RS485_TIMEOUT: u16 = 43;

/// P070 unit type as the simulator reports it (simulator choice: the manual gives no coding;
/// the digits spell MDX60A 0015-5-3, i.e. series 60, 1.5 kW, 380–500 V, 3 phases).
pub const UNIT_TYPE: u32 = 60_001_553;

/// P076 firmware of the basic unit as the simulator reports it: part number 822 609, version
/// 7.11, in the manual's format "822609711 = 822 609 7.11" (the manual's own example number,
/// reused as a simulator choice).
pub const FIRMWARE: u32 = 822_609_711;

/// P071 unit rated current in 0.001 A (simulator choice: 4.0 A, an MDX60A0015-5A3).
pub const RATED_CURRENT_MA: i64 = 4_000;

/// P008 DC link voltage in 0.001 V (simulator choice: constant 560 V, a 400 V supply).
pub const DC_LINK_VOLTAGE_MV: i64 = 560_000;

/// A simulated MOVIDRIVE: a [`SimDrive`] built from the SEW parameter table plus the fieldbus
/// unit profile (process data, control and status words, RS-485 timeout monitor).
pub struct Movidrive {
    drive: SimDrive,
    /// Last process output words taken (PO data enabled).
    po: [u16; PO_WORDS],
    /// Fault-reset bit of the last control word taken (for the rising edge).
    reset_bit: bool,
    /// Time of the last cyclic request telegram since the monitor was (re-)armed.
    last_cyclic: Option<Instant>,
    /// After power-on / fault reset with the monitor on: enable is held off until the first
    /// cyclic request telegram.
    held: bool,
    /// Active timeout warning (warning reactions and "display fault") and its fault number
    /// (43 RS-485, 47 SBus).
    warning: Option<(TimeoutReaction, u16)>,
    /// Time of the last SBus process data since the SBus monitor (P815) was (re-)armed.
    sbus_last: Option<Instant>,
    /// After power-on / fault reset: with the SBus monitor on, enable is held off until the
    /// first SBus process data (display "t", ch. 6.1).
    sbus_awaiting: bool,
    /// The ramp of a running fault reaction with quick stop.
    fault_ramp: QuickRamp,
    /// Actual position in increments (integrated from the speed).
    position: f64,
    /// Time and speed of the last position update.
    last_update: Option<(Instant, f64)>,
}

impl fmt::Debug for Movidrive {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Movidrive")
            .field("address", &self.address())
            .field("po", &self.po)
            .field("held", &self.held)
            .field("warning", &self.warning)
            .field("sbus_last", &self.sbus_last)
            .field("last_cyclic", &self.last_cyclic)
            .field("drive", &self.drive)
            .finish_non_exhaustive()
    }
}

impl Movidrive {
    /// A MOVIDRIVE at RS-485 address `address` (P810, clamped to its range 0…99), every other
    /// parameter at its table default, standstill under controller inhibit.
    ///
    /// With the table defaults P100/P101 select the terminals, so process data do not move the
    /// drive until [`Movidrive::set_bus_control`] (or a write of P100/P101) selects a bus.
    pub fn new(address: u8) -> Movidrive {
        let store = ParamStore::with_options(
            sew::params(),
            StoreOptions {
                value_lists_exhaustive: true,
                lock_index: Some(index::PARAMETER_LOCK),
                ..StoreOptions::default()
            },
        );
        let mut drive = SimDrive::new(store);
        let _ = drive.set_speed_actual_mapping(Some(SpeedMapping {
            index: index::SPEED,
            sub: 0,
            to_raw: |rpm| (rpm * 1000.0).round() as i64,
        }));
        let store = drive.store_mut();
        // P852's second index; the generated table holds it as `index2` of the P852 row.
        if let Some(p852) = sew::params()
            .iter()
            .find(|p| p.index2 == Some(index::USER_UNIT_2))
        {
            let _ = store.add_second_index(index::USER_UNIT_2, p852, p852.default2);
        }
        let _ = store.set_internal(index::UNIT_TYPE, i64::from(UNIT_TYPE));
        let _ = store.set_internal(index::FIRMWARE, i64::from(FIRMWARE));
        let _ = store.set_internal(index::RATED_CURRENT, RATED_CURRENT_MA);
        let _ = store.set_internal(index::RS485_ADDRESS, i64::from(address.min(99)));
        let mut md = Movidrive {
            drive,
            po: [0; PO_WORDS],
            reset_bit: false,
            last_cyclic: None,
            held: false,
            warning: None,
            sbus_last: None,
            sbus_awaiting: true,
            fault_ramp: QuickRamp::Rapid,
            position: 0.0,
            last_update: None,
        };
        md.held = md.rs485_timeout().is_some();
        md.update(Instant::ZERO);
        md
    }

    // ----- identity and communication settings -----

    /// RS-485 address (P810).
    pub fn address(&self) -> u8 {
        self.param_u8(index::RS485_ADDRESS)
    }

    /// RS-485 group address (P811; 100 = no group).
    pub fn group_address(&self) -> u8 {
        self.param_u8(index::RS485_GROUP_ADDRESS)
    }

    /// RS-485 timeout time (P812, ms); `None` when 0 (monitoring off).
    pub fn rs485_timeout(&self) -> Option<Duration> {
        let ms = self.value(index::RS485_TIMEOUT);
        u64::try_from(ms)
            .ok()
            .filter(|&ms| ms > 0)
            .map(Duration::from_millis)
    }

    /// The reaction to an RS-485 timeout (P833).
    pub fn rs485_timeout_reaction(&self) -> TimeoutReaction {
        TimeoutReaction::from_raw(self.value(index::RS485_TIMEOUT_REACTION))
            .unwrap_or(TimeoutReaction::RapidStopWarning)
    }

    /// Select `source` as setpoint source (P100) and control signal source (P101), in RAM and
    /// EEPROM, as a commissioning tool would; no EEPROM write is counted. Acts at `now`.
    pub fn set_bus_control(&mut self, source: BusSource, now: Instant) {
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::SETPOINT_SOURCE, source.setpoint_source());
        let _ = store.set_internal(index::CONTROL_SOURCE, source.control_source());
        self.update(now);
    }

    /// Whether the PO data are enabled (status word 1 bit 2): P876 = ON and P100 or P101 select
    /// a bus (RS-485, fieldbus or SBus).
    pub fn po_data_enabled(&self) -> bool {
        self.value(index::PO_DATA_ENABLE) == 1
            && (self.setpoint_from_bus() || self.control_from_bus())
    }

    // ----- time, power -----

    /// Advance the model to `now`: RS-485 timeout monitor, control, ramp, actual values.
    pub fn tick(&mut self, now: Instant) {
        self.update(now);
    }

    /// Power cycle at `now`: RAM ← EEPROM, controller inhibit, standstill, PO buffer cleared;
    /// held in the safe state if the RS-485 or SBus timeout monitor is on.
    pub fn restart(&mut self, now: Instant) {
        self.drive.restart(now);
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::UNIT_TYPE, i64::from(UNIT_TYPE));
        let _ = store.set_internal(index::FIRMWARE, i64::from(FIRMWARE));
        let _ = store.set_internal(index::RATED_CURRENT, RATED_CURRENT_MA);
        self.po = [0; PO_WORDS];
        self.reset_bit = false;
        self.last_cyclic = None;
        self.warning = None;
        self.held = self.rs485_timeout().is_some();
        self.sbus_last = None;
        self.sbus_awaiting = true;
        self.last_update = None;
        self.update(now);
    }
}
