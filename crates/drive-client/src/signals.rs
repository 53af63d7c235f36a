//! The signals that end a program's work from outside (feature `signals`): SIGINT (Ctrl-C),
//! SIGTERM (`kill`, `timeout`, systemd), SIGHUP (the terminal or the SSH connection went away)
//! and SIGQUIT (Ctrl-\).
//!
//! [`Interrupt::install`] takes them over for the rest of the work: the handlers are in place
//! when it returns, so a signal a moment later never ends the process the default way. The first
//! signal raises the [`Interrupt`], which the work checks between exchanges (an exchange in
//! flight is finished, so the drive's state stays known); a second one ends the process at once
//! (exit 128 + the signal's number) for an exchange that would take long, after removing the
//! temporary files of output files not written yet ([`crate::outfile`]). The front end says each
//! in its own words ([`Heard`]). [`first`] is a plain stop: a future that completes on the
//! first of them.

use std::task::Poll;

use tokio::signal::unix::{SignalKind, signal};

use crate::interrupt::{Cause, Interrupt};

/// A signal that ends the work.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Signal {
    /// SIGINT: Ctrl-C.
    Int,
    /// SIGTERM: `kill`, `timeout`, systemd.
    Term,
    /// SIGHUP: the terminal or SSH connection closed.
    Hup,
    /// SIGQUIT: Ctrl-\.
    Quit,
}

impl Signal {
    /// Every one of them.
    pub const ALL: [Signal; 4] = [Signal::Int, Signal::Term, Signal::Hup, Signal::Quit];

    /// The signal's number (POSIX: 2, 15, 1, 3).
    pub fn number(self) -> i32 {
        match self {
            Signal::Int => 2,
            Signal::Term => 15,
            Signal::Hup => 1,
            Signal::Quit => 3,
        }
    }

    /// The exit code of a process this signal ended: 128 + its number, as a shell reports it.
    pub fn exit_code(self) -> u8 {
        match self {
            Signal::Int => 130,
            Signal::Term => 143,
            Signal::Hup => 129,
            Signal::Quit => 131,
        }
    }

    /// Its name, with what usually sends it, for a person: `Ctrl-C (SIGINT)`.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Int => "Ctrl-C (SIGINT)",
            Signal::Term => "SIGTERM",
            Signal::Hup => "SIGHUP (the terminal went away)",
            Signal::Quit => "SIGQUIT",
        }
    }

    /// The signal of `number`, if it is one of these.
    pub fn of(number: i32) -> Option<Signal> {
        Signal::ALL.into_iter().find(|s| s.number() == number)
    }

    /// The interrupt's [`Cause`] for it (its name, its number as the code).
    pub fn cause(self) -> Cause {
        Cause {
            name: self.name().to_owned(),
            code: self.number(),
        }
    }

    fn kind(self) -> SignalKind {
        match self {
            Signal::Int => SignalKind::interrupt(),
            Signal::Term => SignalKind::terminate(),
            Signal::Hup => SignalKind::hangup(),
            Signal::Quit => SignalKind::quit(),
        }
    }
}

/// What the signals did, for the front end to say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Heard {
    /// The first signal: the interrupt is raised, the exchange in flight is finished.
    First(Signal),
    /// A second signal: the process ends right after this (exit 128 + its number).
    Second(Signal),
}

type Streams = Vec<(tokio::signal::unix::Signal, Signal)>;

/// Handlers for every signal that installs (one that does not keeps its default).
fn streams() -> Streams {
    Signal::ALL
        .into_iter()
        .filter_map(|s| signal(s.kind()).ok().map(|stream| (stream, s)))
        .collect()
}

/// The next of `streams` to deliver a signal (`None` when none installed).
async fn next(streams: &mut Streams) -> Option<Signal> {
    if streams.is_empty() {
        return None;
    }
    std::future::poll_fn(|cx| {
        for (s, which) in streams.iter_mut() {
            if let Poll::Ready(Some(())) = s.poll_recv(cx) {
                return Poll::Ready(Some(*which));
            }
        }
        Poll::Pending
    })
    .await
}

impl Interrupt {
    /// Take over SIGINT, SIGTERM, SIGHUP and SIGQUIT (inside a tokio runtime, see the
    /// [module docs](self)); `say` is told of each signal as it comes, before a second one
    /// ends the process.
    pub fn install(say: impl Fn(Heard) + Send + 'static) -> Interrupt {
        let this = Interrupt::new();
        // Registered here, not in the task below: the task runs only when the work first waits,
        // and a signal before that would end the process the default way.
        let mut streams = streams();
        let handle = this.clone();
        tokio::spawn(async move {
            let Some(first) = next(&mut streams).await else {
                return;
            };
            handle.raise(first.cause());
            say(Heard::First(first));
            if let Some(second) = next(&mut streams).await {
                // The drops that remove the temporary files do not run on this exit.
                crate::outfile::remove_temporary_files();
                say(Heard::Second(second));
                std::process::exit(i32::from(second.exit_code()));
            }
        });
        this
    }
}

/// Completes on the first of the signals: a plain stop. The handlers are in place when this
/// returns (not when the future is first polled), so a signal a moment later no longer ends
/// the process. A handler that does not install leaves that signal's default (and without any,
/// the future never completes).
pub fn first() -> impl Future<Output = Signal> {
    let mut streams = streams();
    async move {
        match next(&mut streams).await {
            Some(s) => s,
            None => std::future::pending().await,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_are_the_shells_and_numbers_name_them() {
        for s in Signal::ALL {
            assert_eq!(i32::from(s.exit_code()), 128 + s.number());
            assert_eq!(Signal::of(s.number()), Some(s));
            assert_eq!(s.cause().code, s.number());
        }
        assert_eq!(Signal::of(9), None);
    }
}
