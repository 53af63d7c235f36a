//! The family-independent drive state machine.
//!
//! # States
//!
//! | state | output stage | motion |
//! |---|---|---|
//! | [`DriveState::Inhibited`] | off (controller inhibit / switch-on disabled) | coasts |
//! | [`DriveState::Ready`] | on, no enable (SEW "stop", DRIVECOM "switched on") | ramps to 0 with the deceleration ramp and holds |
//! | [`DriveState::Enabled`] | on, enabled | follows the setpoint with the acceleration / deceleration ramps |
//! | [`DriveState::QuickStop`] | on | ramps to 0 with the quick-stop ramp and holds |
//! | [`DriveState::Fault`] | off after the fault reaction | coasts, or quick-stops first ([`FaultReaction`]) |
//!
//! # Transitions
//!
//! | from \ command | `enable` | `stop` | `quick_stop` | `inhibit` | `fault_reset` |
//! |---|---|---|---|---|---|
//! | Inhibited | Enabled | Ready | Inhibited | Inhibited | Inhibited |
//! | Ready | Enabled | Ready | QuickStop | Inhibited | Ready |
//! | Enabled | Enabled | Ready | QuickStop | Inhibited | Enabled |
//! | QuickStop | Enabled | Ready | QuickStop | Inhibited | QuickStop |
//! | Fault | error | error | error | Fault | Inhibited |
//!
//! "error" is [`SimError::Faulted`]; the state does not change. A raised fault moves every
//! state to `Fault(code)`; while a fault is active, a further fault keeps the first code.
//!
//! The core is deliberately permissive (it allows `enable` straight from `Inhibited`, as SEW's
//! control word does); a front-end with a stricter profile (DRIVECOM) enforces its own order of
//! commands and maps its states onto these.

use crate::error::SimError;

/// The state of the simulated drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum DriveState {
    /// Controller inhibit / switch-on disabled: output stage off, motor coasts.
    #[default]
    Inhibited,
    /// Output stage on without enable: the drive ramps to 0 and holds.
    Ready,
    /// Enabled: the drive follows the setpoint.
    Enabled,
    /// Quick stop: the drive ramps to 0 with the quick-stop ramp and holds.
    QuickStop,
    /// A fault is active (the code is family-specific, e.g. a SEW fault number).
    Fault(u16),
}

impl DriveState {
    /// Whether the output stage is on (the drive controls the motor).
    pub const fn output_stage_on(self) -> bool {
        matches!(
            self,
            DriveState::Ready | DriveState::Enabled | DriveState::QuickStop
        )
    }

    /// The fault code, in [`DriveState::Fault`].
    pub const fn fault_code(self) -> Option<u16> {
        match self {
            DriveState::Fault(code) => Some(code),
            _ => None,
        }
    }
}

/// How the drive stops when a fault is raised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum FaultReaction {
    /// Output stage off at once; the motor coasts (SEW "immediate switch-off").
    #[default]
    Coast,
    /// Ramp to 0 with the quick-stop ramp, then output stage off (SEW "emergency stop").
    QuickStop,
}

/// A command to the state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// Enable: follow the setpoint.
    Enable,
    /// Controller inhibit: output stage off.
    Inhibit,
    /// Stop: ramp to 0 with the deceleration ramp and hold.
    Stop,
    /// Quick stop: ramp to 0 with the quick-stop ramp and hold.
    QuickStop,
    /// Acknowledge a fault.
    FaultReset,
}

/// The state machine: current state plus fault reaction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriveStateMachine {
    state: DriveState,
    fault_reaction: FaultReaction,
}

impl DriveStateMachine {
    /// A state machine in [`DriveState::Inhibited`] with [`FaultReaction::Coast`].
    pub const fn new() -> DriveStateMachine {
        DriveStateMachine {
            state: DriveState::Inhibited,
            fault_reaction: FaultReaction::Coast,
        }
    }

    /// The current state.
    pub const fn state(&self) -> DriveState {
        self.state
    }

    /// The configured fault reaction.
    pub const fn fault_reaction(&self) -> FaultReaction {
        self.fault_reaction
    }

    /// Configure the fault reaction (applies to faults raised from now on and to the current
    /// one).
    pub fn set_fault_reaction(&mut self, reaction: FaultReaction) {
        self.fault_reaction = reaction;
    }

    /// Apply a command (see the module docs for the transition table); returns the new state.
    pub fn apply(&mut self, command: Command) -> Result<DriveState, SimError> {
        use DriveState as S;
        let next = match (self.state, command) {
            (S::Fault(_), Command::FaultReset) => S::Inhibited,
            (S::Fault(code), Command::Inhibit) => S::Fault(code),
            (S::Fault(code), _) => return Err(SimError::Faulted { code }),
            (_, Command::Enable) => S::Enabled,
            (_, Command::Inhibit) => S::Inhibited,
            (_, Command::Stop) => S::Ready,
            (S::Inhibited, Command::QuickStop) => S::Inhibited,
            (_, Command::QuickStop) => S::QuickStop,
            (state, Command::FaultReset) => state,
        };
        self.state = next;
        Ok(next)
    }

    /// Raise a fault: the state becomes [`DriveState::Fault`] (an active fault keeps its code).
    pub fn raise_fault(&mut self, code: u16) -> DriveState {
        if !matches!(self.state, DriveState::Fault(_)) {
            self.state = DriveState::Fault(code);
        }
        self.state
    }

    /// Back to [`DriveState::Inhibited`], as after power-on.
    pub fn restart(&mut self) {
        self.state = DriveState::Inhibited;
    }
}
