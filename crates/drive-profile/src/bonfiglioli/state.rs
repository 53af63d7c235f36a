//! The DRIVECOM-style state machine of the ACT (ch. 9.1.2) and the ACU (ch. 10.2), used when
//! *Local/Remote* 412 = 1.
//!
//! States are decoded from status word bits 0…3, 5 and 6 (bits 4 and 7…15 do not take part).
//! Transitions are driven by the control word commands of the manual:
//!
//! | command | word | transitions |
//! |---|---|---|
//! | shutdown ("Stillsetzen") | 0x06 | 2, 6, 8 |
//! | switch on ("Einschalten") | 0x07 | 3 |
//! | disable voltage ("Spannung sperren") | 0x00 | 7, 9, 10, 12 |
//! | quick stop ("Schnellhalt") | 0x02 | 11 (ACU also 7, 10) |
//! | disable operation ("Betrieb sperren") | 0x07 | 5 |
//! | enable operation ("Betrieb freigeben") | 0x0F | 4, and the shortcut 4 / 4' |
//! | fault reset ("Reset Störung") | 0x80, rising edge of bit 7 | 15 |
//!
//! Beyond DRIVECOM, the ACT has a shortcut transition 4 (0x0F) from switch-on disabled (0x40)
//! straight to operation enabled (0x27). The ACU has it as transition 4' only in
//! configurations without positioning control (P30 ≠ x40), hence [`AcuStateMachine`] and
//! [`AcuPositioningStateMachine`].
//!
//! ```
//! use drive_profile::bonfiglioli::{ActStateMachine, State};
//! use drive_profile::state::StateMachine;
//!
//! // After power-on the drive shows 0x40, switch-on disabled (ch. 9.1.2).
//! assert_eq!(ActStateMachine::decode(0x0040), State::SwitchOnDisabled);
//! // The shortcut: 0x0F enables operation at once.
//! assert_eq!(
//!     ActStateMachine::control_toward(State::SwitchOnDisabled, State::OperationEnabled),
//!     Some(0x0F)
//! );
//! ```

use crate::state::StateMachine;
use core::marker::PhantomData;

/// Control words of the manual's command tables (ch. 9.1.2, 10.2).
pub mod command {
    /// "Stillsetzen" (shutdown): transitions 2, 6, 8.
    pub const SHUTDOWN: u16 = 0x06;
    /// "Einschalten" (switch on): transition 3; also "Betrieb sperren" (disable operation),
    /// transition 5.
    pub const SWITCH_ON: u16 = 0x07;
    /// "Betrieb sperren" (disable operation): transition 5, behaviour set by P392.
    pub const DISABLE_OPERATION: u16 = 0x07;
    /// "Spannung sperren" (disable voltage): transitions 7, 9, 10, 12.
    pub const DISABLE_VOLTAGE: u16 = 0x00;
    /// "Schnellhalt" (quick stop): transition 11.
    pub const QUICK_STOP: u16 = 0x02;
    /// "Betrieb freigeben" (enable operation): transition 4 and the shortcut 4 / 4'.
    pub const ENABLE_OPERATION: u16 = 0x0F;
    /// "Reset Störung" (fault reset): transition 15 on the rising edge of bit 7.
    pub const FAULT_RESET: u16 = 0x80;
}

/// A state of the drive's state machine: the shared DRIVECOM states. The ACT table has all of
/// them; the ACU table has no "not ready to switch on".
pub use crate::state::DriveState as State;

/// One row of a status word table: the state shows when `word & mask == value`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pattern {
    /// The state.
    pub state: State,
    /// Bits that take part (the table's 0/1 columns; X columns and bits 4, 7…15 do not).
    pub mask: u16,
    /// Their values.
    pub value: u16,
}

const fn pat(state: State, mask: u16, value: u16) -> Pattern {
    Pattern { state, mask, value }
}

