//! `control`: the state machine of section 4.5.3 driven over process data, and the setpoint
//! SW1 it sends.

use std::time::Duration;

use ctt2_uss::client::{NordClient, ParameterChannel, ProcessChannel};
use ctt2_uss::uss::pzd::PzdIn;
use drive_profile::nord::{self, ControlWord, NordStateMachine, State, command};
use serde_json::json;

use super::status::read_optional;
use super::{Session, link_error, param, param_client, state_text, target_of};
use crate::error::{CliError, Result};
use crate::tool::client::parse_decimal;
use crate::tool::interrupt::Interrupt;
use crate::tool::motor::{AtEnd, Motion, MotorGuard, Stopped};
use crate::tool::output::trim_float;

/// A setpoint as the SW1 word carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// The word (4000h = 100 %).
    pub word: u16,
    /// What the user typed, when the word is its nearest (`--round`).
    pub rounded_from: Option<f64>,
}

/// A setpoint in percent as the SW1 word, strictly parsed: BU 0255 4.5.4 sends it as an
/// integer −32768…32767 (8000h…7FFFh) with 4000h = 100 %, so it holds −200 % … 199.9939 %
/// in steps of 100/16384 = 0.006103515625 %. The word holds a value when its nearest step,
/// written with as many decimals as were typed, reads as typed (`10` → 0666h = 9.9976 %,
/// `33.3` → 1550h = 33.3008 %); a value with more precision than the word has (`100.0001`) is
/// refused naming the nearest step, unless `round`. A value past the word's ends is refused,
/// not even `round` cuts it to fit.
pub fn setpoint_word(text: &str, round: bool) -> Result<Setpoint> {
    let p = parse_decimal(text).ok_or_else(|| {
        CliError::usage(format!(
            "`{}` is not a setpoint in percent (e.g. 50, -25 or 12,5)",
            crate::decode::escape(text)
        ))
    })?;
    let text = text.trim();
    let percent_of = |w: i16| nord::percent_from_word(w as u16);
    // Four decimals name every step apart (0.0061 % each), and are taken back as typed.
    let shown = |w: i16| format!("{} % (0x{:04X})", trim_float(percent_of(w), 4), w as u16);
    // The nearest step, then whether the word has it.
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
        return Err(CliError::usage(format!(
            "setpoint {text} % is past what SW1 holds: {} … {} (BU 0255 4.5.4: −32768…32767, \
             4000h = 100 %); the nearest setpoint it holds is {}; nothing was sent",
            shown(i16::MIN),
            shown(i16::MAX),
            shown(end)
        )));
    }
    let word = steps as i16;
    let held = percent_of(word);
    let decimals = text.split_once(['.', ',']).map_or(0, |(_, f)| f.len());
    let at_typed = |x: f64| format!("{x:.decimals$}").parse::<f64>().unwrap_or(f64::NAN);
    if (held - p).abs() <= 1e-9 * p.abs().max(1.0) || at_typed(held) == at_typed(p) {
        return Ok(Setpoint {
            word: word as u16,
            rounded_from: None,
        });
    }
    if !round {
        return Err(CliError::usage(format!(
            "SW1 cannot hold {text} % (steps of 100/16384 = 0.006103515625 %, 4000h = 100 %): \
             the nearest setpoint it holds is {}; give that, or add --round to have it rounded; \
             nothing was sent",
            shown(word)
        )));
    }
    Ok(Setpoint {
        word: word as u16,
        rounded_from: Some(p),
    })
}

/// What `control` was asked to do.
#[derive(Debug, Clone, Copy)]
pub struct ControlSession<'a> {
    pub action: &'a str,
    /// SW1, `None` = 0 %.
    pub setpoint: Option<u16>,
    /// Parameter set 1–4.
    pub set: u8,
    /// How long to wait for the state.
    pub wait: Duration,
}

/// How long the stop of an interrupted `control enable` waits for the drive to leave
/// "operation enabled" (its braking ramp).
pub const STOP_WAIT: Duration = Duration::from_secs(5);

/// Time between two process data exchanges while `control` waits for a state.
pub const CONTROL_PERIOD: Duration = Duration::from_millis(50);

