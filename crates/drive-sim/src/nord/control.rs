//! Process data, the state machine, ramps, BusIO bits and faults of the simulated NORD drive
//! (see the module docs of [`super`]).

use std::time::Duration;

use drive_profile::nord::{
    ControlWord, State, StatusWord, Trigger, physical_to_word, state_info, transitions,
    word_to_physical,
};

use super::{
    FAULT_MEMORY, FAULT_REACTION_TIME, INCREMENTS_PER_REVOLUTION, POLE_PAIRS, QUICK_STOP_TIME,
    SimulatedNord, actual_value_function as iw, input_function as din, output_function as dout,
    setpoint_function, switch_on_disabled_reason as reason,
};
use crate::ramp::{RampConfig, RampMode};
use drive_core::Instant;

const SWITCH_ON: u16 = ControlWord::SWITCH_ON.0;
const ENABLE_VOLTAGE: u16 = ControlWord::ENABLE_VOLTAGE.0;
const NO_QUICK_STOP: u16 = ControlWord::NO_QUICK_STOP.0;
const ENABLE_PULSES: u16 = ControlWord::ENABLE_PULSES.0;
const ENABLE_RAMP: u16 = ControlWord::ENABLE_RAMP.0;
const ENABLE_SETPOINT: u16 = ControlWord::ENABLE_SETPOINT.0;
const FAULT_RESET: u16 = ControlWord::FAULT_RESET.0;
const VALID: u16 = ControlWord::CONTROL_DATA_VALID.0;
const LEFT: u16 = ControlWord::ROTATION_LEFT.0;

/// "Stillsetzen" and "Betrieb freigeben" as the BusIO enable functions apply them.
const SHUTDOWN: u16 = 0x047E;
const ENABLE: u16 = 0x047F;

/// Positions are limited to ±50000 revolutions (ch. 4.5.4).
const POSITION_LIMIT: f64 = 50_000.0 * INCREMENTS_PER_REVOLUTION as f64;

/// Frequencies closer than this count as equal (Hz).
const EPSILON_HZ: f64 = 1e-9;

/// What the BusIO inputs (and control bits 8/9) command at present.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Inputs {
    enable_right: bool,
    enable_left: bool,
    disable_voltage: bool,
    quick_stop: bool,
    /// One bit per input with the function "fault acknowledgement" that is high.
    fault_ack: u8,
}

impl Inputs {
    /// Whether a fault-acknowledgement input rose from `before` to `self`.
    fn fault_ack_edge(self, before: Inputs) -> bool {
        self.fault_ack & !before.fault_ack != 0
    }
}

impl SimulatedNord {
    /// A process-data telegram at `now`: control word `control` and up to three setpoints
    /// (SW1…SW3; further ones are ignored, missing ones keep their last value). Without control
    /// bit 10 the telegram is ignored (only P740 shows it).
    pub fn process(&mut self, control: u16, setpoints: &[u16], now: Instant) {
        self.tick(now);
        self.bus_in = control;
        if control & VALID == 0 {
            return;
        }
        for (slot, value) in self.setpoints.iter_mut().zip(setpoints) {
            *slot = *value;
        }
        let before = self.inputs();
        let previous = self.stw.replace(control);
        let after = self.inputs();
        let bit7_edge = control & FAULT_RESET != 0 && previous.is_none_or(|p| p & FAULT_RESET == 0);
        if (self.bus_controlled() && bit7_edge) || after.fault_ack_edge(before) {
            self.fault_reset();
        }
        self.evaluate(now);
    }

    /// The master's BusIO bits at `now`: bits 0…3 the 1st slave's D0…D3, bit 4 the 2nd slave's
    /// (P480 `[-01]`…`[-05]`); higher bits are ignored.
    pub fn set_busio_in(&mut self, bits: u8, now: Instant) {
        self.tick(now);
        let before = self.inputs();
        self.busio_in = bits & 0x1F;
        if self.inputs().fault_ack_edge(before) {
            self.fault_reset();
        }
        self.evaluate(now);
    }

