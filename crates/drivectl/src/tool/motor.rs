//! The one rule of every command that enables or drives a motor (`movilink pd`, `sbus pd`,
//! `uss|ctt2 control enable`, `bonfiglioli control enable`): while the command is enabling or
//! driving the motor, anything that ends it early — a signal (Ctrl-C, SIGTERM, SIGHUP,
//! SIGQUIT: [`Interrupt`]), a closed output pipe, a failure — sends the family's stop and says
//! so; when the command has done what it was asked and leaves the motor running on purpose, it
//! says so on standard error (also when standard output is closed) with the command that stops
//! it.
//!
//! A family gives [`MotorGuard::run`] two pieces: the work (its exchanges; it checks
//! [`Motion::interrupt`] between them and calls [`Motion::armed`] before the first word that
//! can move the motor) and the stop (one exchange that stops the drive, with what the drive
//! reports). The guard decides when the stop is sent and says what happened, in the same words
//! for every family.
//!
//! Exit codes: a command that runs until it is interrupted (`pd --count 0`, and `pd` whatever
//! its count: it stops the drive at its end anyway) exits 0 after a signal once its stop was
//! answered; a command that was interrupted before it had done what it was asked (`control
//! enable`) exits 128 + the signal's number (130 for Ctrl-C) after sending the stop; a closed
//! output pipe exits 141 as for any other command.

use drive_client::control::ControlError;
pub use drive_client::motor::{AtEnd, Motion, Stopped};
use drive_client::motor::{Ending, drive};

use super::interrupt::{Interrupt, Stop};
use crate::error::{CliError, Result};

/// The guard of one command that drives a motor: `drive_client::motor`'s rule on the signals,
/// said on standard error.
#[derive(Debug)]
pub struct MotorGuard {
    interrupt: Interrupt,
    at_end: AtEnd,
    /// The command that stops the drive, pasted as it is (`drivectl uss --port … control stop`).
    stop_command: String,
}

