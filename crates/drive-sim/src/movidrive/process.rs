//! Process data: the PO words the master sends (taken while P876 is ON and a bus is selected)
//! and the PI words the drive answers, as P870–P875 map them.

use drive_profile::sew::{ControlWord1, index};

use super::Movidrive;
use super::profile::{PERCENT_100, PO_WORDS, PiFunction, PoFunction, RPM_PER_DIGIT};
use drive_core::Instant;

impl Movidrive {
    /// Process output words PO1…PO3 received from the master at `now` (missing words keep their
    /// last value, extra words are ignored). Taken only while P876 "PO data enable" is ON; the
    /// control word acts only with P101 = bus, the speed only with P100 = bus.
    ///
    /// For a cyclic telegram call [`Movidrive::cyclic_telegram_received`] first, at the same
    /// instant: an enable that arrives with the releasing telegram takes effect at once, and a
    /// fault reset carried by it is released by the next cyclic telegram.
    pub fn process_output(&mut self, po: &[u16], now: Instant) {
        self.update(now);
        if self.value(index::PO_DATA_ENABLE) != 1 {
            return;
        }
        for (slot, word) in self.po.iter_mut().zip(po) {
            *slot = *word;
        }
        let cw = self.control_word();
        let reset = cw.is_some_and(|w| w.contains(ControlWord1::FAULT_RESET));
        let edge = reset && !self.reset_bit;
        self.reset_bit = reset;
        if edge && self.control_from_bus() {
            self.fault_reset(now);
        }
        self.update(now);
    }

    /// Process input words PI1…PI3 as mapped by P873–P875 (a shorter slice gets the first
    /// words; words beyond PI3 are set to 0). Reflects the state of the last call that took a
    /// time.
    pub fn process_input(&self, pi: &mut [u16]) {
        let descriptions = [
            index::PI1_DESCRIPTION,
            index::PI1_DESCRIPTION + 1,
            index::PI1_DESCRIPTION + 2,
        ];
        for (i, word) in pi.iter_mut().enumerate() {
            *word = descriptions
                .get(i)
                .and_then(|&d| PiFunction::from_raw(self.value(d)))
                .map_or(0, |f| self.pi_word(f));
        }
    }

    /// The value of one process input function now.
    pub fn pi_word(&self, function: PiFunction) -> u16 {
        let rpm = self.drive.actual_speed();
        match function {
            PiFunction::Speed => saturate_i16(rpm / RPM_PER_DIGIT),
            PiFunction::SpeedPercent => {
                let max = self.max_speed_rpm();
                if max > 0.0 {
                    saturate_i16(rpm / max * PERCENT_100)
                } else {
                    0
                }
            }
            PiFunction::OutputCurrent => saturate_i16(self.output_current_percent() * 10.0),
            PiFunction::ActiveCurrent => saturate_i16(self.active_current_percent() * 10.0),
            PiFunction::PositionLow => (self.position_increments() & 0xffff) as u16,
            PiFunction::PositionHigh => ((self.position_increments() >> 16) & 0xffff) as u16,
            PiFunction::StatusWord1 => self.status_word_1(),
            PiFunction::StatusWord2 => self.status_word_2(),
            PiFunction::None
            | PiFunction::IposData
            | PiFunction::Reserved
            | PiFunction::StatusWord3 => 0,
        }
    }

    /// The last process output words taken.
    pub fn process_output_words(&self) -> [u16; 3] {
        self.po
    }

    /// The raw value of parameter `index` (0 if unknown).
    pub(super) fn value(&self, index: u16) -> i64 {
        self.drive.store().read(index, 0).unwrap_or(0)
    }

    pub(super) fn param_u8(&self, index: u16) -> u8 {
        u8::try_from(self.value(index)).unwrap_or(0)
    }

    pub(super) fn setpoint_from_bus(&self) -> bool {
        matches!(self.value(index::SETPOINT_SOURCE), 2 | 3 | 10) || self.master_slave_slave()
    }

    /// P101 = RS485, fieldbus or SBus; or a master-slave slave (P100 = MASTER-SBus), which
    /// takes the master's control word.
    pub(super) fn control_from_bus(&self) -> bool {
        matches!(self.value(index::CONTROL_SOURCE), 1..=3) || self.master_slave_slave()
    }

    /// What PO word `slot` carries: P870–P872, or for a master-slave slave the assignment the
    /// firmware makes (PO1 control word 1, PO2 speed, PO3 IPOS PO data).
    pub(super) fn po_function(&self, slot: u16) -> Option<PoFunction> {
        if self.master_slave_slave() {
            return [
                PoFunction::ControlWord1,
                PoFunction::Speed,
                PoFunction::IposData,
            ]
            .get(usize::from(slot))
            .copied();
        }
        PoFunction::from_raw(self.value(index::PO1_DESCRIPTION + slot))
    }

    /// The first PO word carrying `wanted`.
    pub(super) fn po_word(&self, wanted: fn(PoFunction) -> bool) -> Option<u16> {
        (0..PO_WORDS as u16)
            .zip(self.po)
            .find(|(slot, _)| self.po_function(*slot).is_some_and(wanted))
            .map(|(_, w)| w)
    }

    pub(super) fn control_word(&self) -> Option<ControlWord1> {
        self.po_word(|f| matches!(f, PoFunction::ControlWord1 | PoFunction::ControlWord2))
            .map(ControlWord1::from_bits)
    }

    pub(super) fn parameter_set_2(&self) -> bool {
        self.control_from_bus()
            && self
                .control_word()
                .is_some_and(|w| w.contains(ControlWord1::PARAMETER_SET_2))
    }

    pub(super) fn integrator_2(&self) -> bool {
        self.control_from_bus()
            && self
                .control_word()
                .is_some_and(|w| w.contains(ControlWord1::INTEGRATOR_2))
    }

    pub(super) fn max_speed_rpm(&self) -> f64 {
        let index = if self.parameter_set_2() {
            index::MAX_SPEED_2
        } else {
            index::MAX_SPEED_1
        };
        self.value(index) as f64 / 1000.0
    }

    pub(super) fn speed_ratio(&self) -> f64 {
        let max = self.max_speed_rpm();
        if max > 0.0 {
            (self.drive.actual_speed() / max).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    }

    /// The speed setpoint from the process data, 1/min (0 unless P100 selects a bus).
    pub(super) fn setpoint_rpm(&self) -> f64 {
        if !self.setpoint_from_bus() {
            return 0.0;
        }
        if let Some(w) = self.po_word(|f| f == PoFunction::Speed) {
            return f64::from(w as i16) * RPM_PER_DIGIT;
        }
        if let Some(w) = self.po_word(|f| f == PoFunction::SpeedPercent) {
            return f64::from(w as i16) / PERCENT_100 * self.max_speed_rpm();
        }
        0.0
    }
}

fn saturate_i16(v: f64) -> u16 {
    if v.is_nan() {
        return 0;
    }
    (v.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16) as u16
}