    /// The BusIO In bits last set.
    pub fn busio_in(&self) -> u8 {
        self.busio_in
    }

    /// The drive's BusIO bits: bits 0…3 the 1st slave's, bits 4…5 the 2nd slave's (P481
    /// `[-01]`…`[-06]`), as of the last tick.
    pub fn busio_out(&self) -> u8 {
        (0..6u8).fold(0, |bits, i| {
            if self.output(self.element(481, i)) {
                bits | 1 << i
            } else {
                bits
            }
        })
    }

    /// Advance the drive to `now`: ramp, position, fault reaction, transitions at 0 Hz, and the
    /// present commands (control word level, BusIO bits).
    pub fn tick(&mut self, now: Instant) {
        self.advance(now);
        self.timed(now);
        self.evaluate(now);
    }

    /// Raise fault `number` at `now` (transition 13): output off at once, fault reaction
    /// active, then fault after [`FAULT_REACTION_TIME`]. P700 `[-01]` shows the number and the
    /// fault memory P701 records it. Ignored for 0 and while a fault is active.
    pub fn raise_fault(&mut self, number: u16, now: Instant) {
        self.tick(now);
        if number == 0 || matches!(self.state, State::FaultReactionActive | State::Fault) {
            return;
        }
        self.fault = number;
        self.fault_at = Some(now);
        self.fault_memory.rotate_right(1);
        if let Some(newest) = self.fault_memory.first_mut() {
            *newest = number;
        }
        self.enter(State::FaultReactionActive, "13");
        self.evaluate(now);
    }

    /// The present fault number (P700 `[-01]`; 0 = none).
    pub fn fault(&self) -> u16 {
        self.fault
    }

    /// The fault memory P701, most recent first (0 = empty).
    pub fn fault_memory(&self) -> [u16; FAULT_MEMORY] {
        self.fault_memory
    }

    /// Set the present warning number (P700 `[-02]`; 0 = none); status bit 7 and the warning
    /// output function follow.
    pub fn set_warning(&mut self, number: u16) {
        self.warning = number;
    }

    /// The present warning number (0 = none).
    pub fn warning(&self) -> u16 {
        self.warning
    }

    /// The state (ch. 4.5.3).
    pub fn state(&self) -> State {
        self.state
    }

    /// The last valid control word (bit 10 set); `None` before the first.
    pub fn control_word(&self) -> Option<u16> {
        self.stw
    }

    /// The setpoints SW1…SW3 last received.
    pub fn setpoints(&self) -> [u16; 3] {
        self.setpoints
    }

    /// The output frequency in Hz (negative = counter-clockwise), as of the last tick.
    pub fn actual_frequency(&self) -> f64 {
        self.ramp.actual()
    }

    /// The simulated position in increments (before P607/P608).
    pub fn position(&self) -> i64 {
        self.position as i64
    }

    /// Preset the simulated position (an encoder preset), limited to ±50000 revolutions.
    pub fn set_position(&mut self, increments: i64) {
        self.position = (increments as f64).clamp(-POSITION_LIMIT, POSITION_LIMIT);
    }

    /// The active parameter set, 1…4.
    pub fn active_parameter_set(&self) -> u8 {
        self.active_set_index() + 1
    }

