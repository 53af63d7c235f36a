//! Control of the simulated ACT/ACU: modes of 412, the state machine driven by 410, status word
//! 411, setpoint, ramp, transition 5, quick stop, fault reset lockout, watchdog 413 (see the
//! module docs of [`super`]).

use std::time::Duration;

use drive_profile::bonfiglioli::State;

use super::{FAULT_WATCHDOG, Input, SimulatedBonfiglioli, Stopping, Variant};
use crate::ramp::{RampConfig, RampMode};
use crate::store::OperatingCondition;
use drive_core::Instant;

/// Acceleration and deceleration of the simulated drive in Hz/s (simulator choice: the ramp
/// parameters are not in this manual).
pub const RAMP_HZ_PER_S: f64 = 5.0;

/// After a fault, a fault reset is not acted on for this long (ch. 9.1.1, 9.1.2: 15 s).
pub const RESET_LOCKOUT: Duration = Duration::from_secs(15);

/// The speed change the ramp times refer to, in Hz.
const REFERENCE_HZ: f64 = 100.0;

/// Control word bits (ch. 9.1.2, 10.2).
const SWITCH_ON: u16 = 1 << 0;
const ENABLE_VOLTAGE: u16 = 1 << 1;
const NO_QUICK_STOP: u16 = 1 << 2;
const ENABLE_OPERATION: u16 = 1 << 3;
const FAULT_RESET: u16 = 1 << 7;

/// How the drive is controlled, from 412 of the active data set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// 0: digital inputs.
    Contacts,
    /// Every other value (3…44, the KP500 keypad modes): not started over the bus or the
    /// contacts; the drive shows switched on.
    Local,
    /// 1: control word 410 drives the state machine.
    StateMachine,
    /// 2: control word 410 bits 0…9 emulate the digital inputs.
    RemoteContacts,
}

impl SimulatedBonfiglioli {
    /// Advance the drive to `now`: ramp, holding times, DC brake, watchdog 413, contact modes.
    pub fn tick(&mut self, now: Instant) {
        if self.watch_from.is_none() {
            self.watch_from = Some(now);
        }
        if self.last_tick.is_none() {
            self.ramp.reset(now);
        }
        self.last_tick = Some(now);
        self.advance_ramp(now);
        self.timers(now);
        self.watchdog(now);
        self.evaluate(now);
        self.sync_condition();
    }

    /// Switch a hardware input at the terminals (takes effect at the next tick, read or write).
    pub fn set_input(&mut self, input: Input, on: bool) {
        let i = &mut self.inputs;
        match input {
            Input::S1ind => i.s1ind = on,
            Input::S2ind => i.s2ind = on,
            Input::S3ind => i.s3ind = on,
            Input::Stoa => i.stoa = on,
            Input::Stob => i.stob = on,
            Input::Mains => i.mains = on,
        }
    }

    /// Whether a hardware input is on.
    pub fn input(&self, input: Input) -> bool {
        let i = &self.inputs;
        match input {
            Input::S1ind => i.s1ind,
            Input::S2ind => i.s2ind,
            Input::S3ind => i.s3ind,
            Input::Stoa => i.stoa,
            Input::Stob => i.stob,
            Input::Mains => i.mains,
        }
    }

    /// A valid exchange arrived at `now`: restarts the watchdog time of 413.
    pub fn valid_exchange(&mut self, now: Instant) {
        self.watch_from = Some(now);
    }

    /// Raise a fault (injection, e.g. `0x0100` = F0100 overload) at `now`: output stage off,
    /// the motor coasts, 260 shows the key. An active fault keeps its key.
    pub fn raise_fault(&mut self, key: u16, now: Instant) {
        self.tick(now);
        if self.state != State::Fault {
            self.state = State::Fault;
            self.fault = key;
            self.fault_since = Some(now);
            self.stopping = Stopping::None;
            self.hold_since = None;
        }
        self.sync_condition();
    }

