//! DRIVECOM-style device state machines, one per family.
//!
//! A family implements [`StateMachine`]: decode a status word into exactly one state (or an
//! explicit unknown state), and compute the control word that moves a drive from its current
//! state one step toward a target state.

use core::fmt;

/// The states of the DRIVECOM-style device state machine, shared by the families that use it
/// (NORD, Bonfiglioli ACT/ACU). Each family decodes its own status word into these states;
/// the names follow the glossary (German originals in the variant docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DriveState {
    /// `Nicht einschaltbereit`: first state after power-up, left by the drive itself.
    NotReadyToSwitchOn,
    /// `Einschaltsperre`: left only by the command shutdown (or a family's shortcut).
    SwitchOnDisabled,
    /// `Einschaltbereit`: initialisation finished, output voltage off.
    ReadyToSwitchOn,
    /// `Eingeschaltet`: ready for operation, output stage disabled.
    SwitchedOn,
    /// `Betrieb freigegeben`: output stage enabled, the drive follows setpoints.
    OperationEnabled,
    /// `Schnellhalt aktiv`: quick stop running.
    QuickStopActive,
    /// `Störungsreaktion aktiv` / `Störung aktiv`: fault reaction running.
    FaultReactionActive,
    /// `Störung`: left only by a fault reset (rising edge of the fault-reset bit).
    Fault,
    /// The status word matches no state of the family's table.
    Unknown,
}

impl DriveState {
    /// Every state of the state machine (without [`DriveState::Unknown`]).
    pub const ALL: [DriveState; 8] = [
        DriveState::NotReadyToSwitchOn,
        DriveState::SwitchOnDisabled,
        DriveState::ReadyToSwitchOn,
        DriveState::SwitchedOn,
        DriveState::OperationEnabled,
        DriveState::QuickStopActive,
        DriveState::FaultReactionActive,
        DriveState::Fault,
    ];

    /// The English state name (glossary terms).
    pub const fn name_en(self) -> &'static str {
        match self {
            DriveState::NotReadyToSwitchOn => "not ready to switch on",
            DriveState::SwitchOnDisabled => "switch-on disabled",
            DriveState::ReadyToSwitchOn => "ready to switch on",
            DriveState::SwitchedOn => "switched on",
            DriveState::OperationEnabled => "operation enabled",
            DriveState::QuickStopActive => "quick stop active",
            DriveState::FaultReactionActive => "fault reaction active",
            DriveState::Fault => "fault",
            DriveState::Unknown => "unknown state",
        }
    }

    /// The German state name (the manuals' terms).
    pub const fn name_de(self) -> &'static str {
        match self {
            DriveState::NotReadyToSwitchOn => "Nicht einschaltbereit",
            DriveState::SwitchOnDisabled => "Einschaltsperre",
            DriveState::ReadyToSwitchOn => "Einschaltbereit",
            DriveState::SwitchedOn => "Eingeschaltet",
            DriveState::OperationEnabled => "Betrieb freigegeben",
            DriveState::QuickStopActive => "Schnellhalt aktiv",
            DriveState::FaultReactionActive => "Störungsreaktion aktiv",
            DriveState::Fault => "Störung",
            DriveState::Unknown => "unbekannter Zustand",
        }
    }
}

impl fmt::Display for DriveState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name_en())
    }
}

/// A drive family's state machine over 16-bit control and status words.
pub trait StateMachine {
    /// The family's state type; it has an explicit `Unknown` variant for words that match none.
    type State: Copy + Eq + core::fmt::Debug;

    /// Decode a status word into exactly one state.
    fn decode(status_word: u16) -> Self::State;

    /// The control word to send now so that a drive in `current` moves toward `target`,
    /// or `None` when it is already there or no transition leads there.
    fn control_toward(current: Self::State, target: Self::State) -> Option<u16>;
}
