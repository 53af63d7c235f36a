//! The control jobs of every family: which words are sent in which order, when the drive's
//! state counts as reached, what the stop is, what an interval loop does. A front end gives
//! the options and says the results; the jobs run inside [`crate::motor::drive`] (the stop
//! rule), check [`Motion::interrupt`] between exchanges and report what they see through a
//! callback, so a closed output ends the work like any other failure.
//!
//! [`sew`]: process data of a MOVIDRIVE over MOVILINK or SBus (`pd`); [`nord`]: the state
//! machine of a NORDAC LINK over process data; [`bonfiglioli`]: the state machine of an
//! ACT/ACU through its control word 410.

pub mod bonfiglioli;
pub mod nord;
pub mod sew;

use std::time::Duration;

use crate::client::ClientError;
use crate::motor::Motion;
use crate::target::Target;

/// What a control job is asked to do with the drive's state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Enable operation: the motor runs (and keeps running once enabled).
    Enable,
    /// Stop on the ramp, the drive stays switched on.
    Stop,
    /// Quick stop.
    QuickStop,
    /// Disable voltage: the output stage off.
    Disable,
    /// Reset a fault.
    Reset,
}

impl Action {
    /// Every action, as [`Action::key`] names it.
    pub const ALL: [Action; 5] = [
        Action::Enable,
        Action::Stop,
        Action::QuickStop,
        Action::Disable,
        Action::Reset,
    ];

    /// Its key: `enable`, `stop`, `quick-stop`, `disable`, `reset`.
    pub fn key(self) -> &'static str {
        match self {
            Action::Enable => "enable",
            Action::Stop => "stop",
            Action::QuickStop => "quick-stop",
            Action::Disable => "disable",
            Action::Reset => "reset",
        }
    }

    /// The action of `key`.
    pub fn of(key: &str) -> Option<Action> {
        Action::ALL.into_iter().find(|a| a.key() == key)
    }
}

/// Why a control job failed.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// An exchange failed: the drive refused, or the link failed.
    #[error("{0}")]
    Client(#[from] ClientError),
    /// An exchange on this parameter failed.
    #[error("{}: {error}", target.label())]
    Param {
        /// The parameter.
        target: Box<Target>,
        /// What failed.
        error: ClientError,
    },
    /// `enable` and `stop` refuse a drive that shows a fault: it must be reset first.
    #[error("the drive shows a fault ({state})")]
    Faulted {
        /// The state it shows, for a person.
        state: String,
    },
    /// No output word is a control word: nothing stops the drive over process data.
    #[error("no control word to stop the drive with")]
    NoStopWord,
}

impl ControlError {
    /// `error` on `target`.
    pub fn on(target: &Target, error: ClientError) -> Self {
        ControlError::Param {
            target: Box::new(*target),
            error,
        }
    }
}

/// `count` exchanges (0: until interrupted) `period` apart, each armed first (it may move the
/// motor): an interrupt ends a pause at once, and the run before the next exchange.
pub async fn paced<E>(
    motion: &Motion<'_>,
    count: u32,
    period: Duration,
    mut exchange: impl AsyncFnMut() -> Result<(), E>,
) -> Result<(), E> {
    let stop = motion.interrupt();
    let mut done = 0u32;
    while count == 0 || done < count {
        if done > 0 {
            pause(motion, period).await;
        }
        if stop.requested() {
            break;
        }
        done = done.saturating_add(1);
        motion.armed();
        exchange().await?;
    }
    Ok(())
}

/// Wait `period`, or less when the work is interrupted.
pub async fn pause(motion: &Motion<'_>, period: Duration) {
    tokio::select! {
        () = drive_core::rt::time::sleep(period) => {}
        () = motion.interrupt().wait() => {}
    }
}

/// How long the stop of an interrupted enable waits for the drive to leave "operation
/// enabled" (its braking ramp).
pub const STOP_WAIT: Duration = Duration::from_secs(5);

/// Time between two exchanges while a job waits for a state.
pub const CONTROL_PERIOD: Duration = Duration::from_millis(50);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interrupt::{Cause, Interrupt};
    use std::cell::Cell;

    #[tokio::test(start_paused = true)]
    async fn paced_runs_count_exchanges_and_ends_on_an_interrupt() {
        let i = Interrupt::new();
        let armed = Cell::new(false);
        let motion = Motion::new(&i, &armed);
        let mut n = 0;
        let start = drive_core::rt::time::now();
        paced(
            &motion,
            3,
            Duration::from_millis(10),
            async || -> Result<(), ()> {
                n += 1;
                Ok(())
            },
        )
        .await
        .unwrap();
        assert_eq!(n, 3);
        assert!(armed.get());
        assert_eq!(
            drive_core::rt::time::elapsed(start),
            Duration::from_millis(20)
        );
        // Until interrupted: the third exchange raises it, no fourth is sent.
        let mut n = 0;
        paced(
            &motion,
            0,
            Duration::from_millis(10),
            async || -> Result<(), ()> {
                n += 1;
                if n == 3 {
                    i.raise(Cause {
                        name: "test".into(),
                        code: 2,
                    });
                }
                Ok(())
            },
        )
        .await
        .unwrap();
        assert_eq!(n, 3);
    }

    #[test]
    fn actions_by_key() {
        for a in Action::ALL {
            assert_eq!(Action::of(a.key()), Some(a));
        }
        assert_eq!(Action::of("bogus"), None);
    }
}
