//! `status`: the status word with its state A–H, the actual values IW1–IW3 and P700.

use ctt2_uss::client::{NordClient, ParameterChannel, ProcessChannel};
use drive_profile::nord::{self, ControlWord, StatusWord};
use serde_json::{Value, json};

use drive_client::nord::NordParamClient;

use super::{Session, link_error, param, param_client, state_text, target_of};
use crate::error::Result;
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ClientError, ParamClient, Target};
use crate::tool::output::trim_float;

/// The set bits of a status word by their English names.
pub fn status_bits(sw: StatusWord) -> Vec<&'static str> {
    sw.set_bits().map(|b| b.name_en).collect()
}

/// What one actual value means, from its P543 function (the simulator's subset of the public
/// NORD documentation's list; 4000h = 100 % of P105 for frequencies, of P112 for current).
pub fn actual_json(
    word: u16,
    function: Option<i64>,
    p105_hz: Option<f64>,
    p112: Option<f64>,
) -> Value {
    let percent = nord::percent_from_word(word);
    let name = function.and_then(|f| {
        nord::by_index(param::BUS_ACTUAL_VALUE)
            .and_then(|p| p.values.iter().find(|v| v.value == f))
            .map(|v| v.en)
    });
    let (value, unit) = match function {
        Some(1 | 8) => (p105_hz.map(|r| nord::word_to_physical(word, r)), Some("Hz")),
        // The current's 100 % is P112 (itself in % of the rated current).
        Some(3) => (
            p112.map(|r| nord::word_to_physical(word, r)),
            Some("% of rated current"),
        ),
        _ => (None, None),
    };
    json!({"word": word, "hex": format!("0x{word:04X}"), "percent": percent,
           "function": function, "function_name": name, "value": value, "unit": unit})
}

pub fn actual_text(v: &Value) -> String {
    let mut s = format!(
        "{} = {} %",
        v["hex"].as_str().unwrap_or(""),
        trim_float(v["percent"].as_f64().unwrap_or(0.0), 2)
    );
    if let (Some(x), Some(unit)) = (v["value"].as_f64(), v["unit"].as_str()) {
        s.push_str(&format!(" = {} {unit}", trim_float(x, 2)));
    }
    match (v["function"].as_i64(), v["function_name"].as_str()) {
        (Some(f), Some(n)) => s.push_str(&format!(" (P543 function {f}: {n})")),
        (Some(f), None) => s.push_str(&format!(" (P543 function {f})")),
        _ => {}
    }
    s
}

/// `status`: see [`NordCommand::Status`](super::NordCommand::Status).
pub async fn status<C>(c: &mut NordClient<C>, s: &Session) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    // Bit 10 clear: the drive does not evaluate this control word (section 4.5.1 footnote 2),
    // it only answers its status word and actual values.
    let answer = c
        .process(ControlWord(0), &[], s.actuals)
        .await
        .map_err(link_error)?;
    let sw = answer.status();
    let state = sw.state();
    let set = sw.parameter_set();
    let mut pc = param_client(c, s);
    let p105 = target_of(param::MAXIMUM_FREQUENCY, None, Some(set))?;
    let p112 = target_of(param::CURRENT_LIMIT, None, Some(set))?;
    let hz = read_physical(&mut pc, &p105).await?;
    let current = read_physical(&mut pc, &p112).await?;
    let mut actuals = Vec::new();
    for (i, word) in answer.actuals().iter().enumerate() {
        let t = target_of(param::BUS_ACTUAL_VALUE, Some(i as u8 + 1), None)?;
        let function = read_optional(&mut pc, &t).await?;
        actuals.push(actual_json(*word, function, hz, current));
    }
    let mut p700 = Vec::new();
    for e in 1..=3 {
        let t = target_of(param::PRESENT_FAULT, Some(e), None)?;
        let v = read_optional(&mut pc, &t).await?;
        let text = v
            .and_then(|raw| crate::tool::meaning::meaning_of(&t, raw))
            .map(|m| m.text);
        p700.push((v, text));
    }
    let info = nord::state_info(state);
    if s.json {
        let p = |i: usize| p700.get(i).and_then(|(v, _)| *v);
        return outln!(
            "{}",
            json!({
                "status_word": sw.0, "hex": format!("0x{:04X}", sw.0),
                "state": info.map(|i| i.letter.to_string()),
                "state_en": state.name_en(), "state_de": state.name_de(),
                "bits": status_bits(sw), "parameter_set": set,
                "p105_hz": hz, "actuals": actuals,
                "fault": p(0), "warning": p(1), "switch_on_disabled_reason": p(2),
            })
        );
    }
    outln!("status word 0x{:04X}: {}", sw.0, state_text(state))?;
    outln!("  bits: {}", status_bits(sw).join(", "))?;
    outln!(
        "  parameter set {set}; P105 maximum frequency {} (the 100 % of frequencies)",
        hz.map_or_else(
            || "unreadable".to_owned(),
            |h| format!("{} Hz", trim_float(h, 1))
        )
    )?;
    for (i, a) in actuals.iter().enumerate() {
        outln!("  actual value {} (IW{}): {}", i + 1, i + 1, actual_text(a))?;
    }
    let names = [
        "present fault",
        "present warning",
        "reason for switch-on disabled",
    ];
    for (i, (v, text)) in p700.iter().enumerate() {
        outln!(
            "  P700 [-{:02}] {}: {}",
            i + 1,
            names.get(i).copied().unwrap_or(""),
            match (v, text) {
                (Some(_), Some(t)) => t.clone(),
                (Some(v), None) => v.to_string(),
                (None, _) => "unreadable".to_owned(),
            }
        )?;
    }
    Ok(())
}

/// A parameter's physical value, `None` when the drive refuses it (a link failure is an
/// error).
pub async fn read_physical<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    t: &Target,
) -> Result<Option<f64>> {
    Ok(read_optional(pc, t)
        .await?
        .and_then(|raw| t.param.map(|p| p.to_physical(raw))))
}

/// A raw value, `None` when the drive refuses it (a link failure is an error).
pub async fn read_optional<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    t: &Target,
) -> Result<Option<i64>> {
    match pc.read(t).await {
        Ok(v) => Ok(Some(v)),
        Err(ClientError::Device(d)) => {
            errln!("drivectl: warning: {}: {d}", t.label());
            Ok(None)
        }
        Err(e) => Err(t.error(e)),
    }
}