/// ACT status word table, ch. 9.1.2 (bits 6, 5, 3, 2, 1, 0).
pub const ACT_PATTERNS: [Pattern; 8] = [
    pat(State::NotReadyToSwitchOn, 0x4F, 0x00),
    pat(State::SwitchOnDisabled, 0x4F, 0x40),
    pat(State::ReadyToSwitchOn, 0x6F, 0x21),
    pat(State::QuickStopActive, 0x6F, 0x07),
    pat(State::SwitchedOn, 0x6F, 0x23),
    pat(State::OperationEnabled, 0x6F, 0x27),
    pat(State::Fault, 0x4F, 0x08),
    pat(State::FaultReactionActive, 0x4F, 0x0F),
];

/// ACU status word table, ch. 10.2: as the ACT, without "not ready to switch on".
pub const ACU_PATTERNS: [Pattern; 7] = [
    pat(State::SwitchOnDisabled, 0x4F, 0x40),
    pat(State::ReadyToSwitchOn, 0x6F, 0x21),
    pat(State::SwitchedOn, 0x6F, 0x23),
    pat(State::OperationEnabled, 0x6F, 0x27),
    pat(State::QuickStopActive, 0x6F, 0x07),
    pat(State::FaultReactionActive, 0x4F, 0x0F),
    pat(State::Fault, 0x4F, 0x08),
];

/// A transition the master can command: from, to, control word, the manual's number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transition {
    /// State before.
    pub from: State,
    /// State after.
    pub to: State,
    /// Control word that commands it.
    pub word: u16,
    /// The manual's transition number.
    pub number: u8,
}

const fn tr(from: State, to: State, word: u16, number: u8) -> Transition {
    Transition {
        from,
        to,
        word,
        number,
    }
}

/// Commanded transitions shared by every variant, in order of preference.
const COMMON: [Transition; 13] = [
    tr(
        State::SwitchOnDisabled,
        State::ReadyToSwitchOn,
        command::SHUTDOWN,
        2,
    ),
    tr(
        State::ReadyToSwitchOn,
        State::SwitchedOn,
        command::SWITCH_ON,
        3,
    ),
    tr(
        State::SwitchedOn,
        State::OperationEnabled,
        command::ENABLE_OPERATION,
        4,
    ),
    tr(
        State::OperationEnabled,
        State::SwitchedOn,
        command::DISABLE_OPERATION,
        5,
    ),
    tr(
        State::SwitchedOn,
        State::ReadyToSwitchOn,
        command::SHUTDOWN,
        6,
    ),
    tr(
        State::ReadyToSwitchOn,
        State::SwitchOnDisabled,
        command::DISABLE_VOLTAGE,
        7,
    ),
    tr(
        State::OperationEnabled,
        State::ReadyToSwitchOn,
        command::SHUTDOWN,
        8,
    ),
    tr(
        State::OperationEnabled,
        State::SwitchOnDisabled,
        command::DISABLE_VOLTAGE,
        9,
    ),
    tr(
        State::SwitchedOn,
        State::SwitchOnDisabled,
        command::DISABLE_VOLTAGE,
        10,
    ),
    tr(
        State::OperationEnabled,
        State::QuickStopActive,
        command::QUICK_STOP,
        11,
    ),
    tr(
        State::QuickStopActive,
        State::SwitchOnDisabled,
        command::DISABLE_VOLTAGE,
        12,
    ),
    tr(
        State::Fault,
        State::SwitchOnDisabled,
        command::FAULT_RESET,
        15,
    ),
    // Placeholder replaced per variant (the shortcut); never matches when disabled.
    tr(
        State::SwitchOnDisabled,
        State::OperationEnabled,
        command::ENABLE_OPERATION,
        4,
    ),
];

/// States the master can ask for.
const TARGETS: [State; 5] = [
    State::SwitchOnDisabled,
    State::ReadyToSwitchOn,
    State::SwitchedOn,
    State::OperationEnabled,
    State::QuickStopActive,
];

const N_STATES: usize = 9;