    /// Acknowledge a fault from the keypad / a digital input at `now` (any mode); like the bus
    /// reset, not acted on within [`RESET_LOCKOUT`] of the fault. Returns whether the fault
    /// was reset.
    pub fn keypad_reset(&mut self, now: Instant) -> bool {
        self.tick(now);
        let done = self.try_reset(now);
        self.evaluate(now);
        self.sync_condition();
        done
    }

    /// Set the warnings of 270 (bit-coded, ch. 12.1); status word bit 7 follows.
    pub fn set_warnings(&mut self, word: u16) {
        self.warnings = word;
    }

    /// The warnings of 270.
    pub fn warnings(&self) -> u16 {
        self.warnings
    }

    /// The fault key of 260 (0 = no fault).
    pub fn fault(&self) -> u16 {
        self.fault
    }

    /// The state (the DRIVECOM states of ch. 9.1.2 / 10.2).
    pub fn state(&self) -> State {
        self.state
    }

    /// The last control word written to 410.
    pub fn control_word(&self) -> u16 {
        self.control_word
    }

    /// The actual frequency in Hz (241, 210), as of the last tick.
    pub fn actual_frequency(&self) -> f64 {
        self.ramp.actual()
    }

    /// The status word 411 as of the last tick.
    pub fn status_word(&self) -> u16 {
        let mut w: u16 = match self.state {
            State::NotReadyToSwitchOn | State::Unknown => 0x00,
            State::SwitchOnDisabled => 0x40,
            State::ReadyToSwitchOn => 0x21,
            State::SwitchedOn => 0x23,
            State::OperationEnabled => 0x27,
            State::QuickStopActive => 0x07,
            State::FaultReactionActive => 0x0F,
            State::Fault => 0x08,
        };
        if self.variant == Variant::Acu && self.inputs.mains {
            w |= 1 << 4;
        }
        if self.warnings != 0 {
            w |= 1 << 7;
        }
        if self.remote() {
            w |= 1 << 9;
        }
        if self.setpoint_reached() {
            w |= 1 << 10;
        }
        w
    }

    /// Values the drive produces, computed on read (`None`: a stored parameter).
    pub(super) fn live_value(&self, param: u16) -> Option<i64> {
        let hz100 = |hz: f64| (hz * 100.0).round() as i64;
        Some(match param {
            11 => i64::from(self.error_register),
            210 | 241 => hz100(self.ramp.actual()),
            229 => self.param(524, 0),
            249 => i64::from(self.active_data_set()),
            250 => i64::from(self.digital_inputs()),
            260 => i64::from(self.fault),
            270 => i64::from(self.warnings),
            282 => self.param(484, 0),
            283 => hz100(self.target()),
            411 => i64::from(self.status_word()),
            _ => return None,
        })
    }

    /// Side effects of an accepted write at `now`.
    pub(super) fn after_write(&mut self, param: u16, now: Instant) {
        match param {
            410 => {
                let old = self.control_word;
                self.control_word = self.param(410, 0) as u16;
                let rising = self.control_word & FAULT_RESET != 0 && old & FAULT_RESET == 0;
                if rising && self.mode() == Mode::StateMachine {
                    self.try_reset(now);
                }
            }
            413 => self.watch_from = Some(now),
            _ => {}
        }
        self.evaluate(now);
        self.sync_condition();
    }

    pub(super) fn sync_condition(&mut self) {
        let running = matches!(self.state, State::OperationEnabled | State::QuickStopActive)
            || self.ramp.actual() != 0.0;
        self.store.set_condition(OperatingCondition {
            controller_inhibited: !running,
            in_operation: running,
        });
    }

    fn try_reset(&mut self, now: Instant) -> bool {
        let due = self
            .fault_since
            .is_some_and(|t| now.saturating_duration_since(t) >= RESET_LOCKOUT);
        if self.state == State::Fault && due {
            self.state = State::SwitchOnDisabled;
            self.fault = 0;
            self.fault_since = None;
            self.watch_from = Some(now);
            true
        } else {
            false
        }
    }

