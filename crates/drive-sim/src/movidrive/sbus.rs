//! What the drive does for SBus (serial communication manual ch. 5, 6.1): its settings P813–P817
//! read live, the SBus timeout monitor (P815, reaction P836, fault 47) on the reactions shared
//! with RS-485, and master-slave operation (ch. 5.4, parameter group P75_).
//!
//! * **Monitor.** On while P815 is neither 0 nor 650 s (both mean off, ch. 5.1) and SBus is a
//!   control or setpoint source (P100 = SBus or MASTER-SBus, P101 = SBus). Process data for the
//!   drive (PO, PO sync taken at its SYNC, GPO of its group) feed it
//!   ([`Movidrive::sbus_process_data_received`]); parameter telegrams and SYNC do not (ch. 6.1:
//!   "F47 … es werden keine Prozessdaten über den SBus empfangen → Senden von Prozessdaten").
//!   It fires the first nanosecond after P815 without process data
//!   ([`Movidrive::sbus_deadline`]) with the reaction of P836, but only while the drive is
//!   enabled (ch. 6.1: "Gerät ist freigegeben und …"); otherwise it lapses until the next
//!   process data. After power-on and fault reset the drive is held off ("t") until the first
//!   process data (ch. 6.1), like the RS-485 monitor.
//! * **Master-slave.** The master is the drive whose P750 "slave setpoint" sends the speed over
//!   SBus (2 = speed (SBus), 3 = speed (RS485+SBus)); it sends, every 1 ms, a group process
//!   telegram to its group (P814): PO1 control word 1 (enable while its output stage is on,
//!   else controller inhibit), PO2 its speed (ramp output) × P751 in 0.2 1/min, PO3 0
//!   ([`Movidrive::master_group_output`]). Only at 500 and 1000 kbit/s (P816, ch. 5.4): at
//!   125/250 kbit/s it refuses with [`MasterSlaveError::BitrateNotAllowed`]. A slave is a
//!   drive with P100 = MASTER-SBus (8): the firmware assigns its PO words (control word 1,
//!   speed, IPOS), so it follows the master's control word and speed through its own ramps.
//!   Where P750/P751 are set (the master) follows the SEW MOVITRAC B manual's parameter group
//!   75 ("P100 = Master SBus must be set at the slave"; P750 makes a drive the master).

use core::fmt;
use std::time::Duration;

use drive_core::can::Bitrate;
use drive_profile::sew::{ControlWord1, index};

use super::Movidrive;
use super::profile::{RPM_PER_DIGIT, TimeoutReaction};
use crate::state::DriveState;
use drive_core::Instant;

/// SEW fault number of "SBus timeout" (F47 "TIMEOUT SBUS", manual ch. 6.1).
pub const FAULT_SBUS_TIMEOUT: u16 = 47;

/// P750 "slave setpoint".
const SLAVE_SETPOINT: u16 = 8592;
/// P751 "scaling slave setpoint" (×1000).
const SLAVE_SCALING: u16 = 8593;
/// P100 value "MASTER-SBus".
const SETPOINT_MASTER_SBUS: i64 = 8;
/// P815 raw value that means "off" besides 0: 650 s.
const SBUS_TIMEOUT_OFF_MS: i64 = 650_000;

/// The drive's role in master-slave operation (ch. 5.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MasterSlave {
    /// Neither.
    Off,
    /// Sends its speed to its group every 1 ms (P750 = speed via SBus).
    Master,
    /// Follows the master of its group (P100 = MASTER-SBus).
    Slave,
}

/// Why a master drive does not send.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum MasterSlaveError {
    /// P816 is 125 or 250 kbit/s; master-slave operation needs 500 or 1000 (ch. 5.4).
    BitrateNotAllowed {
        /// The bit rate set in P816.
        bitrate: Bitrate,
    },
    /// P750 asks for torque or load sharing over SBus, which the simulator does not model.
    NotModelled {
        /// The raw P750 value.
        p750: i64,
    },
}

impl fmt::Display for MasterSlaveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MasterSlaveError::BitrateNotAllowed { bitrate } => write!(
                f,
                "master-slave operation needs 500 or 1000 kbit/s (P816), the drive is set to {bitrate}"
            ),
            MasterSlaveError::NotModelled { p750 } => write!(
                f,
                "P750 = {p750} (torque or load sharing over SBus) is not simulated; use 2 (speed, SBus)"
            ),
        }
    }
}

impl std::error::Error for MasterSlaveError {}

impl Movidrive {
    /// P813 SBus address (0–63).
    pub fn sbus_address(&self) -> u8 {
        self.param_u8(index::SBUS_ADDRESS).min(63)
    }

    /// Set P813 to `address` (clamped to 0–63) in RAM and EEPROM, as a commissioning tool
    /// would; no EEPROM write is counted.
    pub fn set_sbus_address(&mut self, address: u8) {
        let _ = self
            .drive
            .store_mut()
            .set_internal(index::SBUS_ADDRESS, i64::from(address.min(63)));
    }

    /// P814 SBus group address (0–63).
    pub fn sbus_group_address(&self) -> u8 {
        self.param_u8(index::SBUS_GROUP_ADDRESS).min(63)
    }

    /// P815 SBus timeout; `None` when 0 or 650 s (monitoring off).
    pub fn sbus_timeout(&self) -> Option<Duration> {
        let ms = self.value(index::SBUS_TIMEOUT);
        if ms == SBUS_TIMEOUT_OFF_MS {
            return None;
        }
        u64::try_from(ms)
            .ok()
            .filter(|&ms| ms > 0)
            .map(Duration::from_millis)
    }

