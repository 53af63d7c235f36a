//! Interrupts for work that must end cleanly: a backup removes its temporary file, a restore
//! says what it wrote, a command that drives a motor stops it ([`super::motor`]).
//!
//! [`Interrupt::install`] is `drive_client`'s ([`drive_client::signals`]): SIGINT, SIGTERM,
//! SIGHUP and SIGQUIT taken over for the rest of the command; the first sets the flag the work
//! checks between exchanges, a second ends the process at once (exit 128 + its number). This
//! module says both on standard error.

use drive_client::signals::Heard;

/// A signal that ends a command.
pub use drive_client::signals::Signal as Stop;

/// The user (or the system) asked the work to stop: `drive_client`'s [`Interrupt`] raised by
/// the signals.
///
/// [`Interrupt`]: drive_client::Interrupt
#[derive(Debug, Clone)]
pub struct Interrupt {
    inner: drive_client::Interrupt,
}

impl Interrupt {
    /// Take over SIGINT, SIGTERM, SIGHUP and SIGQUIT (inside the tokio runtime). `at_once` is
    /// printed when a second signal ends the process without waiting.
    pub fn install(at_once: &'static str) -> Self {
        let inner = drive_client::Interrupt::install(move |heard| match heard {
            Heard::First(first) => errln!(
                "drivectl: note: interrupted by {}; finishing the exchange in progress (a second \
                 signal stops at once)",
                first.name()
            ),
            _ => errln!("drivectl: stopped at once: {at_once}"),
        });
        Self { inner }
    }

    /// A flag nobody sets (tests, commands without signal handling).
    #[cfg(test)]
    pub fn never() -> Self {
        Self {
            inner: drive_client::Interrupt::new(),
        }
    }

    /// Set the flag as Ctrl-C would (tests).
    #[cfg(test)]
    pub fn set(&self) {
        self.inner.raise(Stop::Int.cause());
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

/// The library flag's `wait`, `requested` and `cause`.
impl std::ops::Deref for Interrupt {
    type Target = drive_client::Interrupt;
    fn deref(&self) -> &drive_client::Interrupt {
        &self.inner
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_signal_is_the_one_reported() {
        let i = Interrupt::never();
        assert_eq!(i.signal(), None);
        i.inner.raise(Stop::Term.cause());
        i.set();
        assert_eq!(i.signal(), Some(Stop::Term));
        assert!(i.requested());
    }
}
