//! `drivectl decode sbus`: explain SBus frames field by field, one frame (`--id ID HEX…`) or a
//! candump log (`--log FILE`).
//!
//! A frame on an SBus MOVILINK identifier is decoded with `sbus_can::telegram` (the parameter
//! channel with the MOVIDRIVE table, process data with the factory meanings of P870–P875); a
//! frame on the sync identifier (`--sync-id`, P817, 0 by default) is the SYNC; any other
//! identifier is a variable telegram (free identifier, ch. 5.5) or another protocol, shown with
//! its two 32-bit variables in both byte orders.

use drive_core::can::{CanFrame, Frame, Id};
use drive_profile::sew::ParamChannel;
use drive_transport::can::candump::{LogErrorKind, LogReader};
use sbus_can::ids::Kind;
use sbus_can::telegram::{DecodeError, ProcessData, Telegram};
use serde_json::{Value, json};

use crate::error::{CliError, Result};
use crate::movilink::decode::{
    Field, carries_value, explain_param, pd_hint, raw_value, return_code_json, return_code_text,
};

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

/// One explained frame in the common shape of every decoder ([`crate::decode`]): `offset` is
/// `null` (a CAN frame is no part of a byte stream) and `bytes` the data bytes; `line` the
/// log's line. SBus's own keys: `id`, `extended`, `remote`, `formed` (how the identifier is
/// formed), `group` (the address is a group address), `service`, `return_code`, and `time` and
/// `interface` for a log record.
pub fn to_json(e: &Explained, line: Option<usize>, time: Option<(u64, &str)>) -> Value {
    let mut t = crate::decode::Telegram::new("sbus");
    t.line = line;
    t.length = e.frame.data().len();
    t.bytes = e.frame.data().to_vec();
    t.error = e.error.clone();
    t.direction = if e.kind == "SYNC" { None } else { direction(e) };
    t.kind = Some(e.kind.clone());
    t.address = e.address.map(i64::from);
    t.param = e.index.map(|i| {
        (
            crate::decode::target(drive_profile::Family::Movidrive, i, 0),
            e.raw,
        )
    });
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
    t.to_json()
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

/// Parse an identifier: decimal, `0x…` or `…h` hexadecimal; 0–2047 (11 bits) unless
/// `extended`, then 0–1FFFFFFFh.
pub fn parse_id(text: &str, extended: bool) -> Result<Id> {
    let t = text.trim();
    let value = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u32::from_str_radix(h, 16)
    } else if let Some(h) = t.strip_suffix('h').or_else(|| t.strip_suffix('H')) {
        u32::from_str_radix(h, 16)
    } else {
        t.parse::<u32>()
    };
    let text = crate::decode::escape(text);
    let value = value.map_err(|e| {
        if *e.kind() == std::num::IntErrorKind::PosOverflow {
            CliError::usage(format!(
                "--id {text}: too large; a standard identifier is 0…2047 (11 bits), an extended \
                 one (--extended) 0…1FFFFFFFh (29 bits)"
            ))
        } else {
            CliError::usage(format!(
                "--id {text}: not a number (decimal, 0x… or …h hexadecimal)"
            ))
        }
    })?;
    if extended {
        drive_core::can::ExtendedId::new(value)
            .map(Id::Extended)
            .ok_or_else(|| {
                CliError::usage(format!(
                    "--id {text}: an extended identifier is 0…1FFFFFFFh (29 bits)"
                ))
            })
    } else {
        u16::try_from(value)
            .ok()
            .and_then(drive_core::can::StandardId::new)
            .map(Id::Standard)
            .ok_or_else(|| {
                CliError::usage(format!(
                    "--id {text}: a standard identifier is 0…2047 (11 bits; SBus uses only these); \
                     --extended for a 29-bit one"
                ))
            })
    }
}

