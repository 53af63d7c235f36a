//! A front end's own words in what a client says.
//!
//! A client's messages sometimes point at something only a front end can name: the setting
//! that reaches a drive again after its address moved (the command line's `--addr 5`), the
//! access width a refusal asks for (`--long`), the option that leaves a motor running. The
//! client decides *what* it points at ([`Setting`]); the front end names it in its own words
//! ([`FrontEnd::name`]), or not at all, and the message then leaves the pointer out. The default,
//! [`Plain`], names nothing: a library caller or the gateway gets messages without any front
//! end's words.
//!
//! Some results are found while a client does something else and only a front end can say them
//! at that moment (a Bonfiglioli drive's variant, found while a backup identifies the drive):
//! they reach [`FrontEnd::note`] as a typed [`Note`]. [`Plain`] drops them; the same results are
//! returned where a caller asks for them directly.

use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::Width;
use drive_core::Parity;

use crate::meaning::KnownVariant;

/// Something a client's message points at that a front end names its own way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Setting {
    /// Talking to the drive (or a group) at this bus address.
    Address(i64),
    /// The line's baud rate.
    Baud(u32),
    /// The line's parity.
    Parity(Parity),
    /// The Modbus transmission mode.
    Mode(Mode),
    /// The SYNC identifier an SBus master sends.
    SyncId,
    /// Accessing a Bonfiglioli parameter with this width.
    Width(Width),
    /// Naming one Bonfiglioli data set.
    DataSet,
    /// Naming one NORD array element.
    ArrayElement,
    /// Leaving a motor running when a process-data session ends.
    KeepRunning,
    /// Writing the settings of the link a restore talks over, which it skips unless confirmed.
    ConfirmLinkSettings,
}

/// Something a client found while doing something else, for the front end to say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Note<'a> {
    /// A Bonfiglioli drive's variant, found by asking the drive
    /// ([`crate::bonfiglioli::BonfiglioliClient::find_variant`]).
    Variant {
        /// The drive's address.
        address: u8,
        /// ACT or ACU; `None` when the drive shows neither.
        variant: Option<KnownVariant>,
        /// What the drive showed, for a person.
        why: &'a str,
    },
}

/// A front end's words for what clients point at, and its ear for their notes.
pub trait FrontEnd: std::fmt::Debug {
    /// The front end's name for `setting` (`--addr 5`), or `None` to leave it out of the
    /// message.
    fn name(&self, setting: Setting) -> Option<String> {
        let _ = setting;
        None
    }

    /// Say `note` now (the default: drop it).
    fn note(&self, note: &Note<'_>) {
        let _ = note;
    }
}

/// No front end's words: nothing named, notes dropped (a library caller, the gateway).
#[derive(Debug, Clone, Copy, Default)]
pub struct Plain;

impl FrontEnd for Plain {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_names_nothing() {
        assert_eq!(Plain.name(Setting::Address(5)), None);
        assert_eq!(Plain.name(Setting::Width(Width::Long)), None);
    }
}