/// `control`: see [`NordCommand::Control`](super::NordCommand::Control).
pub async fn control<C>(c: &mut NordClient<C>, s: &Session, a: &ControlSession<'_>) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    let (target, fixed) = match a.action {
        "enable" => (State::OperationEnabled, None),
        "stop" => (State::ReadyToSwitchOn, None),
        "quick-stop" => (State::SwitchOnDisabled, Some(command::QUICK_STOP.0)),
        "disable" => (State::SwitchOnDisabled, Some(command::DISABLE_VOLTAGE.0)),
        "reset" => (State::SwitchOnDisabled, None),
        other => return Err(CliError::usage(format!("unknown control action `{other}`"))),
    };
    let sw1 = if a.action == "enable" {
        a.setpoint.unwrap_or(0)
    } else {
        0
    };
    // SW1 and IW1, where the process data carry them.
    let sw1_slot: &[u16] = if s.actuals > 0 { &[sw1] } else { &[] };
    let iw = s.actuals.min(1);
    // P509 0 (control terminals or keypad): the drive does not take the bus control word.
    {
        let mut pc = param_client(c, s);
        let t = target_of(param::CONTROL_WORD_SOURCE, None, None)?;
        if let Some(0) = read_optional(&mut pc, &t).await? {
            errln!(
                "drivectl: warning: P509 control word source is 0 (control terminals or \
                 keypad): the drive may not act on the bus control word"
            );
        }
    }
    let with_set = |w: u16| ControlWord(w).with_parameter_set(a.set).map_or(w, |c| c.0);
    let enabling = a.action == "enable";
    let stop_command = format!("{} control stop", s.again);
    // `enable` runs under the motor guard: an interrupt, a closed pipe or a failure while the
    // drive is being enabled sends shutdown (047Eh: braking ramp, then ready to switch on).
    let guard = enabling.then(|| MotorGuard::install(AtEnd::Run, stop_command.clone()));
    let interrupt = match &guard {
        Some(g) => g.interrupt().clone(),
        None => Interrupt::install("the drive keeps the last control word it was sent"),
    };
    let armed = std::cell::Cell::new(false);
    let in_fault = |st: State| matches!(st, State::Fault | State::FaultReactionActive);
    let work = async |c: &mut NordClient<C>, motion: &Motion<'_>| -> Result<(PzdIn, u16)> {
        let stop = motion.interrupt();
        // First only look (bit 10 clear: the drive ignores this word).
        let mut answer = c
            .process(ControlWord(0), &[], iw)
            .await
            .map_err(link_error)?;
        let start = answer.status().state();
        if a.action == "reset" && !in_fault(start) {
            errln!(
                "drivectl: note: the drive shows no fault ({})",
                state_text(start)
            );
            // Nothing to reset: a word sent now could only change what the drive does.
            return Ok((answer, 0));
        }
        if matches!(a.action, "enable" | "stop") && in_fault(start) {
            return Err(CliError::failed(format!(
                "the drive shows a fault ({}): read P700 (`{} status`) and reset it with `{} \
                 control reset` first",
                state_text(start),
                s.again,
                s.again
            )));
        }
        // The word the drive holds from before this command is not known: every word planned
        // here has bit 7 = 0, so the fault reset that follows one of them is a rising edge.
        let mut last: u16 = 0;
        let mut sent = false;
        let deadline = drive_core::rt::time::now() + a.wait;
        loop {
            let state = answer.status().state();
            let reached = if a.action == "reset" {
                !in_fault(state)
            } else {
                state == target
            };
            if (reached && sent) || stop.requested() {
                return Ok((answer, last));
            }
            if sent && drive_core::rt::time::now() >= deadline {
                return Ok((answer, last));
            }
            let word = match fixed {
                Some(w) => w,
                None => NordStateMachine::next_control(last, state, target)
                    .unwrap_or_else(|| hold_word(target)),
            };
            let word = with_set(word);
            // Sent, whether or not the answer comes back: a lost answer to 047Fh may leave the
            // motor running.
            last = word;
            sent = true;
            motion.armed();
            answer = c
                .process(ControlWord(word), sw1_slot, iw)
                .await
                .map_err(link_error)?;
            tokio::select! {
                () = drive_core::rt::time::sleep(CONTROL_PERIOD) => {}
                () = stop.wait() => {}
            }
        }
    };
    let (answer, last) = match &guard {
        Some(g) => {
            let shutdown = with_set(command::SHUTDOWN.0);
            let zero: &[u16] = if s.actuals > 0 { &[0] } else { &[] };
            let stop = async |c: &mut NordClient<C>| -> Result<Stopped> {
                // The drive brakes on its ramp and only then leaves "operation enabled": send
                // shutdown until it has (a few seconds at most; a second signal ends it).
                let deadline = drive_core::rt::time::now() + STOP_WAIT;
                let mut answer = c
                    .process(ControlWord(shutdown), zero, iw)
                    .await
                    .map_err(link_error)?;
                while answer.status().state() == State::OperationEnabled
                    && drive_core::rt::time::now() < deadline
                {
                    drive_core::rt::time::sleep(CONTROL_PERIOD).await;
                    answer = c
                        .process(ControlWord(shutdown), zero, iw)
                        .await
                        .map_err(link_error)?;
                }
                let state = answer.status().state();
                Ok(Stopped {
                    sent: format!(
                        "shutdown 0x{shutdown:04X} (braking ramp, then ready to switch on)"
                    ),
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
            };
            g.run(c, work, stop).await?
        }
        None => {
            let motion = Motion::new(interrupt.inner(), &armed);
            let (answer, last) = work(c, &motion).await?;
            if let Some(sig) = interrupt.signal() {
                // A stop, quick stop or disable keeps acting in the drive: say what it was
                // sent and where it is.
                return Err(CliError::with_code(
                    format!(
                        "interrupted by {}; the drive was sent {} and shows {}",
                        sig.name(),
                        control_word_text(last),
                        state_text(answer.status().state())
                    ),
                    sig.exit_code(),
                ));
            }
            (answer, last)
        }
    };
    let sw = answer.status();
    let state = sw.state();
    let reached = if a.action == "reset" {
        !in_fault(state)
    } else {
        state == target
    };
    if reached && enabling {
        // Said before the output: a closed output pipe must not swallow the note that the
        // motor runs.
        let percent = trim_float(nord::percent_from_word(sw1), 4);
        if s.simulated {
            // The simulated drive ends with this command: there is nothing left to stop.
            errln!(
                "drivectl: note: the simulated motor was enabled and followed SW1 = 0x{sw1:04X} \
                 ({percent} % of P105) until the simulation ended with the command"
            );
        } else if let Some(g) = &guard {
            g.left_running(&format!(
                "the motor is enabled and follows SW1 = 0x{sw1:04X} ({percent} % of P105)"
            ));
        }
    }
    let printed = print_control(s, a, answer, last, sw1, reached);
    if !reached {
        let running = state == State::OperationEnabled;
        return Err(CliError::failed(format!(
            "the drive did not reach {} within {} s (it shows {}{}); check P509 control word \
             source, P700 [-03] reason for switch-on disabled (`{} status`){}",
            state_text(target),
            a.wait.as_secs(),
            state_text(state),
            if running { ", still running" } else { "" },
            s.again,
            if running {
                " and --wait for a long braking ramp"
            } else {
                ""
            }
        )));
    }
    printed
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

/// The word that keeps a drive in `target` once it is there.
pub fn hold_word(target: State) -> u16 {
    match target {
        State::OperationEnabled => command::ENABLE_OPERATION.0,
        State::ReadyToSwitchOn => command::SHUTDOWN.0,
        _ => command::DISABLE_VOLTAGE.0,
    }
}

/// The outcome of `control`: the status word with its state and IW1.
pub fn print_control(
    s: &Session,
    a: &ControlSession<'_>,
    answer: PzdIn,
    last: u16,
    sw1: u16,
    reached: bool,
) -> Result<()> {
    let sw = answer.status();
    let state = sw.state();
    let iw1 = answer.actuals().first().copied();
    if s.json {
        return outln!(
            "{}",
            json!({"action": a.action, "status_word": sw.0, "hex": format!("0x{:04X}", sw.0),
                   "state": nord::state_info(state).map(|i| i.letter.to_string()),
                   "state_en": state.name_en(), "state_de": state.name_de(),
                   "reached": reached, "control_word": (last != 0).then_some(last),
                   "setpoint": sw1, "setpoint_percent": nord::percent_from_word(sw1),
                   "iw1": iw1, "iw1_percent": iw1.map(nord::percent_from_word)})
        );
    }
    outln!(
        "status word 0x{:04X}: {}{}",
        sw.0,
        state_text(state),
        iw1.map_or_else(String::new, |w| format!(
            "; IW1 0x{w:04X} = {} %",
            trim_float(nord::percent_from_word(w), 2)
        ))
    )
}
