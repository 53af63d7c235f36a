//! DRIVECOM-style device state machines, one per family.
//!
//! A family implements [`StateMachine`]: decode a status word into exactly one state (or an
//! explicit unknown state), and compute the control word that moves a drive from its current
//! state one step toward a target state.

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
