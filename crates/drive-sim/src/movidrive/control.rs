//! The control word's commands, the ramps, the RS-485 timeout monitor (P812, reaction P833), the
//! reactions every link monitor shares (RS-485 and SBus) and the fault memory.

use std::time::Duration;

use drive_profile::sew::{BasicCommand, ControlWord1, index};

use super::profile::{PoFunction, QuickRamp, RPM_PER_DIGIT, TimeoutReaction};
use super::{FAULT_RS485_TIMEOUT, Movidrive};
use crate::ramp::RampConfig;
use crate::state::{Command, DriveState, FaultReaction};
use drive_core::Instant;

impl Movidrive {
    /// A cyclic request telegram was received at `now`: feeds the RS-485 timeout monitor,
    /// releases the safe state held after power-on / fault reset, and ends a timeout warning
    /// (the last process data become effective again).
    pub fn cyclic_telegram_received(&mut self, now: Instant) {
        self.update(now);
        self.last_cyclic = Some(now);
        self.held = false;
        if self
            .warning
            .is_some_and(|(_, fault)| fault == FAULT_RS485_TIMEOUT)
        {
            self.warning = None;
        }
        self.update(now);
    }

    /// Whether the drive is held in the safe state until the first cyclic request telegram
    /// (after power-on or fault reset with the RS-485 timeout monitor on; display "t").
    pub fn held_until_first_telegram(&self) -> bool {
        self.held
    }

    /// When the RS-485 timeout fires if no cyclic request comes first: the first instant after
    /// the maximum permitted interval P812 since the last cyclic request (the manual: "the
    /// maximum permitted time between two cyclic request telegrams"; a request exactly P812
    /// after the previous one is in time). `None` while the monitor is off or not armed.
    ///
    /// This is the drive's only RS-485 timeout monitor; a front-end wakes the model at this
    /// time ([`Movidrive::tick`]) so that the reaction happens on time.
    pub fn rs485_deadline(&self) -> Option<Instant> {
        let (timeout, last) = (self.rs485_timeout()?, self.last_cyclic?);
        Some(last + timeout + Duration::from_nanos(1))
    }

    /// The active timeout warning, if any (warning reactions and "display fault").
    pub fn timeout_warning(&self) -> Option<TimeoutReaction> {
        self.warning.map(|(reaction, _)| reaction)
    }

    /// What the control word, the safe state and a timeout warning ask for.
    pub(super) fn desired(&self) -> (Command, QuickRamp) {
        if !self.control_from_bus() {
            // No binary inputs are simulated: with P101 = terminals, DI00 "/controller
            // inhibit" reads 0.
            return (Command::Inhibit, QuickRamp::Rapid);
        }
        let cw = self.control_word().unwrap_or(ControlWord1::RAPID_STOP);
        let mut command = match cw.command() {
            BasicCommand::ControllerInhibit => Command::Inhibit,
            BasicCommand::RapidStop => Command::QuickStop,
            BasicCommand::Stop => Command::Stop,
            BasicCommand::Enable => Command::Enable,
        };
        if (self.held || self.sbus_held()) && command == Command::Enable {
            command = Command::Stop;
        }
        let mut ramp = QuickRamp::Rapid;
        let reaction = match self.timeout_warning() {
            Some(TimeoutReaction::ImmediateStopWarning) => Some((Command::Inhibit, ramp)),
            Some(TimeoutReaction::EmergencyStopWarning) => {
                Some((Command::QuickStop, QuickRamp::Emergency))
            }
            Some(TimeoutReaction::RapidStopWarning) => Some((Command::QuickStop, ramp)),
            _ => None,
        };
        if let Some((r, r_ramp)) = reaction
            && severity(r) >= severity(command)
        {
            command = r;
            ramp = r_ramp;
        }
        (command, ramp)
    }

    pub(super) fn ramp_config(&self, quick: QuickRamp, setpoint: f64) -> RampConfig {
        let set2 = self.parameter_set_2();
        let ms = |i: u16| Duration::from_millis(u64::try_from(self.value(i)).unwrap_or(0));
        let base = if set2 {
            index::RAMP_T21_UP_CW
        } else {
            index::RAMP_T11_UP_CW
        };
        // t11/t21 up CW, down CW, up CCW, down CCW, t12/t22 at base + 0…4;
        // t13/t23 at base + 6, t14/t24 at base + 7.
        let ccw = {
            let actual = self.drive.actual_speed();
            actual < 0.0 || (actual == 0.0 && setpoint < 0.0)
        };
        let (mut up, mut down) = if self.integrator_2() {
            (ms(base + 4), ms(base + 4))
        } else if ccw {
            (ms(base + 2), ms(base + 3))
        } else {
            (ms(base), ms(base + 1))
        };
        if let Some(w) = self.po_word(|f| f == PoFunction::Ramp) {
            up = Duration::from_millis(u64::from(w));
            down = up;
        }
        let quick_stop = match quick {
            QuickRamp::Rapid => ms(base + 6),
            QuickRamp::Emergency => ms(base + 7),
        };
        let mut limit = self.max_speed_rpm();
        if let Some(w) = self.po_word(|f| f == PoFunction::MaxSpeed) {
            let po_limit = f64::from(w as i16).abs() * RPM_PER_DIGIT;
            if po_limit > 0.0 {
                limit = limit.min(po_limit);
            }
        }
        RampConfig {
            reference_speed: 3000.0,
            acceleration: up,
            deceleration: down,
            quick_stop,
            coast: Duration::ZERO,
            speed_limit: limit,
        }
    }