impl MotorGuard {
    /// Take over the signals ([`Interrupt::install`]) for a command that drives a motor;
    /// `stop_command` is the command line that stops the drive, for the messages that say it
    /// may still be running.
    pub fn install(at_end: AtEnd, stop_command: impl Into<String>) -> Self {
        let stop_command = stop_command.into();
        // A second signal ends the process without the stop: say so, with the way out. The
        // message must be 'static; a command runs one guard, so leaking it is bounded.
        let at_once: &'static str = Box::leak(
            format!(
                "the drive was NOT sent a stop and may still be running; stop it with \
                 `{stop_command}`"
            )
            .into_boxed_str(),
        );
        Self {
            interrupt: Interrupt::install(at_once),
            at_end,
            stop_command,
        }
    }

    /// A guard on an interrupt the caller made (tests).
    #[cfg(test)]
    pub fn with_interrupt(interrupt: Interrupt, at_end: AtEnd, stop_command: &str) -> Self {
        Self {
            interrupt,
            at_end,
            stop_command: stop_command.to_owned(),
        }
    }

    /// Run `work` on `m`, then stop the drive with `stop` when the rule says so (see the
    /// [module docs](self)), saying what happened. Returns the work's value when it did what it
    /// was asked; an interruption, a closed pipe or a failure is the error (after the stop).
    pub async fn run<M, T, W, S>(&self, m: &mut M, work: W, stop: S) -> Result<T>
    where
        W: AsyncFnOnce(&mut M, &Motion<'_>) -> Result<T>,
        S: AsyncFnOnce(&mut M) -> Result<Stopped>,
    {
        let driven = drive(
            m,
            self.at_end,
            self.interrupt.inner(),
            work,
            stop,
            CliError::is_closed_pipe,
        )
        .await;
        let signal = self.interrupt.signal();
        let why = || match (&driven.ending, signal) {
            (Ending::Done, _) => "at the end".to_owned(),
            (Ending::Interrupted(_), Some(s)) => format!("on {}", s.name()),
            (Ending::Interrupted(c), None) => format!("on {}", c.name),
            (Ending::OutputClosed, _) => "because standard output was closed".to_owned(),
            (_, _) => "after the failure".to_owned(),
        };
        let sent_stop = driven.stop.is_some();
        match driven.stop {
            Some(Ok(s)) if s.reports.is_empty() => {
                errln!("drivectl: note: sent {} {}", s.sent, why());
            }
            Some(Ok(s)) => errln!(
                "drivectl: note: sent {} {}; the drive reports: {}",
                s.sent,
                why(),
                s.reports
            ),
            Some(Err(e)) => {
                // One line that says all of it: what ended the work, that the stop was not
                // answered, and what to do.
                let unanswered = format!(
                    "the stop sent {} was not answered ({e}): the drive may still be running; \
                     stop it with `{}`",
                    why(),
                    self.stop_command
                );
                return Err(CliError::failed(
                    match (&driven.ending, driven.result, signal) {
                        (Ending::Failed, Err(first), _) => format!("{first}; {unanswered}"),
                        (Ending::Interrupted(_), _, Some(s)) => {
                            format!("interrupted by {}; {unanswered}", s.name())
                        }
                        _ => unanswered,
                    },
                ));
            }
            None => {
                if let Some(reason) = driven.kept_running {
                    // Left as it is on purpose: say so, with the way out.
                    errln!(
                        "drivectl: note: the drive was left as the last exchange set it \
                         ({reason}) and may be running; stop it with `{}`",
                        self.stop_command
                    );
                }
            }
        }
        match (driven.ending, driven.result) {
            (Ending::Done, Ok(v)) => Ok(v),
            // A command whose work is to run until interrupted ends normally.
            (Ending::Interrupted(_), Ok(v)) if self.at_end != AtEnd::Run => Ok(v),
            (Ending::Interrupted(c), Ok(_)) => {
                let (name, code) = match Stop::of(c.code) {
                    Some(s) => (s.name().to_owned(), s.exit_code()),
                    None => (c.name, 1),
                };
                Err(CliError::with_code(
                    format!(
                        "interrupted by {name}{}",
                        if sent_stop {
                            "; the drive was stopped (see above)"
                        } else {
                            " before anything that moves the motor was sent"
                        }
                    ),
                    code,
                ))
            }
            (_, Err(e)) => Err(e),
            (_, Ok(v)) => Ok(v),
        }
    }

    /// Say that the motor was left running on purpose (the command did what it was asked):
    /// `what` says how it runs. On standard error, so a closed standard output cannot swallow
    /// it.
    pub fn left_running(&self, what: &str) {
        errln!(
            "drivectl: note: {what}; it keeps running after drivectl ends: stop it with `{}`",
            self.stop_command
        );
    }
}

impl From<ControlError> for CliError {
    fn from(e: ControlError) -> Self {
        CliError::failed(e.to_string())
    }
}

/// A control job's failure before the command line says it: the job's own (said by the
/// family, which may add its way out), or the command line's (its output went away).
#[derive(Debug)]
pub enum JobError {
    /// The job failed.
    Job(ControlError),
    /// The command line failed.
    Cli(CliError),
}

impl From<ControlError> for JobError {
    fn from(e: ControlError) -> Self {
        JobError::Job(e)
    }
}

impl From<CliError> for JobError {
    fn from(e: CliError) -> Self {
        JobError::Cli(e)
    }
}

impl JobError {
    /// The error as the command line says it, the job's in `say`'s words.
    pub fn said(self, say: impl FnOnce(ControlError) -> CliError) -> CliError {
        match self {
            JobError::Job(e) => say(e),
            JobError::Cli(e) => e,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive that counts the stops it was sent.
    #[derive(Default)]
    struct Drive {
        exchanges: u32,
        stops: u32,
        stop_fails: bool,
    }

    fn stop_of(d: &mut Drive) -> Result<Stopped> {
        d.stops += 1;
        if d.stop_fails {
            return Err(CliError::failed("no answer"));
        }
        Ok(Stopped {
            sent: "stop (control word 0x0002)".into(),
            reports: "no enable".into(),
        })
    }

    fn run(
        at_end: AtEnd,
        drive: &mut Drive,
        interrupt_after: Option<u32>,
        fail_after: Option<CliError>,
    ) -> Result<u32> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let i = Interrupt::never();
        let guard = MotorGuard::with_interrupt(i.clone(), at_end, "drivectl x control stop");
        let fail = std::cell::RefCell::new(fail_after);
        rt.block_on(guard.run(
            drive,
            async |d: &mut Drive, m: &Motion<'_>| {
                m.armed();
                for n in 0..5 {
                    if m.interrupt().requested() {
                        break;
                    }
                    d.exchanges += 1;
                    if interrupt_after == Some(n) {
                        i.set();
                    }
                    if n == 2
                        && let Some(e) = fail.borrow_mut().take()
                    {
                        return Err(e);
                    }
                }
                Ok(d.exchanges)
            },
            async |d: &mut Drive| stop_of(d),
        ))
    }

