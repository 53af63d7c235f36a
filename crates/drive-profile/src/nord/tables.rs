//! Row types of the generated NORD tables and the lookups over them.
//!
//! The tables themselves live in `crate::generated::nord_*` (generated from
//! `data/nord/*.csv` by `cargo xtask codegen`); every lookup here is a scan over a `static`
//! slice and never allocates.

use core::fmt;

use crate::generated::{nord_ctt2, nord_uss};

use super::State;

/// One bit of the control word or the status word (BU 0255 sections 4.5.1 and 4.5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BitInfo {
    /// Bit number 0..15.
    pub bit: u8,
    /// English identifier, e.g. `fault_reset`; used in `Debug` output.
    pub key: &'static str,
    /// German name as printed, e.g. `Fehler quittieren (0→1)`.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Meaning of the value 0 (German; may be empty).
    pub meaning0_de: &'static str,
    /// Meaning of the value 0 (English; may be empty).
    pub meaning0_en: &'static str,
    /// Meaning of the value 1 (German; may be empty).
    pub meaning1_de: &'static str,
    /// Meaning of the value 1 (English; may be empty).
    pub meaning1_en: &'static str,
    /// Control word only: priority of the value 0 when several bits act at once (1 = highest).
    pub priority0: Option<u8>,
    /// Control word only: priority of the value 1.
    pub priority1: Option<u8>,
}

impl BitInfo {
    /// The mask of this bit.
    pub const fn mask(&self) -> u16 {
        1 << self.bit
    }
}

/// One state of the drive with the status-word pattern that identifies it (section 4.5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StateInfo {
    /// The state.
    pub state: State,
    /// The manual's letter (A…H) in figure 3.
    pub letter: char,
    /// German name.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Status-word bits that matter for this state.
    pub mask: u16,
    /// Their required values.
    pub value: u16,
    /// German description.
    pub description_de: &'static str,
    /// English description.
    pub description_en: &'static str,
}

impl StateInfo {
    /// Whether `status_word` shows this state.
    pub const fn matches(&self, status_word: u16) -> bool {
        status_word & self.mask == self.value
    }
}

/// What triggers a state transition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trigger {
    /// A control word with `word & mask == value`.
    Command {
        /// Control-word bits that matter.
        mask: u16,
        /// Their required values.
        value: u16,
    },
    /// A change of control-word bit `bit` from 0 (previous word) to 1 (this word).
    RisingEdge {
        /// The bit number.
        bit: u8,
    },
    /// The drive moves by itself (charging relay closed, fault reaction done, f = 0 Hz).
    Automatic,
    /// A fault occurs (from every state).
    FaultEvent,
}

/// One state transition (section 4.5.3, table "Zustandsübergänge").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transition {
    /// The manual's number, with `a`/`b` where it lists two commands (e.g. `7a`).
    pub id: &'static str,
    /// Source state; `None` means every state.
    pub from: Option<State>,
    /// Target state.
    pub to: State,
    /// What triggers it.
    pub trigger: Trigger,
    /// German command name, e.g. `Stillsetzen`.
    pub command_de: &'static str,
    /// English command name, e.g. `shutdown`.
    pub command_en: &'static str,
    /// Where in the manual the row comes from.
    pub source: &'static str,
}

impl Transition {
    /// Whether control word `word` (with `previous` sent before it) triggers this transition.
    pub const fn triggered_by(&self, previous: u16, word: u16) -> bool {
        match self.trigger {
            Trigger::Command { mask, value } => word & mask == value,
            Trigger::RisingEdge { bit } => {
                let m = 1u16 << (bit & 15);
                previous & m == 0 && word & m != 0
            }
            Trigger::Automatic | Trigger::FaultEvent => false,
        }
    }
}

/// Width of a parameter value in the PKW area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Width {
    /// 16 bit, carried in PWE2.
    Word,
    /// 32 bit, PWE1 = high word, PWE2 = low word.
    DoubleWord,
}

/// What an order ID asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AkRequestKind {
    /// AK 0: no order.
    None,
    /// Read a value.
    Read,
    /// Write a value.
    Write,
    /// Read the number of array elements.
    Count,
    /// Reserved code.
    Reserved,
}

/// One USS order ID (Auftragskennung, PKE bits 12..15).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AkRequest {
    /// The code 0..15.
    pub ak: u8,
    /// German function as printed.
    pub function_de: &'static str,
    /// English function.
    pub function_en: &'static str,
    /// What it asks for.
    pub kind: AkRequestKind,
    /// Width of the value written.
    pub width: Option<Width>,
    /// Whether the IND sub-index addresses an array element.
    pub array: bool,
    /// Whether the write also goes to EEPROM (false for the RAM-only orders 11..14).
    pub eeprom: bool,
    /// Possible positive response IDs.
    pub responses: &'static [u8],
}

impl fmt::Display for AkRequest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "AK {}: {}", self.ak, self.function_en)
    }
}

/// What a response ID reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AkResponseKind {
    /// AK 0: no response.
    None,
    /// A parameter value.
    Value,
    /// An array element's value.
    ArrayValue,
    /// The number of array elements.
    Count,
    /// AK 7: the order cannot be executed; PWE2 holds the error number ([`PweError`]).
    Error,
}

/// One USS response ID (Antwortkennung).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AkInfo {
    /// The code 0..15.
    pub ak: u8,
    /// German meaning as printed.
    pub meaning_de: &'static str,
    /// English meaning.
    pub meaning_en: &'static str,
    /// What it reports.
    pub kind: AkResponseKind,
    /// Width of the value reported.
    pub width: Option<Width>,
}

