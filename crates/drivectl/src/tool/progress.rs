//! Progress bars for work over a few seconds (a backup, a restore, a scan): indicatif on
//! standard error, drawn only on a terminal. [`Bar`] draws `drive_client`'s
//! [`Progress`] of a backup or a restore and says its notices with the bar out of the way.

use drive_client::{Notice, Phase, Progress, Target};

/// A progress bar for `len` steps.
pub fn progress(len: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{what} {{pos}}/{{len}} {{bar:30}} {{msg}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// A bar per phase (`reading`, `writing`, `verifying`), showing the label of the parameter read
/// or written; notices go to `say`.
pub struct Bar<F: FnMut(&Notice)> {
    bar: Option<(indicatif::ProgressBar, Phase)>,
    say: F,
}

impl<F: FnMut(&Notice)> std::fmt::Debug for Bar<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bar").field("bar", &self.bar).finish()
    }
}

impl<F: FnMut(&Notice)> Bar<F> {
    /// No bar yet; notices go to `say`.
    pub fn new(say: F) -> Self {
        Self { bar: None, say }
    }
}

impl<F: FnMut(&Notice)> Progress for Bar<F> {
    fn start(&mut self, phase: Phase, steps: usize) {
        let what = match phase {
            Phase::Reading => "reading",
            Phase::Writing => "writing",
            Phase::Verifying => "verifying",
            _ => "working",
        };
        self.bar = Some((progress(steps, what), phase));
    }

    fn step(&mut self, target: &Target) {
        // A value read back is not named: the bar counts them.
        if let Some((bar, phase)) = &self.bar
            && *phase != Phase::Verifying
        {
            bar.set_message(target.label());
        }
    }

    fn done(&mut self) {
        if let Some((bar, _)) = &self.bar {
            bar.inc(1);
        }
    }

    fn finish(&mut self) {
        if let Some((bar, _)) = self.bar.take() {
            bar.finish_and_clear();
        }
    }

    fn abandon(&mut self) {
        if let Some((bar, _)) = self.bar.take() {
            bar.abandon();
        }
    }

    fn notice(&mut self, notice: &Notice) {
        let Self { bar, say } = self;
        match bar {
            Some((bar, _)) => bar.suspend(|| say(notice)),
            None => say(notice),
        }
    }
}