    /// A parameter's RAM value (data set `ds`, 0 = the first for data-set parameters).
    fn param(&self, number: u16, ds: u16) -> i64 {
        let ds = if self.store.read(number, ds).is_ok() {
            ds
        } else {
            1
        };
        self.store.read(number, ds).unwrap_or(0)
    }

    /// A data-set parameter of the active data set.
    fn active(&self, number: u16) -> i64 {
        self.param(number, u16::from(self.active_data_set()))
    }

    /// 414 if set to 1…4, else 1 (no data set inputs are simulated).
    fn active_data_set(&self) -> u8 {
        match self.param(414, 0) {
            v @ 1..=4 => v as u8,
            _ => 1,
        }
    }

    fn mode(&self) -> Mode {
        match self.active(412) {
            1 => Mode::StateMachine,
            0 => Mode::Contacts,
            2 => Mode::RemoteContacts,
            _ => Mode::Local,
        }
    }

    fn positioning(&self) -> bool {
        self.param(30, 0) % 100 == 40
    }

    /// The hardware enable: S1IND (ACT), STOA and STOB (ACU).
    fn hardware_enable(&self) -> bool {
        match self.variant {
            Variant::Act => self.inputs.s1ind,
            Variant::Acu => self.inputs.stoa && self.inputs.stob,
        }
    }

    fn mains(&self) -> bool {
        self.variant == Variant::Act || self.inputs.mains
    }

    /// Transition 4 conditions of ch. 9.1.2 / 10.2.
    fn can_enable(&self) -> bool {
        let start = self.inputs.s2ind || self.inputs.s3ind;
        match self.variant {
            Variant::Act => self.hardware_enable() && start,
            Variant::Acu => self.hardware_enable() && (start || self.positioning()) && self.mains(),
        }
    }

    fn remote(&self) -> bool {
        match self.mode() {
            Mode::StateMachine => match self.variant {
                Variant::Act => self.hardware_enable() && (self.inputs.s2ind || self.inputs.s3ind),
                Variant::Acu => self.hardware_enable(),
            },
            Mode::RemoteContacts => self.hardware_enable(),
            Mode::Contacts | Mode::Local => false,
        }
    }

    /// Start signals in the contact modes: (clockwise, anticlockwise).
    fn contact_start(&self) -> (bool, bool) {
        match self.mode() {
            Mode::RemoteContacts => {
                let cw = self.control_word;
                let on = self.hardware_enable() && cw & 1 != 0;
                (on && cw & 2 != 0, on && cw & 4 != 0)
            }
            Mode::Contacts => (self.inputs.s2ind, self.inputs.s3ind),
            Mode::StateMachine | Mode::Local => (false, false),
        }
    }

    /// Parameter 250: S1IND…S6IND, MFI1D, EM-S1IND as bits 0…7.
    fn digital_inputs(&self) -> u16 {
        if self.mode() == Mode::RemoteContacts {
            if self.hardware_enable() && self.control_word & 1 != 0 {
                self.control_word & 0xFF
            } else {
                0
            }
        } else {
            u16::from(self.hardware_enable())
                | u16::from(self.inputs.s2ind) << 1
                | u16::from(self.inputs.s3ind) << 2
        }
    }

    /// The maximum frequency 419 in Hz (∞ when 0).
    fn max_hz(&self) -> f64 {
        let v = self.param(419, 0) as f64 / 100.0;
        if v > 0.0 { v } else { f64::INFINITY }
    }

    /// The setpoint on the ramp, in Hz.
    fn target(&self) -> f64 {
        let line = match self.active(434) {
            2 | 3 => self.param(484, 0) as f64 / 100.0,
            _ => 0.0,
        };
        let line = match self.mode() {
            Mode::StateMachine => line,
            _ => match self.contact_start() {
                (false, true) => -line,
                _ => line,
            },
        };
        let max = self.max_hz();
        if max.is_finite() {
            line.clamp(-max, max)
        } else {
            line
        }
    }