/// Run `drivectl decode sbus --id ID HEX…`.
pub fn run_frame(
    id: Option<&str>,
    extended: bool,
    hex_args: &[String],
    sync_id: u16,
    json: bool,
) -> Result<()> {
    let id = parse_id(
        id.ok_or_else(|| {
            CliError::usage(
                "give the frame's identifier (--id ID HEX…) or a candump log (--log FILE)",
            )
        })?,
        extended,
    )?;
    let bytes = crate::decode::parse_hex(hex_args)?;
    let frame = CanFrame::data_frame(id, &bytes).ok_or_else(|| {
        CliError::usage(format!(
            "{} data bytes: a CAN frame carries 0…8",
            bytes.len()
        ))
    })?;
    let e = explain(&frame, sync_id);
    if json {
        outln!("{}", to_json(&e, None, None))?;
    } else {
        out!("{}", to_text(&e, ""))?;
    }
    match &e.error {
        Some(er) => Err(CliError::failed(format!(
            "the frame is no valid SBus telegram: {er}"
        ))),
        None => Ok(()),
    }
}

/// The most a log file may have (a day of a busy 1 Mbit/s bus is far more; split it).
const LOG_LIMIT: u64 = 256 << 20;

/// Whether `token` is a candump time stamp: seconds, a point and exactly six digits (the
/// microseconds), in brackets.
fn is_candump_stamp(token: &str) -> bool {
    token
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .and_then(|t| t.split_once('.'))
        .is_some_and(|(s, us)| {
            !s.is_empty()
                && s.bytes().all(|b| b.is_ascii_digit())
                && us.len() == 6
                && us.bytes().all(|b| b.is_ascii_digit())
        })
}

/// What is wrong with a line of a candump log, in words that say what the line must look
/// like. `text` is the line (to quote its time stamp).
fn log_error_text(kind: &LogErrorKind, text: Option<&str>) -> String {
    let stamp = text.and_then(|t| t.split_whitespace().next());
    match (kind, stamp) {
        (LogErrorKind::Parse(_), Some(s)) if !is_candump_stamp(s) => format!(
            "`{}` is no candump time stamp: candump writes the seconds since 1970 with exactly \
             six digits after the point, in brackets, then the interface and the frame: \
             `(1700000000.123456) can0 20B#3100207E00000000`",
            crate::decode::escape(s)
        ),
        (other, _) => crate::decode::escape(&other.to_string()),
    }
}

