//! The NORD drive state machine (BU 0255 section 4.5.3).

use crate::generated::nord_states::{STATES, TRANSITIONS};
use crate::state::StateMachine;

use super::{ControlWord, StateInfo, Transition};

/// A NORD drive state, decoded from status-word bits 0..6: the shared DRIVECOM states.
///
/// The manual's letters: A not ready to switch on, B switch-on disabled, C ready to switch on,
/// D switched on, E operation enabled, F quick stop active, G fault reaction active
/// (`Störung aktiv`), H fault. The manual's own names and status patterns are in
/// [`state_info`].
pub use crate::state::DriveState as State;

/// The NORD table entry of `state` (letter, status pattern, German and English names and
/// descriptions); `None` for [`State::Unknown`].
pub fn state_info(state: State) -> Option<&'static StateInfo> {
    STATES.iter().find(|s| s.state == state)
}

/// Position on the way from switch-on disabled to operation enabled, for the states a control
/// word can lead to.
const fn rank(state: State) -> Option<u8> {
    match state {
        State::SwitchOnDisabled => Some(0),
        State::ReadyToSwitchOn => Some(1),
        State::SwitchedOn => Some(2),
        State::OperationEnabled => Some(3),
        _ => None,
    }
}

/// The control words the state machine sends, each with bit 10 (control data valid) set,
/// parameter set 1 (bits 14/15 = 0) and no direction bit (bit 12 = 0: clockwise).
///
/// Select another parameter set with [`ControlWord::with_parameter_set`].
pub mod command {
    use super::ControlWord;

    /// `Stillsetzen` (transitions 2, 6, 8): `xxxx x110`; the manual's first command 047Eh.
    /// From operation enabled it ramps down with the braking ramp before switching off.
    pub const SHUTDOWN: ControlWord = ControlWord(0x047E);
    /// `Einschalten` (transition 3): `xxxx x111` with bit 3 = 0.
    pub const SWITCH_ON: ControlWord = ControlWord(0x0477);
    /// `Betrieb sperren` (transition 5): `xxxx 0111`; same word as [`SWITCH_ON`]. The output
    /// voltage is switched off at once.
    pub const DISABLE_OPERATION: ControlWord = ControlWord(0x0477);
    /// `Betrieb freigeben` (transition 4): `x111 1111`; the manual's example 047Fh.
    pub const ENABLE_OPERATION: ControlWord = ControlWord(0x047F);
    /// `Spannung sperren` (transitions 7, 9, 10, 12): `xxxx xx0x`; output voltage off at once.
    /// Bit 7 is 0, so it also serves as the first half of a fault-reset edge.
    pub const DISABLE_VOLTAGE: ControlWord = ControlWord(0x0400);
    /// `Schnellhalt` (transitions 7, 10, 11): `xxxx x01x`; stops with the quick-stop time, then
    /// switch-on disabled at 0 Hz.
    pub const QUICK_STOP: ControlWord = ControlWord(0x0402);
    /// `Fehler quittieren` (transition 15): bit 7 set. Only its rising edge resets a fault, so
    /// the word sent before it must have bit 7 = 0.
    pub const FAULT_RESET: ControlWord = ControlWord(0x0480);
}

/// The NORD state machine: decodes status words and plans control words.
///
/// ```
/// use drive_profile::nord::{NordStateMachine, State};
/// use drive_profile::state::StateMachine;
///
/// assert_eq!(NordStateMachine::decode(0x0B70), State::SwitchOnDisabled);
/// assert_eq!(
///     NordStateMachine::control_toward(State::SwitchOnDisabled, State::OperationEnabled),
///     Some(0x047E)
/// );
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct NordStateMachine;

impl NordStateMachine {
    /// The transitions out of `state` (including the fault transition from every state).
    pub fn transitions_from(state: State) -> impl Iterator<Item = &'static Transition> {
        TRANSITIONS
            .iter()
            .filter(move |t| t.from.is_none_or(|f| f == state))
    }

    /// Like [`StateMachine::control_toward`], but aware of the word sent last so that the fault
    /// reset is an edge: when the planned word sets bit 7 and `last_sent` already had bit 7
    /// set, this returns the planned word with bit 7 cleared instead; the next call then
    /// returns the word with bit 7 set, which the drive sees as the rising edge.
    pub fn next_control(last_sent: u16, current: State, target: State) -> Option<u16> {
        let word = Self::control_toward(current, target)?;
        let bit7 = ControlWord::FAULT_RESET.0;
        if word & bit7 != 0 && last_sent & bit7 != 0 {
            Some(word & !bit7)
        } else {
            Some(word)
        }
    }
}

impl StateMachine for NordStateMachine {
    type State = State;

    /// The state whose status-word pattern (bits 0..6) matches, or [`State::Unknown`].
    fn decode(status_word: u16) -> State {
        STATES
            .iter()
            .find(|s| s.matches(status_word))
            .map_or(State::Unknown, |s| s.state)
    }

    /// The control word that moves a drive in `current` one step toward `target`.
    ///
    /// Targets a control word can reach are switch-on disabled, ready to switch on, switched on
    /// and operation enabled; for any other target, for [`State::Unknown`] and when `current`
    /// equals `target` this returns `None`. The route:
    ///
    /// * up: switch-on disabled → (shutdown 047Eh) ready to switch on → (switch on 0477h)
    ///   switched on → (enable operation 047Fh) operation enabled;
    /// * down from operation enabled: shutdown 047Eh (braking ramp, then ready to switch on)
    ///   or disable operation 0477h toward switched on; from switched on or ready to switch on
    ///   toward switch-on disabled: disable voltage 0400h;
    /// * not ready to switch on (the drive leaves it by itself): the word that will be right
    ///   once it reaches switch-on disabled;
    /// * quick stop active: keep the quick stop (0402h); the drive reaches switch-on disabled
    ///   at 0 Hz by itself (send 0400h instead to switch the voltage off at once);
    /// * fault reaction active: disable voltage 0400h, which has bit 7 = 0;
    /// * fault: fault reset 0480h. **Only a 0 → 1 change of bit 7 resets a fault.** The caller
    ///   must have sent a word with bit 7 = 0 before (every other word here has bit 7 = 0, and
    ///   a fault is always preceded by fault reaction active, for which 0400h is returned).
    ///   If the drive stays in fault (the cause is still active), send a word with bit 7 = 0
    ///   again before the next 0480h — [`NordStateMachine::next_control`] does this for you.
    fn control_toward(current: State, target: State) -> Option<u16> {
        use command::*;
        let goal = rank(target)?;
        if current == target {
            return None;
        }
        let word = match current {
            State::Unknown => return None,
            State::NotReadyToSwitchOn => {
                return Self::control_toward(State::SwitchOnDisabled, target)
                    .or(Some(DISABLE_VOLTAGE.0));
            }
            State::SwitchOnDisabled => SHUTDOWN,
            State::ReadyToSwitchOn => {
                if goal > 1 {
                    SWITCH_ON
                } else {
                    DISABLE_VOLTAGE
                }
            }
            State::SwitchedOn => match goal {
                3 => ENABLE_OPERATION,
                1 => SHUTDOWN,
                _ => DISABLE_VOLTAGE,
            },
            State::OperationEnabled => {
                if goal == 2 {
                    DISABLE_OPERATION
                } else {
                    SHUTDOWN
                }
            }
            State::QuickStopActive => QUICK_STOP,
            State::FaultReactionActive => DISABLE_VOLTAGE,
            State::Fault => FAULT_RESET,
        };
        Some(word.0)
    }
}