    fn setpoint_reached(&self) -> bool {
        if self.state != State::OperationEnabled || self.stopping != Stopping::None {
            return false;
        }
        let band = self.active(549) as f64 / 10_000.0 * self.max_hz();
        let band = if band.is_finite() { band } else { 0.0 };
        (self.ramp.actual() - self.target()).abs() <= band
    }

    fn threshold_hz(&self) -> f64 {
        let t = self.active(637) as f64 / 1000.0 * self.max_hz();
        if t.is_finite() { t } else { 0.0 }
    }

    fn ramp_mode(&self) -> RampMode {
        match self.state {
            State::OperationEnabled => match self.stopping {
                Stopping::None => RampMode::Follow,
                Stopping::Ramp => RampMode::Stop,
                Stopping::DcBrake(_) => RampMode::Coast,
            },
            State::QuickStopActive => RampMode::QuickStop,
            State::SwitchedOn if self.mode() != Mode::StateMachine && self.hardware_enable() => {
                RampMode::Stop
            }
            _ => RampMode::Coast,
        }
    }

    fn advance_ramp(&mut self, now: Instant) {
        let secs = |hz_per_s: f64| {
            if hz_per_s > 0.0 && hz_per_s.is_finite() {
                Duration::from_secs_f64(REFERENCE_HZ / hz_per_s)
            } else {
                Duration::ZERO
            }
        };
        let emergency = if self.ramp.actual() < 0.0 { 425 } else { 424 };
        let config = RampConfig {
            reference_speed: REFERENCE_HZ,
            acceleration: secs(RAMP_HZ_PER_S),
            deceleration: secs(RAMP_HZ_PER_S),
            quick_stop: secs(self.active(emergency) as f64 / 100.0),
            coast: Duration::ZERO,
            speed_limit: self.max_hz(),
        };
        self.ramp.set_config(config);
        let _ = self.ramp.set_setpoint(self.target());
        let mode = self.ramp_mode();
        self.ramp.advance(now, mode);
    }

    /// Holding times and the DC brake.
    fn timers(&mut self, now: Instant) {
        if let Stopping::DcBrake(until) = self.stopping {
            if now >= until {
                self.stopping = Stopping::None;
                self.state = State::SwitchedOn;
                self.ramp.reset(now);
            }
            return;
        }
        let stopping = matches!(
            (self.state, self.stopping),
            (State::QuickStopActive, _) | (State::OperationEnabled, Stopping::Ramp)
        );
        if !stopping {
            self.hold_since = None;
            return;
        }
        if self.ramp.actual().abs() > self.threshold_hz() {
            self.hold_since = None;
            return;
        }
        let since = *self.hold_since.get_or_insert(now);
        let hold = Duration::from_millis(self.active(638).max(0) as u64 * 100);
        if now.saturating_duration_since(since) >= hold {
            self.hold_since = None;
            self.state = if self.state == State::QuickStopActive {
                State::SwitchOnDisabled
            } else {
                self.stopping = Stopping::None;
                State::SwitchedOn
            };
        }
    }

    fn watchdog(&mut self, now: Instant) {
        let limit = self.param(413, 0);
        if limit <= 0 || self.state == State::Fault {
            return;
        }
        let limit = Duration::from_secs(limit as u64);
        if self
            .watch_from
            .is_some_and(|t| now.saturating_duration_since(t) >= limit)
        {
            self.state = State::Fault;
            self.fault = FAULT_WATCHDOG;
            self.fault_since = Some(now);
            self.stopping = Stopping::None;
            self.hold_since = None;
        }
    }

