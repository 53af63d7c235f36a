//! The one rule of every command, page or program that enables or drives a motor: while it is
//! enabling or driving the motor, anything that ends it early — an [`Interrupt`], the front
//! end's output going away, a failure — sends the family's stop; when it has done what it was
//! asked and leaves the motor running on purpose, the front end must say so. [`drive`] applies
//! the rule and returns what happened ([`Driven`]); each front end says it in its own words.
//!
//! A family gives [`drive`] two pieces: the work (its exchanges; it checks
//! [`Motion::interrupt`] between them and calls [`Motion::armed`] before the first word that can
//! move the motor) and the stop (one exchange that stops the drive, with what the drive
//! reports).

use std::cell::Cell;

pub use crate::interrupt::{Cause, Interrupt};

/// What the work does with the motor when it is done without interruption.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AtEnd {
    /// Stop it (process data without "keep running").
    Stop,
    /// Leave it running: that is what the work is for (an enable); an interruption before the
    /// work is done still stops it.
    Run,
    /// Leave it as it is, also when interrupted, for the reason given (the user asked for it;
    /// no control word to stop it with).
    KeepRunning(&'static str),
}

/// What the family's stop did: the command it sent and what the drive answered.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stopped {
    /// The stop as sent, e.g. `stop (control word 0x0002)` or `shutdown 0x047E`.
    pub sent: String,
    /// What the drive reports afterwards, e.g. its decoded status word; empty when it does not
    /// answer by design (a group).
    pub reports: String,
}

/// How the work ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ending {
    /// The work did what it was asked.
    Done,
    /// Asked to stop before the work was done (or while its last exchange was in flight).
    Interrupted(Cause),
    /// The front end's output went away (a closed pipe).
    OutputClosed,
    /// The work failed.
    Failed,
}

/// The work's view of the rule: the interrupt to check between exchanges, and where it says
/// that the motor may now move.
#[derive(Debug)]
pub struct Motion<'a> {
    interrupt: &'a Interrupt,
    armed: &'a Cell<bool>,
}

impl<'a> Motion<'a> {
    /// The view of work that does not move the motor (a stop): the same interrupt checks, and
    /// nothing is stopped for it.
    pub fn new(interrupt: &'a Interrupt, armed: &'a Cell<bool>) -> Self {
        Self { interrupt, armed }
    }

    /// The interrupt: check [`Interrupt::requested`] between exchanges, and select on
    /// [`Interrupt::wait`] in pauses.
    pub fn interrupt(&self) -> &Interrupt {
        self.interrupt
    }

    /// The next word sent can move the motor: from now on an early end sends the stop. (A stop
    /// sent before anything could move the motor would only be noise, or fail on a line that
    /// never worked.)
    pub fn armed(&self) {
        self.armed.set(true);
    }
}

/// What [`drive`] did.
#[derive(Debug)]
pub struct Driven<T, E> {
    /// The work's result.
    pub result: Result<T, E>,
    /// How it ended.
    pub ending: Ending,
    /// Whether anything that can move the motor was sent.
    pub armed: bool,
    /// The stop, when the rule sent one, and how it went.
    pub stop: Option<Result<Stopped, E>>,
    /// When the motor was left as the last exchange set it on purpose: why
    /// ([`AtEnd::KeepRunning`]).
    pub kept_running: Option<&'static str>,
}

/// Run `work` on `m`, then stop the drive with `stop` when the rule says so (see the
/// [module docs](self)). `output_closed` tells a failure that is the front end's output going
/// away (it ends the work like an interrupt).
pub async fn drive<M, T, E, W, S>(
    m: &mut M,
    at_end: AtEnd,
    interrupt: &Interrupt,
    work: W,
    stop: S,
    output_closed: impl Fn(&E) -> bool,
) -> Driven<T, E>
where
    W: AsyncFnOnce(&mut M, &Motion<'_>) -> Result<T, E>,
    S: AsyncFnOnce(&mut M) -> Result<Stopped, E>,
{
    let armed = Cell::new(false);
    let result = work(m, &Motion::new(interrupt, &armed)).await;
    // A cause raised during the last exchange counts: the work was not done when it came.
    let ending = match (&result, interrupt.cause()) {
        (_, Some(c)) => Ending::Interrupted(c),
        (Ok(_), None) => Ending::Done,
        (Err(e), None) if output_closed(e) => Ending::OutputClosed,
        (Err(_), None) => Ending::Failed,
    };
    let armed = armed.get();
    let send_stop = armed
        && match (at_end, &ending) {
            (AtEnd::KeepRunning(_), _) | (AtEnd::Run, Ending::Done) => false,
            (AtEnd::Stop, _) | (AtEnd::Run, _) => true,
        };
    let stop = if send_stop { Some(stop(m).await) } else { None };
    let kept_running = match at_end {
        AtEnd::KeepRunning(reason) if armed => Some(reason),
        _ => None,
    };
    Driven {
        result,
        ending,
        armed,
        stop,
        kept_running,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Drive {
        exchanges: u32,
        stops: u32,
    }

    async fn run(at_end: AtEnd, interrupt_after: Option<u32>, fail: bool) -> Driven<u32, String> {
        let i = Interrupt::new();
        let mut d = Drive::default();
        let driven = drive(
            &mut d,
            at_end,
            &i,
            async |d: &mut Drive, m: &Motion<'_>| {
                m.armed();
                for n in 0..5 {
                    if m.interrupt().requested() {
                        break;
                    }
                    d.exchanges += 1;
                    if interrupt_after == Some(n) {
                        i.raise(Cause {
                            name: "test".into(),
                            code: 2,
                        });
                    }
                    if fail && n == 2 {
                        return Err("closed".to_owned());
                    }
                }
                Ok(d.exchanges)
            },
            async |d: &mut Drive| {
                d.stops += 1;
                Ok(Stopped {
                    sent: "stop".into(),
                    reports: String::new(),
                })
            },
            |e: &String| e == "closed",
        )
        .await;
        assert_eq!(driven.stop.is_some(), d.stops == 1);
        driven
    }

    #[tokio::test]
    async fn the_rule() {
        // Stop at the end, and on every early end.
        assert!(run(AtEnd::Stop, None, false).await.stop.is_some());
        let d = run(AtEnd::Stop, Some(1), false).await;
        assert!(matches!(d.ending, Ending::Interrupted(_)) && d.stop.is_some());
        let d = run(AtEnd::Stop, None, true).await;
        assert_eq!(d.ending, Ending::OutputClosed);
        assert!(d.stop.is_some());
        // An enable is left running when done, stopped when interrupted in its last exchange.
        assert!(run(AtEnd::Run, None, false).await.stop.is_none());
        let d = run(AtEnd::Run, Some(4), false).await;
        assert!(d.result.is_ok() && d.stop.is_some());
        // Keep running: never stopped, and said why.
        let d = run(AtEnd::KeepRunning("asked"), Some(1), false).await;
        assert!(d.stop.is_none());
        assert_eq!(d.kept_running, Some("asked"));
    }
}