    /// P816 SBus bit rate (0 = 125, 1 = 250, 2 = 500, 3 = 1000 kbit/s; the factory setting
    /// 500 for anything else).
    pub fn sbus_bitrate(&self) -> Bitrate {
        match self.value(index::SBUS_BAUD_RATE) {
            0 => Bitrate::K125,
            1 => Bitrate::K250,
            3 => Bitrate::M1,
            _ => Bitrate::K500,
        }
    }

    /// P817 SBus sync identifier, 0–2047 (the table holds it × 1000: raw 1000 = identifier 1).
    pub fn sbus_sync_id(&self) -> u16 {
        u16::try_from(self.value(index::SBUS_SYNC_ID) / 1000)
            .unwrap_or(0)
            .min(2047)
    }

    /// The reaction to an SBus timeout (P836, value list of P830; factory setting 3,
    /// emergency stop / fault).
    pub fn sbus_timeout_reaction(&self) -> TimeoutReaction {
        TimeoutReaction::from_raw(self.value(index::SBUS_TIMEOUT_REACTION))
            .unwrap_or(TimeoutReaction::EmergencyStopFault)
    }

    /// Whether SBus is a control or setpoint source (P100 = SBus / MASTER-SBus, P101 = SBus).
    pub fn sbus_selected(&self) -> bool {
        matches!(self.value(index::SETPOINT_SOURCE), 8 | 10)
            || self.value(index::CONTROL_SOURCE) == 3
    }

    /// Whether the SBus monitor is on (P815 set and SBus selected).
    pub fn sbus_monitored(&self) -> bool {
        self.sbus_timeout().is_some() && self.sbus_selected()
    }

    /// Whether the drive is held in the safe state ("t") until the first SBus process data.
    pub fn sbus_held(&self) -> bool {
        self.sbus_awaiting && self.sbus_monitored()
    }

    /// SBus process data for this drive (PO, PO sync at its SYNC, GPO) arrived at `now`:
    /// feeds the SBus monitor, releases the safe state, ends an SBus timeout warning. Call it
    /// before [`Movidrive::process_output`] at the same instant.
    pub fn sbus_process_data_received(&mut self, now: Instant) {
        self.update(now);
        self.sbus_last = Some(now);
        self.sbus_awaiting = false;
        if self
            .warning
            .is_some_and(|(_, fault)| fault == FAULT_SBUS_TIMEOUT)
        {
            self.warning = None;
        }
        self.update(now);
    }

    /// When the SBus monitor fires if no process data come first: the first nanosecond after
    /// P815 since the last process data (data exactly P815 later are in time). `None` while
    /// the monitor is off or not armed.
    pub fn sbus_deadline(&self) -> Option<Instant> {
        if !self.sbus_monitored() {
            return None;
        }
        let (timeout, last) = (self.sbus_timeout()?, self.sbus_last?);
        Some(last + timeout + Duration::from_nanos(1))
    }

    /// Fire the SBus timeout at its deadline if it has passed.
    pub(super) fn check_sbus_timeout(&mut self, now: Instant) {
        let (Some(fires), Some(timeout), Some(last)) =
            (self.sbus_deadline(), self.sbus_timeout(), self.sbus_last)
        else {
            return;
        };
        if now < fires {
            return;
        }
        let deadline = last + timeout;
        self.sbus_last = None;
        // Bring the drive to the deadline first: was it enabled then?
        self.apply_control(deadline);
        self.drive.tick(deadline);
        self.publish(deadline);
        if self.drive.state() == DriveState::Enabled {
            let reaction = self.sbus_timeout_reaction();
            self.link_timeout(reaction, FAULT_SBUS_TIMEOUT, deadline);
        }
    }

    /// The drive's master-slave role (P750, P100).
    pub fn master_slave(&self) -> MasterSlave {
        if matches!(self.value(SLAVE_SETPOINT), 2 | 3 | 5 | 6 | 8 | 9) {
            MasterSlave::Master
        } else if self.master_slave_slave() {
            MasterSlave::Slave
        } else {
            MasterSlave::Off
        }
    }

    /// P100 = MASTER-SBus.
    pub(super) fn master_slave_slave(&self) -> bool {
        self.value(index::SETPOINT_SOURCE) == SETPOINT_MASTER_SBUS
    }

    /// The group process telegram a master sends now (PO1 control word 1, PO2 speed × P751,
    /// PO3 0); `Ok(None)` for a drive that is no master; the reason a master may not send.
    pub fn master_group_output(&self) -> Result<Option<[u16; 3]>, MasterSlaveError> {
        let p750 = self.value(SLAVE_SETPOINT);
        match p750 {
            2 | 3 => {}
            5 | 6 | 8 | 9 => return Err(MasterSlaveError::NotModelled { p750 }),
            _ => return Ok(None),
        }
        let bitrate = self.sbus_bitrate();
        if bitrate < Bitrate::K500 {
            return Err(MasterSlaveError::BitrateNotAllowed { bitrate });
        }
        let (cw, rpm) = if self.output_stage_enabled() {
            let scale = self.value(SLAVE_SCALING) as f64 / 1000.0;
            (ControlWord1::ENABLE, self.drive.actual_speed() * scale)
        } else {
            (ControlWord1::INHIBIT, 0.0)
        };
        let digits = (rpm / RPM_PER_DIGIT)
            .round()
            .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16;
        Ok(Some([cw.bits(), digits as u16, 0]))
    }
}