impl fmt::Display for AkInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "AK {}: {}", self.ak, self.meaning_en)
    }
}

/// One error number in PWE2 of a response with AK 7.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PweError {
    /// The error number.
    pub number: u16,
    /// German meaning as printed (empty where the manual gives none, e.g. 102).
    pub meaning_de: &'static str,
    /// English meaning (empty where the manual gives none).
    pub meaning_en: &'static str,
}

impl fmt::Display for PweError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.meaning_en.is_empty() {
            write!(f, "error {} (no meaning given in the manual)", self.number)
        } else {
            write!(f, "error {}: {}", self.number, self.meaning_en)
        }
    }
}

/// The four CTT2 message types (section 4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ctt2MessageType {
    /// Standard read (AS-i specification objects: ID, diagnosis).
    StandardRead,
    /// NORD read: process data or the last parameter-channel response.
    NordRead,
    /// NORD write: process data or a parameter order.
    NordWrite,
    /// NORD write and read in one message.
    NordWriteRead,
}

/// Whether a CTT2 code is a request or a response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ctt2Role {
    /// Master → slave.
    Request,
    /// Positive response (request code + 40h).
    ResponseOk,
    /// Negative response with an error code (request code + 80h).
    ResponseError,
}

/// One CTT2 message code (byte 1 of every CTT2 message).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ctt2Message {
    /// The code.
    pub code: u8,
    /// Its message type.
    pub message_type: Ctt2MessageType,
    /// Request or response.
    pub role: Ctt2Role,
    /// German name.
    pub name_de: &'static str,
    /// English name.
    pub name_en: &'static str,
    /// Contents after the code (German).
    pub contents_de: &'static str,
    /// Contents after the code (English).
    pub contents_en: &'static str,
    /// The value the manual prints where it is wrong (see `docs/errata-nord.md`).
    pub printed: Option<u8>,
}

impl fmt::Display for Ctt2Message {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CTT2 code {}: {}", self.code, self.name_en)
    }
}

/// One CTT2 index (byte 2: the object addressed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ctt2Index {
    /// The index.
    pub index: u8,
    /// True for the standard-read objects (ID, diagnosis), false for the NORD channels.
    pub standard: bool,
    /// German object name.
    pub object_de: &'static str,
    /// English object name.
    pub object_en: &'static str,
    /// Longest data length in bytes (longer reads return only this much).
    pub max_len: u8,
    /// Allowed write lengths (empty: not writable).
    pub write_lengths: &'static [u8],
    /// Whether the data start with the drive address (always 1).
    pub address: bool,
}

/// One CTT2 error code (byte 2 of a negative response).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ctt2Error {
    /// The code.
    pub code: u8,
    /// German meaning.
    pub meaning_de: &'static str,
    /// English meaning.
    pub meaning_en: &'static str,
}

impl fmt::Display for Ctt2Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CTT2 error {}: {}", self.code, self.meaning_en)
    }
}

/// One byte of a standard-read object (ID object, diagnostic object).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ctt2ObjectByte {
    /// The object's CTT2 index.
    pub index: u8,
    /// 1-based byte position in the object data.
    pub byte: u8,
    /// German meaning.
    pub name_de: &'static str,
    /// English meaning.
    pub name_en: &'static str,
}

/// The response ID table entry for `code` (e.g. 7 = order cannot be executed).
pub fn ak_response(code: u8) -> Option<&'static AkInfo> {
    nord_uss::AK_RESPONSES.iter().find(|a| a.ak == code)
}

/// The order ID table entry for `code` (e.g. 2 = change parameter value (word)).
pub fn ak_request(code: u8) -> Option<&'static AkRequest> {
    nord_uss::AK_REQUESTS.iter().find(|a| a.ak == code)
}

/// The meaning of PWE2 error number `n` in a response with AK 7.
pub fn pwe_error(n: u16) -> Option<&'static PweError> {
    nord_uss::PWE_ERRORS.iter().find(|e| e.number == n)
}

/// The CTT2 message code `code` (request or response).
pub fn ctt2_message(code: u8) -> Option<&'static Ctt2Message> {
    nord_ctt2::MESSAGES.iter().find(|m| m.code == code)
}

/// The CTT2 code of `message_type` in `role`.
pub fn ctt2_code(message_type: Ctt2MessageType, role: Ctt2Role) -> Option<u8> {
    nord_ctt2::MESSAGES
        .iter()
        .find(|m| m.message_type == message_type && m.role == role)
        .map(|m| m.code)
}

/// The CTT2 index (object) `index`.
pub fn ctt2_index(index: u8) -> Option<&'static Ctt2Index> {
    nord_ctt2::INDICES.iter().find(|i| i.index == index)
}

/// The CTT2 error code `code`.
pub fn ctt2_error(code: u8) -> Option<&'static Ctt2Error> {
    nord_ctt2::ERRORS.iter().find(|e| e.code == code)
}

/// The byte layout of standard-read object `index` (empty for other indices).
pub fn ctt2_object_bytes(index: u8) -> impl Iterator<Item = &'static Ctt2ObjectByte> {
    nord_ctt2::OBJECT_BYTES
        .iter()
        .filter(move |b| b.index == index)
}

/// Minimum CTT2 transfer time per byte in microseconds with `slaves` AS-i slaves on the
/// network: 16 × 154 µs × (2 + slaves) (section 4.4; 31 slaves → 81 312 µs).
pub const fn ctt2_byte_time_us(slaves: u8) -> u32 {
    16 * 154 * (2 + slaves as u32)
}
