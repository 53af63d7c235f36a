//! `control` of a NORDAC LINK: the state machine of BU 0255 section 4.5.3 driven over process
//! data (STW/ZSW), with the setpoint SW1 sent beside every control word.

use std::time::Duration;

use ctt2_uss::client::{NordClient, ParameterChannel, ProcessChannel};
use ctt2_uss::uss::pzd::PzdIn;
use drive_profile::nord::{self, ControlWord, NordStateMachine, State, command};

use super::{Action, CONTROL_PERIOD, ControlError, STOP_WAIT, pause};
use crate::meaning::nord_state_text as state_text;
use crate::motor::{Motion, Stopped};

/// A setpoint as the SW1 word carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// The word (4000h = 100 %).
    pub word: u16,
    /// What was given, when the word is its nearest (rounding asked for).
    pub rounded_from: Option<f64>,
}

/// Why a setpoint is none SW1 holds; nothing was sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SetpointError {
    /// Not a number.
    #[error("not a setpoint in percent")]
    NotANumber,
    /// Past the word's ends (BU 0255 4.5.4: −32768…32767): `nearest` is the end.
    #[error("past what SW1 holds (−200 % … 199.9939 %)")]
    PastEnds {
        /// The nearest word SW1 holds.
        nearest: u16,
    },
    /// More precise than the word's steps of 100/16384 %.
    #[error("more precise than SW1's steps of 100/16384 %")]
    NotExact {
        /// The nearest word.
        nearest: u16,
    },
}

/// A setpoint in percent as the SW1 word, strictly parsed: BU 0255 4.5.4 sends it as an
/// integer −32768…32767 (8000h…7FFFh) with 4000h = 100 %, so it holds −200 % … 199.9939 %
/// in steps of 100/16384 = 0.006103515625 %. The word holds a value when its nearest step,
/// written with as many decimals as were typed, reads as typed (`10` → 0666h = 9.9976 %,
/// `33.3` → 1550h = 33.3008 %); a value with more precision than the word has (`100.0001`) is
/// refused naming the nearest step, unless `round`. A value past the word's ends is refused,
/// not even `round` cuts it to fit.
pub fn setpoint_word(text: &str, round: bool) -> Result<Setpoint, SetpointError> {
    let p = crate::text::parse_decimal(text).ok_or(SetpointError::NotANumber)?;
    let text = text.trim();
    let steps =
        drive_profile::scaling::round(p * f64::from(drive_profile::scaling::PERCENT_100) / 100.0);
    let end = if !steps.is_finite() || steps > f64::from(i16::MAX) {
        Some(i16::MAX)
    } else if steps < f64::from(i16::MIN) {
        Some(i16::MIN)
    } else {
        None
    };
    if let Some(end) = end {
        return Err(SetpointError::PastEnds {
            nearest: end as u16,
        });
    }
    let word = steps as i16 as u16;
    let held = nord::percent_from_word(word);
    let decimals = text.split_once(['.', ',']).map_or(0, |(_, f)| f.len());
    let at_typed = |x: f64| format!("{x:.decimals$}").parse::<f64>().unwrap_or(f64::NAN);
    if (held - p).abs() <= 1e-9 * p.abs().max(1.0) || at_typed(held) == at_typed(p) {
        return Ok(Setpoint {
            word,
            rounded_from: None,
        });
    }
    if !round {
        return Err(SetpointError::NotExact { nearest: word });
    }
    Ok(Setpoint {
        word,
        rounded_from: Some(p),
    })
}

/// What `control` is asked to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Control {
    /// The action.
    pub action: Action,
    /// SW1 of an enable, `None` = 0 %.
    pub setpoint: Option<u16>,
    /// Parameter set 1–4.
    pub set: u8,
    /// How long to wait for the state.
    pub wait: Duration,
    /// Setpoints and actual values the process data carry beside the control and status word
    /// (0–3).
    pub actuals: u8,
}

/// What `control` tells its front end while it runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Event {
    /// `reset` found no fault: nothing was sent.
    NoFault(State),
}

