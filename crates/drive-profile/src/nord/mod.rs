//! NORD NORDAC LINK (SK 270E-FDS / SK 280E-FDS) drive profile, from BU 0255 (CTT2 over AS-i
//! carrying USS PKW/PZD).
//!
//! * Parameters: [`params`], [`by_index`], [`by_number`], [`lookup`], [`search`]; each
//!   [`Param`] implements [`ParamMeta`](crate::ParamMeta) with resolution scaling
//!   (P102: 99.99 s ↔ 9999 at 0.01 s).
//! * Process data: [`ControlWord`], [`StatusWord`], percent setpoints (4000h = 100 %).
//! * The state machine: [`State`], [`NordStateMachine`], the commands in [`command`].
//! * USS codes: [`ak_request`], [`ak_response`], [`pwe_error`]; CTT2 codes: [`ctt2_message`],
//!   [`ctt2_index`], [`ctt2_error`].
//!
//! ```
//! use drive_profile::nord;
//! use drive_profile::ParamMeta;
//!
//! let p = nord::lookup("P102").unwrap();
//! assert_eq!(p.bus_index(), 0x66);
//! assert_eq!(p.from_physical(99.99), Ok(9999));
//! assert_eq!(nord::ak_response(7).unwrap().to_string(),
//!            "AK 7: order cannot be executed (error number in PWE2)");
//! ```

mod param;
mod state;
mod tables;
mod words;

#[cfg(test)]
mod tests;

pub use param::{ArrayElement, Param, ParamElement, Resolution};
pub use state::{NordStateMachine, State, command, state_info};
pub use tables::{
    AkInfo, AkRequest, AkRequestKind, AkResponseKind, BitInfo, Ctt2Error, Ctt2Index, Ctt2Message,
    Ctt2MessageType, Ctt2ObjectByte, Ctt2Role, PweError, StateInfo, Transition, Trigger, Width,
    ak_request, ak_response, ctt2_byte_time_us, ctt2_code, ctt2_error, ctt2_index, ctt2_message,
    ctt2_object_bytes, pwe_error,
};
pub use words::{
    ControlWord, StatusWord, percent_from_word, physical_to_word, setpoint_from_percent,
    word_to_physical,
};

use crate::generated::{nord_params, nord_states, nord_words};

/// Every parameter BU 0255 names, sorted by number.
pub fn params() -> &'static [Param] {
    &nord_params::PARAMS
}

/// The parameter with PNU `pnu` (the number sent in PKE bits 0..10).
pub fn by_index(pnu: u16) -> Option<&'static Param> {
    params().iter().find(|p| p.pnu == pnu)
}

/// The parameter `P<n>`.
pub fn by_number(n: u16) -> Option<&'static Param> {
    params().iter().find(|p| p.number == n)
}

/// The parameter written `P102`, `p102` or `102` (surrounding blanks ignored).
pub fn lookup(s: &str) -> Option<&'static Param> {
    let s = s.trim();
    let digits = s.strip_prefix(['P', 'p']).unwrap_or(s);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    by_number(digits.parse().ok()?)
}

/// The parameters whose German or English name (or an array element's name) contains `term`,
/// ignoring case.
pub fn search(term: &str) -> impl Iterator<Item = &'static Param> + '_ {
    params().iter().filter(move |p| p.matches(term))
}

/// The control-word bit table (16 entries, by bit number).
pub fn control_bits() -> &'static [BitInfo] {
    &nord_words::CONTROL_BITS
}

/// The status-word bit table (16 entries, by bit number).
pub fn status_bits() -> &'static [BitInfo] {
    &nord_words::STATUS_BITS
}

/// The state table with the status-word patterns.
pub fn states() -> &'static [StateInfo] {
    &nord_states::STATES
}

/// The transition table.
pub fn transitions() -> &'static [Transition] {
    &nord_states::TRANSITIONS
}
