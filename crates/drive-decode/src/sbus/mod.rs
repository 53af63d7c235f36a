//! SBus (SEW MOVILINK over CAN): explain frames field by field, one frame ([`decode_frame`]) or,
//! with the feature `candump`, a candump log (`LogDecoder`).
//!
//! A frame on an SBus MOVILINK identifier is decoded with `sbus_can::telegram` (the parameter
//! channel with the MOVIDRIVE table, process data with the factory meanings of P870–P875); a
//! frame on the sync identifier (P817, 0 by default) is the SYNC; any other
//! identifier is a variable telegram (free identifier, ch. 5.5) or another protocol, shown with
//! its two 32-bit variables in both byte orders.

use drive_core::can::{CanFrame, Frame, Id};
use drive_profile::sew::ParamChannel;
use sbus_can::ids::Kind;
use sbus_can::telegram::{DecodeError, ProcessData, Telegram};
use serde_json::json;

use crate::Entry;
use crate::movilink::{
    carries_value, explain_param, pd_hint, raw_value, return_code_json, return_code_text,
};
use crate::shape::{Field, target};

/// The explanation of one frame.
#[derive(Debug, Clone)]
pub struct Explained {
    /// The frame.
    pub frame: CanFrame,
    /// What the identifier names: `parameter request`, `SYNC`, `variable telegram`, …
    pub kind: String,
    /// How the identifier is formed (`8 × 33 + 3 = 267`), if it is an SBus one.
    pub formed: Option<String>,
    /// The SBus address or group address.
    pub address: Option<u8>,
    /// Whether the address is a group address.
    pub group: bool,
    /// The parameter channel's index and service, and the raw value (not for an error answer).
    pub index: Option<u16>,
    /// The service's name.
    pub service: Option<&'static str>,
    /// The data as the parameter's raw value.
    pub raw: Option<i64>,
    /// The return code, when the status bit is set.
    pub return_code: Option<drive_profile::sew::ReturnCode>,
    /// Process data words.
    pub words: Vec<u16>,
    /// The fields in order.
    pub fields: Vec<Field>,
    /// What is wrong with the frame for SBus, if anything.
    pub error: Option<String>,
}

fn field(fields: &mut Vec<Field>, offset: usize, bytes: &[u8], name: &str, meaning: String) {
    fields.push(Field::new(offset, bytes, name, meaning));
}

/// The two 32-bit variables of a variable telegram in MOTOROLA and INTEL byte order (ch. 5.5:
/// 8 bytes `55 66 77 88 11 22 33 44` are DataLow 11223344h, DataHigh 55667788h in MOTOROLA;
/// `44 33 22 11 88 77 66 55` the same in INTEL). Fewer than 8 bytes: the bytes are the low end
/// of the 64-bit value DataHigh:DataLow, so up to 4 bytes are DataLow alone.
pub fn variables(data: &[u8]) -> (u64, u64) {
    let mut motorola = 0u64;
    for b in data {
        motorola = (motorola << 8) | u64::from(*b);
    }
    let mut intel = 0u64;
    for b in data.iter().rev() {
        intel = (intel << 8) | u64::from(*b);
    }
    (motorola, intel)
}

fn split64(v: u64) -> String {
    format!(
        "DataLow {:08X}h, DataHigh {:08X}h",
        v as u32,
        (v >> 32) as u32
    )
}

/// Explain `frame` with `sync_id` as the synchronisation identifier (P817).
pub fn explain(frame: &CanFrame, sync_id: u16) -> Explained {
    let mut e = Explained {
        frame: *frame,
        kind: String::new(),
        formed: None,
        address: None,
        group: false,
        index: None,
        service: None,
        raw: None,
        return_code: None,
        words: Vec::new(),
        fields: Vec::new(),
        error: None,
    };
    let data = frame.data();
    match Telegram::decode(frame, sync_id) {
        Ok(Telegram::Sync) => {
            e.kind = "SYNC".into();
            e.formed = Some(format!("the sync identifier (P817 = {sync_id})"));
            if !data.is_empty() {
                field(
                    &mut e.fields,
                    0,
                    data,
                    "data",
                    "not defined by the manual (drivebus sends the SYNC without data)".into(),
                );
            }
        }
        Ok(t) => explain_telegram(&mut e, &t, data),
        Err(DecodeError::NotSbus { id }) => {
            e.kind = "variable telegram or other protocol".into();
            e.formed = Some(if id & 0x400 != 0 {
                "no SBus MOVILINK identifier: bit 10 is set (reserved, 0 in SBus)".to_string()
            } else {
                format!(
                    "no SBus MOVILINK identifier: function {} (bits 0–2; SBus uses 3–6)",
                    id & 7
                )
            });
            if !data.is_empty() {
                let (m, i) = variables(data);
                field(
                    &mut e.fields,
                    0,
                    data,
                    "variables",
                    format!("MOTOROLA: {}; INTEL: {}", split64(m), split64(i)),
                );
            }
        }
        Err(err) => {
            e.kind = match Kind::classify(frame.standard_id().unwrap_or(u16::MAX)) {
                Some((k, _)) => k.name().to_owned(),
                None => "not SBus".to_owned(),
            };
            if let Some((k, a)) = frame.standard_id().and_then(Kind::classify) {
                e.formed = Some(formed(k, a.get()));
                e.address = Some(a.get());
                e.group = k.is_group();
            }
            if !data.is_empty() {
                field(&mut e.fields, 0, data, "data", "not decoded".into());
            }
            e.error = Some(err.to_string());
        }
    }
    e
}