/// How `control` ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outcome {
    /// The drive's last answer.
    pub answer: PzdIn,
    /// The last control word sent (0: only the status was read).
    pub last: u16,
}

fn in_fault(st: State) -> bool {
    matches!(st, State::Fault | State::FaultReactionActive)
}

impl Control {
    /// The state the action drives toward.
    pub fn target(&self) -> State {
        match self.action {
            Action::Enable => State::OperationEnabled,
            Action::Stop => State::ReadyToSwitchOn,
            Action::QuickStop | Action::Disable | Action::Reset => State::SwitchOnDisabled,
        }
    }

    /// SW1 as sent: the setpoint of an enable, else 0.
    pub fn sw1(&self) -> u16 {
        match self.action {
            Action::Enable => self.setpoint.unwrap_or(0),
            _ => 0,
        }
    }

    /// Whether the drive in `state` has done what the action asks.
    pub fn reached(&self, state: State) -> bool {
        match self.action {
            Action::Reset => !in_fault(state),
            _ => state == self.target(),
        }
    }

    fn with_set(&self, w: u16) -> u16 {
        ControlWord(w)
            .with_parameter_set(self.set)
            .map_or(w, |c| c.0)
    }

    fn setpoints(&self, sw1: u16) -> Vec<u16> {
        if self.actuals > 0 { vec![sw1] } else { vec![] }
    }
}

fn link<C: ProcessChannel>(e: ctt2_uss::client::ClientError<C::Error>) -> ControlError {
    ControlError::Client(crate::nord::client_error(e, C::link_fault, &crate::Plain))
}

/// The word that keeps a drive in `target` once it is there.
pub fn hold_word(target: State) -> u16 {
    match target {
        State::OperationEnabled => command::ENABLE_OPERATION.0,
        State::ReadyToSwitchOn => command::SHUTDOWN.0,
        _ => command::DISABLE_VOLTAGE.0,
    }
}

/// A control word as the manual names the command it carries (parameter set bits aside).
pub fn control_word_text(word: u16) -> String {
    let plain = word & !ControlWord::PARAMETER_SET_MASK;
    let name = [
        (command::SHUTDOWN, "shutdown"),
        (command::SWITCH_ON, "switch on"),
        (command::ENABLE_OPERATION, "enable operation"),
        (command::DISABLE_VOLTAGE, "disable voltage"),
        (command::QUICK_STOP, "quick stop"),
        (command::FAULT_RESET, "fault reset"),
    ]
    .into_iter()
    .find(|(c, _)| c.0 == plain)
    .map(|(_, n)| n);
    match (word, name) {
        (0, _) => "nothing (only the status was read)".to_owned(),
        (_, Some(n)) => format!("{n} 0x{word:04X}"),
        (_, None) => format!("control word 0x{word:04X}"),
    }
}

/// `control`: first only look (bit 10 clear: the drive ignores the word), then send control
/// words toward the action's state every [`CONTROL_PERIOD`] until it is reached (and at least
/// one was sent), the wait is over or the work is interrupted. `enable` and `stop` refuse a
/// faulted drive; `reset` of a drive without a fault sends nothing.
pub async fn control<C, E>(
    c: &mut NordClient<C>,
    a: &Control,
    motion: &Motion<'_>,
    mut on: impl FnMut(Event) -> Result<(), E>,
) -> Result<Outcome, E>
where
    C: ParameterChannel + ProcessChannel,
    E: From<ControlError>,
{
    let stop = motion.interrupt();
    let (target, sw1) = (a.target(), a.setpoints(a.sw1()));
    let fixed = match a.action {
        Action::QuickStop => Some(command::QUICK_STOP.0),
        Action::Disable => Some(command::DISABLE_VOLTAGE.0),
        _ => None,
    };
    let iw = a.actuals.min(1);
    let mut answer = c
        .process(ControlWord(0), &[], iw)
        .await
        .map_err(link::<C>)?;
    let start = answer.status().state();
    if a.action == Action::Reset && !in_fault(start) {
        on(Event::NoFault(start))?;
        // Nothing to reset: a word sent now could only change what the drive does.
        return Ok(Outcome { answer, last: 0 });
    }
    if matches!(a.action, Action::Enable | Action::Stop) && in_fault(start) {
        return Err(ControlError::Faulted {
            state: state_text(start),
        }
        .into());
    }
    // The word the drive holds from before is not known: every word planned here has bit 7 =
    // 0, so the fault reset that follows one of them is a rising edge.
    let mut last: u16 = 0;
    let mut sent = false;
    let deadline = drive_core::rt::time::now() + a.wait;
    loop {
        let state = answer.status().state();
        if (a.reached(state) && sent) || stop.requested() {
            return Ok(Outcome { answer, last });
        }
        if sent && drive_core::rt::time::now() >= deadline {
            return Ok(Outcome { answer, last });
        }
        let word = match fixed {
            Some(w) => w,
            None => NordStateMachine::next_control(last, state, target)
                .unwrap_or_else(|| hold_word(target)),
        };
        let word = a.with_set(word);
        // Sent, whether or not the answer comes back: a lost answer to 047Fh may leave the
        // motor running.
        last = word;
        sent = true;
        motion.armed();
        answer = c
            .process(ControlWord(word), &sw1, iw)
            .await
            .map_err(link::<C>)?;
        pause(motion, CONTROL_PERIOD).await;
    }
}