    /// The status word (ZSW, ch. 4.5.2) as of the last tick.
    pub fn status_word(&self) -> u16 {
        let (mask, value) = state_info(self.state).map_or((0x7F, 0), |s| (s.mask, s.value));
        let mut w = value & mask & 0x7F;
        let commands = self.effective_word();
        let commanded = |bit: u16| commands.is_some_and(|c| c & bit == 0);
        if mask & StatusWord::VOLTAGE_ENABLED.0 == 0 && !commanded(ENABLE_VOLTAGE) {
            w |= StatusWord::VOLTAGE_ENABLED.0;
        }
        if mask & StatusWord::NO_QUICK_STOP.0 == 0 && !commanded(NO_QUICK_STOP) {
            w |= StatusWord::NO_QUICK_STOP.0;
        }
        let mut set = |on: bool, bit: StatusWord| {
            if on {
                w |= bit.0;
            }
        };
        set(self.warning != 0, StatusWord::WARNING);
        set(self.setpoint_reached(), StatusWord::SETPOINT_REACHED);
        set(self.bus_controlled(), StatusWord::BUS_CONTROL);
        set(
            self.output(self.element(481, 8)),
            StatusWord::FUNCTION_481_9,
        );
        let left = self.rotation_left();
        set(!left, StatusWord::ROTATION_RIGHT);
        set(left, StatusWord::ROTATION_LEFT);
        set(
            self.output(self.element(481, 9)),
            StatusWord::FUNCTION_481_10,
        );
        w | u16::from(self.active_set_index()) << 14
    }

    /// The actual values IW1…IW3 per P543 `[-01]`…`[-03]`, as of the last tick.
    pub fn actual_values(&self) -> [u16; 3] {
        let mut out = [0u16; 3];
        for (i, slot) in (0u8..).zip(out.iter_mut()) {
            *slot = self.actual_value(self.element(543, i));
        }
        out
    }

    fn actual_value(&self, function: i64) -> u16 {
        let p105 = self.max_frequency();
        let percent_word =
            |value: f64, reference: f64| physical_to_word(value, reference).unwrap_or(0);
        let position = self.scaled_position();
        match function {
            iw::ACTUAL_FREQUENCY => percent_word(self.ramp.actual(), p105),
            iw::SETPOINT_FREQUENCY => percent_word(self.target().1, p105),
            iw::CURRENT => percent_word(self.current_percent(), self.current_reference()),
            iw::FAULT_NUMBER => self.fault,
            iw::POSITION_LOW => position as u16,
            iw::POSITION_HIGH => (position >> 16) as u16,
            _ => 0,
        }
    }