fn formed(kind: Kind, address: u8) -> String {
    let who = if kind.is_group() {
        "group address"
    } else {
        "SBus address"
    };
    let param = if kind.is_parameter() { " + 512" } else { "" };
    format!(
        "8 × {who} {address}{param} + {} = {}",
        kind.function(),
        kind.id(sbus_can::Address::new(address).unwrap_or_default())
    )
}

fn explain_telegram(e: &mut Explained, t: &Telegram, data: &[u8]) {
    let Some((kind, address)) = t.kind() else {
        return;
    };
    e.kind = kind.name().to_owned();
    e.formed = Some(formed(kind, address.get()));
    e.address = Some(address.get());
    e.group = kind.is_group();
    match *t {
        Telegram::ParamRequest { channel, .. }
        | Telegram::ParamResponse { channel, .. }
        | Telegram::GroupParamRequest { channel, .. } => {
            let response = matches!(t, Telegram::ParamResponse { .. });
            explain_channel(e, &channel, response, kind);
        }
        Telegram::ProcessOutput {
            data: ProcessData(w),
            ..
        }
        | Telegram::ProcessInput {
            data: ProcessData(w),
            ..
        }
        | Telegram::GroupProcessOutput {
            data: ProcessData(w),
            ..
        } => {
            let request = !kind.from_drive();
            e.words = w.to_vec();
            let prefix = if request { "PO" } else { "PI" };
            for (i, v) in w.iter().enumerate() {
                let at = 2 * i;
                field(
                    &mut e.fields,
                    at,
                    data.get(at..at + 2).unwrap_or(&[]),
                    &format!("{prefix}{}", i + 1),
                    format!("{v} (0x{v:04X}): {}", pd_hint(request, i, *v)),
                );
            }
        }
        Telegram::Sync => {}
    }
}

fn explain_channel(e: &mut Explained, ch: &ParamChannel, response: bool, kind: Kind) {
    let raw: [u8; 8] = ch.to_bytes();
    let mut fields = Vec::new();
    explain_param(ch, response, 0, &raw, &mut |at, bytes, name, meaning| {
        field(&mut fields, at, bytes, name, meaning);
    });
    // SBus's meaning of the handshake bit (ch. 5.2), instead of MOVILINK's cyclic handshake.
    if let Some(m) = fields.first_mut() {
        let sync = if ch.management.handshake() {
            "handshake 1 (answer after the next SYNC)"
        } else {
            "handshake 0 (answer at once)"
        };
        m.text = m
            .text
            .replace("handshake 1", sync)
            .replace("handshake 0", sync);
    }
    e.fields = fields;
    e.index = Some(ch.index);
    e.service = ch.service().map(|s| s.name());
    match ch.result() {
        Ok(d) if carries_value(ch, response) => e.raw = Some(raw_value(ch.index, d)),
        Ok(_) => {}
        Err(rc) => e.return_code = Some(rc),
    }
    if kind == Kind::GroupParamRequest && !ch.service().is_some_and(|s| s.is_write()) {
        e.error = Some(
            "a group parameter request carries write services only (ch. 5.1): the drives ignore it"
                .into(),
        );
    }
    if ch.management.service().is_none() {
        e.error = Some(format!(
            "undefined service code {}: a drive answers class 5, code 5 (ch. 5.2)",
            ch.management.service_code()
        ));
    }
}

/// The direction of a frame, from what its identifier names: a request (master → drive),
/// a response (drive → master), or neither (SYNC, a variable telegram, another protocol).
fn direction(e: &Explained) -> Option<&'static str> {
    let (kind, _) = Kind::classify(e.frame.standard_id()?)?;
    Some(if kind.from_drive() {
        "response"
    } else {
        "request"
    })
}