    /// Apply the control word (or the contacts) until the state is stable.
    fn evaluate(&mut self, now: Instant) {
        if self.state == State::Fault {
            return;
        }
        if matches!(self.stopping, Stopping::DcBrake(_)) {
            return; // no control word is acted on during the DC brake (ch. 9.1.2.2)
        }
        let mode = self.mode();
        // Taking the hardware enable away stops the output stage at once (ch. 9.1.2).
        if !self.hardware_enable()
            && matches!(self.state, State::OperationEnabled | State::QuickStopActive)
        {
            self.state = State::SwitchedOn;
            self.stopping = Stopping::None;
            self.hold_since = None;
        }
        if mode != Mode::StateMachine {
            let (cw, ccw) = self.contact_start();
            let run = self.hardware_enable() && self.mains() && (cw || ccw);
            self.stopping = Stopping::None;
            self.state = if run {
                State::OperationEnabled
            } else {
                State::SwitchedOn
            };
            return;
        }
        for _ in 0..4 {
            let next = self.step(now);
            if next == self.state {
                break;
            }
            if next != State::OperationEnabled {
                self.stopping = Stopping::None;
            }
            self.hold_since = None;
            self.state = next;
        }
    }

    /// One transition of the state machine for the current control word.
    fn step(&mut self, now: Instant) -> State {
        let w = self.control_word;
        let s = self.state;
        if w & ENABLE_VOLTAGE == 0 {
            // disable voltage: 7, 9, 10, 12
            return match s {
                State::ReadyToSwitchOn
                | State::SwitchedOn
                | State::OperationEnabled
                | State::QuickStopActive => State::SwitchOnDisabled,
                other => other,
            };
        }
        if w & NO_QUICK_STOP == 0 {
            // quick stop: 11 (and 7, 10)
            return match s {
                State::OperationEnabled => State::QuickStopActive,
                State::ReadyToSwitchOn | State::SwitchedOn => State::SwitchOnDisabled,
                other => other,
            };
        }
        let switch_on = w & SWITCH_ON != 0;
        let operate = w & ENABLE_OPERATION != 0;
        let shortcut = self.variant == Variant::Act || !self.positioning();
        match s {
            State::SwitchOnDisabled if !switch_on => State::ReadyToSwitchOn, // 2
            State::SwitchOnDisabled if operate && shortcut && self.can_enable() => {
                State::OperationEnabled // 4 / 4'
            }
            State::ReadyToSwitchOn if switch_on && self.mains() => State::SwitchedOn, // 3
            State::SwitchedOn if !switch_on => State::ReadyToSwitchOn,                // 6
            State::SwitchedOn if operate && self.can_enable() => State::OperationEnabled, // 4
            State::OperationEnabled if !switch_on => State::ReadyToSwitchOn,          // 8
            State::OperationEnabled if !operate => self.transition_5(now),
            State::OperationEnabled => {
                if self.stopping == Stopping::Ramp {
                    self.stopping = Stopping::None; // 0x0F during the ramp resumes
                }
                State::OperationEnabled
            }
            other => other,
        }
    }

    fn transition_5(&mut self, now: Instant) -> State {
        match self.active(392) {
            0 => State::SwitchedOn,
            1 => {
                if self.stopping == Stopping::None {
                    let t = Duration::from_millis(self.active(632).max(0) as u64 * 100);
                    self.stopping = Stopping::DcBrake(now + t);
                }
                State::OperationEnabled
            }
            _ => {
                if self.stopping == Stopping::None {
                    self.stopping = Stopping::Ramp;
                }
                State::OperationEnabled
            }
        }
    }
}

impl crate::ticker::Timed for SimulatedBonfiglioli {
    /// Enabled or stopping, the motor still turns, or the watchdog (413) is armed.
    fn busy(&self) -> bool {
        matches!(self.state, State::OperationEnabled | State::QuickStopActive)
            || self.actual_frequency() != 0.0
            || self.store().read(413, 0).is_ok_and(|v| v > 0)
    }

    fn tick(&mut self, now: Instant) {
        SimulatedBonfiglioli::tick(self, now);
    }
}
