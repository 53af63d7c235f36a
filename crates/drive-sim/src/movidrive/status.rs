//! Status words 1 and 2, the actual values the drive shows, and the display parameters they are
//! mirrored into.

use drive_profile::sew::{StatusWord1, UnitStatus, index};

use super::profile::{INC_PER_REV, LOAD_PERCENT, MAGNETISING_PERCENT};
use super::{DC_LINK_VOLTAGE_MV, Movidrive, RATED_CURRENT_MA};
use crate::drive::SimDrive;
use crate::state::{DriveState, FaultReaction};
use drive_core::Instant;

impl Movidrive {
    /// Status word 1: basic status block in the low byte; in the high byte the fault number
    /// while bit 5 is set, else the unit status (1 controller inhibit, 2 no enable, 4 enable).
    pub fn status_word_1(&self) -> u16 {
        let high = match self.fault_number() {
            Some(code) => u8::try_from(code).unwrap_or(u8::MAX),
            None => self.unit_status().code(),
        };
        self.basic_status_block().with_high_byte(high).bits()
    }

    /// Status word 2: basic status block in the low byte; high byte = virtual output terminals:
    /// bit 8 DB00 /brake (1 = brake released), bit 9 DO01 and bit 10 DO02 with their P620/P621
    /// functions (factory setting: ready, /fault); bits 11–15 0.
    pub fn status_word_2(&self) -> u16 {
        let brake_released = u16::from(self.output_stage_enabled()) << 8;
        let do01 = u16::from(self.binary_output(self.value(index::DO01))) << 9;
        let do02 = u16::from(self.binary_output(self.value(index::DO02))) << 10;
        brake_released | do01 | do02 | self.basic_status_block().bits()
    }

    /// The fault number shown (drive fault, or a timeout warning's 43 or 47).
    pub fn fault_number(&self) -> Option<u16> {
        self.drive
            .state()
            .fault_code()
            .or(self.warning.map(|(_, fault)| fault))
    }

    /// Whether the output stage is enabled (status word 1 bit 0): enabled, or still
    /// decelerating after stop / rapid stop / a quick-stop fault reaction; the output stage is
    /// inhibited once the motor stands still in those states.
    pub fn output_stage_enabled(&self) -> bool {
        match self.drive.state() {
            DriveState::Enabled => true,
            DriveState::Ready | DriveState::QuickStop => self.drive.motor_turning(),
            DriveState::Fault(_) => {
                self.drive.fault_reaction() == FaultReaction::QuickStop
                    && self.drive.motor_turning()
            }
            DriveState::Inhibited => false,
        }
    }

    /// Actual speed in 1/min.
    pub fn actual_speed_rpm(&self) -> f64 {
        self.drive.actual_speed()
    }

    /// Output current in % of the unit rated current (simulator model: 0 with the output stage
    /// inhibited, else 20 % + 60 % × |n| / n_max).
    pub fn output_current_percent(&self) -> f64 {
        if !self.output_stage_enabled() {
            return 0.0;
        }
        MAGNETISING_PERCENT + LOAD_PERCENT * self.speed_ratio().abs()
    }

    /// Active current in % of the unit rated current (simulator model: 60 % × n / n_max, signed).
    pub fn active_current_percent(&self) -> f64 {
        if !self.output_stage_enabled() {
            return 0.0;
        }
        LOAD_PERCENT * self.speed_ratio()
    }

    /// Actual position in increments (4096 per revolution, integrated from the speed).
    pub fn position_increments(&self) -> i32 {
        let p = self.position.round();
        if p.is_finite() {
            p.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
        } else {
            0
        }
    }

    /// The simulated drive core.
    pub fn drive(&self) -> &SimDrive {
        &self.drive
    }

    /// The simulated drive core, mutably (the profile re-applies the control word at the next
    /// call that takes a time).
    pub fn drive_mut(&mut self) -> &mut SimDrive {
        &mut self.drive
    }

    /// Mirror actual values into the display parameters.
    pub(super) fn publish(&mut self, now: Instant) {
        let rpm = self.drive.actual_speed();
        if let Some((t, last_rpm)) = self.last_update
            && now > t
        {
            let secs = now.saturating_duration_since(t).as_secs_f64();
            self.position += (rpm + last_rpm) / 2.0 / 60.0 * secs * INC_PER_REV;
        }
        let t = self.last_update.map_or(now, |(t, _)| t.max(now));
        self.last_update = Some((t, rpm));
        let current = self.output_current_percent();
        let active = self.active_current_percent();
        let status = i64::from(self.status_word_1());
        let position = i64::from(self.position_increments());
        let store = self.drive.store_mut();
        let _ = store.set_internal(index::FREQUENCY, (rpm / 30.0 * 1000.0).round() as i64);
        let _ = store.set_internal(index::POSITION, position);
        let _ = store.set_internal(
            index::OUTPUT_CURRENT_PERCENT,
            (current * 1000.0).round() as i64,
        );
        let _ = store.set_internal(
            index::ACTIVE_CURRENT_PERCENT,
            (active * 1000.0).round() as i64,
        );
        let _ = store.set_internal(
            index::OUTPUT_CURRENT_AMPERE,
            (current / 100.0 * RATED_CURRENT_MA as f64).round() as i64,
        );
        let _ = store.set_internal(index::DC_LINK_VOLTAGE, DC_LINK_VOLTAGE_MV);
        let _ = store.set_internal(index::DRIVE_STATUS, status);
    }

    pub(super) fn basic_status_block(&self) -> StatusWord1 {
        let bits = [
            (
                self.output_stage_enabled(),
                StatusWord1::OUTPUT_STAGE_ENABLED,
            ),
            (
                self.drive.state().fault_code().is_none(),
                StatusWord1::INVERTER_READY,
            ),
            (self.po_data_enabled(), StatusWord1::PO_DATA_ENABLED),
            (self.integrator_2(), StatusWord1::INTEGRATOR_2),
            (self.parameter_set_2(), StatusWord1::PARAMETER_SET_2),
            (self.fault_number().is_some(), StatusWord1::FAULT_WARNING),
        ];
        bits.into_iter()
            .filter(|(on, _)| *on)
            .fold(StatusWord1::empty(), |w, (_, bit)| w | bit)
    }

    pub(super) fn unit_status(&self) -> UnitStatus {
        match self.drive.state() {
            DriveState::Inhibited => UnitStatus::ControllerInhibit,
            DriveState::Enabled => UnitStatus::Enable,
            DriveState::Ready | DriveState::QuickStop | DriveState::Fault(_) => {
                UnitStatus::NoEnable
            }
        }
    }

    /// A binary output with a P620 function (only the functions the model knows; others 0).
    pub(super) fn binary_output(&self, function: i64) -> bool {
        let fault = self.fault_number().is_some();
        match function {
            1 => !fault,                                    // /fault
            2 => self.drive.state().fault_code().is_none(), // ready
            3 => self.output_stage_enabled(),               // output stage on
            4 => self.output_stage_enabled(),               // rotating field on
            5 => self.output_stage_enabled(),               // brake released
            6 => !self.output_stage_enabled(),              // brake applied
            7 => !self.drive.motor_turning(),               // motor standstill
            8 => self.parameter_set_2(),                    // parameter set
            _ => false,
        }
    }
}
