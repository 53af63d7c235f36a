//! Explain captured frames of every drivebus family field by field: what a frame or a capture
//! says, for the command line (`drivectl decode …`), a gateway or a browser page.
//!
//! * [`input`]: hex bytes from arguments or a capture of text lines, into a [`Capture`] that
//!   remembers each byte's line;
//! * one decoder per family: [`movilink`] (SEW MOVILINK), [`sbus`] (SEW SBus frames, and with
//!   the feature `candump` candump logs), [`nord`] (NORD CTT2 and USS), [`bonfiglioli`]
//!   (Bonfiglioli Modbus RTU and ASCII);
//! * [`shape`]: the one shape of their output, a [`Telegram`] of [`Field`]s with the keys every
//!   decoder shares ([`COMMON_KEYS`]) and the parameter a telegram names as `read --json`
//!   names it.
//!
//! A decoder returns [`Decoded`]: one [`Entry`] per telegram (or run of bytes that starts
//! none), each with its lines of text and its [`Telegram`] for JSON. Nothing from the input
//! panics: a telegram is explained as far as its bytes go, with the problem named. Errors are
//! typed and carry no front end's words.
//!
//! ```
//! use drive_decode::{input, movilink};
//!
//! // A MOVILINK read request of P070 (index 8301) to drive 1, and its answer.
//! let bytes = input::parse_hex(&[
//!     "02 01 86 31 00 20 6D 00 00 00 00 F9",
//!     "1D 01 86 31 00 20 6D 03 93 8D 11 EA",
//! ])?;
//! let decoded = movilink::decode(&input::Capture::from_bytes(bytes));
//! assert_eq!(decoded.telegrams(), 2);
//! assert_eq!(decoded.invalid(), 0);
//! let answer = decoded.entries[1].telegram.to_json();
//! assert_eq!(answer["index"], 8301);
//! assert_eq!(answer["raw"], 60_001_553);
//! assert!(decoded.entries[1].text.starts_with("response telegram at offset 12, 12 bytes: valid"));
//! # Ok::<(), drive_decode::input::InputError>(())
//! ```

#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod bonfiglioli;
pub mod input;
pub mod movilink;
pub mod nord;
pub mod sbus;
pub mod shape;

pub use input::{Capture, InputError};
pub use shape::{COMMON_KEYS, Field, Telegram};

/// One decoded unit of a capture: its text lines (each ending in a line end) and its
/// telegram in the common shape ([`Telegram::to_json`]).
#[derive(Debug, Clone)]
pub struct Entry {
    /// The telegram (`type` `telegram`) or the run of bytes skipped (`skipped`).
    pub telegram: Telegram,
    /// What a terminal shows of it.
    pub text: String,
}

/// What a decoder says of a capture, entry by entry.
#[derive(Debug, Clone, Default)]
pub struct Decoded {
    /// The telegrams and skipped runs in capture order.
    pub entries: Vec<Entry>,
}

impl Decoded {
    fn of(entries: impl Iterator<Item = Entry>) -> Self {
        Self {
            entries: entries.collect(),
        }
    }

    /// Telegrams (frames, messages) found, valid or not; skipped runs are not counted.
    pub fn telegrams(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| !e.telegram.is_skipped())
            .count()
    }

    /// Telegrams with a problem.
    pub fn invalid(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| !e.telegram.is_skipped() && e.telegram.error.is_some())
            .count()
    }

    /// Runs of bytes (Modbus ASCII: characters) that start no telegram.
    pub fn skipped(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| e.telegram.is_skipped())
            .count()
    }

    /// Bytes (Modbus ASCII: characters) in the skipped runs.
    pub fn skipped_bytes(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| e.telegram.is_skipped())
            .map(|e| e.telegram.length)
            .sum()
    }

    /// The text of every entry.
    pub fn text(&self) -> String {
        self.entries.iter().map(|e| e.text.as_str()).collect()
    }

    /// One JSON object per entry, one a line.
    pub fn json_lines(&self) -> String {
        let mut out = String::new();
        for e in &self.entries {
            out.push_str(&e.telegram.to_json().to_string());
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every decoder takes any bytes, with or without lines, without a panic, and accounts
    /// for every byte: its entries' lengths add up to the capture's (Modbus ASCII leaves out
    /// line ends between frames).
    #[test]
    fn every_decoder_covers_any_capture() {
        let mut seed: u32 = 0x9E37_79B9;
        for round in 0..1500 {
            let len = round % 48;
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                    // Start characters and codes of every family now and then.
                    match (seed >> 16) % 8 {
                        0 => 0x02,
                        1 => 0x1D,
                        2 => b':',
                        3 => 0x13,
                        _ => (seed >> 8) as u8,
                    }
                })
                .collect();
            let lines = if round % 2 == 0 {
                Vec::new()
            } else {
                (0..len).map(|i| 1 + i / 9).collect()
            };
            let capture = Capture { bytes, lines };
            let layout = nord::UssLayout {
                pkw: [0, 3, 4][round % 3],
                pzd: (round % 5 == 0).then_some(2),
                drive_first: round % 4 == 0,
                names: nord::SettingNames::default(),
            };
            for (name, decoded) in [
                ("movilink", movilink::decode(&capture)),
                ("ctt2", nord::decode_ctt2(&capture)),
                ("uss", nord::decode_uss(&capture, layout)),
                ("modbus-rtu", bonfiglioli::decode_rtu(&capture)),
                ("modbus-ascii", bonfiglioli::decode_ascii(&capture)),
            ] {
                let covered: usize = decoded.entries.iter().map(|e| e.telegram.length).sum();
                let ends = capture
                    .bytes
                    .iter()
                    .filter(|b| matches!(b, b'\r' | b'\n'))
                    .count();
                let all = if name == "modbus-ascii" {
                    (len - ends..=len).contains(&covered)
                } else {
                    covered == len
                };
                assert!(all, "{name}: {covered} of {:02X?}", capture.bytes);
                assert!(decoded.text().lines().count() >= decoded.entries.len());
            }
        }
    }
}
