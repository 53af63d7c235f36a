//! The command line as the clients' front end ([`Cli`]): what drive-client's messages point at
//! is named by the option that reaches it (`--addr 5`, `--long`), and their notes are said on
//! standard error.

use bonfiglioli_modbus::slave::Width;
use drive_client::front::{FrontEnd, Note, Setting};

/// The command line as the clients' front end: what their messages point at is named by its
/// option (`--addr 5`, `--baud 19200`, `--long`), and their notes are said on standard error.
#[derive(Debug, Clone, Copy, Default)]
pub struct Cli;

impl FrontEnd for Cli {
    fn name(&self, setting: Setting) -> Option<String> {
        Some(match setting {
            Setting::Address(a) => format!("--addr {a}"),
            Setting::Baud(baud) => format!("--baud {baud}"),
            Setting::Parity(parity) => format!("--parity {parity}"),
            Setting::Mode(mode) => format!("--mode {mode}"),
            Setting::SyncId => "--sync-id".to_owned(),
            Setting::Width(Width::Word) => "--word".to_owned(),
            Setting::Width(Width::Long) => "--long".to_owned(),
            Setting::DataSet => "--dataset".to_owned(),
            Setting::ArrayElement => "--array".to_owned(),
            Setting::KeepRunning => "--keep-running".to_owned(),
            Setting::ConfirmLinkSettings => "--yes".to_owned(),
            _ => return None,
        })
    }

    fn note(&self, note: &Note<'_>) {
        if let Note::Variant {
            address,
            variant,
            why,
        } = note
        {
            crate::bonfiglioli::say_variant(*address, *variant, why);
        }
    }
}
