//! `control`: drive-client's job on the state machine of section 4.5.3 over process data
//! ([`drive_client::control::nord`]), its options and its output.

use std::time::Duration;

use ctt2_uss::client::{NordClient, ParameterChannel, ProcessChannel};
use drive_client::control::nord::{self as job, Event, Outcome, SetpointError, control_word_text};
use drive_client::control::{Action, ControlError};
use drive_profile::nord::{self, State};
use serde_json::json;

pub use drive_client::control::nord::Setpoint;

use super::status::read_optional;
use super::{Session, param, param_client, state_text, target_of};
use crate::error::{CliError, Result};
use crate::tool::interrupt::Interrupt;
use crate::tool::motor::{AtEnd, JobError, Motion, MotorGuard, Stopped};
use crate::tool::output::trim_float;

/// A setpoint in percent as the SW1 word ([`job::setpoint_word`]), refused in the command
/// line's words.
pub fn setpoint_word(text: &str, round: bool) -> Result<Setpoint> {
    let shown = |w: u16| {
        format!(
            "{} % (0x{w:04X})",
            trim_float(nord::percent_from_word(w), 4)
        )
    };
    job::setpoint_word(text, round).map_err(|e| {
        let t = text.trim();
        CliError::usage(match e {
            SetpointError::NotANumber => format!(
                "`{}` is not a setpoint in percent (e.g. 50, -25 or 12,5)",
                crate::decode::escape(text)
            ),
            SetpointError::PastEnds { nearest } => format!(
                "setpoint {t} % is past what SW1 holds: {} … {} (BU 0255 4.5.4: −32768…32767, \
                 4000h = 100 %); the nearest setpoint it holds is {}; nothing was sent",
                shown(0x8000),
                shown(0x7FFF),
                shown(nearest)
            ),
            SetpointError::NotExact { nearest } => format!(
                "SW1 cannot hold {t} % (steps of 100/16384 = 0.006103515625 %, 4000h = 100 %): \
                 the nearest setpoint it holds is {}; give that, or add --round to have it \
                 rounded; nothing was sent",
                shown(nearest)
            ),
            e => e.to_string(),
        })
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

/// `control`: see [`NordCommand::Control`](super::NordCommand::Control).
pub async fn control<C>(c: &mut NordClient<C>, s: &Session, a: &ControlSession<'_>) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    let action = Action::of(a.action)
        .ok_or_else(|| CliError::usage(format!("unknown control action `{}`", a.action)))?;
    let r = job::Control {
        action,
        setpoint: a.setpoint,
        set: a.set,
        wait: a.wait,
        actuals: s.actuals,
    };
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
    let enabling = action == Action::Enable;
    // `enable` runs under the motor guard: an interrupt, a closed pipe or a failure while the
    // drive is being enabled sends shutdown (047Eh: braking ramp, then ready to switch on).
    let guard =
        enabling.then(|| MotorGuard::install(AtEnd::Run, format!("{} control stop", s.again)));
    let work = async |c: &mut NordClient<C>, motion: &Motion<'_>| -> Result<Outcome> {
        let on = |e| -> std::result::Result<(), JobError> {
            if let Event::NoFault(st) = e {
                errln!(
                    "drivectl: note: the drive shows no fault ({})",
                    state_text(st)
                );
            }
            Ok(())
        };
        job::control(c, &r, motion, on).await.map_err(|e| {
            e.said(|e| match e {
                ControlError::Faulted { state } => CliError::failed(format!(
                    "the drive shows a fault ({state}): read P700 (`{} status`) and reset it \
                     with `{} control reset` first",
                    s.again, s.again
                )),
                e => e.into(),
            })
        })
    };
    let Outcome { answer, last } = match &guard {
        Some(g) => {
            let stop = async |c: &mut NordClient<C>| -> Result<Stopped> {
                Ok(job::shutdown(c, &r).await?)
            };
            g.run(c, work, stop).await?
        }
        None => {
            let interrupt = Interrupt::install("the drive keeps the last control word it was sent");
            let armed = std::cell::Cell::new(false);
            let out = work(c, &Motion::new(interrupt.inner(), &armed)).await?;
            if let Some(sig) = interrupt.signal() {
                // A stop, quick stop or disable keeps acting in the drive: say what it was
                // sent and where it is.
                return Err(CliError::with_code(
                    format!(
                        "interrupted by {}; the drive was sent {} and shows {}",
                        sig.name(),
                        control_word_text(out.last),
                        state_text(out.answer.status().state())
                    ),
                    sig.exit_code(),
                ));
            }
            out
        }
    };
    let sw = answer.status();
    let state = sw.state();
    let reached = r.reached(state);
    let sw1 = r.sw1();
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
    let printed = print_control(s, a, &Outcome { answer, last }, sw1, reached);
    if !reached {
        let running = state == State::OperationEnabled;
        return Err(CliError::failed(format!(
            "the drive did not reach {} within {} s (it shows {}{}); check P509 control word \
             source, P700 [-03] reason for switch-on disabled (`{} status`){}",
            state_text(r.target()),
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

/// The outcome of `control`: the status word with its state and IW1.
fn print_control(
    s: &Session,
    a: &ControlSession<'_>,
    out: &Outcome,
    sw1: u16,
    reached: bool,
) -> Result<()> {
    let (sw, last) = (out.answer.status(), out.last);
    let state = sw.state();
    let iw1 = out.answer.actuals().first().copied();
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
