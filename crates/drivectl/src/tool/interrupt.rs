//! Interrupts for work that must end cleanly: a backup removes its temporary file, a restore
//! says what it wrote, a command that drives a motor stops it ([`super::motor`]).
//!
//! [`Interrupt::install`] takes over every signal that ends a command from outside — SIGINT
//! (Ctrl-C), SIGTERM (`kill`, `timeout`, systemd), SIGHUP (the terminal or the SSH connection
//! went away) and SIGQUIT (Ctrl-\) — for the rest of the command. The handlers are in place
//! when `install` returns, so a signal a moment later is never the default "end the process
//! now". The first signal sets a flag that the work checks between exchanges (an exchange in
//! flight is finished, so the drive's state stays known); a second one ends the process at
//! once with `at_once`'s message (exit 128 + the signal's number), for an exchange that would
//! take long (a long `--timeout` with many `--retries`); the temporary files of output files
//! not written yet are removed first.

use std::task::Poll;

use tokio::signal::unix::{Signal, SignalKind, signal};

/// A signal that ends a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// SIGINT: Ctrl-C.
    Int,
    /// SIGTERM: `kill`, `timeout`, systemd.
    Term,
    /// SIGHUP: the terminal or SSH connection closed.
    Hup,
    /// SIGQUIT: Ctrl-\.
    Quit,
}

impl Stop {
    const ALL: [Stop; 4] = [Stop::Int, Stop::Term, Stop::Hup, Stop::Quit];

    /// The signal's number (POSIX: 2, 15, 1, 3).
    pub fn number(self) -> i32 {
        match self {
            Stop::Int => 2,
            Stop::Term => 15,
            Stop::Hup => 1,
            Stop::Quit => 3,
        }
    }

    /// The exit code of a command this signal ended: 128 + its number, as a shell reports it.
    pub fn exit_code(self) -> u8 {
        128 + self.number() as u8
    }

    /// Its name, with what usually sends it, for a person: `Ctrl-C (SIGINT)`.
    pub fn name(self) -> &'static str {
        match self {
            Stop::Int => "Ctrl-C (SIGINT)",
            Stop::Term => "SIGTERM",
            Stop::Hup => "SIGHUP (the terminal went away)",
            Stop::Quit => "SIGQUIT",
        }
    }

    fn kind(self) -> SignalKind {
        match self {
            Stop::Int => SignalKind::interrupt(),
            Stop::Term => SignalKind::terminate(),
            Stop::Hup => SignalKind::hangup(),
            Stop::Quit => SignalKind::quit(),
        }
    }

    /// The signal of `number`, if it is one of these.
    pub fn of(number: i32) -> Option<Stop> {
        Stop::ALL.into_iter().find(|s| s.number() == number)
    }
}

/// The user (or the system) asked the work to stop: `drive_client`'s [`Interrupt`] raised by
/// the signals.
///
/// [`Interrupt`]: drive_client::Interrupt
#[derive(Debug, Clone)]
pub struct Interrupt {
    inner: drive_client::Interrupt,
}

/// The next of `streams` to deliver a signal.
async fn next(streams: &mut [(Signal, Stop)]) -> Option<Stop> {
    if streams.is_empty() {
        return None;
    }
    std::future::poll_fn(|cx| {
        for (s, stop) in streams.iter_mut() {
            if let Poll::Ready(Some(())) = s.poll_recv(cx) {
                return Poll::Ready(Some(*stop));
            }
        }
        Poll::Pending
    })
    .await
}

impl Interrupt {
    /// Take over SIGINT, SIGTERM, SIGHUP and SIGQUIT (inside the tokio runtime). `at_once` is
    /// printed when a second signal ends the process without waiting.
    pub fn install(at_once: &'static str) -> Self {
        let this = Self::unset();
        // Registered here, not in the task below: the task runs only when the command first
        // waits, and a signal before that would end the process the default way.
        let mut streams: Vec<(Signal, Stop)> = Stop::ALL
            .into_iter()
            .filter_map(|s| signal(s.kind()).ok().map(|stream| (stream, s)))
            .collect();
        let handle = this.clone();
        tokio::spawn(async move {
            let Some(first) = next(&mut streams).await else {
                return;
            };
            handle.raise(first);
            errln!(
                "drivectl: note: interrupted by {}; finishing the exchange in progress (a second \
                 signal stops at once)",
                first.name()
            );
            if let Some(second) = next(&mut streams).await {
                // The drops that remove a backup's temporary file do not run on this exit.
                super::outfile::remove_temporary_files();
                errln!("drivectl: stopped at once: {at_once}");
                std::process::exit(i32::from(second.exit_code()));
            }
        });
        this
    }

    fn unset() -> Self {
        Self {
            inner: drive_client::Interrupt::new(),
        }
    }

    /// A flag nobody sets (tests, commands without signal handling).
    #[cfg(test)]
    pub fn never() -> Self {
        Self::unset()
    }

    /// Set the flag as `stop` would (tests).
    #[cfg(test)]
    pub fn set(&self) {
        self.raise(Stop::Int);
    }

    fn raise(&self, stop: Stop) {
        self.inner.raise(drive_client::Cause {
            name: stop.name().to_owned(),
            code: stop.number(),
        });
    }

    /// Whether a signal came (tests; work checks [`Interrupt::inner`]).
    #[cfg(test)]
    pub fn requested(&self) -> bool {
        self.inner.requested()
    }

    /// The first signal that came, if any.
    pub fn signal(&self) -> Option<Stop> {
        self.inner.cause().and_then(|c| Stop::of(c.code))
    }

    /// The library's flag the signals raise (for work written in `drive_client`).
    pub fn inner(&self) -> &drive_client::Interrupt {
        &self.inner
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_are_the_shells() {
        assert_eq!(Stop::Int.exit_code(), 130);
        assert_eq!(Stop::Term.exit_code(), 143);
        assert_eq!(Stop::Hup.exit_code(), 129);
        assert_eq!(Stop::Quit.exit_code(), 131);
    }

    #[test]
    fn the_first_signal_is_the_one_reported() {
        let i = Interrupt::never();
        assert_eq!(i.signal(), None);
        i.raise(Stop::Term);
        i.raise(Stop::Int);
        assert_eq!(i.signal(), Some(Stop::Term));
        assert!(i.requested());
    }
}
