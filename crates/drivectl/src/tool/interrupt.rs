//! Ctrl-C for work that must end cleanly: a backup removes its temporary file, a restore says
//! what it wrote, `pd` stops the drive.
//!
//! [`Interrupt::install`] takes over SIGINT for the rest of the command: the first Ctrl-C sets a
//! flag that the work checks between exchanges (an exchange in flight is finished, so the
//! drive's state stays known); a second Ctrl-C ends the process at once with `at_once`'s
//! message (exit 130), for an exchange that would take long (a long `--timeout` with many
//! `--retries`); the temporary files of output files not written yet are removed first.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The user asked the work to stop.
#[derive(Debug, Clone)]
pub struct Interrupt {
    flag: Arc<AtomicBool>,
    notify: Arc<tokio::sync::Notify>,
}

impl Interrupt {
    /// Take over Ctrl-C (inside the tokio runtime). `at_once` is printed when a second Ctrl-C
    /// ends the process without waiting.
    pub fn install(at_once: &'static str) -> Self {
        let flag = Arc::new(AtomicBool::new(false));
        let notify = Arc::new(tokio::sync::Notify::new());
        let (set, wake) = (flag.clone(), notify.clone());
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_err() {
                return;
            }
            set.store(true, Ordering::SeqCst);
            wake.notify_waiters();
            errln!(
                "drivectl: note: interrupted; finishing the exchange in progress (Ctrl-C again stops at once)"
            );
            if tokio::signal::ctrl_c().await.is_ok() {
                // The drops that remove a backup's temporary file do not run on this exit.
                super::outfile::remove_temporary_files();
                errln!("drivectl: stopped at once: {at_once}");
                std::process::exit(130);
            }
        });
        Self { flag, notify }
    }

    /// A flag nobody sets (tests, commands without Ctrl-C handling).
    #[cfg(test)]
    pub fn never() -> Self {
        Self {
            flag: Arc::new(AtomicBool::new(false)),
            notify: Arc::new(tokio::sync::Notify::new()),
        }
    }

    /// A flag the caller sets (tests).
    #[cfg(test)]
    pub fn set(&self) {
        self.flag.store(true, Ordering::SeqCst);
        self.notify.notify_waiters();
    }

    /// Wait until Ctrl-C is pressed (at once if it was).
    pub async fn wait(&self) {
        let notified = self.notify.notified();
        if self.requested() {
            return;
        }
        notified.await;
    }

    /// Whether Ctrl-C was pressed.
    pub fn requested(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}
