//! A request to stop work that must end cleanly: a front end raises it (the command line on
//! Ctrl-C, SIGTERM, SIGHUP or SIGQUIT; a gateway or a browser page when its session is lost),
//! the work checks it between exchanges (an exchange in flight is finished, so the drive's state
//! stays known) and waits on it in its pauses. The first cause raised is the one kept.

use std::sync::{Arc, Mutex};

/// What asked the work to stop, for the messages that say so and a front end's exit code.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cause {
    /// For a person: `Ctrl-C (SIGINT)`, `SIGTERM`, `the browser session was lost`.
    pub name: String,
    /// The front end's code for it (the command line: the signal's number).
    pub code: i32,
}

/// The flag the work checks; clones share it.
#[derive(Debug, Clone, Default)]
pub struct Interrupt {
    cause: Arc<Mutex<Option<Cause>>>,
    notify: Arc<tokio::sync::Notify>,
}

impl Interrupt {
    /// A flag nobody has raised yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Ask the work to stop for `cause` (the first cause raised is kept).
    pub fn raise(&self, cause: Cause) {
        let mut c = self
            .cause
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if c.is_none() {
            *c = Some(cause);
        }
        drop(c);
        self.notify.notify_waiters();
    }

    /// Whether the work was asked to stop.
    pub fn requested(&self) -> bool {
        self.cause().is_some()
    }

    /// Why the work was asked to stop, if it was.
    pub fn cause(&self) -> Option<Cause> {
        self.cause
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    /// Wait until the work is asked to stop (at once if it was).
    pub async fn wait(&self) {
        let notified = self.notify.notified();
        if self.requested() {
            return;
        }
        notified.await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn the_first_cause_is_kept_and_waiters_wake() {
        let i = Interrupt::new();
        assert!(!i.requested());
        let waiter = {
            let i = i.clone();
            tokio::spawn(async move { i.wait().await })
        };
        tokio::task::yield_now().await;
        i.raise(Cause {
            name: "SIGTERM".into(),
            code: 15,
        });
        i.raise(Cause {
            name: "SIGINT".into(),
            code: 2,
        });
        waiter.await.unwrap();
        assert_eq!(i.cause().map(|c| c.code), Some(15));
        i.wait().await;
    }
}