/// Run `drivectl decode sbus --log FILE`: every record of a candump log (`-`: standard input)
/// explained; a line that is no record is reported with its number and the rest is read on.
pub fn run_log(path: &str, sync_id: u16, json: bool) -> Result<()> {
    let bytes = crate::tool::infile::read_limited(std::path::Path::new(path), true, LOG_LIMIT)?;
    // The lines as read, to quote a bad one (the reader strips a BOM from the first).
    let lines: Vec<&[u8]> = bytes.split(|b| *b == b'\n').collect();
    let line_text = |n: u64| {
        usize::try_from(n)
            .ok()
            .and_then(|n| lines.get(n.checked_sub(1)?))
            .and_then(|l| std::str::from_utf8(l).ok())
            .map(|l| l.trim_start_matches('\u{feff}').trim())
    };
    let mut reader = LogReader::new(bytes.as_slice());
    let mut frames = 0usize;
    let mut invalid = 0usize;
    let mut unreadable = 0usize;
    loop {
        let item = reader.next_record();
        let line = usize::try_from(reader.line()).ok();
        match item {
            Ok(None) => break,
            Ok(Some(r)) => {
                frames += 1;
                let e = explain(&r.frame, sync_id);
                if e.error.is_some() {
                    invalid += 1;
                }
                if json {
                    outln!(
                        "{}",
                        to_json(&e, line, Some((r.t_us, r.interface.as_str())))
                    )?;
                } else {
                    let place = format!(
                        "({}.{:06}) {} ",
                        r.t_us / 1_000_000,
                        r.t_us % 1_000_000,
                        crate::decode::escape(&r.interface)
                    );
                    out!("{}", to_text(&e, &place))?;
                }
            }
            Err(e) => {
                unreadable += 1;
                let why = log_error_text(&e.kind, line_text(e.line));
                if json {
                    let mut t = crate::decode::Telegram::skipped("sbus", None, &[], why);
                    t.line = usize::try_from(e.line).ok();
                    outln!("{}", t.to_json())?;
                } else {
                    outln!("{}: line {}: {why}", crate::decode::escape(path), e.line)?;
                }
            }
        }
    }
    if !json {
        outln!("{frames} frame(s), {invalid} not valid SBus, {unreadable} unreadable line(s)")?;
    }
    if frames == 0 && unreadable == 0 {
        return Err(CliError::usage(format!(
            "{path}: no candump records (lines like `(1735270496.916858) can0 20B#3100207E00000000`)"
        )));
    }
    if unreadable > 0 {
        return Err(CliError::failed(format!(
            "{unreadable} line(s) of {path} are no candump records (see above)"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::standard(id, data).unwrap()
    }

    #[test]
    fn manual_5_3_read_of_8318() {
        let e = explain(&frame(523, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
        assert_eq!(e.kind, "parameter request");
        assert_eq!(e.address, Some(1));
        assert_eq!(e.index, Some(8318));
        assert_eq!(
            e.formed.as_deref(),
            Some("8 × SBus address 1 + 512 + 3 = 523")
        );
        assert!(
            e.fields[0].text.contains("answer at once"),
            "{:?}",
            e.fields[0]
        );
        let r = explain(&frame(524, &[0x71, 0, 0x20, 0x7E, 0, 0x0F, 0x42, 0x40]), 0);
        assert_eq!(r.kind, "parameter response");
        assert_eq!(r.raw, Some(1_000_000));
        assert!(r.fields[0].text.contains("after the next SYNC"));
        assert!(r.error.is_none());
    }

    #[test]
    fn process_data_sync_and_errors() {
        let e = explain(&frame(267, &[0, 6, 0x13, 0x88, 0, 0]), 0);
        assert_eq!(e.kind, "process output data (PO)");
        assert_eq!(e.words, [6, 5000, 0]);
        assert!(e.fields[1].text.contains("1000 1/min"), "{:?}", e.fields[1]);
        let s = explain(&frame(0, &[]), 0);
        assert_eq!(s.kind, "SYNC");
        let bad = explain(&frame(267, &[0, 6]), 0);
        assert!(bad.error.as_deref().unwrap().contains("expected 6"));
        let group_read = explain(&frame(8 * 2 + 518, &[0x31, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
        assert!(
            group_read
                .error
                .as_deref()
                .unwrap()
                .contains("write services only")
        );
        let wrong = explain(&frame(523, &[0x3F, 0, 0x20, 0x7E, 0, 0, 0, 0]), 0);
        assert!(wrong.error.as_deref().unwrap().contains("class 5, code 5"));
    }

    /// The manual's variable telegram (ch. 5.5) in both byte orders.
    #[test]
    fn variables_of_the_manual() {
        let (m, _) = variables(&[0x55, 0x66, 0x77, 0x88, 0x11, 0x22, 0x33, 0x44]);
        assert_eq!(split64(m), "DataLow 11223344h, DataHigh 55667788h");
        let (_, i) = variables(&[0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0x66, 0x55]);
        assert_eq!(split64(i), "DataLow 11223344h, DataHigh 55667788h");
        let e = explain(
            &frame(1024, &[0x55, 0x66, 0x77, 0x88, 0x11, 0x22, 0x33, 0x44]),
            0,
        );
        assert_eq!(e.kind, "variable telegram or other protocol");
        assert!(e.fields[0].text.starts_with("MOTOROLA: DataLow 11223344h"));
    }

    #[test]
    fn identifiers_parse_strictly() {
        assert_eq!(
            parse_id("0x10B", false).unwrap(),
            Id::Standard(drive_core::can::StandardId::new(267).unwrap())
        );
        assert_eq!(
            parse_id("10Bh", false).unwrap(),
            parse_id("267", false).unwrap()
        );
        assert!(parse_id("2048", false).is_err());
        assert!(parse_id("4294967296", false).is_err());
        // Past every width: said as too large, not as "not a number" (issue 18).
        let e = parse_id("99999999999999999999", true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("too large") && e.contains("29 bits"), "{e}");
        assert!(parse_id("-1", false).is_err());
        assert!(parse_id("0x1FFFFFFF", true).is_ok());
        assert!(parse_id("0x20000000", true).is_err());
    }
}
