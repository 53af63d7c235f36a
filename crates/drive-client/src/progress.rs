//! What long work (a [backup](crate::backup), a [restore](crate::restore)) tells its front end
//! while it runs: [`Progress`], which the command line draws as a progress bar and a browser
//! page its own way, and the [`Notice`]s to say on the way. Every method has a default that
//! does nothing; `()` is the progress nobody watches.

use serde_json::Value;

use crate::target::Target;
use crate::wear::WearLogError;

/// A phase of a backup or a restore.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Phase {
    /// Reading the drive's values: a backup, or a restore comparing the drive with its file.
    Reading,
    /// Writing the changes of a restore.
    Writing,
    /// Reading a restore's values back.
    Verifying,
}

/// One identification field that differs between a backup file and the drive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldDiff {
    /// The field (`device_type`, `variant`, `firmware`, …).
    pub key: String,
    /// Its value in the file.
    pub saved: Value,
    /// Its value on the drive.
    pub drive: Value,
}

/// Something to say while the work goes on.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Notice {
    /// The file was saved from a drive whose identification differs in these fields, and the
    /// restore goes on because it was asked to ([`crate::restore::Options::any_device`]).
    OtherDevice(Vec<FieldDiff>),
    /// The file was saved from another firmware (`key` is `firmware`): parameters may differ
    /// between firmware versions.
    OtherFirmware(FieldDiff),
    /// The write guard's warning for a change about to be written.
    Warning(String),
    /// A write was sent, but the EEPROM-wear log could not record it.
    NotRecorded(WearLogError),
    /// A setting of the link was written and the client followed it: where the drive answers
    /// now.
    LinkFollowed {
        /// The setting written.
        target: Target,
        /// What changed for the link, for a person.
        note: String,
    },
}

/// What a front end is told as the work goes on (each phase: [`start`](Progress::start), then
/// per step [`step`](Progress::step) and [`done`](Progress::done), then
/// [`finish`](Progress::finish) or, when the work ends early, [`abandon`](Progress::abandon)).
pub trait Progress {
    /// A phase of `steps` steps starts.
    fn start(&mut self, phase: Phase, steps: usize) {
        let _ = (phase, steps);
    }

    /// Work on `target` starts.
    fn step(&mut self, target: &Target) {
        let _ = target;
    }

    /// A step is done.
    fn done(&mut self) {}

    /// The phase is over.
    fn finish(&mut self) {}

    /// The phase ends early (an error, an interrupt): the work stops here.
    fn abandon(&mut self) {}

    /// Something to say now (a front end that draws a bar takes it out of the way first).
    fn notice(&mut self, notice: &Notice) {
        let _ = notice;
    }
}

/// Nobody watches.
impl Progress for () {}