    /// Increments × P607 / P608, as the 32 bits sent.
    fn scaled_position(&self) -> i32 {
        let num = self.element(607, 0).max(1);
        let den = self.element(608, 0).max(1);
        let inc = self.position as i64;
        (inc.saturating_mul(num) / den).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// Simulated current in percent of the rated current.
    fn current_percent(&self) -> f64 {
        if !matches!(self.state, State::OperationEnabled | State::QuickStopActive) {
            0.0
        } else if self.setpoint_reached() {
            30.0
        } else {
            60.0
        }
    }

    /// The 100 % reference of the current: P112 in percent (401 "off" counts as 400 %).
    fn current_reference(&self) -> f64 {
        self.active(112).clamp(1, 400) as f64
    }

    /// P105 of the active set in Hz (at least 0.1 Hz).
    fn max_frequency(&self) -> f64 {
        (self.active(105) as f64 * 0.1).max(0.1)
    }

    /// Whether the control word source P509 is 5 "AS-i".
    pub(super) fn bus_controlled(&self) -> bool {
        self.element(509, 0) == 5
    }

    /// The parameter set selected by control bits 14/15 (bus control only), 0…3.
    pub(super) fn active_set_index(&self) -> u8 {
        match self.stw {
            Some(w) if self.bus_controlled() => (w >> 14) as u8,
            _ => 0,
        }
    }

    /// The BusIO In bits and control bits 8/9 through their P480 functions.
    fn inputs(&self) -> Inputs {
        let mut inputs = Inputs::default();
        let busio = (0u8..5).map(|i| (self.element(480, i), Some(self.busio_in & 1 << i != 0)));
        let stw_bit = |bit: u16| self.stw.map(|w| w & 1 << bit != 0);
        let bits = [
            (self.element(480, 10), stw_bit(8)),
            (self.element(480, 11), stw_bit(9)),
        ];
        for (i, (function, level)) in (0u8..).zip(busio.chain(bits)) {
            let Some(level) = level else { continue };
            match function {
                din::ENABLE_RIGHT => inputs.enable_right |= level,
                din::ENABLE_LEFT => inputs.enable_left |= level,
                din::DISABLE_VOLTAGE => inputs.disable_voltage |= !level,
                din::QUICK_STOP => inputs.quick_stop |= !level,
                din::FAULT_ACK => inputs.fault_ack |= u8::from(level) << i,
                _ => {}
            }
        }
        inputs
    }

    /// The control word the drive applies: the last valid control word under bus control, the
    /// enable inputs' word otherwise; the active-low BusIO functions clear bits 1 and 2.
    /// `None`: no command at all (bus control before the first control word).
    fn effective_word(&self) -> Option<u16> {
        let inputs = self.inputs();
        let base = if self.bus_controlled() {
            self.stw
        } else {
            let enable = inputs.enable_right != inputs.enable_left;
            let word = if enable && self.state != State::SwitchOnDisabled {
                ENABLE
            } else {
                SHUTDOWN
            };
            Some(if enable && inputs.enable_left {
                word | LEFT
            } else {
                word
            })
        };
        let mut word = match base {
            Some(w) => w,
            None if inputs.disable_voltage || inputs.quick_stop => SHUTDOWN & !SWITCH_ON,
            None => return None,
        };
        if inputs.disable_voltage {
            word &= !ENABLE_VOLTAGE;
        }
        if inputs.quick_stop {
            word &= !NO_QUICK_STOP;
        }
        Some(word)
    }

    /// Transition 15 (fault reset), if the drive is in fault.
    fn fault_reset(&mut self) {
        if self.state == State::Fault {
            self.fault = 0;
            self.fault_at = None;
            self.enter(State::SwitchOnDisabled, "15");
        }
    }

    /// Apply the present command level until the state is stable, then settle at `now`.
    pub(super) fn evaluate(&mut self, now: Instant) {
        for _ in 0..8 {
            let changed = self.apply_command();
            self.advance(now);
            if !(self.timed(now) || changed) {
                break;
            }
        }
    }

    /// One command-driven transition; whether the state changed.
    fn apply_command(&mut self) -> bool {
        let Some(word) = self.effective_word() else {
            return false;
        };
        let state = self.state;
        let found = transitions().iter().find(|t| {
            t.from == Some(state)
                && matches!(t.trigger, Trigger::Command { .. })
                && t.triggered_by(0, word)
        });
        match found {
            // "Stillsetzen" from operation enabled: ramp down first (see `timed`).
            Some(t) if t.id == "8" => {
                self.stopping = true;
                false
            }
            Some(t) => {
                self.enter(t.to, t.id);
                true
            }
            None => {
                // A word that keeps operation enabled resumes an interrupted "Stillsetzen".
                self.stopping = false;
                false
            }
        }
    }

    /// The automatic transitions at `now`; whether one was taken.
    fn timed(&mut self, now: Instant) -> bool {
        let stopped = self.ramp.actual().abs() < EPSILON_HZ;
        match self.state {
            State::NotReadyToSwitchOn => self.enter(State::SwitchOnDisabled, "1"),
            State::FaultReactionActive
                if self
                    .fault_at
                    .is_none_or(|t| now.saturating_duration_since(t) >= FAULT_REACTION_TIME) =>
            {
                self.enter(State::Fault, "14");
            }
            State::QuickStopActive if stopped => self.enter(State::SwitchOnDisabled, "12F"),
            State::OperationEnabled if self.stopping && stopped => {
                self.enter(State::ReadyToSwitchOn, "8");
            }
            _ => return false,
        }
        true
    }

    /// Move the output frequency and the position to `now`.
    fn advance(&mut self, now: Instant) {
        let p105 = self.max_frequency();
        let accel = Duration::from_millis(self.active(102).clamp(0, 32_000) as u64 * 10);
        self.ramp.set_config(RampConfig {
            reference_speed: p105,
            acceleration: accel,
            deceleration: accel,
            quick_stop: QUICK_STOP_TIME,
            coast: Duration::ZERO,
            speed_limit: p105,
        });
        let (mode, target) = self.target();
        // The target is finite: a word scaled by a finite P105, or 0.
        let _ = self.ramp.set_setpoint(target);
        let before = self.ramp.actual();
        let elapsed = self
            .ramp
            .last_update()
            .map_or(Duration::ZERO, |last| now.saturating_duration_since(last));
        let after = self.ramp.advance(now, mode);
        let revolutions = (before + after) / 2.0 / POLE_PAIRS * elapsed.as_secs_f64();
        self.position = (self.position + revolutions * INCREMENTS_PER_REVOLUTION as f64)
            .clamp(-POSITION_LIMIT, POSITION_LIMIT);
    }

    /// The ramp mode and the frequency it drives toward, from the state and the command.
    fn target(&self) -> (RampMode, f64) {
        match self.state {
            State::OperationEnabled if self.stopping => (RampMode::Stop, 0.0),
            State::OperationEnabled => {
                let word = self.effective_word().unwrap_or(ENABLE);
                if word & ENABLE_PULSES == 0 {
                    (RampMode::Coast, 0.0)
                } else if word & ENABLE_RAMP == 0 {
                    (RampMode::Follow, self.ramp.actual())
                } else if word & ENABLE_SETPOINT == 0 {
                    (RampMode::Follow, 0.0)
                } else {
                    (RampMode::Follow, self.setpoint_hz(word))
                }
            }
            State::QuickStopActive => (RampMode::QuickStop, 0.0),
            _ => (RampMode::Coast, 0.0),
        }
    }

    /// The setpoint frequency in Hz: the first setpoint with P546 function 1, negated for
    /// counter-clockwise, limited to ±P105.
    fn setpoint_hz(&self, word: u16) -> f64 {
        let p105 = self.max_frequency();
        let sw = (0u8..3)
            .zip(self.setpoints)
            .find(|(i, _)| self.element(546, *i) == setpoint_function::SETPOINT_FREQUENCY)
            .map_or(0, |(_, sw)| sw);
        let hz = word_to_physical(sw, p105).clamp(-p105, p105);
        if word & LEFT != 0 { -hz } else { hz }
    }

    fn setpoint_reached(&self) -> bool {
        (self.ramp.actual() - self.target().1).abs() < EPSILON_HZ
    }

    /// The rotating field: the sign of the frequency, at standstill the selected direction.
    fn rotation_left(&self) -> bool {
        let f = self.ramp.actual();
        if f.abs() >= EPSILON_HZ {
            f < 0.0
        } else {
            self.effective_word().is_some_and(|w| w & LEFT != 0)
        }
    }

    /// The level of an output function.
    fn output(&self, function: i64) -> bool {
        match function {
            dout::RUNNING => matches!(self.state, State::OperationEnabled | State::QuickStopActive),
            dout::FAULT => !matches!(self.state, State::FaultReactionActive | State::Fault),
            dout::WARNING => self.warning != 0,
            dout::READY => matches!(
                self.state,
                State::ReadyToSwitchOn | State::SwitchedOn | State::OperationEnabled
            ),
            _ => false,
        }
    }

    /// P700 `[-03]`.
    pub(super) fn switch_on_disabled_reason(&self) -> i32 {
        if self.state != State::SwitchOnDisabled {
            return reason::NONE;
        }
        match self.effective_word() {
            Some(w) if w & ENABLE_VOLTAGE == 0 => reason::DISABLE_VOLTAGE,
            Some(w) if w & NO_QUICK_STOP == 0 => reason::QUICK_STOP,
            _ => reason::AWAITING_SHUTDOWN,
        }
    }
}

impl crate::ticker::Timed for SimulatedNord {
    /// Running, stopping or reacting to a fault, or the motor still turns.
    fn busy(&self) -> bool {
        matches!(
            self.state,
            State::OperationEnabled | State::QuickStopActive | State::FaultReactionActive
        ) || self.actual_frequency() != 0.0
    }

    fn tick(&mut self, now: Instant) {
        SimulatedNord::tick(self, now);
    }
}