const fn idx(s: State) -> usize {
    match s {
        State::NotReadyToSwitchOn => 0,
        State::SwitchOnDisabled => 1,
        State::ReadyToSwitchOn => 2,
        State::SwitchedOn => 3,
        State::OperationEnabled => 4,
        State::QuickStopActive => 5,
        State::FaultReactionActive => 6,
        State::Fault => 7,
        State::Unknown => 8,
    }
}

fn decode_with(patterns: &[Pattern], word: u16) -> State {
    patterns
        .iter()
        .find(|p| word & p.mask == p.value)
        .map_or(State::Unknown, |p| p.state)
}

/// The transitions of a variant (the shortcut included or not).
fn transitions(shortcut: bool) -> impl Iterator<Item = &'static Transition> {
    COMMON
        .iter()
        .enumerate()
        .filter(move |(i, _)| shortcut || *i + 1 < COMMON.len())
        .map(|(_, t)| t)
}

/// The commanded transitions of the ACT state machine (ch. 9.1.2), shortcut transition 4 included:
/// what a drive does when it receives a control word in a state.
pub fn act_transitions() -> impl Iterator<Item = &'static Transition> {
    transitions(true)
}

/// First control word of a shortest commanded path from `current` to `target`
/// (breadth-first search backwards from the target, without allocation).
fn toward(shortcut: bool, current: State, target: State) -> Option<u16> {
    if current == target || !TARGETS.contains(&target) {
        return None;
    }
    // dist[s] = number of commanded steps from s to target.
    let mut dist = [u8::MAX; N_STATES];
    if let Some(d) = dist.get_mut(idx(target)) {
        *d = 0;
    }
    for level in 0..N_STATES as u8 {
        let mut changed = false;
        for t in transitions(shortcut) {
            let to_d = dist.get(idx(t.to)).copied().unwrap_or(u8::MAX);
            if to_d == level
                && let Some(from_d) = dist.get_mut(idx(t.from))
                && *from_d == u8::MAX
            {
                *from_d = level + 1;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let here = dist.get(idx(current)).copied().unwrap_or(u8::MAX);
    if here == u8::MAX {
        return None;
    }
    transitions(shortcut)
        .find(|t| t.from == current && dist.get(idx(t.to)).copied() == Some(here - 1))
        .map(|t| t.word)
}

/// The ACT state machine (ch. 9.1.2), with the shortcut transition 4 from switch-on disabled.
#[derive(Debug, Clone, Copy, Default)]
pub struct ActStateMachine;

/// The ACU state machine (ch. 10.2) for configurations without positioning control
/// (P30 ≠ x40): with the shortcut transition 4'.
#[derive(Debug, Clone, Copy, Default)]
pub struct AcuStateMachine;

/// The ACU state machine in configurations with positioning control (P30 = x40): no shortcut.
#[derive(Debug, Clone, Copy, Default)]
pub struct AcuPositioningStateMachine;

/// Shared documentation of `control_toward` for the three variants.
///
/// Returns `None` when `current == target`, when `target` cannot be commanded (fault states,
/// not ready to switch on, unknown), and in states the drive leaves by itself (not ready to
/// switch on → switch-on disabled; fault reaction active → fault; unknown): poll again.
/// From `Fault` it returns 0x80; the drive acts on a rising edge of bit 7 only, and not within
/// 15 s of the fault, so repeated resets need a word with bit 7 clear in between, which
/// [`ControlSequencer`] inserts.
impl StateMachine for ActStateMachine {
    type State = State;

    fn decode(status_word: u16) -> State {
        decode_with(&ACT_PATTERNS, status_word)
    }

    fn control_toward(current: State, target: State) -> Option<u16> {
        toward(true, current, target)
    }
}

impl StateMachine for AcuStateMachine {
    type State = State;

    fn decode(status_word: u16) -> State {
        decode_with(&ACU_PATTERNS, status_word)
    }

    /// As [`ActStateMachine`]; transitions 3 and 4' are processed only while status word
    /// bit 4 (mains voltage) is set, see [`super::AcuStatusWord::mains_on`].
    fn control_toward(current: State, target: State) -> Option<u16> {
        toward(true, current, target)
    }
}

impl StateMachine for AcuPositioningStateMachine {
    type State = State;

    fn decode(status_word: u16) -> State {
        decode_with(&ACU_PATTERNS, status_word)
    }

    fn control_toward(current: State, target: State) -> Option<u16> {
        toward(false, current, target)
    }
}

/// Behaviour of transition 5 (operation enabled → switched on), parameter 392 (ch. 9.1.2.2,
/// 10.2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Transition5 {
    /// 0 "freier Auslauf": immediate change, the motor coasts.
    FreeCoast,
    /// 1 "Gleichstrombremse": DC braking for *Bremszeit* 632, then the change; no new control
    /// word is accepted meanwhile. Only in sensorless U/f configurations (e.g. 110).
    DcBrake,
    /// 2 "Rampe" (default): stop on the normal ramp, then the change after the switch-off
    /// threshold P637 and holding time P638; 0x0F during the ramp resumes operation.
    Ramp,
}

impl Transition5 {
    /// From the raw value of P392.
    pub const fn from_raw(v: i64) -> Option<Self> {
        match v {
            0 => Some(Self::FreeCoast),
            1 => Some(Self::DcBrake),
            2 => Some(Self::Ramp),
            _ => None,
        }
    }

    /// The raw value of P392.
    pub const fn raw(self) -> u16 {
        match self {
            Self::FreeCoast => 0,
            Self::DcBrake => 1,
            Self::Ramp => 2,
        }
    }

    /// Whether the state changes at once (no stopping phase in operation enabled).
    pub const fn is_immediate(self) -> bool {
        matches!(self, Self::FreeCoast)
    }

    /// Whether the drive accepts a new control word while it stops.
    pub const fn accepts_control_word_while_stopping(self) -> bool {
        !matches!(self, Self::DcBrake)
    }

    /// Whether enable operation (0x0F) during the stop returns the drive to its setpoint.
    pub const fn can_resume(self) -> bool {
        matches!(self, Self::Ramp)
    }
}

/// Drives a state machine step by step and keeps the fault reset a rising edge.
///
/// `control_toward` is stateless; this remembers the last word sent. When the next word would
/// set bit 7 while the last one (or an unknown previous one) had it set too, it first sends the
/// same word with bit 7 clear.
#[derive(Debug, Clone, Copy)]
pub struct ControlSequencer<M> {
    last: Option<u16>,
    machine: PhantomData<M>,
}

impl<M> Default for ControlSequencer<M> {
    fn default() -> Self {
        Self {
            last: None,
            machine: PhantomData,
        }
    }
}

impl<M: StateMachine> ControlSequencer<M> {
    /// A sequencer that does not know the drive's current control word.
    pub const fn new() -> Self {
        Self {
            last: None,
            machine: PhantomData,
        }
    }

    /// A sequencer that knows the control word last written to P410.
    pub const fn with_last(word: u16) -> Self {
        Self {
            last: Some(word),
            machine: PhantomData,
        }
    }

    /// The control word to write now, or `None` (see [`StateMachine::control_toward`]).
    pub fn next(&mut self, status_word: u16, target: M::State) -> Option<u16> {
        let word = M::control_toward(M::decode(status_word), target)?;
        let reset = command::FAULT_RESET;
        let word = if word & reset != 0 && self.last.is_none_or(|l| l & reset != 0) {
            word & !reset
        } else {
            word
        };
        self.last = Some(word);
        Some(word)
    }

    /// Record a control word written by other means.
    pub fn sent(&mut self, word: u16) {
        self.last = Some(word);
    }

    /// The last word sent, if known.
    pub const fn last(&self) -> Option<u16> {
        self.last
    }
}