    #[test]
    fn pd_stops_at_its_end_and_on_every_early_end() {
        let mut d = Drive::default();
        assert_eq!(run(AtEnd::Stop, &mut d, None, None).unwrap(), 5);
        assert_eq!(d.stops, 1);
        // Interrupted: stopped, and `pd` ends normally.
        let mut d = Drive::default();
        assert_eq!(run(AtEnd::Stop, &mut d, Some(1), None).unwrap(), 2);
        assert_eq!(d.stops, 1);
        // A closed pipe and a failure: stopped, the error kept.
        let mut d = Drive::default();
        let e = run(AtEnd::Stop, &mut d, None, Some(CliError::closed_pipe())).unwrap_err();
        assert!(e.is_closed_pipe());
        assert_eq!(d.stops, 1);
        let mut d = Drive::default();
        let e = run(AtEnd::Stop, &mut d, None, Some(CliError::failed("link"))).unwrap_err();
        assert_eq!(e.to_string(), "link");
        assert_eq!(d.stops, 1);
    }

    #[test]
    fn keep_running_never_stops() {
        let mut d = Drive::default();
        run(AtEnd::KeepRunning("--keep-running"), &mut d, Some(1), None).unwrap();
        run(AtEnd::KeepRunning("--keep-running"), &mut d, None, None).unwrap();
        assert_eq!(d.stops, 0);
    }

    #[test]
    fn an_enable_is_stopped_when_interrupted_even_in_its_last_exchange() {
        // Done without interruption: left running, not stopped.
        let mut d = Drive::default();
        run(AtEnd::Run, &mut d, None, None).unwrap();
        assert_eq!(d.stops, 0);
        // The signal comes during the last exchange: the work returns Ok, but it was not done
        // when the signal came: stopped, and the command fails with the signal's code.
        let mut d = Drive::default();
        let e = run(AtEnd::Run, &mut d, Some(4), None).unwrap_err();
        assert_eq!(d.exchanges, 5);
        assert_eq!(d.stops, 1);
        assert_eq!(e.exit_code(), 130);
        assert!(e.to_string().contains("interrupted by Ctrl-C"), "{e}");
        // A closed pipe while enabling stops it too.
        let mut d = Drive::default();
        let e = run(AtEnd::Run, &mut d, None, Some(CliError::closed_pipe())).unwrap_err();
        assert!(e.is_closed_pipe());
        assert_eq!(d.stops, 1);
    }

    #[test]
    fn an_unanswered_stop_keeps_the_first_error() {
        let mut d = Drive {
            stop_fails: true,
            ..Drive::default()
        };
        let e = run(AtEnd::Stop, &mut d, None, Some(CliError::failed("link"))).unwrap_err();
        assert_eq!(
            e.to_string(),
            "link; the stop sent after the failure was not answered (no answer): the \
             drive may still be running; stop it with `drivectl x control stop`"
        );
        let mut d = Drive {
            stop_fails: true,
            ..Drive::default()
        };
        let e = run(AtEnd::Stop, &mut d, None, None).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("the stop sent at the end was not answered (no answer)"),
            "{e}"
        );
        // A closed pipe does not hide it: the message is printed, exit 1.
        let mut d = Drive {
            stop_fails: true,
            ..Drive::default()
        };
        let e = run(AtEnd::Run, &mut d, None, Some(CliError::closed_pipe())).unwrap_err();
        assert!(!e.is_closed_pipe() && e.exit_code() == 1, "{e}");
        assert!(e.to_string().contains("may still be running"), "{e}");
    }
}