/// The stop of an interrupted enable: shutdown (047Eh: braking ramp, then ready to switch on)
/// until the drive has left "operation enabled", at most [`STOP_WAIT`].
pub async fn shutdown<C>(c: &mut NordClient<C>, a: &Control) -> Result<Stopped, ControlError>
where
    C: ParameterChannel + ProcessChannel,
{
    let shutdown = a.with_set(command::SHUTDOWN.0);
    let zero = a.setpoints(0);
    let iw = a.actuals.min(1);
    let deadline = drive_core::rt::time::now() + STOP_WAIT;
    let mut answer = c
        .process(ControlWord(shutdown), &zero, iw)
        .await
        .map_err(link::<C>)?;
    while answer.status().state() == State::OperationEnabled
        && drive_core::rt::time::now() < deadline
    {
        drive_core::rt::time::sleep(CONTROL_PERIOD).await;
        answer = c
            .process(ControlWord(shutdown), &zero, iw)
            .await
            .map_err(link::<C>)?;
    }
    let state = answer.status().state();
    Ok(Stopped {
        sent: format!("shutdown 0x{shutdown:04X} (braking ramp, then ready to switch on)"),
        reports: if state == State::OperationEnabled {
            format!(
                "{} after {} s, still braking on its ramp",
                state_text(state),
                STOP_WAIT.as_secs()
            )
        } else {
            state_text(state)
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setpoints_are_held_as_typed_or_refused() {
        let w = |t| setpoint_word(t, false);
        assert_eq!(w("50").map(|s| s.word), Ok(0x2000));
        assert_eq!(w("10").map(|s| s.word), Ok(0x0666));
        assert_eq!(w("12,5").map(|s| s.word), Ok(0x0800));
        assert_eq!(w("-25").map(|s| s.word), Ok(0xF000));
        assert_eq!(
            w("100.0001"),
            Err(SetpointError::NotExact { nearest: 0x4000 })
        );
        let r = setpoint_word("100.0001", true).unwrap();
        assert_eq!((r.word, r.rounded_from), (0x4000, Some(100.0001)));
        assert_eq!(w("300"), Err(SetpointError::PastEnds { nearest: 0x7FFF }));
        assert_eq!(
            setpoint_word("-300", true),
            Err(SetpointError::PastEnds { nearest: 0x8000 })
        );
        assert_eq!(w("fast"), Err(SetpointError::NotANumber));
    }

    #[test]
    fn control_words_are_named_as_the_manual_does() {
        assert_eq!(control_word_text(0), "nothing (only the status was read)");
        assert_eq!(control_word_text(0x047F), "enable operation 0x047F");
        assert_eq!(control_word_text(0x447E), "shutdown 0x447E");
        assert_eq!(control_word_text(0x1234), "control word 0x1234");
    }
}