    /// Bring everything up to `now`.
    pub(super) fn update(&mut self, now: Instant) {
        self.check_timeout(now);
        self.check_sbus_timeout(now);
        self.apply_control(now);
        self.drive.tick(now);
        self.publish(now);
    }

    /// Fire the RS-485 timeout at its deadline if it has passed.
    pub(super) fn check_timeout(&mut self, now: Instant) {
        let (Some(fires), Some(timeout), Some(last)) = (
            self.rs485_deadline(),
            self.rs485_timeout(),
            self.last_cyclic,
        ) else {
            return;
        };
        if now < fires {
            return;
        }
        let deadline = last + timeout;
        self.last_cyclic = None;
        let reaction = self.rs485_timeout_reaction();
        self.link_timeout(reaction, FAULT_RS485_TIMEOUT, deadline);
    }

    /// A link monitor (RS-485 P812, SBus P815) fired at `deadline`: motion up to the deadline
    /// under the old control, then `reaction` with fault number `fault`. Shared by both links.
    pub(super) fn link_timeout(
        &mut self,
        reaction: TimeoutReaction,
        fault: u16,
        deadline: Instant,
    ) {
        self.apply_control(deadline);
        self.drive.tick(deadline);
        self.publish(deadline);
        match reaction {
            TimeoutReaction::NoResponse => {}
            TimeoutReaction::ImmediateStopFault
            | TimeoutReaction::EmergencyStopFault
            | TimeoutReaction::RapidStopFault => {
                let (fr, ramp) = match reaction {
                    TimeoutReaction::ImmediateStopFault => (FaultReaction::Coast, QuickRamp::Rapid),
                    TimeoutReaction::EmergencyStopFault => {
                        (FaultReaction::QuickStop, QuickRamp::Emergency)
                    }
                    _ => (FaultReaction::QuickStop, QuickRamp::Rapid),
                };
                if self.drive.state().fault_code().is_none() {
                    self.fault_ramp = ramp;
                    self.drive.set_fault_reaction(fr);
                    let cfg = self.ramp_config(ramp, self.setpoint_rpm());
                    self.drive.set_ramp_config(cfg, deadline);
                    self.drive.raise_fault(fault, deadline);
                    self.record_fault(fault);
                }
            }
            TimeoutReaction::DisplayFault
            | TimeoutReaction::ImmediateStopWarning
            | TimeoutReaction::EmergencyStopWarning
            | TimeoutReaction::RapidStopWarning => {
                self.warning = Some((reaction, fault));
            }
        }
        self.apply_control(deadline);
    }

    /// Bring the state machine, ramps and setpoint in line with the control inputs at `now`.
    pub(super) fn apply_control(&mut self, now: Instant) {
        let state = self.drive.state();
        let (command, quick) = self.desired();
        let quick = if state.fault_code().is_some() {
            self.fault_ramp
        } else {
            quick
        };
        let rpm = self.setpoint_rpm();
        let config = self.ramp_config(quick, rpm);
        if config != *self.drive.ramp_config() {
            self.drive.set_ramp_config(config, now);
        }
        if rpm != self.drive.setpoint() {
            let _ = self.drive.set_setpoint(rpm, now);
        }
        let in_line = matches!(
            (command, state),
            (_, DriveState::Fault(_))
                | (Command::Enable, DriveState::Enabled)
                | (Command::Stop, DriveState::Ready)
                | (
                    Command::QuickStop,
                    DriveState::QuickStop | DriveState::Inhibited
                )
                | (Command::Inhibit, DriveState::Inhibited)
        );
        if !in_line {
            let _ = self.drive.command(command, now);
        }
    }

    pub(super) fn fault_reset(&mut self, now: Instant) {
        if self.drive.state().fault_code().is_some() || self.warning.is_some() {
            let _ = self.drive.fault_reset(now);
            self.warning = None;
            if self.rs485_timeout().is_some() {
                self.held = true;
                self.last_cyclic = None;
            }
            self.sbus_awaiting = true;
            self.sbus_last = None;
        }
    }

    /// Shift the fault memory P080…P084 and enter `code` as fault t-0.
    pub(super) fn record_fault(&mut self, code: u16) {
        let store = self.drive.store_mut();
        for i in (index::FAULT_T0..index::FAULT_T0 + 4).rev() {
            let older = store.read(i, 0).unwrap_or(0);
            let _ = store.set_internal(i + 1, older);
        }
        let _ = store.set_internal(index::FAULT_T0, i64::from(code));
    }
}

/// Order of the basic control commands by how much they take away.
const fn severity(command: Command) -> u8 {
    match command {
        Command::Enable | Command::FaultReset => 0,
        Command::Stop => 1,
        Command::QuickStop => 2,
        Command::Inhibit => 3,
    }
}