/// One explained frame in the common shape of every decoder ([`crate::shape`]): `offset` is
/// `null` (a CAN frame is no part of a byte stream) and `bytes` the data bytes; `line` the
/// log's line. SBus's own keys: `id`, `extended`, `remote`, `formed` (how the identifier is
/// formed), `group` (the address is a group address), `service`, `return_code`, and `time` and
/// `interface` for a log record.
pub fn telegram(
    e: &Explained,
    line: Option<usize>,
    time: Option<(u64, &str)>,
) -> crate::shape::Telegram {
    let mut t = crate::shape::Telegram::new("sbus");
    t.line = line;
    t.length = e.frame.data().len();
    t.bytes = e.frame.data().to_vec();
    t.error = e.error.clone();
    t.direction = if e.kind == "SYNC" { None } else { direction(e) };
    t.kind = Some(e.kind.clone());
    t.address = e.address.map(i64::from);
    t.param = e
        .index
        .map(|i| (target(drive_profile::Family::Movidrive, i, 0), e.raw));
    t.refusal = e.return_code.as_ref().map(return_code_text);
    t.process_data = e.words.clone();
    t.fields = e.fields.clone();
    let mut t = t
        .extra("id", e.frame.raw_id().into())
        .extra("extended", e.frame.is_extended().into())
        .extra("remote", e.frame.is_remote_frame().into())
        .extra("formed", json!(e.formed))
        .extra("group", e.group.into())
        .extra("service", json!(e.service))
        .extra(
            "return_code",
            json!(e.return_code.as_ref().map(return_code_json)),
        );
    if let Some((t_us, iface)) = time {
        t = t
            .extra(
                "time",
                format!("{}.{:06}", t_us / 1_000_000, t_us % 1_000_000).into(),
            )
            .extra("interface", iface.into());
    }
    t
}

/// The text lines of one explained frame.
pub fn to_text(e: &Explained, place: &str) -> String {
    let mut out = format!(
        "{place}{}  {}{}\n",
        e.frame,
        e.kind,
        e.error
            .as_deref()
            .map_or_else(String::new, |er| format!(": INVALID ({er})"))
    );
    if let Some(f) = &e.formed {
        out.push_str(&format!("  identifier {}: {f}\n", e.frame.raw_id()));
    }
    for f in &e.fields {
        out.push_str(&format!(
            "  byte {:<2} {:<24} {:<10} {}\n",
            f.offset, f.bytes, f.name, f.text
        ));
    }
    out
}

/// Why an identifier or data bytes make no CAN frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The identifier is not a number.
    #[error("{text}: not a number (decimal, 0x… or …h hexadecimal)")]
    NotANumber {
        /// The identifier as given, escaped.
        text: String,
    },
    /// The identifier is past every width (more than 32 bits).
    #[error(
        "{text}: too large; a standard identifier is 0…2047 (11 bits), an extended one \
         0…1FFFFFFFh (29 bits)"
    )]
    TooLarge {
        /// The identifier as given, escaped.
        text: String,
    },
    /// An extended identifier past 29 bits.
    #[error("{text}: an extended identifier is 0…1FFFFFFFh (29 bits)")]
    NotExtended {
        /// The identifier as given, escaped.
        text: String,
    },
    /// A standard identifier past 11 bits.
    #[error("{text}: a standard identifier is 0…2047 (11 bits; SBus uses only these)")]
    NotStandard {
        /// The identifier as given, escaped.
        text: String,
    },
    /// More than 8 data bytes.
    #[error("{len} data bytes: a CAN frame carries 0…8")]
    TooLong {
        /// How many bytes were given.
        len: usize,
    },
}

/// Parse an identifier: decimal, `0x…` or `…h` hexadecimal; 0–2047 (11 bits) unless
/// `extended`, then 0–1FFFFFFFh.
///
/// # Errors
///
/// [`FrameError`]: not a number, or past the identifier's width.
pub fn parse_id(text: &str, extended: bool) -> Result<Id, FrameError> {
    let t = text.trim();
    let value = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u32::from_str_radix(h, 16)
    } else if let Some(h) = t.strip_suffix('h').or_else(|| t.strip_suffix('H')) {
        u32::from_str_radix(h, 16)
    } else {
        t.parse::<u32>()
    };
    let text = crate::shape::escape(text);
    let value = value.map_err(|e| {
        if *e.kind() == std::num::IntErrorKind::PosOverflow {
            FrameError::TooLarge { text: text.clone() }
        } else {
            FrameError::NotANumber { text: text.clone() }
        }
    })?;
    if extended {
        drive_core::can::ExtendedId::new(value)
            .map(Id::Extended)
            .ok_or(FrameError::NotExtended { text })
    } else {
        u16::try_from(value)
            .ok()
            .and_then(drive_core::can::StandardId::new)
            .map(Id::Standard)
            .ok_or(FrameError::NotStandard { text })
    }
}

/// The data frame of `id` with `data`.
///
/// # Errors
///
/// [`FrameError::TooLong`] for more than 8 bytes.
pub fn data_frame(id: Id, data: &[u8]) -> Result<CanFrame, FrameError> {
    CanFrame::data_frame(id, data).ok_or(FrameError::TooLong { len: data.len() })
}

/// One frame explained with `sync_id` as the synchronisation identifier (P817), as text and in
/// the common shape.
pub fn decode_frame(frame: &CanFrame, sync_id: u16) -> Entry {
    let e = explain(frame, sync_id);
    Entry {
        telegram: telegram(&e, None, None),
        text: to_text(&e, ""),
    }
}

#[cfg(all(feature = "candump", target_os = "linux"))]
mod log;
#[cfg(all(feature = "candump", target_os = "linux"))]
#[cfg_attr(docsrs, doc(cfg(feature = "candump")))]
pub use log::LogDecoder;

#[cfg(test)]
mod tests;
